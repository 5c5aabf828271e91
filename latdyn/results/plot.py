"""Plots of a results folder (``latdyn plot OUT``): one PNG per probe, an overview, modes, and
the picture of the structure at several recorded times (:mod:`latdyn.results.structure`).

Figures are drawn on matplotlib's Agg canvas directly (``matplotlib.figure.Figure``),
never through pyplot, so plotting neither needs a display nor changes the backend of
a program that imports latdyn.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

from latdyn.errors import ResultsError
from latdyn.results.figures import agg_figure as _figure
from latdyn.results.paraview import PARAVIEW_DIR, part_file
from latdyn.results.result import Result
from latdyn.results.structure import STRUCTURE_FILE, plot_structure

__all__ = ["plot_results", "safe_file_name"]

_X_LABELS = {"t": "time t (s)", "load_factor": "load factor λ"}


def safe_file_name(name: str) -> str:
    """A probe name made safe as a file name stem (anything but ``[A-Za-z0-9_.-]`` -> ``_``)."""
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", name).strip(".")
    return stem or "probe"


def _y_label(name: str, label: str) -> str:
    """``tip (m)`` for the probe ``tip`` labelled ``"tip: position y of arm.end (m)"``; the name alone
    when the label gives no unit."""
    found = re.search(r"\(([^()]*)\)$", label)
    return f"{name} ({found.group(1)})" if found else name




def plot_results(out_dir, plot_dir=None, dpi: int = 120) -> list[Path]:
    """Write the plots of ``out_dir`` into ``plot_dir`` (default ``out_dir/plots``).

    Returns the paths written: ``<probe>.png`` for each probe, ``overview.png`` with
    every probe as a subplot, ``modes.png`` when ``modes.csv`` exists, and ``structure.png``
    (the structure at several recorded times) when the run wrote ParaView files. Raises
    :class:`latdyn.errors.ResultsError` naming the path for a missing or invalid folder.
    """
    result = Result.load(out_dir)
    target = Path(plot_dir) if plot_dir is not None else Path(out_dir) / "plots"
    try:
        target.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ResultsError(f"{target}: cannot create the plot folder ({exc})") from exc

    x = result.t
    x_label = _X_LABELS.get(result.first_column, result.first_column)
    title = result.summary.get("title")
    labels = result.summary.get("probe_labels") or {}  # "name: what it measures (unit)"
    written: list[Path] = []
    used_names: set[str] = {"overview", "modes", Path(STRUCTURE_FILE).stem}

    for name, values in result.probes.items():
        figure = _figure(7.0, 4.0)
        axes = figure.add_subplot()
        axes.plot(x, values, lw=1.2, marker="." if len(x) < 30 else None)
        axes.set_xlabel(x_label)
        label = str(labels.get(name, name))
        axes.set_ylabel(_y_label(name, label))
        axes.set_title(label + (f" — {title}" if title else ""), fontsize="medium")
        axes.grid(True, alpha=0.3)
        stem = safe_file_name(name)
        while stem in used_names:
            stem += "_"
        used_names.add(stem)
        path = target / f"{stem}.png"
        figure.savefig(path, dpi=dpi)
        written.append(path)

    if result.probes:
        n = len(result.probes)
        columns = 1 if n <= 3 else (2 if n <= 8 else 3)
        rows = math.ceil(n / columns)
        figure = _figure(5.0 * columns + 1.0, 2.4 * rows + 0.8)
        axes_grid = figure.subplots(rows, columns, sharex=True, squeeze=False)
        for index, (name, values) in enumerate(result.probes.items()):
            axes = axes_grid[index // columns][index % columns]
            axes.plot(x, values, lw=1.0)
            label = str(labels.get(name, name))
            axes.set_ylabel(_y_label(name, label))
            axes.set_title(label, fontsize="medium")
            axes.grid(True, alpha=0.3)
        for index in range(n, rows * columns):
            axes_grid[index // columns][index % columns].set_visible(False)
        for column in range(columns):
            last = max(i for i in range(n) if i % columns == column) if column < n else None
            if last is not None:
                axes_grid[last // columns][column].set_xlabel(x_label)
                axes_grid[last // columns][column].xaxis.set_tick_params(labelbottom=True)
        figure.suptitle(title or f"probes of {Path(out_dir).name}")
        path = target / "overview.png"
        figure.savefig(path, dpi=dpi)
        written.append(path)

    if result.modes is not None and result.modes.size:
        figure = _figure(7.0, 4.0)
        axes = figure.add_subplot()
        numbers = range(1, result.modes.size + 1)
        axes.bar(numbers, result.modes)
        axes.set_xlabel("mode")
        axes.set_ylabel("frequency (Hz)")
        axes.set_xticks(list(numbers))
        axes.set_title("natural frequencies" + (f" — {title}" if title else ""))
        axes.grid(True, axis="y", alpha=0.3)
        path = target / "modes.png"
        figure.savefig(path, dpi=dpi)
        written.append(path)

    if any((Path(out_dir) / PARAVIEW_DIR / part_file(part)).is_file() for part in ("beams", "bodies")):
        # (a modal run's paraview/ holds only its mode shapes, paraview/modes/: no motion to draw)
        written.append(plot_structure(out_dir, target / STRUCTURE_FILE, title=title, dpi=dpi))
    return written
