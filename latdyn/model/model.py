"""Scene → model: nodes, minimum coordinates and element connectivity.

The paper's generalized coordinates (Sec. 6) are the translations and
rotations of the joint bodies plus the hinge angles.  Here every *node* is a
rigid frame (x, T): a joint body of the scene, an interior node of a beam, or
a free beam end.  A node has 6 coordinates [d, π] (π a spatial rotation,
T ← exp(skew Δπ) T) when it moves freely, none when it is fixed or its
motion is prescribed; a hinge has one coordinate (its angle) when free, none
when its angle is prescribed or it has latched.

Element end i refers to a node, the grid-point offset r_g in node axes
(Eq. 2), the hinge (if any) with its axis a in node axes (Γ_gh e_z, Eq. 4), and
the nodal frame at θ = 0 in node axes E0 (Γ_gh Γ_ehᵀ, Eq. 17), so that
T_e = T R(a, θ) E0.  Offset compensation (Eqs. 59–62) then is exact chain rule
inside the generated kernels, which take x, T r_g, T_e and T a.

Index arrays (``element_dofs`` of shape (n_elem, 14) etc.) are built once; the
time-step path scatters with them and never loops over elements in Python.
"""
from __future__ import annotations

from dataclasses import field

import numpy as np

from latdyn.errors import SceneError
from latdyn.model.cables import add_cables
from latdyn.model.kernels import planar_variant
from latdyn.model.planar import find_plane, restrict_to_plane
from latdyn.numerics.csr import CSR
from latdyn.numerics.linalg import issparse, psd_null_direction
from latdyn.numerics.so3 import cross
from latdyn.records import record
from latdyn.scene.expressions import HingeLaw, TimeFunction
from latdyn.scene.loader import JointFriction, Scene, StopContact

#: columns of the kernels' section block (codegen/conventions.py SECTION):
#: L0 EA EIy EIz GJ rhoA rhoIy rhoIz 1/GAy 1/GAz
SECTION_WIDTH = 10

FREE, PRESCRIBED, FIXED, DEPENDENT = 0, 1, 2, 3


@record
class Node:
    """A node of the model: a body's or a beam's point, with its kind (FREE, PRESCRIBED, FIXED, DEPENDENT)."""

    name: str  # "hub", "arm.node[3]"
    position: np.ndarray  # reference point at t = 0
    kind: int  # FREE | PRESCRIBED | FIXED | DEPENDENT (follows a rigid link, latdyn.model.links)
    body: str | None = None  # scene body name
    beam: str | None = None  # for beam nodes


def lock_tolerance(at: float) -> float:
    """How near a joint's coordinate must be to a latch or stop position ``at`` to be on it (the events of
    latdyn/timeloop/events.py; the loop of steps in C reads it per hinge from the native model,
    ``hinge_event_tolerance``, made here: csrc/newton_step.c hinge_event)."""
    return 1e-7 * max(1.0, abs(at))


@record
class HingeCoordinate:
    """A hinge of the model. Its generalized force on the angle coordinate is
    f = k(θ, θ̇, t)(θ − θ_r) + c(θ, θ̇, t) θ̇ − τ(θ, θ̇, t) (laws: :class:`~latdyn.scene.expressions.HingeLaw`)."""
    beam: str
    end: str  # "start" | "end"
    node: int
    axis: np.ndarray  # in node axes (= global at t = 0)
    stiffness: HingeLaw
    damping: HingeLaw
    torque: HingeLaw | None
    angle: object  # TimeFunction | None (prescribed)
    lock_at: float | None
    rest_angle: float = 0.0
    limits: tuple[float, float] | None = None
    restitution: float = 0.0
    contact: StopContact | None = None  # the stops compliant (Hunt–Crossley), docs/contact.md
    friction: JointFriction | None = None
    #: "hinge" (revolute, θ an angle) or "guide" (prismatic, ``bodies.NAME.guide``: θ is the slide s,
    #: ``beam`` the guided body's name, ``end`` "guide"); both have the same laws and events
    kind: str = "hinge"

    @property
    def name(self) -> str:
        """The joint's name in results: ``BEAM.start|end`` for a hinge, the guided body for a guide."""
        return self.beam if self.kind == "guide" else f"{self.beam}.{self.end}"

    @property
    def conservative_spring(self) -> bool:
        """True when the spring moment depends on θ alone: its potential is
        ∫_{θ_r}^{θ} k(s)(s − θ_r) ds (:meth:`latdyn.assembly.assembler.Assembler.energies`); otherwise its
        work is counted as external work."""
        return set(self.stiffness.depends_on) <= {"theta"}

    @property
    def has_law(self) -> bool:
        """True when any coefficient is not a constant (the hinge force is then evaluated from laws)."""
        return not (self.stiffness.is_constant and self.damping.is_constant)


