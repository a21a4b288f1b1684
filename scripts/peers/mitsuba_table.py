"""Mitsuba 3's BSDF eval on lobe's isotropic table grid, timed as `lobe bench` times a table.

The same work as `lobe bench --tasks table` on the roughconductor configuration: every
(theta_i, theta_o, dphi) cell centre of an NTHETA_I x NTHETA_O x NDPHI grid (docs/design.md §4.1:
theta = (k + 1/2) pi/2 / N, dphi = (k + 1/2) pi / N), light at phi = 0, evaluated once per run,
RGB out. The directions are built once, outside the timed region, as lobe builds its lists once
per job. Each timed run is `bsdf.eval` followed by `dr.eval` and `dr.sync_thread`, so that the
kernel has run when the clock stops. Prints one JSON line: evaluations, runs, median seconds and
evaluations per second.

Run through scripts/peers/mitsuba (it installs Mitsuba in a venv of its own).
"""

import argparse
import json
import math
import statistics
import time

import drjit as dr
import mitsuba as mi


def grid_directions(n_i, n_o, n_dphi):
    """Light and view directions of every cell, row-major (theta_i, theta_o, dphi)."""
    import numpy as np

    ti = (np.arange(n_i) + 0.5) * (math.pi / 2) / n_i
    to = (np.arange(n_o) + 0.5) * (math.pi / 2) / n_o
    dp = (np.arange(n_dphi) + 0.5) * math.pi / n_dphi
    TI, TO, DP = np.meshgrid(ti, to, dp, indexing="ij")
    wi = np.stack([np.sin(TI), np.zeros_like(TI), np.cos(TI)], -1).reshape(-1, 3)
    wo = np.stack([np.sin(TO) * np.cos(DP), np.sin(TO) * np.sin(DP), np.cos(TO)], -1).reshape(-1, 3)
    return wi.astype(np.float32), wo.astype(np.float32)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--res", default="128,128,256", help="NTHETA_I,NTHETA_O,NDPHI")
    ap.add_argument("--alpha", type=float, default=0.3)
    ap.add_argument("--material", default="Au")
    ap.add_argument("--repeats", type=int, default=9)
    a = ap.parse_args()

    mi.set_variant(a.variant)
    n_i, n_o, n_dphi = (int(x) for x in a.res.split(","))
    wi_np, wo_np = grid_directions(n_i, n_o, n_dphi)
    bsdf = mi.load_dict(
        {
            "type": "roughconductor",
            "distribution": "beckmann",
            "alpha": a.alpha,
            "material": a.material,
            "sample_visible": False,
        }
    )
    si = dr.zeros(mi.SurfaceInteraction3f, len(wi_np))
    si.wi = mi.Vector3f(wi_np[:, 0], wi_np[:, 1], wi_np[:, 2])
    wo = mi.Vector3f(wo_np[:, 0], wo_np[:, 1], wo_np[:, 2])
    dr.eval(si, wo)
    ctx = mi.BSDFContext()

    def run():
        t = time.perf_counter()
        v = bsdf.eval(ctx, si, wo)
        dr.eval(v)
        dr.sync_thread()
        return time.perf_counter() - t, v

    _, v = run()  # compiles the kernel
    finite = bool(dr.all(dr.isfinite(v.x)))
    times = [run()[0] for _ in range(a.repeats)]
    med = statistics.median(times)
    n = len(wi_np)
    print(json.dumps({"peer": f"mitsuba {mi.__version__} {a.variant}", "evaluations": n,
                      "runs": a.repeats, "median_s": med, "evals_per_s": n / med,
                      "finite": finite}))


if __name__ == "__main__":
    main()
