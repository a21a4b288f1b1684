"""A batch's CSV: its header names the kind of batch, every row is one finished piece of work,
appended as one write and synced to disk, so that a batch killed at any moment leaves whole
rows (and at most a torn last line, which the next run cuts off) and can be resumed."""

from __future__ import annotations

import csv
import io
import json
import os
from typing import Any, Dict, List, Mapping, Sequence, Tuple

#: The columns of a fit batch's CSV, in order.
FIT_COLUMNS = ("target", "model", "free", "loss", "params", "seconds", "worker", "options")
#: The columns of a sweep's index CSV, in order.
SWEEP_COLUMNS = ("file", "params", "seconds", "worker", "options")


class BatchError(ValueError):
    """A batch refused: bad input, a file that is not a batch's, or a cluster that does not
    answer. The message names the input and what is valid."""


def csv_line(fields: Sequence[str]) -> str:
    text = io.StringIO()
    csv.writer(text, lineterminator="\n").writerow(fields)
    return text.getvalue()


def _canonical(options: Mapping[str, Any]) -> str:
    return json.dumps(options, sort_keys=True, separators=(",", ":"))


def read_rows(path: str, columns: Sequence[str], what: str) -> Tuple[List[Dict[str, str]], int]:
    """The rows of the batch CSV ``path`` as dicts, and the byte length of its whole lines (a
    torn last line, left by a kill in the middle of a write, is not counted). Refuses a file
    whose header is not ``columns`` or with a row of another length."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise BatchError(f"{path}: cannot read it: {e.strerror}") from None
    whole = data.rfind(b"\n") + 1
    try:
        text = data[:whole].decode("utf-8")
    except UnicodeDecodeError:
        raise BatchError(f"{path}: not a lobe.batch {what} CSV (it is not UTF-8 text)") from None
    lines = text.splitlines(keepends=True)
    header = csv_line(columns)
    if not lines or lines[0] != header:
        first = lines[0].rstrip("\n") if lines else data[:80].decode("utf-8", "replace")
        raise BatchError(
            f"{path}: not a lobe.batch {what} CSV: its first line is {first[:120]!r}, and a "
            f"{what} CSV starts with {header.rstrip()!r}; give another --out (an existing file "
            "that is not a batch's is never overwritten)")
    rows = []
    for number, row in enumerate(csv.reader(lines[1:]), start=2):
        if len(row) != len(columns):
            raise BatchError(f"{path}: line {number} has {len(row)} fields, a {what} row has "
                             f"{len(columns)} ({','.join(columns)}); the file is damaged")
        rows.append(dict(zip(columns, row)))
    return rows, whole


class Ledger:
    """The open CSV of one batch. ``done`` holds the keys of the rows already there (resumed);
    :meth:`append` adds a row durably."""

    def __init__(self, path: str, columns: Sequence[str], key: Sequence[str], what: str,
                 options: Mapping[str, Any], resume: bool) -> None:
        self.path = path
        self.columns = tuple(columns)
        self.key = tuple(key)
        self.options = _canonical(options)
        self.done: Dict[Tuple[str, ...], Dict[str, str]] = {}
        self.notes: List[str] = []
        exists = os.path.exists(path)
        if exists and os.path.isdir(path):
            raise BatchError(f"{path}: is a folder; --out names the CSV file to write")
        if exists and os.path.getsize(path) > 0:
            rows, whole = read_rows(path, columns, what)
            if not resume:
                self.notes.append(f"--no-resume: the old {path} was kept as {self._set_aside()}")
            else:
                for row in rows:
                    if row["options"] != self.options:
                        raise BatchError(
                            f"{path}: its rows were made with the options {row['options']}, and "
                            f"this batch asks for {self.options}; give the same options, another "
                            "--out, or --no-resume (which keeps the old file beside it)")
                    self.done[self._key(row)] = row
                if whole < os.path.getsize(path):
                    # A write cut short by a kill: the pair it was recording is done again.
                    with open(path, "r+b") as f:
                        f.truncate(whole)
                        os.fsync(f.fileno())
                    self.notes.append(f"{path}: cut off a torn last line (its work is done again)")
        folder = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(folder):
            raise BatchError(f"{path}: the folder {folder} does not exist")
        fresh = not os.path.exists(path) or os.path.getsize(path) == 0
        try:
            self._file = open(path, "a", encoding="utf-8", newline="")
        except OSError as e:
            raise BatchError(f"{path}: cannot write it: {e.strerror}") from None
        if fresh:
            self._write(csv_line(self.columns))
            _sync_folder(folder)

    def _set_aside(self) -> str:
        k = 1
        while os.path.exists(f"{self.path}.~{k}~"):
            k += 1
        aside = f"{self.path}.~{k}~"
        os.rename(self.path, aside)
        return aside

    def _key(self, row: Mapping[str, str]) -> Tuple[str, ...]:
        return tuple(row[k] for k in self.key)

    def _write(self, text: str) -> None:
        self._file.write(text)
        self._file.flush()
        os.fsync(self._file.fileno())

    def append(self, row: Mapping[str, Any]) -> None:
        """Writes ``row`` (every column but ``options``, which the ledger adds) as one line,
        flushed and synced before it returns."""
        full = dict(row, options=self.options)
        self._write(csv_line([str(full[c]) for c in self.columns]))
        self.done[self._key({k: str(v) for k, v in full.items()})] = {k: str(v) for k, v in full.items()}

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> "Ledger":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _sync_folder(folder: str) -> None:
    """Makes a new or renamed file's name durable (where the platform lets a folder be synced)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_atomic(path: str, data: bytes) -> None:
    """Writes ``data`` to ``path`` whole or not at all: a temporary file beside it, synced, then
    renamed over it."""
    folder = os.path.dirname(os.path.abspath(path))
    temp = os.path.join(folder, f".{os.path.basename(path)}.{os.getpid()}.tmp")
    try:
        with open(temp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(temp, path)
    except BaseException:
        if os.path.exists(temp):
            os.unlink(temp)
        raise
    _sync_folder(folder)

