"""Mitsuba 3's own chi-square test of roughconductor's sampler, as one whole run.

`mitsuba.chi2.ChiSquareTest` with `BSDFAdapter` on roughconductor (GGX, alpha 0.3, sampling the
visible normals, its default), at one view direction theta_o (degrees, in the x-z plane) with
SAMPLES draws over Mitsuba's default 101 x 50 sphere cells. Mitsuba's test is what is timed: the
histogram, the pdf tabulation and the verdict, plus Mitsuba's start; the wall time of the whole
process is taken by scripts/peers/mitsuba-chi2. Prints one JSON line: draws, the p-value, the
verdict and the seconds inside Python.

Run through scripts/peers/mitsuba-python (a venv of its own on first use).
"""

import argparse
import json
import math
import time

import drjit as dr
import mitsuba as mi


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--samples", type=float, default=1e8)
    ap.add_argument("--alpha", type=float, default=0.3)
    ap.add_argument("--theta-o-deg", type=float, default=45.0)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()

    start = time.perf_counter()
    mi.set_variant(a.variant)
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    t = math.radians(a.theta_o_deg)
    sample_func, pdf_func = BSDFAdapter(
        "roughconductor",
        {"type": "roughconductor", "distribution": "ggx", "alpha": a.alpha},
        wi=[math.sin(t), 0.0, math.cos(t)],
    )
    test = ChiSquareTest(
        domain=SphericalDomain(),
        sample_func=sample_func,
        pdf_func=pdf_func,
        sample_dim=3,
        sample_count=int(a.samples),
        seed=a.seed,
    )
    passed = bool(test.run(0.01, quiet=True))
    seconds = time.perf_counter() - start
    print(
        json.dumps(
            {
                "peer": "mitsuba " + mi.__version__,
                "draws": int(a.samples),
                "p_value": float(test.p_value),
                "passed": passed,
                "seconds_in_python": seconds,
            }
        )
    )


if __name__ == "__main__":
    main()
