"""The parameters' part of an event's impulse weight derivative, (∂K/∂p) w, generated (docs/parameters.md "The impulse
weight's derivative"; latdyn/analyses/transient_sensitivities.py ``_stiffness_derivative``).

At an event the forward sensitivities need δ(W w) = H δq + (∂W/∂p) w, W = M + s K, and the adjoint its transpose.
(∂K/∂p) w is ∂(K w)/∂p, K the evaluation's (∂r/∂q without the elements' gravity tangent): the derivative along w of
the static ∂r/∂p wherever that holds every term K differentiates (not a cable's masses' weight, below). Each use of a parameter whose ∂r/∂p comes from a generated kernel with the derivative values in the
parameter's place has the same kernel's stiffness with them there, so (∂K/∂p) w is that stiffness along w:

* section values: ``beam_stiffness_D_section`` (:meth:`ParameterDerivatives.add_section_stiffness_along`, before);
* a hinge's (or a guide's) spring, damper and torque laws: ∂r/∂p is ``hinge_force`` fed the derivative law's
  value in the law's slot (:meth:`ParameterDerivatives._hinge_force`); its K along the angle, ∂f/∂θ
  (``hinge_stiffness``), fed the derivative law's value, ∂/∂θ and ∂/∂θ̇ there, times w_j; the rest angle's ∂f/∂θ_r
  = −k (θ = 0, θ_r = 1 in the kernel) moves along θ with the stiffness law's own ∂k/∂θ: the kernel's ∂f/∂θ there
  with k's slot (0, ∂k/∂θ, ∂k/∂θ̇);
* a point load's components: ∂r/∂p is ``point_load`` at the derivative values (linear in the values); its K along w,
  ``point_load_stiffness_D_q``'s ``load_stiffness_along`` at the same values;
* a joint body's mass and centre of mass: ∂r/∂p is ``joint_body``'s weight at (∂m/∂p, c) (linear in m) or
  ``joint_body_D_com`` along ∂c/∂p (the weight's moment (T c) × m g is linear in c, its force free of the turns), so
  its K along w, the weight's stiffness ``joint_body_gravity_stiffness_D_q``'s ``body_gravity_stiffness_along``, at
  (∂m/∂p, c) or (m, ∂c/∂p); the inertia's static ∂r/∂p is 0, and so is its (∂K/∂p) w;
* a cable's EA and damping: the taut law is linear in (EA, c) at a fixed rest length
  (latdyn/analyses/cable_sensitivities.py), so ``cable_stiffness_D_q``'s ``cable_stiffness_along`` at (∂EA/∂p,
  ∂c/∂p) for the elements taut at the state;
* a cable's rest length: K_c is not linear in L0 (N_el = EA (ℓ/L0 − 1)), so its own kernel,
  ``cable_stiffness_D_rest_length``'s ∂(K_c w)/∂L0 (codegen/joints.py, beside ``cable_stiffness_D_q``), times the
  element's share of ∂L0/∂p;
* a cable's ρA and rest length move its lumped point masses (½ ρA L0/elements at each end of each element, at the
  end's offset from its node): their weight's stiffness in K, ``joint_body_gravity_stiffness_D_q`` at the masses'
  ∂m/∂p (:func:`_cable_masses`). The static ∂r/∂p holds no cable weight (the cables' part adds the masses' forces
  with the inertia forces alone), so the difference along w this replaced left it out: ρA's column was 0, a rest
  length's 0.05–0.3 off (tests/test_weight_derivative_parameters2.py);
* a compliant stop's stiffness, exponent and damping: F = ⟨δ⟩ⁿ ⟨k ± c θ̇⟩ is not linear in n, nor in (k, c) across
  its clip, so its own kernel, ``contact_stiffness_D_law``'s ∂(∂f_contact/∂θ)/∂(k, n, c) at the joint's (θ, θ̇),
  times the law's derivative and w_j (:func:`_stops`);
* friction's laws: its force depends on θ̇ alone, so its part of K is 0, and its (∂K/∂p) w too;
* geometry parameters (a body's ``at``, a beam's free end, an end's offset, a ``y_axis``): ∂r/∂p is
  Σ_e ∂F_e/∂X · V_e(q), the element's internal force along its reference variation at the state
  (latdyn/analyses/geometry_sensitivities.py), so along w the new kernel ``beam_stiffness_D_reference``'s
  ∂(K_e w_e)/∂X · V_e (codegen/derivation.py: the forward-mode program of the lowered product K v seeded with the
  reference data's first variation, as ``beam_internal_force_D_reference``'s), which holds the variation's turn with
  the end too (:func:`_geometry`); a load at a moved offset, affine in its offset, by ``point_load_stiffness_D_q`` at
  the moved offset less at none. A moved hinge axis too: its frame's turn T_j θ J(θa) δa moves with θ along w, and
  the kernel's product holds that move — 40bf44a took it for not generated and differenced the axis's column;
  measured since, the generated column is 4.7e-13 and 1.5e-13 off Richardson differences on the knee and the
  latching boom where the difference was 1.1e-9 and 6e-10 (tests/test_sensitivities_time_shift_exact.py);
* initial velocities: no ∂r/∂p;
* the event's time shift δt_e (an impulse or restart taken at t_e + δt_e adds ∂r/∂t δt_e to ∂r/∂p): along w
  ∂(∂r/∂t)/∂q w δt_e (:func:`time_stiffness_along`) — the loads' and hinges' laws in t through the kernels above with
  their rates in t in the parameter's place; a reel (a cable's rest length L0(t)), whose ∂r/∂t is ∂F/∂L0 · share ·
  L0′(t), by ``cable_stiffness_D_rest_length``'s ∂(K_c w)/∂L0 · share · L0′(t) (:func:`_reels_along`); a continuous
  controller's output naming t, whose ∂r/∂t is its ∂y/∂t through its actuators, by :func:`controller_parameter_along`
  of that one column t (below); a prescribed motion (since prestime; 0d1fc61 differenced every parameter with it),
  whose static ∂r/∂t is K_·p q̇_p + C_·p q̈_p, by the H parts of latdyn/analyses/weight_derivative.py with their
  direction on every coordinate, ∂(K u)/∂q w at u = q̇_p, and a damped cable's ∂(K_c w)/∂v a at a = q̈_p
  (:func:`_prescribed_along`; no new kernel) — not where a continuous controller's coupling has an entry in a
  prescribed coordinate's column (:func:`_prescribed_generated`: a sensor on a prescribed body; that entry moves with
  the output's second derivative by a free and a prescribed read, not taken: the difference); with rigid links or
  guides through the reduction, the dependent nodes hanging from the prescribed coordinates (:func:`linked_prescribed_along`,
  since linkedheld; the difference before held the elements' gravity tangent's move, which W's K does not), not
  beside a continuous controller's coupling, a load a controller drives or a damped cable
  (:func:`_linked_prescribed_generated`: the difference).

Beside continuous or sampled controllers and angles friction holds, ∂r/∂p holds their terms too (the controllers'
outputs' explicit ∂y/∂p, chained, held and states' terms; K's columns of the held angles times their δθ): the
parameters' own parts are generated as above, and those terms' derivative along w is taken apart
(``TransientSensitivities._terms_beside_stiffness_along``; a parameter a controller's output alone uses has that part
only). The continuous controllers' is exact (:func:`controller_parameter_along`): SymPy's mixed second derivatives of
each output and of its parameters' partials by the reads that move along q (lambdified once per expression in a
process), times the sensors' generated gradients, through the chain of controllers reading controllers and the held
δS of their states; a hinge actuator's row −a δ(dy/dp), a load's ``point_load`` at a δ(dy/dp) and
``point_load_stiffness_D_q`` at a dy/dp. Exact too since ctrlhand:

* a sampled controller's held outputs (:func:`sampled_held_along`): a held δy is a constant of the step (the
  sample's, carried by the forward method), so a hinge's row −a δy does not move along w, and a load component a δy
  turns with its node and frame, ``point_load_stiffness_D_q`` at the values a δy;
* a controller reading a free joint's torque or force whose laws a parameter moves: ∂F/∂p = −∂f/∂p moves along the
  joint's own angle as the laws' part of (∂K/∂p) w does, the ``hinge_force`` stiffness with the derivative law in the
  law's slot and ``contact_stiffness_D_law`` (:func:`_moved_forces_along`), and the output's gradient by it
  with SymPy's mixed second derivatives as the other reads; since ctrlexact likewise a cable's tension whose EA,
  damping or rest length a parameter moves and an element's section force whose section values a parameter moves,
  since shearsec both by generated second derivatives (``cable_tension_D_q_D_section``'s ∂²N/∂σ∂q,
  ``beam_section_forces_D_q_D_section``'s ∂((∂S/∂q) w)/∂σ, contracted with the parameter's δσ), a shear-flexible
  element's too (its axial force reads EI and 1/GA through μ = 1/(1 + 12 EI/(GA L²))) — before, the difference
  below, 6.0e-11 – 1.1e-10 of each column off Richardson differences of the block at the 3D boom's latch, 2.4e-12 –
  3.8e-14 now; at the shear-flexible wheel's stops, pd reading
  the root element's M_z and axial force, by EI and GA 1.1e-13 – 2.4e-11 and 9.4e-12 – 6.1e-11 where the difference was
  1.4e-11 – 1.0e-9 and 7.0e-10 – 8.3e-8 (tests/test_weight_derivative_controllers_sensed.py);
* the angles friction holds (:func:`held_angles_along`): a held angle is no free coordinate, so its K column times δθ_j
  moves along w as ∂(K e_j)/∂q w, the generated ``beam_stiffness_D_q`` at the unit on the held slot times w_e and the
  couplings' row of the held angle from the controllers' second derivatives (``_controller_curvatures``), with W's K:
  the elements' gravity tangent is not in it (csrc/evaluate.c holds it in the inertia tangent), where the difference
  of the static K's columns this replaced held it (6.2e-6 – 1.1e-5 of the block off at the 3D panel's sticks, and the
  whole runs' Fc 7.7e-8 and 2.3e-7 off Richardson differences where they are 1.8e-8 and 2.2e-8 now; the difference
  that remains below takes W's K's columns too, ``TransientSensitivities._held_forces`` without ``element_gravity``).

Still a central difference of those terms along w (step WEIGHT_STEP ℓ/|w|_∞): a controller reading a section force
or a point a geometry parameter moves (no kernel gives ∂²s/∂X∂q), or a stuck or locked joint's force
(:func:`_sensed_forces_generated`);
a controller whose output's second derivatives along q are not generated
(``weight_derivative._exact_controllers``: a free joint's force whose law's slope does not parse back as a law, a
variant generated before the sensors' second-derivative kernels, an output whose second derivatives are not
functions, or a controller reading those); a held angle whose column a load's controller's coupling or such a
controller's reaches.

With rigid links or guides, K_red = Pᵀ K_all P + ∂Pᵀ/∂q · r_all: the generated parts are taken along P w on
the assembled coordinates (:func:`stiffness_along_all`; a rigid link's section ρA through its body's weight
stiffness, :func:`_link_masses`) and reduced, and the geometric term of each column of the static ∂r_all/∂p times w
added exactly (``TransientSensitivities._linked_stiffness_along``). Beside controllers the same, their terms of
∂r_all/∂p moved along u = P w with every assembled rate held (:func:`linked_controller_parameter_along`: the unlinked
:func:`controller_parameter_along`, sampled controllers' held outputs and controllers' states included, its sensors'
generated gradients by the assembled coordinates, a dependent node's too), projected by Pᵀ, their part of ∂r_all/∂p
in the geometric term, and an event's time shift where :func:`time_shift_generated` (:func:`time_shift_along`:
:func:`time_stiffness_along` at ``full`` = P w and a prescribed motion's part through the reduction,
:func:`linked_prescribed_along`, since linkedheld; the adjoint's coefficient of δt_e by the same decision and path,
since shiftone) (linkedparam; 0d1fc61 differenced the whole static ∂r/∂p there, tests/
test_weight_derivative_linked_parameters.py, tests/test_weight_derivative_linked_held.py). Not generated, the whole static ∂r/∂p
differenced along w by the caller (:func:`exact_parameters` False): a geometry parameter in a variant generated
before ``beam_stiffness_D_reference`` or, beside rigid links or guides, one that shifts a subtree on a part that turns
or moves a rigid link's vector (:func:`_geometry_generated`; one that translates the linked subtrees rigidly is
generated since diffgen), a hinge law that names an input or a
controller (its value is the runtime's; a controller's output read at the moved states, ``TransientSensitivities._controller_outputs_at``),
every parameter of a run whose state an event moved in time through a prescribed motion beside a continuous
controller's coupling entry in a prescribed column, or a controller's output in t whose second derivatives along q are
not generated (:func:`time_generated`; a reel and the other controllers in t are generated since timehand, 40bf44a
differenced them; prescribed motions otherwise since prestime), and with rigid links or guides every parameter beside
held angles (refused: a joint that sticks on such a model, ``TransientSensitivities._refuse_what_a_held_angle_moves``;
the difference is for none), a time shift not generated, a controller reading a joint's force whose laws a parameter moves or a
controller outside ``_exact_controllers`` (their terms through the reduction are not separated; a parameter moving the
links' own data, a geometry parameter, keeps it too). That difference
moves the configuration with every assembled rate held, the dependent nodes' too
(``TransientSensitivities._advanced_at_held_rates``: K_red is ∂r/∂q at the assembled rates held; completed at each
moved configuration, a gain of a dependent node's velocity read took Pᵀ (∂C_all/∂p) ∂(J v)/∂q w with it, 2.7e-4 off
Richardson differences of whole runs on the gimbal, tests/test_sensitivities_linked_controller_latch.py).

The weight's move along the rates, ∂(K w)/∂v δv, is not a parameter's part: latdyn/analyses/weight_derivative.py
"Along the rates" (the hinges' ∂²f/∂θ∂θ̇, controllers' couplings and loads of angles and rates, damped cables).
"""
from __future__ import annotations

