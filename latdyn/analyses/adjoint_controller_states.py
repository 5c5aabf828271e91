"""The discrete adjoint through the states of continuous controllers and seeded by controller probes (issue 34;
docs/parameters.md, "The discrete adjoint", "Controllers").

The forward method carries each continuous controller's states beside the step's columns
(:class:`latdyn.analyses.sensitivities.ControllerStates`, csrc/controller_states.c): per step, with
A = I − h/2 ∂f/∂S, ∂f/∂s, ∂f/∂S, ∂f/∂p at the step's end (its accepted S_{n+1}),

    held     = A⁻¹ (δS_n + h/2 (δf_n + ∂f/∂p))                         (``begin_step``),
    E        = ∂r/∂p + B held,   B the actuators' rows of ∂y/∂S          (``ControllerTerms.add`` with ``held``),
    z = S⁻¹(−(E + K δq⁰ + C δv⁰)) with S's K and C condensed from (S_n, f_n)   (``condensed``),
    δS_{n+1} = held + A⁻¹ h/2 ∂f/∂s δs_{n+1},   δs_{n+1} = D_q δq_{n+1} + D_v δv_{n+1} (``after_step``, ``_sensed``),
    δf_{n+1} = ∂f/∂s δs_{n+1} + ∂f/∂S δS_{n+1} + ∂f/∂p,

and δS_0 = 0, δf_0 = ∂f/∂s δs_0 + ∂f/∂p at the start (``start``; δs_0 = D_q δq_0 + D_v δv_0 of the start's
moves); beside events a step whose size moves adds B by_h to its step size's column and by_h δh to δS_{n+1} (by_h = A⁻¹ ½ (f_n + f_{n+1})), and δS_{n+1} is held through the event's
jump and restart (``hold``: B δS in the restart's ∂r/∂p, ∂(B δS)/∂q w in the weights'). The reverse pass carries S̄
and f̄ beside the structure's bars and applies the transposes in reverse order, each named after its forward piece:

- :meth:`StatesTransposed.after_step_transposed`: S̄ += ∂f/∂Sᵀ f̄, s̄ = ∂f/∂sᵀ f̄ + h/2 ∂f/∂sᵀ A⁻ᵀ S̄,
  q̄ += D_qᵀ s̄ (v̄ += D_vᵀ s̄ for a sensor reading a rate), dy/dp += ∂f/∂pᵀ f̄, and held̄ = S̄;
- the structure's step as without states (its matrix taken in :meth:`StatesTransposed.condensed`, the forward
  method's own context), then :meth:`StatesTransposed.held_transposed`: held̄ −= Bᵀ w;
- :meth:`StatesTransposed.begin_step_transposed`: ĥ = A⁻ᵀ held̄, S̄_n = ĥ, f̄_n = h/2 ĥ, dy/dp += h/2 ∂f/∂pᵀ ĥ;
- at t = 0 :meth:`StatesTransposed.start_transposed`: dy/dp += ∂f/∂pᵀ f̄_0 + δs_0ᵀ ∂f/∂sᵀ f̄_0 (δs_0 the forward
  method's on the start's δq_0, δv_0);
- beside events: h̄ += by_hᵀ S̄_{n+1} (:meth:`StatesTransposed.after_step_transposed`), B by_h in the step size's
  column (:meth:`StatesTransposed.by_step_size`), and at the event S̄ += Bᵀū of the restart and ± the weights'
  ∂(B δS)/∂q w transposed (:meth:`StatesTransposed.held_stiffness_along`;
  :meth:`AdjointSensitivities._held_weights_transposed`).

A controller reading a rate (a hinge's or guide's rate, a point's velocity: δs = D_q δq + D_v δv in the forward
method, D_v on the step end's δv) adds v̄ += D_vᵀ s̄ beside q̄ += D_qᵀ s̄
(:meth:`StatesTransposed.after_step_transposed`; a sampled one's at its sample,
:meth:`SamplesTransposed.sample_transposed`). After a latch the forward method takes its
δf anew at the jumped rates, δf⁺ = ∂f/∂s (D_q δq + D_v δv⁺) + ∂f/∂S δS + ∂f/∂p in place of the step's
(``ControllerStates.restarted``; after a stop the run keeps f and the step's δf stands,
``sensitivities.rates_taken_anew``): :meth:`StatesTransposed.restarted_transposed` comes first in the event's
reverse order (s̄ = ∂f/∂sᵀ f̄ onto q̄ and v̄ of the jumped state, S̄ += ∂f/∂Sᵀ f̄, dy/dp += ∂f/∂pᵀ f̄, f̄ = 0 on those
rows), and the step after the latch starts from the restarted (S, f) stored then
(``AdjointSensitivities._states_before``).

D_s (D_q, and D_v where a sensor reads a rate) and B are the forward method's maps (``ControllerStates._sensed``,
``ControllerTerms.add``) applied to unit columns — n columns of δq (2n of [δq | δv]), P of held (P the states) — and
transposed; ∂f/∂s, ∂f/∂S, ∂f/∂p are the step's compiled
laws' (``ControllerStates._at``). Everything is evaluated again at the stored state with the stored (S, f) put in the
scene's arrays (:meth:`StatesTransposed.at`): the forward pass stores the accepted (S, f) of every step
(:meth:`StatesTransposed.stored`).

Controller probes (:func:`probe_forms`): a state S at a row seeds S̄ there; an output y = clip(f(t, s, y_j, S; p))
inside its limits seeds Σ ∂f/∂s (the sensor's forms, :meth:`AdjointSensitivities.output_forms`) + Σ ∂f/∂y_j (the
earlier controller's forms) + ∂f/∂S on S̄ + ∂f/∂p explicit — the forward method's
``controller_probe_sensitivities._continuous_output`` as forms; clipped, 0. What the forward method adds where the
row's time moves (∂f/∂t δt at an event's row and the rows after it before a step lands on the grid, an output naming
t) is seeded on t̄ at that row with the forward method's own coefficient
(:func:`latdyn.analyses.adjoint_time.row_coefficients`; ``AdjointSensitivities.reverse``). Beside events a sampled
controller's held δy is transposed through the event's pieces as the states' δS
(:meth:`SamplesTransposed.held_stiffness_along`). After an event each step ends at t + δt: a sensor the prescribed
motions move at fixed free coordinates moves by ∂s/∂t δt_{n+1} in the forward method's δs (``_sensed`` with
``moved``), transposed as t̄ += D_tᵀ s̄ (:meth:`StatesTransposed._sensed_transposed`), and ∂r/∂t's prescribed part is
taken with the states condensed as in the step, as the forward method's (``AdjointSensitivities._step_transposed``).
"""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from latdyn.analyses.controller_probe_sensitivities import controller_arguments, output_and_gradient

