"""Batches over lobe: every model fitted to every material of a set (the table of Ngan, Durand
& Matusik 2005: materials against models, with the fitted parameters and the loss), and
sweeps that write a table or an albedo LUT at every point of a parameter grid.

A batch writes one CSV row per finished piece of work, synced to disk as it lands, so a
batch that is killed loses only the pieces in flight, and running it again with the same
output carries on where it stopped. It runs in this process, or as Ray tasks on a cluster
(``ray="auto"`` or the head node's ``"HOST:PORT"``; ``pip install 'lobe[ray]'``) with the
same numbers. The same as a command: ``python -m lobe.batch fit|sweep|report|merge``.

    >>> import lobe.batch
    >>> lobe.batch.fit(["gold.binary", "scans/"], [("microfacet{distribution=ggx}", "alpha,specular"),
    ...                 ("cook_torrance", "diffuse,specular,roughness")], "fits.csv")
"""

from __future__ import annotations

import builtins
import itertools
import json
import os
import sys
import time
from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import lobe

from . import _run, _work
from ._ledger import FIT_COLUMNS, SWEEP_COLUMNS, BatchError, Ledger, csv_line, read_rows, write_atomic

__all__ = ["fit", "sweep", "report", "merge", "Summary", "BatchError", "FIT_COLUMNS",
           "SWEEP_COLUMNS", "TARGET_SUFFIXES"]

#: The files a target may be (a folder of targets expands to the files with these endings):
#: a MERL measurement, a BRDF Explorer shader, a lobe table (its ``.npy``, beside its ``.json``).
TARGET_SUFFIXES = (".binary", ".brdf", ".npy")

#: Files a folder of targets holds beside them that are not targets of their own: the rest of
#: a lobe table's set (``.json`` sidecar, ``.exr``) and the pictures ``lobe fit -o`` draws.
_COMPANION_SUFFIXES = (".json", ".exr", ".png", ".svg", ".pdf", ".csv")

Model = Union[Tuple[str, Union[str, Sequence[str]]], Mapping[str, Any]]


@dataclass
class Summary:
    """What a batch did: ``total`` pieces asked for, ``skipped`` (already in the output from an
    earlier run), ``done`` now, ``failed`` (piece and message; not written, so a rerun tries
    them again), ``seconds`` of wall time and the ``workers`` (host:pid) that ran them."""

    out: str
    total: int
    skipped: int
    done: int
    failed: List[Tuple[str, str]] = field(default_factory=list)
    seconds: float = 0.0
    workers: List[str] = field(default_factory=list)
    notes: List[str] = field(default_factory=list)

    def __str__(self) -> str:
        failed = f", {len(self.failed)} failed" if self.failed else ""
        return (f"{self.out}: {self.total} in all, {self.done} done now, {self.skipped} already "
                f"there{failed}; {self.seconds:.1f} s on {len(self.workers)} "
                f"worker{'s' if len(self.workers) != 1 else ''}")


def _is_file_target(text: str) -> bool:
    return text.lower().endswith(TARGET_SUFFIXES + (".json",)) or os.sep in text or os.path.exists(text)