@record
class Model:
    """Everything the solvers need, as arrays."""

    scene: Scene
    nodes: list[Node]
    hinges: list[HingeCoordinate]
    # elements
    element_nodes: np.ndarray  # (n_elem, 2) node index of each end
    element_offsets: np.ndarray  # (n_elem, 2, 3) r_g in node axes
    element_axes: np.ndarray  # (n_elem, 2, 3) hinge axis in node axes (0 if clamped)
    element_frames0: np.ndarray  # (n_elem, 2, 3, 3) E0 in node axes
    element_hinges: np.ndarray  # (n_elem, 2) hinge index or -1
    element_sections: np.ndarray  # (n_elem, 10) L0 EA EIy EIz GJ rhoA rhoIy rhoIz 1/GAy 1/GAz (0: shear-rigid)
    element_beam: list[str]  # beam name of each element
    beam_elements: dict[str, np.ndarray]  # beam -> element indices in order
    beam_nodes: dict[str, np.ndarray]  # beam -> node indices (elements + 1)
    beam_grid_offsets: dict[str, tuple[np.ndarray, np.ndarray]]  # offsets of the end grid points
    # rigid bodies (only those with inertia)
    body_nodes: np.ndarray  # (n_b,) node index
    body_mass: np.ndarray  # (n_b,)
    body_com: np.ndarray  # (n_b, 3) in node axes
    body_inertia: np.ndarray  # (n_b, 3, 3) about the COM, node axes
    body_node: dict[str, int]  # scene body name -> node index
    locked: np.ndarray = field(default=None)  # (n_hinge,) bool
    #: (n_hinge,) bool: the locked hinges that stick by friction (latdyn.timeloop.events.stick_and_slip);
    #: they are released when their reaction exceeds the breakaway level, a latch never is
    stuck: np.ndarray = field(default=None)
    #: (n_hinge,) int8: the side (−1 lower, +1 upper) of the rigid stop a locked hinge rests on
    #: (latdyn.timeloop.events.settle_on_stops), 0 otherwise; released when its reaction would pull
    resting: np.ndarray = field(default=None)
    # coordinate numbering (rebuilt when a hinge latches)
    node_dofs: np.ndarray = field(default=None)  # (n_nodes, 6) index or -1
    hinge_dofs: np.ndarray = field(default=None)  # (n_hinge,) index or -1
    element_dofs: np.ndarray = field(default=None)  # (n_elem, 14)
    n_dofs: int = 0  # free coordinates
    n_total: int = 0  # all coordinates (free first); index n_total is a dummy for clamped ends
    free_nodes: np.ndarray = field(default=None)
    free_hinges: np.ndarray = field(default=None)
    #: planar model (``solve.planar``): the index of the plane's normal axis; its nodes carry
    #: d_i, d_j, π_n only (:mod:`latdyn.model.planar`). None: the 3D model.
    plane: int | None = None
    #: (n_elem,) angle β (rad) by which each element's section axes were turned about its x axis
    #: so that local z is the plane's normal (:func:`latdyn.model.planar.restrict_to_plane`); zeros in 3D
    section_turns: np.ndarray = field(default=None)
    plane_reason: str = ""  # why the model is (not) planar, for ``latdyn check``
    # rigid links (latdyn.model.links): None without; the dependent nodes' coordinates are numbered
    # after the free ones, and the assembly works on the first n_assembled coordinates
    links: object = None
    n_assembled: int = 0
    #: the cable elements (:class:`latdyn.model.cables.CableElements`), None without cables
    cables: object = None
    #: (n_nodes,) bool: nodes with translations only (a cable's inner and free end nodes; their
    #: rotations are no coordinates)
    translation_only: np.ndarray = field(default=None)

    # ------------------------------------------------------------------ building
    @classmethod
    def from_scene(cls, scene: Scene) -> "Model":
        nodes: list[Node] = []
        body_node: dict[str, int] = {}
        for body in scene.bodies.values():
            kind = FIXED if body.fixed else (PRESCRIBED if body.prescribed else FREE)
            body_node[body.name] = len(nodes)
            nodes.append(Node(body.name, np.array(body.at, float), kind, body=body.name))

        hinges: list[HingeCoordinate] = []
        element_nodes, offsets, axes, frames0, elem_hinges, sections, elem_beam = [], [], [], [], [], [], []
        beam_elements, beam_nodes, beam_grid_offsets = {}, {}, {}
        link_bodies = []  # (node, mass, com, inertia) of the rigid links
        edges = []
        closing = _closing_sliders(scene)
        _guides(scene, nodes, body_node, hinges, edges, skip=closing)
        for beam in scene.beams.values():
            if beam.rigid:
                _rigid_link(scene, beam, nodes, body_node, hinges, edges, link_bodies,
                            beam_elements, beam_nodes, beam_grid_offsets)
                continue
            start, end = beam.start.point, beam.end.point
            length = float(np.linalg.norm(end - start))
            x_axis = (end - start) / length
            y_axis = np.array(beam.y_axis, float)
            frame = np.column_stack([x_axis, y_axis, cross(x_axis, y_axis)])
            n = beam.elements
            ends = []
            for which, spec in (("start", beam.start), ("end", beam.end)):
                if spec.body is not None:
                    node = body_node[spec.body]
                    offset = np.array(spec.offset, float)
                else:
                    node = len(nodes)
                    nodes.append(Node(f"{beam.name}.{which}", np.array(spec.point, float), FREE, beam=beam.name))
                    offset = np.zeros(3)
                hinge_index = _add_hinge(hinges, beam.name, which, node, spec.hinge)
                ends.append((node, offset, hinge_index))
            node_list = [ends[0][0]]
            for k in range(1, n):
                node_list.append(len(nodes))
                nodes.append(Node(f"{beam.name}.node[{k}]", start + (end - start) * k / n, FREE, beam=beam.name))
            node_list.append(ends[1][0])
            first = len(element_nodes)
            section = beam.section
            row = [length / n, section.EA, section.EIy, section.EIz, section.GJ, section.rhoA,
                   section.rhoIy, section.rhoIz, *section.shear_compliances]
            for k in range(n):
                element_nodes.append((node_list[k], node_list[k + 1]))
                o1 = ends[0][1] if k == 0 else np.zeros(3)
                o2 = ends[1][1] if k == n - 1 else np.zeros(3)
                offsets.append((o1, o2))
                h1 = ends[0][2] if k == 0 else -1
                h2 = ends[1][2] if k == n - 1 else -1
                elem_hinges.append((h1, h2))
                axes.append(tuple(hinges[h].axis if h >= 0 else np.zeros(3) for h in (h1, h2)))
                frames0.append((frame, frame))
                sections.append(row)
                elem_beam.append(beam.name)
            beam_elements[beam.name] = np.arange(first, first + n)
            beam_nodes[beam.name] = np.array(node_list)
            beam_grid_offsets[beam.name] = (ends[0][1], ends[1][1])

        cable_nodes, point_masses = [], []  # translation-only nodes; (node, mass, offset) lumped cable mass

        def cable_node(name, position):
            cable_nodes.append(len(nodes))
            nodes.append(Node(name, position, FREE, beam=name.split(".")[0]))
            return len(nodes) - 1

        _check_closures(scene, nodes, edges)
        cables = add_cables(scene, body_node, cable_node, beam_nodes, beam_grid_offsets, point_masses)
        link_bodies += [(node, mass, offset, np.zeros((3, 3))) for node, mass, offset in point_masses]
        massive = [b for b in scene.bodies.values() if b.mass > 0 or np.any(b.inertia != 0)]
        links = None
        if edges:
            from latdyn.model.links import RigidLinks

            links = _tree_order(scene, edges, nodes)
            links = RigidLinks(links, [b.name for b in scene.beams.values() if b.rigid])
        model = cls(
            scene=scene, nodes=nodes, hinges=hinges,
            element_nodes=np.array(element_nodes, dtype=np.int64).reshape(-1, 2),
            element_offsets=np.array(offsets, float).reshape(-1, 2, 3),
            element_axes=np.array(axes, float).reshape(-1, 2, 3),
            element_frames0=np.array(frames0, float).reshape(-1, 2, 3, 3),
            element_hinges=np.array(elem_hinges, dtype=np.int64).reshape(-1, 2),
            element_sections=np.array(sections, float).reshape(-1, SECTION_WIDTH),
            element_beam=elem_beam, beam_elements=beam_elements, beam_nodes=beam_nodes,
            beam_grid_offsets=beam_grid_offsets,
            body_nodes=np.array([body_node[b.name] for b in massive] + [lb[0] for lb in link_bodies],
                                dtype=np.int64),
            body_mass=np.array([b.mass for b in massive] + [lb[1] for lb in link_bodies], float),
            body_com=np.array([b.com for b in massive] + [lb[2] for lb in link_bodies], float).reshape(-1, 3),
            body_inertia=np.array([b.inertia for b in massive] + [lb[3] for lb in link_bodies],
                                  float).reshape(-1, 3, 3),
            body_node=body_node, links=links, cables=cables,
        )
        model.translation_only = np.zeros(len(nodes), dtype=bool)
        model.translation_only[cable_nodes] = True
        model.locked = np.zeros(len(hinges), dtype=bool)
        model.stuck = np.zeros(len(hinges), dtype=bool)
        model.resting = np.zeros(len(hinges), dtype=np.int8)
        model.section_turns = np.zeros(len(model.element_nodes))
        normal, model.plane_reason = find_plane(scene)
        if normal is not None:
            restrict_to_plane(model, normal)
        model.number_coordinates()
        return model

    @property
    def kernel_variant(self) -> str:
        """The generated kernels this model uses: the scene's formulation, planar or 3D."""
        formulation = self.scene.solve.formulation
        return formulation if self.plane is None else planar_variant(formulation, self.plane)

    def prescribed_nodes(self) -> list[int]:
        """The indices of the nodes of prescribed bodies, in the model's order of nodes (a body's kind does not
        change over a run)."""
        return [i for i, node in enumerate(self.nodes) if node.kind == PRESCRIBED]

    def prescribed_coordinates(self) -> np.ndarray:
        """The coordinates (in the numbering now) that the prescribed motions move: each prescribed body's
        six, each prescribed hinge angle's or slide's one; the constrained ones among them (a planar model's
        out-of-plane slots are none)."""
        nodes = self.prescribed_nodes()
        hinges = [j for j, hinge in enumerate(self.hinges) if hinge.angle is not None]
        rows = np.concatenate([self.node_dofs[nodes].ravel(), self.hinge_dofs[hinges]]).astype(np.int64)
        return rows[(rows >= self.n_dofs) & (rows < self.n_total)]

    def node_slots(self) -> np.ndarray:
        """(6,) bool: which of a free node's [dx dy dz rx ry rz] are coordinates (all in 3D;
        d_i, d_j, r_n in a planar model)."""
        slots = np.ones(6, dtype=bool)
        if self.plane is not None:
            n = self.plane
            slots[[n, 3 + (n + 1) % 3, 3 + (n + 2) % 3]] = False
        return slots

    def number_coordinates(self) -> None:
        """Number the coordinates: free ones first (the :meth:`node_slots` of each free node, node
        by node, then 1 per free, unlatched hinge), then the rest (fixed, prescribed, latched,
        out of plane), so that reactions of prescribed motion can be scattered like any force."""
        n_nodes, n_hinges = len(self.nodes), len(self.hinges)
        free_node = np.array([n.kind == FREE for n in self.nodes], dtype=bool)
        free_hinge = np.array([h.angle is None for h in self.hinges], dtype=bool) & ~self.locked
        dependent = np.array([n.kind == DEPENDENT for n in self.nodes], dtype=bool)
        order_hinges = np.concatenate([np.flatnonzero(free_hinge), np.flatnonzero(~free_hinge)]).astype(np.int64)
        free_slot = free_node[:, None] & self.node_slots()[None, :]  # (n_nodes, 6)
        if self.translation_only is not None:
            free_slot[self.translation_only, 3:] = False
        self.node_dofs = np.zeros((n_nodes, 6), dtype=np.int64)
        self.hinge_dofs = np.zeros(n_hinges, dtype=np.int64)
        n_free_slots, n_free_hinges = int(free_slot.sum()), int(free_hinge.sum())
        self.n_dofs = n_free_slots + n_free_hinges
        # free node coordinates (row-major: node by node), free hinges, then the constrained ones
        self.node_dofs[free_slot] = np.arange(n_free_slots)
        self.hinge_dofs[order_hinges[:n_free_hinges]] = n_free_slots + np.arange(n_free_hinges)
        base = self.n_dofs
        # the dependent nodes of rigid links (assembled, then mapped by latdyn.model.links), then the constrained
        dependent_slot = np.repeat(dependent[:, None], 6, axis=1)
        n_dependent = int(dependent_slot.sum())
        self.node_dofs[dependent_slot] = base + np.arange(n_dependent)
        base += n_dependent
        rest_slot = ~free_slot & ~dependent_slot
        n_rest = int(rest_slot.sum())
        self.node_dofs[rest_slot] = base + np.arange(n_rest)
        base += n_rest
        rest_hinges = order_hinges[n_free_hinges:]
        self.hinge_dofs[rest_hinges] = base + np.arange(len(rest_hinges))
        self.n_total = base + len(rest_hinges)
        self.n_assembled = self.n_dofs + n_dependent
        self.free_nodes = np.flatnonzero(free_node)
        self.free_hinges = np.flatnonzero(free_hinge)
        n_elem = len(self.element_nodes)
        dofs = np.zeros((n_elem, 14), dtype=np.int64)
        for end, base_col in ((0, 0), (1, 7)):
            dofs[:, base_col:base_col + 6] = self.node_dofs[self.element_nodes[:, end]]
            h = self.element_hinges[:, end]
            # a clamped end has no hinge: its θ slot points at a dummy coordinate past the end
            padded = np.append(self.hinge_dofs, self.n_total)
            dofs[:, base_col + 6] = padded[np.where(h >= 0, h, len(self.hinge_dofs))]
        self.element_dofs = dofs

    # ------------------------------------------------------------------ naming
    def dof_names(self) -> list[str]:
        """A readable name for every coordinate, for diagnostics."""
        names = [""] * (self.n_total + 1)
        labels = ["dx", "dy", "dz", "rx", "ry", "rz"]
        for i, node in enumerate(self.nodes):
            for k in range(6):
                names[self.node_dofs[i, k]] = f"{node.name}:{labels[k]}"
        for k, hinge in enumerate(self.hinges):
            names[self.hinge_dofs[k]] = f"{hinge.kind} {hinge.name}"
        return names[: self.n_dofs]

    def size_report(self) -> str:
        """What the model carries and why (``latdyn check``).

        Coordinates per kind (node translations, node rotations, hinge angles), the nodes they
        belong to, and what was removed: 6 per fixed or prescribed body, 1 per prescribed hinge
        angle or latched hinge. ``latdyn check`` adds :func:`latdyn.analyses.check.dynamics_report`.
        """
        n_free = len(self.free_nodes)
        free_guides = sum(1 for k in self.free_hinges if self.hinges[k].kind == "guide")
        free_hinges = len(self.free_hinges) - free_guides
        n_guides = sum(1 for h in self.hinges if h.kind == "guide")
        slots = self.node_slots()
        translations, rotations = int(slots[:3].sum()), int(slots[3:].sum())
        own = self.translation_only if self.translation_only is not None else np.zeros(len(self.nodes), bool)
        n_own = int(own[self.free_nodes].sum())  # a cable's own nodes: translations only
        lines = [
            f"model: {len(self.nodes)} nodes ({n_free} free), {len(self.element_nodes)} elements, "
            f"{len(self.hinges) - n_guides} hinges ({free_hinges} with a coordinate), "
            + (f"{n_guides} guides ({free_guides} with a coordinate), " if n_guides else "")
            + f"{self.n_dofs} coordinates",
            f"  coordinates: {translations * n_free} node translations + {rotations * (n_free - n_own)} node rotations "
            f"+ {free_hinges} hinge angles" + (f" + {free_guides} slides" if n_guides else "") + f" = {self.n_dofs}",
            f"  planar: {self.plane_reason}",
        ]
        bodies = [n for n in self.nodes if n.body is not None]
        link_nodes = [n for n in self.nodes if n.body is None and n.beam in _rigid_names(self.scene)]
        interior = sum(1 for i, n in enumerate(self.nodes) if n.body is None and ".node[" in n.name and not own[i])
        free_ends = sum(1 for i, n in enumerate(self.nodes) if n.body is None and n.beam is not None
                        and ".node[" not in n.name and not own[i]) - len(link_nodes)
        lines.append(f"  nodes: {len(bodies)} joint bodies, {interior} interior beam nodes, "
                     f"{free_ends} free beam ends" + (f", {len(link_nodes)} rigid-link nodes" if link_nodes else "")
                     + (f", {int(own.sum())} cable nodes (translations only)" if own.any() else "")
                     + f"; {int(slots.sum())} coordinates per free node")
        fixed = [n.name for n in self.nodes if n.kind == FIXED]
        prescribed = [n.name for n in self.nodes if n.kind == PRESCRIBED]
        prescribed_angles = [h.name for h in self.hinges if h.angle is not None and h.kind == "hinge"]
        prescribed_slides = [h.name for h in self.hinges if h.angle is not None and h.kind == "guide"]
        latched = [h.name for k, h in enumerate(self.hinges) if self.locked[k]]
        out_of_plane = [self.nodes[i].name for i in self.free_nodes] if self.plane is not None else []
        removed = [(6, "fixed bodies", fixed), (6, "prescribed bodies", prescribed),
                   (1, "prescribed hinge angles", prescribed_angles), (1, "prescribed slides", prescribed_slides),
                   (1, "latched joints", latched),
                   (3, "free nodes out of plane", out_of_plane)]
        parts = [f"{per * len(names)} for {len(names)} {what} ({_short(names)})"
                 for per, what, names in removed if names]
        lines.append("  removed: " + ("; ".join(parts) if parts else "none"))
        if self.links is not None:
            lines.append(self.links.report(self))
        lines.extend(self.joint_law_lines())
        return "\n".join(lines)

    def joint_law_lines(self) -> list[str]:
        """``latdyn check``'s lines on what acts at the joints and cables beyond their laws: latches and
        rigid stops (events), compliant stops (a Hunt–Crossley force, no event), friction (stick and slip
        by events) and cables (tension only, slack and taut located in time)."""
        free = [h for h in self.hinges if h.angle is None]
        latches = [h.name for h in free if h.lock_at is not None]
        rigid = [f"{h.name} (e = {h.restitution:g})" for h in free if h.limits is not None and h.contact is None]
        lines = []
        if latches or rigid:
            lines.append(f"  events: {len(latches)} joints with lock_at ({_short(latches) or '-'}), each removing its "
                         f"coordinate when it latches; {len(rigid)} joints with rigid stops ({_short(rigid) or '-'})")
        compliant = [f"{h.name} (k = {h.contact.stiffness:g}, n = {h.contact.exponent:g}, c = {h.contact.damping:g})"
                     for h in free if h.contact is not None]
        if compliant:
            lines.append(f"  compliant stops: {len(compliant)} joints ({_short(compliant)}), the force k δⁿ + c δⁿ δ̇ "
                         "past a limit, no event")
        friction = [f"{h.name} (coulomb {h.friction.coulomb:g}, static {h.friction.static:g}"
                    + (f", viscous {h.friction.viscous:g}" if h.friction.viscous else "") + ")"
                    for h in free if h.friction is not None]
        if friction:
            lines.append(f"  friction: {len(friction)} joints ({_short(friction)}), sticking and slipping by events")
        if self.cables is not None:
            cables = self.cables
            described = [f"{name} ({int(np.sum(cables.cable == i))} el, EA = {cables.EA[cables.first[i]]:g}"
                         + (f", damping {cables.damping[cables.first[i]]:g}" if cables.damping[cables.first[i]] else "")
                         + ")" for i, name in enumerate(cables.names)]
            lines.append(f"  cables: {len(described)} ({_short(described)}), tension only, slack and taut by events")
        return lines


    def hinge_index(self, beam: str, end: str) -> int:
        """The index of hinge ``beam.end``, or of the guide of body ``beam`` with ``end`` "guide"."""
        for k, hinge in enumerate(self.hinges):
            if hinge.beam == beam and hinge.end == end:
                return k
        raise KeyError(f"{beam}.{end}")

    def point(self, ref) -> tuple[int, np.ndarray]:
        """A scene point → (node, offset in node axes)."""
        if ref.body is not None and ref.beam is None:
            return self.body_node[ref.body], np.zeros(3)
        nodes = self.beam_nodes[ref.beam]
        offsets = self.beam_grid_offsets[ref.beam]
        if ref.node == 0:
            return int(nodes[0]), offsets[0]
        if ref.node == len(nodes) - 1:
            return int(nodes[-1]), offsets[1]
        return int(nodes[ref.node]), np.zeros(3)

    def check_held(self, mass, stiffness, file: str, factorization) -> None:
        """Refuse a coordinate that neither inertia nor stiffness holds (SCENE.md).

        A direction x of the free coordinates is unheld when it lies in both null
        spaces, M x = 0 and K x = 0 at rest (K the material stiffness, no load terms):
        nothing then enters the iteration matrix along x, which is singular at any
        step.  M is positive semi-definite; K is too for elastic members, but a
        controller (or a law) may give a coordinate a negative stiffness, which holds it
        as well as a positive one (a destabilising controller: the run may diverge,
        which is the physics asked for).  Each matrix is normalised by its largest
        |diagonal| and the sum A = M̂ + K̂ Jacobi-scaled (by diag M̂ + |diag K̂|), which
        makes the test blind to units and to the n⁴ spread of bending stiffness in fine
        meshes.  A coordinate with a zero diagonal in both is unheld at once; otherwise
        :func:`latdyn.numerics.linalg.psd_null_direction` (inverse iteration on one sparse
        LU, any size; for a model the dense LU serves, the exact smallest eigenpair of
        the dense A) returns the smallest Rayleigh quotient it reaches: round-off (~1e-16)
        for an unheld direction, not below λ_min(A) (but for round-off) for a held model,
        where the weakest held direction of a fine mesh still has λ ≳ 1/N² (N elements
        in a chain).  λ_min(A) > τ proves every direction held whatever the sign of K
        (an unheld x has xᵀAx = 0).  Where it is not, and K̂ may be indefinite (a negative
        diagonal, or negative along the direction found), the decision is taken again on
        M̂ + |K̂| (:func:`_sign_blind`: the same null space as M̂ and K̂ together, and for a
        positive semi-definite K̂ the same matrix), so a negative stiffness is never taken
        for none.  The direction need not be a coordinate axis (a massless body spinning
        about the axis of a hinge that carries its only beam): the coordinates with the
        largest components are named.  ``mass`` and ``stiffness`` may be dense or sparse.
        """
        n = self.n_dofs
        if n == 0:
            return
        names = self.dof_names()
        if isinstance(mass, CSR):  # both (the prepared run's check without SciPy: numerics.csr)
            M, K = _normalised_csr(mass), _normalised_csr(stiffness)
            A = _csr_sum(M, K)
            d = _held_diagonal(A, K)
            self._refuse_empty(d, names, file)
            scale = 1.0 / np.sqrt(d)
            scaled = CSR(A.shape, A.indptr, A.indices, A.data * scale[A.rows] * scale[A.indices])
            if _held_by_cholesky(scaled, factorization):
                return
        else:
            if issparse(mass) or issparse(stiffness):  # one kind for both (dense + sparse is np.matrix)
                import scipy.sparse as sps  # a model the dense LU serves runs without scipy.sparse

                mass, stiffness = sps.csr_matrix(mass), sps.csr_matrix(stiffness)
            M, K = _normalised(mass), _normalised(stiffness)
            A = M + K
            d = _held_diagonal(A, K)
            self._refuse_empty(d, names, file)
            scale = 1.0 / np.sqrt(d)
            if issparse(A):
                import scipy.sparse as sps

                scaled = (sps.diags(scale) @ A @ sps.diags(scale)).tocsc()
            else:
                scaled = scale[:, None] * A * scale[None, :]
        rho, mode = psd_null_direction(scaled, factorization, tol=HELD_TOLERANCE)
        if rho <= HELD_TOLERANCE and _maybe_indefinite(K, mode * scale):
            rho, mode = _sign_blind(M, K, factorization)
        if rho <= HELD_TOLERANCE:
            worst = [names[i] for i in np.argsort(-np.abs(mode))[:3] if abs(mode[i]) > 0.1]
            raise SceneError(file, self._key_of(worst[0]),
                             "a coordinate that nothing holds (neither inertia nor stiffness): "
                             + ", ".join(worst))

    def _refuse_empty(self, diagonal, names, file: str) -> None:
        """Refuse the coordinates with neither mass nor stiffness on their diagonal (Model.check_held)."""
        empty = np.flatnonzero(diagonal <= 1e-14)
        if len(empty):
            raise SceneError(file, self._key_of(names[empty[0]]),
                             "a coordinate that nothing holds (neither inertia nor stiffness): "
                             + ", ".join(names[i] for i in empty[:3]))

    def _key_of(self, dof_name: str) -> str:
        """The scene key a coordinate belongs to, for error messages."""
        if dof_name.startswith("guide "):
            return f"bodies.{dof_name[len('guide '):]}.guide"
        if dof_name.startswith("hinge "):
            beam, end = dof_name[len("hinge "):].rsplit(".", 1)
            return f"beams.{beam}.{end}.hinge"
        node = dof_name.split(":")[0]
        for nd in self.nodes:
            if nd.name == node:
                group = "cables" if nd.beam in self.scene.cables else "beams"
                return f"bodies.{nd.body}" if nd.body else f"{group}.{nd.beam}"
        return "bodies"


