"""State, element evaluation and sparse assembly (Eqs. 58 and 62, summed over elements).

The equations of motion on the free coordinates are

    r(q, v, v̇, t) = Σ_e L_eᵀ [M_e a_e + g_e + F_e − Q_e^grav] + rigid bodies + hinges − loads = 0

with a_e the element accelerations: free entries from v̇, prescribed ones from
their laws, so prescribed motion drives the inertia forces (it is known
kinematics, not a penalty).  Scatter indices are computed once; element
kernels are called once per evaluation for the whole batch.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sps

from latdyn.assembly.evaluation import Evaluation
from latdyn.assembly.linked import evaluate_linked
from latdyn.model.model import PRESCRIBED, Model
from latdyn.numerics.linalg import DENSE_LIMIT
from latdyn.numerics.so3 import expm_so3

# ----------------------------------------------------------------------------- rotations


def _plain_hinges(hinges):
    """(k, c, θ_r) of every hinge as arrays (0 where a law gives them), the hinges whose force
    needs their laws (a stiffness or damping that varies, a torque in θ or θ̇), and the other
    hinges with a torque (of t alone)."""
    def plain(h):
        torque_of_t = h.torque is None or set(h.torque.depends_on) <= {"t"}
        return h.stiffness.is_constant and h.damping.is_constant and torque_of_t

    flags = [plain(h) for h in hinges]
    k0 = np.array([h.stiffness.constant if f else 0.0 for h, f in zip(hinges, flags)], float)
    c0 = np.array([h.damping.constant if f else 0.0 for h, f in zip(hinges, flags)], float)
    rest = np.array([h.rest_angle for h in hinges], float)
    with_law = [k for k, f in enumerate(flags) if not f]
    with_torque = [k for k, (h, f) in enumerate(zip(hinges, flags)) if f and h.torque is not None]
    return k0, c0, rest, with_law, with_torque


#: 16-point Gauss–Legendre nodes and weights on [−1, 1] (hinge spring potentials).
_GAUSS_16 = np.polynomial.legendre.leggauss(16)

# ----------------------------------------------------------------------------- state


@dataclass
class State:
    """Explicit, picklable state of every node and hinge (free and constrained)."""

    t: float
    x: np.ndarray  # (n_nodes, 3) reference points
    T: np.ndarray  # (n_nodes, 3, 3) rotations
    v: np.ndarray  # (n_nodes, 3)
    w: np.ndarray  # (n_nodes, 3) spatial angular velocities
    a: np.ndarray  # (n_nodes, 3) accelerations
    alpha: np.ndarray  # (n_nodes, 3) spatial angular accelerations
    theta: np.ndarray  # (n_hinges,)
    theta_dot: np.ndarray
    theta_ddot: np.ndarray

    def copy(self) -> "State":
        return replace(self, **{k: np.array(getattr(self, k)) for k in
                                ("x", "T", "v", "w", "a", "alpha", "theta", "theta_dot", "theta_ddot")})

    def as_dict(self) -> dict[str, np.ndarray]:
        """Flat arrays for the state history file."""
        out = {"x": self.x.ravel(), "T": self.T.ravel(), "v": self.v.ravel(), "w": self.w.ravel(),
               "theta": self.theta.copy(), "theta_dot": self.theta_dot.copy()}
        return {k: v for k, v in out.items() if v.size}


def initial_state(model: Model) -> State:
    n, h = len(model.nodes), len(model.hinges)
    state = State(0.0, np.array([nd.position for nd in model.nodes], float).reshape(n, 3),
                  np.tile(np.eye(3), (n, 1, 1)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
                  np.zeros((n, 3)), np.zeros(h), np.zeros(h), np.zeros(h))
    iv = model.scene.initial_velocity
    free = model.free_nodes
    state.w[free] = iv.angular
    state.v[free] = iv.linear + np.cross(iv.angular, state.x[free] - iv.about)
    apply_prescribed(model, state, 0.0)
    if model.links is not None:
        model.links.complete(state)
    return state


def apply_prescribed(model: Model, state: State, t: float) -> None:
    """Set prescribed bodies and hinge angles to their laws at time t (in place)."""
    state.t = t
    for i, node in enumerate(model.nodes):
        if node.kind != PRESCRIBED:
            continue
        body = model.scene.bodies[node.body]
        x0 = node.position
        if body.translation is not None:
            f = body.translation
            state.x[i] = x0 + [g.value(t) for g in f]
            state.v[i] = [g.rate(t) for g in f]
            state.a[i] = [g.accel(t) for g in f]
        else:
            state.x[i], state.v[i], state.a[i] = x0, 0.0, 0.0
        if body.rotation_angle is not None:
            axis = body.rotation_axis
            angle = body.rotation_angle
            state.T[i] = expm_so3(axis * angle.value(t))
            state.w[i] = axis * angle.rate(t)
            state.alpha[i] = axis * angle.accel(t)
        else:
            state.T[i], state.w[i], state.alpha[i] = np.eye(3), 0.0, 0.0
    for k, hinge in enumerate(model.hinges):
        if hinge.angle is not None:
            state.theta[k] = hinge.angle.value(t)
            state.theta_dot[k] = hinge.angle.rate(t)
            state.theta_ddot[k] = hinge.angle.accel(t)
        elif model.locked[k]:
            state.theta_dot[k] = state.theta_ddot[k] = 0.0
    if model.links is not None:
        model.links.place(state)


# ----------------------------------------------------------------------------- coordinates ↔ state


def pack(model: Model, node_lin: np.ndarray, node_ang: np.ndarray, hinge: np.ndarray) -> np.ndarray:
    """Node/hinge arrays -> the vector of all coordinates (free first), length n_total + 1."""
    out = np.zeros(model.n_total + 1)
    out[model.node_dofs[:, 0:3]] = node_lin
    out[model.node_dofs[:, 3:6]] = node_ang
    out[model.hinge_dofs] = hinge
    return out


def padded(model: Model, vector: np.ndarray) -> np.ndarray:
    """A free-coordinate vector extended by zeros to all coordinates (n_total + 1), so that
    node slots that are not coordinates (out of plane, :meth:`Model.node_slots`) read 0."""
    if len(vector) == model.n_total + 1:
        return vector
    out = np.zeros(model.n_total + 1)
    out[:model.n_dofs] = vector[:model.n_dofs]
    return out


def unpack_free(model: Model, vector: np.ndarray, node_lin: np.ndarray, node_ang: np.ndarray,
                hinge: np.ndarray) -> None:
    """Write a free-coordinate vector into node/hinge arrays (in place)."""
    free = model.free_nodes
    vector = padded(model, vector)
    node_lin[free] = vector[model.node_dofs[free, 0:3]]
    node_ang[free] = vector[model.node_dofs[free, 3:6]]
    fh = model.free_hinges
    hinge[fh] = vector[model.hinge_dofs[fh]]


def free_velocity(model: Model, state: State) -> np.ndarray:
    return pack(model, state.v, state.w, state.theta_dot)[: model.n_dofs]


def free_acceleration(model: Model, state: State) -> np.ndarray:
    return pack(model, state.a, state.alpha, state.theta_ddot)[: model.n_dofs]


def advance(model: Model, state: State, increment: np.ndarray) -> State:
    """q ∘ exp(Δ) on the free coordinates: x += Δd, T ← exp(skew Δπ) T, θ += Δθ."""
    new = state.copy()
    free = model.free_nodes
    increment = padded(model, increment)
    new.x[free] = state.x[free] + increment[model.node_dofs[free, 0:3]]
    new.T[free] = expm_so3(increment[model.node_dofs[free, 3:6]]) @ state.T[free]
    fh = model.free_hinges
    new.theta[fh] = state.theta[fh] + increment[model.hinge_dofs[fh]]
    if model.links is not None:  # dependent nodes: forward kinematics, never integrated
        model.links.place(new)
    return new


# ----------------------------------------------------------------------------- evaluation


class Assembler:
    """Evaluates the equations of motion of a model with batched kernels."""

    def __init__(self, model: Model, kernels, gravity: np.ndarray):
        self.model = model
        self.kernels = kernels
        self.gravity = np.asarray(gravity, float)
        self.has_gravity = bool(np.any(self.gravity != 0))
        self.loads = model.scene.loads
        points = [model.point(load.at) for load in self.loads]
        self._load_nodes = np.array([node for node, _ in points], np.int64)
        self._load_offsets = np.array([r for _, r in points], float).reshape(-1, 3)
        self._follower = np.array([load.frame != "global" for load in self.loads], bool)
        self._load_frames = np.array([model.body_node[load.frame] if load.frame != "global" else node
                                      for load, (node, _) in zip(self.loads, points)], np.int64)
        # the hinged_end kernel's input of each element end (e, 2, 16): hinge axis, grid point, element
        # axes at t = 0 (node axes), and the hinge angle, filled in at each evaluation
        self._element_ends = np.concatenate([model.element_axes, model.element_offsets,
                                             model.element_frames0.reshape(-1, 2, 9),
                                             np.zeros(model.element_axes.shape[:2] + (1,))], axis=2)
        self._body_section = np.concatenate([model.body_mass[:, None], model.body_com,
                                             model.body_inertia.reshape(-1, 9)], axis=1)
        self._hinge_plain = None  # constant hinge coefficients as arrays (_plain_hinges), on first use
        self._conservative = np.array([h.conservative_spring for h in model.hinges], bool)
        self.reindex()

    def _load_columns(self) -> np.ndarray:
        """The columns of each load's stiffness block (l, 6): its node's rotations, then its frame
        body's (the node's again for a global load, whose frame block is zero)."""
        dofs = self.model.node_dofs
        return np.concatenate([dofs[self._load_nodes, 3:6], dofs[self._load_frames, 3:6]], axis=1)

    def reindex(self) -> None:
        """Scatter maps for the current coordinate numbering (rebuilt when a hinge latches)."""
        m = self.model
        n = m.n_assembled  # = n_dofs, plus the dependent nodes' coordinates with rigid links
        rows, cols = [], []

        def block_pattern(dofs, column_dofs=None):
            """Mask and (row, col) of the free×free entries of blocks over ``dofs`` (b, k) × ``column_dofs``
            (b, j; default: ``dofs``, square blocks)."""
            column_dofs = dofs if column_dofs is None else column_dofs
            r = np.broadcast_to(dofs[:, :, None], dofs.shape + (column_dofs.shape[1],))
            c = np.broadcast_to(column_dofs[:, None, :], dofs.shape + (column_dofs.shape[1],))
            mask = (r < n) & (c < n)
            rows.append(r[mask])
            cols.append(c[mask])
            return mask

        self._elem_mask = block_pattern(m.element_dofs)
        self._body_mask = block_pattern(m.node_dofs[m.body_nodes].reshape(-1, 6))
        hd = m.hinge_dofs[m.free_hinges]
        rows.append(hd)
        cols.append(hd)
        # a load's block: the node's rows × the rotations of the node, then of its frame body
        self._load_mask = block_pattern(m.node_dofs[self._load_nodes], self._load_columns())
        rows = np.concatenate(rows) if rows else np.zeros(0, np.int64)
        cols = np.concatenate(cols) if cols else np.zeros(0, np.int64)
        key = rows * max(n, 1) + cols
        unique, self._position = np.unique(key, return_inverse=True)
        self._csr_rows, self._csr_cols = unique // max(n, 1), unique % max(n, 1)
        self._nnz = len(unique)
        counts = np.bincount(self._csr_rows, minlength=n)
        self._indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self._indices = self._csr_cols.astype(np.int64)

    # -- pieces ----------------------------------------------------------------
    def element_geometry(self, state: State) -> np.ndarray:
        """The element kernels' geometry block (codegen/conventions.py GEOMETRY): reference points,
        and from the generated kernel ``hinged_end`` (codegen/joints.py) the offsets (Eq. 2), nodal
        frames (Eq. 17) and hinge axes (Eq. 9) of both ends."""
        m = self.model
        nodes = m.element_nodes
        ends = self._element_ends.copy()
        ends[:, :, 15] = np.append(state.theta, 0.0)[np.where(m.element_hinges >= 0, m.element_hinges,
                                                                len(state.theta))]
        frames, offsets, axes = self.kernels.hinged_end(state.T[nodes].reshape(-1, 9), ends.reshape(-1, 16))
        frames, offsets, axes = frames.reshape(-1, 2, 9), offsets.reshape(-1, 2, 3), axes.reshape(-1, 2, 3)
        x = state.x[nodes]
        return np.concatenate([x[:, 0], x[:, 1], offsets[:, 0], offsets[:, 1], frames[:, 0], frames[:, 1],
                               axes[:, 0], axes[:, 1]], axis=1)

    def element_rates(self, state: State, lin, ang, hinge) -> np.ndarray:
        m = self.model
        nodes = m.element_nodes
        h = m.element_hinges
        th = np.append(hinge, 0.0)[np.where(h >= 0, h, len(hinge))]
        return np.concatenate([lin[nodes[:, 0]], ang[nodes[:, 0]], th[:, :1],
                               lin[nodes[:, 1]], ang[nodes[:, 1]], th[:, 1:]], axis=1)

    def _scatter_vector(self, element_vectors, body_vectors, extra) -> np.ndarray:
        m = self.model
        total = np.zeros(m.n_total + 1)
        total += np.bincount(m.element_dofs.ravel(), weights=element_vectors.ravel(), minlength=m.n_total + 1)
        if len(m.body_nodes):
            bd = m.node_dofs[m.body_nodes]
            total += np.bincount(bd.ravel(), weights=body_vectors.ravel(), minlength=m.n_total + 1)
        total += extra
        return total

    def assemble(self, parts: list, dense: bool | None = None):
        """Scatter masked block data (in the order of :meth:`reindex`) into a matrix on
        the free coordinates: a dense array for small models, CSR otherwise."""
        n = self.model.n_assembled
        data = np.concatenate([np.ravel(p) for p in parts]) if parts else np.zeros(0)
        values = np.bincount(self._position, weights=data, minlength=self._nnz)
        if dense is None:
            dense = n <= DENSE_LIMIT
        if dense:
            out = np.zeros((n, n))
            out[self._csr_rows, self._csr_cols] = values
            return out
        return sps.csr_matrix((values, self._indices, self._indptr), shape=(n, n))

    def body_kinematics(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """Centre of mass from the reference point r_c = T c and inertia about it J = T I Tᵀ, global."""
        m = self.model
        T = state.T[m.body_nodes]
        rc = np.einsum("bij,bj->bi", T, m.body_com)
        return rc, T @ m.body_inertia @ np.transpose(T, (0, 2, 1))

    def joint_bodies(self, state: State, inertia: bool, load_factor: float):
        """The generated joint-body kernel (codegen/joints.py) for every body: residual rows, mass,
        gyroscopic and gravity-stiffness blocks; without ``inertia`` the weight alone."""
        m = self.model
        i = m.body_nodes
        if inertia:
            motion = np.concatenate([state.w[i], state.a[i], state.alpha[i]], axis=1)
        else:
            motion = np.zeros((len(i), 9))
        gravity = np.broadcast_to(load_factor * self.gravity, (len(i), 3))
        return self.kernels.joint_body(state.T[i].reshape(-1, 9), motion, self._body_section, gravity)

    def point_loads(self, state: State, load_factor: float):
        """The generated point-load kernel (codegen/joints.py) for every load at ``state.t``: the
        loads' residual rows on their nodes (l, 6), their power, and their stiffness blocks (l, 6, 6):
        columns the node's rotations, then those of the frame body (zero for a global load)."""
        nodes, offsets, frames, follower = self._load_nodes, self._load_offsets, self._load_frames, self._follower
        t = state.t
        values = np.zeros((len(self.loads), 6))
        for k, load in enumerate(self.loads):
            if load.force:
                values[k, :3] = [g.value(t) for g in load.force]
            if load.moment:
                values[k, 3:] = [g.value(t) for g in load.moment]
        R = np.where(follower[:, None, None], state.T[frames], np.eye(3))
        velocity = np.concatenate([state.v[nodes], state.w[nodes]], axis=1)
        force, power, by_node, by_frame = self.kernels.point_load(
            state.T[nodes].reshape(-1, 9), offsets, load_factor * values, R.reshape(-1, 9), velocity)
        blocks = np.concatenate([by_node, by_frame * follower[:, None, None]], axis=2)
        return force, float(power.sum()), blocks

    # -- the equations of motion ------------------------------------------------
    def evaluate(self, state: State, matrices: bool = True, load_factor: float = 1.0,
                 inertia: bool = True) -> Evaluation:
        """Residual r(q, v, v̇, t) on the free coordinates (and, with ``matrices``, the blocks of M, C, K);
        ``inertia=False``: the static residual; ``load_factor`` scales loads, gravity and hinge torques.
        With rigid links the dependent nodes are completed first and the result is reduced to the
        minimum coordinates (:func:`latdyn.assembly.linked.evaluate_linked`)."""
        if self.model.links is not None:
            return evaluate_linked(self.model.links, self, state, matrices, load_factor, inertia)
        return self._evaluate_assembled(state, matrices, load_factor, inertia)

    def _evaluate_assembled(self, state: State, matrices: bool, load_factor: float, inertia: bool) -> Evaluation:
        """The equations of motion on the first ``n_assembled`` coordinates (free, then dependent)."""
        m = self.model
        ks = self.kernels
        n = m.n_assembled
        geometry = self.element_geometry(state)
        section = m.element_sections
        n_elem = len(geometry)
        elem_mass = elem_damp = None
        if inertia:
            qdot = self.element_rates(state, state.v, state.w, state.theta_dot)
            qddot = self.element_rates(state, state.a, state.alpha, state.theta_ddot)
            if matrices:
                force, tangent, mass, quad, elem_damp = ks.beam_dynamics(geometry, qdot, section)
                elem_mass = mass
            else:
                (force,) = ks.beam_internal_force(geometry, section)
                (mass,) = ks.beam_mass_matrix(geometry, section)
                (quad,) = ks.beam_quadratic_velocity(geometry, qdot, section)
                tangent = None
            elem_vec = force + np.einsum("eij,ej->ei", mass, qddot) + quad  # Eqs. 55, 58
        else:
            if matrices:
                force, tangent = ks.beam_internal_force_D_q(geometry, section)
            else:
                (force,) = ks.beam_internal_force(geometry, section)
                tangent = None
            elem_vec = force.copy()
        elem_stiff = tangent
        if self.has_gravity:
            grav = np.broadcast_to(self.gravity, (n_elem, 3))
            gforce, _, _ = ks.beam_gravity(geometry, section, grav)
            elem_vec -= load_factor * gforce

        # joint bodies (generated: codegen/joints.py)
        nb = len(m.body_nodes)
        body_vec = np.zeros((nb, 6))
        body_mass = body_damp = body_stiff = np.zeros((nb, 6, 6))
        if nb:
            body_vec, Mb, Gb, body_stiff = self.joint_bodies(state, inertia, load_factor)
            if inertia:
                body_mass, body_damp = Mb, Gb

        # hinges: springs, dampers, applied torques (hinge_forces)
        extra = np.zeros(m.n_total + 1)
        hinge_force, hinge_k, hinge_c, power = self.hinge_forces(state, load_factor)
        extra[m.hinge_dofs] += hinge_force

        # loads at points (generated: codegen/joints.py)
        load_blocks = np.zeros(0)
        if self.loads:
            load_force, load_power, blocks = self.point_loads(state, load_factor)
            np.add.at(extra, m.node_dofs[self._load_nodes], load_force)
            power += load_power
            load_blocks = blocks[self._load_mask]

        total = self._scatter_vector(elem_vec, body_vec, extra)
        result = Evaluation(residual=total[:n], reaction=total[n:m.n_total], external_power=power,
                            assembler=self)
        if matrices:
            hinge_k, hinge_c = hinge_k[m.free_hinges], hinge_c[m.free_hinges]
            zero_elements = np.zeros((n_elem, 14, 14))
            zero_loads = np.zeros_like(load_blocks)
            result.blocks = {
                "stiffness": (elem_stiff, body_stiff, hinge_k, load_blocks),
                "mass": (elem_mass if elem_mass is not None else zero_elements, body_mass,
                         np.zeros(len(hinge_k)), zero_loads),
                "damping": (elem_damp if elem_damp is not None else zero_elements, body_damp, hinge_c,
                            zero_loads),
            }
        return result

    def hinge_forces(self, state: State, load_factor: float = 1.0):
        """Generalized hinge forces f = k(θ − θ_r) + c θ̇ − λτ (k, c, τ laws in θ, θ̇, t), their
        derivatives ∂f/∂θ and ∂f/∂θ̇ (diagonal entries of K and C), and the power of the hinges
        counted as external work: applied torques, and springs that are not conservative
        (a stiffness law in θ̇ or t; see :attr:`latdyn.model.model.HingeCoordinate.conservative_spring`).
        The laws' values and first derivatives at each hinge's (θ, θ̇, t) go into the generated kernel
        ``hinge_force`` (codegen/joints.py), which forms f and its derivatives."""
        hinges = self.model.hinges
        if not hinges:
            return np.zeros(0), np.zeros(0), np.zeros(0), 0.0
        if self._hinge_plain is None:
            self._hinge_plain = _plain_hinges(hinges)
        k0, c0, rest, with_law, with_torque = self._hinge_plain
        laws = np.zeros((len(hinges), 9))
        laws[:, 0], laws[:, 3] = k0, c0  # constant springs and dampers; the laws below replace them
        t = state.t
        for k in with_torque:  # torques of t alone on hinges with constant springs
            laws[k, 6] = hinges[k].torque.value(0.0, 0.0, t)
        for k in with_law:
            hinge = hinges[k]
            theta, rate = float(state.theta[k]), float(state.theta_dot[k])
            for j, law in enumerate((hinge.stiffness, hinge.damping, hinge.torque)):
                if law is not None:
                    laws[k, 3 * j:3 * j + 3] = law.value(theta, rate, t), law.d_theta(theta, rate, t), \
                        law.d_rate(theta, rate, t)
        kinematics = np.column_stack([state.theta, state.theta_dot, rest, np.full(len(hinges), load_factor)])
        force, d_theta, d_rate, spring_power, torque_power = self.kernels.hinge_force(kinematics, laws)
        power = float(torque_power.sum() + spring_power[~self._conservative].sum())
        return force, d_theta, d_rate, power

    def hinge_potential(self, state: State, hinges=None) -> float:
        """Potential of the conservative hinge springs, Σ ∫_{θ_r}^{θ} k(s)(s − θ_r) ds, over all
        hinges or the indices ``hinges``.

        Constant k: ½k(θ − θ_r)². A law k(θ): Gauss–Legendre quadrature, 16 points on each
        piece of at most 0.25 rad (exact for polynomials of degree 31 on a piece)."""
        total = 0.0
        every = self.model.hinges
        for k in range(len(every)) if hinges is None else hinges:
            hinge = every[k]
            if not hinge.conservative_spring:
                continue
            s = float(state.theta[k]) - hinge.rest_angle
            if hinge.stiffness.is_constant:
                total += 0.5 * hinge.stiffness.constant * s * s
                continue
            pieces = max(1, int(np.ceil(abs(s) / 0.25)))
            nodes, weights = _GAUSS_16
            edges = hinge.rest_angle + s * np.arange(pieces + 1) / pieces
            for a, b in zip(edges[:-1], edges[1:]):
                points = 0.5 * (a + b) + 0.5 * (b - a) * nodes
                values = [hinge.stiffness.value(p, 0.0, 0.0) * (p - hinge.rest_angle) for p in points]
                total += 0.5 * (b - a) * float(np.dot(weights, values))
        return total

    def energies(self, state: State) -> dict[str, float]:
        """Kinetic, strain and gravity potential energy of the whole model."""
        m = self.model
        ks = self.kernels
        if m.links is not None:
            m.links.complete(state)
        geometry = self.element_geometry(state)
        section = m.element_sections
        qdot = self.element_rates(state, state.v, state.w, state.theta_dot)
        strain, _ = ks.beam_strain_energy(geometry, section)
        (kinetic,) = ks.beam_kinetic_energy(geometry, qdot, section)
        grav = np.broadcast_to(self.gravity, (len(geometry), 3))
        _, potential, _ = ks.beam_gravity(geometry, section, grav)
        K, U, V = float(kinetic.sum()), float(strain.sum()), float(potential.sum())
        U += self.hinge_potential(state)
        if len(m.body_nodes):
            rc, J = self.body_kinematics(state)
            i = m.body_nodes
            vc = state.v[i] + np.cross(state.w[i], rc)
            K += float(0.5 * np.sum(m.body_mass * np.einsum("bi,bi->b", vc, vc))
                       + 0.5 * np.einsum("bi,bij,bj->", state.w[i], J, state.w[i]))
            V -= float(np.sum(m.body_mass * ((state.x[i] + rc) @ self.gravity)))
        return {"kinetic": K, "strain": U, "potential": V}

    def momentum(self, state: State) -> tuple[np.ndarray, np.ndarray]:
        """Linear momentum and angular momentum about the global origin.

        For an element, P·c = q̇ᵀ M q̇_c with q̇_c the rigid translation c, and
        H·c = q̇ᵀ M q̇_c with q̇_c the rigid rotation c about the origin
        (B q̇_c = c × X), so the mass-matrix kernel gives both exactly.
        """
        m = self.model
        if m.links is not None:
            m.links.complete(state)
        geometry = self.element_geometry(state)
        (mass,) = self.kernels.beam_mass_matrix(geometry, m.element_sections)
        qdot = self.element_rates(state, state.v, state.w, state.theta_dot)
        Mq = np.einsum("eij,ej->ei", mass, qdot)
        P, H = np.zeros(3), np.zeros(3)
        x1, x2 = geometry[:, 0:3], geometry[:, 3:6]
        for k in range(3):
            c = np.eye(3)[k]
            trans = np.zeros_like(qdot)
            trans[:, 0:3] = c
            trans[:, 7:10] = c
            rot = np.zeros_like(qdot)
            rot[:, 0:3] = np.cross(c, x1)
            rot[:, 3:6] = c
            rot[:, 7:10] = np.cross(c, x2)
            rot[:, 10:13] = c
            P[k] = np.sum(Mq * trans)
            H[k] = np.sum(Mq * rot)
        if len(m.body_nodes):
            rc, J = self.body_kinematics(state)
            i = m.body_nodes
            vc = state.v[i] + np.cross(state.w[i], rc)
            p = m.body_mass[:, None] * vc
            P += p.sum(axis=0)
            H += np.sum(np.cross(state.x[i] + rc, p) + np.einsum("bij,bj->bi", J, state.w[i]), axis=0)
        return P, H
