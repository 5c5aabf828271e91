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

Events (docs/parameters.md, "Sensitivities through events"): a latch or a rigid stop is landed on
exactly (|θ − θ_e| ≤ :data:`LANDING`, :meth:`TransientSensitivities.land`); the step's derivative has a
column for a unit change of its size h, and the event time's derivative δh makes the hinge angle's
total derivative vanish; the jump of δv through the impulse and the restarted accelerations are
differentiated (:meth:`TransientSensitivities._jump`, :meth:`TransientSensitivities.after_events`); the
derivative of the impulse weight M + dt²K along δq (a third derivative of the element, not generated)
is taken by a central difference (:meth:`TransientSensitivities._weight_derivative`).
A compliant stop's onset (``contact``) is landed on too, and its time enters through the landing
step's size as a latch's does (:meth:`TransientSensitivities._contact_onset`); its force being continuous
there, nothing jumps; its law's stiffness, exponent and damping enter ∂r/∂p through the generated
``contact_force_D_law`` (docs/parameters.md, "Compliant stops").

This round runs one step at a time from Python (the time loop's per-step path; the native loop is
later); it carries (δq, δv, δv̇, δa) on the free coordinates, (n, k), in
:attr:`latdyn.timeloop.progress.TransientProgress.sensitivities`, checkpointed with the run.
"""
from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from latdyn.analyses.sensitivities import (_BODY_KEY, _HINGE_KEY, _INITIAL_VELOCITY_KEY, _LOAD_KEY, _SECTION_KEY,
                                           SENSITIVITIES_FILE, ParameterDerivatives)
from latdyn.assembly.assembler import free_acceleration, free_velocity, pack, unpack_free
from latdyn.assembly.factorization import solve_linear
from latdyn.errors import SceneError, SolverError
from latdyn.model.model import lock_tolerance
from latdyn.numerics.inertia import split_inertia
from latdyn.numerics.linalg import issparse
from latdyn.numerics.so3 import dexp_so3, expm_so3
from latdyn.step.integrators import consistent_acceleration
from latdyn.timeloop.events import first_crossing, lock_events, stop_hits
from latdyn.timeloop.impulse import hinge_directions, massless_element_stiffness

__all__ = ["TransientSensitivities"]


#: |v̇_0| and |Q_cᵀ r| below which a start counts as at rest in equilibrium (SI units; module docstring)
AT_REST = 1e-9
#: |θ − θ_event| (rad, times max(1, |θ_event|)) to which a step lands on a latch or a stop when
#: sensitivities are asked (the loop's own landing stops at lock_tolerance, 1e-7)
LANDING = 1e-12
#: secant passes at most for that landing
LANDING_PASSES = 30
#: a landing farther than this (relative, as LANDING) from the event is flagged in summary.json warnings:
#: the event-time derivative assumes the step ends on it
LANDING_MISSED = 1e-10
#: the configuration step (times the length scale) of the central differences of the impulse weight
#: M + dt²K along δq (module docstring, "Events": the one derivative not generated)
WEIGHT_STEP = 1e-5


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
        carried = {"dq": zero, "dv": zero, "dvdot": zero, "da": zero, "rows": [],
                   "dt": np.zeros(k), "dh": np.zeros(k), "h": None, "events": [], "pending": None}
        if n == 0 or k == 0:
            return carried
        ev = self.assembler.evaluate(state, matrices=True)
        split = split_inertia(model, ev.combined(1.0, 0.0, 0.0))
        self._refuse_events(ev, split)
        if split.n_massless:
            self._refuse_start(state, ev, split)
        dv = self._initial_velocities()
        rhs = self.residual_derivatives(state, 1.0, inertia=True) + ev.combined(0.0, 1.0, 0.0) @ dv
        if split.n_massless == 0:   # Δ = −M⁻¹r: one factorization for every column
            dvdot = -np.asarray(solve_linear(ev.combined(1.0, 0.0, 0.0), rhs)).reshape(n, k)
        else:
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

    def _refuse_events(self, ev, split) -> None:
        """Events (a latch, a rigid stop) are differentiated where the impulse's weight is M + dt²K
        alone (no directions or elements without inertia: latdyn/timeloop/impulse.py); else refused
        (laws in time with events are refused before the run: latdyn.analyses.sensitivities.refusal)."""
        model, scene = self.model, self.scene
        events = [h.name for h in model.hinges if h.lock_at is not None or (h.limits is not None and h.contact is None)]
        if not events:
            return
        why = None
        if split.n_massless or massless_element_stiffness(ev) is not None:
            why = (f"the model has directions without inertia ({split.n_massless}) or elements without mass, "
                   "whose impulse response (rigid and static through the jump) is not differentiated yet; "
                   "expected beams with rhoA and rotary inertia (rhoIy, rhoIz)")
        if why is not None:
            raise SceneError(scene.file, "solve.sensitivities",
                             f"sensitivities through the events of {events[0]} (lock_at, limits): {why} "
                             "(docs/parameters.md, \"Sensitivities through events\")")

    # ------------------------------------------------------------------ landing on an event
    def land(self, step, old, attempt):
        """The step from ``old`` landed on the first latch or stop it crosses or reaches to
        |θ − θ_event| ≤ :data:`LANDING` (secant on the step size from 0 and the step tried), where the
        derivative of the event time assumes it exactly; ``step(h)`` takes a step of size h from
        ``old``. Returns (state, stats, h, lands) of the last converged step."""
        new, stats, h, lands = attempt
        event = first_crossing(self.model, old, new)
        if event is None:
            return attempt
        k, at = event
        tight = LANDING * max(1.0, abs(at))
        a, ga = 0.0, float(old.theta[k] - at)
        b, gb = h, float(new.theta[k] - at)
        best = attempt
        for _ in range(LANDING_PASSES):
            if abs(gb) <= tight or gb == ga:
                break
            c = b - gb * (b - a) / (gb - ga)
            if not 0.0 < c <= h * (1 + 1e-12):
                break
            retry, retry_stats = step(c)
            if not retry_stats.converged:
                break
            best = (retry, retry_stats, c, False)
            a, ga, b, gb = b, gb, c, float(retry.theta[k] - at)
        return best

    # ------------------------------------------------------------------ a step
    def step(self, carried: dict, old, new, h: float, a_old: np.ndarray, a_new: np.ndarray,
             lands: bool = True) -> dict:
        """The carried sensitivities after the accepted step ``old`` → ``new`` of size ``h`` (``a_old``,
        ``a_new``: the algorithmic accelerations before and after it; ``lands``: it ended on the time
        grid), with the derivative of its size (module docstring, "Events") and the jump of the event it
        ends on, if any, taken before the events renumber the coordinates (:meth:`after_events`)."""
        model, p = self.model, self.params
        n, k = model.n_dofs, len(self.names)
        if n == 0 or k == 0:
            return {**carried, "h": h}
        am, af, gamma, beta = p.alpha_m, p.alpha_f, p.gamma, p.beta
        beta_p, gamma_p = (1 - am) / (h * h * beta * (1 - af)), gamma / (h * beta)
        # k parameter columns and one of a unit change of the step size (its derivative, δh = 1)
        dq, dv, dvdot, da = (np.hstack([carried[key], np.zeros((n, 1))]) for key in ("dq", "dv", "dvdot", "da"))
        v_old = free_velocity(model, old)
        # the step's own increment hΔq, its rotations' exp and tangent operator
        increment = h * (v_old + h * (0.5 - beta) * a_old + h * beta * a_new)
        turn, tangent = self._rotation_operators(increment)
        da0 = (af * dvdot - am * da) / (1 - am)
        du0 = h * (dv + h * (0.5 - beta) * da + h * beta * da0)
        du0[:, k] += v_old + 2 * h * (0.5 - beta) * a_old + 2 * h * beta * a_new     # ∂(hΔq)/∂h
        dq0 = turn(dq) + tangent(du0)
        dv0 = dv + h * (1 - gamma) * da + h * gamma * da0
        dv0[:, k] += (1 - gamma) * a_old + gamma * a_new                               # ∂v_{n+1}/∂h
        M, C, K = self._matrices(new)
        rhs = -(np.hstack([self.residual_derivatives(new, 1.0, inertia=True), np.zeros((n, 1))])
                + K @ dq0 + C @ dv0)
        J = tangent.matrix if issparse(K) else tangent.matrix.toarray()
        matrix = beta_p * M + gamma_p * C + K @ J
        try:
            z = np.asarray(solve_linear(matrix, rhs)).reshape(n, k + 1)
        except np.linalg.LinAlgError:
            raise SolverError(f"the sensitivities at t = {new.t:.6g} need the step's exact iteration matrix, "
                              "which is singular there") from None
        dvdot_new = beta_p * z
        columns = {"dq": dq0 + tangent(z), "dv": dv0 + gamma_p * z, "dvdot": dvdot_new,
                   "da": da0 + (1 - af) / (1 - am) * dvdot_new}
        event = self._event(old, new)
        dh = self._step_size_derivative(carried, h, lands, event or self._contact_onset(old, new), columns["dq"])
        total = {key: value[:, :k] + np.outer(value[:, k], dh) for key, value in columns.items()}
        carried = {**carried, **total, "dt": carried["dt"] + dh, "dh": dh, "h": h, "pending": None}
        if event is None:
            return carried
        return self._jump(carried, new, *event)

    def _event(self, old, new):
        """(hinge, kind, restitution) of the latch or stop impact the events will apply at the end of
        the step old → new (:func:`latdyn.timeloop.events.hinge_events`), or None; several at once, or
        a joint resting on its stop, are refused (SolverError): their derivative is not that of one event."""
        model = self.model
        reached, crossing = lock_events(model, old, new)
        latched = reached + [j for j, _ in crossing]
        hits, _, restitution, rests = stop_hits(model, new, old)
        if not latched and not hits:
            return None
        if any(rests) or len(latched) + len(hits) > 1:
            what = "a hinge resting on its stop" if any(rests) else "several hinge events at one instant"
            raise SolverError(f"the sensitivities at t = {new.t:.6g} meet {what}, whose derivative is not that of "
                              "one event (docs/parameters.md, \"Sensitivities through events\")")
        if latched:
            return int(latched[0]), "latch", 0.0
        return int(hits[0]), "stop", float(restitution[0])

    def _contact_onset(self, old, new):
        """(hinge, "contact", 0.0) when the step old → new landed on a compliant stop from inside (its
        onset, δ = 0: the Hunt–Crossley force is continuous there, so the state's sensitivities do not
        jump, but the landing step's size is the onset's time, a function of p), else None
        (docs/parameters.md, "Compliant stops")."""
        model = self.model
        for k in model.free_hinges:
            hinge = model.hinges[k]
            if hinge.contact is None or hinge.limits is None:
                continue
            for side, stop in zip((-1, 1), hinge.limits):
                inside = side * (old.theta[k] - stop) < -lock_tolerance(stop)
                if inside and abs(new.theta[k] - stop) <= lock_tolerance(stop):
                    return int(k), "contact", 0.0
        return None

    def _step_size_derivative(self, carried: dict, h: float, lands: bool, event, dq: np.ndarray) -> np.ndarray:
        """δh (k,) of the accepted step: the event's time makes the hinge's angle its lock_at or stop
        exactly, δθ_p + δθ_h δh = 0 (δθ_h = ∂θ_{n+1}/∂h); a step landing on the time grid ends at a fixed
        time, δh = −δt_n; the nominal step is fixed; any other (the steps doubling back to dt after a
        shortened one, a cut one) is the previous accepted step times h/h_prev (latdyn/timeloop/control.py)."""
        k = len(self.names)
        if event is not None:
            dof = self.model.hinge_dofs[event[0]]
            return -dq[dof, :k] / dq[dof, k]
        if lands:
            return -carried["dt"]
        if carried["h"] is None or abs(h - self.scene.solve.dt) <= 1e-12 * self.scene.solve.dt:
            return np.zeros(k)
        return (h / carried["h"]) * carried["dh"]

    # ------------------------------------------------------------------ the jump at an event
    def _jump(self, carried: dict, new, hinge: int, kind: str, restitution: float) -> dict:
        """The velocities' sensitivities through the impulse of the latch or stop at ``new`` (before the
        jump; module docstring, "Events"): with W = M + dt²K, X = W⁻¹N, Δv = X(NᵀX)⁻¹(−(1+e)Nᵀv⁻),

            w = δv⁻ − W⁻¹ δ(W)Δv,      δv⁺ = w + X(NᵀX)⁻¹(−e Nᵀδv⁻ − Nᵀw),

        δq unchanged (the event time made δθ = 0 on the stop, so projecting onto it moves nothing to first
        order). The free coordinates are about to be renumbered (a latch): δq and δv are kept on the nodes
        and hinges until :meth:`after_events`."""
        model, dt = self.model, self.scene.solve.dt
        scale = dt * dt
        N = hinge_directions(model, [hinge])
        ev = self.assembler.evaluate(new, matrices=True)
        W = ev.combined(1.0, 0.0, scale)
        X = np.asarray(solve_linear(W, N)).reshape(N.shape)
        v_minus = free_velocity(model, new)
        NtX = N.T @ X
        change = X @ np.linalg.solve(NtX, -(1.0 + restitution) * (N.T @ v_minus))
        dv_minus = carried["dv"]
        w = dv_minus - np.asarray(solve_linear(W, self._weight_derivative(new, change, carried["dq"], scale)))
        w = w.reshape(dv_minus.shape)
        dv_plus = w + X @ np.linalg.solve(NtX, -restitution * (N.T @ dv_minus) - N.T @ w)
        dt_event = carried["dt"]
        record = {"joint": model.hinges[hinge].name, "kind": kind, "t": float(new.t),
                  "dt": {name: float(dt_event[c]) for c, name in enumerate(self.names)}}
        at = model.hinges[hinge].lock_at if kind == "latch" else min(model.hinges[hinge].limits,
                                                                   key=lambda stop: abs(new.theta[hinge] - stop))
        miss = abs(float(new.theta[hinge]) - at) / max(1.0, abs(at))
        if miss > LANDING_MISSED:   # the derivative assumes the step on the event: flagged (finish)
            carried = {**carried, "missed": carried.get("missed", []) + [(record["joint"], record["t"], miss)]}
        return {**carried, "events": carried["events"] + [record],
                "pending": {"kind": kind, "dq": self._on_nodes(carried["dq"]), "dv": self._on_nodes(dv_plus)}}

    def _on_nodes(self, columns: np.ndarray) -> list:
        """Free-coordinate columns as (node translations, node rotations, hinge angles), one per column."""
        model, out = self.model, []
        for c in range(columns.shape[1]):
            nodes = model.node_dofs.shape[0]
            dx, dpi = np.zeros((nodes, 3)), np.zeros((nodes, 3))
            dtheta = np.zeros(len(model.hinges))
            unpack_free(model, columns[:, c], dx, dpi, dtheta)
            out.append((dx, dpi, dtheta))
        return out

    def _weight_derivative(self, state, w: np.ndarray, dq: np.ndarray, scale: float,
                           mass: bool = True) -> np.ndarray:
        """δ(W w) (n, k) for W = M + scale·K (``mass``) or scale·K at ``state`` (K the evaluation's, without
        the inertia tangent, as the impulse uses it), along each column's (δq, δp): ∂(W w)/∂q δq by a
        central difference of W w along δq (the derivative of K is a third derivative of the element,
        not generated: the one difference of the sensitivities, module docstring), ∂M/∂p w exactly (the
        inertia forces are linear in the accelerations: ∂r/∂p at accelerations w less at none, at rest),
        scale ∂K/∂p w by a central difference of ∂r/∂p (static) along w."""
        model, assembler, k = self.model, self.assembler, len(self.names)
        length = self.length or 1.0
        out = np.zeros((model.n_dofs, k))

        def product(moved):
            return np.asarray(assembler.evaluate(moved, matrices=True).combined(1.0 if mass else 0.0, 0.0, scale) @ w)

        for c in range(k):
            size = float(np.max(np.abs(dq[:, c]), initial=0.0))
            if size == 0.0:
                continue
            eta = WEIGHT_STEP * length / size
            out[:, c] = (product(assembler.advance(state, eta * dq[:, c]))
                         - product(assembler.advance(state, -eta * dq[:, c]))) / (2 * eta)
        size = float(np.max(np.abs(w), initial=0.0))
        if size == 0.0:
            return out
        eta = WEIGHT_STEP * length / size
        out += scale * (self.residual_derivatives(assembler.advance(state, eta * w), 1.0)
                        - self.residual_derivatives(assembler.advance(state, -eta * w), 1.0)) / (2 * eta)
        if mass:
            at_rest = state.copy()
            for name in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot"):
                getattr(at_rest, name)[...] = 0.0
            accelerated = at_rest.copy()
            unpack_free(model, w, accelerated.a, accelerated.alpha, accelerated.theta_ddot)
            out += (self.residual_derivatives(accelerated, 1.0, inertia=True)
                    - self.residual_derivatives(at_rest, 1.0, inertia=True))
        return out

    def after_events(self, carried: dict, new) -> dict:
        """``carried`` after the events of the step ended at ``new`` (its coordinates renumbered, its
        accelerations restarted): δq, δv on the new numbering and the restart differentiated: after a
        latch the consistent accelerations, M δv̇ = −(∂r/∂p + K δq + C δv); after a stop those of
        :func:`latdyn.timeloop.events.restart_accelerations`, W v̇ = −r(q, v, 0), so
        W δv̇ = −(∂r/∂p + K δq + C δv + dt² δ(K)v̇) (K exact, at the restarted v̇); δa = δv̇."""
        pending = carried.get("pending")
        if pending is None:
            return carried
        model, k = self.model, len(self.names)
        n = model.n_dofs

        def packed(columns):
            return np.column_stack([pack(model, *column)[:n] for column in columns]) if k else np.zeros((n, 0))

        dq, dv = packed(pending["dq"]), packed(pending["dv"])
        out = {**carried, "dq": dq, "dv": dv, "pending": None}
        if n == 0:
            return {**out, "dvdot": np.zeros((0, k)), "da": np.zeros((0, k))}
        M, C, K = self._matrices(new)
        rhs = self.residual_derivatives(new, 1.0, inertia=True) + K @ dq + C @ dv
        if pending["kind"] == "latch":
            matrix = M
        else:
            scale = self.scene.solve.dt ** 2
            matrix = self.assembler.evaluate(new, matrices=True).combined(1.0, 0.0, scale)
            rhs = rhs + self._weight_derivative(new, free_acceleration(model, new), dq, scale, mass=False)
        dvdot = np.asarray(solve_linear(matrix, rhs)).reshape(n, k) * -1.0
        return {**out, "dvdot": dvdot, "da": dvdot.copy()}

    def _matrices(self, state):
        """M, C and the exact K at ``state`` (:meth:`latdyn.assembly.assembler.Assembler.exact_matrices`:
        the elements' inertia tangent and the joint bodies' ``joint_body_inertia_stiffness``, which the
        step's Newton matrix leaves out)."""
        return self.assembler.exact_matrices(state)

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
        if n <= 0:
            matrix = np.zeros((0, 0))
        else:
            import scipy.sparse as sps

            keep, fixed, indices, indptr, order = self._tangent_pattern(slots, n)
            values = np.concatenate([np.ones(fixed), J[keep]])
            matrix = sps.csr_matrix((values[order], indices, indptr), shape=(n, n))
        tangent.matrix = matrix
        return turn, tangent

    def _tangent_pattern(self, slots: np.ndarray, n: int):
        """The CSR pattern of J (the identity off the rotation coordinates, 3 × 3 blocks on them) for this
        numbering, built once: (the blocks' entries kept, how many identity rows, indices, indptr, the
        order of [identity entries, kept block entries] in the CSR data)."""
        key = (n, slots.tobytes())
        cache = self.__dict__.setdefault("_patterns", {})
        if key not in cache:
            import scipy.sparse as sps

            rows = np.broadcast_to(slots[:, :, None], (len(slots), 3, 3))
            cols = np.broadcast_to(slots[:, None, :], (len(slots), 3, 3))
            keep = (rows < n) & (cols < n)
            fixed = np.ones(n, bool)
            fixed[slots[slots < n]] = False
            r = np.concatenate([np.flatnonzero(fixed), rows[keep]])
            c = np.concatenate([np.flatnonzero(fixed), cols[keep]])
            pattern = sps.csr_matrix((np.arange(1.0, len(r) + 1.0), (r, c)), shape=(n, n))
            cache[key] = (keep, int(fixed.sum()), pattern.indices.copy(), pattern.indptr.copy(),
                          pattern.data.astype(int) - 1)
        return cache[key]

    # ------------------------------------------------------------------ rows
    def record(self, carried: dict, state) -> dict:
        """``carried`` with the row of every probe's sensitivity at ``state`` (a new list of rows), all
        parameters at once: a point x + T r moves by δx + δπ × T r, a hinge angle by δθ."""
        dx, dpi, dtheta = self._by_parameter(carried["dq"])
        row = [float(state.t)]
        for probe in self.probes:
            row.extend(self._probe_derivatives(probe, state, dx, dpi, dtheta))
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
        writer.summary["probe_sensitivities"] = self._at_extremes(
            table, {p.name: np.asarray(recorded.probes[p.name])[:len(carried["rows"])] for p in self.probes})
        writer.summary["event_sensitivities"] = list(carried.get("events", []))
        for joint, t, miss in carried.get("missed", []):
            warning = (f"the step landed {miss:.2g} (relative) off the event of {joint} at t = {t:.9g} (secant "
                       "on the step size not converged): its sensitivities are not exact to better than that")
            print(f"latdyn: warning: {warning}", file=sys.stderr)
            writer.summary.setdefault("warnings", []).append(warning)
        if writer.out_dir is not None:
            text = csv_line(["t", *self.columns]) + "".join(csv_line(row) for row in carried["rows"])
            atomic_write_bytes(Path(writer.out_dir) / SENSITIVITIES_FILE, text.encode("utf-8"))