__all__ = ["StatesTransposed", "probe_forms"]


class StatesTransposed:
    """The transposes of :class:`latdyn.analyses.sensitivities.ControllerStates`' pieces for ``owner`` (an
    AdjointSensitivities whose controllers have states): module docstring."""

    def __init__(self, owner):
        self.owner = owner
        self.states = owner.controllers.states
        self.terms = owner.controllers
        self.P = len(self.states.slots)

    # ------------------------------------------------------------------ the forward pass: storing
    def stored(self) -> tuple:
        """(S, f) (P,) each: the accepted states and their rates as the scene holds them now."""
        states = self.states
        return states.values[states.slots].copy(), states.rates[states.rate_index].copy()

    @contextmanager
    def at(self, stored: tuple):
        """A context in which the scene's arrays hold ``stored`` (S, f), put back after."""
        states = self.states
        kept = self.stored()
        states.values[states.slots], states.rates[states.rate_index] = stored
        try:
            yield
        finally:
            states.values[states.slots], states.rates[states.rate_index] = kept

    def condensed(self, before: tuple, h: float):
        """The forward method's :meth:`ControllerStates.condensed` from the step's start ``before`` (S_n, f_n)."""
        return self.states.condensed({"controller_S": before[0], "controller_f": before[1]}, h)

    # ------------------------------------------------------------------ the pieces at one step's end
    def step_terms(self, state, h: float, before: tuple) -> dict:
        """{controller name: (rows, A (p, p), ∂f/∂s (p, m), ∂f/∂S (p, p), ∂f/∂p (p, k), by_h (p,))} at the step's end
        ``state`` (the scene's arrays holding its accepted S, f: :meth:`at`), as ``ControllerStates.begin_step``
        takes them (``_at``), A = I − h/2 ∂f/∂S, by_h = A⁻¹ ½ (f_n + f_{n+1}) the states' derivative by the step's
        size (``before``: the step's start's (S_n, f_n))."""
        out, states = {}, self.states
        f_next = self.stored()[1]
        for c in states.controllers:
            rows = slice(states.first[c.name], states.first[c.name] + len(c.states))
            _, f_s, f_S, f_p = states._at(c, state)
            A = np.eye(len(c.states)) - 0.5 * h * f_S
            out[c.name] = (rows, A, f_s, f_S, f_p, np.linalg.solve(A, 0.5 * (before[1][rows] + f_next[rows])))
        return out

    def by_step_size(self, terms: dict) -> np.ndarray:
        """(P,) the states' derivative by the step's size at a fixed configuration (``step_terms``' by_h, stacked)."""
        out = np.zeros(self.P)
        for c in self.states.controllers:
            rows, *_, by_h = terms[c.name]
            out[rows] = by_h
        return out

    def after_step_transposed(self, state, h: float, terms: dict, S_bar: np.ndarray, f_bar: np.ndarray,
                              q_bar: np.ndarray, v_bar: np.ndarray, gradient: np.ndarray,
                              t_bar: np.ndarray | None = None, theta_bar: np.ndarray | None = None) -> tuple:
        """The transpose of ``ControllerStates.after_step`` (module docstring) for the bars at the step's end:
        q̄, v̄ (a sensor reading a rate: δs = D_q δq + D_v δv) and the gradient updated in place, and ``t_bar`` (where
        the step's end moves in time: δs's ∂s/∂t δt_{n+1} along the prescribed motions, :meth:`_sensed_transposed`)
        and ``theta_bar`` (the held angles' adjoints, where friction holds a joint through the step: δs reads its
        held δθ, :func:`_held_sensed_transposed`);
        returns (held̄ (P, m), the adjoint of the step's δh through δS_{n+1} += by_h δh (m,))."""
        hh = 0.5 * h
        held_bar = np.zeros_like(S_bar)
        h_bar = np.zeros(S_bar.shape[1])
        sensed_bar = {}
        for c in self.states.controllers:
            rows, A, f_s, f_S, f_p, by_h = terms[c.name]
            S_next_bar = S_bar[rows] + f_S.T @ f_bar[rows]            # δf_{n+1} = … + ∂f/∂S δS_{n+1} + ∂f/∂p
            gradient += f_p.T @ f_bar[rows]
            s_bar = f_s.T @ f_bar[rows] + hh * (f_s.T @ np.linalg.solve(A.T, S_next_bar))
            held_bar[rows] = S_next_bar                               # δS_{n+1} = held + A⁻¹ h/2 ∂f/∂s δs
            h_bar += by_h @ S_next_bar                                #            + by_h δh
            sensed_bar[c.name] = s_bar
        for c in self.states.controllers:   # δs = D_q δq + D_v δv: the forward method's map on unit columns, transposed
            if len(self.states.sensors[c.name]):
                self._sensed_transposed(c, state, sensed_bar[c.name], q_bar, v_bar, t_bar)
                _held_sensed_transposed(self.owner, lambda dq, dv: self.states._sensed(c, state, dq, None, dv),
                                        self.states.sensors[c.name], sensed_bar[c.name], theta_bar)
        return held_bar, h_bar

    def _sensed_transposed(self, c, state, s_bar: np.ndarray, q_bar: np.ndarray, v_bar: np.ndarray,
                           t_bar: np.ndarray | None = None) -> None:
        """q̄ += D_qᵀ s̄ and v̄ += D_vᵀ s̄ in place: δs = D_q δq + D_v δv of ``c``'s sensors at ``state`` (D_v where one
        reads a rate, :func:`latdyn.analyses.sensitivities.reads_rates`), the forward method's
        ``ControllerStates._sensed`` on the n unit columns of δq (and of δv) and transposed; with ``t_bar`` (the
        state's time moving with p) also t̄ += D_tᵀ s̄, D_t the same map's ∂s/∂t along the prescribed motions at fixed
        free coordinates (``moved`` = δt = 1 on zero columns)."""
        D_q, D_v = _sensed_forms(self.owner, lambda dq, dv: self.states._sensed(c, state, dq, None, dv),
                                 self.states.sensors[c.name])
        q_bar += D_q.T @ s_bar
        if D_v is not None:
            v_bar += D_v.T @ s_bar
        if t_bar is not None:
            from latdyn.analyses.sensitivities import reads_rates

            n, m = self.owner.model.n_dofs, len(self.states.sensors[c.name])
            zero = np.zeros((n, 1))
            D_t = np.asarray(self.states._sensed(c, state, zero, np.ones(1),
                                                 zero if reads_rates(self.states.sensors[c.name]) else None),
                             float).reshape(m)
            t_bar += D_t @ s_bar

    def reads_rates(self) -> bool:
        """Whether a controller with states reads a rate (its δf is taken anew after a latch:
        :meth:`restarted_transposed`)."""
        from latdyn.analyses.sensitivities import reads_rates

        return any(reads_rates(self.states.sensors[c.name]) for c in self.states.controllers)

    def restarted_transposed(self, state, bars: list, gradient: np.ndarray, timed: bool = False) -> list:
        """The transpose of ``ControllerStates.restarted`` at the state ``state`` after an event's jump and restart:
        forward, each controller reading a rate takes δf⁺ = ∂f/∂s δs⁺ + ∂f/∂S δS + ∂f/∂p anew, δs⁺ = D_q δq + D_v δv⁺
        of the jumped rates (and, ``timed``, ∂s/∂t δt_e along the prescribed motions), in place of the step's δf; so,
        ``bars`` [q̄, v̄, S̄, f̄, t̄] after it: s̄ = ∂f/∂sᵀ f̄, t̄ += D_tᵀ s̄,
        q̄ += D_qᵀ s̄, v̄ += D_vᵀ s̄, S̄ += ∂f/∂Sᵀ f̄, dy/dp += ∂f/∂pᵀ f̄ and f̄ = 0 on its rows (the step's δf
        reaches no further). Returns the bars before it (new arrays); the others' f̄ passes unchanged (their δf is
        kept)."""
        from latdyn.analyses.sensitivities import reads_rates

        q_bar, v_bar, S_bar, f_bar, t_bar = (np.array(bar, float) for bar in bars)
        for c in self.states.controllers:
            if not reads_rates(self.states.sensors[c.name]):
                continue
            rows = slice(self.states.first[c.name], self.states.first[c.name] + len(c.states))
            _, f_s, f_S, f_p = self.states._at(c, state)
            bar = f_bar[rows].copy()
            gradient += f_p.T @ bar
            S_bar[rows] += f_S.T @ bar
            self._sensed_transposed(c, state, f_s.T @ bar, q_bar, v_bar, t_bar if timed else None)
            f_bar[rows] = 0.0
        return [q_bar, v_bar, S_bar, f_bar, t_bar]

    def held_map(self, state) -> np.ndarray:
        """B (n, P): the forward method's ∂r/∂p of a held δS (``ControllerTerms.add`` with ``held`` the unit
        columns, no parameter's partials: as ``ControllerStates.by_step_size`` applies it) on the free coordinates."""
        total = np.zeros((self.owner.model.n_total + 1, self.P))
        self._unit_terms().add(state, total)
        return self.owner._on_free_coordinates(state, total)

    def _unit_terms(self):
        """The forward method's ControllerTerms with ``held`` the P unit columns of δS and no parameter's partials."""
        import copy

        one = copy.copy(self.terms)
        one.k, one.partials, one.sampled, one.forces_read = self.P, {}, None, {}
        eye = np.eye(self.P)
        one.held = {c.name: eye[self.states.first[c.name]:self.states.first[c.name] + len(c.states)]
                    for c in self.states.controllers}
        return one

    def held_stiffness_along(self, state, w: np.ndarray) -> np.ndarray:
        """(n, P): ∂(B δS)/∂q along ``w`` for the P unit columns of δS, the held part of the forward method's
        ``_terms_beside_stiffness_along`` (an event's weight derivative with δS held, ``ControllerStates.hold``):
        exact as the forward method's (latdyn/analyses/parameter_stiffness.py ``controller_parameter_along`` of the
        unit columns; with rigid links or guides through the reduction, :meth:`_linked_held_stiffness_along`), else (a
        controller whose second derivatives along q are not generated) the same central difference (step WEIGHT_STEP
        ℓ/|w|_∞) of ``ControllerTerms.add`` with the unit columns held."""
        from latdyn.analyses.parameter_stiffness import controller_parameter_along

        if float(np.max(np.abs(w), initial=0.0)) > 0.0:
            if self.owner.model.links is not None:
                exact = self._linked_held_stiffness_along(state, w)
                if exact is not None:
                    return exact
            else:
                exact = controller_parameter_along(self.owner, state, w, self._unit_terms())
                if exact is not None:
                    return self.owner._on_free_coordinates(state, exact)
        return _held_map_along(self.owner, self.held_map, self.P, state, w)

    def _linked_held_stiffness_along(self, state, w: np.ndarray) -> np.ndarray | None:
        """(n, P) or None: :meth:`held_stiffness_along` on a model with rigid links or guides. B = Pᵀ B_all (B_all the
        unit columns' ∂r_all/∂p on the assembled coordinates), so along w at the assembled rates held (the forward
        method's K_red)

            ∂(B δS)/∂q w = Pᵀ ∂B_all/∂q[P w] δS + ∂Pᵀ/∂q[w] B_all δS,

        the forward method's path (``TransientSensitivities._linked_stiffness_along``: ``controller_parameter_along`` at
        u = P w, the sensors' generated gradients by the assembled coordinates, a dependent node's too, projected, and
        the reduction's geometric term, :func:`latdyn.analyses.weight_derivative.geometric_product`); None where
        ``controller_parameter_along`` does not form it. Before (diffgen), ``controller_parameter_along`` with w on the
        free coordinates alone and no geometric term: 0 at the latch of the chain of rigid bays under a PI of a
        dependent node's place, where the block is 8.3 (its product with the impulse's adjoint was 4e-17 there:
        tests/test_adjoint_states_linked.py)."""
        from latdyn.analyses.parameter_stiffness import controller_parameter_along

        owner = self.owner
        model = owner.model
        terms = self._unit_terms()
        full = owner._along_assembled(state, w)
        along = controller_parameter_along(owner, state, full[:model.n_dofs], terms, full=full)
        if along is None:
            return None
        out = owner._on_free_coordinates(state, along)
        on_all = np.zeros((model.n_total + 1, self.P))   # B_all: the unit columns before the reduction
        terms.add(state, on_all)
        return out + owner._geometric_products(state, on_all[:model.n_assembled], w)

    def held_transposed(self, state, w: np.ndarray, held_bar: np.ndarray) -> np.ndarray:
        """held̄ − Bᵀ w: the held part's use in the step's ∂r/∂p (z = S⁻¹(−(… + B held …))), transposed."""
        return held_bar - self.held_map(state).T @ w

    def begin_step_transposed(self, h: float, terms: dict, held_bar: np.ndarray, gradient: np.ndarray) -> tuple:
        """The transpose of ``ControllerStates.begin_step``'s held = A⁻¹(δS_n + h/2 (δf_n + ∂f/∂p)): (S̄_n, f̄_n),
        the gradient updated in place."""
        hh = 0.5 * h
        S_bar, f_bar = np.zeros_like(held_bar), np.zeros_like(held_bar)
        for c in self.states.controllers:
            rows, A, _, _, f_p, _ = terms[c.name]
            spread = np.linalg.solve(A.T, held_bar[rows])
            S_bar[rows] = spread
            f_bar[rows] = hh * spread
            gradient += hh * (f_p.T @ spread)
        return S_bar, f_bar

    def start_transposed(self, state, f_bar: np.ndarray, gradient: np.ndarray, moves: tuple | None = None) -> None:
        """The transpose of ``ControllerStates.start`` (δS_0 = 0, δf_0 = ∂f/∂s δs_0 + ∂f/∂p): dy/dp += ∂f/∂pᵀ f̄_0
        + δs_0ᵀ ∂f/∂sᵀ f̄_0, δs_0 = D_q δq_0 + D_v δv_0 the forward method's own (``_sensed``) on the start's moves
        ``moves`` = (δq_0, δv_0) (``TransientSensitivities.start_moves``; None: the start does not move)."""
        from latdyn.analyses.sensitivities import reads_rates

        for c in self.states.controllers:
            rows = slice(self.states.first[c.name], self.states.first[c.name] + len(c.states))
            _, f_s, _, f_p = self.states._at(c, state)
            gradient += f_p.T @ f_bar[rows]
            sensors = self.states.sensors[c.name]
            if moves is not None and len(sensors) and (np.any(moves[0]) or reads_rates(sensors)):
                ds = np.asarray(self.states._sensed(c, state, moves[0], None, moves[1]), float)
                gradient += ds.reshape(len(sensors), -1).T @ (f_s.T @ f_bar[rows])


