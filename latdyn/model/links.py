"""Rigid links in minimum coordinates: dependent nodes and the map J from the coordinates.

A rigid link (``rigid: true``, SCENE.md) is one rigid body.  Its *link node* L sits at the
start grid point; its frame follows the start end, T_L = T_A R(a, θ_s) (Eq. 17 with the link's
own axes folded into its node axes, which are the global axes at t = 0 like every node's),
and its mass and inertia enter as a body inertia on L.  A body B at the link's ``to`` end
follows the link, T_B = T_L R(a_B, −θ_e) (the end hinge angle is the turn of the beam end
relative to B, as for flexible beams), x_B = (end grid point) − T_B r_B.  L and B are
*dependent nodes*: functions of their parent's configuration and one hinge angle.  Each
dependency is an edge p → c of a tree rooted at an independent node (free, fixed or
prescribed),

    T_c = T_p R(a, sθ),    x_c = x_p + T_p (o + R(a, sθ) b)                  (edge)

with a the hinge axis, o the hinge point and b the child's reference point from the hinge
point, all in the parent's node axes at θ = 0 (θ ≡ 0 on a clamped edge), s = ±1.

A *prismatic* edge (a sliding joint, ``bodies.NAME.guide``) moves the child along the axis a
fixed in the parent and keeps the parent's orientation; its coordinate is the slide s:

    T_c = T_p,    x_c = x_p + T_p (o + s a)                                   (prismatic edge)

with o the child's reference point at s = 0 from the parent's (parent axes).  Its joint twist is
ξ = (g, 0), g = T_p a: a translation along the current axis; every formula below holds for it
with that ξ: in the acceleration, ṡ V_p ×̂ ξ = (ṡ ω × g, 0) and the ω × v_c of the point's
acceleration make the Coriolis term 2ω × ṡg, and the parent's acceleration at the child's point
the centrifugal one of a slide on a turning body.

A *closure* edge (a slider-crank whose rigid rod closes the loop onto a slider on a fixed guide,
:func:`latdyn.model.model._closure`) makes its child a function of the parent's (the pin's) position p
alone, with no coordinate of its own: the slider on its line o + s(p) a at the rod's length l from p,
the rod's node at p turned about the loop's normal n by α(p) (codegen/joints.py, "Closure edges"):

    x_c = o + s(p) a, T_c = T_c(0)   (slider),   x_c = p, T_c = R(n, α(p))   (rod)      (closure edge)

so V_c = A(p) V_p with A = ∂(x_c, π_c)/∂p on the parent's translation, J_c = A J_p, and the
velocity-quadratic acceleration (v_p·∇)² of x_c and α. A wrench r on the child moves the pin as
g = Aᵀ r, whose derivative by p at fixed r (D) adds J_pᵀ D J_p to K; g joins the pin's wrench for the
terms of its path. A closure child is a leaf of the tree.

Velocities are spatial twists at the global origin, V = (v_O, ω) with the velocity of a
point y equal to v_O + ω × y; a node's coordinate velocities are (v, w) = (v_O + ω × x, ω).
Along an edge V_c = V_p + s θ̇ ξ with the joint twist ξ = (o_g × g, g) (g = T_p a the
current axis, o_g the current hinge point), so every dependent node's twist is its root's
plus the joint twists on its path, and J (the derivative of the dependent nodes'
coordinates by the independent ones) is built by that sum.  Accelerations:
V̇_c = V̇_p + s(θ̈ ξ + θ̇ V_p ×̂ ξ) with the spatial cross product (v, ω) ×̂ (v', ω') =
(ω × v' + v × ω', ω × ω').

The equations of motion are assembled, as for any model, on the independent coordinates
*and* the dependent nodes' coordinates (the latter numbered after the free ones, see
:meth:`latdyn.model.model.Model.number_coordinates`); then, with P = [I; J] on the free ones,

    r_min = Pᵀ r_all,   M_min = Pᵀ M P,   C_min = Pᵀ (C P + M_·dep ∂c/∂v),
    K_min = Pᵀ K P + ∂(Pᵀ)/∂q · r_all

where c(q, v) = J̇ v is the velocity-quadratic part of the dependent accelerations and the
last term of K_min (*geometric*) is the derivative of Pᵀ by q at fixed r_all. Like the rest of the
package, K omits the derivatives of inertia forces by q. The runtime evaluates all of it from
the generated kernels of codegen/joints.py (``rigid_link_edge`` per edge, ``prismatic_link_edge``
per prismatic edge: the child's configuration and rates, its factors of J and ∂c/∂v;
``hinge_wrench``, ``slide_wrench`` and ``root_wrench``: the geometric stiffness), composed along the tree in C (latdyn/assembly/csrc/links.c, laid out by
latdyn/assembly/native_links.py); this module holds the tree. Configurations of dependent nodes
are never integrated: they are set by forward kinematics in tree order after every update of the
independent coordinates (:meth:`latdyn.assembly.assembler.Assembler.complete_links`).
"""
from __future__ import annotations

