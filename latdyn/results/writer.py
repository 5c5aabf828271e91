"""Result files of a run (SCENE.md, "Commands and results") and the in-memory result.

One :class:`ResultWriter` per run writes, into ``out_dir``:

``probes.csv``
    Header ``t,<probe names in file order>`` (``load_factor,...`` for static runs),
    one row per :meth:`ResultWriter.record`. Each row is formatted completely in
    memory and handed to the kernel with a single ``os.write`` on an ``O_APPEND``
    descriptor (no user-space buffer), so a crash, a Ctrl-C or a SIGKILL leaves only
    complete rows; :meth:`Result.load` also skips a malformed trailing line should a
    full disk ever cut one short. Values are written with ``repr(float)``, which
    round-trips float64 exactly.

``state.h5`` (or ``state.npz`` when h5py is missing)
    The full state history: dataset ``t`` ``(n_rows,)`` and one dataset per state key
    ``(n_rows, width)``, with attributes ``first_column`` and ``meta`` (JSON).
    *Labels:* the writer's ``attributes`` become file attributes (a run stores
    ``nodes``, the model node names such as ``"hub"``, ``"arm.node[3]"``, ``"arm.end"``;
    ``hinges``, ``"BEAM.start"``/``"BEAM.end"``; ``coordinates``, the free coordinates at
    t = 0 in solver order, ``"arm.node[3]:dx"`` …), and each dataset with ``labels``
    has an attribute ``columns`` naming every column and a ``description``. For a run
    (see :func:`state_labels`) the layout is node-major: node ``i`` (``nodes[i]``) owns
    columns ``3i … 3i+2`` of ``x`` (reference point, global), ``v`` (its velocity) and
    ``w`` (spatial angular velocity), labelled ``"arm.node[3]:x"`` … ``":z"``, and
    columns ``9i … 9i+8`` of ``T`` (rotation node axes → global, row-major,
    ``":T[0,0]"`` … ``":T[2,2]"``); hinge ``k`` (``hinges[k]``) owns column ``k`` of
    ``theta`` and ``theta_dot`` (labelled ``"arm.start"``). Datasets of empty arrays
    (no hinges) are absent. :func:`load_state_labels` reads the labels back.
    *Crash safety, the choice made:* the file on disk is always a complete, closed
    HDF5 file. New rows are held in memory and appended at a checkpoint by copying
    the current file to ``state.h5.tmp``, appending to the copy (datasets are
    resizable and chunked), closing it, fsync-ing it and ``os.replace``-ing it over
    ``state.h5``. A SIGKILL therefore loses at most the rows since the last
    checkpoint and never leaves a half-written file (an HDF5 file kept open and
    flushed can be left unreadable by a kill during a metadata update). Checkpoints
    happen every ``checkpoint_rows`` rows or ``checkpoint_seconds`` seconds,
    whichever comes first, but never more often than keeps checkpoint time below
    about 10 % of the run's wall time, and at :meth:`close`. The NPZ fallback keeps
    the whole history in memory and rewrites ``state.npz`` the same way (temp +
    ``os.replace``); its labels are one JSON string under the key ``_labels``.

``paraview/beams.vtkhdf``, ``paraview/bodies.vtkhdf``
    One transient VTKHDF file per part of ``mesh`` (``beams``, and ``bodies`` for a run with
    joint bodies), frames appended in blocks (and at checkpoints and close), at ``paraview_every``;
    what the parts hold and the file layout: :mod:`latdyn.results.paraview`. Open them in ParaView
    (>= 5.12) or read them with VTK's ``vtkHDFReader``.

``modes.csv``
    ``mode,frequency_hz``, modes numbered from 1 (:meth:`ResultWriter.write_modes`).

``summary.json``
    Written atomically at the start with ``"status": "running"`` (so a killed run is
    recognisable) and again by :meth:`ResultWriter.close` with the final status
    ``solved``, ``failed`` or ``interrupted``. Keys always present: ``latdyn_version``,
    ``scene_hash``, ``wall_time_s``, ``steps``, ``newton_iterations``,
    ``rejected_steps``, ``energy_balance_error`` (``null`` when the caller did not
    give one), ``status``, ``rows``, ``first_column``, ``probes``, plus the writer's
    ``meta`` and whatever the caller passes. Non-finite floats are written as ``null``
    (strict JSON).

Files of an earlier run with these names are removed when a writer starts, so the
folder never mixes two runs, unless it *resumes* (``resume=`` a
:meth:`ResultWriter.bookmark` of the earlier writer, kept in a run's checkpoint, see
:mod:`latdyn.timeloop.checkpoint`): then the files are cut back to the bookmark (``probes.csv`` to
its rows, the state history to its rows, atomically; ParaView frames it does not list are
cut back to its frames) and appended to. Every later decision of the writer (which frames)
depends only on the counts in the bookmark, so
the finished files equal those of one uninterrupted writer. (The state-history
"checkpoints" above are the writer's own flushes, unrelated to a run's checkpoint file.) With ``out_dir=None`` nothing is written; the writer
only keeps the probe rows for :meth:`ResultWriter.result`.
"""
from __future__ import annotations

