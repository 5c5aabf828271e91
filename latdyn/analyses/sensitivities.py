"""Exact sensitivities of static paths, load control, arc length and displacement control (SCENE.md,
"Parameters and sensitivities").

The computed static solution at a recorded load factor λ > 0 is the configuration q at which
Newton made the residual r(q; λ, p) vanish. Its derivative by a parameter p is the tangent vector

    δq/δp = −K⁻¹ ∂r/∂p,      K = ∂r/∂Δ at (q, λ)   (the static Newton matrix, at the converged q)

in the coordinates of the configuration update (translations added, rotations T ← exp(skew δπ) T,
hinge angles added): rotation sensitivities live in the tangent space, as the step's own
increments do. The row at λ = 0 is the initial configuration, which Newton does not solve for and
which only geometry parameters move (δq_0 = δX, :mod:`latdyn.analyses.geometry_sensitivities`); for
the rest its sensitivities are zero. Geometry parameters' ∂r/∂p: the generated derivatives of the
element forces along the reference data's variation (the same module).

∂r/∂p comes from the generated kernels the residual itself is made of, by their linearity:

- a load component F_c(t; p) enters the residual through ``point_load``, linear in the load's
  values: ∂r/∂p = point_load(…, values = λ ∂F/∂p) (global or turning with a body);
- a hinge's stiffness k, damping c and torque τ enter through ``hinge_force``, f = k s + c θ̇ − λ τ
  with s = θ − θ_r, linear in (k, c, τ): ∂f/∂p = hinge_force(…, laws = (∂k/∂p, ∂c/∂p, ∂τ/∂p)), the
  laws' derivatives those of :meth:`latdyn.scene.parameters.Parameters.derivative`; the rest angle
  enters affinely: ∂f/∂θ_r = hinge_force(θ = θ̇ = 0, θ_r = 1, laws = (k, 0, 0)).

A probe's derivative is its value's derivative along δq: a point x + T r moves by δx + δπ × T r;
a hinge angle by δθ; an element's section forces, a cable's tension and length and a point in a body's
frame by the generated kernels' derivatives (:mod:`latdyn.analyses.probe_derivatives`).

- a section's values (EA … ρIz, GAy, GAz as their compliances 1/GA) enter through the element's internal
  force and gravity load (F − λ Q): the generated derivatives by the section values
  (``beam_internal_force_D_section``, ``beam_inertia_force_D_section`` at rest; forward mode, exact in every
  formulation and for shear-flexible sections, whose element is not linear in EI and 1/GA) contracted with
  (∂EA/∂p, …, ∂(1/GAz)/∂p), the planar model's quarter turns of the section axes applied as the model applies
  them (:meth:`ParameterDerivatives._section_element_forces`);
- a joint body's mass m and centre of mass c enter a static residual through ``joint_body`` at
  rest, λ-gravity alone, linear in m at fixed c and affine in c at fixed m: the kernel with
  (∂m/∂p, c), and with (m, ∂c/∂p) less with (m, 0); inertias do not enter it.

Under displacement control the controlled displacement c(q) is held and λ moves instead: with
g = ∂c/∂q and q_ref = −∂r/∂λ, δq = δq_r + δλ K⁻¹q_ref, δq_r = −K⁻¹ ∂r/∂p, δλ = −g·δq_r / g·K⁻¹q_ref.

Under arc length each row lies at the arc length Δs_n from the row before: :class:`ArcLengthSensitivities`
differentiates that chain with the bordered matrix [K, −q_ref; DᵀW, 0] (regular at limit points) and
locates the limit points the rows pass, for the limit load's derivative (docs/parameters.md, "Arc length").

Transient runs: :mod:`latdyn.analyses.transient_sensitivities` (the step differentiated), on
:class:`ParameterDerivatives` (∂r/∂p with the inertia forces).

Compliant stops of hinges and guides (their law's stiffness, exponent and damping:
:meth:`ParameterDerivatives._contact_forces`, the generated ``contact_force_D_law``), friction while the joint slips
(coulomb, static, stribeck_rate, viscous, stick_rate: the generated ``friction_force_D_law``; sticking and the
release: latdyn/analyses/transient_sensitivities.py) and controllers (:class:`ControllerTerms`:
parameters inside their outputs; :class:`ControllerStates`: continuous controllers' states carried through the step;
:class:`SampledTerms`: sampled controllers' held outputs and states) enter ∂r/∂p of transient runs.

What is refused (:func:`refusal`, exit 2 naming ``solve.sensitivities``): any analysis but static
load control, arc length and displacement control and transient runs of an implicit method (fixed steps,
or adaptive ones where :func:`latdyn.analyses.adaptive_sensitivities.refusal` allows them; inputs are held at
their values: the derivative is the one at fixed inputs; a joint sticking by friction is refused, when it does,
only where latdyn/analyses/transient_sensitivities.py says), continuous controllers that read a force (a
tension, a section or joint force), controllers whose states' rates name t beside events (cables through their
slack/taut events, guides with theirs: :func:`_transient_refusal`, :meth:`ControllerTerms.refusal`); a
parameter used anywhere but in load components, numbers that place the structure (geometry parameters,
where :func:`latdyn.analyses.geometry_sensitivities.geometry_refusal` allows them), hinge stiffness, damping,
torque and rest angle, section
values (every formulation, shear-flexible sections too), body masses, centres of mass and inertias,
compliant stops' laws and, in transient runs, a guide's compliant stops' and a hinge's or guide's friction laws,
initial velocities, controllers' outputs and states' rates,
guides' laws and cables' EA, damping, rest length and rhoA; probes other than point positions and displacements in the
global frame, hinge angles and guide positions and, in transient runs, rates, point velocities and joint forces
(latdyn/analyses/joint_force_sensitivities.py), element section forces, cable tensions and lengths and points in a
body's frame (latdyn/analyses/probe_derivatives.py: static and transient; a body frame's velocity in transient
runs), and energies and momenta where latdyn/analyses/energy_sensitivities.py refuses them;
(rigid links and guides are differentiated
through the reduction: latdyn/analyses/link_sensitivities.py). A static path does not apply rigid stops
and latches (``limits`` without ``contact``, ``lock_at``: events of the time loop, docs/static_paths.md): its rows
are the path without them, and so are their sensitivities — exact, and the structure's own while every joint
stays inside its limits and short of its ``lock_at``; a path that ends past one is flagged by the run's warning
(latdyn/analyses/not_equilibria.py ``stops_passed``), its sensitivities with it (transient runs differentiate latches and stops:
latdyn/analyses/transient_sensitivities.py). Under gravity the static
Newton matrix K − λ ∂Q/∂q holds the beams' gravity tangent (the generated ``beam_gravity_D_q``), so
beams with mass are differentiated exactly there too. docs/parameters.md.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from latdyn.analyses import adaptive_sensitivities
from latdyn.analyses import controller_probe_sensitivities as controller_probes
from latdyn.analyses.energy_sensitivities import is_energy_or_momentum
from latdyn.analyses.energy_sensitivities import probe_derivatives as energy_probe_derivatives
from latdyn.analyses.energy_sensitivities import refusal as energy_refusal
from latdyn.analyses.joint_force_sensitivities import is_joint_force
from latdyn.analyses.joint_force_sensitivities import refusal as joint_force_refusal
from latdyn.analyses.geometry_sensitivities import GEOMETRY_KEY, ReferenceGeometry, geometry_refusal, model_refusal
from latdyn.analyses.link_sensitivities import add_link_section_forces, dependent_rates
from latdyn.analyses.probe_derivatives import is_probe_here, probe_derivatives
from latdyn.analyses.probe_derivatives import refusal as probe_refusal
from latdyn.analyses.sensitivity_rows import point_moved
from latdyn.analyses.limit_points import bordered_solve
from latdyn.assembly.factorization import solve_linear
from latdyn.assembly.native_model import NO_CONTACT, joint_contact_rows
from latdyn.errors import SceneError, SolverError
from latdyn.results.result import SENSITIVITIES_FILE
from latdyn.scene.expressions import HingeLaw, parse_hinge_law, reading_inputs
from latdyn.timeloop.jumps import jumping_key, prescribed_motion_jump_key

__all__ = ["refusal", "StaticSensitivities", "SENSITIVITIES_FILE"]


# the keys of a parameter's uses (latdyn/analyses/parameter_keys.py), by their names here
from latdyn.analyses.parameter_keys import (  # noqa: F401  re-exported under these names
    LOAD_KEY as _LOAD_KEY, SECTION_KEY as _SECTION_KEY, SECTION_COLUMN as _SECTION_COLUMN, BODY_KEY as
    _BODY_KEY, INITIAL_VELOCITY_KEY as _INITIAL_VELOCITY_KEY, GUIDE_KEY as _GUIDE_KEY, GUIDE_LAW as
    _GUIDE_LAW, CABLE_KEY as _CABLE_KEY, HINGE_KEY as _HINGE_KEY, CONTACT_KEY as _CONTACT_KEY,
    CONTROLLER_KEY as _CONTROLLER_KEY, FRICTION_SLOT, has_events, joint_law, laws_naming)


def refusal(scene) -> SceneError | None:
    """The SceneError that refuses ``solve.sensitivities`` of ``scene``, or None when every named
    parameter, the analysis and every probe are differentiated exactly here."""
    names = scene.solve.sensitivities
    if not names:
        return None
    key, solve = "solve.sensitivities", scene.solve

    def refuse(what):
        return SceneError(scene.file, key, f"{what}; expected sensitivities only where they are exact "
                                           "(docs/parameters.md, \"Sensitivities\")")

    why = (_transient_refusal(scene) if solve.analysis == "transient"
           else ControllerTerms.parameter_in_a_reading_law(scene, "parameters in the laws that read controllers "
                                                                  "are differentiated in transient runs only")
           if solve.analysis == "static" else None)
    if why is not None:
        return refuse(why)
    if solve.analysis not in ("static", "transient") or (
            solve.analysis == "static" and solve.method not in ("load-control", "displacement-control", "arc-length")):
        method = f"{solve.analysis}" + (f" ({solve.method})" if solve.analysis == "static" else "")
        return refuse(f"sensitivities are computed for static load control, arc length and displacement control "
                      f"and for transient runs with an implicit method only, not yet for a {method} analysis")
    for name in names:
        for used in scene.parameters.depending_on(name):
            section = _SECTION_KEY.match(used)
            initial = solve.analysis == "transient" and (_INITIAL_VELOCITY_KEY.match(used) or _CONTROLLER_KEY.match(used)
                                                         or _cable_use(scene, used) or _GUIDE_KEY.match(used)
                                                         or joint_law(used))
            if GEOMETRY_KEY.match(used):   # a number that places the structure (geometry_sensitivities.py)
                why = geometry_refusal(scene, name, used)
                if why is not None:
                    return refuse(why)
                refused = model_refusal(scene, name, used)   # what the model would refuse, before compiling
                if refused is not None:
                    return refused
                continue
            if not (_LOAD_KEY.match(used) or _HINGE_KEY.match(used) or section or _BODY_KEY.match(used) or initial
                    or _CONTACT_KEY.match(used)):
                return refuse(f"parameter {name!r} is used at {used}: sensitivities are computed for parameters "
                              "of load components, of numbers that place the structure (bodies.NAME.at, a "
                              "beam's free end from/to, an end's offset, a beam's y_axis, a hinge's axis), of hinge "
                              "stiffness, damping, torque and rest_angle, of section values (EA, EIy, EIz, GJ, "
                              "rhoA, rhoIy, rhoIz, GAy, GAz), of body masses, centres of mass and inertias, of a "
                              "hinge's compliant stops (contact.stiffness, .exponent, .damping) "
                              "and, in transient runs, of a guide's compliant stops, of a hinge's or guide's "
                              "friction (coulomb, static, stribeck_rate, viscous, stick_rate), of "
                              "initial_velocity.linear and .angular, of controllers' "
                              "outputs and states' rates (controllers.NAME.output, .states.S), of guides' "
                              "stiffness, damping, "
                              "force and rest, and of cables' EA, damping, rest_length and rhoA (> 0) only")
    transient = solve.analysis == "transient"
    guided = any(getattr(body, "guide", None) is not None for body in scene.bodies.values())
    if solve.sensitivity_method == "adjoint":   # what the discrete adjoint leaves to the forward method
        refused = adjoint_refusal(scene)
        if refused is not None:
            return refused
    for probe in scene.output.probes:
        if is_energy_or_momentum(probe):   # latdyn/analyses/energy_sensitivities.py
            refused = energy_refusal(scene, probe)
            if refused is not None:
                return refused
            continue
        point = probe.kind == "point" and probe.quantity in ("position", "displacement") and probe.frame == "global"
        # a point's velocity v + ω × T r: δv, δω carried by the transient step (a guided body's or a rigid
        # link's dependent node: P δv + ∂(J v)/∂q δq, latdyn/analyses/link_sensitivities.py dependent_rates)
        velocity = (transient and probe.kind == "point" and probe.quantity == "velocity"
                    and probe.frame == "global")
        slide = probe.kind == "guide" and probe.quantity in ("position", "rate") and transient
        joint = probe.kind == "hinge" and (probe.quantity == "angle" or (transient and probe.quantity == "rate"))
        force = transient and is_joint_force(probe)   # latdyn/analyses/joint_force_sensitivities.py
        why_not = joint_force_refusal(scene, probe) if force else None
        here = is_probe_here(probe)   # section forces, cables, body frames: latdyn/analyses/probe_derivatives.py
        why_not = why_not or (probe_refusal(scene, probe) if here else None)
        control = controller_probes.is_controller_probe(probe)   # latdyn/analyses/controller_probe_sensitivities.py
        why_not = why_not or (controller_probes.refusal(scene, probe) if control else None)
        if why_not is not None:
            return refuse(why_not)
        if not (point or velocity or slide or joint or force or here or control):
            return refuse(f"probe {probe.name!r} ({probe.kind} {probe.quantity}"
                          f"{'' if probe.kind != 'point' else ', frame ' + probe.frame}) is not differentiated yet: "
                          "point positions and displacements in the global frame, hinge angles, element section "
                          "forces, cable tensions and lengths, points in a body's frame, energies and momenta and, in "
                          "transient runs, hinge "
                          "rates and torques, guide positions, rates and forces, point velocities and "
                          "controllers' outputs and states "
                          "are")
    # a controller with states or a sampled one reading a rate: δs = D_q δq + D_v δv (ControllerStates._sensed,
    # SampledTerms.sample, _sensor_derivatives with the step end's δv)
    return None


def adjoint_refusal(scene) -> SceneError | None:
    """The SceneError naming ``solve.sensitivity_method`` that refuses the adjoint for ``scene``, or None
    (latdyn/analyses/adjoint_sensitivities.py: through latches, rigid stops, compliant stops' onsets (a hinge's or a
    guide's) and cables, beside laws in t too, with rigid links and guides and geometry parameters (beside them and
    beside controllers too: what the forward method takes, its start's move, ∂r/∂p and probes' moves transposed),
    friction slipping,
    sticking and released (a stick beside what its transpose does not take is refused when the joint sticks:
    ``AdjointSensitivities._refuse_a_stick``), through
    controllers with states and sampled ones, latdyn/analyses/adjoint_controller_states.py; the forward method's
    refusals come first, :func:`refusal`)."""
    key = "solve.sensitivity_method"
    why = None
    if scene.solve.analysis != "transient":
        why = f"the adjoint differentiates transient runs only, not a {scene.solve.analysis} analysis"
    elif scene.solve.adaptive:
        why = "the adjoint differentiates fixed-step runs, not the step sizes of adaptive steps (adaptive: true)"
    if why is None:
        return None
    return SceneError(scene.file, key, f"{why}; expected sensitivity_method: forward (the default) here "
                                       "(docs/parameters.md, \"The discrete adjoint\")")


def _law_in_time(scene):
    """Whether a law of ``scene`` depends on t (a function of the law): a law in θ, θ̇ and t that names t; a
    TimeFunction that is a table of t or an expression naming t, or that names a continuous controller's output
    whose expression names t (:attr:`latdyn.scene.controllers.Controller.output_names_t`), or reads a controller
    that does (a stateless controller in the probes, ``pd: {output: "Kp*(0.3 - angle)"}``, does not)."""
    controllers = getattr(scene, "controllers", None) or {}
    timed_controllers: set = set()
    for c in controllers.values():   # in file order: a controller reads only earlier ones
        if c.output_names_t or c.states_name_t or any(name in timed_controllers for name in c.reads):
            timed_controllers.add(c.name)

    def timed(law):
        if law is None or isinstance(law, (int, float)):
            return False
        depends = getattr(law, "depends_on", None)
        if depends is not None:
            return "t" in (depends() if callable(depends) else depends)
        if getattr(law, "is_constant", True):
            return False
        if not getattr(law, "input_names", ()):   # a table, or an expression whose one free symbol is t:
            return True                          # in t, read without SymPy (0.5 s of a fresh process)
        expressions = getattr(law, "expressions", None)
        if expressions is None:   # a table of t
            return True
        t, (value, _, _) = expressions
        return t in value.free_symbols or any(name in timed_controllers for name in law.input_names)

    return timed


def depends_on_time(scene) -> bool:
    """Whether a load component, hinge or guide law or prescribed motion (a body's, a hinge's, a slide's) of
    ``scene`` depends on t (:func:`_timed_key`)."""
    return _timed_key(scene) is not None


def _transient_refusal(scene) -> str | None:
    """Why ``solve.sensitivities`` of a transient ``scene`` is not exact here, or None
    (latdyn/analyses/transient_sensitivities.py; docs/parameters.md, "Transient sensitivities")."""
    solve = scene.solve
    if solve.method == "explicit":
        return "sensitivities of a transient run are computed for the implicit methods (generalized-alpha, " \
               "hht-alpha, newmark), not for method explicit"
    if solve.adaptive and adaptive_sensitivities.refusal(scene) is not None:   # the step control differentiated
        return adaptive_sensitivities.refusal(scene)
    why = ControllerTerms.refusal(scene)
    if why is not None:
        return why
    jumping = jumping_key(scene, float(solve.t_end))
    if jumping is not None:   # the restart at the jump (latdyn.timeloop.jumps) is not differentiated
        return (f"{jumping} jumps in t, where the run restarts from the new law's accelerations; the sensitivities "
                "do not differentiate that restart yet (a continuous law in t, or a Piecewise that joins, is taken)")
    drive = prescribed_motion_jump_key(scene, float(solve.t_end))
    if drive is not None:   # landed on and restarted (with a kink's impulse), not differentiated
        return (f"{drive[0]}: the prescribed rate or acceleration jumps at t = {drive[1]:.9g}, where the run lands, "
                "applies the jump (a kink's impulse on the free rates) and restarts; the sensitivities do not "
                "differentiate that restart (a law whose rate and acceleration are continuous is taken)")
    return None   # friction: sticking refused, when it comes, where not followed


def _timed_key(scene) -> str | None:
    """The first key of ``scene`` whose law depends on t (:func:`_law_in_time`): a load component, a hinge's or
    guide's law or prescribed angle or slide, a body's prescribed motion; None where none does."""
    timed = _law_in_time(scene)

    for i, load in enumerate(scene.loads):
        if any(timed(c) for c in (load.force or []) + (load.moment or [])):
            return f"loads[{i}]"
    for beam, which, hinge in scene.hinges:
        for key in ("angle", "stiffness", "damping", "torque"):
            law = getattr(hinge, key, None)
            if (key == "angle" and law is not None) or (key != "angle" and timed(law)):
                return f"beams.{beam}.{which}.hinge.{key}"
    for name, body in scene.bodies.items():
        guide = body.guide
        if guide is None:
            continue
        for key in ("position", "stiffness", "damping", "force"):
            law = getattr(guide, key, None)
            if (key == "position" and law is not None) or (key != "position" and timed(law)):
                return f"bodies.{name}.guide.{key}"
    return next((f"bodies.{name}.motion" for name, body in scene.bodies.items() if body.prescribed), None)


def _cable_use(scene, used: str) -> bool:
    """Whether ``used`` is a cable value differentiated in transient runs: EA, damping, rest length and rhoA
    (the lumped mass, rhoA times the rest length at t = 0; not where rhoA is 0: no mass to move)."""
    cable = _CABLE_KEY.match(used)
    return bool(cable) and (cable["value"] != "rhoA" or scene.cables[cable["cable"]].rhoA > 0.0)


def _refuse_without_gravity_tangent(scene, model, kernels) -> None:
    """Refuse (SceneError naming ``solve.sensitivities``) beams with mass under gravity when the scene's
    kernel variant was generated before ``beam_gravity_D_q``: without it the static Newton matrix
    lacks the gravity load's tangent and is not the exact one."""
    from latdyn.assembly.native_model import has_gravity_tangent
    massive = np.any(model.element_sections[:, 5:8] != 0.0) if len(model.element_sections) else False
    if np.any(scene.gravity) and massive and not has_gravity_tangent(kernels):
        raise SceneError(scene.file, "solve.sensitivities",
                         f"sensitivities under gravity on beams with mass need the kernel beam_gravity_D_q, which "
                         f"the generated variant {kernels.variant!r} does not hold yet (python -m codegen --variant "
                         f"{kernels.variant})")


class ParameterDerivatives:
    """What the static and the transient sensitivities share: the named parameters, the laws of
    their derivatives, ∂r/∂p at a state from the generated kernels (:meth:`residual_derivatives`),
    a probe's derivative along a tangent vector (:meth:`probe_row`) and the summary of the rows."""

    def __init__(self, prepared):
        self.scene = prepared.scene
        self.model, self.assembler = prepared.model, prepared.assembler
        self.kernels = self.assembler.kernels
        self.names = list(self.scene.solve.sensitivities)
        self.probes = list(self.scene.output.probes)
        self.columns = [f"{p.name}/{name}" for p in self.probes for name in self.names]
        params = self.scene.parameters
        # the derivative laws, parsed once: key -> {column: HingeLaw in theta, theta_dot, t}, only
        # where the key uses the parameter
        self.derivatives: dict[str, dict[int, object]] = {}
        parsed: dict[str, object] = {}   # one law per derivative text (many parameters' derivatives read alike)
        # held: a derivative law reads the inputs' current values and, a hinge's or guide's law that names a
        # controller (transient runs), its output's at the state: ∂τ/∂p at fixed y, whose δy the step's matrix
        # carries (the coupling ∂τ/∂y ∂y/∂s) and ControllerTerms its explicit part (∂τ/∂y dy/dp)
        outputs = getattr(self.scene, "controller_outputs", None)
        inputs = tuple(self.scene.inputs.names) + (tuple(outputs.names) if outputs is not None else ())
        for column, name in enumerate(self.names):
            for key in params.depending_on(name):
                if _CONTROLLER_KEY.match(key):   # a law in the controller's sensors: ControllerTerms
                    continue
                text = params.derivative(key, name, inputs)
                if text not in parsed:
                    with reading_inputs(self.scene.inputs, outputs):
                        parsed[text] = parse_hinge_law(text, self.scene.file, key)
                self.derivatives.setdefault(key, {})[column] = parsed[text]
        self._values_at: tuple[float, dict] = (float("nan"), {})
        #: the reference configuration's derivative by geometry parameters (None without them)
        self.geometry = ReferenceGeometry(self) if any(map(GEOMETRY_KEY.match, self.derivatives)) else None
        self.controllers = ControllerTerms(self) if self.scene.controllers else None
        #: the derivative laws of θ, θ̇ or an input compiled, whose C both paths of a transient run call
        #: (latdyn/analyses/derivative_laws.py; set by TransientSensitivities), None: their NumPy values
        self.derivative_laws = None
        #: the initial positions of the points whose displacement's norm a probe reads (the rows' δ|u|), the initial
        #: state made only for them (a run's start, 1–3 ms, where no probe reads one)
        norms = [p for p in self.probes if p.kind == "point" and p.quantity == "displacement"
                 and p.component in (None, "norm")]
        initial = self.assembler.initial_state() if norms else None
        self.initial_points = {p.name: initial.x[node] + initial.T[node] @ offset
                               for p in norms for node, offset in [self.model.point(p.point)]}

    # ------------------------------------------------------------------ ∂r/∂p
    def residual_derivatives(self, state, load_factor: float, inertia: bool = False,
                             on_all: bool = False, sections: bool = True,
                             element_gravity: bool = True) -> np.ndarray:
        """∂r/∂p on the free coordinates, one column per parameter (n_dofs, k): of the static residual,
        or with ``inertia`` of the equations of motion r(q, v, v̇, t) at ``state`` (its velocities and
        accelerations); ``on_all``: on all coordinates (n_total + 1, k), before the rigid links' and
        guides' reduction. ``sections`` False leaves the section values' element forces out
        (:meth:`_section_forces`); ``element_gravity`` False (static only) the elements' gravity load −λ ∂Q/∂p
        of the section values and the geometry parameters: the parts whose derivative along the configuration
        is not in the evaluation's K (the elements' gravity tangent sits in the inertia tangent, csrc/evaluate.c;
        an event's (∂K/∂p) w, latdyn/analyses/transient_sensitivities.py ``_stiffness_derivative``)."""
        model, k = self.model, len(self.names)
        total = np.zeros((model.n_total + 1, k))
        for j, which, laws in self._hinge_uses():
            for column, law in laws.items():
                total[model.hinge_dofs[j], column] += self._hinge_force(state, j, which, law, load_factor)
        weight_factor = load_factor if (element_gravity or inertia) else 0.0
        if sections:
            self._section_forces(state, total, weight_factor, inertia)
        self._add_geometry_forces(state, total, load_factor, inertia, weight_factor)
        self._body_forces(state, total, load_factor, inertia)
        add_link_section_forces(self, state, total, load_factor, inertia)
        self._contact_forces(state, total)
        if self.controllers is not None:
            self.controllers.add(state, total)
        self._add_load_forces(state, total, load_factor)
        return total if on_all else self._on_free_coordinates(state, total)

    def _add_geometry_forces(self, state, total: np.ndarray, load_factor: float, inertia: bool,
                             weight_factor: float) -> None:
        """Add ∂r/∂p of the geometry parameters into ``total`` (all coordinates, k columns;
        :meth:`ReferenceGeometry.add`), where there are any."""
        if self.geometry is not None:
            self.geometry.add(state, total, load_factor, inertia, weight_factor)

    def _hinge_uses(self) -> list:
        """(hinge index, which law, {column: derivative law}) of every use of a parameter by a hinge's (or a guide's)
        law, in the order of :attr:`derivatives`; found once per derivatives (not per step: a lattice's 10² uses
        matched every step cost 20 µs)."""
        held = self.__dict__.get("_hinge_uses_found")
        if held is None or held[0] is not self.derivatives:
            uses = []
            for key, laws in self.derivatives.items():
                load, hinge = self._key_kinds(key)
                if hinge and not load:
                    uses.append((self.model.hinge_index(hinge["beam"], hinge["end"]), hinge["law"], laws))
            held = (self.derivatives, uses)
            self._hinge_uses_found = held
        return held[1]

    def _add_load_forces(self, state, total: np.ndarray, load_factor: float) -> None:
        """Add ∂(load)/∂p into ``total`` for the load components that name a parameter
        (:meth:`_load_pair_forces`)."""
        pairs = self._load_pair_forces(state, load_factor)
        if pairs is not None:
            nodes, columns, forces = pairs
            np.add.at(total, (self.model.node_dofs[nodes], columns[:, None]), forces)

    def _load_pair_forces(self, state, load_factor: float):
        """(nodes (m,), parameter columns (m,), generalized forces (m, 6)) of every (load, parameter) pair
        (:meth:`_load_layout`): the point_load kernel, linear in the values, called once for them all with
        λ ∂(the load's six values)/∂p of each pair; None where no load names a parameter."""
        pairs, columns, place, laws = self._load_layout()
        if not len(pairs):
            return None
        distinct, use = self.load_laws_distinct()
        values = np.zeros((len(pairs), 6))
        values[place] = load_factor * np.array([self._of_time(law, state.t) for law in distinct])[use]
        nodes, forces = self._load_forces(state, pairs, values)
        return nodes, columns, forces

    def load_laws_distinct(self) -> tuple:
        """(the load uses' laws as distinct objects, each use's index among them) (:meth:`_load_layout`), made once."""
        if "_load_laws_distinct" not in self.__dict__:
            laws = self._load_layout()[3]
            distinct = list({id(law): law for law in laws}.values())
            order = {id(law): position for position, law in enumerate(distinct)}
            self._load_laws_distinct = (distinct, np.array([order[id(law)] for law in laws], np.int64))
        return self._load_laws_distinct

    def _on_free_coordinates(self, state, total: np.ndarray) -> np.ndarray:
        """``total`` (all coordinates) on the free ones: its first n_dofs rows, or with rigid links and guides
        reduced by the projection Pᵀ (the dependent nodes' rows carried onto the coordinates they move with:
        :func:`reduced_columns`, the compiled step's reduction)."""
        model = self.model
        if model.links is None:
            return total[:model.n_dofs]
        return reduced_columns(self.assembler, state, total)

    def _section_forces(self, state, total: np.ndarray, load_factor: float, inertia: bool = False) -> None:
        """Add ∂(element internal force − λ gravity load)/∂p into ``total`` for the section values that
        name a parameter (with ``inertia``: ∂(internal force + M a + g − gravity load)/∂p, as evaluate.c sums
        them): :meth:`_section_element_forces` scattered onto the elements' coordinates, in one native call
        where the kernels are the C backend's (:meth:`_native_section_forces`), else from Python."""
        if self._native_section_forces(state, total, load_factor, inertia):
            return
        forces = self._section_element_forces(state, load_factor, inertia)
        if forces is not None:
            elements, column, by_element = forces
            np.add.at(total, (self.model.element_dofs[elements], column[:, None]), by_element)

    def _section_element_forces(self, state, load_factor: float, inertia: bool = False):
        """(elements (m,), parameter columns (m,), forces (m, 14)) of :meth:`_section_forces` before their
        scatter: each use's element's ∂(force)/∂p on the element's coordinates (``model.element_dofs``); None
        where no parameter is a section's. The generated derivatives by the section values
        (``beam_internal_force_D_section``, ``beam_inertia_force_D_section``: forward mode of the lowered
        forces, exact for every formulation and for shear-flexible sections, whose factors μ = 1/(1 + Φ) make
        the element nonlinear in EI and 1/GA), each element's once, contracted with the use's ∂(section block)/∂p
        (:meth:`_section_derivative_blocks`); the inertia force at rest (static: its −λ Q alone) where gravity
        is on or with ``inertia``."""
        blocks = self._section_derivative_blocks(state)
        if blocks is None:
            return None
        elements, column, rows = blocks
        model = self.model
        on, use = self._section_elements_once()   # each element's derivatives once
        geometry, rates, accelerations = self.assembler.native().element_inputs(state)
        at, sections = np.ascontiguousarray(geometry[on]), np.ascontiguousarray(model.element_sections[on])
        by_section = np.asarray(self.kernels.beam_internal_force_D_section(at, sections)[1]).reshape(len(on), 14, 9)
        gravity = load_factor * np.asarray(self.assembler.gravity, float)
        if inertia or np.any(gravity):
            if not inertia:   # the static residual F − λ Q: the inertia force M a + g − Q at rest
                rates, accelerations = np.zeros_like(rates), np.zeros_like(accelerations)
            by_section = by_section + np.asarray(self.kernels.beam_inertia_force_D_section(
                at, np.ascontiguousarray(rates[on]), np.ascontiguousarray(accelerations[on]), sections,
                np.ascontiguousarray(np.repeat(gravity[None], len(on), axis=0)))[1]).reshape(len(on), 14, 9)
        return elements, column, np.einsum("epd,ed->ep", by_section[use], rows[:, 1:])

    def _native_section_forces(self, state, total: np.ndarray, load_factor: float, inertia: bool) -> bool:
        """:meth:`_section_forces` in one native call (``NativeModel.section_parameter_forces``,
        csrc/parameter_forces.c: the element inputs, the same generated kernels by the section values, the
        contraction with each use's ∂s/∂p and the scatter); False where it cannot serve (kernels without C libraries,
        ``total`` not C-contiguous float64, section rows not the kernels' ten columns), and the caller takes the
        Python path; True with nothing added where no parameter is a section value's. Its
        contractions sum their nine products in the section values' order, where NumPy's einsum sums them in
        SIMD lanes: the two agree to round-off (to the bit on every scene measured, docs/performance.md)."""
        blocks = self._section_derivative_blocks(state)
        if blocks is None:
            return True
        kernels = self._section_kernel_addresses()
        elements, column, rows = blocks
        if (kernels is None or total.dtype != np.float64 or not total.flags.c_contiguous
                or rows.shape[1] != 10):   # the kernels' section rows: L0 and the nine values (csrc/parameter_forces.c)
            return False
        on, use = self._section_elements_once()
        gravity = load_factor * np.asarray(self.assembler.gravity, float)
        with_kernel = inertia or bool(np.any(gravity))
        uses = tuple(np.ascontiguousarray(a, np.int64) for a in (on, use, elements, column))
        self.assembler.native().section_parameter_forces(
            state, (kernels[0], kernels[1] if with_kernel else None), inertia,
            np.ascontiguousarray(gravity) if with_kernel else None, (*uses, np.ascontiguousarray(rows, np.float64)),
            total)
        return True

    def _section_kernel_addresses(self):
        """The addresses of the C kernels ``beam_internal_force_D_section`` and ``beam_inertia_force_D_section``,
        found once; None where the kernels have no C libraries (the NumPy backend)."""
        if "_section_kernels_found" not in self.__dict__:
            found = tuple(self.kernels.address(name)
                          for name in ("beam_internal_force_D_section", "beam_inertia_force_D_section"))
            self._section_kernels_found = None if None in found else found
        return self._section_kernels_found

    def _section_elements_once(self) -> tuple:
        """(the distinct elements of the section uses, each use's index among them): ``np.unique`` of the layout's
        elements (:meth:`_section_layout`, made once), taken once."""
        if "_section_elements_distinct" not in self.__dict__:
            self._section_elements_distinct = np.unique(self._section_layout()[0], return_inverse=True)
        return self._section_elements_distinct

    def add_section_stiffness_along(self, state, full: np.ndarray, total: np.ndarray) -> None:
        """Add the elements' (∂K/∂p) v into ``total`` (n_total + 1, k) for the section values that name a parameter,
        v = ``full`` on all coordinates (n_total + 1): the generated ``beam_stiffness_D_section`` ((∂F_i/∂q) v by the
        section values, exact for every section, shear-flexible ones too) of each element once, contracted with each
        use's ∂s/∂p (:meth:`_section_derivative_blocks`); nothing without such a parameter. The arc length's first
        step (:meth:`ArcLengthSensitivities.stiffness_derivative_along`) and an event's impulse weight
        (latdyn/analyses/transient_sensitivities.py ``_weight_derivative``)."""
        blocks = self._section_derivative_blocks(state)
        if blocks is None:
            return
        model = self.model
        elements, column, rows = blocks
        on, use = self._section_elements_once()
        geometry, _, _ = self.assembler.native().element_inputs(state)
        by_section = np.asarray(self.kernels.beam_stiffness_D_section(
            np.ascontiguousarray(geometry[on]), np.ascontiguousarray(full[model.element_dofs[on]]),
            np.ascontiguousarray(model.element_sections[on]))[1]).reshape(len(on), 14, 9)
        np.add.at(total, (model.element_dofs[elements], column[:, None]),
                  np.einsum("epd,ed->ep", by_section[use], rows[:, 1:]))

    def _section_derivative_blocks(self, state):
        """(elements (m,), parameter columns (m,), section rows (m, 10)): for every use of a parameter
        by a section value, that section's elements with the section block replaced by the value's
        derivative (L0 kept, the rest 0; GAy, GAz as their compliances' −(1/GA)² ∂GA/∂p; the planar model's
        quarter turns applied as latdyn.model.planar.restrict_to_plane applies them); None where no parameter
        is a section's. The rows' layout is made once (:meth:`_section_layout`); per call only the laws' values.
        The element forces, section forces, energies and the arc length's ∂K/∂p v contract them with the
        generated derivatives by the section values (:meth:`_section_element_forces`)."""
        layout = self._section_layout()
        if layout is None:
            return None
        elements, columns, rows, slot, laws = layout
        rows = rows.copy()
        rows[np.arange(len(rows)), slot] = self._section_values(laws, state.t)
        return elements, columns, rows

    def _section_values(self, laws: list, t: float) -> np.ndarray:
        """Each section use's derivative value at ``t`` on its elements (scaled as :meth:`_section_layout` says);
        where every law is a constant (reads neither t nor an input), made once, else per call."""
        held = self.__dict__.get("_section_values_held")
        if held is not None:
            return held
        values = np.array([self._of_time(law, t) for law in laws])[self._section_use] * self._section_scale
        if all(law.is_constant for law in laws):
            self._section_values_held = values
        return values

    def _section_layout(self):
        """The layout of :meth:`_section_derivative_blocks`, made once: (elements, columns, rows with L0,
        the column of each row's derivative value (after the quarter turns), the laws of the uses)."""
        if "_section_layout_made" in self.__dict__:
            return self._section_layout_made
        model = self.model
        chosen, columns, slots, laws = [], [], [], []   # per use: its elements, column, value's slot, law
        for key, by_column in self.derivatives.items():
            section = _SECTION_KEY.match(key)
            if not section:
                continue
            elements = self._section_elements(section["section"])
            if len(elements) == 0:
                continue
            for column, law in by_column.items():
                chosen.append(elements)
                columns.append(column)
                slots.append(_SECTION_COLUMN[section["value"]])
                laws.append(law)
        if not chosen:
            self._section_layout_made = None
            return None
        counts = np.array([len(elements) for elements in chosen], np.int64)   # the uses spread on their elements
        elements = np.concatenate(chosen)
        slot = np.repeat(np.array(slots, np.int64), counts)
        if model.plane is not None:   # latdyn.model.planar.restrict_to_plane: a quarter turn swaps y, z
            quarter = np.abs(np.sin(model.section_turns[elements])) > 0.5
            swap = np.arange(model.element_sections.shape[1])
            swap[[2, 3, 6, 7, 8, 9]] = [3, 2, 7, 6, 9, 8]
            slot = np.where(quarter, swap[slot], slot)
        rows = np.zeros((len(elements), model.element_sections.shape[1]))
        rows[:, 0] = model.element_sections[elements, 0]                       # L0
        # a compliance c = 1/GA moves by −c² δGA; the other values by their own derivative
        compliance = model.element_sections[elements, slot]
        self._section_scale = np.where(slot >= 8, -compliance * compliance, 1.0)
        self._section_use = np.repeat(np.arange(len(laws), dtype=np.int64), counts)
        self._section_layout_made = (elements, np.repeat(np.array(columns, np.int64), counts), rows, slot, laws)
        return self._section_layout_made

    def _of_time(self, law, t: float) -> float:
        """``law.value(0, 0, t)`` (a derivative law of a load or a section value, in t alone), each law once
        at a time t (the laws of one text are one object: ``__init__``)."""
        at, values = self._values_at
        if at != t:
            values = {}
            self._values_at = (t, values)
        key = id(law)
        if key not in values:
            values[key] = law.value(0.0, 0.0, t)
        return values[key]

    def _section_elements(self, name: str) -> np.ndarray:
        """The elements of the beams of section ``name`` (every section's found in one pass over the
        elements: one pass per section cost 0.7 s at a lattice's 10³ sections)."""
        if "_elements_of_section" not in self.__dict__:
            found: dict[str, list] = {}
            for e, beam in enumerate(self.model.element_beam):
                found.setdefault(self.scene.beams[beam].section.name, []).append(e)
            self._elements_of_section = {section: np.array(elements, dtype=np.int64)
                                         for section, elements in found.items()}
        return self._elements_of_section.get(name, np.zeros(0, dtype=np.int64))

    def _body_forces(self, state, total: np.ndarray, load_factor: float, inertia: bool = False) -> None:
        """Add ∂(joint body force)/∂p into ``total`` for body masses, centres of mass and inertias that
        name a parameter, from the generated ``joint_body`` (codegen/joints.py ``joint_body_terms``).
        Static (at rest) it is λ-gravity alone; with ``inertia`` the Newton–Euler forces at the node's
        ω, a, α. It is linear in (m, I) at a fixed centre of mass c — the kernel with (∂m/∂p, c, ∂I/∂p)
        —, and by c the generated ``joint_body_D_com`` (∂f/∂c, 6 × 3) along ∂c/∂p."""
        model, gravity = self.model, load_factor * np.asarray(self.assembler.gravity, float)
        if not np.any(gravity) and not inertia:
            return
        for body, laws in self._body_uses():
            if body["inertia"] and not inertia:
                continue
            node = model.body_node[body["body"]]
            found = np.flatnonzero(model.body_nodes == node)
            if not len(found):
                if body["com"] is not None:   # a body without mass or inertia: its centre of mass moves no force
                    continue
                raise SceneError(self.scene.file, "solve.sensitivities",
                                 f"bodies.{body['body']} has neither mass nor inertia at the parameters' values, so "
                                 "a parameter of its mass or inertia adds the body's first inertia, which is not "
                                 "differentiated; expected a body with mass or inertia (docs/parameters.md)")
            b = int(found[0])
            frame = np.ascontiguousarray(state.T[node].reshape(1, 9))
            motion = np.zeros((1, 9))
            if inertia:
                motion[0] = np.concatenate([state.w[node], state.a[node], state.alpha[node]])

            def force_of(block):
                return np.asarray(self.kernels.joint_body(frame, motion, block, gravity[None])[0]).reshape(6)

            for column, law in laws.items():
                block, along = self.body_block(body, b, law.value(0.0, 0.0, state.t))
                if along is None:
                    force = force_of(block)
                else:                   # ∂f/∂c along ∂c/∂p
                    force = np.asarray(self.kernels.joint_body_D_com(frame, motion, block, gravity[None])[0]
                                       ).reshape(6, 3) @ along
                total[model.node_dofs[node], column] += force

    def body_block(self, body, b: int, value: float) -> tuple:
        """(the joint_body kernel's block (1, 13), None) of a use ``body`` (a body key's match) of joint body ``b``
        whose mass or inertia moves by ``value`` — the kernel is linear in (m, I) at a fixed centre of mass c:
        (∂m/∂p, c, ∂I/∂p) —, or (the body's own block, ∂c/∂p (3,)) of a use by its centre of mass, whose force is
        joint_body_D_com's ∂f/∂c along it (:meth:`_body_forces`; the loop of steps in C tabulates the same,
        latdyn/analyses/sensitivities_in_loop.py)."""
        model, block = self.model, np.zeros((1, 13))
        if body["mass"]:
            block[0, 0], block[0, 1:4] = value, model.body_com[b]
            return block, None
        if body["inertia"]:   # inertia[i] (the diagonal) or inertia[i][j] (symmetrised)
            i, j = body["row"], body["col"] if body["col"] is not None else body["row"]
            step = np.zeros((3, 3))
            step[int(i), int(j)] += 0.5 * value
            step[int(j), int(i)] += 0.5 * value
            block[0, 1:4], block[0, 4:13] = model.body_com[b], step.reshape(9)
            return block, None
        block[0, 0], block[0, 1:4] = model.body_mass[b], model.body_com[b]
        block[0, 4:13] = model.body_inertia[b].reshape(9)
        along = np.zeros(3)
        along[int(body["com"])] = value
        return block, along

    def _body_uses(self) -> list:
        """(the body key's match, {column: derivative law}) of every use of a parameter by a joint body's mass,
        centre of mass or inertia, in the order of :attr:`derivatives`; matched once per derivatives."""
        held = self.__dict__.get("_body_uses_found")
        if held is None or held[0] is not self.derivatives:
            held = (self.derivatives, [(body, laws) for key, laws in self.derivatives.items()
                                       for body in [_BODY_KEY.match(key)] if body])
            self._body_uses_found = held
        return held[1]

    def _contact_forces(self, state, total: np.ndarray) -> None:
        """Add ∂f/∂p of the hinges and guides whose compliant stops' stiffness, exponent or damping or whose
        friction's coulomb, static, stribeck_rate, viscous or stick_rate name a parameter into ``total``: the
        generated ``contact_force_D_law`` (∂f_contact/∂(k, n, c) at the joint's θ, θ̇; zero outside contact)
        or ``friction_force_D_law`` (∂f_friction/∂(F_c, F_s, 1/v_s, c_v, v₀) of the slipping law; a stuck
        joint's coordinate is no free one) times the law's derivative by the parameter."""
        model = self.model
        for law, laws in self.joint_law_uses():
            beam, end, kind, slot = law
            j = model.hinge_index(beam, end)
            row = self.contact_row(j)
            at = np.array([[float(state.theta[j]), float(state.theta_dot[j]), model.hinges[j].rest_angle, 1.0]])
            kernel = self.kernels.contact_force_D_law if kind == "contact" else self.kernels.friction_force_D_law
            slope = float(np.asarray(kernel(at, row)[0]).reshape(-1)[slot])
            if kind == "friction" and slot == FRICTION_SLOT["stribeck_rate"]:   # −(1/v_s)² ∂f/∂(1/v_s)
                slope *= -row[0, 7] ** 2
            for column, derivative in laws.items():
                total[model.hinge_dofs[j], column] += derivative.value(0.0, 0.0, state.t) * slope

    def joint_law_uses(self) -> list:
        """((beam, end, "contact" or "friction", slot), {column: derivative law}) of every use of a parameter by a
        joint's compliant stop or friction (:func:`joint_law`), in the order of :attr:`derivatives`; parsed once per
        derivatives (:meth:`_contact_forces`; the loop of steps in C lays them out alike)."""
        held = self.__dict__.get("_joint_laws")
        if held is None or held[0] is not self.derivatives:
            held = (self.derivatives, [(joint_law(key), laws) for key, laws in self.derivatives.items()
                                       if joint_law(key) is not None])
            self._joint_laws = held
        return held[1]

    def contact_row(self, j: int) -> np.ndarray:
        """Joint ``j``'s contact row (1, 11) as the kernels read it (:func:`joint_contact_rows`), made once."""
        rows = self.__dict__.setdefault("_contact_rows", {})
        if j not in rows:
            rows[j] = np.ascontiguousarray(joint_contact_rows([self.model.hinges[j]]))
        return rows[j]

    def _key_kinds(self, key: str):
        """(the load key's match, the hinge key's match) of a parameter's use, matched once."""
        cache = self.__dict__.setdefault("_kinds", {})
        if key not in cache:
            guide = _GUIDE_KEY.match(key)   # a guide's laws are a hinge's, on its slide (latdyn/model/model.py)
            cache[key] = (_LOAD_KEY.match(key), _HINGE_KEY.match(key) or guide and {
                "beam": guide["body"], "end": "guide", "law": _GUIDE_LAW.get(guide["law"], guide["law"])})
        return cache[key]

    def _load_layout(self):
        """The loads' parameter uses, laid out once: (the load of each (load, column) pair (m,), its column
        (m,), the (pair, slot) of each use, the uses' laws), pairs in the order of their first use."""
        if "_load_layout_made" not in self.__dict__:
            pair_of: dict[tuple[int, int], int] = {}
            rows, slots, laws = [], [], []
            for key, by_column in self.derivatives.items():
                load, _ = self._key_kinds(key)
                if not load:
                    continue
                for column, law in by_column.items():
                    rows.append(pair_of.setdefault((int(load["load"]), column), len(pair_of)))
                    slots.append(int(load["axis"]) + (3 if load["kind"] == "moment" else 0))
                    laws.append(law)
            pairs = np.array([index for index, _ in pair_of], np.int64)
            columns = np.array([column for _, column in pair_of], np.int64)
            self._load_layout_made = (pairs, columns, (np.array(rows, np.int64), np.array(slots, np.int64)), laws)
        return self._load_layout_made

    def _load_forces(self, state, indices, values: np.ndarray):
        """(nodes (m,), generalized forces (m, 6)) of loads ``indices`` with these values (m, 6): one call of
        the point_load kernel for them all."""
        node, offset, frame = self._load_points()
        indices = np.asarray(indices, np.int64)
        nodes = node[indices]
        frames = np.where((frame[indices] >= 0)[:, None, None], state.T[np.maximum(frame[indices], 0)], np.eye(3))
        rows = lambda a: np.ascontiguousarray(np.reshape(a, (len(indices), -1)), dtype=float)  # noqa: E731
        velocity = np.concatenate([state.v[nodes], state.w[nodes]], axis=1)
        force = self.kernels.point_load(rows(state.T[nodes]), rows(offset[indices]), rows(values),
                                        rows(frames), rows(velocity))[0]
        return nodes, np.asarray(force).reshape(len(indices), 6)

    def _load_points(self):
        """(node (loads,), offset (loads, 3), the node of its frame body or −1 for global (loads,)) of every
        scene load (found once)."""
        if "_load_points_made" not in self.__dict__:
            model, loads = self.model, self.scene.loads
            points = [model.point(load.at) for load in loads]
            self._load_points_made = (
                np.array([node for node, _ in points], np.int64).reshape(-1),
                np.array([offset for _, offset in points], float).reshape(-1, 3),
                np.array([model.body_node[load.frame] if load.frame != "global" else -1 for load in loads],
                         np.int64).reshape(-1))
        return self._load_points_made

    def _hinge_force(self, state, j: int, which: str, law, load_factor: float) -> float:
        """∂f/∂p of hinge ``j`` through its ``which`` law (the hinge_force kernel, linear in the laws;
        its compliant stops and friction depend on no law, so they are left out: ``NO_CONTACT``)."""
        contact = NO_CONTACT[None]
        hinge = self.model.hinges[j]
        theta, rate, t = float(state.theta[j]), float(state.theta_dot[j]), state.t
        laws = np.zeros((1, 9))
        compiled = self.derivative_laws   # the laws of the state compiled (latdyn/analyses/derivative_laws.py)
        value = (lambda f: f.value(theta, rate, t)) if compiled is None else (lambda f: compiled.value(f, theta, rate, t))
        derivative = value(law)
        if which == "rest_angle":   # f = k (θ − θ_r) + …: affine in θ_r
            laws[0, 0] = value(hinge.stiffness)
            unit_rest = np.array([[0.0, 0.0, 1.0, load_factor]])
            return derivative * float(np.asarray(self.kernels.hinge_force(unit_rest, laws, contact)[0]).reshape(-1)[0])
        laws[0, {"stiffness": 0, "damping": 3, "torque": 6}[which]] = derivative
        at = np.array([[theta, rate, hinge.rest_angle, load_factor]])
        return float(np.asarray(self.kernels.hinge_force(at, laws, contact)[0]).reshape(-1)[0])

    def _at_extremes(self, table: dict, series: dict) -> dict:
        """``probe_sensitivities``: for each recorded series (name → values over the rows) the
        derivatives of ``table`` at its last row and at the rows of its largest and smallest value
        (the first where several tie); an empty series is left out."""
        out = {}
        for name_of, values in series.items():
            values = np.asarray(values)
            if len(values) == 0:
                continue
            last, high, low = len(values) - 1, int(np.argmax(values)), int(np.argmin(values))
            out[name_of] = {which: {name: float(table[(name_of, name)][row]) for name in self.names}
                            for which, row in (("end", last), ("max", high), ("min", low))}
        return out

    def _by_parameter(self, tangent: np.ndarray, state):
        """(δx, δπ, δθ) of every node and hinge, (n_nodes, 3, k) (n_nodes, 3, k) (n_hinges, k), from the
        free-coordinate sensitivities ``tangent`` (n_dofs, k), one column a parameter (the update's
        coordinates: :func:`latdyn.assembly.assembler.unpack_free`, a column at a time); the dependent
        nodes of a model with guides moved by the reduction at ``state`` (:meth:`_dependent_motion`)."""
        dx, dpi, dtheta = self._on_free_nodes_and_hinges(tangent)
        if self.model.n_dofs and tangent.shape[1] and self.model.links is not None:
            self._dependent_motion(state, tangent, dx, dpi)
        return dx, dpi, dtheta

    def _on_free_nodes_and_hinges(self, columns: np.ndarray) -> tuple:
        """``columns`` (n_dofs, k) on the free nodes' six slots and the free hinges, as (n_nodes, 3, k),
        (n_nodes, 3, k), (n_hinges, k); zero elsewhere."""
        model, k = self.model, columns.shape[1]
        n_nodes = model.node_dofs.shape[0]
        linear, angular = np.zeros((n_nodes, 3, k)), np.zeros((n_nodes, 3, k))
        joint = np.zeros((len(model.hinges), k))
        if model.n_dofs and k:
            full = np.vstack([columns, np.zeros((model.n_total + 1 - model.n_dofs, k))])
            free, hinges = model.free_nodes, model.free_hinges
            linear[free], angular[free] = full[model.node_dofs[free, 0:3]], full[model.node_dofs[free, 3:6]]
            joint[hinges] = full[model.hinge_dofs[hinges]]
        return linear, angular, joint

    def _dependent_motion(self, state, dq: np.ndarray, dx: np.ndarray, dpi: np.ndarray) -> None:
        """(δx, δπ) of the dependent nodes (guided bodies) into ``dx``, ``dpi``: P δq on their rows (the
        projection of latdyn/assembly/linked.py, J of the generated edge kernels)."""
        from latdyn.analyses.link_sensitivities import held_linked_parts

        model = self.model
        P = held_linked_parts(self, state, rates=False)[0]
        full = np.asarray(P @ dq)
        for node in model.links.dependent:
            dofs = model.node_dofs[node]
            dx[node], dpi[node] = full[dofs[0:3]], full[dofs[3:6]]

    def _rates_by_parameter(self, dv: np.ndarray, dq: np.ndarray | None = None, state=None) -> tuple:
        """(δv, δω, δθ̇) of every node and hinge from the free-coordinate sensitivities of the rates ``dv``
        (n_dofs, k) — the transient step's carried δv: the rates are vectors (ω spatial), so δω is the
        derivative of ω's components. Free nodes and hinges; with ``dq`` and ``state`` the nodes that follow
        rigid links or guides too, P δv + ∂(J v)/∂q δq (:func:`latdyn.analyses.link_sensitivities.dependent_rates`:
        a guided body's with the generated ``prismatic_link_edge_rates_D_q``)."""
        rates = self._on_free_nodes_and_hinges(dv)
        if self.model.links is not None and dq is not None and dv.shape[1]:
            dependent_rates(self, state, dq, dv, rates[0], rates[1])
        return rates

    def _probe_derivatives(self, probe, state, dx, dpi, dtheta, rates=None, explicit: bool = True) -> list:
        """The derivatives of ``probe`` at ``state`` by every parameter along (δx, δπ, δθ) of
        :meth:`_by_parameter` (and, for rate probes, (δv, δω, δθ̇) of :meth:`_rates_by_parameter`): a
        point x + T r moves by δx + δπ × T r, a hinge angle by δθ, a hinge rate by δθ̇, a point's velocity
        v + ω × T r by δv + δω × T r + ω × (δπ × T r). ``explicit`` (the columns are the parameters'): with
        a point's moves by geometry parameters at a fixed state (its offset, a held node, a displacement's
        start: :meth:`ReferenceGeometry.point_moves`); off for columns that are not the parameters' (the
        discrete adjoint's unit columns, latdyn/analyses/adjoint_sensitivities.py ``output_forms``)."""
        model = self.model
        if is_probe_here(probe):   # section forces, cables, points in a body frame
            return probe_derivatives(self, probe, state, dx, dpi, dtheta, rates)
        if controller_probes.is_controller_probe(probe):   # latdyn/analyses/controller_probe_sensitivities.py
            return controller_probes.probe_derivatives(self, probe, state, dx, dpi, dtheta, rates)
        if is_energy_or_momentum(probe):   # latdyn/analyses/energy_sensitivities.py
            return energy_probe_derivatives(self, probe, state, dx, dpi, dtheta, rates, _BODY_KEY)
        if probe.kind in ("hinge", "guide"):
            joint = (probe.beam, probe.end) if probe.kind == "hinge" else (probe.body, "guide")
            which = rates[2] if probe.quantity == "rate" else dtheta
            return [float(v) for v in which[model.hinge_index(*joint)]]
        node, offset = model.point(probe.point)
        arm = state.T[node] @ offset
        moved = point_moved(dx[node], dpi[node], arm)    # δ(x + T r), (3, k)
        if explicit and self.geometry is not None:   # a geometry parameter moves the point's offset and its reference
            offset_moved, reference_moved = self.geometry.point_moves(probe, state)
            moved = moved + offset_moved - (reference_moved if probe.quantity == "displacement" else 0.0)
        if probe.quantity == "velocity":   # δ(v + ω × T r): the arm's move, not the node's (nor a held root's δX)
            dvel, domega, _ = rates
            held, carried = self.geometry.velocity_moves(state, node) if explicit and self.geometry is not None \
                else (0.0, None)
            moved = dvel[node] + np.cross(domega[node], arm, axisa=0, axisc=0) \
                + np.cross(state.w[node], moved - dx[node] - held, axisb=0, axisc=0)
            if carried is not None:   # a shift on a part that turns moves the node's velocity (ReferenceGeometry)
                moved = moved + carried
        if probe.component in (None, "norm"):
            value = state.x[node] + arm
            if probe.quantity == "displacement":
                value = value - self.initial_points[probe.name]
            elif probe.quantity == "velocity":
                value = state.v[node] + np.cross(state.w[node], arm)
            size = float(np.linalg.norm(value))
            if size > 0:
                return [float(v) for v in value @ moved / size]
            # |·| at 0: differentiable only along 0
            return [0.0 if not np.any(moved[:, c]) else float("nan") for c in range(moved.shape[1])]
        return [float(v) for v in moved["xyz".index(probe.component)]]


class StaticSensitivities(ParameterDerivatives):
    """The sensitivities of the recorded rows of a static path: :meth:`record` at each row; then
    :meth:`table` (``Result.sensitivities``), :meth:`summary` (``probe_sensitivities``) and
    :meth:`write` (``sensitivities.csv``), called by latdyn/analyses/continuation.py."""

    def __init__(self, prepared):
        super().__init__(prepared)
        _refuse_without_gravity_tangent(self.scene, self.model, self.kernels)
        self.rows: list[tuple[float, list[float]]] = []
        #: δλ/δp per row and parameter: zero under load control (λ is the grid's), moving under
        #: displacement control and arc length
        self.load_factor_rows: list[list[float]] = []
        self.controlled = self.scene.solve.method in ("displacement-control", "arc-length")

    # ------------------------------------------------------------------ rows
    def record(self, state, load_factor: float, constraint_gradient=None) -> None:
        """The sensitivities of every probe at this recorded row. Load control: δq = −K⁻¹ ∂r/∂p.
        Displacement control (``constraint_gradient``: the controlled displacement's gradient g, its
        target fixed): the load factor moves too, r(q, λ) = 0 and g·δq = 0 give
        δq = δq_r + δλ δq_λ with δq_r = −K⁻¹ ∂r/∂p, δq_λ = K⁻¹ q_ref (∂r/∂λ = −q_ref) and
        δλ = −g·δq_r / g·δq_λ."""
        model, k = self.model, len(self.names)
        if load_factor == 0.0 or model.n_dofs == 0:   # the initial configuration: moved by geometry parameters only
            if self.geometry is not None:
                self._append_row(state, load_factor, self.geometry.initial_tangent(), np.zeros(k))
                return
            # positions and angles do not move; energies may, explicitly (latdyn/analyses/energy_sensitivities.py)
            self._append_row(state, load_factor, np.zeros((model.n_dofs, k)), np.zeros(k))
            return
        ev = self.assembler.evaluate(state, matrices=True, load_factor=load_factor, inertia=False)
        rhs = -self.residual_derivatives(state, load_factor)
        if constraint_gradient is not None:   # the residual is affine in λ: q_ref = r(λ) − r(λ + 1)
            shifted = self.assembler.evaluate(state, matrices=False, load_factor=load_factor + 1.0, inertia=False)
            rhs = np.column_stack([rhs, ev.residual - shifted.residual])
        solved = self._solve(ev.stiffness, rhs, load_factor)
        tangent, moved = solved[:, :k], np.zeros(k)
        if constraint_gradient is not None:
            g, along_load = constraint_gradient(state), solved[:, k]
            held = g @ tangent
            if self.geometry is not None:   # the controlled displacement's start and offset move too
                held = held + self.geometry.control_moves(state)
            moved = -held / float(g @ along_load)          # δλ
            tangent = tangent + np.outer(along_load, moved)
        self._append_row(state, load_factor, tangent, moved)

    def _solve(self, stiffness, rhs, load_factor):
        """K⁻¹ rhs (n, columns); a singular K refused (SolverError)."""
        try:
            return np.asarray(solve_linear(stiffness, rhs)).reshape(self.model.n_dofs, -1)
        except np.linalg.LinAlgError:
            raise SolverError(f"the sensitivities at load factor {load_factor:.6g} need the static stiffness, "
                              "which is singular there (a limit or bifurcation point)") from None

    def _append_row(self, state, load_factor, tangent: np.ndarray, moved) -> None:
        """The row at ``state``: the load factor's sensitivities ``moved`` and the probes' along ``tangent``."""
        self.load_factor_rows.append([float(x) for x in moved])
        moved_by = self._by_parameter(tangent, state)
        self.rows.append((load_factor, [value for p in self.probes
                                        for value in self._probe_derivatives(p, state, *moved_by)]))

    # ------------------------------------------------------------------ results
    def table(self) -> dict:
        """``{(probe, name): array over the rows}``; under displacement control and arc length also
        ``("load_factor", name)``, the load factor's own sensitivity."""
        data = np.array([values for _, values in self.rows]).reshape(len(self.rows), len(self.columns))
        out = {(p.name, name): data[:, i * len(self.names) + c]
               for i, p in enumerate(self.probes) for c, name in enumerate(self.names)}
        if self.controlled:
            moved = np.array(self.load_factor_rows).reshape(len(self.rows), len(self.names))
            out.update({("load_factor", name): moved[:, c] for c, name in enumerate(self.names)})
        return out

    def summary(self, probe_values: dict, load_factors=None) -> dict:
        """``probe_sensitivities``: each probe's derivative at the last row, and at the rows of its
        largest and smallest value (the first where several tie); with ``load_factors`` (displacement
        control, arc length) the same for the load factor, under the name ``load_factor``."""
        series = {p.name: probe_values[p.name] for p in self.probes}
        if load_factors is not None and self.controlled:
            series["load_factor"] = load_factors
        return self._at_extremes(self.table(), series)

    def write(self, folder) -> None:
        """``sensitivities.csv``: ``load_factor,<probe>/<NAME>,…``, one row per recorded row; under displacement
        control and arc length then ``load_factor/<NAME>,…``, the load factor's own (what :meth:`table` gives
        as ``("load_factor", NAME)``, and ``Result.load`` reads back)."""
        from latdyn.results.files import atomic_write_bytes, csv_line

        header = ["load_factor", *self.columns]
        moved = [[] for _ in self.rows]
        if self.controlled:
            header += [f"load_factor/{name}" for name in self.names]
            moved = self.load_factor_rows
        text = csv_line(header) + "".join(csv_line([lam, *values, *extra])
                                          for (lam, values), extra in zip(self.rows, moved))
        atomic_write_bytes(Path(folder) / SENSITIVITIES_FILE, text.encode("utf-8"))


@dataclass
class ArcStep:
    """What an arc-length step hands its row's sensitivities (latdyn/analyses/continuation.py
    ``arc_length``): the step's increment Δq from the row before (the tangent-space difference of its
    ends, :meth:`latdyn.analyses.continuation.Path.compose`; ‖Δq‖_W = Δs), its arc length Δs and the first step's Δs₀ (every Δs is Δs₀ times
    factors the path chose: halvings and the adaptation to the Newton iterations), and whether its
    end was solved at λ = 1 exactly (the last row)."""
    increment: np.ndarray
    length: float
    first: float
    at_full_load: bool = False


class ArcLengthSensitivities(StaticSensitivities):
    """The sensitivities of an arc-length path (docs/parameters.md, "Arc length"): each row's point
    (q_{n+1}, λ_{n+1}) solves r(q, λ; p) = 0 and ‖q ⊖ q_n‖_W = Δs_n from the row before, so it depends
    on p through the residual, through the row before and through Δs_n = c_n Δs₀(p). Differentiated,
    with D = q_{n+1} ⊖ q_n (the step's increment) and the bordered matrix that stays regular at a limit
    point (where K alone is singular):

        [ K      −q_ref ] [δq_{n+1}]   [ −∂r/∂p                     ]
        [ DᵀW     0     ] [δλ_{n+1}] = [ DᵀW δq_n + Δs_n δΔs_n       ],   δΔs_n = (Δs_n/Δs₀) δΔs₀,

    δΔs₀ from Δs₀ = ‖K₀⁻¹q_ref‖_W / steps at the start: δ(K₀⁻¹q_ref) = K₀⁻¹(δq_ref − δK₀ K₀⁻¹q_ref), δK₀
    from the generated kernels (the element tangent's derivative by the section values along v,
    ``beam_stiffness_D_section``; ``hinge_force``'s ∂f/∂θ with the laws replaced by their derivatives). The last
    row, solved at λ = 1, is load control's: δq = −K⁻¹∂r/∂p, δλ = 0. The limit points the rows pass are located
    on the path (:meth:`limit_points`) and the limit load's derivative taken there.

    The row DᵀW needs no transport between the rows' tangent spaces: a node's rotation part of D is the
    rotation vector d of T_{n+1} T_nᵀ = exp(skew d), whose variation is δd = dexp(d)⁻¹(δπ_{n+1} −
    exp(skew d) δπ_n); W weighs a node's three rotations alike, and dᵀ dexp(d)⁻¹ = dᵀ exp(skew d) = dᵀ
    (both fix their axis d), so dᵀ δd = dᵀ(δπ_{n+1} − δπ_n) exactly, however far the node turns in a
    step. That holds because the path's D is that difference of the ends, its rotations composed
    (:meth:`latdyn.analyses.continuation.Path.compose`), in every 3D arc-length run: the sum of the
    increments differs from it by their commutators, and a run that summed them (without sensitivities,
    before) took another path than the one differentiated (docs/parameters.md, "Arc length")."""

    def __init__(self, prepared, weight: np.ndarray):
        super().__init__(prepared)
        self.weight = weight
        self.previous = np.zeros((self.model.n_dofs, len(self.names)))   # δq of the row before
        self.first_step = np.zeros(len(self.names))                      # δΔs₀/Δs₀
        #: (state, λ, the step into it) of every row, for :meth:`limit_points`
        self.states: list[tuple[object, float, ArcStep | None]] = []

    def record(self, state, load_factor: float, constraint_gradient=None, step: ArcStep | None = None) -> None:
        """The row's sensitivities: at λ = 0 zeros (and δΔs₀ found), after a step the bordered solve
        of the class docstring, at λ = 1 load control's."""
        model, k = self.model, len(self.names)
        self.states.append((state.copy(), load_factor, step))
        if step is None or model.n_dofs == 0:
            if load_factor == 0.0 and model.n_dofs:
                self.first_step = self._first_step_derivative(state)
            super().record(state, load_factor)
            return
        ev = self.assembler.evaluate(state, matrices=True, load_factor=load_factor, inertia=False)
        rhs = -self.residual_derivatives(state, load_factor)
        if step.at_full_load:
            tangent, moved = self._solve(ev.stiffness, rhs, load_factor), np.zeros(k)
        else:
            along = self.weight * step.increment                       # DᵀW
            shifted = self.assembler.evaluate(state, matrices=False, load_factor=load_factor + 1.0, inertia=False)
            load = ev.residual - shifted.residual                     # q_ref = −∂r/∂λ
            held = along @ self.previous + step.length * step.length * self.first_step
            solved = bordered_solve(ev.stiffness, -load, along, np.vstack([rhs, held[None]]), load_factor)
            tangent, moved = solved[:-1], solved[-1]
        self.previous = tangent
        self._append_row(state, load_factor, tangent, moved)

    def _first_step_derivative(self, state) -> np.ndarray:
        """δΔs₀/Δs₀ per parameter: Δs₀ = ‖t₀‖_W/steps, t₀ = K₀⁻¹q_ref at the start (λ = 0), so
        δΔs₀/Δs₀ = t₀ᵀW δt₀ / t₀ᵀW t₀ with δt₀ = K₀⁻¹(δq_ref − δK₀ t₀), δq_ref = ∂r/∂p(λ=0) − ∂r/∂p(λ=1)."""
        ev = self.assembler.evaluate(state, matrices=True, load_factor=0.0, inertia=False)
        shifted = self.assembler.evaluate(state, matrices=False, load_factor=1.0, inertia=False)
        start = self._solve(ev.stiffness, ev.residual - shifted.residual, 0.0)[:, 0]
        load = self.residual_derivatives(state, 0.0) - self.residual_derivatives(state, 1.0)
        moved = self._solve(ev.stiffness, load - self.stiffness_derivative_along(state, start), 0.0)
        size = float(start @ (self.weight * start))
        return (start * self.weight) @ moved / size

    def stiffness_derivative_along(self, state, direction: np.ndarray) -> np.ndarray:
        """(∂K/∂p) v at a state of load factor 0 (the start), one column per parameter (n_dofs, k): the
        elements' tangent by their section values (the generated ``beam_stiffness_D_section``, (∂K/∂s) v exact
        for every section, shear-flexible ones too) and the hinges' by their stiffness laws and rest
        angles; loads, gravity, masses and applied torques enter K only times λ, and damping times θ̇ = 0.
        With rigid links or guides the dependent nodes move by P v and the sum is reduced by Pᵀ
        (latdyn/analyses/link_sensitivities.py)."""
        model, k = self.model, len(self.names)
        total = np.zeros((model.n_total + 1, k))
        full = np.concatenate([direction, np.zeros(model.n_total + 1 - model.n_dofs)])
        if model.links is not None:   # the dependent nodes move with it: P v (latdyn/assembly/linked.py)
            full[:model.n_assembled] = np.asarray(self.assembler.evaluate(state, matrices=True).projection @ direction)
        self.add_section_stiffness_along(state, full, total)
        for key in self.derivatives:
            contact = _CONTACT_KEY.match(key)
            if contact and self._in_contact(state, model.hinge_index(contact["beam"], contact["end"])):
                raise SceneError(self.scene.file, "solve.sensitivities",
                                 f"the arc-length path starts with {contact['beam']}.{contact['end']} on its "
                                 f"compliant stop, whose law ({key}) then moves the start's stiffness and so the "
                                 "first step's length: not differentiated (it needs the contact law's second "
                                 "derivative); expected a start inside the limits")
        for key, laws in self.derivatives.items():
            hinge = _HINGE_KEY.match(key)
            if not hinge or hinge["law"] not in ("stiffness", "rest_angle"):
                continue
            j = model.hinge_index(hinge["beam"], hinge["end"])
            theta, rate, t = float(state.theta[j]), float(state.theta_dot[j]), state.t
            for column, law in laws.items():
                values = np.zeros((1, 9))
                if hinge["law"] == "stiffness":   # ∂f/∂θ = k + s ∂k/∂θ + …, with k replaced by ∂k/∂p
                    values[0, 0:3] = law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t)
                    at = np.array([[theta, rate, model.hinges[j].rest_angle, 0.0]])
                else:   # ∂/∂θ_r (k + (θ − θ_r) ∂k/∂θ) = −∂k/∂θ: s = −1, laws (0, ∂k/∂θ, ∂k/∂θ̇)
                    stiffness = model.hinges[j].stiffness
                    values[0, 1:3] = law.value(theta, rate, t) * np.array(
                        [stiffness.d_theta(theta, rate, t), stiffness.d_rate(theta, rate, t)])
                    at = np.array([[0.0, 0.0, 1.0, 0.0]])
                d_theta = float(np.asarray(self.kernels.hinge_force(at, values, NO_CONTACT[None])[1]).reshape(-1)[0])
                total[model.hinge_dofs[j], column] += d_theta * full[model.hinge_dofs[j]]
        return self._on_free_coordinates(state, total)

    def _in_contact(self, state, j: int) -> bool:
        """Whether hinge ``j`` is at or past one of its compliant stops at ``state``."""
        limits = self.model.hinges[j].limits
        return limits is not None and not limits[0] < float(state.theta[j]) < limits[1]

    # ------------------------------------------------------------------ limit points
    def limit_points(self, path) -> list[dict]:
        """``limit_point_sensitivities``: for each turn of λ among the rows (a row whose λ is above or
        below both neighbours'), the limit point located on the path between its neighbours and
        dλ_c/dp there. Located: on the hyperplane family cᵀW (q ⊖ q_m) = σ through the turning row m
        (c the chord of the two steps about it), the σ where dλ/dσ = 0 (regula falsi, each point by
        Newton on the bordered system); there K φ = 0 has a left null vector φ, and the bordered
        derivative δλ = φᵀ∂r/∂p / φᵀq_ref does not depend on c: the limit load's derivative
        (``path``: latdyn.analyses.continuation.Path, its evaluate, step_to and increment_size)."""
        out = []
        lams = [lam for _, lam, _ in self.states]
        for m in range(1, len(self.states) - 1):
            before, after = lams[m] - lams[m - 1], lams[m + 1] - lams[m]
            if before * after >= 0.0 or self.states[m + 1][2] is None or self.states[m][2] is None:
                continue
            if self.states[m + 1][2].at_full_load:
                continue
            located = self._locate_limit(path, m)
            if located is None:
                path.writer.summary.setdefault("warnings", []).append(
                    f"the limit point near load factor {lams[m]:.6g} could not be located on the path: its "
                    "load factor's sensitivity is left out of limit_point_sensitivities")
                continue
            state, lam, chord = located
            ev = self.assembler.evaluate(state, matrices=True, load_factor=lam, inertia=False)
            shifted = self.assembler.evaluate(state, matrices=False, load_factor=lam + 1.0, inertia=False)
            rhs = np.vstack([-self.residual_derivatives(state, lam), np.zeros((1, len(self.names)))])
            solved = bordered_solve(ev.stiffness, shifted.residual - ev.residual, chord, rhs, lam)
            out.append({"kind": "maximum" if before > 0 else "minimum", "load_factor": float(lam),
                        "dload_factor": {name: float(solved[-1, c]) for c, name in enumerate(self.names)}})
        return out

    def _locate_limit(self, path, m: int):
        """(state, λ, cᵀW) of the limit point about row m, or None (:meth:`limit_points`): the path's own
        where it located the turn at that row (Path.locate_turn: an arc-length path's rows are its points),
        else located here between the rows about it."""
        from latdyn.analyses.limit_points import locate_limit

        if self.states[m][1] in path.located_limits:
            return path.located_limits[self.states[m][1]]

        start, lam0, into = self.states[m]
        chord = self.weight * (into.increment + self.states[m + 1][2].increment)
        ends = (-float(chord @ into.increment), float(chord @ self.states[m + 1][2].increment))
        located = locate_limit(path, start, lam0, chord, ends)
        return None if located is None else (*located, chord)


