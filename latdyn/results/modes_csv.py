"""``modes.csv``, the natural frequencies of a modal run (SCENE.md, "Commands and results"):
header ``mode,frequency_hz`` and any further columns the run adds, one row per mode, modes
numbered from 1; numbers in the format of every result file
(:func:`latdyn.results.files.format_float`). Written atomically, once."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from latdyn.results.files import atomic_write_bytes, format_float

__all__ = ["MODES_FILE", "write_modes_csv"]

MODES_FILE = "modes.csv"


def write_modes_csv(folder: Path, frequencies_hz: np.ndarray, columns: dict) -> None:
    """Write ``folder/modes.csv``: ``frequencies_hz`` (one per mode), then ``columns``, name ->
    one value per mode, numbers or words."""

    def cell(value):
        return value if isinstance(value, str) else format_float(value)

    text = ",".join(["mode", "frequency_hz", *columns]) + "\n" + "".join(
        ",".join([str(i), format_float(f), *(cell(values[i - 1]) for values in columns.values())]) + "\n"
        for i, f in enumerate(frequencies_hz, start=1))
    atomic_write_bytes(folder / MODES_FILE, text.encode())
