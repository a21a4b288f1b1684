"""Ctrl-C during a long job: KeyboardInterrupt soon after, nothing partial, the session usable."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

CHILD = textwrap.dedent("""
    import signal, sys, time
    import numpy as np
    import lobe
    # Python's own Ctrl-C handler, even where this process was started with SIGINT ignored (as a
    # shell without job control starts background commands), which Python would then keep.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    s = lobe.Session(backend="cpu")
    job, out = sys.argv[1], sys.argv[2]
    print("start", flush=True)
    t0 = time.perf_counter()
    try:
        if job == "albedo":
            # The adaptive reference: about 70 ms a direction here, so half a minute in all.
            result = s.albedo("microfacet", mu=np.linspace(0.01, 1.0, 400), method="reference")
        else:
            # 10 M cells of EON on the f64 reference: about 9 s here, written as 240 MB of files.
            result = s.write_table(out, "eon", grid="isotropic", res=(200, 200, 250))
        print("finished", flush=True)
    except KeyboardInterrupt as e:
        print(f"interrupted {time.perf_counter() - t0:.3f} {e}", flush=True)
    f = s.eval("lambert", [0, 0, 1], [0, 0, 1], params={"albedo": 0.5})
    print("after", f[0], flush=True)
""")

#: The longest the job may take to stop after SIGINT: one chunk of work (a direction of the
#: reference, a 64 Ki-cell chunk of a table) plus the 50 ms signal poll, with room for a busy
#: machine.
STOP_WITHIN_S = 3.0


@pytest.mark.parametrize("job", ["albedo", "write_table"])
def test_sigint_stops_a_long_job_with_keyboard_interrupt_and_nothing_partial(tmp_path, job):
    out = tmp_path / "t.exr"
    child = subprocess.Popen([sys.executable, "-c", CHILD, job, str(out)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    assert child.stdout.readline().strip() == "start"
    # Well inside the job on a machine many times faster than the one the comments above time.
    time.sleep(0.2)
    sent = time.perf_counter()
    child.send_signal(signal.SIGINT)
    lines = [child.stdout.readline().strip() for _ in range(2)]
    stopped = time.perf_counter() - sent
    child.wait(timeout=60)
    assert child.returncode == 0, child.stderr.read()
    assert lines[0].startswith("interrupted"), lines
    assert stopped < STOP_WITHIN_S, stopped
    assert lines[1].startswith("after 0.1591549430918"), lines
    assert os.listdir(tmp_path) == [], os.listdir(tmp_path)