def probe_forms(owner, probe, state) -> tuple:
    """(c_q, c_v, c_v̇ (n,), explicit (k,), c_S (P,)) of the continuous controller probe ``probe`` at ``state`` (the
    scene's arrays holding that row's accepted states): its derivative is c_qᵀδq + c_vᵀδv + c_v̇ᵀδv̇ + explicit + c_SᵀδS
    (module docstring), the forward method's ``controller_probe_sensitivities`` as forms; a sampled controller's
    (…, c_y (C,), c_S (P_s,)) with the others 0: its held δy_k or its state's δS_{k+1} (:class:`SamplesTransposed`)."""
    terms = owner.controllers
    states = terms.states
    n, k = owner.model.n_dofs, len(owner.names)
    P = 0 if states is None else len(states.slots)
    c = owner.scene.controllers[probe.controller]
    if c.sampled:   # the held δy_k or δS_{k+1} of the last sample: seeded on ȳ or the sampled states' S̄
        sampled = terms.sampled
        c_y, c_sampled = np.zeros(len(sampled.controllers)), np.zeros(int(sum(len(d.states)
                                                                               for d in sampled.controllers)))
        if probe.state is None:
            c_y[sampled.index[c.name]] = 1.0
        else:
            c_sampled[sampled.first[c.name] + c.states.index(probe.state)] = 1.0
        return np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(k), np.zeros(P), c_y, c_sampled
    if probe.state is not None:
        c_S = np.zeros(P)
        c_S[states.first[c.name] + c.states.index(probe.state)] = 1.0
        return np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(k), c_S
    return _output_forms(owner, c.name, state, {})[1]


