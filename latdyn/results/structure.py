"""Pictures of the structure from a results folder alone: ``OUT/plots/structure.png``
(``latdyn plot OUT``) and the drawing each animation frame repeats (:mod:`latdyn.results.animation`).

What is drawn comes from the ParaView files of the run (:mod:`latdyn.results.paraview`), which
hold the grid points of every frame and how they connect: ``paraview/beams.vtkhdf`` (beam
elements as line cells between consecutive grid points, so each beam is a polyline; rigid links
as line cells with cell data ``rigid`` = 1) and ``paraview/bodies.vtkhdf`` (joint bodies as vertex
cells, cell data ``kind`` 0 free, 1 prescribed, 2 fixed, 3 placed by a rigid link, and a line from a
body to each grid point at an offset from it), and ``paraview/cables.vtkhdf`` when the scene has cables
(one line cell per cable element, drawn as thin dashed lines). :func:`load_structure` reads them into a
:class:`StructureHistory`; :func:`draw_structure` draws one frame of it on matplotlib axes;
:func:`plot_structure` draws several recorded times on one picture, coloured by time.

A scene that stays in a coordinate plane (every point of every frame in it, to round-off) is
drawn in that plane; any other in 3D, seen from 15°–35° off its thinnest direction (a truss
folding about y is seen nearly side on). Axes are equal (one metre is one metre in every direction) and labelled in the scene's
units (m, s: SI in every example; a scene in other consistent units reads its own).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from latdyn.errors import ResultsError
from latdyn.results.paraview import PARAVIEW_DIR, part_file

__all__ = ["StructureHistory", "load_structure", "draw_structure", "plot_structure", "structure_view",
           "STRUCTURE_FILE", "PICTURE_TIMES"]

#: The file :func:`plot_structure` writes into the plot folder.
STRUCTURE_FILE = "structure.png"
#: How many recorded times the structure picture shows (fewer when fewer frames were recorded).
PICTURE_TIMES = 6
#: Line cells, vertex cells (vtkCellType.h).
_LINE, _VERTEX = 3, 1
#: ``kind`` of a fixed joint body in ``bodies.vtkhdf``.
_FIXED = 2


@dataclass
class StructureHistory:
    """The drawable structure of every ParaView frame of a run.

    Attributes
    ----------
    times : (n_frames,) the recorded times (load factors for a static path: ``time_label`` says).
    time_label : ``"t"`` or ``"load factor"``.
    beam_points : (n_frames, n_beam_points, 3) grid points of beams and rigid links.
    beam_segments : (n_segments, 2) point indices of each beam element.
    link_segments : (n_links, 2) point indices of each rigid link.
    body_points : (n_frames, n_body_points, 3) joint bodies' reference points and lever-arm ends.
    bodies : (n_bodies,) point index of each joint body; ``body_fixed`` (n_bodies,) bool.
    arm_segments : (n_arms, 2) lines from a joint body to a grid point at an offset from it.
    cable_points : (n_frames, n_cable_points, 3) the cables' points; ``cable_segments`` (n, 2) their elements.
    """

    times: np.ndarray
    time_label: str
    beam_points: np.ndarray
    beam_segments: np.ndarray
    link_segments: np.ndarray
    body_points: np.ndarray
    bodies: np.ndarray
    body_fixed: np.ndarray
    arm_segments: np.ndarray
    cable_points: np.ndarray | None = None
    cable_segments: np.ndarray | None = None

    @property
    def frames(self) -> int:
        return len(self.times)

    def all_points(self) -> np.ndarray:
        """Every point of every frame, (n, 3): what the axes must hold."""
        cables = [] if self.cable_points is None else [self.cable_points.reshape(-1, 3)]
        return np.concatenate([self.beam_points.reshape(-1, 3), self.body_points.reshape(-1, 3), *cables])

    def frame_index(self, t: float) -> int:
        """The recorded frame nearest to ``t``."""
        return int(np.argmin(np.abs(self.times - t)))

    def picture_frames(self, count: int = PICTURE_TIMES) -> list[int]:
        """``count`` frames evenly spread in time from the first to the last (distinct)."""
        if self.frames <= count:
            return list(range(self.frames))
        wanted = np.linspace(self.times[0], self.times[-1], count)
        return sorted({self.frame_index(t) for t in wanted})


def _read_part(path: Path) -> dict:
    import h5py

    try:
        with h5py.File(path, "r", locking=False) as f:
            root = f["VTKHDF"]
            steps = root["Steps"]
            times = np.asarray(steps["Values"][:], dtype=float)
            n_points = int(root["NumberOfPoints"][0])
            offsets = np.asarray(steps["PointOffsets"][:], dtype=np.int64).reshape(-1)
            points_all = root["Points"]
            points = np.stack([points_all[o:o + n_points] for o in offsets]) if len(offsets) else np.zeros((0, n_points, 3))
            types = np.asarray(root["Types"][:])
            cell_offsets = np.asarray(root["Offsets"][:], dtype=np.int64)
            connectivity = np.asarray(root["Connectivity"][:], dtype=np.int64)
            cell_data = {name: np.asarray(root["CellData"][name][:]) for name in ("rigid", "kind")
                         if name in root.get("CellData", {})}
    except (OSError, KeyError, ValueError, IndexError) as exc:
        raise ResultsError(f"{path}: not a readable ParaView (VTKHDF) file of latdyn ({exc})") from exc
    return {"times": times, "points": points, "types": types, "offsets": cell_offsets,
            "connectivity": connectivity, "cell_data": cell_data}


def _cells(part: dict, cell_type: int) -> tuple[np.ndarray, np.ndarray]:
    """The cells of one type as an (n, k) index array, and their positions among all cells."""
    which = np.flatnonzero(part["types"] == cell_type)
    if not len(which):
        return np.zeros((0, 2 if cell_type == _LINE else 1), dtype=np.int64), which
    starts, ends = part["offsets"][which], part["offsets"][which + 1]
    size = int(ends[0] - starts[0])
    index = starts[:, None] + np.arange(size)[None, :]
    return part["connectivity"][index], which


def load_structure(out_dir) -> StructureHistory:
    """Read the drawable structure of every ParaView frame in ``out_dir``.

    Raises :class:`latdyn.errors.ResultsError` naming the path when the folder does not exist or
    holds no ParaView files (a run with ``output.paraview_every: 0`` writes none).
    """
    folder = Path(out_dir)
    if not folder.is_dir():
        raise ResultsError(f"{folder}: no such results folder")
    beams_path = folder / PARAVIEW_DIR / part_file("beams")
    bodies_path = folder / PARAVIEW_DIR / part_file("bodies")
    if not beams_path.is_file() and not bodies_path.is_file():
        raise ResultsError(
            f"{folder}: no ParaView files ({PARAVIEW_DIR}/{part_file('beams')}, {PARAVIEW_DIR}/"
            f"{part_file('bodies')}), which hold the structure's positions; they are written by "
            "`latdyn run` unless the scene sets output.paraview_every: 0")
    beams = _read_part(beams_path) if beams_path.is_file() else None
    bodies = _read_part(bodies_path) if bodies_path.is_file() else None
    times = (beams or bodies)["times"]
    if beams is not None and bodies is not None and len(beams["times"]) != len(bodies["times"]):
        raise ResultsError(f"{folder / PARAVIEW_DIR}: the beams file has {len(beams['times'])} frames, "
                           f"the bodies file {len(bodies['times'])}; the files do not belong together")
    if not len(times):
        raise ResultsError(f"{folder / PARAVIEW_DIR}: the ParaView files hold no frames")
    empty_points = np.zeros((len(times), 0, 3))
    no_segments = np.zeros((0, 2), dtype=np.int64)
    beam_segments, link_segments = no_segments, no_segments
    if beams is not None:
        lines, which = _cells(beams, _LINE)
        rigid = beams["cell_data"].get("rigid", np.zeros(len(beams["types"]), dtype=np.int64))[which] != 0
        beam_segments, link_segments = lines[~rigid], lines[rigid]
    body_index, body_fixed, arm_segments = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=bool), no_segments
    if bodies is not None:
        vertices, which = _cells(bodies, _VERTEX)
        body_index = vertices[:, 0]
        kind = bodies["cell_data"].get("kind", np.zeros(len(bodies["types"]), dtype=np.int64))
        body_fixed = kind[which] == _FIXED
        arm_segments = _cells(bodies, _LINE)[0]
    cables_path = folder / PARAVIEW_DIR / part_file("cables")
    cables = _read_part(cables_path) if cables_path.is_file() else None
    if cables is not None and len(cables["times"]) != len(times):
        raise ResultsError(f"{folder / PARAVIEW_DIR}: the cables file has {len(cables['times'])} frames, "
                           f"the others {len(times)}; the files do not belong together")
    first_column = _first_column(folder)
    return StructureHistory(
        cable_points=cables["points"] if cables is not None else empty_points,
        cable_segments=_cells(cables, _LINE)[0] if cables is not None else no_segments,
        times=times, time_label="load factor" if first_column == "load_factor" else "t",
        beam_points=beams["points"] if beams is not None else empty_points,
        beam_segments=beam_segments, link_segments=link_segments,
        body_points=bodies["points"] if bodies is not None else empty_points,
        bodies=body_index, body_fixed=body_fixed, arm_segments=arm_segments)


def _first_column(folder: Path) -> str:
    """``t`` or ``load_factor``: the first column of ``probes.csv`` (``t`` when it cannot be read)."""
    try:
        with open(folder / "probes.csv", encoding="utf-8") as f:
            return f.readline().split(",")[0].strip() or "t"
    except OSError:
        return "t"


# ----------------------------------------------------------------------------- the view
@dataclass
class StructureView:
    """How a structure is shown: ``plane`` the two coordinate indices of a planar scene (None: 3D),
    ``lower``/``upper`` the equal-sized box every frame fits in."""

    plane: tuple[int, int] | None
    lower: np.ndarray
    upper: np.ndarray
    elevation: float = 20.0
    azimuth: float = -60.0


_AXIS_NAMES = "xyz"


def structure_view(history: StructureHistory) -> StructureView:
    """The plane a planar scene stays in (or None), and equal axes holding every frame."""
    points = history.all_points()
    if not len(points):
        return StructureView(None, -np.ones(3), np.ones(3))
    lower, upper = points.min(axis=0), points.max(axis=0)
    extent = upper - lower
    size = max(float(extent.max()), 1e-12)
    flat = [i for i in range(3) if extent[i] <= 1e-9 * size]
    plane = None
    if flat:
        # the normal is the flat axis (z before y before x when several are: a line is drawn in x-y)
        normal = flat[-1]
        plane = tuple(i for i in range(3) if i != normal)
    centre = 0.5 * (lower + upper)
    if plane is not None:
        # each in-plane axis as long as the structure is along it (at least a fifth of the largest,
        # so a straight beam keeps some height), with a margin so that points on the edge show
        half = 0.5 * np.maximum(extent, 0.2 * size) + 0.04 * size
        return StructureView(plane, centre - half, centre + half)
    # 3D: each axis as long as the structure is along it (at least a third of the largest, so a
    # flat structure keeps some depth), on the same scale; seen from off its thinnest direction
    half = 0.5 * np.maximum(extent, 0.35 * size) * 1.08
    thinnest = int(np.argmin(extent))
    elevation, azimuth = {0: (20.0, -25.0), 1: (20.0, -65.0), 2: (35.0, -60.0)}[thinnest]
    return StructureView(None, centre - half, centre + half, elevation, azimuth)


def make_axes(figure, view: StructureView, units: str = "m"):
    """Axes for ``view``: 2D in the plane of a planar scene, else 3D; equal, labelled, limited."""
    if view.plane is None:
        axes = figure.add_subplot(projection="3d")
        axes.set_xlim(view.lower[0], view.upper[0])
        axes.set_ylim(view.lower[1], view.upper[1])
        axes.set_zlim(view.lower[2], view.upper[2])
        axes.set_box_aspect(tuple(view.upper - view.lower), zoom=0.95)  # equal: a metre is a metre on every axis
        from matplotlib.ticker import MaxNLocator

        for axis in (axes.xaxis, axes.yaxis, axes.zaxis):
            axis.set_major_locator(MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10]))
        axes.view_init(elev=view.elevation, azim=view.azimuth)
        axes.set_xlabel(f"x ({units})")
        axes.set_ylabel(f"y ({units})")
        axes.set_zlabel(f"z ({units})")
        return axes
    i, j = view.plane
    axes = figure.add_subplot()
    # the box every frame fits in as data limits, grown (never cut) to fill the axes at equal scales
    axes.update_datalim([(view.lower[i], view.lower[j]), (view.upper[i], view.upper[j])])
    axes.margins(0.0)
    axes.autoscale_view()
    axes.set_aspect("equal", adjustable="datalim")
    axes.set_xlabel(f"{_AXIS_NAMES[i]} ({units})")
    axes.set_ylabel(f"{_AXIS_NAMES[j]} ({units})")
    axes.grid(True, alpha=0.3)
    return axes


def _segments(points: np.ndarray, pairs: np.ndarray, view: StructureView) -> np.ndarray:
    coords = points if view.plane is None else points[:, list(view.plane)]
    return coords[pairs]


def draw_structure(axes, history: StructureHistory, frame: int, view: StructureView, colour,
                   alpha: float = 1.0) -> list:
    """Draw frame ``frame`` on ``axes`` in ``colour``: beams as polylines through their grid
    points, rigid links as thick lines, lever arms as thin lines, joint bodies as dots (fixed
    ones as squares). Returns the artists (for an animation to update with :func:`update_structure`)."""
    from matplotlib.collections import LineCollection

    if view.plane is None:
        from mpl_toolkits.mplot3d.art3d import Line3DCollection as Collection
    else:
        Collection = LineCollection
    beam_points, body_points = history.beam_points[frame], history.body_points[frame]
    artists = {}
    cable_points = history.cable_points[frame] if history.cable_points is not None else np.zeros((0, 3))
    cable_segments = history.cable_segments if history.cable_segments is not None else np.zeros((0, 2), np.int64)
    for key, points, pairs, width in (("beams", beam_points, history.beam_segments, 1.6),
                                      ("links", beam_points, history.link_segments, 3.5),
                                      ("arms", body_points, history.arm_segments, 0.8),
                                      ("cables", cable_points, cable_segments, 0.9)):
        collection = Collection(_segments(points, pairs, view), colors=[colour], linewidths=width, alpha=alpha,
                                linestyles="dashed" if key == "cables" else "solid")
        axes.add_collection(collection)
        artists[key] = collection
    for key, chosen, marker, size in (("free_bodies", ~history.body_fixed, "o", 4.0),
                                      ("fixed_bodies", history.body_fixed, "s", 6.0)):
        coords = body_points[history.bodies[chosen]]
        if view.plane is None:
            (line,) = axes.plot(coords[:, 0], coords[:, 1], coords[:, 2], linestyle="none", marker=marker,
                                markersize=size, color="black" if key == "fixed_bodies" else colour, alpha=alpha)
        else:
            i, j = view.plane
            (line,) = axes.plot(coords[:, i], coords[:, j], linestyle="none", marker=marker, markersize=size,
                                color="black" if key == "fixed_bodies" else colour, alpha=alpha)
        artists[key] = line
    return artists


def update_structure(artists: dict, history: StructureHistory, frame: int, view: StructureView) -> None:
    """Move the artists of :func:`draw_structure` to frame ``frame``."""
    beam_points, body_points = history.beam_points[frame], history.body_points[frame]
    artists["beams"].set_segments(_segments(beam_points, history.beam_segments, view))
    artists["links"].set_segments(_segments(beam_points, history.link_segments, view))
    artists["arms"].set_segments(_segments(body_points, history.arm_segments, view))
    if history.cable_points is not None and history.cable_segments is not None:
        artists["cables"].set_segments(_segments(history.cable_points[frame], history.cable_segments, view))
    for key, chosen in (("free_bodies", ~history.body_fixed), ("fixed_bodies", history.body_fixed)):
        coords = body_points[history.bodies[chosen]]
        if view.plane is None:
            artists[key].set_data_3d(coords[:, 0], coords[:, 1], coords[:, 2])
        else:
            i, j = view.plane
            artists[key].set_data(coords[:, i], coords[:, j])


def time_text(history: StructureHistory, frame: int) -> str:
    value = history.times[frame]
    return f"t = {value:.4g} s" if history.time_label == "t" else f"load factor {value:.4g}"


def plot_structure(out_dir, path, title: str | None = None, dpi: int = 120,
                   count: int = PICTURE_TIMES, history: StructureHistory | None = None) -> Path:
    """Write the picture of the structure at ``count`` recorded times to ``path`` (a PNG).

    Earlier times are drawn fainter and underneath, the last one on top; a legend gives each
    colour's time. Raises :class:`latdyn.errors.ResultsError` as :func:`load_structure` does."""
    from matplotlib import colormaps
    from matplotlib.lines import Line2D

    from latdyn.results.figures import agg_figure as _figure

    history = history if history is not None else load_structure(out_dir)
    view = structure_view(history)
    frames = history.picture_frames(count)
    if view.plane is None:
        figure = _figure(8.5, 5.5)
    else:  # the axes' own aspect, and room for the legend beside them
        width, height = (view.upper - view.lower)[list(view.plane)]
        figure = _figure(min(max(4.0 * width / height, 3.0), 9.0) + 2.0, 5.0)
    axes = make_axes(figure, view)
    colours = colormaps["viridis"](np.linspace(0.0, 0.85, len(frames)))
    handles = []
    for rank, (frame, colour) in enumerate(zip(frames, colours)):
        alpha = 1.0 if rank == len(frames) - 1 else 0.35 + 0.5 * rank / max(len(frames) - 1, 1)
        draw_structure(axes, history, frame, view, colour, alpha=alpha)
        handles.append(Line2D([], [], color=colour, lw=2.0, label=time_text(history, frame)))
    figure.legend(handles=handles, loc="outside right center", fontsize="small", title="recorded at")
    plane = "" if view.plane is None else f" (plane {_AXIS_NAMES[view.plane[0]]}–{_AXIS_NAMES[view.plane[1]]})"
    axes.set_title((title or "structure") + plane)
    path = Path(path)
    figure.savefig(path, dpi=dpi)
    return path