def _held_diagonal(A, K) -> np.ndarray:
    """The diagonal of M̂ + |diag K̂| (Model.check_held): diag A where K̂'s diagonal is not negative (the
    same sums as before a negative stiffness was looked for), else diag M̂ + |diag K̂|, which a negative
    stiffness does not cancel."""
    d = np.asarray(A.diagonal(), float)
    k = np.asarray(K.diagonal(), float)
    negative = k < 0.0
    if negative.any():
        d = d.copy()
        d[negative] += -2.0 * k[negative]
    return d


def _maybe_indefinite(K, x) -> bool:
    """Whether the normalised stiffness K̂ may be indefinite, so that a small xᵀ(M̂ + K̂)x does not prove
    x unheld (Model.check_held): a negative diagonal, or xᵀK̂x negative beyond round-off along the
    direction found (x in unscaled coordinates). A positive semi-definite K̂ gives neither."""
    if (np.asarray(K.diagonal(), float) < 0.0).any():
        return True
    Kx = K.matvec(x) if isinstance(K, CSR) else K @ x
    return float(x @ np.asarray(Kx).ravel()) < -1e-12 * float(x @ x)


#: Largest model whose stiffness :func:`_sign_blind` takes as a dense matrix (|K̂| by its eigenvalues);
#: above it, K̂ᵀK̂ (the same null space, its small eigenvalues squared).
SIGN_BLIND_DENSE = 4000


