"""The result files of a run (SCENE.md, "Commands and results"): one :class:`ResultWriter` per run
writes, into ``out_dir``, each output through the module that holds its format:

``probes.csv``
    One row per :meth:`ResultWriter.record` (:mod:`latdyn.results.probes_csv`).
``state.h5`` (or ``state.npz`` when h5py, which reads it back, is missing)
    The full state history, appended to at the writer's checkpoints, a complete file after each
    (:mod:`latdyn.results.state_history`; written by :mod:`latdyn.results.hdf5_writer`, as are the
    ParaView files).
``paraview/beams.vtkhdf``, ``paraview/bodies.vtkhdf``
    One transient VTKHDF file per part of ``mesh``, frames at ``paraview_every``
    (:mod:`latdyn.results.paraview`).
``modes.csv``
    The natural frequencies of a modal run (:meth:`ResultWriter.write_modes`,
    :mod:`latdyn.results.modes_csv`).
``summary.json``
    ``"status": "running"`` from the start, the final status and the run's numbers at
    :meth:`ResultWriter.close` (:mod:`latdyn.results.summary`).

Files of an earlier run with these names are removed when a writer starts, so the folder never
mixes two runs, unless it *resumes* (``resume=`` a :meth:`ResultWriter.bookmark` of the earlier
writer, kept in a run's checkpoint, see :mod:`latdyn.timeloop.checkpoint`): then the files are cut
back to the bookmark (``probes.csv`` to its rows, the state history to its rows, atomically;
ParaView frames it does not list are cut back to its frames) and appended to. Every later decision
of the writer (which frames) depends only on the counts in the bookmark, so the finished files
equal those of one uninterrupted writer. (The state-history "checkpoints" are the writer's own
flushes, unrelated to a run's checkpoint file.) With ``out_dir=None`` nothing is written; the
writer only keeps the probe rows for :meth:`ResultWriter.result`.

What a run recorded, in memory or read back from its folder, is a :class:`Result`
(:mod:`latdyn.results.result`). :class:`Result`, :func:`load_state_history`,
:func:`load_state_labels`, :func:`state_labels`, :func:`progress_bar` and the file names are
importable from this module too.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from latdyn.errors import ResultsError, UnboundedError
from latdyn.results.modes_csv import MODES_FILE, write_modes_csv
from latdyn.results.paraview import PARAVIEW_DIR, ParaviewWriter
from latdyn.results.probes_csv import PROBES_FILE, ProbesCsv
from latdyn.results.progress import progress_bar
from latdyn.results.result import Result, load_state_history, load_state_labels
from latdyn.results.state_history import (
    STATE_H5_FILE,
    STATE_NPZ_FILE,
    StateHistory,
    state_labels,
)
from latdyn.results.summary import SUMMARY_FILE, compose_summary, write_summary

__all__ = [
    "MODES_FILE",
    "PARAVIEW_DIR",
    "PROBES_FILE",
    "STATE_H5_FILE",
    "STATE_NPZ_FILE",
    "SUMMARY_FILE",
    "RUN_CHECKPOINT_MIN_SECONDS",
    "Result",
    "ResultWriter",
    "ResultsError",
    "load_state_history",
    "load_state_labels",
    "progress_bar",
    "state_labels",
]

#: an earlier run's files, removed when a writer starts (probes.csv is emptied instead)
EARLIER_RUN_FILES = (SUMMARY_FILE, MODES_FILE, STATE_H5_FILE, STATE_NPZ_FILE)
#: the temporary files of an interrupted atomic write, removed when a writer starts or resumes
TEMPORARY_FILES = (STATE_H5_FILE + ".tmp", STATE_NPZ_FILE + ".tmp", SUMMARY_FILE + ".tmp")
#: A run's writer rewrites its state history (and appends its ParaView frames) at most once a
#: second (``checkpoint_min_seconds``): a killed run keeps every row and frame up to its last
#: checkpoint, at most ``checkpoint_rows`` rows or ``checkpoint_seconds`` but never less than the
#: last second before the kill; a run shorter than a second writes them once, at its close
#: (the spin-up's 2001 rows: 4 rewrites of state.h5 and 7 blocks of frames fewer, ~35 ms of CPU).
RUN_CHECKPOINT_MIN_SECONDS = 1.0


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
    checkpoint_min_seconds :
        And not before this many seconds of wall time since the last time (a run: 1 s,
        :data:`RUN_CHECKPOINT_MIN_SECONDS`): a short run then writes its files once, at its close.
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
        checkpoint_min_seconds: float = 0.0,
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
        #: ``{(probe, parameter): values over the rows}`` of a run with solve.sensitivities (latdyn/analyses/sensitivities.py)
        self.sensitivities: dict = {}
        self.meta = dict(meta or {})
        self.out_dir = None if out_dir is None else Path(out_dir)
        self.checkpoint_rows = max(1, int(checkpoint_rows))
        self.checkpoint_seconds = float(checkpoint_seconds)
        self.checkpoint_min_seconds = float(checkpoint_min_seconds)
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

        # probe rows (latdyn.results.probes_csv), in memory for result() and in probes.csv
        self._probes = ProbesCsv(self.out_dir, first_column, self.columns)
        self._modes: np.ndarray | None = None
        self._final_summary: dict | None = None

        # state history (latdyn.results.state_history), written at the writer's checkpoints
        self._state = StateHistory(self.out_dir, first_column, self.meta, self._labels, self._attributes)
        self._last_checkpoint = time.perf_counter()
        self._last_checkpoint_cost = 0.0

        # ParaView frames (latdyn.results.paraview), opened with the other files
        self._paraview: ParaviewWriter | None = None
        self._paraview_every = paraview_every

        if self.out_dir is not None:
            if resume is not None:
                self._reopen_files(resume)
            else:
                self._start_files()

    # -- setup
    def _start_files(self) -> None:
        folder = self.out_dir
        folder.mkdir(parents=True, exist_ok=True)
        for name in EARLIER_RUN_FILES + TEMPORARY_FILES:
            (folder / name).unlink(missing_ok=True)
        paraview = folder / PARAVIEW_DIR
        if paraview.is_dir():  # the folder is ours: the frames of an earlier run go (and older series)
            for stale in [p for pattern in ("*.vtkhdf", "*.vtu", "*.pvd", "*.tmp") for p in paraview.glob(pattern)]:
                stale.unlink(missing_ok=True)
        self._open_paraview()
        self._probes.create()
        write_summary(folder, {"status": "running"}, durable=False)

    def bookmark(self) -> dict:
        """What was recorded so far, for resuming into the same folder (``resume=``).

        ``rows`` (probe rows), ``state_rows`` (state history rows), and ``paraview``, the
        ParaView bookkeeping (:meth:`latdyn.results.paraview.ParaviewWriter.bookmark`: frames
        written, the schedule's index, ``unwritten``, the time of the last record when its
        frame is not written, else None). Everything the writer decides from here on
        depends only on these counts, so a resumed writer continues exactly as this one
        would have.
        """
        return {"rows": len(self._probes.times), "state_rows": self._state.rows(),
                "paraview": None if self._paraview is None else self._paraview.bookmark()}

    @property
    def last_time(self) -> float | None:
        """The first column of the last probe row (a resumed run's included), None before any."""
        return self._probes.times[-1] if self._probes.times else None

    def reattach_last_frame(self, frame) -> None:
        """Resumed: the frame (or a callable giving it) of the bookmark's ``unwritten``
        record, written at :meth:`close` should it stay the last one."""
        if self._paraview is not None:
            self._paraview.reattach_last_frame(frame)

    def _open_paraview(self, mark: dict | None = None) -> None:
        """The ParaView frames' writer (:mod:`latdyn.results.paraview`); ``mark``: its bookmark, to resume."""
        self._paraview = ParaviewWriter(self.out_dir / PARAVIEW_DIR, self.mesh, self._paraview_every, resume=mark)

    def _reopen_files(self, mark: dict) -> None:
        """Resume into ``out_dir``: keep the first ``mark["rows"]`` rows of every file,
        drop what an interrupted run wrote after the bookmark, append from there."""
        folder = self.out_dir
        rows, state_rows = int(mark["rows"]), int(mark["state_rows"])
        self._probes.reopen(rows)
        for name in TEMPORARY_FILES:
            (folder / name).unlink(missing_ok=True)
        if state_rows:
            self._state.reopen(state_rows)
        # ParaView: the bookmark's frames; later ones go
        self._open_paraview(mark.get("paraview"))
        write_summary(folder, {"status": "running"}, durable=False)

    # -- recording
    def warn(self, warning: str) -> None:
        """A warning of the run: on stderr and in summary.json ``warnings``."""
        print(f"latdyn: warning: {warning}", file=sys.stderr)
        self.summary.setdefault("warnings", []).append(warning)

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
        t = float(t)
        self._probes.add(t, values)

        if state is not None:
            self._state.add(t, state)
            if self._checkpoint_due():
                self.checkpoint(durable=False)
        if frame is None and node_positions is not None:
            frame = {"beams": {"points": node_positions, "point_data": node_data or {}}}
        if frame is not None and self.out_dir is not None:
            self._paraview.record(t, frame)

    def record_rows(self, times, values, states: dict, frames) -> None:
        """Append k rows at once (rows recorded where the step runs): ``times`` (k,), ``values``
        (k, probes) in ``columns`` order, ``states`` name -> (k, width) arrays, ``frames(r)`` row r's
        frame or a callable giving it, asked only for the frames written (None: none); the same files
        as :meth:`record` of each row (the state history's checkpoint judged once, after them)."""
        if self.closed:
            raise RuntimeError("ResultWriter.record_rows() after close()")
        self._probes.add_rows(times, values)
        self._state.add_rows(times, states)
        if self._checkpoint_due():
            self.checkpoint(durable=False)
        if frames is not None and self.out_dir is not None:
            self._paraview.record_rows(times, frames)

    def _checkpoint_due(self) -> bool:
        """Whether the state history is rewritten now: ``checkpoint_rows`` rows or ``checkpoint_seconds``
        since the last time, but not before ``checkpoint_min_seconds`` nor more often than keeps
        the checkpoints below about 10 % of the wall time."""
        if self.out_dir is None:
            return False
        since = time.perf_counter() - self._last_checkpoint
        due = self._state.unwritten() >= self.checkpoint_rows or since >= self.checkpoint_seconds
        return due and since >= max(self.checkpoint_min_seconds, 9.0 * self._last_checkpoint_cost)

    def checkpoint(self, durable: bool = True) -> None:
        """Write the state history on disk now, with every row so far (a complete file after it); the
        probe rows not yet in probes.csv and the ParaView frames not yet in their files go there first.
        ``durable``: the file synced to the disk (at the close and for a resume checkpoint; the writer's
        periodic checkpoints need only a complete file: :mod:`latdyn.results.state_history`, "Crash
        safety")."""
        self._probes.flush()
        if self._paraview is not None:
            self._paraview.write_pending()
        began = time.perf_counter()
        if self._state.write(durable):
            end = time.perf_counter()
            self._last_checkpoint = end
            self._last_checkpoint_cost = end - began

    # -- modes and summary
    def write_modes(self, frequencies_hz, columns: dict | None = None) -> None:
        """Write ``modes.csv`` (``mode,frequency_hz``, then ``columns``: name -> values per mode,
        numbers or words; modes numbered from 1)."""
        self._modes = np.asarray(frequencies_hz, dtype=float).ravel()
        if self.out_dir is not None:
            write_modes_csv(self.out_dir, self._modes, columns or {})

    def _compose_summary(self, summary: dict | None, status: str | None) -> dict:
        """The final summary.json (:func:`latdyn.results.summary.compose_summary`): ``meta``, then
        :attr:`summary`, then ``summary``, and what the files hold."""
        recorded = {"rows": len(self._probes.times), "first_column": self.first_column,
                    "probes": list(self.columns), **self._state.summary()}
        if self._paraview is not None and self._paraview.files:
            recorded["paraview_files"] = self._paraview.files
            recorded["paraview_frames"] = self._paraview.frames
        if self._modes is not None:
            recorded["modes"] = int(self._modes.size)
        return compose_summary({**self.meta, **self.summary, **(summary or {})}, status, self._start, recorded)

    def close(self, summary: dict | None = None, status: str | None = None) -> dict:
        """Finish every file and write ``summary.json``; returns the summary written.

        ``status`` (or ``summary["status"]``) is ``solved`` (default), ``failed``, ``unbounded`` or
        ``interrupted``. A second call does nothing and returns the same summary.
        """
        if self.closed:
            return self._final_summary
        frame_error = None
        try:
            self.checkpoint()
        finally:
            self._state.close()
            try:
                if self._paraview is not None:
                    self._paraview.close()  # the last record's frame when the schedule skipped it
            except Exception as exc:  # the other files are still finished; see below
                frame_error = exc
                summary = dict(summary or {}, paraview_error=f"{type(exc).__name__}: {exc}")
            final = self._compose_summary(summary, status)
            self._probes.close()
            if self.out_dir is not None:
                write_summary(self.out_dir, final)
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
            status = "unbounded" if isinstance(exc, UnboundedError) else "failed"
            self.close({"error": f"{exc_type.__name__}: {exc}"}, status=status)
        return False  # re-raise

    def result(self) -> Result:
        """The :class:`Result` of what was recorded so far."""
        t, probes = self._probes.table()
        summary = self._final_summary if self._final_summary is not None else {"status": "running"}
        result = Result(
            t, probes, summary=summary,
            out_dir=None if self.out_dir is None else str(self.out_dir),
            modes=self._modes, first_column=self.first_column,
        )
        result.sensitivities = dict(self.sensitivities)
        return result