def _force_sensor_refusal(scene) -> str | None:
    """Why a continuous controller that reads a force (a cable's tension, an element's section force, a free joint's
    torque or force: latdyn/assembly/control.py ``CABLE_TENSION``, ``SECTION_FORCE``, ``JOINT_FORCE``) keeps the
    sensitivities from being exact, or None. Along the carried δq, δv the sensor's derivative is in the step's exact
    K and C already (the coupling entries, from the generated cable_tension, beam_section_forces_D_q and the joint's
    hinge_force: csrc/evaluate.c ``sensor_jacobian``), and the controller's ∂f/∂p is read at the sensor's value (the
    evaluation's, :meth:`ControllerTerms.sensed_in_c`); the force's own explicit dependence on a parameter (∂F/∂p of
    the cable's EA, damping or rest length, the element's section values, the joint's laws) enters through ∂f/∂s
    (:meth:`ControllerTerms.sensed_force_slopes`; a geometry parameter's through the section force's generated
    ∂S/∂X, :func:`moved_forces`). Refused: a sensed law of t in a run with events (∂F/∂t δt is not taken through the controller), and readers with states
    (their δs along δq)."""
    forces = {p.name: p for p in scene.output.probes if (p.kind == "cable" and p.quantity == "tension")
              or p.kind == "element" or (p.kind in ("hinge", "guide") and p.quantity in ("torque", "force"))}
    uses = {used: name for name in scene.solve.sensitivities for used in scene.parameters.depending_on(name)}
    timed = _law_in_time(scene)
    for c in scene.controllers.values():
        read = sorted(set(forces) & set(c.reads))
        if not read or c.sampled:
            continue
        if c.states:
            return (f"sensitivities of runs with a continuous controller with states that reads a force (a cable's "
                    f"tension, a section or joint force: {c.name} reads {read[0]!r}) are not computed yet; expected "
                    "coordinates (a cable's length, an angle, a point), or a controller without states")
        for name in read:
            _, laws = _sensed_force_laws(scene, forces[name])
            if has_events(scene) and any(timed(law) for law in laws):
                return (f"controller {c.name!r} reads the force {name!r}, whose law depends on t, in a run with "
                        "events (a latch, a stop, a cable's change): its rate in t is not taken through a controller "
                        "yet; expected a law of the state alone")
    return None