def _sign_blind(M, K, factorization) -> tuple[float, np.ndarray]:
    """The smallest Rayleigh quotient and its direction of the Jacobi-scaled M̂ + |K̂| (Model.check_held
    where K̂ may be indefinite): |K̂| = V|Λ|Vᵀ is positive semi-definite with K̂'s null space, so M̂ + |K̂|
    is singular exactly where a direction is in both null spaces, and a negative stiffness holds as a
    positive one does. Dense up to SIGN_BLIND_DENSE coordinates; above, K̂ᵀK̂ normalised (the same null
    space; its weakest held directions are squared, so a refusal there is checked on both)."""
    n = M.shape[0]
    if n <= SIGN_BLIND_DENSE:
        dense_M, dense_K = (m.toarray() if (isinstance(m, CSR) or issparse(m)) else np.asarray(m, float)
                            for m in (M, K))
        eigenvalues, vectors = np.linalg.eigh(0.5 * (dense_K + dense_K.T))
        B = dense_M + (vectors * np.abs(eigenvalues)) @ vectors.T
    else:
        import scipy.sparse as sps

        Ms, Ks = (sps.csr_matrix((m.data, m.indices, m.indptr), shape=m.shape) if isinstance(m, CSR)
                  else sps.csr_matrix(m) for m in (M, K))
        square = (Ks.T @ Ks).tocsr()
        top = float(np.abs(square.diagonal()).max(initial=0.0))
        B = (Ms + (square / top if top > 0 else square)).tocsr()
    d = np.asarray(B.diagonal(), float)
    if (d <= 1e-14).any():
        x = (d <= 1e-14).astype(float)
        return 0.0, x
    scale = 1.0 / np.sqrt(d)
    if issparse(B):
        import scipy.sparse as sps

        scaled = (sps.diags(scale) @ B @ sps.diags(scale)).tocsc()
    else:
        scaled = scale[:, None] * B * scale[None, :]
    return psd_null_direction(scaled, factorization, tol=HELD_TOLERANCE)