import numpy as np

from latdyn.analyses.geometry_sensitivities import GEOMETRY_KEY, WIDTH
from latdyn.analyses.parameter_keys import BODY_KEY, CABLE_KEY, INITIAL_VELOCITY_KEY, SECTION_KEY, joint_law
from latdyn.analyses.weight_derivative import _scattered
from latdyn.assembly.native_model import NO_CONTACT

__all__ = ["controller_parameter_along", "exact_parameters", "held_angles_along", "linked_controller_parameter_along",
           "sampled_held_along", "stiffness_along", "stiffness_along_all", "time_generated", "time_shift_along",
           "time_shift_generated", "time_stiffness_along"]


def _generated_use(owner, key: str, laws: dict) -> bool:
    """Whether a use ``key`` of the parameters (``laws``: column → derivative law) has its (∂K/∂p) w generated
    (module docstring)."""
    if SECTION_KEY.match(key) or INITIAL_VELOCITY_KEY.match(key) or BODY_KEY.match(key):
        return True
    if CABLE_KEY.match(key) or joint_law(key) is not None:   # EA, damping, rest length, ρA; stops, friction
        return True
    if GEOMETRY_KEY.match(key):
        return _geometry_generated(owner, laws)
    load, hinge = owner._key_kinds(key)
    if load:
        return True
    if hinge:
        if hinge["law"] == "rest_angle":
            j = owner.model.hinge_index(hinge["beam"], hinge["end"])
            return _slopes_known(owner.model.hinges[j].stiffness)
        return all(_slopes_known(law) for law in laws.values())
    return False


def _geometry_generated(owner, laws: dict) -> bool:
    """Whether a geometry use of the parameters ``laws`` (column → derivative law) has its (∂K/∂p) w generated
    (:func:`_geometry`): the variant holds ``beam_stiffness_D_reference`` (a hinge axis's key too: its nodal frame's
    turn T_j θ J(θa) δa moving with θ is in the kernel's second variation, measured against Richardson), and with
    rigid links or guides none of its parameters shifts a subtree on a part that turns or moves a rigid link's vector
    (``ReferenceGeometry.turning``, ``link_moves``). The parameters taken there translate each linked subtree rigidly
    or not at all (geometry_sensitivities.py ``_linked_refusal``): their static ∂r_all/∂p is the elements' reference
    forces and the loads' moved arms alone, whose move along u = P w is :func:`_geometry`'s, and the reduction's
    geometric term of it is ``TransientSensitivities._linked_stiffness_along``'s; a turning shift's K d + C δv + M δa
    + d × F_S and a link's moved joint body along w are not generated (the caller's difference)."""
    if "beam_stiffness_D_reference" not in owner.kernels.info:
        return False
    if owner.model.links is None:
        return True
    geometry = owner.geometry
    differenced = ({column for _, column, _, _ in geometry.turning}
                   | {column for _, _, column, _ in geometry.link_moves})
    return not differenced & set(laws)


def _slopes_known(law) -> bool:
    """Whether a hinge law's (value, ∂/∂θ, ∂/∂θ̇) are the law's own at the state: it names no input or controller
    (their values are the runtime's), and it has ``d_theta`` and ``d_rate`` or reads neither θ nor θ̇ (a law's rate
    in t alone, :class:`latdyn.analyses.transient_sensitivities._TimeRate`)."""
    if getattr(law, "input_names", ()):
        return False
    reads = getattr(law, "depends_on", ())
    return hasattr(law, "d_theta") or not ({"theta", "theta_dot"} & set(reads))


def exact_parameters(owner) -> np.ndarray:
    """(k,) bool: the parameters whose every use has its (∂K/∂p) w generated (module docstring; beside controllers
    and held angles the caller adds their terms' difference); none with rigid links or guides where the parameters'
    parts are not formed through the reduction (:func:`_reduction_generated`), nor where the state is moved in time
    and that part is not generated (:func:`time_shift_generated`; checked per call: the time shift and held angles
    change at each event, the controllers' wiring at a latch)."""
    shifted = owner.time_shift is not None and owner.explicit_time is not None and np.any(owner.time_shift)
    if not _reduction_generated(owner) or (shifted and not time_shift_generated(owner)):
        return np.zeros(len(owner.names), bool)
    found = owner.__dict__.get("_parameter_stiffness_exact")
    if found is None:
        found = np.ones(len(owner.names), bool)
        for key, laws in owner.derivatives.items():
            if not _generated_use(owner, key, laws):
                found[list(laws)] = False
        owner._parameter_stiffness_exact = found
    return found


def _linked_controllers_generated(owner) -> bool:
    """Whether the controllers' terms of ∂r_all/∂p move along u = P w exactly on a model with rigid links or guides
    (:func:`linked_controller_parameter_along`): no controllers, or every continuous controller's second derivatives
    along q generated (:func:`latdyn.analyses.weight_derivative._exact_controllers`) and no joint's force read whose
    laws a parameter moves. Sampled controllers' held outputs are formed too (:func:`sampled_held_along`)."""
    from latdyn.analyses.weight_derivative import _exact_controllers

    terms = owner.controllers
    if terms is None:
        return True
    return not any(terms.forces_read.values()) and all(_exact_controllers(owner.assembler))


def _reduction_generated(owner) -> bool:
    """Whether the parameters' parts move through a rigid links' or guides' reduction exactly: no rigid links or
    guides, or the controllers' terms formed through it (:func:`_linked_controllers_generated`) and no held angle (its
    column through the reduction is not formed: a stick there is refused). Checked per call (held angles change at
    each event)."""
    return owner.model.links is None or (_linked_controllers_generated(owner)
                                         and not (owner.held is not None and np.any(owner.held)))


def time_shift_generated(owner) -> bool:
    """Whether an event's time shift's part of (∂K/∂p) w, ∂(∂r/∂t)/∂q w δt_e, is generated (:func:`time_shift_along`):
    the laws' rates in t and the prescribed motions' part are (:func:`time_generated`; with rigid links or guides the
    motions' through the reduction, :func:`_linked_prescribed_generated`) and so are the reduction's terms
    (:func:`_reduction_generated`). The one decision of the forward method (:func:`exact_parameters`, which its
    ``TransientSensitivities._stiffness_derivative`` follows) and of the adjoint (latdyn/analyses/adjoint_time.py
    ``shift_stiffness_along``); where it is False both take the central difference along w."""
    return time_generated(owner) and _reduction_generated(owner)