import csv
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from latdyn.errors import ResultsError
from latdyn.results.files import atomic_write_bytes, csv_line, format_float, json_safe
from latdyn.results.state_history import (
    LABELS_KEY,
    STATE_H5_FILE,
    STATE_NPZ_FILE,
    StateHistory,
)

try:  # optional: the NPZ fallback is used without it
    import h5py
except ImportError:  # pragma: no cover - exercised by monkeypatching in the tests
    h5py = None

__all__ = [
    "Result",
    "ResultWriter",
    "ResultsError",
    "load_state_history",
    "load_state_labels",
    "state_labels",
    "progress_bar",
    "PROBES_FILE",
    "MODES_FILE",
    "SUMMARY_FILE",
    "STATE_H5_FILE",
    "STATE_NPZ_FILE",
    "PARAVIEW_DIR",
]

PROBES_FILE = "probes.csv"
MODES_FILE = "modes.csv"
SUMMARY_FILE = "summary.json"
PARAVIEW_DIR = "paraview"  # latdyn.results.paraview.PARAVIEW_DIR


#: keys that summary.json always has (SCENE.md); the caller fills the values
SUMMARY_KEYS = (
    "latdyn_version",
    "scene_hash",
    "wall_time_s",
    "steps",
    "newton_iterations",
    "rejected_steps",
    "energy_balance_error",
)
STATUSES = ("running", "solved", "failed", "interrupted")

#: probes.csv is written in blocks: the rows recorded since the last write go to the file when
#: this many have gathered, when CSV_BLOCK_SECONDS have passed, and at every checkpoint and at
#: close (an interrupt, a failure: the file is complete up to the last recorded row)
CSV_BLOCK_ROWS = 512
CSV_BLOCK_SECONDS = 1.0