def _held_by_cholesky(scaled, factorization) -> bool:
    """Whether a banded Cholesky factorization proves every direction held (Model.check_held, before the
    inverse iteration): A − 2τ·I positive definite (τ = ``HELD_TOLERANCE``, A the Jacobi-scaled sum, unit
    diagonal) proves λ_min(A) > 2τ − e > τ (e ≲ 1e-12, the factorization's backward error:
    ``Factorization.positive_definite``), and the inverse iteration's Rayleigh quotient is never below
    λ_min, so it would not have refused either: the same decision, ≈ 0.3 ms instead of an LU and about
    ten inverse iterations (≈ 7 ms of the 16-bay lattice's start; docs/performance.md, "Seventh pass").
    False where the factorization breaks down (a direction with λ ≤ 2τ may be there: the inverse
    iteration decides and names it, as before) or where ``factorization`` offers no such test or the band
    is too wide for it (the sparse LU's models)."""
    test = getattr(factorization, "positive_definite", None)
    return test is not None and test(scaled, 2.0 * HELD_TOLERANCE) is True


def _short(names, count: int = 4) -> str:
    """The first few names, then how many more."""
    names = list(names)
    text = ", ".join(names[:count])
    return text + (f", … {len(names) - count} more" if len(names) > count else "")


def _add_hinge(hinges: list, beam: str, which: str, node: int, hinge) -> int:
    """Append the model hinge of a scene hinge (None: a clamped end) and return its index (-1 if none)."""
    if hinge is None:
        return -1
    h = hinge
    hinges.append(HingeCoordinate(beam, which, node, np.array(h.axis, float), _law(h.stiffness), _law(h.damping),
                                  None if h.torque is None else _law(h.torque), h.angle,
                                  None if h.lock_at is None else float(h.lock_at),
                                  float(h.rest_angle), h.limits, float(h.restitution), h.contact, h.friction))
    return len(hinges) - 1