def time_generated(owner) -> bool:
    """Whether the laws' and motions' terms of the event's time shift's part, ∂(∂r/∂t)/∂q w δt_e, are generated
    (:func:`time_stiffness_along`; the whole decision, with the reduction's terms, is :func:`time_shift_generated`): the
    scene's laws in t are loads' and hinges' (or guides') whose rates in t have their slopes (:func:`_generated_use`
    of :class:`latdyn.analyses.transient_sensitivities.ExplicitTime`'s laws), reels (a cable's rest length L0(t),
    :func:`_reels_along`) and continuous controllers' outputs naming t whose output's second derivatives along q are
    generated (:func:`_controllers_in_time_generated`); prescribed motions on a model without rigid links or guides
    and without a continuous controller's coupling entry in a prescribed column (:func:`_prescribed_generated`,
    :func:`_prescribed_along`). The
    laws' and motions' part found once, the controllers' and couplings' per call (their
    wiring is renumbered at a latch; :func:`latdyn.analyses.weight_derivative._exact_controllers` keeps it per
    wiring)."""
    found = owner.__dict__.get("_time_stiffness_exact")
    if found is None:
        timed = owner.explicit_time
        laws = timed.laws
        found = all(_generated_use(laws, key, by) for key, by in laws.derivatives.items())
        owner._time_stiffness_exact = found
    if owner.model.links is not None and owner.explicit_time.prescribed:
        return found and _controllers_in_time_generated(owner) and _linked_prescribed_generated(owner)
    return found and _controllers_in_time_generated(owner) and _prescribed_generated(owner)


def _prescribed_generated(owner) -> bool:
    """Whether the prescribed motions' part of the time shift's, ∂(K_·p q̇_p + C_·p q̈_p)/∂q w, is generated
    (:func:`_prescribed_along`): no prescribed motion, or no continuous controller's coupling entry in a prescribed
    coordinate's column (a sensor reading a prescribed body's place or turn: its entry moves along w with the output's
    second derivatives by a free and a prescribed read, which
    :func:`latdyn.analyses.weight_derivative._coupling_part` does not take: the difference; a coupling on free
    columns alone is no part of K_·p). Checked per call (the couplings are renumbered at a latch)."""
    if not owner.explicit_time.prescribed:
        return True
    from latdyn.analyses.prescribed_rates import coupling_entries

    entries = coupling_entries(owner.assembler)
    if entries is None:
        return True
    return not np.any(owner.explicit_time.motions.mask()[entries[len(entries) // 2:]])


def _prescribed_along(owner, state, w: np.ndarray, total: np.ndarray) -> None:
    """The prescribed motions' part of ∂(∂r/∂t)/∂q w into ``total`` (n_total + 1,), where :func:`time_generated`: the
    static ∂r/∂t through them is K_·p q̇_p + C_·p q̈_p (latdyn/analyses/prescribed_rates.py, csrc/prescribed_rates.c
    without the inertia), q̇_p, q̈_p the motion laws' rates at t on the prescribed coordinates (``PrescribedRates.rates``)
    and fixed along w (the prescribed coordinates do not move with the free ones), so along w it is ∂(K u)/∂q w at
    u = q̇_p plus ∂(C a)/∂q w = ∂(K w)/∂v a at a = q̈_p: the H parts of latdyn/analyses/weight_derivative.py with
    their direction ``full`` on every coordinate — the elements' ``beam_stiffness_D_q`` and the joint bodies'
    weight stiffness (:func:`~latdyn.analyses.weight_derivative._generated`; a prescribed body's own block is on its
    own rows alone, no free row), the point loads' ``point_load_stiffness_D_q`` (a follower load turning with a
    prescribed frame, :func:`~latdyn.analyses.weight_derivative._load_part`), the taut cable elements'
    ``cable_stiffness_D_q`` (:func:`~latdyn.analyses.weight_derivative._cable_part`) at u, times w; and the damped
    cables' K_c(a) w − K_c(0) w (:func:`~latdyn.analyses.weight_derivative._cable_rates_product`: K_c affine in the
    rates). A hinge's K_jj and C_jj are of its own angle and rate: a prescribed hinge's are on its own (reaction) row,
    a free hinge's move with no prescribed coordinate. No new kernel."""
    from latdyn.analyses.weight_derivative import _cable_part, _cable_rates_product, _generated, _load_part, _taut_cables

    model, assembler = owner.model, owner.assembler
    rates = owner.explicit_time.motions.rates(float(state.t))
    full = np.zeros(model.n_total + 1)
    full[:model.n_dofs] = w
    u = rates[0]
    if np.any(u):
        for rows, cols, values in (_generated(assembler, state, None, 1.0, False, full=u),
                                   _load_part(assembler, state, None, 1.0, full=u),
                                   _cable_part(assembler, state, None, 1.0, full=u)):
            np.add.at(total, rows, values * full[cols])
    if np.any(rates[1]):
        taut = _taut_cables(assembler, state)
        if taut is not None:
            total += _cable_rates_product(assembler, taut, full, rates[1][:, None])[:, 0]


def _linked_prescribed_generated(owner) -> bool:
    """Whether :func:`linked_prescribed_along` forms the prescribed motions' part of the time shift on a model with
    rigid links or guides: no continuous controller's coupling entry (a sensor on a node the motion carries moves
    its entry with the output's second derivatives by reads the motion and w move, and a rate sensor's entry is of
    C), no load a controller drives, and no damped cable (its K moves with the rates, which the reduction completes
    for the dependent nodes in ∂r/∂t and holds in K): the static C then has no column the motion moves (a hinge's
    damper is on its own angle, a free coordinate or a prescribed one's reaction row), so ∂r_all/∂t is K δq_all
    there and the dependent rates' move in time, ∂(J v)/∂q_p q̇_p + J_·p q̈_p, meets no block. Checked per call (the
    couplings are renumbered at a latch)."""
    assembler = owner.assembler
    control = assembler.control
    if len(np.asarray(getattr(control, "coupling_rows", np.zeros(0)))) or np.any(
            np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64))) == 1):
        return False
    cables = owner.model.cables
    return cables is None or not np.any(np.asarray(cables.damping) != 0.0)


def linked_prescribed_along(owner, state, w: np.ndarray, full: np.ndarray) -> tuple:
    """The prescribed motions' part of ∂(∂r/∂t)/∂q w on a model with rigid links or guides, exactly, where
    :func:`_linked_prescribed_generated`: (its part on the assembled coordinates (n_total + 1,), which the caller
    reduces by Pᵀ; its part on the free coordinates (n,)). The static ∂r_min/∂t through the motions is
    (latdyn/analyses/prescribed_rates.py, csrc/linked_prescribed_rates.c)

        ∂r_min/∂t = Pᵀ K_all u + ∂Pᵀ/∂q_p[q̇_p] · r_all,   u = δq_all in time: q̇_p, and J_·p q̇_p on the dependent rows

    (C_all has no column u or the dependent rates' move reaches: :func:`_linked_prescribed_generated`). Along w, the
    free coordinates moving by w and the dependent ones by U = P w (``full``), every rate held (the evaluation's K,
    ``TransientSensitivities._advanced_at_held_rates``), the mixed derivative of r_min(q_f ⊕ ε w, q_p(t + τ)) in the
    two scalars ε, τ:

        Pᵀ ∂(K_all u)/∂q_all U                     the generated H parts at the direction u (the unlinked
                                                   :func:`_prescribed_along`'s, on every assembled coordinate)
      + Pᵀ K_all ∂(J_·p q̇_p)/∂q w                 the dependent nodes' move in time moved along w (the compiled links'
                                                   rates' derivative at the prescribed rates,
                                                   ``weight_derivative._rates_jacobian_derivative``)
      + ∂(Pᵀ ∂r_all/∂t)/∂q w at fixed ∂r_all/∂t    (the caller's geometric term of the static ∂r_all/∂p, which holds it)
      + ∂Pᵀ/∂q_p[q̇_p] · ∂r_all/∂q U               r_all moved along w (``latdyn_linked_geometric_product`` on the
                                                   prescribed columns)
      + ∂/∂q(∂Pᵀ/∂q_p[q̇_p])[w] · r_all            the links' second derivatives (``linked_geometric_rate_in_time`` of
                                                   the static r_all; the mixed derivative of Pᵀ y taken in either
                                                   order, the two scalars moving different coordinates).

    K_all in the first two is the impulse weight's (``PrescribedRates.blocks_times`` without the elements' gravity
    tangent, which W's K does not hold, as the unlinked :func:`_prescribed_along`'s); ∂r_all/∂q in the fourth the
    static residual's, r_all's own. The central difference of the static ∂r/∂p along w this replaced held the
    elements' gravity tangent's move in both (the static ∂r/∂t is K u with it): on a cart latching on a guide on a
    slewing base under gravity, carrying a flexible boom, 7e-7 of the block off this at a turned state (6.7e-12
    without gravity), and the whole runs' sensitivities 1.8e-7 (k), 1.1e-7 (m), 1.0e-7 (F) off Richardson
    differences where they are 3.1e-8, 6.2e-9, 3.5e-9 now (tests/test_weight_derivative_linked_held.py). Before, that
    difference took two evaluations of the static ∂r/∂p at each weighing."""
    import ctypes

    from latdyn.analyses.weight_derivative import (_cable_part, _generated, _load_part, _rates_jacobian_derivative,
                                                   linked_geometric_rate_in_time)

    model, assembler = owner.model, owner.assembler
    motions = owner.explicit_time.motions
    size, n, n_asm = model.n_total + 1, model.n_dofs, model.n_assembled
    rates = motions.rates(float(state.t))
    along = np.zeros(size)
    along[:n_asm] = full[:n_asm]
    _, _, moves, (by_w, residual) = motions.linked_moves(state, inertia=False, along=along)   # one static evaluation
    u = moves[0]
    assembled = np.zeros(size)
    for rows, cols, values in (_generated(assembler, state, None, 1.0, False, full=u),
                               _load_part(assembler, state, None, 1.0, full=u),
                               _cable_part(assembler, state, None, 1.0, full=u)):
        np.add.at(assembled, rows, values * full[cols])
    dependent = model.node_dofs[model.links.dependent].ravel()
    moved_in_time = np.zeros(size)
    moved_in_time[dependent] = _rates_jacobian_derivative(assembler, state, np.zeros(n), prescribed=rates[0]) @ w
    moved_in_time[model.n_total] = 0.0
    on = (moved_in_time != 0.0).astype(np.int64)
    if np.any(on):
        assembled += motions.blocks_times(state, on, np.stack([moved_in_time, np.zeros(size), np.zeros(size)]), False)
    native = assembler.native()
    assembler.complete_links(state)   # J of the state in the links' buffers
    marked, vector, product = (np.ascontiguousarray(motions.mask(), np.int64), np.ascontiguousarray(rates[0]),
                               np.zeros(size))
    by_w[n_asm:] = 0.0
    residual = np.where(np.arange(size) < n_asm, residual, 0.0)
    native.library.latdyn_linked_geometric_product(native.model_ref, ctypes.byref(native.configuration(state)),
                                                   by_w.ctypes.data, marked.ctypes.data, vector.ctypes.data,
                                                   product.ctypes.data)
    free = product[:n] + linked_geometric_rate_in_time(assembler, state, residual[:n_asm], w, rates[0])
    return assembled, free