# ----------------------------------------------------------------------------- Result
class Result:
    """What a run recorded: plain attributes, picklable.

    Attributes
    ----------
    t : np.ndarray, shape (n_rows,)
        Recorded times; for static runs the load factors (``first_column`` says which).
    probes : dict[str, np.ndarray]
        Probe name -> values, shape (n_rows,), in file order.
    summary : dict
        Contents of ``summary.json`` (``{"status": "running"}`` before the writer closed).
    out_dir : str or None
        The results folder, None for a run that wrote no files.
    modes : np.ndarray or None
        Natural frequencies in Hz for modal runs.
    first_column : str
        ``"t"`` or ``"load_factor"``.
    """

    def __init__(self, t, probes, summary=None, out_dir=None, modes=None, first_column="t"):
        self.t = np.asarray(t, dtype=float)
        self.probes = {str(k): np.asarray(v, dtype=float) for k, v in probes.items()}
        self.summary = dict(summary or {})
        self.out_dir = None if out_dir is None else str(out_dir)
        self.modes = None if modes is None else np.asarray(modes, dtype=float)
        self.first_column = first_column

    @property
    def load_factor(self) -> np.ndarray:
        """Alias of :attr:`t`, the natural name for static runs."""
        return self.t

    @property
    def status(self):
        return self.summary.get("status")

    def __getitem__(self, name: str) -> np.ndarray:
        return self.probes[name]

    def __repr__(self) -> str:
        return (
            f"Result({self.first_column}: {len(self.t)} rows, probes={list(self.probes)}, "
            f"status={self.status!r}, out_dir={self.out_dir!r})"
        )

    def state_history(self) -> dict:
        """The state history from ``out_dir`` (see :func:`load_state_history`)."""
        if self.out_dir is None:
            raise ResultsError("this result was not written to a folder; it has no state history")
        return load_state_history(self.out_dir)

    def state_labels(self) -> dict:
        """The labels of the state history (see :func:`load_state_labels`)."""
        if self.out_dir is None:
            raise ResultsError("this result was not written to a folder; it has no state history")
        return load_state_labels(self.out_dir)

    @classmethod
    def load(cls, out_dir) -> "Result":
        """Read ``probes.csv`` and, where present, ``summary.json`` and ``modes.csv``.

        A folder with only ``modes.csv`` (a modal run without probes) is accepted.
        Raises :class:`ResultsError` naming the path when the folder or its files are
        missing or malformed.
        """
        folder = Path(out_dir)
        if not folder.is_dir():
            raise ResultsError(f"{folder}: no such results folder")
        probes_path = folder / PROBES_FILE
        modes_path = folder / MODES_FILE
        summary_path = folder / SUMMARY_FILE
        if not probes_path.is_file() and not modes_path.is_file():
            raise ResultsError(f"{folder}: not a latdyn results folder (no {PROBES_FILE} or {MODES_FILE})")

        first_column, t, probes = "t", np.zeros(0), {}
        if probes_path.is_file():
            first_column, t, probes = _read_probes(probes_path)

        modes = None
        if modes_path.is_file():
            modes = _read_modes(modes_path)

        summary = {}
        if summary_path.is_file():
            try:
                summary = json.loads(summary_path.read_text(encoding="utf-8"))
            except (OSError, ValueError) as exc:
                raise ResultsError(f"{summary_path}: unreadable summary ({exc})") from exc
        return cls(t, probes, summary=summary, out_dir=str(folder), modes=modes, first_column=first_column)


def _read_probes(path: Path):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except OSError as exc:
        raise ResultsError(f"{path}: cannot read ({exc})") from exc
    if not rows or not rows[0]:
        raise ResultsError(f"{path}: empty file, expected a header 't,<probe names>'")
    header = rows[0]
    first_column = header[0]
    if first_column not in ("t", "load_factor"):
        raise ResultsError(f"{path}: first column is {first_column!r}, expected 't' or 'load_factor'")
    data = []
    for number, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            if number == len(rows):  # a cut-off last line: ignore it
                continue
            raise ResultsError(f"{path}: line {number} has {len(row)} fields, expected {len(header)}")
        try:
            data.append([float(x) for x in row])
        except ValueError as exc:
            if number == len(rows):
                continue
            raise ResultsError(f"{path}: line {number}: {exc}") from exc
    table = np.array(data, dtype=float).reshape(len(data), len(header))
    probes = {name: table[:, j + 1].copy() for j, name in enumerate(header[1:])}
    return first_column, table[:, 0].copy(), probes


def _read_modes(path: Path) -> np.ndarray:
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        if not rows or rows[0][:2] != ["mode", "frequency_hz"]:
            raise ResultsError(f"{path}: expected a header 'mode,frequency_hz'")
        return np.array([float(r[1]) for r in rows[1:] if len(r) >= 2], dtype=float)
    except (OSError, ValueError, IndexError) as exc:
        if isinstance(exc, ResultsError):
            raise
        raise ResultsError(f"{path}: cannot read ({exc})") from exc


def _state_paths(folder: Path) -> tuple[Path, Path]:
    """The HDF5 and NPZ state-history paths of a results folder; refuses an HDF5 file without h5py."""
    h5_path, npz_path = folder / STATE_H5_FILE, folder / STATE_NPZ_FILE
    if h5_path.is_file() and h5py is None:
        raise ResultsError(f"{h5_path}: h5py is needed to read this file")
    return h5_path, npz_path


