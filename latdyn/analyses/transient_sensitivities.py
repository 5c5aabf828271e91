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

    δπ_{n+1} = R δπ_n + J h δΔq,    R = exp(skew hΔq),  J = dexp(hΔq)  (the generated ``so3_dexp``)

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
differentiated exactly; adaptive step control chooses sizes that depend on p, and the control's rules are
differentiated (latdyn/analyses/adaptive_sensitivities.py: ``carried["dh_next"]``, the next trial's δh).

At t = 0 the configuration depends on geometry parameters only (δq_0 = δX, K δq_0 added to the start's ∂r/∂p
with the exact K: latdyn/analyses/geometry_sensitivities.py); the velocities do through
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
derivative of the impulse weight M + dt²K along δq is the matrix H = ∂(W w)/∂q, generated for the elements
(``beam_stiffness_D_q``, ``beam_inertia_tangent``) and the joint bodies' mass and weight
(``joint_body_inertia_stiffness``, ``joint_body_gravity_stiffness_D_q``), the hinges' (``hinge_stiffness_by_angle``),
the point loads' (``point_load_stiffness_D_q``), the cables' (``cable_stiffness_D_q``) and the couplings of
controllers of joints' angles and rates (SymPy's second derivatives of their outputs), the other couplings' blocks
differenced along the coordinates they are on (latdyn/analyses/weight_derivative.py), and along
p (∂K/∂p) w: the section values' part generated for every parameter, the rest a difference along w of the static
∂r/∂p without the section values' element forces and the elements' gravity load, which the evaluation's K (the
impulse's) leaves out (:meth:`TransientSensitivities._weight_derivative`,
:meth:`TransientSensitivities._stiffness_derivative`).
A compliant stop's onset (``contact``) is landed on too, and its time enters through the landing
step's size as a latch's does (:meth:`TransientSensitivities._contact_onset`); its force being continuous
there, nothing jumps; its law's stiffness, exponent and damping enter ∂r/∂p through the generated
``contact_force_D_law`` (docs/parameters.md, "Compliant stops"); a guide's likewise, on its slide.
Friction while a joint slips is a force of the residual like any other (its rate derivative in the exact
matrix, its law's values through the generated ``friction_force_D_law``). Sticking and the release come at a
step's end (δt 0): a stick is a stop's impulse with restitution 0 and a stop's restart; while stuck, the held
angle's δθ is carried (``held``) and enters the residual through the exact K's column of that angle
(:meth:`TransientSensitivities._held_forces`), and every probe and controller's sensor reads it as the joint's δθ
(:meth:`record`: the energies' and momenta's forms at the joint's slot too; latdyn/analyses/sensitivities.py
``_sensor_derivatives``); a release restarts as after a stop, the held δθ back among the free coordinates (:meth:`TransientSensitivities._stick_candidates`, :meth:`TransientSensitivities._stick_or_release`;
what is refused there: :meth:`TransientSensitivities._refuse_sticking`; docs/parameters.md, "Friction"). On a model
with rigid links the held angle moves the reduced residual, the impulse's weight and the dependent nodes through the
reduction too: the reduced residual by the exact reduced K's column of the angle had it been free
(:meth:`TransientSensitivities._linked_held_forces`, the prescribed motions' path at a unit rate on it) and the
dependent nodes by J's column of it (:meth:`TransientSensitivities._held_dependent_motion`), and the weight by
∂(K w)/∂θ_j (:meth:`TransientSensitivities._linked_held_stiffness_along`), exactly (no central difference along the
angle since heldcol).

A hinge resting on its rigid stop (locked there after landing with restitution 0, released at a step's end where its
reaction would pull it off; or put back on it at the end of a step it started on the stop and ended beyond):
its coming to rest as a stop's impulse with e = 0 and a restart on the locked model, its δθ 0 while it rests, the
release as a stop's restart, the projection at a step's end with its term δ[X(NᵀX)⁻¹](θ − stop)
(:meth:`TransientSensitivities._settle_or_release`, :meth:`TransientSensitivities._projected`; docs/parameters.md,
"A hinge resting on its stop").

Laws in time (:class:`ExplicitTime`): where loads, hinge or guide laws, prescribed motions or a reel depend on
t, a step's end t_{n+1} = t_n + h moves with δt_{n+1} = δt_n + δh (δt_e after an event, until a step lands on
the grid), and the step's derivative adds ∂r/∂t δt_{n+1}: ∂r/∂t δt_n in the parameters' columns and ∂r/∂t in
the step size's (:meth:`TransientSensitivities._add_time_columns`); the impulse and the restart at the event
are taken at t_e + δt_e (:attr:`TransientSensitivities.time_shift`). ∂r/∂t is exact for the laws, a reel and
prescribed motions (the coupling blocks times the motions' exact rates, on a model with rigid links or guides with
the dependent nodes they carry: latdyn/analyses/prescribed_rates.py; docs/parameters.md, "Sensitivities through
events", "Laws in time").

Cables (:class:`CableSensitivities`): their EA, damping and rest length from the generated taut law, and
their slack/taut changes as events landed on exactly, the event time differentiated from the gap's
gradients (no jump: the discrete run neither jumps nor restarts there). Guides: a guide's laws as a
hinge's on its slide (a prescribed slide as a prescribed hinge angle), ∂r/∂p reduced by the projection Pᵀ,
the step's K exact with the guided bodies' rates'
derivatives (:meth:`latdyn.assembly.assembler.Assembler.exact_matrices`: the reduction's own K is not exact); their
latches and stops as the hinges', the impulse weight's dependence on the rates followed. Rigid links take the
same reduction (latdyn/analyses/link_sensitivities.py). Inputs are held at their values (the derivative at fixed
inputs). docs/parameters.md, "Cables", "Guides", "Rigid links" and "Inputs".

Controllers: parameters inside their outputs enter ∂r/∂p (:class:`latdyn.analyses.sensitivities.ControllerTerms`);
the states of continuous controllers are carried as (δS, δf) beside the step's derivative, the step's matrix
taken with the states condensed from the step's start as inside the step
(:class:`latdyn.analyses.sensitivities.ControllerStates`); a sampled controller's held output and states jump
at the fixed instants k/rate, and the restart after each sample is differentiated
(:meth:`TransientSensitivities.after_sample`, :class:`latdyn.analyses.sensitivities.SampledTerms`). docs/parameters.md, "Controllers".

The step's matrix (without rigid links and guides): M, C and the exact K as the values of the
assembler's pattern from one native evaluation and one scatter
(:meth:`latdyn.assembly.assembler.Assembler.exact_matrix_values`), then one native call
(latdyn/assembly/csrc/sensitivity_step.c ``latdyn_sensitivity_step``,
:meth:`latdyn.analyses.step_matrix.ExactStepMatrix.solve_step`): β′M + γ′C + K J summed on a pattern built
once per numbering, factorised in its held storage, and the k + 1 right-hand sides −(∂r/∂p + K δq⁰ + C δv⁰)
formed and solved; with rigid links and guides, the reduction's matrices (:meth:`_matrices`) summed by SciPy.
The predicted parts δa⁰, δq⁰, δv⁰ and the update after the solve are one native call each, with R and J per
free node (:class:`_StepColumns`: ``latdyn_sensitivity_predict``, ``latdyn_sensitivity_update``), on both paths.
∂r/∂p stays the generated kernels called from Python. The run takes one step at a time from Python (the
time loop's per-step path), except the smooth steps of runs whose every term is native, which the loop of steps in C
differentiates with the same calls in the same order (latdyn/analyses/sensitivities_in_loop.py,
csrc/sensitivity_loop.c: :meth:`in_loop`); it carries (δq, δv, δv̇, δa) on the free
coordinates, (n, k), in :attr:`latdyn.timeloop.progress.TransientProgress.sensitivities`, checkpointed with
the run.
"""
from __future__ import annotations

import contextlib

from contextlib import nullcontext
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from latdyn.analyses import adaptive_sensitivities
from latdyn.analyses.cable_sensitivities import LANDING, CableSensitivities
from latdyn.analyses.derivative_laws import ControllerPartials, DerivativeLaws
from latdyn.analyses.energy_sensitivities import external_work_after_event, external_work_step, is_energy_or_momentum
from latdyn.analyses.geometry_sensitivities import GEOMETRY_KEY
from latdyn.analyses.parameter_stiffness import (controller_parameter_along, exact_parameters, held_angles_along,
                                                 linked_controller_parameter_along,
                                                 stiffness_along as parameter_stiffness_along,
                                                 stiffness_along_all as parameter_stiffness_along_all,
                                                 time_shift_along)
from latdyn.analyses.prescribed_rates import linked_columns
from latdyn.analyses.sensitivities import (_BODY_KEY, _CABLE_KEY, _GUIDE_KEY, _HINGE_KEY, _INITIAL_VELOCITY_KEY,
                                           _LOAD_KEY, _SECTION_KEY, SENSITIVITIES_FILE, ParameterDerivatives,
                                           rates_taken_anew)
from latdyn.analyses.joint_force_sensitivities import (held_reaction_columns, held_sensor_forms, is_joint_force,
                                                       joint_force_derivatives, joint_force_forms, joint_of)
from latdyn.analyses.step_matrix import ExactStepMatrix, turns_about_one_axis
from latdyn.analyses.weight_derivative import (_generated, _load_part, cable_stiffness_by_rates,
                                               configuration_tangent_of_weight, geometric_product,
                                               geometric_second_product, linked_configuration_tangent,
                                               linked_generated_loads,
                                               linked_geometric_rate_in_time,
                                               linked_geometric_derivative, linked_has_rest, linked_rest_product,
                                               linked_cable_rates_product, linked_coupling_rates_product,
                                               linked_chain_rates_product,
                                               linked_rates_tangent,
                                               needs_the_kernel, rates_rest_needed, rates_rest_product,
                                               rates_tangent_of_weight, refuse_without_kernel,
                                               stiffness_moving_with_rates, times)
from latdyn.assembly.assembler import free_acceleration, free_velocity, pack, unpack_free
from latdyn.assembly.factorization import factorization_for, solve_linear, solve_linear_csr
from latdyn.assembly.linked import dependent_columns
from latdyn.errors import SceneError, SolverError
from latdyn.model.model import lock_tolerance
from latdyn.numerics import csr
from latdyn.numerics.csr import CSR
from latdyn.numerics.inertia import split_inertia
from latdyn.numerics.linalg import issparse
from latdyn.scene.expressions import TimeFunction, _drop_deltas
from latdyn.step.integrators import consistent_acceleration, start_without_scipy
from latdyn.timeloop.events import (cable_crossings, cable_gaps, lock_events, may_stick, restart_accelerations,
                                    sticking_hinges, stop_holds, stop_hits)
from latdyn.timeloop.impulse import hinge_directions, massless_element_stiffness
from latdyn.timeloop.landing import LANDING_PASSES, first_event, land

__all__ = ["TransientSensitivities", "friction_key"]


#: |v̇_0| and |Q_cᵀ r| below which a start counts as at rest in equilibrium (SI units; module docstring)
AT_REST = 1e-9
#: landings at most of one step on a cable element that an earlier landing's step shows past its change before
#: the element it landed on (:meth:`TransientSensitivities.land`)
RELANDINGS = 4
#: a landing farther than this (relative, as LANDING) from the event is flagged in summary.json warnings:
#: the event-time derivative assumes the step ends on it
LANDING_MISSED = 1e-10
#: what a joint stuck from t = 0 does, in a refusal's message (latdyn.timeloop.events.stick_at_start;
#: :meth:`TransientSensitivities._refuse_what_a_held_angle_moves`)
HELD_FROM_THE_START = ("the joint is held by friction from the start (it starts at rest, the force or torque that "
                       "holds it within its static level)")
#: the configuration step (times the length scale) of the central differences inside the impulse weight's
#: derivative that are not generated (module docstring, "Events"; latdyn/analyses/weight_derivative.py): along the
#: coordinates of the blocks not generated (some controllers' couplings, the loads they drive, a hinge law naming an
#: input), along δq with rigid links or guides, and of
#: ∂r/∂p along w (without the section values' forces and the elements' gravity load) for the parameters it holds
WEIGHT_STEP = 1e-5
#: the caches a ParameterDerivatives makes of its :attr:`derivatives` on first use (latdyn/analyses/sensitivities.py,
#: latdyn/analyses/link_sensitivities.py): dropped from a copy given other derivatives (:class:`ExplicitTime`)
DERIVATIVE_CACHES = ("_kinds", "_sections_only", "_section_layout_made", "_section_scale", "_section_use",
                     "_section_elements_distinct", "_section_values_held", "_load_layout_made", "_load_laws_distinct",
                     "_hinge_uses_found", "_body_uses_found", "_joint_laws", "_link_section_uses")


def friction_key(joint) -> str:
    """The scene key of a joint's friction: a guide's (``bodies.NAME.guide.friction``) or a hinge's."""
    return (f"bodies.{joint.beam}.guide.friction" if joint.end == "guide"
            else f"beams.{joint.beam}.{joint.end}.hinge.friction")


def stop_key(joint) -> str:
    """The scene key of a joint's stops: a guide's (``bodies.NAME.guide.limits``) or a hinge's."""
    return (f"bodies.{joint.beam}.guide.limits" if joint.end == "guide"
            else f"beams.{joint.beam}.{joint.end}.hinge.limits")


class TransientSensitivities(ParameterDerivatives):
    """The sensitivities of a transient run (module docstring). The time loop calls :meth:`start` at
    t = 0, :meth:`step` per accepted step, :meth:`record` per recorded row and :meth:`finish` at the
    end; what it carries between them is a dict (``carried``), replaced, never changed in place."""

    def __init__(self, prepared):
        super().__init__(prepared)
        #: the run's model, assembler and scene, for its own restart of the accelerations (:meth:`_restarted`)
        self.prepared = prepared
        self.derivative_laws = DerivativeLaws.of(self)
        if self.controllers is not None:   # the controllers' ∂f/∂p compiled alike
            self.controllers.compiled = ControllerPartials.of(self.controllers, self.controllers.partial_expressions,
                                                              self.controllers.rate_expressions)
        self.params = self.length = None
        #: the cables' parameters and events (:class:`CableSensitivities`), None without cables
        self.cables = CableSensitivities(self) if self.model.cables is not None else None
        #: ∂r/∂t at fixed coordinates (:class:`ExplicitTime`), None where nothing depends on t
        self.explicit_time = ExplicitTime.of(self)
        #: δt (k,) of the state the events' derivatives are taken at (:meth:`residual_derivatives` adds
        #: ∂r/∂t δt there), None elsewhere
        self.time_shift = None
        #: δθ (n_hinges, k) of the joints friction holds (carried as ``held``; :meth:`_held_forces`), None without
        self.held = None
        #: whether an impulse's weight is M + dt²K alone (:meth:`start` finds it where something is free there; a
        #: start with nothing free has no direction without inertia to find)
        self._impulse_weighted = True
        #: the stuck joints at the step's start, and the jumps of those that may stick or be released at its end
        #: (:meth:`_stick_candidates`), for :meth:`after_events`
        self._stuck_before, self._candidates = None, {}
        #: the hinges resting on their rigid stops at the step's start (``model.resting``), and the restarts of
        #: those the step's end may release (:meth:`_release_candidates`), for :meth:`after_events`
        self._resting_before, self._releases = None, {}

    def bind(self, integrator) -> None:
        """The integrator's parameters (α_m, α_f, γ, β) and length scale (the inertia tangent's steps); the
        assembler's native models built with the inertia tangent's buffers before the run's first step
        (``Assembler.inertia_tangent_buffers``): the step's evaluation of the exact matrices then leaves the
        run's model, and modified Newton's held factorization, as they are — the run's states are those
        without sensitivities, to the bit."""
        self.params, self.length = integrator.p, integrator.length_scale
        self.assembler.inertia_tangent_buffers = True

    def in_loop(self):
        """The run's smooth steps' derivative inside the loop of steps in C
        (:class:`latdyn.analyses.sensitivities_in_loop.SensitivityLoop`), or None where every step is taken from
        Python (:func:`latdyn.analyses.sensitivities_in_loop.refusal`): decided once per run."""
        from latdyn.analyses import sensitivities_in_loop

        if not sensitivities_in_loop.SENSITIVITIES_IN_LOOP or sensitivities_in_loop.refusal(self) is not None:
            return None
        return sensitivities_in_loop.SensitivityLoop(self)

    def residual_derivatives(self, state, load_factor: float, inertia: bool = False,
                             on_all: bool = False, sections: bool = True,
                             element_gravity: bool = True, held_through_links: bool = True) -> np.ndarray:
        """∂r/∂p of :class:`latdyn.analyses.sensitivities.ParameterDerivatives` (``sections``,
        ``element_gravity`` as there), with the cables' (:meth:`CableSensitivities.residual_derivatives`) and the
        angles friction holds (:meth:`_held_forces`; with rigid links on the free coordinates alone,
        :meth:`_linked_held_forces`, unless ``held_through_links`` is False: the weight's derivative takes their
        move of K w apart, :meth:`_linked_held_stiffness_along`)."""
        total = super().residual_derivatives(state, load_factor, inertia, on_all=True, sections=sections,
                                             element_gravity=element_gravity)
        if self.cables is not None and self.cables.uses:
            self.cables.residual_derivatives(state, total, inertia)
        held = self._held_forces(state, inertia, element_gravity)
        if held is not None:   # the angles friction holds, moved by δθ: K's columns of them
            total += held
        linked_held = held_through_links and not on_all and self._holds_through_links()
        shifted = self.time_shift is not None and self.explicit_time is not None and np.any(self.time_shift)
        if on_all:
            if shifted:
                total += np.outer(self.explicit_time(state, inertia, on_all=True), self.time_shift)
            return total
        free = self._on_free_coordinates(state, total)
        if linked_held:   # with rigid links: the reduced residual's derivative by the held angles times δθ
            free = free + self._linked_held_forces(state, inertia)
        if shifted:   # the state moved in time by δt: ∂r/∂t δt (the events' derivatives, module docstring)
            free = free + np.outer(self.explicit_time(state, inertia), self.time_shift)
        return free

    # ------------------------------------------------------------------ t = 0
    def start(self, state) -> dict:
        """The carried sensitivities at t = 0 (after the integrator's start made ``state``'s
        accelerations consistent): δq = δX of geometry parameters (else 0), δv = δv_0, δv̇ = δa = the start's
        derivative."""
        model, k = self.model, len(self.names)
        n = model.n_dofs
        zero = np.zeros((n, k))
        carried = {"dq": zero, "dv": zero, "dvdot": zero, "da": zero, "rows": [],
                   "dt": np.zeros(k), "dh": np.zeros(k), "h": None, "events": [], "pending": None}
        if n == 0 or k == 0:
            return carried
        ev = self.assembler.evaluate(state, matrices=True)
        mass, split = self._start_mass(ev)
        self._refuse_events(ev, split)
        #: whether an impulse's weight is M + dt²K alone (a stick's jump: :meth:`_stick_or_release`)
        self._impulse_weighted = not (split.n_massless or massless_element_stiffness(ev) is not None)
        if model.stuck.any():   # stuck by friction from t = 0, its held angle the start's (stick_at_start)
            self._refuse_what_a_held_angle_moves(state, HELD_FROM_THE_START, int(np.flatnonzero(model.stuck)[0]),
                                                 through_links=True)
        if split.n_massless:
            self._refuse_start(state, ev, split)
        dv = self._initial_velocities()
        dq, moved = zero, None
        if self.geometry is not None:   # geometry parameters move the start: δq_0 = δX, through the exact K,
            dq = self.geometry.initial_tangent()   # and the rigid spin's velocities δv_0 = ω × δX, through C
            moved = self.geometry.initial_velocity_tangent()
        started = dv if moved is None else dv + moved   # δv_0
        states = self._controller_states()
        if states is not None:   # δS_0 held for ∂r/∂p at the start, δf_0 by the start's δq_0, δv_0
            carried = {**carried, **states.start(state, dq, started)}
        sampled = self._sampled_controllers()
        if sampled is not None:  # the sample at t = 0 (before the start) of the start's δq_0, δv_0: its held δy
            carried = {**carried, **sampled.start(state, k, dq, started)}
        damping = ev.combined_csr(0.0, 1.0, 0.0) if isinstance(mass, CSR) else ev.combined(0.0, 1.0, 0.0)
        rhs = self.residual_derivatives(state, 1.0, inertia=True) + _times(damping, dv)
        if moved is not None:
            dv = started
            rhs = rhs + self._matrices(state)[2] @ dq + _times(damping, moved)
        if states is not None:
            self.controllers.held = {}
        if split.n_massless == 0:   # Δ = −M⁻¹r: one factorization for every column
            solved = solve_linear_csr(mass, rhs) if isinstance(mass, CSR) else solve_linear(mass, rhs)
            dvdot = -np.asarray(solved).reshape(n, k)
        else:
            dvdot = np.column_stack([consistent_acceleration(model, SimpleNamespace(residual=rhs[:, c],
                                                                                    combined=ev.combined))
                                     for c in range(k)])
        return {**carried, "dq": dq, "dv": dv, "dvdot": dvdot, "da": dvdot.copy()}

    def start_moves(self) -> tuple | None:
        """(δq_0, δv_0) (n, k) of the start as :meth:`start` takes them (δq_0 = δX of geometry parameters, δv_0 the
        ``initial_velocity`` parameters' and the rigid spin's ω × δX), or None where no parameter moves the start:
        what the sample at t = 0 and the states' δf_0 read through their sensors (the adjoint's
        ``start_transposed``)."""
        dv = self._initial_velocities()
        dq = np.zeros_like(dv)
        if self.geometry is not None:
            dq = self.geometry.initial_tangent()
            dv = dv + self.geometry.initial_velocity_tangent()
        return (dq, dv) if np.any(dq) or np.any(dv) else None

    def _start_mass(self, ev) -> tuple:
        """(M, its split into directions with and without inertia) at the start, M as the run's own start takes
        it (:func:`latdyn.step.integrators.consistent_acceleration`): where that start needs no SciPy (a model
        above the dense LU's size, without rigid links, every direction with inertia) a
        :class:`latdyn.numerics.csr.CSR` — the same entries, products and factors as SciPy's CSR, so the same
        start to the bit (latdyn.numerics.csr, :func:`latdyn.assembly.factorization.solve_linear_csr`) without
        importing scipy.sparse —, else :meth:`Evaluation.combined`'s (dense up to DENSE_LIMIT coordinates)."""
        if start_without_scipy(self.model):
            mass = ev.combined_csr(1.0, 0.0, 0.0)
            split = split_inertia(self.model, mass)
            if split.n_massless == 0:
                return mass, split
        mass = ev.combined(1.0, 0.0, 0.0)
        return mass, split_inertia(self.model, mass)

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
                  or GEOMETRY_KEY.match(key)
                  or (_HINGE_KEY.match(key) and _HINGE_KEY.match(key)["law"] == "stiffness")
                  or _CABLE_KEY.match(key) or (_GUIDE_KEY.match(key) and _GUIDE_KEY.match(key)["law"] == "stiffness")
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
        (laws in time with events: :class:`ExplicitTime`). A kernel variant generated before
        ``beam_stiffness_D_q`` is refused here, at the start, where the events' H would need it
        (:func:`latdyn.analyses.weight_derivative.needs_the_kernel`)."""
        model, scene = self.model, self.scene
        if needs_the_kernel(scene, model):
            refuse_without_kernel(self.assembler)
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
        """The step from ``old`` landed on the first event it crosses or reaches (latdyn.timeloop.landing
        first_event, the rule of the run without sensitivities): a latch or stop to |θ − θ_event| ≤ :data:`LANDING`
        · max(1, |θ_event|), a cable element's change of side to a gap |g| ≤ :data:`LANDING` · EA, where the
        derivative of the event time assumes it exactly, by the search of the run without sensitivities
        (latdyn.timeloop.landing.land) to this tolerance, at most :data:`LANDING_PASSES` retries; ``step(h)`` takes
        a step of size h from ``old``. Returns (state, stats, h, lands) of the last converged step.

        A cable landing whose step ends with another element past its change (the trial's linear interpolation
        put that one later: a reel paying out a massive cable, its elements' gaps far from linear in the step's
        size) lands again, on that element, from the step kept (at most :data:`RELANDINGS` times): the earlier
        change is the event (a reel of L + 0.3 t on tests/test_sensitivity_step_sequence.py's mast was refused as
        "several cable elements changing at one instant", one element at −6.6e-12, another at −0.36)."""
        event = first_event(self.assembler, old, attempt[0], cables=self.cables is not None)
        if event is None:
            return attempt
        best, gap, tight = self._land_once(step, old, attempt, event)
        for _ in range(RELANDINGS):
            if event.hinge is not None or best is attempt or not cable_crossings(self.assembler, old, best[0]):
                break
            best, gap, tight = self._land_once(step, old, best)
        if abs(ga_start := gap(old)) <= tight and abs(gap(best[0])) > tight:
            self._refuse_change_at_step_start(old, ga_start)
        if best is not attempt and not self._ends_on_a_change(old, best[0]):
            self._refuse_landing_short(old, attempt, best, event, gap)
        return best

    def _land_once(self, step, old, attempt, event=None):
        """One landing's search of :meth:`land` from the step ``attempt`` onto ``event`` (None: the first event of
        the step, which exists): (the last converged step, the gap function it landed on, its tolerance)."""
        if event is None:
            event = first_event(self.assembler, old, attempt[0], cables=self.cables is not None)
        gap, tight = event.gap(self.assembler), event.tight(self.assembler)
        return land(step, old, attempt, gap, tight, LANDING_PASSES), gap, tight

    def _ends_on_a_change(self, old, new) -> bool:
        """Whether the step old → new ends on an event its derivative takes (a latch, a stop, a compliant
        stop's onset, a cable element's change of side)."""
        if self._event(old, new) is not None or self._contact_onset(old, new) is not None:
            return True
        return self.cables is not None and self.cables.event(old, new) is not None

    def _refuse_landing_short(self, old, attempt, best, event, gap):
        """A landing whose search kept a shorter step that reaches no event (Newton failed on its next retry,
        or the passes ran out short of it): that step's size is the search's, a function of p through the
        trials' ends, which its derivative does not take (it takes an event's time, a grid point or the
        step control's size). The trial's crossing may be Newton's, not the motion's (fuzzer seed 16 case 16:
        a trial of 0.03 s ended at θ = −6.17 past a stop at −0.597, the shorter steps near −0.03, their
        sizes' δh left out put rows 1.8e-2 off Richardson differences stable in h = 1e-3..1e-4). Refused
        (SolverError) when it happens, naming the joint or cable."""
        if event.hinge is not None:
            k, at = event.hinge, event.at
            what = f"the {'lock_at' if at == self.model.hinges[k].lock_at else 'stop'} {at:g} of {self.model.hinges[k].name}"
        else:
            what = "a cable element's change of side"
        raise SolverError(
            f"the sensitivities at t = {float(old.t):.6g} meet a step shortened toward {what} that no shorter step "
            f"reached: the trial of {attempt.h:.3g} s crossed it (its gap {gap(attempt.new):.3g} at the end), the "
            f"step kept is {best[2]:.3g} s (its gap {gap(best[0]):.3g}), the landing's search stopped short (Newton "
            "failed on its next retry, or its passes ran out), and that step's size, a function of p through the "
            "search, is not differentiated (docs/parameters.md, \"Sensitivities through events\"); a smaller "
            "solve.dt may keep the trial from crossing")

    def _refuse_change_at_step_start(self, old, gap_start: float):
        """A landing that cannot land because the change sits at the step's start (its gap zero there: a
        cable whose ends are at its rest length at t = 0, the default rest_length, and move apart; an
        element that turns back at the instant it changed side): the
        step holds the element on its old side to its end, and the event time's derivative, computed as if
        the step ended on the change, was O(1) wrong (benchmarks/fuzz_sensitivities.py seed 1 case 30:
        tests/test_sensitivities_fuzz_finds.py). Refused when it happens (SolverError)."""
        names = []
        if self.model.cables is not None:
            gaps, _ = cable_gaps(self.assembler, old)
            cables = self.model.cables
            names = sorted({f"cables.{cables.names[cables.cable[e]]}" for e in range(len(gaps))
                            if abs(gaps[e]) <= LANDING * float(cables.EA[e])})
        what = ", ".join(names) or "a joint's event"
        raise SolverError(f"{self.scene.file}: solve.sensitivities: the sensitivities at t = {float(old.t):.6g} meet "
                          f"{what} changing side at the start of a step, which no step lands on (its gap "
                          f"{gap_start:.3g} there: a cable at its rest length at t = 0, the default rest_length, that "
                          "goes taut at once, or an element turning back at the instant it changed side): its event "
                          "time's derivative is not computed; expected each change of side landed on by a step of its "
                          f"own: a rest length a little off the ends' distance at t = 0, or a solve.dt smaller than "
                          f"{self.scene.solve.dt:g} that resolves an element's change and its turning back "
                          "(docs/parameters.md, \"Cables\")")

    # ------------------------------------------------------------------ a step
    def step(self, carried: dict, old, new, h: float, a_old: np.ndarray, a_new: np.ndarray,
             lands: bool = True) -> dict:
        """The carried sensitivities after the accepted step ``old`` → ``new`` of size ``h`` (``a_old``,
        ``a_new``: the algorithmic accelerations before and after it; ``lands``: it ended on the time
        grid), with the derivative of its size (module docstring, "Events") and the jump of the event it
        ends on, if any, taken before the events renumber the coordinates (:meth:`after_events`)."""
        model = self.model
        n, k = model.n_dofs, len(self.names)
        self._stuck_before, self._candidates = model.stuck.copy(), {}
        self._resting_before, self._releases = model.resting.copy(), {}
        self.held = self._held(carried)
        if k == 0:
            return {**carried, "h": h}
        if n == 0:   # nothing free (all latched): no event can end the step; the step's time still moves with p
            self._release_candidates(carried, new)   # a hinge resting on its stop may be released there
            dh = -carried["dt"] if lands else np.zeros(k)   # landing on the grid, or the nominal step after a restart
            # the work accounts still move: a prescribed motion's drive reaction with its ∂r_d/∂p
            return external_work_step(self, carried, {**carried, "dt": carried["dt"] + dh, "dh": dh, "dh_step": dh,
                                                      "h": h}, old, new, h)
        columns, states = self.step_columns(carried, old, new, h, a_old, a_new)
        event = self._event(old, new)
        cable = self._cable_event(old, new, event)
        if cable is None:   # a rest's projection comes at the step's end, whose size is the step control's
            landed = None if event is not None and event[1] == "rest" else event
            dh = self._step_size_derivative(carried, h, lands, landed or self._contact_onset(old, new), columns["dq"])
        else:
            dh = self.cables.step_size_derivative(new, cable[0], columns["dq"], columns["dv"], k,
                                                  started=carried["dt"])
        total = {key: value[:, :k] + value[:, k:] * dh for key, value in columns.items()}   # + the column of h times δh
        before, carried = carried, {**carried, **total, "dt": carried["dt"] + dh, "dh": dh, "dh_step": dh, "h": h,
                                   "pending": None}
        carried = external_work_step(self, before, carried, old, new, h)   # latdyn/analyses/energy_sensitivities.py
        if self.scene.solve.adaptive:   # what the accepted step's error estimate is differentiated from (resized)
            carried["accepted_trial"] = adaptive_sensitivities.accepted_trial(new, a_new - a_old, total, before, dh, h)
        if states is not None:   # δS with the step size's part (an event's δh)
            carried = {**carried, **states.after_step(new, carried["dq"], dh, carried["dt"], carried["dv"])}
        if np.any(self.held) and (cable is not None or event is not None):
            self._refuse_sticking(new, "another event (a latch, a stop, a cable's change) comes while a joint is stuck",
                                  int(np.flatnonzero(self.model.stuck)[0]))
        if cable is not None:
            return self._after_cable_event(carried, new, *cable)
        if event is None:
            self._stick_candidates(carried, old, new)
            self._release_candidates(carried, new)
            return carried
        self.time_shift = carried["dt"]   # the impulse's weight at the event, moved in time by δt_e
        if states is not None:   # the states kept through the jump: δS held in ∂r/∂p there
            states.hold(carried)
        try:
            return self._jump(carried, new, *event)
        finally:
            self.time_shift = None
            if states is not None:
                self.controllers.held = {}

    def step_columns(self, carried: dict, old, new, h: float, a_old: np.ndarray, a_new: np.ndarray):
        """The derivative of the converged step ``old`` → ``new`` of size ``h`` before its size's derivative
        is known: ({dq, dv, dvdot, da} (n, k + 1), the continuous controllers' states or None), k parameter
        columns and one of a unit change of h (module docstring); one solve with the step's exact matrix."""
        model, p = self.model, self.params
        n, k = model.n_dofs, len(self.names)
        am, af, gamma, beta = p.alpha_m, p.alpha_f, p.gamma, p.beta
        beta_p, gamma_p = (1 - am) / (h * h * beta * (1 - af)), gamma / (h * beta)
        v_old = free_velocity(model, old)
        # the step's own increment hΔq, its rotations' exp and tangent operator
        increment = h * (v_old + h * (0.5 - beta) * a_old + h * beta * a_new)
        turn, tangent = self._rotation_operators(increment)
        # k parameter columns and one of a unit change of the step size (its derivative, δh = 1): the
        # predicted parts δa⁰, δq⁰, δv⁰ (module docstring) in one native call
        step = _StepColumns(self, n, k, (h, am, af, gamma, beta), turn, tangent)
        da0, dq0, dv0 = step.predict(v_old, a_old, a_new, *(carried[key] for key in ("dq", "dv", "dvdot", "da")))
        if self._sampled_controllers() is not None:   # the held δy of the last sample (checkpoints carry it)
            self._sampled_controllers().held = carried["sampled_dy"]
        states = self._controller_states()
        if states is not None:   # the states' held part for ∂r/∂p; the matrix with the states condensed as in the step
            states.begin_step(carried, new, h)
        with states.condensed(carried, h) if states is not None else nullcontext():
            solve = self._step_system(new, tangent, beta_p, gamma_p)
            # ∂r/∂t through the prescribed motions with the states condensed as in the step: the coupling blocks'
            # total dy/ds, S_{n+1} moving with a sensor the motion moves (a cable's length from a prescribed anchor)
            moved = (self.explicit_time.through_prescribed(new) if states is not None and self.explicit_time is not None
                     and self.explicit_time.prescribed else None)
        explicit = np.hstack([self.residual_derivatives(new, 1.0, inertia=True), np.zeros((n, 1))])
        if states is not None:   # the states' derivative by the step's size moves the outputs (an event's δh)
            explicit[:, k] += self._on_free_coordinates(new, states.by_step_size(new)[:, None])[:, 0]
        self._add_time_columns(explicit, None if self.explicit_time is None else self.explicit_time(new, prescribed=moved),
                               carried["dt"])
        z = np.asarray(solve(explicit, dq0, dv0)).reshape(n, k + 1)
        return step.update(z, beta_p, gamma_p), states

    def rejected(self, carried: dict, progress, attempt, integrator, control) -> dict:
        """``carried`` with the derivative of the next trial's size after the error estimate rejected the
        trial ``attempt`` (latdyn/analyses/adaptive_sensitivities.py)."""
        return adaptive_sensitivities.rejected(self, carried, progress, attempt, integrator, control)

    def halved(self, carried: dict) -> dict:
        """``carried`` with the derivative of a trial that takes half the way to the next grid point (adaptive
        steps; latdyn/analyses/adaptive_sensitivities.py)."""
        return adaptive_sensitivities.halved(self, carried)

    def resized(self, carried: dict, control, lands: bool | None = None, integrator=None) -> dict:
        """``carried`` with the derivative of the next step's size (``carried["dh_next"]``) after an accepted step
        (``lands`` None; adaptive steps: its error estimate's derivative from ``integrator``'s joint groups) or a
        trial Newton did not converge (``lands``: whether it landed on the grid), as ``control.resize`` says
        the size follows from the step before, on fixed and adaptive steps alike
        (latdyn/analyses/adaptive_sensitivities.py)."""
        return adaptive_sensitivities.resized(self, carried, control, lands, integrator)

    def _step_system(self, new, tangent, beta_p: float, gamma_p: float):
        """``solve(explicit, dq0, dv0)`` at the step's end ``new``: z = S⁻¹(−(explicit + K δq⁰ + C δv⁰)) with the
        exact iteration matrix S = β′M + γ′C + K J and the exact C and K (module docstring), M, C and K
        evaluated here (inside the controllers' condensation, where the step has one), S factorised in the
        call. Without rigid links and guides M, C and K are the values of the assembler's pattern and S is
        summed, factorised and the columns formed and solved in one native call
        (:meth:`latdyn.analyses.step_matrix.ExactStepMatrix.solve_step`, :meth:`_step_matrix`); with them, the
        same call with M, C and K of the compiled step's reduction (``Assembler.linked_exact_matrix_values``, the loop
        of steps' own: dense on the full pattern, or above DENSE_LIMIT coordinates or on a sparse storage on the
        iteration matrix's reduced pattern), or where that is None the reduction's matrices (:meth:`_matrices`)
        summed by SciPy.
        A singular matrix raises SolverError."""
        def singular():
            return SolverError(f"the sensitivities at t = {new.t:.6g} need the step's exact iteration matrix, "
                               "which is singular there")

        linked = self.model.links is not None
        # with rigid links or guides the compiled step's reduction (csrc/linked_matrices.c), as the loop of steps;
        # None: SciPy's below
        values = (self.assembler.linked_exact_matrix_values(new) if linked else
                  self.assembler.exact_matrix_values(new))
        if values is not None:
            step_matrix = self._step_matrix(tangent.slots, dense=linked)

            def solve(explicit, dq0, dv0):
                try:
                    return step_matrix.solve_step(values, tangent.blocks, beta_p, gamma_p, explicit, dq0, dv0)
                except np.linalg.LinAlgError:
                    raise singular() from None
            return solve
        matrix, C, K = self._reduced_step_matrix(new, tangent, beta_p, gamma_p)
        try:
            solver = factorization_for(matrix).factor(matrix)
        except np.linalg.LinAlgError:
            raise singular() from None
        return lambda explicit, dq0, dv0: solver.solve(-(explicit + K @ dq0 + C @ dv0))

    def _reduced_step_matrix(self, new, tangent, beta_p: float, gamma_p: float) -> tuple:
        """(β′M + γ′C + K J, C, K) with the reduction's matrices (:meth:`_matrices`: rigid links, guides), summed
        by SciPy or NumPy as K is stored; the forward step factorises it, the adjoint its transpose."""
        M, C, K = self._matrices(new)
        J = tangent.matrix if issparse(K) else tangent.matrix.toarray()
        return beta_p * M + gamma_p * C + K @ J, C, K

    def _add_time_columns(self, explicit: np.ndarray, rate: np.ndarray | None, started: np.ndarray) -> None:
        """Add to the step's ∂r/∂p columns ``explicit`` (n, k + 1) the explicit time dependence at its end
        t_{n+1} = t_n + h (module docstring, "Laws in time"): ∂r/∂t δt_n in the parameters' columns
        (``started`` = δt_n: the step starts where the events before it put it) and ∂r/∂t in the step
        size's, so that the total carries ∂r/∂t δt_{n+1} (δt_{n+1} = δt_n + δh)."""
        if rate is None:   # ``rate``: ∂r/∂t at the step's end (ExplicitTime), None without laws in t
            return
        explicit[:, :-1] += np.outer(rate, started)
        explicit[:, -1] += rate

    def _controller_states(self):
        """The continuous controllers' states differentiated
        (:class:`latdyn.analyses.sensitivities.ControllerStates`), or None without."""
        return None if self.controllers is None else self.controllers.states

    def _sampled_controllers(self):
        """The sampled controllers differentiated (:class:`latdyn.analyses.sensitivities.SampledTerms`), or
        None without."""
        return None if self.controllers is None else self.controllers.sampled

    def after_sample(self, carried: dict, state, due: list) -> dict:
        """``carried`` after the sample at ``state`` of the sampled controllers named in ``due`` and the
        restart after it (the time loop's ``_restart_after_sample``: v̇ made consistent with the new held
        outputs, M v̇ + r(q, v, t) = 0, a = v̇), differentiated: δy_k and δS_{k+1}
        (:meth:`latdyn.analyses.sensitivities.SampledTerms.sample`), then
        δv̇ = δa = −M⁻¹ (K δq + C δv + ∂r/∂p) at the restarted state, M, C and the exact K of
        :meth:`_matrices`. A model with directions without inertia is refused there (its restart splits
        them off: not differentiated yet)."""
        model, k = self.model, len(self.names)
        if model.n_dofs == 0 or k == 0:
            return carried
        carried = {**carried, **self._sampled_controllers().sample(carried, state, carried["dq"], due)}
        M, C, K = self._matrices(state)
        self.refuse_massless_restart(state, M)
        states = self._controller_states()
        if states is not None:   # the continuous controllers' states kept through the restart: δS held
            states.hold(carried)
        rhs = self.residual_derivatives(state, 1.0, inertia=True) + K @ carried["dq"] + C @ carried["dv"]
        if states is not None:
            self.controllers.held = {}
        dvdot = -np.asarray(solve_linear(M, rhs)).reshape(model.n_dofs, k)
        return {**carried, "dvdot": dvdot, "da": dvdot.copy()}

    def refuse_massless_restart(self, state, M) -> None:
        """Refuse (SceneError naming solve.sensitivities) the restart after a sample at ``state`` where M splits off
        directions without inertia (not differentiated yet)."""
        split = split_inertia(self.model, M)
        if split.n_massless:
            raise SceneError(self.scene.file, "solve.sensitivities",
                             f"the restart after a sampled controller's sample at t = {state.t:.6g} splits off "
                             f"{split.n_massless} direction(s) without inertia, which is not differentiated yet; "
                             "expected beams with rotary inertia (rhoIy, rhoIz) and bodies with mass and inertia "
                             "(docs/parameters.md, \"Controllers\")")

    def _event(self, old, new):
        """(hinge, kind, restitution) of the latch or stop impact the events will apply at the end of
        the step old → new (:func:`latdyn.timeloop.events.hinge_events`), or None; several at once, or
        a joint resting on its stop, are refused (SolverError): their derivative is not that of one event."""
        model = self.model
        reached, crossing = lock_events(self.assembler, old, new)
        latched = reached + [j for j, _ in crossing]
        hits, _, restitution, rests = stop_hits(self.assembler, new, old)
        if not latched and not hits:
            return None
        if len(latched) + len(hits) > 1:
            raise SolverError(f"the sensitivities at t = {new.t:.6g} meet several hinge events at one instant, whose "
                              "derivative is not that of one event (docs/parameters.md, \"Sensitivities through "
                              "events\")")
        if latched:
            return int(latched[0]), "latch", 0.0
        if rests[0]:   # started the step on its stop, ends it beyond: projected back at the step's end (_projected)
            self._refuse_what_a_rest_moves(new, int(hits[0]))
            return int(hits[0]), "rest", 0.0
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

    def _cable_event(self, old, new, hinge_event):
        """(element, the whole cable's change or None) of the cable element that turns over at the end of the
        step old → new (:meth:`CableSensitivities.event`), or None; with a hinge event in the same step,
        refused (SolverError)."""
        if self.cables is None:
            return None
        cable = self.cables.event(old, new)
        if cable is not None and hinge_event is not None:
            raise SolverError(f"the sensitivities at t = {new.t:.6g} meet a cable's change and a hinge event at one "
                              "instant, whose derivative is not that of one event (docs/parameters.md, \"Cables\")")
        return cable

    def _after_cable_event(self, carried: dict, new, e: int, change) -> dict:
        """``carried`` after a step that ended on cable element ``e``'s change: the event recorded when the
        whole cable changed, and the steps that follow of sizes fixed by the nominal step (the time loop
        restarts at dt, or at a fraction of it after a damped cable's jump of tension), not by this one's
        (δh of the next step 0 unless it lands on the grid)."""
        record = self.cables.record(new, e, change, carried["dt"], self.names)
        events = carried["events"] + ([record] if record is not None else [])
        carried = {**carried, "events": events, "dh": np.zeros(len(self.names))}
        miss = abs(float(cable_gaps(self.assembler, new)[0][e])) / float(self.model.cables.EA[e])
        if miss > LANDING_MISSED:   # the derivative assumes the step on the change: flagged (finish)
            name = self.model.cables.names[self.model.cables.cable[e]]
            carried = {**carried, "missed": carried.get("missed", []) + [(f"cables.{name}", float(new.t), miss)]}
        return carried

    def _step_size_derivative(self, carried: dict, h: float, lands: bool, event, dq: np.ndarray) -> np.ndarray:
        """δh (k,) of the accepted step: the event's time makes the hinge's angle its lock_at or stop
        exactly, δθ_p + δθ_h δh = 0 (δθ_h = ∂θ_{n+1}/∂h); a step landing on the time grid ends at a fixed
        time, δh = −δt_n; any other is the size the step control chose for the trial, differentiated
        (``carried["dh_next"]``, :meth:`resized`: the nominal step's 0, a step doubling back 2 δh_prev, a trial
        cut after Newton failed half its trial's δh, −δt_n/2 where that trial landed on the grid)."""
        k = len(self.names)
        if event is not None:
            dof = self.model.hinge_dofs[event[0]]
            return -dq[dof, :k] / dq[dof, k]
        if lands:
            return -carried["dt"]
        return carried.get("dh_next", np.zeros(k))

    # ------------------------------------------------------------------ the jump at an event
    def _jump(self, carried: dict, new, hinge: int, kind: str, restitution: float) -> dict:
        """The velocities' sensitivities through the impulse of the latch or stop at ``new`` (before the
        jump; module docstring, "Events"): with W = M + dt²K, X = W⁻¹N, Δv = X(NᵀX)⁻¹(−(1+e)Nᵀv⁻),

            w = δv⁻ − W⁻¹ δ(W)Δv,      δv⁺ = w + X(NᵀX)⁻¹(−e Nᵀδv⁻ − Nᵀw),

        δq unchanged (the event time made δθ = 0 on the stop, so projecting onto it moves nothing to first
        order). The free coordinates are about to be renumbered (a latch): δq and δv are kept on the nodes
        and hinges until :meth:`after_events`."""
        model = self.model
        dv_plus = self._impulse(carried, new, hinge, restitution)
        if kind == "rest":   # no event of the run's (nor its time): the projection's δq, the impulse's δv, a restart
            return {**carried, "pending": {"kind": "stop", "hinge": hinge,
                                           "dq": self._on_nodes(self._projected(carried, new, hinge)),
                                           "dv": self._on_nodes(dv_plus),
                                           "vdot": self._on_nodes(free_acceleration(model, new)[:, None])[0],
                                           "dvdot": self._on_nodes(carried["dvdot"]), "restarts": 1, "free_restarts": 0}}
        dt_event = carried["dt"]
        record = {"joint": model.hinges[hinge].name, "kind": kind, "t": float(new.t),
                  "dt": {name: float(dt_event[c]) for c, name in enumerate(self.names)}}
        at = model.hinges[hinge].lock_at if kind == "latch" else min(model.hinges[hinge].limits,
                                                                   key=lambda stop: abs(new.theta[hinge] - stop))
        miss = abs(float(new.theta[hinge]) - at) / max(1.0, abs(at))
        if miss > LANDING_MISSED:   # the derivative assumes the step on the event: flagged (finish)
            carried = {**carried, "missed": carried.get("missed", []) + [(record["joint"], record["t"], miss)]}
        # the accelerations before the events and their derivative: the stop's restart weighs with W at them
        return {**carried, "events": carried["events"] + [record],
                "pending": {"kind": kind, "hinge": hinge, "dq": self._on_nodes(carried["dq"]),
                            "dv": self._on_nodes(dv_plus),
                            "vdot": self._on_nodes(free_acceleration(model, new)[:, None])[0],
                            "dvdot": self._on_nodes(carried["dvdot"]), "restarts": 1, "free_restarts": 0}}

    def _impulse(self, carried: dict, new, hinge: int, restitution: float) -> np.ndarray:
        """δv⁺ (n, k) through the impulse on ``hinge`` at ``new`` (before the jump; :meth:`_jump`'s formula)."""
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
        weight = self._weight_derivative(new, change, carried["dq"], scale, rates=(carried["dv"], carried["dvdot"]))
        w = dv_minus - np.asarray(solve_linear(W, weight))
        w = w.reshape(dv_minus.shape)
        return w + X @ np.linalg.solve(NtX, -restitution * (N.T @ dv_minus) - N.T @ w)

    def _projected(self, carried: dict, new, hinge: int) -> np.ndarray:
        """δq⁺ (n, k) of the projection that puts ``hinge``, resting on its rigid stop, back on it at the end of a
        step it started on the stop and ended beyond (latdyn/timeloop/events.py ``hinge_stops``; no landing: the
        overshoot d = θ − stop is not 0). The run moves q⁺ = q ∘ exp(Δ), Δ = −X μ, μ = (NᵀX)⁻¹ d, X = W⁻¹N,
        W = M + dt²K at the step's end (the impulse's). Differentiated, with δX μ = −W⁻¹ δ(W)(Xμ) (the impulse
        weight's derivative along (δq, δp), :meth:`_weight_derivative`) and δd = Nᵀδq:

            δΔ = −(I − X(NᵀX)⁻¹Nᵀ) δX μ − X(NᵀX)⁻¹ Nᵀδq,     δq⁺ = R δq + J δΔ,

        R = exp(skew Δπ), J = dexp(Δπ) on the rotation coordinates (the step's update, :meth:`_rotation_operators`),
        so that Nᵀδq⁺ = 0: the hinge's angle is the stop's (the term δ[X(NᵀX)⁻¹](θ − stop) is δX μ's)."""
        W, N, X, NtX, moved = self._projection(new, hinge)
        dq, dt = carried["dq"], self.scene.solve.dt
        weight = self._weight_derivative(new, moved, dq, dt * dt, rates=(carried["dv"], carried["dvdot"]))
        dX_mu = -np.asarray(solve_linear(W, weight)).reshape(dq.shape)
        d_delta = -dX_mu + X @ np.linalg.solve(NtX, N.T @ dX_mu) - X @ np.linalg.solve(NtX, N.T @ dq)
        turn, tangent = self._rotation_operators(-moved)
        return turn(dq) + tangent(d_delta)

    def _projection(self, new, hinge: int) -> tuple:
        """(W, N, X, NᵀX, Xμ) of the projection that puts ``hinge`` back on its rigid stop at ``new``
        (:meth:`_projected`, its transpose ``AdjointSensitivities._projected_transposed``): W = M + dt²K at the step's
        end, N the hinge's direction, X = W⁻¹N, Xμ = X(NᵀX)⁻¹(θ − stop) = −Δ."""
        model, dt = self.model, self.scene.solve.dt
        N = hinge_directions(model, [hinge])
        W = self.assembler.evaluate(new, matrices=True).combined(1.0, 0.0, dt * dt)
        X = np.asarray(solve_linear(W, N)).reshape(N.shape)
        NtX = N.T @ X
        stop = min(model.hinges[hinge].limits, key=lambda at: abs(new.theta[hinge] - at))
        moved = (X @ np.linalg.solve(NtX, np.array([new.theta[hinge] - stop]))).reshape(-1)   # X μ = −Δ
        return W, N, X, NtX, moved

    def _refuse_what_a_rest_moves(self, new, j: int) -> None:
        """The models and probes where a projection onto a stop at a step's end (:meth:`_projected`) is not
        differentiated: refused (:meth:`_refuse_resting`)."""
        self._refuse_a_linked_rest(new, j)
        if any(is_energy_or_momentum(probe) for probe in self.probes) or self._controller_states() is not None \
                or self._sampled_controllers() is not None:
            self._refuse_resting(new, j, "a hinge that rests on its stop is put back on it at a step's end beside "
                                         "energy or momentum probes or controllers with states or sampled ones "
                                         "(their terms of the projection are not carried)")

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

    def _at_rest_and_accelerated(self, state, w: np.ndarray) -> tuple:
        """``state`` at rest (rates and accelerations 0) and the same with the accelerations ``w`` on the free
        coordinates, the dependent nodes completed: ∂M/∂p w is ∂r/∂p at the second less at the first (the
        inertia forces are linear in the accelerations; :meth:`_weight_derivative` and its transpose)."""
        at_rest = state.copy()
        for name in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot"):
            getattr(at_rest, name)[...] = 0.0
        accelerated = at_rest.copy()
        unpack_free(self.model, w, accelerated.a, accelerated.alpha, accelerated.theta_ddot)
        self.assembler.complete_links(at_rest)
        self.assembler.complete_links(accelerated)
        return at_rest, accelerated

    def _weight_derivative(self, state, w: np.ndarray, dq: np.ndarray, scale: float,
                           mass: bool = True, rates=None) -> np.ndarray:
        """δ(W w) (n, k) for W = M + scale·K (``mass``) or scale·K at ``state`` (K the evaluation's, without
        the inertia tangent, as the impulse uses it), along each column's (δq, δp): H δq with H = ∂(W w)/∂q
        generated (:func:`latdyn.analyses.weight_derivative.configuration_tangent_of_weight`: the elements', joint
        bodies' (their weight's too), hinges', loads' and cables' parts and most continuous controllers' couplings
        from the generated kernels, the couplings not generated and the blocks of the loads their controllers drive
        differenced along the coordinates they are on), ∂M/∂p w exactly (the inertia forces
        are linear in the accelerations: ∂r/∂p at accelerations w less at none, at rest), scale ∂K/∂p w
        (:meth:`_stiffness_derivative`: the section values', hinges', loads', joint bodies' and cables' EA and damping
        parts generated, the rest differenced along w).

        With guides or rigid links (their reduction, latdyn/assembly/linked.py) K also holds the geometric term
        ∂Pᵀ/∂q · r_all, with r_all at the state's rates: ∂(W w)/∂q δq moves the free rates along ``rates`` =
        (δv, δv̇) too (the dependent ones following; :meth:`_linked_weight_derivative`: exact but for the links'
        second derivatives and the blocks not generated), and ∂K/∂p adds that term of the inertia forces'
        ∂r_all/∂p (:meth:`_geometric_derivative`, exact)."""
        model, assembler = self.model, self.assembler
        linked = model.links is not None
        if linked:
            out = self._linked_weight_derivative(state, w, dq, scale, mass, rates)
        else:
            out = times(configuration_tangent_of_weight(assembler, state, w, scale, mass, self.coordinate_step()), dq)
            if rates is not None and self.stiffness_moves_with_rates(state):   # W moves with δv too
                out += scale * self._stiffness_by_rates(state, w, rates[0])
        if not np.any(w):
            return out
        out += scale * self._stiffness_derivative(state, w)
        if linked:
            out += scale * self._geometric_derivative(state, w)
            if self._holds_through_links():   # the held angles move K w
                out += scale * self._linked_held_stiffness_along(state, w)
        if mass:
            at_rest, accelerated = self._at_rest_and_accelerated(state, w)
            out += (self.residual_derivatives(accelerated, 1.0, inertia=True)
                    - self.residual_derivatives(at_rest, 1.0, inertia=True))
        return out

    def stiffness_moves_with_rates(self, state) -> bool:
        """Whether the evaluation's K at ``state`` moves with the free rates (a model without rigid links or guides):
        :func:`latdyn.analyses.weight_derivative.stiffness_moving_with_rates`, two evaluations, which the event's
        weight derivative asks before :meth:`_stiffness_by_rates` (generated, or 2k evaluations where a block not
        generated moves; the adjoint's transpose 2n)."""
        moving = stiffness_moving_with_rates(self.assembler, state)
        self._rates_moving = (state, moving)   # which blocks: :meth:`_stiffness_by_rates` at the same state
        return bool(moving)

    def _stiffness_by_rates(self, state, w: np.ndarray, dv: np.ndarray) -> np.ndarray:
        """∂(K w)/∂v δv (n, k) at ``state`` (a model without rigid links or guides), where
        :meth:`stiffness_moves_with_rates`: the evaluation's K depends on the free rates where a term does (a damped
        cable's geometric terms c ℓ̇, a hinge law whose ∂τ/∂θ holds θ̇, a compliant stop's damping in contact, a
        controller's couplings), and the impulse's weight M + dt² K moves with them. Generated
        (latdyn/analyses/weight_derivative.py, "Along the rates"): the hinges' ∂²f/∂θ∂θ̇, the couplings and driven
        loads of a controller of angles and rates by its mixed second derivatives, and of the other controllers whose
        second derivatives are generated (points' velocities, tensions, section forces, joints' forces, inputs,
        states, chains) through their sensors' rate derivatives (:func:`rates_tangent_of_weight`), the damped taut
        cables' (:func:`cable_stiffness_by_rates`, K_c affine in the rates); the blocks not generated
        (:func:`rates_rest_needed`: a hinge law whose slope does not parse back, the remaining controllers' couplings
        and loads) a
        central difference of their K w along each column's δv (:func:`rates_rest_product`; the step relative: the
        rates' own size, or 1), no evaluation where there is none."""
        model, assembler = self.model, self.assembler
        held = self.__dict__.get("_rates_moving")
        moving = held[1] if held is not None and held[0] is state else stiffness_moving_with_rates(assembler, state)
        out = times(rates_tangent_of_weight(assembler, state, w), dv)
        if "loads and cables" in moving:
            out += cable_stiffness_by_rates(assembler, state, w, dv)   # the damped cables' c ℓ̇: generated
        if not rates_rest_needed(assembler, moving):
            return out
        v0 = free_velocity(model, state)

        def product(v):
            moved = state.copy()
            unpack_free(model, v, moved.v, moved.w, moved.theta_dot)
            return rates_rest_product(assembler, moved, w)

        for c in range(dv.shape[1]):
            size = float(np.max(np.abs(dv[:, c]), initial=0.0))
            if size == 0.0:
                continue
            eta = WEIGHT_STEP * max(float(np.max(np.abs(v0), initial=0.0)), 1.0) / size
            out[:, c] += (product(v0 + eta * dv[:, c]) - product(v0 - eta * dv[:, c])) / (2 * eta)
        return out

    def by_sections_only(self) -> np.ndarray:
        """(k,) bool: the parameters whose every use is a section value (SCENE.md ``sections.NAME.EA`` … ``GAz``): their
        (∂K/∂p) w at an event is generated (:meth:`_stiffness_derivative`). None where ∂r/∂p carries more than the
        parameters' own terms, whose derivative along w the difference of ∂r/∂p takes with them: a state moved in time
        (∂r/∂t δt_e), joints friction holds (K's columns of the held angles times their δθ), controllers (their
        states' and held outputs' terms), and rigid links or guides (the reduction's geometric term)."""
        shifted = self.time_shift is not None and self.explicit_time is not None and np.any(self.time_shift)
        held = self.held is not None and np.any(self.held)
        if shifted or held or self.scene.controllers or self.model.links is not None:
            return np.zeros(len(self.names), bool)
        found = self.__dict__.get("_sections_only")
        if found is None:
            params = self.scene.parameters
            found = np.array([all(_SECTION_KEY.match(key) for key in params.depending_on(name)) for name in self.names],
                             bool)
            self._sections_only = found
        return found

    def _section_stiffness_along(self, state, w: np.ndarray) -> np.ndarray:
        """(∂K/∂p) w (n, k) of the elements by the section values that name a parameter, generated
        (:meth:`latdyn.analyses.sensitivities.ParameterDerivatives.add_section_stiffness_along`)."""
        model = self.model
        full = np.zeros(model.n_total + 1)
        full[:model.n_dofs] = w
        total = np.zeros((model.n_total + 1, len(self.names)))
        self.add_section_stiffness_along(state, full, total)
        return self._on_free_coordinates(state, total)

    def _stiffness_derivative(self, state, w: np.ndarray) -> np.ndarray:
        """(∂K/∂p) w (n, k) at ``state``, K the evaluation's as the impulse weighs with it: the elements' internal
        force tangent, the joint bodies' weight, hinges, loads, cables, contact (the elements' gravity tangent is
        not in it: csrc/evaluate.c holds it in the inertia tangent). Without rigid links or guides: the section
        values' part generated for every parameter (``beam_stiffness_D_section``, :meth:`_section_stiffness_along`),
        the hinges', loads', joint bodies', cables' (EA, damping, rest length, ρA), compliant stops', friction's and
        geometry parameters' parts (and the event's time shift's through loads' and hinges' laws in t, reels and
        continuous controllers' outputs in t) generated for
        the parameters whose every use has one (latdyn/analyses/parameter_stiffness.py ``exact_parameters``), beside
        controllers and held angles with their terms of ∂r/∂p taken apart (:meth:`_terms_beside_stiffness_along`: the
        continuous controllers' exact, the held angles' and the rest differenced), and for the others a central
        difference along w (step :data:`WEIGHT_STEP` ℓ/|w|_∞) of the static ∂r/∂p without the section values' element
        forces and without the elements' gravity load (``sections``, ``element_gravity`` of
        :meth:`residual_derivatives`): a hinge law naming an input, and all
        of them where a prescribed motion beside a continuous controller's coupling entry in a prescribed column
        moves the state in time (a reel's, a continuous controller's output in t and, since prestime, a prescribed
        motion's otherwise are generated, :func:`~latdyn.analyses.parameter_stiffness.time_stiffness_along`). With
        rigid links or guides the same parts through the reduction (:meth:`_linked_stiffness_along`, the controllers'
        terms along P w with them, the time shift's where
        :func:`~latdyn.analyses.parameter_stiffness.time_shift_generated`, a prescribed motion's through the reduction
        too: :func:`~latdyn.analyses.parameter_stiffness.time_shift_along`) where the controllers' are formed, else
        the difference of the static ∂r/∂p without the elements' gravity
        load along w (the reduction's projection moves with it); :meth:`_geometric_derivative` adds the inertia
        forces' geometric term."""
        model = self.model
        out = np.zeros((model.n_dofs, len(self.names)))
        linked = model.links is not None
        exact = exact_parameters(self)
        if linked and np.any(exact):   # the parameters' own parts through P w, the reduction's geometric term exact
            along = self._linked_stiffness_along(state, w)
            if along is None:   # a controller's mixed second derivatives not functions: the difference below
                exact = np.zeros_like(exact)
            else:
                out[:, exact] += along[:, exact]
        if not linked:
            out += self._section_stiffness_along(state, w)
            if np.any(exact):   # the hinges', loads', joint bodies' and cables' uses, generated
                along = self._on_free_coordinates(state, parameter_stiffness_along(self, state, w))
                shifted = self.time_shift is not None and self.explicit_time is not None and np.any(self.time_shift)
                if shifted:   # the state moved in time by δt_e: ∂(∂r/∂t)/∂q w δt_e, generated (exact_parameters)
                    along += np.outer(time_shift_along(self, state, w), self.time_shift)
                out[:, exact] += along[:, exact]
                if self.controllers is not None or (self.held is not None and np.any(self.held)):
                    out[:, exact] += self._terms_beside_stiffness_along(state, w)[:, exact]
        if not np.all(exact):
            assembler = self.assembler
            eta = WEIGHT_STEP * (self.length or 1.0) / float(np.max(np.abs(w)))

            def static(moved):
                with self._controller_outputs_at(moved):   # a derivative law naming a controller reads y there
                    return self.residual_derivatives(moved, 1.0, sections=linked, element_gravity=False,
                                                     held_through_links=False)

            if linked:   # K_red is ∂r/∂q at the assembled rates held, the dependent nodes' too
                with self._at_held_rates():
                    moved = (static(self._advanced_at_held_rates(state, eta * w))
                             - static(self._advanced_at_held_rates(state, -eta * w))) / (2 * eta)
            else:
                moved = (static(assembler.advance(state, eta * w))
                         - static(assembler.advance(state, -eta * w))) / (2 * eta)
            out[:, ~exact] += moved[:, ~exact]
        return out

    def _advanced_at_held_rates(self, state, increment: np.ndarray):
        """``state`` advanced along ``increment`` on the free coordinates (the dependent nodes' positions completed)
        with every node's rates and accelerations held at ``state``'s, the dependent nodes' too: the evaluation's K on
        a model with rigid links or guides is ∂r/∂q at the assembled rates held (K_red = Pᵀ K_all P + ∂Pᵀ/∂q · r_all,
        latdyn/assembly/linked.py: the dependent rates' move with q, Pᵀ C_·dep ∂(J v)/∂q, is not in the impulse's
        weight), so (∂K_red/∂p) w differences ∂r/∂p along w there. With the dependent rates completed at the moved
        configuration the difference held Pᵀ (∂C_all/∂p) ∂(J v)/∂q w beside it: a gain multiplying a velocity read on a
        dependent node (the gimbal's PD of a point at an offset on its inner ring, tests/
        test_sensitivities_linked_controller_latch.py) was 2.7e-4 off Richardson differences of whole runs."""
        moved = self.assembler.advance(state, increment)
        for name in ("v", "w", "a", "alpha"):
            getattr(moved, name)[...] = getattr(state, name)
        return moved

    @contextlib.contextmanager
    def _at_held_rates(self):
        """Within the block the controllers' sensors read a state's rates as given (``ControllerTerms.rates_held``:
        the probes do not complete the dependent nodes' rates in place), for :meth:`_advanced_at_held_rates`."""
        terms = self.controllers
        if terms is None:
            yield
            return
        terms.rates_held = True
        try:
            yield
        finally:
            terms.rates_held = False

    @contextlib.contextmanager
    def _controller_outputs_at(self, moved):
        """Within the block the scene's controller outputs are the continuous controllers' at ``moved``
        (``latdyn_controller_outputs_at``), put back after it, where a parameter's derivative law names a controller
        (a hinge torque or guide force ``Kt*pd``: ∂τ/∂p = pd at fixed output, whose move along w, ∂y/∂q w, the
        difference of the static ∂r/∂p in :meth:`_stiffness_derivative` then holds; left at the step's outputs it
        was 1.8e-7 of the angle off Richardson differences after a rigid stop). A hinge law reads a controller's
        output from the scene's array (its arguments are θ, θ̇, t), so the array is filled at the state the law is
        evaluated at. A controller law reading an earlier controller's output takes it as an argument (codegen/laws.py
        ``_block``): the compiled partials (``ControllerPartials``) need no refill."""
        outputs = getattr(self.scene, "controller_outputs", None)
        named = set(outputs.names) if outputs is not None else set()
        if not named or not any(named & set(getattr(law, "input_names", ()))
                                for laws in self.derivatives.values() for law in laws.values()):
            yield
            return
        held = outputs.values.copy()
        self.assembler.native(True).controller_outputs_at(moved)
        try:
            yield
        finally:
            outputs.values[:] = held

    def _linked_stiffness_along(self, state, w: np.ndarray) -> np.ndarray:
        """(∂K/∂p) w (n, k) with rigid links or guides (no held angles: a stick there is refused) for the parameters
        of ``exact_parameters``, or None where a controller's terms are not formed
        (latdyn/analyses/parameter_stiffness.py ``linked_controller_parameter_along`` None: the caller differences):
        K_red = Pᵀ K_all P + ∂Pᵀ/∂q · r_all, so
        (∂K_red/∂p) w = Pᵀ (∂K_all/∂p)(P w) + ∂Pᵀ/∂q[w] · ∂r_all/∂p — the generated parts (the section values' and
        latdyn/analyses/parameter_stiffness.py's) along P w on the assembled coordinates, reduced, and the forward
        step's geometric term of each column of the static ∂r_all/∂p (without the elements' gravity load) times w
        (:func:`latdyn.analyses.weight_derivative.geometric_product`, exact; :meth:`_geometric_derivative` adds the
        inertia forces'); beside controllers their terms of ∂r_all/∂p along u = P w at the assembled rates held
        (``linked_controller_parameter_along``, since linkedparam). Before, the difference of the whole reduced
        static ∂r/∂p along w."""
        n_asm = self.model.n_assembled
        full = self._along_assembled(state, w)
        total = parameter_stiffness_along_all(self, state, full)
        self.add_section_stiffness_along(state, full, total)
        if self.controllers is not None:   # the controllers' terms of ∂r_all/∂p along u = P w, the rates held
            beside = linked_controller_parameter_along(self, state, full)
            if beside is None:
                return None
            total += beside
        out = self._on_free_coordinates(state, total)
        if self.time_shift is not None and self.explicit_time is not None and np.any(self.time_shift):
            # ∂(∂r_min/∂t)/∂q w δt_e: the laws' rates in t along u, the prescribed motions through the reduction
            timed = time_shift_along(self, state, w, full=full)
            if timed is None:
                return None
            out += np.outer(timed, self.time_shift)
        static = self.residual_derivatives(state, 1.0, on_all=True, element_gravity=False)[:n_asm]
        return out + self._geometric_products(state, static, w)

    def _along_assembled(self, state, w: np.ndarray) -> np.ndarray:
        """u = P w (n_total + 1,) on the assembled coordinates with rigid links or guides: the dependent nodes moving
        with the free ones along w (P of the evaluation at ``state``, its links completed)."""
        self.assembler.complete_links(state)
        projection = self.assembler.evaluate(state, matrices=True).projection
        full = np.zeros(self.model.n_total + 1)
        full[:self.model.n_assembled] = np.asarray(projection @ w).reshape(-1)
        return full

    def _geometric_products(self, state, columns: np.ndarray, w: np.ndarray) -> np.ndarray:
        """(n, columns): ∂(Pᵀ y)/∂q[w] at fixed y for each column y of ``columns`` (on the assembled coordinates), the
        forward step's geometric term of y times w (:func:`latdyn.analyses.weight_derivative.geometric_product`)."""
        out = np.zeros((self.model.n_dofs, columns.shape[1]))
        self.assembler.complete_links(state)   # J of the state in the links' buffers
        for c in range(columns.shape[1]):
            if np.any(columns[:, c]):
                out[:, c] += geometric_product(self.assembler, state, columns[:, c], w)
        return out

    def _terms_beside_stiffness_along(self, state, w: np.ndarray) -> np.ndarray:
        """(n, k): the derivative along w of the static ∂r/∂p's terms beside the parameters' own, alone — the
        continuous and sampled controllers' (:meth:`latdyn.analyses.sensitivities.ControllerTerms.add`: their
        outputs' explicit ∂y/∂p, the chained and held outputs' and the states' terms on the actuators' rows) and the
        angles friction holds (:meth:`_held_forces`: K's columns of them times their δθ). The continuous
        controllers' exact (latdyn/analyses/parameter_stiffness.py ``controller_parameter_along``: SymPy's mixed
        second derivatives times the sensors' generated gradients, chained); a central difference (step
        :data:`WEIGHT_STEP` ℓ/|w|_∞, two evaluations) of what that does not form — the held angles' columns, and the
        controllers' terms where it returns None (a controller reading a force whose ∂F/∂p's move is not generated —
        a geometry parameter's section force or placed point, a stuck joint's reaction —, a controller whose second
        derivatives along q are not generated; a section force by section values, shear-flexible too, is generated
        since shearsec). The parameters' own terms beside
        them are generated (latdyn/analyses/parameter_stiffness.py)."""
        model, assembler = self.model, self.assembler
        exact = controller_parameter_along(self, state, w) if self.controllers is not None else None
        out = (self._on_free_coordinates(state, exact) if exact is not None
               else np.zeros((model.n_dofs, len(self.names))))
        differenced = self.controllers is not None and exact is None
        holding = self.held is not None and np.any(self.held)
        held_exact = held_angles_along(self, state, w) if holding else None
        if held_exact is not None:
            out += self._on_free_coordinates(state, held_exact)
        held_differenced = holding and held_exact is None
        if not differenced and not held_differenced:
            return out
        eta = WEIGHT_STEP * (self.length or 1.0) / float(np.max(np.abs(w)))

        def beside(moved):
            total = np.zeros((model.n_total + 1, len(self.names)))
            if differenced:
                self.controllers.add(moved, total)   # a chained output is the compiled partials' argument
            held = self._held_forces(moved, False, False) if held_differenced else None
            if held is not None:
                total += held
            return self._on_free_coordinates(moved, total)

        ahead, behind = beside(assembler.advance(state, eta * w)), beside(assembler.advance(state, -eta * w))
        return out + (ahead - behind) / (2 * eta)

    def coordinate_step(self) -> float:
        """The configuration step of the central differences along one coordinate (H_rest's columns,
        latdyn/analyses/weight_derivative.py): a unit vector moves one node against its elements, so the step
        lies between the length scale's ℓ (round-off) and the shortest element's L_min (truncation), their
        geometric mean, :data:`WEIGHT_STEP` √(ℓ min(ℓ, L_min)) (on the latching boom of 50 elements of 0.02 m,
        benchmarks/transient_sensitivities_cost.py --scene boom_latch, differences along each coordinate were
        8.6e-7 off the forward method's with ℓ's step, 1.7e-7 with L_min's, 1.3e-8 with this one)."""
        length = self.length or 1.0
        sections = self.model.element_sections
        shortest = float(np.min(sections[:, 0])) if len(sections) else length
        return WEIGHT_STEP * float(np.sqrt(length * min(length, shortest)))

    def _linked_weight_derivative(self, state, w: np.ndarray, dq: np.ndarray, scale: float, mass: bool,
                                  rates) -> np.ndarray:
        """∂(W w)/∂q δq (n, k) of :meth:`_weight_derivative` with guides or rigid links (the reduction's W w,
        latdyn/analyses/weight_derivative.py "Rigid links and guides"): the generated blocks' part Pᵀ W_gen P w exactly
        (:func:`latdyn.analyses.weight_derivative.linked_configuration_tangent`: the elements', joint bodies', generated
        hinges', loads', cables' and couplings' blocks; the damped taut cables' move with the rates,
        :func:`latdyn.analyses.weight_derivative.linked_cable_rates_product`), the reduction's geometric term
        s ∂(Pᵀ r_all)/∂q[w] exactly, the links' second derivatives generated
        (:func:`latdyn.analyses.weight_derivative.linked_geometric_derivative`), and the blocks not generated,
        Pᵀ W_rest P w where the model has them (:func:`latdyn.analyses.weight_derivative.linked_has_rest`), a central
        difference along each column's move (:meth:`_linked_move`)."""
        assembler = self.assembler
        out = linked_configuration_tangent(assembler, state, w, dq, scale, mass)
        out += linked_geometric_derivative(assembler, state, w, dq, scale, rates)
        by_rates = linked_cable_rates_product(assembler, state, w, dq, scale, rates)
        if by_rates is not None:   # the damped taut cables' c ℓ̇ moving with the rates, the dependent ones' too
            out += by_rates
        by_sensed_rates = linked_coupling_rates_product(assembler, state, w, dq, scale, rates)
        if by_sensed_rates is not None:   # controllers of positions and rates: their entries move with the rates
            out += by_sensed_rates
        by_chain = linked_chain_rates_product(assembler, state, w, dq, scale, rates)
        if by_chain is not None:   # the other controllers' couplings and driven loads moving with the rates
            out += by_chain
        hinges_and_couplings = linked_rates_tangent(assembler, state, w) if rates is not None else None
        if hinges_and_couplings is not None:   # the hinges' and mixed couplings' entries moving with the free rates
            out += scale * times(hinges_and_couplings, rates[0])
        if not linked_has_rest(assembler):
            return out
        for c in range(dq.shape[1]):
            eta = self._linked_move_step(dq, rates, c)
            if eta is None:
                continue
            ahead, behind = (self._linked_move(state, dq, rates, c, s * eta) for s in (1.0, -1.0))
            out[:, c] += (linked_rest_product(assembler, assembler.evaluate(ahead, matrices=True), w, scale, mass)
                          - linked_rest_product(assembler, assembler.evaluate(behind, matrices=True), w, scale,
                                                mass)) / (2 * eta)
        return out

    def _linked_move_step(self, dq: np.ndarray, rates, c: int):
        """The step of :meth:`_linked_weight_derivative`'s difference along column ``c`` (None: no move),
        :data:`WEIGHT_STEP` ℓ over the move's size, each move in its own units (a configuration, a rate and an
        acceleration over the nominal step): the rates' derivatives, large in a rate's units, must not shrink the
        configuration's step to where the difference (of the stiffness's size) is round-off (a latch of rigid
        links)."""
        dt = self.scene.solve.dt
        moves = [dq[:, c]] + ([rates[0][:, c] * dt, rates[1][:, c] * dt * dt] if rates is not None else [])
        size = float(max(np.max(np.abs(m), initial=0.0) for m in moves))
        return None if size == 0.0 else WEIGHT_STEP * (self.length or 1.0) / size

    def _linked_move(self, state, dq: np.ndarray, rates, c: int, eta: float):
        """``state`` moved by ``eta`` along column ``c``: the configuration along δq, the free rates along
        ``rates`` = (δv, δv̇) too (the dependent ones completed)."""
        model, assembler = self.model, self.assembler
        ahead = assembler.advance(state, eta * dq[:, c])
        if rates is not None:
            unpack_free(model, free_velocity(model, state) + eta * rates[0][:, c], ahead.v, ahead.w, ahead.theta_dot)
            unpack_free(model, free_acceleration(model, state) + eta * rates[1][:, c], ahead.a, ahead.alpha,
                        ahead.theta_ddot)
            assembler.complete_links(ahead)
        return ahead

    def _geometric_derivative(self, state, w: np.ndarray) -> np.ndarray:
        """∂Pᵀ/∂q[w] · (∂r_all/∂p with the inertia forces less without) (n, k): the part of ∂K/∂p w of a
        reduction's geometric term ∂Pᵀ/∂q · r_all (latdyn/assembly/linked.py; r_all with the inertia
        forces) that the static ∂r/∂p (without the elements' gravity load) differenced along w leaves out;
        (∂P[w])ᵀ y = ∂(Pᵀ y)/∂q[w] at fixed y, the forward step's geometric term of each column y times w
        (:func:`latdyn.analyses.weight_derivative.geometric_product`, exact; a central difference of P along w
        before). A geometry parameter that shifts a subtree on a part that turns (latdyn/analyses/
        geometry_sensitivities.py ``ReferenceGeometry.turning``) moves P itself (∂P/∂p: its columns that reach the
        anchor A move the subtree's points by g × d), and ∂P/∂p moves along w with A's turn: the moments d × F_S of the
        inertia forces turned (``ReferenceGeometry.moments_turned``; the static forces' are in the difference)."""
        model, assembler = self.model, self.assembler
        n_asm = model.n_assembled
        inertial = (self.residual_derivatives(state, 1.0, inertia=True, on_all=True)
                    - self.residual_derivatives(state, 1.0, on_all=True, element_gravity=False))[:n_asm]
        out = self._geometric_rate_in_time(state, w) + self._shifts_turned(state, w)
        if not np.any(inertial):
            return out
        return out + self._geometric_products(state, inertial, w)

    def _shifts_turned(self, state, w: np.ndarray) -> np.ndarray:
        """(n, k): Pᵀ of ``ReferenceGeometry.moments_turned`` along P w at the state's inertia forces and the elements'
        weight (r_all with the inertia forces less the static r_all without the elements' gravity load): the move along
        w of ∂P/∂p's term d × F_S of the reduction's geometric term (module docstring of
        latdyn/analyses/geometry_sensitivities.py) of the forces that the static ∂r/∂p :meth:`_stiffness_derivative`
        differences leaves out (the elements' weight with the inertia forces: ``ReferenceGeometry.add`` at
        ``weight_factor`` 0); zeros without such a shift."""
        model, assembler = self.model, self.assembler
        if self.geometry is None or not self.geometry.turning:
            return np.zeros((model.n_dofs, len(self.names)))
        assembler.complete_links(state)
        along = np.zeros(model.n_total + 1)
        along[:model.n_assembled] = np.asarray(assembler.evaluate(state, matrices=True).projection @ w).reshape(-1)
        forces = np.zeros(model.n_total + 1)
        with_inertia = np.asarray(assembler.evaluate_assembled(state, False, 1.0, True).residual)
        with assembler.native().without_element_gravity():
            weightless = np.asarray(assembler.evaluate_assembled(state, False, 1.0, False).residual)
        forces[:model.n_assembled] = with_inertia - weightless
        return self._on_free_coordinates(state, self.geometry.moments_turned(state, along, forces))

    def _geometric_rate_in_time(self, state, w: np.ndarray) -> np.ndarray:
        """(n, k): at an event moved in time (``time_shift`` δt_e) on a model with rigid links or guides and
        prescribed motions, ∂/∂t of the reduction's geometric term ∂Pᵀ/∂q[w] · r_inertia (r_inertia the inertia
        forces' part of r_all: r_all with them less without) times δt_e — the part of ∂(K w)/∂t δt_e that
        neither the static ∂r/∂t's along w (:meth:`_stiffness_derivative`: its geometric term is of the static
        r_all) nor the inertia forces' ∂r_all/∂t through ∂Pᵀ/∂q[w] (below) holds: P moves with the
        prescribed coordinates (:func:`latdyn.analyses.weight_derivative.linked_geometric_rate_in_time`). Zeros
        elsewhere (left out before: 3e-6 of the slewing gimbal's sensitivities after its latch,
        tests/test_sensitivities_slewing_latch.py)."""
        model, k = self.model, len(self.names)
        out = np.zeros((model.n_dofs, k))
        shifted = self.time_shift is not None and self.explicit_time is not None and np.any(self.time_shift)
        if not shifted or not self.explicit_time.prescribed:
            return out
        assembler, n_asm = self.assembler, model.n_assembled
        inertia_forces = (np.asarray(assembler.evaluate_assembled(state, False, 1.0, True).residual)
                          - np.asarray(assembler.evaluate_assembled(state, False, 1.0, False).residual))[:n_asm]
        motion_rates = self.explicit_time.motions.rates(float(state.t))[0]
        rate = linked_geometric_rate_in_time(assembler, state, inertia_forces, w, motion_rates)
        return np.outer(rate, self.time_shift)

    def after_events(self, carried: dict, new, end_after_events: bool) -> dict:
        """``carried`` after the events of the step ended at ``new`` (its coordinates renumbered, its
        accelerations restarted): δq, δv on the new numbering and the restart differentiated: after a
        latch the consistent accelerations, M δv̇ = −(∂r/∂p + K δq + C δv); after a stop those of
        :func:`latdyn.timeloop.events.restart_accelerations`, W v̇ = −r(q, v, 0), so
        W δv̇ = −(∂r/∂p + K δq + C δv + dt² δ(K)v̇) (K exact, at the restarted v̇); δa = δv̇.
        ``end_after_events``: whether the loop evaluated the step's end again after the events (latdyn/timeloop/
        loop.py ``_accept``), so that the step's external work took its end's power and drives' reactions after
        the jump (:func:`external_work_after_event`)."""
        carried = self._settle_or_release(self._stick_or_release(carried, new), new)
        pending = carried.get("pending")
        states = self._controller_states()
        if pending is None:   # no jump (a latch's, a stop's, a stick's or release's: each leaves one pending)
            return carried
        self.time_shift = carried["dt"]   # the restart at the event's time, moved by δt_e
        if states is not None:   # the states kept through the restart: δS held in ∂r/∂p there
            states.hold(carried)
        try:
            carried = external_work_after_event(self, carried, self._restart(carried, new, pending), new,
                                                end_after_events)
        finally:
            self.time_shift = None
            if states is not None:
                self.controllers.held = {}
        # the states' rates taken anew after a latch's jump (a rate sensor's δs⁺: ControllerStates.restarted); after a
        # stop the run keeps them (rates_taken_anew)
        if states is None or not rates_taken_anew(pending["kind"], self.model):
            return carried
        return states.restarted(carried, new)

    # ------------------------------------------------------------------ sticking by friction
    def _held(self, carried: dict) -> np.ndarray:
        """δθ (n_hinges, k) of the joints friction holds, as ``carried`` holds them (zero rows elsewhere)."""
        held = carried.get("held")
        return held if held is not None else np.zeros((len(self.model.hinges), len(self.names)))

    def _held_forces(self, state, inertia: bool, element_gravity: bool = True):
        """Σ_j K[:, θ_j] δθ_j (n_total + 1, k) over the joints friction holds (:attr:`held`), or None: a stuck
        joint's angle is no free coordinate, but it is where the run stuck it, a function of p, and every
        residual moves with it through K's column of that angle — the elements' blocks (their tangent and, with
        ``inertia``, inertia tangent, as in the exact K), a controller's coupling, and the joint's own law on its
        (reaction's) row: one native evaluation at ``state``. Without ``inertia`` and ``element_gravity`` (the
        static ∂r/∂p an event's weight derivative differences, :meth:`_stiffness_derivative`) the elements' tangent
        without their gravity load's, as W's K (the evaluation with the inertia forces: csrc/evaluate.c holds it in
        the inertia tangent); the static evaluation's held it, and the held angle's block was 6.2e-6 – 1.1e-5 off W's
        at the 3D panel's sticks (tests/test_weight_derivative_controllers_held.py)."""
        held = self.held
        if held is None or not np.any(held) or self.model.links is not None:   # linked: _linked_held_forces
            return None
        model, native = self.model, self.assembler.native(True)
        native.evaluate(state, True, 1.0, inertia or not element_gravity, inertia)
        b, control = native.buffers, self.assembler.control
        stiffness = b["tangent"] + b["inertia_tangent"] if inertia else b["tangent"]
        dofs, out = model.element_dofs, np.zeros((model.n_total + 1, held.shape[1]))
        for j in np.flatnonzero(np.any(held, axis=1)):
            d = model.hinge_dofs[j]
            column = np.zeros(model.n_total + 1)
            elements, slot = np.nonzero(dofs == d)
            np.add.at(column, dofs[elements], stiffness[elements, :, slot])
            coupled = control.coupling_cols == d
            np.add.at(column, control.coupling_rows[coupled], b["coupling_stiffness"][coupled])
            column[d] += b["hinge_d_theta"][j]
            out += np.outer(column, held[j])
        return out

    def _holds_through_links(self) -> bool:
        """Whether friction holds an angle (:attr:`held` not 0) on a model with rigid links."""
        return self.model.links is not None and self.held is not None and bool(np.any(self.held))

    def _linked_held_forces(self, state, inertia: bool) -> np.ndarray:
        """Σ_j ∂r_min/∂θ_j δθ_j (n, k) over the joints friction holds, on a model with rigid links: the reduced
        residual r_min = Pᵀ r_all(q_all(z, θ_j)) moves with a held angle through the joint's own blocks (Pᵀ K_all's
        column of θ_j), the dependent nodes that hang from it (Pᵀ K_all J_·θj), P itself (∂Pᵀ/∂θ_j · r_all) and
        the dependent rates at fixed free rates (Pᵀ(C_·dep ∂(J v)/∂θ_j + M_·dep ∂(J a + c)/∂θ_j); θ̇_j = θ̈_j = 0
        while it is held) — the exact K's column of θ_j had it been free, which the prescribed motions' path forms
        for a coordinate that is no free one (latdyn/analyses/prescribed_rates.py :func:`linked_columns`,
        csrc/linked_prescribed_rates.c at the unit rate on θ_j): one native evaluation at ``state``, then one call
        per held joint. Without those terms (Pᵀ of K_all's column alone, as :meth:`_held_forces` forms it without
        links) the gimbal's tip was 0.86 of its sensitivity off Richardson differences; a central difference of r_min
        along θ_j (step :data:`WEIGHT_STEP` rad, two reduced evaluations per held joint) stood here before heldcol, and
        this agrees with it to 6.5e-11 of the column, the difference's truncation
        (tests/test_sensitivities_linked_sticks.py)."""
        held = self.held
        hinges = np.flatnonzero(np.any(held, axis=1))
        columns, _ = linked_columns(self.assembler, state, [int(d) for d in self.model.hinge_dofs[hinges]], inertia)
        return columns.T @ held[hinges]

    def _linked_held_stiffness_along(self, state, w: np.ndarray) -> np.ndarray:
        """Σ_j ∂(K w)/∂θ_j δθ_j (n, k) over the joints friction holds on a model with rigid links, K the
        evaluation's (the impulse's and the restart's weight W = M + dt²K, its geometric term ∂Pᵀ/∂q · r_all
        with the inertia forces at ``state``'s accelerations): the held angle moves W as it moves r_min
        (:meth:`_linked_held_forces`). With K_red = Pᵀ K_all P + ∂Pᵀ/∂q · r_all (latdyn/assembly/linked.py) and the
        held angle's move on the assembled coordinates m = e_θj + J_·θj (the dependent nodes hanging from it),
        exactly:

            ∂(K_red w)/∂θ_j = Pᵀ [H(u) m + K_all ∂(J w)/∂θ_j] + ∂Pᵀ/∂θ_j · K_all u
                              + ∂Pᵀ/∂q[w] · ∂r_all/∂θ_j + ∂/∂θ_j(∂Pᵀ/∂q[w]) · r_all,      u = P w,

        H(u) = ∂(K_all u)/∂q_all the generated elements', joint bodies' and point loads' parts at u
        (latdyn/analyses/weight_derivative.py ``_generated``, ``_load_part``: W's K, the elements' gravity tangent
        not in it; the hinges' blocks are on their own angles, the held one's on its reaction row, and the blocks not
        generated there, controllers' and cables', are refused beside a stick on links,
        :meth:`_refuse_what_a_held_angle_moves`), ∂(J w)/∂θ_j the compiled links' rates' derivative at rates w
        (:func:`latdyn.assembly.linked.dependent_columns`), the geometric terms the forward step's on θ_j's column
        (``latdyn_linked_geometric_product``) and on w's (:func:`geometric_product`) with ∂r_all/∂θ_j the inertia
        forces' exact column (:func:`linked_columns`), and the links' second derivatives along the unit on θ_j
        (:func:`latdyn.analyses.weight_derivative.geometric_second_product`). Two native evaluations per weighing
        (one with the inertia tangent), then no evaluation per held joint. A central difference of K w along θ_j
        (step :data:`WEIGHT_STEP` rad, two reduced evaluations with the matrices per held joint) stood here before
        heldcol; this agrees with it to 1.4e-10 (the gimbal) and 3.0e-10 (the boom's end hinge) of the product at
        random w at every step while stuck (tests/test_sensitivities_linked_sticks.py)."""
        import ctypes

        model, assembler, held = self.model, self.assembler, self.held
        n, n_asm, size = model.n_dofs, model.n_assembled, model.n_total + 1
        hinges = np.flatnonzero(np.any(held, axis=1))
        coordinates = [int(d) for d in model.hinge_dofs[hinges]]
        _, moved_residual = linked_columns(assembler, state, coordinates, True)   # ∂r_all/∂θ_j, the inertia forces'
        ev = assembler.evaluate(state, matrices=True)
        P, r_all, K_all = ev.projection, ev.assembled_residual, ev.combined_before_reduction(0.0, 0.0, 1.0, True)
        u, y = np.zeros(size), np.zeros(size)
        u[:n_asm] = np.asarray(P @ w).reshape(-1)
        y[:n_asm] = np.asarray(K_all @ u[:n_asm]).reshape(-1)
        parts = [_generated(assembler, state, w, 1.0, False, full=u),
                 _load_part(assembler, state, w, 1.0, full=u, exact=linked_generated_loads(assembler))]
        rows, cols, values = (np.concatenate([part[i] for part in parts]) for i in range(3))
        assembled = rows < n_asm
        rows, cols, values = rows[assembled], cols[assembled], values[assembled]
        dependent = model.node_dofs[model.links.dependent].ravel()
        at_rates_w = state.copy()   # the independent rates w, every other 0: ∂(J w)/∂θ_j
        for name in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot"):
            getattr(at_rates_w, name)[...] = 0.0
        unpack_free(model, w, at_rates_w.v, at_rates_w.w, at_rates_w.theta_dot)
        native = assembler.native()
        out = np.zeros((n, held.shape[1]))
        for i, (j, d) in enumerate(zip(hinges, coordinates)):
            _, rates_moved = dependent_columns(assembler, at_rates_w, d)
            jacobian, _ = dependent_columns(assembler, state, d)   # the links' buffers at the state again
            move = np.zeros(size)
            move[d], move[dependent] = 1.0, jacobian.ravel()
            inner = np.zeros(n_asm)
            np.add.at(inner, rows, values * move[cols])
            moved_w = np.zeros(n_asm)
            moved_w[dependent] = rates_moved.ravel()
            inner += np.asarray(K_all @ moved_w).reshape(-1)
            column = np.asarray(P.T @ inner).reshape(-1)
            marked, product = np.zeros(size, np.int64), np.zeros(size)
            marked[d] = 1
            native.library.latdyn_linked_geometric_product(native.model_ref, ctypes.byref(native.configuration(state)),
                                                           y.ctypes.data, marked.ctypes.data, move.ctypes.data,
                                                           product.ctypes.data)
            unit = np.zeros(size)
            unit[d] = 1.0
            column += (product[:n] + geometric_product(assembler, state, moved_residual[i][:n_asm], w)
                       + geometric_second_product(assembler, state, r_all, w, unit))
            out += np.outer(column, held[j])
        return out

    def _held_dependent_motion(self, state, dx: np.ndarray, dpi: np.ndarray, rates) -> None:
        """Add the dependent nodes' moves by the held angles into (δx, δπ) and, with ``rates``, their rates' (δv, δω)
        (n_nodes, 3, k) on a model with rigid links: a node that hangs from a held joint moves with its δθ_j by J's
        column of θ_j (a constrained column of the compiled links' slots), its rates v_dep = J v by ∂(J v)/∂θ_j at
        fixed free rates (the generated edge kernels' ``*_rates_D_q`` composed along the tree):
        :func:`latdyn.assembly.linked.dependent_columns`, no evaluation of the model. A central difference of the
        completed dependent nodes along θ_j stood here before heldcol; this agrees with it to 2.6e-11 (δx), 1.7e-11
        (δπ), 2.1e-13 (δv) on the gimbal of tests/test_sensitivities_linked_sticks.py."""
        dependent = self.model.links.dependent
        for j in np.flatnonzero(np.any(self.held, axis=1)):
            jacobian, by_velocity = dependent_columns(self.assembler, state, int(self.model.hinge_dofs[j]))
            for k, node in enumerate(dependent):
                dx[node] += np.outer(jacobian[k, :3], self.held[j])
                dpi[node] += np.outer(jacobian[k, 3:], self.held[j])
                if rates is not None:
                    rates[0][node] += np.outer(by_velocity[k, :3], self.held[j])
                    rates[1][node] += np.outer(by_velocity[k, 3:], self.held[j])

    def _stick_candidates(self, carried: dict, old, new) -> None:
        """For each joint the time loop may stick at the end of the step old → new (its rate reversed or fell into
        the stick band: latdyn/timeloop/events.py) or release (a stuck one), what :meth:`after_events` needs if it
        does, on the nodes and hinges (the coordinates are renumbered then): the stick's jump of δv (a stop's
        impulse with restitution 0, :meth:`_impulse`; δq unchanged, no landing: its time's derivative is 0),
        the held δθ; a release's δq with the held δθ back on its angle, δv (its rate's 0); and the accelerations
        before the restart (its weight is evaluated at them, as the run's)."""
        model = self.model
        for j in sticking_hinges(model) + [int(j) for j in np.flatnonzero(model.stuck)]:
            if j in self._candidates or (not model.stuck[j] and not may_stick(self.assembler, j, old, new)):
                continue
            dq, dvdot = self._on_nodes(carried["dq"]), self._on_nodes(carried["dvdot"])
            vdot = self._on_nodes(free_acceleration(model, new)[:, None])[0]
            if model.stuck[j]:   # a release: the held angle's δθ back among the free coordinates
                for c, (_, _, dtheta) in enumerate(dq):
                    dtheta[j] = self.held[j, c]
                self._candidates[j] = {"dq": dq, "dv": self._on_nodes(carried["dv"]), "vdot": vdot, "dvdot": dvdot,
                                       "held": np.zeros(len(self.names))}
                continue
            self.time_shift = carried["dt"]
            try:
                dv_plus = self._impulse(carried, new, j, 0.0)
            finally:
                self.time_shift = None
            self._candidates[j] = {"dq": dq, "dv": self._on_nodes(dv_plus), "vdot": vdot, "dvdot": dvdot,
                                   "held": carried["dq"][model.hinge_dofs[j]].copy()}

    def _stick_or_release(self, carried: dict, new) -> dict:
        """``carried`` after the events of the step ended at ``new``: where a joint stuck or was released by
        friction there, its held δθ and the restart pending as after a stop (:meth:`_restart`: the time loop
        restarts the accelerations as after an impact); refused where that is not differentiated
        (:meth:`_refuse_sticking`)."""
        model, before = self.model, self._stuck_before
        changed = [] if before is None else [int(j) for j in np.flatnonzero(before != model.stuck)]
        self._stuck_before = None
        if not changed:
            return carried
        j = changed[0]
        happens = "the joint sticks" if model.stuck[j] else "the joint is released"
        if len(changed) > 1 or carried.get("pending") is not None:
            self._refuse_sticking(new, "several joints stick or slip, or a latch, a stop or a cable's change comes, "
                                       "at one instant", j)
        if j not in self._candidates:   # a step with nothing free prepares none (:meth:`step`)
            self._refuse_sticking(new, f"{happens} after steps on which nothing was free (the joints held by friction "
                                       "were the only coordinates, as after a start at rest: a release from there is "
                                       "not prepared)", j)
        self._refuse_what_a_held_angle_moves(new, happens, j, through_links=True)
        candidate = self._candidates[j]
        held = self._held(carried).copy()
        held[j] = candidate["held"]
        self.held = held
        pending = {"kind": "stop", "dq": candidate["dq"], "dv": candidate["dv"], "vdot": candidate["vdot"],
                   "dvdot": candidate["dvdot"], "restarts": 1, "free_restarts": 0}
        return {**carried, "held": held, "pending": pending}

    def _refuse_what_a_held_angle_moves(self, new, happens: str, joint: int, through_links: bool = False) -> None:
        """The models and probes whose terms of a stuck joint's held angle are not carried: refused
        (:meth:`_refuse_sticking`, naming ``joint``'s friction) where a joint sticks, is released, or is stuck from
        t = 0 (latdyn.timeloop.events.stick_at_start); ``happens`` says which, for the message
        (:data:`HELD_FROM_THE_START` at t = 0). A hinge held on a model with rigid links is carried by the forward
        method (``through_links``: :meth:`_linked_held_forces`, :meth:`_linked_held_stiffness_along`,
        :meth:`_held_dependent_motion`) where no guide, latch, rigid stop, cable or controller is in the model and the
        probes are those :meth:`_probes_unchecked_through_links` checks beside a held angle (against Richardson
        differences on the gimbals of tests/test_sensitivities_linked_sticks.py; the rest is not); the discrete
        adjoint (its own call) refuses it.
        The probes read it (:meth:`record`), energies and momenta too: their forms c_q are on all
        coordinates, the stuck joint's slot included; the controllers' sensors too
        (:meth:`_controllers_drive_stuck_joints_alone`; tests/test_sensitivities_sticks_beside.py)."""
        model = self.model
        if model.links is not None and not through_links:
            self._refuse_sticking(new, f"{happens} in a model with guides or rigid links (the discrete adjoint "
                                       "does not transpose their reduction with a held angle or slide)", joint)
        if model.links is not None:
            guides = any(h.end == "guide" for h in model.hinges)
            events = model.cables is not None or any(
                h.lock_at is not None or (h.limits is not None and h.contact is None) for h in model.hinges)
            probes = self._probes_unchecked_through_links()
            if guides or events or probes or self.controllers is not None:
                what = ("guides" if guides else "latches, rigid stops or cables" if events
                        else "controllers" if self.controllers is not None
                        else f"probe {probes[0]!r} (not a point, a joint's angle, rate or torque, a kinetic, strain, "
                             "potential or total energy, the external work without loads on the links' nodes, a "
                             "momentum or an element's section force)")
                self._refuse_sticking(new, f"{happens} in a model with rigid links beside {what} (their terms "
                                           "of the held angle through the reduction are not carried)", joint)
        if not self._impulse_weighted:
            self._refuse_sticking(new, f"{happens} in a model with directions or elements without inertia "
                                       "(the impulse response's rigid and static parts are not differentiated)", joint)
        if (self._controller_states() is not None or self._sampled_controllers() is not None) \
                and not self._controllers_drive_stuck_joints_alone():
            self._refuse_sticking(new, f"{happens} beside controllers with states or sampled ones that drive "
                                       "another coordinate (their condensed terms of the held angle are not "
                                       "carried there)", joint)

    def _controllers_drive_stuck_joints_alone(self) -> bool:
        """Whether every controller's actuator is the torque of a joint stuck now (none is: a release, whose held
        angle ends). A controller with states or a sampled one reads the held angle through its sensors
        (``_sensor_derivatives`` adds the held δθ to the joints' δθ: δS and the sampled δy carry it); where it drives
        a stuck joint its output's terms of the held angle land on that joint's reaction row alone. On a free
        coordinate the states' condensed dy/ds = ∂y/∂s + ∂y/∂S A⁻¹ h/2 ∂f/∂s would multiply the held δθ there, which
        :meth:`_held_forces` (the coupling outside the step's condensation) does not take: refused."""
        stuck, control, sampled = self.model.stuck, self.assembler.control, self._sampled_controllers()
        driven = list(zip(control.actuator_kind, control.actuator_index))   # the continuous controllers' (0: a hinge)
        if sampled is not None:   # the sampled ones' (SampledTerms.actuators: kind 0 a hinge or a guide)
            driven += [(kind, index) for kind, index, *_ in sampled.actuators]
        return not stuck.any() or all(kind == 0 and stuck[index] for kind, index in driven)

    def _refuse_sticking(self, new, why: str, joint: int) -> None:
        """SceneError (exit 2) naming the friction of ``joint`` (a hinge index), which sticks, is released or is
        stuck at ``new``: ``why`` that is not differentiated here (docs/parameters.md, "Friction")."""
        raise SceneError(self.scene.file, friction_key(self.model.hinges[joint]),
                         f"at t = {new.t:.6g} {why}: solve.sensitivities differentiates a joint's slipping, "
                         "sticking and release by friction, not this; expected a run without it, or no "
                         "solve.sensitivities (docs/parameters.md, \"Friction\")")

    # ------------------------------------------------------------------ resting on a rigid stop
    def _release_candidates(self, carried: dict, new) -> None:
        """For each hinge resting on its rigid stop (``model.resting``: locked there, latdyn/timeloop/events.py
        "resting on a stop") that the step's end releases (its reaction at ``new`` would pull it off: the run's own
        test, ``stop_holds``, at the state ``release_from_stops`` reads), what :meth:`after_events` needs, on the
        nodes and hinges (the coordinates are renumbered then): δq with the hinge's δθ 0 (it landed on the stop
        exactly, δθ_p + δθ_h δh = 0, and stayed there: a stop angle is no parameter), δv with its rate's 0 (a locked
        hinge's rate is 0), and the accelerations before the restart (:meth:`_restart`; the release's time is the
        step's end, on the grid: δt 0, as a release by friction). Known here, not from the resting hinges after the
        events: the run may settle the released hinge on its stop again at once (:meth:`_settle_or_release`)."""
        model = self.model
        for j in np.flatnonzero(model.resting):
            if stop_holds(self.prepared, new, int(j)):
                continue
            self._releases[int(j)] = {"dq": self._on_nodes(carried["dq"]), "dv": self._on_nodes(carried["dv"]),
                                      "vdot": self._on_nodes(free_acceleration(model, new)[:, None])[0],
                                      "dvdot": self._on_nodes(carried["dvdot"])}

    def _settle_or_release(self, carried: dict, new) -> dict:
        """``carried`` after the events of the step ended at ``new`` where a hinge came to rest on its rigid stop or
        was released from it (latdyn/timeloop/events.py ``settle_on_stops``, ``release_from_stops``). Settling
        follows the impact that left it on the stop without rate (restitution 0, landed on exactly: :meth:`_jump`
        with e = 0); the run then locks it and restarts the accelerations on the locked model,
        (M + dt²K) v̇ = −r(q, v, 0) on the coordinates left, which :meth:`_restart` differentiates on the new
        numbering: the restart the impact's own (on the free model) left is replaced, and r(q, v, 0) does not read
        the accelerations it was taken at, nor does W without rigid links or guides. While locked, its angle is
        the stop's (δθ = 0) and it is no coordinate, as a latched hinge. A release at a step's end restarts as a
        stop does, its δθ (0) and rate (0) back among the free coordinates (:meth:`_release_candidates`).
        Refused (:meth:`_refuse_resting`) where that is not what the run did: several at one instant, a release
        beside another event; and on models with rigid links beside what was not checked (:meth:`_refuse_a_linked_rest`).
        A release restarts twice (``restarts``, :meth:`_restart`): the run's release (``release_from_stops``) frees
        the hinge on its stop without rate, which ``hinge_stops`` then finds there (a hit: on the stop, its rate
        not away from it) and restarts the accelerations again, at those the release's restart left; with rigid
        links W reads them (its geometric term), so the second differs from the first (measured on the gimbal of
        tests/test_sensitivities_linked_rest.py: δθ̈ after the release 4.1e-3 off Richardson differences of the
        run's state with one restart differentiated, 1.8e-8 with both); without them it is the first again.
        ``settle_on_stops``' trial on the locked model after it is undone where the reaction pulls off, its
        accelerations with it; where at the accelerations the two restarts left the stop holds it, the trial stays:
        the hinge is released and settled again at one instant, its ``model.resting`` as before, and the run's
        accelerations are those of a third restart, on the locked model, weighed at the second's
        (``free_restarts`` 2, :meth:`_restart_before_settling`). Left out (the step's δv̇ kept), δθ̈ of the other
        ring was 4.9 times Richardson's on tests/test_sensitivities_linked_rest.py's FUZZ (released and settled
        again at 0.155 s), and every row after it off, 3.0e-3 … 4.6e-2.
        """
        before, self._resting_before = self._resting_before, None
        releases, self._releases = self._releases, {}
        model = self.model
        if before is None or not len(self.names):
            return carried
        changed = [int(j) for j in np.flatnonzero(before != model.resting)]
        # released at the step's end and settled on the same stop again at once: resting as before
        settled_again = [j for j in releases if model.resting[j] == before[j]]
        if not changed and not settled_again:
            return carried
        j = (changed + settled_again)[0]
        if len(changed) + len(settled_again) > 1:
            self._refuse_resting(new, j, "several hinges come to rest on their stops or leave them at one instant")
        self._refuse_a_linked_rest(new, j)
        pending = carried.get("pending")
        if model.resting[j] and j not in releases:   # settled after its impact with restitution 0: the restart on
            if pending is None or pending.get("hinge") != j or pending["kind"] != "stop":   # the locked model
                self._refuse_resting(new, j, "a hinge comes to rest on its stop without an impact landed on it")
            return {**carried, "pending": {**pending, "free_restarts": 1}}
        if pending is not None or j not in releases:
            self._refuse_resting(new, j, "a hinge leaves its stop beside another event at one instant")
        release = releases[j]
        # released: the release's restart and the hit's on the free model; settled again: a third on the locked one
        restarts = {"restarts": 1, "free_restarts": 2} if model.resting[j] else {"restarts": 2, "free_restarts": 0}
        return {**carried, "pending": {"kind": "stop", "hinge": j, "dq": release["dq"], "dv": release["dv"],
                                       "vdot": release["vdot"], "dvdot": release["dvdot"], **restarts}}

    def _probes_unchecked_through_links(self) -> list:
        """The names of the probes whose terms of a held angle through the rigid links' reduction are not checked
        (:meth:`_refuse_what_a_held_angle_moves`; a rest there takes fewer,
        :meth:`_refuse_a_linked_rest`): all but points (in global axes; since heldcol in a body's axes too), joints'
        angles and rates, and since heldcol the kinetic, strain and total energies, momenta, elements' bending moments and joints' torques, a stuck one's
        reaction with its held angles' column (:func:`latdyn.analyses.joint_force_sensitivities.held_reaction_columns`)
        (the gimbals of tests/test_sensitivities_linked_sticks.py: ≤ 3.3e-8 of each probe's largest sensitivity off
        Richardson differences with the inner ring stuck, its own torque 1.1e-7 – 6.6e-7, ≤ 3.0e-7 with the boom's
        end hinge, at Newton's default tolerance), and the external work where no load is on a node that follows the
        links or in its axes (1.2e-9 at Newton's tolerance 1e-12; the loads' power on a dependent node does not take
        the held angle's move of it); and since workstick an element's axial force and torque (Richardson
        differences of the gimbal with its boom's EA 1e3: axial forces ≤ 7.2e-9 by F_c and 3.3e-9 by EI, torque
        2.8e-9 and 1.9e-8; at the boom's EA 1e5 the axial force was 2.0e-6, 6.2e-6, 2.0e-5 off at h = 1e-3, 3e-4,
        1e-4 p, growing as 1/h with the differences at h and h/2 as far apart: the roundoff of the reference's stiff
        stretch, not the derivative), and the potential energy (the gimbal under gravity, stuck and released twice:
        1.8e-9 by F_c, 4.5e-12 by m, 9.2e-10 by EI, 1.3e-8 by k at Newton's tolerance 1e-12). Not that external work."""
        def checked(probe) -> bool:
            if probe.kind == "energy" and probe.quantity == "external_work":
                node, _, frame = self._load_points()
                return not np.any(np.isin(np.concatenate([node, frame]), self.model.links.dependent))
            return probe.kind in ("point", "momentum") or (
                probe.kind == "hinge" and probe.quantity in ("angle", "rate", "torque")) or (
                probe.kind == "element" and probe.quantity in ("moment_y", "moment_z", "axial_force", "torque")) or (
                probe.kind == "energy" and probe.quantity in ("kinetic", "strain", "potential", "total"))

        return [p.name for p in self.probes if not checked(p)]

    def _refuse_a_linked_rest(self, new, j: int) -> None:
        """A hinge resting on its rigid stop in a model with rigid links is differentiated where no guide, latch,
        cable, controller or geometry parameter is in the model and the probes are points in global axes and joints'
        angles and rates (checked against Richardson differences on the gimbals of
        tests/test_sensitivities_linked_rest.py and benchmarks/fuzz_lifted.py's rests); refused elsewhere
        (:meth:`_refuse_resting`). fuzznew refused it whatever the model after fuzz_lifted's seed 1 case 5 was found
        3.0e-3 … 4.6e-2 off: the run released its ring and settled it again at one instant, which
        :meth:`_settle_or_release` did not follow (linkrest)."""
        model = self.model
        if model.links is None:
            return
        if any(h.end == "guide" for h in model.hinges):
            self._refuse_resting(new, j, "a joint comes to rest on its stop or leaves it in a model with guides (their "
                                         "reduction's restart is not differentiated there)")
        events = model.cables is not None or any(h.lock_at is not None for h in model.hinges)
        probes = [p.name for p in self.probes if not ((p.kind == "point" and p.frame == "global")
                                                      or (p.kind == "hinge" and p.quantity in ("angle", "rate")))]
        if events or probes or self.controllers is not None or self.geometry is not None:
            what = ("latches or cables" if events
                    else "controllers" if self.controllers is not None
                    else "geometry parameters" if self.geometry is not None
                    else f"probe {probes[0]!r} (not a point in global axes, a joint's angle or rate)")
            self._refuse_resting(new, j, f"a joint comes to rest on its stop or leaves it in a model with rigid links "
                                         f"beside {what} (their terms through the reduction's restart are not "
                                         "checked)")

    def _refuse_resting(self, new, j: int, why: str) -> None:
        """SceneError (exit 2) naming the rigid stop (``limits``) of hinge j: ``why`` its coming to rest on the stop
        or its release is not differentiated here (docs/parameters.md, "Sensitivities through events")."""
        raise SceneError(self.scene.file, stop_key(self.model.hinges[j]),
                         f"at t = {float(new.t):.6g} {why}: solve.sensitivities differentiates a hinge that lands on "
                         "its rigid stop with restitution 0 (without guides), rests there and is released at a step's end, one at a "
                         "time, not this; expected a run without it, or no solve.sensitivities (docs/parameters.md, "
                         "\"Sensitivities through events\")")

    def _restart(self, carried: dict, new, pending: dict) -> dict:
        """:meth:`after_events` at the event's time (``time_shift`` set: ∂r/∂t δt_e in ∂r/∂p). After a stop the
        run may restart more than once at one instant (``pending["restarts"]``: a release's, then its stop's,
        :meth:`_settle_or_release`), each at the accelerations the one before left: differentiated in turn."""
        model, k = self.model, len(self.names)
        n = model.n_dofs

        def packed(columns):
            return np.column_stack([pack(model, *column)[:n] for column in columns]) if k else np.zeros((n, 0))

        # δv̇ before the events on the new numbering: with rigid links the restart's W moves with the accelerations it
        # is taken at (its geometric term ∂Pᵀ/∂q · r_all holds the inertia forces)
        dq, dv, dvdot = packed(pending["dq"]), packed(pending["dv"]), packed(pending["dvdot"])
        out = {**carried, "dq": dq, "dv": dv, "pending": None}
        if n == 0:
            return {**out, "dvdot": np.zeros((0, k)), "da": np.zeros((0, k))}
        if pending["kind"] == "latch":
            M, C, K = self._matrices(new)
            rhs = self.residual_derivatives(new, 1.0, inertia=True) + K @ dq + C @ dv
            dvdot = np.asarray(solve_linear(M, rhs)).reshape(n, k) * -1.0
            return {**out, "dvdot": dvdot, "da": dvdot.copy()}
        if pending["free_restarts"]:   # settled on its stop: the restarts on the model with the hinge free came first
            before, dvdot = self._restart_before_settling(new, pending)
        else:
            before = new.copy()
            unpack_free(model, pack(model, *pending["vdot"])[:n], before.a, before.alpha, before.theta_ddot)
        for restart in range(pending["restarts"]):
            after = new if restart == pending["restarts"] - 1 else self._restarted(before)
            dvdot = self._restart_once(before, after, dq, dv, dvdot)
            before = after
        return {**out, "dvdot": dvdot, "da": dvdot.copy()}

    def _restart_before_settling(self, new, pending: dict) -> tuple:
        """(the state, δv̇ (n, k) on the locked numbering) the restart on the locked model starts from where the hinge
        ``pending["hinge"]`` came to rest on its stop at ``new``: the run restarts the accelerations with the hinge
        free ``pending["free_restarts"]`` times — once after the impact (``hinge_stops``); twice where it released
        the hinge and found it on its stop again (``release_from_stops``, then ``hinge_stops``) — then
        ``settle_on_stops`` zeroes its θ̈, locks it and restarts again, at the accelerations the last left (with
        rigid links W reads them: measured on the gimbal of tests/test_sensitivities_linked_rest.py, δθ̈ after the
        landing 3.1e-5 off Richardson differences of the run's state weighed at those before the impact). Those
        are differentiated in turn on the numbering with the hinge free (:meth:`_restart_once`), the model
        renumbered so for them and back, as ``settle_on_stops``' trial does."""
        model, j = self.model, pending["hinge"]
        side = model.resting[j]
        model.locked[j], model.resting[j] = False, 0
        model.number_coordinates()
        self.assembler.reindex()
        try:
            n = model.n_dofs
            dq, dv, dvdot = (np.column_stack([pack(model, *column)[:n] for column in pending[key]])
                             for key in ("dq", "dv", "dvdot"))
            before = new.copy()
            unpack_free(model, pack(model, *pending["vdot"])[:n], before.a, before.alpha, before.theta_ddot)
            for _ in range(pending["free_restarts"]):
                after = self._restarted(before)
                dvdot = self._restart_once(before, after, dq, dv, dvdot)
                before = after
            dvdot = self._on_nodes(dvdot)
        finally:
            model.locked[j], model.resting[j] = True, side
            model.number_coordinates()
            self.assembler.reindex()
        after.theta_ddot[j] = 0.0   # settle_on_stops: the locked hinge without acceleration, δθ̈ 0 with it
        n = model.n_dofs
        return after, np.column_stack([pack(model, *column)[:n] for column in dvdot])

    def _restarted(self, state):
        """A copy of ``state`` with the accelerations the run's restart takes from it
        (latdyn/timeloop/events.py ``restart_accelerations``: (M + dt²K) v̇ = −r(q, v, 0), W at ``state``'s)."""
        restarted = state.copy()
        restart_accelerations(self.prepared, None, restarted, self.scene.solve.dt)
        return restarted

    def _restart_once(self, before, after, dq: np.ndarray, dv: np.ndarray, dvdot_before: np.ndarray) -> np.ndarray:
        """δv̇ (n, k) of one restart, W v̇ = −r(q, v, 0) with W = M + dt²K at the accelerations of ``before`` and v̇
        those of ``after``: W δv̇ = −(∂r/∂p + K δq + C δv + dt² δ(K)v̇) (∂r/∂p, K, C exact at ``after``: r at v̇ less
        r(q, v, 0) is M v̇; δ(K) along δq and, with rigid links or guides, the accelerations before, δv̇⁻)."""
        model, n, k = self.model, self.model.n_dofs, len(self.names)
        scale = self.scene.solve.dt * self.scene.solve.dt
        self.assembler.complete_links(before)
        M, C, K = self._matrices(after)
        rhs = self.residual_derivatives(after, 1.0, inertia=True) + K @ dq + C @ dv
        matrix = self.assembler.evaluate(before, matrices=True).combined(1.0, 0.0, scale)
        rhs = rhs + self._weight_derivative(before, free_acceleration(model, after), dq, scale, mass=False,
                                            rates=(dv, dvdot_before))
        return np.asarray(solve_linear(matrix, rhs)).reshape(n, k) * -1.0

    def _matrices(self, state):
        """M, C and the exact K at ``state`` (:meth:`latdyn.assembly.assembler.Assembler.exact_matrices`:
        the elements' inertia tangent and the joint bodies' ``joint_body_inertia_stiffness``, which the
        step's Newton matrix leaves out; with guides the reduction's, with the dependent rates'
        q-dependence composed along the tree from the generated ``*_rates_D_q`` kernels)."""
        return self.assembler.exact_matrices(state)

    def _rotation_operators(self, increment: np.ndarray):
        """(R·, J·) on free-coordinate columns for the step's increment hΔq: on each free node's
        rotation coordinates R = exp(skew hΔq) and J = dexp(hΔq), the identity elsewhere
        (:class:`_NodeRotations`: ``.blocks`` the (f, 3, 3) blocks; J also as a SciPy matrix, ``.matrix``,
        made on first use). Where no free node has more than one rotation coordinate (a planar model: its
        nodes turn about the plane's normal alone), both are the identity on the coordinates — rotations
        about one fixed axis add, exp(skew ψ)_zz = dexp(ψ)_zz = 1 and the couplings to the other two
        (not coordinates) vanish, exactly, as the maps computed give them — and are taken as such
        (:meth:`_NodeRotations.identity`), without the maps."""
        model = self.model
        n = model.n_dofs
        # per numbering (Model's numbering makes node_dofs and free_nodes anew): the free nodes' rotation slots
        # (f, 3; ≥ n: not a coordinate), where the increment is read (n: a zero), the identity or None
        key = (model.node_dofs, model.free_nodes, n)
        held = self.__dict__.get("_identity_rotations")
        if held is None or any(a is not b for a, b in zip(held[0][:2], key[:2])) or held[0][2] != n:
            slots = model.node_dofs[model.free_nodes, 3:6]
            about_one_axis = turns_about_one_axis(slots, n)
            held = (key, slots, np.where(slots < n, slots, n),
                    _NodeRotations.identity(self, slots, n) if about_one_axis else None)
            self._identity_rotations = held
        _, slots, read, identity = held
        if identity is not None:
            return identity, identity
        psi = np.ascontiguousarray(np.append(increment, 0.0)[read])
        # the generated so3_exp and so3_dexp in the kernels' backend (C where compiled: the step's own and the
        # loop of steps' (csrc/sensitivity_loop.c); 9 µs against 32 µs for its NumPy form, expm_so3, at 31 nodes)
        turn = np.asarray(self.kernels.so3_exp(psi)[0]).reshape(-1, 3, 3)
        tangent = np.asarray(self.kernels.so3_dexp(psi)[0]).reshape(-1, 3, 3)
        return _NodeRotations(self, turn, slots, n), _NodeRotations(self, tangent, slots, n)

    def _step_matrix(self, slots: np.ndarray, dense: bool = False) -> "ExactStepMatrix":
        """The step's exact iteration matrix β′M + γ′C + K J on the assembler's pattern
        (:class:`latdyn.analyses.step_matrix.ExactStepMatrix`), built once per numbering; ``dense``: on the full
        n × n pattern (rigid links and guides: the reduced M, C and K of ``Assembler.linked_exact_matrix_values``; above
        DENSE_LIMIT coordinates or on a sparse storage on their pattern, ``Assembler.linked_exact_pattern``, the
        factorization chosen for it)."""
        n = self.model.n_dofs
        if dense:   # held per numbering (the native model's links are laid out anew with it)
            key = (self.assembler.native(True), n)
            pattern = self.assembler.linked_exact_pattern(key[0])
            held = self.__dict__.get("_held_dense_step_matrix")
            if held is None or held[0] is not key[0] or held[1] != n or not np.array_equal(held[2], slots):
                if pattern is not None:
                    held = (key[0], n, slots.copy(), ExactStepMatrix(*pattern, n, slots))
                else:
                    indptr = np.arange(0, n * n + 1, max(n, 1), dtype=np.int64)[:n + 1]
                    indices = np.tile(np.arange(n, dtype=np.int64), n)
                    held = (key[0], n, slots.copy(), ExactStepMatrix(indptr, indices, n, slots, kind="dense"))
                self._held_dense_step_matrix = held
            return held[3]
        indptr, indices = self.assembler.pattern()   # new arrays at every renumbering (Assembler.reindex)
        held = self.__dict__.get("_held_step_matrix")
        if held is None or held[0] is not indices or held[1] != n or not np.array_equal(held[2], slots):
            held = (indices, n, slots.copy(), ExactStepMatrix(indptr, indices, n, slots))
            self._held_step_matrix = held
        return held[3]

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
        parameters at once: a point x + T r moves by δx + δπ × T r, a hinge angle by δθ, rates by the
        carried δv (:meth:`_probe_derivatives`), energies and momenta along δq, δv and the external work as
        :meth:`step` carried it (latdyn/analyses/energy_sensitivities.py), a joint's force by its law's or its reaction's derivative
        along (δq, δv, δv̇) (latdyn/analyses/joint_force_sensitivities.py), section forces, cables' tensions
        (with δv: the damper) and lengths and points in a body's frame (latdyn/analyses/probe_derivatives.py)."""
        self.held = self._held(carried)
        dx, dpi, dtheta = self._by_parameter(carried["dq"], state)
        dtheta = dtheta + self.held   # a stuck joint's angle: where the run stuck it
        rates = (self._rates_by_parameter(carried["dv"], carried["dq"], state)
                 if any(p.quantity in ("rate", "velocity", "tension") or is_energy_or_momentum(p) for p in self.probes)
                 else None)
        if self._holds_through_links():
            self._held_dependent_motion(state, dx, dpi, rates)
        self._prescribed_in_time(state, np.asarray(carried["dt"]), dx, dpi, dtheta, rates)
        self.carried_accounts = carried   # the work's and dissipation's (latdyn/analyses/energy_sensitivities.py)
        forces = self._joint_forces(state, carried)
        row = [float(state.t)]
        for probe in self.probes:
            if is_joint_force(probe):   # a hinge's torque, a guide's force: its law or its reaction
                row.extend(float(v) for v in forces[joint_of(self.model, probe)])
                continue
            row.extend(self._probe_derivatives(probe, state, dx, dpi, dtheta, rates))
        return {**carried, "rows": carried["rows"] + [row]}

    def _joint_forces(self, state, carried: dict) -> dict:
        """The joint-force probes' derivatives at ``state`` (:func:`joint_force_derivatives`). At a row whose time
        moves with p (δt ≠ 0: an event's row, the rows after it until a step lands on the grid, adaptive steps)
        a force's explicit time dependence moves it too: a held joint's reaction by ∂r_d/∂t δt (its residual
        row: laws and loads in t, reels, prescribed motions; ∂r/∂p with ``time_shift``, as at an event) and a
        free joint's law −f(θ, θ̇, t) by −∂f/∂t δt (the laws' time derivatives through the same kernels,
        :class:`ExplicitTime`)."""
        moved = np.asarray(carried["dt"], float)
        shifted = self.explicit_time is not None and bool(np.any(moved))
        if shifted:
            self.time_shift = moved
        try:
            forces = joint_force_derivatives(self, state, carried["dq"], carried["dv"], carried["dvdot"])
        finally:
            if shifted:
                self.time_shift = None
        free = [j for j in forces if self.model.hinge_dofs[j] < self.model.n_dofs]
        stuck = np.flatnonzero(np.any(self.held, axis=1)) if self.held is not None else np.zeros(0, np.int64)
        if len(stuck) and free:   # a controller driving a free joint from a held angle: its δθ (held_sensor_forms)
            for j, column in held_sensor_forms(self, state, free, stuck).items():
                forces[j] = forces[j] + column @ self.held[stuck]
        reactions = [j for j in forces if j not in free]
        if len(stuck) and reactions and self.model.links is not None:   # a reaction through the links by the δθ
            for j, column in held_reaction_columns(self, state, reactions, stuck).items():
                forces[j] = forces[j] + column @ self.held[stuck]
        if shifted and free:
            rates = joint_force_forms(self.explicit_time.laws, state, free)
            for j in free:
                forces[j] = forces[j] + rates[j][3][0] * moved
        return forces

    def _prescribed_in_time(self, state, moved: np.ndarray, dx, dpi, dtheta, rates) -> None:
        """A row whose time moves with p (δt ≠ 0: after an event until a step lands on the grid, adaptive steps)
        moves the prescribed bodies and hinge angles along their motion: δx += v δt, δπ += ω δt, δθ += θ̇ δt on
        them, and their rates by their accelerations (the motion's own, at the row's time), into the
        (δx, δπ, δθ) and rates a probe's derivative reads."""
        from latdyn.model.model import PRESCRIBED

        if not np.any(moved):
            return
        nodes = [i for i, node in enumerate(self.model.nodes) if node.kind == PRESCRIBED]
        hinges = [j for j, hinge in enumerate(self.model.hinges) if hinge.angle is not None]
        for i in nodes:
            dx[i] += np.outer(state.v[i], moved)
            dpi[i] += np.outer(state.w[i], moved)
            if rates is not None:
                rates[0][i] += np.outer(state.a[i], moved)
                rates[1][i] += np.outer(state.alpha[i], moved)
        for j in hinges:
            dtheta[j] += state.theta_dot[j] * moved
            if rates is not None:
                rates[2][j] += state.theta_ddot[j] * moved
        if self.model.links is not None and (nodes or hinges):
            self._dependent_in_time(state, moved, dx, dpi, rates)

    def _dependent_in_time(self, state, moved: np.ndarray, dx, dpi, rates) -> None:
        """The nodes that follow rigid links from a prescribed body or hinge angle, at a row whose time moves
        with p (:meth:`_prescribed_in_time`): P δq moves them with the free coordinates only, and the
        prescribed motion carries them on by its own rates at fixed free coordinates
        (:meth:`dependent_motion_in_time`), δx += v° δt, δπ += ω° δt, and their rates by ∂v_dep/∂t."""
        dependent = self.model.links.dependent
        still, unaccelerated = self.dependent_motion_in_time(state, rates is not None)
        for node in dependent:
            dx[node] += np.outer(still.v[node], moved)
            dpi[node] += np.outer(still.w[node], moved)
        if rates is None:
            return
        for node in dependent:
            rates[0][node] += np.outer(unaccelerated.a[node], moved)
            rates[1][node] += np.outer(unaccelerated.alpha[node], moved)

    def dependent_motion_in_time(self, state, accelerations: bool = True) -> tuple:
        """(still, unaccelerated): copies of ``state`` whose dependent nodes' (v, ω) are (v°, ω°), their rates
        completed with the free rates 0 (the prescribed motion's own at fixed free coordinates), and whose
        dependent nodes' (a, α) are ∂v_dep/∂t at fixed free coordinates and rates, (a°, α°) − ∂(J v)/∂q v: their
        accelerations completed with the free accelerations 0 (J_p θ̈_p + the rates' quadratic terms) less the
        part of those terms that moves with the free coordinates (the generated ``*_rates_D_q``,
        latdyn/assembly/linked.py); ``unaccelerated`` None unless ``accelerations``."""
        model, assembler = self.model, self.assembler
        still = state.copy()
        unpack_free(model, np.zeros(model.n_dofs), still.v, still.w, still.theta_dot)
        assembler.complete_links(still)
        if not accelerations:
            return still, None
        from latdyn.assembly.linked import evaluate_linked

        unaccelerated = state.copy()
        unpack_free(model, np.zeros(model.n_dofs), unaccelerated.a, unaccelerated.alpha, unaccelerated.theta_ddot)
        assembler.complete_links(unaccelerated)
        ev = evaluate_linked(model.links, assembler, state, True, 1.0, True, inertia_tangent=True, rates_term=True)
        by_velocity = np.asarray(ev.rates_tangent[0] @ free_velocity(model, state)).reshape(-1, 6)
        for i, node in enumerate(model.links.dependent):
            unaccelerated.a[node] = unaccelerated.a[node] - by_velocity[i, 0:3]
            unaccelerated.alpha[node] = unaccelerated.alpha[node] - by_velocity[i, 3:6]
        return still, unaccelerated

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
            warning = (f"the step landed {miss:.2g} (relative) off the event of {joint} at t = {t:.9g} (regula "
                       "falsi on the step size not converged): its sensitivities are not exact to better than that")
            writer.warn(warning)
        if writer.out_dir is not None:
            text = csv_line(["t", *self.columns]) + "".join(csv_line(row) for row in carried["rows"])
            atomic_write_bytes(Path(writer.out_dir) / SENSITIVITIES_FILE, text.encode("utf-8"))


class _StepColumns:
    """The step's derivative before and after its solve (module docstring), k parameter columns and the
    step size's, each (n, k + 1): :meth:`predict` the predicted parts δa⁰, δq⁰, δv⁰ from the carried
    (δq, δv, δv̇, δa), :meth:`update` the step's end (δq, δv, δv̇, δa) from the solve z; each one native call
    (``latdyn_sensitivity_predict``, ``latdyn_sensitivity_update`` of csrc/sensitivity_step.c) with the
    exponential's R and J per free node (:class:`_NodeRotations`: none where they are the identity)."""

    def __init__(self, owner: TransientSensitivities, n: int, k: int, step: tuple, turn, tangent):
        from latdyn.assembly.library import native_library

        self.n, self.k, self.step = n, k, np.array(step, float)
        self.library = native_library()
        identity = turn.is_identity and tangent.is_identity
        self.f = 0 if identity else len(turn.slots)
        self.slots = np.ascontiguousarray(turn.slots, np.int64)
        self.turn, self.tangent = (np.ascontiguousarray(rotations.blocks, float) for rotations in (turn, tangent))
        self.predicted = None

    def predict(self, v_old, a_old, a_new, dq, dv, dvdot, da) -> tuple:
        """(δa⁰, δq⁰, δv⁰), each (n, k + 1)."""
        n, m = self.n, self.k + 1
        out = np.empty((5, n, m))
        inputs = [np.ascontiguousarray(a, float) for a in (v_old, a_old, a_new, dq, dv, dvdot, da)]
        self.library.latdyn_sensitivity_predict(n, self.k, self.step.ctypes.data, self.f, self.slots.ctypes.data,
                                                self.turn.ctypes.data, self.tangent.ctypes.data,
                                                *(a.ctypes.data for a in inputs), out.ctypes.data)
        self.predicted = out
        return out[0], out[1], out[2]

    def update(self, z: np.ndarray, beta_p: float, gamma_p: float) -> dict:
        """{dq, dv, dvdot, da} at the step's end from the solve ``z`` (n, k + 1) after :meth:`predict`."""
        out = np.empty((4, self.n, self.k + 1))
        z = np.ascontiguousarray(z, float)
        self.library.latdyn_sensitivity_update(self.n, self.k, self.step.ctypes.data, beta_p, gamma_p, self.f,
                                               self.slots.ctypes.data, self.tangent.ctypes.data, z.ctypes.data,
                                               self.predicted.ctypes.data, out.ctypes.data)
        return dict(zip(("dq", "dv", "dvdot", "da"), out))


class _NodeRotations:
    """A 3 × 3 block per free node on its rotation coordinates (``slots`` (f, 3), ≥ n: not a
    coordinate), the identity on the other coordinates: applied to free-coordinate columns by calling
    it; ``blocks`` (f, 3, 3); ``matrix`` the n × n SciPy CSR form (the iteration matrix's storage),
    made on first use."""

    def __init__(self, owner: TransientSensitivities, blocks: np.ndarray, slots: np.ndarray, n: int,
                 is_identity: bool = False):
        self.owner, self.blocks, self.slots, self.n = owner, blocks, slots, n
        self.complete = bool(np.all(slots < n))
        #: the identity on the coordinates (:meth:`identity`): applied as a copy
        self.is_identity = is_identity
        self._matrix = None

    @classmethod
    def identity(cls, owner: TransientSensitivities, slots: np.ndarray, n: int) -> "_NodeRotations":
        """The identity blocks on ``slots`` (R and J where each node has at most one rotation coordinate:
        :meth:`TransientSensitivities._rotation_operators`)."""
        return cls(owner, np.tile(np.eye(3), (len(slots), 1, 1)), slots, n, is_identity=True)

    def __call__(self, columns: np.ndarray) -> np.ndarray:
        slots, n = self.slots, self.n
        out = np.array(columns, dtype=float, copy=True)
        if self.is_identity:
            return out
        if self.complete:   # every free node's three rotations are coordinates (3D)
            out[slots] = np.einsum("fij,fjk->fik", self.blocks, columns[slots])
            return out
        on = slots < n
        full = np.vstack([columns, np.zeros((1, columns.shape[1]))])
        pieces = full[np.where(on, slots, n)]                                 # (f, 3, k)
        turned = np.einsum("fij,fjk->fik", self.blocks, pieces)
        out[slots[on]] = turned[on]
        return out

    @property
    def matrix(self):
        if self._matrix is None:
            n = self.n
            if n <= 0:
                self._matrix = np.zeros((0, 0))
            else:
                import scipy.sparse as sps

                keep, fixed, indices, indptr, order = self.owner._tangent_pattern(self.slots, n)  # noqa: SLF001
                values = np.concatenate([np.ones(fixed), self.blocks[keep]])
                self._matrix = sps.csr_matrix((values[order], indices, indptr), shape=(n, n))
        return self._matrix


# ---------------------------------------------------------------------------------------------- time


class _TimeRate:
    """∂f/∂t of a scene law at fixed θ, θ̇ (``value(θ, θ̇, t)``, as the parameters' derivative laws): of a
    :class:`latdyn.scene.expressions.TimeFunction` (a load component, a torque of t) its exact ``rate``
    (SymPy's derivative; a table's slope), of a :class:`latdyn.scene.expressions.HingeLaw` in θ, θ̇ and t
    the SymPy derivative of its expression by t (deltas dropped as for its other derivatives)."""

    #: read as a law of t alone where laws of the state are compiled (derivative_laws.of_the_state): a law of the
    #: state and t takes :func:`_time_rate_law`'s compiled rate, and keeps the Python path where it has none
    depends_on, input_names = ("t",), ()

    def __init__(self, law):
        self.function = None
        time = law if isinstance(law, TimeFunction) else law.time_function
        if time is not None:
            self.function = lambda theta, rate, t: time.rate(t)
            return
        import sympy as sp

        symbols, (expr, *_) = law.expressions    # (θ, θ̇, t, the inputs and controllers it names)
        derivative = _drop_deltas(sp.diff(expr, symbols[2]))
        compiled = sp.lambdify(symbols, derivative, modules="numpy")
        self.function = lambda theta, rate, t: compiled(float(theta), float(rate), float(t), *law._input_values())

    def value(self, theta: float, rate: float, t: float) -> float:
        with np.errstate(all="ignore"):
            return float(self.function(theta, rate, t))


def _time_rate_law(law, scene, key: str):
    """∂f/∂t at fixed θ, θ̇ of a hinge or guide law of the state and t as a law of the state itself (a
    :class:`latdyn.scene.expressions.HingeLaw` of SymPy's derivative's text, deltas dropped as :class:`_TimeRate`
    drops them), which :class:`latdyn.analyses.derivative_laws.DerivativeLaws` compiles as the parameters' derivative
    laws (the same C on the per-step path and in the loop of steps); the text kept in the expression cache (kind
    "time_rate"). None where the law has no SymPy expression or its derivative does not parse."""
    from latdyn.scene import expressions as scene_expressions

    def rate(held):
        import sympy as sp

        symbols, (expr, *_) = held
        return _drop_deltas(sp.diff(expr, symbols[2]))

    return scene_expressions.derivative_as_law(law, scene, key, "time_rate", "d/dt", "its rate in t", rate)


class ExplicitTime:
    """∂r/∂t of the equations of motion at fixed free coordinates, rates and accelerations (module
    docstring, "Laws in time"): what moves the residual when a step's end moves in time.

    - load components f(t), hinge and guide laws k, c, τ in (θ, θ̇, t): their exact time derivatives
      (:class:`_TimeRate`) through the same generated kernels as the parameters' derivatives
      (:meth:`latdyn.analyses.sensitivities.ParameterDerivatives.residual_derivatives`: point_load,
      hinge_force, linear in those values), one column;
    - a reel (a cable's rest length L0(t)): :meth:`CableSensitivities.reel_forces`;
    - prescribed motions (a body's translation and rotation, a hinge's angle): exactly, the blocks of M, C and
      the exact K coupling every row to the prescribed coordinates times the motion laws' exact first, second
      and third time derivatives (:class:`latdyn.analyses.prescribed_rates.PrescribedRates`, one native call,
      csrc/prescribed_rates.c), a continuous controller's coupling on a prescribed coordinate among those blocks;
      on a model with rigid links or guides the dependent nodes moved with the prescribed coordinates, reduced by
      Pᵀ, with the links' geometric term (:meth:`~latdyn.analyses.prescribed_rates.PrescribedRates.linked`,
      csrc/linked_prescribed_rates.c)."""

    def __init__(self, owner, laws: dict, prescribed: bool, reels: bool):
        import copy

        self.owner = owner
        self.prescribed, self.reels = prescribed, reels
        #: ∂r/∂t through the prescribed motions, exactly (None without prescribed motions)
        self.motions = None
        if prescribed:
            from latdyn.analyses.prescribed_rates import PrescribedRates

            self.motions = PrescribedRates(owner)
        # the parameters' machinery, with one column: t (the controllers' outputs' explicit ∂y/∂t through
        # their actuators, as ∂y/∂p: :func:`_controller_time_rates`)
        self.laws = copy.copy(owner)
        self.laws.names, self.laws.derivatives = ["t"], laws
        self.laws.controllers = _controller_time_rates(owner)
        for cache in DERIVATIVE_CACHES:   # the owner's, made of its derivatives: made afresh of the laws in t
            self.laws.__dict__.pop(cache, None)
        self.laws._values_at = (float("nan"), {})
        self.laws.geometry = None   # the one column is t: no start moved by geometry parameters (k columns)
        self.laws.motions, self.laws.reels = self.motions, reels   # the loop's ∂r/∂t struct reads them (_TimeRates)
        # the rates of laws of the state and t (HingeLaws of ∂f/∂t: _time_rate_law) compiled as the parameters'
        # derivative laws of the state, the same C on both paths (latdyn/analyses/derivative_laws.py); none: None
        self.laws.derivative_laws = DerivativeLaws.of(self.laws)

    @classmethod
    def of(cls, owner) -> "ExplicitTime | None":
        """The scene's explicit time dependence, or None where nothing depends on t or neither an event nor
        adaptive steps can move a step's end in time (then every δt is 0:
        :func:`latdyn.analyses.sensitivities.has_events`)."""
        from latdyn.analyses.parameter_keys import prescribed_motion
        from latdyn.analyses.sensitivities import depends_on_time, has_events

        scene = owner.scene
        reels = any(not c.rest_length.is_constant for c in scene.cables.values()) if scene.cables else False
        timed = owner.controllers is not None and any(c.output_names_t for c in owner.controllers.continuous)
        if (not depends_on_time(scene) and not reels and not timed) or not (has_events(scene) or scene.solve.adaptive):
            return None
        laws: dict[str, dict[int, _TimeRate]] = {}

        def add(key, law):
            if law is not None and not isinstance(law, (int, float)) and "t" in _depends(law):
                of_the_state = not isinstance(law, TimeFunction) and law.time_function is None
                rate = _time_rate_law(law, scene, key) if of_the_state else None
                laws[key] = {0: rate if rate is not None else _TimeRate(law)}

        for i, load in enumerate(scene.loads):
            for kind in ("force", "moment"):
                for axis, component in enumerate(getattr(load, kind) or []):
                    add(f"loads[{i}].{kind}[{axis}]", component)
        for beam, which, hinge in scene.hinges:
            for law in ("stiffness", "damping", "torque"):
                add(f"beams.{beam}.{which}.hinge.{law}", getattr(hinge, law))
        for name, body in scene.bodies.items():
            if body.guide is not None:
                for law in ("stiffness", "damping", "force"):
                    add(f"bodies.{name}.guide.{law}", getattr(body.guide, law))
        return cls(owner, laws, prescribed_motion(scene), reels)

    def of_laws(self, state, inertia: bool = True, on_all: bool = False) -> np.ndarray:
        """∂r/∂t of the laws and reels (not the prescribed motions): (n_total + 1,) with ``on_all``, else on
        the free coordinates (``inertia``: as the parameters' ∂r/∂p; no law in t moves an inertia force)."""
        total = ParameterDerivatives.residual_derivatives(self.laws, state, 1.0, inertia=inertia, on_all=True)[:, 0]
        if self.reels and self.owner.cables is not None:
            self.owner.cables.reel_forces(state, total)
        if on_all:
            return total
        return self.owner._on_free_coordinates(state, total[:, None])[:, 0]

    def __call__(self, state, inertia: bool = True, on_all: bool = False,
                 prescribed: np.ndarray | None = None) -> np.ndarray:
        """∂r/∂t (n,) on the free coordinates at ``state``: of the equations of motion, or without
        ``inertia`` of the static residual (:meth:`TransientSensitivities._stiffness_derivative` differences the
        static ∂r/∂p along w; the laws in t are loads', hinges' and guides', none the elements' gravity load, which
        it leaves out; the prescribed motions' part is of the whole static residual); ``on_all``: on all
        coordinates (n_total + 1,), before the rigid links' and guides' reduction (their geometric term at an
        event, :meth:`TransientSensitivities._geometric_derivative`, reads it). ``prescribed``: the prescribed
        motions' part already evaluated (the step's, with the controllers' states condensed), else evaluated here."""
        out = self.of_laws(state, inertia, on_all=on_all)
        if self.prescribed:
            out = out + (self.through_prescribed(state, inertia, on_all=on_all) if prescribed is None else prescribed)
        return out

    def through_prescribed(self, state, inertia: bool = True, on_all: bool = False) -> np.ndarray:
        """∂r/∂t (n,) through the prescribed motions alone (class docstring): the loads, laws and rest
        lengths read the state's own time; exactly (:class:`latdyn.analyses.prescribed_rates.PrescribedRates`);
        ``on_all``: of the assembled residual and the reactions (n_total + 1,), before the reduction."""
        if self.owner.model.links is not None:
            total, reduced = self.motions.linked(state, inertia)
            return total if on_all else reduced
        total = self.motions(state, inertia)
        return total if on_all else self.owner._on_free_coordinates(state, total[:, None])[:, 0]


def _controller_time_rates(owner):
    """The continuous controllers' explicit time derivative as a one-column
    :class:`latdyn.analyses.sensitivities.ControllerTerms` (its column t): ∂y/∂t at fixed sensors, SymPy's
    derivative of the output by t (deltas dropped), chained through the controllers that read a timed one and
    applied through the actuators as ∂y/∂p is; None where no continuous controller's output names t. Controllers
    with states or sampled ones beside events or adaptive steps are refused before (their states and samples are
    not moved in t). Its partials ∂f/∂t are compiled as the parameters' are
    (:class:`latdyn.analyses.derivative_laws.ControllerPartials`): the one C function the per-step Python path and the
    loop of steps (csrc/sensitivity_loop.c ``explicit_time_columns``) call; their lambdas where they do not compile."""
    terms = owner.controllers
    if terms is None:
        return None
    timed = [c for c in terms.continuous if c.output_names_t]
    if not timed:
        return None
    import copy

    import sympy as sp   # here, not above: a run without such a controller does not import SymPy (0.5 s)

    rates = copy.copy(terms)
    rates.k, rates.held, rates.sampled, rates.states = 1, {}, None, None
    # the sensed forces' ∂F/∂p are the parameters' columns, not t's (a force whose law names t is refused beside
    # events before the run): a reader of an element's axial force moved by EA beside a timed controller ended in a
    # ValueError (1,) against (k,) (tests/test_fuzz_run_findings6.py)
    rates.forces_read = {}
    expressions = {c.name: {0: _drop_deltas(sp.diff(c.output_expr, c.symbols[0]))} for c in timed}
    rates.partial_expressions = expressions
    rates.partials = {name: {0: sp.lambdify(c.symbols, expressions[name][0], modules=["math", "numpy"])}
                      for name, c in ((c.name, c) for c in timed)}
    rates.compiled = ControllerPartials.of(rates, expressions)
    return rates


def _times(matrix, columns: np.ndarray) -> np.ndarray:
    """``matrix @ columns`` (n, k) for a NumPy array, a SciPy sparse matrix or a :class:`latdyn.numerics.csr.CSR`
    (column by column: SciPy's ``csr_matvecs`` adds each row's products in the stored order from 0, as
    :meth:`~latdyn.numerics.csr.CSR.matvec` does, so the same values to the bit)."""
    if not isinstance(matrix, CSR):
        return matrix @ columns
    return csr.times(matrix, columns)


def _depends(law) -> tuple:
    """The variables among θ, θ̇, t a scene law uses (a TimeFunction: t unless constant)."""
    if isinstance(law, TimeFunction):
        return () if law.is_constant else ("t",)
    return law.depends_on


# ---------------------------------------------------------------------------------------------- cables