def moved_forces(scene) -> dict:
    """The force probes (a cable's tension, an element's section force, a joint's torque or force) that a continuous
    controller reads and whose own laws a parameter of ``solve.sensitivities`` moves, by name; a section force by any
    geometry parameter too (its element's reference: ``beam_section_forces_D_reference``, zero where it does not move)."""
    uses = {used for name in scene.solve.sensitivities for used in scene.parameters.depending_on(name)}
    read = {r for c in scene.controllers.values() if not c.sampled for r in c.reads}
    placed = any(GEOMETRY_KEY.match(used) for used in uses)   # a section force moves with its element's reference
    return {p.name: p for p in scene.output.probes if p.name in read
            and ((((p.kind == "cable" and p.quantity == "tension") or p.kind == "element" or is_joint_force(p))
                  and (any(used.startswith(_sensed_force_laws(scene, p)[0]) for used in uses)
                       or (placed and p.kind == "element")))
                 or (placed and is_placed_point(p)))}


def is_placed_point(probe) -> bool:
    """Whether ``probe`` is a point's position or displacement: a value a geometry parameter moves at a fixed state
    (its offset, a held node, a displacement's reference: ReferenceGeometry.point_moves), which a controller reading it
    takes as :func:`moved_forces`' forces (``ControllerTerms.sensed_force_slopes``)."""
    return probe.kind == "point" and probe.quantity in ("position", "displacement")


