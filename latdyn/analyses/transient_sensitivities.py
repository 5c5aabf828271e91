"""Exact sensitivities of transient runs: direct differentiation of the discrete Lie-group
generalized-α step (SCENE.md, "Parameters and sensitivities"; docs/parameters.md).

The step (latdyn/step/integrators.py) maps x_n = (q_n, v_n, v̇_n, a_n) to x_{n+1} with

    a_{n+1} = ((1 − α_f) v̇_{n+1} + α_f v̇_n − α_m a_n) / (1 − α_m)
    Δq      = v_n + h(½ − β) a_n + hβ a_{n+1},     q_{n+1} = q_n ∘ exp(h Δq)
    v_{n+1} = v_n + h(1 − γ) a_n + hγ a_{n+1}
    r(q_{n+1}, v_{n+1}, v̇_{n+1}, t_{n+1}; p) = 0.

Its derivative by a parameter p, with δq in the coordinates of the configuration update (x += δd,
T ← exp(skew δπ) T, θ += δθ: rotations in the spatial tangent space): from
T_{n+1} = exp(h Δq) T_n,

    δπ_{n+1} = R δπ_n + J h δΔq,    R = exp(skew hΔq),  J = dexp(hΔq)  (:func:`latdyn.numerics.so3.dexp_so3`)

(translations and hinge angles: δd_{n+1} = δd_n + h δΔq). With y = δv̇_{n+1} = β′z, the predicted
parts (those of y = 0) δa⁰, δΔq⁰, δv⁰, δq⁰, and δq_{n+1} = δq⁰ + J z, δv_{n+1} = δv⁰ + γ′z, the
differentiated equilibrium K δq + C δv + M δv̇ + ∂r/∂p = 0 reads

    (β′M + γ′C + K J) z = −(∂r/∂p + K δq⁰ + C δv⁰),

one linear solve per accepted step for all parameters (one column each), with the EXACT matrix at
the converged state: M, C and K of the evaluation that ``newton: exact`` uses (K with the elements'
inertia tangent, :meth:`latdyn.assembly.assembler.Assembler.evaluate` ``inertia_tangent``), the
joint bodies' inertia tangent (the generated ``joint_body_inertia_stiffness``, which the step's
matrix leaves out) and the tangent operator J of exp (the step's matrix takes J ≈ I). The step's
own factorization is not that matrix (modified Newton may hold an older one), so the matrix is
factorised afresh. ∂r/∂p comes from the generated kernels by their linearity in the parameters
(:class:`latdyn.analyses.sensitivities.ParameterDerivatives`, with the inertia forces). The
accepted step sizes are held: a fixed-step run (its cuts after a Newton failure included) is
differentiated exactly; adaptive step control is refused (its step sizes depend on p).

At t = 0 the configuration depends on no supported parameter (δq_0 = 0); the velocities do through
``initial_velocity.linear`` and ``.angular`` only, in which they are affine at a fixed ``about``
(:func:`latdyn.assembly.initial.initial_velocities`): δv_0 = v_0(its values + their derivatives) −
v_0(its values), exactly. The start's consistent accelerations
(:func:`latdyn.step.integrators.consistent_acceleration`) are
differentiated as the start computes them: v̇_0 = Δ(r) is linear in the residual r at fixed M, K
and split into directions with and without inertia, so δv̇_0 = Δ(∂r/∂p + C δv_0 at the started
state), and δa_0 = δv̇_0. That is exact when the split has no directions without inertia (then Δ = −M⁻¹r, and
∂r/∂p at the started state holds ∂M/∂p v̇_0), or when the parameter moves neither M, K nor the split
(global load components, hinge damping, torque and rest angle), or when the start is at rest in
equilibrium (Δ = 0 and the statics of the directions without inertia balanced, to 1e-9 in SI
units), where the terms ∂M/∂p Δ, ∂K/∂p Δ vanish; anything else is refused
(:class:`latdyn.errors.SceneError` naming ``solve.sensitivities``).

This round runs one step at a time from Python (the time loop's per-step path; the native loop is
later); it carries (δq, δv, δv̇, δa) on the free coordinates, (n, k), in
:attr:`latdyn.timeloop.progress.TransientProgress.sensitivities`, checkpointed with the run.
"""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from latdyn.analyses.sensitivities import (_BODY_KEY, _HINGE_KEY, _INITIAL_VELOCITY_KEY, _LOAD_KEY, _SECTION_KEY,
                                           SENSITIVITIES_FILE, ParameterDerivatives)
