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

where c(q, v) = J̇ v is the velocity-quadratic part of the dependent accelerations (its
derivative by v is taken by central differences, exact for a quadratic to round-off) and the
last term of K_min (*geometric*) is analytic (:meth:`RigidLinks.geometric_stiffness`).
Like the rest of the package, K omits the derivatives of inertia forces by q.
Configurations of dependent nodes are never integrated: :meth:`RigidLinks.place` sets them
by forward kinematics in tree order after every update of the independent coordinates.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from latdyn.numerics.so3 import expm_so3, skew


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis, broadcast (numpy.cross costs ~20 µs a call in these loops)."""
    a, b = np.asarray(a), np.asarray(b)
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


@dataclass
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


@dataclass
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

    # ------------------------------------------------------------------ kinematics
    def place(self, state) -> None:
        """Forward kinematics on SO(3), in tree order: x and T of every dependent node (in place)."""
        for e in self.edges:
            theta = state.theta[e.hinge] if e.hinge >= 0 else 0.0
            if e.prismatic:
                Tp = state.T[e.parent]
                state.T[e.child] = Tp
                state.x[e.child] = state.x[e.parent] + Tp @ (e.point + theta * e.axis)
                continue
            R = expm_so3(e.axis * (e.sign * theta)) if e.hinge >= 0 else np.eye(3)
            Tp = state.T[e.parent]
            state.T[e.child] = Tp @ R
            state.x[e.child] = state.x[e.parent] + Tp @ (e.point + R @ e.arm)

    def _joint(self, state, e: Edge):
        """Current axis g = T_p a, hinge point o_g and joint twist ξ = (o_g × g, g) of an edge;
        ξ = (g, 0) on a prismatic edge (o_g is then the child's point at s = 0)."""
        Tp = state.T[e.parent]
        g = Tp @ e.axis
        o = state.x[e.parent] + Tp @ e.point
        if e.prismatic:
            return g, o, np.concatenate([g, np.zeros(3)])
        return g, o, np.concatenate([_cross(o, g), g])

    def _rates(self, state, v, w, a, alpha, theta_dot, theta_ddot) -> None:
        """Velocities and accelerations of the dependent nodes from the independent ones, batched:
        v, w, a, alpha (batch, n_nodes, 3) and theta_dot, theta_ddot (batch, n_hinges), in place."""
        for e in self.edges:
            p, c = e.parent, e.child
            xp, xc = state.x[p], state.x[c]
            omega, omega_dot = w[:, p], alpha[:, p]
            v_origin = v[:, p] - _cross(omega, xp)  # V_p = (v_p − ω × x_p, ω)
            v_origin_dot = a[:, p] - _cross(omega_dot, xp) - _cross(omega, v[:, p])
            if e.hinge >= 0:
                _, _, xi = self._joint(state, e)
                rate = e.sign * theta_dot[:, e.hinge][:, None]
                accel = e.sign * theta_ddot[:, e.hinge][:, None]
                # V_p ×̂ ξ = (ω × ξ_v + v_O × ξ_ω, ω × ξ_ω)
                cross_v = _cross(omega, xi[:3]) + _cross(v_origin, xi[3:])
                cross_w = _cross(omega, xi[3:])
                v_origin_dot = v_origin_dot + accel * xi[:3] + rate * cross_v
                omega_dot = omega_dot + accel * xi[3:] + rate * cross_w
                v_origin = v_origin + rate * xi[:3]
                omega = omega + rate * xi[3:]
            w[:, c] = omega
            alpha[:, c] = omega_dot
            v[:, c] = v_origin + _cross(omega, xc)
            a[:, c] = v_origin_dot + _cross(omega_dot, xc) + _cross(omega, v[:, c])

    def complete(self, state) -> None:
        """Configuration, velocities and accelerations of every dependent node from the
        independent ones (in place; idempotent)."""
        self.place(state)
        arrays = [state.v[None], state.w[None], state.a[None], state.alpha[None],
                  state.theta_dot[None], state.theta_ddot[None]]
        arrays = [np.array(x) for x in arrays]
        self._rates(state, *arrays)
        state.v[:], state.w[:], state.a[:], state.alpha[:] = (x[0] for x in arrays[:4])

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

    def twists(self, model, state):
        """Twist Jacobians of the dependent nodes and their roots on the coordinates they use.

        Returns (columns, twist) with ``columns`` the coordinate indices (all numbering) of the
        roots' 6 coordinates and the hinges on the edges, and ``twist`` a dict node ->
        (6, len(columns)) array: δV = (δv_O, δω) of the node per unit of each column.
        """
        columns = self.columns(model)
        where = {int(c): k for k, c in enumerate(columns)}
        twist = {}
        for r in {self.root[c] for c in self.dependent}:
            X = np.zeros((6, len(columns)))
            d = [where[int(i)] for i in model.node_dofs[r]]
            X[:3, d[:3]] = np.eye(3)
            X[:3, d[3:]] = skew(state.x[r])  # δv_O = δd + x × δπ
            X[3:, d[3:]] = np.eye(3)
            twist[r] = X
        for e in self.edges:
            X = twist[e.parent].copy()
            if e.hinge >= 0:
                _, _, xi = self._joint(state, e)
                X[:, where[int(model.hinge_dofs[e.hinge])]] += e.sign * xi
            twist[e.child] = X
        return columns, twist

    @staticmethod
    def point_jacobian(twist: np.ndarray, y: np.ndarray) -> np.ndarray:
        """δy of a point y of a body from its twist Jacobian: δv_O + δω × y, (3, n_columns)."""
        return twist[:3] - skew(y) @ twist[3:]



    def geometric_stiffness(self, model, state, columns, twist, residual_all, n) -> np.ndarray:
        """∂(Pᵀ)/∂q · r_all on the free coordinates (n, n), r_all held fixed.

        For a dependent node c with residual wrench (f, m) (force, moment about x_c), Pᵀ puts
        m + (x_c − x_r) × f on its root's rotations, s g·(m + (x_c − o) × f) on each hinge of
        its path (axis g, point o) and g·f on each slide.  Varied with f, m fixed (g, o move with
        the edge's parent p):

            root:   −skew(f) (δx_c − δx_r)
            hinge:  s [(g × u)·δω_p + (f × g)·(δx_c − δo)],  u = m + (x_c − o) × f
            slide:  (g × f)·δω_p
        """
        import scipy.sparse as sps  # on use: only models with rigid links need it

        rows, cols, values = [], [], []

        def add(row_indices, block):
            rows.append(np.repeat(row_indices, len(fc)))
            cols.append(np.tile(fc, len(row_indices)))
            values.append(np.ravel(block))

        free = columns < n
        fc = columns[free]
        for c in self.dependent:
            d = model.node_dofs[c]
            f, m = residual_all[d[:3]], residual_all[d[3:]]
            if not (np.any(f) or np.any(m)):
                continue
            x_c = state.x[c]
            dx_c = self.point_jacobian(twist[c], x_c)
            r = self.root[c]
            rd = model.node_dofs[r]
            if rd[3] < n:
                dx_r = self.point_jacobian(twist[r], state.x[r])
                add(rd[3:], (-skew(f) @ (dx_c - dx_r))[:, free])
            for k in self.path(c):
                e = self.edges[k]
                if e.hinge < 0 or model.hinge_dofs[e.hinge] >= n:
                    continue
                g, o, _ = self._joint(state, e)
                tp = twist[e.parent]
                if e.prismatic:
                    add(np.array([model.hinge_dofs[e.hinge]]), (e.sign * _cross(g, f) @ tp[3:])[free])
                    continue
                u = m + _cross(x_c - o, f)
                row = e.sign * (_cross(g, u) @ tp[3:] + _cross(f, g) @ (dx_c - self.point_jacobian(tp, o)))
                add(np.array([model.hinge_dofs[e.hinge]]), row[free])
        if not rows:
            return sps.csr_matrix((n, n))
        return sps.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))

    def convective_derivative(self, model, state, columns) -> np.ndarray:
        """∂a_dep/∂v on the free coordinates, (6 n_dep, n): central differences of the dependent
        accelerations, which are quadratic in the velocities (exact up to round-off)."""
        import scipy.sparse as sps  # on use: only models with rigid links need it

        n = model.n_dofs
        free_cols = columns[columns < n]
        n_dep = len(self.dependent)
        out = np.zeros((6 * n_dep, len(free_cols)))
        if not len(free_cols):
            return sps.csr_matrix((6 * n_dep, n))
        batch = 2 * len(free_cols)
        v = np.repeat(state.v[None], batch, axis=0)
        w = np.repeat(state.w[None], batch, axis=0)
        a = np.repeat(state.a[None], batch, axis=0)
        alpha = np.repeat(state.alpha[None], batch, axis=0)
        theta_dot = np.repeat(state.theta_dot[None], batch, axis=0)
        theta_ddot = np.repeat(state.theta_ddot[None], batch, axis=0)
        # which node slot / hinge each free column is
        node_of = {}
        for i, row in enumerate(model.node_dofs):
            for k, dof in enumerate(row):
                if dof < n:
                    node_of[int(dof)] = (i, k)
        hinge_of = {int(d): k for k, d in enumerate(model.hinge_dofs) if d < n}
        step = max(1.0, float(np.abs(np.concatenate([state.v.ravel(), state.w.ravel(),
                                                       state.theta_dot])).max(initial=0.0)))
        for j, col in enumerate(free_cols):
            for b, sign in ((2 * j, 1.0), (2 * j + 1, -1.0)):
                if int(col) in hinge_of:
                    theta_dot[b, hinge_of[int(col)]] += sign * step
                else:
                    i, k = node_of[int(col)]
                    (v if k < 3 else w)[b, i, k % 3] += sign * step
        self._rates(state, v, w, a, alpha, theta_dot, theta_ddot)
        for k, c in enumerate(self.dependent):
            diff = np.concatenate([a[0::2, c] - a[1::2, c], alpha[0::2, c] - alpha[1::2, c]], axis=1)
            out[6 * k:6 * k + 6] = diff.T / (2 * step)
        rows = np.repeat(np.arange(6 * n_dep), len(free_cols))
        return sps.csr_matrix((out.ravel(), (rows, np.tile(free_cols, 6 * n_dep))), shape=(6 * n_dep, n))

    # ------------------------------------------------------------------ report
    def report(self, model) -> str:
        dependent_bodies = [model.nodes[c].name for c in self.dependent if model.nodes[c].body is not None]
        link_nodes = [model.nodes[c].name for c in self.dependent if model.nodes[c].body is None]
        guides = [e.link for e in self.edges if e.prismatic]
        return (f"  rigid links: {len(self.links)} ({', '.join(self.links[:4])}"
                f"{', …' if len(self.links) > 4 else ''}); guides: {len(guides)}"
                + (f" ({', '.join(guides[:4])}{', …' if len(guides) > 4 else ''})" if guides else "")
                + "; dependent nodes (no coordinates of their own): "
                f"{len(link_nodes)} link nodes, {len(dependent_bodies)} bodies"
                + (f" ({', '.join(dependent_bodies[:4])})" if dependent_bodies else "")
                + f"; {6 * len(self.dependent)} coordinates removed")


