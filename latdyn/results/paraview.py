"""The ParaView output of a run: one transient VTKHDF file per part (SCENE.md, ``output.paraview_every``).

What is drawn (:func:`parts`, :func:`frame`, for a run built by :mod:`latdyn.solve`):

- ``beams``: the beam grid points, shared by consecutive elements (one point per model node
  and grid offset, so a beam of n elements is a polyline of n + 1 points; an end at an offset
  from its joint body is its own point), line cells = the elements, then one line per rigid
  link (``rigid: true``) from its start grid point to its end grid point. Point data
  ``displacement`` (from t = 0) and ``velocity`` (v + ω × T r_g), both (n_points, 3); cell
  data ``axial_force``, ``torque``, ``moment_y``, ``moment_z`` (mid-element section forces,
  the values of the ``{element: ...}`` probes; NaN on rigid links, which have none),
  ``beam`` (index in scene order) and ``rigid`` (1 on rigid links, else 0).
- ``bodies``: every joint body (fixed, prescribed, free, or placed by a rigid link; with or
  without mass) as a vertex cell at its reference point, and a line cell from the body's
  reference point to each beam or rigid-link grid point at an offset from it (the joint's
  lever arm). Point data ``displacement``, ``velocity``, ``angular_velocity`` (of the body)
  and ``axis_x``, ``axis_y``, ``axis_z`` (the body axes, for glyphs); cell data ``body``
  (index in scene order, also on its connector lines), ``mass`` (0 on connector lines) and
  ``kind`` (0 free, 1 prescribed, 2 fixed, 3 placed by a rigid link).

- ``cables``: the cables' points (ends and inner nodes), one line cell per cable element; point data
  ``displacement`` and ``velocity``; cell data ``tension`` (N of each element, 0 while slack) and
  ``cable`` (index in scene order).

A part without cells (a scene without beams has no ``beams``) is skipped: it has no file.

How it is written (:class:`ParaviewWriter`): ``OUT/paraview/<part>.vtkhdf``, one HDF5 file
per part in VTK's VTKHDF format (``Version`` [2, 0], ``Type`` ``UnstructuredGrid``, transient;
read natively by ParaView >= 5.12 and VTK's ``vtkHDFReader``), written by latdyn's own HDF5 writer
(:mod:`latdyn.results.hdf5_writer`, as h5py would write it with HDF5's earliest object format):

``/VTKHDF`` (attributes ``Version``, ``Type``)
    ``NumberOfPoints``, ``NumberOfCells``, ``NumberOfConnectivityIds`` (1,): the one piece,
    stored once; ``Types`` (n_cells,) uint8 (1 vertex, 3 line), ``Connectivity``,
    ``Offsets`` (n_cells + 1,): the cells, stored once (the mesh does not change).
    ``Points`` (n_frames · n_points, 3): frame after frame. ``PointData/<name>``
    (n_frames · n_points[, k]) likewise; ``CellData/<name>`` (n_frames · n_cells[, k]) for
    what changes (section forces), (n_cells,) stored once for what does not (``beam``,
    ``rigid``, ``body``, ``mass``, ``kind``).
``/VTKHDF/Steps`` (attribute ``NSteps``)
    ``Values`` (n_frames,) the recorded times (exact float64, as in ``probes.csv``);
    ``PartOffsets`` 0 and ``NumberOfParts`` 1 (every step reads the one piece);
    ``PointOffsets`` k · n_points; ``CellOffsets``, ``ConnectivityIdOffsets`` (n_frames, 1) 0
    (the stored cells); ``PointDataOffsets/<name>`` k · n_points; ``CellDataOffsets/<name>``
    k · n_cells, or 0 for the arrays stored once. Offset datasets with equal contents are one
    dataset under several names (HDF5 hard links), so a frame resizes few datasets.

Frames are written in blocks: the first creates the file (under a temporary name, flushed, then
renamed and kept open for appending), later ones gather in memory and
are appended and flushed (:meth:`latdyn.results.hdf5_writer.File.flush`) every :data:`FRAME_BLOCK` frames or
:data:`FRAME_BLOCK_SECONDS`, at every checkpoint and at close (one write a dataset per block:
~0.2 ms a frame less than one at a time; the default
~200 frames of a short run go in one; the frames of a block of rows recorded where the step runs
come as one :class:`FrameBlock` and are gathered as one piece), so a Ctrl-C or a solver failure (which close the
file) leave every recorded frame, and a kill at any moment a complete, readable file of
the frames up to the last flushed block (at most the last second's frames lost): a flush writes the
file's metadata where the current one is not and rewrites the superblock last. Nothing locks the
files, so ParaView can open them while a run goes on. *Resuming* writes a part's file anew with the
bookmark's frames (read through h5py) and renames it over the old one.

*Which frames:* with ``every`` (seconds; ``output.paraview_every``) a record carries a frame
when its time reaches the next multiple of ``every`` (the first row at or after k · every);
``every=None`` writes every record's frame, ``every=0`` none. The frame of the last record is
always written, at :meth:`ParaviewWriter.close` if the schedule skipped it (so the frame at
``t_end`` is in the files, and the last recorded one of a failed run). :func:`default_every`
is the package's choice: about :data:`DEFAULT_FRAMES` frames per run, snapped to the rows.

*Resuming* (:meth:`ParaviewWriter.bookmark`, ``resume=``): the files are cut back to the
frames of the bookmark and appended to, and the schedule continues from the bookmark's
counts, so the finished files hold what an uninterrupted run's hold.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from latdyn.results import hdf5_writer

__all__ = ["ParaviewWriter", "normalise_mesh", "parts", "frame", "frames", "default_every", "part_file",
           "PARAVIEW_DIR", "VTKHDF_VERSION", "DEFAULT_FRAMES"]

PARAVIEW_DIR = "paraview"
#: The VTKHDF version written: 2.0 holds transient unstructured grids (VTK >= 9.3, ParaView >= 5.12).
VTKHDF_VERSION = (2, 0)
#: About this many frames per run by default (:func:`default_every`).
DEFAULT_FRAMES = 200
#: frames gathered before they are appended to the files in one write (module docstring): at most
#: this many, or the frames of this many seconds (a run's writer also appends them at its
#: checkpoints of the state history, at most once a second: results.writer.RUN_CHECKPOINT_MIN_SECONDS)
FRAME_BLOCK = 256
FRAME_BLOCK_SECONDS = 1.0
#: VTK cell type numbers (vtkCellType.h) of the cell blocks a mesh may name.
CELL_TYPES = {"vertex": 1, "line": 3, "triangle": 5, "quad": 9, "tetra": 10, "hexahedron": 12}


def part_file(part: str) -> str:
    """The file name of a part: ``beams`` → ``beams.vtkhdf``."""
    return f"{part}.vtkhdf"


def default_every(t_end: float, row_every: float, frames: int = DEFAULT_FRAMES) -> float:
    """The package's time between frames: ``t_end / frames`` rounded up to a whole number of
    row intervals ``row_every`` (at least one), so a run has at most ``frames`` + 1 frames
    and each lands on a row."""
    if not t_end > 0 or not row_every > 0:
        return row_every
    rows = max(1, math.ceil(t_end / frames / row_every - 1e-9))
    return rows * row_every


# ----------------------------------------------------------------------------- the parts of a run
def parts(model, state) -> dict:
    """The ParaView parts of a model (module docstring) at ``state`` (t = 0).

    Returns ``{part: {"n_points", "cells": [(type, (n, k) int array)], "cell_data": {name:
    (n_cells,)} (constant), "node": (n_points,), "offset": (n_points, 3) r_g in node axes,
    "p0": (n_points, 3) positions in ``state``}}``; ``beams`` also has ``"elements"``, the
    number of its cells that are beam elements (the rest are rigid links)."""
    scene = model.scene
    ends = [model.element_nodes.reshape(-1)]
    offsets = [model.element_offsets.reshape(-1, 3)]
    cell_beam = [model.element_beam]
    for name, beam in scene.beams.items():  # rigid links: a line from start to end grid point
        if not beam.rigid:
            continue
        link = int(model.beam_nodes[name][0])
        start_offset, end_offset = model.beam_grid_offsets[name]
        start = ((model.body_node[beam.start.body], beam.start.offset) if beam.start.body is not None
                 else (link, start_offset))
        end = ((model.body_node[beam.end.body], beam.end.offset) if beam.end.body is not None
               else (link, end_offset))  # the same point as the link's end (latdyn.model.links, edge)
        ends.append(np.array([start[0], end[0]], dtype=np.int64))
        offsets.append(np.array([start[1], end[1]], dtype=float).reshape(2, 3))
        cell_beam.append([name])
    ends, offsets = np.concatenate(ends).astype(np.int64), np.concatenate(offsets)
    cell_beam = [b for block in cell_beam for b in block]
    n_elements = len(model.element_nodes)

    def positions(nodes, r):
        return state.x[nodes] + np.einsum("nij,nj->ni", state.T[nodes], r)

    mesh = {}
    if len(ends):
        _, first, inverse = np.unique(np.column_stack([ends, offsets]), axis=0, return_index=True,
                                      return_inverse=True)
        order = np.argsort(first)  # points in order of first use: a beam's points run start → end
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        node, offset = ends[first[order]], offsets[first[order]]
        beam_index = {name: i for i, name in enumerate(scene.beams)}
        lines = rank[inverse.reshape(-1)].reshape(-1, 2)
        mesh["beams"] = {
            "n_points": len(node), "cells": [("line", lines)], "elements": n_elements,
            "node": node, "offset": offset, "p0": positions(node, offset),
            "cell_data": {"beam": np.array([beam_index[b] for b in cell_beam], dtype=np.int64),
                          "rigid": (np.arange(len(lines)) >= n_elements).astype(np.int64)},
        }
    else:
        node, offset = np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    names = list(model.body_node)
    if names:
        body_nodes = np.array([model.body_node[b] for b in names], dtype=np.int64)
        body_of_node = np.full(len(model.nodes), -1, dtype=np.int64)
        body_of_node[body_nodes] = np.arange(len(names))
        arm = (body_of_node[node] >= 0) & np.any(offset != 0.0, axis=1)
        n_b, n_c = len(names), int(arm.sum())
        points_node = np.concatenate([body_nodes, node[arm]])
        points_offset = np.concatenate([np.zeros((n_b, 3)), offset[arm]])
        cell_body = np.concatenate([np.arange(n_b), body_of_node[node[arm]]])
        mass = np.array([scene.bodies[b].mass for b in names], float)
        mesh["bodies"] = {
            "n_points": n_b + n_c,
            "cells": [("vertex", np.arange(n_b).reshape(-1, 1)),
                      ("line", np.column_stack([body_of_node[node[arm]], n_b + np.arange(n_c)]))],
            "node": points_node, "offset": points_offset, "p0": positions(points_node, points_offset),
            "cell_data": {"body": cell_body, "mass": np.concatenate([mass, np.zeros(n_c)]),
                          "kind": np.array([model.nodes[i].kind for i in body_nodes[cell_body]], dtype=np.int64)},
        }
    cables = model.cables
    if cables is not None:
        node, offset = cables.nodes.reshape(-1), cables.offsets.reshape(-1, 3)
        _, first, inverse = np.unique(np.column_stack([node, offset]), axis=0, return_index=True,
                                      return_inverse=True)
        order = np.argsort(first)
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        mesh["cables"] = {
            "n_points": len(order), "cells": [("line", rank[inverse.reshape(-1)].reshape(-1, 2))],
            "node": node[first[order]], "offset": offset[first[order]],
            "p0": positions(node[first[order]], offset[first[order]]),
            "cell_data": {"cable": cables.cable.copy()},
        }
    return mesh


def frame(assembler, mesh: dict, state, kernel_sections=None) -> dict:
    """One ParaView frame of ``state`` for the parts of :func:`parts` (vectorized): ``{part:
    {"points", "point_data", "cell_data"}}`` with the cell data that changes (section forces;
    ``kernel_sections``: the strain-energy kernel's at ``state`` when computed already, a row
    recorded where the step runs)."""
    from latdyn.results.probes import SECTION_QUANTITIES, section_forces

    assembler.complete_links(state)
    out = {}
    for name, part in mesh.items():
        nodes = part["node"]
        R = state.T[nodes]
        r = np.einsum("nij,nj->ni", R, part["offset"])  # T r_g
        points = state.x[nodes] + r
        point_data = {"displacement": points - part["p0"], "velocity": state.v[nodes] + np.cross(state.w[nodes], r)}
        cell_data = {}
        if name == "beams":
            n_cells = len(part["cells"][0][1])
            forces = np.full((n_cells, len(SECTION_QUANTITIES)), np.nan)
            if part["elements"]:
                forces[: part["elements"]] = section_forces(assembler, state, kernel_sections=kernel_sections)
            cell_data.update(zip(SECTION_QUANTITIES, forces.T))
        elif name == "cables":
            cell_data["tension"] = assembler.native().cable_state(state)[:, 4]
        else:
            point_data.update(angular_velocity=state.w[nodes], axis_x=R[:, :, 0], axis_y=R[:, :, 1], axis_z=R[:, :, 2])
        out[name] = {"points": points, "point_data": point_data, "cell_data": cell_data}
    return out


def frames(assembler, mesh: dict, states, kernel_sections=None) -> "FrameBlock | None":
    """:func:`frame` of several states at once: ``states`` a State whose arrays have a leading row
    axis (a block of rows recorded where the step runs), ``kernel_sections`` their strain-energy
    kernel's section forces (rows, elements, 4) or None. The same arrays to the last bit (the same
    operations, row by row along the leading axis) without one pass of Python a frame. None for a
    model whose frames need a state at a time (cables' tensions). Rigid links' dependent nodes need no
    completing here: the loop's step completed them in C before it recorded the row (csrc/links.c), as
    :func:`frame`'s ``complete_links`` would again, to the same bits."""
    from latdyn.results.probes import SECTION_QUANTITIES, section_forces

    if "cables" in mesh:
        return None
    m = len(states.t)
    parts = {}
    for name, part in mesh.items():
        nodes = part["node"]
        R = states.T[:, nodes]
        r = np.einsum("mnij,nj->mni", R, part["offset"])  # T r_g, as frame() row by row
        points = states.x[:, nodes] + r
        point_data = {"displacement": points - part["p0"], "velocity": states.v[:, nodes] + np.cross(states.w[:, nodes], r)}
        cell_data = {}
        if name == "beams":
            forces = np.full((m, len(part["cells"][0][1]), len(SECTION_QUANTITIES)), np.nan)
            if part["elements"]:
                forces[:, : part["elements"]] = section_forces(assembler, None, kernel_sections=kernel_sections) \
                    if kernel_sections is not None else \
                    [section_forces(assembler, _row(states, j)) for j in range(m)]
            cell_data = {q: forces[:, :, k] for k, q in enumerate(SECTION_QUANTITIES)}
        else:
            point_data.update(angular_velocity=states.w[:, nodes], axis_x=R[..., 0], axis_y=R[..., 1], axis_z=R[..., 2])
        parts[name] = {"points": points, "point_data": point_data, "cell_data": cell_data}
    return FrameBlock(m, parts)


class FrameBlock:
    """The frames of :func:`frames`: ``parts`` ``{part: {"points", "point_data", "cell_data"}}`` whose
    arrays have a leading frame axis, written by :meth:`ParaviewWriter.record_rows` as one block; a
    sequence of frames too (``block[j]``: frame j as :func:`frame` gives it, views of the arrays)."""

    def __init__(self, count: int, parts: dict):
        self.count, self.parts = count, parts

    def __len__(self) -> int:
        return self.count

    def __getitem__(self, j: int) -> dict:
        if not -self.count <= j < self.count:
            raise IndexError(j)
        return {name: {"points": part["points"][j], "point_data": {k: a[j] for k, a in part["point_data"].items()},
                       "cell_data": {k: a[j] for k, a in part["cell_data"].items()}}
                for name, part in self.parts.items()}


def _frames_slice(block: dict, start: int, stop: int) -> dict:
    """A part's frames ``start`` to ``stop`` of a block (arrays with a leading frame axis; views)."""
    return {"points": block["points"][start:stop],
            "point_data": {k: a[start:stop] for k, a in block["point_data"].items()},
            "cell_data": {k: a[start:stop] for k, a in block["cell_data"].items()}}


def _row(states, j: int):
    """Row ``j`` of a State with a leading row axis."""
    from latdyn.assembly.assembler import State
    from latdyn.assembly.native_model import STATE_FIELDS

    return State(float(states.t[j]), *(getattr(states, name)[j] for name in STATE_FIELDS))


def normalise_mesh(mesh: dict) -> dict:
    """``{part: {"n_points": int, "cells": [(cell type, int array (n, k)), ...], "n_cells": int,
    "cell_data": {name: (n_cells,) or (n_cells, k)}}}`` (the constant cell data, stored once);
    the legacy form ``{"lines": (n, 2), "n_nodes": int}`` is the part ``beams``. Other keys of a
    part are ignored (the caller may keep its own data there)."""
    if "lines" in mesh and "n_nodes" in mesh:
        mesh = {"beams": {"n_points": mesh["n_nodes"], "cells": [("line", mesh["lines"])]}}
    out = {}
    for name, part in mesh.items():
        name = str(name)
        if not name.replace("_", "").isalnum():
            raise ValueError(f"mesh part name {name!r}: letters, digits and '_' only")
        n_points = int(part["n_points"])
        cells = []
        for cell_type, connectivity in part["cells"]:
            if cell_type not in CELL_TYPES:
                raise ValueError(f"mesh part {name!r}: cell type {cell_type!r}, expected one of {sorted(CELL_TYPES)}")
            array = np.asarray(connectivity, dtype=np.int64)
            if array.ndim == 1:
                array = array.reshape(-1, 1)
            if array.ndim != 2:
                raise ValueError(f"mesh part {name!r}: {cell_type} cells must be an (n, k) array")
            if not len(array):
                continue  # an empty block (no connector lines, say)
            if array.min() < 0 or array.max() >= n_points:
                raise ValueError(f"mesh part {name!r}: cells refer to points outside 0 .. {n_points - 1}")
            cells.append((str(cell_type), array))
        n_cells = sum(len(c) for _, c in cells)
        cell_data = {}
        for key, value in (part.get("cell_data") or {}).items():
            array = np.asarray(value)
            if array.ndim not in (1, 2) or array.shape[0] != n_cells:
                raise ValueError(f"cell data {key!r} of {name!r} has shape {array.shape}, "
                                 f"expected ({n_cells},) or ({n_cells}, k)")
            cell_data[str(key)] = array
        out[name] = {"n_points": n_points, "cells": cells, "n_cells": n_cells, "cell_data": cell_data}
    return out


def _vertices(frame_: dict) -> dict:
    """Parts of a frame given without a mesh: the points of each part as vertices."""
    out = {}
    for name, data in frame_.items():
        n = len(np.asarray(data["points"]).reshape(-1, 3))
        out[str(name)] = {"n_points": n, "cells": [("vertex", np.arange(n).reshape(-1, 1))]}
    return normalise_mesh(out)


# ----------------------------------------------------------------------------- one file
class _PartFile:
    """The transient VTKHDF file of one part, open for appending (module docstring), written by
    :mod:`latdyn.results.hdf5_writer`."""

    def __init__(self, path: Path, part: dict, keep: int | None = None):
        self.path = path
        self.n_points, self.n_cells = part["n_points"], part["n_cells"]
        self.static = dict(part["cell_data"])
        self._pending: list = []  # blocks of frames appended, not yet in the file (append_block)
        self._pending_frames = 0  # the frames they hold
        self._written_at = time.perf_counter()
        self.file = None  # created at the first frame, when the arrays' names and shapes are known
        self.steps = 0
        self._part = part
        if keep is not None:  # resuming: the first `keep` frames stay
            self._rewrite(keep)

    def _rewrite(self, keep: int) -> None:
        """Resume: the file written anew with its first ``keep`` frames (read through h5py), renamed
        over the old one; kept open."""
        import h5py

        try:
            old = h5py.File(self.path, "r", locking=False)
        except OSError as exc:
            raise _resume_error(self.path, f"unreadable ({exc})") from exc
        with old:
            try:
                root = old["VTKHDF"]
                on_disk = int(root["Steps"].attrs["NSteps"])
                first = {"point_data": {name: root["PointData"][name][:1] for name in root["PointData"]},
                         "cell_data": {name: root["CellData"][name][:1] for name in root["CellData"]
                                       if name not in self.static}}
            except (KeyError, ValueError) as exc:
                raise _resume_error(self.path, f"unreadable ({exc})") from exc
            if on_disk < keep:
                raise _resume_error(self.path, f"it has {on_disk} frames, the checkpoint recorded {keep}")
            self._create(first, rename=False)
            p, c = self.n_points, self.n_cells
            frames = {"points": root["Points"][: keep * p].reshape(keep, p, 3),
                      "point_data": {n: root["PointData"][n][: keep * p].reshape(keep, p, *root["PointData"][n].shape[1:])
                                     for n in self._point_data},
                      "cell_data": {n: root["CellData"][n][: keep * c].reshape(keep, c, *root["CellData"][n].shape[1:])
                                    for n in self._cell_data}}
            times = list(root["Steps"]["Values"][:keep])
        if keep:
            self._pending, self._pending_frames = [(times, frames)], keep
            self.write_pending(durable=True)
        else:
            self.file.flush(durable=True)
        self.file.rename(self.path)

    def append(self, t: float, data: dict) -> None:
        """Append one frame (``{"points", "point_data", "cell_data"}``, checked by the caller): the
        first creates the file; later ones gather and go to the file in blocks (:data:`FRAME_BLOCK`
        frames or :data:`FRAME_BLOCK_SECONDS`; :meth:`write_pending` at checkpoints and close)."""
        self.append_block([t], {"points": data["points"][None],
                                "point_data": {k: v[None] for k, v in data["point_data"].items()},
                                "cell_data": {k: v[None] for k, v in data["cell_data"].items()}})

    def append_block(self, times: list, block: dict) -> None:
        """Append the frames at ``times`` at once: ``block`` as a frame of :meth:`append` whose arrays
        have a leading frame axis (a block of rows' frames, :class:`FrameBlock`); the same file as
        appending them one at a time (blocks of at most :data:`FRAME_BLOCK` frames go to the file)."""
        if self.file is None:
            self._create({kind: {k: v[0] for k, v in block[kind].items()} for kind in ("point_data", "cell_data")})
            self._pending, self._pending_frames, self._written_at = [], 0, time.perf_counter()
        elif set(block["point_data"]) != set(self._point_data) or set(block["cell_data"]) != set(self._cell_data):
            raise ValueError(f"{self.path.name}: a frame with arrays {sorted(block['point_data'])} + "
                             f"{sorted(block['cell_data'])}, the file has {self._point_data} + {self._cell_data}")
        start = 0
        while start < len(times):
            stop = min(len(times), start + FRAME_BLOCK - self._pending_frames)
            part = block if start == 0 and stop == len(times) else _frames_slice(block, start, stop)
            self._pending.append((list(times[start:stop]), part))
            self._pending_frames += stop - start
            start = stop
            if self._pending_frames >= FRAME_BLOCK or time.perf_counter() - self._written_at >= FRAME_BLOCK_SECONDS:
                self.write_pending()

    def write_pending(self, durable: bool = False) -> None:
        """The frames gathered since the last write, appended in one write a dataset, then flushed."""
        self._written_at = time.perf_counter()
        if self.file is None or not self._pending:
            return
        k, m = self.steps, self._pending_frames
        for dataset, rows, value in self._growing:
            if value is None:  # the fill value: the chunks allocated hold it
                dataset.grow(m * rows)
                continue
            pieces, first = [], k
            for times, data in self._pending:
                pieces.append(np.asarray(value(data, times, first), dtype=dataset.dtype).reshape(len(times) * rows, *dataset.width))
                first += len(times)
            dataset.append(pieces[0] if len(pieces) == 1 else np.concatenate(pieces))
        self._steps.set_attribute("NSteps", np.int64(k + m))
        self.steps = k + m
        self._pending.clear()
        self._pending_frames = 0
        self.file.flush(durable)

    @property
    def frames(self) -> int:
        """Frames appended: on disk and gathered."""
        return self.steps + self._pending_frames

    def close(self) -> None:
        if self.file is not None:
            try:
                self.write_pending()
            finally:
                self.file.close()
                self.file = None

    def _create(self, first: dict, rename: bool = True) -> None:
        """The file's objects (``first``: a frame's point and cell data, their names and widths), under a
        temporary name, flushed, then renamed (``rename``) and kept open."""
        part = self._part
        self.path.parent.mkdir(parents=True, exist_ok=True)
        f = hdf5_writer.File(self.path.with_name(self.path.name + ".tmp"))
        root = f.root.create_group("VTKHDF")
        root.set_attribute("Version", np.array(VTKHDF_VERSION, dtype=np.int64))
        root.set_attribute("Type", np.bytes_("UnstructuredGrid"))  # fixed-length ASCII, as VTK writes it
        connectivity = np.concatenate([c.reshape(-1) for _, c in part["cells"]]) if part["cells"] \
            else np.zeros(0, np.int64)
        sizes = np.concatenate([np.full(len(c), c.shape[1]) for _, c in part["cells"]]) if part["cells"] \
            else np.zeros(0, np.int64)
        types = np.concatenate([np.full(len(c), CELL_TYPES[t]) for t, c in part["cells"]]) if part["cells"] \
            else np.zeros(0)
        root.create_dataset("NumberOfPoints", np.array([self.n_points], np.int64))
        root.create_dataset("NumberOfCells", np.array([self.n_cells], np.int64))
        root.create_dataset("NumberOfConnectivityIds", np.array([len(connectivity)], np.int64))
        root.create_dataset("Types", types.astype(np.uint8))
        root.create_dataset("Connectivity", connectivity.astype(np.int64))
        root.create_dataset("Offsets", np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64))
        frames_per_chunk = max(1, 4096 // max(1, self.n_points))
        p, c = self.n_points, self.n_cells

        def growing(group, name, rows, sample):
            width = np.asarray(sample, dtype=float).shape[1:]
            return group.create_growing(name, width, "f8", (max(1, rows) * frames_per_chunk, *width))

        # what grows with the frames: (dataset, rows a frame, the value of frames k, k + 1, ... of a block
        # (arrays with a leading frame axis; t the frames' times) or None for the fill value)
        self._growing = [(growing(root, "Points", p, np.zeros((1, 3))), p, lambda d, t, k: d["points"])]
        point_data = root.create_group("PointData")
        self._point_data = sorted(first["point_data"])
        for name in self._point_data:
            self._growing.append((growing(point_data, name, p, first["point_data"][name]), p,
                                  lambda d, t, k, n=name: d["point_data"][n]))
        cell_data = root.create_group("CellData")
        for name, value in self.static.items():
            cell_data.create_dataset(name, np.asarray(value))
        self._cell_data = sorted(first["cell_data"])
        for name in self._cell_data:
            self._growing.append((growing(cell_data, name, c, first["cell_data"][name]), c,
                                  lambda d, t, k, n=name: d["cell_data"][n]))
        steps = self._steps = root.create_group("Steps")
        steps.set_attribute("NSteps", np.int64(0))
        self._growing.append((steps.create_growing("Values", (), "f8", (1024,)), 1, lambda d, t, k: t))
        made = {name: steps.create_growing(name, (), "i8", (1024,), fillvalue=fill)
                for name, fill in (("PartOffsets", 0), ("NumberOfParts", 1), ("PointOffsets", 0))}
        self._growing.append((made["PointOffsets"], 1, lambda d, t, k: np.arange(k, k + len(t), dtype=np.int64) * p))
        cell_offsets = steps.create_growing("CellOffsets", (1,), "i8", (1024, 1))
        steps.link("ConnectivityIdOffsets", cell_offsets)  # both 0: hard links to one dataset
        self._growing += [(made["PartOffsets"], 1, None), (made["NumberOfParts"], 1, None), (cell_offsets, 1, None)]
        offsets = steps.create_group("PointDataOffsets")
        for name in self._point_data:
            offsets.link(name, made["PointOffsets"])
        offsets = steps.create_group("CellDataOffsets")
        changing = None
        for name in sorted([*self.static, *self._cell_data]):
            if name in self.static:
                offsets.link(name, made["PartOffsets"])  # stored once: offset 0 at every step
            elif changing is None:
                changing = offsets.create_growing(name, (), "i8", (1024,))
                self._growing.append((changing, 1, lambda d, t, k: np.arange(k, k + len(t), dtype=np.int64) * c))
            else:
                offsets.link(name, changing)
        self.file = f
        if rename:
            f.flush()  # complete on disk before it takes the file's name
            f.rename(self.path)
        del self._part


def _resume_error(path: Path, why: str):
    from latdyn.errors import ResultsError

    return ResultsError(f"{path}: cannot resume: {why}")


# ----------------------------------------------------------------------------- the writer
class ParaviewWriter:
    """Writes the frames of a run into ``folder`` (``OUT/paraview``), one file per part.

    ``mesh``: the parts (:func:`parts`, or ``{part: {"n_points", "cells", "cell_data"}}``, or
    the legacy ``{"lines", "n_nodes"}``); None: each frame's points as vertices. ``every``:
    the time between frames (module docstring; None every record, 0 none). ``resume``: a
    :meth:`bookmark` of an earlier writer of this folder."""

    def __init__(self, folder, mesh: dict | None = None, every: float | None = None, resume: dict | None = None):
        if every is not None and not every >= 0:
            raise ValueError(f"every must be None or a time >= 0, not {every!r}")
        self.folder = Path(folder)
        self.every = None if every is None else float(every)
        self._parts = None if mesh is None else normalise_mesh(mesh)
        self._files: dict[str, _PartFile] = {}
        self._next = 0  # index k of the next multiple k · every that a record's frame must reach
        self._unwritten = None  # (t, frame or callable or None) of the last record when not written
        self.frames = 0  # frames written
        if resume is not None:
            self._reopen(resume)

    # -- files
    def _part_files(self, data: dict) -> dict:
        if self._parts is None:
            self._parts = _vertices(data)
        if set(data) != set(self._parts):
            raise ValueError(f"frame has parts {sorted(data)}, the mesh has {sorted(self._parts)}")
        for name, part in self._parts.items():
            if name not in self._files and part["n_cells"] and part["n_points"]:  # an empty part has no file
                self._files[name] = _PartFile(self.folder / part_file(name), part)
        return self._files

    def _write(self, t: float, data) -> None:
        data = data() if callable(data) else data
        checked = {}
        for name, part_file_ in self._part_files(data).items():
            checked[name] = _checked(name, data[name], self._parts[name])
        for name, file in self._files.items():
            file.append(t, checked[name])
        self.frames += 1

    def _write_block(self, times: list, block: "FrameBlock") -> None:
        """The frames of a :class:`FrameBlock` at ``times``, as :meth:`_write` of each (the same files)."""
        checked = {}
        for name in self._part_files(block[0]):
            checked[name] = _checked_block(name, block, self._parts[name])
        for name, file in self._files.items():
            file.append_block(times, checked[name])
        self.frames += len(times)

    # -- recording
    def record(self, t: float, data) -> None:
        """A recorded row's frame (or a callable giving it, called only if written)."""
        if self.every == 0:
            return
        due = self.every is None or t >= self._next * self.every - 1e-9 * self.every
        if not due:
            self._unwritten = (t, data)
            return
        self._unwritten = None
        self._write(t, data)
        if self.every:
            self._next = math.floor(t / self.every + 1e-9) + 1

    def record_rows(self, times, frame_of) -> None:
        """The frames of rows at ``times``, as :meth:`record` of each: ``frame_of(r)`` gives row r's
        frame (or a callable), asked for the rows whose frame is written now and for the last row;
        where ``frame_of`` also has ``many(rows)`` (the frames of a list of rows, or None), the
        frames written are asked for together."""
        if self.every == 0 or not len(times):
            return
        due = []
        for r, t in enumerate(times):
            if self.every is None or t >= self._next * self.every - 1e-9 * self.every:
                due.append(r)
                if self.every:
                    self._next = math.floor(t / self.every + 1e-9) + 1
        many = getattr(frame_of, "many", None)
        given = many(due) if many is not None and due else None
        if isinstance(given, FrameBlock):
            self._write_block([times[r] for r in due], given)
        else:
            for k, r in enumerate(due):
                self._write(times[r], frame_of(r) if given is None else given[k])
        last = len(times) - 1
        self._unwritten = None if due and due[-1] == last else (times[last], frame_of(last))

    def reattach_last_frame(self, data) -> None:
        """Resumed: the frame (or a callable) of the bookmark's ``unwritten`` record."""
        if self._unwritten is not None:
            self._unwritten = (self._unwritten[0], data)

    def close(self) -> None:
        """Write the last record's frame when the schedule skipped it; close the files."""
        try:
            if self._unwritten is not None and self._unwritten[1] is not None:
                t, data = self._unwritten
                self._unwritten = None
                self._write(t, data)
        finally:
            for file in self._files.values():
                file.close()

    def write_pending(self) -> None:
        """Every frame recorded so far into its file (at a checkpoint: the bookmark's frames on disk)."""
        for file in self._files.values():
            file.write_pending()

    @property
    def files(self) -> list[str]:
        """The files written, relative to the results folder (``paraview/beams.vtkhdf`` first)."""
        names = sorted((n for n, f in self._files.items() if f.frames), key=lambda n: (n != "beams", n))
        return [f"{PARAVIEW_DIR}/{part_file(n)}" for n in names]

    # -- resuming
    def bookmark(self) -> dict:
        """``frames`` (written so far, in every file), ``next`` (the schedule's index) and
        ``unwritten`` (the time of the last record when its frame is not written, else None)."""
        return {"frames": self.frames, "next": self._next,
                "unwritten": None if self._unwritten is None else self._unwritten[0],
                "files": sorted(name for name, f in self._files.items() if f.frames)}

    def _reopen(self, mark: dict) -> None:
        self.frames, self._next = int(mark["frames"]), int(mark["next"])
        if mark.get("unwritten") is not None:
            self._unwritten = (float(mark["unwritten"]), None)
        listed = set(mark.get("files", ()))
        if self.folder.is_dir():  # files of parts the bookmark does not list are an interrupted run's
            for stale in self.folder.glob("*.vtkhdf*"):
                if stale.name.removesuffix(".vtkhdf") not in listed:
                    stale.unlink(missing_ok=True)
        if listed and self._parts is None:
            raise ValueError("resuming ParaView frames needs the mesh")
        for name in sorted(listed):
            path = self.folder / part_file(name)
            if not path.is_file():
                raise _resume_error(path, "the file is missing")
            self._files[name] = _PartFile(path, self._parts[name], keep=self.frames)


def _checked_block(name: str, block: "FrameBlock", part: dict) -> dict:
    """A block's part as :func:`_checked` gives each of its frames, with the leading frame axis."""
    if name not in block.parts:
        raise ValueError(f"frame has parts {sorted(block.parts)}, the mesh has {name!r}")
    return _checked_frames(name, block.parts[name], part, len(block))


def _checked(name: str, data: dict, part: dict) -> dict:
    """A frame's part as float arrays of the part's sizes."""
    framed = {"points": np.asarray(data["points"], dtype=float)[None],
              **{kind: {key: np.asarray(value, dtype=float)[None] for key, value in (data.get(kind) or {}).items()}
                 for kind in ("point_data", "cell_data")}}
    out = _checked_frames(name, framed, part, 1)
    return {"points": out["points"][0], **{kind: {key: array[0] for key, array in out[kind].items()}
                                           for kind in ("point_data", "cell_data")}}


def _checked_frames(name: str, data: dict, part: dict, m: int) -> dict:
    """``m`` frames of a part (arrays with a leading frame axis) as float arrays of the part's sizes; the
    messages name one frame's shapes."""
    points = np.asarray(data["points"], dtype=float).reshape(m, -1, 3)
    if points.shape[1] != part["n_points"]:
        raise ValueError(f"frame part {name!r} has {points.shape[1]} points, the mesh has {part['n_points']}")
    out = {"points": points, "point_data": {}, "cell_data": {}}
    for kind, count in (("point_data", part["n_points"]), ("cell_data", part["n_cells"])):
        for key, value in (data.get(kind) or {}).items():
            array = np.asarray(value, dtype=float)
            if array.ndim not in (2, 3) or array.shape[:2] != (m, count):
                raise ValueError(f"{kind.replace('_', ' ')} {key!r} of {name!r} has shape {array.shape[1:]}, "
                                 f"expected ({count},) or ({count}, k)")
            if kind == "cell_data" and key in part["cell_data"]:
                raise ValueError(f"cell data {key!r} of {name!r} is constant (the mesh's); a frame may not repeat it")
            out[kind][str(key)] = array
    return out
