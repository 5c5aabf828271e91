"""The state history of a run: every recorded state (node reference points, rotations,
velocities, hinge angles and rates; one dataset per key, one row per record) in ``state.h5``
(HDF5, appended to) or, without h5py, ``state.npz`` (the whole history rewritten). The writer
(:class:`latdyn.results.writer.ResultWriter`) decides when the rows go to disk (its checkpoints);
each write replaces the file atomically, and a resumed run cuts it back to the rows its bookmark
recorded. :mod:`latdyn.results.result` reads it back.

``state.h5`` holds dataset ``t`` ``(n_rows,)`` and one dataset per state key ``(n_rows, width)``,
with attributes ``first_column`` and ``meta`` (JSON).
*Labels:* the writer's ``attributes`` become file attributes (a run stores ``nodes``, the model
node names such as ``"hub"``, ``"arm.node[3]"``, ``"arm.end"``; ``hinges``,
``"BEAM.start"``/``"BEAM.end"``; ``coordinates``, the free coordinates at t = 0 in solver order,
``"arm.node[3]:dx"`` …), and each dataset with ``labels`` has an attribute ``columns`` naming
every column and a ``description``. For a run (see :func:`state_labels`) the layout is
node-major: node ``i`` (``nodes[i]``) owns columns ``3i … 3i+2`` of ``x`` (reference point,
global), ``v`` (its velocity) and ``w`` (spatial angular velocity), labelled ``"arm.node[3]:x"``
… ``":z"``, and columns ``9i … 9i+8`` of ``T`` (rotation node axes → global, row-major,
``":T[0,0]"`` … ``":T[2,2]"``); hinge ``k`` (``hinges[k]``) owns column ``k`` of ``theta`` and
``theta_dot`` (labelled ``"arm.start"``). Datasets of empty arrays (no hinges) are absent.
*Crash safety, the choice made:* the file on disk is always a complete, closed HDF5 file. New
rows are held in memory and appended at a checkpoint by copying the current file to
``state.h5.tmp``, appending to the copy (datasets are resizable and chunked), closing it and
``os.replace``-ing it over ``state.h5``. A killed process (SIGKILL, a crash of Python) therefore
loses at most the rows since the last checkpoint and never leaves a half-written file (an HDF5 file
kept open and flushed can be left unreadable by a kill during a metadata update): what a process
wrote is the kernel's once written, whatever becomes of the process. Syncing to the disk
(``fsync``) guards against the operating system's crash or a power loss instead, and is paid where
a result is complete: the file of the writer's close and of a resume checkpoint
(:mod:`latdyn.timeloop.checkpoint`) is synced before it replaces the old one, the writer's periodic
checkpoints are not (a power loss during a run may then leave an older state.h5, or on some file
systems an empty one, where a killed process leaves the last checkpoint's; 1-3 ms a checkpoint on
this machine's disk, more on a network one). The writer checkpoints every
``checkpoint_rows`` rows or ``checkpoint_seconds`` seconds, whichever comes first, but never more
often than keeps checkpoint time below about 10 % of the run's wall time, and at its close. The
NPZ fallback keeps the whole history in memory and rewrites ``state.npz`` the same way (temp +
``os.replace``); its labels are one JSON string under the key ``_labels``.
"""
from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np

from latdyn.errors import ResultsError
from latdyn.results.files import atomic_write_bytes, fsync_path, json_safe

try:  # optional: the NPZ fallback is used without it
    import h5py
except ImportError:  # pragma: no cover - exercised by monkeypatching in the tests
    h5py = None

STATE_H5_FILE = "state.h5"


STATE_NPZ_FILE = "state.npz"

#: the fewest rows of a state dataset's chunk (its size is fixed at the file's first write)
FIRST_CHUNK_ROWS = 64


LABELS_KEY = "_labels"  # NPZ only: the labels as one JSON string


#: ``description`` attributes of the state datasets a run writes (see :func:`state_labels`)
STATE_DESCRIPTIONS = {
    "x": "node reference points, global; 3 columns per node (x, y, z), node order = attribute nodes",
    "T": "node rotations (node axes -> global), row-major; 9 columns per node, node order = attribute nodes",
    "v": "node reference-point velocities, global; 3 columns per node",
    "w": "node spatial angular velocities, global; 3 columns per node",
    "theta": "hinge angles; one column per hinge, order = attribute hinges",
    "theta_dot": "hinge rates; one column per hinge, order = attribute hinges",
}