def expand_targets(targets: Union[str, os.PathLike, Sequence[Union[str, os.PathLike]]]) -> List[str]:
    """The targets one by one: model specs as they are (checked), files by absolute path, folders
    expanded to the files in them lobe reads (sorted by name). Refuses a spec that does not
    resolve, a missing file, a file lobe does not read and a folder with no targets in it."""
    items = [targets] if isinstance(targets, (str, os.PathLike)) else list(targets)
    if not items:
        raise BatchError("targets: none given; give model specs, MERL .binary, .brdf or lobe "
                         "table .npy files, or folders of them")
    out: List[str] = []
    for item in items:
        text = os.fspath(item) if isinstance(item, os.PathLike) else item
        if not isinstance(text, str):
            raise BatchError(f"targets: {item!r} is not a model spec or a path")
        if os.path.isdir(text):
            names = sorted(os.listdir(text))
            found = [os.path.join(os.path.abspath(text), n) for n in names
                     if n.lower().endswith(TARGET_SUFFIXES) and os.path.isfile(os.path.join(text, n))]
            if not found:
                raise BatchError(f"targets: the folder {text} holds no file lobe reads as a target "
                                 f"({', '.join(TARGET_SUFFIXES)})")
            out.extend(found)
        elif _is_file_target(text):
            if not os.path.exists(text):
                raise BatchError(f"targets: no such file: {text}")
            if not os.path.isfile(text):
                raise BatchError(f"targets: {text} is not a file or a folder")
            if text.lower().endswith(".json"):
                text = text[:-5] + ".npy"
                if not os.path.isfile(text):
                    raise BatchError(f"targets: {item}: a lobe table's .json needs its .npy beside it")
            if not text.lower().endswith(TARGET_SUFFIXES):
                raise BatchError(f"targets: {text} is not a file lobe reads as a target: give a MERL "
                                 ".binary, a BRDF Explorer .brdf or a lobe table .npy (or a model spec)")
            # By absolute path: a worker of a cluster runs in a folder of its own.
            out.append(os.path.abspath(text))
        else:
            try:
                # Resolving the spec (no device needed) checks its name and parameters.
                lobe.parity_tolerance(text, [0.0, 0.0, 1.0], [0.0, 0.0, 1.0])
            except (ValueError, TypeError) as e:
                raise BatchError(f"targets: {text}: {e}") from None
            out.append(text)
    seen = set()
    return [t for t in out if not (t in seen or seen.add(t))]


def _models(models: Sequence[Model]) -> List[Tuple[str, Tuple[str, ...]]]:
    if isinstance(models, (str, Mapping)) or (isinstance(models, tuple) and len(models) == 2
                                              and isinstance(models[0], str)
                                              and not isinstance(models[1], tuple)):
        models = [models]  # type: ignore[list-item]
    out = []
    for m in models:
        if isinstance(m, Mapping):
            unknown = set(m) - {"model", "free"}
            if unknown or "model" not in m or "free" not in m:
                raise BatchError(f"models: {dict(m)!r}: a model is {{'model': SPEC, 'free': KEYS}}")
            spec, free = m["model"], m["free"]
        elif isinstance(m, (tuple, list)) and len(m) == 2:
            spec, free = m
        else:
            raise BatchError(f"models: {m!r}: a model is a (spec, free keys) pair or "
                             "{'model': SPEC, 'free': KEYS}")
        keys = free.split(",") if isinstance(free, str) else list(free)
        keys = [str(k).strip() for k in keys if str(k).strip()]
        if not isinstance(spec, str) or not spec.strip():
            raise BatchError(f"models: {m!r}: the model spec must be a non-empty text")
        if not keys:
            raise BatchError(f"models: {spec}: no free keys; name the parameters to fit")
        spec = spec.strip()
        name, brace, rest = spec.partition("{")
        if name.lower().endswith(".brdf") and os.path.isfile(name):
            # By absolute path, as file targets are: a worker of a cluster has a folder of its own.
            spec = os.path.abspath(name) + brace + rest
        out.append((spec, tuple(keys)))
    if not out:
        raise BatchError("models: none given; give (spec, free keys) pairs")
    return out


def _check_model(spec: str, free: Sequence[str], backend: str, device: Optional[str]) -> None:
    """Refuses a model spec that does not parse and free keys it cannot fit, before any work
    starts: the fit's own checks, on a trivial fit (one bin of a Lambert target, one start,
    one iteration)."""
    try:
        _work.session(backend, device).fit("lambert", spec, list(free), max_bins=1, starts=1,
                                           max_iters=1)
    except (ValueError, TypeError, FileNotFoundError) as e:
        raise BatchError(f"models: {spec} --free {','.join(free)}: {e}") from None


def _backend(backend: str) -> None:
    if backend not in ("gpu", "cpu"):
        raise BatchError(f"backend: {backend!r} is not a backend; give 'gpu' or 'cpu'")


