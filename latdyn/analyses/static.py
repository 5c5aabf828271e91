"""Static analysis with load stepping, and modal analysis about the initial configuration."""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import advance, apply_prescribed
from latdyn.errors import SolverError
from latdyn.numerics.inertia import split_inertia
from latdyn.numerics.linalg import solve_linear
from latdyn.step.integrators import increment_size, newton_diagnosis


def static_analysis(prepared, probes, writer, length_scale: float) -> None:
    """Newton on the tangent at load factors λ = k/steps, k = 1…steps.

    Loads, gravity and hinge torques are their values at t = 0 scaled by λ;
    prescribed bodies and hinge angles sit at their t = 0 positions.  A step
    that does not converge is split in halves (down to 1/64 of a step).
    """
    scene, model, assembler = prepared.scene, prepared.model, prepared.assembler
    state = prepared.state
    state.v[:] = state.w[:] = 0.0
    state.theta_dot[:] = 0.0
    tol = scene.solve.tol if scene.solve.tol is not None else 1e-10
    max_iter = max(scene.solve.max_iterations, 30)
    writer.record(0.0, probes.values(state), state=state.as_dict(), frame=_frame(assembler, writer, state))
    steps = scene.solve.steps
    lam, dlam = 0.0, 1.0 / steps
    iterations = 0
    done = 0
    while lam < 1.0 - 1e-12:
        target = min(1.0, lam + dlam)
        trial = state
        converged = False
        residual = None
        for _ in range(max_iter):
            ev = assembler.evaluate(trial, matrices=True, load_factor=target, inertia=False)
            residual = ev.residual
            if model.n_dofs == 0:
                converged = True
                break
            try:
                dx = solve_linear(ev.stiffness, -ev.residual)
            except (np.linalg.LinAlgError, RuntimeError):
                break
            if not np.all(np.isfinite(dx)):
                break
            trial = advance(model, trial, dx)
            apply_prescribed(model, trial, 0.0)
            iterations += 1
            if increment_size(model, dx, length_scale) <= tol:
                converged = True
                break
        if not converged:
            if dlam < 1.0 / (64 * steps):
                raise SolverError(f"static analysis failed at load factor {target:.4g}",
                                  newton_diagnosis(model, residual, target, dlam))
            dlam /= 2
            continue
        state, lam = trial, target
        done += 1
        if abs(lam * steps - round(lam * steps)) < 1e-9:
            writer.record(lam, probes.values(state), state=state.as_dict(), frame=_frame(assembler, writer, state))
        dlam = min(dlam * 2, 1.0 / steps)
        writer.summary.update(steps=done, newton_iterations=iterations)
    prepared.state = state


def _frame(assembler, writer, state):
    """The ParaView frame of a load step, computed only if the writer writes it."""
    from latdyn.results.paraview import frame

    snapshot = state.copy()
    return lambda: frame(assembler, writer.mesh, snapshot)


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
