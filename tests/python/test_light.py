"""Session.light gives the numbers `lobe light` writes, and refuses bad maps as the CLI does."""

import struct
import subprocess

import numpy as np
import pytest

import lobe


def _rle_decode(data, size):
    """OpenEXR's RLE (ImfRle.cpp's layout): a signed count byte, then -count literal bytes or
    one byte repeated count + 1 times; then the predictor undone and the two halves interleaved."""
    out = bytearray()
    i = 0
    while i < len(data):
        count = struct.unpack_from("b", data, i)[0]
        i += 1
        if count < 0:
            out += data[i:i - count]
            i -= count
        else:
            out += bytes([data[i]]) * (count + 1)
            i += 1
    assert len(out) == size, (len(out), size)
    d = np.frombuffer(bytes(out), dtype=np.uint8).astype(np.int64)
    d[1:] -= 128
    t = (np.cumsum(d) & 0xFF).astype(np.uint8)  # t[i] = t[i-1] + d[i] - 128, t[0] = d[0]
    half = (size + 1) // 2
    raw = np.empty(size, dtype=np.uint8)
    raw[0::2] = t[:half]
    raw[1::2] = t[half:]
    return raw.tobytes()


def read_lobe_exr(path):
    """The float32 R, G, B of a single-part tiled EXR with RLE or no compression (what lobe
    writes: 64 x 64 tiles, one level): an (H, W, 3) array."""
    data = open(path, "rb").read()
    assert data[:4] == b"\x76\x2f\x31\x01"
    at = 8
    attrs = {}
    while data[at] != 0:
        name_end = data.index(b"\0", at)
        name = data[at:name_end].decode()
        type_end = data.index(b"\0", name_end + 1)
        (size,) = struct.unpack_from("<i", data, type_end + 1)
        attrs[name] = data[type_end + 5:type_end + 5 + size]
        at = type_end + 5 + size
    at += 1
    xmin, ymin, xmax, ymax = struct.unpack("<4i", attrs["dataWindow"])
    w, h = xmax - xmin + 1, ymax - ymin + 1
    tx, ty = struct.unpack_from("<II", attrs["tiles"], 0)
    compression = attrs["compression"][0]
    assert compression in (0, 1), f"compression {compression}: this reader knows none and RLE"
    channels = []
    c = attrs["channels"]
    k = 0
    while c[k] != 0:
        end = c.index(b"\0", k)
        channels.append(c[k:end].decode())
        (ptype,) = struct.unpack_from("<i", c, end + 1)
        assert ptype == 2, "float32 channels"
        k = end + 1 + 16
    n_tiles = -(-w // tx) * -(-h // ty)
    offsets = struct.unpack_from(f"<{n_tiles}Q", data, at)
    image = np.zeros((h, w, len(channels)), dtype=np.float32)
    for off in offsets:
        x, y, _, _, packed = struct.unpack_from("<5i", data, off)
        tw, th = min(tx, w - x * tx), min(ty, h - y * ty)
        raw_size = tw * th * len(channels) * 4
        block = data[off + 20:off + 20 + packed]
        raw = block if packed == raw_size or compression == 0 else _rle_decode(block, raw_size)
        tile = np.frombuffer(raw, dtype="<f4").reshape(th, len(channels), tw)
        image[y * ty:y * ty + th, x * tx:x * tx + tw, :] = tile.transpose(0, 2, 1)
    order = [channels.index(n) for n in ("R", "G", "B")]
    return image[:, :, order]


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
def test_light_is_the_exr_lobe_light_writes(lobe_bin, tmp_path, gpu, cpu, backend):
    out = tmp_path / "lit.exr"
    done = subprocess.run(
        [lobe_bin, "light", "--model", "microfacet", "--set", "alpha=0.3", "--env", "studio",
         "--size", "24", "--backend", backend, "-o", str(out)],
        capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    written = read_lobe_exr(out)
    s = gpu if backend == "gpu" else cpu
    image = s.light("microfacet", "studio", size=24, params={"alpha": 0.3})
    assert image.shape == (24, 24, 3) and image.dtype == np.float64
    assert image.astype(np.float32).tobytes() == written.astype(np.float32).tobytes()
    assert image[0, 0].tolist() == [0.0, 0.0, 0.0]  # outside the sphere


def test_an_array_map_lights_as_the_same_map_from_a_file(cpu, tmp_path):
    """A constant array of radiance 2 lights a Lambert sphere (albedo 0.5) to 1 (rho L), as the
    built-in constant map of radiance 1 lights it to 0.5, within the texel rule's 2e-3."""
    arr = np.full((32, 64, 3), 2.0)
    image = cpu.light("lambert", arr, size=16, params={"albedo": 0.5})
    inside = image[8, 8]
    assert np.allclose(inside, 1.0, rtol=2e-3), inside
    builtin = cpu.light("lambert", "constant", size=16, params={"albedo": 0.5})
    assert np.allclose(builtin[8, 8], 0.5, rtol=2e-3)


def test_bad_maps_are_refused(cpu, tmp_path):
    bad = np.ones((4, 8, 3))
    bad[2, 5, 1] = np.nan
    with pytest.raises(ValueError, match="row 2, column 5"):
        cpu.light("lambert", bad, size=8)
    with pytest.raises(ValueError, match="env"):
        cpu.light("lambert", np.ones((4, 8)), size=8)
    with pytest.raises(FileNotFoundError):
        cpu.light("lambert", str(tmp_path / "missing.hdr"), size=8)
    (tmp_path / "x.hdr").write_text("hello")
    with pytest.raises(ValueError, match="not an environment map"):
        cpu.light("lambert", str(tmp_path / "x.hdr"), size=8)
    with pytest.raises(ValueError, match="size"):
        cpu.light("lambert", "sky", size=0)
    with pytest.raises(ValueError, match="method"):
        cpu.light("lambert", "sky", size=8, method="both")
    with pytest.raises(ValueError, match="no microfacet lobe the split sum can prefilter"):
        cpu.light("phong", "sky", size=8, method="split_sum")


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
def test_split_sum_is_the_exr_lobe_light_writes(lobe_bin, tmp_path, gpu, cpu, backend):
    """method="split_sum" gives the numbers `lobe light --method split_sum` writes."""
    out = tmp_path / "split.exr"
    done = subprocess.run(
        [lobe_bin, "light", "--model", "microfacet", "--set", "alpha=0.3", "--set", "diffuse=0.2",
         "--env", "studio", "--size", "24", "--method", "split_sum", "--backend", backend,
         "-o", str(out)],
        capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    written = read_lobe_exr(out)
    s = gpu if backend == "gpu" else cpu
    image = s.light("microfacet", "studio", size=24, params={"alpha": 0.3, "diffuse": 0.2},
                    method="split_sum")
    assert image.shape == (24, 24, 3)
    assert image.astype(np.float32).tobytes() == written.astype(np.float32).tobytes()
    exact = s.light("microfacet", "studio", size=24, params={"alpha": 0.3, "diffuse": 0.2})
    assert not np.array_equal(image, exact)


def test_light_report_is_the_csv_lobe_light_report_writes(lobe_bin, tmp_path, cpu):
    """Session.light_report gives the rows `lobe light --report` writes to its CSV."""
    out = tmp_path / "r.exr"
    done = subprocess.run(
        [lobe_bin, "light", "--report", "--report-steps", "3", "--model", "microfacet",
         "--env", "studio", "--size", "12", "--backend", "cpu", "-o", str(out)],
        capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = (tmp_path / "r_report.csv").read_text().splitlines()
    header = lines[0].split(",")
    report = cpu.light_report("microfacet", "studio", size=12, steps=3)
    assert report["parameter"] == "alpha"
    assert len(report["rows"]) == len(lines) - 1 == 3
    for line, row in zip(lines[1:], report["rows"]):
        fields = dict(zip(header, line.split(",")))
        for key in ("value", "alpha", "rms", "max_relative", "mean_relative", "mean_relative_normal"):
            assert float(fields[key]) == row[key], key
        # A band with no pixel (12 pixels across has none with n.v < 0.3) is empty in the CSV
        # and None here.
        for key in ("mean_relative_grazing", "mean_relative_middle"):
            assert (None if fields[key] == "" else float(fields[key])) == row[key], key
        assert int(fields["lobe_resolved"]) == int(row["lobe_resolved"])


def test_light_report_refuses_a_model_without_a_roughness(cpu):
    with pytest.raises(ValueError, match="microfacet \\(alpha\\)"):
        cpu.light_report("lambert", "sky", size=8)
    with pytest.raises(ValueError, match="2 to 64"):
        cpu.light_report("microfacet", "sky", size=8, steps=1)
