"""The response of the free coordinates to impulses on hinges: impacts on stops and latches.

An impact lasts no time: the configuration, and so every finite force (elastic, applied,
gravity), is continuous through it, and only the inertia forces take the impulse. On the
directions with inertia (Q_m of :func:`latdyn.numerics.inertia.split_inertia`, M Q_c = 0) the
velocities jump by Newton's impulse law; the directions without inertia (a massless beam, the
twist of an Euler–Bernoulli beam without rotary inertia) cannot take an impulse and stay in
their static equilibrium, Q_cᵀ r = 0, through the impact: their velocities are those the
massive ones imply,

    Δy_c = −K_cc⁻¹ K_cm Δy_m,          K_ab = Q_aᵀ K Q_b,

so that a velocity jump is Δv = Q T Δy_m with T = [I; −K_cc⁻¹ K_cm] (static condensation, as
in :func:`latdyn.step.integrators.consistent_acceleration`). A hinge constraint Nᵀv = u acts on
the massive directions through the condensed Jacobian Ñ = Tᵀ Qᵀ N (an impulse N λ on a
direction without inertia passes statically to the massive ones, by virtual work), and the
impulse law on the condensed system is

    M_mm Δy_m = Ñ λ,     Ñᵀ Δy_m = u − Nᵀv⁻,     M_mm = Q_mᵀ M Q_m,

so that Δv = X (NᵀX)⁻¹ (u − Nᵀv⁻) with X = Q T M_mm⁻¹ Ñ, the *impulse response* (the velocity
change per unit impulse on each hinge). On the massive directions the step's iteration matrix
weights what the step does not resolve, M_mm + h² K_red (K_red the condensed stiffness), as the
projection with M + h²K did before: stiff modes with inertia take the impact quasi-statically
(with M_mm alone the arm of tests/test_hinges.py, EI = 1e9, rang at ω ~ 1e5 rad/s and the run
ended unbounded). On a mechanism direction this changes the jump by O(h² k / I): second order.

The kinetic energy the jump removes: with one hinge moving into its stop at u⁻ and restitution
e, (1 − e²) · ½ u⁻² / (Ñᵀ M_mm⁻¹ Ñ) where M_mm alone weights the jump, the kinetic energy of the
impacting motion (docs/energy.md).

Open: where a massless beam's *bending* couples the hinge to a body's translation (a hinge across
a massless beam), the condensed Ñ lets the translation take part of the jump with weight
M_mm + h² K_red, and the result still depends on the step (docs/initial_state.md).

(Before, the jump was the projection weighted by A = M + dt²K, the integrator's iteration
matrix: the directions without inertia took part of the jump with weight dt²K against the
inertia of the massive ones, so a stop behind a massless beam gave answers that changed with the
step and converged to nothing; on flexible parts with inertia the jump depended on the step, and
a run through a latch was not second order.)
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sps

from latdyn.assembly.factorization import solve_linear
from latdyn.errors import SolverError
from latdyn.numerics.inertia import split_inertia


def hinge_directions(model, hinges) -> np.ndarray:
    """N: one column per hinge, the unit vector of its free coordinate (Nᵀv are the hinge rates)."""
    N = np.zeros((model.n_dofs, len(hinges)))
    N[model.hinge_dofs[list(hinges)], np.arange(len(hinges))] = 1.0
    return N


def impulse_response(model, ev, N: np.ndarray, step: float) -> np.ndarray:
    """X: the change of the free velocities per unit impulse on the constraint directions N (n × k),
    the directions without inertia following their statics (module docstring):

        [ Q_mᵀ(M + h²K)Q_m   h² Q_mᵀK Q_c ] [y_m]   [Ñ]
        [ Q_cᵀK Q_m            Q_cᵀK Q_c  ] [y_c] = [0],      X = Q_m y_m + Q_c y_c,

    h the nominal step; the second row is the statics of the directions without inertia, the
    first the impulse law on the massive ones, M_mm + h² K_red (K_red = K_mm − K_mc K_cc⁻¹ K_cm,
    never formed) weighting what the step does not resolve as in the integrator's iteration
    matrix. Without directions without inertia X = (M + h²K)⁻¹ N. Where a hinge's rate moves no
    direction with inertia (NᵀX singular: massless parts on both sides of it), nothing takes an
    impulse and its stop acts as a static constraint: X = (M + h²K)⁻¹ N, whose K-weighted
    projection keeps the massless parts in their statics against the stop."""
    quasi_static = ev.combined(1.0, 0.0, step * step)
    M = ev.mass
    split = split_inertia(model, M)
    if split.n_massless == 0 or split.n_massive == 0:
        return solve_linear(quasi_static, N).reshape(N.shape)
    Qm, Qc = split.massive, split.massless
    K = ev.stiffness
    Kcc = Qc.T @ K @ Qc
    Kcm = Qc.T @ K @ Qm
    Kcc_t = Kcc.T
    if sps.issparse(Kcc):
        Kcc, Kcc_t = Kcc.tocsr(), Kcc_t.tocsr()
    try:
        # Ñ = Q_mᵀN − K_cmᵀ K_cc⁻ᵀ Q_cᵀN: the impulse on the massless directions, passed on statically
        passed = solve_linear(Kcc_t, np.asarray(Qc.T @ N))
    except np.linalg.LinAlgError as exc:
        raise SolverError("a coordinate without inertia is held by no stiffness",
                          "directions of the model carry neither inertia nor stiffness; "
                          "`latdyn check` names the coordinate") from exc
    condensed = np.asarray(Qm.T @ N).reshape(split.n_massive, -1) - np.asarray(Kcm.T @ passed).reshape(split.n_massive, -1)
    blocks = [[Qm.T @ quasi_static @ Qm, step * step * (Qm.T @ K @ Qc)], [Kcm, Kcc]]
    if sps.issparse(Kcc):
        B = sps.bmat([[sps.csr_matrix(b) for b in row] for row in blocks], format="csr")
    else:
        B = np.block(blocks)
    rhs = np.vstack([condensed, np.zeros((split.n_massless, condensed.shape[1]))])
    X = np.asarray(split.basis @ solve_linear(B, rhs)).reshape(N.shape)
    NtX = N.T @ X
    scale = max(float(np.max(np.abs(np.diag(NtX)), initial=0.0)), 1e-300)
    if not np.all(np.isfinite(NtX)) or np.linalg.matrix_rank(NtX, tol=1e-10 * scale) < N.shape[1]:
        return solve_linear(quasi_static, N).reshape(N.shape)
    return X


def jump(X: np.ndarray, N: np.ndarray, v: np.ndarray, target: np.ndarray) -> np.ndarray:
    """v⁺ = v⁻ + X (NᵀX)⁻¹ (target − Nᵀv⁻): the velocities after the impulses that bring the hinge
    rates Nᵀv to ``target``."""
    return v + X @ np.linalg.solve(N.T @ X, target - N.T @ v)
