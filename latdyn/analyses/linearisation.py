"""The linearisation about a state (M, C, K in a frame that may turn) and its modes.

SCENE.md, "Linearisation".  The equations of motion on the free coordinates,
r(q, v, v̇, t) = 0 (latdyn/assembly.py), are linearised about a state (q₀, v₀, v̇₀) in a
frame that turns at the rate Ω of the prescribed rotations (zero without them), so that a
structure spinning steadily is at rest in it.  A perturbation (u, u̇, ü) in that frame, in
global components at the instant of the state, changes the state by

    δq = u  (q₀ ∘ exp u: x += u_d, T ← exp(skew u_π) T, θ += u_θ)
    translations:  δv = u̇ + Ω×u,               δv̇ = ü + 2Ω×u̇ + (Ω̇× + Ω×Ω×) u
    rotations:     δω = u̇ + (Ω − ω₀)×u,        δω̇ = ü + (2Ω − ω₀)×u̇ + ((Ω̇ − ω̇₀)× + (Ω − ω₀)×Ω×) u
    hinges:        δθ̇ = u̇,  δθ̈ = ü

(ω₀ = Ω for a node turning with the frame, which removes the node's own rate), so that with
r_q = ∂r/∂q at fixed v, v̇, r_v = ∂r/∂v (latdyn/assembly.py ``damping``: hinge dampers and the
gyroscopic ∂g/∂q̇ of the kernels) and M = ∂r/∂v̇,

    M ü + (r_v + M B₁) u̇ + (r_q + r_v A₁ + M B₀) u = F δf       (δv = u̇ + A₁u, δv̇ = ü + B₁u̇ + B₀u)

C = r_v + M B₁ holds the Coriolis (gyroscopic) terms of the frame, K the centrifugal and
load stiffening and the inertia tangent.  r_q is the exact tangent of the generated kernels
(:meth:`latdyn.assembly.assembler.Assembler.exact_matrices`: the elements' material, geometric,
load, gravity and inertia tangents, the joint bodies' inertia tangent, the hinges' laws; with
rigid links or guides their reduction with the dependent rates' q-dependence,
:func:`latdyn.assembly.linked.evaluate_linked`, tests/test_linked_tangent_terms.py). Its check,
:func:`tangent_q_by_differences`, is the material tangent (load factor 0, analytic) plus central
differences of everything else (inertia, gravity, loads, hinge torques): the difference of two
residuals at the same q leaves the elastic forces out exactly, so rigid-body modes stay at
round-off; columns that no row of the block pattern shares are perturbed together
(:func:`column_groups`).

Directions without inertia are condensed statically as in the modal analysis about the
initial configuration (Guyan, exact for them): with the joint-by-joint basis Q = [Q_m Q_c]
of :func:`latdyn.numerics.inertia.split_inertia`, u = T z, T = Q_m − Q_c K̃_cc⁻¹ K̃_cm.  The modes are
the eigenvalues λ of the first-order form A = [[0, I], [−M⁻¹K, −M⁻¹C]] (or of (K, M) when C
vanishes and K is symmetric): ``frequency_hz`` = |Im λ|/2π (the frequency the free response
oscillates at), ``natural_frequency_hz`` = |λ|/2π, ``damping_ratio`` = −Re λ/|λ| (negative:
unstable).  Each conjugate pair is one mode; real eigenvalues (rigid-body, overdamped,
divergent directions) are paired by size, a pair is one mode of frequency 0 (damping ratio 0
for rigid-body pairs, −1 for a divergent one, −(λ₁+λ₂)/(2√(λ₁λ₂)) ≥ 1 for an overdamped one).
Modes are listed by natural frequency (an overdamped mode of high natural frequency does not
come first for its damped frequency 0; undamped, ``frequency_hz`` ascends as before);
``modes.csv`` holds numbers only, the dominant direction of each mode goes to ``summary.json``
(``mode_directions``).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from latdyn.assembly.factorization import Factorization
from latdyn.assembly.prepare import length_scale
from latdyn.numerics.inertia import split_inertia
from latdyn.numerics.so3 import skew
from latdyn.step.compiled import matrix_pattern

#: Relative step of the central differences (translations: times the scene's size ℓ).
DIFFERENCE_STEP = 1e-6


# ----------------------------------------------------------------------------- the frame
@dataclass
class Frame:
    """The frame the perturbations are seen in: angular velocity Ω and acceleration Ω̇ (global)."""

    omega: np.ndarray
    omega_dot: np.ndarray

    @classmethod
    def inertial(cls) -> Frame:
        return cls(np.zeros(3), np.zeros(3))


def frame_of(model, state) -> Frame:
    """The common angular velocity of the prescribed rotating bodies at ``state`` (the frame that
    turns with them), or the inertial frame when none rotates or they rotate differently."""
    from latdyn.model.model import PRESCRIBED

    rotating = [i for i, node in enumerate(model.nodes)
                if node.kind == PRESCRIBED and model.scene.bodies[node.body].rotation_angle is not None]
    if not rotating:
        return Frame.inertial()
    w, a = state.w[rotating], state.alpha[rotating]
    scale = max(float(np.abs(w).max()), 1e-300)
    if np.abs(w - w[0]).max() > 1e-12 * scale or np.abs(a - a[0]).max() > 1e-12 * max(np.abs(a).max(), 1e-300):
        return Frame.inertial()
    return Frame(w[0].copy(), a[0].copy())


def frame_kinematics(model, state, frame: Frame):
    """A₁, B₁, B₀ (n × n) of the module docstring: δv = u̇ + A₁u, δv̇ = ü + B₁u̇ + B₀u."""
    n = model.n_dofs
    A1, B1, B0 = (np.zeros((n, n)) for _ in range(3))
    W, Wd = skew(frame.omega), skew(frame.omega_dot)

    def put(target, dofs, block):
        keep = dofs < n  # a planar model's out-of-plane slots are not coordinates
        target[np.ix_(dofs[keep], dofs[keep])] = block[np.ix_(keep, keep)]

    for i in model.free_nodes:
        d = model.node_dofs[i]
        put(A1, d[:3], W)
        put(B1, d[:3], 2 * W)
        put(B0, d[:3], Wd + W @ W)
        own = skew(frame.omega - state.w[i])
        put(A1, d[3:], own)
        put(B1, d[3:], W + own)
        put(B0, d[3:], skew(frame.omega_dot - state.alpha[i]) + own @ W)
    return A1, B1, B0


# ----------------------------------------------------------------------------- tangents
@dataclass
class Linearisation:
    """M ü + C u̇ + K u = F δf about ``state`` in ``frame`` (dense, free coordinates)."""

    model: object
    assembler: object
    state: object
    frame: Frame
    load_factor: float
    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    seconds: float = 0.0


def _steps(model, length: float) -> np.ndarray:
    """Central-difference step of every free coordinate: ℓ·DIFFERENCE_STEP for translations."""
    h = np.full(model.n_total + 1, DIFFERENCE_STEP)
    h[model.node_dofs[model.free_nodes, 0:3]] = DIFFERENCE_STEP * length
    return h[:model.n_dofs]


def column_groups(assembler) -> list[np.ndarray] | None:
    """Columns of r_q that can be found from one perturbation together (Curtis, Powell & Reid
    1974): no row of the iteration matrix's pattern (the assembly's blocks: elements, joint bodies,
    hinges, loads at their nodes; with rigid links that of Pᵀ A P, :func:`latdyn.step.compiled.matrix_pattern`)
    holds two of them, so each row's change comes from one column.  Greedy colouring, about 3 × 6
    groups for a chain of beams whatever its length.  None where the pattern does not bound the
    residual's dependence (a load in a body's axes depends on that body's rotation): then every
    column alone."""
    model = assembler.model
    if any(load.frame != "global" for load in model.scene.loads):
        return None
    n = model.n_dofs
    rows, cols = _dependence(assembler)
    by_column = [[] for _ in range(n)]
    by_row = [[] for _ in range(n)]
    for r, c in zip(rows.tolist(), cols.tolist()):
        by_column[c].append(r)
        by_row[r].append(c)
    colour = np.full(n, -1)
    for j in range(n):
        taken = {colour[k] for r in by_column[j] for k in by_row[r] if colour[k] >= 0}
        c = 0
        while c in taken:
            c += 1
        colour[j] = c
    return [np.flatnonzero(colour == c) for c in range(colour.max() + 1)] if n else []


def tangent_q(assembler, state, load_factor: float = 1.0, inertia: bool = True) -> np.ndarray:
    """r_q = ∂r/∂q at fixed velocities and accelerations (dense): the exact matrix of the generated
    kernels (:meth:`latdyn.assembly.assembler.Assembler.exact_matrices`: the tangent with the
    elements' and the joint bodies' inertia tangents; with rigid links or guides, reduced with the
    dependent rates' q-dependence)."""
    return np.asarray(assembler.exact_matrices(state, load_factor, inertia, dense=True)[2], dtype=float)


def tangent_q_by_differences(assembler, state, load_factor: float = 1.0, inertia: bool = True) -> np.ndarray:
    """r_q as the material tangent at load factor 0 plus central differences of the rest of the residual,
    the columns of one :func:`column_groups` group from one pair of perturbations: the check of the
    exact one (:func:`tangent_q`)."""
    model = assembler.model
    n = model.n_dofs
    material = assembler.evaluate(state, matrices=True, load_factor=0.0, inertia=False).combined(
        0.0, 0.0, 1.0, dense=True)

    def rest(s):
        return (assembler.evaluate(s, matrices=False, load_factor=load_factor, inertia=inertia).residual
                - assembler.evaluate(s, matrices=False, load_factor=0.0, inertia=False).residual)

    K = np.array(material, dtype=float)
    h = _steps(model, length_scale(model))
    groups = column_groups(assembler)
    if groups is None:
        groups = [np.array([j]) for j in range(n)]
    pattern = None if len(groups) == n else (np.asarray(material) != 0.0) | _block_pattern(assembler)
    for group in groups:
        e = np.zeros(n)
        e[group] = h[group]
        change = (rest(assembler.advance(state, e)) - rest(assembler.advance(state, -e)))
        if len(group) == 1:
            K[:, group[0]] += change / (2 * h[group[0]])
            continue
        for j in group:
            rows = np.flatnonzero(pattern[:, j])
            K[rows, j] += change[rows] / (2 * h[j])
    return K


def _dependence(assembler) -> tuple[np.ndarray, np.ndarray]:
    """(row, col) on the free coordinates of every entry r_q can hold: the iteration matrix's pattern."""
    n = assembler.model.n_dofs
    rows, cols = matrix_pattern(assembler)
    keep = (rows < n) & (cols < n)
    return rows[keep], cols[keep]


def _block_pattern(assembler) -> np.ndarray:
    """(n, n) bool: the entries r_q can hold (:func:`_dependence`)."""
    n = assembler.model.n_dofs
    out = np.zeros((n, n), dtype=bool)
    out[_dependence(assembler)] = True
    return out


def linearise(assembler, state, frame: Frame, load_factor: float = 1.0) -> Linearisation:
    """M, C, K about ``state`` in ``frame`` (module docstring)."""
    started = time.perf_counter()
    model = assembler.model
    ev = assembler.evaluate(state, matrices=True, load_factor=load_factor)
    M = ev.combined(1.0, 0.0, 0.0, dense=True)
    Cv = ev.combined(0.0, 1.0, 0.0, dense=True)
    Kq = tangent_q(assembler, state, load_factor)
    A1, B1, B0 = frame_kinematics(model, state, frame)
    C = Cv + M @ B1
    K = Kq + Cv @ A1 + M @ B0
    return Linearisation(model, assembler, state, frame, load_factor, M, C, K, time.perf_counter() - started)


# ----------------------------------------------------------------------------- condensation and modes
@dataclass
class Reduced:
    """The linearisation on the directions with inertia: M_r z̈ + C_r ż + K_r z = B_r δf, u = T z + D_u δf."""

    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    transform: np.ndarray  # T (n × m)
    basis: np.ndarray  # Q (n × n)
    n_massive: int
    condense: object  # F (n × k) -> (B_r (m × k), D_u (n × k))


def reduce(lin: Linearisation) -> Reduced:
    """Static condensation of the directions without inertia (module docstring)."""
    split = split_inertia(lin.model, lin.mass)
    Q = np.asarray(split.basis)
    M, C, K = (Q.T @ X @ Q for X in (lin.mass, lin.damping, lin.stiffness))
    m, c = slice(0, split.n_massive), slice(split.n_massive, Q.shape[0])
    if split.n_massless:
        K_cc = Factorization((), (), Q.shape[0] - split.n_massive, kind="dense").factor(K[c, c])
        G = K_cc.solve(K[c, m])  # z_c = −G z_m (+ K_cc⁻¹ F̃_c δf)
        K_r = K[m, m] - K[m, c] @ G
        C_r = C[m, m] - C[m, c] @ G
        T = Q[:, m] - Q[:, c] @ G
    else:
        K_r, C_r, T = K[m, m], C[m, m], Q[:, m]

    def condense(F):
        Ft = Q.T @ F
        if not split.n_massless:
            return Ft[m], np.zeros_like(F)
        Fc = K_cc.solve(Ft[c])  # the factors of K_cc, held
        return Ft[m] - K[m, c] @ Fc, Q[:, c] @ Fc

    return Reduced(0.5 * (M[m, m] + M[m, m].T), C_r, K_r, T, Q, split.n_massive, condense)


@dataclass
class Mode:
    eigenvalue: complex
    frequency_hz: float
    natural_frequency_hz: float
    damping_ratio: float
    shape: np.ndarray  # (n,) complex, free coordinates


def modes(lin: Linearisation, count: int | None = None, first_order=None) -> list[Mode]:
    """The modes of the linearisation, lowest natural frequency first (module docstring).
    ``first_order``: a function of the :class:`Reduced` model giving the A of ẋ = A x, x = [z, ż, …]
    with further first-order states (the continuous controllers' states:
    :func:`latdyn.analyses.linearise.closed_loop_matrix`), whose eigenvalues are then the modes'."""
    import scipy.linalg as sla

    red = reduce(lin)
    M, C, K = red.mass, red.damping, red.stiffness
    m = M.shape[0]
    if m == 0:
        return []
    scale = max(float(np.abs(K).max()), 1e-300)
    symmetric = first_order is None and np.abs(K - K.T).max() <= 1e-9 * scale and np.abs(C).max() <= 1e-12 * max(
        float(np.sqrt(np.abs(K).max() * np.abs(M).max())), 1e-300)
    found = []
    if symmetric:  # undamped, conservative: (K, M), as about the initial configuration
        try:  # held (K positive definite): (M, K), whose largest eigenvalues 1/ω² are the low modes,
            # accurate where stiff parts (K to 1e10) would drown them in the round-off of (K, M)
            inverse, vectors = sla.eigh(M, 0.5 * (K + K.T))
            omega2, vectors = 1.0 / inverse[::-1], vectors[:, ::-1]
        except (np.linalg.LinAlgError, ValueError):  # rigid-body or divergent directions
            omega2, vectors = sla.eigh(0.5 * (K + K.T), M)
        top = max(float(np.abs(omega2).max()), 1e-300)
        for w2, v in zip(omega2, vectors.T):
            if w2 >= 0 or abs(w2) <= 1e-10 * top:
                w = np.sqrt(max(w2, 0.0))
                found.append(Mode(1j * w, w / (2 * np.pi), w / (2 * np.pi), 0.0, red.transform @ v))
            else:  # divergence: λ = ±√(−ω²)
                s = np.sqrt(-w2)
                found.append(Mode(s + 0j, 0.0, s / (2 * np.pi), -1.0, red.transform @ v))
    else:
        Minv = np.linalg.inv(M)
        A = np.block([[np.zeros((m, m)), np.eye(m)], [-Minv @ K, -Minv @ C]]) if first_order is None \
            else first_order(red)
        lam, vectors = np.linalg.eig(A)
        top = max(float(np.abs(lam).max()), 1e-300)
        tol = 1e-9 * top
        real = [k for k in range(len(lam)) if abs(lam[k].imag) <= tol]
        for k in range(len(lam)):
            if lam[k].imag > tol:
                a = abs(lam[k])
                zeta = -lam[k].real / a
                zeta = 0.0 if abs(zeta) <= 1e-9 else zeta  # conservative gyroscopic pairs: round-off
                found.append(Mode(lam[k], lam[k].imag / (2 * np.pi), a / (2 * np.pi), zeta,
                                  red.transform @ vectors[:m, k]))
        real.sort(key=lambda k: abs(lam[k]))
        zero = 1e-6 * np.sqrt(top)  # rigid-body pairs: ±√(round-off) about 0
        for i in range(0, len(real), 2):
            pair = [lam[k].real for k in real[i:i + 2]]
            big = real[i + len(pair) - 1]
            if max(abs(p) for p in pair) <= zero:
                w, zeta = 0.0, 0.0
            else:
                w = np.sqrt(abs(np.prod(pair))) if len(pair) == 2 else abs(pair[0])
                zeta = -1.0 if max(pair) > zero else (-sum(pair) / (2 * w) if len(pair) == 2 else 1.0)
            found.append(Mode(complex(max(pair)), 0.0, w / (2 * np.pi), zeta, red.transform @ vectors[:m, big]))
    found.sort(key=lambda mode: (mode.natural_frequency_hz, mode.frequency_hz))
    return found if count is None else found[:count]


def dominant_directions(model, lin: Linearisation, found: list[Mode]) -> list[str]:
    """Per mode, the kind of coordinate that holds most of its kinetic energy φᴴMφ: a global
    direction of translation (x, y, z), of rotation (rx, ry, rz), or hinge."""
    names = model.dof_names()
    kinds = [name.rsplit(":", 1)[-1].replace("d", "") if ":" in name else "hinge" for name in names]
    labels = sorted(set(kinds))
    out = []
    for mode in found:
        phi = mode.shape
        energy = np.real(np.conj(phi) * (lin.mass @ phi))
        if not np.any(energy > 0):
            energy = np.abs(phi) ** 2
        share = {label: float(sum(e for e, k in zip(energy, kinds) if k == label)) for label in labels}
        out.append(max(share, key=share.get) if share else "")
    return out


# ----------------------------------------------------------------------------- the states to linearise about
def at_rest(state):
    """A copy of ``state`` without velocities and accelerations (nodes and hinges): the
    configuration alone, as the modal analysis about the initial configuration sees it."""
    state = state.copy()
    state.v[:] = state.w[:] = state.a[:] = state.alpha[:] = 0.0
    state.theta_dot[:] = state.theta_ddot[:] = 0.0
    return state
