"""The state history of a run: every recorded state (node reference points, rotations,
velocities, hinge angles and rates; one dataset per key, one row per record) in ``state.h5``
(HDF5, appended to; written by latdyn's own writer, :mod:`latdyn.results.hdf5_writer`, as h5py
would write it with HDF5 1.8's object format; for a model of more than 454 nodes, whose labels do
not fit that writer's attribute messages, by h5py itself, copied, appended to and renamed over the
old file) or, without h5py (which reads it back), ``state.npz`` (the whole history rewritten). The writer (:class:`latdyn.results.writer.ResultWriter`) decides when
the rows go to disk (its checkpoints); each write leaves a complete file, and a resumed run cuts it
back to the rows its bookmark recorded. :mod:`latdyn.results.result` reads it back.

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
*Crash safety, the choice made:* the file on disk is always a complete HDF5 file. It is created at
the first checkpoint under ``state.h5.tmp``, complete, then renamed, and kept open; new rows are held
in memory and appended at a checkpoint: their chunks are written in place (the datasets are chunked
and extensible), then the file's metadata is written where the file's current metadata is not, and
the superblock, rewritten last, points at it (:mod:`latdyn.results.hdf5_writer`). A killed process
(SIGKILL, a crash of Python) therefore loses at most the rows since the last checkpoint and never
leaves a half-written file: what a process wrote is the kernel's once written, whatever becomes of
the process. Syncing to the disk (``fsync``) guards against the operating system's crash or a power
loss instead, and is paid where a result is complete: at the writer's close and at a resume
checkpoint (:mod:`latdyn.timeloop.checkpoint`) the file is synced before and after its superblock is
rewritten; the writer's periodic checkpoints are not synced (a power loss during a run may then
leave the file of an earlier checkpoint, or on some file systems a damaged one, where a killed
process leaves the last checkpoint's). The writer checkpoints every ``checkpoint_rows`` rows or
``checkpoint_seconds`` seconds, whichever comes first, but never more often than keeps checkpoint
time below about 10 % of the run's wall time, and at its close. A resumed run writes the file anew
with the rows its bookmark recorded (read through h5py), synced, and renames it over the old one.
The NPZ fallback keeps the whole history in memory and rewrites ``state.npz`` atomically (temp +
``os.replace``); its labels are one JSON string under the key ``_labels``.
"""
from __future__ import annotations

import importlib.util
import io
import json
import os
import shutil
from pathlib import Path

import numpy as np

from latdyn.errors import ResultsError
from latdyn.results.files import atomic_write_bytes, fsync_path, json_safe

from latdyn.results import hdf5_writer

