"""The transient sensitivities' smooth step inside the loop of steps in C (issue 34, item 2).

A run with ``solve.sensitivities`` took every step from Python (latdyn/timeloop/loop.py ``_python_step``, then
:meth:`latdyn.analyses.transient_sensitivities.TransientSensitivities.step`). Where every term of that step's
derivative is native, the loop of steps (csrc/newton_step.c ``latdyn_advance``) carries δq, δv, δv̇, δa and δt
through each step it accepts (csrc/sensitivity_loop.c): the same calls on the same inputs, in the Python step's
order, and returns to Python where it returns without sensitivities (an event, a Newton failure, the budget, the
rows' buffers full). Its rows are recorded on its way as the run without sensitivities records them (csrc/rows.c),
with the carried δq, δv, δv̇ and δt at each row (``sensitivity_loop_row``), from which :meth:`SensitivityLoop.record_rows`
takes the rows' sensitivities: a block's points' components and hinge angles at once
(latdyn/analyses/sensitivity_rows.py), other probes by :meth:`TransientSensitivities.record` at each row's state.
Every event, jump, stick or release, landing, Newton cut and the steps after them take the Python path
as before; so do the runs :func:`refusal` names, for the whole run (decided once, at the start).

Native: ∂r/∂p of section values (constants, as every section value is: latdyn/scene/loader.py refuses a law of t or
of an input there, so their derivative laws are constants; the generated ``*_D_section`` kernels,
csrc/parameter_forces.c), of load components (the generated ``point_load``, linear in the values, with the
derivative laws' values at each grid point tabulated here before each call: a law in t is evaluated by the same
law object at the same t the Python step reads), of a hinge's stiffness, damping, rest angle and torque whose
derivative laws (and for the rest angle the hinge's stiffness) are values of t alone or laws of θ, θ̇, t and inputs
that compile (the generated ``hinge_force``, linear in the laws, at the hinge's θ, θ̇ in C, the laws of t tabulated
alike, the laws of the state compiled as the step's own laws and evaluated in C at the hinge's θ, θ̇, t, the same C
the Python step calls: latdyn/analyses/derivative_laws.py; ``_hinge_refusal``)
and of a joint body's mass, inertia and centre of mass (the generated ``joint_body`` with the use's block, or
``joint_body_D_com`` along ∂c/∂p, the blocks made by ``ParameterDerivatives.body_block`` and tabulated alike) and of
a rigid link's own section values (its joint body's mass and inertia, link_sensitivities.add_link_section_forces:
the same kernel with the generated ``rigid_link_inertia_D_section``'s block, after the joint bodies' uses as the Python step adds it), of
a hinge's compliant stops' and friction's law values (the generated ``contact_force_D_law``,
``friction_force_D_law`` at the hinge's θ, θ̇ in C, times the derivative laws' values tabulated alike), a guide's
laws and its compliant stops' and friction's values (the hinge laws they are, on the slide), of
geometry parameters (the held variations of ReferenceGeometry taken to the state by the generated
``reference_variation_at_state``, then the generated ``beam_internal_force_D_reference`` and
``beam_inertia_force_D_reference``, and for a load at a moved offset ``point_load_D_offset`` with the load's values
tabulated alike, csrc/geometry_forces.c, with the Python path's rows: ``_geometry_refusal``; a shift of a subtree on a
part that turns and a rigid link's length or direction moved — ReferenceGeometry.turning and link_moves — by
csrc/turning_shifts.c, the C the Python path calls too, on M, C and the exact K scattered from the step's evaluation
before the reduction, not beside controllers that read other than joints' angles and rates), of a cable's EA,
damping, rest length and ρA whose derivative laws are values of t alone (the generated ``cable_force`` with the
derivative in EA's or c's place, ``cable_force_D_rest_length``, and ``joint_body`` for its lumped masses, at each
element held taut, csrc/cable_forces.c, the laws tabulated alike: ``_cable_refusal``; a step that crosses a cable's
change or ends near one is handed back: csrc/cable_forces.c ``cable_near_change``; beside the controllers and the
explicit time dependence below too, their columns added after the controllers' and the loads' and before ∂r/∂t δt_n,
as the Python step adds them: tests/test_sensitivities_in_loop_cables2.py), and
parameters of ``initial_velocity`` (they move the start only), and explicit time dependence beside events
through load components and hinge and guide laws whose rate in t is a value of t alone (laws of t alone, and laws
naming a controller's output or an input whose derivative by t names neither: a PD torque ``pd + 0.3*sin(9*t)``;
``_rate_in_time_alone``), through continuous controllers' outputs that name t (a feed-forward set point
``Kp*(a0 + g*sin(3*t) - angle)``, chains of them: their ∂f/∂t compiled as the parameters' ∂f/∂p are,
transient_sensitivities._controller_time_rates, the same C on both paths, taken through the actuators by
``controller_parameter_forces`` on ∂r/∂t's struct, ``_TimeRates._controllers``, where ``_controller_refusal`` takes the
controllers) (∂r/∂t at the step's end through the same point_load and
hinge_force calls, their exact rates tabulated per grid point: :class:`_TimeRates`, ``_time_refusal``; ∂r/∂t δt_n in
the parameters' columns, ∂r/∂t in the step size's, as ``TransientSensitivities._add_time_columns``; δt_n is 0 at
every step the loop takes in the runs measured, the landing on the grid before it having cancelled it) and through
prescribed motions (the blocks of M, C and the exact K coupling every row to the prescribed coordinates, and the
continuous controllers' couplings of sensors that read them, times the motion laws' exact rate, acceleration and
jerk tabulated per grid point: csrc/prescribed_rates.c ``latdyn_prescribed_time_rate``, which the Python path's
ExplicitTime.through_prescribed calls too; :class:`_TimeRates` ``_motions``; on a model with rigid links or guides
the dependent nodes moved with the prescribed coordinates through J, ∂c/∂v and the dependent rates' ∂/∂q, reduced by
Pᵀ, with the geometric term ∂(Pᵀ)/∂q_p q̇_p · r_all, csrc/linked_prescribed_rates.c
``latdyn_linked_prescribed_time_rate``, on both paths too),
through reels (a cable's
rest length in t: each a rest-length use of csrc/cable_forces.c with L0′(t) tabulated, ``_TimeRates._reels``; beside
the other explicit time dependence and controllers too, their columns after the hinge laws', the controllers' and the
loads', as ExplicitTime.of_laws adds them: tests/test_sensitivities_in_loop_accounts2.py) and through hinge and guide
laws of the state and
t (their ∂f/∂t a law of the state compiled with the derivative laws, transient_sensitivities._time_rate_law), and the
parameters inside continuous controllers' outputs (their partials ∂f/∂p compiled as the step's controller laws, the
same C the Python step calls: derivative_laws.ControllerPartials; with limits their outputs too, which decide the
clip) for controllers without states that read hinge and guide angles and rates and inputs (constant in a run: the
compiled laws read the scene's inputs' array, bound before each call of the loop; the law's argument read from that
array, ``_reads`` kind 4) and drive hinge torques and guide forces, and for those that read points' positions,
displacements and velocities (global, or in a body's axes) and cables' lengths and tensions, elements' section forces and free joints' torques and forces (the values the
evaluation at the step's end left in Work, csrc/evaluate.c ``sensor_value``, which the
Python step reads too through ``latdyn_controller_outputs_at``: ControllerTerms.sensed_in_c; a force's coupling along
δq, δv is in the exact K and C on both paths; where a parameter moves a free joint's own laws — its stiffness,
damping, rest angle or torque, its compliant stops' laws — its ∂F/∂p through ∂f/∂s as
ControllerTerms.sensed_force_slopes takes it: −(the joint's row of the hinge laws' ∂r/∂p, the generated hinge_force's,
as ``hinge_parameter_forces`` leaves it, plus its row of the stops' and friction's, the generated contact_force_D_law's
and friction_force_D_law's: csrc/sensitivity_loop.c ``joint_law_force_slopes``) times the reader's compiled output's
∂f/∂s, SensitivityLoop._sensed_force_slopes; where a parameter moves a read element's section values, its ∂S/∂p
from the generated beam_section_forces_D_section contracted with the section uses' rows, csrc/parameter_forces.c
``section_force_slope``, which ControllerTerms.sensed_force_slopes calls too; where a parameter moves a read cable's
EA, damping or rest length, its tension's ∂N/∂p from the generated cable_force and cable_force_D_rest_length at the
element's inputs, csrc/cable_forces.c ``cable_tension_slope``, as probe_derivatives._tension_by_parameters forms it),
that read earlier
controllers (chains: the earlier controllers' outputs and the reader's derivatives by them from their compiled output
laws, derivative_laws.chained_outputs and ControllerPartials.gradient, which the Python step calls too; a chain starts
at a controller with partials or at one reading a force whose own laws a parameter moves, partials or none:
tests/test_sensitivities_in_loop_controller_chains.py) and that drive
load components (the generated point_load per actuated load with the actuators' slopes, as ControllerTerms.add),
and sampled controllers between their samples (the loop hands each sample
instant back to Python, latdyn/timeloop/loop.py ``samples_in_loop`` off, where the sample and its restart are
differentiated as before, TransientSensitivities.after_sample; between them the held outputs' δy, copied into the
struct before each call, through their hinge, guide and load actuators as SampledTerms.add: csrc/sensitivity_loop.c
``sampled_parameter_forces``), and continuous controllers with states (a PI's integral, a filter) that read hinge
and guide angles and points' positions and displacements in global or a body's axes, at a node or offset from it (not
beside geometry parameters; their values the evaluation's sensor_value, a point's δs at an offset or in a body's axes
its gradient times δq, csrc/controller_states.c ``controller_state_sensed``, which the per-step path calls too; a
prescribed body's or hinge's beside events too: δt is 0 at every step the loop takes), on a model with rigid links or
guides too where no sensor of theirs is on a rigid link's body or a guided body (the matrices condensed inside
``latdyn_linked_exact_values``, the step size's column reduced by Pᵀ, tests/test_sensitivities_in_loop_states_more.py),
and drive hinge torques, guide forces and load components (the step size's column
through the states reaching the loads by csrc/sensitivity_loop.c ``controller_states_load_step_size``), read by
no other controller (the package runs no such chain: latdyn/assembly/control.py), beside sampled controllers too
(``_states_refusal``), and probes recording their states and outputs (each recorded row's δS and accepted S kept in C,
csrc/controller_states.c ``controller_states_row``, and handed to TransientSensitivities.record by
:meth:`SensitivityLoop.record_rows`, so a row's controller probe reads them as on the Python path): the loop carries
δS, δf
and the accepted (S, f) at each step's start (handed to and from the carried sensitivities around each call, so in the
checkpoint), takes the states' rates' ∂f/∂s, ∂f/∂S and the output's ∂y/∂S from the step's own compiled controller law
and the rates' ∂f/∂p from the compiled partials (ControllerPartials.rate_uses), evaluates M, C and the exact K with the
states condensed from (S_n, f_n) and h/2 as the step does, and does the p × p algebra (held δS, the step size's part,
δS_{n+1}, δf_{n+1}) in csrc/controller_states.c, the C the per-step path's ControllerStates calls too
(``_controller_refusal``; the controllers' couplings are in the exact K and C on both paths); on models with rigid
links and guides too (with the controllers above, every kind of them: a sensor at a point on a rigid link's body or a
guided body reads the dependent node the step's evaluation completed, its couplings reduced with K and C, and the
actuated loads' columns reduced by Pᵀ with the others, tests/test_sensitivities_in_loop_linked_controllers.py; and
with the explicit time dependence above; a force sensor between dependent nodes reads the force the evaluation
computed after completing them, tests/test_sensitivities_in_loop_controller_reads2.py): M, C and the exact K on the
minimum coordinates and ∂r/∂p (the controllers' columns among them) and ∂r/∂t each reduced by Pᵀ, from the compiled
step's own reduction (csrc/linked_matrices.c, ``latdyn_linked_exact_values`` and ``latdyn_linked_reduce_columns``
over csrc/links.c's), which the per-step Python path calls too (``Assembler.linked_exact_matrix_values``,
``sensitivities.reduced_columns``): up to DENSE_LIMIT free coordinates on a dense or band storage, dense, S on the full
n × n pattern; above it or on a sparse storage as values of the iteration matrix's reduced pattern
(``Assembler.linked_exact_pattern``), S on that pattern, its factorization chosen for it (band or sparse). Energy and momentum probes of a row's state alone (kinetic, strain, potential, total, linear and
angular momenta) need no term in the step: their rows' sensitivities are TransientSensitivities.record's at each row
from the carried δq, δv (``_energy_refusal``). The work accounts, sums over the steps by the forward run's
quadrature — the dissipated energy (the dampers' work) and the external work (the point loads' power, the generated
point_load's, with ∂Q/∂p of the load parameters, and the hinges' applied torques and springs that are not
conservative) — are carried by csrc/work_accounts.c at each step the loop accepts and at each row it records, the C
the per-step Python path calls too (energy_sensitivities._dissipated_step, external_work_step, _power), with the
laws' values (damping laws, load values, applied torques and springs, and their parameters' derivative laws) tabulated
per grid point where they are laws of t alone, and where they name θ, θ̇ or an input compiled as the step's hinge laws
and evaluated in C at the hinge's θ, θ̇, t (energy_sensitivities.account_laws, the same C on both paths), with a
prescribed motion's drive (δr_d = ∂r_d/∂p + K_d δq + C_d δv + M_d δv̇ from ∂r/∂p's rows and one evaluation's blocks,
and ½ Σ_d Δq_d (δr_d,n + δr_d,n+1): csrc/drive_sensitivities.c, which energy_sensitivities._drive_reactions and
external_work_step call too); the dissipated energy with rigid links and guides too (its dampers' δθ, δθ̇ — a guide's
δs, δṡ — are free coordinates), the external work with rigid links and guides (a load's node or frame that follows the links
or a guide moved by J δq, J δv + ∂(J v)/∂q δq from the links' buffers: csrc/work_accounts.c dependent_node_motion, which
energy_sensitivities._power calls too) (``_account_refusal``; the accounts and their terms handed back at the loop's end, an event's account
after it is the Python path's, energy_sensitivities.external_work_after_event). Not native (the Python path): hinge and guide laws whose derivative
names θ, θ̇ or an input and does not compile (every form of the expression language's names measured compiles: only
a failed build or no compiler), cable parameters whose derivative names θ, θ̇ or an input, section
values whose derivative is a law in t or an input (the loader refuses those anyway), controllers with states
that ``_states_refusal`` names (a sensor other than joint angles and rates, nodes' velocity components and points'
positions and displacements — a point's velocity off its node or in a body's axes, whose δs = D_q δq + D_v δv the
per-step path takes (ControllerStates._sensed), not this loop —, a point on a rigid link's body or a guided body (its δs P δq,
the per-step path's NumPy), beside geometry parameters, or whose laws did not compile),
controllers reading a
section force whose section values a parameter moves beside geometry parameters (refused on both paths),
controllers' outputs that name t where ``_controller_refusal`` refuses their controllers (an input
read, …) or their rate in t does not compile, or laws of the state and t whose rate in t is not a value of t alone
and does not compile, the work accounts (energy_sensitivities.external_work_step)
with a law of θ, θ̇ or an input in them that does not compile, and the NumPy kernels. The discrete adjoint's forward
pass and its reverse pass's smooth steps (latdyn/analyses/adjoint_in_loop.py) are native on the runs
:func:`model_refusal` lets through, with rigid links and guides too, not with cables (``adjoint_in_loop.refusal``).

Step matrices of every storage: where a model has S on the supernodal sparse LU (above DENSE_LIMIT coordinates, its
bandwidth after reverse Cuthill–McKee above BAND_LIMIT: a designer's lattice, with rigid links or not), the loop
sums, factorises and solves it by the same native call as the Python step (csrc/sensitivity_step.c
``latdyn_sensitivity_step``: one factorization a step, k + 1 back-substitutions), and at a step whose sparse pivot
fails the band LU with pivoting stands in as it does in :meth:`latdyn.analyses.step_matrix.ExactStepMatrix.solve_step`
(Factorization._factor_pivoted's band, made once a numbering at the layout: the same storage, order and right-hand
sides, ``latdyn_sensitivity_step_pivoted``), so those steps stay in the loop too (:meth:`SensitivityLoop._pivoted`).

Results: the planar models' rotations are the identity and every sum is the Python step's: the sensitivities
are the Python path's to the bit. In 3D, R = exp(skew hΔq) and J = dexp(hΔq) are the generated ``so3_exp`` and
``so3_dexp`` on both paths (the C kernels, called from C in the loop and through the kernel set in the Python step),
so those are the same bits too.
"""
from __future__ import annotations

