"""An animation of the structure's motion from a results folder alone (``latdyn animate OUT [-o FILE]``).

Each frame of the animation is one ParaView frame of the run (:mod:`latdyn.results.structure`
reads them), drawn as :func:`latdyn.results.structure.draw_structure` draws it, on axes that hold
every frame, with the time written on it. At most ``max_frames`` frames are drawn: when the run
recorded more, they are taken evenly from the first to the last (both always included).

The format follows FILE's extension: ``.gif`` with matplotlib's ``PillowWriter`` (Pillow comes
with matplotlib: nothing to install), ``.mp4`` with matplotlib's ``FFMpegWriter``, which needs the
``ffmpeg`` program on PATH (without it the command says so and writes nothing).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from latdyn.errors import ResultsError
from latdyn.results.structure import (draw_structure, load_structure, make_axes, structure_view, time_text,
                                      update_structure)

__all__ = ["animate", "ANIMATION_FILE", "MAX_FRAMES", "FORMATS"]

#: The default file, in the results folder.
ANIMATION_FILE = "animation.gif"
#: Frames drawn at most by default (the run's ParaView frames, evenly thinned).
MAX_FRAMES = 120
#: Extensions written, and the matplotlib writer of each.
FORMATS = {".gif": "pillow", ".mp4": "ffmpeg"}


def animation_frames(count: int, max_frames: int) -> list[int]:
    """Indices of at most ``max_frames`` of ``count`` frames, evenly spread, first and last included."""
    if max_frames < 1:
        raise ResultsError(f"the number of animation frames must be at least 1, not {max_frames}")
    if count <= max_frames:
        return list(range(count))
    return sorted({int(round(i)) for i in np.linspace(0, count - 1, max_frames)})


def _writer(path: Path, fps: float):
    from matplotlib import animation

    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise ResultsError(f"{path}: cannot write an animation as {suffix or 'a file without extension'!r}; "
                           f"the file must end in {' or '.join(FORMATS)}")
    if suffix == ".gif":
        return animation.PillowWriter(fps=fps)
    if not animation.FFMpegWriter.isAvailable():
        raise ResultsError(f"{path}: writing .mp4 needs the program ffmpeg, which is not on PATH "
                           "(install ffmpeg, or write a .gif: -o FILE.gif)")
    return animation.FFMpegWriter(fps=fps, codec="h264", extra_args=["-pix_fmt", "yuv420p"])


def animate(out_dir, path=None, max_frames: int = MAX_FRAMES, fps: float = 20.0, dpi: int = 90) -> Path:
    """Write the animation of the run in ``out_dir`` to ``path`` (default ``out_dir/animation.gif``).

    Returns the path written. Raises :class:`latdyn.errors.ResultsError` naming the path for a
    missing or unreadable results folder, one without ParaView files, an extension other than
    ``.gif``/``.mp4``, or ``.mp4`` without ffmpeg; nothing is written then.
    """
    from latdyn.results.figures import agg_figure as _figure

    path = Path(path) if path is not None else Path(out_dir) / ANIMATION_FILE
    if not fps > 0:
        raise ResultsError(f"the frame rate must be > 0, not {fps}")
    writer = _writer(path, fps)  # a bad extension or no ffmpeg: said before any work
    history = load_structure(out_dir)
    if not path.parent.is_dir():
        raise ResultsError(f"{path.parent}: no such folder to write {path.name} into")
    title = _title(Path(out_dir))
    view = structure_view(history)
    figure = _figure(6.4, 5.2)
    axes = make_axes(figure, view)
    axes.set_title(title)
    frames = animation_frames(history.frames, max_frames)
    artists = draw_structure(axes, history, frames[0], view, "tab:blue")
    label = axes.text2D(0.02, 0.96, "", transform=axes.transAxes) if view.plane is None else \
        axes.text(0.02, 0.96, "", transform=axes.transAxes, va="top")
    try:
        with writer.saving(figure, str(path), dpi):
            for frame in frames:
                update_structure(artists, history, frame, view)
                label.set_text(time_text(history, frame))
                writer.grab_frame()
    except OSError as exc:
        raise ResultsError(f"{path}: cannot write the animation ({exc})") from exc
    return path


def _title(folder: Path) -> str:
    import json

    try:
        title = json.loads((folder / "summary.json").read_text(encoding="utf-8")).get("title")
    except (OSError, ValueError, AttributeError):
        title = None
    return str(title) if title else folder.name