#: whether h5py is installed (found, not imported: latdyn writes its HDF5 files itself,
#: :mod:`latdyn.results.hdf5_writer`; h5py reads them back). Without it, the NPZ fallback.
h5py = True if importlib.util.find_spec("h5py") is not None else None

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
    """``attrs[name] = value`` through h5py; a list of str as h5py stores it (variable-length UTF-8
    strings), its type named rather than found by h5py's walk over every item."""
    import h5py

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
        self._file = None  # state.h5 open for appending (hdf5_writer.File), its datasets by key
        self._datasets: dict = {}
        self._fits: bool | None = None  # whether latdyn's writer holds the labels (_ours)
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
        """Every row so far into the file (a complete file after it; ``durable``: synced to the disk);
        False when there was nothing to write. A durable call with nothing new to write still syncs
        the file a periodic (not durable) write left on the disk."""
        if self.folder is None or self.keys is None:
            return False
        if self.unwritten() == 0:
            if durable and self._unsynced and self.path.is_file():
                fsync_path(self.path)
                self._unsynced = False
            return False
        if self.use_h5 and self._ours():
            self._write_h5(durable)
        elif self.use_h5:
            self._write_h5_through_h5py(durable)
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
        """The pending rows appended to ``state.h5`` (created at the first write: under a temporary
        name, then renamed; kept open) and the file flushed (module docstring, "Crash safety")."""
        n_new = len(self._pending_t)
        new = self._file is None
        if new:
            self._create_h5(chunk_rows=None)
        self._append_h5(np.asarray(self._pending_t, dtype=float), {k: self._rows(k) for k in self.keys})
        self._file.flush(durable)
        if new:  # complete on disk before it takes its name
            self._file.rename(self.path)
        self.rows_on_disk += n_new
        self._pending_t.clear()
        for k in self.keys:
            self._pending[k].clear()

    def _create_h5(self, chunk_rows: dict | None, attributes: dict | None = None, labels: dict | None = None) -> None:
        """A new ``state.h5`` with the history's attributes and empty datasets, under a temporary name
        (the caller renames it once flushed; ``chunk_rows``: the rows of each key's chunk, ``attributes``
        and ``labels`` a resumed file's; None: chosen from the first write, as below, and the history's own)."""
        f = hdf5_writer.File(self.path.with_name(self.path.name + ".tmp"), header_version=2)  # as h5py's libver v108 writes them
        root = f.root
        if attributes is None:
            attributes = {"first_column": self.first_column, "meta": json.dumps(json_safe(self.meta)),
                          **self.attributes}
        labels = self.labels if labels is None else labels
        for name, value in attributes.items():
            root.set_attribute(name, value)
        self._datasets = {"t": root.create_growing("t", (), "f8", (1024,))}
        n_new = len(self._pending_t)
        for k in self.keys:
            width = self.widths[k]
            # a chunk of up to 1024 rows and 2 MiB, but no more rows than the first write
            # brings (at least 64): a short run's file is its rows, not chunks mostly empty
            rows_per_chunk = chunk_rows[k] if chunk_rows is not None else \
                max(1, min(1024, (1 << 18) // max(1, width), max(FIRST_CHUNK_ROWS, n_new)))
            dataset = root.create_growing(k, (width,), "f8", (rows_per_chunk, max(1, width)))
            if k in labels:
                dataset.set_attribute("columns", labels[k])
                if k in STATE_DESCRIPTIONS:
                    dataset.set_attribute("description", STATE_DESCRIPTIONS[k])
            self._datasets[k] = dataset
        self._file = f

    def _append_h5(self, t: np.ndarray, rows: dict) -> None:
        self._datasets["t"].append(t)
        for k in self.keys:
            self._datasets[k].append(rows[k])

    def close(self) -> None:
        """The file closed (after the last :meth:`write`)."""
        if self._file is not None:
            self._file.close(durable=False)
            self._file = None

    def _ours(self) -> bool:
        """Whether latdyn's writer writes the file: every attribute fits an object header message
        (:func:`latdyn.results.hdf5_writer.fits`: lists of at most 4092 labels, a model of at most 454
        nodes); else h5py writes it, in HDF5's dense attribute storage (module docstring)."""
        if self._fits is None:
            labels = {f"columns of {k}": self.labels[k] for k in self.keys or () if k in self.labels}
            self._fits = all(hdf5_writer.fits(name, value) for name, value in {**self.attributes, **labels}.items())
        return self._fits

    def _write_h5_through_h5py(self, durable: bool) -> None:
        """The rows appended through h5py to a copy of the file, renamed over it (a model whose labels
        do not fit latdyn's writer: :meth:`_ours`)."""
        import h5py

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
                for name, value in self.attributes.items():
                    _set_attribute(f.attrs, name, value)
                f.create_dataset("t", shape=(0,), maxshape=(None,), dtype="f8", chunks=(1024,))
                for k in self.keys:
                    width = self.widths[k]
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
            import h5py

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
        if self.use_h5 and self._ours():
            self._pending = {k: [] for k in self.keys}
            self._rewrite_h5(rows)
            self.rows_on_disk = rows
        elif self.use_h5:  # h5py's file: cut back on a copy, renamed over it
            import h5py

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

    def _rewrite_h5(self, rows: int) -> None:
        """Resume: ``state.h5`` written anew with its first ``rows`` rows (read through h5py, in
        blocks), the same attributes and chunks, synced and renamed over the old one; kept open."""
        import h5py

        path = self.path
        with h5py.File(path, "r") as old:
            attributes = {name: _attribute_value(old.attrs, name) for name in old.attrs}
            chunk_rows = {k: old[k].chunks[0] for k in self.keys}
            labels = {k: _attribute_value(old[k].attrs, "columns") for k in self.keys if "columns" in old[k].attrs}
            self._create_h5(chunk_rows, attributes, labels)
            block = max(1, min(chunk_rows.values(), default=1)) * 16
            for start in range(0, rows, block):
                stop = min(rows, start + block)
                self._append_h5(np.asarray(old["t"][start:stop]), {k: np.asarray(old[k][start:stop]) for k in self.keys})
        self._file.flush(durable=True)
        self._file.rename(path)


def _attribute_value(attrs, name: str):
    """An attribute as h5py reads it, in the form :meth:`hdf5_writer.Group.set_attribute` writes it back
    the same (str and lists of str, numbers and arrays of them, ``np.bytes_``)."""
    value = attrs[name]
    if isinstance(value, np.ndarray) and value.dtype.kind == "O":
        return [v.decode("utf-8") if isinstance(v, bytes) else str(v) for v in value.tolist()]
    if isinstance(value, bytes):
        return np.bytes_(value)
    return value