def _output_forms(owner, name: str, state, done: dict) -> tuple:
    """(the output's value, its forms) of the continuous controller ``name`` at ``state``: the forward method's
    ``_continuous_output`` with each sensor's δs as its probe's forms and each earlier controller's δy as its
    forms; ``done`` the earlier controllers' by name."""
    if name in done:
        return done[name]
    terms, scene = owner.controllers, owner.scene
    states = terms.states
    n, k = owner.model.n_dofs, len(owner.names)
    P = 0 if states is None else len(states.slots)
    c = scene.controllers[name]
    arguments = controller_arguments(terms, c, state, lambda r: _output_forms(owner, r, state, done)[0])
    compiled = terms.compiled
    raw, gradient = output_and_gradient(terms, c, arguments)   # the forward method's
    forms = [np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(k), np.zeros(P)]
    if gradient is not None:
        probes = {p.name: p for p in scene.output.probes}
        for i, r in enumerate(c.reads):
            if r in probes:
                sensor = owner.output_forms(probes[r], state)
            elif r in scene.controllers:
                sensor = done[r][1]
            else:   # an input: held, no parameter moves it
                continue
            for part, form in zip(forms, sensor):
                part += gradient[i] * form
        if c.states:
            first = states.first[c.name]
            by_states = states.output_by_states(c, arguments)
            if by_states is None:
                by_states = gradient[len(c.reads):]
            forms[4][first:first + len(c.states)] += by_states
        for column, partial in terms.partials.get(c.name, {}).items():
            forms[3][column] += float(partial(*arguments)) if compiled is None else compiled.value(partial, arguments)
    done[name] = (c.clip(raw), tuple(forms))
    return done[name]


