"""lobe.batch: fits and sweeps in this process and on a local Ray cluster give the same numbers,
survive kill -9 (of a Ray worker, of the whole batch) without losing or redoing a finished
piece, and refuse bad input with a message naming it."""

import csv
import io
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time

import numpy as np
import pytest

import lobe
import lobe.batch

TESTDATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "testdata")

#: Fits kept small so the file runs in well under two minutes on lavapipe: 800 bins of the
#: target, two starts of at most 40 iterations (a fit takes about 0.1-0.3 s here).
FIT = ["--max-bins", "800", "--starts", "2", "--max-iters", "40"]
FIT_KW = dict(max_bins=800, starts=2, max_iters=40)

#: Six model targets (a GGX and a Beckmann lobe, Phong, Ashikhmin-Shirley, Oren-Nayar, a
#: rough conductor preset) and two fitted models with their free keys.
TARGETS = [
    "microfacet{distribution=ggx,alpha=0.25,specular=0.9,0.6,0.3}",
    "microfacet{distribution=beckmann,alpha=0.4}",
    "phong{shininess=40}",
    "ashikhmin_shirley{nu=200,nv=50}",
    "oren_nayar",
    "cook_torrance{roughness=0.3}",
]
MODELS = [("microfacet{distribution=ggx}", "alpha,specular"), ("phong", "diffuse,specular,shininess")]

#: How long a batch or a cluster may take to come up or finish here before the test calls it
#: hung: a 12-pair batch takes a few seconds, Ray's head node about 5-10 s on 2 busy cores.
HANG_S = 120


def fit_args(out, targets=TARGETS, models=MODELS, extra=()):
    args = [sys.executable, "-m", "lobe.batch", "fit", "--out", str(out)] + FIT + list(extra)
    for t in targets:
        args += ["--target", t]
    for spec, free in models:
        args += ["--model", spec, "--free", free]
    return args


def run(args, **kw):
    return subprocess.run(args, capture_output=True, text=True, timeout=HANG_S, **kw)


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def pairs(rs):
    return sorted((r["target"], r["model"], r["free"]) for r in rs)


def numbers(rs):
    return {(r["target"], r["model"], r["free"]): (r["loss"], r["params"]) for r in rs}


#: How long a worker's CPU time is watched to tell a fitting worker from an idle one: a fit
#: keeps a core busy (several 10 ms clock ticks in 0.3 s even on a loaded machine), an idle
#: Ray worker waits on a socket.
BUSY_WINDOW_S = 0.3


