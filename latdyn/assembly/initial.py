"""The velocities at t = 0: the scene's rigid motion (``initial_velocity``) carried onto the
coordinates through hinges, flexible beams and rigid links alike, with the rates of prescribed
bodies and prescribed hinge angles (docs/initial_state.md).

The structure is cut into *parts*: each joint body and each beam (flexible or rigid link).  A
part moves rigidly at t = 0, with the spatial twist V = (v_O, ω) at the global origin (the
velocity of a point y of the part is v_O + ω × y), so no element starts with a strain rate
where the joints allow it.  A beam end joined to a body is an *edge* from its parent to its
child along the beam's direction (``from`` body → beam → ``to`` body, as for rigid links,
latdyn/model/links.py); every edge reads, with g the hinge axis, o the hinge point and
ξ = (o × g, g) the joint twist,

    V_beam − V_body − θ̇ ξ = 0          (θ̇ = 0 clamped, the law's rate prescribed, free otherwise)

and the twists are found by least squares in two ranks: first the *constraints* (these edge
equations, fixed bodies at rest, prescribed bodies at their law's rate), then the *rigid
motion* V₀ of ``initial_velocity`` for the parts the constraints leave free:

- a part with no parent edge (a free body that no beam ends at, a beam from a free point):
  its whole twist, V = V₀;
- a part whose parent edges are free hinges only: its angular velocity, ω = ω₀ (the free
  hinge takes the relative rate, θ̇ = g·(ω₀ − ω_parent); the part keeps the velocity of the
  hinge point that its parent gives it);
- a part with a clamped or prescribed parent edge follows its parent (plus the prescribed
  rate): nothing of V₀ is asked of it, so that a rotor spun by a prescribed hinge angle
  spins relative to its gimbal, the gimbal keeping V₀.

On a tree of parts both ranks hold exactly; only a closed loop whose joints cannot take the
motion leaves a residual (the least-squares compromise, spread as strain rate).  Rows are
written at the hinge point (translations divided by the scene's size ℓ), so the result does
not depend on the origin or the units.  The free coordinates then take the twist of their
part: node velocities v = v_O + ω × x, w = ω, free hinge rates θ̇; the dependent nodes of rigid
links are completed from them.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sps
from scipy.sparse.linalg import spsolve

from latdyn.model.model import FIXED, PRESCRIBED

#: weight of the constraint rows against the rigid motion's (ranks of the least squares): on a
#: tree both hold exactly whatever it is; in a loop that cannot take the motion the constraints
#: are violated by ~1/CONSTRAINT_WEIGHT² of the rigid motion's residual
CONSTRAINT_WEIGHT = 1e4


def _skew(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def initial_velocities(model, state) -> None:
    """Set the free coordinates' velocities of ``state`` (t = 0, prescribed motion applied) from
    the scene's rigid motion, in place (module docstring)."""
    from latdyn.assembly.prepare import length_scale  # prepare builds the assembler, which calls this

    length = length_scale(model)
    scene = model.scene
    iv = scene.initial_velocity
    omega0 = np.asarray(iv.angular, float)
    v_origin0 = np.asarray(iv.linear, float) - np.cross(omega0, iv.about)  # V₀ at the origin
    parts = list(scene.bodies) + [f"beam {name}" for name in scene.beams]
    index = {p: k for k, p in enumerate(parts)}
    free_hinges = [k for k in model.free_hinges]
    hinge_column = {k: 6 * len(parts) + j for j, k in enumerate(free_hinges)}
    n = 6 * len(parts) + len(free_hinges)
    scale = 1.0 / max(length, 1e-12)
    strong, weak = _Rows(n), _Rows(n)

    def block(part):
        return slice(6 * index[part], 6 * index[part] + 3), slice(6 * index[part] + 3, 6 * index[part] + 6)

    def point_velocity(part, y, sign=1.0):
        """The velocity of point y of ``part`` (3 rows) as column blocks, scaled by 1/ℓ."""
        lin, ang = block(part)
        return [(lin, sign * scale * np.eye(3)), (ang, -sign * scale * _skew(y))]  # ω × y = −skew(y) ω

    def angular(part, sign=1.0):
        return [(block(part)[1], sign * np.eye(3))]

    # bodies: fixed at rest, prescribed at their law's rate (strong rows)
    parent_edges = {p: [] for p in parts}
    for name, body in scene.bodies.items():
        node = model.body_node[name]
        kind = model.nodes[node].kind
        if kind in (FIXED, PRESCRIBED):
            x, v, w = state.x[node], state.v[node], state.w[node]
            strong.add(point_velocity(name, x), v * scale)
            strong.add(angular(name), w)
            parent_edges[name].append("fixed")
    # edges: V_beam − V_body − θ̇ ξ = 0 at the hinge point o
    for name, beam in scene.beams.items():
        part = f"beam {name}"
        for end, spec in (("start", beam.start), ("end", beam.end)):
            if spec.body is None:
                continue
            body = spec.body
            node = model.body_node[body]
            o = state.x[node] + state.T[node] @ np.asarray(spec.offset, float)
            try:
                h = model.hinge_index(name, end)
            except KeyError:
                h = -1
            strong.add(point_velocity(part, o) + point_velocity(body, o, -1.0), np.zeros(3))  # o moves with both
            m = angular(part) + angular(body, -1.0)
            rhs = np.zeros(3)
            kind = "clamped"
            if h >= 0:
                g = state.T[node] @ model.hinges[h].axis
                if h in hinge_column:
                    m.append((slice(hinge_column[h], hinge_column[h] + 1), -g[:, None]))
                    kind = "free"
                else:  # prescribed (or latched: at rest)
                    rhs = state.theta_dot[h] * g
                    kind = "prescribed"
            strong.add(m, rhs)
            child = part if end == "start" else body
            parent_edges[child].append(kind)
    # the rigid motion, for the parts the constraints leave free
    for part in parts:
        kinds = parent_edges[part]
        if any(k != "free" for k in kinds):
            continue  # fixed, prescribed, or following a parent through a clamp or a prescribed hinge
        weak.add(angular(part), omega0)
        if not kinds:
            y = _reference_point(model, scene, part)
            weak.add(point_velocity(part, y), (v_origin0 + np.cross(omega0, y)) * scale)
    A = sps.vstack([CONSTRAINT_WEIGHT * strong.matrix(), weak.matrix()]).tocsc()
    b = np.concatenate([CONSTRAINT_WEIGHT * strong.rhs(), weak.rhs()])
    # the augmented system [[I, A], [Aᵀ, 0]] [r; z] = [b; 0] of the least squares (conditioned
    # like A, where the normal equations would square it)
    m = A.shape[0]
    augmented = sps.bmat([[sps.identity(m), A], [A.T, None]], format="csc")
    z = np.atleast_1d(spsolve(augmented, np.concatenate([b, np.zeros(n)])))[m:]
    # the free coordinates take the twist of their part
    node_part = {}
    for name in scene.bodies:
        node_part[model.body_node[name]] = name
    for name in scene.beams:
        for node in model.beam_nodes[name]:
            node_part.setdefault(int(node), f"beam {name}")
    for node in model.free_nodes:
        part = node_part[int(node)]
        k = index[part]
        v_origin, omega = z[6 * k:6 * k + 3], z[6 * k + 3:6 * k + 6]
        state.w[node] = omega
        state.v[node] = v_origin + np.cross(omega, state.x[node])
    for k, column in hinge_column.items():
        state.theta_dot[k] = z[column]


