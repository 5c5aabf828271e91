"""A reference for the native generalized-α Newton iteration, in the tests only.

The runtime's Newton iteration exists once, in C (``latdyn_newton_step``,
latdyn/assembly/csrc/newton_step.c; :class:`latdyn.step.compiled.CompiledGeneralizedAlpha`).
This module restates it from the scheme of :mod:`latdyn.step.integrators` in a few lines of
NumPy around the same one evaluation (:meth:`latdyn.assembly.assembler.Assembler.evaluate`,
rigid links reduced by :mod:`latdyn.assembly.linked`), with SciPy's solve: what the C iteration,
its matrix storages (dense, band, sparse LU), its modified Newton and its loop of steps must
equal. :func:`reference_engine` makes :func:`latdyn.run` step with it.
"""
from __future__ import annotations

import contextlib

import numpy as np

from latdyn.assembly.assembler import State, free_acceleration, free_velocity, unpack_free
from latdyn.assembly.factorization import solve_linear
from latdyn.step.integrators import GeneralizedAlpha, StepStats, increment_size
from latdyn.timeloop import transient


class ReferenceGeneralizedAlpha(GeneralizedAlpha):
    """:class:`GeneralizedAlpha` with the step taken in Python, full Newton."""

    def step(self, state: State, h: float, t_new: float | None = None) -> tuple[State, StepStats]:
        """One step of size h from ``state``; ``t_new`` (default t + h) is the exact landing time."""
        model = self.assembler.model
        p = self.p
        n = model.n_dofs
        t_new = state.t + h if t_new is None else t_new
        v_n = free_velocity(model, state)
        vdot_n = free_acceleration(model, state)
        a_n = self.a
        # predictor: v̇_{n+1} = v̇_n
        vdot = vdot_n.copy()
        a_new = (p.alpha_f * vdot_n + (1 - p.alpha_f) * vdot - p.alpha_m * a_n) / (1 - p.alpha_m)
        v = v_n + h * (1 - p.gamma) * a_n + h * p.gamma * a_new
        dq = v_n + h * (0.5 - p.beta) * a_n + h * p.beta * a_new
        beta_p = (1 - p.alpha_m) / (h * h * p.beta * (1 - p.alpha_f))
        gamma_p = p.gamma / (h * p.beta)
        stats = StepStats()

        def configured() -> State:
            """q_n ∘ exp(hΔq) at t_{n+1}, with the current v and v̇."""
            s = self.assembler.advance(state, h * dq)
            self.assembler.apply_prescribed(s, t_new)
            unpack_free(model, v, s.v, s.w, s.theta_dot)
            unpack_free(model, vdot, s.a, s.alpha, s.theta_ddot)
            return s

        trial = state
        previous = np.inf
        for iteration in range(1, self.max_iterations + 1):
            trial = configured()
            ev = self.assembler.evaluate(trial, matrices=True, inertia_tangent=self.inertia_tangent and n > 0)
            self.last_evaluation = ev
            if n == 0:
                stats.converged = True
                break
            S = ev.combined(beta_p, gamma_p, 1.0)
            try:
                dx = solve_linear(S, -ev.residual)
            except (np.linalg.LinAlgError, RuntimeError):
                stats.residual = ev.residual
                break
            if not np.all(np.isfinite(dx)):
                stats.residual = ev.residual
                break
            dq += dx / h
            v += gamma_p * dx
            vdot += beta_p * dx
            stats.iterations = iteration
            size = increment_size(self.assembler, dx, self.length_scale)
            if iteration > 1:
                stats.contraction = max(stats.contraction, size / previous)
            previous = size
            if size <= self.tol:
                stats.converged = True
                trial = configured()
                break
            stats.residual = ev.residual
        if stats.converged:
            self.a_candidate = (p.alpha_f * vdot_n + (1 - p.alpha_f) * vdot - p.alpha_m * a_n) / (1 - p.alpha_m)
        return trial, stats



@contextlib.contextmanager
def reference_engine():
    """Within: :func:`latdyn.run` takes its implicit steps with :class:`ReferenceGeneralizedAlpha`
    (``summary.json``'s ``engine`` says ``reference``)."""
    native = transient.implicit_integrator

    def reference(prepared, params, tol, length, summary):
        integrator = ReferenceGeneralizedAlpha(prepared.assembler, params, tol, prepared.scene.solve.max_iterations,
                                               length)
        integrator.inertia_tangent = prepared.scene.solve.newton == "exact"
        summary.update(engine="reference", newton="exact" if prepared.scene.solve.newton == "exact" else "full")
        return integrator

    transient.implicit_integrator = reference
    try:
        yield
    finally:
        transient.implicit_integrator = native