def _controllers_in_time_generated(owner) -> bool:
    """Whether the continuous controllers' explicit ∂y/∂t (ExplicitTime's one-column ControllerTerms, t its column)
    moves along w exactly (:func:`controller_parameter_along` forms it): none names t, or every controller's second
    derivatives along q are generated and no sampled controller or sensed force's law is in the terms."""
    from latdyn.analyses.weight_derivative import _exact_controllers

    terms = owner.explicit_time.laws.controllers
    if terms is None:
        return True
    return terms.sampled is None and not any(terms.forces_read.values()) and all(_exact_controllers(owner.assembler))


def time_stiffness_along(owner, state, w: np.ndarray, full: np.ndarray | None = None):
    """∂(∂r/∂t)/∂q w (n_total + 1,) of the static residual, where :func:`time_generated`: :func:`stiffness_along` of
    the scene's laws' rates in t (ExplicitTime's one column t: the loads' and hinges' rates, as ∂r/∂t takes them),
    the reels' (:func:`_reels_along`) and the continuous controllers' outputs' ∂y/∂t through their actuators
    (:func:`controller_parameter_along` of ExplicitTime's ControllerTerms: SymPy's mixed second derivatives of ∂f/∂t
    by the reads that move along q, times the sensors' generated gradients, chained) and the prescribed motions'
    (:func:`_prescribed_along`; no rigid links or guides). ``full`` (n_total + 1,): with rigid links or guides the
    direction u = P w on the assembled coordinates (the caller projects by Pᵀ); None where a controller's terms are
    not formed there."""
    timed = owner.explicit_time
    if full is not None:   # rigid links or guides: along u = P w on the assembled coordinates, the rates held
        out = stiffness_along_all(timed.laws, state, full, cables=False)[:, 0]
        if timed.reels:
            _reels_along(owner, state, full, out)
        if timed.laws.controllers is not None:
            beside = controller_parameter_along(owner, state, w, terms=timed.laws.controllers, full=full)
            if beside is None:
                return None
            out = out + beside[:, 0]
        return out
    out = stiffness_along(timed.laws, state, w, cables=False)[:, 0]
    if timed.reels:
        full = np.zeros(owner.model.n_total + 1)
        full[:owner.model.n_dofs] = w
        _reels_along(owner, state, full, out)
    if timed.prescribed:
        _prescribed_along(owner, state, w, out)
    if timed.laws.controllers is not None:
        out = out + controller_parameter_along(owner, state, w, terms=timed.laws.controllers)[:, 0]
    return out


def time_shift_along(owner, state, w: np.ndarray, full: np.ndarray | None = None) -> np.ndarray | None:
    """(n,): the coefficient of an event's time shift δt_e in the parameters' generated (∂K/∂p) w on the free
    coordinates, ∂(∂r/∂t)/∂q w of the static residual, where :func:`time_shift_generated`; None where it is not, or
    where a controller's terms are not formed along P w (the callers' central difference). The one path of the
    forward method (``TransientSensitivities._stiffness_derivative``, ``_linked_stiffness_along``) and the adjoint
    (latdyn/analyses/adjoint_time.py ``shift_stiffness_along``). Without rigid links or guides
    :func:`time_stiffness_along` along w on the free rows; with them (r_min = Pᵀ r_all) :func:`time_stiffness_along`
    along u = P w (``full``: the forward method's, shared with the parameters' parts; formed here where None)
    reduced by Pᵀ, and the prescribed motions' part through the reduction (:func:`linked_prescribed_along`) — but for
    the reduction's geometric term ∂Pᵀ/∂q[w] of the static ∂r_all/∂t, which the caller adds (the forward method with
    the other columns of the static ∂r_all/∂p, the adjoint alone)."""
    if not time_shift_generated(owner):
        return None
    if owner.model.links is None:
        return owner._on_free_coordinates(state, time_stiffness_along(owner, state, w)[:, None])[:, 0]
    if full is None:
        full = owner._along_assembled(state, w)
    out = time_stiffness_along(owner, state, w, full=full)
    if out is None:
        return None
    free = np.zeros(owner.model.n_dofs)
    if owner.explicit_time.prescribed:
        assembled, free = linked_prescribed_along(owner, state, w, full)
        out = out + assembled
    return owner._on_free_coordinates(state, out[:, None])[:, 0] + free


def _reels_along(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """A reel's part of ∂(∂r/∂t)/∂q w into ``total`` (n_total + 1,): ∂r/∂t is ∂F/∂L0 · share · L0′(t) on the elements
    taut at the state (:meth:`latdyn.analyses.cable_sensitivities.CableSensitivities.reel_forces`), so along w
    ``cable_stiffness_D_rest_length``'s ∂(K_c w)/∂L0 · share · L0′(t), as a rest length parameter's (:func:`_cables`)
    with L0′(t) for ∂L0/∂p."""
    cables = owner.cables
    if cables is None:
        return
    taut = None
    for k, rest in enumerate(cables.cables.rest_length):
        if rest.is_constant:
            continue
        rate = rest.rate(state.t)
        if rate == 0.0:
            continue
        taut = cables.taut(state) if taut is None else taut
        for e in np.flatnonzero((cables.cables.cable == k) & taut):
            rows = cables._rows(e)
            along = full[rows]
            if not np.any(along):
                continue
            inputs = cables.inputs(state, e)
            out = rate * cables.cables.share[e] * np.asarray(owner.kernels.cable_stiffness_D_rest_length(
                *(np.ascontiguousarray(a[None]) for a in inputs), np.ascontiguousarray(along[None]))[0])
            np.add.at(total, rows, np.asarray(out).reshape(12))


def stiffness_along(owner, state, w: np.ndarray, cables: bool = True) -> np.ndarray:
    """(∂K/∂p) w (n_total + 1, k) of the hinges', loads', joint bodies' and cables' uses of the parameters
    (module docstring; the section values' are :meth:`ParameterDerivatives.add_section_stiffness_along`'s), w on the
    free coordinates; every column, exact or not (the caller takes the exact ones)."""
    full = np.zeros(owner.model.n_total + 1)
    full[:owner.model.n_dofs] = w
    return stiffness_along_all(owner, state, full, cables)


def stiffness_along_all(owner, state, full: np.ndarray, cables: bool = True) -> np.ndarray:
    """:func:`stiffness_along` with the direction ``full`` (n_total + 1,) on all coordinates (with rigid links or
    guides P w: the dependent nodes moving with the free ones)."""
    model = owner.model
    total = np.zeros((model.n_total + 1, len(owner.names)))
    _hinges(owner, state, full, total)
    _loads(owner, state, full, total)
    _geometry(owner, state, full, total)
    _bodies(owner, state, full, total)
    if cables:   # (ExplicitTime's laws in t have none: its reels are not generated here)
        _cables(owner, state, full, total)
        _cable_masses(owner, state, full, total)
        _stops(owner, state, full, total)
        _link_masses(owner, state, full, total)
    return total


def _law_row(law, theta: float, rate: float, t: float) -> tuple:
    """(value, ∂/∂θ, ∂/∂θ̇) of a hinge law at the state: the ``hinge_force`` kernel's three slots of a law (a law of
    t alone: its slopes 0)."""
    if not hasattr(law, "d_theta"):
        return law.value(theta, rate, t), 0.0, 0.0
    return law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t)