def _sensed_force_laws(scene, probe) -> tuple:
    """(the key prefixes of the laws a force probe's value reads, those laws) for :func:`_force_sensor_refusal`."""
    if probe.kind == "cable":
        return (f"cables.{probe.beam}.",), [scene.cables[probe.beam].rest_length]
    if probe.kind == "element":
        section = scene.beams[probe.beam].section
        return tuple(f"sections.{n}." for n, s in scene.sections.items() if s is section), []
    if probe.kind == "hinge":
        joint = next(h for beam, which, h in scene.hinges if (beam, which) == (probe.beam, probe.end))
        return (f"beams.{probe.beam}.{probe.end}.hinge.",), [joint.stiffness, joint.damping, joint.torque]
    joint = scene.bodies[probe.body].guide
    return (f"bodies.{probe.body}.guide.",), [joint.stiffness, joint.damping, joint.force]


def _driven_joint_law(key: str) -> bool:
    """Whether ``key`` is a hinge's torque or a guide's force (the laws a continuous controller drives as a y + b)."""
    hinge, guide = _HINGE_KEY.match(key), _GUIDE_KEY.match(key)
    return bool((hinge and hinge["law"] == "torque") or (guide and guide["law"] == "force"))


class ControllerTerms:
    """∂r/∂p through continuous controllers (SCENE.md ``controllers`` without ``rate``) for transient
    sensitivities. A controller's output y = clip(f(t, s; p)) is a law of its sensors s (probes read at
    the state, earlier controllers' outputs); its exact derivatives by s are in the step's matrix
    already (latdyn/assembly/control.py: the actuators' rows × the sensors' coordinates in K and C), so
    what p adds is the explicit part, through the chain of controllers in file order,

        dy_k/dp = ∂f_k/∂p + Σ_j ∂f_k/∂y_j dy_j/dp          (0 while y_k is clipped at a limit),

    ∂f_k/∂p the derivative of the output's text by the parameter (Parameters.derivative, SymPy), and
    the residual's rows of each actuator take it times their force per unit output: −a on a hinge's
    coordinate (f = … − τ, τ = a y + b; a = 1 for the controller's name alone), the point-load
    kernel's force for a unit value on a load's component (global or turning with a body). The states
    of continuous controllers: :class:`ControllerStates`; sampled controllers: :class:`SampledTerms`;
    what neither covers is refused (:meth:`refusal`). Inputs a controller reads are held at their
    current values (:meth:`signal_values`): no parameter moves them."""

    def __init__(self, owner: ParameterDerivatives):
        import sympy as sp

        from latdyn.results.probes import ProbeSet
        from latdyn.scene.expressions import parse_named_expression

        scene, assembler = owner.scene, owner.assembler
        self.model, self.k = owner.model, len(owner.names)
        self.continuous = [c for c in scene.controllers.values() if not c.sampled]
        names = {c.name for c in self.continuous}
        #: controller name -> {column: ∂f/∂p as a function of (t, reads, states)}
        self.partials: dict[str, dict[int, object]] = {}
        #: controllers with states: name -> {column: {state: ∂(dS/dt)/∂p as a function of (t, reads, states)}}
        self.rate_partials: dict[str, dict[int, dict[str, object]]] = {}
        #: the partials' SymPy expressions (controller name -> {column: ∂f/∂p}), and the partials compiled, whose C
        #: both paths of a transient run call (latdyn/analyses/derivative_laws.py ControllerPartials; set by
        #: TransientSensitivities), None: their lambdas
        self.partial_expressions: dict[str, dict[int, object]] = {}
        #: the states' rates' partials' SymPy expressions (controller name -> {column: {state: ∂(dS/dt)/∂p}}),
        #: compiled beside the outputs' (ControllerPartials.of)
        self.rate_expressions: dict[str, dict[int, dict[str, object]]] = {}
        self.compiled = None
        for column, name in enumerate(owner.names):
            for key in scene.parameters.depending_on(name):
                match = _CONTROLLER_KEY.match(key)
                if not match:
                    continue
                c = scene.controllers[match["name"]]
                text = scene.parameters.derivative(key, name, c.reads + c.states)
                _, expr = parse_named_expression(text, c.reads + c.states, scene.file, key,
                                                 "the controller's sensors and states")
                law = sp.lambdify(c.symbols, expr, modules=["math", "numpy"])
                if match["state"] is None:
                    self.partials.setdefault(c.name, {})[column] = law
                    self.partial_expressions.setdefault(c.name, {})[column] = expr
                else:              # ∂(dS/dt)/∂p of one state
                    self.rate_partials.setdefault(c.name, {}).setdefault(column, {})[match["state"]] = law
                    self.rate_expressions.setdefault(c.name, {}).setdefault(column, {})[match["state"]] = expr
        #: controller name -> {an earlier controller it reads: the index of ∂f/∂y_j in its
        #: ``Controller.output_gradient``}
        self.chained = {c.name: {r: i for i, r in enumerate(c.reads) if r in names} for c in self.continuous}
        #: controller name -> {a force it reads whose own laws a parameter moves: its place in the reads}, and
        #: those forces' probes by name (:meth:`sensed_force_slopes`)
        self.moved_forces = moved_forces(scene)
        self.forces_read = {c.name: {r: i for i, r in enumerate(c.reads) if r in self.moved_forces}
                            for c in self.continuous}
        self.sensors = ProbeSet(assembler, assembler.initial_state())
        self.assembler, self.owner = assembler, owner
        #: controller name -> dS_{n+1}/dp at the step's end configuration held fixed (p_c, k), set by
        #: :class:`ControllerStates` before ∂r/∂p is taken at a step's end (or δS_0 at the start)
        self.held: dict[str, np.ndarray] = {}
        #: whether :meth:`signal_values` leaves the state's rates as they are (its probes read a copy, completed): an
        #: event's (∂K/∂p) w on a model with rigid links or guides differences ∂r/∂p along w at the assembled rates
        #: held, the dependent nodes' too (``TransientSensitivities._at_held_rates``); the compiled partials read the
        #: sensors from C at the state as given (:meth:`sensed_in_c`)
        self.rates_held = False
        #: the controllers with states, differentiated (None without)
        self.states = ControllerStates(self) if any(c.states for c in self.continuous) else None
        #: the sampled controllers' held outputs and states, differentiated (None without)
        self.sampled = SampledTerms(self) if any(c.sampled for c in scene.controllers.values()) else None

    @staticmethod
    def refusal(scene) -> str | None:
        """Why the controllers of ``scene`` keep its transient sensitivities from being exact, or None."""
        why = SampledTerms.refusal(scene) or _force_sensor_refusal(scene)
        if why is not None:
            return why
        for c in scene.controllers.values():
            if c.states and c.states_name_t and has_events(scene):
                return (f"sensitivities of runs with controllers whose states' rates name t ({c.name}) and events (a "
                        "latch, a stop, a compliant stop's onset, a cable's change: the event time moves the states' "
                        "rates in t) are not computed yet; states whose rates do not name t are")
        return ControllerTerms.parameter_in_a_reading_law(scene, "expected the parameter inside the controller's "
                                                                 "output, or in a hinge's torque or a guide's force, "
                                                                 "instead", joint_laws=True)

    @staticmethod
    def parameter_in_a_reading_law(scene, expected: str, joint_laws: bool = False) -> str | None:
        """Why a parameter of ``solve.sensitivities`` used in a law that names a controller (a hinge torque,
        guide force or load component scaled by it, ``"k*(ctl)"``) keeps the sensitivities from being
        computed, ending in ``expected``; or None. With ``joint_laws`` (transient runs) a hinge's torque and a
        guide's force are taken: τ = a y + b (latdyn/assembly/control.py), ∂τ/∂p = y ∂a/∂p + ∂b/∂p at fixed y is a
        derivative law reading the controller's output at the state as the step's laws read it (the scene's
        ``controller_outputs``: :class:`ParameterDerivatives`), y's own δy is the step's matrix's coupling a ∂y/∂s
        and, for a parameter inside the output too, :meth:`add`'s a dy/dp; at an event the difference of the static
        ∂r/∂p along w reads y at the moved states (``TransientSensitivities._controller_outputs_at``). A load
        component's derivative law is one of t alone (:meth:`ParameterDerivatives._add_load_forces`) and a static
        path runs no controller between its laws: both stay refused (seed 6 case 11 of the sensitivity fuzzer)."""
        if not getattr(scene, "controllers", None):
            return None
        readers = ControllerTerms._laws_naming(scene, set(scene.controllers))
        for name in scene.solve.sensitivities:
            for used in scene.parameters.depending_on(name):
                if used in readers and not (joint_laws and _driven_joint_law(used)):
                    written = scene.parameters.uses[used][0]
                    return (f"parameter {name!r} is used at {used}, a law that names a controller ({written!r}: "
                            f"a hinge torque, guide force or load component): {expected}")
        return None

    def signal_values(self, state) -> dict:
        """The values the controllers read at ``state``: the probes' and the inputs' (held: their current
        values, which do not depend on the parameters)."""
        probed = state.copy() if self.rates_held else state   # ProbeSet.values completes the links in place
        return {**dict(zip(self.sensors.names, self.sensors.values(probed))), **self.owner.scene.inputs.current()}

    def sensed_in_c(self, state) -> dict:
        """The values of the probes the continuous controllers read other than hinge and guide angles and rates
        (points' positions and velocities, in global or a body's axes, …) as the step's evaluation computes them in
        C (csrc/evaluate.c ``sensor_value``, through ``latdyn_controller_outputs_at``), by probe name: the values the
        loop of steps reads at the same state (csrc/sensitivity_loop.c ``controller_parameter_forces``), so that
        both paths evaluate ∂f/∂p at the same bits (the probes' NumPy values may differ from them at round-off). The
        controllers' outputs that call leaves in the scene's array are put back."""
        from latdyn.assembly.control import ANGLE, CONTROLLER, RATE

        wiring = self.assembler.control
        wanted = [(i, name) for k in range(wiring.n)
                  for i, name in zip(range(int(wiring.sensor_start[k]), int(wiring.sensor_start[k + 1])),
                                     wiring.sensor_names(k))
                  if int(wiring.sensor_kind[i]) not in (ANGLE, RATE, CONTROLLER)]
        if not wanted:
            return {}
        native = self.assembler.native(True)
        outputs = self.owner.scene.controller_outputs.values
        held = outputs.copy()
        native.controller_outputs_at(state)
        outputs[:] = held
        sensed = native.buffers["sensor_values"]
        return {name: float(sensed[i]) for i, name in wanted}

    def sensed_force_slopes(self, state) -> dict:
        """∂F/∂p (k,) at ``state`` (the configuration and rates held) of each force a continuous controller reads whose
        own laws a parameter moves (:func:`moved_forces`), by probe name: a section force's and a cable's tension's
        explicit part as their probes' sensitivities take it (latdyn/analyses/probe_derivatives.py: the generated
        beam_section_forces_D_section, cable_force), a free joint's −∂f/∂p of its laws (the generated hinge_force
        through :meth:`ParameterDerivatives._hinge_force`, its compliant stops' contact_force_D_law), as
        joint_force_sensitivities.joint_force_forms takes it."""
        owner, model = self.owner, self.model
        zero = np.zeros((model.n_dofs, self.k))
        out = {}
        for name, probe in self.moved_forces.items():
            if is_joint_force(probe):
                j = model.hinge_index(probe.beam, probe.end) if probe.kind == "hinge" else \
                    model.hinge_index(probe.body, "guide")
                d = model.hinge_dofs[j]
                laws = np.zeros((model.n_total + 1, self.k))
                for key, by_column in owner.derivatives.items():
                    _, hinge = owner._key_kinds(key)
                    if hinge and model.hinge_index(hinge["beam"], hinge["end"]) == j:
                        for column, law in by_column.items():
                            laws[d, column] += owner._hinge_force(state, j, hinge["law"], law, 1.0)
                owner._contact_forces(state, laws)
                out[name] = -laws[d]
            elif probe.kind == "element" and owner.geometry is None and \
                    owner.kernels.address("beam_section_forces_D_section") is not None:
                out[name] = self._section_force_slope(state, probe)
            else:   # a cable's tension, a section force, a point's position or displacement by a geometry
                # parameter: its probe's explicit part
                moved = owner._by_parameter(zero, state)
                out[name] = np.asarray(owner._probe_derivatives(probe, state, *moved,
                                                                owner._rates_by_parameter(zero)), float)
                if owner.geometry is not None and owner.geometry.turning:   # less the shift d of its node, which ∂r/∂X's K d carries (below)
                    out[name] -= self._shift_sensed(probe, state)
        return out

    def _shift_sensed(self, probe, state) -> np.ndarray:
        """(k,): the point ``probe``'s move by the shifts of subtrees on parts that turn (d of its node,
        ``ReferenceGeometry.shifts``), as it reads it. Its probe's explicit part holds d, but ∂r/∂X of the shift
        (``ReferenceGeometry._add_shifts``: K d with K on the assembled coordinates, the controller's coupling to the
        sensed node among its blocks) moves the controller's output by ∂f/∂s ∂s/∂x d already: counted twice, the
        gimbal's PD of its outer ring's x by the ring offset was 0.35 off Richardson differences of whole runs."""
        owner, model = self.owner, self.model
        d = owner.geometry.shifts(state)[0]
        return np.asarray(owner._probe_derivatives(probe, state, d, np.zeros_like(d),
                                                   np.zeros((len(model.hinges), self.k)), explicit=False), float)

    def _section_force_slope(self, state, probe) -> np.ndarray:
        """∂S/∂p (k,) at ``state`` of the element's section force ``probe`` a controller reads, its section values moved
        by parameters: the generated beam_section_forces_D_section contracted with the section uses' rows
        (ParameterDerivatives._section_derivative_blocks) and weighed as the controller's sensor weighs the forces
        (csrc/parameter_forces.c ``latdyn_section_force_slope``, the C the loop of steps calls)."""
        import ctypes

        from latdyn.assembly.control import _section_sensor

        owner, k = self.owner, self.k
        out = np.zeros(k)
        blocks = owner._section_derivative_blocks(state)
        if blocks is None:
            return out
        elements, columns, rows = (np.ascontiguousarray(a, t) for a, t in zip(blocks, (np.int64, np.int64, float)))
        _, index, _, _, weights, _ = _section_sensor(self.model, probe)
        weights = np.ascontiguousarray(weights[:2], float)
        native = self.assembler.native(inertia_tangent=True)
        _native_library().latdyn_section_force_slope(
            native.model_ref, native.work_ref, ctypes.byref(native.configuration(state)),
            owner.kernels.address("beam_section_forces_D_section"), index // 4, index % 4, weights.ctypes.data,
            len(elements), elements.ctypes.data, columns.ctypes.data, rows.ctypes.data, k, out.ctypes.data)
        return out

    _laws_naming = staticmethod(laws_naming)

    def state_values(self, c) -> list:
        """The accepted states S of controller ``c`` (their values in ``scene.controller_states``)."""
        states = self.owner.scene.controller_states
        return [states[f"{c.name}.{s}"] for s in c.states]

    def add(self, state, total: np.ndarray) -> None:
        """Add the controllers' ∂r/∂p at ``state`` into ``total`` (class docstring)."""
        if self.sampled is not None:   # the held outputs' δy (SampledTerms)
            self.sampled.add(state, total)
        w = self.assembler.control   # the wiring of the current numbering
        if not (self.partials or self.held or any(self.forces_read.values())) or not len(w.actuator_kind):
            return
        values = self.signal_values(state)
        if self.compiled is not None:
            values.update(self.sensed_in_c(state))   # what the loop of steps reads (:meth:`sensed_in_c`)
        outputs, slopes, forces = {}, {}, None
        for c in self.continuous:
            arguments = [state.t, *[values[r] if r in values else outputs[r] for r in c.reads],
                         *self.state_values(c)]
            raw = float(c.functions()[0](*arguments)) if self.compiled is None else self.compiled.output(c, arguments)
            outputs[c.name] = c.clip(raw)
            slope = np.zeros(self.k)
            if c.limits is None or c.limits[0] < raw < c.limits[1]:
                for column, partial in self.partials.get(c.name, {}).items():
                    slope[column] += (float(partial(*arguments)) if self.compiled is None else
                                      self.compiled.value(partial, arguments))
                if self.forces_read.get(c.name):   # ∂f/∂s ∂F/∂p of the forces whose laws a parameter moves
                    gradient = (c.output_gradient(*arguments) if self.compiled is None else
                                self.compiled.gradient(c, arguments))
                    if forces is None:
                        forces = self.sensed_force_slopes(state)
                    for read, i in self.forces_read[c.name].items():
                        slope += gradient[i] * forces[read]
                if self.chained[c.name] or c.name in self.held:
                    gradient = (c.output_gradient(*arguments) if self.compiled is None else
                                self.compiled.gradient(c, arguments))
                    for read, i in self.chained[c.name].items():
                        slope += gradient[i] * slopes[read]
                    if c.name in self.held:   # ∂y/∂S dS/dp (the states at the configuration held), in the states' order
                        by_states = self.states.output_by_states(c, arguments)   # the step's compiled law's
                        if by_states is None:
                            by_states = gradient[len(c.reads):]
                        for l, row in enumerate(self.held[c.name]):
                            slope += by_states[l] * row
            slopes[c.name] = slope
        loads: dict[int, np.ndarray] = {}   # load -> its six values' derivatives (6, k)
        for kind, index, component, controller, gain in zip(w.actuator_kind, w.actuator_index, w.actuator_component,
                                                            w.actuator_controller, w.actuator_gain):
            moved = (gain if gain else 1.0) * slopes[w.controllers[controller].name]
            if kind == 0:   # a hinge torque τ = a y (+ b): its row f = … − τ
                total[self.model.hinge_dofs[index]] -= moved
            else:           # a load component a y (+ b): the point-load kernel, linear in its values
                loads.setdefault(int(index), np.zeros((6, self.k)))[component] += moved
        for index, values in loads.items():
            columns = [c for c in range(self.k) if np.any(values[:, c])]
            if columns:
                nodes, forces = self.owner._load_forces(state, [index] * len(columns), values[:, columns].T)
                total[self.model.node_dofs[nodes[0]][:, None], np.array(columns)[None, :]] += forces.T