from latdyn.assembly.assembler import free_velocity, unpack_free
from latdyn.assembly.factorization import solve_linear
from latdyn.errors import SceneError, SolverError
from latdyn.numerics.inertia import split_inertia
from latdyn.numerics.linalg import issparse
from latdyn.numerics.so3 import dexp_so3, expm_so3
from latdyn.step.integrators import consistent_acceleration

__all__ = ["TransientSensitivities"]

#: |v̇_0| and |Q_cᵀ r| below which a start counts as at rest in equilibrium (SI units; module docstring)
AT_REST = 1e-9


class TransientSensitivities(ParameterDerivatives):
    """The sensitivities of a transient run (module docstring). The time loop calls :meth:`start` at
    t = 0, :meth:`step` per accepted step, :meth:`record` per recorded row and :meth:`finish` at the
    end; what it carries between them is a dict (``carried``), replaced, never changed in place."""

    def __init__(self, prepared):
        super().__init__(prepared)
        self.params = self.length = None

    def bind(self, integrator) -> None:
        """The integrator's parameters (α_m, α_f, γ, β) and length scale (the inertia tangent's steps)."""
        self.params, self.length = integrator.p, integrator.length_scale

    # ------------------------------------------------------------------ t = 0
    def start(self, state) -> dict:
        """The carried sensitivities at t = 0 (after the integrator's start made ``state``'s
        accelerations consistent): δq = δv = 0, δv̇ = δa = the start's derivative."""
        model, k = self.model, len(self.names)
        n = model.n_dofs
        zero = np.zeros((n, k))
        carried = {"dq": zero, "dv": zero, "dvdot": zero, "da": zero, "rows": []}
        if n == 0 or k == 0:
            return carried
        ev = self.assembler.evaluate(state, matrices=True)
        split = split_inertia(model, ev.combined(1.0, 0.0, 0.0))
        if split.n_massless:
            self._refuse_start(state, ev, split)
        dv = self._initial_velocities()
        rhs = self.residual_derivatives(state, 1.0, inertia=True) + ev.combined(0.0, 1.0, 0.0) @ dv
        dvdot = np.column_stack([consistent_acceleration(model, SimpleNamespace(residual=rhs[:, c],
                                                                                combined=ev.combined))
                                 for c in range(k)])
        return {**carried, "dv": dv, "dvdot": dvdot, "da": dvdot.copy()}

    def _initial_velocities(self) -> np.ndarray:
        """δv_0 (n, k): the initial state's free velocities with the rigid motion's components moved by
        their derivatives, less without (affine in them at a fixed ``about``)."""
        model, scene = self.model, self.scene
        dv = np.zeros((model.n_dofs, len(self.names)))
        given = scene.initial_velocity
        for key, laws in self.derivatives.items():
            initial = _INITIAL_VELOCITY_KEY.match(key)
            if not initial:
                continue
            for column, law in laws.items():
                moved = {"linear": np.array(given.linear, float), "angular": np.array(given.angular, float)}
                moved[initial["kind"]][int(initial["axis"])] += law.value(0.0, 0.0, 0.0)
                try:
                    scene.initial_velocity = type(given)(moved["linear"], moved["angular"], given.about, given.given)
                    ahead = free_velocity(model, self.assembler.initial_state())
                finally:
                    scene.initial_velocity = given
                dv[:, column] += ahead - free_velocity(model, self.assembler.initial_state())
        return dv

    def _refuse_start(self, state, ev, split) -> None:
        """With directions without inertia, the start's derivative is exact only for parameters that move
        neither M nor K, or at rest in equilibrium (module docstring)."""
        moving = [key for key in self.derivatives
                  if _SECTION_KEY.match(key) or _BODY_KEY.match(key) or _INITIAL_VELOCITY_KEY.match(key)
                  or (_HINGE_KEY.match(key) and _HINGE_KEY.match(key)["law"] == "stiffness")
                  or (_LOAD_KEY.match(key) and self.scene.loads[int(_LOAD_KEY.match(key)["load"])].frame != "global")]
        if not moving:
            return
        from latdyn.assembly.assembler import free_acceleration

        accelerations = np.max(np.abs(free_acceleration(self.model, state)), initial=0.0)
        unbalanced = np.max(np.abs(split.massless.T @ ev.residual), initial=0.0)
        if accelerations > AT_REST or unbalanced > AT_REST:
            raise SceneError(self.scene.file, "solve.sensitivities",
                             f"the model has {split.n_massless} direction(s) without inertia and the run does not "
                             f"start at rest in equilibrium (accelerations up to {accelerations:.3g} at t = 0), so "
                             f"the start's consistent accelerations depend on {moving[0]} through M and K, which "
                             "is not differentiated yet; expected a start at rest in equilibrium, rotary inertia "
                             "(rhoIy, rhoIz) on the beams, or parameters of global loads and hinge damping, torque "
                             "and rest angle (docs/parameters.md, \"Transient sensitivities\")")

    # ------------------------------------------------------------------ a step
    def step(self, carried: dict, old, new, h: float, a_old: np.ndarray, a_new: np.ndarray) -> dict:
        """The carried sensitivities after the accepted step ``old`` → ``new`` of size ``h`` (``a_old``,
        ``a_new``: the algorithmic accelerations before and after it)."""
        model, p = self.model, self.params
        n, k = model.n_dofs, len(self.names)
        if n == 0 or k == 0:
            return carried
        am, af, gamma, beta = p.alpha_m, p.alpha_f, p.gamma, p.beta
        beta_p, gamma_p = (1 - am) / (h * h * beta * (1 - af)), gamma / (h * beta)
        dq, dv, dvdot, da = carried["dq"], carried["dv"], carried["dvdot"], carried["da"]
        # the step's own increment hΔq, its rotations' exp and tangent operator
        increment = h * (free_velocity(model, old) + h * (0.5 - beta) * a_old + h * beta * a_new)
        turn, tangent = self._rotation_operators(increment)
        da0 = (af * dvdot - am * da) / (1 - am)
        dq0 = turn(dq) + tangent(h * (dv + h * (0.5 - beta) * da + h * beta * da0))
        dv0 = dv + h * (1 - gamma) * da + h * gamma * da0
        M, C, K = self._matrices(new)
        rhs = -(self.residual_derivatives(new, 1.0, inertia=True) + K @ dq0 + C @ dv0)
        J = tangent.matrix if issparse(K) else tangent.matrix.toarray()
        matrix = beta_p * M + gamma_p * C + K @ J
        try:
            z = np.asarray(solve_linear(matrix, rhs)).reshape(n, k)
        except np.linalg.LinAlgError:
            raise SolverError(f"the sensitivities at t = {new.t:.6g} need the step's exact iteration matrix, "
                              "which is singular there") from None
        dvdot_new = beta_p * z
        return {"dq": dq0 + tangent(z), "dv": dv0 + gamma_p * z, "dvdot": dvdot_new,
                "da": da0 + (1 - af) / (1 - am) * dvdot_new, "rows": carried["rows"]}

    def _matrices(self, state):
        """M, C and the exact K at ``state`` (:meth:`latdyn.assembly.assembler.Assembler.exact_matrices`:
        the elements' inertia tangent and the joint bodies' ``joint_body_inertia_stiffness``, which the
        step's Newton matrix leaves out)."""
        return self.assembler.exact_matrices(state, length=self.length)

    def _rotation_operators(self, increment: np.ndarray):
        """(R·, J·) on free-coordinate columns for the step's increment hΔq: on each free node's
        rotation coordinates R = exp(skew hΔq) and J = dexp(hΔq), the identity elsewhere; J also as a
        matrix (``.matrix``, the form of the iteration matrix's storage)."""
        model = self.model
        n = model.n_dofs
        nodes = model.free_nodes
        slots = model.node_dofs[nodes, 3:6]                               # (f, 3), ≥ n: not a coordinate
        padded = np.append(increment, 0.0)
        psi = padded[np.where(slots < n, slots, n)]
        R, J = expm_so3(psi), dexp_so3(psi)
        on = slots < n

        def operator(blocks):
            def apply(columns):
                out = np.array(columns, dtype=float, copy=True)
                full = np.vstack([columns, np.zeros((1, columns.shape[1]))])
                pieces = full[np.where(on, slots, n)]                     # (f, 3, k)
                turned = np.einsum("fij,fjk->fik", blocks, pieces)
                out[slots[on]] = turned[on]
                return out
            return apply

        turn, tangent = operator(R), operator(J)
        rows = np.broadcast_to(slots[:, :, None], J.shape)
        cols = np.broadcast_to(slots[:, None, :], J.shape)
        keep = (rows < n) & (cols < n)
        fixed = np.ones(n, bool)
        fixed[slots[on]] = False
        r = np.concatenate([np.flatnonzero(fixed), rows[keep]])
        c = np.concatenate([np.flatnonzero(fixed), cols[keep]])
        values = np.concatenate([np.ones(int(fixed.sum())), J[keep]])
        if n <= 0:
            matrix = np.zeros((0, 0))
        else:
            import scipy.sparse as sps

            matrix = sps.csr_matrix((values, (r, c)), shape=(n, n))
        tangent.matrix = matrix
        return turn, tangent

    # ------------------------------------------------------------------ rows
    def record(self, carried: dict, state) -> dict:
        """``carried`` with the row of every probe's sensitivity at ``state`` (a new list of rows)."""
        model, k = self.model, len(self.names)
        by_parameter = []
        for column in range(k):
            dx, dpi, dtheta = np.zeros_like(state.x), np.zeros_like(state.x), np.zeros_like(state.theta)
            if model.n_dofs:
                unpack_free(model, carried["dq"][:, column], dx, dpi, dtheta)
            by_parameter.append((dx, dpi, dtheta))
        row = [float(state.t)] + [self._probe_derivative(p, state, *by_parameter[c])
                                  for p in self.probes for c in range(k)]
        return {**carried, "rows": carried["rows"] + [row]}

    def table(self, carried: dict) -> dict:
        """``{(probe, name): array over the rows}`` (``Result.sensitivities``)."""
        data = np.array(carried["rows"], float).reshape(len(carried["rows"]), 1 + len(self.columns))
        return {(p.name, name): data[:, 1 + i * len(self.names) + c]
                for i, p in enumerate(self.probes) for c, name in enumerate(self.names)}

    def finish(self, carried: dict, writer) -> None:
        """``sensitivities.csv`` (``t,<probe>/<NAME>,…``), summary.json ``probe_sensitivities`` (each
        probe's derivative at the last row and at the rows of its largest and smallest value, the first
        where several tie) and ``event_sensitivities`` (no events: a run with events is refused), and
        the table the Result carries."""
        from latdyn.results.files import atomic_write_bytes, csv_line

        table = self.table(carried)
        writer.sensitivities = table
        recorded = writer.result()
        out = {}
        for p in self.probes:
            values = np.asarray(recorded.probes[p.name])[:len(carried["rows"])]
            if len(values) == 0:
                continue
            last, high, low = len(values) - 1, int(np.argmax(values)), int(np.argmin(values))
            out[p.name] = {which: {name: float(table[(p.name, name)][row]) for name in self.names}
                           for which, row in (("end", last), ("max", high), ("min", low))}
        writer.summary["probe_sensitivities"] = out
        writer.summary["event_sensitivities"] = []
        if writer.out_dir is not None:
            text = csv_line(["t", *self.columns]) + "".join(csv_line(row) for row in carried["rows"])
            atomic_write_bytes(Path(writer.out_dir) / SENSITIVITIES_FILE, text.encode("utf-8"))