def _hinges(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """The hinges' (and guides') laws: ``hinge_force``'s ∂f/∂θ with the derivative law in the law's slot, times w_j
    (the rest angle: with the stiffness law's slope in k's slot at θ = 0, θ_r = 1, times ∂θ_r/∂p)."""
    model = owner.model
    contact = NO_CONTACT[None]
    t = float(state.t)
    for j, which, laws in owner._hinge_uses():
        d = int(_scattered(np.asarray(model.hinge_dofs[j]), model.n_total))
        along = full[d]
        if along == 0.0:
            continue
        theta, rate = float(state.theta[j]), float(state.theta_dot[j])
        hinge = model.hinges[j]
        for column, law in laws.items():
            row = np.zeros((1, 9))
            if which == "rest_angle":   # f = k (θ − θ_r) + …: ∂f/∂θ_r = −k, along θ −∂k/∂θ
                slope = _law_row(hinge.stiffness, theta, rate, t)
                row[0, 0:3] = 0.0, slope[1], slope[2]
                at = np.array([[0.0, 0.0, 1.0, 1.0]])
                scale = law.value(theta, rate, t)
            else:
                slot = {"stiffness": 0, "damping": 3, "torque": 6}[which]
                row[0, slot:slot + 3] = _law_row(law, theta, rate, t)
                at = np.array([[theta, rate, hinge.rest_angle, 1.0]])
                scale = 1.0
            stiffness = float(np.asarray(owner.kernels.hinge_force(at, row, contact)[1]).reshape(-1)[0])
            total[d, column] += scale * stiffness * along


def _loads(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """The point loads' components: ``point_load_stiffness_D_q``'s K_l w at the derivative values (the load factor
    1, as the events' ∂r/∂p is taken), on the load's node rows."""
    pairs, columns, place, _ = owner._load_layout()
    if not len(pairs):
        return
    model = owner.model
    distinct, use = owner.load_laws_distinct()
    values = np.zeros((len(pairs), 6))
    values[place] = np.array([owner._of_time(law, state.t) for law in distinct])[use]
    node, offset, frame = owner._load_points()
    nodes, frames = node[pairs], frame[pairs]
    follower = frames >= 0
    direction = np.zeros((len(pairs), 6))
    direction[:, 0:3] = full[_scattered(model.node_dofs[nodes, 3:6], model.n_total)]
    direction[follower, 3:6] = full[_scattered(model.node_dofs[frames[follower], 3:6], model.n_total)]
    on = np.flatnonzero(np.any(direction != 0.0, axis=1))
    if not len(on):
        return
    turns = np.where(follower[on, None, None], state.T[np.maximum(frames[on], 0)], np.eye(3))
    rows = lambda a: np.ascontiguousarray(np.reshape(a, (len(on), -1)), dtype=float)  # noqa: E731
    along = np.asarray(owner.kernels.point_load_stiffness_D_q(
        rows(state.T[nodes[on]]), rows(offset[pairs[on]]), rows(values[on]), rows(turns),
        rows(direction[on]))[0]).reshape(len(on), 6)
    np.add.at(total, (_scattered(model.node_dofs[nodes[on]], model.n_total), columns[on, None]), along)


def _geometry(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """The geometry parameters' uses (docs/parameters.md "Geometry parameters"): their static ∂r/∂p is
    Σ_e ∂F_e/∂X · V_e(q), ``beam_internal_force_D_reference`` along the element's reference variation at the state
    (:meth:`ReferenceGeometry.at_state`: ψ, δo, δh spatial, turning with the end), plus the loads at a moved offset
    (``point_load_D_offset``), so along w

        (∂K/∂p) w = Σ_e A_e ∂(K_e w_e)/∂X · V_e + Σ_l [K_l(δr) − K_l(0)] w_l,

    the elements' from the generated ``beam_stiffness_D_reference`` (K_e v at v = w_e, its derivative along V_e).
    That is the whole derivative along w: the reference seeds (δT_e = skew(ψ) T_e, δo, δh) and the configuration's
    (δT_e = skew(ω) T_e with ω = Δπ + Δθ h, δo = Δπ × o, δh = Δπ × h; codegen/derivation.py
    ``geometry_first_variation``, ``reference_first_variation``) each depend on the block the other moves, and the
    kernel's second variation along V_e of the configuration's seed — skew(ω) skew(ψ) T_e, Δπ × δo, Δπ × δh — is
    what the static ∂r/∂p's seed turning with the end (its ψ by ω, its δo and δh by Δπ) gives along w, skew(ψ) skew(ω)
    T_e + skew(ω × ψ) T_e the same. A moved hinge axis's term T_j θ J(θa) δa, which moves with θ beyond the end's
    turn, is held too — measured, not derived here: the axis's columns ≤ 4.7e-13 off Richardson differences of the
    static ∂r/∂p along w (tests/test_sensitivities_time_shift_exact.py; the end's frame turns by Δθ about the axis
    that the reference's δh moves, a term of the kernel's second variation, is the likely reason). The loads: the
    generated ``point_load_stiffness_D_q`` at the moved offset δr less at none (the load is affine in its offset, its
    K_l w too)."""
    geometry = owner.geometry
    if geometry is None or "beam_stiffness_D_reference" not in owner.kernels.info:
        return   # a variant generated before the kernel: every geometry column is the caller's difference
    model, k = owner.model, geometry.k
    elements = geometry.elements
    along = full[model.element_dofs[elements]] if len(elements) else np.zeros((0, 14))
    on = np.flatnonzero(np.any(along != 0.0, axis=1))
    if len(on):
        elements, along = elements[on], along[on]
        m = len(elements)
        at = np.ascontiguousarray(owner.assembler.native().element_inputs(state)[0][elements])
        variation = geometry.at_state(state, elements, at)                           # (m, WIDTH, k)
        tiled = lambda a: np.ascontiguousarray(np.tile(a, (k, 1)))  # noqa: E731
        forces = np.asarray(owner.kernels.beam_stiffness_D_reference(
            tiled(at), tiled(along), tiled(model.element_sections[elements]),
            np.ascontiguousarray(variation.transpose(2, 0, 1).reshape(k * m, WIDTH)))[1]).reshape(k, m, 14)
        for column in range(k):
            np.add.at(total[:, column], model.element_dofs[elements], forces[column])
    for index, node, offset in geometry.moved_loads:
        frame_node = geometry.load_frame_node(index)
        direction = np.zeros(6)
        direction[0:3] = full[_scattered(model.node_dofs[node, 3:6], model.n_total)]
        if frame_node >= 0:
            direction[3:6] = full[_scattered(model.node_dofs[frame_node, 3:6], model.n_total)]
        if not np.any(direction):
            continue
        values = geometry.load_arm_values(state.t, index, 1.0)
        frame = np.eye(3) if frame_node < 0 else state.T[frame_node]
        rows = lambda a: np.ascontiguousarray(np.tile(np.reshape(a, (1, -1)), (k + 1, 1)), dtype=float)  # noqa: E731
        arms = np.ascontiguousarray(np.concatenate([np.zeros((1, 3)), offset.T]))     # none, then δr by column
        out = np.asarray(owner.kernels.point_load_stiffness_D_q(rows(state.T[node]), arms, rows(values), rows(frame),
                                                               rows(direction))[0]).reshape(k + 1, 6)
        total[model.node_dofs[node]] += (out[1:] - out[0]).T


def _bodies(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """The joint bodies' mass and centre of mass: their weight's stiffness along w_b,
    ``joint_body_gravity_stiffness_D_q`` at (∂m/∂p, c) or (m, ∂c/∂p) (linear in m, and in c with none at c = 0)."""
    model = owner.model
    gravity = np.asarray(owner.assembler.gravity, float)
    if not np.any(gravity):
        return
    t = float(state.t)
    for body, laws in owner._body_uses():
        if body["inertia"]:   # the static ∂r/∂p of an inertia is 0
            continue
        node = model.body_node[body["body"]]
        found = np.flatnonzero(model.body_nodes == node)
        if not len(found):
            continue
        dofs, moving, frame = _node_along(owner, state, full, node)
        if dofs is None:
            continue
        for column, law in laws.items():
            block, com = owner.body_block(body, int(found[0]), law.value(0.0, 0.0, t))
            if com is not None:   # ∂f/∂c along ∂c/∂p: the weight at the centre of mass ∂c/∂p
                block = block.copy()
                block[0, 1:4] = com
            total[dofs, column] += _weight_stiffness_along(owner, frame, moving, block, gravity)


def _node_along(owner, state, full: np.ndarray, node: int) -> tuple:
    """(its rows (6,), w on them, its frame (1, 9)) of a joint body's node, or (None, None, None) where w does not turn
    it (a weight's stiffness is on its turns alone)."""
    model = owner.model
    dofs = _scattered(model.node_dofs[node], model.n_total)
    moving = full[dofs]
    if not np.any(moving[3:6]):
        return None, None, None
    return dofs, moving, np.ascontiguousarray(state.T[node].reshape(1, 9))


def _weight_stiffness_along(owner, frame: np.ndarray, moving: np.ndarray, block: np.ndarray,
                            gravity: np.ndarray) -> np.ndarray:
    """(6,) a joint body's weight's stiffness along w on its node, ``joint_body_gravity_stiffness_D_q`` at ``block``."""
    along = owner.kernels.joint_body_gravity_stiffness_D_q(frame, np.ascontiguousarray(moving[None]), block,
                                                           np.ascontiguousarray(gravity[None]))[0]
    return np.asarray(along).reshape(6)


def _cables(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """The cables' EA, damping and rest length, for the elements taut at the state (:meth:`CableSensitivities.taut`):
    ``cable_stiffness_D_q``'s K_c w at (∂EA/∂p, 0) or (0, ∂c/∂p) (the taut law is linear in them), and
    ``cable_stiffness_D_rest_length``'s ∂(K_c w)/∂L0 times the element's share of ∂L0/∂p (K_c is not linear in L0)."""
    cables = owner.cables
    if cables is None or not cables.uses:
        return
    uses = [use for use in cables.uses if use[1] in ("EA", "damping", "rest_length")]
    if not uses:
        return
    taut = cables.taut(state)
    t = float(state.t)
    for k, value, column, law in uses:
        derivative = law.value(0.0, 0.0, t)
        if derivative == 0.0:
            continue
        for e in np.flatnonzero((cables.cables.cable == k) & taut):
            rows = cables._rows(e)
            along = full[rows]
            if not np.any(along):
                continue
            if value == "rest_length":
                inputs = cables.inputs(state, e)
                out = derivative * cables.cables.share[e] * np.asarray(owner.kernels.cable_stiffness_D_rest_length(
                    *(np.ascontiguousarray(a[None]) for a in inputs), np.ascontiguousarray(along[None]))[0])
            else:
                moved = {"EA": derivative, "c": 0.0} if value == "EA" else {"EA": 0.0, "c": derivative}
                inputs = cables.inputs(state, e, **moved)
                out = owner.kernels.cable_stiffness_D_q(*(np.ascontiguousarray(a[None]) for a in inputs),
                                                        np.ascontiguousarray(along[None]))[0]
            np.add.at(total[:, column], rows, np.asarray(out).reshape(12))


def _cable_masses(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """A cable's ρA and rest length move its lumped point masses, ½ ρA L0/elements at each end of each element at
    an offset from its node (latdyn/model/cables.py), and so their weight and its stiffness in K (the joint bodies'
    G_b): ``joint_body_gravity_stiffness_D_q`` along w at the masses' ∂m/∂p
    (:meth:`CableSensitivities.mass_blocks`, the blocks ∂r/∂p's inertia forces take; the weight is linear in m).
    The static ∂r/∂p holds no cable's weight (:meth:`CableSensitivities.residual_derivatives` adds the masses' forces
    with the inertia forces alone), so its difference along w, the path before, left this part out: 1.0 of ρA's
    column and 0.05 of a rest length's on the 3D boom of tests/test_weight_derivative_parameters2.py."""
    cables = owner.cables
    if cables is None or not cables.uses:
        return
    gravity = np.asarray(owner.assembler.gravity, float)
    if not np.any(gravity):
        return
    model = owner.model
    for k, value, column, law in cables.uses:
        if value not in ("rhoA", "rest_length") or k not in cables.mass_rows:
            continue
        rows, block, weight = cables.mass_blocks(k, value, law)
        nodes = model.body_nodes[rows]
        dofs = _scattered(model.node_dofs[nodes], model.n_total)
        moving = full[dofs]
        on = np.flatnonzero(np.any(moving[:, 3:6] != 0.0, axis=1))
        if not len(on) or not np.any(block[:, 0]):
            continue
        frames = np.ascontiguousarray(state.T[nodes[on]].reshape(-1, 9))
        along = owner.kernels.joint_body_gravity_stiffness_D_q(frames, np.ascontiguousarray(moving[on]),
                                                               np.ascontiguousarray(block[on]),
                                                               np.ascontiguousarray(weight[on]))[0]
        np.add.at(total[:, column], dofs[on], np.asarray(along).reshape(len(on), 6))


def _link_masses(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """A rigid link's section ρA (and ρIy, ρIz, which weigh nothing) moves its joint body's mass: its weight's stiffness
    along w on the link's node, ``joint_body_gravity_stiffness_D_q`` at the block ∂r/∂p takes
    (latdyn/analyses/link_sensitivities.py ``add_link_section_forces``: (∂m/∂p, c, ∂I/∂p) of ``link_section_block``,
    linear in m)."""
    from latdyn.analyses.link_sensitivities import link_section_block, link_section_uses

    uses = link_section_uses(owner) if owner.model.links is not None else None
    gravity = np.asarray(owner.assembler.gravity, float)
    if not uses or not np.any(gravity):
        return
    model, t = owner.model, float(state.t)
    for beam, b, node, value, laws in uses:
        dofs, moving, frame = _node_along(owner, state, full, node)
        if dofs is None:
            continue
        for column, law in laws.items():
            block = link_section_block(owner.kernels, beam, value, law.value(0.0, 0.0, t), model.body_com[b])
            total[dofs, column] += _weight_stiffness_along(owner, frame, moving, block, gravity)


def _stops(owner, state, full: np.ndarray, total: np.ndarray) -> None:
    """The hinges' (and guides') compliant stops' stiffness, exponent and damping: ``contact_stiffness_D_law``'s
    ∂(∂f_contact/∂θ)/∂(k, n, c) at the joint's (θ, θ̇) times the law's derivative by the parameter, times w_j (the
    force is not linear in n, nor in (k, c) across its clip). Friction's force depends on θ̇ alone: its part of K,
    and of (∂K/∂p) w, is 0."""
    model = owner.model
    t = float(state.t)
    for (beam, end, kind, slot), laws in owner.joint_law_uses():
        if kind != "contact":
            continue
        j = model.hinge_index(beam, end)
        d = int(_scattered(np.asarray(model.hinge_dofs[j]), model.n_total))
        along = full[d]
        if along == 0.0:
            continue
        at = np.array([[float(state.theta[j]), float(state.theta_dot[j]), model.hinges[j].rest_angle, 1.0]])
        slope = float(np.asarray(owner.kernels.contact_stiffness_D_law(at, owner.contact_row(j))[0]).reshape(-1)[slot])
        for column, derivative in laws.items():
            total[d, column] += derivative.value(0.0, 0.0, t) * slope * along


#: SymPy's mixed second derivatives of a continuous controller's output and of its parameters' partials by the reads
#: that move along q, lambdified once per (output, partials, symbols, moving reads) in a process
#: (:func:`_mixed_laws`)
_MIXED: dict = {}


def _mixed_laws(controller, partials: dict, moving: tuple):
    """(a function of ``(t, *reads, *states)`` giving, flat, ∂²f/∂x∂a_p for x over the reads and states (rows) and p
    over ``moving`` (columns), then ∂(∂f/∂p_col)/∂a_p for each column of ``partials`` in its order; the columns) of
    ``controller``'s output f (before its limits) and its parameters' partials ``partials`` (column → SymPy
    expression, ``ControllerTerms.partial_expressions``), Dirac deltas dropped as the compiled laws' (a kink's
    second derivative is 0 away from it); None where one is not a function (an unevaluated derivative)."""
    import sympy as sp

    from latdyn.scene.expressions import _drop_deltas

    columns = sorted(partials)
    key = (controller.output_expr, tuple(controller.symbols), tuple(moving),
           tuple((c, partials[c]) for c in columns))
    if key not in _MIXED:
        symbols = controller.symbols
        reads = symbols[1:1 + len(controller.reads)]
        first = [sp.diff(controller.output_expr, x) for x in symbols[1:]]
        entries = [sp.diff(f, reads[p]) for f in first for p in moving]
        entries += [sp.diff(partials[c], reads[p]) for c in columns for p in moving]
        entries = [_drop_deltas(e) for e in entries]
        singular = any(e.has(sp.Derivative, sp.Subs) for e in entries)
        _MIXED[key] = None if singular else (sp.lambdify(symbols, entries or [0], modules=["math", "numpy"]), columns)
    return _MIXED[key]


def controller_parameter_along(owner, state, w: np.ndarray, terms=None, full: np.ndarray | None = None):
    """(n_total + 1, k): the derivative along w of the controllers' terms of ∂r/∂p
    (:meth:`latdyn.analyses.sensitivities.ControllerTerms.add`) at ``state``, exact, or None where it is not formed
    here (the caller differences those terms then): a controller reading a force whose laws a parameter moves where
    that force's ∂F/∂p's move is not generated (:func:`_sensed_forces_generated`), or one whose output's second
    derivatives along q are not generated
    (:func:`latdyn.analyses.weight_derivative._exact_controllers`). The sampled controllers' held outputs:
    :func:`sampled_held_along`. With a_p the reads of f_k that move along q (a
    sensor: its generated gradient ∂s/∂q, :func:`latdyn.analyses.weight_derivative._sensor_kinematics`; an earlier
    controller's output y_j: its total gradient g_j, :func:`latdyn.analyses.weight_derivative._controller_curvatures`)
    and δa_p = ∂a_p/∂q w, the chain of :meth:`ControllerTerms.add`, dy_k/dp = ∂f_k/∂p + Σ_j ∂f_k/∂y_j dy_j/dp +
    Σ_l ∂f_k/∂S_l δS_l (held), moves along w as

        δ(dy_k/dp) = Σ_p ∂(∂f_k/∂p)/∂a_p δa_p + Σ_j (Σ_p ∂²f_k/∂y_j∂a_p δa_p) dy_j/dp + Σ_j ∂f_k/∂y_j δ(dy_j/dp)
                     + Σ_l (Σ_p ∂²f_k/∂S_l∂a_p δa_p) δS_l + Σ_F [(Σ_p ∂²f_k/∂F∂a_p δa_p) ∂F/∂p + ∂f_k/∂F δ(∂F/∂p)]

    (0 while y_k is clipped at a limit), SymPy's mixed second derivatives (:func:`_mixed_laws`); a hinge actuator's
    row takes −a δ(dy/dp), a load component's the ``point_load`` kernel at a δ(dy/dp) plus
    ``point_load_stiffness_D_q`` at a dy/dp along w (the load's turn with its node and frame); F a force whose laws a
    parameter moves (a free joint's, a cable's tension, a section force), δ(∂F/∂p) :func:`_moved_forces_along`. Before, a central difference of
    :meth:`ControllerTerms.add` along w (kpstops found it dropped the chained outputs' move there; sampled controllers
    and joint-force readers until ctrlhand).
    ``terms``: a ControllerTerms other than ``owner.controllers`` (its ``k`` columns: the adjoint's held δS map,
    latdyn/analyses/adjoint_controller_states.py ``held_stiffness_along``). ``full`` (n_total + 1,): the direction on
    every assembled coordinate (a model with rigid links or guides, u = P w, :func:`linked_controller_parameter_along`;
    default w on the free coordinates, 0 elsewhere)."""
    from latdyn.analyses.weight_derivative import _exact_controllers

    terms = owner.controllers if terms is None else terms
    model, assembler = owner.model, owner.assembler
    if terms is None:
        return None
    forces_read = any(terms.forces_read.values())
    if forces_read and not _sensed_forces_generated(owner, terms):
        return None
    control = assembler.control
    total = np.zeros((model.n_total + 1, terms.k))
    if terms.sampled is not None:   # the held outputs' δy: constants of the step, their loads turning along w
        sampled_held_along(owner, state, w, terms.sampled, total, full=full)
    if not (terms.partials or terms.held or forces_read) or not len(control.actuator_kind):
        return total
    exact = _exact_controllers(assembler)
    if not all(exact):
        return None
    return _controller_parameter_along(owner, terms, state, w, exact, total, full=full)   # chained: the laws' arguments


def linked_controller_parameter_along(owner, state, full: np.ndarray):
    """(n_total + 1, k) on every coordinate, or None: with rigid links or guides, the derivative of the controllers'
    terms of ∂r_all/∂p (:meth:`latdyn.analyses.sensitivities.ControllerTerms.add`) along u = P w on the assembled
    coordinates (``full``), every assembled rate held (the evaluation's K_red = Pᵀ K_all P + ∂Pᵀ/∂q · r_all is ∂r/∂q
    at the assembled rates held, the dependent nodes' too: latdyn/assembly/linked.py), exact as
    :func:`controller_parameter_along` unlinked: the sensors' generated gradients by the assembled coordinates (a
    dependent node's too, :func:`latdyn.analyses.weight_derivative._sensor_kinematics`) times u. The caller projects
    it by Pᵀ and adds the reduction's geometric term of ∂r_all/∂p. None (the caller keeps the difference) where
    :func:`controller_parameter_along` does not form it, and where a controller reads a joint's force whose laws a
    parameter moves (its ∂F/∂p's move, :func:`_moved_forces_along`, is on the free coordinates alone)."""
    terms = owner.controllers
    if terms is None:
        return None
    if any(terms.forces_read.values()):
        return None
    return controller_parameter_along(owner, state, full[:owner.model.n_dofs], full=full)


def sampled_held_along(owner, state, w: np.ndarray, sampled, total: np.ndarray,
                       full: np.ndarray | None = None) -> np.ndarray:
    """Add into ``total`` (n_total + 1, k) the derivative along w of the sampled controllers' held outputs' terms of
    ∂r/∂p (:meth:`latdyn.analyses.sensitivities.SampledTerms.add`), exact: a held δy is a constant of the step (the
    sample's, ``SampledTerms.sample``: the output's derivative at the sample, carried by the forward method), so a
    hinge's or guide's row −a δy does not move along w, and a load component a δy moves only as the load turns with
    its node and its frame, ``point_load_stiffness_D_q``'s K_l w at the values a δy (:func:`_load_actuator_along`).
    Before, a central difference of ``ControllerTerms.add`` along w (step WEIGHT_STEP ℓ/|w|_∞)."""
    loads: dict[int, np.ndarray] = {}
    for kind, index, component, i, gain in sampled.actuators:
        moved = gain * sampled.held[i]
        if kind == 1 and np.any(moved):
            loads.setdefault(int(index), np.zeros((6, total.shape[1])))[component] += moved
    for index, values in loads.items():
        _load_actuator_along(owner, state, w, index, np.zeros_like(values), values, total, full=full)
    return total


def _sensed_forces_generated(owner, terms) -> bool:
    """Whether every force a continuous controller reads whose laws a parameter moves (``ControllerTerms.forces_read``)
    has its ∂F/∂p's move along q generated (:func:`_moved_forces_along`): a free joint's torque or force (its laws and
    compliant stops, :func:`_hinges`, :func:`_stops`); a cable's tension (its EA, damping, rest length; ρA moves no
    force: ``cable_tension_D_q_D_section``); an element's section force whose section values alone a parameter moves
    (no geometry parameter; shear-rigid or shear-flexible: ``beam_section_forces_D_q_D_section``). The others keep the
    difference: a placed point and a section force that a geometry parameter moves (no kernel gives ∂²s/∂X∂q), a
    stuck or locked joint's force (a reaction), and a force whose kernel the generated variant does not hold yet (one
    regenerated before it: the committed tree regenerates every variant at once)."""
    from latdyn.analyses.joint_force_sensitivities import is_joint_force, joint_of

    model = owner.model
    read = {r for found in terms.forces_read.values() for r in found}
    for name in read:
        probe = terms.moved_forces[name]
        if is_joint_force(probe):
            if model.hinge_dofs[joint_of(model, probe)] >= model.n_dofs:   # a stuck or locked joint's force
                return False
        elif probe.kind == "element":
            if owner.geometry is not None or "beam_section_forces_D_q_D_section" not in owner.kernels.info:
                return False
        elif probe.kind == "cable":
            if "cable_tension_D_q_D_section" not in owner.kernels.info:
                return False
        else:   # a placed point
            return False
    return True


def _moved_forces_along(owner, terms, state, w: np.ndarray) -> dict:
    """{name: ∂(∂F/∂p)/∂q w (k,)} of the forces of :func:`_sensed_forces_generated`, the rates held (as W's K):

    * a free joint's force F = −f (its laws and compliant stops, ``ControllerTerms.sensed_force_slopes``): −∂(∂f/∂p)/∂θ
      w_θ, the generated ``hinge_force`` stiffness with the derivative law in the law's slot (:func:`_hinges`) and
      ``contact_stiffness_D_law`` (:func:`_stops`) along the joint's own angle alone;
    * a cable's tension, its first element's N = EA (ℓ − L0)/L0 + c ℓ̇ (0 while slack): ∂N/∂p = (∂N/∂σ) δσ over
      σ = (L0, EA, c) moves along w as (∂²N/∂σ∂q w) δσ, the generated ``cable_tension_D_q_D_section`` times w on the
      element's ends (:func:`_tension_along`);
    * an element's section force w0 S_k + w1 S_k+1 (latdyn.assembly.control ``_section_sensor``), shear-rigid or
      shear-flexible: ∂S/∂p = (∂S/∂σ) δσ moves along w as (∂((∂S/∂q) w)/∂σ) δσ, the generated
      ``beam_section_forces_D_q_D_section`` at the element's section (:func:`_section_force_along`)."""
    from latdyn.analyses.joint_force_sensitivities import is_joint_force, joint_of

    model = owner.model
    out = {}
    for name in {r for found in terms.forces_read.values() for r in found}:
        probe = terms.moved_forces[name]
        if probe.kind == "cable":
            out[name] = _tension_along(owner, state, w, probe)
            continue
        if probe.kind == "element":
            out[name] = _section_force_along(owner, state, w, probe)
            continue
        assert is_joint_force(probe), probe
        j = joint_of(model, probe)
        d = int(model.hinge_dofs[j])
        along = np.zeros(model.n_total + 1)
        along[d] = w[d]
        total = np.zeros((model.n_total + 1, terms.k))
        if along[d] != 0.0:
            _hinges(owner, state, along, total)
            _stops(owner, state, along, total)
        out[name] = -total[d]
    return out


def _tension_along(owner, state, w: np.ndarray, probe) -> np.ndarray:
    """(k,) ∂(∂N/∂p)/∂q w of a cable's tension (:func:`_moved_forces_along`): the generated
    ``cable_tension_D_q_D_section``'s ∂²N/∂σ∂q of its first element, σ = (L0, EA, c) (codegen/joints.py), its column
    of the value a use moves times that use's derivative (∂EA/∂p, ∂c/∂p, or the element's share of ∂L0/∂p as
    :func:`_cables`' reel share · L0), times w on the element's ends; 0 while the element is slack (the sensor reads 0
    there, csrc/evaluate.c). Before (ctrlexact), by hand from facts of the law: N linear in (EA, c), and
    N_el = EA (ℓ/L0 − 1) giving ∂²N/∂L0∂q = −(1/L0) ∂N_el/∂q."""
    from latdyn.analyses.weight_derivative import _cable_inputs

    model = owner.model
    cables = model.cables
    k = cables.names.index(probe.beam)
    element = int(np.flatnonzero(cables.cable == k)[0])
    out = np.zeros(len(owner.names))
    geometry, velocity, section, taut = _cable_inputs(owner.assembler, state, np.array([element]))
    full = np.zeros(model.n_total + 1)
    full[:model.n_dofs] = w
    along = full[_scattered(model.node_dofs[cables.nodes[element]].reshape(12), model.n_total)]
    if not taut[0] or not np.any(along):
        return out
    by_section = np.asarray(owner.kernels.cable_tension_D_q_D_section(geometry, velocity, section)[1],
                            float).reshape(12, 3).T @ along   # ∂(∂N/∂q w)/∂[L0, EA, c]
    t = float(state.t)
    for cable, value, column, law in owner.cables.uses:
        if cable != k or value not in _TENSION_VALUES:
            continue
        share = cables.share[element] if value == "rest_length" else 1.0
        out[column] += by_section[_TENSION_VALUES[value]] * share * law.value(0.0, 0.0, t)
    return out


#: the cable values a tension reads, each its column of ``cable_tension_D_q_D_section``'s [L0, EA, c]
_TENSION_VALUES = {"rest_length": 0, "EA": 1, "damping": 2}


def _section_force_along(owner, state, w: np.ndarray, probe) -> np.ndarray:
    """(k,) ∂(∂S/∂p)/∂q w of an element's section force w0 S_k + w1 S_k+1 (:func:`_moved_forces_along`): with
    ∂S/∂p = (∂S/∂σ) δσ for each section use's derivative rows δσ (``ParameterDerivatives._section_derivative_blocks``,
    weighed as csrc/parameter_forces.c ``section_force_slope`` weighs ∂S/∂σ), its move along w is
    (∂((∂S/∂q) w_e)/∂σ) δσ, the generated ``beam_section_forces_D_q_D_section``'s derivative by the section values at
    the element's section and configuration (codegen/derivation.py: forward mode of the lowered product), contracted
    with δσ. Exact whether or not S is linear in σ: a shear-flexible element's axial force reads EI through
    μ = 1/(1 + 12 EI/(GA L²)); before (ctrlexact), a shear-rigid one's S at the section [L0, δσ] (S linear in the
    stiffness values there, a fact of the generated law used by hand), a shear-flexible one's a central difference
    along w."""
    from latdyn.assembly.control import _section_sensor

    model = owner.model
    out = np.zeros(len(owner.names))
    blocks = owner._section_derivative_blocks(state)
    _, index, _, _, weights, _ = _section_sensor(model, probe)
    e, first = index // 4, index % 4
    full = np.zeros(model.n_total + 1)
    full[:model.n_dofs] = w
    along = full[_scattered(model.element_dofs[e], model.n_total)]
    uses = np.flatnonzero(blocks[0] == e) if blocks is not None else np.zeros(0, np.int64)
    if not len(uses) or not np.any(along):
        return out
    geometry = np.ascontiguousarray(owner.assembler.native().element_inputs(state)[0][e:e + 1])
    by_section = np.asarray(owner.kernels.beam_section_forces_D_q_D_section(
        geometry, np.ascontiguousarray(along[None]), np.ascontiguousarray(model.element_sections[e:e + 1]))[1],
        float).reshape(4, -1)
    moved = blocks[2][uses][:, 1:] @ by_section.T   # (uses, 4): Σ_σ ∂((∂S/∂q) w_e)/∂σ δσ (L0, slot 0, is no value)
    weighed = weights[0] * moved[:, first] + (weights[1] * moved[:, first + 1] if first < 3 else 0.0)
    np.add.at(out, blocks[1][uses], weighed)
    return out


def held_angles_along(owner, state, w: np.ndarray):
    """(n_total + 1, k): the derivative along w of the held angles' terms of ∂r/∂p, Σ_j K[:, θ_j] δθ_j over the joints
    friction holds (``TransientSensitivities._held_forces``), exact, or None where it is not formed here (a model with
    rigid links or guides; a held angle a load's controller or a controller outside
    :func:`latdyn.analyses.weight_derivative._exact_controllers` reads). A held angle is no free coordinate, so w does
    not move it and its column moves along w as ∂(K e_j)/∂q w, formed in that order (no symmetry of the second
    derivative assumed):

        Σ_e A_e ∂(K_e e_j)/∂q_e w_e δθ_j  +  Σ_a (−a) Σ_i ∂(∂y_a/∂θ_j)/∂q_i w_i δθ_j,

    the elements' from the generated ``beam_stiffness_D_q`` at the direction e_j (the unit on the held angle's slot)
    times w_e, the couplings' from the controllers' second derivatives (:func:`latdyn.analyses.weight_derivative.
    _controller_curvatures`, row θ_j); the joint's own law on its own row (K_jj of its own angle, w_j = 0) and that
    row are not on the free coordinates. Before, a central difference of ``_held_forces`` along w (step WEIGHT_STEP
    ℓ/|w|_∞, two native evaluations)."""
    from latdyn.analyses.weight_derivative import _controller_curvatures, _exact_controllers

    held = owner.held
    model, assembler = owner.model, owner.assembler
    if held is None or not np.any(held):
        return np.zeros((model.n_total + 1, len(owner.names)))
    total = np.zeros((model.n_total + 1, held.shape[1]))   # held's columns: the parameters' (the adjoint's unit δθ)
    if model.links is not None:
        return None
    control = assembler.control
    n = model.n_dofs
    full = np.zeros(model.n_total + 1)
    full[:n] = w
    hinges = np.flatnonzero(np.any(held, axis=1))
    cols = np.asarray(control.coupling_cols)
    coupled = [int(a) for a in np.asarray(control.coupling_actuator)[np.isin(cols, model.hinge_dofs[hinges])]]
    curvatures = None
    if coupled:
        exact = _exact_controllers(assembler)
        if any(control.actuator_kind[a] != 0 or not exact[int(control.actuator_controller[a])] for a in coupled):
            return None
        columns, curvatures = _controller_curvatures(assembler, state, exact)
        local = {int(c): i for i, c in enumerate(columns)}
        along = full[columns] if len(columns) else np.zeros(0)
    dofs = model.element_dofs
    geometry = None
    for j in hinges:
        d = int(model.hinge_dofs[j])
        column = np.zeros(model.n_total + 1)
        elements, slot = np.nonzero(dofs == d)
        if len(elements):
            if geometry is None:
                geometry = assembler.native().element_inputs(state)[0]
            direction = np.zeros((len(elements), 14))
            direction[np.arange(len(elements)), slot] = 1.0
            blocks = np.asarray(assembler.kernels.beam_stiffness_D_q(
                np.ascontiguousarray(geometry[elements]), direction,
                np.ascontiguousarray(model.element_sections[elements]))[1]).reshape(-1, 14, 14)
            np.add.at(column, dofs[elements], np.einsum("eij,ej->ei", blocks, full[dofs[elements]]))
        if curvatures is not None and d in local:
            for a in sorted({a for a, c in zip(np.asarray(control.coupling_actuator), cols) if c == d}):
                gain = float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0
                curvature = curvatures[int(control.actuator_controller[a])]
                column[int(model.hinge_dofs[control.actuator_index[a]])] -= gain * float(curvature[local[d]] @ along)
        total += np.outer(column, held[j])
    return total


def _controller_parameter_along(owner, terms, state, w: np.ndarray, exact: list, total: np.ndarray,
                                full: np.ndarray | None = None) -> np.ndarray:
    """:func:`controller_parameter_along`'s chain and actuators (the chained outputs the compiled partials' arguments,
    computed at ``state``: codegen/laws.py ``_block``). ``full``: the direction on every coordinate (u = P w)."""
    from latdyn.analyses.weight_derivative import (_controller_curvatures, _controller_reads, _MOVING_SENSORS,
                                                   _sensor_dofs, _sensor_kinematics)
    from latdyn.assembly.control import CONTROLLER

    model, assembler = owner.model, owner.assembler
    control = assembler.control
    k_cols = terms.k
    n = model.n_dofs
    columns, _, _, gradients = _controller_curvatures(assembler, state, exact, with_outputs=True)
    if full is not None:   # u = P w on the assembled coordinates, a dependent node's too
        along = full[np.asarray(columns, np.int64)] if len(columns) else np.zeros(0)
    else:
        along = np.where(columns < n, w[np.minimum(columns, n - 1)], 0.0) if len(columns) else np.zeros(0)
    place = {c.name: k for k, c in enumerate(control.controllers)}
    values = terms.signal_values(state)
    if terms.compiled is not None:
        values.update(terms.sensed_in_c(state))
    outputs, slopes, moves, forces, forces_along = {}, {}, {}, None, None
    for c in terms.continuous:
        k = place[c.name]
        reads = _controller_reads(control, k)
        arguments = [state.t, *[values[r] if r in values else outputs[r] for r in c.reads], *terms.state_values(c)]
        raw = float(c.functions()[0](*arguments)) if terms.compiled is None else terms.compiled.output(c, arguments)
        outputs[c.name] = c.clip(raw)
        slope, move = np.zeros(k_cols), np.zeros(k_cols)
        slopes[c.name], moves[c.name] = slope, move
        if c.limits is not None and not c.limits[0] < raw < c.limits[1]:
            continue
        moving, delta = [], []
        for p, (kind, index, sensor) in enumerate(reads):
            if kind == CONTROLLER:
                moving.append(p)
                delta.append(float(gradients[index] @ along) if len(along) else 0.0)
            elif kind in _MOVING_SENSORS:
                gradient, _ = _sensor_kinematics(assembler, state, kind, index, sensor)
                dofs = np.asarray(_sensor_dofs(assembler, kind, index, sensor), np.int64)
                moved = full[dofs] if full is not None else np.where(dofs < n, w[np.minimum(dofs, n - 1)], 0.0)
                moving.append(p)
                delta.append(float(np.asarray(gradient, float) @ moved))
        partials = {column: expression for column, expression in terms.partial_expressions.get(c.name, {}).items()
                    if column in terms.partials.get(c.name, {})}
        laws = _mixed_laws(c, partials, tuple(moving))
        if laws is None:
            return None
        law, order = laws
        flat = np.asarray(law(*arguments), float).reshape(-1)
        m, width = len(moving), len(c.symbols) - 1
        delta = np.asarray(delta, float)
        mixed = flat[:width * m].reshape(width, m) @ delta if m else np.zeros(width)   # Σ_p ∂²f/∂x∂a_p δa_p
        by_partials = flat[width * m:].reshape(len(order), m) @ delta if m else np.zeros(len(order))
        for i, column in enumerate(order):
            slope[column] += (float(terms.partials[c.name][column](*arguments)) if terms.compiled is None else
                              terms.compiled.value(terms.partials[c.name][column], arguments))
            move[column] += by_partials[i]
        if terms.forces_read.get(c.name):   # ∂f/∂s ∂F/∂p of the joints' forces whose laws a parameter moves
            gradient = (c.output_gradient(*arguments) if terms.compiled is None else
                        terms.compiled.gradient(c, arguments))
            if forces is None:
                forces = terms.sensed_force_slopes(state)
                forces_along = _moved_forces_along(owner, terms, state, w)
            for read, i in terms.forces_read[c.name].items():
                slope += gradient[i] * forces[read]
                move += mixed[i] * forces[read] + gradient[i] * forces_along[read]
        if terms.chained[c.name] or c.name in terms.held:
            gradient = (c.output_gradient(*arguments) if terms.compiled is None else
                        terms.compiled.gradient(c, arguments))
            for read, i in terms.chained[c.name].items():
                slope += gradient[i] * slopes[read]
                move += mixed[i] * slopes[read] + gradient[i] * moves[read]
            if c.name in terms.held:
                by_states = terms.states.output_by_states(c, arguments)
                if by_states is None:
                    by_states = gradient[len(c.reads):]
                for l, row in enumerate(terms.held[c.name]):
                    slope += by_states[l] * row
                    move += mixed[len(c.reads) + l] * row
    loads: dict[int, list] = {}
    for kind, index, component, controller, gain in zip(control.actuator_kind, control.actuator_index,
                                                        control.actuator_component, control.actuator_controller,
                                                        control.actuator_gain):
        name = control.controllers[controller].name
        a = gain if gain else 1.0
        if kind == 0:
            total[model.hinge_dofs[index]] -= a * moves[name]
        else:
            pair = loads.setdefault(int(index), [np.zeros((6, k_cols)), np.zeros((6, k_cols))])
            pair[0][component] += a * moves[name]
            pair[1][component] += a * slopes[name]
    for index, (moved_values, held_values) in loads.items():
        _load_actuator_along(owner, state, w, index, moved_values, held_values, total, full=full)
    return total


def _load_actuator_along(owner, state, w: np.ndarray, index: int, moved_values: np.ndarray, held_values: np.ndarray,
                         total: np.ndarray, full: np.ndarray | None = None) -> None:
    """Load ``index``'s part of :func:`controller_parameter_along`: ``point_load`` (linear in its values) at the
    values' move along w, and ``point_load_stiffness_D_q``'s K_l w at the values, on the load's node rows."""
    model = owner.model
    columns = [c for c in range(total.shape[1]) if np.any(moved_values[:, c])]
    if columns:
        nodes, forces = owner._load_forces(state, [index] * len(columns), moved_values[:, columns].T)
        total[model.node_dofs[nodes[0]][:, None], np.array(columns)[None, :]] += forces.T
    columns = [c for c in range(total.shape[1]) if np.any(held_values[:, c])]
    if not columns:
        return
    if full is None:
        full = np.zeros(model.n_total + 1)
        full[:model.n_dofs] = w
    node, offset, frame = owner._load_points()
    direction = np.zeros(6)
    direction[0:3] = full[_scattered(model.node_dofs[node[index], 3:6], model.n_total)]
    if frame[index] >= 0:
        direction[3:6] = full[_scattered(model.node_dofs[frame[index], 3:6], model.n_total)]
    if not np.any(direction):
        return
    turn = state.T[frame[index]] if frame[index] >= 0 else np.eye(3)
    m = len(columns)
    rows = lambda a: np.ascontiguousarray(np.reshape(a, (m, -1)), dtype=float)  # noqa: E731
    along = np.asarray(owner.kernels.point_load_stiffness_D_q(
        rows(np.repeat(state.T[node[index]][None], m, 0)), rows(np.repeat(offset[index][None], m, 0)),
        rows(held_values[:, columns].T), rows(np.repeat(turn[None], m, 0)), rows(np.repeat(direction[None], m, 0)))[0])
    along = along.reshape(m, 6)
    rows_at = _scattered(model.node_dofs[node[index]], model.n_total)
    for i, c in enumerate(columns):
        np.add.at(total[:, c], rows_at, along[i])
