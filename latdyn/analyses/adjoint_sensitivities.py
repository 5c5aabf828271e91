"""The discrete adjoint of a transient run: the derivatives of a few scalar outputs by many parameters
(``solve.sensitivity_method: adjoint``; docs/parameters.md, "The discrete adjoint").

The forward method (:mod:`latdyn.analyses.transient_sensitivities`) carries the columns
X_n = (δq, δv, δv̇, δa) of every parameter through each accepted step,

    δa⁰ = (α_f δv̇ − α_m δa)/(1 − α_m),   δu⁰ = h δv + h²(½ − β) δa + h²β δa⁰,
    δq⁰ = R δq + J δu⁰,                  δv⁰ = δv + h(1 − γ) δa + hγ δa⁰,
    A z = −(E + K δq⁰ + C δv⁰),          A = β′M + γ′C + K J,
    δq' = δq⁰ + J z,  δv' = δv⁰ + γ′z,  δv̇' = β′z,  δa' = δa⁰ + (1 − α_f)/(1 − α_m) β′z,

with E = ∂r/∂p at the step's end, M, C and the exact K there, R = exp(skew hΔq) and J = dexp(hΔq) on the
rotation coordinates. The recurrence is linear in X and in E, and an output is linear in one row's δq
(a point x + T r moves by δx + δπ × T r, a hinge angle by δθ): dy/dp = cᵀ δq_row (a rate's and a joint
force's also c_vᵀδv_row, a joint force's c_v̇ᵀδv̇_row and its explicit ∂/∂p: seeded into v̄, v̇̄ and the
gradient at its row). So the derivative of m
outputs by k parameters is the transposed recurrence run backwards over the stored trajectory with m
columns (X̄ = (q̄, v̄, v̇̄, ā), each (n, m)): per step, from the bars at the step's end,

    z̄ = Jᵀq̄ + γ′v̄ + β′v̇̄ + (1 − α_f)/(1 − α_m) β′ā,      w = A⁻ᵀ z̄,      dy/dp += −Eᵀ w,
    q̄⁰ = q̄ − Kᵀw,  v̄⁰ = v̄ − Cᵀw,  ā⁰ = ā + hγ v̄⁰ + h²β ū,   ū = Jᵀq̄⁰,
    q̄ ← Rᵀq̄⁰,  v̄ ← v̄⁰ + h ū,  ā ← h(1 − γ) v̄⁰ + h²(½ − β) ū − α_m/(1 − α_m) ā⁰,  v̇̄ ← α_f/(1 − α_m) ā⁰,

and each output's cᵀ added to q̄ at its row. At t = 0 (δq_0 = 0, δv_0 = D_v the initial velocities',
δv̇_0 = δa_0 = Δ(E_0 + C_0 D_v), Δ the start's consistent accelerations, linear in the residual):
r̄ = Δᵀ(v̇̄_0 + ā_0), dy/dp += E_0ᵀ r̄ + D_vᵀ(v̄_0 + C_0ᵀ r̄). Δ = −M⁻¹ where every direction has inertia;
with directions without inertia it is :func:`latdyn.step.integrators.consistent_acceleration`, whose
factors (I − Q_c K_cc⁻¹ Q_cᵀ K)(−Q_m (Q_mᵀ M Q_m)⁻¹ Q_mᵀ)(I − K Q_c K_cc⁻¹ Q_cᵀ) transposed are the same map
of Mᵀ and Kᵀ (M symmetric: the same split), so Δᵀ is that function on the transposed matrices.

Rᵀ = exp(−skew hΔq) and Jᵀ = dexp(−hΔq) (the odd terms of both series change sign). The exact
matrices are evaluated again at each stored state on the reverse pass (:meth:`TransientSensitivities._matrices`),
E by the same batched kernels as the forward method (:meth:`TransientSensitivities.residual_derivatives`),
so the adjoint's derivatives are the forward method's to round-off, at a cost independent of k but for
the kernels of E.

What the forward pass stores, in memory (``carried["trajectory"]``, checkpointed with the run): each
accepted step's end state (a copy: 24 numbers a node and 3 a hinge) and size and the algorithmic
accelerations before and after it (2n numbers). What is refused (:func:`adjoint_refusal`, exit 2 naming
``solve.sensitivity_method``): everything the forward method refuses, and anything whose derivative
leaves the smooth recurrence above: events (hinge or guide ``lock_at`` and ``limits``, cables), guides,
controllers with states and sampled ones (continuous controllers without states enter E and the matrices
as in the forward method).
"""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from latdyn.analyses.energy_sensitivities import is_energy_or_momentum
from latdyn.analyses.energy_sensitivities import probe_forms as energy_probe_forms
from latdyn.analyses.joint_force_sensitivities import is_joint_force, joint_force_forms, joint_of
from latdyn.analyses.sensitivities import _BODY_KEY, SENSITIVITIES_FILE
from latdyn.analyses.transient_sensitivities import TransientSensitivities, _NodeRotations
from latdyn.assembly.assembler import free_velocity
from latdyn.assembly.factorization import solve_linear
from latdyn.errors import SolverError
from latdyn.numerics.inertia import split_inertia
from latdyn.numerics.linalg import issparse
from latdyn.step.integrators import consistent_acceleration