def _sensed_forms(owner, sensed, probes: list) -> tuple:
    """(D_q (m, n), D_v (m, n) or None): δs = D_q δq + D_v δv of the sensors ``probes`` from the forward method's map
    ``sensed(dq, dv)`` on unit columns: the n of δq alone where no sensor reads a rate (``dv`` None), else the 2n of
    [δq | δv] in one call."""
    from latdyn.analyses.sensitivities import reads_rates

    n, m = owner.model.n_dofs, len(probes)
    if not reads_rates(probes):
        return np.asarray(sensed(np.eye(n), None), float).reshape(m, n), None
    eye, zero = np.eye(n), np.zeros((n, n))
    both = np.asarray(sensed(np.hstack([eye, zero]), np.hstack([zero, eye])), float).reshape(m, 2 * n)
    return both[:, :n], both[:, n:]


def _held_sensed_transposed(owner, sensed, probes: list, s_bar: np.ndarray, theta_bar: np.ndarray | None) -> None:
    """θ̄ += D_θᵀ s̄ in place on the rows of the joints friction holds now (``owner.model.stuck``): a stuck joint's
    angle is no free coordinate, and the forward method's sensors read its held δθ as the joint's δθ
    (latdyn/analyses/sensitivities.py ``_sensor_derivatives`` adds ``owner.held``), so δs = D_q δq + D_v δv + D_θ δθ;
    D_θ is the forward method's map ``sensed(dq, dv)`` of the sensors ``probes`` on zero δq (and δv) with a unit held
    δθ of each stuck joint (:meth:`AdjointSensitivities._unit_held`). Nothing where no joint is stuck or ``theta_bar``
    is None."""
    from latdyn.analyses.sensitivities import reads_rates

    stuck = np.flatnonzero(owner.model.stuck)
    if theta_bar is None or not len(stuck):
        return
    zero = np.zeros((owner.model.n_dofs, len(stuck)))
    saved, owner.held = owner.held, owner._unit_held(stuck)
    try:
        D_theta = np.asarray(sensed(zero, zero if reads_rates(probes) else None), float)
    finally:
        owner.held = saved
    theta_bar[stuck] += D_theta.reshape(len(probes), len(stuck)).T @ s_bar