def load_state_history(out_dir) -> dict:
    """Read the state history of a results folder.

    Returns ``{"t": (n_rows,), key: (n_rows, width), ...}`` from ``state.h5`` or,
    failing that, ``state.npz``. Raises :class:`ResultsError` when neither exists.
    """
    folder = Path(out_dir)
    h5_path, npz_path = _state_paths(folder)
    if h5_path.is_file():
        with h5py.File(h5_path, "r") as f:
            return {name: f[name][()] for name in f.keys()}
    if npz_path.is_file():
        with np.load(npz_path) as f:
            return {name: f[name] for name in f.files if name != LABELS_KEY}
    raise ResultsError(f"{folder}: no state history ({STATE_H5_FILE} or {STATE_NPZ_FILE})")


def state_labels(nodes, hinges) -> dict:
    """Column labels of the state history of a run, for ``ResultWriter(labels=...)``.

    ``nodes``: node names in model order; ``hinges``: hinge names (``"BEAM.start"``).
    Returns ``{"x": ["NODE:x", "NODE:y", "NODE:z", ...], "v": ..., "w": ...,
    "T": ["NODE:T[0,0]", ..., "NODE:T[2,2]", ...], "theta": hinges, "theta_dot": hinges}``
    (the layout of ``State.as_dict``: node-major, T row-major).
    """
    nodes, hinges = [str(n) for n in nodes], [str(h) for h in hinges]
    vector = [f"{n}:{c}" for n in nodes for c in "xyz"]
    matrix = [f"{n}:T[{i},{j}]" for n in nodes for i in range(3) for j in range(3)]
    return {"x": vector, "T": matrix, "v": list(vector), "w": list(vector),
            "theta": hinges, "theta_dot": list(hinges)}


def load_state_labels(out_dir) -> dict:
    """The labels of a state history: ``{"columns": {key: [label per column]}, name:
    [...] for each file attribute given as ``attributes`` (``nodes``, ``hinges``,
    ``coordinates`` for a run)}``; ``{"columns": {}}`` for a file without labels."""
    folder = Path(out_dir)
    h5_path, npz_path = _state_paths(folder)
    if h5_path.is_file():
        with h5py.File(h5_path, "r") as f:
            out = {str(k): [str(x) for x in np.atleast_1d(v)] for k, v in f.attrs.items()
                   if k not in ("first_column", "meta")}
            out["columns"] = {name: [str(x) for x in f[name].attrs["columns"]]
                              for name in f.keys() if "columns" in f[name].attrs}
            return out
    if npz_path.is_file():
        with np.load(npz_path) as f:
            if LABELS_KEY in f.files:
                return json.loads(str(f[LABELS_KEY]))
            return {"columns": {}}
    raise ResultsError(f"{folder}: no state history ({STATE_H5_FILE} or {STATE_NPZ_FILE})")