import ctypes
from functools import partial

import numpy as np

from latdyn.analyses.energy_sensitivities import STATE_ENERGIES, is_energy_or_momentum
from latdyn.analyses.geometry_sensitivities import GEOMETRY_KEY
from latdyn.analyses.sensitivity_rows import block_rows
from latdyn.analyses.parameter_keys import (BODY_KEY, CABLE_KEY, CONTACT_KEY, FRICTION_KEY, FRICTION_SLOT,
                                            GUIDE_CONTACT_KEY, GUIDE_KEY, HINGE_KEY)
from latdyn.analyses.sensitivities import _INITIAL_VELOCITY_KEY, _LOAD_KEY, _SECTION_KEY
from latdyn.assembly.native_model import NO_CONTACT
from latdyn.analyses.step_matrix import turns_about_one_axis

__all__ = ["SENSITIVITIES_IN_LOOP", "refusal", "model_refusal", "SensitivityLoop"]

#: Whether a run whose sensitivities' terms are all native takes its smooth steps in the loop of steps (False:
#: every step from Python, the reference it must equal: tests/test_sensitivities_in_loop.py). Private.
SENSITIVITIES_IN_LOOP = True


def refusal(owner) -> str | None:
    """Why the sensitivities of ``owner`` (a TransientSensitivities) take every step from Python, or None where
    their smooth steps may run in the loop of steps (module docstring). Once a run."""
    why = model_refusal(owner, differentiated=True)
    if why is not None:
        return why
    for key, laws in owner.derivatives.items():
        if _INITIAL_VELOCITY_KEY.match(key) or _LOAD_KEY.match(key) or GEOMETRY_KEY.match(key):
            continue   # (the geometry parameters: as a whole, _geometry_refusal)
        if CABLE_KEY.match(key):
            if not all(map(_in_time_alone, laws.values())):
                return f"{key}: its derivative is a law in theta, theta_dot or an input"
            continue   # (the cables' kernels: model_refusal)
        if _SECTION_KEY.match(key) and not GEOMETRY_KEY.match(key) and all(law.is_constant for law in laws.values()):
            continue
        why = (_hinge_refusal(owner, key, laws) if HINGE_KEY.match(key) or GUIDE_KEY.match(key) else
               _body_refusal(owner, key, laws) if BODY_KEY.match(key) else
               _joint_law_refusal(owner, key, laws) if (CONTACT_KEY.match(key) or GUIDE_CONTACT_KEY.match(key)
                                                        or FRICTION_KEY.match(key)) else
               f"{key}: not a native parameter kind")
        if why is not None:
            return why
    if owner._section_layout() is not None and owner._section_kernel_addresses() is None:  # noqa: SLF001
        return "section kernels without C libraries"
    return _geometry_refusal(owner) if owner.geometry is not None else None


#: the generated kernels the cables' parameters' ∂r/∂p calls in the loop (csrc/cable_forces.c)
CABLE_KERNELS = ("cable_force", "cable_force_D_rest_length", "joint_body")


def _cable_refusal(owner) -> str | None:
    """Why a model with cables keeps the run on the Python path, or None: their parameters' ∂r/∂p
    (CableSensitivities.residual_derivatives) is the generated kernels' of :data:`CABLE_KERNELS`, which
    csrc/cable_forces.c calls on the evaluation's inputs; each slack/taut change, and every step that ends within
    twice an element's tolerance of one, is handed back to Python (csrc/cable_forces.c ``cable_near_change``). A reel
    (a rest length in t) is explicit time dependence beside the cables' events (:func:`model_refusal`)."""
    if any(owner.kernels.address(name) is None for name in CABLE_KERNELS):
        return "cable kernels without C libraries"
    return None


#: the generated kernels the geometry parameters' ∂r/∂p calls in the loop (csrc/geometry_forces.c)
GEOMETRY_KERNELS = ("reference_variation_at_state", "beam_internal_force_D_reference",
                    "beam_inertia_force_D_reference", "point_load_D_offset")


def _geometry_refusal(owner) -> str | None:
    """Why the geometry parameters keep the run on the Python path, or None: their ∂r/∂p
    (ReferenceGeometry.add) is the generated kernels' of :data:`GEOMETRY_KERNELS` along the held variations, which
    csrc/geometry_forces.c forms at the state as the Python path does (a load at a moved offset: the generated
    point_load_D_offset with the load's values tabulated per grid point, ReferenceGeometry._load_arms)."""
    if any(owner.kernels.address(name) is None for name in GEOMETRY_KERNELS):
        return "geometry kernels without C libraries"
    if (owner.geometry.turning or owner.geometry.link_moves) and owner.scene.controllers:
        from latdyn.assembly.control import ANGLE, RATE

        # a sensed point moved by the shift: ControllerTerms._shift_sensed, the per-step path's; joints' angles and
        # rates hold no reference
        if not {int(kind) for kind in owner.assembler.control.sensor_kind} <= {ANGLE, RATE}:
            return ("a geometry parameter moves a hinge point, a guide's origin or a rigid link on a part that turns, "
                    "beside controllers that read other than joints' angles and rates")
        if owner.controllers.sampled is not None:   # (not measured with the shift in the loop)
            return ("a geometry parameter moves a hinge point, a guide's origin or a rigid link on a part that turns, "
                    "beside sampled controllers")
    return None


def _in_time_alone(law) -> bool:
    """Whether a law's value is one of t alone (a number, a table, an expression in t): tabulated at the grid points
    by the law object itself, as the Python step reads it (at the hinge's θ, θ̇, which it does not name)."""
    return not {"theta", "theta_dot"} & set(law.depends_on) and not law.input_names


def _rate_in_time_alone(law) -> bool:
    """Whether a hinge or guide law's rate in t (transient_sensitivities._TimeRate, ExplicitTime's) is a value of t
    alone, tabulated per grid point as :func:`_in_time_alone`'s: a law of t alone, or a law that names inputs or a
    controller's output (a torque ``pd`` or ``pd + 0.3*sin(9*t)`` of a PD controller pd) whose derivative by t, as
    _TimeRate takes it (SymPy's, deltas dropped), names none of them nor θ, θ̇ (the rate then reads no input: the same
    value whatever they hold when it is tabulated)."""
    if _in_time_alone(law):
        return True
    if law.time_function is not None:   # a law of t and inputs: its rate, TimeFunction.rate, reads them
        return False
    import sympy as sp

    from latdyn.scene.expressions import _drop_deltas

    symbols, (expr, *_) = law.expressions   # (θ, θ̇, t, the inputs and controllers it names)
    return _drop_deltas(sp.diff(expr, symbols[2])).free_symbols <= {symbols[2]}


def _hinge_refusal(owner, key: str, laws: dict) -> str | None:
    """Why a hinge law's parameter (``key``, its derivative laws ``laws``) keeps the run on the Python path, or None:
    its ∂r/∂p is the generated hinge_force's at the derivative law's value (ParameterDerivatives._hinge_force), which
    the loop tabulates per grid point where the value is one of t alone — the derivative's, and for the rest angle
    the stiffness's."""
    hinge = owner._key_kinds(key)[1]   # noqa: SLF001 - a guide's law read as the hinge law it is, on its slide
    if owner.kernels.address("hinge_force") is None:
        return "hinge kernels without C libraries"
    if not all(map(partial(_tabulated_or_compiled, owner), laws.values())):
        return f"{key}: its derivative is a law in theta, theta_dot or an input that did not compile"
    if hinge["law"] == "rest_angle":
        stiffness = owner.model.hinges[owner.model.hinge_index(hinge["beam"], hinge["end"])].stiffness
        if not _tabulated_or_compiled(owner, stiffness):
            return f"{key}: the hinge's stiffness is a law in theta, theta_dot or an input that did not compile"
    return None


def _tabulated_or_compiled(owner, law) -> bool:
    """Whether the loop has a hinge law's value: tabulated per grid point (a law of t alone), or the compiled law
    at the hinge's θ, θ̇ in C that the Python path calls too (latdyn/analyses/derivative_laws.py)."""
    return _in_time_alone(law) or (owner.derivative_laws is not None and owner.derivative_laws.index(law) >= 0)


def _joint_law_refusal(owner, key: str, laws: dict) -> str | None:
    """Why a hinge's compliant stop's or friction's parameter keeps the run on the Python path, or None: its ∂r/∂p is
    the generated contact_force_D_law's or friction_force_D_law's slope times the derivative law's value at t
    (ParameterDerivatives._contact_forces), which the loop tabulates per grid point."""
    if any(law.input_names for law in laws.values()):
        return f"{key}: its derivative names an input"
    name = "contact_force_D_law" if CONTACT_KEY.match(key) else "friction_force_D_law"
    if owner.kernels.address(name) is None:
        return "joint law kernels without C libraries"
    return None


def _body_refusal(owner, key: str, laws: dict) -> str | None:
    """Why a joint body's parameter (``key``, its derivative laws ``laws``) keeps the run on the Python path, or None:
    its ∂r/∂p is the generated joint_body's (or joint_body_D_com's) with the derivative law's value at t
    (ParameterDerivatives._body_forces), which the loop tabulates per grid point."""
    body = BODY_KEY.match(key)
    if any(law.input_names for law in laws.values()):
        return f"{key}: its derivative names an input"
    name = "joint_body_D_com" if body["com"] is not None else "joint_body"
    if owner.kernels.address(name) is None:
        return "joint body kernels without C libraries"
    model = owner.model
    if body["com"] is None and not np.any(model.body_nodes == model.body_node[body["body"]]):
        return f"{key}: a body without mass or inertia (the Python step refuses it)"
    return None