def _reference_point(model, scene, part: str) -> np.ndarray:
    """A point of a part at t = 0: a body's reference point, a beam's mid-point."""
    if part in scene.bodies:
        return np.asarray(scene.bodies[part].at, float)
    beam = scene.beams[part[len("beam "):]]
    return 0.5 * (np.asarray(beam.start.point, float) + np.asarray(beam.end.point, float))


class _Rows:
    """Rows of a sparse least-squares problem, gathered 3 at a time as (column slice, (3, k) block) pairs."""

    def __init__(self, n: int):
        self.n, self._rows, self._cols, self._values, self._b = n, [], [], [], []

    def add(self, blocks: list, b: np.ndarray) -> None:
        first = 3 * len(self._b)
        for columns, values in blocks:
            cols = np.arange(columns.start, columns.stop)
            self._rows.append(np.repeat(first + np.arange(3), len(cols)))
            self._cols.append(np.tile(cols, 3))
            self._values.append(np.ravel(values))
        self._b.append(np.asarray(b, float))

    def matrix(self):
        if not self._b:
            return sps.csr_matrix((0, self.n))
        return sps.csr_matrix((np.concatenate(self._values), (np.concatenate(self._rows), np.concatenate(self._cols))),
                              shape=(3 * len(self._b), self.n))

    def rhs(self) -> np.ndarray:
        return np.concatenate(self._b) if self._b else np.zeros(0)