# ----------------------------------------------------------------------------- writer
class ResultWriter:
    """Writes the result files of one run; see the module docstring for the formats.

    Parameters
    ----------
    out_dir : str, Path or None
        Results folder (created, with parents). None: write nothing, keep probe rows.
    columns : sequence of str
        Probe names in file order.
    first_column : "t" or "load_factor"
    mesh : dict, optional
        The ParaView parts: ``{part: {"n_points": int, "cells": [(type, int array
        (n, k)), ...], "cell_data": {name: constant array}}}``, one file per part
        (``beams`` → ``paraview/beams.vtkhdf``, :mod:`latdyn.results.paraview`); or the legacy
        ``{"lines": int array (n_cells, 2), "n_nodes": int}`` (the part ``beams``).
        Kept as :attr:`mesh` (the caller's dict, extra keys included).
    meta : dict, optional
        JSON-able run description (title, analysis, ...): merged into summary.json and
        stored as the ``meta`` attribute of the state history.
    labels : dict, optional
        State key → one label per column (e.g. :func:`state_labels`); stored as the
        ``columns`` attribute of that dataset. Checked against the widths.
    attributes : dict, optional
        Name → list of strings, stored as file attributes of ``state.h5`` (``nodes``,
        ``hinges``, ``coordinates`` for a run).
    paraview_every : float or None
        Time between ParaView frames (:class:`latdyn.results.paraview.ParaviewWriter`): None, a
        frame for every ``record`` that carries one; 0, none. The last record's frame is
        always written.
    checkpoint_rows, checkpoint_seconds :
        When the state history is rewritten on disk (whichever comes first).
    resume : dict, optional
        A :meth:`bookmark` of an earlier writer of this folder: the files are kept,
        cut back to what the bookmark says was recorded, and appended to (see
        :meth:`bookmark`).
    """

    def __init__(
        self,
        out_dir,
        columns,
        first_column: str = "t",
        mesh: dict | None = None,
        meta: dict | None = None,
        *,
        labels: dict | None = None,
        attributes: dict | None = None,
        paraview_every: float | None = None,
        checkpoint_rows: int = 500,
        checkpoint_seconds: float = 10.0,
        resume: dict | None = None,
    ):
        if first_column not in ("t", "load_factor"):
            raise ValueError(f"first_column must be 't' or 'load_factor', not {first_column!r}")
        self.columns = [str(c) for c in columns]
        if len(set(self.columns)) != len(self.columns):
            raise ValueError(f"duplicate probe names in {self.columns}")
        if first_column in self.columns:
            raise ValueError(f"a probe may not be named {first_column!r}")
        self.first_column = first_column
        self.meta = dict(meta or {})
        self.out_dir = None if out_dir is None else Path(out_dir)
        self.checkpoint_rows = max(1, int(checkpoint_rows))
        self.checkpoint_seconds = float(checkpoint_seconds)
        #: the caller may fill this during the run; merged into summary.json at close
        self.summary: dict = {}
        self.closed = False
        self._start = time.perf_counter()

        #: the ``mesh`` given by the caller (None without one)
        self.mesh = mesh
        self._labels = {str(k): [str(x) for x in v] for k, v in (labels or {}).items()}
        self._attributes = {str(k): [str(x) for x in v] for k, v in (attributes or {}).items()}
        for name in self._attributes:
            if name in ("first_column", "meta"):
                raise ValueError(f"attribute name {name!r} is reserved")

        # probe rows not yet in probes.csv (see CSV_BLOCK_ROWS)
        self._csv_pending: list[str] = []
        self._csv_written_at = time.perf_counter()
        # probe rows in memory (for result())
        self._t: list[float] = []
        self._rows: list[list[float]] = []
        self._modes: np.ndarray | None = None
        self._final_summary: dict | None = None

        # state history (latdyn.results.state_history), written at the writer's checkpoints
        self._state = StateHistory(self.out_dir, first_column, self.meta, self._labels, self._attributes)
        self._last_checkpoint = time.perf_counter()
        self._last_checkpoint_cost = 0.0

        # ParaView frames (latdyn.results.paraview), opened with the other files
        self._paraview = None
        self._paraview_every = paraview_every

        self._fd = None
        if self.out_dir is not None:
            if resume is not None:
                self._reopen_files(resume)
            else:
                self._start_files()

    # -- setup
    def _start_files(self) -> None:
        folder = self.out_dir
        folder.mkdir(parents=True, exist_ok=True)
        for name in (SUMMARY_FILE, MODES_FILE, STATE_H5_FILE, STATE_NPZ_FILE,
                     STATE_H5_FILE + ".tmp", STATE_NPZ_FILE + ".tmp", SUMMARY_FILE + ".tmp"):
            try:
                (folder / name).unlink()
            except FileNotFoundError:
                pass
        paraview = folder / PARAVIEW_DIR
        if paraview.is_dir():  # the folder is ours: the frames of an earlier run go (and older series)
            for stale in [p for pattern in ("*.vtkhdf", "*.vtu", "*.pvd", "*.tmp") for p in paraview.glob(pattern)]:
                try:
                    stale.unlink()
                except FileNotFoundError:
                    pass
        self._open_paraview()
        self._fd = os.open(folder / PROBES_FILE, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND, 0o644)
        self._write_text(csv_line([self.first_column, *self.columns]))
        self._write_summary({"status": "running"})

    def bookmark(self) -> dict:
        """What was recorded so far, for resuming into the same folder (``resume=``).

        ``rows`` (probe rows), ``state_rows`` (state history rows), and ``paraview``, the
        ParaView bookkeeping (:meth:`latdyn.results.paraview.ParaviewWriter.bookmark`: frames
        written, the schedule's index, ``unwritten``, the time of the last record when its
        frame is not written, else None). Everything the writer decides from here on
        depends only on these counts, so a resumed writer continues exactly as this one
        would have.
        """
        return {"rows": len(self._t), "state_rows": self._state.rows(),
                "paraview": None if self._paraview is None else self._paraview.bookmark()}

    def reattach_last_frame(self, frame) -> None:
        """Resumed: the frame (or a callable giving it) of the bookmark's ``unwritten``
        record, written at :meth:`close` should it stay the last one."""
        if self._paraview is not None:
            self._paraview.reattach_last_frame(frame)

    def _open_paraview(self, mark: dict | None = None) -> None:
        """The ParaView frames' writer (:mod:`latdyn.results.paraview`); ``mark``: its bookmark, to resume."""
        from latdyn.results.paraview import ParaviewWriter

        self._paraview = ParaviewWriter(self.out_dir / PARAVIEW_DIR, self.mesh, self._paraview_every, resume=mark)

    def _reopen_files(self, mark: dict) -> None:
        """Resume into ``out_dir``: keep the first ``mark["rows"]`` rows of every file,
        drop what an interrupted run wrote after the bookmark, append from there."""
        folder = self.out_dir
        rows, state_rows = int(mark["rows"]), int(mark["state_rows"])
        # probes.csv: header and the first `rows` rows; a later or cut-off row goes
        path = folder / PROBES_FILE
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise ResultsError(f"{path}: cannot resume ({exc})") from exc
        lines = data.split(b"\n")
        header = csv_line([self.first_column, *self.columns]).encode("utf-8")
        if not data.startswith(header):
            raise ResultsError(f"{path}: cannot resume: its header is not {header.decode().strip()!r}")
        if len(lines) - 2 < rows:  # complete rows: the last piece is empty or a cut-off row
            raise ResultsError(f"{path}: cannot resume: it has fewer than the {rows} rows the checkpoint recorded")
        keep = sum(len(line) + 1 for line in lines[: rows + 1])
        for line in lines[1: rows + 1]:
            values = [float(x) for x in line.decode("utf-8").split(",")]
            self._t.append(values[0])
            self._rows.append(values[1:])
        os.truncate(path, keep)
        for name in (STATE_H5_FILE + ".tmp", STATE_NPZ_FILE + ".tmp", SUMMARY_FILE + ".tmp"):
            try:
                (folder / name).unlink()
            except FileNotFoundError:
                pass
        if state_rows:
            self._state.reopen(state_rows)
        # ParaView: the bookmark's frames; later ones go
        self._open_paraview(mark.get("paraview"))
        self._fd = os.open(path, os.O_WRONLY | os.O_APPEND)
        self._write_summary({"status": "running"})

    def _flush_rows(self) -> None:
        """The probe rows recorded since the last write, to probes.csv in one write."""
        if self._csv_pending and self._fd is not None:
            self._write_text("".join(self._csv_pending))
        self._csv_pending.clear()
        self._csv_written_at = time.perf_counter()

    def _write_text(self, text: str) -> None:
        data = text.encode("utf-8")
        written = os.write(self._fd, data)
        while written < len(data):  # short writes are rare on regular files
            written += os.write(self._fd, data[written:])

    # -- recording
    def record(self, t, values, state: dict | None = None, node_positions=None, node_data: dict | None = None,
               frame=None) -> None:
        """Append one row.

        t : float — time (or load factor).
        values : sequence in ``columns`` order, or dict name -> value.
        state : dict name -> 1-D float array, same keys and widths every call.
        frame : one ParaView frame, ``{part: {"points": (n_points, 3), "point_data":
            {name: (n_points,) or (n_points, k)}, "cell_data": {name: (n_cells,) or
            (n_cells, k)}}}`` (cells counted over the part's cell blocks in order), or a
            callable returning that, called only if the frame is written; it must not
            depend on objects the caller changes later (the last frame is written at
            :meth:`close`).
        node_positions, node_data : the legacy form of ``frame``, for the part ``beams``:
            ``(n_points, 3)`` positions and its point data.
        """
        if self.closed:
            raise RuntimeError("ResultWriter.record() after close()")
        if isinstance(values, dict):
            missing = [c for c in self.columns if c not in values]
            if missing:
                raise ValueError(f"values lack probes {missing}")
            row = [float(values[c]) for c in self.columns]
        else:
            row = [float(v) for v in np.ravel(np.asarray(values, dtype=float))]
            if len(row) != len(self.columns):
                raise ValueError(f"record() got {len(row)} values for {len(self.columns)} probes")
        t = float(t)
        if self._fd is not None:  # floats need no CSV quoting
            self._csv_pending.append(",".join(map(format_float, (t, *row))) + "\n")
            if len(self._csv_pending) >= CSV_BLOCK_ROWS \
                    or time.perf_counter() - self._csv_written_at >= CSV_BLOCK_SECONDS:
                self._flush_rows()
        self._t.append(t)
        self._rows.append(row)

        if state is not None:
            self._state.add(t, state)
            now = time.perf_counter()
            due = self._state.unwritten() >= self.checkpoint_rows or now - self._last_checkpoint >= self.checkpoint_seconds
            # keep checkpoints below ~10 % of the wall time
            if self.out_dir is not None and due and now - self._last_checkpoint >= 9.0 * self._last_checkpoint_cost:
                self.checkpoint()
        if frame is None and node_positions is not None:
            frame = {"beams": {"points": node_positions, "point_data": node_data or {}}}
        if frame is not None and self.out_dir is not None:
            self._add_frame(t, frame)

    def checkpoint(self) -> None:
        """Rewrite the state history on disk now (atomically), with every row so far; the probe
        rows not yet in probes.csv and the ParaView frames not yet in their files go there first."""
        self._flush_rows()
        if self._paraview is not None:
            self._paraview.write_pending()
        began = time.perf_counter()
        if self._state.write():
            end = time.perf_counter()
            self._last_checkpoint = end
            self._last_checkpoint_cost = end - began

    def _add_frame(self, t: float, frame) -> None:
        self._paraview.record(t, frame)

    # -- modes and summary
    def write_modes(self, frequencies_hz, columns: dict | None = None) -> None:
        """Write ``modes.csv`` (``mode,frequency_hz``, then ``columns``: name -> values per mode,
        numbers or words; modes numbered from 1)."""
        freqs = np.asarray(frequencies_hz, dtype=float).ravel()
        self._modes = freqs
        if self.out_dir is None:
            return
        columns = columns or {}

        def cell(value):
            return value if isinstance(value, str) else format_float(value)

        text = ",".join(["mode", "frequency_hz", *columns]) + "\n" + "".join(
            ",".join([str(i), format_float(f), *(cell(values[i - 1]) for values in columns.values())]) + "\n"
            for i, f in enumerate(freqs, start=1))
        atomic_write_bytes(self.out_dir / MODES_FILE, text.encode())

    def _compose_summary(self, summary: dict | None, status: str | None) -> dict:
        merged = dict(self.meta)
        merged.update(self.summary)
        merged.update(summary or {})
        if status is None:
            status = merged.get("status") or "solved"
        if status not in STATUSES:
            raise ValueError(f"status must be one of {STATUSES}, not {status!r}")
        from latdyn.version import __version__

        merged.setdefault("latdyn_version", __version__)
        if merged.get("wall_time_s") is None:
            merged["wall_time_s"] = time.perf_counter() - self._start
        for key in SUMMARY_KEYS:
            merged.setdefault(key, None)
        merged["status"] = status
        merged["rows"] = len(self._t)
        merged["first_column"] = self.first_column
        merged["probes"] = list(self.columns)
        merged.update(self._state.summary())
        if self._paraview is not None and self._paraview.files:
            merged["paraview_files"] = self._paraview.files
            merged["paraview_frames"] = self._paraview.frames
        if self._modes is not None:
            merged["modes"] = int(self._modes.size)
        return json_safe(merged)

    def _write_summary(self, summary: dict) -> None:
        if self.out_dir is None:
            return
        text = json.dumps(json_safe(summary), indent=2, sort_keys=False, allow_nan=False) + "\n"
        atomic_write_bytes(self.out_dir / SUMMARY_FILE, text.encode())

    def close(self, summary: dict | None = None, status: str | None = None) -> dict:
        """Finish every file and write ``summary.json``; returns the summary written.

        ``status`` (or ``summary["status"]``) is ``solved`` (default), ``failed`` or
        ``interrupted``. A second call does nothing and returns the same summary.
        """
        if self.closed:
            return self._final_summary
        frame_error = None
        try:
            self.checkpoint()
        finally:
            try:
                if self._paraview is not None:
                    self._paraview.close()  # the last record's frame when the schedule skipped it
            except Exception as exc:  # the other files are still finished; see below
                frame_error = exc
                summary = dict(summary or {}, paraview_error=f"{type(exc).__name__}: {exc}")
            final = self._compose_summary(summary, status)
            if self._fd is not None:
                os.close(self._fd)
                self._fd = None
            self._write_summary(final)
            self._final_summary = final
            self.closed = True
        if frame_error is not None and final["status"] == "solved":
            raise frame_error
        return final

    def __enter__(self) -> "ResultWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if self.closed:
            return False
        if exc_type is None:
            self.close()
        elif issubclass(exc_type, KeyboardInterrupt):
            self.close({"error": "interrupted"}, status="interrupted")
        else:
            self.close({"error": f"{exc_type.__name__}: {exc}"}, status="failed")
        return False  # re-raise

    def __del__(self):  # a writer dropped without close(): at least release the descriptor
        fd = getattr(self, "_fd", None)
        if fd is not None:
            try:
                os.close(fd)
            except OSError:
                pass

    def result(self) -> Result:
        """The :class:`Result` of what was recorded so far."""
        table = np.array(self._rows, dtype=float).reshape(len(self._rows), len(self.columns))
        probes = {name: table[:, j].copy() for j, name in enumerate(self.columns)}
        summary = self._final_summary if self._final_summary is not None else {"status": "running"}
        return Result(
            np.array(self._t, dtype=float), probes, summary=summary,
            out_dir=None if self.out_dir is None else str(self.out_dir),
            modes=self._modes, first_column=self.first_column,
        )