def model_refusal(owner, differentiated: bool = False, timed: bool = False,
                  continuous_controllers: bool = False) -> str | None:
    """Why the run of ``owner`` (a TransientSensitivities) takes every step from Python whatever its parameters'
    kinds (no parameters, NumPy kernels, cables without their C kernels,
    controllers, explicit time dependence beside events, the work accounts' probes that :func:`_account_refusal`
    names: :func:`_energy_refusal`), or None:
    :func:`refusal`'s part that the discrete
    adjoint's forward pass, which differentiates nothing as it goes, shares (latdyn/analyses/adjoint_in_loop.py,
    which refuses cables itself; rigid links and guides it takes). ``differentiated`` (:func:`refusal`: the loop
    differentiates the steps): controllers and explicit time dependence beside events only where
    :func:`_controller_refusal` and :func:`_time_refusal` say (the adjoint's forward pass keeps refusing them all), on
    a model with rigid links or guides too (their columns reduced by Pᵀ after the controllers' and ∂r/∂t after the
    laws' rates, as the Python path's ``_on_free_coordinates``). ``timed``: explicit time dependence beside events
    taken whatever it is (the adjoint's forward pass, which stores the steps the loop takes from a grid point, where
    δt is 0). ``continuous_controllers``: continuous controllers without states taken whatever they read (the
    adjoint's passes: the loop's step evaluates them in C as the run without sensitivities does, and a step stores
    nothing of theirs; the reverse step's K and C hold their couplings as the Python path's evaluation does);
    controllers with states or sampled ones refused (their S, f and held outputs stored and transposed per step in
    Python, latdyn/analyses/adjoint_controller_states.py)."""
    scene, model = owner.scene, owner.model
    if not owner.names:
        return "no parameters"
    if getattr(owner.kernels, "backend", None) != "c":
        return "kernels without C libraries"
    if model.cables is not None:
        rates = owner.explicit_time
        why = _cable_refusal(owner)
        if why is not None:
            return why
    if scene.controllers and continuous_controllers:
        terms = owner.controllers
        if terms.states is not None or terms.sampled is not None:
            return "controllers with states or sampled controllers"
    elif scene.controllers:
        why = _controller_refusal(owner) if differentiated else "controllers"
        if why is not None:
            return why
    if owner.explicit_time is not None and not timed:
        why = _time_refusal(owner) if differentiated else "explicit time dependence beside events"
        if why is not None:
            return why
    why = _energy_refusal(owner)
    if why is not None:
        return why
    return None


def _energy_refusal(owner) -> str | None:
    """Why the energy or momentum probes of ``owner`` keep the run on the Python path, or None. The energies of the
    state alone (kinetic, strain, potential, total) and the momenta are functions of a row's state: their
    derivatives need only the δq, δv the loop carries to the row (``row_carried``; TransientSensitivities.record at
    the row, latdyn/analyses/energy_sensitivities.py), and the step carries nothing for them
    (energy_sensitivities.external_work_step returns the step's columns as they are): the loop takes them; the
    discrete adjoint seeds its rows with their forms at the stored states (``probe_forms``), so its forward pass
    stored by the loop takes them too. The work accounts (the external work, the dissipated energy: sums over the
    steps, ``external_work_step``; the adjoint refuses them itself) are carried by the loop where
    :func:`_account_refusal` says, else per step in Python."""
    for probe in owner.probes:
        if not is_energy_or_momentum(probe):
            continue
        if probe.kind == "energy" and probe.quantity in ("dissipated", "external_work"):
            why = _account_refusal(owner, probe.quantity)
            if why is not None:
                return why
        elif probe.kind == "energy" and probe.quantity not in STATE_ENERGIES:
            return f"the {probe.quantity} energy (a work account carried per step in Python)"
    return None


def _account_refusal(owner, quantity: str) -> str | None:
    """Why a work account's sensitivity (``quantity``: the dissipated energy or the external work, sums over the steps:
    energy_sensitivities._dissipated_step, external_work_step) keeps the run on the Python path, or None: the loop
    carries them by csrc/work_accounts.c, the C the Python path calls (δθ, δθ̇, δπ, δu the carried δq, δv at the free
    coordinates: the dissipated energy with rigid links and guides too, its hinges' and guides' δθ, δθ̇ free
    coordinates; the external work with rigid links and guides too, a load's node or frame that follows them moved
    through the links' J and rates' tangent, csrc/work_accounts.c dependent_node_motion) with the laws' values tabulated per grid point where they are laws of t alone, as the Python step reads them,
    and compiled where they name θ, θ̇ or an input (energy_sensitivities.account_laws: the same C on both paths, at the
    hinge's θ, θ̇, t): for the dissipated energy every hinge's damping law and the damping parameters' derivative laws,
    for the external work the loads' values and their derivative laws, every hinge's applied torque, a spring that is
    not conservative, the torque's, stiffness's and rest angle's parameters' derivative laws; a prescribed motion's
    drive by csrc/drive_sensitivities.c, which the Python path calls too — not with rigid links or guides, whose drive's
    reaction is the reduced residual's row (joint_force_sensitivities.reaction_forms_through_links, Python)."""
    from latdyn.analyses.energy_sensitivities import account_laws, applied_torque_uses, damping_uses

    model = owner.model
    what = "the dissipated energy" if quantity == "dissipated" else "the external work"
    if quantity == "dissipated":
        laws = [hinge.damping for hinge in model.hinges] + [law for _, _, law in damping_uses(owner)]
    else:
        laws = ([hinge.torque for hinge in model.hinges if hinge.torque is not None]
                + [hinge.stiffness for hinge in model.hinges if not hinge.conservative_spring]
                + [law for *_, law in applied_torque_uses(owner)])
        if any(not hasattr(c, "value") and not isinstance(c, (int, float))
               for load in owner.scene.loads for c in (load.force or []) + (load.moment or [])):
            return f"{what} with a load value that is not a law of t (carried per step in Python)"
    if quantity != "dissipated" and model.links is not None and len(model.prescribed_coordinates()):
        return (f"{what} of a prescribed motion with rigid links or guides (the drive's reaction through the reduction, "
                "energy_sensitivities._drive_reactions, carried per step in Python)")
    compiled = account_laws(owner)   # the laws of the state, compiled: the C both paths call
    if not all(_in_time_alone(law) or (compiled is not None and compiled.index(law) >= 0) for law in laws):
        return (f"{what} with a law in theta, theta_dot or an input that did not compile (a work account carried per "
                "step in Python)")
    return None


def _controller_refusal(owner) -> str | None:
    """Why the controllers of ``owner`` keep the run on the Python path, or None: the loop takes continuous controllers
    (with states where :func:`_states_refusal` takes them; sampled ones between their samples,
    ``sampled_parameter_forces``: SampledTerms.add) whose parameters' partials compiled
    (derivative_laws.ControllerPartials), where every controller a parameter's slope reaches or whose output such a
    controller reads (derivative_laws.chained_outputs) reads only inputs (:func:`_reads`), probes and earlier continuous
    controllers — hinge and guide angles and rates, the global components of a point's position, displacement or
    velocity and their components in a body's axes, cables' lengths and tensions, elements' section forces and free
    joints' forces (the values the evaluation computes in C, which the Python path reads too:
    ControllerTerms.sensed_in_c; where a parameter moves a free joint's own laws, its ∂F/∂p the joint's row of the hinge
    laws' ∂r/∂p and of its compliant stops' and friction's, :meth:`SensitivityLoop._sensed_force_slopes`; a section
    force's ∂S/∂p by its section values csrc/parameter_forces.c ``section_force_slope``; a cable's tension's by its
    cable's laws csrc/cable_forces.c ``cable_tension_slope``) and earlier
    controllers' outputs (their compiled outputs and derivatives: ControllerPartials.gradient) — and drives hinge
    torques, guide forces or load components (:func:`controller_parameter_forces` of
    csrc/sensitivity_loop.c; ControllerTerms.add).
    On a model with rigid links or guides too: a point on a rigid link's body or a guided body is a dependent node,
    which the step's evaluation completes (csrc/links.c) before its sensors are read (a force between dependent nodes
    likewise), the sensors' derivatives along
    the free δq are in the reduced K and C (their couplings on all coordinates, reduced by the forward step's own
    reduction), and the actuators' columns, on all coordinates, are reduced by Pᵀ with the others
    (``latdyn_linked_reduce_columns``), the C the per-step Python path calls too (``_on_free_coordinates``,
    sensitivities.reduced_columns): tests/test_sensitivities_in_loop_linked_controllers.py."""
    from latdyn.analyses.derivative_laws import chained_outputs
    from latdyn.assembly.control import ANGLE, BODY_FRAME, BODY_VELOCITY, CABLE_LENGTH, CABLE_TENSION, CONTROLLER, \
        JOINT_FORCE, OFFSET_POSITION, OFFSET_VELOCITY, POSITION, RATE, SECTION_FORCE, VELOCITY

    terms = owner.controllers
    if terms.states is not None:
        why = _states_refusal(owner)
        if why is not None:
            return why
    readers = {name for name, reads in getattr(terms, "forces_read", {}).items() if reads}
    moved = sorted(read for reads in getattr(terms, "forces_read", {}).values() for read in reads
                   if terms.moved_forces[read].kind == "element" and (
                       getattr(owner, "geometry", None) is not None or getattr(owner, "kernels", None) is None
                       or owner.kernels.address("beam_section_forces_D_section") is None))
    if moved:   # a section force's ∂S/∂p beside geometry parameters, or without the kernel's C
        return f"a controller reads the force {moved[0]!r}, whose own laws a parameter moves"
    points = sorted(read for reads in getattr(terms, "forces_read", {}).values() for read in reads
                    if terms.moved_forces[read].kind == "point")
    if points:   # a point's ∂s/∂X of a geometry parameter (ControllerTerms.sensed_force_slopes): the per-step path's
        return f"a controller reads the point {points[0]!r}, which a geometry parameter moves"
    tensions = [read for reads in getattr(terms, "forces_read", {}).values() for read in reads
                if terms.moved_forces[read].kind == "cable"]
    if tensions and getattr(owner, "cables", None) is None:   # (its ∂N/∂p from the cables' uses, cable_forces.c)
        return f"a controller reads the tension {tensions[0]!r}, whose cable's laws a parameter moves"
    if readers and (terms.compiled is None or any(name not in terms.compiled.outputs for name in readers)):
        return "controllers reading a force whose own laws a parameter moves, whose outputs did not compile"
    # (a free joint's ∂F/∂p: its row of the hinge laws' ∂r/∂p and of its compliant stops' and friction's, the generated
    # hinge_force and contact_force_D_law, friction_force_D_law: SensitivityLoop._sensed_force_slopes)
    continuous = {c.name for c in terms.continuous} & (set(terms.partials) | readers)   # (the sampled ones': Python's)
    if continuous and terms.compiled is None:
        return "controllers' parameters whose derivatives did not compile"
    if not continuous:
        return None
    kinds = (ANGLE, RATE, POSITION, VELOCITY, OFFSET_POSITION, OFFSET_VELOCITY, BODY_FRAME, BODY_VELOCITY, CONTROLLER,
             CABLE_LENGTH, CABLE_TENSION, SECTION_FORCE, JOINT_FORCE)
    inputs = set(owner.scene.inputs.names) if owner.scene.inputs is not None else set()
    chained = set(chained_outputs(terms))
    if any(name not in terms.compiled.outputs for name in chained):
        return "controllers of a chain whose outputs did not compile"
    wiring = owner.assembler.control
    for k, c in enumerate(wiring.controllers):
        if c.name not in terms.partials and c.name not in chained and c.name not in readers:
            continue
        sensors = range(int(wiring.sensor_start[k]), int(wiring.sensor_start[k + 1]))
        if tuple(r for r in c.reads if r not in inputs) != wiring.sensor_names(k) \
                or any(int(wiring.sensor_kind[i]) not in kinds for i in sensors):
            return (f"controller {c.name}: a parameter's slope reaches it or its output, and it reads a probe other "
                    "than joint coordinates and rates, points' positions and velocities, cables' lengths and tensions, "
                    "elements' section forces and joints' forces, or an input")
    return None


def _read_joint(model, probe) -> int:
    """The joint (hinge or guide) whose torque or force the probe ``probe`` reads: its index among the model's."""
    return model.hinge_index(probe.beam, probe.end) if probe.kind == "hinge" else model.hinge_index(probe.body, "guide")


def _states_refusal(owner) -> str | None:
    """Why the continuous controllers with states of ``owner`` keep the run on the Python path, or None: the loop
    carries their δS, δf (csrc/controller_states.c, the C the Python step calls: ControllerStates.begin_step and
    after_step) where each reads hinge or guide angles or rates (a rate's δs its row of the step end's δv), nodes'
    velocity components (likewise) and the components of points' positions and displacements in
    global or a body's axes alone (not beside geometry parameters, which move a point; δs a row of δq for an angle or a
    node's coordinate, and for a point offset from its node or in a body's axes the gradient the evaluation's
    sensor_value leaves times δq, csrc/controller_states.c ``controller_state_sensed``, which ControllerStates._sensed
    calls too, the values the evaluation's) through its step law
    (ControllerStates ``place``), drives hinge torques, guide forces or loads, is read by no other controller (a probe
    may record its states and output: each row's δS and S are kept, :meth:`SensitivityLoop.record_rows`), its states'
    rates' partials and (with limits) its output compiled (derivative_laws.ControllerPartials), on a model without
    rigid links or guides (beside sampled controllers too: their held δy are added first, SampledTerms.add, on both
    paths). A sensor on a prescribed body or hinge beside events too: after an event the Python path moves it by
    ∂s/∂t δt (ControllerStates._sensed, TransientSensitivities._prescribed_in_time), and at every step the loop takes
    δt_{n+1} = δt_n + δh is 0 exactly (the step lands on the grid, δh = −δt_n: csrc/sensitivity_loop.c), where that
    term is nothing on the Python path as well (tests/test_sensitivities_in_loop_states_more.py)."""
    from latdyn.assembly.control import ANGLE, BODY_FRAME, OFFSET_POSITION, POSITION, RATE, VELOCITY

    from latdyn.analyses.sensitivities import senses_dependent

    terms, states = owner.controllers, owner.controllers.states
    wiring = owner.assembler.control
    stated = {c.name for c in states.controllers}
    for c in terms.continuous:
        if stated & set(c.reads):
            return f"controller {c.name} reads a controller with states"
    compiled = terms.compiled
    for c in states.controllers:
        k = next(k for k, d in enumerate(wiring.controllers) if d.name == c.name)
        sensors = range(int(wiring.sensor_start[k]), int(wiring.sensor_start[k + 1]))
        kinds = {int(wiring.sensor_kind[i]) for i in sensors}
        points = {POSITION, OFFSET_POSITION, BODY_FRAME}
        if (c.name not in states.place or tuple(c.reads) != wiring.sensor_names(k)
                or not kinds <= {ANGLE, RATE, VELOCITY} | points or (kinds & points and owner.geometry is not None)):
            return (f"controller {c.name}: states, and it reads other than hinge and guide angles and rates, nodes' "
                    "velocities and points' positions and displacements in global or a body's axes (or those beside "
                    "geometry parameters)")
        if senses_dependent(owner.model, wiring, k):
            return (f"controller {c.name}: states reading a point on a rigid link's body or a guided body (its δs P δq, "
                    "the per-step path's NumPy: ParameterDerivatives._dependent_motion)")
        if c.name in terms.rate_partials and compiled is None:
            return f"controller {c.name}: its states' rates' parameters' derivatives did not compile"
        if c.limits is not None and (compiled is None or c.name not in compiled.outputs):
            return f"controller {c.name}: states and limits, its output's law did not compile"
    return None


