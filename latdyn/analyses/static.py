"""Static analysis (load stepping and path following, :mod:`latdyn.analyses.continuation`), and modal analysis
about the initial configuration."""
from __future__ import annotations

import numpy as np

from latdyn.numerics.inertia import split_inertia


def static_analysis(prepared, probes, writer, length_scale: float) -> None:
    """The static analysis by its ``solve.method``: load control on the grid λ = k/steps (default),
    arc-length continuation or displacement control (:mod:`latdyn.analyses.continuation`)."""
    from latdyn.analyses.continuation import static_path

    static_path(prepared, probes, writer, length_scale)


def modal_analysis(prepared, count: int) -> np.ndarray:
    """Lowest ``count`` natural frequencies (Hz) about the initial configuration.

    Directions without inertia (found joint by joint, :mod:`latdyn.numerics.inertia`) are
    condensed statically, which is exact for them (Guyan):  in the basis
    Q = [Q_m, Q_c] with M Q_c = 0,  K_red = K_mm − K_mc K_cc⁻¹ K_cm  and
    M_red = Q_mᵀ M Q_m, positive definite.  Rigid-body modes come out near zero.
    """
    model, assembler = prepared.model, prepared.assembler
    state = prepared.state.copy()
    state.v[:] = state.w[:] = 0.0
    state.theta_dot[:] = 0.0
    if model.n_dofs == 0:
        return np.zeros(0)
    ev = assembler.evaluate(state, matrices=True)
    M, K = ev.combined(1.0, 0.0, 0.0, dense=True), ev.combined(0.0, 0.0, 1.0, dense=True)
    split = split_inertia(model, M)
    Q = split.basis
    M = Q.T @ (0.5 * (M + M.T)) @ Q
    K = Q.T @ (0.5 * (K + K.T)) @ Q
    m = slice(0, split.n_massive)
    c = slice(split.n_massive, model.n_dofs)
    if split.n_massless:
        K = K[m, m] - K[m, c] @ np.linalg.solve(K[c, c], K[c, m])
    M = M[m, m]
    import scipy.linalg as sla

    eigenvalues = sla.eigh(0.5 * (K + K.T), 0.5 * (M + M.T), eigvals_only=True)
    omega = np.sqrt(np.clip(eigenvalues, 0.0, None))
    return (omega / (2 * np.pi))[:count]