# ----------------------------------------------------------------------------- progress
class _NoProgress:
    def update(self, t, **postfix) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class _Progress(_NoProgress):
    """A tqdm bar over simulated time (or load factor); ``update`` takes the absolute value."""

    def __init__(self, total_time: float, unit: str, interactive: bool):
        from tqdm import tqdm

        self._total = float(total_time)
        self._bar = tqdm(
            total=self._total,
            unit=unit,
            file=sys.stderr,
            leave=True,
            dynamic_ncols=True,
            # on a terminal: after half a second; in a log: only runs longer than 5 s,
            # and seldom, so a log is not flooded with carriage returns
            delay=0.5 if interactive else 5.0,
            mininterval=0.2 if interactive else 30.0,
            bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} {unit} [{elapsed}<{remaining}{postfix}]",
        )

    def update(self, t, **postfix) -> None:
        value = min(max(float(t), 0.0), self._total)
        if postfix:
            self._bar.set_postfix(postfix, refresh=False)
        self._bar.update(value - self._bar.n)

    def close(self) -> None:
        self._bar.close()


def progress_bar(total_time: float, enabled: bool = True, unit: str = "s"):
    """A progress bar over ``[0, total_time]``: an object with ``.update(t, **postfix)``
    (``t`` absolute; ``postfix`` e.g. ``dt=1e-3, newton=3``) and ``.close()``; also a
    context manager.

    Disabled (a no-op object) when ``enabled`` is false or tqdm is missing. When
    enabled it appears after 0.5 s on a terminal, and in a non-terminal stderr (a log)
    only for runs that last more than 5 s, refreshed at most every 30 s. Use
    ``unit="load"`` and ``total_time=1`` for static runs.
    """
    if not enabled or not total_time or total_time <= 0:
        return _NoProgress()
    try:
        interactive = sys.stderr.isatty()
    except (AttributeError, ValueError):
        interactive = False
    try:
        return _Progress(total_time, unit, interactive)
    except ImportError:
        return _NoProgress()