def _time_refusal(owner) -> str | None:
    """Why the explicit time dependence beside events of ``owner`` (its ExplicitTime: ∂r/∂t δt, latdyn/analyses/
    transient_sensitivities.py ``_add_time_columns``) keeps the run on the Python path, or None: the loop takes
    ∂r/∂t of load components and hinge and guide laws whose rate in t is one of t alone (:func:`_rate_in_time_alone`),
    their exact rates (the same ``_TimeRate`` objects) tabulated per grid point through the same generated point_load
    and hinge_force (:class:`_TimeRates`), and of prescribed
    motions (latdyn/analyses/prescribed_rates.py: the coupling blocks, a controller's among them, times the motion
    laws' rates, csrc/prescribed_rates.c on both paths; with rigid links or guides the dependent nodes carried,
    csrc/linked_prescribed_rates.c), of reels (``model_refusal``: alone), and of
    hinge and guide laws of the state and t whose rate compiled (transient_sensitivities._time_rate_law, the same C
    on both paths) and of continuous controllers' outputs that name t (their ∂y/∂t through the actuators: ExplicitTime's
    ``controllers``, compiled as ∂f/∂p, transient_sensitivities._controller_time_rates) where :func:`_controller_refusal`
    takes those controllers; controllers' outputs that name t it refuses or whose rate in t did not
    compile, and laws of the state and t whose rate did not compile (a SymPy rate in NumPy) not."""
    rates = owner.explicit_time
    if rates.laws.controllers is not None:   # ∂y/∂t of outputs that name t (_controller_time_rates): compiled, as ∂y/∂p
        why = _controller_refusal(rates.laws)
        if why is not None or rates.laws.controllers.compiled is None:
            return ("explicit time dependence beside events through a controller's output: "
                    + (why or "its rate in t did not compile"))
    model = owner.model
    compiled = rates.laws.derivative_laws   # the rates of laws of the state and t, compiled (ExplicitTime)
    for key, by_column in rates.laws.derivatives.items():
        hinge = owner._key_kinds(key)[1]   # noqa: SLF001 - a guide's law read as the hinge law it is, on its slide
        if hinge is not None:
            law = getattr(model.hinges[model.hinge_index(hinge["beam"], hinge["end"])], hinge["law"])
            if not _rate_in_time_alone(law) and (compiled is None or compiled.index(by_column[0]) < 0):
                return (f"explicit time dependence beside events: {key} is a law of the state and t whose rate did "
                        "not compile")
        elif not _LOAD_KEY.match(key):
            return f"explicit time dependence beside events: {key}"
    return None


def _reads(wiring, inputs) -> tuple:
    """The arguments of each continuous controller's compiled laws in its reads' order (ControllerTerms.add's), as
    csrc/sensitivity_loop.c ``controller_parameter_forces`` reads them: (each one's first entry, then the total; kinds;
    indices) — a sensor of the wiring as kind 0 (a hinge's θ, index the hinge), 1 (its θ̇), 3 (an earlier controller's
    output, index its place) or 2 (a value the evaluation left in Work's sensor_values: points, forces; index the
    sensor's place), an input (``inputs``: the scene's inputs' names) as kind 4, index its place in their array."""
    from latdyn.assembly.control import ANGLE, CONTROLLER, RATE

    start, kinds, indices = [0], [], []
    for k, c in enumerate(wiring.controllers):
        sensors = dict(zip(wiring.sensor_names(k), range(int(wiring.sensor_start[k]), int(wiring.sensor_start[k + 1]))))
        for name in c.reads:
            i = sensors.get(name)
            if i is None:   # an input (_controller_refusal: every other read is one of its sensors)
                kinds.append(4)
                indices.append(list(inputs).index(name))
                continue
            kind = {ANGLE: 0, RATE: 1, CONTROLLER: 3}.get(int(wiring.sensor_kind[i]), 2)
            kinds.append(kind)
            indices.append(i if kind == 2 else int(wiring.sensor_index[i]))
        start.append(len(kinds))
    return start, kinds, indices


