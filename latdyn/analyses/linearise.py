"""Linearisation about a state: modes of loaded and spinning structures, buckling, linear models.

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
load stiffening and the inertia tangent.  r_q is the material tangent of the assembly
(hinge springs and internal forces, load factor 0, analytic) plus central differences of
everything else (inertia, gravity, loads, hinge torques): the difference of two residuals at
the same q leaves the elastic forces out exactly, so rigid-body modes stay at round-off;
columns that no row of the block pattern shares are perturbed together (:func:`column_groups`).

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

import copy
import sys
import time
from dataclasses import dataclass

import numpy as np

from latdyn.analyses import continuation, mechanism, stability
from latdyn.assembly.assembler import pack, unpack_free
from latdyn.assembly.factorization import Factorization
from latdyn.assembly.prepare import length_scale
from latdyn.errors import SceneError, SolverError
from latdyn.numerics.inertia import split_inertia
from latdyn.numerics.so3 import skew
from latdyn.results.writer import ResultWriter
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
    """r_q = ∂r/∂q at fixed velocities and accelerations (dense): the analytic material tangent
    at load factor 0 plus central differences of the rest of the residual (module docstring),
    the columns of one :func:`column_groups` group from one pair of perturbations."""
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


def modes(lin: Linearisation, count: int | None = None) -> list[Mode]:
    """The modes of the linearisation, lowest natural frequency first (module docstring)."""
    import scipy.linalg as sla

    red = reduce(lin)
    M, C, K = red.mass, red.damping, red.stiffness
    m = M.shape[0]
    if m == 0:
        return []
    scale = max(float(np.abs(K).max()), 1e-300)
    symmetric = np.abs(K - K.T).max() <= 1e-9 * scale and np.abs(C).max() <= 1e-12 * max(
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
        A = np.block([[np.zeros((m, m)), np.eye(m)], [-Minv @ K, -Minv @ C]])
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


def _scene_copy(scene, **solve):
    """The scene with ``solve`` fields replaced (the model of a linearisation is always 3D,
    as the modal analysis's: latdyn.model.planar.find_plane)."""
    other = copy.copy(scene)
    other.solve = copy.copy(scene.solve)
    for key, value in solve.items():
        setattr(other.solve, key, value)
    return other


def _planar(prepared) -> str:
    """``solve.planar`` for the run that reaches the state: the model of ``prepared`` (3D for modes)."""
    return "off" if prepared.model.plane is None else "auto"


def static_state(prepared):
    """The equilibrium of the static analysis of the scene (its loads, ``steps``), load factor 1."""
    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    other = prepare(_scene_copy(prepared.scene, analysis="static", planar=_planar(prepared)),
                    prepared.assembler.kernels.backend)
    probes = ProbeSet(other.assembler, other.state)
    writer = ResultWriter(None, probes.names, "load_factor")
    continuation.static_path(other, probes, writer, length_scale(other.model))
    return other, at_rest(other.state)


def transient_state(prepared, t: float):
    """The state a transient run of the same scene reaches at time ``t`` (3D model)."""
    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet
    from latdyn.timeloop.transient import transient

    scene = prepared.scene
    if scene.solve.dt is None:
        raise SceneError(scene.file, "solve.dt", "missing required key 'dt' (about: {t: T} runs the "
                                                 "transient of the scene to T with this step)")
    other = prepare(_scene_copy(scene, analysis="transient", t_end=float(t), planar=_planar(prepared)),
                    prepared.assembler.kernels.backend)
    probes = ProbeSet(other.assembler, other.state)
    transient(other, probes, ResultWriter(None, probes.names), False)
    return other, other.state


def state_about(prepared, about):
    """(prepared, state, frame, load factor) of ``solve.about``."""
    if about == "static":
        other, state = static_state(prepared)
        return other, state, Frame.inertial(), 1.0
    if about == "steady":  # latdyn/analyses/steady.py
        from latdyn.analyses.steady import steady_state

        other, state, frame, _ = steady_state(prepared)
        return other, state, frame, 1.0
    if isinstance(about, float):
        other, state = transient_state(prepared, about)
        return other, state, frame_of(other.model, state), 1.0
    return prepared, at_rest(prepared.state), Frame.inertial(), 1.0  # initial: at rest


# ----------------------------------------------------------------------------- the analyses
def modal_analysis(prepared, count: int, about="initial"):
    """Modes about ``about`` (SCENE.md): (list of :class:`Mode`, dominant directions, Linearisation,
    report).  ``report`` holds what the run says of the state beyond its modes: about a steady
    spin, ``steady_state`` (stable or not, how it was found: latdyn/analyses/steady.py) and
    ``warnings``; empty otherwise."""
    report = {}
    if about == "steady":
        from latdyn.analyses.steady import steady_state, steady_summary

        other, state, frame, search = steady_state(prepared)
        load_factor = 1.0
    else:
        other, state, frame, load_factor = state_about(prepared, about)
    if other.model.n_dofs == 0:
        return [], [], None, report
    lin = linearise(other.assembler, state, frame, load_factor)
    found = modes(lin, None if about == "steady" else count)
    if about == "steady":  # judged by all its roots, not only the listed ones
        report["steady_state"], report["warnings"] = steady_summary(search, found)
        found = found[:count]
    return found, dominant_directions(other.model, lin, found), lin, report


def modes_table(found: list[Mode], directions: list[str]) -> dict:
    """The extra columns of ``modes.csv`` after ``frequency_hz``."""
    return {"damping_ratio": [m.damping_ratio for m in found],
            "natural_frequency_hz": [m.natural_frequency_hz for m in found]}


#: Load factor of the pre-buckling state that gives the change of the tangent K_1 = (K(λ₁) − K₀)/λ₁.
PREBUCKLING_FACTOR = 1e-4
#: The stability search stops when the bracket of the load factor is this narrow (relative).
STABILITY_TOL = 1e-7


def _stability(assembler, state, load_factor: float, K0_factor) -> float:
    """The lowest eigenvalue of the symmetric part of the static tangent against the unloaded one,
    min eig(K_T(λ), K₀): 1 unloaded, 0 where the loaded structure loses stability."""
    import scipy.linalg as sla

    K = tangent_q(assembler, state, load_factor, inertia=False)
    K = 0.5 * (K + K.T)
    return float(sla.eigh(K, b=K0_factor, eigvals_only=True, subset_by_index=[0, 0])[0])


def buckling_analysis(prepared, count: int = 6) -> dict:
    """The lowest load factor at which the loaded structure loses stability (SCENE.md).

    ``buckling_factor``: the load factor λ at which the tangent of the static equilibrium path
    K_T(λ) (loads, gravity and hinge torques times λ, as the static analysis) stops being
    positive definite: the zero of f(λ) = min eig(K_T(λ), K₀), found by stepping along the path
    (the static analysis's Newton at each λ, :func:`latdyn.analyses.continuation.newton_fixed` on the
    analytic tangent; the stability tangents by :func:`tangent_q`) with secant predictions and regula
    falsi once bracketed.  This is a bifurcation (an Euler column, lateral buckling) or a limit point (then Newton stops beyond it: ``buckling_kind`` says which was seen).

    ``linearised_buckling_factors``: the classical linearised estimate about the unloaded
    configuration, the smallest μ > 0 of det(K₀ + μ K₁) = 0 with K₁ = (K(λ₁) − K₀)/λ₁ at the small
    load factor λ₁ = PREBUCKLING_FACTOR.  K₁ holds the stress (geometric) stiffness and also the
    initial-displacement stiffness of the pre-buckling deflection; where a load bends the
    structure (a cantilever's tip load) the latter makes spurious low factors (measured: 0.14
    for a cantilever with EI_strong/EI_weak = 100 whose lateral buckling is at 1.0), so it is
    reported, not used.  For a column (axial pre-buckling) the two agree.

    Under follower loads (:func:`latdyn.analyses.stability.follower_loads`) the symmetric part of
    the tangent tells nothing: divergence and flutter are searched instead
    (:func:`latdyn.analyses.stability.search`, ``solve.flutter``); conservative problems take the
    search above, unchanged (``instability``: ``buckling`` or ``none``).
    """
    import scipy.linalg as sla

    model, assembler = prepared.model, prepared.assembler
    if model.n_dofs == 0:
        return {"buckling_factor": None}
    started = time.perf_counter()
    reference = at_rest(prepared.state)
    K0 = tangent_q(assembler, reference, 0.0, inertia=False)
    K0s = 0.5 * (K0 + K0.T)
    path = continuation.Path(prepared, None, None, length_scale(model))  # Newton's settings and counters
    try:
        np.linalg.cholesky(K0s)
    except np.linalg.LinAlgError:
        free = mechanism.coordinate_names(model, mechanism.free_directions(K0, path.weight)[0])
        raise SolverError("buckling: the unloaded structure is not held (its tangent is not positive definite"
                          + (f"; nothing holds {', '.join(free)}: no stiffness, no support" if free else "")
                          + "): a free structure or a mechanism has no buckling load") from None
    followers = stability.follower_loads(model)
    loaded, _, _, converged = continuation.newton_fixed(path, reference, PREBUCKLING_FACTOR)
    if not converged:
        raise SolverError(f"buckling: no static equilibrium at load factor {PREBUCKLING_FACTOR:g}")
    K1 = (tangent_q(assembler, loaded, PREBUCKLING_FACTOR, inertia=False) - K0) / PREBUCKLING_FACTOR
    nu = sla.eigvals(-K1, K0)
    nu = nu[np.isfinite(nu)]
    if followers:  # directions the load does not change (axial, torsion) give ν of round-off, 1/ν ~ 1e11
        nu = nu[np.abs(nu) > 1e-9 * max(float(np.abs(nu).max(initial=0.0)), 1e-300)]
    linearised = np.sort([1.0 / v.real for v in nu if v.real > 0 and abs(v.imag) <= 1e-8 * abs(v)])
    if followers:  # non-conservative: divergence and flutter along the path (latdyn/analyses/stability.py)
        step = min(1.0 / prepared.scene.solve.steps, 0.5 * float(linearised[0]) if len(linearised) else 1.0)
        flutter = prepared.scene.solve.flutter is not False
        out = stability.search(prepared, path, reference, K0s, step, flutter, STABILITY_TOL)
        out.update(follower_loads=[f"loads[{i}]" for i in followers],
                   linearised_buckling_factors=[float(x) for x in linearised[:count]],
                   buckling_s=time.perf_counter() - started)
        if not flutter:
            out.update(flutter_factor=None, flutter_searched_to=None)  # not searched
        for warning in out.get("warnings", []):
            print(f"latdyn: warning: {warning}", file=sys.stderr)
        return out

    # along the path: f(λ) = min eig(K_T(λ), K₀) from f(0) = 1 to its zero
    lam, f, state = 0.0, 1.0, reference
    step = min(1.0 / prepared.scene.solve.steps,
               0.5 * float(linearised[0]) if len(linearised) else 1.0)
    below = (lam, f, state)
    above = None
    kind, evaluations = None, 0
    for _ in range(200):
        if above is None:
            target = below[0] + step
        else:  # regula falsi in the bracket
            (l0, f0, _), (l1, f1) = below, above
            target = l0 + (l1 - l0) * f0 / (f0 - f1)
            target = min(max(target, l0 + 0.01 * (l1 - l0)), l1 - 0.01 * (l1 - l0))
        trial, _, _, converged = continuation.newton_fixed(path, below[2], target)
        if not converged:
            if above is None and step > STABILITY_TOL * max(below[0], 1e-12):
                step *= 0.5
                above_limit = target
                kind = "limit point (Newton finds no equilibrium beyond)"
                continue
            break
        value = _stability(assembler, trial, target, K0s)
        evaluations += 1
        if value > 0.0:
            l0, f0 = below[0], below[1]
            below = (target, value, trial)
            if above is None:  # secant prediction of the zero, at most doubling the step
                slope = (value - f0) / (target - l0)
                guess = target - value / slope if slope < 0 else np.inf
                step = min(max(guess - target, 0.05 * step), 2 * step) if np.isfinite(guess) else 2 * step
                if kind is not None:
                    step = min(step, 0.5 * (above_limit - target))
        else:
            above = (target, value)
            kind = "bifurcation or limit point (tangent singular)"
        width = (above[0] if above is not None else (above_limit if kind else np.inf)) - below[0]
        if width <= STABILITY_TOL * max(below[0], 1e-12):
            break
        if above is None and below[0] > 1e6 * max(1.0, float(linearised[0]) if len(linearised) else 1.0):
            break
    if above is not None:
        (l0, f0, _), (l1, f1) = below, above
        factor = l0 + (l1 - l0) * f0 / (f0 - f1)
    elif kind is not None:
        factor = below[0]
    else:
        factor = None
    return {"buckling_factor": None if factor is None else float(factor),
            "buckling_kind": kind, "conservative": True,
            "instability": "none" if factor is None else "buckling",
            **({"flutter_factor": None, "flutter_searched_to": None}  # conservative: no flutter to search
               if prepared.scene.solve.flutter else {}),
            "linearised_buckling_factors": [float(x) for x in linearised[:count]],
            "stability_evaluations": evaluations,
            "buckling_s": time.perf_counter() - started}


def _state_from(model, template, arrays: dict):
    """A State from the flat arrays of ``State.as_dict`` (a recorded load step)."""
    state = template.copy()
    for key in ("x", "T", "v", "w", "theta", "theta_dot"):
        if key in arrays:
            getattr(state, key).flat[:] = arrays[key]
    return state


# ----------------------------------------------------------------------------- linear models
def _input_forces(model, state, inputs) -> np.ndarray:
    """F (n × k): the generalized force of each unit input (``Scene.solve.linear_model``)."""
    scene = model.scene
    F = np.zeros((model.n_total + 1, len(inputs)))
    for j, (kind, ref) in enumerate(inputs):
        if kind == "hinge":
            F[model.hinge_dofs[model.hinge_index(*ref)], j] = 1.0
            continue
        if kind == "load":
            load = scene.loads[ref]
            point = load.at
            f = np.array([g.value(state.t) for g in load.force]) if load.force else np.zeros(3)
            mo = np.array([g.value(state.t) for g in load.moment]) if load.moment else np.zeros(3)
            if load.frame != "global":
                R = state.T[model.body_node[load.frame]]
                f, mo = R @ f, R @ mo
        else:
            point, axis = ref
            f, mo = np.zeros(3), np.zeros(3)
            (f if kind == "force" else mo)[axis] = 1.0
        node, r = model.point(point)
        if node not in set(model.free_nodes.tolist()):
            raise SceneError(scene.file, "solve.linear_model.inputs",
                             f"expected an input at a point that moves freely; {model.nodes[node].name} "
                             "is fixed, prescribed or rigidly linked")
        d = model.node_dofs[node]
        F[d[:3], j] += f
        F[d[3:], j] += np.cross(state.T[node] @ r, f) + mo
    return F[:model.n_dofs]


def _output_jacobians(lin: Linearisation, names: list[str]):
    """y₀, ∂y/∂q (at fixed velocities) and ∂y/∂v of the named probes, by central differences of
    the probe functions (latdyn/probes.py)."""
    from latdyn.results.probes import ProbeSet

    model, assembler, state = lin.model, lin.assembler, lin.state
    probes = ProbeSet(assembler, assembler.initial_state())
    index = [probes.names.index(name) for name in names]

    def y(s):
        return np.array(probes.values(s))[index]

    n = model.n_dofs
    h = _steps(model, length_scale(model))
    Cq, Cv = np.zeros((len(names), n)), np.zeros((len(names), n))
    v0 = pack(model, state.v, state.w, state.theta_dot)[:n]
    for j in range(n):
        e = np.zeros(n)
        e[j] = h[j]
        Cq[:, j] = (y(assembler.advance(state, e)) - y(assembler.advance(state, -e))) / (2 * h[j])
        plus, minus = state.copy(), state.copy()
        unpack_free(model, v0 + e, plus.v, plus.w, plus.theta_dot)
        unpack_free(model, v0 - e, minus.v, minus.w, minus.theta_dot)
        Cv[:, j] = (y(plus) - y(minus)) / (2 * h[j])
    return y(state.copy()), Cq, Cv


def linear_model(lin: Linearisation, spec: dict) -> dict:
    """A, B, C, D of ẋ = A x + B u, y − y₀ = C x + D u about the linearisation's state, x = [z, ż]
    (the directions with inertia, module docstring), u the named inputs, y the named probes;
    arrays for ``numpy.savez`` (``scipy.signal.StateSpace(A, B, C, D)``)."""
    red = reduce(lin)
    m = red.n_massive
    F = _input_forces(lin.model, lin.state, spec["inputs"])
    Br, Du = red.condense(F)
    Minv = np.linalg.inv(red.mass)
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-Minv @ red.stiffness, -Minv @ red.damping]])
    B = np.vstack([np.zeros((m, F.shape[1])), Minv @ Br])
    y0, Cq, Cv = _output_jacobians(lin, spec["outputs"])
    A1, _, _ = frame_kinematics(lin.model, lin.state, lin.frame)
    Cy = Cq + Cv @ A1  # δv = u̇ + A₁u
    C = np.hstack([Cy @ red.transform, Cv @ red.transform])
    D = Cy @ Du
    names = lin.model.dof_names()
    # a state's name: the coordinate it moves most (the basis is block-diagonal by joint)
    z_names = [names[int(np.argmax(np.abs(red.basis[:, k])))] for k in range(m)]
    return {"A": A, "B": B, "C": C, "D": D, "y0": y0,
            "inputs": np.array(spec["input_names"]), "outputs": np.array(spec["outputs"]),
            "states": np.array(z_names + [f"d/dt {s}" for s in z_names]),
            "state_description": np.array(
                "x = [z, dz/dt]: the coordinates with inertia (directions without inertia condensed "
                "statically), perturbations about the state in the frame turning at frame_omega, "
                "global components at time t; inputs: hinge torques (N m), point forces (N) and moments "
                "(N m) in global axes, loads[i] scale factors; outputs: probe values minus y0"),
            "t": np.array(lin.state.t), "frame_omega": lin.frame.omega, "load_factor": np.array(lin.load_factor)}


