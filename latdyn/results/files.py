"""Writing result files safely: atomic replacement, fsync, JSON-safe values, CSV lines and the
float format every numeric cell uses (shortest repr that reads back to the same float); h5py, which
writes the HDF5 files, imported where they are first written (:data:`h5py`) or beside the steps
(:func:`import_h5py_beside`)."""
from __future__ import annotations

import csv
import importlib
import importlib.util
import io
import math
import os
import sys
import threading
from pathlib import Path

import numpy as np


class _ModuleOnUse:
    """An optional module imported at its first attribute (``h5py.File``), not with the module that
    names it: a run imports h5py (≈ 30 ms of CPU) where it first writes an HDF5 file, by which time
    :func:`import_h5py_beside` has usually imported it beside the steps. Where the module is not
    installed the name is None, as an ``import`` in ``try/except ImportError`` leaves it."""

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attribute: str):
        return getattr(importlib.import_module(self._name), attribute)

    @classmethod
    def of(cls, name: str) -> "_ModuleOnUse | None":
        """The module itself where already imported, None where not installed, else one imported on use."""
        if name in sys.modules:
            return sys.modules[name]
        return None if importlib.util.find_spec(name) is None else cls(name)


#: h5py (None where not installed), imported on its first use
h5py = _ModuleOnUse.of("h5py")


def import_h5py_beside() -> None:
    """Import h5py in a thread of its own, to be ready when the first HDF5 file is written: the caller
    goes on into C (the time loop's steps, ``latdyn_advance`` through ctypes, which releases the
    interpreter's lock), so the import runs on another core meanwhile. Where the caller's thread
    imports h5py before the thread is done, it waits for that import (Python's module lock), as it
    would for its own. A failed import here says nothing: the one where h5py is used reports it."""
    if h5py is None or "h5py" in sys.modules:
        return

    def quietly() -> None:
        try:
            importlib.import_module("h5py")
        except BaseException:  # noqa: BLE001 - the import where h5py is used raises it again
            pass

    threading.Thread(target=quietly, name="latdyn-import-h5py", daemon=True).start()


def atomic_write_bytes(path: Path, data: bytes, fsync: bool = True) -> None:
    """Write ``data`` to ``path`` so that the file is either the old or the new one."""
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        if fsync:
            os.fsync(f.fileno())
    os.replace(tmp, path)


def fsync_path(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def json_safe(value):
    """Plain JSON types; numpy scalars/arrays converted, non-finite floats -> None."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        value = float(value)
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, Path):
        return str(value)
    return str(value)


def csv_line(fields) -> str:
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow(fields)
    return buffer.getvalue()


def format_float(value) -> str:
    return repr(float(value))