def _guides(scene, nodes, body_node, hinges, edges, skip=()) -> None:
    """The sliding joints (``bodies.NAME.guide``): each guided body becomes a dependent node on a prismatic
    edge (:mod:`latdyn.model.links`) from the node of ``on`` (a fixed node at the origin, ``ground``, when
    the guide is on the ground), its slide s the coordinate of a :class:`HingeCoordinate` of kind "guide"."""
    from latdyn.model.links import Edge

    ground = None
    for body in scene.bodies.values():
        g = body.guide
        if g is None or body.name in skip:  # a slider a rigid rod closes onto: a closure edge (_closure)
            continue
        if g.on is None and ground is None:
            ground = len(nodes)
            nodes.append(Node("ground", np.zeros(3), FIXED))
        parent = ground if g.on is None else body_node[g.on]
        child = body_node[body.name]
        nodes[child].kind = DEPENDENT
        hinges.append(HingeCoordinate(body.name, "guide", child, np.array(g.axis, float), _law(g.stiffness),
                                      _law(g.damping), None if g.force is None else _law(g.force), g.position,
                                      None if g.lock_at is None else float(g.lock_at), float(g.rest), g.limits,
                                      float(g.restitution), contact=g.contact, friction=g.friction, kind="guide"))
        edges.append(Edge(parent, child, len(hinges) - 1, np.array(g.axis, float), 1.0,
                          np.asarray(body.at, float) - nodes[parent].position, np.zeros(3), body.name,
                          prismatic=True))


def _rigid_names(scene) -> set:
    return {b.name for b in scene.beams.values() if b.rigid}


def rigid_link_rows(beam) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows (ends, y_rule, section) of the generated ``rigid_link_inertia`` kernels (codegen/joints.py, "Rigid
    link's inertia") for the rigid link ``beam``: its start and end grid points at t = 0, the loader's rule for its
    ŷ (latdyn/scene/loader.py ``beam``: global Z × x̂ without a ``y_axis``, e_y less its part along x̂ for a
    vertical link, the ``y_axis`` given less its part along x̂, scaled as the loader's ``_direction`` scales it
    before its length is taken) and its section's (ρA, ρIy, ρIz)."""
    start, end = np.asarray(beam.start.point, float), np.asarray(beam.end.point, float)
    vector = end - start
    x_axis = vector / float(np.linalg.norm(vector))
    if beam.y_given is not None:
        given = np.asarray(beam.y_given, float)
        rule = [*(given / np.abs(given).max()), 0.0]
    elif np.hypot(x_axis[0], x_axis[1]) >= 1e-9:
        rule = [0.0, 0.0, 0.0, 1.0]
    else:
        rule = [0.0, 1.0, 0.0, 0.0]
    s = beam.section
    return (np.concatenate([start, end])[None], np.array([rule]), np.array([[s.rhoA, s.rhoIy, s.rhoIz]], float))


def rigid_link_inertia(beam) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass from the start grid point, inertia about it in global axes at t = 0) of the rigid
    link ``beam``, the slender rod of :func:`_rigid_link`: the generated ``rigid_link_inertia`` (codegen/joints.py,
    derived by integrating over the rod; its derivatives by the ends and by the section values are generated beside
    it: latdyn/analyses/geometry_sensitivities.py, latdyn/analyses/link_sensitivities.py)."""
    from latdyn.model.kernels import joint_kernel

    (block,) = joint_kernel("rigid_link_inertia")(*rigid_link_rows(beam))
    return float(block[0, 0]), block[0, 1:4].copy(), block[0, 4:13].reshape(3, 3).copy()


def _rigid_link(scene, beam, nodes, body_node, hinges, edges, link_bodies, beam_elements, beam_nodes,
                beam_grid_offsets) -> None:
    """Add a rigid link (:mod:`latdyn.model.links`): its link node L at the start grid point (dependent on
    the start body through the start hinge, or free when the start is a free point), its inertia
    on L, and the dependency of a body at its ``to`` end on L through the end hinge.

    Its inertia (:func:`rigid_link_inertia`, generated) is the slender rod's: mass ρA L at mid-length, about its
    centre in the link's axes (x along it, y, z of the section) diag((ρI_y + ρI_z) L, ρA L³/12 + ρI_y L,
    ρA L³/12 + ρI_z L), as codegen/joints.py derives it."""
    from latdyn.model.links import Edge

    key = f"beams.{beam.name}.rigid"
    start, end = beam.start, beam.end
    vector = end.point - start.point
    mass, centre, inertia = rigid_link_inertia(beam)
    link = len(nodes)
    closes = end.body is not None and end.body in _closing_sliders(scene)
    if closes:  # the rod of a slider-crank closing its loop: its node and the slider follow the pin (_closure)
        if start.body is None:
            raise SceneError(scene.file, key, f"rigid link {beam.name!r} closes a loop onto the guided body "
                                              f"{end.body!r} from a free end; expected it to start at a body (the pin)")
        nodes.append(Node(f"{beam.name}.link", np.array(start.point, float), DEPENDENT, beam=beam.name))
    elif start.body is not None:
        parent = body_node[start.body]
        nodes.append(Node(f"{beam.name}.link", np.array(start.point, float), DEPENDENT, beam=beam.name))
        h = _add_hinge(hinges, beam.name, "start", parent, start.hinge)
        edges.append(Edge(parent, link, h, hinges[h].axis.copy() if h >= 0 else np.zeros(3), 1.0,
                          np.array(start.offset, float), np.zeros(3), beam.name))
    else:
        nodes.append(Node(f"{beam.name}.link", np.array(start.point, float), FREE, beam=beam.name))
    link_bodies.append((link, mass, centre, inertia))
    if end.body is not None:
        child = body_node[end.body]
        node = nodes[child]
        if node.kind in (FIXED, PRESCRIBED):
            what = "fixed" if node.kind == FIXED else "prescribed"
            raise SceneError(scene.file, key, f"rigid link {beam.name!r} ends at body {end.body!r}, which is {what}: "
                                              "a rigid link positions the body at its `to` end, and this one is "
                                              f"positioned already; expected the {what} body as the link's `from` "
                                              "(or rigid: false)")
        if closes and node.kind != DEPENDENT:
            _closure(scene, beam, nodes, body_node, edges, link)
            beam_elements[beam.name] = np.zeros(0, dtype=np.int64)
            beam_nodes[beam.name] = np.array([link, link])
            beam_grid_offsets[beam.name] = (np.zeros(3), vector.copy())
            return
        if node.kind == DEPENDENT and scene.bodies[end.body].guide is not None:
            raise SceneError(scene.file, key, f"rigid link {beam.name!r} ends at body {end.body!r}, which slides on "
                                              "a guide: the guide positions the body already (a closed loop that "
                                              "minimum coordinates cannot express); make the beam flexible "
                                              "(rigid: false; a stiff section follows the rigid kinematics, "
                                              "docs/guides.md 'The slider-crank') or start the link at the body")
        if node.kind == DEPENDENT:
            other = next(e.link for e in edges if e.child == child)
            raise SceneError(scene.file, key, f"body {end.body!r} is reached by two rigid links ({other!r} and "
                                              f"{beam.name!r}): a closed loop that minimum coordinates cannot "
                                              "express; make one beam of the loop flexible (rigid: false; a stiff "
                                              "section follows the rigid kinematics, docs/guides.md 'The "
                                              "slider-crank'), or start one of the links at the body")
        node.kind = DEPENDENT
        h = _add_hinge(hinges, beam.name, "end", child, end.hinge)
        edges.append(Edge(link, child, h, hinges[h].axis.copy() if h >= 0 else np.zeros(3), -1.0,
                          vector.copy(), -np.array(end.offset, float), beam.name))
        # a loop: walking up from the link node reaches the body it positions
        parent_of = {e.child: e for e in edges}
        walk, loop = link, [beam.name]
        while walk in parent_of:
            e = parent_of[walk]
            walk = e.parent
            if e.link != loop[-1]:
                loop.append(e.link)
            if walk == child:
                raise SceneError(scene.file, key, "the rigid links " + ", ".join(repr(n) for n in loop[::-1])
                                 + " close a loop: a closed loop made only of rigid links cannot be expressed in "
                                 "minimum coordinates; make one beam of the loop flexible (rigid: false; a stiff "
                                 "section follows the rigid kinematics, docs/guides.md 'The slider-crank')")
    beam_elements[beam.name] = np.zeros(0, dtype=np.int64)
    beam_nodes[beam.name] = np.array([link, link])
    beam_grid_offsets[beam.name] = (np.zeros(3), vector.copy())


def _closing_sliders(scene) -> set:
    """The guided bodies a rigid link ends at: each closes a slider-crank's loop (:func:`_closure`)."""
    return {b.end.body for b in scene.beams.values()
            if b.rigid and b.end.body is not None and scene.bodies[b.end.body].guide is not None}