class ControllerStates:
    """The states of continuous controllers (``controllers.NAME.states`` without ``rate``) carried
    through the step's derivative (docs/parameters.md, "Controllers"). The step integrates
    dS/dt = f(t, s, S; p) by the trapezoidal rule condensed into the output (docs/control.md),

        S_{n+1} = S_n + h/2 (f_n + f(t_{n+1}, s_{n+1}, S_{n+1})),

    so its derivative, with A = I − h/2 ∂f/∂S at the step's end,

        δS_{n+1} = A⁻¹ (δS_n + h/2 δf_n + h/2 ∂f/∂p)  +  A⁻¹ h/2 ∂f/∂s δs_{n+1}
                 = (held: the configuration fixed)    +  (through the sensors),
        δf_{n+1} = ∂f/∂s δs_{n+1} + ∂f/∂S δS_{n+1} + ∂f/∂p.

    The held part enters ∂r/∂p as ∂y/∂S times it (:meth:`ControllerTerms.add`); the part through the
    sensors is the condensed total derivative dy/ds = ∂y/∂s + ∂y/∂S A⁻¹ h/2 ∂f/∂s that the step's
    matrix holds when the evaluation condenses the states from (S_n, f_n) (:meth:`condensed`). δs is
    the sensors' derivative along δq (probes: hinge angles, point positions and displacements) and, for a sensor
    reading a rate (a hinge's or guide's rate, a point's velocity), along the step end's δv: δs = D_q δq + D_v δv
    (:meth:`_sensed`; after an event's jump δf is taken anew at the jumped rates, :meth:`restarted`),
    ∂y/∂S, ∂f/∂s, ∂f/∂S and ∂f/∂p the symbolic derivatives of the controller's expressions, those the
    code generator prints for Newton (codegen/laws.py): ∂f/∂s and ∂f/∂S the step's compiled controller law's own
    (:meth:`_rates_gradients`), ∂f/∂p compiled beside the outputs' partials (derivative_laws.ControllerPartials); the
    p × p algebra csrc/controller_states.c's, which the loop of steps calls too. At the start (and a restart) the
    states are held: δS_0 = 0 (``initial`` is a number), δf_0 = ∂f/∂s δs_0 + ∂f/∂p, δs_0 = D_q δq_0 + D_v δv_0 of
    the start's moves (geometry and ``initial_velocity`` parameters; :meth:`start`). A step whose size moves with p (an
    event's, the steps after it) adds A⁻¹ ½ (f_n + f_{n+1}) δh to δS_{n+1} (:meth:`by_step_size`: its ∂r/∂h in
    the step size's column), and through an event's jump and restart δS is held (:meth:`hold`)."""

    def __init__(self, terms: ControllerTerms):
        import sympy as sp

        from latdyn.assembly.control import state_rates

        self.terms, scene = terms, terms.owner.scene
        self.controllers = [c for c in terms.continuous if c.states]
        self.values, self.rates = scene.controller_states.values, state_rates(scene)
        #: S of the stateful controllers in scene.controller_states, and their rates' entries (the continuous
        #: controllers' states in file order, as latdyn.assembly.control.wiring lays them out)
        self.slots = np.array([scene.controller_states.index(f"{c.name}.{s}") for c in self.controllers
                               for s in c.states], np.int64)
        first, index = 0, []
        for c in terms.continuous:
            index.extend(range(first, first + len(c.states)) if c.states else [])
            first += len(c.states)
        self.rate_index = np.array(index, np.int64)
        self.first = dict(zip((c.name for c in self.controllers),
                              np.cumsum([0] + [len(c.states) for c in self.controllers]).tolist()))
        probes = {p.name: p for p in scene.output.probes}
        wiring = terms.assembler.control
        self.sensors, self.gradients, self._sensed_slots = {}, {}, {}
        #: controller name -> its place in the wiring, for those that read a point offset from its node or in a body's
        #: axes (in the wiring's order): their sensors' values the evaluation's (ControllerTerms.sensed_in_c) and their
        #: δs the C of the loop of steps (:meth:`_sensed`, csrc/controller_states.c controller_state_sensed)
        self.by_gradient = {}
        #: controller name -> its place k in the wiring, whose compiled law ``controller_laws(k, t, s, out)`` the
        #: step calls (:meth:`_rates_gradients`); controllers that read what the law's arguments do not carry keep
        #: SymPy's lambdified gradients
        self.place = {}
        for c in self.controllers:
            reads, S = c.symbols[1:1 + len(c.reads)], c.symbols[1 + len(c.reads):]
            sensed = [i for i, r in enumerate(c.reads) if r in probes]
            self.sensors[c.name] = [probes[c.reads[i]] for i in sensed]
            k = next(k for k, d in enumerate(wiring.controllers) if d.name == c.name)
            wired = wiring.sensor_names(k)
            if all(n in probes for n in wired):   # the law's arguments: the probes it reads, then its states
                self.place[c.name] = k
                self._sensed_slots[c.name] = [wired.index(c.reads[i]) for i in sensed]
                if _reads_points_by_gradient(wiring, k) and [c.reads[i] for i in sensed] == list(wired):
                    self.by_gradient[c.name] = k
            else:
                self.gradients[c.name] = sp.lambdify(c.symbols, [
                    [[sp.diff(f, reads[i]) for i in sensed] for f in c.state_exprs],
                    [[sp.diff(f, x) for x in S] for f in c.state_exprs]], modules=["math", "numpy"])
        self._law = None

    def _rates_gradients(self, c, arguments: list) -> tuple[np.ndarray, np.ndarray]:
        """∂f/∂s (p, m) over ``c``'s sensors and ∂f/∂S (p, p) of its states' rates at ``arguments`` (t, the reads,
        the states): the step's own compiled controller law (codegen/laws.py ``latdyn_controller_laws``: for state
        j at ``(1 + j)(1 + m + p)`` its rate and ∂f_j/∂(sensors, states); csrc/evaluate.c
        ``latdyn_controller_states_accept`` reads the same), the one C function for the step and its derivative."""
        p = len(c.states)
        if c.name not in self.place:
            f_s, f_S = self.gradients[c.name](*arguments)
            return (np.array(f_s, float).reshape(p, len(self.sensors[c.name])), np.array(f_S, float).reshape(p, p))
        out, m = self._law_at(c, arguments)
        width = 1 + m + p
        rows = np.array([[out[width * (1 + j) + 1 + i] for i in range(m + p)] for j in range(p)], float)
        rows = rows.reshape(p, m + p)
        return rows[:, self._sensed_slots[c.name]], rows[:, m:]

    def output_by_states(self, c, arguments: list) -> np.ndarray | None:
        """∂y/∂S (p,) of ``c``'s output before its limits at ``arguments`` (t, the reads, the states): the step's
        compiled controller law's ``out[1 + m + l]`` (:meth:`_rates_gradients`); None where ``c`` keeps SymPy's."""
        if c.name not in self.place:
            return None
        out, m = self._law_at(c, arguments)
        return np.array([out[1 + m + l] for l in range(len(c.states))], float)

    def output_gradient(self, c, arguments: list) -> np.ndarray | None:
        """∂y/∂(reads, S) of ``c``'s output before its limits at ``arguments`` (t, the reads, the states): the step's
        compiled controller law's (its ``out[1:1 + m + p]``, the sensors in the wiring's order) where ``c`` reads its
        wired sensors alone, in their order; None where it does not (or keeps SymPy's)."""
        if c.name not in self.place or tuple(c.reads) != self.terms.assembler.control.sensor_names(self.place[c.name]):
            return None
        out, m = self._law_at(c, arguments)
        return np.array([out[1 + i] for i in range(m + len(c.states))], float)

    def _law_at(self, c, arguments: list):
        """The step's compiled controller law of ``c`` called at ``arguments`` (t, the reads, the states): (its
        ``out`` array, m its sensors)."""
        import ctypes

        from latdyn.analyses.derivative_laws import _CONTROLLER_LAW

        native = self.terms.assembler.native(inertia_tangent=True)
        if self._law is None or self._law[0] is not native:
            width = max(1 + len(d.reads) + len(d.states) for d in self.controllers)
            self._law = (native, _CONTROLLER_LAW(native.model.controller_laws), (ctypes.c_double * width)(),
                         (ctypes.c_double * ((1 + width) * width))())
        _, law, args, out = self._law
        k = self.place[c.name]
        wiring = self.terms.assembler.control
        wired = wiring.sensor_names(k)
        m = len(wired)
        by_name = dict(zip(c.reads, arguments[1:1 + len(c.reads)]))
        for i, name in enumerate(wired):
            args[i] = float(by_name[name])
        for j, value in enumerate(arguments[1 + len(c.reads):]):
            args[m + j] = float(value)
        native.laws.bind_inputs()
        law(k, float(arguments[0]), args, out)
        return out, m

    def _at(self, c, state, values=None):
        """(arguments, ∂f/∂s (p, m), ∂f/∂S (p, p), ∂f/∂p (p, k)) of ``c`` at ``state``, its accepted S: the
        rates' gradients from the step's compiled law (:meth:`_rates_gradients`), their partials by the
        parameters from the compiled partials (derivative_laws.ControllerPartials) where they compiled."""
        if values is None:
            values = self.terms.signal_values(state)
        if c.name in self.by_gradient:   # the offset and body-axes points as the evaluation computes them in C
            values = {**values, **self.terms.sensed_in_c(state)}
        arguments = [state.t, *[values[r] for r in c.reads], *self.terms.state_values(c)]
        f_s, f_S = self._rates_gradients(c, arguments)
        p = len(c.states)
        f_p = np.zeros((p, self.terms.k))
        compiled = self.terms.compiled
        for column, laws in self.terms.rate_partials.get(c.name, {}).items():
            for j, s in enumerate(c.states):
                if s in laws:
                    f_p[j, column] = (float(laws[s](*arguments)) if compiled is None else
                                      compiled.value(laws[s], arguments))
        return arguments, f_s, f_S, f_p

    def _sensed(self, c, state, dq: np.ndarray, moved: np.ndarray | None = None,
                dv: np.ndarray | None = None) -> np.ndarray:
        """δs (m, k): the derivatives of ``c``'s sensors along δq (probe derivatives), and along the prescribed
        motions by the step end's δt ``moved`` (None: 0). A controller reading a point offset from its node or in a
        body's axes (``by_gradient``), where no sensor of it reads a node that follows rigid links or a guide
        (:func:`senses_dependent`) and none is on a prescribed body or joint or δt is 0: the gradients of the
        evaluation's sensors times δq, the C the loop of steps calls (csrc/controller_states.c
        ``latdyn_controller_states_sensed``). A controller reading a rate (a hinge's or guide's rate, a point's
        velocity): δs = D_q δq + D_v δv, ``dv`` the step end's δv (:func:`_sensor_derivatives`; the loop of steps takes a
        joint's rate and a node's velocity component as that row of δv, csrc/controller_states.c
        controller_state_sensed, the same bits)."""
        import ctypes

        owner = self.terms.owner
        k = self.by_gradient.get(c.name)
        rated = reads_rates(self.sensors[c.name])
        if rated or k is None or senses_dependent(owner.model, self.terms.assembler.control, k) or (
                moved is not None and np.any(moved) and _senses_prescribed(owner.model, self.terms.assembler.control, k)):
            return _sensor_derivatives(owner, self.sensors[c.name], state, dq, moved,
                                       (np.zeros_like(dq) if dv is None else dv) if rated else None)
        native = self.terms.assembler.native(inertia_tangent=True)
        wiring = self.terms.assembler.control
        first, count = int(wiring.sensor_start[k]), int(wiring.sensor_start[k + 1] - wiring.sensor_start[k])
        sensor_dof, column_dof = (np.ascontiguousarray(a, np.int64) for a in sensor_rows(owner.model, wiring))
        dq = np.ascontiguousarray(dq, float)
        ds = np.zeros((count, dq.shape[1]))
        native.laws.bind_inputs()
        _native_library().latdyn_controller_states_sensed(
            native.model_ref, native.work_ref, ctypes.byref(native.configuration(state)), float(state.t), first, count,
            sensor_dof.ctypes.data, column_dof.ctypes.data, dq.shape[1], dq.ctypes.data, None, ds.ctypes.data)
        return ds

    def _accepted(self) -> dict:
        return {"S": self.values[self.slots].copy(), "f": self.rates[self.rate_index].copy()}

    def restarted(self, carried: dict, state) -> dict:
        """``carried`` after the step's events at ``state`` where the integrator restarts there and takes the states'
        rates f at the state after the events' jumps (latdyn.step.compiled ``start``: S kept, f taken anew; after a
        latch, :func:`rates_taken_anew`), so for the controllers that read a rate (whose sensor jumps with v)
        δf = ∂f/∂s δs⁺ + ∂f/∂S δS + ∂f/∂p with δs⁺ = D_q δq + D_v δv⁺ of the jumped rates (:meth:`_sensed`); called
        after such a jump only (TransientSensitivities.after_events), elsewhere after_step's δf stands (after a stop
        the run keeps f: restart_accelerations restarts the accelerations alone). The others' δf is kept (their
        sensors do not jump)."""
        rated = [c for c in self.controllers if reads_rates(self.sensors[c.name])]
        if not rated or "controller_df" not in carried:
            return carried
        df = carried["controller_df"].copy()
        for c in rated:
            rows = slice(self.first[c.name], self.first[c.name] + len(c.states))
            _, f_s, f_S, f_p = self._at(c, state)
            ds = np.asarray(self._sensed(c, state, carried["dq"], carried["dt"], carried["dv"]), float)
            df[rows] = f_s @ ds.reshape(len(self.sensors[c.name]), -1) + f_S @ carried["controller_dS"][rows] + f_p
        return {**carried, "controller_df": df, **self._prefixed(self._accepted())}

    def start(self, state, dq: np.ndarray | None = None, dv: np.ndarray | None = None) -> dict:
        """δS_0 = 0, δf_0 at the start ``state``, δS_0 held for ∂r/∂p there: δf_0 = ∂f/∂s δs_0 + ∂f/∂p, the
        sensors moved by the start's δs_0 = D_q δq_0 + D_v δv_0 (:meth:`_sensed`; ``dq`` = δq_0 = δX of geometry
        parameters, ``dv`` = δv_0 of ``initial_velocity`` parameters and the rigid spin's ω × δX; None or zero: the
        sensors do not move, and ∂f/∂s δs_0 is not added)."""
        k = self.terms.k
        dS, df = np.zeros((len(self.slots), k)), np.zeros((len(self.slots), k))
        dq = None if dq is None or not np.any(dq) else dq
        dv = None if dv is None or not np.any(dv) else dv
        for c in self.controllers:
            rows = slice(self.first[c.name], self.first[c.name] + len(c.states))
            _, f_s, f_S, f_p = self._at(c, state)
            df[rows] = f_S @ dS[rows] + f_p
            moved = dq is not None or (dv is not None and reads_rates(self.sensors[c.name]))
            if moved:   # the start's sensors moved by δq_0, δv_0 (the first step's δf_n)
                ds = np.asarray(self._sensed(c, state, np.zeros_like(dv) if dq is None else dq, None, dv), float)
                df[rows] = df[rows] + f_s @ ds.reshape(len(self.sensors[c.name]), -1)
            self.terms.held[c.name] = dS[rows]
        return {"controller_dS": dS, "controller_df": df, **self._prefixed(self._accepted())}

    @staticmethod
    def _prefixed(values: dict) -> dict:
        return {f"controller_{key}": value for key, value in values.items()}

    def hold(self, carried: dict) -> None:
        """δS as carried held for ∂r/∂p at an accepted state (a restart: the states kept, δq given)."""
        for c in self.controllers:
            self.terms.held[c.name] = carried["controller_dS"][self.first[c.name]:self.first[c.name] + len(c.states)]

    def begin_step(self, carried: dict, state, h: float) -> None:
        """The held part of δS_{n+1} (class docstring) at the step's end ``state``, for ∂r/∂p there, and the
        states' derivative by the step's size at that configuration, A⁻¹ ½ (f_n + f_{n+1}) (:meth:`by_step_size`;
        the accepted f_{n+1}: the integrator accepted the step before it is differentiated)."""
        hh = 0.5 * h
        self._step = {}
        library, k = _native_library(), self.terms.k
        for c in self.controllers:
            rows = slice(self.first[c.name], self.first[c.name] + len(c.states))
            _, f_s, f_S, f_p = self._at(c, state)
            p = len(c.states)
            arrays = [np.ascontiguousarray(a, float) for a in (
                f_S, f_p, carried["controller_dS"][rows], carried["controller_df"][rows], carried["controller_f"][rows],
                self.rates[self.rate_index][rows])]
            factor, pivots = np.zeros((p, p)), np.zeros(p, np.int64)
            held, by_h = np.zeros((p, k)), np.zeros(p)
            info = library.latdyn_controller_states_begin(p, k, hh, *(a.ctypes.data for a in arrays),
                                                          factor.ctypes.data, pivots.ctypes.data, held.ctypes.data,
                                                          by_h.ctypes.data)
            if info:
                raise SolverError(f"the sensitivities at t = {float(state.t):.6g} need controller {c.name}'s states' "
                                  "step matrix I − h/2 ∂f/∂S, which is singular there")
            self.terms.held[c.name] = held
            self._step[c.name] = (rows, (factor, pivots), np.ascontiguousarray(f_s, float), arrays[0], arrays[1], hh,
                                  by_h)

    def by_step_size(self, state) -> np.ndarray:
        """∂r/∂h (n_total + 1,) at the step's end ``state`` through the states' derivative by the step size at a
        fixed configuration (:meth:`begin_step`): ∂y/∂S A⁻¹ ½ (f_n + f_{n+1}) through the actuators, as
        :meth:`ControllerTerms.add` applies a held δS (its step-size column: an event's or an adaptive step's δh)."""
        import copy

        one = copy.copy(self.terms)
        one.k, one.partials, one.sampled = 1, {}, None
        one.forces_read = {}   # the sensed forces' ∂F/∂p are the parameters' columns, not the step size's
        one.held = {c.name: self._step[c.name][6][:, None] for c in self.controllers}
        total = np.zeros((self.terms.model.n_total + 1, 1))
        one.add(state, total)
        return total[:, 0]

    def condensed(self, carried: dict, h: float):
        """A context in which the evaluation condenses the states from the step's start (S_n, f_n) with
        h/2, as inside the step: its K and C hold the total dy/ds (class docstring)."""
        from contextlib import contextmanager

        @contextmanager
        def context():
            native = self.terms.assembler.native(inertia_tangent=True)
            half = native.buffers["controller_half_step"]
            kept = (half.copy(), self.values[self.slots].copy(), self.rates[self.rate_index].copy())
            half[0] = 0.5 * h
            self.values[self.slots], self.rates[self.rate_index] = carried["controller_S"], carried["controller_f"]
            try:
                yield
            finally:
                half[:] = kept[0]
                self.values[self.slots], self.rates[self.rate_index] = kept[1], kept[2]
        return context()

    def after_step(self, state, dq: np.ndarray, dh: np.ndarray | None = None, moved: np.ndarray | None = None,
                   dv: np.ndarray | None = None) -> dict:
        """δS_{n+1}, δf_{n+1} and the accepted (S, f) after the step ending at ``state``, δq and δv its
        configuration's and rates' derivatives (δv for the sensors reading rates: δs = D_q δq + D_v δv), ``dh`` its
        size's (class docstring; None: 0)."""
        k = self.terms.k
        dS, df = np.zeros((len(self.slots), k)), np.zeros((len(self.slots), k))
        library = _native_library()
        dh = None if dh is None else np.ascontiguousarray(dh, float)
        for c in self.controllers:   # csrc/controller_states.c latdyn_controller_states_after
            rows, (factor, pivots), f_s, f_S, f_p, hh, by_h = self._step[c.name]
            p, m = len(c.states), len(self.sensors[c.name])
            ds = np.ascontiguousarray(self._sensed(c, state, dq, moved, dv), float).reshape(m, k)
            held = np.ascontiguousarray(self.terms.held[c.name], float)
            out_S, out_f, scratch = np.zeros((p, k)), np.zeros((p, k)), np.zeros((p, k))
            library.latdyn_controller_states_after(p, m, k, hh, factor.ctypes.data, pivots.ctypes.data, f_s.ctypes.data,
                                                   f_S.ctypes.data, f_p.ctypes.data, held.ctypes.data, by_h.ctypes.data,
                                                   ds.ctypes.data, None if dh is None else dh.ctypes.data,
                                                   scratch.ctypes.data, out_S.ctypes.data, out_f.ctypes.data)
            dS[rows], df[rows] = out_S, out_f
        self.terms.held = {}
        return {"controller_dS": dS, "controller_df": df, **self._prefixed(self._accepted())}


