"""The package gives the numbers the command line gives for the same requests."""

import csv
import io
import json
import math
import os
import pathlib
import subprocess

import numpy as np
import pytest

import lobe


def run(lobe_bin, *args):
    done = subprocess.run([lobe_bin, *args], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def sin_cos_deg(x):
    """lobe's degree conversion (src/grid/angles.rs sin_cos_deg): exact at multiples of 90 degrees."""
    q = x / 90.0
    quadrant = math.copysign(math.floor(abs(q) + 0.5), q)  # Rust's round: halves away from 0
    r = math.radians(x - 90.0 * quadrant)
    s, c = math.sin(r), math.cos(r)
    return {0: (s, c), 1: (c, -s), 2: (-s, -c), 3: (-c, s)}[int(quadrant) % 4]


def direction_deg(theta, phi):
    st, ct = sin_cos_deg(theta)
    sp, cp = sin_cos_deg(phi)
    return [st * cp, st * sp, ct]


TABLES = [
    ("cook_torrance", "isotropic", (6, 5, 4), ["--material", "gold"], {"material": "gold"}),
    ("phong{shininess=50}", "full", (3, 4, 5, 6), ["--set", "diffuse=0.1,0.2,0.3"],
     {"params": {"diffuse": (0.1, 0.2, 0.3)}}),
    ("microfacet", "halfdiff", (5, 4, 3), ["--set", "alpha=0.2"], {"params": {"alpha": 0.2}}),
    # NTHETA_I = NTHETA_O: a reciprocal model's mirror cells are copies of the cells evaluated.
    ("microfacet", "isotropic", (8, 8, 16), ["--set", "alpha=0.3"], {"params": {"alpha": 0.3}}),
]


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
@pytest.mark.parametrize("model,grid,res,flags,kwargs", TABLES)
def test_table_is_bit_identical_to_the_npy_lobe_writes(lobe_bin, tmp_path, gpu, cpu, backend,
                                                       model, grid, res, flags, kwargs):
    out = tmp_path / "t.exr"
    run(lobe_bin, "table", "--model", model, "--grid", grid, "--res", ",".join(map(str, res)),
        "-o", str(out), "--backend", backend, *flags)
    written = np.load(tmp_path / "t.npy")
    s = gpu if backend == "gpu" else cpu
    t = s.table(model, grid=grid, res=res, **kwargs)
    assert t.values.dtype == written.dtype == np.float32
    assert t.values.shape == written.shape == tuple(res) + (3,)
    assert t.values.tobytes() == written.tobytes()
    # The axes: names and sizes as the sidecar lists them, angles at the cell centres.
    sidecar = json.loads((tmp_path / "t.json").read_text())
    axes = [a for a in sidecar["axes"] if a["name"] != "rgb"]
    assert list(t.axes) == [a["name"] for a in axes]
    for a in axes:
        n, hi = a["size"], a["range_rad"][1]
        np.testing.assert_allclose(t.axes[a["name"]], (np.arange(n) + 0.5) * hi / n, rtol=1e-15)


def test_write_table_writes_the_files_lobe_table_writes(lobe_bin, tmp_path, gpu):
    run(lobe_bin, "table", "--model", "oren_nayar", "--grid", "isotropic", "--res", "4,4,4",
        "-o", str(tmp_path / "cli.exr"))
    invalid = gpu.write_table(tmp_path / "py.exr", "oren_nayar", grid="isotropic", res=(4, 4, 4))
    assert invalid == 0
    assert (tmp_path / "py.npy").read_bytes() == (tmp_path / "cli.npy").read_bytes()
    assert (tmp_path / "py.exr").is_file() and (tmp_path / "py.json").is_file()


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
def test_eval_equals_lobe_eval(lobe_bin, gpu, cpu, backend):
    pairs = [(30, 0, 60, 90), (10, 45, 20, 225), (75, 300, 5, 10)]
    s = gpu if backend == "gpu" else cpu
    for model, flags, kwargs in [
        ("cook_torrance", ["--material", "gold"], {"material": "gold"}),
        ("ashikhmin_shirley{nu=10,nv=1000}", [], {}),
    ]:
        wi = [direction_deg(ti, pi) for ti, pi, _, _ in pairs]
        wo = [direction_deg(to, po) for _, _, to, po in pairs]
        got = s.eval(model, wi, wo, **kwargs)
        for (ti, pi, to, po), row in zip(pairs, got):
            text = run(lobe_bin, "eval", "--model", model, "--wi-deg", f"{ti},{pi}",
                       "--wo-deg", f"{to},{po}", "--backend", backend, *flags)
            want = [float(v) for v in list(csv.DictReader(io.StringIO(text)))[0].values()][4:]
            assert row.tolist() == want, (model, ti, pi, to, po)


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
def test_albedo_equals_lobe_albedo(lobe_bin, gpu, cpu, backend):
    s = gpu if backend == "gpu" else cpu
    text = run(lobe_bin, "albedo", "--model", "microfacet", "--set", "alpha=0.3", "--mu", "0.1,0.5,1",
               "--format", "json", "--backend", backend)
    want = json.loads(text)
    got = s.albedo("microfacet", mu=[0.1, 0.5, 1.0], params={"alpha": 0.3})
    assert got.albedo.tolist() == [p["albedo"] for p in want["points"]]
    assert got.error.tolist() == [p["error_estimate"] for p in want["points"]]
    hemi = s.hemispherical_albedo("microfacet", params={"alpha": 0.3})
    assert hemi.albedo.tolist() == want["hemispherical"]["albedo"]
    assert hemi.e_avg.tolist() == want["hemispherical"]["e_avg"]
    assert hemi.error.tolist() == want["hemispherical"]["error_estimate"]


@pytest.mark.parametrize("method", ["uniform", "cosine", "sampled"])
def test_albedo_seed_equals_lobe_albedo_seed(lobe_bin, cpu, method):
    """One Monte Carlo request, seed and all, gives the numbers of ``lobe albedo --seed``; another
    seed gives other numbers (Oren-Nayar's weights vary from draw to draw)."""
    seed = 4000000123
    text = run(lobe_bin, "albedo", "--model", "oren_nayar", "--mu", "0.3,0.8", "--method", method,
               "--samples", "4096", "--seed", str(seed), "--format", "json", "--backend", "cpu")
    want = json.loads(text)
    assert want["seed"] == seed
    got = cpu.albedo("oren_nayar", mu=[0.3, 0.8], method=method, samples=4096, seed=seed)
    assert got.albedo.tolist() == [p["albedo"] for p in want["points"]]
    assert got.error.tolist() == [p["error_estimate"] for p in want["points"]]
    hemi = cpu.hemispherical_albedo("oren_nayar", method=method, samples=4096, seed=seed)
    assert hemi.albedo.tolist() == want["hemispherical"]["albedo"]
    default = cpu.albedo("oren_nayar", mu=[0.3, 0.8], method=method, samples=4096)
    assert default.albedo.tolist() == cpu.albedo("oren_nayar", mu=[0.3, 0.8], method=method,
                                                 samples=4096, seed=0).albedo.tolist()
    assert default.albedo.tolist() != got.albedo.tolist()


@pytest.mark.parametrize("bad, error", [(-1, ValueError), (2**32, ValueError), (1.5, TypeError),
                                        ("3", TypeError), (True, TypeError)])
def test_albedo_refuses_a_bad_seed_naming_it(cpu, bad, error):
    with pytest.raises(error, match="seed"):
        cpu.albedo("lambert", mu=0.5, method="uniform", seed=bad)


def test_albedo_lut_equals_lobe_albedo_lut(lobe_bin, tmp_path, gpu):
    run(lobe_bin, "albedo", "--model", "microfacet", "--lut", str(tmp_path / "lut.exr"),
        "--lut-res", "6,5")
    lut = gpu.albedo_lut("microfacet", res=(6, 5))
    written = np.load(tmp_path / "lut.npy")
    assert written.shape == lut.e.shape == (5, 6, 3)
    assert lut.e.astype(np.float32).tobytes() == written.tobytes()
    avg = np.load(tmp_path / "lut_avg.npy")
    assert lut.e_avg.astype(np.float32).tobytes() == avg.tobytes()



@pytest.mark.parametrize("kind", ["dfg", "kulla-conty"])
def test_engine_lut_equals_lobe_albedo_engine(lobe_bin, tmp_path, gpu, kind):
    run(lobe_bin, "albedo", "--lut", str(tmp_path / "e.exr"), "--engine", kind, "--lut-res", "4,5")
    written = np.load(tmp_path / "e.npy")
    lut = gpu.engine_lut(kind, res=(4, 5))
    # One texel per (p, mu); the file keeps a channel axis only where there are several.
    assert lut.values.shape[:2] == written.shape[:2] == (5, 4)
    assert lut.values.size == written.size
    assert lut.values.astype(np.float32).tobytes() == written.tobytes()


SILENCED = [
    ["models"],
    ["eval", "--backend", "cpu", "--wi-deg", "30,0", "--wo-deg", "30,180"],
    ["albedo", "--backend", "cpu", "--model", "lambert"],
    ["table", "--model", "lambert", "--grid", "isotropic", "--res", "2,2,2", "-o", "{dir}/t.exr"],
]


@pytest.mark.parametrize("args", SILENCED, ids=lambda a: a[0])
def test_a_script_can_silence_lobe_with_devnull(lobe_bin, tmp_path, args):
    """subprocess.DEVNULL opens /dev/null read-write, as batch runners do: lobe honours it, with
    standard input closed too, and writes its files as it would to a terminal."""
    argv = [lobe_bin, *(a.format(dir=tmp_path) for a in args)]
    done = subprocess.run(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    if args[0] == "table":
        assert (tmp_path / "t.npy").is_file()


def test_a_closed_standard_output_is_refused(lobe_bin):
    """A report written to a closed descriptor would be lost with status 0: lobe says so."""
    done = subprocess.run([lobe_bin, "models"], stdin=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True, timeout=120, preexec_fn=lambda: os.close(1))
    assert done.returncode != 0
    assert "standard output is closed" in done.stderr


def test_models_are_the_catalogue_lobe_models_prints(lobe_bin):
    want = json.loads(run(lobe_bin, "models", "--format", "json"))
    assert lobe.models() == want["models"]
    assert lobe.materials() == want["materials"]


def test_fit_equals_lobe_fit(lobe_bin, gpu):
    args = dict(free=["alpha", "specular"], max_iters=40, max_bins=2048, starts=2)
    text = run(lobe_bin, "fit", "--target", "cook_torrance", "--target-set", "roughness=0.4",
               "--model", "microfacet", "--free", "alpha,specular", "--max-iters", "40",
               "--max-bins", "2048", "--starts", "2", "--format", "json")
    want = json.loads(text)
    got = gpu.fit("cook_torrance", "microfacet", target_params={"roughness": 0.4}, **args)
    for report in (want, got.report):
        report.pop("seconds")
    assert got.report == want
    assert got.params == want["parameters"] and got.loss == want["loss"]["total"]
    assert got.channel_loss.tolist() == want["loss"]["channel"]


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
def test_compare_equals_lobe_compare(lobe_bin, gpu, cpu, backend):
    s = gpu if backend == "gpu" else cpu
    text = run(lobe_bin, "compare", "phong", "blinn_phong", "--set-a", "shininess=200",
               "--set-b", "smoothness=0.4", "--grid", "isotropic", "--res", "10,10,20",
               "--format", "json", "--backend", backend)
    want = json.loads(text)
    got = s.compare("phong", "blinn_phong", params_a={"shininess": 200}, params_b={"smoothness": 0.4},
                    grid="isotropic", res=(10, 10, 20))
    assert got == {k: want[k] for k in got}
    assert "relative_l2" in str(got)


def test_the_package_version_is_lobes():
    import pathlib
    import re

    cargo = pathlib.Path(__file__).resolve().parents[2] / "Cargo.toml"
    version = re.search(r'^version = "([^"]+)"', cargo.read_text(), re.M).group(1)
    assert lobe.__version__ == version


def test_chi2_gives_the_report_lobe_chi2_prints(lobe_bin, cpu):
    args = ["chi2", "--backend", "cpu", "--model", "microfacet", "--set", "alpha_x=0.1", "--set", "alpha_y=0.4",
            "--theta-o-deg", "0,45", "--phi-o-deg", "30", "--samples", "2^14", "--seed", "9",
            "--checked-draws", "1000", "--format", "json"]
    cli = json.loads(run(lobe_bin, *args))
    py = cpu.chi2("microfacet", params={"alpha_x": 0.1, "alpha_y": 0.4}, theta_o_deg=[0, 45],
                  phi_o_deg=30, samples=1 << 14, seed=9, checked_draws=1000)
    assert py["passed"] == cli["passed"] is True
    assert py["parameters"] == cli["parameters"]
    for a, b in zip(py["directions"], cli["directions"]):
        assert a["observed"] == b["observed"]
        assert a["expected"] == b["expected"]
        assert a["p_value"] == b["p_value"]
        assert a["draws"] == b["draws"]
        assert a["draws"]["checked_draws"] == 1000
    every = cpu.chi2("lambert", theta_o_deg=[30], samples=1 << 12, checked_draws=None)
    assert every["directions"][0]["draws"]["checked_draws"] == 1 << 12
    with pytest.raises(ValueError, match="checked_draws"):
        cpu.chi2("lambert", checked_draws=0)
    with pytest.raises(ValueError, match="theta_o_deg"):
        cpu.chi2("lambert", theta_o_deg=[95])
    with pytest.raises(ValueError, match="significance"):
        cpu.chi2("lambert", significance=1.5)


def test_chi2_takes_view_vectors_and_draws_on_the_sessions_backend(session):
    # One unit vector (3,) or several (k, 3); the report names where the draws were counted.
    t = 0.7
    wo = np.array([[0.0, 0.0, 1.0], [math.sin(t), 0.0, math.cos(t)]])
    both = session.chi2("microfacet", wo, params={"alpha": 0.3}, samples=1 << 16, seed=3)
    assert both["passed"] is True
    assert both["backend"].startswith(session.backend)
    assert [d["theta_o_deg"] for d in both["directions"]] == pytest.approx([0.0, math.degrees(t)])
    one = session.chi2("microfacet", wo[1], params={"alpha": 0.3}, samples=1 << 16, seed=3)
    assert len(one["directions"]) == 1
    assert one["directions"][0]["theta_o_deg"] == pytest.approx(math.degrees(t))
    with pytest.raises(ValueError, match="wo"):
        session.chi2("lambert", [0.0, 0.0, -1.0])
    with pytest.raises(ValueError, match="wo"):
        session.chi2("lambert", [0.0, 0.0, 2.0])
    with pytest.raises(ValueError, match="theta_o_deg"):
        session.chi2("lambert", [0.0, 0.0, 1.0], theta_o_deg=[10])


# A .brdf file with its own sampler: a normalised Blinn-Phong lobe drawn through its half
# vector, whose density over the solid angle of L is the half vector's over 4 (V.h).
BLINN_WITH_SAMPLER = (
    pathlib.Path(__file__).resolve().parents[2] / "testdata" / "brdf" / "half_vector_sampler.brdf"
).read_text()


def test_chi2_and_pdf_of_a_brdf_files_sampler_are_lobe_chi2s(lobe_bin, gpu, cpu, tmp_path):
    # The shader's sampler is tested on the GPU with its own pdfL integrated: the same counts,
    # expectations and p-value through Python as through `lobe chi2`; a CPU session has no
    # twin of the shader and refuses it naming the file.
    path = tmp_path / "half_vector_sampler.brdf"
    path.write_text(BLINN_WITH_SAMPLER)
    cli = json.loads(run(lobe_bin, "chi2", "--model", str(path), "--theta-o-deg", "45", "--samples",
                         "2^16", "--seed", "4", "--format", "json"))
    py = gpu.chi2(str(path), theta_o_deg=[45], samples=1 << 16, seed=4)
    assert py["passed"] == cli["passed"] is True
    assert py["density"] == cli["density"]
    assert py["density"].endswith("(f32)")
    for a, b in zip(py["directions"], cli["directions"]):
        assert a["observed"] == b["observed"]
        assert a["expected"] == b["expected"]
        assert a["p_value"] == b["p_value"]
    # Session.pdf at the drawn directions is the draws' own density (pdfL in another kernel).
    t = math.radians(45)
    wo = np.array([math.sin(t), 0.0, math.cos(t)])
    s = gpu.sample(str(path), wo, 512, seed=1)
    kept = s.pdf > 0
    wi = s.wi[kept] / np.linalg.norm(s.wi[kept], axis=1, keepdims=True)
    assert np.allclose(gpu.pdf(str(path), wi, wo), s.pdf[kept], rtol=1e-5, atol=0)
    with pytest.raises(Exception, match="half_vector_sampler.brdf"):
        cpu.chi2(str(path), theta_o_deg=[45], samples=1 << 10)
    with pytest.raises(Exception, match="half_vector_sampler.brdf"):
        cpu.pdf(str(path), wi, wo)
