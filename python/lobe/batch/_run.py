"""Where a batch's pieces run: in this process one after another, or as Ray tasks on a cluster
(Ray schedules them, retries the ones whose worker died and places them); either way the
results come back here, one at a time, as they finish."""

from __future__ import annotations

import logging
import socket
import sys
import time
from typing import Any, Callable, Iterator, List, Optional, Sequence, TextIO, Tuple

from ._ledger import BatchError

#: What ``--ray`` says when Ray is not installed.
RAY_HINT = ("Ray is not installed in this Python; install it with pip install 'lobe[ray]' "
            "(from lobe's source folder: pip install '.[ray]'), or run without --ray")

#: How long a cluster address gets to answer before the batch gives up on it: a head node
#: on a network answers a TCP connection in milliseconds; ten seconds allows a slow link.
CONNECT_WAIT_S = 10.0

#: Ray's default port for a head node (``ray start --head``).
RAY_DEFAULT_PORT = 6379

#: How often Ray runs a task again after its worker process died (Ray's own retries).
TASK_RETRIES = 3


def _host_port(address: str) -> Tuple[str, int]:
    rest = address.split("://", 1)[1] if "://" in address else address
    host, _, port = rest.rpartition(":") if ":" in rest else (rest, "", "")
    if not port:
        return rest, RAY_DEFAULT_PORT
    try:
        return host, int(port)
    except ValueError:
        raise BatchError(f"--ray {address}: not an address; give auto or HOST:PORT "
                         f"(the head node's, port {RAY_DEFAULT_PORT} by default)") from None


def _answers(address: str, wait_s: float) -> None:
    host, port = _host_port(address)
    try:
        with socket.create_connection((host, port), timeout=wait_s):
            pass
    except OSError as e:
        why = "no answer" if isinstance(e, socket.timeout) else (e.strerror or str(e))
        raise BatchError(
            f"--ray {address}: no Ray cluster answers at {host}:{port} ({why}, waited at most "
            f"{wait_s:g} s); start one (ray start --head) or give its head node's HOST:PORT, "
            "or run without --ray") from None


def connect(address: str, wait_s: float = CONNECT_WAIT_S) -> Any:
    """Ray, connected to the cluster at ``address`` ("auto": the one ``ray start`` left on this
    machine)."""
    try:
        import ray
    except ImportError:
        raise BatchError(f"--ray {address}: {RAY_HINT}") from None
    if address != "auto":
        _answers(address, wait_s)
    if ray.is_initialized():
        ray.shutdown()
    try:
        ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
    except (ConnectionError, RuntimeError, ValueError) as e:
        raise BatchError(f"--ray {address}: cannot join the cluster: {e}") from None
    return ray


def local(fn: Callable[..., Any], calls: Sequence[Tuple[Any, ...]]) -> Iterator[Tuple[int, Any]]:
    """Each call of ``fn`` in this process, in order: (index, result or the exception)."""
    for i, args in enumerate(calls):
        try:
            yield i, fn(*args)
        except Exception as e:  # noqa: BLE001 - a failed piece is reported, the batch goes on
            yield i, e


class Runner:
    """Where the pieces run: this process (``ray=None``), or the Ray cluster at ``ray``, joined
    when the runner is made (so a cluster that does not answer stops the batch before it
    writes anything) and left by :meth:`close`."""

    def __init__(self, ray: Optional[str]) -> None:
        self.address = ray
        self.ray = None if ray is None else connect(ray)

    def results(self, fn: Callable[..., Any],
                calls: Sequence[Tuple[Any, ...]]) -> Iterator[Tuple[int, Any]]:
        """Each call of ``fn``, as it finishes: (its index in ``calls``, its result or the
        exception it raised)."""
        if self.ray is None:
            return local(fn, calls)
        return self._on_ray(fn, calls) if calls else iter(())

    def _on_ray(self, fn: Callable[..., Any],
                calls: Sequence[Tuple[Any, ...]]) -> Iterator[Tuple[int, Any]]:
        # A task asks for one CPU, and one GPU where the cluster has any (its worker then has a
        # device of its own); Ray runs it again when its worker dies.
        ray = self.ray
        gpus = ray.cluster_resources().get("GPU", 0) > 0
        remote = ray.remote(fn).options(num_cpus=1, num_gpus=1 if gpus else 0,
                                        max_retries=TASK_RETRIES, retry_exceptions=False)
        index = {remote.remote(*args): i for i, args in enumerate(calls)}
        pending: List[Any] = list(index)
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            for ref in ready:
                try:
                    yield index[ref], ray.get(ref)
                except ray.exceptions.RayTaskError as e:
                    cause = getattr(e, "cause", None)
                    yield index[ref], cause if isinstance(cause, Exception) else e
                except ray.exceptions.RayError as e:
                    yield index[ref], e

    def close(self) -> None:
        if self.ray is not None:
            self.ray.shutdown()
            self.ray = None

    def __enter__(self) -> "Runner":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class Progress:
    """A one-line progress bar on stderr when stderr is a terminal; nothing otherwise."""

    WIDTH = 30

    def __init__(self, total: int, what: str, stream: Optional[TextIO] = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.on = total > 0 and hasattr(self.stream, "isatty") and self.stream.isatty()
        self.total, self.what = total, what
        self.done = self.failed = 0
        self.started = time.perf_counter()
        self._draw()

    def step(self, failed: bool = False) -> None:
        self.done += 1
        self.failed += failed
        self._draw()

    def _draw(self) -> None:
        if not self.on:
            return
        filled = self.WIDTH * self.done // self.total
        elapsed = time.perf_counter() - self.started
        eta = elapsed / self.done * (self.total - self.done) if self.done else float("nan")
        failed = f", {self.failed} failed" if self.failed else ""
        self.stream.write(f"\r[{'#' * filled}{'.' * (self.WIDTH - filled)}] {self.done}/{self.total} "
                          f"{self.what}{failed}, {elapsed:.0f} s, about {eta:.0f} s left  ")
        self.stream.flush()

    def close(self) -> None:
        if self.on:
            self.stream.write("\n")
            self.stream.flush()