def _reads_points_by_gradient(wiring, k: int) -> bool:
    """Whether the wiring's controller ``k`` reads a point offset from its node or a point in a body's axes (sensor
    kinds OFFSET_POSITION, BODY_FRAME: their δs by the evaluation's gradient, ControllerStates._sensed)."""
    from latdyn.assembly.control import BODY_FRAME, OFFSET_POSITION

    return any(int(wiring.sensor_kind[i]) in (OFFSET_POSITION, BODY_FRAME)
               for i in range(int(wiring.sensor_start[k]), int(wiring.sensor_start[k + 1])))


def _senses_prescribed(model, wiring, k: int) -> bool:
    """Whether a sensor of the wiring's controller ``k`` reads a prescribed joint's angle or a point on a prescribed
    body, or in a prescribed body's axes."""
    from latdyn.assembly.control import ANGLE, BODY_FRAME
    from latdyn.model.model import PRESCRIBED

    for i in range(int(wiring.sensor_start[k]), int(wiring.sensor_start[k + 1])):
        kind, index = int(wiring.sensor_kind[i]), int(wiring.sensor_index[i])
        if kind == ANGLE:
            if model.hinges[index].angle is not None:
                return True
            continue
        if model.nodes[index // 3].kind == PRESCRIBED or (
                kind == BODY_FRAME and model.nodes[int(wiring.sensor_frame_node[i])].kind == PRESCRIBED):
            return True
    return False