def write_linear_model(prepared, out_dir, summary: dict, lin: Linearisation | None = None) -> dict:
    """``OUT/linear_model.npz`` about ``solve.about`` (SCENE.md); ``lin`` when already computed."""
    scene = prepared.scene
    if lin is None:
        other, state, frame, load_factor = state_about(prepared, scene.solve.about)
        lin = linearise(other.assembler, state, frame, load_factor)
    arrays = linear_model(lin, scene.solve.linear_model)
    if out_dir is not None:
        from pathlib import Path

        np.savez(Path(out_dir) / LINEAR_MODEL_FILE, **arrays)
    summary["linear_model"] = {"states": int(arrays["A"].shape[0]), "inputs": int(arrays["B"].shape[1]),
                               "outputs": int(arrays["C"].shape[0])}
    return arrays


LINEAR_MODEL_FILE = "linear_model.npz"


#: Frames per period of each mode's animation (``OUT/paraview/modes``).
MODE_FRAMES = 16
#: The largest translation of an animated mode, times the scene's size ℓ (or rotation, rad).
MODE_AMPLITUDE = 0.05
MODES_DIR = "modes"


def write_mode_shapes(lin: Linearisation, found: list[Mode], out_dir) -> list[str]:
    """The mode shapes as ParaView animations: ``OUT/paraview/modes/mode_<k>/<part>.vtkhdf``
    (latdyn.results.paraview's parts and fields), one period in :data:`MODE_FRAMES` frames whose "time" is
    the phase as a fraction of the period; the state ⊕ a·Re(φ e^{2πi·phase}), φ scaled so that its
    largest translation is MODE_AMPLITUDE·ℓ (a mode without translation: its largest rotation
    MODE_AMPLITUDE rad).  ``displacement`` is then the mode's motion about the state."""
    import shutil
    from pathlib import Path

    from latdyn.results import paraview as paraview

    if out_dir is None or not found:
        return []
    folder = Path(out_dir) / paraview.PARAVIEW_DIR / MODES_DIR
    if folder.is_dir():  # ours: an earlier run's modes go
        shutil.rmtree(folder)
    model, assembler, state = lin.model, lin.assembler, lin.state
    length = length_scale(model)
    mesh = paraview.parts(model, state)
    translations = model.node_dofs[model.free_nodes, 0:3].ravel()
    translations = translations[translations < model.n_dofs]
    written = []
    for k, mode in enumerate(found, start=1):
        phi = mode.shape / max(np.abs(mode.shape).max(), 1e-300)
        moved = np.abs(phi[translations]).max() if len(translations) else 0.0
        scale = MODE_AMPLITUDE * (length / moved if moved > 1e-6 else 1.0)
        writer = paraview.ParaviewWriter(folder / f"mode_{k:02d}", mesh, every=None)
        try:
            for j in range(MODE_FRAMES + 1):
                phase = j / MODE_FRAMES
                shifted = assembler.advance(state, scale * np.real(phi * np.exp(2j * np.pi * phase)))
                writer.record(phase, paraview.frame(assembler, mesh, shifted))
        finally:
            writer.close()
        written += [f"{paraview.PARAVIEW_DIR}/{MODES_DIR}/mode_{k:02d}/{name}" for name in
                    (Path(f).name for f in writer.files)]
    return written
