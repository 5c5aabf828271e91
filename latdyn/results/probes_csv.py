"""``probes.csv``, the table of probe values a run records (SCENE.md, "Commands and results").

Header ``t,<probe names in file order>`` (``load_factor,...`` for static runs), then one row per
record. Values are written with ``repr(float)`` (:func:`latdyn.results.files.format_float`), which
round-trips float64 exactly. Rows are written in blocks (:data:`CSV_BLOCK_ROWS`,
:data:`CSV_BLOCK_SECONDS`, and whenever the writer flushes); each block is formatted completely in
memory and handed to the kernel with a single ``os.write`` on an ``O_APPEND`` descriptor (no
user-space buffer), so a crash, a Ctrl-C or a SIGKILL leaves only complete rows
(:meth:`latdyn.results.result.Result.load` also skips a malformed trailing line should a full disk
ever cut one short). A resumed run cuts the file back to the rows its bookmark recorded and
appends to it.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from latdyn.errors import ResultsError
from latdyn.results.files import csv_line, format_float

__all__ = ["CSV_BLOCK_ROWS", "CSV_BLOCK_SECONDS", "PROBES_FILE", "ProbesCsv"]

PROBES_FILE = "probes.csv"

#: probes.csv is written in blocks: the rows recorded since the last write go to the file when
#: this many have gathered, when CSV_BLOCK_SECONDS have passed, and at every flush (the writer
#: flushes at its checkpoints and at close: after an interrupt or a failure the file is complete up
#: to the last recorded row)
CSV_BLOCK_ROWS = 512
CSV_BLOCK_SECONDS = 1.0


class ProbesCsv:
    """The probe rows of a run: all of them in memory (:attr:`times`, :attr:`rows`) and, with a
    ``folder``, in its ``probes.csv`` once :meth:`create` or :meth:`reopen` has opened the file."""

    def __init__(self, folder: Path | None, first_column: str, columns: list[str]):
        self.path = None if folder is None else folder / PROBES_FILE
        self.first_column = first_column
        self.columns = columns
        #: the first column of every row (time or load factor) and its probe values in column order
        self.times: list[float] = []
        self.rows: list[list[float]] = []
        self._unwritten: list[str] = []  # formatted rows not yet in the file
        self._written_at = time.perf_counter()
        self._fd: int | None = None

    def _header(self) -> str:
        return csv_line([self.first_column, *self.columns])

    def create(self) -> None:
        """Open the file, a former one emptied, and write the header."""
        self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND, 0o644)
        self._write(self._header())

    def reopen(self, rows: int) -> None:
        """Resume: keep the header and the first ``rows`` rows of the file, taken back into memory,
        drop a later or cut-off row, and open the file to append."""
        path = self.path
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise ResultsError(f"{path}: cannot resume ({exc})") from exc
        lines = data.split(b"\n")
        header = self._header().encode("utf-8")
        if not data.startswith(header):
            raise ResultsError(f"{path}: cannot resume: its header is not {header.decode().strip()!r}")
        if len(lines) - 2 < rows:  # complete rows: the last piece is empty or a cut-off row
            raise ResultsError(f"{path}: cannot resume: it has fewer than the {rows} rows the checkpoint recorded")
        keep = sum(len(line) + 1 for line in lines[: rows + 1])
        for line in lines[1: rows + 1]:
            values = [float(x) for x in line.decode("utf-8").split(",")]
            self.times.append(values[0])
            self.rows.append(values[1:])
        os.truncate(path, keep)
        self._fd = os.open(path, os.O_WRONLY | os.O_APPEND)

    def add(self, t: float, values) -> None:
        """One row: ``values`` in column order, or a dict probe name -> value."""
        if isinstance(values, dict):
            missing = [c for c in self.columns if c not in values]
            if missing:
                raise ValueError(f"values lack probes {missing}")
            row = [float(values[c]) for c in self.columns]
        else:
            row = [float(v) for v in np.ravel(np.asarray(values, dtype=float))]
            if len(row) != len(self.columns):
                raise ValueError(f"record() got {len(row)} values for {len(self.columns)} probes")
        self._append(t, row)

    def add_rows(self, times, values: np.ndarray) -> None:
        """Rows at ``times`` (k,), ``values`` (k, probes) in column order: as :meth:`add` of each."""
        values = np.asarray(values, dtype=float)
        if values.shape != (len(times), len(self.columns)):
            raise ValueError(f"record_rows() got values of shape {values.shape} for {len(times)} rows of "
                             f"{len(self.columns)} probes")
        for t, row in zip(times, values.tolist()):
            self._append(float(t), row)

    def _append(self, t: float, row: list[float]) -> None:
        if self._fd is not None:  # floats need no CSV quoting
            self._unwritten.append(",".join(map(format_float, (t, *row))) + "\n")
            if len(self._unwritten) >= CSV_BLOCK_ROWS \
                    or time.perf_counter() - self._written_at >= CSV_BLOCK_SECONDS:
                self.flush()
        self.times.append(t)
        self.rows.append(row)

    def flush(self) -> None:
        """The rows added since the last write, to the file in one write."""
        if self._unwritten and self._fd is not None:
            self._write("".join(self._unwritten))
        self._unwritten.clear()
        self._written_at = time.perf_counter()

    def close(self) -> None:
        """Release the file; rows not flushed before are not written."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def table(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The rows as arrays: the first column ``(n_rows,)`` and probe name -> values ``(n_rows,)``."""
        table = np.array(self.rows, dtype=float).reshape(len(self.rows), len(self.columns))
        return np.array(self.times, dtype=float), {name: table[:, j].copy() for j, name in enumerate(self.columns)}

    def _write(self, text: str) -> None:
        data = text.encode("utf-8")
        written = os.write(self._fd, data)
        while written < len(data):  # short writes are rare on regular files
            written += os.write(self._fd, data[written:])

    def __del__(self):  # dropped without close(): at least release the descriptor
        fd = getattr(self, "_fd", None)
        if fd is not None:
            try:
                os.close(fd)
            except OSError:
                pass