def senses_dependent(model, wiring, k: int) -> bool:
    """Whether a sensor of the wiring's controller ``k`` reads a point on a node that follows rigid links or a guide
    (model.links.dependent), or in such a body's axes: its δs is P δq there (ParameterDerivatives._dependent_motion)."""
    from latdyn.assembly.control import ANGLE, BODY_FRAME, RATE

    if model.links is None:
        return False
    dependent = set(int(i) for i in model.links.dependent)
    for i in range(int(wiring.sensor_start[k]), int(wiring.sensor_start[k + 1])):
        kind, index = int(wiring.sensor_kind[i]), int(wiring.sensor_index[i])
        if kind not in (ANGLE, RATE) and (index // 3 in dependent
                              or (kind == BODY_FRAME and int(wiring.sensor_frame_node[i]) in dependent)):
            return True
    return False


def sensor_rows(model, wiring) -> tuple[np.ndarray, np.ndarray]:
    """(each of the wiring's sensors' row in δq, each column of their gradients' row in δq), −1 for 0: a joint's
    angle its free hinge's coordinate, a node's coordinate its free node's (as ParameterDerivatives.
    _on_free_nodes_and_hinges takes them); a point offset from its node (its node's six coordinates) or in a body's
    axes (its node's six, then the body's) each gradient column's coordinate likewise; the other kinds −1
    (csrc/controller_states.c controller_state_sensed)."""
    from latdyn.assembly.control import ANGLE, BODY_FRAME, OFFSET_POSITION, RATE

    hinges, nodes = set(int(j) for j in model.free_hinges), set(int(i) for i in model.free_nodes)

    def free(node: int, component: int) -> int:
        dof = int(model.node_dofs[node, component])
        return dof if node in nodes and dof < model.n_dofs else -1

    n = wiring.n_sensors
    sensor_dof, column_dof = [], np.full(int(wiring.sensor_column_start[n]), -1, np.int64)
    for i, (kind, index) in enumerate(zip(wiring.sensor_kind[:n], wiring.sensor_index[:n])):
        kind, index = int(kind), int(index)
        if kind in (ANGLE, RATE):   # a joint's angle, or its rate (its row of δv)
            dof = int(model.hinge_dofs[index])
            sensor_dof.append(dof if index in hinges and dof < model.n_dofs else -1)
        else:
            sensor_dof.append(free(index // 3, index % 3))
        if kind in (OFFSET_POSITION, BODY_FRAME):
            ends = [index // 3] + ([int(wiring.sensor_frame_node[i])] if kind == BODY_FRAME else [])
            start = int(wiring.sensor_column_start[i])
            column_dof[start:start + 6 * len(ends)] = [free(node, j) for node in ends for j in range(6)]
    return np.array(sensor_dof, np.int64), column_dof


def _native_library():
    """The runtime's C library (csrc/controller_states.c among its units)."""
    from latdyn.assembly.library import native_library

    return native_library()


def _sensor_derivatives(owner: ParameterDerivatives, probes: list, state, dq: np.ndarray,
                        moved: np.ndarray | None = None, dv: np.ndarray | None = None) -> np.ndarray:
    """δs (m, k) = D_q δq + D_v δv: the derivatives of the sensors ``probes`` (hinge angles and rates, guide slides
    and rates, point positions, displacements and velocities) at ``state`` along δq (n, k) and, for the rate
    sensors, the step end's δv (n, k) (:meth:`ParameterDerivatives._probe_derivatives` with
    :meth:`ParameterDerivatives._rates_by_parameter`: a dependent node's P δv + ∂(J v)/∂q δq), and where the state's
    time moves with p (``moved`` = δt, an event's and the steps after it) along the prescribed motions at fixed free
    coordinates, ∂s/∂t δt (a cable's length from a moving anchor; the time loop's ``_prescribed_in_time``, as a
    probe's row, the rates by the motions' accelerations). A joint that friction holds is no free coordinate: its
    angle's δθ is the held one (``owner.held``, as a probe's row reads it). ``dv`` None: no sensor reads a rate."""
    dx, dpi, dtheta = owner._by_parameter(dq, state)
    if owner.held is not None and np.any(owner.held):   # a stuck joint's angle: where the run stuck it (the
        dtheta = dtheta + owner.held                     # parameters' columns; TransientSensitivities.record)
    rates = None if dv is None else owner._rates_by_parameter(np.asarray(dv, float), dq, state)
    if moved is not None:
        owner._prescribed_in_time(state, np.asarray(moved, float), dx, dpi, dtheta, rates)
    return np.array([owner._probe_derivatives(probe, state, dx, dpi, dtheta, rates) for probe in probes],
                    float).reshape(len(probes), dq.shape[1])


def rates_taken_anew(kind: str, model) -> bool:
    """Whether the time loop takes the continuous controllers' states' rates f anew after an event of ``kind``
    ("latch"; "stop": a stop's, a stick's or a release's jump), ``model`` on the numbering after it: after a latch, or
    where nothing is left free, the integrator restarts (``integrator.start``, latdyn/timeloop/events.py
    ``latch_hinges``, ``_renumber``) and takes f at the jumped rates; after a stop, a stick or a release that leaves
    coordinates free it restarts the accelerations alone (``restart_accelerations``) and keeps f, the step's
    (:meth:`ControllerStates.restarted`)."""
    return kind == "latch" or model.n_dofs == 0


def reads_rates(probes: list) -> bool:
    """Whether any of the sensors ``probes`` reads a rate (a hinge's or a guide's rate, a point's velocity): its δs
    takes the step end's δv (:func:`_sensor_derivatives`)."""
    return any(p.quantity in ("rate", "velocity") for p in probes)


class SampledTerms:
    """Sampled controllers (``controllers.NAME.rate``) differentiated (docs/parameters.md, "Controllers").
    At each instant t_k = k/rate (fixed: a grid point, where the steps after an event land, δt = 0 there, so
    the samples are differentiated beside events as without), from the accepted state's sensors s and the
    states S_k (latdyn.timeloop.sampling),

        y_k = clip(f(t_k, s, S_k; p)),            S_{k+1} = S_k + g(t_k, s, S_k; p)/rate,
        δy_k = ∂f/∂s δs + ∂f/∂S δS_k + ∂f/∂p      (0 while y_k is clipped),
        δS_{k+1} = δS_k + (∂g/∂s δs + ∂g/∂S δS_k + ∂g/∂p)/rate,

    δs the sensors' derivative along δq at t_k (and δv for a rate sensor), the partial derivatives those of the
    controller's
    expressions (SymPy, as the code generator's). The held δy_k enters ∂r/∂p of every step until the
    next sample through the actuators that name the controller (τ = a y + b: −a δy on a hinge's or a
    guide's row, the point-load kernel's force for a δy of a load's component: :meth:`add`). The
    restart after the sample (the accelerations made consistent with the new outputs,
    M v̇ + r(q, v, t) = 0) is differentiated by the time loop's
    :meth:`latdyn.analyses.transient_sensitivities.TransientSensitivities.after_sample`.
    What this does not cover is refused (:meth:`refusal`)."""

    def __init__(self, terms: ControllerTerms):
        import sympy as sp

        from latdyn.assembly.control import actuator_gain

        self.terms, owner = terms, terms.owner
        scene, model = owner.scene, owner.model
        self.controllers = [c for c in scene.controllers.values() if c.sampled]
        self.index = {c.name: i for i, c in enumerate(self.controllers)}
        self.first = dict(zip(self.index, np.cumsum([0] + [len(c.states) for c in self.controllers]).tolist()))
        probes = {p.name: p for p in scene.output.probes}
        self.sensors = {c.name: [probes[r] for r in c.reads] for c in self.controllers}
        self.gradients = {}
        for c in self.controllers:
            reads, S = c.symbols[1:1 + len(c.reads)], c.symbols[1 + len(c.reads):]
            self.gradients[c.name] = sp.lambdify(c.symbols, [
                [[sp.diff(g, x) for x in reads] for g in c.state_exprs],
                [[sp.diff(g, x) for x in S] for g in c.state_exprs]], modules=["math", "numpy"])
        #: (kind 0 a hinge or guide / 1 a load, its index, the load's component, controller index, ∂τ/∂y)
        self.actuators = []
        for j, hinge in enumerate(model.hinges):
            for c in self.controllers:
                gain = actuator_gain(hinge.torque, c.name)
                if gain is not None:
                    self.actuators.append((0, j, 0, self.index[c.name], gain))
        for l, load in enumerate(owner.assembler.loads):
            for offset, components in ((0, load.force), (3, load.moment)):
                for p, law in enumerate(components or ()):
                    for c in self.controllers:
                        gain = actuator_gain(law, c.name)
                        if gain is not None:
                            self.actuators.append((1, l, offset + p, self.index[c.name], gain))
        #: the held δy (controllers, k) that :meth:`add` applies, set from what the run carries
        self.held = np.zeros((len(self.controllers), terms.k))

    @staticmethod
    def refusal(scene) -> str | None:
        """Why the sampled controllers of ``scene`` keep its transient sensitivities from being exact, or None."""
        from latdyn.assembly.control import actuator_gain

        sampled = [c for c in scene.controllers.values() if c.sampled]
        if not sampled:
            return None
        names = {c.name for c in sampled}
        probes = {p.name for p in scene.output.probes}
        for c in scene.controllers.values():
            if not c.sampled and names & set(c.reads):
                return (f"sensitivities of runs with a continuous controller that reads a sampled one ({c.name}) are "
                        "not computed yet")
            if c.sampled and not set(c.reads) <= probes:
                return (f"sensitivities through the sampled controller {c.name}, which reads another controller or "
                        "an input, are not computed yet; expected sampled controllers that read probes and their "
                        "own states")
        laws = [(f"beams.{beam}.{which}.hinge.{what}", getattr(hinge, what, None))
                for beam, which, hinge in scene.hinges for what in ("stiffness", "damping", "angle")]
        laws += [(f"bodies.{name}.guide.{what}", getattr(body.guide, what, None)) for name, body in scene.bodies.items()
                 if body.guide is not None for what in ("stiffness", "damping", "position")]
        laws += [(f"bodies.{name}.motion", law) for name, body in scene.bodies.items()
                 for law in [*(getattr(body, "translation", None) or ()), getattr(body, "rotation_angle", None)]]
        actuated = [(f"beams.{beam}.{which}.hinge.torque", hinge.torque) for beam, which, hinge in scene.hinges]
        actuated += [(f"bodies.{name}.guide.force", body.guide.force) for name, body in scene.bodies.items()
                     if body.guide is not None]
        actuated += [(f"loads[{i}]", law) for i, load in enumerate(scene.loads)
                     for law in [*(load.force or ()), *(load.moment or ())]]
        for key, law in laws + actuated:
            named = names & set(getattr(law, "input_names", ()))
            if named and ((key, law) in laws or len(named) > 1 or actuator_gain(law, next(iter(named))) is None):
                return (f"a sampled controller ({sorted(named)[0]}) named at {key}: sensitivities are computed where "
                        "one sampled controller y drives a hinge torque, a guide force or a load component a*y + b "
                        "(a constant)")
        return None

    def _rows(self, c) -> slice:
        return slice(self.first[c.name], self.first[c.name] + len(c.states))

    def start(self, state, k: int, dq: np.ndarray | None = None, dv: np.ndarray | None = None) -> dict:
        """What the run carries from the sample at t = 0 (the states from ``initial``): its sensors moved by the
        start's δs_0 = D_q δq_0 + D_v δv_0, as a later sample's (:meth:`sample`; ``dq`` = δq_0 = δX of geometry
        parameters, ``dv`` = δv_0 of ``initial_velocity`` parameters and the rigid spin's ω × δX; None: 0)."""
        initial = np.array([c.initial[s] for c in self.controllers for s in c.states], float)
        n = self.terms.owner.model.n_dofs
        carried = {"sampled_dy": np.zeros((len(self.controllers), k)), "sampled_dS": np.zeros((len(initial), k)),
                   "sampled_S": initial, "dv": np.zeros((n, k)) if dv is None else dv}
        return self.sample(carried, state, np.zeros((n, k)) if dq is None else dq, [c.name for c in self.controllers])

    def sample(self, carried: dict, state, dq: np.ndarray, due: list) -> dict:
        """δy_k, δS_{k+1} of the controllers ``due`` at ``state`` (class docstring), their S_{k+1} as the
        sample left them, and the held δy set for ∂r/∂p."""
        dy, dS, S = carried["sampled_dy"].copy(), carried["sampled_dS"].copy(), carried["sampled_S"].copy()
        values = dict(zip(self.terms.sensors.names, self.terms.sensors.values(state)))
        states = self.terms.owner.scene.controller_states
        for c in self.controllers:
            if c.name not in due:
                continue
            rows, i = self._rows(c), self.index[c.name]
            inside, y_s, y_S, y_p, g_s, g_S, g_p = self.partials(c, state.t, values, S[rows])
            rated = reads_rates(self.sensors[c.name])   # δs = D_q δq + D_v δv at the sample's state
            ds = _sensor_derivatives(self.terms.owner, self.sensors[c.name], state, dq, None,
                                     carried.get("dv", np.zeros_like(dq)) if rated else None)
            dy[i] = y_s @ ds + y_S @ dS[rows] + y_p if inside else 0.0
            dS[rows] = dS[rows] + (g_s @ ds + g_S @ dS[rows] + g_p) / c.rate
            S[rows] = [states[f"{c.name}.{name}"] for name in c.states]
        self.held = dy
        return {"sampled_dy": dy, "sampled_dS": dS, "sampled_S": S}

    def partials(self, c, t: float, values: dict, S: np.ndarray) -> tuple:
        """(inside its limits, ∂f/∂s (m,), ∂f/∂S (p,), ∂f/∂p (k,), ∂g/∂s (p, m), ∂g/∂S (p, p), ∂g/∂p (p, k)) of the
        sampled controller ``c`` at the instant ``t``, its sensors' ``values`` (by name) and states ``S`` before the
        sample (class docstring)."""
        arguments = [t, *[values[r] for r in c.reads], *S]
        raw = float(c.functions()[0](*arguments))
        g_s, g_S = self.gradients[c.name](*arguments)
        p, m = len(c.states), len(c.reads)
        gradient = c.output_gradient(*arguments)
        y_s, y_S = gradient[:m], gradient[m:]
        g_s, g_S = np.array(g_s, float).reshape(p, m), np.array(g_S, float).reshape(p, p)
        y_p, g_p = np.zeros(self.terms.k), np.zeros((p, self.terms.k))
        for column, law in self.terms.partials.get(c.name, {}).items():
            y_p[column] = float(law(*arguments))
        for column, laws in self.terms.rate_partials.get(c.name, {}).items():
            for j, name in enumerate(c.states):
                if name in laws:
                    g_p[j, column] = float(laws[name](*arguments))
        inside = c.limits is None or c.limits[0] < raw < c.limits[1]
        return inside, y_s, y_S, y_p, g_s, g_S, g_p

    def add(self, state, total: np.ndarray) -> None:
        """Add the held outputs' ∂r/∂p (class docstring) into ``total`` (all coordinates, k columns)."""
        model, owner = self.terms.model, self.terms.owner
        loads: dict[int, np.ndarray] = {}
        for kind, index, component, i, gain in self.actuators:
            moved = gain * self.held[i]
            if not np.any(moved):
                continue
            if kind == 0:   # a hinge torque or guide force τ = a y + b: its row f = … − τ
                total[model.hinge_dofs[index]] -= moved
            else:
                loads.setdefault(index, np.zeros((6, self.terms.k)))[component] += moved
        for index, values in loads.items():
            columns = [c for c in range(self.terms.k) if np.any(values[:, c])]
            nodes, forces = owner._load_forces(state, [index] * len(columns), values[:, columns].T)
            total[model.node_dofs[nodes[0]][:, None], np.array(columns)[None, :]] += forces.T


def reduced_columns(assembler, state, total: np.ndarray) -> np.ndarray:
    """Pᵀ ``total`` ((n_total or n_assembled …, k) or a vector on all coordinates) on the minimum coordinates of a
    model with rigid links or guides at ``state``: ``latdyn_linked_reduce_columns`` (csrc/linked_matrices.c), the
    residual's reduction of the compiled step (csrc/links.c reduce_links) column by column, with J of ``state``
    (its dependent nodes completed here) — the call the sensitivities' step in the loop of steps makes."""
    model = assembler.model
    native = assembler.native()
    assembler.complete_links(state)
    vector = total.ndim == 1
    columns = np.ascontiguousarray(np.asarray(total, np.float64)[:model.n_assembled].reshape(model.n_assembled, -1))
    k = columns.shape[1]
    out = np.empty((model.n_dofs, k))
    if out.size:
        native.library.latdyn_linked_reduce_columns(native.model_ref, columns.ctypes.data, k, out.ctypes.data)
    return out[:, 0] if vector else out