class SensitivityLoop:
    """The ``SensitivityLoop`` struct of csrc/sensitivity_loop.c for ``owner``'s sensitivities: laid out per
    numbering (:meth:`prepared`), filled from the carried sensitivities before a call of the loop of steps and
    read back after it (:meth:`carried_after`)."""

    def __init__(self, owner):
        from latdyn.assembly.library import SensitivityLoopData

        self.owner = owner
        self.data = SensitivityLoopData()
        self._for = None
        self._keep: list = []
        #: ∂r/∂t's struct (explicit time dependence beside events: :class:`_TimeRates`), None without
        self._rates = None

    def _pointer(self, array: np.ndarray) -> int:
        """The address of ``array`` (of a held zero where it is empty), kept alive with the layout."""
        if not array.size:
            array = np.zeros(1)
        self._keep.append(array)
        return array.ctypes.data

    def _layout(self) -> bool:
        """The per-numbering part of the struct (the free nodes' slots, S's pattern and storage, the exact
        matrices' segments, the section and load uses, on the sparse LU the band LU that stands in where its pivot
        fails); False where this numbering takes the Python path (no free coordinates)."""
        owner = self.owner
        model, assembler = owner.model, owner.assembler
        n, k = model.n_dofs, len(owner.names)
        native = assembler.native(True)
        key = (native, n)
        if self._for is not None and self._for[0] == key:
            return self._for[1]
        self._keep = []
        d, ints = self.data, lambda a: np.ascontiguousarray(a, np.int64)
        ok = n > 0
        linked = model.links is not None
        linked_layout = assembler.linked_exact_layout(native) if linked else None
        ok = ok and (linked_layout is not None or not linked)
        if ok:
            slots = model.node_dofs[model.free_nodes, 3:6]
            step_matrix = owner._step_matrix(slots, dense=linked)   # noqa: SLF001 - the Python step's own, per numbering
        if not ok:
            self._for = (key, False)
            return False
        cols = k + 1
        about_one_axis = turns_about_one_axis(slots, n)
        f = len(slots)
        d.k, d.f = k, 0 if about_one_axis else f
        self._slots = ints(slots)
        d.slots = self._pointer(self._slots)
        self._psi, self._turn, self._tangent = np.zeros((f, 3)), np.zeros((f, 9)), np.zeros((f, 9))
        d.psi, d.turn, d.tangent = (self._pointer(a) for a in (self._psi, self._turn, self._tangent))
        if about_one_axis:   # R = J = I (TransientSensitivities._rotation_operators); S's blocks the identity's
            self._identity = np.ascontiguousarray(np.tile(np.eye(3), (f, 1, 1)))
            d.blocks = self._pointer(self._identity)
        else:
            d.blocks = d.tangent
        self._buffers = {name: np.zeros(size) for name, size in (
            ("increment", n + 1), ("predicted", 5 * n * cols), ("explicit", n * cols),
            ("total", (model.n_total + 1) * k), ("z", n * cols), ("updated", 4 * n * cols))}
        for name, array in self._buffers.items():
            setattr(d, name, self._pointer(array))
        self._carried = {name: np.zeros((n, k)) for name in ("dq", "dv", "dvdot", "da")}
        for name, array in self._carried.items():
            setattr(d, name, self._pointer(array))
        self._dt, self._dh = np.zeros(k), np.zeros(k)
        d.dt, d.dh = self._pointer(self._dt), self._pointer(self._dh)
        # M, C and the exact K (Assembler.exact_matrix_values; with rigid links or guides linked_exact_matrix_values,
        # dense on the minimum coordinates), the bodies' inertia stiffness
        d.linked = int(linked)
        if linked:
            gather, storage, stiffness = linked_layout
            d.linked_gather, d.linked_storage = gather.ctypes.data, storage.ctypes.data
            d.linked_body_D = stiffness.ctypes.data
            d.n_segments = 0
            self._keep.append(linked_layout)
            d.linked_count = gather.size   # n², or the reduced pattern's entries (Assembler.linked_exact_pattern)
            self._mck = np.zeros((3, gather.size))
        else:
            arguments, stiffness = assembler.exact_segments(native)
            d.n_segments, d.counts, d.first, d.second, d.indices, d.positions = arguments
            self._keep.append((assembler._exact_held, assembler._positions3, stiffness))   # noqa: SLF001 - what they point into
            self._mck = np.zeros((3, assembler.pattern()[1].size))
        d.mck_size, d.mck = self._mck.size, self._pointer(self._mck)
        bodies = len(model.body_nodes)
        kernel = assembler._body_stiffness_kernel() if bodies else None   # noqa: SLF001
        d.body_kernel = kernel
        if kernel is not None:
            rows, gravity = assembler.body_stiffness_inputs(1.0)
            d.body_rows, d.body_gravity = self._pointer(rows), self._pointer(gravity)
            d.body_scratch = self._pointer(np.zeros(18 * bodies))
            d.body_stiffness = self._pointer(stiffness)
        # S
        d.step = ctypes.addressof(step_matrix._structure)   # noqa: SLF001
        self._step_matrix = step_matrix
        d.S = step_matrix._summed.ctypes.data   # noqa: SLF001
        d.factor, d.pivots = step_matrix.factorization.values.ctypes.data, step_matrix.factorization.pivots.ctypes.data
        d.solve_work = self._pointer(np.zeros(3 * n * cols))
        self._pivoted(step_matrix)
        self._sections()
        self._loads()
        self._hinges()
        self._bodies()
        self._joint_laws()
        self._geometry()
        self._controllers()
        d.time_rates = None
        if owner.explicit_time is not None:   # ∂r/∂t at the step's end, one column (refusal: _time_refusal)
            self._rates = _TimeRates(owner.explicit_time.laws)
            self._rates._layout()   # noqa: SLF001
            d.time_rates = ctypes.addressof(self._rates.data)
        self._cables()
        self._accounts()
        if self._rates is not None and self._rates.data.cables and not d.cables:
            self._near_changes()
        self._for = (key, True)
        return True

    def _accounts(self) -> None:
        """The work accounts' part (csrc/work_accounts.c), where a dissipated-energy or an external-work probe asks for
        it (:func:`_account_refusal`): each hinge's coordinate among the free ones (δθ = δq there, −1: not free), the
        damping parameters' uses (energy_sensitivities.damping_uses), the loads' points and their nodes' and frames'
        free coordinates, the (load, parameter) pairs, the applied torques' uses (applied_torque_uses), the carried
        accounts and their terms."""
        from latdyn.analyses.energy_sensitivities import applied_torque_uses, damping_uses
        from latdyn.assembly.library import WorkAccountsData

        owner, d = self.owner, self.data
        d.accounts = None
        quantities = {p.quantity for p in owner.probes if p.kind == "energy"} & {"dissipated", "external_work"}
        if not quantities:
            return
        model, k = owner.model, len(owner.names)
        H, n = len(model.hinges), model.n_dofs
        a = self._accounts_data = WorkAccountsData()
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        free = set(model.free_hinges.tolist())
        a.hinges = H
        a.hinge_row = ints([int(model.hinge_dofs[j]) if j in free and model.hinge_dofs[j] < n else -1
                            for j in range(H)])
        self._account = {"theta": np.zeros(H)}
        if "dissipated" in quantities:
            uses = damping_uses(owner)
            a.n_uses = len(uses)
            a.use_hinge, a.use_column = ints([j for j, _, _ in uses]), ints([column for _, column, _ in uses])
            self._account.update({name: np.zeros(size) for name, size in (
                ("dissipated", k), ("torque", H), ("dtorque", H * k), ("dtheta", H * k))})
        if "external_work" in quantities:
            self._account.update({name: np.zeros(size) for name, size in (
                ("work", k), ("power", 1 + k), ("work_torque", H), ("work_dtorque", H * k), ("work_dtheta", H * k))})
            node, offset, frame = owner._load_points()   # noqa: SLF001
            free_nodes = set(model.free_nodes.tolist())
            rows = lambda i, slots: [int(model.node_dofs[i, s]) if i >= 0 and i in free_nodes else -1   # noqa: E731
                                     for s in slots]
            a.loads = len(node)
            a.load_node, a.load_frame = ints(node), ints(frame)
            a.load_offset = self._pointer(np.ascontiguousarray(offset, np.float64))
            a.node_rows = ints([rows(int(i), range(6)) for i in node])
            a.frame_rows = ints([rows(int(i), range(3, 6)) for i in frame])
            pairs, columns, _, _ = owner._load_layout()   # noqa: SLF001
            a.pairs = len(pairs)
            a.pair_load, a.pair_column = ints(pairs), ints(columns)
            uses = applied_torque_uses(owner)
            a.n_torque_uses = len(uses)
            a.torque_use_hinge, a.torque_use_column, a.torque_use_kind = (ints([use[i] for use in uses])
                                                                          for i in range(3))
            L, P = len(node), len(pairs)
            a.work_scratch = self._pointer(np.zeros(1 + k + H + H * k + L * (73 + 12 * k) + 76 * P))
            self._drive(a, k)
            a.linked_loads = 0
            if model.links is not None:   # loads on nodes that follow the links (dependent_node_motion)
                slots = owner.assembler.native(True).links.slot_of_node
                slot = lambda i: slots[int(i)] if int(i) >= 0 and int(i) not in free_nodes else -1   # noqa: E731
                a.load_slot, a.frame_slot = ints([slot(i) for i in node]), ints([slot(i) for i in frame])
                a.linked_loads = int(any(slot(i) >= 0 for i in list(node) + list(frame)))
                a.linked_scratch = self._pointer(np.zeros(12 * k))
        for name, array in self._account.items():
            setattr(a, name, self._pointer(array))
        a.scratch = self._pointer(np.zeros(H + 3 * H * k))
        self._account_state_laws(a, quantities)
        d.accounts = ctypes.addressof(a)

    def _drive(self, a, k: int) -> None:
        """The prescribed motions' drive in the external work (energy_sensitivities._drive_reactions,
        csrc/drive_sensitivities.c): the prescribed coordinates, each one's place among them and among drive_work's
        increments (6 per prescribed node, then one per hinge), the loop's ∂r/∂p on every coordinate and joint bodies'
        inertia stiffness at the step's end, the loads' block columns and the couplings, the held δr_d and the prescribed
        nodes' x and T (_carry_accounts)."""
        from latdyn.analyses.prescribed_rates import coupling_entries, load_block_columns

        owner, d = self.owner, self.data
        model = owner.model
        rows = model.prescribed_coordinates()
        a.drive_rows = len(rows)
        if not len(rows):
            return
        nodes = model.prescribed_nodes()
        hinges = [j for j, hinge in enumerate(model.hinges) if hinge.angle is not None]
        every = np.concatenate([model.node_dofs[nodes].ravel(), model.hinge_dofs[hinges]]).astype(np.int64)
        slots = np.concatenate([np.arange(6 * len(nodes)), 6 * len(nodes) + np.asarray(hinges, np.int64)]).astype(np.int64)
        where = np.full(model.n_total + 1, -1, np.int64)
        where[rows] = np.arange(len(rows))
        ints = lambda values: self._pointer(np.ascontiguousarray(values, np.int64))   # noqa: E731
        a.drive_coordinates, a.drive_where = ints(rows), ints(where)
        a.drive_slot = ints(slots[(every >= model.n_dofs) & (every < model.n_total)])   # prescribed_coordinates' rows
        self._account.update({"drive_dr": np.zeros(len(rows) * k), "drive_x": np.zeros(3 * len(nodes)),
                              "drive_T": np.zeros(9 * len(nodes))})
        a.drive_total = d.total
        a.drive_body_stiffness = d.body_stiffness if d.body_kernel else None
        a.drive_load_columns = self._pointer(load_block_columns(owner.assembler))
        couplings = coupling_entries(owner.assembler)
        a.drive_couplings = self._pointer(couplings) if couplings is not None else None
        a.drive_scratch = self._pointer(np.zeros(len(rows) * k + 6 * len(nodes) + len(model.hinges) + len(rows)))

    def _account_state_laws(self, a, quantities: set) -> None:
        """The accounts' laws of θ, θ̇ or an input (energy_sensitivities.account_laws): the compiled laws' address and
        each law's number among them (−1: a law of t alone, tabulated) in the struct's order, and the scratch where the
        loop puts their values at the hinges' θ, θ̇, t beside the tabulated ones (csrc/work_accounts.c)."""
        from latdyn.analyses.energy_sensitivities import account_laws, applied_torque_uses, damping_uses

        a.state_laws = None
        compiled = account_laws(self.owner)
        if compiled is None:
            return
        hinges = self.owner.model.hinges
        number = lambda law: compiled.index(law) if law is not None else -1   # noqa: E731
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        uses, torque_uses = damping_uses(self.owner), applied_torque_uses(self.owner)
        a.damping_law = ints([number(hinge.damping) for hinge in hinges] if "dissipated" in quantities else [])
        a.use_law = ints([number(law) for *_, law in uses] if "dissipated" in quantities else [])
        a.torque_law = ints([[number(hinge.torque), number(None if hinge.conservative_spring else hinge.stiffness)]
                             for hinge in hinges] if "external_work" in quantities else [])
        a.torque_use_law = ints([number(law) for *_, law in torque_uses] if "external_work" in quantities else [])
        a.law_scratch = self._pointer(np.zeros(11 * len(hinges) + len(uses) + len(torque_uses)))
        a.state_laws = compiled.address

    def _pivoted(self, step_matrix) -> None:
        """S on the sparse LU: the band LU with pivoting that stands in at a step whose sparse pivot fails, the
        Python step's own (Factorization._factor_pivoted's, made here once a numbering and kept for it), S's entries'
        offsets in its storage (csrc/sensitivity_step.c ``latdyn_sensitivity_step_pivoted``); else none."""
        from latdyn.assembly.factorization import Factorization

        d, factorization = self.data, step_matrix.factorization
        d.pivoted = None
        if factorization.kind != "sparse":
            return
        if factorization._band is None:   # noqa: SLF001 - the stand-in _factor_pivoted makes, made here first
            factorization._band = Factorization(factorization.rows, factorization.cols, factorization.n, kind="band")  # noqa: SLF001
        band = factorization._band   # noqa: SLF001
        self._keep.append(band)
        d.pivoted = ctypes.addressof(band.structure)
        d.pivoted_storage = self._pointer(np.ascontiguousarray(band.position(step_matrix.rows, step_matrix.cols),
                                                               np.int64))
        d.pivoted_factor, d.pivoted_pivots = band.values.ctypes.data, band.pivots.ctypes.data

    def _near_changes(self) -> None:
        """A reel without cable parameters: the cables' struct with no use, so that the loop hands a step ending near
        a cable element's change to the caller as with them (csrc/cable_forces.c ``cable_near_change``)."""
        from latdyn.assembly.library import CableForcesData

        c = self._cable_data = CableForcesData()
        c.n_uses = 0
        self.data.cables = ctypes.addressof(c)

    def _hinges(self) -> None:
        """The (use, column) pairs of ParameterDerivatives._hinge_uses, in its order: hinge, column, the derivative's
        place among hinge_force's law values (−1: the rest angle), the kernel's (θ, θ̇, θ_r, λ)."""
        owner, d, model = self.owner, self.data, self.owner.model
        uses = [(j, which, column) for j, which, laws in owner._hinge_uses() for column in laws]  # noqa: SLF001
        d.n_hinge_uses = len(uses)
        d.derivative_laws = None
        if not uses:
            return
        d.hinge_kernel = owner.kernels.address("hinge_force")
        compiled = owner.derivative_laws   # the laws of the state, compiled: their numbers (−1: tabulated)
        if compiled is not None:
            hinges = model.hinges
            number = [(compiled.index(law), compiled.index(hinges[j].stiffness) if which == "rest_angle" else -1)
                      for j, which, laws in owner._hinge_uses() for law in laws.values()]   # noqa: SLF001
            d.derivative_laws = compiled.address
            d.hinge_law_index = self._pointer(np.array(number, np.int64).reshape(-1))
        slot = {"stiffness": 0, "damping": 3, "torque": 6, "rest_angle": -1}
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        d.hinge_joint, d.hinge_column = ints([j for j, _, _ in uses]), ints([column for _, _, column in uses])
        d.hinge_slot = ints([slot[which] for _, which, _ in uses])
        d.hinge_at = self._pointer(np.array([[0.0, 0.0, 1.0, 1.0] if which == "rest_angle" else
                                             [0.0, 0.0, model.hinges[j].rest_angle, 1.0] for j, which, _ in uses]))
        d.no_contact = self._pointer(np.ascontiguousarray(NO_CONTACT, np.float64))

    def _bodies(self) -> None:
        """The (use, column) pairs of ParameterDerivatives._body_forces, in its order (a centre of mass of a body
        without mass or inertia moves no force: left out there and here)."""
        owner, d, model = self.owner, self.data, self.owner.model
        uses, links = self._body_uses(), self._link_uses()
        d.n_body_uses = len(uses) + len(links)
        if not d.n_body_uses:
            return
        d.body_force_kernel = owner.kernels.address("joint_body")
        d.body_com_kernel = (owner.kernels.address("joint_body_D_com")
                             if any(body["com"] is not None for body, *_ in uses) else None)
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        d.body_use_node = ints([model.body_node[body["body"]] for body, *_ in uses] + [node for _, _, node, *_ in links])
        d.body_use_column = ints([column for _, _, column, _ in uses] + [column for *_, column, _ in links])
        d.body_use_axis = ints([-1 if body["com"] is None else int(body["com"]) for body, *_ in uses] + [-1] * len(links))
        d.body_use_gravity = self._pointer(np.ascontiguousarray(1.0 * np.asarray(owner.assembler.gravity, float)))
        d.body_use_scratch = self._pointer(np.zeros(150))

    def _joint_laws(self) -> None:
        """The (use, column) pairs of ParameterDerivatives._contact_forces, in its order: hinge, column, kernel, slot,
        the kernel's (θ, θ̇, θ_r, 1), the joint's contact row and the slope's factor (the Stribeck rate's −(1/v_s)²,
        by the Python path's expression; else 1, which multiplies exactly)."""
        owner, d, model = self.owner, self.data, self.owner.model
        uses = []
        for (beam, end, kind, slot), laws in owner.joint_law_uses():
            j = model.hinge_index(beam, end)
            row = owner.contact_row(j)
            factor = -row[0, 7] ** 2 if kind == "friction" and slot == FRICTION_SLOT["stribeck_rate"] else 1.0
            uses += [(j, column, kind, slot, row, factor) for column in laws]
        d.n_law_uses = len(uses)
        if not uses:
            return
        kinds = {kind for _, _, kind, *_ in uses}
        d.contact_kernel = owner.kernels.address("contact_force_D_law") if "contact" in kinds else None
        d.friction_kernel = owner.kernels.address("friction_force_D_law") if "friction" in kinds else None
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        d.law_joint, d.law_column = ints([use[0] for use in uses]), ints([use[1] for use in uses])
        d.law_kind, d.law_slot = ints([int(use[2] == "friction") for use in uses]), ints([use[3] for use in uses])
        d.law_at = self._pointer(np.array([[0.0, 0.0, model.hinges[use[0]].rest_angle, 1.0] for use in uses]))
        d.law_rows = self._pointer(np.ascontiguousarray(np.concatenate([use[4] for use in uses]), np.float64))
        d.law_factor = self._pointer(np.array([float(use[5]) for use in uses]))

    def _geometry(self) -> None:
        """The geometry parameters' part (csrc/geometry_forces.c): the elements they move, the held variations
        (ReferenceGeometry.variations), the elements with mass among them, λ g and the generated kernels."""
        from latdyn.assembly.library import GeometryForcesData

        owner, d = self.owner, self.data
        geometry = owner.geometry
        d.geometry = d.shifts = None
        if geometry is not None and (geometry.turning or geometry.link_moves):
            self._shifts()
        if geometry is None or not len(geometry.elements):
            return
        g = self._geometry_data = GeometryForcesData()
        elements = np.ascontiguousarray(geometry.elements, np.int64)
        sections = owner.model.element_sections[elements]
        on = np.ascontiguousarray(np.flatnonzero(np.any(sections[:, 5:8] != 0.0, axis=1)), np.int64)
        k, m = d.k, len(elements)
        g.m, g.elements = m, self._pointer(elements)
        g.held = self._pointer(np.ascontiguousarray(geometry.variations[elements]))
        g.n_on, g.on = len(on), self._pointer(on)
        g.variation_kernel, g.internal_kernel, g.inertia_kernel = (owner.kernels.address(name)
                                                                   for name in GEOMETRY_KERNELS[:3])
        g.gravity = self._pointer(np.ascontiguousarray(1.0 * np.asarray(owner.assembler.gravity, float)))
        g.scratch = self._pointer(np.zeros(148 * k * m + 130 * k * len(on)))
        arms = geometry.moved_loads
        g.n_arms = len(arms)
        if arms:
            ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
            g.arm_node, g.arm_frame = ints([node for _, node, _ in arms]), ints(
                [geometry.load_frame_node(index) for index, _, _ in arms])
            g.arm_moves = self._pointer(np.ascontiguousarray(np.array([moved.T for _, _, moved in arms], float)))
            g.arm_kernel = owner.kernels.address("point_load_D_offset")
            g.arm_scratch = self._pointer(np.zeros(30 * k))
        d.geometry = ctypes.addressof(g)

    def _shifts(self) -> None:
        """The turning shifts' part (csrc/turning_shifts.c, ReferenceGeometry.shift_layout, the Python path's struct):
        M, C and the exact K before the reduction scattered onto the assembler's pattern as
        Assembler.assembled_exact_values scatters them (its segments, the bodies' inertia stiffness copied in from the
        loop's), the pattern and the values' buffer."""
        owner, d = self.owner, self.data
        assembler = owner.assembler
        data, arrays, _ = owner.geometry.shift_layout()
        self._keep.append((data, arrays))   # (the geometry's own per numbering: this numbering's, alive with the layout)
        (data.n_segments, data.counts, data.first, data.second, data.indices,
         data.positions), stiffness = assembler.exact_segments(assembler.native(True))
        self._keep.append((assembler._exact_held, assembler._positions3, stiffness))   # noqa: SLF001 - what they point into
        data.stiffness, data.n_stiffness = stiffness.ctypes.data, stiffness.size if len(owner.model.body_nodes) else 0
        indptr, pattern = (np.ascontiguousarray(a, np.int64) for a in assembler.pattern())
        data.indptr, data.pattern, data.nnz = self._pointer(indptr), self._pointer(pattern), pattern.size
        data.mck = self._pointer(np.zeros(3 * pattern.size))
        d.shifts = ctypes.addressof(data)

    def _controllers(self) -> None:
        """The continuous controllers' parameter uses (ControllerTerms.add), in its order: each use's controller (its
        place in the wiring) and column, its law's number its place (ControllerPartials); the sensors of each
        controller (:func:`_reads`); the hinge actuators in the wiring's order."""
        owner, d = self.owner, self.data
        terms = owner.controllers
        d.n_partials, d.sampled_held, d.n_actuated_loads, d.n_sampled_loads = 0, None, 0, 0
        loads = self._actuated_loads(terms)
        if terms is not None and terms.sampled is not None:
            self._sampled(terms.sampled, loads)
        d.states = None
        states = terms.states if terms is not None else None
        if terms is None or (terms.compiled is None and states is None):
            return
        wiring = owner.assembler.control
        place = {c.name: k for k, c in enumerate(wiring.controllers)}
        uses = terms.compiled.uses if terms.compiled is not None else []
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        d.n_partials = len(uses)
        d.controller_partials = terms.compiled.address if terms.compiled is not None else None
        d.partial_controller = ints([place[name] for name, _, _ in uses])
        d.partial_column = ints([column for _, column, _ in uses])
        d.n_partial_controllers = wiring.n
        inputs = owner.scene.inputs
        start, kinds, indices = _reads(wiring, inputs.names if inputs is not None else ())
        d.read_start, d.read_kind, d.read_index = ints(start), ints(kinds), ints(indices)
        d.input_values = inputs.values.ctypes.data if inputs is not None else None   # (never reallocated)
        self._sensed_force_slopes(terms, place, start)
        hinges = [(int(index), int(of), float(gain) if gain else 1.0) for kind, index, of, gain in zip(
            wiring.actuator_kind, wiring.actuator_index, wiring.actuator_controller, wiring.actuator_gain) if kind == 0]
        d.n_hinge_actuators = len(hinges)
        d.actuator_hinge, d.actuator_of = ints([h for h, _, _ in hinges]), ints([of for _, of, _ in hinges])
        d.actuator_factor = self._pointer(np.array([factor for _, _, factor in hinges], float))
        d.controller_slopes = self._pointer(np.zeros(wiring.n * len(owner.names)))
        width = max([1] + [int(start[k + 1] - start[k]) + len(c.states)
                           for k, c in enumerate(wiring.controllers)])   # the reads, then the states
        d.controller_scratch = self._pointer(np.zeros(2 * width + 1))
        outputs = terms.compiled.outputs if terms.compiled is not None else {}
        d.output_law = ints([outputs.get(c.name, -1) for c in wiring.controllers])
        d.output_limits = self._pointer(np.array([c.limits if c.limits is not None else (0.0, 0.0)
                                                  for c in wiring.controllers], float).reshape(-1))
        # chains and load actuators (ControllerTerms.add's outputs, the chain rule and its loads' point_load calls)
        d.output_limited = ints([int(c.limits is not None) for c in wiring.controllers])
        d.held_outputs = self._pointer(np.zeros(wiring.n))
        d.output_gradient = self._pointer(np.zeros(width + 1))
        actuators, order = loads[0]
        d.n_load_actuators = len(actuators)
        if actuators:
            d.load_actuator_load = ints([order.index(index) for index, *_ in actuators])
            d.load_actuator_component = ints([a[1] for a in actuators])
            d.load_actuator_of = ints([a[2] for a in actuators])
            d.load_actuator_factor = self._pointer(np.array([a[3] for a in actuators], float))
        if states is not None:
            self._controller_states(states, place)

    def _sensed_force_slopes(self, terms, place: dict, start: list) -> None:
        """The forces a controller reads whose own laws a parameter moves (ControllerTerms.forces_read; free joints'
        torques and forces alone, :func:`_controller_refusal`): each read's slot among the laws' arguments
        (:func:`_reads`: the reads' order) and its joint's row, whose ∂r/∂p of the hinge laws and then of its compliant
        stops' and friction's laws is −∂F/∂p (csrc/sensitivity_loop.c ``joint_law_force_slopes``), as
        ControllerTerms.sensed_force_slopes sums them; an element's section force (row −1) its element, its sensor's
        first force and weights and the generated beam_section_forces_D_section, whose ∂S/∂p by the section uses
        csrc/parameter_forces.c ``section_force_slope`` takes (the C ControllerTerms.sensed_force_slopes calls)."""
        from latdyn.analyses.joint_force_sensitivities import is_joint_force
        from latdyn.assembly.control import _section_sensor

        d, model = self.data, self.owner.model
        reads = [(int(start[place[name]]) + i, probe) for name, forces in terms.forces_read.items()
                 for probe, i in forces.items()]
        d.n_force_reads, d.force_element, d.force_cable_element = len(reads), None, None
        if not reads:
            return
        probes = [terms.moved_forces[name] for _, name in reads]
        rows = [int(model.hinge_dofs[_read_joint(model, probe)]) if is_joint_force(probe) else -1 for probe in probes]
        d.force_read = self._pointer(np.array([slot for slot, _ in reads], np.int64))
        d.force_row = self._pointer(np.array(rows, np.int64))
        d.force_slopes = self._pointer(np.zeros(len(reads) * len(self.owner.names)))
        if any(probe.kind == "cable" for probe in probes):   # a tension: its cable's first element
            cables = model.cables
            d.force_cable_element = self._pointer(np.array(
                [int(cables.first[cables.names.index(probe.beam)]) if probe.kind == "cable" else -1 for probe in probes],
                np.int64))
        if all(probe.kind != "element" for probe in probes):
            return
        sensors = [_section_sensor(model, probe) if probe.kind == "element" else None for probe in probes]
        d.force_element = self._pointer(np.array([-1 if x is None else x[1] // 4 for x in sensors], np.int64))
        d.force_first = self._pointer(np.array([-1 if x is None else x[1] % 4 for x in sensors], np.int64))
        d.force_weights = self._pointer(np.array([(0.0, 0.0) if x is None else x[4][:2] for x in sensors], float))
        d.section_forces_D_section = self.owner.kernels.address("beam_section_forces_D_section")

    def _controller_states(self, states, place: dict) -> None:
        """The controllers with states' part (csrc/controller_states.c ControllerStatesLoop): each one's place in the
        wiring and its states' rows (ControllerStates.first), each sensor's hinge coordinate in δq (the free hinges'
        within the free coordinates, −1: δθ = 0, as ParameterDerivatives._on_free_nodes_and_hinges), the states' rates'
        compiled partials (ControllerPartials.rate_uses: controller, state, column, law number), the carried δS, δf,
        (S, f) filled before each call (:meth:`prepared`) and read back after it (:meth:`carried_after`), scratch."""
        from latdyn.analyses.sensitivities import sensor_rows
        from latdyn.assembly.library import ControllerStatesLoopData

        owner, d = self.owner, self.data
        model, wiring, k = owner.model, owner.assembler.control, len(owner.names)
        t = self._states_data = ControllerStatesLoopData()
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        controllers = states.controllers
        order = {c.name: i for i, c in enumerate(controllers)}
        t.n = len(controllers)
        t.place = ints([place[c.name] for c in controllers])
        t.first = ints([states.first[c.name] for c in controllers] + [len(states.slots)])
        sensor_dof, column_dof = sensor_rows(model, wiring)   # the per-step path's own (ControllerStates._sensed)
        t.sensor_dof, t.column_dof = ints(sensor_dof), ints(column_dof)
        rate_uses = (owner.controllers.compiled.rate_uses if owner.controllers.compiled is not None else [])
        first_law = (len(owner.controllers.compiled.uses) + len(owner.controllers.compiled.outputs)
                     if owner.controllers.compiled is not None else 0)
        t.n_rate_uses = len(rate_uses)
        t.rate_use = ints([[order[name], controllers[order[name]].states.index(state), column, first_law + u]
                           for u, (name, column, state, _) in enumerate(rate_uses)] or [0])
        P = len(states.slots)
        width_s = max([1] + [len(states.sensors[c.name]) for c in controllers])
        width_S = max(len(c.states) for c in controllers)
        t.width_s, t.width_S = width_s, width_S
        self._states_carried = {name: np.zeros((P, k)) for name in ("controller_dS", "controller_df")}
        self._states_carried.update({name: np.zeros(P) for name in ("controller_S", "controller_f")})
        t.dS, t.df = (self._pointer(self._states_carried[name]) for name in ("controller_dS", "controller_df"))
        t.S_n, t.f_n = (self._pointer(self._states_carried[name]) for name in ("controller_S", "controller_f"))
        t.S_next, t.f_next, t.by_h = (self._pointer(np.zeros(P)) for _ in range(3))
        t.f_s, t.f_S = self._pointer(np.zeros(P * width_s)), self._pointer(np.zeros(P * width_S))
        t.factor = self._pointer(np.zeros(P * width_S))
        t.f_p, t.held, t.scratch = (self._pointer(np.zeros(P * k)) for _ in range(3))
        t.pivots = ints(np.zeros(P, np.int64))
        t.ds = self._pointer(np.zeros(width_s * k))
        width = width_s + width_S
        t.law_args, t.law_out = self._pointer(np.zeros(width)), self._pointer(np.zeros((1 + width_S) * (1 + width)))
        t.by_step = self._pointer(np.zeros(model.n_total + 1))
        d.states = ctypes.addressof(t)

    def _actuated_loads(self, terms) -> tuple:
        """The load actuators of the continuous controllers (load, component, controller's place in the wiring,
        ∂(component)/∂y) in the wiring's order and their loads in their first actuator's order, and the sampled
        controllers' (SampledTerms.actuators: controller's place among the sampled ones) likewise; the actuated loads'
        points laid out in the struct (the continuous controllers' loads, then the sampled ones')."""
        owner, d = self.owner, self.data
        continuous, sampled = [], []
        if terms is not None:
            wiring = owner.assembler.control
            continuous = [(int(index), int(component), int(of), float(gain) if gain else 1.0) for kind, index,
                          component, of, gain in zip(wiring.actuator_kind, wiring.actuator_index,
                                                     wiring.actuator_component, wiring.actuator_controller,
                                                     wiring.actuator_gain) if kind != 0]
            if terms.sampled is not None:
                sampled = [(int(index), int(component), int(i), float(gain))
                           for kind, index, component, i, gain in terms.sampled.actuators if kind != 0]
        orders = [list(dict.fromkeys(index for index, *_ in a)) for a in (continuous, sampled)]
        everything = orders[0] + orders[1]
        d.n_actuated_loads, d.n_sampled_loads = len(everything), len(orders[1])
        if everything:
            node, offset, frame = owner._load_points()   # noqa: SLF001
            ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
            d.actuated_load_node, d.actuated_load_frame = ints(node[everything]), ints(frame[everything])
            d.actuated_load_offset = self._pointer(np.ascontiguousarray(offset[everything], np.float64))
            d.actuated_load_scratch = self._pointer(np.zeros(83 * len(owner.names)))
        return (continuous, orders[0]), (sampled, orders[1])

    def _sampled(self, sampled, loads) -> None:
        """The sampled controllers' part (SampledTerms.add): their hinge and guide actuators, their load actuators
        (places after the continuous controllers' loads), and the held δy's buffer, filled before each call
        (:meth:`prepared`)."""
        d = self.data
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        hinges = [(int(index), int(i), float(gain)) for kind, index, _, i, gain in sampled.actuators if kind == 0]
        d.n_sampled_hinge_actuators = len(hinges)
        d.sampled_hinge, d.sampled_hinge_of = ints([h[0] for h in hinges]), ints([h[1] for h in hinges])
        d.sampled_hinge_gain = self._pointer(np.array([h[2] for h in hinges], float))
        actuators, order = loads[1]
        first = d.n_actuated_loads - d.n_sampled_loads
        d.n_sampled_load_actuators = len(actuators)
        d.sampled_load = ints([first + order.index(index) for index, *_ in actuators])
        d.sampled_load_component, d.sampled_load_of = ints([a[1] for a in actuators]), ints([a[2] for a in actuators])
        d.sampled_load_gain = self._pointer(np.array([a[3] for a in actuators], float))
        self._sampled_held = np.zeros(sampled.held.shape)
        d.sampled_held = self._pointer(self._sampled_held)

    def _cables(self) -> None:
        """The cables' parameters' part (csrc/cable_forces.c): the uses of CableSensitivities in its order (cable,
        column, which value), each element's cable, the kernels, and per use that moves a cable's lumped masses
        their rows and the joint_body kernel's blocks (CableSensitivities.mass_blocks)."""
        from latdyn.assembly.library import CableForcesData

        owner, d = self.owner, self.data
        d.cables = None
        terms = owner.cables
        if terms is None or not terms.uses:
            return
        c = self._cable_data = CableForcesData()
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        which = {"EA": 0, "damping": 1, "rest_length": 2, "rhoA": 3}
        c.n_uses = len(terms.uses)
        c.cable, c.column = ints([u[0] for u in terms.uses]), ints([u[2] for u in terms.uses])
        c.value = ints([which[u[1]] for u in terms.uses])
        c.element_cable = ints(terms.cables.cable)
        c.force_kernel, c.rest_kernel = (owner.kernels.address(name) for name in CABLE_KERNELS[:2])
        row, rows, start, blocks, gravity = [], [], [], [], []
        for k, value, _, law in terms.uses:
            moved = value in ("rhoA", "rest_length") and k in terms.mass_rows
            at, block, g = terms.mass_blocks(k, value, law) if moved else (np.zeros(1, np.int64), None, None)
            row.append(int(at[0]))
            rows.append(len(at) if moved else 0)
            start.append(sum(len(b) for b in blocks))
            if moved:
                blocks.append(block)
                gravity.append(g)
        c.mass_row, c.mass_rows, c.mass_from = ints(row), ints(rows), ints(start)
        c.mass_blocks = self._pointer(np.ascontiguousarray(np.concatenate(blocks) if blocks else np.zeros((1, 13))))
        c.mass_gravity = self._pointer(np.ascontiguousarray(np.concatenate(gravity) if gravity else np.zeros((1, 3))))
        c.body_kernel = owner.kernels.address("joint_body") if blocks else None
        c.scratch = self._pointer(np.zeros(337 + 132 * max(rows)))
        d.cables = ctypes.addressof(c)

    def _body_uses(self) -> list:
        """(body key's match, index among the joint bodies, column, derivative law) of every body use the Python
        step adds (ParameterDerivatives._body_forces), in its order."""
        model, uses = self.owner.model, []
        for body, laws in self.owner._body_uses():   # noqa: SLF001
            found = np.flatnonzero(model.body_nodes == model.body_node[body["body"]])
            if not len(found):   # a centre of mass of a body without mass or inertia (others: refusal)
                continue
            uses += [(body, int(found[0]), column, law) for column, law in laws.items()]
        return uses

    def _link_uses(self) -> list:
        """(rigid link beam, index among the joint bodies, its link node, the section value, column, derivative law)
        of every use of a rigid link's own section value (link_sensitivities.add_link_section_forces, which the Python
        step adds right after the joint bodies' forces: here the body uses after theirs, the generated joint_body with
        the block of ``link_section_block`` at the derivative law's value)."""
        from latdyn.analyses.link_sensitivities import link_section_uses

        return [(beam, b, node, value, column, law) for beam, b, node, value, laws in link_section_uses(self.owner)
                for column, law in laws.items()]

    def _sections(self) -> None:
        """The section uses of ParameterDerivatives._native_section_forces (their rows constant: refusal)."""
        owner, d = self.owner, self.data
        layout = owner._section_layout()   # noqa: SLF001
        d.n_uses = 0
        if layout is None:
            return
        elements, column, rows = owner._section_derivative_blocks(_AtTime(0.0))  # noqa: SLF001 - constant laws (refusal)
        on, use = owner._section_elements_once()   # noqa: SLF001
        internal, inertia = owner._section_kernel_addresses()   # noqa: SLF001
        gravity = 1.0 * np.asarray(owner.assembler.gravity, float)
        d.internal_D_section, d.inertia_D_section = internal, inertia
        d.gravity = self._pointer(np.ascontiguousarray(gravity))
        arrays = [np.ascontiguousarray(a, np.int64) for a in (on, use, elements, column)]
        d.n_on, d.on = len(on), self._pointer(arrays[0])
        d.n_uses, d.use, d.elements, d.columns = len(use), *(self._pointer(a) for a in arrays[1:])
        d.rows = self._pointer(np.ascontiguousarray(rows, np.float64))
        d.section_scratch = self._pointer(np.zeros(max(len(on) * (36 + 14 + 14 + 10 + 3 + 2 * (14 + 126)), 1)))

    def _loads(self) -> None:
        """The (load, parameter) pairs of ParameterDerivatives._load_pair_forces."""
        owner, d = self.owner, self.data
        pairs, columns, _, _ = owner._load_layout()   # noqa: SLF001
        d.n_pairs = len(pairs)
        if not len(pairs):
            return
        node, offset, frame = owner._load_points()   # noqa: SLF001
        d.pair_node = self._pointer(np.ascontiguousarray(node[pairs], np.int64))
        d.pair_frame = self._pointer(np.ascontiguousarray(frame[pairs], np.int64))
        d.pair_column = self._pointer(np.ascontiguousarray(columns, np.int64))
        d.pair_offset = self._pointer(np.ascontiguousarray(offset[pairs], np.float64))
        d.pair_scratch = self._pointer(np.zeros(76 * len(pairs)))

    def prepared(self, carried: dict, grid_index: int, stop_index: int, control, rows: int = 0, state=None):
        """The struct filled for a loop of steps from grid point ``grid_index`` (``state``: the state there) through
        ``stop_index`` with the carried sensitivities ``carried`` and ``rows`` rows to record on the way
        (:meth:`record_rows`); None where this numbering takes the Python path."""
        if not self._layout():
            return None
        d, owner = self.data, self.owner
        n, k = owner.model.n_dofs, len(owner.names)
        self._row_carried = np.zeros((rows, 3 * n * k + k)) if rows else None
        d.row_carried = self._row_carried.ctypes.data if rows else None
        if d.accounts:
            self._carry_accounts(carried, state, rows)
        for name, array in self._carried.items():
            np.copyto(array, carried[name])
        np.copyto(self._dt, carried["dt"])
        d.steps, d.info = 0, 0
        self._tabulate(grid_index, stop_index, control)
        if d.n_partials or (d.states and owner.controllers.compiled is not None):   # the inputs and controllers'
            # outputs the controllers' partials read, bound for this call
            owner.controllers.compiled.bind()
        if d.sampled_held:   # the held δy of the last sample (as the Python step reads it: a resumed run's from the
            np.copyto(self._sampled_held, carried["sampled_dy"])   # checkpoint), constant up to the next sample
        if d.states:   # the controllers' states' carried δS, δf and (S, f) at the loop's start (ControllerStates)
            for name, array in self._states_carried.items():
                np.copyto(array, carried[name])
            P = len(self._states_carried["controller_S"])   # each row's δS and S (a controller probe's: record_rows)
            self._row_states = np.zeros((rows, P * (k + 1))) if rows else None
            self._states_data.row_states = self._row_states.ctypes.data if rows else None
        if self._rates is not None:   # ∂r/∂t's laws' rates alike (_TimeRates)
            self._rates._tabulate(grid_index, stop_index, control)   # noqa: SLF001
            if self._rates.data.n_partials:   # the controllers' outputs' rates in t: their signals bound alike
                self._rates.owner.controllers.compiled.bind()
        return d

    def _carry_accounts(self, carried: dict, state, rows: int) -> None:
        """The work accounts and their terms at ``state`` (the loop's start) into the struct, as the Python step reads
        them (energy_sensitivities._dissipated_step and external_work_step: the held terms, or those at the step's
        start), and the rows' buffer."""
        from latdyn.analyses.energy_sensitivities import _damper_torques, _power

        a, k, account = self._accounts_data, len(self.owner.names), self._account
        np.copyto(account["theta"], np.asarray(state.theta, float))
        if "dissipated" in account:
            held = carried.get("dissipated_terms")
            terms = held if held is not None else _damper_torques(self.owner, state, carried)
            np.copyto(account["dissipated"], carried.get("dissipated_sensitivity", np.zeros(k)))
            for name, value in zip(("torque", "dtorque", "dtheta"), terms):
                np.copyto(account[name], np.asarray(value, float).reshape(-1))
        if "work" in account:
            held = carried.get("external_work_terms")
            power, dpower, *terms = held if held is not None else _power(self.owner, state, carried)
            np.copyto(account["work"], carried.get("external_work_sensitivity", np.zeros(k)))
            account["power"][0], account["power"][1:] = power, dpower
            for name, value in zip(("work_torque", "work_dtorque", "work_dtheta"), terms):
                np.copyto(account[name], np.asarray(value, float).reshape(-1))
            if "drive_dr" in account:   # the drive's δr_d and the prescribed nodes' x, T at the loop's start
                from latdyn.analyses.energy_sensitivities import _drive_reactions

                held = carried.get("external_work_drive")
                _, dreaction = held if held is not None else _drive_reactions(self.owner, state, carried)
                nodes = self.owner.model.prescribed_nodes()
                np.copyto(account["drive_dr"], np.asarray(dreaction, float).reshape(-1))
                np.copyto(account["drive_x"], np.asarray(state.x, float)[nodes].reshape(-1))
                np.copyto(account["drive_T"], np.asarray(state.T, float)[nodes].reshape(-1))
        self._row_accounts = np.zeros((rows, 2 * k)) if rows else None
        a.row_accounts = self._row_accounts.ctypes.data if rows else None

    def _tabulate(self, grid_index: int, stop_index: int, control) -> None:
        """The derivative laws' values of t at each grid point from ``grid_index`` + 1 through ``stop_index`` into
        the struct (:meth:`tabulate_at`; the step's end time as the loop of steps computes it)."""
        self.tabulate_at([control.grid_time(grid) for grid in range(grid_index + 1, stop_index + 1)], grid_index + 1)

    def tabulate_at(self, times: list, grid_index: int) -> None:
        """The derivative laws' values of t at each of ``times`` into the struct, row ``grid_index`` the first (the
        loads', hinges', joint bodies', stops' and friction's; laws of the state: in C): the loop's grid points, or
        the discrete adjoint's stored states (latdyn/analyses/adjoint_in_loop.py ``ReverseSteps``, row i the stored
        state i + 1)."""
        d, owner = self.data, self.owner
        if d.n_pairs:   # the derivative laws' values at each grid point the loop may reach (_load_pair_forces)
            pairs, _, place, _ = owner._load_layout()   # noqa: SLF001
            distinct, use = owner.load_laws_distinct()
            table = np.zeros((len(times), len(pairs), 6))
            for row, t in enumerate(times):
                table[row][place] = 1.0 * np.array([owner._of_time(law, t) for law in distinct])[use]  # noqa: SLF001
            self._table = table
            d.pair_values, d.values_from = table.ctypes.data, grid_index
        if d.n_hinge_uses:   # the derivative laws' values (for the rest angle the stiffness's) at each grid point
            hinges = owner.model.hinges
            compiled = owner.derivative_laws   # the laws of the state compiled: in C; the others tabulated here
            tabulated = lambda law: law is not None and (compiled is None or compiled.index(law) < 0)   # noqa: E731
            uses = [(law if tabulated(law) else None,
                     hinges[j].stiffness if which == "rest_angle" and tabulated(hinges[j].stiffness) else None)
                    for j, which, laws in owner._hinge_uses() for law in laws.values()]   # noqa: SLF001
            values = [[(law.value(0.0, 0.0, t) if law is not None else 0.0,
                        stiffness.value(0.0, 0.0, t) if stiffness is not None else 0.0)
                       for law, stiffness in uses] for t in times]
            if owner.derivative_laws is not None:   # the inputs they read, bound for this call
                owner.derivative_laws.bind()
            self._hinge_table = np.array(values, float).reshape(len(times), len(uses), 2)
            d.hinge_values, d.values_from = self._hinge_table.ctypes.data, grid_index
        if d.n_body_uses:   # the kernel's block and ∂c/∂p of each use at each grid point (ParameterDerivatives.body_block)
            from latdyn.analyses.link_sensitivities import link_section_block

            table = np.zeros((len(times), d.n_body_uses, 16))
            uses, links = self._body_uses(), self._link_uses()
            for row, t in enumerate(times):
                for u, (body, b, _, law) in enumerate(uses):
                    block, along = owner.body_block(body, b, law.value(0.0, 0.0, t))
                    table[row, u, :13] = block[0]
                    if along is not None:
                        table[row, u, 13:] = along
                for u, (beam, b, _, value, _, law) in enumerate(links, len(uses)):   # add_link_section_forces' block
                    if row and law.is_constant:   # a law without t: the first time's row (the same bits)
                        table[row, u] = table[0, u]
                        continue
                    table[row, u, :13] = link_section_block(owner.kernels, beam, value, law.value(0.0, 0.0, t),
                                                            owner.model.body_com[b])[0]
            self._body_table = table
            d.body_values, d.values_from = table.ctypes.data, grid_index
        if d.n_law_uses:   # the compliant stops' and friction's derivative laws at each grid point (_contact_forces)
            laws = [law for _, by_column in owner.joint_law_uses() for law in by_column.values()]
            self._law_table = np.array([[law.value(0.0, 0.0, t) for law in laws] for t in times], float).reshape(
                len(times), len(laws))
            d.law_values, d.values_from = self._law_table.ctypes.data, grid_index
        if d.cables:   # the cables' derivative laws at each grid point (CableSensitivities.residual_derivatives)
            laws = [law for _, _, _, law in owner.cables.uses]
            self._cable_table = np.array([[law.value(0.0, 0.0, t) for law in laws] for t in times], float).reshape(
                len(times), len(laws))
            self._cable_data.values, self._cable_data.values_from = self._cable_table.ctypes.data, grid_index
        if d.accounts:
            self._tabulate_accounts(times, grid_index - 1)
        if d.geometry and self._geometry_data.n_arms:   # the moved loads' values at each grid point (_load_arms)
            geometry = owner.geometry
            self._arm_table = np.array([[geometry.load_arm_values(t, index, 1.0) for index, _, _ in
                                         geometry.moved_loads] for t in times], float)
            g = self._geometry_data
            g.arm_values, g.values_from = self._arm_table.ctypes.data, grid_index

    def _tabulate_accounts(self, times: list, grid_index: int) -> None:
        """The work accounts' laws at each grid point (``times``, from ``grid_index`` + 1): the damping laws'
        (c, ∂c/∂θ, ∂c/∂θ̇) and the damping parameters' ∂c/∂p (_damper_torques); the loads' values and the pairs'
        derivative laws', the hinges' applied torques' laws and their parameters' (_power); laws of t alone
        (:func:`_account_refusal`), each read as the Python step reads it."""
        from latdyn.analyses.energy_sensitivities import applied_torque_laws, applied_torque_uses, damping_uses

        from latdyn.analyses.energy_sensitivities import account_laws

        owner, a, account = self.owner, self._accounts_data, self._account
        hinges, count = owner.model.hinges, len(times)
        a.values_from = grid_index + 1
        at = [_AtRest(t, len(hinges)) for t in times]
        compiled = account_laws(owner)
        if compiled is not None:   # the inputs the laws of the state read, bound for this call
            compiled.bind()

        def values(law, theta, rate, t):   # a law of t alone's; a law of the state's: in C (zeros here)
            return (0.0, 0.0, 0.0) if compiled is not None and compiled.index(law) >= 0 else (
                law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t))

        if "dissipated" in account:
            uses = damping_uses(owner)
            self._account_laws = np.array([[values(h.damping, 0.0, 0.0, t) for h in hinges] for t in times],
                                          float).reshape(count, len(hinges), 3)
            self._account_uses = np.array([[values(law, 0.0, 0.0, t)[0] for _, _, law in uses] for t in times],
                                          float).reshape(count, len(uses))
            a.laws, a.use_values = self._account_laws.ctypes.data, self._account_uses.ctypes.data
        if "work" in account:
            def value(law, t):
                return float(law.value(t)) if hasattr(law, "value") else float(law)

            loads = owner.scene.loads
            self._load_table = np.array([[[value(c, t) for c in (load.force or [0.0] * 3)]
                                          + [value(c, t) for c in (load.moment or [0.0] * 3)] for load in loads]
                                         for t in times], float).reshape(count, len(loads), 6)
            pairs, _, place, laws = owner._load_layout()   # noqa: SLF001
            table = np.zeros((count, len(pairs), 6))
            for row, t in enumerate(times):
                table[row][place] = np.array([owner._of_time(law, t) for law in laws])   # noqa: SLF001
            self._pair_table = table
            self._torque_table = np.array([applied_torque_laws(owner.model, state, values) for state in at],
                                          float).reshape(count, len(hinges), 8)
            uses = applied_torque_uses(owner)
            self._torque_uses = np.array([[values(law, 0.0, 0.0, t)[0] for *_, law in uses] for t in times],
                                         float).reshape(count, len(uses))
            a.load_values, a.pair_values = self._load_table.ctypes.data, self._pair_table.ctypes.data
            a.torque_laws, a.torque_use_values = self._torque_table.ctypes.data, self._torque_uses.ctypes.data

    def record_rows(self, carried: dict, block, rows: int) -> dict:
        """``carried`` with the sensitivities of the first ``rows`` rows the last call of the loop of steps recorded
        on its way (``block``: a step.compiled.RowBlock), each as :meth:`TransientSensitivities.record` records a
        row from Python: at the row's state, from the δq, δv, δv̇ and δt the loop carried to it
        (csrc/sensitivity_loop.c ``sensitivity_loop_row``); the carried columns themselves left as they were (the
        loop's last are :meth:`carried_after`'s)."""
        owner = self.owner
        n, k = owner.model.n_dofs, len(owner.names)
        nk = n * k
        held = self._row_carried[:rows]
        at_once = block_rows(owner, carried, block.states.t[:rows], block.states.T[:rows],
                             held[:, :nk].reshape(rows, n, k), held[:, 3 * nk:])
        if at_once is not None:   # every row in one pass (latdyn/analyses/sensitivity_rows.py)
            owner.held = owner._held(carried)   # noqa: SLF001 - as TransientSensitivities.record leaves it
            return {**carried, "rows": carried["rows"] + at_once}
        states = self._row_states if self.data.states else None
        if states is not None:   # the controllers' states as the loop leaves them, put back after the rows
            slots = owner.controllers.states.slots
            values = owner.scene.controller_states.values
            kept, P = values[slots].copy(), len(slots)
        for r in range(rows):
            held = self._row_carried[r]
            at_row = {**carried, "dq": held[:nk].reshape(n, k), "dv": held[nk:2 * nk].reshape(n, k),
                      "dvdot": held[2 * nk:3 * nk].reshape(n, k), "dt": held[3 * nk:]}
            if self.data.accounts:   # the work accounts at the row (csrc/work_accounts.c)
                if "dissipated" in self._account:
                    at_row["dissipated_sensitivity"] = self._row_accounts[r, :k]
                if "work" in self._account:
                    at_row["external_work_sensitivity"] = self._row_accounts[r, k:]
            if states is not None:   # the carried δS and the accepted S at the row (controller probes read them)
                at_row["controller_dS"] = states[r, :P * k].reshape(P, k)
                values[slots] = states[r, P * k:]
            carried = {**carried, "rows": owner.record(at_row, block.state(r))["rows"]}
        if states is not None:
            values[slots] = kept
        return carried

    def steps_in_call(self) -> int:
        """The steps the last call of the loop of steps differentiated (the run's count, summary.json
        ``sensitivity_steps_in_loop``, is carried by the checkpoint: TransientProgress)."""
        return int(self.data.steps)

    def carried_after(self, carried: dict) -> dict:
        """``carried`` after the loop's steps, as the Python path leaves it after a
        smooth step landing on the grid (TransientSensitivities.step, then the control's resize after a step
        onto the grid: the nominal step, dh_next 0)."""
        d = self.data
        if d.steps == 0:
            return carried
        dh = self._dh.copy()
        accounts = {}
        if d.accounts:   # the work accounts and their terms at the last step's end (_dissipated_step's, external_work_step's)
            account, hinges, k = self._account, len(self.owner.model.hinges), len(dh)
            if "dissipated" in account:
                accounts = {"dissipated_sensitivity": account["dissipated"].copy(), "dissipated_terms": (
                    account["torque"].copy(), account["dtorque"].reshape(hinges, k).copy(),
                    account["dtheta"].reshape(hinges, k).copy())}
            if "work" in account:
                accounts.update({"external_work_sensitivity": account["work"].copy(), "external_work_terms": (
                    float(account["power"][0]), account["power"][1:].copy(), account["work_torque"].copy(),
                    account["work_dtorque"].reshape(hinges, k).copy(), account["work_dtheta"].reshape(hinges, k).copy()),
                    "external_work_drive": (self.owner.model.prescribed_coordinates(), account["drive_dr"].reshape(
                        -1, k).copy() if "drive_dr" in account else np.zeros((0, k)))})
        if d.states:   # the controllers' states' carried δS, δf and (S, f) at the last step's end
            accounts.update({name: array.copy() for name, array in self._states_carried.items()})
        return {**carried, **{name: array.copy() for name, array in self._carried.items()}, "dt": self._dt.copy(),
                "dh": dh, "dh_step": dh, "h": d.h, "pending": None, "dh_next": np.zeros(len(dh)), **accounts}


class _TimeRates(SensitivityLoop):
    """∂r/∂t at fixed coordinates (ExplicitTime.of_laws of latdyn/analyses/transient_sensitivities.py: the laws' rates
    in t through the parameters' machinery with one column, t) as a struct of its own, which the loop's step reads
    beside its parameters' (``time_rates``): the hinge laws', the controllers' outputs' (∂f/∂t compiled) and the load
    components' uses of ``laws`` (the
    ExplicitTime's one-column copy of the owner), their rates tabulated per grid point, its ``total`` the column."""

    def _layout(self) -> bool:
        if self._for is not None:
            return True
        owner, d = self.owner, self.data
        d.k, d.n_uses, d.n_body_uses, d.n_law_uses = 1, 0, 0, 0
        self._total = np.zeros(owner.model.n_total + 1)
        d.total = self._pointer(self._total)
        self._loads()
        self._hinges()
        self._controllers()   # outputs that name t: their ∂f/∂t compiled (_controller_time_rates), as ∂f/∂p
        self._reels()
        self._motions()
        self._for = (None, True)
        return True

    def _reels(self) -> None:
        """The reels' part (ExplicitTime.of_laws: CableSensitivities.reel_forces): each cable whose rest length is a
        law in t as a rest-length use of csrc/cable_forces.c (the generated cable_force_D_rest_length times the
        element's share and L0′(t), at each element held taut), its rate tabulated per grid point (:meth:`_tabulate`)."""
        from latdyn.assembly.library import CableForcesData

        d, owner = self.data, self.owner
        d.cables = None
        terms = owner.cables
        if terms is None or not owner.reels:
            return
        self._reeled = [k for k, rest in enumerate(terms.cables.rest_length) if not rest.is_constant]
        c = self._cable_data = CableForcesData()
        ints = lambda values: self._pointer(np.array(values, np.int64))   # noqa: E731
        uses = len(self._reeled)
        c.n_uses = uses
        c.cable, c.column, c.value = ints(self._reeled), ints([0] * uses), ints([2] * uses)
        c.element_cable = ints(terms.cables.cable)
        c.force_kernel, c.rest_kernel = (owner.kernels.address(name) for name in CABLE_KERNELS[:2])
        c.mass_row, c.mass_rows, c.mass_from = ints([0] * uses), ints([0] * uses), ints([0] * uses)
        c.mass_blocks, c.mass_gravity = self._pointer(np.zeros((1, 13))), self._pointer(np.zeros((1, 3)))
        c.body_kernel = None
        c.scratch = self._pointer(np.zeros(337))
        d.cables = ctypes.addressof(c)

    def _motions(self) -> None:
        """The prescribed motions' part (ExplicitTime.through_prescribed, latdyn/analyses/prescribed_rates.py): the
        mask of the prescribed coordinates, the loads' block columns, the coordinates the motion laws move, scratch
        for their dense rates and the result; their values tabulated per grid point (:meth:`_tabulate`)."""
        d, motions = self.data, self.owner.motions
        d.n_motions = 0
        if motions is None:
            return
        coordinates = motions.motion_coordinates()
        d.n_motions = len(coordinates)
        if not d.n_motions:
            return
        size = self.owner.model.n_total + 1
        d.prescribed_mask = self._pointer(motions.mask())
        d.load_columns = self._pointer(motions.load_columns())
        couplings = motions.couplings()
        d.motion_couplings = self._pointer(couplings) if couplings is not None else None
        d.motion_coordinates = self._pointer(coordinates)
        d.motion_rates = self._pointer(np.zeros(3 * size))
        self._through = np.zeros(size)
        d.through_prescribed = self._pointer(self._through)
        if self.owner.model.links is not None:   # csrc/linked_prescribed_rates.c's scratch
            d.linked_motion_mask = self._pointer(np.zeros(size, np.int64))
            d.linked_motion_moved = self._pointer(np.zeros(3 * size))
            d.linked_motion_all = self._pointer(np.zeros(size))

    def _tabulate(self, grid_index: int, stop_index: int, control) -> None:
        """The laws' rates (SensitivityLoop._tabulate) and the motion laws' rate, acceleration and jerk at each grid
        point from ``grid_index`` + 1 through ``stop_index`` (PrescribedRates.values)."""
        super()._tabulate(grid_index, stop_index, control)
        d = self.data
        if d.cables:   # the reels' L0′(t) (CableSensitivities.reel_forces: the rest length's rate)
            rest = self.owner.cables.cables.rest_length
            self._reel_table = np.array([[rest[k].rate(control.grid_time(grid)) for k in self._reeled]
                                         for grid in range(grid_index + 1, stop_index + 1)], float)
            self._cable_data.values, self._cable_data.values_from = self._reel_table.ctypes.data, grid_index + 1
        if d.n_motions:
            motions = self.owner.motions
            self._motion_table = np.ascontiguousarray([motions.values(control.grid_time(grid))
                                                       for grid in range(grid_index + 1, stop_index + 1)], float)
            d.motion_values, d.motions_from = self._motion_table.ctypes.data, grid_index + 1


class _AtRest:
    """A stand-in state at time t with every hinge at θ = θ̇ = 0, for the hinges' laws of t alone tabulated per grid
    point (energy_sensitivities.applied_torque_laws)."""

    def __init__(self, t: float, hinges: int):
        self.t, self.theta, self.theta_dot = t, np.zeros(hinges), np.zeros(hinges)


class _AtTime:
    """A stand-in state at time t for the layouts read at no state (the laws' values)."""

    def __init__(self, t: float):
        self.t = t
