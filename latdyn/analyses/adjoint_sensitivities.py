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
gradient at its row; a section force's explicit ∂S/∂p and a body frame's forms likewise:
latdyn/analyses/probe_derivatives.py ``probe_forms``). So the derivative of m
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

Geometry parameters (latdyn/analyses/geometry_sensitivities.py; docs/parameters.md, "Geometry parameters by the
adjoint") move the start too: δq_0 = D_q (δX of the free nodes), δv_0 gains D_ω (ω × δX, a hinge's δa·ω) and the
start's accelerations take K_0 D_q + C_0 D_ω (K_0 exact), so t = 0 adds D_qᵀ(q̄_0 + K_0ᵀ r̄) + D_ωᵀ(v̄_0 + C_0ᵀ r̄)
(:meth:`_start_moved_transposed`), a row at t = 0 seeded on q̄_0 as well; their ∂r/∂p columns (the generated
``*_D_reference`` kernels) enter Eᵀw as the other kinds', and a point probe's moves at a fixed state (its offset, a
held node, a displacement's start) are its explicit part (:meth:`_point_moves`). Beside rigid links and guides
these are the forward method's own on the reduction: D_q and D_ω on the free (minimum) coordinates, K_0 and C_0 the
reduced ones (:meth:`_matrices`), ∂r/∂p the reduced one (the held dependent nodes' moves and the shifts on parts that
turn, :meth:`ReferenceGeometry.add`) transposed onto w, the probes' moves with the shifts; beside controllers their
terms of ∂r/∂p (a point sensor's ∂s/∂X through ∂f/∂s) come with the other parameters' (:meth:`residual_transposed_product`).

Rᵀ = exp(−skew hΔq) and Jᵀ = dexp(−hΔq): the forward operators' 3 × 3 blocks transposed. Per reverse step
the exact M, C, K are evaluated again at the stored state
(:meth:`latdyn.assembly.assembler.Assembler.exact_matrix_values`) and A = β′M + γ′C + K J is assembled and factorised as the forward method's step does, on its held pattern
and storage (:class:`latdyn.analyses.step_matrix.ExactStepMatrix`), w solved with Aᵀ from those factors
(:meth:`latdyn.assembly.factorization.Factorization.solve_transposed`: no transposed matrix formed or
factorised), Kᵀw and Cᵀw by views of the held C and K; where the run allows it, each smooth step's evaluation,
factorization, transposed solve and bars in one native call with the same sums
(latdyn/analyses/adjoint_in_loop.py, csrc/adjoint_reverse.c). Eᵀw is one batched product
(:meth:`AdjointSensitivities.residual_transposed_product`): each use of a section value or load component
by a parameter contributes its element's or load's forces (the forward method's kernels, one call for all)
dotted with w at their coordinates, without forming E (n × k); the other kinds through E's columns. So the
adjoint's derivatives are the forward method's to round-off, at a cost independent of k but for the
kernels of E. A norm probe exactly 0 at its row (|·| not differentiable there) is seeded as its three
components and given the forward method's value: 0 for a parameter that does not move the point, NaN for
one that does.

The matrices are evaluated again rather than stored: the forward pass steps as the run without
sensitivities does and never evaluates them (its Newton matrix lacks the inertia tangent and is taken at
the iterates, not at the converged state), so storing them would move the same evaluation to the forward
pass and keep 3 × nnz numbers a step (76 kB for the 30-element cantilever, 539 kB for a 1000-member
lattice, against 8.8 kB and 120 kB of stored state).

Events (docs/parameters.md, "The discrete adjoint", "Events"): at a step that ends on a hinge's latch or rigid
stop, a compliant stop's onset (no jump: the landing step's size alone, rule ``onset``) or a cable element's change,
the forward method composes the step with linear maps — its size's
derivative δh, a linear functional of the step's parameter columns added through the step size's column; the
jump of δv through the impulse; the renumbering after a latch; the restarted accelerations — and the reverse pass
applies their transposes in reverse order, each named after its forward piece (:meth:`_restart_transposed`,
:meth:`_renumbering_transposed`, :meth:`_impulse_transposed` with :meth:`_weight_derivative_transposed`,
:meth:`_step_size_transposed` with :meth:`_step_size_column`); t̄ and ḡ, the adjoints of δt and of the carried δh,
run back beside the bars, and each event time is an output seeded on t̄ (``event_sensitivities``). Beside laws in
t the forward method's ∂r/∂t δt terms (a step's, the step size column's, the restart's and the impulse weight's)
are transposed onto t̄ by latdyn/analyses/adjoint_time.py.

What the forward pass stores, in memory (``carried["trajectory"]``, checkpointed with the run; the smooth steps
stored by the loop of steps in C where the run allows it, latdyn/analyses/adjoint_in_loop.py): each
accepted step's end state (a copy: 24 numbers a node and 3 a hinge) and size and the algorithmic
accelerations before and after it (2n numbers); where the scene has events, the numbering and cables' sides each
step was taken on, the event it ends on, its size's rule (:meth:`_size_rule`) and after an event the state after
the jump and restart. What is refused (:func:`adjoint_refusal`, exit 2 naming ``solve.sensitivity_method``):
everything the forward method refuses, and what leaves the recurrence above and its events' pieces: a joint that
friction sticks or releases beside geometry parameters or a controller's probe, or with another event at one
instant or while stuck (refused when it sticks, :meth:`_refuse_a_stick`; friction slipping, and its sticks and
releases otherwise — beside latches, stops, cables, continuous controllers without states, controllers with states
or sampled ones that drive the stuck joint alone (their sensors read the held angle: θ̄ += D_θᵀ s̄ at each step's
states and each sample, their held δS and δy through the friction events' restarts and jumps) and joint-force and
section-force probes too —, are taken: the forward method's stick — a stop's impulse with restitution 0, the held
angle's δθ_j = δq[θ_j], a stop's restart —, the steps while stuck — K's column of the held angle times δθ_j in ∂r/∂p — and
its release — δq[θ_j] = δθ_j, a stop's restart — transposed, the held angles' adjoints θ̄ carried back beside the
bars: :meth:`_friction_event_transposed`, :meth:`_held_step_transposed`, :meth:`_held_forms`). A hinge resting on
its rigid stop is taken: its coming to rest — the landed impact with restitution 0 and the restart on the locked
numbering —, the steps it rests, its release at a step's end, :meth:`_release_transposed`, and its projection back
onto the stop, :meth:`_projected_transposed`, are transposed (beside controllers with states or sampled ones the
held δS and δy of the restarts too, :meth:`_held_through_restart`; the projection the forward method refuses there). Controllers are taken:
continuous ones without states enter E and the matrices as in the forward method; with states and sampled ones
(beside events too: :meth:`_held_weights_transposed`; reading rates too) and controller probes (an output naming t at
a row whose time moves: its ∂f/∂t seeded on t̄ there, :meth:`reverse`) through the states' and held outputs' bars
beside these, latdyn/analyses/adjoint_controller_states.py, :meth:`_step_transposed`, :meth:`after_sample`. Rigid
links and guides
are taken: the matrices are the reduced step's, a probe on a node that follows them has its output gradient on the
coordinates it moves with (:func:`latdyn.analyses.link_sensitivities.columns_moving`; a section force's, a cable's and
a body frame's seeds likewise, latdyn/analyses/probe_derivatives.py ``probe_forms``, and the energies' and momenta's
through the forward method's maps of the free columns, latdyn/analyses/energy_sensitivities.py ``probe_forms``), and
at an event the impulse's and the
restart's weights of the reduction, which move with the step's δv and δv̇ as well as δq (their geometric term, the
forward method's ``rates``), are transposed along all three (:meth:`_linked_weight_transposed`).
"""
from __future__ import annotations

from contextlib import nullcontext
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from latdyn.analyses import adjoint_time
from latdyn.analyses.adjoint_controller_states import probe_forms as controller_probe_forms
from latdyn.analyses.adjoint_in_loop import accepted
from latdyn.analyses.controller_probe_sensitivities import is_controller_probe, names_t
from latdyn.analyses.energy_sensitivities import is_energy_or_momentum
from latdyn.analyses.energy_sensitivities import probe_forms as energy_probe_forms
from latdyn.analyses.geometry_sensitivities import GEOMETRY_KEY
from latdyn.analyses.joint_force_sensitivities import (held_sensor_forms, is_joint_force, joint_force_forms,
                                                       joint_of)
from latdyn.analyses.link_sensitivities import columns_moving
from latdyn.analyses.parameter_stiffness import held_angles_along
from latdyn.analyses.probe_derivatives import is_probe_here, probe_derivatives, probe_forms
from latdyn.analyses.sensitivities import (_BODY_KEY, _LOAD_KEY, _SECTION_KEY, SENSITIVITIES_FILE,
                                           rates_taken_anew)
from latdyn.analyses.transient_sensitivities import (HELD_FROM_THE_START, TransientSensitivities, _NodeRotations,
                                                     _StepColumns, friction_key)
from latdyn.analyses.weight_derivative import configuration_tangent_of_weight, transposed_times
from latdyn.assembly.assembler import free_acceleration, free_velocity, pack, unpack_free
from latdyn.assembly.factorization import factorization_for, solve_linear, solve_linear_csr
from latdyn.errors import SolverError
from latdyn.numerics.csr import CSR, Transpose, transposed
from latdyn.numerics.linalg import issparse
from latdyn.step.integrators import consistent_acceleration
from latdyn.timeloop.events import stop_holds
from latdyn.timeloop.impulse import hinge_directions, massless_element_stiffness

__all__ = ["AdjointSensitivities"]

#: why a stick is refused where the stuck joints are the only coordinates (:meth:`AdjointSensitivities._refuse_a_stick`)
NOTHING_ELSE_FREE = "with nothing else free (the stuck joints the only coordinates)"


class AdjointSensitivities(TransientSensitivities):
    """The discrete adjoint (module docstring), called by the time loop as the forward method is:
    :meth:`start` and :meth:`step` store the trajectory, :meth:`record` the rows' step indices, and
    :meth:`finish` runs the reverse pass and writes ``probe_sensitivities`` and the end row."""

    def in_loop(self):
        """The forward pass's smooth steps stored by the loop of steps in C
        (:class:`latdyn.analyses.adjoint_in_loop.AdjointLoop`), or None where every step is stored from Python
        (:meth:`step`; :func:`latdyn.analyses.adjoint_in_loop.refusal`): decided once per run."""
        from latdyn.analyses import adjoint_in_loop

        if not adjoint_in_loop.ADJOINT_IN_LOOP or adjoint_in_loop.refusal(self) is not None:
            return None
        return adjoint_in_loop.AdjointLoop(self)

    # ------------------------------------------------------------------ the forward pass: storing
    def start(self, state) -> dict:
        """The carried trajectory at t = 0: the started state (its accelerations consistent) and the
        refusals of the forward method's start (directions without inertia off rest; events where the
        impulse's weight is not M + dt²K alone)."""
        model = self.model
        carried = {"trajectory": [], "rows": [], "start": state.copy(), "events": [],
                   "numbering_start": self._numbering(), "timed": False, "dh_moves": False}
        if self._states_transposed() is not None:   # the accepted (S, f) at t = 0
            carried["controller_start"] = self._states_transposed().stored()
        if self._samples_transposed() is not None:   # the held outputs after the sample at t = 0, the states it left
            carried["outputs_start"] = self.scene.controller_outputs.values.copy()
            carried["sampled_S"] = self._sampled_states()
        if model.n_dofs and self.names:
            ev = self.assembler.evaluate(state, matrices=True)
            _, split = self._start_mass(ev)
            self._refuse_events(ev, split)
            if split.n_massless:
                self._refuse_start(state, ev, split)
            #: whether an impulse's weight is M + dt²K alone, as the forward method's start sets it (a stick's jump)
            self._impulse_weighted = not (split.n_massless or massless_element_stiffness(ev) is not None)
        if model.stuck.any():   # stuck by friction from t = 0 (latdyn.timeloop.events.stick_at_start): δθ_0 = 0 held
            # with nothing else free the forward method's start prepares nothing and refuses nothing (its release
            # is refused when it comes): the adjoint's reason is that nothing else is free, not the model's guides
            self._refuse_a_stick(state, int(np.flatnonzero(model.stuck)[0]),
                                 NOTHING_ELSE_FREE if model.n_dofs == 0 else None, HELD_FROM_THE_START)
        return carried

    def _refuse_a_stick(self, state, joint: int, why: str | None = None,
                        happens: str = "the joint sticks or slips") -> None:
        """SceneError (exit 2) naming the friction of ``joint``, which sticks or is released at ``state``, where the
        reverse pass does not transpose its stick or release (``why``; else the checks below): the forward method's
        own refusals (:meth:`TransientSensitivities._refuse_what_a_held_angle_moves`: guides or rigid links, directions
        without inertia, controllers with states or sampled ones driving another coordinate), and this pass's: a stick
        beside geometry parameters (the held angle's terms of the start's move are not formed), with nothing else free,
        and beside a controller's probe, an energy or a momentum (its forms of the held angle are not formed). The
        events the forward method takes beside a stick are taken (a latch, a stop or a cable's change while no joint is
        stuck: :meth:`step`, :meth:`_stick_or_release_stored`), continuous controllers without states, controllers
        with states or sampled ones driving the stuck joint alone (their sensors' held δθ, θ̄ += D_θᵀ s̄:
        adjoint_controller_states.py ``_held_sensed_transposed``; their held δS and δy through the stick's and
        release's restart and jump, :meth:`_friction_event_transposed`), and probes of points, joints' angles,
        rates and forces, section forces, cables and points in a body's frame (:meth:`_held_forms`). Everything else
        is transposed (:meth:`_friction_event_transposed`). ``happens`` says what the joint does, for the message
        (``HELD_FROM_THE_START`` at t = 0)."""
        from latdyn.errors import SceneError

        self._refused = True   # nothing for :meth:`finish` to write where the run is refused (exit 2)
        if why is None:
            self._refuse_what_a_held_angle_moves(state, happens, joint)   # SceneError: the forward method refuses it too
            if self.geometry is not None:
                why = "beside geometry parameters"
            elif self.model.n_dofs == 0:
                why = NOTHING_ELSE_FREE
            else:
                other = [probe.name for probe in self.probes if not _held_angle_probe(probe)]
                why = (f"beside probe {other[0]!r} (a controller's, an energy or a momentum: its forms of the held "
                       "angle are not transposed)" if other else None)
        if why is None:
            self._refused = False
            return
        raise SceneError(self.scene.file, friction_key(self.model.hinges[joint]),
                         f"at t = {float(state.t):.6g} {happens} {why}: the discrete adjoint "
                         "differentiates a stick and a release beside the events, continuous controllers without "
                         "states and probes the forward method takes there, not this; expected "
                         "solve.sensitivity_method: forward (the default), which does (docs/parameters.md, "
                         "\"Friction\")")

    def _may_stick(self) -> bool:
        """Whether a joint of the model has friction that can hold it (static level > 0): the numbering each step is
        taken on is stored then (a stick and a release renumber the coordinates)."""
        if "_sticks_here" not in self.__dict__:
            self._sticks_here = any(h.friction is not None and h.friction.static > 0.0 and h.angle is None
                                    for h in self.model.hinges)
        return self._sticks_here

    def step(self, carried: dict, old, new, h: float, a_old: np.ndarray, a_new: np.ndarray,
             lands: bool = True) -> dict:
        """The accepted step ``old`` → ``new`` stored (its end state before the events, size and algorithmic
        accelerations; where the scene has events, the coordinates' numbering and the cables' sides it was
        taken on, the event it ends on and the rule its size's derivative follows, :meth:`_size_rule`);
        appended in place: the trajectory grows with the run and a copy per step would cost its length."""
        entry = {"state": new.copy(), "h": float(h), "a_old": np.array(a_old, float),
                 "a_new": np.array(a_new, float), "pending": True}   # accepted once its events are (after_events)
        if self._states_transposed() is not None:   # the controllers' accepted (S, f) at the step's end
            entry["controller"] = self._states_transposed().stored()
        if self._samples_transposed() is not None:   # the held outputs the step was taken with
            entry["outputs"] = self.scene.controller_outputs.values.copy()
        if self._with_events():
            event = self._event(old, new) if self.model.n_dofs else None
            cable = self._cable_event(old, new, event)
            if (event is not None or cable is not None) and self.model.stuck.any():   # the forward method's refusal
                self._refuse_a_stick(new, int(np.flatnonzero(self.model.stuck)[0]),
                                     "while another event (a latch, a stop, a cable's change) comes")
            # the projection at a step's end lands on nothing: its step's size is the step control's (the forward
            # method's ``landed``)
            landed = None if event is not None and event[1] == "rest" else event
            # a compliant stop's onset: no jump, its time through the landing step's size (the forward method's
            # ``landed or self._contact_onset(old, new)``)
            onset = self._contact_onset(old, new) if landed is None and cable is None and self.model.n_dofs else None
            timed = carried["timed"]   # δt_n may be non-zero: the step's ∂r/∂t δt_n (laws in t, adjoint_time.py)
            # the resting hinges the step's end releases (the run's test, as the forward method's
            # _release_candidates): one the run settles on its stop again at once keeps its ``resting``
            released = [int(j) for j in np.flatnonzero(self.model.resting) if not stop_holds(self.prepared, new, int(j))]
            entry.update({"numbering": self._numbering(), "event": event, "cable": cable, "onset": onset,
                          "rule": self._size_rule(carried, h, lands, landed or onset, cable), "timed": timed,
                          "resting": self.model.resting.copy(), "released": released})
            if not self.model.n_dofs:   # nothing free (all latched): the forward method's δh, −δt_n onto the grid,
                entry["rule"] = ("lands",) if lands and timed else None   # else 0 (TransientSensitivities.step)
                carried["timed"], carried["dh_moves"] = timed and not lands, False
            entry["timed_end"] = carried["timed"]   # δt_{n+1} may be non-zero: a row here moves in time
        if "numbering" not in entry and self._may_stick():   # a stick or release at its end renumbers
            entry["numbering"] = self._numbering()
        if carried["trajectory"] and carried["trajectory"][-1].get("pending"):   # not accepted: a run resumed
            carried["trajectory"].pop()                                             # from before it
        carried["trajectory"].append(entry)
        return carried

    def after_events(self, carried: dict, new, end_after_events: bool) -> dict:
        """After the events of the step just stored: the numbering and cables' sides the rows and the next
        step are taken on, and after a latch or a stop the state after its jump and restart (where the reverse
        pass transposes the restart, :meth:`_restart_transposed`). ``end_after_events`` (the loop evaluated the
        step's end again after the events) only moves the external work's terms, which the adjoint refuses
        (latdyn/analyses/energy_sensitivities.py ``refusal``): not read here."""
        if carried["trajectory"]:
            carried["trajectory"][-1].pop("pending", None)
        if self._with_events() and carried["trajectory"]:
            entry = carried["trajectory"][-1]
            entry["numbering_end"] = self._numbering()
            if entry.get("event") is not None:
                entry["after"] = new.copy()
                states_t = self._states_transposed()   # after a latch f taken anew at the jumped rates: the next step's
                if (states_t is not None and states_t.reads_rates()   # (S_n, f_n) (ControllerStates.restarted)
                        and rates_taken_anew(entry["event"][1], self.model)):
                    entry["controller_restarted"] = states_t.stored()
        if self._may_stick() and carried["trajectory"]:
            self._stick_or_release_stored(carried["trajectory"][-1], new)
        if self._with_events() and carried["trajectory"]:
            self._settle_or_release_stored(carried["trajectory"][-1], new)
        return carried

    def _settle_or_release_stored(self, entry: dict, new) -> None:
        """Where a hinge came to rest on its rigid stop or was released from it at the end of the step ``entry`` holds
        (the resting hinges when it was taken against the model's now), what the reverse pass transposes: coming to
        rest follows the landed impact with restitution 0 (or the projection) that ``entry`` already holds, its
        restart on the locked numbering (``numbering_end``, ``after``: :meth:`_restart_transposed`); a release
        (``rest`` = ("release", j)) restarts as after a stop with δt 0 (:meth:`_release_transposed`). Refused as the
        forward method refuses them (:meth:`TransientSensitivities._settle_or_release`, :meth:`_refuse_resting`), and
        where the run releases a hinge and settles it on its stop again at one instant (``released``, ``resting``
        unchanged: the forward method's three restarts there are not transposed). Beside controllers with states or sampled ones the held δS and δy of the restarts are transposed as at a stop
        (:meth:`_held_through_restart`); the projection back onto the stop the forward method refuses beside them
        (:meth:`TransientSensitivities._refuse_what_a_rest_moves`). Geometry parameters are taken: the released boom's
        end angle by the tip's z (tests/test_sensitivities_hinge_on_stop.py RELEASE), 4.3e-9 off the forward method's
        (3.7e-7 of that small derivative, 0.009), is the round-off both carry, not a term left out: ∂r/∂X of the stiff
        boom (6.5e7 on the free coordinates at t = 0) and K δq of the start it moves cancel to 17 (5.9 on the hinge's
        row), so one rounding of ∂r/∂X moves the forward method's own derivative by up to 2.8e-9 (three draws of a
        relative 1.1e-16 on each entry; tests/test_adjoint_geometry_linked.py)."""
        before = entry.get("resting")
        if before is None:
            return
        changed = [int(j) for j in np.flatnonzero(before != self.model.resting)]
        settled_again = [j for j in entry["released"] if self.model.resting[j] == before[j]]
        if not changed and not settled_again:
            return
        j = (changed + settled_again)[0]
        if len(changed) + len(settled_again) > 1:
            self._refuse_resting(new, j, "several hinges come to rest on their stops or leave them at one instant")
        if self.model.links is not None:
            self._refuse_resting(new, j, "a joint comes to rest on its stop or leaves it in a model with guides or "
                                         "rigid links (the discrete adjoint does not transpose the reduction's "
                                         "restarts there; the forward method differentiates it on rigid links)")
        if settled_again:   # the forward method's three restarts (TransientSensitivities._settle_or_release)
            self._refuse_resting(new, j, "a hinge is released from its stop and settled on it again at one instant "
                                         "(the discrete adjoint does not transpose its restarts; the forward method "
                                         "differentiates it)")
        event = entry.get("event")
        if self.model.resting[j]:
            if event is None or event[0] != j or event[1] not in ("stop", "rest"):
                self._refuse_resting(new, j, "a hinge comes to rest on its stop without an impact landed on it")
        elif event is not None or entry.get("cable") is not None or entry.get("friction") is not None:
            self._refuse_resting(new, j, "a hinge leaves its stop beside another event at one instant")
        if self.model.stuck.any():   # the held angles' terms of the rest's restart are not transposed
            self._refuse_a_stick(new, int(np.flatnonzero(self.model.stuck)[0]),
                                 "while a hinge comes to rest on its stop or leaves it")
        if not self.model.resting[j]:
            entry.update({"rest": ("release", j), "after": new.copy(), "numbering_end": self._numbering()})

    def _stick_or_release_stored(self, entry: dict, new) -> None:
        """Where a joint stuck or was released by friction at the end of the step ``entry`` holds (the stuck joints
        of the numbering it was taken on against the model's now), what the reverse pass transposes
        (:meth:`_friction_event_transposed`): ``friction`` ("stick" or "release", the joint), the numbering after it
        and the state after its jump and restart; refused where that is not transposed (:meth:`_refuse_a_stick`)."""
        before = entry["numbering"][2]
        changed = np.flatnonzero(before != self.model.stuck)
        if not len(changed):
            return
        if len(changed) > 1:   # the forward method refuses both (TransientSensitivities._stick_or_release)
            self._refuse_a_stick(new, int(changed[0]), "with another joint at one instant")
        j = int(changed[0])
        if entry.get("event") is not None or entry.get("cable") is not None:
            self._refuse_a_stick(new, j, "at the instant of another event (a latch, a stop, a cable's change)")
        self._refuse_a_stick(new, j)
        entry.update({"friction": ("stick" if self.model.stuck[j] else "release", j),
                      "numbering_end": self._numbering(), "after": new.copy()})

    # ------------------------------------------------------------------ events: what the forward pass keeps
    def _with_events(self) -> bool:
        """Whether the model has latches, stops (rigid or compliant) or cables (the adjoint's refusal leaves no
        other events)."""
        if "_events_here" not in self.__dict__:
            self._events_here = self.model.cables is not None or any(
                h.lock_at is not None or h.limits is not None for h in self.model.hinges)
        return self._events_here

    def _states_transposed(self):
        """The transposes of the continuous controllers' states' pieces
        (:class:`latdyn.analyses.adjoint_controller_states.StatesTransposed`), or None without states."""
        if "_states_t" not in self.__dict__:
            from latdyn.analyses.adjoint_controller_states import StatesTransposed

            self._states_t = (None if self.controllers is None or self.controllers.states is None
                              else StatesTransposed(self))
        return self._states_t

    def _samples_transposed(self):
        """The transposes of the sampled controllers' pieces
        (:class:`latdyn.analyses.adjoint_controller_states.SamplesTransposed`), or None without sampled controllers."""
        if "_samples_t" not in self.__dict__:
            from latdyn.analyses.adjoint_controller_states import SamplesTransposed

            self._samples_t = (None if self.controllers is None or self.controllers.sampled is None
                               else SamplesTransposed(self))
        return self._samples_t

    def _sampled_states(self) -> np.ndarray:
        """The sampled controllers' states as the scene holds them now (SampledTerms' order)."""
        states = self.scene.controller_states
        return np.array([states[f"{c.name}.{s}"] for c in self.controllers.sampled.controllers for s in c.states],
                        float)

    def after_sample(self, carried: dict, state, due: list) -> dict:
        """The sample at ``state`` of the sampled controllers named in ``due`` (after the step just stored) and the
        restart after it, stored on that step's entry: the controllers due, their states before the sample, the
        state and the held outputs after it (what the reverse pass transposes,
        :class:`latdyn.analyses.adjoint_controller_states.SamplesTransposed`). A restart that splits off directions
        without inertia is refused as the forward method refuses it."""
        if self.model.n_dofs == 0 or not self.names:
            return carried
        self.refuse_massless_restart(state, self._matrices(state)[0])
        carried["trajectory"][-1]["sample"] = {"due": list(due), "S": carried["sampled_S"], "state": state.copy(),
                                               "outputs": self.scene.controller_outputs.values.copy()}
        carried["sampled_S"] = self._sampled_states()
        return carried

    def _numbering(self) -> tuple:
        """(the locked joints, the cables' sides or None, the joints friction holds): what the coordinates' numbering
        and the evaluation's cable law depend on, changed by latches, cables' changes, sticks and releases."""
        cables = self.model.cables
        return (self.model.locked.copy(), (None if cables is None else np.array(cables.sides, float)),
                self.model.stuck.copy())

    def _numbered(self, numbering: tuple) -> None:
        """The model put back on ``numbering`` (:meth:`_numbering`): the locked joints and the coordinates
        renumbered as a latch renumbers them (latdyn/timeloop/events.py ``latch_hinges``), the cables' sides
        set in place (the evaluation reads them there)."""
        model = self.model
        locked, sides = numbering[:2]
        if len(numbering) > 2:   # the joints friction holds (locked too)
            model.stuck[:] = numbering[2]
        if not np.array_equal(model.locked, locked):
            model.locked[:] = locked
            model.number_coordinates()
            self.assembler.reindex()
        if sides is not None:
            model.cables.sides[:] = sides

    def _size_rule(self, carried: dict, h: float, lands: bool, event, cable):
        """The rule of the step's δh as the forward method's :meth:`_step_size_derivative` (and
        :meth:`CableSensitivities.step_size_derivative`) applies it, or None where δh is 0 exactly
        (before any event δt_n and the last δh are 0): ("event",) the hinge's angle held on its event,
        ("cable",) the element's gap held at 0, ("lands",) δh = −δt_n, ("sized", a, b) δh = a δh_prev + b δt_n,
        the trial's size as the step control chose it (:meth:`resized`). Updates ``carried``'s flags of whether
        δt_n and the carried δh may be non-zero, and whether the step's δh is its trial's (``trial_sized``)."""
        timed, dh_moves = carried["timed"], carried["dh_moves"]
        carried["trial_sized"] = not lands and event is None and cable is None
        if event is not None or cable is not None:
            rule = ("cable",) if cable is not None else ("onset",) if event[1] == "contact" else ("event",)
            carried["timed"], carried["dh_moves"] = True, True
            return rule
        if lands:
            carried["timed"], carried["dh_moves"] = False, timed
            return ("lands",) if timed else None
        a, b = carried.get("next_size", (0.0, 0.0))
        moves = (a != 0.0 and dh_moves) or (b != 0.0 and timed)
        carried["timed"], carried["dh_moves"] = timed or moves, moves
        return ("sized", a, b) if moves else None

    def resized(self, carried: dict, control, lands: bool | None = None, integrator=None) -> dict:
        """The forward method's :meth:`TransientSensitivities.resized` as coefficients: the next trial's δh =
        a δh_prev + b δt_n (``carried["next_size"]``, δh_prev the last accepted step's), from ``control.resize``
        (∂h'/∂h, ∂h'/∂h_proposed; fixed steps). After a trial Newton did not converge (``lands``: it landed on the
        grid, its δh −δt_n), δh' = ∂h'/∂h δh_trial + ∂h'/∂h_proposed δh_proposed; after an accepted step whose δh
        was its trial's, δh' = (∂h'/∂h + ∂h'/∂h_proposed) δh (the proposed size was the step's own)."""
        if not self._with_events():   # δt_n and every δh are 0 exactly
            return carried
        resize = control.resize
        if resize is None:
            raise SolverError("the adjoint sensitivities meet a step size that does not follow from the step before "
                              "it (a pause of latdyn.Simulation between grid points); expected latdyn run")
        a, b = carried.get("next_size", (0.0, 0.0))
        if lands is not None:
            trial = (0.0, -1.0) if lands else (a, b)
            carried["next_size"] = (resize.by_step * trial[0] + resize.by_proposed * a,
                                    resize.by_step * trial[1] + resize.by_proposed * b)
        elif carried.get("trial_sized", True):
            carried["next_size"] = (resize.by_step + resize.by_proposed, 0.0)
        elif resize.by_proposed != 0.0 and (a, b) != (0.0, 0.0):
            raise SolverError("the adjoint sensitivities meet a step sized from a trial proposed before an event or a "
                              "landing on the grid, which the reverse pass does not follow; expected the nominal step "
                              "after them (docs/parameters.md, \"The discrete adjoint\")")
        else:
            carried["next_size"] = (resize.by_step, 0.0)
        return carried

    def record(self, carried: dict, state) -> dict:
        """The row at ``state``: the index of the stored state it is (0: the start; a run that failed in the
        events of its last step records the state before that step, which :meth:`finish` leaves out)."""
        carried["rows"].append(len(accepted(carried["trajectory"])))
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

    def residual_transposed_product(self, state, w: np.ndarray, inertia: bool = True) -> np.ndarray:
        """(k, m): (∂r/∂p)ᵀ w at ``state`` for the m columns of ``w`` (n, m) on the free coordinates, ∂r/∂p
        of the equations of motion (:meth:`residual_derivatives`) without forming it: the uses of section
        values and of load components each as one batched product of their element or load forces
        (:meth:`_section_element_forces`, :meth:`_load_pair_forces`) with w at their coordinates, summed into
        their parameters' rows (10³ sections of a lattice, 100 load amplitudes: no (n, k) array, no
        per-parameter Python); the geometry parameters' likewise, each pair of an element and a parameter that
        moves its reference one row of the generated kernels (:meth:`ReferenceGeometry.transposed_product`); the
        other parameters' (hinges, bodies, contact, controllers) by
        :meth:`residual_derivatives` on all coordinates, transposed onto w there (the free coordinates are
        the first n). With rigid links (the reduction onto minimum coordinates, latdyn/assembly/linked.py)
        ∂r/∂p is the reduced one, formed by :meth:`residual_derivatives` and transposed onto w. ``inertia``:
        with the inertia forces (the step's residual), or the static residual's ∂r/∂p (an impulse weight's
        derivative, :meth:`_weight_derivative_transposed`)."""
        model, k = self.model, len(self.names)
        if model.links is not None:
            return self.residual_derivatives(state, 1.0, inertia=inertia).T @ w
        weights = np.zeros((model.n_total + 1, w.shape[1]))
        weights[:model.n_dofs] = w
        product = np.zeros((k, w.shape[1]))
        for forces, dofs in ((self._section_element_forces(state, 1.0, inertia=inertia), model.element_dofs),
                             (self._load_pair_forces(state, 1.0), model.node_dofs)):
            if forces is not None:
                at, columns, by_use = forces
                np.add.at(product, columns, np.einsum("ep,epm->em", by_use, weights[dofs[at]]))
        if self.geometry is not None:   # the pairs of an element and a geometry parameter that moves it
            product += self.geometry.transposed_product(state, weights, 1.0, inertia, 1.0)
        if self._other_than_batched():
            self._batched_apart = True
            try:
                product += self.residual_derivatives(state, 1.0, inertia=inertia, on_all=True).T @ weights
            finally:
                self._batched_apart = False
        return product

    def _other_than_batched(self) -> bool:
        """Whether a parameter enters ∂r/∂p otherwise than through a section value, a load component or a number
        that places the structure (a hinge, body, contact, … key, or a controller's output)."""
        if "_others" not in self.__dict__:
            self._others = self.controllers is not None or any(
                not (_SECTION_KEY.match(key) or _LOAD_KEY.match(key) or GEOMETRY_KEY.match(key))
                for key in self.derivatives)
        return self._others

    def _add_geometry_forces(self, state, total: np.ndarray, load_factor: float, inertia: bool,
                             weight_factor: float) -> None:
        """:meth:`ParameterDerivatives._add_geometry_forces`, left out while :meth:`residual_transposed_product`
        takes the geometry parameters' product apart (:meth:`ReferenceGeometry.transposed_product`)."""
        if not self.__dict__.get("_batched_apart", False):
            super()._add_geometry_forces(state, total, load_factor, inertia, weight_factor)

    def _section_forces(self, state, total: np.ndarray, load_factor: float, inertia: bool = False) -> None:
        """:meth:`ParameterDerivatives._section_forces`, left out while :meth:`residual_transposed_product`
        takes the sections' product apart."""
        if not self.__dict__.get("_batched_apart", False):
            super()._section_forces(state, total, load_factor, inertia)

    def _add_load_forces(self, state, total: np.ndarray, load_factor: float) -> None:
        """:meth:`ParameterDerivatives._add_load_forces`, left out while :meth:`residual_transposed_product`
        takes the loads' product apart."""
        if not self.__dict__.get("_batched_apart", False):
            super()._add_load_forces(state, total, load_factor)

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
        if is_controller_probe(probe):   # latdyn/analyses/adjoint_controller_states.py: (…, c_S) on the states too
            return controller_probe_forms(self, probe, state)
        if is_probe_here(probe):   # section forces, points in a body frame: latdyn/analyses/probe_derivatives.py
            return probe_forms(self, probe, state)
        if is_energy_or_momentum(probe):   # latdyn/analyses/energy_sensitivities.py
            c_q, c_v, explicit = energy_probe_forms(self, probe, state, _BODY_KEY)
            return c_q, c_v, np.zeros_like(c_q), explicit
        c_q, c_v = self.output_gradient(probe, state)
        return c_q, c_v, np.zeros_like(c_q), self._point_moves(probe, state)

    def _point_moves(self, probe, state) -> np.ndarray:
        """(k,) a probe's explicit derivative by the geometry parameters at a fixed state: a point's offset, a
        fixed or prescribed node and a displacement's start moved (the forward method's
        :meth:`_probe_derivatives` on zero columns, :meth:`ReferenceGeometry.point_moves`); zero without geometry
        parameters and for joint probes."""
        k = len(self.names)
        if self.geometry is None or probe.kind != "point":
            return np.zeros(k)
        zero = np.zeros((self.model.n_dofs, k))
        return np.asarray(self._probe_derivatives(probe, state, *self._by_parameter(zero, state),
                                                  self._rates_by_parameter(zero, zero, state)), float)

    def output_gradient(self, probe, state) -> tuple:
        """(c_q, c_v) (n,) each: the probe's derivative at ``state`` is c_qᵀδq + c_vᵀδv
        (:meth:`_probe_derivatives` on the unit columns of the coordinates it reads, its node's or its
        hinge's: a position or angle reads δq alone, a rate or velocity δv and, through ω × (δπ × T r),
        δq)."""
        model, n = self.model, self.model.n_dofs
        if probe.kind in ("hinge", "guide"):
            joint = (probe.beam, probe.end) if probe.kind == "hinge" else (probe.body, "guide")
            dofs = np.array([model.hinge_dofs[model.hinge_index(*joint)]])
        else:   # a node that follows rigid links moves with its root's and its joints' coordinates
            dofs = columns_moving(model, model.point(probe.point)[0])
        dofs = dofs[dofs < n]
        c_q, c_v = np.zeros(n), np.zeros(n)
        if len(dofs):
            units = np.zeros((n, len(dofs)))
            units[dofs, np.arange(len(dofs))] = 1.0
            still = np.zeros_like(units)
            c_q[dofs] = self._probe_derivatives(probe, state, *self._by_parameter(units, state),
                                                self._rates_by_parameter(still, units, state), explicit=False)
            if probe.quantity in ("rate", "velocity"):
                c_v[dofs] = self._probe_derivatives(probe, state, *self._by_parameter(still, state),
                                                    self._rates_by_parameter(units, still, state), explicit=False)
        return c_q, c_v

    def reverse(self, carried: dict, outputs: list) -> tuple:
        """((k, m) the derivatives of the m ``outputs`` (:meth:`outputs`) by the k parameters, (k, e) those of
        the e event times (:meth:`event_records`)): the transposed recurrence run backwards over the stored
        trajectory (module docstring), the event times as outputs seeded on δt at their steps' ends."""
        n, k = self.model.n_dofs, len(self.names)
        events = self.event_records(carried)
        if k == 0 or (not outputs and not events) or (n == 0 and not self._with_events()):
            return np.zeros((k, len(outputs))), np.zeros((k, len(events)))
        trajectory, rows = carried["trajectory"], carried["rows"]
        states = [carried["start"]] + [entry.get("after", entry["state"]) for entry in trajectory]
        numberings = [carried.get("numbering_start")]
        for entry in trajectory:   # a step without an event or a stick (the loop's) ends on the numbering before it
            numberings.append(entry.get("numbering_end") or numberings[-1])
        final = self._numbering() if self._with_events() or self._may_stick() else None   # put back at the end
        held_seeds: dict[int, list] = {}   # stored state index -> [(column, c_θ (n_hinges,))]: held angles' forms
        seeds: dict[int, list] = {}   # stored state index -> [(column, (c_q, c_v, c_v̇, explicit))]
        timings: dict[int, list] = {}   # stored state index -> [(column, its seed on δt there)]
        taken: list[list[int]] = []   # each output's columns: one, or a norm at 0's three components
        columns = 0
        try:
            # the outputs' forms taken state by state (a latch's renumbering rebuilds the native model; with rigid links
            # or guides the reduction's parts held per state: link_sensitivities.held_linked_parts), each output's
            # columns in the outputs' order
            forms_of, held = {}, {}   # held: a probe's forms at a state, once (its end and its max or min at one row)
            moving = {}   # stored state index -> each probe's coefficient of δt at a row whose time moves
            timed_rows = {}   # output -> (stored state index, its coefficient of δt there): a controller's output in t
            timed_held = {}   # the same by (probe, stored state index), as ``held``
            self._linked_parts_held = {}
            for at in sorted(range(len(outputs)), key=lambda at: rows[outputs[at][2]]):
                probe, index = outputs[at][0], rows[outputs[at][2]]
                if (id(probe), index) in held:
                    forms_of[at] = held[id(probe), index]
                    if (id(probe), index) in timed_held:
                        timed_rows[at] = timed_held[id(probe), index]
                    continue
                if final is not None:   # the row's forms on the numbering it was recorded on
                    self._numbered(numberings[index])
                # at the start δq_0 = 0 but for geometry parameters: a row there moves through δv_0, δv̇_0 and explicitly
                with self._controllers_at(carried, index):
                    forms = [self.output_forms(probe, states[index])]
                    if index and trajectory[index - 1].get("timed_end") and adjoint_time.moves_in_time(self) and (
                            index not in moving):   # the rows' coefficients of δt, the states as accepted there
                        moving[index] = adjoint_time.row_coefficients(self, states[index])
                if _norm_at_zero(probe, forms[0]):   # |·| at 0 (:meth:`_at_a_zero_norm`)
                    forms = [self.output_forms(replace(probe, component=axis), states[index]) for axis in "xyz"]
                forms_of[at] = held[id(probe), index] = forms
                if final is not None and self.model.stuck.any():   # a joint friction holds: its angle's δθ
                    held["theta", id(probe), index] = self._held_forms(probe, states[index])
                if index in moving and moving[index][self.probes.index(probe)] != 0.0:
                    # the row's time moves with p (an output row at an event) and the probe depends on t there: a
                    # controller's output naming t seeds t̄ at the row with its coefficient of δt (the forward method's
                    # ∂f/∂t δt, controller_probe_sensitivities._continuous_output); any other probe is refused (no
                    # check has reached one: a prescribed motion, a joint force's law in t, a controller reading them)
                    if is_controller_probe(probe) and probe.state is None and names_t(
                            self.scene, self.scene.controllers[probe.controller]):
                        timed_rows[at] = timed_held[id(probe), index] = (
                            index, float(moving[index][self.probes.index(probe)]))
                    else:
                        raise SolverError(f"the adjoint sensitivities meet probe {probe.name!r} at t = "
                                          f"{states[index].t:.6g}, a row whose time moves with the parameters (an "
                                          "output row at an event beside laws in t) where the probe depends on t "
                                          "explicitly (a prescribed motion, a joint force's law or reaction in t); "
                                          "expected sensitivity_method: forward there, or output.every a multiple of "
                                          "solve.dt")
            self._linked_parts_held = None
            for at, (_, _, row) in enumerate(outputs):
                forms = forms_of[at]
                taken.append(list(range(columns, columns + len(forms))))
                columns += len(forms)
                for column, form in zip(taken[-1], forms):
                    seeds.setdefault(rows[row], []).append((column, form))
                c_theta = held.get(("theta", id(outputs[at][0]), rows[row]))
                if c_theta is not None:
                    held_seeds.setdefault(rows[row], []).append((taken[-1][0], c_theta))
                if at in timed_rows:   # its ∂f/∂t δt at the row: seeded on t̄ there
                    timings.setdefault(timed_rows[at][0], []).append((taken[-1][0], timed_rows[at][1]))
            for index, _ in events:   # an event time's column, seeded on δt there with 1
                timings.setdefault(index, []).append((columns, 1.0))
                columns += 1
            if final is not None:   # the reverse pass starts on the numbering the last accepted step ended on
                self._numbered(numberings[-1] if numberings[-1] is not None else final)
            gradient = self._reverse_columns(carried, states, seeds, columns, timings, held_seeds)
        finally:
            self._linked_parts_held = None
            if final is not None:
                self._numbered(final)
        return self._at_a_zero_norm(gradient[:, :columns - len(events)], taken), gradient[:, columns - len(events):]

    def event_records(self, carried: dict) -> list:
        """[(stored state index, {joint, kind, t})] of the run's events as the forward method records them in
        ``event_sensitivities`` (its ``dt`` filled by the reverse pass): a latch or stop of a hinge, a whole
        cable's change between slack and taut (an element of a cable that stays taut or slack: none)."""
        out = []
        for i, entry in enumerate(carried["trajectory"]):
            event, cable = entry.get("event"), entry.get("cable")
            if event is not None and event[1] != "rest":   # a projection onto a stop is no event of the run's
                out.append((i + 1, {"joint": self.model.hinges[event[0]].name, "kind": event[1],
                                    "t": float(entry["state"].t)}))
            elif cable is not None and cable[1] is not None:
                cables = self.model.cables
                out.append((i + 1, {"joint": cables.names[cables.cable[cable[0]]], "kind": cable[1],
                                    "t": float(entry["state"].t)}))
        return out

    @staticmethod
    def _at_a_zero_norm(gradient: np.ndarray, taken: list) -> np.ndarray:
        """(k, m): each output's column of ``gradient``; a norm probe whose value is 0 at its row (|·| is not
        differentiable there: its gradient's entries are NaN along the coordinates that move the point) by the
        forward method's rule on its components' derivatives D (k, 3): 0 where D's row is 0 (the parameter
        does not move the point), NaN where it is not (:meth:`ParameterDerivatives._probe_derivatives`)."""
        out = np.zeros((gradient.shape[0], len(taken)))
        for output, columns in enumerate(taken):
            if len(columns) == 1:
                out[:, output] = gradient[:, columns[0]]
            else:
                out[:, output] = np.where(np.any(gradient[:, columns] != 0.0, axis=1), np.nan, 0.0)
        return out

    def _reverse_columns(self, carried: dict, states: list, seeds: dict, m: int, timings: dict,
                         held_seeds: dict | None = None) -> np.ndarray:
        """(k, m): the transposed recurrence (module docstring) with the m columns that ``seeds`` seeds
        ({stored state index: [(column, (c_q, c_v, c_v̇, explicit))]}) at their states and ``timings`` ({index: [(column,
        seed)]}: an event time's 1) on δt there. At a step that ends on a latch or a stop the forward method's pieces
        come transposed in reverse order: the restart (:meth:`_restart_transposed`), the renumbering
        (:meth:`_renumbering_transposed`), the jump (:meth:`_impulse_transposed`), then the step with its size's
        derivative (:meth:`_step_size_transposed`); t̄ and ḡ carry the adjoints of δt_n and of the last δh."""
        model, p = self.model, self.params
        k = len(self.names)
        trajectory = carried["trajectory"]
        gradient = np.zeros((k, m))
        am, af, gamma, beta = p.alpha_m, p.alpha_f, p.gamma, p.beta
        n = model.n_dofs
        q_bar, v_bar, vdot_bar, a_bar = (np.zeros((n, m)) for _ in range(4))
        t_bar, g_bar = np.zeros(m), np.zeros(m)   # the adjoints of δt_{n+1} and of the carried δh
        theta_bar = np.zeros((len(model.hinges), m))   # the adjoints of the held angles' δθ (joints friction holds)
        held_seeds = held_seeds or {}
        states_t = self._states_transposed()   # the controllers' states: S̄, f̄ beside the bars
        S_bar, f_bar = (None, None) if states_t is None else (np.zeros((states_t.P, m)), np.zeros((states_t.P, m)))
        samples_t = self._samples_transposed()   # the sampled controllers: ȳ (the held δy's) and their states' S̄
        y_bar, sampled_bar = (None, None) if samples_t is None else samples_t.bars(m)
        outputs = self.scene.controller_outputs.values
        final_outputs = outputs.copy()
        if samples_t is not None:   # ∂r/∂p's held part is transposed apart (SamplesTransposed.held_transposed)
            self.controllers.sampled.held = np.zeros_like(self.controllers.sampled.held)
        from latdyn.analyses.adjoint_in_loop import reverse_steps

        native = reverse_steps(self, [entry["state"].t for entry in trajectory]) if n else None   # the smooth steps
        # in one native call each
        for i in range(len(trajectory) - 1, -1, -1):
            for column, (c_q, c_v, c_vdot, explicit, *c_S) in seeds.get(i + 1, []):
                q_bar[:, column] += c_q
                v_bar[:, column] += c_v
                vdot_bar[:, column] += c_vdot
                gradient[:, column] += explicit
                if c_S:   # a controller probe (latdyn/analyses/adjoint_controller_states.py)
                    self._seed_controllers(c_S, column, S_bar, y_bar, sampled_bar)
            for column, seed in timings.get(i + 1, []):
                t_bar[column] += seed
            for column, c_theta in held_seeds.get(i + 1, []):
                theta_bar[:, column] += c_theta
            entry = trajectory[i]
            if entry.get("sample") is not None:   # the sample after the step and its restart, transposed
                sample = entry["sample"]
                outputs[:] = sample["outputs"]
                bars = [q_bar, v_bar, vdot_bar, a_bar]
                with self._controllers_at(carried, i + 1):
                    y_bar, u_bar = samples_t.restart_transposed(sample["state"], bars, y_bar, gradient)
                    if states_t is not None:   # the continuous states held through the restart (ControllerStates.hold)
                        S_bar = S_bar + states_t.held_map(sample["state"]).T @ u_bar
                    # the angles friction holds: K's columns of them times δθ in the restart's ∂r/∂p
                    # (TransientSensitivities.after_sample), ū = −M⁻ᵀs̄ where a step's w stands: θ̄ += K_θᵀū
                    theta_bar = self._held_step_transposed(sample["state"], -u_bar, theta_bar)
                q_bar, v_bar, vdot_bar, a_bar = bars
                q_bar, v_bar = q_bar.copy(), v_bar.copy()
                y_bar, sampled_bar = samples_t.sample_transposed(sample["state"], sample["due"], sample["S"], q_bar,
                                                                 v_bar, y_bar, sampled_bar, gradient, theta_bar)
            if samples_t is not None:   # the held outputs the step was taken with
                outputs[:] = entry["outputs"]
            if entry.get("friction") is not None:   # a stick's or release's restart, renumbering (and jump)
                with self._controllers_at(carried, i + 1):   # the states as accepted at the event
                    q_bar, v_bar, vdot_bar, theta_bar, by_event, t_by_event, held_bars = \
                        self._friction_event_transposed(entry, q_bar, v_bar, vdot_bar + a_bar, theta_bar,
                                                        (carried, i, S_bar, y_bar))
                S_bar, y_bar = held_bars
                gradient += by_event
                t_bar = t_bar + t_by_event
                a_bar = np.zeros_like(v_bar)
            elif entry.get("rest") is not None:   # released from its stop at the step's end: a stop's restart
                with self._controllers_at(carried, i + 1):   # the states as accepted at the release
                    q_bar, v_bar, by_release, t_by_release, (S_bar, y_bar) = self._release_transposed(
                        entry, q_bar, v_bar, vdot_bar + a_bar, (carried, i, S_bar, y_bar))
                gradient += by_release
                t_bar = t_bar + t_by_release
                vdot_bar, a_bar = np.zeros_like(v_bar), np.zeros_like(v_bar)   # set afresh by the restart
            elif entry.get("after") is not None:   # the event's restart, renumbering and jump, transposed
                held = states_t is not None or samples_t is not None   # δS or δy held through the event's pieces
                with self._controllers_at(carried, i + 1):   # the states as accepted at the event (they do not jump)
                    if "controller_restarted" in entry:   # δf⁺ of the jumped rates (after a latch), transposed
                        self._numbered(entry["numbering_end"])
                        q_bar, v_bar, S_bar, f_bar, t_bar = states_t.restarted_transposed(
                            entry["after"], [q_bar, v_bar, S_bar, f_bar, t_bar], gradient,
                            adjoint_time.moves_in_time(self))
                    self._weights_met = [] if held else None
                    q_bar, v_bar, vdot_by_restart, by_restart, t_by_restart = self._restart_transposed(
                        entry, q_bar, v_bar, vdot_bar + a_bar)
                    gradient += by_restart
                    if states_t is not None:   # δS held through the restart (ControllerStates.hold): B δS in its ∂r/∂p
                        S_bar = self._held_weights_transposed(carried, i, S_bar, 1.0, states_t, restart=True)
                    if samples_t is not None:   # the held δy likewise (SampledTerms.add): A_y δy
                        y_bar = self._held_weights_transposed(carried, i, y_bar, 1.0, samples_t, restart=True)
                    q_bar, v_bar = self._renumbering_transposed(entry, q_bar, v_bar)
                    self._weights_met = [] if held else None
                    v_bar, q_by_jump, vdot_by_jump, by_jump, t_by_jump = self._impulse_transposed(entry, v_bar)
                    if entry["event"][1] == "rest":   # put back on its stop: δq⁺ the projection's (_projected)
                        q_bar, v_by, vdot_by, by_projection, t_by_projection = self._projected_transposed(entry,
                                                                                                        q_bar)
                        v_bar, vdot_by_jump = v_bar + v_by, vdot_by_jump + vdot_by
                        by_jump, t_by_jump = by_jump + by_projection, t_by_jump + t_by_projection
                    if states_t is not None:   # and through the jump: ∂(B δS)/∂q along the impulse's Δv in its weight
                        S_bar = self._held_weights_transposed(carried, i, S_bar, -1.0, states_t)
                    if samples_t is not None:
                        y_bar = self._held_weights_transposed(carried, i, y_bar, -1.0, samples_t)
                    self._weights_met = None
                q_bar = q_bar + q_by_jump
                gradient += by_jump
                t_bar = t_bar + t_by_restart + t_by_jump   # the restart and the jump at t_e + δt_e
                # the restart set δv̇, δa afresh: the step's own δv̇ reaches past it only through the weights' rates
                # (guides, rigid links: :meth:`_weight_derivative_transposed`), δa not at all
                if vdot_by_restart is not None and vdot_by_restart.shape != vdot_by_jump.shape:
                    # come to rest: the restart on the locked numbering, whose weight without guides or rigid links
                    # (the forward method refuses a rest with them) does not move with the rates
                    vdot_by_restart = None
                vdot_bar = vdot_by_jump if vdot_by_restart is None else vdot_by_jump + vdot_by_restart
                a_bar = np.zeros_like(v_bar)
            elif "numbering" in entry:
                self._numbered(entry["numbering"])
            h, new = entry["h"], entry["state"]
            old = states[i]
            if not model.n_dofs:   # nothing free: δh = −δt_n onto the grid (rule "lands"), else 0; no step system
                if entry.get("rule") is not None:
                    t_bar = t_bar - (t_bar + g_bar)
                g_bar = np.zeros(m)
                continue
            beta_p, gamma_p = (1 - am) / (h * h * beta * (1 - af)), gamma / (h * beta)
            increment = h * (free_velocity(model, old) + h * (0.5 - beta) * entry["a_old"]
                             + h * beta * entry["a_new"])
            turn, tangent = self._rotation_operators(increment)
            turn_t, tangent_t = _transposed_rotations(self, turn), _transposed_rotations(self, tangent)
            rule = entry.get("rule")
            if states_t is None and rule is None and native is not None:   # csrc/adjoint_reverse.c: the step below
                bars = [q_bar, v_bar, vdot_bar, a_bar]                     # in one call, w returned for ∂r/∂p's
                w = native.step(new, h, (tangent, tangent_t, turn_t), bars, i)  # contraction
                if w is not None:
                    g_bar = np.zeros(m)
                    product = native.residual_transposed_product(w)   # linked: ∂r/∂p left by the native step
                    gradient -= product if product is not None else self.residual_transposed_product(new, w)
                    if entry.get("timed") and adjoint_time.moves_in_time(self):   # ∂r/∂t δt_n, transposed
                        t_bar = t_bar + adjoint_time.step_transposed(self, new, w)
                    q_bar, v_bar, vdot_bar, a_bar = bars
                    theta_bar = self._held_step_transposed(new, w, theta_bar)
                    continue
            theta_bar = theta_bar.copy()   # the states' sensors add their held angles' part in place
            bars = [q_bar, v_bar, vdot_bar, a_bar, S_bar, f_bar, t_bar, g_bar]
            w = self._step_transposed(carried, i, (new, h, turn, turn_t, tangent, tangent_t, beta_p, gamma_p, old),
                                      bars, gradient, theta_bar)
            q_bar, v_bar, vdot_bar, a_bar, S_bar, f_bar, t_bar, g_bar = bars
            if samples_t is not None:   # the held δy's part of the step's ∂r/∂p
                y_bar = samples_t.held_transposed(new, w, y_bar)
            with self._controllers_at(carried, i + 1):   # K's columns of the held angles as the step's ∂r/∂p took them
                theta_bar = self._held_step_transposed(new, w, theta_bar)
        if carried.get("numbering_start") is not None and (self._with_events() or self._may_stick()):
            self._numbered(carried["numbering_start"])
        for column, (c_q, c_v, c_vdot, explicit, *c_S) in seeds.get(0, []):   # δS_0 = 0: a state's seed adds nothing
            q_bar[:, column] += c_q   # δq_0 = δX of geometry parameters (0 without)
            if len(c_S) > 1:   # a sampled controller's probe: δy_0, δS_1 of the sample at t = 0 (start_transposed)
                self._seed_controllers([np.zeros(0)] + c_S[1:], column, None, y_bar, sampled_bar)
            v_bar[:, column] += c_v
            vdot_bar[:, column] += c_vdot   # δv̇_0 = δa_0: the start's consistent accelerations' derivative
            gradient[:, column] += explicit
        if model.n_dofs == 0:
            return gradient
        # the start's δq_0, δv_0 through the controllers' sensors (the sample at t = 0, the states' δf_0)
        moves = self.start_moves() if states_t is not None or samples_t is not None else None
        with self._controllers_at(carried, 0):
            if states_t is not None:   # δf_0 = ∂f/∂s δs_0 + ∂f/∂p
                states_t.start_transposed(carried["start"], f_bar, gradient, moves)
            if samples_t is None:
                return gradient + self._through_the_start(carried["start"], v_bar, vdot_bar + a_bar, q_bar)
            outputs[:] = carried["outputs_start"]
            samples_t.start_transposed(carried["start"], y_bar, sampled_bar, gradient, moves)
            sampled = self.controllers.sampled
            # the held δy_0 = ∂f/∂s δs_0 + ∂f/∂p in the start's ∂r/∂p, as the forward method's
            sampled.start(carried["start"], k, *(moves or ()))
            try:
                return gradient + self._through_the_start(carried["start"], v_bar, vdot_bar + a_bar, q_bar)
            finally:
                sampled.held = np.zeros_like(sampled.held)
                outputs[:] = final_outputs

    @staticmethod
    def _seed_controllers(c_S: list, column: int, S_bar, y_bar, sampled_bar) -> None:
        """A controller probe's seed (latdyn/analyses/adjoint_controller_states.py ``probe_forms``'s parts after the
        first four) into the ``column`` of the continuous states' S̄, the held outputs' ȳ and the sampled states' S̄."""
        if S_bar is not None and len(c_S[0]):
            S_bar[:, column] += c_S[0]
        if len(c_S) > 1:
            y_bar[:, column] += c_S[1]
            sampled_bar[:, column] += c_S[2]

    def _controllers_at(self, carried: dict, index: int):
        """A context in which the scene's arrays hold the controllers' accepted (S, f) of the stored state
        ``index`` (0: the start), or a null context without controller states."""
        states_t = self._states_transposed()
        if states_t is None:
            return nullcontext()
        return states_t.at(carried["controller_start"] if index == 0 else
                           carried["trajectory"][index - 1]["controller"])

    def _step_transposed(self, carried: dict, i: int, step: tuple, bars: list, gradient: np.ndarray,
                         theta_bar: np.ndarray | None = None) -> np.ndarray:
        """Step ``i`` of the reverse pass from Python (module docstring: z̄, w, the bars' update; where its size moves
        with p the step size's column and δh's functional transposed, :meth:`_step_size_column`,
        :meth:`_step_size_transposed`): ``bars`` [q̄, v̄, v̇̄, ā, S̄, f̄, t̄, ḡ] at its end replaced by those at its
        start, ``gradient`` (k, m) and ``theta_bar`` (the held angles' adjoints: the states' sensors read a held angle,
        ``StatesTransposed.after_step_transposed``) updated in place;
        returns the step's w (a sampled controller's held part,
        :meth:`SamplesTransposed.held_transposed`). With continuous controllers' states (S̄, f̄ not None) the hooks of
        latdyn/analyses/adjoint_controller_states.py around it, in the forward method's reverse order: ``after_step``
        transposed first (h̄ gains by_hᵀS̄_{n+1}), the step's matrix condensed from (S_n, f_n), the states' B by_h in
        the step size's column, then the held part's ∂r/∂p and ``begin_step`` transposed."""
        p, model = self.params, self.model
        am, af, gamma, beta = p.alpha_m, p.alpha_f, p.gamma, p.beta
        new, h, turn, turn_t, tangent, tangent_t, beta_p, gamma_p, old = step
        states_t = self._states_transposed()
        q_bar, v_bar, vdot_bar, a_bar, S_bar, f_bar, t_bar, g_bar = bars
        entry = carried["trajectory"][i]
        with self._controllers_at(carried, i + 1):
            if states_t is None:
                condensed, by_size, h_by_states = nullcontext(), None, None
            else:
                before = self._states_before(carried, i)
                terms = states_t.step_terms(new, h, before)
                q_bar, v_bar = q_bar.copy(), v_bar.copy()
                timed = entry.get("timed_end") and adjoint_time.moves_in_time(self)   # δs's ∂s/∂t δt_{n+1} onto t̄
                t_bar = t_bar.copy()
                held_bar, h_by_states = states_t.after_step_transposed(new, h, terms, S_bar, f_bar, q_bar, v_bar,
                                                                       gradient, t_bar if timed else None, theta_bar)
                condensed = states_t.condensed(before, h)
            with condensed:
                C_t, K_t, solve_transposed, solve = self._transposed_step_system(new, tangent, beta_p, gamma_p)
                # ∂r/∂t through the prescribed motions with the states condensed as in the step (the forward method's
                # step_columns), its laws' part outside
                explicit = self.explicit_time
                moved = (explicit.through_prescribed(new) if states_t is not None and explicit is not None
                         and explicit.prescribed else None)
            rate = adjoint_time.rate_at(self, new, moved) if adjoint_time.moves_in_time(self) else None
            rule = entry.get("rule")
            if rule is not None:   # the step's size moves with p: its column (the states' ∂r/∂h in it), δh transposed
                if states_t is not None:
                    by_size = states_t.held_map(new) @ states_t.by_step_size(terms)
                column = self._step_size_column(entry, old, C_t.T, K_t.T, solve, (turn, tangent), beta_p, gamma_p,
                                                by_size, rate)
                h_bar = sum(np.einsum("i,im->m", column[key], bar) for key, bar in
                            (("dq", q_bar), ("dv", v_bar), ("dvdot", vdot_bar), ("da", a_bar)))
                h_bar = h_bar + t_bar + g_bar
                if h_by_states is not None:
                    h_bar = h_bar + h_by_states
                q_bar, v_bar, t_bar, g_bar, by_size = self._step_size_transposed(entry, rule, column, h_bar,
                                                                                 q_bar, v_bar, t_bar)
                gradient += by_size
            else:
                g_bar = np.zeros_like(g_bar)
            z_bar = tangent_t(q_bar) + gamma_p * v_bar + beta_p * vdot_bar + (1 - af) / (1 - am) * beta_p * a_bar
            w = np.asarray(solve_transposed(z_bar)).reshape(model.n_dofs, q_bar.shape[1])
            gradient -= self.residual_transposed_product(new, w)
            if entry.get("timed") and rate is not None:   # ∂r/∂t δt_n, transposed
                t_bar = t_bar + adjoint_time.step_transposed(self, new, w, rate)
            if states_t is not None:
                held_bar = states_t.held_transposed(new, w, held_bar)
                S_bar, f_bar = states_t.begin_step_transposed(h, terms, held_bar, gradient)
        dq0_bar = q_bar - K_t @ w
        dv0_bar = v_bar - C_t @ w
        du0_bar = tangent_t(dq0_bar)
        da0_bar = a_bar + h * gamma * dv0_bar + h * h * beta * du0_bar
        bars[:] = [turn_t(dq0_bar), dv0_bar + h * du0_bar,
                   af / (1 - am) * da0_bar,
                   h * (1 - gamma) * dv0_bar + h * h * (0.5 - beta) * du0_bar - am / (1 - am) * da0_bar, S_bar, f_bar,
                   t_bar, g_bar]
        return w

    @staticmethod
    def _states_before(carried: dict, i: int) -> tuple:
        """(S_n, f_n) the forward method's step ``i`` starts from (``ControllerStates.begin_step``, ``condensed``): the
        accepted (S, f) of the step before, or after its event's restart where the states' rates were taken anew there
        (``ControllerStates.restarted``: a controller reading a rate; :meth:`after_events`)."""
        if i == 0:
            return carried["controller_start"]
        entry = carried["trajectory"][i - 1]
        return entry.get("controller_restarted", entry["controller"])

    def _held_weights_transposed(self, carried: dict, i: int, S_bar: np.ndarray, sign: float, held,
                                 restart: bool = False) -> np.ndarray:
        """``S_bar`` with what ``held`` holds through step ``i``'s event transposed: the continuous states' δS_{n+1}
        (``held`` the StatesTransposed; ControllerStates.hold) or the sampled controllers' δy (the SamplesTransposed),
        B δS in the restart's ∂r/∂p, and ∂(B δS)/∂q w in each impulse or restart weight's (∂K/∂p) w that
        :meth:`_weight_derivative_transposed` met, ``self._weights_met``; ``sign`` +1 for the restart's (ū = −B⁻ᵀs̄),
        −1 for the impulse's (w = δv⁻ − W⁻¹(…))."""
        with self._controllers_at(carried, i + 1):
            if restart:
                after, u_bar = self._restart_u
                S_bar = S_bar + held.held_map(after).T @ u_bar
            for state, w, u_bar, scale in self._weights_met:
                S_bar = S_bar + sign * scale * (held.held_stiffness_along(state, w).T @ u_bar)
        return S_bar

    # ------------------------------------------------------------------ sticking by friction transposed
    def _friction_event_transposed(self, entry: dict, q_bar: np.ndarray, v_bar: np.ndarray, s_bar: np.ndarray,
                                   theta_bar: np.ndarray, held: tuple) -> tuple:
        """The transpose of the forward method's stick or release at the end of the step ``entry`` holds
        (:meth:`TransientSensitivities._stick_candidates`, :meth:`TransientSensitivities._stick_or_release`, its
        :meth:`_restart`), its pieces in reverse order, for the bars (q̄, v̄, s̄ = v̇̄ + ā) after it and θ̄ (n_hinges, m),
        the held angles' adjoints:

        - the restart as after a stop (:meth:`_restart_transposed`), with the held angles' terms of its ∂r/∂p (K's
          columns of them at the state after it, :meth:`_held_columns`) and of its weight's (∂K/∂p)v̇ (their
          move along v̇, generated: :meth:`_held_stiffness_columns`): θ̄ += (K_θ + dt² ∂K_θ/∂q[v̇])ᵀ ū;
        - the renumbering (:meth:`_renumbering_transposed`); a release's δq[θ_j] = δθ_j gives θ̄_j = q̄[θ_j] (the
          held δθ_j is 0 after it); a stick's δθ_j = δq[θ_j] before it gives q̄[θ_j] += θ̄_j, θ̄_j = 0;
        - a stick's jump, a stop's impulse with restitution 0 (:meth:`_impulse_transposed`), with the held angles'
          terms of its weight (the other joints friction holds): θ̄ −= (dt² ∂K_θ/∂q[Δv] + ∂(M a)_θ/∂a[Δv])ᵀ ū.

        The restart sets δv̇ and δa afresh (the stick's ``dvdot`` 0): nothing of v̇̄ or ā passes. Beside laws in t the
        restart and the jump are at t_e + δt_e, as the forward method takes them (its ``time_shift`` there: δt_e
        non-zero after an event until a step lands on the grid), their ∂/∂t onto t̄ (latdyn/analyses/adjoint_time.py).
        Beside controllers with states or sampled ones (``held`` = (carried, the step's index, S̄, ȳ), S̄ or ȳ None
        without them) what the forward method holds through it, transposed (:meth:`_held_weights_transposed`): the
        restart's ∂r/∂p holds the continuous states' B δS (:meth:`TransientSensitivities.after_events`:
        ``ControllerStates.hold``) and the sampled outputs' A_y δy (``SampledTerms.held``, set for the step), and
        its weight's (∂K/∂p)v̇ their moves along v̇; a stick's jump (:meth:`TransientSensitivities._stick_candidates`,
        after ``ControllerStates.after_step`` released δS) the sampled outputs' alone.
        Returns (q̄, v̄, v̇̄, θ̄ before it, (k, m) into the gradient, (m,) into t̄, (S̄, ȳ) before it); the model left on
        the numbering before it."""
        kind, j = entry["friction"]
        model, scale = self.model, self.scene.solve.dt * self.scene.solve.dt
        carried, i, S_bar, y_bar = held
        states_t, samples_t = self._states_transposed(), self._samples_transposed()
        theta_bar = theta_bar.copy()
        self._restart_weight = None
        self._weights_met = [] if states_t is not None or samples_t is not None else None
        q_bar, v_bar, _, gradient, t_bar = self._restart_transposed(entry, q_bar, v_bar, s_bar)
        S_bar, y_bar = self._held_through_restart(held)
        stuck = np.flatnonzero(model.stuck)   # on the numbering after it: the angles held through the restart
        if len(stuck) and model.n_dofs:
            after, u_bar = self._restart_u
            theta_bar[stuck] += self._held_columns(after, stuck, True).T @ u_bar
            before, _ = self._restart_weight
            rates = free_acceleration(model, after)
            if np.any(rates):
                theta_bar[stuck] += scale * (self._held_stiffness_columns(before, rates, stuck).T @ u_bar)
        self._numbered(entry["numbering_end"])
        if kind == "release":   # its angle back among the free coordinates, δq[θ_j] = δθ_j
            theta_bar[j] = q_bar[model.hinge_dofs[j]]
        q_bar, v_bar = self._renumbering_transposed(entry, q_bar, v_bar)
        if kind == "release":
            return q_bar, v_bar, np.zeros_like(v_bar), theta_bar, gradient, t_bar, (S_bar, y_bar)
        q_bar[model.hinge_dofs[j]] += theta_bar[j]   # the held δθ_j: δq[θ_j] at the stick
        theta_bar[j] = 0.0
        self._weights_met = [] if samples_t is not None else None
        v_bar, q_by_jump, vdot_by_jump, by_jump, t_by_jump = self._impulse_transposed(
            {**entry, "event": (j, "stick", 0.0)}, v_bar)
        if samples_t is not None:   # the held δy through the jump: ∂(A_y δy)/∂q along its Δv in its weight
            y_bar = self._held_weights_transposed(carried, i, y_bar, -1.0, samples_t)
        self._weights_met = None
        stuck = np.flatnonzero(model.stuck)   # the other joints friction holds through the jump
        if len(stuck):
            change, u_bar = self._impulse_weight
            new = entry["state"]
            at_rest, accelerated = self._at_rest_and_accelerated(new, change)
            weight = (scale * self._held_stiffness_columns(new, change, stuck)
                      + self._held_columns(accelerated, stuck, True) - self._held_columns(at_rest, stuck, True))
            theta_bar[stuck] -= weight.T @ u_bar
        return (q_bar + q_by_jump, v_bar, vdot_by_jump, theta_bar, gradient + by_jump, t_bar + t_by_jump,
                (S_bar, y_bar))

    def _held_through_restart(self, held: tuple) -> tuple:
        """(S̄, ȳ) of ``held`` = (carried, the step's index, S̄, ȳ) before the stop's restart just transposed
        (:meth:`_restart_transposed`, which met its weight's moves in ``self._weights_met``): the continuous states'
        B δS in its ∂r/∂p and ∂(B δS)/∂q v̇ in its weight's (``ControllerStates.hold``), the sampled outputs' A_y δy
        likewise (``SampledTerms.held``), transposed (:meth:`_held_weights_transposed`); S̄ or ȳ None without them."""
        carried, i, S_bar, y_bar = held
        states_t, samples_t = self._states_transposed(), self._samples_transposed()
        if states_t is not None:
            S_bar = self._held_weights_transposed(carried, i, S_bar, 1.0, states_t, restart=True)
        if samples_t is not None:
            y_bar = self._held_weights_transposed(carried, i, y_bar, 1.0, samples_t, restart=True)
        self._weights_met = None
        return S_bar, y_bar

    def _held_columns(self, state, stuck: np.ndarray, inertia: bool, element_gravity: bool = True) -> np.ndarray:
        """(n, s): the forward method's held forces (:meth:`TransientSensitivities._held_forces`: K's column of each
        held angle, with ``inertia`` the inertia tangent's too, without ``element_gravity`` W's K, at ``state``) of a
        unit δθ of each joint of ``stuck``, on the free coordinates: ∂r/∂p's held part is these times δθ."""
        saved, self.held = self.held, self._unit_held(stuck)
        try:
            return self._on_free_coordinates(state, self._held_forces(state, inertia, element_gravity))
        finally:
            self.held = saved

    def _unit_held(self, stuck: np.ndarray) -> np.ndarray:
        """(n_hinges, s): a unit δθ of each joint of ``stuck``, as the forward method's :attr:`held`."""
        unit = np.zeros((len(self.model.hinges), len(stuck)))
        unit[stuck, np.arange(len(stuck))] = 1.0
        return unit

    def _held_stiffness_columns(self, state, w: np.ndarray, stuck: np.ndarray) -> np.ndarray:
        """(n, s): the held angles' part of the forward method's (∂K/∂p) w (:meth:`_terms_beside_stiffness_along`) for
        a unit δθ of each joint of ``stuck``: the generated ``held_angles_along`` (``beam_stiffness_D_q`` at the held
        slot times w), which forms every one the reverse pass meets — the held angles it leaves out, on a model with
        rigid links or guides and reached by a controller's coupling, are refused at the stick
        (:meth:`_refuse_a_stick`). Before linkedheld a difference of W's K's held columns along w stood behind it,
        which no run reached."""
        saved, self.held = self.held, self._unit_held(stuck)
        try:
            return self._on_free_coordinates(state, held_angles_along(self, state, w))
        finally:
            self.held = saved

    def _held_step_transposed(self, new, w: np.ndarray, theta_bar: np.ndarray) -> np.ndarray:
        """θ̄ before a step taken while joints were held by friction: the step's ∂r/∂p holds K's columns of their
        angles times δθ (:meth:`_held_columns` at its end, with the inertia tangent), so θ̄ −= (K_θ)ᵀ w."""
        stuck = np.flatnonzero(self.model.stuck)
        if not len(stuck):
            return theta_bar
        theta_bar = theta_bar.copy()
        theta_bar[stuck] -= self._held_columns(new, stuck, True).T @ w
        return theta_bar

    def _held_forms(self, probe, state) -> np.ndarray:
        """c_θ (n_hinges,): ``probe``'s derivative by each held angle's δθ at ``state`` (the forward method's
        :meth:`record`: δθ += held), zero elsewhere. A joint's force: the forward method's is its forms along (δq, δv,
        δv̇) plus ∂r_d/∂p on all coordinates, which holds the held forces (:meth:`_held_forces`, with the inertia
        tangent) — a held joint's reaction on row d moves by K[d, θ_j] δθ_j (:meth:`_held_forces` on all
        coordinates); a free joint's law by a controller's coupling to the held angle where one drives it from there
        (:func:`latdyn.analyses.joint_force_sensitivities.held_sensor_forms`). Any other probe:
        :meth:`_probe_derivatives` on unit δθ columns of the joints friction holds (a section force through the
        element's angle slot, a point in a body's frame, a cable reads none), its explicit ∂y/∂p left out."""
        model = self.model
        stuck = np.flatnonzero(model.stuck)
        out = np.zeros(len(model.hinges))
        if is_joint_force(probe):
            j = joint_of(model, probe)
            d = model.hinge_dofs[j]
            if d >= model.n_dofs:   # its reaction: row d of the held forces on all coordinates
                saved, self.held = self.held, self._unit_held(stuck)
                try:
                    out[stuck] = self._held_forces(state, True)[d]
                finally:
                    self.held = saved
            else:   # its law: a controller's sensor of a held angle (0 without one)
                out[stuck] = held_sensor_forms(self, state, [j], stuck).get(j, 0.0)
            return out
        zero = np.zeros((model.n_dofs, len(stuck)))
        dx, dpi, dtheta = self._by_parameter(zero, state)
        dtheta[stuck, np.arange(len(stuck))] += 1.0
        rates = (self._rates_by_parameter(zero, zero, state) if probe.quantity in ("rate", "velocity", "tension")
                 else None)
        if is_probe_here(probe):   # section forces, cables, points in a body's frame: along the unit columns alone
            out[stuck] = probe_derivatives(self, probe, state, dx, dpi, dtheta, rates, explicit=False)
        else:
            out[stuck] = self._probe_derivatives(probe, state, dx, dpi, dtheta, rates, explicit=False)
        return out

    # ------------------------------------------------------------------ events transposed
    def _step_size_column(self, entry: dict, old, C, K, solve, rotations: tuple, beta_p: float,
                          gamma_p: float, explicit: np.ndarray | None = None, rate: np.ndarray | None = None) -> dict:
        """{dq, dv, dvdot, da} (n,): the forward method's column of a unit change of the step size h
        (:meth:`TransientSensitivities.step_columns`, its column k), computed as it computes it: the native
        predict and update (:class:`_StepColumns` with no parameter column: ∂(hΔq)/∂h, ∂v_{n+1}/∂h) around the
        solve with the step's exact matrix (``solve``; ``C``, ``K`` its damping and stiffness; ``rotations``: the
        step's (R, J)); beside laws in t its explicit part ∂r/∂t at the step's end, as the forward method's
        ``_add_time_columns`` puts it in the column of h (latdyn/analyses/adjoint_time.py; ``rate`` where the caller
        evaluated it, the prescribed motions' part with the controllers' states condensed as in the step)."""
        p, model, n = self.params, self.model, self.model.n_dofs
        step = _StepColumns(self, n, 0, (entry["h"], p.alpha_m, p.alpha_f, p.gamma, p.beta), *rotations)
        none = np.zeros((n, 0))
        _, dq0, dv0 = step.predict(free_velocity(model, old), entry["a_old"], entry["a_new"], none, none, none, none)
        rhs = K @ dq0 + C @ dv0 if explicit is None else explicit.reshape(n, 1) + K @ dq0 + C @ dv0
        if adjoint_time.moves_in_time(self):
            rhs = rhs + (adjoint_time.rate_at(self, entry["state"]) if rate is None else rate)[:, None]
        z = np.asarray(solve(-rhs)).reshape(n, 1)
        return {key: column[:, 0] for key, column in step.update(z, beta_p, gamma_p).items()}

    def _step_size_transposed(self, entry: dict, rule: tuple, column: dict, h_bar: np.ndarray,
                              q_bar: np.ndarray, v_bar: np.ndarray, t_bar: np.ndarray) -> tuple:
        """The transpose of the step size's derivative δh (the forward method's :meth:`_step_size_derivative`,
        :meth:`CableSensitivities.step_size_derivative`) for the adjoint ``h_bar`` (m,) of δh: (q̄, v̄ of the
        step's parameter columns, t̄ of δt_n, ḡ of the last step's δh, (k, m) into the gradient).
        ("event",): δh = −δq_p[θ]/δq_h[θ] → q̄[θ] −= h̄/δq_h[θ]; ("cable",): δh = −(g_qᵀδq_p + g_vᵀδv_p + g_p
        + g_t δt_n)/(g_qᵀδq_h + g_vᵀδv_h + g_t) → q̄ −= g_q h̄ᵀ/d, v̄ −= g_v h̄ᵀ/d, −g_p h̄ᵀ/d, t̄ −= g_t h̄/d;
        ("lands",): δh = −δt_n → t̄ −= h̄; ("sized", a, b): δh = a δh_prev + b δt_n → ḡ = a h̄, t̄ += b h̄.
        δt_{n+1} = δt_n + δh: t̄ passes on unchanged besides."""
        k = len(self.names)
        by_size = np.zeros((k, len(h_bar)))
        g_bar = np.zeros_like(h_bar)
        if rule[0] in ("event", "onset"):   # a latch's or stop's angle, or a compliant stop's onset's, held
            dof = self.model.hinge_dofs[(entry["event"] if rule[0] == "event" else entry["onset"])[0]]
            q_bar = q_bar.copy()
            q_bar[dof] -= h_bar / column["dq"][dof]
        elif rule[0] == "cable":
            g_q, g_v, g_p, g_t = self.cables.gap_forms(entry["state"], entry["cable"][0], k)
            d = float(g_q @ column["dq"] + g_v @ column["dv"]) + g_t
            self.cables.refuse_grazing(entry["state"], entry["cable"][0], d)
            q_bar, v_bar = q_bar - np.outer(g_q, h_bar) / d, v_bar - np.outer(g_v, h_bar) / d
            by_size -= np.outer(g_p, h_bar) / d
            t_bar = t_bar - g_t * h_bar / d
        elif rule[0] == "lands":
            t_bar = t_bar - h_bar
        else:
            g_bar = rule[1] * h_bar
            t_bar = t_bar + rule[2] * h_bar
        return q_bar, v_bar, t_bar, g_bar, by_size

    def _impulse_transposed(self, entry: dict, v_bar_plus: np.ndarray) -> tuple:
        """The transpose of the forward method's :meth:`_impulse` at the stored state before the jump: with
        W = M + dt²K, X = W⁻¹N, G = X(NᵀX)⁻¹, Δv = G(−(1 + e)Nᵀv⁻) and (forward) w = δv⁻ − W⁻¹(D δq + P),
        δv⁺ = (I − GNᵀ)w − e GNᵀδv⁻ (D δq + P = δ(W)Δv, :meth:`_weight_derivative`), for the adjoint v̄⁺ (n, m):

            w̄ = (I − NGᵀ)v̄⁺,   v̄⁻ = w̄ − e NGᵀv̄⁺,   ū = W⁻ᵀw̄,   q̄ −= Dᵀū,   dy/dp −= Pᵀū

        (:meth:`_weight_derivative_transposed`; with guides or rigid links D moves with δv⁻ and δv̇⁻ too, the forward
        method's ``rates``: v̄⁻ −= D_vᵀū, v̇̄⁻ −= D_v̇ᵀū). Returns (v̄⁻, the part of q̄, the part of v̇̄⁻, (k, m) into the
        gradient, (m,) into t̄: the weight's part moving with the event's time, latdyn/analyses/adjoint_time.py)."""
        model, dt = self.model, self.scene.solve.dt
        new, (hinge, _, restitution) = entry["state"], entry["event"]
        scale = dt * dt
        N = hinge_directions(model, [hinge])
        W = self.assembler.evaluate(new, matrices=True).combined(1.0, 0.0, scale)
        X = np.asarray(solve_linear(W, N)).reshape(N.shape)
        G = X @ np.linalg.inv(N.T @ X)
        change = G @ (-(1.0 + restitution) * (N.T @ free_velocity(model, new)))
        pushed = G.T @ v_bar_plus
        w_bar = v_bar_plus - N @ pushed
        v_bar_minus = w_bar - restitution * (N @ pushed)
        u_bar = np.asarray(solve_linear(_transposed(W), w_bar)).reshape(w_bar.shape)
        self._impulse_weight = (change, u_bar)   # the held angles' part of its weight (a stick: friction events)
        q_part, v_part, vdot_part, p_part = self._weight_derivative_transposed(new, change, u_bar, scale)
        t_part = (adjoint_time.weight_transposed(self, new, change, u_bar, scale, mass=True)
                  if adjoint_time.moves_in_time(self) else np.zeros(u_bar.shape[1]))
        return v_bar_minus - v_part, -q_part, -vdot_part, -p_part, -t_part

    def _projected_transposed(self, entry: dict, q_bar_plus: np.ndarray) -> tuple:
        """The transpose of the forward method's :meth:`_projected` at the stored state before the events (a hinge
        put back on its rigid stop at the step's end): with W = M + dt²K, X = W⁻¹N, G = X(NᵀX)⁻¹, Xμ = G(θ − stop)
        and (forward) δΔ = (I − GNᵀ)W⁻¹ δ(W)(Xμ) − GNᵀδq, δq⁺ = R δq + J δΔ (R, J the rotation operators at
        Δ = −Xμ), δ(W)(Xμ) = D δq + D_v δv + D_v̇ δv̇ + P (:meth:`_weight_derivative`), for the adjoint q̄⁺ (n, m):

            Δ̄ = Jᵀq̄⁺,   ū = W⁻ᵀ(I − NGᵀ)Δ̄,   q̄ = Rᵀq̄⁺ − NGᵀΔ̄ + Dᵀū,   v̄ += D_vᵀū,   v̇̄ += D_v̇ᵀū,   dy/dp += Pᵀū

        (:meth:`_weight_derivative_transposed`). Returns (q̄ before it, the part of v̄, the part of v̇̄, (k, m) into
        the gradient, (m,) into t̄: the weight at t_e + δt_e, latdyn/analyses/adjoint_time.py)."""
        new, hinge = entry["state"], entry["event"][0]
        scale = self.scene.solve.dt * self.scene.solve.dt
        W, N, X, NtX, moved = self._projection(new, hinge)
        turn, tangent = self._rotation_operators(-moved)
        delta_bar = _transposed_rotations(self, tangent)(q_bar_plus)
        pushed = N @ np.linalg.solve(NtX.T, X.T @ delta_bar)   # N Gᵀ Δ̄
        q_bar = _transposed_rotations(self, turn)(q_bar_plus) - pushed
        u_bar = np.asarray(solve_linear(_transposed(W), delta_bar - pushed)).reshape(delta_bar.shape)
        q_part, v_part, vdot_part, p_part = self._weight_derivative_transposed(new, moved, u_bar, scale)
        t_part = (adjoint_time.weight_transposed(self, new, moved, u_bar, scale, mass=True)
                  if adjoint_time.moves_in_time(self) else np.zeros(u_bar.shape[1]))
        return q_bar + q_part, v_part, vdot_part, p_part, t_part

    def _release_transposed(self, entry: dict, q_bar: np.ndarray, v_bar: np.ndarray, s_bar: np.ndarray,
                            held: tuple) -> tuple:
        """The transpose of the forward method's release of a hinge from its rigid stop at the end of the step
        ``entry`` holds (:meth:`TransientSensitivities._settle_or_release`, :meth:`_release_candidates`): a stop's
        restart at the step's end (:meth:`_restart_transposed`, δt of the release 0: the step's end) on the free
        numbering, then the renumbering (:meth:`_renumbering_transposed`: the released angle's δθ and rate were 0,
        its bars go nowhere). The restart sets δv̇, δa afresh (the release's ``dvdot`` 0): nothing of s̄ = v̇̄ + ā
        passes. Beside controllers with states or sampled ones (``held`` = (carried, the step's index, S̄, ȳ)) their
        held δS and δy in the restart (:meth:`_held_through_restart`; the forward method's second restart at the
        release, without rigid links the first again, is this one). Returns (q̄, v̄ before it, (k, m) into the
        gradient, (m,) into t̄, (S̄, ȳ) before it); the model left on the numbering before it."""
        self._weights_met = [] if self._states_transposed() is not None or self._samples_transposed() is not None \
            else None
        q_bar, v_bar, _, gradient, t_part = self._restart_transposed(entry, q_bar, v_bar, s_bar)
        held = self._held_through_restart(held)
        q_bar, v_bar = self._renumbering_transposed(entry, q_bar, v_bar)
        return q_bar, v_bar, gradient, t_part, held

    def _restart_transposed(self, entry: dict, q_bar: np.ndarray, v_bar: np.ndarray, s_bar: np.ndarray) -> tuple:
        """The transpose of the forward method's :meth:`_restart` at the stored state after the event (on its
        numbering): forward δv̇ = δa = −B⁻¹(E + K δq + C δv [+ D₂δq + P₂]), B = M after a latch, after a stop
        W = M + dt²K at the accelerations before it, with D₂δq + P₂ = dt² δ(K)v̇ (:meth:`_weight_derivative`,
        ``mass=False``); for the adjoint s̄ = v̇̄ + ā: ū = −B⁻ᵀs̄, q̄ += Kᵀū [+ D₂ᵀū], v̄ += Cᵀū, dy/dp += Eᵀū
        [+ P₂ᵀū]; with guides or rigid links δ(K)v̇ moves with the step's δv̇ before the event too (the forward
        method's ``rates``): v̇̄ += D₂,v̇ᵀū. Returns (q̄, v̄, v̇̄ of the step before the event (None after a latch: its
        restart weighs with M alone), (k, m) into the gradient, (m,) into t̄: beside laws in t the restart at
        t_e + δt_e, latdyn/analyses/adjoint_time.py)."""
        model = self.model
        self._numbered(entry["numbering_end"])
        # a stick or release restarts as after a stop (the forward method's _stick_or_release)
        after, kind = entry["after"], (entry["event"][1] if entry.get("event") is not None else "stop")
        n = model.n_dofs
        if n == 0:   # nothing free after the latch: the forward method restarts nothing (TransientSensitivities._restart)
            return q_bar, v_bar, None, np.zeros((len(self.names), s_bar.shape[1])), np.zeros(s_bar.shape[1])
        M, C, K = self._matrices(after)
        if kind == "latch":
            matrix = M
        else:
            scale = self.scene.solve.dt * self.scene.solve.dt
            before = after.copy()
            unpack_free(model, free_acceleration(model, entry["state"]), before.a, before.alpha, before.theta_ddot)
            self.assembler.complete_links(before)
            matrix = self.assembler.evaluate(before, matrices=True).combined(1.0, 0.0, scale)
        u_bar = -np.asarray(solve_linear(_transposed(matrix), s_bar)).reshape(n, s_bar.shape[1])
        self._restart_u = (after, u_bar)   # the held states' part of its ∂r/∂p (_held_weights_transposed)
        self._restart_weight = None if kind == "latch" else (before, u_bar)   # the held angles' (friction events)
        q_bar = q_bar + np.asarray(K.T @ u_bar)
        v_bar = v_bar + np.asarray(C.T @ u_bar)
        vdot_bar = None   # a latch restarts with M alone
        by_restart = self.residual_transposed_product(after, u_bar)
        timed = adjoint_time.moves_in_time(self)
        by_time = adjoint_time.restart_transposed(self, after, u_bar) if timed else np.zeros(u_bar.shape[1])
        if kind != "latch":
            q_part, v_part, vdot_bar, p_part = self._weight_derivative_transposed(
                before, free_acceleration(model, after), u_bar, scale, mass=False)
            q_bar, v_bar, by_restart = q_bar + q_part, v_bar + v_part, by_restart + p_part
            if timed:
                by_time = by_time + adjoint_time.weight_transposed(self, before, free_acceleration(model, after),
                                                                   u_bar, scale, mass=False)
        return q_bar, v_bar, vdot_bar, by_restart, by_time

    def _stiffness_by_rates_transposed(self, state, w: np.ndarray, u_bar: np.ndarray, scale: float) -> np.ndarray:
        """The transpose of the forward method's rates' term of the weight derivative, scale ∂(K w)/∂v δv
        (:meth:`TransientSensitivities._stiffness_by_rates`), applied to ``u_bar`` (n, m): scale (∂(K w)/∂v)ᵀ ū,
        ∂(K w)/∂v the forward method's along each free rate (the identity's columns): generated for the hinges, the
        couplings and loads of the controllers whose second derivatives are generated and the damped cables, no
        evaluation (the same sparse matrix, :func:`latdyn.analyses.weight_derivative.rates_tangent_of_weight`); a
        difference,
        two evaluations a free rate, of the blocks not generated alone (latdyn/analyses/weight_derivative.py, "Along
        the rates"). Where K moves with the rates
        at ``state`` (:meth:`TransientSensitivities.stiffness_moves_with_rates`, the forward method's one predicate:
        a damped cable's c ℓ̇ terms, a hinge law whose ∂τ/∂θ holds θ̇, a controller's couplings that hold a rate …),
        else 0."""
        if not self.stiffness_moves_with_rates(state):
            return np.zeros_like(u_bar)
        n = self.model.n_dofs
        by_rates = self._stiffness_by_rates(state, w, np.eye(n))
        return scale * np.asarray(by_rates.T @ u_bar)

    def _renumbering_transposed(self, entry: dict, q_bar: np.ndarray, v_bar: np.ndarray) -> tuple:
        """The transpose of the forward method's renumbering at an event (δq, δv of the numbering before it put
        on the nodes and hinges, :meth:`_on_nodes`, and packed on the numbering after it, :meth:`_restart`): the
        bars on the numbering after it put on the nodes and packed on the numbering before it (a latched
        joint's angle, no coordinate after the latch, gets 0). Leaves the model on the numbering before it."""
        self._numbered(entry["numbering_end"])
        on_nodes = self._on_nodes(np.hstack([q_bar, v_bar]))
        self._numbered(entry["numbering"])
        model, m = self.model, q_bar.shape[1]
        n = model.n_dofs
        packed = np.column_stack([pack(model, *column)[:n] for column in on_nodes]) if on_nodes else np.zeros((n, 0))
        return packed[:, :m], packed[:, m:]

    def _weight_derivative_transposed(self, state, w: np.ndarray, u_bar: np.ndarray, scale: float,
                                      mass: bool = True) -> tuple:
        """The transpose of the forward method's :meth:`_weight_derivative` (δ(W w) = D δq + D_v δv + D_v̇ δv̇ + P,
        W = M + scale·K, or scale·K without ``mass``; δv, δv̇ its ``rates``) applied to ``u_bar`` (n, m): (Dᵀū,
        D_vᵀū, D_v̇ᵀū (n, m) each, Pᵀū (k, m)). Without guides and rigid links D = ∂(W w)/∂q is the forward method's
        matrix H (:func:`latdyn.analyses.weight_derivative.configuration_tangent_of_weight`: the generated
        elements', joint bodies' (their weight's too), hinges', loads', cables' and most couplings' parts, the differences of
        the other couplings' blocks and the loads they drive only along the coordinates they are on), Dᵀū its transposed
        product; D_v the rates' term where K moves with them (:meth:`_stiffness_by_rates_transposed`), D_v̇ = 0.
        With guides or rigid links (D, D_v, D_v̇) are the forward method's own map
        (:meth:`TransientSensitivities._linked_weight_derivative`) applied to the unit columns of δq, δv and δv̇ —
        one call of 3n columns, its generated parts exact and its differences (the links' second derivatives, the
        blocks not generated) the forward method's along each unit move — and transposed. Pᵀū:
        scale·((∂K/∂p) w)ᵀū with the forward method's (∂K/∂p) w (:meth:`_stiffness_derivative`: the section values',
        hinges', loads', joint bodies', cables', compliant stops' and friction's parts generated,
        latdyn/analyses/parameter_stiffness.py, controllers' terms differenced apart, the rest a difference along w
        of ∂r/∂p without them and the elements' gravity load; with guides or rigid links its reduction's geometric
        term, :meth:`_geometric_derivative`), and with ``mass`` the transposed products
        (:meth:`residual_transposed_product`, exact) at the accelerations w less at rest."""
        linked = self.model.links is not None
        if linked:
            q_part, v_part, vdot_part = self._linked_weight_transposed(state, w, u_bar, scale, mass)
        else:
            H = configuration_tangent_of_weight(self.assembler, state, w, scale, mass, self.coordinate_step())
            q_part = transposed_times(H, u_bar)
            v_part = self._stiffness_by_rates_transposed(state, w, u_bar, scale)
            vdot_part = np.zeros_like(u_bar)
        p_part = np.zeros((len(self.names), u_bar.shape[1]))
        size = float(np.max(np.abs(w), initial=0.0))
        if size == 0.0:
            return q_part, v_part, vdot_part, p_part
        # the forward method's (∂K/∂p) w (n, k), transposed: the same numbers, so the difference in it (the
        # parameters not of section values alone) is the forward method's to the bit rather than a transposed
        # product's round-off over its step (1.5e-11 of the outputs beside a controller)
        stiffness = self._stiffness_derivative(state, w)
        if linked:
            stiffness = stiffness + self._geometric_derivative(state, w)
        p_part += scale * (stiffness.T @ u_bar)
        if self.__dict__.get("_weights_met") is not None:   # the held states' part (_held_weights_transposed)
            self._weights_met.append((state, w, u_bar, scale))
        if mass:
            at_rest, accelerated = self._at_rest_and_accelerated(state, w)
            p_part += (self.residual_transposed_product(accelerated, u_bar)
                       - self.residual_transposed_product(at_rest, u_bar))
        return q_part, v_part, vdot_part, p_part

    def _linked_weight_transposed(self, state, w: np.ndarray, u_bar: np.ndarray, scale: float, mass: bool) -> tuple:
        """(Dᵀū, D_vᵀū, D_v̇ᵀū) of :meth:`_weight_derivative_transposed` with guides or rigid links: the forward
        method's :meth:`TransientSensitivities._linked_weight_derivative` on the 3n unit moves (δq, then δv, then
        δv̇ of one free coordinate each) gives the columns of [D | D_v | D_v̇], transposed onto ``u_bar``."""
        n = self.model.n_dofs
        eye, zero = np.eye(n), np.zeros((n, n))
        moves = (np.hstack([eye, zero, zero]), np.hstack([zero, eye, zero]), np.hstack([zero, zero, eye]))
        columns = self._linked_weight_derivative(state, w, moves[0], scale, mass, moves[1:])
        return tuple(columns[:, part * n:(part + 1) * n].T @ u_bar for part in range(3))

    def _transposed_step_system(self, new, tangent, beta_p: float, gamma_p: float):
        """(Cᵀ, Kᵀ, solve_transposed, solve) at the stored state ``new``: the forward method's step matrix
        S = β′M + γ′C + K J on its held pattern and storage (:meth:`TransientSensitivities._step_system`),
        factorised as the forward method factorises it, and solved with Sᵀ from those factors
        (:meth:`latdyn.assembly.factorization.Factorization.solve_transposed`); Cᵀ and Kᵀ views of the held
        matrices' storage, made once per pattern. With rigid links or guides, M, C and the exact K of the compiled
        step's reduction (``Assembler.linked_exact_matrix_values``, as the forward method's step and the native
        reverse step, csrc/adjoint_reverse.c) on the forward step's held pattern the same way; where the reduction has
        none (``linked_exact_layout`` None), the reduction's matrices (:meth:`_matrices`) summed as the forward method
        sums them and Sᵀ factorised. A singular S raises SolverError."""
        linked = self.model.links is not None
        # with rigid links or guides the compiled step's reduction (csrc/linked_matrices.c) where it has one, as the
        # forward method's step (TransientSensitivities._step_system) and the native reverse step
        values = (self.assembler.linked_exact_matrix_values(new) if linked else
                  self.assembler.exact_matrix_values(new))
        if linked and values is None:
            summed, C, K = self._reduced_step_matrix(new, tangent, beta_p, gamma_p)
            matrix = _transposed(summed)
            try:
                solver = factorization_for(matrix).factor(matrix)
            except np.linalg.LinAlgError:
                raise SolverError(f"the adjoint sensitivities at t = {new.t:.6g} need the step's exact iteration "
                                  "matrix, which is singular there") from None
            return C.T, K.T, solver.solve, solver.solve_transposed
        try:
            step_matrix = self._step_matrix(tangent.slots, dense=linked)
            factors = step_matrix.factor(values, tangent.blocks, beta_p, gamma_p)
            return (*self._held_transposes(step_matrix), factors.solve_transposed, factors.solve)
        except np.linalg.LinAlgError:
            raise SolverError(f"the adjoint sensitivities at t = {new.t:.6g} need the step's exact iteration "
                              "matrix, which is singular there") from None

    @staticmethod
    def _held_transposes(step_matrix) -> tuple:
        """(Cᵀ, Kᵀ) of ``step_matrix``'s held C and K: views of latdyn.numerics.csr's CSR sharing their values,
        which each :meth:`~latdyn.analyses.step_matrix.ExactStepMatrix.factor` replaces in place; their products
        are SciPy's CSC products to the bit (:class:`latdyn.numerics.csr.Transpose`), without importing
        scipy.sparse."""
        return Transpose(step_matrix.damping), Transpose(step_matrix.stiffness)

    def _through_the_start(self, state, v_bar: np.ndarray, s_bar: np.ndarray, q_bar: np.ndarray) -> np.ndarray:
        """(k, m) what t = 0 adds (module docstring): E_0ᵀ r̄ + D_vᵀ(v̄_0 + C_0ᵀ r̄), r̄ = Δᵀ s̄; with geometry
        parameters also :meth:`_start_moved_transposed`."""
        return self._through_the_start_at_rest(state, v_bar, s_bar) + self._start_moved_transposed(
            state, v_bar, s_bar, q_bar)

    def _start_moved_transposed(self, state, v_bar: np.ndarray, s_bar: np.ndarray, q_bar: np.ndarray) -> np.ndarray:
        """(k, m) the transpose of the start's move by geometry parameters (the forward method's :meth:`start`:
        δq_0 = D_q = δX of the free nodes, :meth:`ReferenceGeometry.initial_tangent`, δv_0 gains D_ω = ω × δX and
        a hinge's δa·ω, :meth:`ReferenceGeometry.initial_velocity_tangent`, and the start's accelerations
        δv̇_0 = δa_0 = Δ(… + K_0 D_q + C_0 D_ω), K_0 the exact K): D_qᵀ(q̄_0 + K_0ᵀ r̄) + D_ωᵀ(v̄_0 + C_0ᵀ r̄), r̄ = Δᵀ s̄
        (:meth:`_start_weights_transposed`); zero without geometry parameters."""
        if self.geometry is None:
            return np.zeros((len(self.names), q_bar.shape[1]))
        r_bar = self._start_weights_transposed(state, s_bar)
        _, C, K = self._matrices(state)
        moved_q, moved_v = self.geometry.initial_tangent(), self.geometry.initial_velocity_tangent()
        return moved_q.T @ (q_bar + np.asarray(K.T @ r_bar)) + moved_v.T @ (v_bar + np.asarray(C.T @ r_bar))

    def _start_weights_transposed(self, state, s_bar: np.ndarray) -> np.ndarray:
        """r̄ = Δᵀ s̄ (n, m): the start's consistent accelerations' map transposed, as
        :meth:`_through_the_start_at_rest` computes it."""
        model = self.model
        ev = self.assembler.evaluate(state, matrices=True)
        M, split = self._start_mass(ev)
        if isinstance(M, CSR):
            return -np.asarray(solve_linear_csr(transposed(M), s_bar)).reshape(s_bar.shape)
        if split.n_massless == 0:
            return -np.asarray(solve_linear(_transposed(M), s_bar)).reshape(s_bar.shape)
        flipped = SimpleNamespace(combined=lambda a, b, c: _transposed(ev.combined(a, b, c)))
        return np.column_stack([consistent_acceleration(model, SimpleNamespace(residual=s_bar[:, c],
                                                                                combined=flipped.combined))
                                for c in range(s_bar.shape[1])])

    def _through_the_start_at_rest(self, state, v_bar: np.ndarray, s_bar: np.ndarray) -> np.ndarray:
        """(k, m) E_0ᵀ r̄ + D_vᵀ(v̄_0 + C_0ᵀ r̄), r̄ = Δᵀ s̄: the start where it does not move (no geometry
        parameter)."""
        model = self.model
        ev = self.assembler.evaluate(state, matrices=True)
        M, split = self._start_mass(ev)   # the forward method's M: a CSR without SciPy where the run's start takes one
        if isinstance(M, CSR):   # Mᵀ and Cᵀ r̄ as SciPy's M.T.tocsr() and C.T @ r̄ compute them (latdyn.numerics.csr)
            r_bar = -np.asarray(solve_linear_csr(transposed(M), s_bar)).reshape(s_bar.shape)
            C = ev.combined_csr(0.0, 1.0, 0.0)
            C_t_r_bar = np.empty_like(r_bar)
            for c in range(r_bar.shape[1]):
                C_t_r_bar[:, c] = C.rmatvec(r_bar[:, c])
            return self.residual_transposed_product(state, r_bar) + self._initial_velocities().T @ (v_bar + C_t_r_bar)
        if split.n_massless == 0:
            r_bar = -np.asarray(solve_linear(_transposed(M), s_bar)).reshape(s_bar.shape)
        else:
            flipped = SimpleNamespace(combined=lambda a, b, c: _transposed(ev.combined(a, b, c)))
            r_bar = np.column_stack([consistent_acceleration(model, SimpleNamespace(residual=s_bar[:, c],
                                                                                    combined=flipped.combined))
                                     for c in range(s_bar.shape[1])])
        C = ev.combined(0.0, 1.0, 0.0)
        dv = self._initial_velocities()
        return self.residual_transposed_product(state, r_bar) + dv.T @ (v_bar + C.T @ r_bar)

    # ------------------------------------------------------------------ the end
    def finish(self, carried: dict, writer) -> None:
        """The reverse pass; summary.json ``probe_sensitivities`` (end, max, min, as the forward method
        writes them) and ``event_sensitivities`` (each latch's, stop's and cable change's time derivative, as the
        forward method writes them: :meth:`event_records`); ``sensitivities.csv`` and
        ``Result.sensitivities`` with the end row alone (``t,<probe>/<NAME>,…``)."""
        from latdyn.results.files import atomic_write_bytes, csv_line

        if self.__dict__.get("_refused", False):   # a joint stuck (:meth:`_refuse_a_stick`): the run is refused
            return
        recorded = writer.result()
        # a run that failed in the events of its last step (a SolverError after the step was stored): the
        # accepted steps before it, as the forward method's carried sensitivities are
        carried = {**carried, "trajectory": accepted(carried["trajectory"])}
        series = {p.name: recorded.probes[p.name] for p in self.probes}
        outputs = self.outputs(carried, series)
        gradient, timed = self.reverse(carried, outputs)
        summary: dict = {}
        for column, (probe, which, _) in enumerate(outputs):
            summary.setdefault(probe.name, {})[which] = {name: float(gradient[c, column])
                                                         for c, name in enumerate(self.names)}
        writer.summary["probe_sensitivities"] = summary
        writer.summary["event_sensitivities"] = [
            {**record, "dt": {name: float(timed[c, e]) for c, name in enumerate(self.names)}}
            for e, (_, record) in enumerate(self.event_records(carried))]
        end = {(probe, name): np.array([values["end"][name]])
               for probe, values in summary.items() for name in self.names}
        writer.sensitivities = end
        if writer.out_dir is not None and carried["rows"]:
            t_end = float(np.asarray(recorded.t)[len(carried["rows"]) - 1])
            row = [t_end] + [float(end[(p.name, name)][0]) if (p.name, name) in end else float("nan")
                             for p in self.probes for name in self.names]
            text = csv_line(["t", *self.columns]) + csv_line(row)
            atomic_write_bytes(Path(writer.out_dir) / SENSITIVITIES_FILE, text.encode("utf-8"))


def _held_angle_probe(probe) -> bool:
    """Whether the reverse pass seeds ``probe``'s forms of a held angle (:meth:`AdjointSensitivities._held_forms`, the
    forward method's :meth:`record` on the angle's δθ): every probe but a controller's (its states' and held outputs'
    terms of the held angle are not formed) and energies and momenta (the forward method takes them beside a stick
    since stickstates; their held forms are not transposed here)."""
    return not (is_controller_probe(probe) or is_energy_or_momentum(probe))


def _norm_at_zero(probe, forms: tuple) -> bool:
    """Whether ``probe`` is a point's norm whose forms (c_q, c_v, c_v̇, explicit) hold a NaN: its value is 0
    and a coordinate moves the point (:meth:`ParameterDerivatives._probe_derivatives`)."""
    return (probe.kind == "point" and probe.component in (None, "norm")
            and any(np.isnan(form).any() for form in forms))


def _transposed_rotations(owner, rotations: _NodeRotations) -> _NodeRotations:
    """The transposed operator of ``rotations`` (each node's 3 × 3 block transposed): Rᵀ = exp(−skew hΔq),
    Jᵀ = dexp(−hΔq); an operator marked as the identity (``is_identity``, where the step's maps are: a
    planar model's) is its own transpose."""
    if getattr(rotations, "is_identity", False):
        return rotations
    return _NodeRotations(owner, np.ascontiguousarray(np.transpose(rotations.blocks, (0, 2, 1))), rotations.slots,
                          rotations.n)


def _transposed(matrix):
    """``matrix``ᵀ in the storage the linear solves take (CSR for a sparse one)."""
    return matrix.T.tocsr() if issparse(matrix) else np.ascontiguousarray(matrix.T)