from dataclasses import field

import numpy as np

from latdyn.records import record


@record
class Edge:
    """The dependency of node ``child`` on node ``parent`` (module docstring, "edge")."""
    parent: int
    child: int
    hinge: int  # hinge index, -1 when clamped
    axis: np.ndarray  # a, parent node axes (0 when clamped)
    sign: float  # s: +1 at a link's start, −1 at its end
    point: np.ndarray  # o, hinge point from the parent's reference point, parent node axes
    arm: np.ndarray  # b, child's reference point from the hinge point, parent node axes at θ = 0
    link: str  # the rigid link (beam name) the edge belongs to; for a guide, the guided body
    prismatic: bool = False  # a sliding joint: the hinge coordinate is the slide along `axis`
    #: a closure edge (module docstring, "Closure"): "slider" or "rod", its child a function of the parent's
    #: position with no coordinate; ``closure_data`` the kernel's input o[3] a[3] n[3] l σ β₀ 0
    closure: str = ""
    closure_data: np.ndarray = None

    @property
    def kind(self) -> int:
        """The edge's kind in csrc/links.c: 0 revolute or clamped, 1 prismatic, 2 slider closure, 3 rod closure."""
        return 1 if self.prismatic else {"": 0, "slider": 2, "rod": 3}[self.closure]


@record
class RigidLinks:
    """The dependent nodes of a model, in tree order, and the maps of the module docstring."""

    edges: list[Edge]  # one per dependent node, parents before children
    links: list[str]  # names of the rigid links
    root: dict = field(default_factory=dict)  # dependent node -> its independent root node

    def __post_init__(self):
        self.dependent = np.array([e.child for e in self.edges], dtype=np.int64)
        self.edge_of = {e.child: k for k, e in enumerate(self.edges)}
        for e in self.edges:
            self.root[e.child] = self.root.get(e.parent, e.parent)

    def path(self, node: int) -> list[int]:
        """Indices of the edges from the root down to ``node``."""
        out = []
        while node in self.edge_of:
            k = self.edge_of[node]
            out.append(k)
            node = self.edges[k].parent
        return out[::-1]

    # ------------------------------------------------------------------ the map J
    def columns(self, model) -> np.ndarray:
        """The coordinates (all numbering, sorted) the dependent nodes move with: their roots' 6
        coordinates and the hinges on the edges."""
        cols = []
        for e in self.edges:
            r = self.root[e.child]
            cols.extend(int(i) for i in model.node_dofs[r])
            if e.hinge >= 0:
                cols.append(int(model.hinge_dofs[e.hinge]))
        return np.array(sorted(set(cols)), dtype=np.int64)

    # ------------------------------------------------------------------ report
    def report(self, model) -> str:
        dependent_bodies = [model.nodes[c].name for c in self.dependent if model.nodes[c].body is not None]
        link_nodes = [model.nodes[c].name for c in self.dependent if model.nodes[c].body is None]
        guides = [e.link for e in self.edges if e.prismatic]
        loops = [e.link for e in self.edges if e.closure == "rod"]
        return (f"  rigid links: {len(self.links)} ({', '.join(self.links[:4])}"
                f"{', …' if len(self.links) > 4 else ''}); guides: {len(guides)}"
                + (f" ({', '.join(guides[:4])}{', …' if len(guides) > 4 else ''})" if guides else "")
                + (f"; slider-cranks closed by a rigid rod: {len(loops)} ({', '.join(loops[:4])}; the slide and "
                   "the rod's hinge angles follow the crank)" if loops else "")
                + "; dependent nodes (no coordinates of their own): "
                f"{len(link_nodes)} link nodes, {len(dependent_bodies)} bodies"
                + (f" ({', '.join(dependent_bodies[:4])})" if dependent_bodies else "")
                + f"; {6 * len(self.dependent)} coordinates removed")