def cpu_ticks(pid):
    """User and system CPU time of process ``pid`` in clock ticks (/proc/PID/stat)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def written_rows(path):
    """The rows of ``path`` whose lines a running batch has finished writing: the file read at
    once, up to its last newline (a batch appends a row at a time, so a poll can catch the
    header or a row half written)."""
    with open(path, newline="") as f:
        text = f.read()
    text = text[: text.rfind("\n") + 1]
    return list(csv.DictReader(io.StringIO(text))) if text else []


def wait_rows(path, count, proc):
    """Polls ``path`` until it has ``count`` rows (or the batch ended)."""
    deadline = time.monotonic() + HANG_S
    while time.monotonic() < deadline:
        if os.path.exists(path) and len(written := written_rows(path)) >= count:
            return written
        if proc.poll() is not None:
            pytest.fail(f"the batch ended before {count} rows: {proc.stderr.read()}")
        time.sleep(0.02)
    pytest.fail(f"no {count} rows in {path} after {HANG_S} s")


@pytest.fixture(scope="module")
def cluster():
    """A Ray head node on loopback with two CPUs (so two workers), its session files in a
    folder of its own; ended, with every process it started, even when a test fails."""
    ray_bin = os.path.join(os.path.dirname(sys.executable), "ray")
    if not os.path.exists(ray_bin):
        pytest.fail("Ray is not installed in the test environment: pip install '.[ray]' "
                    "(tests/python.rs installs it)")
    folder = tempfile.mkdtemp(prefix="lobe-ray-", dir="/tmp")
    port = free_port()
    head = subprocess.Popen(
        [ray_bin, "start", "--head", "--block", "--node-ip-address", "127.0.0.1", "--port",
         str(port), "--num-cpus", "2", "--num-gpus", "0", "--include-dashboard", "false",
         "--disable-usage-stats", "--temp-dir", folder],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        address = f"127.0.0.1:{port}"
        deadline = time.monotonic() + HANG_S
        probe = [sys.executable, "-c", f"import ray; ray.init(address='{address}', "
                 "logging_level='ERROR'); print(ray.cluster_resources().get('CPU'))"]
        while True:
            if head.poll() is not None:
                pytest.fail(f"ray start ended: {head.stdout.read()}")
            done = subprocess.run(probe, capture_output=True, text=True, timeout=HANG_S)
            if done.returncode == 0 and done.stdout.strip() == "2.0":
                break
            if time.monotonic() > deadline:
                pytest.fail(f"the Ray head node did not come up: {done.stderr}")
            time.sleep(0.5)
        yield address
    finally:
        # The head node, its raylet, GCS and workers are one process group (start_new_session):
        # asked to stop, then killed, so that nothing of the cluster outlives the tests.
        for sig, wait_s in ((signal.SIGTERM, 3), (signal.SIGKILL, 15)):
            try:
                os.killpg(head.pid, sig)
            except ProcessLookupError:
                break
            try:
                head.wait(timeout=wait_s)
            except subprocess.TimeoutExpired:
                continue
        subprocess.run(["rm", "-rf", folder], check=False)


@pytest.fixture(scope="module")
def local_rows(tmp_path_factory):
    out = tmp_path_factory.mktemp("local") / "fits.csv"
    done = run(fit_args(out))
    assert done.returncode == 0, done.stderr
    return rows(out)


def test_a_local_batch_has_one_row_per_pair_with_the_numbers_of_session_fit(local_rows, gpu):
    assert pairs(local_rows) == sorted((t, m, f) for t in TARGETS for m, f in MODELS)
    assert list(local_rows[0]) == list(lobe.batch.FIT_COLUMNS)
    # One door against the other: the row is the fit Session.fit gives for the same request.
    r = local_rows[0]
    one = gpu.fit(r["target"], r["model"], r["free"].split(","), **FIT_KW)
    assert r["loss"] == repr(one.loss)
    assert json.loads(r["params"]) == one.params
    assert {row["worker"] for row in local_rows} == {row["worker"] for row in local_rows[:1]}
    assert json.loads(r["options"]) == dict(FIT_KW, loss="log", backend="gpu", device=None)


def test_the_same_batch_on_ray_gives_the_same_numbers_on_several_workers(local_rows, cluster, tmp_path):
    out = tmp_path / "fits.csv"
    done = run(fit_args(out, extra=["--ray", cluster]))
    assert done.returncode == 0, done.stderr
    got = rows(out)
    assert pairs(got) == pairs(local_rows)
    assert numbers(got) == numbers(local_rows)
    workers = {r["worker"] for r in got}
    assert len(workers) >= 2, f"one worker ran every pair: {workers}"
    assert "12 done now" in done.stderr


def test_a_ray_worker_killed_mid_batch_costs_no_pair(local_rows, cluster, tmp_path):
    out = tmp_path / "fits.csv"
    proc = subprocess.Popen(fit_args(out, extra=["--ray", cluster]), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        first = wait_rows(out, 1, proc)
        victim = int(first[0]["worker"].rsplit(":", 1)[1])
        # The worker that finished the first pair has taken the next one (ten or more remain
        # queued for two workers): killed while it is fitting, which its CPU time shows.
        busy = cpu_ticks(victim)
        time.sleep(BUSY_WINDOW_S)
        assert cpu_ticks(victim) > busy, "the worker was idle, not in the middle of a fit"
        assert len(rows(out)) <= len(TARGETS) * len(MODELS) - 4
        os.kill(victim, signal.SIGKILL)
        _, err = proc.communicate(timeout=HANG_S)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    got = rows(out)
    assert pairs(got) == pairs(local_rows), "a pair is missing or there twice"
    assert numbers(got) == numbers(local_rows)


def test_a_local_batch_killed_and_run_again_redoes_no_finished_pair(local_rows, tmp_path):
    out = tmp_path / "fits.csv"
    proc = subprocess.Popen(fit_args(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_rows(out, 3, proc)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=HANG_S)
    finally:
        proc.kill()
    before = out.read_bytes()
    kept = rows(out)
    assert 3 <= len(kept) < len(TARGETS) * len(MODELS)
    again = run(fit_args(out))
    assert again.returncode == 0, again.stderr
    after = out.read_bytes()
    assert after.startswith(before[: before.rfind(b"\n") + 1]), "a finished row was rewritten"
    got = rows(out)
    assert pairs(got) == pairs(local_rows), "a pair is missing or there twice"
    assert numbers(got) == numbers(local_rows)
    new = got[len(kept):]
    assert len({r["worker"] for r in new}) == 1 and new[0]["worker"] not in {r["worker"] for r in kept}
    assert f"{len(kept)} already there" in again.stderr
    # A third run has nothing left to do.
    third = run(fit_args(out))
    assert third.returncode == 0 and "0 done now" in third.stderr
    assert out.read_bytes() == after


def test_a_torn_last_line_is_cut_off_and_its_pair_done_again(local_rows, tmp_path):
    out = tmp_path / "fits.csv"
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=lobe.batch.FIT_COLUMNS, lineterminator="\n")
        w.writeheader()
        for r in local_rows[:2]:
            w.writerow(r)
        f.write('oren_nayar,phong,"diffuse,spec')  # a write cut off by a kill
    done = run(fit_args(out))
    assert done.returncode == 0, done.stderr
    assert "torn last line" in done.stderr
    assert numbers(rows(out)) == numbers(local_rows)


def test_no_resume_sets_the_old_file_aside(local_rows, tmp_path):
    out = tmp_path / "fits.csv"
    targets = TARGETS[:1]
    assert run(fit_args(out, targets=targets)).returncode == 0
    old = out.read_bytes()
    done = run(fit_args(out, targets=targets, extra=["--no-resume"]))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "fits.csv.~1~").read_bytes() == old
    assert len(rows(out)) == len(MODELS)
    assert "fits.csv.~1~" in done.stderr


def test_folder_targets_expand_to_the_files_lobe_reads(gpu, tmp_path):
    folder = tmp_path / "scans"
    folder.mkdir()
    for name, spec in [("a", "microfacet{alpha=0.3}"), ("b", "phong{shininess=20}")]:
        gpu.write_table(folder / f"{name}.exr", spec, grid="isotropic", res=(8, 8, 16))
    (folder / "notes.txt").write_text("not a target")
    assert lobe.batch.expand_targets([str(folder)]) == [str(folder / "a.npy"), str(folder / "b.npy")]
    out = tmp_path / "fits.csv"
    s = lobe.batch.fit([folder], [("phong", "diffuse,specular,shininess")], out, quiet=True, **FIT_KW)
    assert (s.total, s.done, s.failed) == (2, 2, [])
    r = rows(out)[0]
    one = gpu.fit(str(folder / "a.npy"), "phong", ["diffuse", "specular", "shininess"], **FIT_KW)
    assert r["target"] == str(folder / "a.npy") and r["loss"] == repr(one.loss)


def test_report_marks_the_best_model_of_each_material(local_rows, tmp_path):
    csv_path = tmp_path / "fits.csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=lobe.batch.FIT_COLUMNS, lineterminator="\n")
        w.writeheader()
        w.writerows(local_rows)
    done = run([sys.executable, "-m", "lobe.batch", "report", str(csv_path), "-o", str(tmp_path / "fits.png")])
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].split()[0] == "material" and len(lines) == 1 + len(TARGETS)
    for t in TARGETS:
        mine = [r for r in local_rows if r["target"] == t]
        best = min(mine, key=lambda r: float(r["loss"]))
        line = next(l for l in lines if l.startswith(t))
        assert line.endswith(f"{best['model']} [{best['free']}]")
        assert f"{float(best['loss']):.4g}*" in line
    png = (tmp_path / "fits.png").read_bytes()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    svg_path = tmp_path / "fits.svg"
    assert lobe.batch.report(csv_path, svg_path) == done.stdout
    assert svg_path.read_text().count('stroke="#e8112d"') == len(TARGETS)


def test_merge_joins_shards_into_every_pair_once(local_rows, tmp_path):
    a, b, merged = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "merged.csv"
    assert run(fit_args(a, targets=TARGETS[:4])).returncode == 0
    assert run(fit_args(b, targets=TARGETS[3:])).returncode == 0  # TARGETS[3] in both shards
    done = run([sys.executable, "-m", "lobe.batch", "merge", str(a), str(b), "-o", str(merged)])
    assert done.returncode == 0, done.stderr
    assert pairs(rows(merged)) == pairs(local_rows)
    assert numbers(rows(merged)) == numbers(local_rows)
    other = tmp_path / "other.csv"
    assert run(fit_args(other, targets=TARGETS[:1], extra=["--loss", "l2"])).returncode == 0
    refused = run([sys.executable, "-m", "lobe.batch", "merge", str(a), str(other), "-o", str(merged)])
    assert refused.returncode == 2 and "only shards of one batch merge" in refused.stderr


@pytest.mark.parametrize("kind", ["albedo-lut", "table"])
def test_a_sweep_writes_one_file_per_point_and_resumes(gpu, cluster, tmp_path, kind):
    args = [sys.executable, "-m", "lobe.batch", "sweep", "--model", "microfacet", "--vary",
            "alpha=0.1:0.7:3", "--vary", "distribution=ggx,beckmann", "--kind", kind]
    args += ["--res", "8,4", "--samples", "64"] if kind == "albedo-lut" else ["--res", "4,4,8"]
    local, on_ray = tmp_path / "local", tmp_path / "ray"
    done = run(args + ["--out", str(local)])
    assert done.returncode == 0, done.stderr
    index = rows(local / "index.csv")
    assert len(index) == 6
    for k, r in enumerate(index):
        point = json.loads(r["params"])
        assert point == {"alpha": [0.1, 0.4, 0.7][k // 2], "distribution": ["ggx", "beckmann"][k % 2]}
        if kind == "albedo-lut":
            lut = np.load(local / r["file"])
            one = gpu.albedo_lut("microfacet", params=point, res=(8, 4), samples=64)
            assert lut["e"].tobytes() == one.e.tobytes() and lut["p"].tobytes() == one.p.tobytes()
        else:
            values = np.load(local / r["file"].replace(".exr", ".npy"))
            one = gpu.table("microfacet", grid="isotropic", res=(4, 4, 8), params=point)
            assert values.tobytes() == one.values.tobytes()
    again = run(args + ["--out", str(local)])
    assert again.returncode == 0 and "6 already there" in again.stderr
    done = run(args + ["--out", str(on_ray), "--ray", cluster])
    assert done.returncode == 0, done.stderr
    for r in rows(on_ray / "index.csv"):
        for suffix in ([".npz"] if kind == "albedo-lut" else [".npy", ".json"]):
            name = r["file"].rsplit(".", 1)[0] + suffix
            assert (on_ray / name).read_bytes() == (local / name).read_bytes(), name


# Bad input: a clear message naming it, exit status 2, nothing written or clobbered.

def refused(args, *needles):
    done = run(args)
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    assert "Traceback" not in done.stderr
    for n in needles:
        assert n in done.stderr, (n, done.stderr)
    return done


def test_a_target_lobe_does_not_read_is_refused(tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text("hello")
    out = tmp_path / "fits.csv"
    refused(fit_args(out, targets=[str(notes)]), str(notes), "not a file lobe reads", ".binary")
    refused(fit_args(out, targets=[str(tmp_path / "gone.binary")]), "no such file", "gone.binary")
    empty = tmp_path / "empty"
    empty.mkdir()
    refused(fit_args(out, targets=[str(empty)]), "holds no file lobe reads")
    refused(fit_args(out, targets=["blinn_phong{shininess=80}"]), "blinn_phong{shininess=80}",
            "unknown parameter 'shininess'", "smoothness")
    assert not out.exists()


def test_a_model_spec_that_does_not_parse_is_refused(tmp_path):
    out = tmp_path / "fits.csv"
    refused(fit_args(out, models=[("phong{shininess=", "shininess")]), "phong{shininess=", "'}'")
    refused(fit_args(out, models=[("no_such_model", "alpha")]), "no_such_model")
    refused(fit_args(out, models=[("phong", "alpha")]), "phong", "alpha")
    refused(fit_args(out, models=[("phong", "shininess")], extra=["--model", "lambert"]), "--free")
    assert not out.exists()


def test_a_csv_that_is_not_a_batch_file_is_refused_and_kept(local_rows, tmp_path):
    out = tmp_path / "fits.csv"
    out.write_text("name,value\nfoo,1\n")
    refused(fit_args(out), str(out), "not a lobe.batch fit CSV", "name,value")
    refused(fit_args(out, extra=["--no-resume"]), "not a lobe.batch fit CSV")
    assert out.read_text() == "name,value\nfoo,1\n"
    assert not (tmp_path / "fits.csv.~1~").exists()
    # A batch file made with other options is not resumed under these.
    ours = tmp_path / "ours.csv"
    assert run(fit_args(ours, targets=TARGETS[:1])).returncode == 0
    kept = ours.read_bytes()
    refused(fit_args(ours, targets=TARGETS[:1], extra=["--starts", "3"]), "options", "--no-resume")
    assert ours.read_bytes() == kept
    refused([sys.executable, "-m", "lobe.batch", "report", str(out)], "not a lobe.batch fit CSV")


def test_a_cluster_that_does_not_answer_is_refused_within_a_bounded_wait(tmp_path):
    out = tmp_path / "fits.csv"
    started = time.monotonic()
    port = free_port()
    refused(fit_args(out, extra=["--ray", f"127.0.0.1:{port}"]), f"127.0.0.1:{port}",
            "no Ray cluster answers")
    assert time.monotonic() - started < 60
    refused(fit_args(out, extra=["--ray", "127.0.0.1:port"]), "not an address")
    assert not out.exists()


def test_ray_missing_says_how_to_install_it(tmp_path):
    out = tmp_path / "fits.csv"
    code = ("import sys; sys.modules['ray'] = None; from lobe.batch.__main__ import main; "
            f"sys.exit(main({fit_args(out, extra=['--ray', 'auto'])[3:]!r}))")
    refused([sys.executable, "-c", code], "pip install 'lobe[ray]'")


def test_a_sweep_refuses_a_value_out_of_range_and_another_grid_in_its_folder(tmp_path):
    sweep = [sys.executable, "-m", "lobe.batch", "sweep", "--model", "cook_torrance", "--kind",
             "table", "--res", "2,2,4"]
    out = tmp_path / "tables"
    refused(sweep + ["--vary", "roughness=0.1,2", "--out", str(out)], "roughness = 2.0", "(0, 1]")
    assert not out.exists()
    grid = ["--vary", "roughness=0.2,0.4", "--vary", "ior=1.5,2"]
    assert run(sweep + grid + ["--out", str(out)]).returncode == 0
    index = (out / "index.csv").read_bytes()
    # The same values in another order name other points: not resumed.
    refused(sweep + grid[2:] + grid[:2] + ["--out", str(out)], "options", "--no-resume")
    assert (out / "index.csv").read_bytes() == index