def _set_attribute(attrs, name: str, value) -> None:
    """``attrs[name] = value``; a list of str as h5py stores it (variable-length UTF-8 strings), its
    type named rather than found by h5py's walk over every item (~0.1 ms for a state's 600 labels)."""
    if isinstance(value, (list, tuple)) and value and all(type(item) is str for item in value):
        attrs.create(name, value, dtype=h5py.string_dtype())
    else:
        attrs[name] = value


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


class StateHistory:
    """The rows of the state history and their file in ``folder`` (None: rows are checked, not kept)."""

    def __init__(self, folder: Path | None, first_column: str, meta: dict, labels: dict, attributes: dict):
        self.folder = folder
        self.first_column, self.meta, self.labels, self.attributes = first_column, meta, labels, attributes
        self.keys: list[str] | None = None  # fixed by the first state
        self.widths: dict[str, int] = {}
        self._pending_t: list[float] = []
        self._pending: dict[str, list[np.ndarray]] = {}  # per key, blocks of rows (n_i, width) in order
        self.use_h5 = h5py is not None
        self.rows_on_disk = 0
        self._unsynced = False  # the file on disk was last written without a sync

    @property
    def path(self) -> Path:
        return self.folder / (STATE_H5_FILE if self.use_h5 else STATE_NPZ_FILE)

    def rows(self) -> int:
        """Rows recorded so far (a bookmark's ``state_rows``)."""
        if self.keys is None:
            return 0
        return len(self._pending_t) + (self.rows_on_disk if self.use_h5 else 0)

    def unwritten(self) -> int:
        """Rows recorded but not yet in the file."""
        return len(self._pending_t) - (0 if self.use_h5 else self.rows_on_disk)

    def add(self, t: float, state: dict) -> None:
        """One row: the same keys and widths every time (the first state fixes them)."""
        arrays = {str(k): np.array(v, dtype=float).ravel() for k, v in state.items()}
        if self.keys is None:
            if "t" in arrays:
                raise ValueError("a state key may not be named 't'")
            for k, a in arrays.items():
                if k in self.labels and len(self.labels[k]) != a.size:
                    raise ValueError(f"state {k!r} has {a.size} entries but {len(self.labels[k])} labels")
            self.keys = list(arrays)
            self.widths = {k: a.size for k, a in arrays.items()}
            self._pending = {k: [] for k in self.keys}
        elif set(arrays) != set(self.keys):
            raise ValueError(f"state keys changed: {sorted(arrays)} vs {sorted(self.keys)}")
        for k in self.keys:
            if arrays[k].size != self.widths[k]:
                raise ValueError(f"state {k!r} has {arrays[k].size} entries, expected {self.widths[k]}")
        if self.folder is None:
            return
        for k in self.keys:
            self._pending[k].append(arrays[k].reshape(1, -1))
        self._pending_t.append(t)

    def add_rows(self, times, states: dict) -> None:
        """Rows at ``times`` (k,): ``states`` name -> (k, width) arrays, as :meth:`add` of each row
        (copied once)."""
        if not len(times):
            return
        arrays = {str(k): np.array(v, dtype=float).reshape(len(times), -1) for k, v in states.items()}
        self.add(times[0], {k: a[0] for k, a in arrays.items()})
        if self.folder is None:
            return
        if len(times) > 1:
            for k in self.keys:  # one block, not a view a row (2001 rows: np.stack of 2000 views a key)
                self._pending[k].append(arrays[k][1:])
        self._pending_t.extend(float(t) for t in times[1:])

    def write(self, durable: bool = True) -> bool:
        """Every row so far into the file (atomically; ``durable``: synced to the disk before it
        replaces the old one); False when there was nothing to write. A durable call with nothing new
        to write still syncs the file a periodic (not durable) rewrite left on the disk."""
        if self.folder is None or self.keys is None:
            return False
        if self.unwritten() == 0:
            if durable and self._unsynced and self.path.is_file():
                fsync_path(self.path)
                self._unsynced = False
            return False
        if self.use_h5:
            self._write_h5(durable)
        else:
            self._write_npz(durable)
        self._unsynced = not durable
        return True

    def summary(self) -> dict:
        """``state_file`` and ``state_rows`` for summary.json (nothing before the first state)."""
        if self.keys is None or self.folder is None:
            return {}
        return {"state_file": self.path.name, "state_rows": self.rows_on_disk}

    def _rows(self, k: str) -> np.ndarray:
        """The pending rows of ``k`` as one (rows, width) array (its blocks joined, values unchanged)."""
        blocks = self._pending[k]
        return np.concatenate(blocks) if blocks else np.zeros((0, self.widths[k]))

    def _write_h5(self, durable: bool) -> None:
        path = self.path
        tmp = path.with_name(path.name + ".tmp")
        n_new = len(self._pending_t)
        if path.is_file():
            shutil.copyfile(path, tmp)
            mode = "a"
        else:
            mode = "w"
        # HDF5 1.8 object format: attributes (the labels) may exceed 64 KiB
        with h5py.File(tmp, mode, libver=("v108", "latest")) as f:
            if mode == "w":
                f.attrs["first_column"] = self.first_column
                f.attrs["meta"] = json.dumps(json_safe(self.meta))
                for name, strings in self.attributes.items():
                    _set_attribute(f.attrs, name, strings)
                f.create_dataset("t", shape=(0,), maxshape=(None,), dtype="f8", chunks=(1024,))
                for k in self.keys:
                    width = self.widths[k]
                    # a chunk of up to 1024 rows and 2 MiB, but no more rows than the first write
                    # brings (at least 64): a short run's file is its rows, not chunks mostly empty
                    rows_per_chunk = max(1, min(1024, (1 << 18) // max(1, width), max(FIRST_CHUNK_ROWS, n_new)))
                    dataset = f.create_dataset(k, shape=(0, width), maxshape=(None, width), dtype="f8",
                                               chunks=(rows_per_chunk, max(1, width)))
                    if k in self.labels:
                        _set_attribute(dataset.attrs, "columns", self.labels[k])
                        if k in STATE_DESCRIPTIONS:
                            dataset.attrs["description"] = STATE_DESCRIPTIONS[k]
            n_old = f["t"].shape[0]
            f["t"].resize((n_old + n_new,))
            f["t"][n_old:] = np.asarray(self._pending_t)
            for k in self.keys:
                f[k].resize((n_old + n_new, self.widths[k]))
                f[k][n_old:] = self._rows(k)
        if durable:
            fsync_path(tmp)
        os.replace(tmp, path)
        self.rows_on_disk += n_new
        self._pending_t.clear()
        for k in self.keys:
            self._pending[k].clear()

    def _write_npz(self, durable: bool) -> None:
        # no appending to an NPZ: the whole history stays in memory and is rewritten
        arrays = {"t": np.asarray(self._pending_t, dtype=float)}
        for k in self.keys:
            arrays[k] = self._rows(k)
        if self.labels or self.attributes:
            labels = dict(self.attributes)
            labels["columns"] = {k: v for k, v in self.labels.items() if k in self.widths}
            arrays[LABELS_KEY] = np.array(json.dumps(labels))
        buffer = io.BytesIO()
        np.savez(buffer, **arrays)
        atomic_write_bytes(self.path, buffer.getvalue(), fsync=durable)
        self.rows_on_disk = len(self._pending_t)

    def reopen(self, rows: int) -> None:
        """Resume: the file's first ``rows`` rows (a later one goes, atomically)."""
        path = self.path
        if not path.is_file():
            raise ResultsError(f"{path}: cannot resume: the state history is missing")
        if self.use_h5:
            with h5py.File(path, "r") as f:
                keys = [k for k in f.keys() if k != "t"]
                widths = {k: int(f[k].shape[1]) for k in keys}
                on_disk = int(f["t"].shape[0])
        else:
            with np.load(path) as f:
                keys = [k for k in f.files if k not in ("t", LABELS_KEY)]
                history = {k: f[k] for k in ["t", *keys]}
            widths = {k: int(history[k].shape[1]) for k in keys}
            on_disk = len(history["t"])
        if on_disk < rows:
            raise ResultsError(f"{path}: cannot resume: it has {on_disk} rows, the checkpoint recorded {rows}")
        order = [k for k in ("x", "T", "v", "w", "theta", "theta_dot") if k in keys]  # State.as_dict order
        self.keys = order + [k for k in keys if k not in order]
        self.widths = widths
        if self.use_h5:
            self._pending = {k: [] for k in self.keys}
            if on_disk > rows:
                tmp = path.with_name(path.name + ".tmp")
                shutil.copyfile(path, tmp)
                with h5py.File(tmp, "a") as f:
                    f["t"].resize((rows,))
                    for k in keys:
                        f[k].resize((rows, widths[k]))
                fsync_path(tmp)
                os.replace(tmp, path)
            self.rows_on_disk = rows
        else:  # the whole history in memory, as the writer keeps it
            self._pending_t = [float(x) for x in history["t"][:rows]]
            self._pending = {k: [np.array(history[k][:rows], dtype=float).reshape(-1, widths[k])] for k in self.keys}
            self.rows_on_disk = on_disk
            if on_disk > rows:
                self._write_npz(durable=True)