def _free_joint(joint) -> bool:
    """True when a hinge or guide carries no law, stop, latch or prescription (a closure's joints must not)."""
    return (joint is not None and isinstance(joint.stiffness, (int, float)) and joint.stiffness == 0
            and isinstance(joint.damping, (int, float)) and joint.damping == 0
            and getattr(joint, "torque", getattr(joint, "force", None)) is None
            and getattr(joint, "angle", getattr(joint, "position", None)) is None
            and joint.limits is None and joint.lock_at is None and joint.contact is None and joint.friction is None)


def _closure(scene, beam, nodes, body_node, edges, link) -> None:
    """A slider-crank whose rigid rod ``beam`` closes the loop onto a slider on a fixed guide
    (:mod:`latdyn.model.links`, "Closure"): the rod's node ``link`` and the slider follow the pin (the rod's
    start body) on closure edges, functions of the pin's position; the rod's hinges and the guide have no
    coordinate. Refused, with the key, unless the rod is hinged at both ends about one normal n of the
    loop's plane, with no law, stop, latch or offset, and the guide is on the ground or a fixed body, at
    right angles to n, with no law either (:func:`_check_closures` checks the crank)."""
    from latdyn.model.links import Edge

    key = f"beams.{beam.name}"
    slider = scene.bodies[beam.end.body]
    guide = slider.guide
    if guide.on is not None and not scene.bodies[guide.on].fixed:
        raise SceneError(scene.file, f"bodies.{slider.name}.guide.on", f"the rigid rod {beam.name!r} closes a loop "
                         f"onto {slider.name!r}, whose guide is on the moving body {guide.on!r}; a closed loop of "
                         "rigid links is built for a slider on the ground or a fixed body (docs/guides.md, 'The "
                         "slider-crank'); expected that, or the rod flexible (rigid: false)")
    if not _free_joint(guide):
        raise SceneError(scene.file, f"bodies.{slider.name}.guide", f"the guide of {slider.name!r} closes the loop of "
                         f"the rigid rod {beam.name!r}: its slide is no coordinate, so it takes no stiffness, damping, "
                         "force, position, limits, lock_at, contact or friction; expected none (or the rod flexible, "
                         "rigid: false)")
    for which, end in (("start", beam.start), ("end", beam.end)):
        if not _free_joint(end.hinge):
            raise SceneError(scene.file, f"{key}.{which}.hinge", f"the rigid rod {beam.name!r} closes a loop: it needs "
                             "a hinge at both ends with no stiffness, damping, torque, angle, limits, lock_at, contact "
                             "or friction (its angles are no coordinates); expected such a hinge (or the rod "
                             "flexible, rigid: false)")
        if np.linalg.norm(end.offset) > 0:
            raise SceneError(scene.file, f"{key}.{which}", f"the rigid rod {beam.name!r} closes a loop: its ends are "
                             "the pin's and the slider's reference points; expected no offset")
    for probe in scene.output.probes:
        if (probe.kind == "hinge" and probe.beam == beam.name) or (probe.kind == "guide" and probe.body == slider.name):
            raise SceneError(scene.file, f"output.probes.{probe.name}", f"the {probe.kind} of the rigid rod "
                             f"{beam.name!r}'s closed loop has no coordinate to record; expected a point probe "
                             f"({{point: {slider.name}, quantity: position}}) or the crank's hinge")
    normal = np.array(beam.start.hinge.axis, float)
    normal /= np.linalg.norm(normal)
    axis = np.array(guide.axis, float)
    axis /= np.linalg.norm(axis)
    pin, end = np.array(beam.start.point, float), np.array(beam.end.point, float)
    tolerance = 1e-9
    if (np.linalg.norm(np.cross(normal, beam.end.hinge.axis)) > tolerance or abs(normal @ axis) > tolerance
            or abs(normal @ (end - pin)) > tolerance * np.linalg.norm(end - pin)):
        raise SceneError(scene.file, f"{key}.end.hinge", f"the rigid rod {beam.name!r} closes a loop that is not "
                         "planar: a closed loop of rigid links is built for a slider-crank whose hinge axes are one "
                         "normal n, its guide and rod at right angles to n; expected that (or the rod flexible, "
                         "rigid: false)")
    length = float(np.linalg.norm(end - pin))
    direction = (end - pin) / length
    side = float(axis @ direction)
    if abs(side) < 1e-9:
        raise SceneError(scene.file, f"{key}.rigid", f"the rigid rod {beam.name!r} starts at right angles to the "
                         f"guide of {slider.name!r}: a dead point, where the slider's position is no function of the "
                         "crank's; expected the mechanism away from it")
    across = np.cross(normal, axis)
    data = np.concatenate([end, axis, normal, [length, np.sign(side),
                                               np.arctan2(across @ direction, axis @ direction), 0.0]])
    parent, child = body_node[beam.start.body], body_node[slider.name]
    nodes[child].kind = DEPENDENT
    edges.append(Edge(parent, link, -1, np.zeros(3), 0.0, np.zeros(3), np.zeros(3), beam.name, closure="rod",
                      closure_data=data))
    edges.append(Edge(parent, child, -1, np.zeros(3), 0.0, np.zeros(3), np.zeros(3), beam.name, closure="slider",
                      closure_data=data.copy()))


