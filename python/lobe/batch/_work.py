"""One piece of a batch, as a worker runs it (in this process, or in a Ray worker): each
process keeps one :class:`lobe.Session` per backend for all its pieces, so a device is opened
and pipelines are built once per process."""

from __future__ import annotations

import io
import json
import os
import socket
import tempfile
import threading
import time
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple

import numpy as np

import lobe

_sessions: Dict[Tuple[str, Optional[str]], lobe.Session] = {}
_lock = threading.Lock()


def session(backend: str, device: Optional[str]) -> lobe.Session:
    """This process's session for ``backend`` and ``device``, opened on first use."""
    with _lock:
        key = (backend, device)
        if key not in _sessions:
            _sessions[key] = lobe.Session(backend=backend, device=device)
        return _sessions[key]


def worker() -> str:
    """host:pid of this process."""
    return f"{socket.gethostname()}:{os.getpid()}"


def fit_one(target: str, model: str, free: Sequence[str], options: Mapping[str, Any]) -> Dict[str, Any]:
    """Fits ``model``'s ``free`` keys to ``target``; returns the row of the fit CSV (less its
    options): the loss as Python's shortest round-trip text, the fitted parameters as JSON."""
    s = session(options["backend"], options["device"])
    started = time.perf_counter()
    result = s.fit(target, model, list(free), loss=options["loss"], max_bins=options["max_bins"],
                   starts=options["starts"], max_iters=options["max_iters"])
    seconds = time.perf_counter() - started
    return {
        "target": target,
        "model": model,
        "free": ",".join(free),
        "loss": repr(float(result.loss)),
        "params": json.dumps(result.params, sort_keys=True, separators=(",", ":")),
        "seconds": f"{seconds:.3f}",
        "worker": worker(),
    }


def sweep_one(index: int, point: Mapping[str, Any], options: Mapping[str, Any]) -> Dict[str, Any]:
    """Computes one grid point of a sweep; returns its files (name suffix to bytes) and the row
    of the index (less its file and options). The files are made here and carried back, so that
    the process that owns the output folder writes them, wherever this one runs."""
    s = session(options["backend"], options["device"])
    params = dict(options["params"], **point)
    started = time.perf_counter()
    files: Dict[str, bytes] = {}
    if options["kind"] == "table":
        with tempfile.TemporaryDirectory() as folder:
            stem = os.path.join(folder, "t")
            s.write_table(stem + ".exr", options["model"], grid=options["grid"], res=options["res"],
                          params=params, white_furnace=options["white_furnace"])
            for suffix in (".exr", ".npy", ".json"):
                with open(stem + suffix, "rb") as f:
                    files[suffix] = f.read()
    else:
        lut = s.albedo_lut(options["model"], params=params, white_furnace=options["white_furnace"],
                           param=options["param"], range=options["range"], res=options["res"],
                           mapping=options["mapping"], method=options["method"],
                           samples=options["samples"])
        data = io.BytesIO()
        np.savez(data, e=lut.e, e_avg=lut.e_avg, mu=lut.mu, p=lut.p, e_error=lut.e_error,
                 e_avg_error=lut.e_avg_error, max_error=np.float64(lut.max_error),
                 keys=np.array(lut.keys), mapping=np.array(lut.mapping),
                 point=np.array(json.dumps(point, sort_keys=True)))
        files[".npz"] = data.getvalue()
    seconds = time.perf_counter() - started
    return {
        "index": index,
        "files": files,
        "params": json.dumps(point, sort_keys=True, separators=(",", ":")),
        "seconds": f"{seconds:.3f}",
        "worker": worker(),
    }