def _positive(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise BatchError(f"{name}: expected a positive integer, got {value!r}")
    return value


def _finish(summary: Summary, started: float, progress: _run.Progress, quiet: bool) -> Summary:
    progress.close()
    summary.seconds = time.perf_counter() - started
    if not quiet:
        for note in summary.notes:
            print(note, file=sys.stderr)
        for what, why in summary.failed:
            print(f"failed: {what}: {why}", file=sys.stderr)
        print(summary, file=sys.stderr)
    return summary


def fit(targets: Union[str, os.PathLike, Sequence[Union[str, os.PathLike]]], models: Sequence[Model],
        out: Union[str, os.PathLike], ray: Optional[str] = None, resume: bool = True, *,
        loss: str = "log", max_bins: int = 65536, starts: int = 4, max_iters: int = 400,
        backend: str = "gpu", device: Optional[str] = None, quiet: bool = False) -> Summary:
    """Fits every model to every target, one CSV row per (target, model) pair in ``out``.

    ``targets``: model specs, MERL ``.binary``, BRDF Explorer ``.brdf`` or lobe table ``.npy``
    files, or folders (each expands to the files in it with those endings, by name).
    ``models``: ``(spec, free)`` pairs or ``{"model": spec, "free": free}`` dicts, ``free`` the
    keys to fit ("alpha,specular" or a list); fixed parameters go in the spec's braces.
    ``loss``, ``max_bins``, ``starts``, ``max_iters``: as ``lobe fit`` (and
    :meth:`lobe.Session.fit`) take them; ``backend``, ``device``: as :class:`lobe.Session`.

    Columns: ``target``, ``model``, ``free``, ``loss`` (the fit's loss), ``params`` (JSON of
    every parameter of the fitted model), ``seconds`` (of the fit), ``worker`` (host:pid) and
    ``options`` (JSON of the options above). ``resume``: keep the rows of an earlier run with the
    same ``out`` and fit only the missing pairs (a CSV made with other options is refused);
    ``resume=False`` sets the old file aside as ``out.~N~`` and starts over. ``ray``: run on the
    Ray cluster at this address ("auto" for the one ``ray start`` left here); without it the
    pairs run in this process, with the same numbers. A pair whose fit fails is reported and
    left out (a rerun tries it again). Returns a :class:`Summary`; prints a progress bar on a
    terminal and the summary on stderr (``quiet`` prints nothing).
    """
    started = time.perf_counter()
    out = os.fspath(out)
    target_list = expand_targets(targets)
    model_list = _models(models)
    if loss not in ("log", "l2"):
        raise BatchError(f"loss: {loss!r} is not a loss; give 'log' or 'l2'")
    _backend(backend)
    options = {"loss": loss, "max_bins": _positive("max_bins", max_bins),
               "starts": _positive("starts", starts), "max_iters": _positive("max_iters", max_iters),
               "backend": backend, "device": device}
    if ray is None:
        try:
            for spec, free in model_list:
                _check_model(spec, free, backend, device)
        except lobe.GpuError as e:
            raise BatchError(f"backend {backend}: {e}") from None
    else:
        # The driver may have no device of its own: the models are checked on the f64 reference.
        # A .brdf shader has no f64 twin; a bad one fails its pairs with the fit's own message.
        for spec, free in model_list:
            if not spec.lower().endswith(".brdf"):
                _check_model(spec, free, "cpu", None)
    with _run.Runner(ray) as runner, \
            Ledger(out, FIT_COLUMNS, ("target", "model", "free"), "fit", options, resume) as ledger:
        pairs = [(t, spec, free) for t in target_list for spec, free in model_list]
        todo = [p for p in pairs if (p[0], p[1], ",".join(p[2])) not in ledger.done]
        summary = Summary(out, len(pairs), len(pairs) - len(todo), 0, notes=list(ledger.notes))
        progress = _run.Progress(len(todo), "pairs")
        workers = set()
        calls = [(t, spec, free, options) for t, spec, free in todo]
        try:
            for i, result in runner.results(_work.fit_one, calls):
                if isinstance(result, BaseException):
                    t, spec, free = todo[i]
                    summary.failed.append((f"{t} x {spec} --free {','.join(free)}", str(result)))
                else:
                    ledger.append(result)
                    summary.done += 1
                    workers.add(result["worker"])
                progress.step(isinstance(result, BaseException))
        finally:
            summary.workers = sorted(workers)
            _finish(summary, started, progress, quiet)
    return summary


def _grid_points(vary: Mapping[str, Sequence[Any]]) -> List[Dict[str, Any]]:
    if not isinstance(vary, Mapping) or not vary:
        raise BatchError("vary: give each swept parameter with its values, e.g. {'alpha': [0.1, 0.5]}")
    keys = list(vary)
    values = []
    for k in keys:
        v = vary[k]
        vs = [v] if isinstance(v, (str, int, float)) else list(v)
        if not vs:
            raise BatchError(f"vary: {k} has no values")
        values.append([tuple(x) if isinstance(x, (list, tuple)) else x for x in vs])
    return [dict(zip(keys, combo)) for combo in itertools.product(*values)]


def sweep(model: str, vary: Mapping[str, Sequence[Any]], out: Union[str, os.PathLike],
          kind: str = "table", ray: Optional[str] = None, resume: bool = True, *,
          params: Optional[Mapping[str, Any]] = None, grid: str = "isotropic",
          res: Optional[Sequence[int]] = None, param: Union[None, str, Sequence[str]] = None,
          range: Optional[Tuple[float, float]] = None, mapping: Optional[str] = None,
          method: str = "peak", samples: Optional[int] = None, white_furnace: bool = False,
          backend: str = "gpu", device: Optional[str] = None, quiet: bool = False) -> Summary:
    """Writes a table or an albedo LUT of ``model`` at every point of the grid ``vary`` (each
    key with its values; the grid is every combination, the first key slowest) into the folder
    ``out``, with ``out/index.csv`` naming each point's file and its values.

    ``kind="table"``: the table set ``out/table-NNNNN.{exr,npy,json}`` as
    :meth:`lobe.Session.write_table` writes it (``grid``, ``res``). ``kind="albedo-lut"``: the
    LUT of :meth:`lobe.Session.albedo_lut` (``param``, ``range``, ``res`` as (Nmu, Np),
    ``mapping``, ``method``, ``samples``) as ``out/albedo-lut-NNNNN.npz`` with its arrays under
    their field names. ``params``: the parameters every point shares. Each file is written whole
    or not at all and its index row after it; ``resume`` and ``ray`` as in :func:`fit` (a rerun
    skips the points whose row and files are there)."""
    started = time.perf_counter()
    out = os.fspath(out)
    if kind not in ("table", "albedo-lut"):
        raise BatchError(f"kind: {kind!r} is not a sweep; give 'table' or 'albedo-lut'")
    if not isinstance(model, str) or not model.strip():
        raise BatchError("model: give the model spec to sweep")
    _backend(backend)
    points = _grid_points(vary)
    shared = dict(params or {})
    clash = sorted(set(shared) & set(vary))
    if clash:
        raise BatchError(f"vary: {', '.join(clash)} is both swept and fixed by params")
    if res is None:
        res = (90, 90, 180) if kind == "table" else (32, 32)
    options: Dict[str, Any] = {
        "kind": kind, "model": model, "params": {k: (list(v) if isinstance(v, tuple) else v)
                                                 for k, v in shared.items()},
        # In the order given (the grid's order, which names the files), not sorted as a dict.
        "vary": [[k, [list(x) if isinstance(x, tuple) else x for x in
                      ([vary[k]] if isinstance(vary[k], (str, int, float)) else vary[k])]] for k in vary],
        "res": [int(r) for r in res], "white_furnace": bool(white_furnace),
        "backend": backend, "device": device}
    if kind == "table":
        options["grid"] = grid
    else:
        options.update(param=param, range=None if range is None else [float(v) for v in range],
                       mapping=mapping, method=method, samples=samples)
    # Each swept value resolved with the shared parameters (no device needed), then the first
    # point, here and now at a small resolution: the model and every option are checked before
    # the batch starts.
    for key, values in options["vary"]:
        for v in values:
            try:
                lobe.parity_tolerance(model, [0.0, 0.0, 1.0], [0.0, 0.0, 1.0],
                                      params=dict(shared, **{key: v}))
            except (ValueError, TypeError) as e:
                raise BatchError(f"vary: {key} = {v!r}: {e}") from None
    check = dict(options, res=[min(r, 4) for r in options["res"]])
    if ray is None or not model.lower().endswith(".brdf"):
        try:
            _work.sweep_one(0, points[0], check if ray is None else dict(check, backend="cpu", device=None))
        except (ValueError, TypeError, FileNotFoundError, lobe.GpuError) as e:
            raise BatchError(f"sweep of {model}: {e}") from None
    if os.path.exists(out) and not os.path.isdir(out):
        raise BatchError(f"{out}: is a file; a sweep writes into a folder")
    index_path = os.path.join(out, "index.csv")
    stem = "table" if kind == "table" else "albedo-lut"
    suffixes = (".exr", ".npy", ".json") if kind == "table" else (".npz",)
    names = [f"{stem}-{k:05d}" for k in builtins.range(len(points))]
    if os.path.isdir(out) and not os.path.exists(index_path):
        theirs = sorted(n for n in os.listdir(out) if n.startswith(("table-", "albedo-lut-")))
        if theirs:
            raise BatchError(f"{out}: holds {theirs[0]} but no index.csv, so its files are not a "
                             "sweep's; give a new or empty folder")
    with _run.Runner(ray) as runner:
        os.makedirs(out, exist_ok=True)
        ledger = Ledger(index_path, SWEEP_COLUMNS, ("file",), "sweep index", options, resume)
        todo = [k for k in builtins.range(len(points))
                if not ((names[k] + suffixes[0],) in ledger.done
                        and all(os.path.isfile(os.path.join(out, names[k] + s)) for s in suffixes))]
        summary = Summary(index_path, len(points), len(points) - len(todo), 0, notes=list(ledger.notes))
        progress = _run.Progress(len(todo), "points")
        workers = set()
        calls = [(k, points[k], options) for k in todo]
        try:
            for i, result in runner.results(_work.sweep_one, calls):
                k = todo[i]
                if isinstance(result, BaseException):
                    summary.failed.append((f"{names[k]} {json.dumps(points[k])}", str(result)))
                else:
                    for suffix, data in result["files"].items():
                        write_atomic(os.path.join(out, names[k] + suffix), data)
                    ledger.append({"file": names[k] + suffixes[0], "params": result["params"],
                                   "seconds": result["seconds"], "worker": result["worker"]})
                    summary.done += 1
                    workers.add(result["worker"])
                progress.step(isinstance(result, BaseException))
        finally:
            ledger.close()
            summary.workers = sorted(workers)
            _finish(summary, started, progress, quiet)
    return summary


def merge(inputs: Sequence[Union[str, os.PathLike]], out: Union[str, os.PathLike]) -> int:
    """Merges fit CSVs (the shards of one batch, e.g. one per Slurm array task) into ``out``:
    every row once, in the order read; a pair in several inputs is kept once, as its first
    input has it. The inputs must have been made with the same options. ``out`` is written
    whole or not at all, and replaces only a fit CSV. Returns the number of rows written."""
    paths = [os.fspath(p) for p in inputs]
    out = os.fspath(out)
    if not paths:
        raise BatchError("merge: give the fit CSVs to merge")
    if os.path.exists(out):
        read_rows(out, FIT_COLUMNS, "fit")  # refuses to replace a file that is not a batch's
    rows: Dict[Tuple[str, str, str], Dict[str, str]] = {}
    options = None
    for path in paths:
        for row in read_rows(path, FIT_COLUMNS, "fit")[0]:
            if options is None:
                options, first = row["options"], path
            elif row["options"] != options:
                raise BatchError(f"merge: {path} was made with the options {row['options']}, "
                                 f"{first} with {options}; only shards of one batch merge")
            rows.setdefault((row["target"], row["model"], row["free"]), row)
    text = csv_line(FIT_COLUMNS) + "".join(csv_line([r[c] for c in FIT_COLUMNS]) for r in rows.values())
    write_atomic(out, text.encode("utf-8"))
    return len(rows)


def report(inputs: Union[str, os.PathLike, Sequence[Union[str, os.PathLike]]],
           out: Optional[Union[str, os.PathLike]] = None) -> str:
    """The materials-against-models table of fit CSVs: the loss of each (target, model) pair,
    the best model per target marked with ``*``, as text (returned). ``out``: also draw it as a
    heat map (``.svg`` or ``.png``)."""
    from . import _report

    paths = [os.fspath(inputs)] if isinstance(inputs, (str, os.PathLike)) else [os.fspath(p) for p in inputs]
    rows = [r for p in paths for r in read_rows(p, FIT_COLUMNS, "fit")[0]]
    table = _report.Matrix.of(rows)
    if out is not None:
        _report.draw(table, os.fspath(out))
    return table.text()