__all__ = ["AdjointSensitivities"]


class AdjointSensitivities(TransientSensitivities):
    """The discrete adjoint (module docstring), called by the time loop as the forward method is:
    :meth:`start` and :meth:`step` store the trajectory, :meth:`record` the rows' step indices, and
    :meth:`finish` runs the reverse pass and writes ``probe_sensitivities`` and the end row."""

    # ------------------------------------------------------------------ the forward pass: storing
    def start(self, state) -> dict:
        """The carried trajectory at t = 0: the started state (its accelerations consistent) and the
        refusals of the forward method's start (directions without inertia off rest)."""
        model = self.model
        carried = {"trajectory": [], "rows": [], "start": state.copy(), "events": []}
        if model.n_dofs and self.names:
            ev = self.assembler.evaluate(state, matrices=True)
            split = split_inertia(model, ev.combined(1.0, 0.0, 0.0))
            if split.n_massless:
                self._refuse_start(state, ev, split)
        return carried

    def step(self, carried: dict, old, new, h: float, a_old: np.ndarray, a_new: np.ndarray,
             lands: bool = True) -> dict:
        """The accepted step ``old`` → ``new`` stored (its end state, size and algorithmic accelerations);
        appended in place: the trajectory grows with the run and a copy per step would cost its length."""
        carried["trajectory"].append({"state": new.copy(), "h": float(h), "a_old": np.array(a_old, float),
                                      "a_new": np.array(a_new, float)})
        return carried

    def record(self, carried: dict, state) -> dict:
        """The row at ``state``: the index of the stored state it is (0: the start)."""
        carried["rows"].append(len(carried["trajectory"]))
        return carried

    # ------------------------------------------------------------------ the reverse pass
    def _section_derivative_blocks(self, state):
        """The forward method's section blocks (:meth:`ParameterDerivatives._section_derivative_blocks`),
        built once where no section value's derivative depends on t (each block depends on the state only
        through t): the reverse pass asks for them at every step, and at 10³ sections building them took
        most of its time (benchmarks/transient_sensitivities_cost.py --scene lattice1000)."""
        if "_held_section_blocks" not in self.__dict__:
            timed = any("t" in law.depends_on for key, laws in self.derivatives.items()
                        if key.startswith("sections.") for law in laws.values())
            self._held_section_blocks = None if timed else (super()._section_derivative_blocks(state),)
        held = self._held_section_blocks
        return super()._section_derivative_blocks(state) if held is None else held[0]

    def outputs(self, carried: dict, series: dict) -> list:
        """(probe, which, row index) of every output: each probe's last row and the rows of its largest
        and smallest recorded value (the first where several tie), as the forward method's summary."""
        out = []
        for probe in self.probes:
            values = np.asarray(series[probe.name])[:len(carried["rows"])]
            if len(values) == 0:
                continue
            for which, row in (("end", len(values) - 1), ("max", int(np.argmax(values))),
                               ("min", int(np.argmin(values)))):
                out.append((probe, which, row))
        return out

    def output_forms(self, probe, state) -> tuple:
        """(c_q, c_v, c_v̇ (n,) each, explicit (k,)): the probe's derivative at ``state`` is
        c_qᵀδq + c_vᵀδv + c_v̇ᵀδv̇ + explicit — a joint force's the forms of
        :func:`latdyn.analyses.joint_force_sensitivities.joint_force_forms` (its law's slopes and ∂f/∂p while
        free, a prescribed joint's exact rows and ∂r_d/∂p), any other probe's :meth:`output_gradient`."""
        if is_joint_force(probe):
            j = joint_of(self.model, probe)
            return joint_force_forms(self, state, [j])[j]
        if is_energy_or_momentum(probe):   # latdyn/analyses/energy_sensitivities.py
            c_q, c_v, explicit = energy_probe_forms(self, probe, state, _BODY_KEY)
            return c_q, c_v, np.zeros_like(c_q), explicit
        c_q, c_v = self.output_gradient(probe, state)
        return c_q, c_v, np.zeros_like(c_q), np.zeros(len(self.names))

    def output_gradient(self, probe, state) -> tuple:
        """(c_q, c_v) (n,) each: the probe's derivative at ``state`` is c_qᵀδq + c_vᵀδv
        (:meth:`_probe_derivatives` on the unit columns of the coordinates it reads, its node's or its
        hinge's: a position or angle reads δq alone, a rate or velocity δv and, through ω × (δπ × T r),
        δq)."""
        model, n = self.model, self.model.n_dofs
        if probe.kind in ("hinge", "guide"):
            joint = (probe.beam, probe.end) if probe.kind == "hinge" else (probe.body, "guide")
            dofs = np.array([model.hinge_dofs[model.hinge_index(*joint)]])
        else:
            dofs = model.node_dofs[model.point(probe.point)[0]]
        dofs = dofs[dofs < n]
        c_q, c_v = np.zeros(n), np.zeros(n)
        if len(dofs):
            units = np.zeros((n, len(dofs)))
            units[dofs, np.arange(len(dofs))] = 1.0
            still = np.zeros_like(units)
            c_q[dofs] = self._probe_derivatives(probe, state, *self._by_parameter(units, state),
                                                self._rates_by_parameter(still))
            if probe.quantity in ("rate", "velocity"):
                c_v[dofs] = self._probe_derivatives(probe, state, *self._by_parameter(still, state),
                                                    self._rates_by_parameter(units))
        return c_q, c_v

    def reverse(self, carried: dict, outputs: list) -> np.ndarray:
        """(k, m): the derivatives of the m ``outputs`` (:meth:`outputs`) by the k parameters, the
        transposed recurrence run backwards over the stored trajectory (module docstring)."""
        model, p = self.model, self.params
        n, k, m = model.n_dofs, len(self.names), len(outputs)
        gradient = np.zeros((k, m))
        if n == 0 or k == 0 or m == 0:
            return gradient
        trajectory, rows = carried["trajectory"], carried["rows"]
        states = [carried["start"]] + [entry["state"] for entry in trajectory]
        seeds: dict[int, list] = {}   # stored state index -> [(output column, (c_q, c_v, c_v̇, explicit))]
        for column, (probe, _, row) in enumerate(outputs):
            index = rows[row]   # at the start δq_0 = 0: a row there moves only through δv_0, δv̇_0 and explicitly
            seeds.setdefault(index, []).append((column, self.output_forms(probe, states[index])))
        am, af, gamma, beta = p.alpha_m, p.alpha_f, p.gamma, p.beta
        q_bar, v_bar, vdot_bar, a_bar = (np.zeros((n, m)) for _ in range(4))
        for i in range(len(trajectory) - 1, -1, -1):
            for column, (c_q, c_v, c_vdot, explicit) in seeds.get(i + 1, []):
                q_bar[:, column] += c_q
                v_bar[:, column] += c_v
                vdot_bar[:, column] += c_vdot
                gradient[:, column] += explicit
            entry = trajectory[i]
            h, new = entry["h"], entry["state"]
            beta_p, gamma_p = (1 - am) / (h * h * beta * (1 - af)), gamma / (h * beta)
            increment = h * (free_velocity(model, states[i]) + h * (0.5 - beta) * entry["a_old"]
                             + h * beta * entry["a_new"])
            # Rᵀ = exp(−skew hΔq) and Jᵀ = dexp(−hΔq) are the forward operators at −hΔq; J for the matrix K J
            turn_t, tangent_t = self._rotation_operators(-increment)
            J = _NodeRotations(self, np.transpose(tangent_t.blocks, (0, 2, 1)), tangent_t.slots, n).matrix
            M, C, K = self._matrices(new)
            if not issparse(K):
                J = J.toarray()
            matrix = beta_p * M + gamma_p * C + K @ J
            z_bar = tangent_t(q_bar) + gamma_p * v_bar + beta_p * vdot_bar + (1 - af) / (1 - am) * beta_p * a_bar
            try:
                w = np.asarray(solve_linear(_transposed(matrix), z_bar)).reshape(n, m)
            except np.linalg.LinAlgError:
                raise SolverError(f"the adjoint sensitivities at t = {new.t:.6g} need the step's exact iteration "
                                  "matrix, which is singular there") from None
            gradient -= self.residual_derivatives(new, 1.0, inertia=True).T @ w
            dq0_bar = q_bar - K.T @ w
            dv0_bar = v_bar - C.T @ w
            du0_bar = tangent_t(dq0_bar)
            da0_bar = a_bar + h * gamma * dv0_bar + h * h * beta * du0_bar
            q_bar = turn_t(dq0_bar)
            v_bar = dv0_bar + h * du0_bar
            a_bar = h * (1 - gamma) * dv0_bar + h * h * (0.5 - beta) * du0_bar - am / (1 - am) * da0_bar
            vdot_bar = af / (1 - am) * da0_bar
        for column, (_, c_v, c_vdot, explicit) in seeds.get(0, []):
            v_bar[:, column] += c_v
            vdot_bar[:, column] += c_vdot   # δv̇_0 = δa_0: the start's consistent accelerations' derivative
            gradient[:, column] += explicit
        return gradient + self._through_the_start(carried["start"], v_bar, vdot_bar + a_bar)

    def _through_the_start(self, state, v_bar: np.ndarray, s_bar: np.ndarray) -> np.ndarray:
        """(k, m) what t = 0 adds (module docstring): E_0ᵀ r̄ + D_vᵀ(v̄_0 + C_0ᵀ r̄), r̄ = Δᵀ s̄."""
        model = self.model
        ev = self.assembler.evaluate(state, matrices=True)
        M = ev.combined(1.0, 0.0, 0.0)
        split = split_inertia(model, M)
        if split.n_massless == 0:
            r_bar = -np.asarray(solve_linear(_transposed(M), s_bar)).reshape(s_bar.shape)
        else:
            transposed = SimpleNamespace(combined=lambda a, b, c: _transposed(ev.combined(a, b, c)))
            r_bar = np.column_stack([consistent_acceleration(model, SimpleNamespace(residual=s_bar[:, c],
                                                                                    combined=transposed.combined))
                                     for c in range(s_bar.shape[1])])
        C = ev.combined(0.0, 1.0, 0.0)
        dv = self._initial_velocities()
        return self.residual_derivatives(state, 1.0, inertia=True).T @ r_bar + dv.T @ (v_bar + C.T @ r_bar)

    # ------------------------------------------------------------------ the end
    def finish(self, carried: dict, writer) -> None:
        """The reverse pass; summary.json ``probe_sensitivities`` (end, max, min, as the forward method
        writes them) and ``event_sensitivities`` (none: events are refused); ``sensitivities.csv`` and
        ``Result.sensitivities`` with the end row alone (``t,<probe>/<NAME>,…``)."""
        from latdyn.results.files import atomic_write_bytes, csv_line

        recorded = writer.result()
        series = {p.name: recorded.probes[p.name] for p in self.probes}
        outputs = self.outputs(carried, series)
        gradient = self.reverse(carried, outputs)
        summary: dict = {}
        for column, (probe, which, _) in enumerate(outputs):
            summary.setdefault(probe.name, {})[which] = {name: float(gradient[c, column])
                                                         for c, name in enumerate(self.names)}
        writer.summary["probe_sensitivities"] = summary
        writer.summary["event_sensitivities"] = []
        end = {(probe, name): np.array([values["end"][name]])
               for probe, values in summary.items() for name in self.names}
        writer.sensitivities = end
        if writer.out_dir is not None and carried["rows"]:
            t_end = float(np.asarray(recorded.t)[len(carried["rows"]) - 1])
            row = [t_end] + [float(end[(p.name, name)][0]) if (p.name, name) in end else float("nan")
                             for p in self.probes for name in self.names]
            text = csv_line(["t", *self.columns]) + csv_line(row)
            atomic_write_bytes(Path(writer.out_dir) / SENSITIVITIES_FILE, text.encode("utf-8"))


def _transposed(matrix):
    """``matrix``ᵀ in the storage the linear solves take (CSR for a sparse one)."""
    return matrix.T.tocsr() if issparse(matrix) else np.ascontiguousarray(matrix.T)
