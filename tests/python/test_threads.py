"""One session used from several Python threads at once."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np


def test_a_session_serves_several_threads_with_the_values_of_one(gpu):
    def job(k):
        t = gpu.table("cook_torrance", grid="isotropic", res=(8, 8, 8 + k % 3), params={"roughness": 0.3})
        return k, t.values

    alone = {k: job(k)[1] for k in range(3)}
    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(job, range(12)))
    for k, values in results:
        assert values.tobytes() == alone[k % 3].tobytes()


def test_the_gil_is_released_while_a_job_runs(cpu):
    # Another Python thread records the time while the main thread waits in a job: with the
    # GIL held through the call, no record could fall inside the call's middle. The job is the
    # adaptive reference integrator; how long it takes depends on the machine, so the number of
    # directions doubles until one call lasts long enough to tell (MIN_CALL_SECONDS: a few
    # hundred of the recorder's 1 ms sleeps fit in its middle).
    import threading
    import time

    MIN_CALL_SECONDS = 0.25
    MAX_DIRECTIONS = 1 << 12

    n = 8
    while True:
        stamps = []
        stop = threading.Event()

        def record():
            while not stop.is_set():
                stamps.append(time.perf_counter())
                time.sleep(0.001)

        t = threading.Thread(target=record)
        t.start()
        start = time.perf_counter()
        cpu.albedo("microfacet", mu=np.linspace(0.1, 1.0, n), method="reference")
        end = time.perf_counter()
        stop.set()
        t.join()
        if end - start >= MIN_CALL_SECONDS or n >= MAX_DIRECTIONS:
            break
        n *= 2
    assert end - start >= MIN_CALL_SECONDS, f"{n} directions took only {end - start:.3f} s"
    margin = 0.2 * (end - start)
    inside = [x for x in stamps if start + margin < x < end - margin]
    assert inside, f"no other thread ran during the {end - start:.3f} s call"