def _check_closures(scene, nodes, edges) -> None:
    """Each closure's pin turns on one crank about a fixed pivot with the loop's normal n as axis (its path up
    the tree: one revolute edge about n, clamped ones, a fixed root), and every crank angle closes the loop:
    the pin's distance R from the pivot and the pivot's height c above the guide line with |c| + R < l (no dead
    point, no angle where the rod cannot reach the guide). Refused with the rod's key otherwise."""
    parent_of = {e.child: e for e in edges}
    for e in edges:
        if e.closure and any(other.parent == e.child for other in edges):
            raise SceneError(scene.file, f"beams.{e.link}.rigid", f"the rigid rod {e.link!r} closes a loop whose "
                             f"{'slider' if e.closure == 'slider' else 'rod'} carries a rigid link or a guide of its own; "
                             "a closed loop of rigid links is built with nothing hung from the slider but beams and "
                             "loads; expected the link or guide elsewhere (or the rod flexible, rigid: false)")
        if e.closure != "rod":
            continue
        key = f"beams.{e.link}.rigid"
        o, axis, normal = e.closure_data[0:3], e.closure_data[3:6], e.closure_data[6:9]
        length = e.closure_data[9]
        pin = nodes[e.parent].position
        walk, cranks = e.parent, []
        while walk in parent_of:
            up = parent_of[walk]
            if up.closure or up.prismatic:
                cranks.append(None)
            elif up.hinge >= 0:
                cranks.append(up)
            walk = up.parent
        if nodes[walk].kind != FIXED or len(cranks) != 1 or cranks[0] is None:
            raise SceneError(scene.file, key, f"the rigid rod {e.link!r} closes a loop whose pin is not turned by one "
                             "crank about a fixed pivot: a closed loop of rigid links is built for a slider-crank (one "
                             "hinge between a fixed body and the pin); expected that (or the rod flexible, rigid: false)")
        crank = cranks[0]
        pivot = nodes[crank.parent].position + crank.point
        if np.linalg.norm(np.cross(crank.axis, normal)) > 1e-9:
            raise SceneError(scene.file, key, f"the crank of the rigid rod {e.link!r} turns about an axis that is not "
                             "the loop's normal (the rod's hinge axes): the loop is not planar; expected one axis")
        arm = pin - pivot
        radius = float(np.linalg.norm(arm - normal * (normal @ arm)))
        height = float(np.cross(normal, axis) @ (pivot - o))
        if abs(height) + radius >= length:
            raise SceneError(scene.file, key, f"the rigid rod {e.link!r} (length {length:.6g}) cannot close the loop at "
                             f"every crank angle: the crank's radius {radius:.6g} and its pivot's distance "
                             f"{abs(height):.6g} from the guide line reach a dead point (the rod at right angles to the "
                             "guide) or beyond; expected a rod longer than their sum")


def _tree_order(scene, edges, nodes) -> list:
    """The edges of the rigid links with parents before children (by depth in the tree)."""
    parent_of = {e.child: e.parent for e in edges}

    def depth(node):
        d = 0
        while node in parent_of:
            node, d = parent_of[node], d + 1
        return d

    return sorted(edges, key=lambda e: depth(e.child))


def _law(value) -> HingeLaw:
    """A hinge coefficient of the scene (number, TimeFunction or HingeLaw) as a HingeLaw."""
    if isinstance(value, HingeLaw):
        return value
    if isinstance(value, TimeFunction):
        return HingeLaw(value)  # keeps the inputs it names
    return HingeLaw(float(value))


#: Largest Rayleigh quotient of the Jacobi-scaled M/‖M‖ + K/‖K‖ taken as a null
#: direction (see :meth:`Model.check_held`).  Measured: an unheld direction gives
#: 5e-17 (free beam without rotary inertia spinning about its oblique axis, 10⁴
#: coordinates); the weakest held ones are chains of massless twist held by GJ,
#: λ_min = 1.1e-7 with 1666 elements, 1.2e-8 with 5000 (∝ 1/N², so 1e-10 only
#: past ~50 000 elements in one chain); the example scenes have λ_min ≥ 5e-4.
HELD_TOLERANCE = 1e-10


def _normalised_csr(matrix: CSR) -> CSR:
    """:func:`_normalised` of a :class:`latdyn.numerics.csr.CSR`."""
    rows = matrix.rows
    transposed = _transposed_entries(matrix)
    if transposed is not None:  # a symmetric pattern (the assembler's): the same sums, without sorting
        A = CSR(matrix.shape, matrix.indptr, matrix.indices, 0.5 * matrix.data + 0.5 * matrix.data[transposed])
    else:
        A = CSR.from_coo(np.concatenate([0.5 * matrix.data, 0.5 * matrix.data]), np.concatenate([rows, matrix.indices]),
                         np.concatenate([matrix.indices, rows]), matrix.shape)
    top = float(np.abs(A.diagonal()).max(initial=0.0))
    return CSR(A.shape, A.indptr, A.indices, A.data / top) if top > 0 else A


def _transposed_entries(matrix: CSR) -> np.ndarray | None:
    """For a square CSR matrix whose pattern is symmetric, the place of each entry's transposed entry
    (entry k is (i, j), entry ``places[k]`` is (j, i)); None for an unsymmetric pattern."""
    n = matrix.shape[0]
    rows, cols = matrix.rows, np.asarray(matrix.indices, np.int64)
    keys, wanted = rows * n + cols, cols * n + rows  # keys ascending: the CSR is canonical
    places = np.minimum(np.searchsorted(keys, wanted), max(len(keys) - 1, 0))
    return places if len(keys) and np.array_equal(keys[places], wanted) else None


def _csr_sum(a: CSR, b: CSR) -> CSR:
    if np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices):  # one pattern: the same sums
        return CSR(a.shape, a.indptr, a.indices, a.data + b.data)
    return CSR.from_coo(np.concatenate([a.data, b.data]), np.concatenate([a.rows, b.rows]),
                        np.concatenate([a.indices, b.indices]), a.shape)


def _normalised(matrix):
    """Symmetric part of a dense or sparse matrix (a NumPy array or CSR), divided by its largest
    |diagonal|."""
    if issparse(matrix):
        A = matrix.tocsr()
        A = (0.5 * (A + A.T)).tocsr()
    else:
        A = np.asarray(matrix, float)
        A = 0.5 * (A + A.T)
    top = float(np.abs(A.diagonal()).max(initial=0.0))
    return A / top if top > 0 else A
