"""python -m lobe.batch fit|sweep|report|merge: the batches of :mod:`lobe.batch` as a command."""

from __future__ import annotations

import argparse
import sys
from typing import Any, Dict, List, Optional, Sequence

import lobe

from . import BatchError, fit, merge, report, sweep

EXAMPLES = """examples:
  python -m lobe.batch fit --targets merl/ --model 'microfacet{distribution=ggx}' --free alpha,specular \\
      --model cook_torrance --free diffuse,specular,roughness --out fits.csv
  python -m lobe.batch fit --targets merl/ --model phong --free diffuse,specular,shininess \\
      --out fits.csv --ray auto
  python -m lobe.batch sweep --model microfacet --vary ior=1.2:2:5 --kind albedo-lut \\
      --param alpha --range 0.05,1 --res 32,32 --out luts/
  python -m lobe.batch report fits.csv -o fits.png
  python -m lobe.batch merge shard-*.csv -o fits.csv
"""


def _ints(name: str, count: Optional[int] = None):
    def parse(text: str) -> List[int]:
        try:
            values = [int(v) for v in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name}: expected integers separated by commas, got {text!r}")
        if any(v <= 0 for v in values) or (count is not None and len(values) != count):
            n = f"{count} " if count else ""
            raise argparse.ArgumentTypeError(f"{name}: expected {n}positive integers, got {text!r}")
        return values
    return parse


def _value(text: str) -> Any:
    """A parameter value as lobe's KEY=VALUE takes it: a number, r,g,b, or an option's name."""
    parts = text.split(",")
    try:
        numbers = [float(p) for p in parts]
    except ValueError:
        return text
    return numbers[0] if len(numbers) == 1 else tuple(numbers)


def _vary(text: str) -> tuple:
    """KEY=V1,V2,... (numbers or options), KEY=LO:HI:N (N values evenly spaced, both ends
    included) or KEY=R,G,B;R,G,B;... (rgb values)."""
    key, eq, values = text.partition("=")
    if not eq or not key.strip() or not values.strip():
        raise argparse.ArgumentTypeError(f"--vary {text!r}: expected KEY=V1,V2,..., KEY=LO:HI:N or "
                                         "KEY=R,G,B;R,G,B")
    key = key.strip()
    if ";" in values:
        return key, [_value(v) for v in values.split(";") if v.strip()]
    if values.count(":") == 2:
        lo, hi, n = values.split(":")
        try:
            lo_f, hi_f, count = float(lo), float(hi), int(n)
        except ValueError:
            raise argparse.ArgumentTypeError(f"--vary {text!r}: LO:HI:N takes two numbers and a count") from None
        if count < 1:
            raise argparse.ArgumentTypeError(f"--vary {text!r}: N must be at least 1")
        if count == 1:
            return key, [lo_f]
        return key, [lo_f + (hi_f - lo_f) * k / (count - 1) for k in range(count)]
    return key, [_value(v) for v in values.split(",")]


def _set(text: str) -> tuple:
    key, eq, value = text.partition("=")
    if not eq or not key.strip():
        raise argparse.ArgumentTypeError(f"--set {text!r}: expected KEY=VALUE")
    return key.strip(), _value(value)


