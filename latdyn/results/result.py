"""A run's result: :class:`Result`, what a run recorded, in memory (from
:meth:`latdyn.results.writer.ResultWriter.result`) or read back from its results folder
(:meth:`Result.load`: ``probes.csv``, ``summary.json``, ``modes.csv``, ``sensitivities.csv``); and the state history of a
folder with its labels (:func:`load_state_history`, :func:`load_state_labels`). The formats: the
modules that write them, :mod:`latdyn.results.probes_csv`, :mod:`latdyn.results.summary`,
:mod:`latdyn.results.modes_csv`, :mod:`latdyn.results.state_history`."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from latdyn.errors import ResultsError
from latdyn.results.modes_csv import MODES_FILE
from latdyn.results.probes_csv import PROBES_FILE
from latdyn.results.state_history import LABELS_KEY, STATE_H5_FILE, STATE_NPZ_FILE
from latdyn.results.summary import SUMMARY_FILE

#: written by latdyn/analyses/sensitivities.py (a later layer): ``load_factor|t,<probe>/<NAME>,…``
SENSITIVITIES_FILE = "sensitivities.csv"



def _h5py():
    """h5py, imported when a state.h5 is read (a run writes its HDF5 files without it:
    :mod:`latdyn.results.hdf5_writer`); None where it is not installed (only state.npz can be read)."""
    try:
        import h5py
    except ImportError:  # pragma: no cover - exercised by monkeypatching in the tests
        return None
    return h5py

__all__ = ["Result", "load_state_history", "load_state_labels"]


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
    sensitivities : dict[tuple[str, str], np.ndarray]
        ``(probe, parameter)`` -> d(probe)/d(parameter) over the rows, for a run with
        ``solve.sensitivities`` (``sensitivities.csv``; latdyn/analyses/sensitivities.py); else empty.
    """

    def __init__(self, t, probes, summary=None, out_dir=None, modes=None, first_column="t"):
        self.t = np.asarray(t, dtype=float)
        self.probes = {str(k): np.asarray(v, dtype=float) for k, v in probes.items()}
        self.summary = dict(summary or {})
        self.out_dir = None if out_dir is None else str(out_dir)
        self.modes = None if modes is None else np.asarray(modes, dtype=float)
        self.first_column = first_column
        self.sensitivities: dict = {}

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
        result = cls(t, probes, summary=summary, out_dir=str(folder), modes=modes, first_column=first_column)
        if (folder / SENSITIVITIES_FILE).is_file():
            _, _, columns = _read_probes(folder / SENSITIVITIES_FILE)
            result.sensitivities = {tuple(name.rsplit("/", 1)): values for name, values in columns.items()}
        return result


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
    if h5_path.is_file() and _h5py() is None:
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
        with _h5py().File(h5_path, "r") as f:
            return {name: f[name][()] for name in f.keys()}
    if npz_path.is_file():
        with np.load(npz_path) as f:
            return {name: f[name] for name in f.files if name != LABELS_KEY}
    raise ResultsError(f"{folder}: no state history ({STATE_H5_FILE} or {STATE_NPZ_FILE})")


def load_state_labels(out_dir) -> dict:
    """The labels of a state history: ``{"columns": {key: [label per column]}, name:
    [...] for each file attribute given as ``attributes`` (``nodes``, ``hinges``,
    ``coordinates`` for a run)}``; ``{"columns": {}}`` for a file without labels."""
    folder = Path(out_dir)
    h5_path, npz_path = _state_paths(folder)
    if h5_path.is_file():
        with _h5py().File(h5_path, "r") as f:
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
