"""Mitsuba 3's render of `lobe light`'s scene, and its comparison with lobe's exact sum.

The scene of docs/design.md §15.2: the unit sphere seen from +z by an orthographic camera whose
frame spans [-1, 1]^2 (row 0 at +y, column 0 at -x), lit only by a lat-long EXR map through
Mitsuba's `envmap` (+y up, u = atan2(x, -z) / 2pi: the layout lobe reads), with a
`roughconductor` GGX BSDF of the given alpha and RGB eta and k, the `direct` integrator and a box
pixel filter.

  render:  --out IMAGES.npy   renders --seeds renders of --spp samples per pixel and saves them
           as an array (seeds, size, size, 3); prints one JSON line with the seconds per render.
  compare: --compare LOBE.exr --images IMAGES.npy   prints one JSON line: over the pixels whose
           whole footprint lies inside the sphere, the mean and RMS of
           z = (mean over seeds - lobe) / standard error (the seeds' standard deviation over
           sqrt(seeds)), and the mean relative difference |mean - lobe| / lobe.

Run through scripts/peers/mitsuba-python (a venv of its own on first use).
"""

import argparse
import json
import math
import time

import numpy as np


def render(a):
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    eta = [float(x) for x in a.eta.split(",")]
    k = [float(x) for x in a.k.split(",")]
    scene = mi.load_dict(
        {
            "type": "scene",
            "integrator": {"type": "direct"},
            "sensor": {
                "type": "orthographic",
                # Looking down -z from +z with +y up: Mitsuba's film then has row 0 at +y and
                # column 0 at -x, lobe's layout.
                "to_world": mi.ScalarTransform4f().look_at(
                    origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]
                ),
                "film": {
                    "type": "hdrfilm",
                    "width": a.size,
                    "height": a.size,
                    "rfilter": {"type": "box"},
                    "pixel_format": "rgb",
                },
                "sampler": {"type": "independent", "sample_count": a.spp},
            },
            "sphere": {
                "type": "sphere",
                "radius": 1.0,
                "bsdf": {
                    "type": "roughconductor",
                    "distribution": "ggx",
                    "alpha": a.alpha,
                    "eta": {"type": "rgb", "value": eta},
                    "k": {"type": "rgb", "value": k},
                },
            },
            "light": {"type": "envmap", "filename": a.env},
        }
    )
    images, seconds = [], []
    for s in range(a.seeds):
        t0 = time.perf_counter()
        img = mi.render(scene, spp=a.spp, seed=a.seed0 + s)
        dr.eval(img)
        dr.sync_thread()
        arr = np.array(img)[:, :, :3]
        seconds.append(time.perf_counter() - t0)
        images.append(arr)
    np.save(a.out, np.stack(images).astype(np.float64))
    print(json.dumps({"renders": a.seeds, "spp": a.spp, "size": a.size, "seconds": seconds}))


def read_exr(path):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32))


def compare(a):
    lobe = read_exr(a.compare).astype(np.float64)
    imgs = np.load(a.images)
    n, size = imgs.shape[0], imgs.shape[1]
    mean = imgs.mean(0)
    se = imgs.std(0, ddof=1) / math.sqrt(n)
    # Pixels whose whole square lies inside the sphere: the farthest corner within radius 1.
    c = -1 + (2 * np.arange(size) + 1) / size
    x, y = np.meshgrid(c, -c)
    h = 1.0 / size
    inside = (np.abs(x) + h) ** 2 + (np.abs(y) + h) ** 2 < 1.0
    m = inside[:, :, None] & (se > 0) & (lobe > 0)
    z = (mean - lobe)[m] / se[m]
    rel = np.abs(mean - lobe)[m] / lobe[m]
    lum = lambda im: im @ np.array([0.2126, 0.7152, 0.0722])
    print(
        json.dumps(
            {
                "seeds": n,
                "pixels": int(inside.sum()),
                "values": int(m.sum()),
                "mean_z": float(z.mean()),
                "rms_z": float(np.sqrt((z**2).mean())),
                "fraction_abs_z_above_3": float((np.abs(z) > 3).mean()),
                "mean_relative_difference": float(rel.mean()),
                "median_relative_standard_error": float(np.median(se[m] / lobe[m])),
                "mean_luminance_mitsuba": float(lum(mean)[inside].mean()),
                "mean_luminance_lobe": float(lum(lobe)[inside].mean()),
            }
        )
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--env", default="sky.exr")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--alpha", type=float, default=0.3)
    ap.add_argument("--eta", default="1,1,1", help="r,g,b")
    ap.add_argument("--k", default="0,0,0", help="r,g,b")
    ap.add_argument("--out")
    ap.add_argument("--compare")
    ap.add_argument("--images")
    a = ap.parse_args()
    if a.compare:
        compare(a)
    else:
        render(a)


if __name__ == "__main__":
    main()