def _run_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--ray", metavar="auto|ADDRESS",
                   help="run on a Ray cluster: auto (the one `ray start` left on this machine) or the "
                        "head node's HOST:PORT; without it the batch runs in this process")
    p.add_argument("--no-resume", action="store_true",
                   help="start over: an earlier output is kept beside the new one as OUT.~N~ "
                        "(default: resume, skipping the work already in it)")
    p.add_argument("--backend", choices=["gpu", "cpu"], default="gpu",
                   help="gpu (Vulkan, f32; lavapipe without a GPU) or cpu (the f64 reference)")
    p.add_argument("--device", help="the first Vulkan device whose name contains this")
    p.add_argument("--quiet", action="store_true", help="print no progress and no summary")


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(
        prog="python -m lobe.batch",
        description="Batches over lobe, in this process or on a Ray cluster, resumable: fit every "
                    "model to every target (one CSV row per pair), sweep a parameter grid into "
                    "tables or albedo LUTs, report a fit batch as a table and a heat map, merge "
                    "the CSVs of shards.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = top.add_subparsers(dest="command", required=True, metavar="fit|sweep|report|merge")

    f = sub.add_parser("fit", help="fit every model to every target",
                       description="Fits every --model to every target, one CSV row per pair "
                                   "(target, model, free, loss, params, seconds, worker, options).")
    f.add_argument("--target", action="append", default=[], metavar="T",
                   help="a model spec, a MERL .binary, a .brdf or a lobe table .npy (repeatable)")
    f.add_argument("--targets", action="append", default=[], metavar="DIR",
                   help="a folder: every .binary, .brdf and .npy file in it (repeatable)")
    f.add_argument("--model", action="append", default=[], metavar="SPEC",
                   help="a model to fit, fixed parameters in its braces (repeatable, each with --free)")
    f.add_argument("--free", action="append", default=[], metavar="KEYS",
                   help="the keys to fit of the --model before it, comma-separated")
    f.add_argument("--out", required=True, help="the CSV (resumed when it is there)")
    f.add_argument("--loss", choices=["log", "l2"], default="log", help="as lobe fit (default log)")
    f.add_argument("--max-bins", type=int, default=65536, help="as lobe fit (default 65536)")
    f.add_argument("--starts", type=int, default=4, help="as lobe fit (default 4)")
    f.add_argument("--max-iters", type=int, default=400, help="as lobe fit (default 400)")
    _run_options(f)

    s = sub.add_parser("sweep", help="tables or albedo LUTs over a parameter grid",
                       description="Writes a table set or an albedo LUT (.npz) per point of the grid "
                                   "of --vary values into --out, with --out/index.csv naming each "
                                   "point's file and values.")
    s.add_argument("--model", required=True, metavar="SPEC", help="the model")
    s.add_argument("--vary", action="append", type=_vary, default=[], metavar="KEY=VALUES",
                   help="a swept parameter: KEY=V1,V2,..., KEY=LO:HI:N or KEY=R,G,B;R,G,B (repeatable; "
                        "the grid is every combination)")
    s.add_argument("--set", action="append", type=_set, default=[], metavar="KEY=VALUE",
                   help="a parameter every point shares (repeatable)")
    s.add_argument("--kind", choices=["table", "albedo-lut"], default="table",
                   help="what each point writes (default table)")
    s.add_argument("--out", required=True, metavar="DIR", help="the folder (resumed when it has an index)")
    s.add_argument("--grid", choices=["full", "isotropic", "halfdiff"], default="isotropic",
                   help="table: its grid, as lobe table (default isotropic)")
    s.add_argument("--res", metavar="N,N,...",
                   help="table: cells per axis (default 90,90,180); albedo-lut: Nmu,Np (default 32,32)")
    s.add_argument("--param", help="albedo-lut: the key(s) its rows sweep, comma-separated")
    s.add_argument("--range", metavar="LO,HI", help="albedo-lut: the rows' range")
    s.add_argument("--mapping", choices=["linear", "log", "square", "perceptual"],
                   help="albedo-lut: how rows map to the parameter")
    s.add_argument("--method", default="peak", help="albedo-lut: the quadrature (default peak)")
    s.add_argument("--samples", type=int, help="albedo-lut: nodes per direction")
    s.add_argument("--white-furnace", action="store_true", help="every specular Fresnel factor set to 1")
    _run_options(s)

    r = sub.add_parser("report", help="a fit batch as a table and a heat map",
                       description="Prints materials against models (the loss of each pair, * at each "
                                   "material's best) and draws it as a heat map.")
    r.add_argument("csv", nargs="+", help="fit CSVs")
    r.add_argument("-o", "--output", help="the heat map, .png or .svg")

    m = sub.add_parser("merge", help="merge the fit CSVs of shards",
                       description="Merges fit CSVs of one batch (e.g. one per Slurm array task) into "
                                   "one: every pair once.")
    m.add_argument("csv", nargs="+", help="fit CSVs")
    m.add_argument("-o", "--output", required=True, help="the merged CSV")
    return top


def _fit(a: argparse.Namespace) -> int:
    if not a.model:
        raise BatchError("--model: give at least one model, each with --free KEYS")
    if len(a.free) != len(a.model):
        raise BatchError(f"--free: {len(a.model)} --model but {len(a.free)} --free; give each "
                         "--model its --free KEYS")
    targets = a.target + a.targets
    if not targets:
        raise BatchError("--target/--targets: give what to fit against")
    summary = fit(targets, list(zip(a.model, a.free)), a.out, ray=a.ray, resume=not a.no_resume,
                  loss=a.loss, max_bins=a.max_bins, starts=a.starts, max_iters=a.max_iters,
                  backend=a.backend, device=a.device, quiet=a.quiet)
    return 1 if summary.failed else 0


def _sweep(a: argparse.Namespace) -> int:
    if not a.vary:
        raise BatchError("--vary: give at least one swept parameter, KEY=VALUES")
    vary: Dict[str, Any] = {}
    for key, values in a.vary:
        if key in vary:
            raise BatchError(f"--vary: {key} is given twice")
        vary[key] = values
    res = None if a.res is None else _ints("--res")(a.res)
    rng = None
    if a.range is not None:
        try:
            rng = tuple(float(v) for v in a.range.split(","))
        except ValueError:
            rng = ()
        if len(rng) != 2:
            raise BatchError(f"--range {a.range!r}: expected LO,HI")
    param = None if a.param is None else a.param.split(",")
    summary = sweep(a.model, vary, a.out, kind=a.kind, ray=a.ray, resume=not a.no_resume,
                    params=dict(a.set), grid=a.grid, res=res, param=param, range=rng,
                    mapping=a.mapping, method=a.method, samples=a.samples,
                    white_furnace=a.white_furnace, backend=a.backend, device=a.device, quiet=a.quiet)
    return 1 if summary.failed else 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    a = parser().parse_args(argv)
    try:
        if a.command == "fit":
            return _fit(a)
        if a.command == "sweep":
            return _sweep(a)
        if a.command == "report":
            sys.stdout.write(report(a.csv, a.output))
            if a.output:
                print(f"wrote {a.output}", file=sys.stderr)
            return 0
        n = merge(a.csv, a.output)
        print(f"wrote {a.output}: {n} rows", file=sys.stderr)
        return 0
    except (BatchError, ValueError, TypeError, FileNotFoundError, lobe.GpuError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except argparse.ArgumentTypeError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted: the finished work is in the output; run the same command again to "
              "carry on", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