def _held_map_along(owner, held_map, columns: int, state, w: np.ndarray) -> np.ndarray:
    """(n, ``columns``): ∂(``held_map`` x)/∂q along ``w`` for the unit columns of x, the forward method's
    ``_terms_beside_stiffness_along`` central difference (step WEIGHT_STEP ℓ/|w|_∞) of the held part alone."""
    from latdyn.analyses.transient_sensitivities import WEIGHT_STEP

    size = float(np.max(np.abs(w), initial=0.0))
    if size == 0.0:
        return np.zeros((owner.model.n_dofs, columns))
    eta = WEIGHT_STEP * (owner.length or 1.0) / size
    assembler = owner.assembler
    return (held_map(assembler.advance(state, eta * w)) - held_map(assembler.advance(state, -eta * w))) / (2 * eta)


class SamplesTransposed:
    """The transposes of :class:`latdyn.analyses.sensitivities.SampledTerms`' pieces and of the restart after a sample
    (:meth:`TransientSensitivities.after_sample`) for ``owner`` (an AdjointSensitivities with sampled controllers):
    the reverse pass carries ȳ (C, m), the adjoint of the held δy_k (C sampled controllers), and S̄ (P_s, m), of
    their states' δS_{k+1}. Per step the held δy enters ∂r/∂p through the actuators, A_y δy (``SampledTerms.add``):
    ȳ −= A_yᵀ w (:meth:`held_transposed`). At a sample (:meth:`sample_transposed`), forward
    δy_k = ∂f/∂s δs + ∂f/∂S δS_k + ∂f/∂p (0 while clipped), δS_{k+1} = δS_k + (∂g/∂s δs + ∂g/∂S δS_k + ∂g/∂p)/rate,
    δs = D_s δq, then the restart δv̇ = δa = −M⁻¹(∂r/∂p + A_y δy_k + K δq + C δv) (:meth:`restart_transposed`):
    ū = −M⁻ᵀ(v̇̄ + ā), q̄ += Kᵀū, v̄ += Cᵀū, dy/dp += (∂r/∂p)ᵀū, ȳ += A_yᵀū, and v̇̄ = ā = 0 before it; then
    s̄ = ∂f/∂sᵀ ȳ_c + ∂g/∂sᵀ S̄/rate, q̄ += D_sᵀ s̄, S̄_k = S̄ + ∂g/∂Sᵀ S̄/rate + ∂f/∂Sᵀ ȳ_c,
    dy/dp += ∂f/∂pᵀ ȳ_c + ∂g/∂pᵀ S̄/rate, and ȳ_c = 0 (the sample replaced the held δy of the controllers due).
    At t = 0 the sample has δS_0 = 0 and the start's δs_0 = D_q δq_0 + D_v δv_0: δy_0 = ∂f/∂s δs_0 + ∂f/∂p,
    δS_1 = (∂g/∂s δs_0 + ∂g/∂p)/rate (:meth:`start_transposed`)."""

    def __init__(self, owner):
        self.owner = owner
        self.sampled = owner.controllers.sampled
        self.C = len(self.sampled.controllers)
        self.P = int(sum(len(c.states) for c in self.sampled.controllers))

    def bars(self, m: int) -> tuple:
        """(ȳ, S̄) zero."""
        return np.zeros((self.C, m)), np.zeros((self.P, m))

    def _unit_held(self):
        """The forward method's SampledTerms with ``held`` the C unit columns of δy (its ControllerTerms' ``k`` C)."""
        import copy

        one = copy.copy(self.sampled)
        one.terms = copy.copy(self.sampled.terms)
        one.terms.k = self.C
        one.held = np.eye(self.C)
        return one

    def _held_map_on_all(self, state, one) -> np.ndarray:
        """A_y,all (n_total + 1, C): the forward method's ∂r/∂p of a held δy (``SampledTerms.add`` on the unit columns
        ``one``) on every coordinate, before the reduction."""
        total = np.zeros((self.owner.model.n_total + 1, self.C))
        one.add(state, total)
        return total

    def held_map(self, state) -> np.ndarray:
        """A_y (n, C): the forward method's ∂r/∂p of a held δy (``SampledTerms.add`` on the unit columns) on the free
        coordinates."""
        return self.owner._on_free_coordinates(state, self._held_map_on_all(state, self._unit_held()))

    def held_stiffness_along(self, state, w: np.ndarray) -> np.ndarray:
        """(n, C): ∂(A_y δy)/∂q along ``w`` for the C unit columns of δy (an event's weights with the held δy in
        ∂r/∂p: the forward method's ``_terms_beside_stiffness_along``, its held outputs' part), exact as the forward
        method's (latdyn/analyses/parameter_stiffness.py ``sampled_held_along`` of the unit columns: a hinge's row
        −a δy does not move, a load's a δy turns with its node and frame, ``point_load_stiffness_D_q``); with rigid
        links or guides through the reduction as the forward method's (:meth:`_linked_held_stiffness_along`)."""
        from latdyn.analyses.parameter_stiffness import sampled_held_along

        if float(np.max(np.abs(w), initial=0.0)) == 0.0:
            return np.zeros((self.owner.model.n_dofs, self.C))
        if self.owner.model.links is not None:   # w moves the dependent nodes too (P w)
            return self._linked_held_stiffness_along(state, w)
        total = sampled_held_along(self.owner, state, w, self._unit_held(),
                                   np.zeros((self.owner.model.n_total + 1, self.C)))
        return self.owner._on_free_coordinates(state, total)

    def _linked_held_stiffness_along(self, state, w: np.ndarray) -> np.ndarray:
        """(n, C): :meth:`held_stiffness_along` on a model with rigid links or guides. The held map is A_y = Pᵀ A_y,all
        (A_y,all the unit columns' ∂r_all/∂p on the assembled coordinates), so along w

            ∂(A_y δy)/∂q w = Pᵀ ∂A_y,all/∂q[P w] δy + ∂Pᵀ/∂q[w] A_y,all δy,

        the forward method's path for the held outputs' part (``TransientSensitivities._linked_stiffness_along``:
        ``linked_controller_parameter_along``'s ``sampled_held_along`` at u = P w, projected, and the reduction's
        geometric term of the static ∂r_all/∂p's columns, :func:`latdyn.analyses.weight_derivative.geometric_product`),
        exact. Before (diffgen), a central difference of :meth:`held_map` along w (step WEIGHT_STEP ℓ/|w|_∞, two
        evaluations at each weight met): 1.7e-11 off Richardson differences of the block at the latch of
        tests/test_adjoint_sampled_linked.py."""
        from latdyn.analyses.parameter_stiffness import sampled_held_along

        owner = self.owner
        model = owner.model
        one = self._unit_held()
        along = sampled_held_along(owner, state, w, one, np.zeros((model.n_total + 1, self.C)),
                                   full=owner._along_assembled(state, w))
        out = owner._on_free_coordinates(state, along)
        on_all = self._held_map_on_all(state, one)
        return out + owner._geometric_products(state, on_all[:model.n_assembled], w)

    def held_transposed(self, state, w: np.ndarray, y_bar: np.ndarray) -> np.ndarray:
        """ȳ − A_yᵀ w: the held δy's use in the step's ∂r/∂p, transposed."""
        return y_bar - self.held_map(state).T @ w

    def restart_transposed(self, state, bars: list, y_bar: np.ndarray, gradient: np.ndarray) -> tuple:
        """The restart after the sample at ``state`` transposed (class docstring): ``bars`` [q̄, v̄, v̇̄, ā] replaced in
        place, ``gradient`` updated; returns (ȳ, ū) (ū for the continuous states held through the restart: their
        Bᵀū). M, C and the exact K are the forward method's (:meth:`_matrices`)."""
        from latdyn.assembly.factorization import solve_linear

        owner = self.owner
        q_bar, v_bar, vdot_bar, a_bar = bars
        M, C, K = owner._matrices(state)
        s_bar = vdot_bar + a_bar
        u_bar = -np.asarray(solve_linear(M.T.tocsr() if hasattr(M, "tocsr") else np.ascontiguousarray(M.T),
                                         s_bar)).reshape(s_bar.shape)
        gradient += owner.residual_transposed_product(state, u_bar)
        y_bar = y_bar + self.held_map(state).T @ u_bar
        bars[:] = [q_bar + np.asarray(K.T @ u_bar), v_bar + np.asarray(C.T @ u_bar), np.zeros_like(vdot_bar),
                   np.zeros_like(a_bar)]
        return y_bar, u_bar

    def sample_transposed(self, state, due: list, S_before: np.ndarray, q_bar: np.ndarray, v_bar: np.ndarray,
                          y_bar: np.ndarray, S_bar: np.ndarray, gradient: np.ndarray,
                          theta_bar: np.ndarray | None = None) -> tuple:
        """The sample of the controllers ``due`` at ``state`` (their states ``S_before`` before it) transposed
        (class docstring; a sensor reading a rate: δs = D_q δq + D_v δv, δv the sample's state's, v̄ += D_vᵀ s̄): q̄, v̄
        and ``gradient`` updated in place, and ``theta_bar`` (the held angles' adjoints where friction holds a joint
        at the sample: δs reads its held δθ, :func:`_held_sensed_transposed`); returns (ȳ, S̄) before the sample."""
        from latdyn.analyses.sensitivities import _sensor_derivatives

        sampled, owner = self.sampled, self.owner
        values = dict(zip(sampled.terms.sensors.names, sampled.terms.sensors.values(state)))
        y_bar, S_bar = y_bar.copy(), S_bar.copy()
        for c in sampled.controllers:
            if c.name not in due:
                continue
            rows, i = sampled._rows(c), sampled.index[c.name]
            inside, y_s, y_S, y_p, g_s, g_S, g_p = sampled.partials(c, state.t, values, S_before[rows])
            by_rate = S_bar[rows] / c.rate
            out_bar = y_bar[i] if inside else np.zeros_like(y_bar[i])
            s_bar = np.outer(y_s, out_bar) + g_s.T @ by_rate
            gradient += np.outer(y_p, out_bar) + g_p.T @ by_rate
            S_bar[rows] = S_bar[rows] + g_S.T @ by_rate + np.outer(y_S, out_bar)
            y_bar[i] = 0.0
            if len(c.reads):   # the forward method's SampledTerms.sample: δs = D_q δq + D_v δv (+ the held δθ)
                def sensed(dq, dv, c=c):
                    return _sensor_derivatives(owner, sampled.sensors[c.name], state, dq, None, dv)

                D_q, D_v = _sensed_forms(owner, sensed, sampled.sensors[c.name])
                q_bar += D_q.T @ s_bar
                if D_v is not None:
                    v_bar += D_v.T @ s_bar
                _held_sensed_transposed(owner, sensed, sampled.sensors[c.name], s_bar, theta_bar)
        return y_bar, S_bar

    def start_transposed(self, state, y_bar: np.ndarray, S_bar: np.ndarray, gradient: np.ndarray,
                         moves: tuple | None = None) -> None:
        """The sample at t = 0 transposed (δS_0 = 0; the forward method's ``SampledTerms.start``):
        dy/dp += ∂f/∂pᵀ ȳ_c + ∂g/∂pᵀ S̄/rate + δs_0ᵀ s̄, s̄ = ∂f/∂sᵀ ȳ_c + ∂g/∂sᵀ S̄/rate, δs_0 = D_q δq_0 + D_v δv_0 the
        forward method's own (``_sensor_derivatives``) on the start's moves ``moves`` = (δq_0, δv_0)
        (``TransientSensitivities.start_moves``; None: the start does not move, δs_0 = 0)."""
        from latdyn.analyses.sensitivities import _sensor_derivatives

        sampled = self.sampled
        values = dict(zip(sampled.terms.sensors.names, sampled.terms.sensors.values(state)))
        initial = np.array([c.initial[s] for c in sampled.controllers for s in c.states], float)
        for c in sampled.controllers:
            rows, i = sampled._rows(c), sampled.index[c.name]
            inside, y_s, _, y_p, g_s, _, g_p = sampled.partials(c, state.t, values, initial[rows])
            if inside:
                gradient += np.outer(y_p, y_bar[i])
            gradient += g_p.T @ (S_bar[rows] / c.rate)
            if moves is not None and len(c.reads):
                out_bar = y_bar[i] if inside else np.zeros_like(y_bar[i])
                s_bar = np.outer(y_s, out_bar) + g_s.T @ (S_bar[rows] / c.rate)
                ds = _sensor_derivatives(self.owner, sampled.sensors[c.name], state, moves[0], None, moves[1])
                gradient += ds.T @ s_bar
