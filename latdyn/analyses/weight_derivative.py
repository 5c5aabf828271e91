"""The derivative of an event's impulse weight along the configuration, H = ∂(W w)/∂q, generated
(docs/parameters.md, "The impulse weight's derivative").

A latch, a rigid stop with restitution and a stick weigh the velocity jump with W = M + s K (s = dt²) at the state
before the jump, and a stop's restart with s K (latdyn/timeloop/impulse.py, latdyn/timeloop/events.py). The forward
sensitivities need δ(W w) = H δq + (∂W/∂p) w along each column's (δq, δp), the adjoint Hᵀū
(latdyn/analyses/transient_sensitivities.py ``_weight_derivative``, latdyn/analyses/adjoint_sensitivities.py
``_weight_derivative_transposed``); (∂W/∂p) w is latdyn/analyses/parameter_stiffness.py's (the parameters' own
uses, and beside them the controllers' terms of ∂r/∂p exact, ``controller_parameter_along`` (a sampled controller's
held outputs, ``sampled_held_along``; a free joint's force, a cable's tension (EA, damping, rest length) and an
element's section force by its section values, shear-flexible too, whose laws a parameter moves, read by a controller),
and the held angles' columns, ``held_angles_along``; the terms of a controller reading another force a parameter moves
(a geometry parameter's section force or placed point, a stuck or locked joint's force) or outside
:func:`_exact_controllers` a central difference; with rigid links or guides beside controllers the same
parts through the reduction, the controllers' terms along u = P w, ``linked_controller_parameter_along``, and the
geometric term of ∂r_all/∂p, and a generated time shift, since linkedparam; beside held angles, a time shift not
generated, a controller reading a joint's
force a parameter moves or one outside :func:`_exact_controllers` the whole static ∂r/∂p a central difference along
w, at the assembled rates held, ``TransientSensitivities._advanced_at_held_rates``). H is assembled once per event as an
n × n sparse matrix on the free coordinates, so one matrix serves both:

    H = Σ_e A_e [s ∂(K_e w_e)/∂q_e + c_m ∂(M_e w_e)/∂q_e] A_eᵀ + Σ_b A_b [s ∂(K_b w_b)/∂q_b + c_m ∂(M_b w_b)/∂q_b] A_bᵀ
        + Σ_j s (∂K_jj/∂θ_j) w_j e_j e_jᵀ + Σ_l s A_l ∂(K_l w_l)/∂q_l A_lᵀ + Σ_c s A_c ∂(K_c w_c)/∂q_c A_cᵀ
        + s ∂(K_y w)/∂q + H_rest

(c_m = 1 with the mass, 0 without; w_e, w_b: w on the element's and the body's coordinates, 0 on those that are
no free coordinate; l the point loads, c the cable elements, K_y the continuous controllers' couplings). Generated
and exact:

* the elements' stiffness along w, ∂(K_e v)/∂q_e at v = w_e: ``beam_stiffness_D_q`` (codegen/derivation.py:
  the forward-mode program of the lowered product (∂F_i/∂q) v, seeded with the geometry block's first
  variation under the configuration update, as ``beam_inertia_tangent``'s);
* the elements' mass, ∂(M_e a)/∂q_e at a = w_e: ``beam_inertia_tangent`` at rest (rates 0, no gravity), whose
  ∂(M a + g − Q)/∂q is then ∂(M a)/∂q;
* the joint bodies' mass, ∂(M_b a)/∂[d; π] at a = w_b: ``joint_body_inertia_stiffness`` at rest, no gravity;
* the joint bodies' K, their weight's stiffness G_b = ∂(−[W; r_c × W])/∂π (codegen/joints.py), along w_b:
  ``joint_body_gravity_stiffness_D_q``;
* the free hinges' (and a model's guides' alike) diagonal of K, K_jj = ∂f/∂θ of their spring, damper and torque laws
  and compliant stops, which depends on the hinge's own angle alone: (∂K_jj/∂θ_j) w_j from
  ``hinge_stiffness_by_angle`` (codegen/joints.py: f with each law expanded to second order in θ, differentiated
  twice), fed the laws' values and first derivatives at the state and their second derivatives ∂²f/∂θ² — SymPy's,
  of the law's ∂f/∂θ parsed as a law of the state (:func:`_angle_slope_law`, as the laws' rates in t are), evaluated
  with NumPy at the event (the events take the Python path; nothing is compiled for them: a scene without events,
  or without laws of θ, makes nothing new). A hinge that a continuous controller alone drives has no torque law
  there (csrc/evaluate.c ``hinge_forces``). A law naming an input is taken at the input's value at the event (the
  law and its slope read the scene's inputs, as the compiled laws do); a torque a y + b naming a continuous
  controller's output y (a constant a, b of θ, θ̇, t and inputs: latdyn.assembly.control refuses any other) with
  b's second derivative, SymPy's of the law with y a symbol (y moves along q through the couplings below), a sampled
  controller's held output as an input (:func:`_names_held_in_a_hinge_law`). The slope law is not checked finite at
  θ = θ̇ = t = 0 as a user's law is (``sqrt(abs(theta))``'s slope is infinite there; it is evaluated at the event's
  state alone: latdyn.scene.expressions ``derivative_as_law``); a second derivative not finite at the event's state
  is refused (:func:`_refuse_infinite_curvature`, a SceneError naming ``solve.sensitivities`` and the law) rather
  than carried as inf or nan. A hinge whose ∂f/∂θ does not parse back as a law (:func:`exact_hinges`) keeps the
  difference below along its angle;
* the point loads' blocks K_l (the node's rows × the turns of the node and of the body the load turns with; a
  global load's frame half zero), along w_l on those columns: ``point_load_stiffness_D_q`` (codegen/joints.py: K_l w
  as the derivative of the load's force along the turns τ w at τ = 0, differentiated once more by the turns the
  node and the frame start from) at the load's values at the state (:func:`_load_part`). A load a continuous
  controller of :func:`_exact_controllers` drives (alone or through a law a y + b) is taken at the controller's
  output there, and its values' move with the controller's sensors and the couplings' two terms (their force
  turning with the node and the frame, the controller's gradient moving) are :func:`_driven_load_part`'s, from the
  same ``point_load`` at a unit component; a load another controller drives keeps the difference below
  (:func:`exact_loads`);
* the cable elements' blocks K_c (both end nodes' [d, π], the damper's c ℓ̇ at the state's rates included), along
  w_c: ``cable_stiffness_D_q`` (the same construction on the taut law of ``cable_force``), for the elements taut at
  the state as csrc/evaluate.c ``cables`` decides (held taut, or on no side a positive gap min(N_el, N)); a slack
  element's K is the runtime's zero, its derivative too (:func:`_cable_part`);
* the continuous controllers' couplings (:func:`exact_couplings`) from a controller that reads joints' angles and
  rates, points' positions and displacements (global at their node or at an offset, or in a body's axes), nodes'
  velocities, points' velocities at an offset and relative to a body, cables' lengths and tensions, elements' section
  forces, free
  joints' forces whose laws are generated, inputs, its own states and earlier such controllers (:func:`_exact_controllers`): K's entry −a ∂y/∂q_c (a joint's force) or F(e_p) ∂y/∂q_c (a load
  component) moves along q with y's second derivative through the chain rule (:func:`_controller_curvatures`):
  SymPy's first and second derivatives of each output's expression by its reads that move (lambdified once per
  controller in a process, :func:`_output_curvature`) at the sensors' values the evaluation computes, the rates
  held (W has no C), an input and a sampled controller's output at their values at the event, a state at its
  held value, an earlier controller's output through its own gradient and second derivative; each sensor's own
  second derivative through the kinematics under the configuration update (:func:`_sensor_kinematics`: 0 for an
  angle and a global component; a point x + T r, a point in a body's axes, a point's velocity v + ω × T r (by the
  turn, the rates held) and a cable's length composed of the generated ``point_load``'s force and turn tangents, as csrc/evaluate.c composes their gradients from it; a free
  joint's force from ``hinge_force`` and ``hinge_stiffness_by_angle``; a cable's tension N (its first element's, the
  damper's c ℓ̇ at the state's rates held; 0 while slack) from ``cable_tension_D_q_D_q``, ∂N/∂q differentiated once
  more under the update of the ends, codegen/joints.py beside ``cable_stiffness_D_q``; an element's section force
  from ``beam_section_forces_D_q_D_q``, the forward-mode program of the lowered product (∂S/∂q) a seeded as
  ``beam_stiffness_D_q``'s, codegen/derivation.py, at a = each of the element's fourteen coordinates; a point's
  velocity relative to a body, in its axes, from ``point_velocity_in_body_D_q_D_q`` (codegen/joints.py: the
  gradient of ``point_velocity_in_body``, the sensor csrc/evaluate.c takes its value and gradient from, differentiated
  once more under the update of both nodes, the rates held); a variant generated before these kernels keeps the
  difference for those controllers); 0 while an output is saturated (:func:`_coupling_part`,
  :func:`_driven_load_part`).

Not generated, H_rest: the couplings of a controller reading a free joint's force whose law is not generated, or a
controller of those, and the blocks of the loads such controllers drive. Their product (W
without the generated blocks) w is differenced centrally along each coordinate those blocks are on
(:func:`rest_support`: those couplings' rows and columns, the driven loads' nodes and frame bodies, a hinge not in
:func:`exact_hinges`), two evaluations per coordinate, step
:data:`latdyn.analyses.transient_sensitivities.WEIGHT_STEP` √(ℓ L_min) (ℓ the length scale, L_min the shortest
element where shorter). A model with none of them has H exact with no evaluation.

The same parts serve the event's time shift through prescribed motions on a model without rigid links or guides
(latdyn/analyses/parameter_stiffness.py ``_prescribed_along``, since prestime): :func:`_generated`, :func:`_load_part`
and :func:`_cable_part` with their direction ``full`` at u = q̇_p on the prescribed coordinates give ∂(K u)/∂q, times
w, and :func:`_cable_rates_product` at a = q̈_p a damped cable's ∂(C a)/∂q w; no new kernel. With rigid links or
guides the same parts at the motion's direction on the dependent nodes too, along P w, beside the links' terms
(latdyn/analyses/parameter_stiffness.py ``linked_prescribed_along``, since linkedheld).

Rigid links and guides: the reduced weight is W_red = Pᵀ W_all P + s ∂(Pᵀ r_all)/∂q (latdyn/assembly/linked.py: W_all
the blocks on the assembled coordinates, free and dependent, P = [I; J] the projection, r_all the residual before the
reduction, with the inertia forces at the state's rates). :func:`configuration_tangent_of_weight` does not take them
(its free coordinates are the assembled ones); ``TransientSensitivities._linked_weight_derivative`` splits W_red w:

* exact, the generated blocks W_gen (elements, joint bodies, the hinges of :func:`linked_exact_hinges`, the point
  loads of :func:`linked_generated_loads`, the cable elements, the couplings of :func:`linked_exact_couplings` — of
  controllers of joints' angles and rates, and of controllers reading nodes' positions, points' positions at an
  offset from their node and in a body's axes and cables' lengths (a dependent node's by the assembled coordinates;
  the offset and the length since linkedctrl, ea72688 differenced them), joints' angles, inputs, their states and
  earlier such controllers, and of controllers reading such positions beside joints' rates and nodes' velocities (a
  dependent node's too: :func:`_linked_rate_controllers`, since linkedctrl), whose entries move with the rates the
  reduction's move carries by −a Σ_p ∂²f/∂s_p∂s_r ∂s_p/∂q_c δs_r, δv_all = P δv + ∂(J v)/∂q δq
  (:func:`linked_coupling_rates_product`, exact, one evaluation) (:func:`_linked_position_controllers`, :func:`_coupling_part` at
  u = P w on the assembled coordinates), and since linkedhand (40bf44a differenced them) the couplings of the other
  controllers of :func:`_exact_controllers` whose reads' moves along the rates :func:`_read_moves` gives — points'
  velocities at an offset and relative to a body, cables' tensions, elements' section forces, free joints' forces
  (their laws generated along the rates), a rate beside an input, a sampled controller's held output, a state or
  another such controller, on dependent nodes too (:func:`_linked_chain_controllers`) — and the point loads they
  drive with their coupling entries (:func:`linked_generated_loads`): along P δq the unlinked parts at u = P w
  (:func:`_coupling_part`, :func:`_load_part`, :func:`_driven_load_part`, the sensors' second derivatives at the
  state's rates, the dependent nodes' completed), along the rates the reduction's move carries
  Pᵀ s ∂(K u)/∂v_all δv_all with δv_all = P δv + ∂(J v)/∂q δq, a hinge's row by −a M_k · δv_all and a driven
  component's node rows by K_l(a e_c) u (V_k · δv_all) + g (M_k · δv_all), V_k = ∂y_k/∂v_all and
  M_k = ∂(∂y_k/∂q_all · u)/∂v_all of :func:`_chain_rates_moves` on the assembled coordinates
  (:func:`linked_chain_rates_product`, exact, one evaluation):
  :func:`_linked_split`) through the reduction, :func:`linked_configuration_tangent`: with u = P w, y = W_gen u,
  ∂(Pᵀ W_gen P w)/∂q δq = Pᵀ H_gen (P δq) + ∂(Pᵀ y)/∂q δq + Pᵀ W_gen (∂(J w)/∂q δq) — H_gen the generated H above
  on every assembled coordinate (the dependent nodes' elements and bodies too; a load on a node that follows the
  links on its dependent turns and its frame body's, a global load's zero frame half skipped; a cable element on
  both ends' coordinates, dependent ones too, taut at the state, a slack one's zero), y holding the loads', cables'
  and couplings' W w, ∂(Pᵀ y)/∂q at fixed y the forward
  step's geometric term of y (csrc/links.c ``geometric_term`` from the generated wrench kernels, times δq:
  csrc/linked_weight.c), ∂(J w)/∂q the compiled links' rates' derivative at rates w (csrc/links.c
  ``dependent_rates_tangent``, the generated edge kernels' ``*_rates_D_q``): the derivative of P along δq applied
  to w, exact for every edge kind (hinges, slides, closures), where a polarisation of the links' quadratic term
  would hold for their positions' rows alone (on the 3D gimbal of skew hinges ∂(J w)/∂q δq and ∂(J δq)/∂q w differ
  by 0.61 of the former on the rotations' rows, 2.3e-16 on the translations'); of those blocks the damped taut
  cables' K_c, the hinges' K_jj of :func:`linked_rate_moving_hinges` (a stiffness law of θ̇, a damping law of θ, a
  torque law of θ and θ̇, a damped compliant stop) and the couplings whose output mixes an angle and a rate move with
  the rates (the loads' with the configuration and t alone), and the move carries the rates, the dependent ones
  following the configuration too: Pᵀ s ∂(K u)/∂v_all δv_all with δv_all = P δv + ∂(J v)/∂q δq, exactly — the
  cables' K_c affine in the rates (``cable_stiffness_D_q`` at the move less at none,
  :func:`linked_cable_rates_product`), the hinges' and couplings' rows, columns and rates free hinges' ones (P the
  identity there, ∂(J v)/∂q δq on dependent rows alone), so s ∂(K u)/∂v δv from the generated
  ``hinge_stiffness_by_rate`` and SymPy's mixed ∂²y/∂θ∂θ̇ (:func:`linked_rates_tangent`: the unlinked
  :func:`_hinge_rates_part`, :func:`_coupling_rates_part` on the linked masks; no evaluation);
* the geometric term's own derivative, :func:`linked_geometric_derivative`: along (δq, δv, δv̇),
  s ∂(Pᵀ δr_all)/∂q[w] exactly (δr_all = K_all δq_all + C_all δv_all + M_all δa_all, the blocks before the reduction
  with the inertia tangent, the dependent rates following the links through their compiled buffers), plus
  s ∂/∂q(∂(Pᵀ r)/∂q[w]) δq at fixed r = r_all — the links' second derivatives, exactly
  (:func:`geometric_second_product`: csrc/links.c ``geometric_term`` differentiated along the tree by the product
  rule in csrc/linked_weight_second.c, whose header has the equations — the slots' maps moved,
  δJ_c = δ(transfer) J_p + transfer δJ_p, from the generated edge kernels' ``*_rates_D_q``, the wrench kernels'
  rows moved with the generated second derivatives :data:`SECOND_KERNELS`, a closure's g = ∂x_cᵀ r moving the pin's
  wrench by D δx_p; no evaluation of the model, no difference); at an event moved in time (δt_e) with prescribed
  motions, P moves with the prescribed coordinates too: the geometric term of the inertia forces moved in time,
  ∂/∂t(∂(Pᵀ y)/∂q[w]) at fixed y, the same composition along the prescribed coordinates' rates q̇_p
  (:func:`linked_geometric_rate_in_time`; the static residual's part with ∂r/∂t's own,
  latdyn/analyses/parameter_stiffness.py ``linked_prescribed_along``);
* differenced, the blocks not generated anywhere (as H_rest: the couplings not of :func:`exact_couplings` and the
  loads their controllers drive, the hinges outside :func:`exact_hinges`), the couplings and driven loads of a
  controller outside :func:`_linked_chain_controllers` (a free joint's force whose laws are not generated along the
  rates, an output whose second derivatives by all its reads are not functions), and the hinges whose K_jj moves with
  their rate where ∂K_jj/∂θ̇ is not generated (:func:`linked_exact_hinges`, :func:`exact_hinges_by_rates`: a law
  whose slope in θ does not parse back as a law),
  Pᵀ W_rest P w (:func:`linked_rest_product`, computed on its own: the reduced W w less the exact part carried that
  part's round-off, 1e-8 of H δq over the step on the slider-crank), centrally along each column's move (δq, the free
  rates along δv, δv̇, the dependent ones completed) as before, two evaluations a parameter — none where the model
  has no such block (:func:`linked_has_rest`: the gimbal latching with loads in the rings' frames, a slider-crank
  with damped cables, a guided mass with follower loads, a chain of rigid bays with a PD of its hinges' angles and
  rate take none; 10be92c took 2k there, docs/performance.md "The linked weight's loads, cables and couplings
  generated (issue 34)"; the gimbal with a damper 0.05 (1 + 4θ²) or a torque of θ and θ̇ on its outer hinge, or a PD
  mixing a hinge's angle and rate, take none since af426b0's linkedrates, docs/performance.md "The linked weight's
  rates generated (issue 34)"; the gimbal with a PD of a point's velocities at an offset and in a body's axes, a
  guided mass with loads a PD drives and a chain of rigid bays with a controller of a hinge's torque at a compliant
  stop, an input and another controller take none since linkedhand, docs/performance.md "The linked weight's last
  differences generated (issue 34)").

Along the rates: W moves with them where K does, ∂(K w)/∂v δv (``TransientSensitivities._stiffness_by_rates``; its
transpose in the adjoint, the same matrix times the identity). Which terms of K move with the rates is asked of the
model's own evaluation, not of a list of the laws that can make them (:func:`stiffness_moving_with_rates`: K's blocks
at the state's rates and at rates moved, compared bit for bit): a damped cable's c ℓ̇ terms, a hinge law whose ∂τ/∂θ
holds θ̇, a compliant stop's Hunt–Crossley damping n δⁿ⁻¹ c δ̇ in contact, a continuous controller's couplings whose
∂y/∂s holds a rate (an output nonlinear in an angle and a rate) and the block of a load in a body's frame whose
component a controller of a rate drives (found so at random rates: tests/test_sensitivities_rate_stiffness.py); not
the joint bodies' gyroscopic terms nor the elements' (the inertia tangent, which the weight's K leaves out), nor
friction (∂f/∂θ = 0: its level and engagement are functions of the rate alone), nor a stop out of contact, an undamped
one, an undamped cable or a controller linear in its sensors. Generated and exact, with no evaluation of the model:

* the free hinges' diagonal, (∂K_jj/∂θ̇_j) w_j δθ̇_j with ∂K_jj/∂θ̇_j = ∂²f/∂θ∂θ̇ from ``hinge_stiffness_by_rate``
  (codegen/joints.py: f with each law expanded to second order in (θ, θ̇), its compliant stop with its damping
  included, differentiated by θ and θ̇ at the state), fed the laws' values and first derivatives and their mixed second derivatives,
  the ``d_rate`` of :func:`_angle_slope_law`'s law (SymPy's ∂²f/∂θ∂θ̇, evaluated with NumPy at the event), for the
  hinges of :func:`exact_hinges_by_rates` (:func:`_hinge_rates_part`; a law naming an input or a controller's output
  at its value at the event, as along q);
* the continuous controllers' couplings on a joint's force from a controller that reads joints' angles and rates
  alone (:func:`exact_couplings_by_rates`): K's entry −a ∂y/∂θ_j moves with a rate sensor's θ̇_i by
  −a ∂²y/∂θ_j∂θ̇_i, SymPy's mixed second derivatives of the output lambdified once per output in a process
  (:func:`_output_mixed`), 0 while the output is saturated (:func:`_coupling_rates_part`); and from a controller that
  reads points' positions (global at their node or at an offset, in a body's axes) and cables' lengths beside joints'
  angles, joints' rates and nodes' velocities (:func:`_position_and_rate_reads`, a model without rigid links or
  guides): K's entry −a Σ_p ∂f/∂s_p ∂s_p/∂q_c moves with a rate sensor r by −a Σ_p ∂²f/∂s_p∂s_r ∂s_p/∂q_c (those
  sensors' gradients hold no rate; a rate sensor's ∂s_r/∂v is a coordinate's unit), the gradients those of
  :func:`_sensor_kinematics` (:func:`_general_coupling_rates_part`);
* the point loads such a controller drives (:func:`exact_loads_by_rates`): a component a y + b moves with a rate
  sensor by a ∂y/∂θ̇_i, the load's block (linear in its values) by K_l(a ∂y/∂θ̇_i e_c) w from the generated
  ``point_load_stiffness_D_q``, and its couplings g ∂y/∂θ_j (g: ``point_load``'s force at a e_c) by g ∂²y/∂θ_j∂θ̇_i
  (:func:`_load_rates_part`); with the hinges' and couplings' parts one sparse n × n matrix,
  :func:`rates_tangent_of_weight`;
* the couplings (on a hinge's force) and driven loads of the other controllers of :func:`_exact_controllers`
  (:func:`_rates_chain_controllers`, a model without rigid links or guides): those reading points' velocities at an
  offset or relative to a body, cables' tensions, elements' section forces, free joints' forces (whose laws are
  generated along the rates), inputs, their states and other such controllers. Each read a_p carries
  G_p = ∂a_p/∂q · w, V_p = ∂a_p/∂v and M_p = ∂(∂a_p/∂q · w)/∂v (:func:`_read_moves`: a point's velocity at an
  offset, v + ω × T r, and relative to a body, ``point_velocity_in_body``, linear and homogeneous in the rates, value
  and gradient along q alike, so V is its rate gradient and M its gradient's product at the unit rates; a cable's
  tension N_el + c ℓ̇ affine in them, ``cable_tension``'s gradient at the unit rates less at none; a free joint's
  force −f by −∂f/∂θ̇ (``hinge_force``) and −∂K_jj/∂θ̇ w_j (``hinge_stiffness_by_rate``); an angle, a position, a
  cable's length and a section force no rate; a rate a unit V), a controller's output through the chain rule,
  M_k = Σ_pr ∂²f/∂a_p∂a_r G_p V_r + Σ_p ∂f/∂a_p M_p with SymPy's second derivatives by all its moving reads
  (:func:`_chain_rates_moves`, 0 while saturated); a hinge's row moves by −a M_k
  (:func:`_chain_coupling_rates_part`), a driven load's node rows by K_l(a e_c) w V_k + g M_k
  (:func:`_chain_load_rates_part`, ``point_load_stiffness_D_q`` and ``point_load`` as :func:`_load_rates_part`);
* the damped taut cables' blocks: K_c is affine in the rates, so ``cable_stiffness_D_q`` at δv less at 0
  (:func:`cable_stiffness_by_rates`).

Still a central difference (:func:`rates_rest_needed`; two evaluations a parameter, the adjoint's two a free rate),
of the blocks not generated alone (:func:`rates_rest_product`: K w of those blocks, the others out): a hinge law of
θ whose slope does not parse back as a law (:func:`exact_hinges_by_rates`), and the couplings and driven loads of a
controller outside :func:`_exact_controllers` or whose second derivatives by its rate reads are not functions, or
which reads a free joint's force whose laws are not generated along the rates (:func:`exact_couplings_by_rates`,
:func:`exact_loads_by_rates`). Rigid links and guides: the rates' move is in
``TransientSensitivities._linked_weight_derivative`` (above), not here.
"""
from __future__ import annotations

import math
import weakref

import numpy as np

from latdyn.numerics import csr
from latdyn.numerics.csr import CSR
from latdyn.numerics.linalg import RCM_IN_PYTHON

__all__ = ["cable_stiffness_by_rates", "configuration_tangent_of_weight", "exact_couplings", "exact_couplings_by_rates",
           "exact_hinges", "exact_hinges_by_rates", "exact_loads", "exact_loads_by_rates",
           "geometric_product", "geometric_second_product", "linked_configuration_tangent", "linked_geometric_derivative",
           "linked_cable_rates_product", "linked_chain_rates_product", "linked_coupling_rates_product",
           "linked_exact_couplings", "linked_exact_hinges",
           "linked_generated_loads",
           "linked_geometric_rate_in_time", "linked_has_rest", "linked_rate_moving_hinges", "linked_rates_tangent",
           "linked_rest_product",
           "needs_the_kernel", "rates_rest_needed", "rates_rest_product", "rates_tangent_of_weight",
           "refuse_without_kernel", "rest_support", "stiffness_moving_with_rates", "times", "transposed_times"]

#: the names of the evaluation's blocks of K, in their order (latdyn.assembly.assembler.Assembler.evaluation_in)
STIFFNESS_BLOCKS = ("elements", "joint bodies", "joints", "loads and cables", "controllers' couplings")
#: the move of the free rates that :func:`stiffness_moving_with_rates` compares K at, relative to the rates' size
#: (their largest, or 1): small enough to stay on one side of a law's kinks, large enough that a rate's term of
#: 1e-12 of its entry moves the entry's last bits
RATES_MOVE = 1e-3
#: id(law) -> (the law, its :func:`_angle_slope_law`): parsed once per law in a process (the law kept, so that its id
#: is not reused)
_SLOPES: dict = {}
#: (output's expression, symbols, moving reads) -> its :func:`_output_curvature`, made once per process (a scene
#: loaded again reuses it; the expression's hash, not its printed text: printing it at each event cost the boom's H
#: 2.7 ms)
_CURVATURES: dict = {}
#: id(the assembler's controllers' wiring) -> (a weak reference to the wiring, its :func:`linked_exact_couplings`):
#: found once per wiring (a latch's renumbering wires them again), not at each of an event's evaluations (the outputs'
#: text from SymPy: 18 ms an event on the gimbal with a mixed PD before, 9 ms after)
_LINKED_COUPLINGS: dict = {}
#: id(wiring) -> (the wiring, its :func:`_exact_controllers`): found once per numbering of a model in a process
_EXACT: dict = {}
#: (output's expression, symbols, angle reads, rate reads) -> its :func:`_output_mixed`, made once per process
_MIXED: dict = {}


def _sparse(rows: np.ndarray, cols: np.ndarray, values: np.ndarray, n: int):
    """The n × n matrix of the entries (rows, cols, values) on the free coordinates (others dropped), summed:
    a :class:`latdyn.numerics.csr.CSR` up to :data:`latdyn.numerics.linalg.RCM_IN_PYTHON` coordinates (as the
    latch's impulse, :func:`latdyn.timeloop.impulse.without_scipy`: importing scipy.sparse for it cost the boom's
    sensitivity run ≈ 0.07 s), else SciPy's CSR."""
    keep = (rows < n) & (cols < n)
    if n <= RCM_IN_PYTHON:
        return CSR.from_coo(values[keep], rows[keep], cols[keep], (n, n))
    import scipy.sparse as sps  # the events' derivatives only

    return sps.csr_matrix((values[keep], (rows[keep], cols[keep])), shape=(n, n))


def times(H, x: np.ndarray) -> np.ndarray:
    """H x for :func:`configuration_tangent_of_weight`'s H (either storage; the same sums), floats even where H has no
    entry (NumPy's ``bincount`` of nothing is integer: an empty generated part then took no float difference added in
    place, a traceback at 86d57d9 on the wheel's stop with a damper naming an input)."""
    return np.asarray(csr.times(H, x) if isinstance(H, CSR) else H @ x, float)


def transposed_times(H, x: np.ndarray) -> np.ndarray:
    """Hᵀ x for :func:`configuration_tangent_of_weight`'s H (either storage; the same sums; floats, as
    :func:`times`)."""
    return np.asarray(csr.transposed_times(H, x) if isinstance(H, CSR) else H.T @ x, float)


def needs_the_kernel(scene, model) -> bool:
    """Whether the sensitivities of ``scene`` may take H through ``beam_stiffness_D_q``: the model has beam elements,
    no rigid links or guides (their weight's derivative stays a difference, ``TransientSensitivities``), and the scene
    has events (latdyn.analyses.sensitivities.has_events) or a joint with friction (its stick's jump)."""
    from latdyn.analyses.sensitivities import has_events

    if model.links is not None or not len(model.element_dofs):
        return False
    return has_events(scene) or any(h.friction is not None for h in model.hinges)


def refuse_without_kernel(assembler) -> None:
    """SceneError (exit 2) naming ``solve.sensitivities`` where the generated variant predates ``beam_stiffness_D_q``
    (the committed tree regenerates every variant at once; a variant regenerated alone says which command): at the
    sensitivities' start where :func:`needs_the_kernel` (``TransientSensitivities.start``, the adjoint's too, before
    the first step), and at each event's H with elements along w."""
    kernels = assembler.kernels
    if "beam_stiffness_D_q" in (getattr(kernels, "info", None) or {}):
        return
    from latdyn.errors import SceneError

    variant = getattr(kernels, "variant", "?")
    raise SceneError(assembler.model.scene.file, "solve.sensitivities",
                     "the sensitivities through an event need the kernel beam_stiffness_D_q, which the generated "
                     f"variant {variant!r} does not hold yet; expected it regenerated (python -m codegen --variant "
                     f"{variant})")


def _generated(assembler, state, w: np.ndarray, scale: float, mass: bool, full: np.ndarray | None = None):
    """(rows, cols, values) of the generated part of H (module docstring): the elements' and the joint bodies'.
    ``full`` (n_total + 1; default w on the free coordinates, 0 elsewhere): the direction on every coordinate, the
    dependent nodes' too (a model with rigid links or guides: P w, :func:`linked_configuration_tangent`)."""
    model, kernels = assembler.model, assembler.kernels
    if full is None:
        full = np.zeros(model.n_total + 1)
        full[:model.n_dofs] = w
    rows, cols, values = [], [], []
    dofs = model.element_dofs
    along = full[dofs]
    on = np.flatnonzero(np.any(along != 0.0, axis=1))   # an element without w has no term: K_e w_e, M_e w_e = 0
    if len(on):
        refuse_without_kernel(assembler)
        geometry = np.ascontiguousarray(assembler.native().element_inputs(state)[0][on])
        direction = np.ascontiguousarray(along[on])
        sections = np.ascontiguousarray(model.element_sections[on])
        blocks = scale * np.asarray(kernels.beam_stiffness_D_q(geometry, direction, sections)[1]).reshape(-1, 14, 14)
        if mass:
            rest = np.zeros_like(direction)
            blocks = blocks + np.asarray(kernels.beam_inertia_tangent(
                geometry, rest, direction, sections, np.zeros((len(on), 3)))[1]).reshape(-1, 14, 14)
        d = dofs[on]
        rows.append(np.broadcast_to(d[:, :, None], blocks.shape).ravel())
        cols.append(np.broadcast_to(d[:, None, :], blocks.shape).ravel())
        values.append(blocks.ravel())
    nodes = model.body_nodes
    d = model.node_dofs[nodes]                                                       # (b, 6): [d; π]
    moving = full[np.where(d < model.n_assembled, d, model.n_total)]   # free (and dependent) coordinates
    if len(nodes) and np.any(moving) and (mass or assembler.has_gravity):
        moving = np.ascontiguousarray(moving)
        section = np.ascontiguousarray(np.concatenate([model.body_mass[:, None], model.body_com,
                                                       model.body_inertia.reshape(-1, 9)], axis=1))
        frames = np.ascontiguousarray(state.T[nodes].reshape(-1, 9))
        blocks = np.zeros((len(nodes), 6, 6))
        if mass:   # ∂(M_b w_b)/∂q_b: the inertia stiffness at rest with accelerations w_b, no gravity
            motion = np.ascontiguousarray(np.concatenate([np.zeros((len(nodes), 3)), moving], axis=1))
            blocks += np.asarray(kernels.joint_body_inertia_stiffness(frames, motion, section,
                                                                      np.zeros((len(nodes), 3)))[0]).reshape(-1, 6, 6)
        if assembler.has_gravity:   # s ∂(G_b w_b)/∂q_b: the weight's stiffness along w_b
            gravity = np.ascontiguousarray(np.repeat(assembler.gravity[None], len(nodes), axis=0))
            blocks += scale * np.asarray(kernels.joint_body_gravity_stiffness_D_q(
                frames, moving, section, gravity)[1]).reshape(-1, 6, 6)
        rows.append(np.broadcast_to(d[:, :, None], blocks.shape).ravel())
        cols.append(np.broadcast_to(d[:, None, :], blocks.shape).ravel())
        values.append(blocks.ravel())
    if not rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(values)


def rest_support(assembler) -> np.ndarray:
    """The free coordinates the blocks of H_rest are on (module docstring), sorted: the angles of the free hinges
    whose part is not generated (:func:`exact_hinges`), the nodes and frame bodies of the point loads a continuous
    controller drives (:func:`exact_loads`), and the rows and columns of the continuous controllers' couplings not
    generated (:func:`exact_couplings`). Empty where the model has none of them."""
    model = assembler.model
    n = model.n_dofs
    found = [model.hinge_dofs[model.free_hinges][~exact_hinges(assembler)].ravel()]
    if len(assembler.loads):
        driven = ~exact_loads(assembler)
        found += [model.node_dofs[assembler._load_nodes[driven]].ravel(), assembler._load_columns()[driven].ravel()]
    control = assembler.control
    differenced = ~exact_couplings(assembler)
    found += [np.asarray(control.coupling_rows)[differenced], np.asarray(control.coupling_cols)[differenced]]
    every = np.concatenate([np.asarray(f, np.int64) for f in found] + [np.zeros(0, np.int64)])
    return np.unique(every[(every >= 0) & (every < n)])


def exact_loads(assembler) -> np.ndarray:
    """(loads,) bool: whether the point load's part of H is generated (:func:`_load_part`): each of its components
    a continuous controller drives (alone or through a law a y + b; latdyn.assembly.control: its values then move
    with the controller's sensors, the couplings' columns) is driven by one of :func:`_exact_controllers` (its
    values' and couplings' derivatives along q then generated, :func:`_driven_load_part`); otherwise its block
    stays in :func:`rest_support`'s difference."""
    control = assembler.control
    out = np.ones(len(assembler.loads), bool)
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    if not np.any(kinds == 1):
        return out
    plain = _exact_controllers(assembler)
    for a in np.flatnonzero(kinds == 1):
        if not plain[int(control.actuator_controller[a])]:
            out[int(control.actuator_index[a])] = False
    return out


def _scattered(dofs: np.ndarray, n_total: int) -> np.ndarray:
    """``dofs`` with the slots that are no coordinate (negative) on n_total, the slot :func:`_sparse` drops and a
    direction reads 0 at."""
    return np.where(dofs < 0, n_total, dofs)


def _law_value(component, t: float) -> float:
    """A load component's value at t: its law of time, or a constant."""
    return float(component.value(t)) if hasattr(component, "value") else float(component)


def _load_part(assembler, state, w: np.ndarray, scale: float, full: np.ndarray | None = None,
               exact: np.ndarray | None = None):
    """(rows, cols, values) of the point loads' part of H: s ∂(K_l w_l)/∂[π_node, π_frame] for each load of
    :func:`exact_loads` with w on its block's columns, from the generated ``point_load_stiffness_D_q``
    (codegen/joints.py) at the load's values at the state (its laws of t, the components a controller drives at its
    output there: :func:`_load_values`; the evaluation's load factor 1). The driven values' own move along q is
    :func:`_driven_load_part`'s. ``full`` (n_total + 1; default w on the free coordinates, 0 elsewhere): the direction
    on every coordinate, a dependent node's turns too (a model with rigid links or guides: P w,
    :func:`linked_configuration_tangent`); ``exact`` (loads,) bool: the loads taken (default :func:`exact_loads`)."""
    model, loads = assembler.model, assembler.loads
    if full is None:
        full = np.zeros(model.n_total + 1)
        full[:model.n_dofs] = w
    follower = np.array([load.frame != "global" for load in loads], bool)
    columns = _scattered(assembler._load_columns(), model.n_total)
    along = full[columns]
    along[~follower, 3:] = 0.0   # a global load has no frame: its block's frame half is zero (csrc/evaluate.c)
    exact = exact_loads(assembler) if exact is None else exact
    on = np.flatnonzero(exact & np.any(along != 0.0, axis=1))
    if not len(on):
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    values = _load_values(assembler, state, on)
    nodes, frames = assembler._load_nodes[on], assembler._load_frames[on]
    frame_turns = np.where(follower[on][:, None, None], state.T[frames], np.eye(3))
    rows = lambda a: np.ascontiguousarray(np.reshape(a, (len(on), -1)), dtype=float)  # noqa: E731
    blocks = np.asarray(assembler.kernels.point_load_stiffness_D_q(
        rows(state.T[nodes]), rows(assembler._load_offsets[on]), rows(values), rows(frame_turns),
        rows(along[on]))[1]).reshape(-1, 6, 6).copy()
    blocks[~follower[on], :, 3:] = 0.0
    blocks *= scale
    d = _scattered(model.node_dofs[nodes], model.n_total)
    c = columns[on]
    return (np.broadcast_to(d[:, :, None], blocks.shape).ravel(), np.broadcast_to(c[:, None, :], blocks.shape).ravel(),
            blocks.ravel())


def _driving(assembler, state):
    """[(load, component, gain a, controller k)] of the load components continuous controllers drive (a = ∂τ/∂y
    of a law a y + b, 1 for the name alone) and the controllers' outputs at ``state`` with their curvatures
    (:func:`_controller_curvatures`, for the controllers of :func:`_exact_controllers`; their gradients too):
    (actuators, outputs, gradients, columns, curvatures)."""
    control = assembler.control
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    actuators = [(int(control.actuator_index[a]), int(control.actuator_component[a]),
                  float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0,
                  int(control.actuator_controller[a])) for a in np.flatnonzero(kinds == 1)]
    if not actuators:
        return actuators, {}, {}, np.zeros(0, np.int64), {}
    columns, curvatures, outputs, gradients = _controller_curvatures(assembler, state, _exact_controllers(assembler),
                                                                     with_outputs=True)
    return actuators, outputs, gradients, columns, curvatures


def _load_values(assembler, state, on: np.ndarray) -> np.ndarray:
    """(len(on), 6) the values [force; moment] of the loads ``on`` at ``state``: their laws of t at its time, and a
    component a continuous controller drives at the controller's output there (:func:`_controller_curvatures`;
    a law a y + b as a y + b(t), b(t) its value less a times the output it read)."""
    loads = assembler.loads
    t = float(state.t)
    values = np.array([[_law_value(c, t) for c in (loads[l].force or [0.0] * 3)]
                       + [_law_value(c, t) for c in (loads[l].moment or [0.0] * 3)] for l in on], float)
    actuators, outputs, _, _, _ = _driving(assembler, state)
    if not actuators:
        return values
    held = assembler.model.scene.controller_outputs
    row = {int(l): i for i, l in enumerate(on)}
    for l, p, gain, k in actuators:
        if l not in row or k not in outputs:
            continue
        law = (loads[l].force if p < 3 else loads[l].moment)[p % 3]
        alone = assembler.control.load_controller[l, p] == k
        before = 0.0 if alone else values[row[l], p] - gain * float(held[assembler.control.controllers[k].name])
        values[row[l], p] = gain * outputs[k] + before
    return values


def _driven_load_part(assembler, state, w: np.ndarray, scale: float, full: np.ndarray | None = None,
                      exact: np.ndarray | None = None):
    """(rows, cols, values) of the part of H that the load components driven by controllers of
    :func:`_exact_controllers` add beyond :func:`_load_part`'s turns (at the driven values): with e_p a unit
    component times the gain a, F(e_p) its generalized force on the node's six rows (``point_load``'s, as
    csrc/evaluate.c controller_couplings takes it) and K_l(e_p) its block on the load's columns (by the node's and
    the frame's turns), y the controller's output, g = ∂y/∂q and G = ∂²y/∂q∂q over the angle coordinates it reaches
    (:func:`_controller_curvatures`):

        the load's block, its values moving:         s (K_l(e_p) w_l) gᵀ              (node rows × angle columns)
        the couplings F(e_p) gᵀ, F turning:          s K_l(e_p) (gᵀ w)                (node rows × load columns)
        the couplings, g moving:                     s F(e_p) (G w)ᵀ                  (node rows × angle columns)

    0 for a saturated controller (g, G = 0). ``full`` (n_total + 1; default w on the free coordinates): the direction on
    every assembled coordinate (a model with rigid links or guides, u = P w: :func:`linked_configuration_tangent`);
    ``exact`` (loads,) bool: the loads taken (default :func:`exact_loads`; :func:`linked_generated_loads`)."""
    actuators, _, gradients, columns, curvatures = _driving(assembler, state)
    model = assembler.model
    n = model.n_dofs
    exact = exact_loads(assembler) if exact is None else exact
    actuators = [(l, p, gain, k) for l, p, gain, k in actuators if exact[l] and np.any(gradients.get(k, 0.0))]
    if not actuators:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    if full is None:
        full = np.zeros(model.n_total + 1)
        full[:n] = w
        along = np.where(columns < n, w[np.minimum(columns, n - 1)], 0.0)
    else:
        along = full[columns] if len(columns) else np.zeros(0)
    loads = assembler.loads
    load_columns = _scattered(assembler._load_columns(), model.n_total)
    rows = lambda a: np.ascontiguousarray(np.reshape(a, (1, -1)), dtype=float)  # noqa: E731
    out_rows, out_cols, out_values = [], [], []
    for l, p, gain, k in actuators:
        follower = loads[l].frame != "global"
        node, frame = int(assembler._load_nodes[l]), int(assembler._load_frames[l])
        unit = np.zeros(6)
        unit[p] = gain
        force, _, by_node, by_frame = (np.asarray(x) for x in assembler.kernels.point_load(
            rows(state.T[node]), rows(assembler._load_offsets[l]), rows(unit),
            rows(state.T[frame] if follower else np.eye(3)), rows(np.zeros(6))))
        block = np.concatenate([by_node.reshape(6, 3), by_frame.reshape(6, 3) if follower else np.zeros((6, 3))],
                               axis=1)
        force = force.reshape(6)
        c = load_columns[l]
        w_l = full[c]
        d = _scattered(model.node_dofs[node], model.n_total)
        g, G = gradients[k], curvatures[k]
        for r_, c_, v_ in ((d[:, None] + 0 * columns[None], columns[None] + 0 * d[:, None],
                            np.outer(block @ w_l, g) + np.outer(force, G.T @ along)),
                           (d[:, None] + 0 * c[None], c[None] + 0 * d[:, None], block * float(g @ along))):
            out_rows.append(r_.ravel())
            out_cols.append(c_.ravel())
            out_values.append(scale * v_.ravel())
    return np.concatenate(out_rows), np.concatenate(out_cols), np.concatenate(out_values)


def cable_stiffness_by_rates(assembler, state, w: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """∂(K w)/∂v δv (n, k) of the cable elements taut at ``state`` (as :func:`_cable_part` finds them), each column of
    ``dv`` (n, k) a move of the free rates: K_c is affine in the rates (the damper's c ℓ̇, ℓ̇ linear in the ends'
    velocities), so K_c(δv) w − K_c(0) w from the generated ``cable_stiffness_D_q``'s ``cable_stiffness_along`` is
    it exactly (``TransientSensitivities._stiffness_by_rates`` where the loads' and cables' block moves with the
    rates, :func:`stiffness_moving_with_rates`; a load a controller drives there is :func:`rates_rest_product`'s)."""
    model = assembler.model
    n, k = dv.shape
    taut = _taut_cables(assembler, state)
    if taut is None or not k:
        return np.zeros((n, k))
    full, moves = np.zeros(model.n_total + 1), np.zeros((model.n_total + 1, k))
    full[:n], moves[:n] = w, dv
    return _cable_rates_product(assembler, taut, full, moves)[:n]


def _cable_rates_product(assembler, taut, full: np.ndarray, moves: np.ndarray) -> np.ndarray:
    """K_c(δv) w − K_c(0) w (n_total + 1, k) of the taut cable elements ``taut`` (:func:`_taut_cables`) along
    ``full`` (n_total + 1), each column of ``moves`` (n_total + 1, k) a move of the rates on every coordinate: the
    generated ``cable_stiffness_D_q``'s ``cable_stiffness_along`` at the move less at none (K_c affine in the
    rates)."""
    dofs, geometry, _, section = taut
    k = moves.shape[1]
    along = full[dofs]                                          # (e, 12)
    m = len(dofs)
    rows = lambda a: np.ascontiguousarray(np.reshape(a, (m * k, -1)), dtype=float)  # noqa: E731
    repeated = lambda a: np.repeat(a[:, None], k, axis=1)  # noqa: E731   (e, k, ·)
    velocity = np.transpose(moves[dofs], (0, 2, 1))            # (e, k, 12): each column's move on the element
    kernel = assembler.kernels.cable_stiffness_D_q
    at = (rows(repeated(geometry)), rows(repeated(section)), rows(repeated(along)))
    moved = np.asarray(kernel(at[0], rows(velocity), at[1], at[2])[0]).reshape(m, k, 12)
    still = np.asarray(kernel(at[0], rows(np.zeros_like(velocity)), at[1], at[2])[0]).reshape(m, k, 12)
    grown = np.zeros((len(full), k))
    np.add.at(grown, dofs, np.transpose(moved - still, (0, 2, 1)))
    return grown


def _taut_cables(assembler, state):
    """(dofs (e, 12) with n_total for no coordinate, geometry (e, 12), velocity (e, 12), section (e, 4)) of the cable
    elements taut at ``state`` (csrc/evaluate.c ``cables``: held taut, or on no side a positive gap min(N_el, N)), the
    generated cable kernels' inputs; None where there is none."""
    model, cables = assembler.model, assembler.model.cables
    if cables is None or not len(cables.nodes):
        return None
    geometry, velocity, section, taut = _cable_inputs(assembler, state, np.arange(len(cables.nodes)))
    if not np.any(taut):
        return None
    dofs = _scattered(assembler.cable_dofs(), model.n_total)
    return dofs[taut], geometry[taut], velocity[taut], section[taut]


def _cable_inputs(assembler, state, on: np.ndarray):
    """(geometry (e, 12), velocity (e, 12), section (e, 4), taut (e,) bool) of the cable elements ``on`` at ``state``:
    the generated cable kernels' inputs, and whether each is taut as csrc/evaluate.c ``cables`` decides (held taut,
    or on no side a positive gap min(N_el, N))."""
    from latdyn.analyses.cable_sensitivities import _turned

    cables = assembler.model.cables
    t = float(state.t)
    nodes = cables.nodes[on]
    geometry = np.array([np.concatenate([state.x[a], state.x[b], _turned(state.T[a], cables.offsets[e, 0]),
                                         _turned(state.T[b], cables.offsets[e, 1])])
                         for e, (a, b) in zip(on, nodes)])
    velocity = np.concatenate([state.v[nodes[:, 0]], state.w[nodes[:, 0]], state.v[nodes[:, 1]], state.w[nodes[:, 1]]],
                              axis=1)
    rest = [cables.rest_length[cables.cable[e]] for e in on]
    section = np.column_stack([cables.share[on] * [r.value(t) for r in rest],
                               cables.share[on] * [r.rate(t) for r in rest], cables.EA[on], cables.damping[on]])
    rows = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    geometry, velocity, section = rows(geometry), rows(velocity), rows(section)
    law = np.asarray(assembler.kernels.cable_force(geometry, velocity, section)[3]).reshape(-1, 5)
    sides = np.asarray(cables.sides, float)[on]
    taut = (sides > 0) | ((sides == 0) & (np.minimum(law[:, 3], law[:, 4]) > 0.0))
    return geometry, velocity, section, taut


def _cable_part(assembler, state, w: np.ndarray, scale: float, full: np.ndarray | None = None):
    """(rows, cols, values) of the cable elements' part of H: s ∂(K_e w_e)/∂[d1, π1, d2, π2] for each element taut
    at the state (:func:`_taut_cables`; a slack one's K is zero, its derivative too) with w on its coordinates, from
    the generated ``cable_stiffness_D_q`` (codegen/joints.py: the taut law, the damper's c ℓ̇ at the state's rates
    included). ``full``: the direction on every coordinate, as :func:`_load_part`'s (a dependent node's too)."""
    model = assembler.model
    taut = _taut_cables(assembler, state)
    if taut is None:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    dofs, geometry, velocity, section = taut
    if full is None:
        full = np.zeros(model.n_total + 1)
        full[:model.n_dofs] = w
    along = full[dofs]
    on = np.flatnonzero(np.any(along != 0.0, axis=1))
    if not len(on):
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    rows = lambda a: np.ascontiguousarray(a[on], dtype=float)  # noqa: E731
    blocks = np.asarray(assembler.kernels.cable_stiffness_D_q(rows(geometry), rows(velocity), rows(section),
                                                              rows(along))[1]).reshape(-1, 12, 12) * scale
    d = dofs[on]
    return (np.broadcast_to(d[:, :, None], blocks.shape).ravel(), np.broadcast_to(d[:, None, :], blocks.shape).ravel(),
            blocks.ravel())


def _output_curvature(controller, moving: tuple):
    """SymPy's f, ∂f/∂a_i and ∂²f/∂a_i∂a_j of a continuous controller's output f before saturation by its reads at the
    positions ``moving`` of ``controller.reads`` (those that move with the configuration: its sensors of
    :data:`_MOVING_SENSORS` and the earlier controllers it reads; a rate, an input and a state are held along q; Dirac
    deltas dropped from the first, as the compiled law's), lambdified once per output's expression, symbols and
    positions in a process (:data:`_CURVATURES`: a scene loaded again, its parameters the same, reuses it), a
    function of ``(t, *reads values, *state values)`` giving f, its m first derivatives and the (m, m) second ones,
    flat; None where a second derivative is not a function (DiracDelta of a kink, an unevaluated derivative)."""
    key = (controller.output_expr, tuple(controller.symbols), tuple(moving))
    if key not in _CURVATURES:
        import sympy as sp

        from latdyn.scene.expressions import _drop_deltas

        reads = controller.symbols[1:1 + len(controller.reads)]
        first = [sp.diff(controller.output_expr, reads[i]) for i in moving]
        second = [[sp.diff(first[a], reads[j]) if b >= a else None for b, j in enumerate(moving)]
                  for a in range(len(moving))]
        second = [second[a][b] if b >= a else second[b][a] for a in range(len(moving)) for b in range(len(moving))]
        singular = any(e.has(sp.DiracDelta, sp.Derivative, sp.Subs) for e in second)
        _CURVATURES[key] = None if singular else sp.lambdify(controller.symbols,
                                                             [controller.output_expr]
                                                             + [_drop_deltas(e) for e in first] + second,
                                                             modules=["math", "numpy"])
    return _CURVATURES[key]


def _controller_reads(control, k: int) -> list:
    """For each name controller ``k`` reads (``controller.reads``, its law's arguments after t, before its
    states): ``(kind, index, sensor)`` of the sensor that gives it (latdyn.assembly.control: kinds ANGLE, RATE,
    CONTROLLER, …, in the order of the wiring's sensors), or ``(None, name, -1)`` for a name no sensor gives: an
    input or a sampled controller's held output, read from the scene's arrays (as the compiled laws read them)."""
    controller = control.controllers[k]
    sensed = set(control.sensor_names(k))
    m = int(control.sensor_start[k])
    out = []
    for name in controller.reads:
        if name in sensed:
            out.append((int(control.sensor_kind[m]), int(control.sensor_index[m]), m))
            m += 1
        else:
            out.append((None, name, -1))
    return out


#: the sensor kinds whose values move along q with a second derivative :func:`_sensor_kinematics` gives
#: (latdyn.assembly.control: a joint's angle, a point's global position component at its node or at an offset, a
#: point's position component in a body's axes, a point's velocity at an offset (by its node's turn: v + ω × T r at
#: the rates held), a cable's length, a cable's tension, an element's section force, a point's velocity relative to a
#: body in its axes (at the rates held), a free joint's force), and those held along q (a joint's rate, a node's
#: velocity)
_MOVING_SENSORS, _HELD_SENSORS = (0, 2, 5, 6, 7, 8, 11, 12, 13, 14), (1, 3)
#: the generated second derivative a force sensor's move along q needs (codegen/joints.py, codegen/derivation.py): a
#: cable's tension (kind 11) and an element's section force (12); a variant generated before it keeps the difference
_FORCE_SECOND = {11: "cable_tension_D_q_D_q", 12: "beam_section_forces_D_q_D_q"}
#: the generated second derivatives of the sensors that have their own kernel: the force sensors' and a point's
#: velocity relative to a body (13, codegen/joints.py ``point_velocity_in_body_D_q_D_q``); a joints unit generated
#: before it keeps the difference
_SENSOR_SECOND = {**_FORCE_SECOND, 13: "point_velocity_in_body_D_q_D_q"}


def _exact_controllers(assembler) -> list:
    """(controllers,) bool: whether a continuous controller's output has its second derivatives along q generated
    (:func:`_controller_curvatures`): it reads joints' angles and rates, points' positions and displacements
    (global, at an offset, in a body's axes), nodes' velocities, points' velocities at an offset and relative to a
    body, cables' lengths and tensions, elements' section forces (where the variant holds :data:`_SENSOR_SECOND`'s
    kernels), free joints'
    forces whose laws are generated
    (:func:`exact_hinges`), inputs, its own states (held across the impulse) and earlier controllers of this kind
    alone, with an output whose second derivatives by the sensors that move
    and the controllers it reads are functions (:func:`_output_curvature`)."""
    from latdyn.assembly.control import CONTROLLER

    control = assembler.control
    known = _EXACT.get(id(control))
    if known is not None and known[0] is control:
        return known[1]
    model = assembler.model
    generated = dict(zip((int(j) for j in model.free_hinges), exact_hinges(assembler)))
    info = getattr(assembler.kernels, "info", None) or {}
    held = {kind for kind, name in _SENSOR_SECOND.items() if name not in info}
    out = []
    for k, controller in enumerate(control.controllers):
        reads = _controller_reads(control, k)
        plain = all(kind is None or (kind in _MOVING_SENSORS + _HELD_SENSORS and (kind != 14 or generated.get(index))
                                     and kind not in held)
                    or (kind == CONTROLLER and out[index]) for kind, index, _ in reads)
        moving = tuple(p for p, (kind, _, _) in enumerate(reads) if kind in _MOVING_SENSORS + (CONTROLLER,))
        out.append(plain and _output_curvature(controller, moving) is not None)
    if len(_EXACT) >= 64:   # one entry a numbering: a process running many scenes keeps the last ones
        _EXACT.clear()
    _EXACT[id(control)] = (control, out)
    return out


def _sensor_dofs(assembler, kind: int, index: int, sensor: int) -> np.ndarray:
    """The coordinates a sensor of :data:`_MOVING_SENSORS` moves with (latdyn.assembly.control ``_sensor``'s
    columns; a slot that is no coordinate on n_total)."""
    model = assembler.model
    if kind in (0, 14):
        dofs = [model.hinge_dofs[index]]
    elif kind == 2:
        dofs = [model.node_dofs[index // 3, index % 3]]
    elif kind == 5:
        dofs = model.node_dofs[index // 3]
    elif kind == 6:   # its K columns: the node's turn (the node's six rates are C's)
        dofs = model.node_dofs[index // 3, 3:]
    elif kind == 8:   # each element's end nodes, as csrc/evaluate.c's gradient (12 columns an element)
        dofs = model.node_dofs[model.cables.nodes[_cable_elements(assembler, index, sensor)]].reshape(-1)
    elif kind == 11:  # its K columns: the first element's end nodes (their six rates are C's)
        dofs = model.node_dofs[model.cables.nodes[index]].reshape(-1)
    elif kind == 12:  # the element's fourteen coordinates
        dofs = model.element_dofs[index // 4]
    else:
        dofs = np.concatenate([model.node_dofs[index // 3], model.node_dofs[assembler.control.sensor_frame_node[sensor]]])
    return _scattered(np.asarray(dofs, np.int64), model.n_total)


def _point_load(assembler, T, r, values, R):
    """The generated ``point_load``'s (force (b, 6), ∂force/∂π_node (b, 6, 3), ∂force/∂π_frame (b, 6, 3)) for rows
    of node frames T, offsets r, values [F; Mo] and frames R (no velocity) — the kinematics of a point x + T r under
    the configuration's update (csrc/evaluate.c ``sensor`` takes a point sensor's gradient from it)."""
    values = np.atleast_2d(np.asarray(values, float))
    b = len(values)
    rows = lambda a: np.ascontiguousarray(np.broadcast_to(np.reshape(a, (1, -1)), (b, np.size(a))), dtype=float)  # noqa: E731
    out = assembler.kernels.point_load(rows(T), rows(r), np.ascontiguousarray(values), rows(R), np.zeros((b, 6)))
    return (np.asarray(out[0]).reshape(b, 6), np.asarray(out[2]).reshape(b, 6, 3), np.asarray(out[3]).reshape(b, 6, 3))


def _sensor_kinematics(assembler, state, kind: int, index: int, sensor: int):
    """(∂s/∂q on :func:`_sensor_dofs` (d,), ∂(∂s/∂q_c)/∂q_i (d, d): row c the gradient's column, column i the move,
    or None where 0) of a sensor of :data:`_MOVING_SENSORS` at ``state``, under the configuration's update
    (x += d, T ← exp(skew π) T): an angle and a global component x_c are linear in q; a free joint's force −f of its
    laws has −K_jj (``hinge_force``'s ∂f/∂θ) moving with −∂K_jj/∂θ (``hinge_stiffness_by_angle``, as
    :func:`_hinge_part`); a point's velocity v + ω × T r at an offset, by the node's turn at fixed rates, the moment
    rows of ``point_load`` at the values −(e_c × ω) (csrc/evaluate.c's) moving with that call's ∂/∂π_node; a point
    x + T r at an offset,
    component c, has the gradient Jᵀ e_c = ``point_load``'s force for the values −e_c and its move by the node's turn
    that force's ∂/∂π_node; a point's component in a body's axes s = b·(x + T r − x_b), b = T_b e_c, has the
    gradient [b; T r × b] on the point's node (``point_load`` at the frame T_b, values −e_c: its ∂/∂π_node and
    ∂/∂π_frame move it), −b on the body's translation (moved by the body's turn as that force's first rows), and
    b × u on the body's turn, u = x + T r − x_b (``point_load`` at the body's node with offset e_c and values −u:
    its ∂/∂π_node moves it at fixed u; u moves with the point's Jacobian J and −I on the body's translation,
    b × δu the same kernel's moment rows for the values −δu)."""
    if kind in (0, 2):
        return np.ones(1), None
    if kind == 8:
        return _cable_length_kinematics(assembler, state, index, sensor)
    if kind == 11:
        return _tension_kinematics(assembler, state, index)
    if kind == 12:
        return _section_force_kinematics(assembler, state, index, sensor)
    if kind == 13:
        return _body_velocity_kinematics(assembler, state, index, sensor)
    if kind == 14:   # s = −f of the joint's laws (csrc/evaluate.c): −∂f/∂θ = −K_jj, moving with −∂K_jj/∂θ
        states, laws, curvatures, contacts = _hinge_rows(assembler, state, [index])
        kernels = assembler.kernels
        stiffness = np.asarray(kernels.hinge_force(states, laws, contacts)[1]).reshape(1)
        slope = np.asarray(kernels.hinge_stiffness_by_angle(states, laws, curvatures, contacts)[0]).reshape(1, 1)
        return -stiffness, -slope
    control = assembler.control
    node, c = index // 3, index % 3
    T, r = state.T[node], control.sensor_offset[sensor]
    unit = -np.eye(6)[c]
    if kind == 6:   # ω × T r by the turn at fixed ω: the moment rows of point_load at the values −(e_c × ω)
        lever, by_node, _ = _point_load(assembler, T, r, np.concatenate([-np.cross(np.eye(3)[c], state.w[node]),
                                                                         np.zeros(3)]), np.eye(3))
        return lever[0, 3:], by_node[0, 3:]
    if kind == 5:
        force, by_node, _ = _point_load(assembler, T, r, unit, np.eye(3))
        second = np.zeros((6, 6))
        second[:, 3:] = by_node[0]
        return force[0], second
    body = int(control.sensor_frame_node[sensor])
    Tb = state.T[body]
    gradient, second = np.zeros(12), np.zeros((12, 12))
    point, by_node, by_frame = _point_load(assembler, T, r, unit, Tb)
    gradient[:6], second[:6, 3:6], second[:6, 9:] = point[0], by_node[0], by_frame[0]
    gradient[6:9], second[6:9, 9:] = -point[0, :3], -by_frame[0, :3]
    u = state.x[node] + T @ r - state.x[body]
    lever, turned, _ = _point_load(assembler, Tb, np.eye(3)[c], np.concatenate([-u, np.zeros(3)]), np.eye(3))
    gradient[9:], second[9:, 9:] = lever[0, 3:], turned[0, 3:]
    crossed = _point_load(assembler, Tb, np.eye(3)[c], -np.eye(3, 6), np.eye(3))[0][:, 3:].T    # δu ↦ b × δu
    jacobian = _point_load(assembler, T, r, -np.eye(3, 6), np.eye(3))[0]                       # J (3, 6)
    second[9:, :6], second[9:, 6:9] = crossed @ jacobian, -crossed
    return gradient, second


def exact_couplings(assembler) -> np.ndarray:
    """(couplings,) bool: whether a continuous controller's coupling entry of K has its part of H generated
    (:func:`_coupling_part` for a hinge's or guide's force, :func:`_driven_load_part` for a load component): its
    controller is one of :func:`_exact_controllers` (joints' angles and rates, inputs, its states, earlier such
    controllers). A hinge's entry −a ∂y/∂q_c (the total derivative through the controllers read; an angle sensor's
    own second derivative is 0) then moves along q with ∂²y/∂q_c∂q_i alone, a load's F(e_p) ∂y/∂q_c with its node's
    and frame's turns too; the others keep the difference (:func:`rest_support`)."""
    control = assembler.control
    rows = np.asarray(control.coupling_rows)
    out = np.zeros(len(rows), bool)
    if not len(rows):
        return out
    plain = _exact_controllers(assembler)
    for e, a in enumerate(np.asarray(control.coupling_actuator)):
        out[e] = plain[control.actuator_controller[a]]
    return out


def _cable_elements(assembler, first: int, sensor: int) -> np.ndarray:
    """The elements of the cable whose length sensor ``sensor`` reads, from its first ``first`` (their gradient's
    columns, 12 an element: latdyn.assembly.control)."""
    control = assembler.control
    width = int(control.sensor_column_start[sensor + 1] - control.sensor_column_start[sensor])
    return first + np.arange(width // 12)


def _cable_length_kinematics(assembler, state, first: int, sensor: int):
    """:func:`_sensor_kinematics` of a cable's length ℓ = Σ_e |d_e|, d = p_b − p_a the span between its element's
    end points p = x + T r: with e = d/|d| and J_a, J_b the end points' Jacobians (``point_load``'s force for the
    values −e_j), the gradient [−J_aᵀ e; J_bᵀ e] (``point_load`` at the values ±e, as csrc/evaluate.c) moves with
    the ends' turns at fixed e (that call's ∂/∂π_node) and with e, δe = (I − e eᵀ) δd/|d|: Jᵀ (I − e eᵀ) J/|d|,
    J = [−J_a, J_b]."""
    cables = assembler.model.cables
    elements = _cable_elements(assembler, first, sensor)
    gradient, second = np.zeros(12 * len(elements)), np.zeros((12 * len(elements), 12 * len(elements)))
    for k, element in enumerate(elements):
        a, b = cables.nodes[element]
        ra, rb = cables.offsets[element, 0], cables.offsets[element, 1]
        span = state.x[b] + state.T[b] @ rb - state.x[a] - state.T[a] @ ra
        length = float(np.linalg.norm(span))
        if length == 0.0:
            continue
        e = span / length
        at = slice(12 * k, 12 * k + 12)
        toward_a, turned_a, _ = _point_load(assembler, state.T[a], ra, np.concatenate([e, np.zeros(3)]), np.eye(3))
        toward_b, turned_b, _ = _point_load(assembler, state.T[b], rb, np.concatenate([-e, np.zeros(3)]), np.eye(3))
        gradient[at] = np.concatenate([toward_a[0], toward_b[0]])
        jacobian = np.concatenate([-_point_load(assembler, state.T[a], ra, -np.eye(3, 6), np.eye(3))[0],
                                   _point_load(assembler, state.T[b], rb, -np.eye(3, 6), np.eye(3))[0]], axis=1)
        block = jacobian.T @ (np.eye(3) - np.outer(e, e)) @ jacobian / length
        block[0:6, 3:6] += turned_a[0]
        block[6:12, 9:12] += turned_b[0]
        second[at, at] = block
    return gradient, second


def _tension_kinematics(assembler, state, element: int):
    """:func:`_sensor_kinematics` of a cable's tension, its first element's N (csrc/evaluate.c: 0 while slack, as
    ``cables`` decides, its gradient too): the generated ``cable_tension_D_q_D_q`` (codegen/joints.py) at the element's
    inputs (:func:`_cable_inputs`, the damper's c ℓ̇ at the state's rates held): that gradient's derivative by the update
    of the ends; the gradient ∂N/∂q on the end nodes' [d, π] is ``cable_tension``'s, as csrc/evaluate.c's."""
    geometry, velocity, section, taut = _cable_inputs(assembler, state, np.array([element]))
    if not taut[0]:
        return np.zeros(12), None
    kernels = assembler.kernels
    gradient = kernels.cable_tension(geometry, velocity, section)[1]   # csrc/evaluate.c's, to the bit
    second = kernels.cable_tension_D_q_D_q(geometry, velocity, section)[1]
    return np.asarray(gradient, float).reshape(12), np.asarray(second, float).reshape(12, 12)


def _section_force_kinematics(assembler, state, index: int, sensor: int):
    """:func:`_sensor_kinematics` of an element's section force w0 S_k + w1 S_k+1 (latdyn.assembly.control
    SECTION_FORCE; index 4 e + k, the weights in ``sensor_offset``): the generated ``beam_section_forces_D_q_D_q``
    (codegen/derivation.py) at the element's inputs along each of its fourteen coordinates a = e_c, whose
    (∂S/∂q) e_c is the gradient's column c and ∂((∂S/∂q) e_c)/∂q its move."""
    e, k = index // 4, index % 4
    weight = assembler.control.sensor_offset[sensor]
    n = assembler.model.element_dofs.shape[1]
    geometry = np.ascontiguousarray(np.repeat(assembler.native().element_inputs(state)[0][e:e + 1], n, axis=0))
    sections = np.ascontiguousarray(np.repeat(assembler.model.element_sections[e:e + 1], n, axis=0))
    along, moved = assembler.kernels.beam_section_forces_D_q_D_q(geometry, np.eye(n), sections)
    along, moved = np.asarray(along, float).reshape(n, 4), np.asarray(moved, float).reshape(n, 4, n)
    gradient = weight[0] * along[:, k] + (weight[1] * along[:, k + 1] if k < 3 else 0.0)
    second = weight[0] * moved[:, k] + (weight[1] * moved[:, k + 1] if k < 3 else 0.0)
    return gradient, second


def _body_velocity_kinematics(assembler, state, index: int, sensor: int):
    """:func:`_sensor_kinematics` of a point's velocity relative to a body, in its axes (latdyn.assembly.control
    BODY_VELOCITY; index 3 n + c, the point's offset in ``sensor_offset``, the body's node in ``sensor_frame_node``):
    the generated ``point_velocity_in_body_D_q_D_q`` (codegen/joints.py) at the state, the rates held: the gradient's
    derivative by the update of both nodes; the gradient by [d_n, π_n, d_b, π_b] is ``point_velocity_in_body``'s, as
    csrc/evaluate.c's."""
    control = assembler.control
    node, c, body = index // 3, index % 3, int(control.sensor_frame_node[sensor])
    geometry = np.concatenate([state.x[node], state.x[body], np.reshape(state.T[node], 9),
                               control.sensor_offset[sensor], np.reshape(state.T[body], 9)])
    velocity = np.concatenate([state.v[node], state.w[node], state.v[body], state.w[body]])
    rows = (np.ascontiguousarray(geometry[None], dtype=float), np.ascontiguousarray(velocity[None], dtype=float))
    gradient = assembler.kernels.point_velocity_in_body(*rows)[1]    # csrc/evaluate.c's, to the bit
    second = assembler.kernels.point_velocity_in_body_D_q_D_q(*rows)[1]
    return np.asarray(gradient, float).reshape(3, 12)[c], np.asarray(second, float).reshape(3, 12, 12)[c]


def _controller_curvatures(assembler, state, exact: list, with_outputs: bool = False):
    """(the coordinates the controllers reach (m,), {k: ∂²y_k/∂q∂q (m, m)}) at ``state`` for the controllers of
    ``exact`` (:func:`_exact_controllers`), in their order: with a_p the arguments of f_k that move along q (a sensor
    s − s_0 of :data:`_MOVING_SENSORS`: its gradient ∂s/∂q and ∂(∂s/∂q_c)/∂q_i, :func:`_sensor_kinematics`; an
    earlier controller's output y_j: its total gradient g_j and second derivative),

        g_k = Σ_p ∂f_k/∂a_p ∂a_p/∂q,
        ∂(∂y_k/∂q_c)/∂q_i = Σ_pr ∂²f_k/∂a_p∂a_r (∂a_p/∂q_c)(∂a_r/∂q_i) + Σ_p ∂f_k/∂a_p ∂(∂a_p/∂q_c)/∂q_i

    (the chain rule of csrc/evaluate.c controller_total, once more; row c the coupling's column, column i the move),
    SymPy's first and second derivatives (:func:`_output_curvature`) at the
    arguments the evaluation reads: the sensors' values as csrc/evaluate.c computes them
    (``NativeModel.controller_outputs_at``; the controllers' array put back), the inputs' and sampled controllers'
    values from the scene's arrays, the states' held values; 0 (both) where the output is saturated
    (csrc/evaluate.c controller_outputs). ``with_outputs``: (columns, curvatures, the outputs y_k after saturation,
    the gradients g_k (m,))."""
    from latdyn.assembly.control import CONTROLLER

    control, model, scene = assembler.control, assembler.model, assembler.model.scene
    reads = {k: _controller_reads(control, k) for k, on in enumerate(exact) if on}
    dofs = {sensor: _sensor_dofs(assembler, kind, index, sensor) for entries in reads.values()
            for kind, index, sensor in entries if kind in _MOVING_SENSORS}
    columns = sorted({int(d) for found in dofs.values() for d in found})
    local = {c: i for i, c in enumerate(columns)}
    m = len(columns)
    inputs, held = getattr(scene, "inputs", None), getattr(scene, "controller_outputs", None)
    states = control.states.values if control.states is not None else np.zeros(0)
    sensed = None
    if any(kind not in (0, 1, CONTROLLER) for entries in reads.values() for kind, _, _ in entries if kind is not None):
        native = assembler.native()
        kept = held.values.copy()
        native.controller_outputs_at(state)
        held.values[:] = kept
        sensed = np.array(native.buffers["sensor_values"], float)
    t = float(state.t)
    outputs, gradients, curvatures = {}, {}, {}
    for k, entries in reads.items():
        controller = control.controllers[k]
        values, rows, seconds, moving = [], [], [], []
        for p, (kind, index, sensor) in enumerate(entries):
            if kind is None:
                values.append(float(inputs[index] if inputs is not None and index in inputs else held[index]))
                continue
            if kind == CONTROLLER:
                values.append(outputs[index])
                rows.append(gradients[index])
                seconds.append(curvatures[index])
                moving.append(p)
                continue
            values.append(float(state.theta[index] - control.sensor_origin[sensor]) if kind == 0 else
                          float(state.theta_dot[index] - control.sensor_origin[sensor]) if kind == 1 else
                          float(sensed[sensor]))
            if kind in _MOVING_SENSORS:
                gradient, second = _sensor_kinematics(assembler, state, kind, index, sensor)
                at = np.array([local[int(d)] for d in dofs[sensor]], np.int64)
                row = np.zeros(m)
                np.add.at(row, at, gradient)
                rows.append(row)
                full = np.zeros((m, m))
                if second is not None:
                    np.add.at(full, (at[:, None], at[None, :]), second)
                seconds.append(full)
                moving.append(p)
        arguments = (t, *values, *states[control.state_slot[control.state_start[k]:control.state_start[k + 1]]])
        derivatives = np.asarray(_output_curvature(controller, tuple(moving))(*arguments), float).reshape(-1)
        y = float(derivatives[0])
        lo, hi = control.limits[k]
        outputs[k] = float(min(max(y, lo), hi))
        if y < lo or y > hi or not moving:   # saturated: ∂y/∂s = 0 about the state, its derivative too
            gradients[k], curvatures[k] = np.zeros(m), np.zeros((m, m))
            continue
        slope = derivatives[1:1 + len(moving)]
        second = derivatives[1 + len(moving):].reshape(len(moving), len(moving))
        D = np.array(rows).reshape(len(moving), m)
        curvature = D.T @ second @ D
        for a, own in zip(slope, seconds):
            curvature = curvature + a * own
        gradients[k], curvatures[k] = slope @ D, curvature
    if with_outputs:
        return np.asarray(columns, np.int64), curvatures, outputs, gradients
    return np.asarray(columns, np.int64), curvatures


def _coupling_part(assembler, state, w: np.ndarray, scale: float, exact: np.ndarray | None = None,
                   full: np.ndarray | None = None):
    """(rows, cols, values) of the couplings' part of H for the entries of :func:`exact_couplings`: K's entry
    K_rc = −a ∂y/∂q_c (a = ∂τ/∂y of the hinge's law a y + b, 1 for the controller's name alone; y's total derivative
    through the controllers it reads; 0 while the output is saturated, csrc/evaluate.c controller_outputs) along w:
    s Σ_c ∂K_rc/∂q_i w_c = −s a Σ_c ∂²y/∂q_c∂q_i w_c in column i, over the angle coordinates the actuator's
    controller reaches (:func:`_controller_curvatures`; rates held: W has no C). ``exact`` (couplings,) bool: the
    entries taken (default :func:`exact_couplings`; :func:`linked_exact_couplings`, whose controllers read joints'
    angles and rates alone: their own curvatures alone are formed, or whose controllers read positions,
    :func:`_linked_position_controllers`: every controller of :func:`_exact_controllers` formed, for the chain).
    ``full`` (n_total + 1,): the direction on every assembled coordinate (a model with rigid links or guides, u = P w:
    a sensor on a dependent node moves with its dependent coordinates), w on the free ones otherwise."""
    control, model = assembler.control, assembler.model
    subset = exact is not None
    exact = exact_couplings(assembler) if exact is None else exact
    n = model.n_dofs
    actuators = sorted({int(control.coupling_actuator[e]) for e in np.flatnonzero(exact)
                        if control.actuator_kind[control.coupling_actuator[e]] == 0})
    if not actuators:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    controllers = _exact_controllers(assembler)
    driving = {int(control.actuator_controller[a]) for a in actuators}
    chained = [p or r or c for p, r, c in zip(_linked_position_controllers(assembler),
                                              _linked_rate_controllers(assembler), _linked_chain_controllers(assembler))]
    if subset and not any(chained[k] for k in driving):
        # linked_exact_couplings of joints alone: no chain; the actuators' own
        controllers = [bool(on) and k in driving for k, on in enumerate(controllers)]
    columns, curvatures = _controller_curvatures(assembler, state, controllers)
    if full is not None:
        along = full[columns] if len(columns) else np.zeros(0)
    else:
        along = np.where(columns < n, w[np.minimum(columns, n - 1)], 0.0) if len(columns) else np.zeros(0)
    out_rows, out_cols, out_values = [], [], []
    for a in actuators:
        curvature = curvatures[int(control.actuator_controller[a])]
        if not np.any(along) or not np.any(curvature):
            continue
        gain = float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0
        row = int(model.hinge_dofs[control.actuator_index[a]])
        out_rows.append(np.full(len(columns), row, np.int64))
        out_cols.append(columns)
        out_values.append(-scale * gain * (curvature.T @ along))
    if not out_rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(out_rows), np.concatenate(out_cols), np.concatenate(out_values)


def _angle_slope_law(law, scene, key: str):
    """∂f/∂θ of a hinge law of the angle as a law of the state itself (a :class:`latdyn.scene.expressions.HingeLaw`
    of SymPy's derivative's text, deltas dropped as for its first derivatives), whose own ``d_theta`` is then
    SymPy's ∂²f/∂θ²; kept in the expression cache (kind "angle_slope"). None where the law has no SymPy
    expression or its derivative does not parse."""
    from latdyn.scene import expressions as scene_expressions

    return scene_expressions.derivative_as_law(law, scene, key, "angle_slope", "d/dtheta", "its slope in the angle",
                                               lambda held: held[1][1])


def _slope_law(law, scene, key: str):
    """:func:`_angle_slope_law` of ``law``, parsed once per law in a process (:data:`_SLOPES`)."""
    slope = _SLOPES.get(id(law))
    if slope is None or slope[0] is not law:
        slope = _SLOPES[id(law)] = (law, _angle_slope_law(law, scene, key))
    return slope[1]


def _hinge_laws(assembler, j: int) -> tuple:
    """((key, law or None) × 3): hinge ``j``'s stiffness, damping and torque laws as csrc/evaluate.c hinge_forces
    takes them (a hinge that a continuous controller alone drives: no torque law)."""
    hinge = assembler.model.hinges[j]
    driven = getattr(getattr(assembler, "control", None), "hinge_controller", None)
    torque = hinge.torque if driven is None or driven[j] < 0 else None
    return (("stiffness", hinge.stiffness), ("damping", hinge.damping), ("torque", torque))


def _names_held_in_a_hinge_law(scene) -> set:
    """The names a hinge law may read whose values its slopes in θ and θ̇ hold: the scene's inputs (a number at the
    event, the value the law and its slope read from the scene's inputs as the compiled laws do) and the
    controllers' outputs — a continuous controller only in a torque or force a y + b with a constant a
    (latdyn.assembly.control ``driven``), whose y moves through the couplings (:func:`_coupling_part`,
    :func:`_coupling_rates_part`) while the law's own ∂²/∂θ², ∂²/∂θ∂θ̇ are b's, SymPy's with y a symbol; a sampled one's
    held output a number, as an input."""
    inputs = set(getattr(getattr(scene, "inputs", None), "names", ()))
    return inputs | set(getattr(scene, "controllers", None) or {})


def exact_hinges(assembler) -> np.ndarray:
    """(free hinges,) bool: whether the free hinge's part of H is generated (:func:`_hinge_part`): each of its laws
    is constant, of t alone, or of θ with a second derivative (:func:`_angle_slope_law`), naming inputs and
    controllers' outputs alone (:func:`_names_held_in_a_hinge_law`); otherwise its angle stays in
    :func:`rest_support`, differenced as before."""
    model = assembler.model
    held = _names_held_in_a_hinge_law(model.scene)
    out = np.ones(len(model.free_hinges), bool)
    for i, j in enumerate(model.free_hinges):
        for key, law in _hinge_laws(assembler, int(j)):
            if law is None or "theta" not in law.depends_on:
                continue
            if set(getattr(law, "input_names", ())) - held or _slope_law(
                    law, model.scene, f"joints.{model.hinges[j].name}.{key}") is None:
                out[i] = False
    return out


def _hinge_part(assembler, state, w: np.ndarray, scale: float, exact: np.ndarray | None = None):
    """(rows, values) of the hinges' part of H, on its diagonal: s (∂K_jj/∂θ_j) w_j for each free hinge j with
    w_j ≠ 0, K_jj = ∂f/∂θ of its laws and its compliant stop (the generated ``hinge_stiffness_by_angle``,
    codegen/joints.py, from the laws' values, first and second derivatives in θ at the state; a hinge driven by a
    continuous controller alone has no torque law there, as csrc/evaluate.c hinge_forces). ``exact`` (free hinges,)
    bool: the hinges taken (default :func:`exact_hinges`; :func:`linked_exact_hinges`)."""
    exact = exact_hinges(assembler) if exact is None else exact
    hinge_rows, by_angle = _hinge_stiffness_slope(assembler, state, w, exact, "hinge_stiffness_by_angle", "d_theta")
    return hinge_rows, scale * by_angle * w[hinge_rows]


def _hinge_stiffness_slope(assembler, state, w: np.ndarray, exact: np.ndarray, kernel: str, by: str):
    """(rows, slopes) of the free hinges j with ``exact`` and w_j ≠ 0: their K_jj = ∂f/∂θ's derivative from the
    generated ``kernel`` (``hinge_stiffness_by_angle``: by θ, ``hinge_stiffness_by_rate``: by θ̇) at
    :func:`_hinge_rows` with the slope laws' derivative ``by``."""
    model = assembler.model
    n = model.n_dofs
    free = np.asarray(model.free_hinges, np.int64)
    dofs = np.asarray(model.hinge_dofs, np.int64)[free] if len(free) else np.zeros(0, np.int64)
    on = [(j, d) for j, d, taken in zip(free, dofs, exact) if taken and d < n and w[d] != 0.0]
    if not on:
        return np.zeros(0, np.int64), np.zeros(0)
    slopes = getattr(assembler.kernels, kernel)(*_hinge_rows(assembler, state, [j for j, _ in on], by))
    return np.array([d for _, d in on], np.int64), np.asarray(slopes[0]).reshape(-1)


def _hinge_rows(assembler, state, hinges: list, by: str = "d_theta") -> tuple:
    """(states, laws, curvatures, contacts) of free hinges of :func:`exact_hinges` at ``state``, the generated hinge
    kernels' rows: [θ, θ̇, θ_r, 1], their laws' values and first derivatives in θ and θ̇ at the state (a hinge driven
    by a continuous controller alone has no torque law there, as csrc/evaluate.c hinge_forces), for each law of θ its
    slope law's (:func:`_slope_law`) derivative ``by`` ("d_theta": ∂²f/∂θ², "d_rate": ∂²f/∂θ∂θ̇), and their
    compliant stops."""
    from latdyn.assembly.native_model import joint_contact_rows

    model = assembler.model
    scene = model.scene
    contact_rows = joint_contact_rows(model.hinges)
    states, laws, curvatures, contacts = [], [], [], []
    for j in hinges:
        hinge = model.hinges[j]
        theta, rate, t = float(state.theta[j]), float(state.theta_dot[j]), float(state.t)
        row, curvature = np.zeros(9), np.zeros(3)
        for slot, (key, law) in enumerate(_hinge_laws(assembler, int(j))):
            if law is None:
                continue
            row[3 * slot:3 * slot + 3] = law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t)
            if "theta" in law.depends_on:
                slope = _slope_law(law, scene, f"joints.{hinge.name}.{key}")
                curvature[slot] = getattr(slope, by)(theta, rate, t)
                if not math.isfinite(curvature[slot]):
                    _refuse_infinite_curvature(scene, hinge, key, law, by, theta, rate, t)
        states.append([theta, rate, hinge.rest_angle, 1.0])
        laws.append(row)
        curvatures.append(curvature)
        contacts.append(contact_rows[j])
    rows = lambda a: np.ascontiguousarray(np.asarray(a, float))  # noqa: E731
    return rows(states), rows(laws), rows(curvatures), rows(contacts)


def _refuse_infinite_curvature(scene, hinge, key: str, law, by: str, theta: float, rate: float, t: float) -> None:
    """SceneError (exit 2) naming ``solve.sensitivities``: a hinge law's second derivative (``by``: "d_theta"
    ∂²f/∂θ², "d_rate" ∂²f/∂θ∂θ̇) is not finite at an event's state (``abs(theta)**1.5`` at θ = 0), so the impulse
    weight's derivative H there is not either; refused rather than carried as inf or nan into the sensitivities."""
    from latdyn.errors import SceneError

    which = "d2f/dtheta2" if by == "d_theta" else "d2f/dtheta/dtheta_dot"
    raise SceneError(scene.file, "solve.sensitivities",
                     f"the sensitivities through the event at t = {t:.6g} need the hinge {hinge.name}'s {key} law "
                     f"{str(law.source)!r} twice differentiable there, but its {which} is not finite at "
                     f"theta = {theta:.6g}, theta_dot = {rate:.6g}; expected a law with a finite second derivative at "
                     "the event's state (or no sensitivities)")


def _rest_product(assembler, state, w: np.ndarray, scale: float, mass: bool) -> np.ndarray:
    """(W_rest w) at ``state``: the evaluation's W = c_m M + s K without the elements', the joint bodies', the
    generated hinges', the generated loads' and the cable elements' blocks (the generated part; a hinge's diagonal,
    which depends on its own angle alone, is :func:`_hinge_part`'s where :func:`exact_hinges`, a load's
    :func:`_load_part`'s where :func:`exact_loads`, a cable element's :func:`_cable_part`'s, a coupling's
    :func:`_coupling_part`'s where :func:`exact_couplings`), times w."""
    ev = assembler.evaluate(state, matrices=True)
    stiffness = ev.flat_blocks("stiffness")
    hinges = np.where(exact_hinges(assembler), 0.0, scale * stiffness[2])   # the generated hinges' out
    # the generated loads' and every cable element's blocks out: those of the loads a controller drives stay
    driven = np.broadcast_to(~exact_loads(assembler)[:, None, None], (len(assembler.loads), 6, 6))
    cable_blocks = int(np.count_nonzero(assembler._cable_mask))
    differenced = np.concatenate([driven[assembler._load_mask], np.zeros(cable_blocks, bool)])
    loads = np.where(differenced, scale * stiffness[3], 0.0)
    couplings = np.where(exact_couplings(assembler)[assembler._coupling_mask], 0.0, scale * stiffness[4])
    parts = [0.0 * stiffness[0], 0.0 * stiffness[1], hinges, loads, couplings]
    if mass:
        inertia = ev.flat_blocks("mass")
        parts = parts[:2] + [p + m for p, m in zip(parts[2:], inertia[2:])]
    return np.asarray(assembler.assemble(parts) @ w)


def configuration_tangent_of_weight(assembler, state, w: np.ndarray, scale: float, mass: bool, step: float):
    """H = ∂(W w)/∂q (n × n, sparse: :func:`_sparse`; applied by :func:`times`, :func:`transposed_times`) at ``state`` for
    W = M + ``scale``·K (``mass``) or ``scale``·K (module docstring): the generated part, plus H_rest's columns on
    :func:`rest_support` by central differences of W_rest w along each of those coordinates with the configuration step
    ``step``. ValueError on a model with rigid links or guides: H assumes the free coordinates are the assembled ones
    (their reduction's geometric term keeps the difference of W w,
    ``TransientSensitivities._linked_weight_derivative``)."""
    model = assembler.model
    if model.links is not None:
        raise ValueError("configuration_tangent_of_weight assumes a model without rigid links or guides (its free "
                         "coordinates the assembled ones); with them W w is differenced along δq "
                         "(TransientSensitivities._linked_weight_derivative)")
    n = model.n_dofs
    rows, cols, values = _generated(assembler, state, w, scale, mass)
    hinge_rows, hinge_values = _hinge_part(assembler, state, w, scale)
    load_rows, load_cols, load_values = _load_part(assembler, state, w, scale)
    cable_rows, cable_cols, cable_values = _cable_part(assembler, state, w, scale)
    coupling_rows, coupling_cols, coupling_values = _coupling_part(assembler, state, w, scale)
    driven_rows, driven_cols, driven_values = _driven_load_part(assembler, state, w, scale)
    rows, cols, values = (np.concatenate([rows, hinge_rows, load_rows, cable_rows, coupling_rows, driven_rows]),
                          np.concatenate([cols, hinge_rows, load_cols, cable_cols, coupling_cols, driven_cols]),
                          np.concatenate([values, hinge_values, load_values, cable_values, coupling_values,
                                          driven_values]))
    support = rest_support(assembler)
    if len(support):
        columns = []
        for j in support:
            unit = np.zeros(n)
            unit[j] = step
            ahead = _rest_product(assembler, assembler.advance(state, unit), w, scale, mass)
            behind = _rest_product(assembler, assembler.advance(state, -unit), w, scale, mass)
            columns.append((ahead - behind) / (2 * step))
        block = np.column_stack(columns)
        rows = np.concatenate([rows, np.repeat(np.arange(n), len(support))])
        cols = np.concatenate([cols, np.tile(support, n)])
        values = np.concatenate([values, block.ravel()])
    return _sparse(rows, cols, values, n)


def _rates_direction(n: int) -> np.ndarray:
    """(n,) a fixed direction along every free rate, none zero and no two alike (alternating signs, sizes
    0.5 … 1.5 from the golden ratio's fractions): no cancellation among the rates a term of K reads."""
    i = np.arange(n)
    return np.where(i % 2, -1.0, 1.0) * (0.5 + np.modf((i + 1) * 0.6180339887498949)[0])


def stiffness_moving_with_rates(assembler, state) -> tuple:
    """The names of K's blocks (:data:`STIFFNESS_BLOCKS`) whose values at ``state`` move with the free rates,
    empty where none does (module docstring, "Along the rates"): the evaluation's K (as the impulse weighs with it)
    at the state's rates and at the rates moved by :data:`RATES_MOVE` times their size along
    :func:`_rates_direction`, compared bit for bit — a term that does not read a rate, or reads it times 0 (a
    stop out of contact, a cable without damping, a controller linear in its sensors), computes the same bits.
    Two evaluations; a model without rigid links or guides (their reduction moves the rates with δq)."""
    from latdyn.assembly.assembler import free_velocity, unpack_free

    model = assembler.model
    v = free_velocity(model, state)
    moved = state.copy()
    size = max(float(np.max(np.abs(v), initial=0.0)), 1.0)
    unpack_free(model, v + RATES_MOVE * size * _rates_direction(len(v)), moved.v, moved.w, moved.theta_dot)
    here = assembler.evaluate(state, matrices=True).flat_blocks("stiffness")
    there = assembler.evaluate(moved, matrices=True).flat_blocks("stiffness")
    return tuple(name for name, a, b in zip(STIFFNESS_BLOCKS, here, there) if not np.array_equal(a, b))


def _hinge_moves_with_its_rate(assembler, j: int) -> bool:
    """Whether free hinge ``j``'s K_jj = ∂f/∂θ moves with its rate θ̇_j: a stiffness law of θ̇, a damping law of θ
    (c(θ) θ̇ has ∂/∂θ = c′(θ) θ̇), a torque law of θ and θ̇ both, or a compliant stop with damping (n δⁿ⁻¹ c δ̇ in
    contact)."""
    laws = {key: (law.depends_on if law is not None else ()) for key, law in _hinge_laws(assembler, int(j))}
    contact = assembler.model.hinges[j].contact
    return bool("theta_dot" in laws["stiffness"] or "theta" in laws["damping"]
                or {"theta", "theta_dot"} <= set(laws["torque"]) or (contact is not None and contact.damping != 0.0))


def linked_rate_moving_hinges(assembler) -> np.ndarray:
    """(free hinges,) bool: the free hinges whose K_jj moves with their rate (:func:`_hinge_moves_with_its_rate`),
    which the reduction's move carries (``TransientSensitivities._linked_move``)."""
    model = assembler.model
    return np.array([_hinge_moves_with_its_rate(assembler, int(j)) for j in model.free_hinges], bool)


def linked_exact_hinges(assembler) -> np.ndarray:
    """(free hinges,) bool: the free hinges (guides) whose diagonal entry of H a model with rigid links or guides takes
    generated (:func:`_hinge_part`, :func:`linked_configuration_tangent`): those of :func:`exact_hinges` whose
    K_jj = ∂f/∂θ does not move with the hinge's rate (:func:`linked_rate_moving_hinges`), or whose move with it is
    generated too (:func:`exact_hinges_by_rates`: s (∂K_jj/∂θ̇_j) w_j δθ̇_j, :func:`linked_rates_tangent`; the hinge's
    rate is a free one, P does not move its row; a law naming an input since ctrlweight, 86d57d9 differenced it). The
    others keep the difference (:func:`linked_rest_product`): before 10be92c's linkedrest their entries' move with the
    rates was left out (a damper 0.05 (1 + 4θ²) on the gimbal's outer hinge: 1.7e-4 of ∂(W w)/∂q δq at the latch),
    after it every hinge moving with its rate was differenced."""
    return exact_hinges(assembler) & (~linked_rate_moving_hinges(assembler) | exact_hinges_by_rates(assembler))


def linked_generated_loads(assembler) -> np.ndarray:
    """(loads,) bool: the point loads whose part of H a model with rigid links or guides takes generated
    (:func:`_load_part` on the assembled coordinates, :func:`linked_configuration_tangent`): those of
    :func:`exact_loads` whose every driven component's controller is one of :func:`_linked_chain_controllers` (its
    values' and couplings' move along P δq :func:`_driven_load_part`'s at u = P w, along the rates the reduction's
    move carries :func:`linked_chain_rates_product`'s; 40bf44a differenced every driven load)."""
    control = assembler.control
    out = exact_loads(assembler).copy()
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    if not np.any(kinds == 1):
        return out
    chain = _linked_chain_controllers(assembler)
    for a in np.flatnonzero(kinds == 1):   # driven by a controller of the chain: its moves generated (linkedhand)
        if not chain[int(control.actuator_controller[a])]:
            out[int(control.actuator_index[a])] = False
    return out


def _mixed_curvature_vanishes(controller, angles: tuple, rates: tuple) -> bool:
    """Whether SymPy's ∂²f/∂s_i∂ṡ_j of a continuous controller's output f by its angle reads ``angles`` and rate
    reads ``rates`` (positions in its reads) is 0 as SymPy writes it (not simplified: an output whose mixed
    derivative is 0 only after simplification keeps the difference): its couplings' entries −a ∂f/∂θ then do not
    move with the rates. Made once per output's text, reads and positions in a process (:data:`_CURVATURES`)."""
    reads = controller.symbols[1:1 + len(controller.reads)]
    key = ("mixed", str(controller.output_expr), tuple(str(x) for x in controller.symbols), angles, rates)
    if key not in _CURVATURES:
        import sympy as sp

        _CURVATURES[key] = all(sp.diff(controller.output_expr, reads[i], reads[j]) == 0 for i in angles for j in rates)
    return _CURVATURES[key]


def linked_exact_couplings(assembler) -> np.ndarray:
    """(couplings,) bool: the continuous controllers' coupling entries of K whose part of H a model with rigid links
    or guides takes generated (:func:`_coupling_part`, :func:`linked_configuration_tangent`): those of
    :func:`exact_couplings` whose controller reads joints' angles and rates alone (a joint's coordinate and rate are
    free ones, or none where it is locked or prescribed: P does not move their rows) with an output whose mixed
    second derivatives by an angle and a rate vanish (:func:`_mixed_curvature_vanishes`; the entries then do not move
    with the rates that the reduction's move carries, ``TransientSensitivities._linked_move``) or are generated
    (:func:`_joint_reads`: no state, no input; their move along the rates is :func:`linked_rates_tangent`'s), of
    :func:`_linked_position_controllers`, :func:`_linked_rate_controllers` or :func:`_linked_chain_controllers`
    (:func:`linked_chain_rates_product`), and a load component's entries where its load is of
    :func:`linked_generated_loads`. The others keep the difference (:func:`linked_rest_product`)."""
    control = assembler.control
    held = _LINKED_COUPLINGS.get(id(control))
    if held is not None and held[0]() is control:
        return held[1]
    from latdyn.assembly.control import ANGLE, RATE

    out = exact_couplings(assembler).copy()
    _LINKED_COUPLINGS[id(control)] = (weakref.ref(control), out)
    if not np.any(out):
        return out
    plain = []
    for k, controller in enumerate(control.controllers):
        kinds = control.sensor_kind[control.sensor_start[k]:control.sensor_start[k + 1]]
        joints = bool(np.all((kinds == ANGLE) | (kinds == RATE))) and len(kinds) == len(controller.reads)
        plain.append(joints and (_mixed_curvature_vanishes(controller, tuple(np.flatnonzero(kinds == ANGLE)),
                                                           tuple(np.flatnonzero(kinds == RATE)))
                                 or _joint_reads(control, k) is not None))
    positions = _linked_position_controllers(assembler)
    rates = _linked_rate_controllers(assembler)
    chain = _linked_chain_controllers(assembler)
    loads = linked_generated_loads(assembler)
    kinds = np.asarray(control.actuator_kind)
    for e, a in enumerate(np.asarray(control.coupling_actuator)):   # a load's entries: with its block
        k = control.actuator_controller[a]
        out[e] &= (bool(kinds[a] == 0) and (plain[k] or positions[k] or rates[k] or chain[k])
                   or bool(kinds[a] == 1) and bool(loads[control.actuator_index[a]]))
    return out


#: the sensor kinds whose values a model with rigid links or guides takes through its exact part (the reduction's move
#: carries the rates: no kind whose value or gradient moves with them; latdyn.assembly.control ANGLE, POSITION,
#: OFFSET_POSITION, BODY_FRAME, CABLE_LENGTH): a joint's angle, a node's global position component, a point's position
#: at an offset from its node (x + T r), a point's position or displacement in a body's axes
#: (tests/test_weight_derivative_linked_rates.py), a cable's length (Σ |p_b − p_a| of its elements' end points at their
#: offsets; tests/test_weight_derivative_linked_controllers.py) — on a dependent node by the assembled coordinates,
#: :func:`_sensor_kinematics` composed of the generated ``point_load`` as unlinked
_LINKED_POSITION_SENSORS = (0, 2, 5, 7, 8)


def _linked_position_controllers(assembler) -> list:
    """(controllers,) bool: the continuous controllers of :func:`_exact_controllers` whose couplings a model with rigid
    links or guides takes generated beside those of joints' angles and rates (:func:`linked_exact_couplings`): they
    read joints' angles, nodes' positions, points' positions at an offset and in a body's axes and cables' lengths
    (:data:`_LINKED_POSITION_SENSORS`: on a dependent node too, its second derivative by the assembled coordinates), inputs, their own states and earlier such
    controllers alone — nothing whose value moves
    with the rates the reduction's move carries, so their entries −a ∂y/∂q_all move along P δq alone
    (:func:`_coupling_part` on the assembled coordinates, ``full`` = P w)."""
    from latdyn.assembly.control import CONTROLLER

    control = assembler.control
    exact = _exact_controllers(assembler)
    out = []
    for k in range(len(control.controllers)):
        reads = _controller_reads(control, k)
        out.append(bool(exact[k]) and all(kind is None or kind in _LINKED_POSITION_SENSORS
                                          or (kind == CONTROLLER and out[index]) for kind, index, _ in reads))
    return out


def _linked_rate_controllers(assembler) -> list:
    """(controllers,) bool: the continuous controllers whose couplings a model with rigid links or guides takes
    generated though their entries move with the rates the reduction's move carries: those of
    :func:`_position_and_rate_reads` (``linked``) — they read positions (:data:`_RATE_FREE_POSITIONS`, the kinds of
    :data:`_LINKED_POSITION_SENSORS`) and plain rates (a joint's rate, a node's velocity component, on a dependent
    node too), at least one of each, no input, state or other controller, not joints' alone (:func:`_joint_reads`:
    :func:`linked_rates_tangent`'s). Along q their entries −a ∂y/∂q_all move as a
    position controller's (:func:`_coupling_part`, the rates held); along the rates by
    :func:`linked_coupling_rates_product`."""
    control = assembler.control
    return [_joint_reads(control, k) is None and _position_and_rate_reads(assembler, k, linked=True) is not None
            for k in range(len(control.controllers))]


def _linked_split(assembler, exact: np.ndarray):
    """(hinges (free hinges,), loads and cables (the flat entries of K's block 3), couplings (the flat entries of
    block 4)) bool: whether each entry of the evaluation's blocks (:meth:`latdyn.assembly.evaluation.Evaluation.
    flat_blocks`) is in W_gen on a model with rigid links or guides (:func:`_linked_weight`): the hinges of
    ``exact`` (:func:`linked_exact_hinges`), the loads of :func:`linked_generated_loads`, every cable element (taut or
    slack: :func:`_cable_part` takes the taut ones, a slack one's block is the runtime's zero), the couplings of
    :func:`linked_exact_couplings`."""
    loads = np.broadcast_to(linked_generated_loads(assembler)[:, None, None], (len(assembler.loads), 6, 6))
    cables = np.ones(int(np.count_nonzero(assembler._cable_mask)), bool)
    return (np.asarray(exact, bool), np.concatenate([loads[assembler._load_mask], cables]),
            linked_exact_couplings(assembler)[assembler._coupling_mask])


def exact_hinges_by_rates(assembler) -> np.ndarray:
    """(free hinges,) bool: whether the free hinge's part of ∂(K w)/∂v is generated (:func:`_hinge_rates_part`): each
    of its laws that reads θ or θ̇ names inputs and controllers' outputs alone (:func:`_names_held_in_a_hinge_law`:
    held along the rates, their values the scene's at the event; its slopes are then the law's own), and one that
    reads θ has its slope law (:func:`_angle_slope_law`, whose ``d_rate`` is SymPy's ∂²f/∂θ∂θ̇); otherwise its entry
    stays in :func:`rates_rest_product`'s difference."""
    model = assembler.model
    held = _names_held_in_a_hinge_law(model.scene)
    out = np.ones(len(model.free_hinges), bool)
    for i, j in enumerate(model.free_hinges):
        for key, law in _hinge_laws(assembler, int(j)):
            reads = set(getattr(law, "depends_on", ())) if law is not None else set()
            if not {"theta", "theta_dot"} & reads:
                continue
            if set(getattr(law, "input_names", ())) - held or ("theta" in reads and _slope_law(
                    law, model.scene, f"joints.{model.hinges[j].name}.{key}") is None):
                out[i] = False
    return out


def _hinge_rates_part(assembler, state, w: np.ndarray, exact: np.ndarray | None = None):
    """(rows, values) of the hinges' part of ∂(K w)/∂v, on its diagonal: (∂K_jj/∂θ̇_j) w_j for each free hinge j of
    :func:`exact_hinges_by_rates` with w_j ≠ 0, K_jj = ∂f/∂θ of its laws and its compliant stop (the generated
    ``hinge_stiffness_by_rate``, codegen/joints.py: ∂²f/∂θ∂θ̇ from the laws' values, first derivatives and mixed
    second derivatives at the state — SymPy's, the ``d_rate`` of the law's slope in the angle — and the stop's
    Hunt–Crossley damping in contact). ``exact`` (free hinges,) bool: the hinges taken (default
    :func:`exact_hinges_by_rates`; :func:`linked_rates_tangent`'s)."""
    exact = exact_hinges_by_rates(assembler) if exact is None else exact
    hinge_rows, by_rate = _hinge_stiffness_slope(assembler, state, w, exact, "hinge_stiffness_by_rate", "d_rate")
    return hinge_rows, by_rate * w[hinge_rows]


def _output_mixed(controller, angles: tuple, rates: tuple):
    """SymPy's ∂²f/∂s_i∂ṡ_j of a continuous controller's output f before saturation by its angle reads i
    (``angles``) and its rate reads j (``rates``), lambdified once per output's expression, reads, angles and rates
    in a process (:data:`_MIXED`), a function of ``(t, *reads values)`` giving the (angles, rates) matrix; None
    where a mixed derivative is not a function (DiracDelta of a kink, an unevaluated derivative)."""
    reads = controller.symbols[1:1 + len(controller.reads)]
    # keyed by the expression itself (SymPy's cached structural hash): printing its text cost 2–9 ms a call
    key = (controller.output_expr, tuple(controller.symbols), tuple(angles), tuple(rates))
    if key not in _MIXED:
        import sympy as sp

        mixed = [[sp.diff(controller.output_expr, reads[i], reads[j]) for j in rates] for i in angles]
        singular = any(e.has(sp.DiracDelta, sp.Derivative, sp.Subs) for row in mixed for e in row)
        _MIXED[key] = None if singular else sp.lambdify(controller.symbols[:1 + len(reads)], mixed,
                                                        modules=["math", "numpy"])
    return _MIXED[key]


def _output_rate_slopes(controller, rates: tuple):
    """SymPy's ∂f/∂ṡ_j of a continuous controller's output f before saturation by its rate reads j (``rates``),
    lambdified once per output's expression, reads and rates in a process (:data:`_MIXED`, as :func:`_output_mixed`;
    the controller's own ``output_gradient`` is lambdified per loaded scene), a function of ``(t, *reads values)``."""
    key = ("rate slopes", controller.output_expr, tuple(controller.symbols), tuple(rates))
    if key not in _MIXED:
        import sympy as sp

        reads = controller.symbols[1:1 + len(controller.reads)]
        _MIXED[key] = sp.lambdify(controller.symbols[:1 + len(reads)],
                                  [sp.diff(controller.output_expr, reads[j]) for j in rates], modules=["math", "numpy"])
    return _MIXED[key]


def _joint_reads(control, k: int):
    """(first sensor, angle reads, rate reads) of continuous controller ``k`` (their positions among its reads), or
    None unless it reads joints' angles and rates alone — no input, no other controller, no state — with mixed
    second derivatives of its output by them that are functions (:func:`_output_mixed`)."""
    from latdyn.assembly.control import ANGLE, RATE

    controller = control.controllers[k]
    first, last = int(control.sensor_start[k]), int(control.sensor_start[k + 1])
    kinds = np.asarray(control.sensor_kind[first:last])
    angles, rates = tuple(np.flatnonzero(kinds == ANGLE)), tuple(np.flatnonzero(kinds == RATE))
    if controller.states or len(kinds) != len(controller.reads) or len(angles) + len(rates) != len(kinds):
        return None
    return None if _output_mixed(controller, angles, rates) is None else (first, angles, rates)


#: the sensor kinds whose gradient along q does not move with the rates (a joint's angle, a node's or a point's
#: position component, global, at an offset or in a body's axes, a cable's length) and
#: those read at rates whose gradient along v is constant (a joint's rate, a node's velocity component):
#: :func:`_position_and_rate_reads`
_RATE_FREE_POSITIONS, _PLAIN_RATES = (0, 2, 5, 7, 8), (1, 3)


def _position_and_rate_reads(assembler, k: int, linked: bool = False):
    """(position reads, rate reads) of continuous controller ``k`` (their positions among its reads), or None unless
    it reads sensors of :data:`_RATE_FREE_POSITIONS` and :data:`_PLAIN_RATES` alone, at least one rate and one
    position, no input, state or other controller, on a model without rigid links or guides, with mixed second
    derivatives of its output by them that are functions (:func:`_output_mixed`) and the sensors' second derivatives
    generated (:func:`_exact_controllers`). Its coupling entry K_rc = −a Σ_p ∂f/∂s_p ∂s_p/∂q_c then moves with the
    rates through ∂²f/∂s_p∂s_r alone: a position sensor's gradient holds no rate, a rate sensor's ∂s_r/∂v is a
    coordinate's unit. ``linked``: on a model with rigid links or guides too (:func:`_linked_rate_controllers`: the
    rates' move there is :func:`linked_coupling_rates_product`'s, a rate sensor's coordinate a dependent one too)."""
    control = assembler.control
    if (assembler.model.links is not None and not linked) or not _exact_controllers(assembler)[k]:
        return None
    controller = control.controllers[k]
    reads = _controller_reads(control, k)
    if controller.states or any(kind is None for kind, _, _ in reads):
        return None
    kinds = [kind for kind, _, _ in reads]
    positions = tuple(p for p, kind in enumerate(kinds) if kind in _RATE_FREE_POSITIONS)
    rates = tuple(p for p, kind in enumerate(kinds) if kind in _PLAIN_RATES)
    if len(positions) + len(rates) != len(kinds) or not positions or not rates:
        return None
    return None if _output_mixed(controller, positions, rates) is None else (positions, rates)


def _rate_column(assembler, kind: int, index: int) -> int:
    """The free rate a rate sensor reads (a joint's rate: its coordinate's; a node's velocity component: its
    translation's), n_total where it is no free coordinate."""
    model = assembler.model
    return int(model.hinge_dofs[index] if kind == 1 else model.node_dofs[index // 3, index % 3])


def _general_coupling_rates_part(assembler, state, w: np.ndarray, full: np.ndarray | None = None,
                                 linked: bool = False):
    """(rows, cols, values) of the couplings' part of ∂(K w)/∂v for a hinge's force driven by a controller of
    :func:`_position_and_rate_reads` (not of joints alone: those are :func:`_coupling_rates_part`'s): K's entry
    K_rc = −a Σ_p ∂f/∂s_p ∂s_p/∂q_c moves with rate sensor r by −a Σ_p ∂²f/∂s_p∂s_r ∂s_p/∂q_c, so along w: row r of
    the hinge, column the rate's, −a Σ_p ∂²f/∂s_p∂s_r (∂s_p/∂q · w) — SymPy's mixed second derivatives
    (:func:`_output_mixed`) at the sensors' values the evaluation computes, the gradients ∂s_p/∂q those of
    :func:`_sensor_kinematics` (csrc/evaluate.c's); 0 while the output is saturated. ``linked``, ``full``: the
    controllers of :func:`_linked_rate_controllers` on a model with rigid links or guides, the direction u = P w on
    every assembled coordinate (n_total + 1,), rows and columns assembled ones (:func:`linked_coupling_rates_product`)."""
    control, model = assembler.control, assembler.model
    n = model.n_dofs
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    taken = [(int(a), int(control.actuator_controller[a])) for a in np.flatnonzero(kinds == 0)
             if _joint_reads(control, int(control.actuator_controller[a])) is None
             and _position_and_rate_reads(assembler, int(control.actuator_controller[a]), linked) is not None]
    if not taken:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    native = assembler.native()
    held = model.scene.controller_outputs
    kept = held.values.copy()
    native.controller_outputs_at(state)
    held.values[:] = kept
    sensed = np.array(native.buffers["sensor_values"], float)
    if full is None:
        full = np.zeros(model.n_total + 1)
        full[:n] = w
    t = float(state.t)
    out_rows, out_cols, out_values = [], [], []
    for a, k in taken:
        controller = control.controllers[k]
        positions, rates = _position_and_rate_reads(assembler, k, linked)
        reads = _controller_reads(control, k)
        values = [float(sensed[sensor]) for _, _, sensor in reads]
        lo, hi = control.limits[k]
        if not lo <= float(_output_curvature(controller, positions)(t, *values)[0]) <= hi:
            continue   # saturated: ∂y/∂s = 0 about the state (csrc/evaluate.c controller_outputs)
        along = np.array([float(_sensor_kinematics(assembler, state, reads[p][0], reads[p][1], reads[p][2])[0]
                                @ full[_sensor_dofs(assembler, reads[p][0], reads[p][1], reads[p][2])])
                          for p in positions])
        if not np.any(along):
            continue
        mixed = np.asarray(_output_mixed(controller, positions, rates)(t, *values), float).reshape(len(positions),
                                                                                                   len(rates))
        gain = float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0
        out_rows.append(np.full(len(rates), int(model.hinge_dofs[control.actuator_index[a]]), np.int64))
        out_cols.append(np.array([_rate_column(assembler, reads[r][0], reads[r][1]) for r in rates], np.int64))
        out_values.append(-gain * (mixed.T @ along))
    if not out_rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(out_rows), np.concatenate(out_cols), np.concatenate(out_values)


def exact_couplings_by_rates(assembler) -> np.ndarray:
    """(couplings,) bool: whether a continuous controller's coupling entry of K has its part of ∂(K w)/∂v generated
    (:func:`_coupling_rates_part`): its actuator is a hinge's force, and its controller reads joints' angles and
    rates alone (:func:`_joint_reads`), or positions and plain rates (:func:`_position_and_rate_reads`,
    :func:`_general_coupling_rates_part`; a model without rigid links or guides), or its controller is one of
    :func:`_rates_chain_controllers` (on a hinge's force or a load's component: :func:`_chain_coupling_rates_part`,
    :func:`_chain_load_rates_part`). A joints' controller's entry
    −a ∂y/∂θ_j then moves with the rates by −a ∂²y/∂θ_j∂θ̇_i alone (an angle sensor does not read a rate); the same
    for a load's component such a controller drives (its entries g ∂y/∂θ_j, g the load's generalized force per unit
    output: :func:`_load_rates_part`); the others keep
    :func:`rates_rest_product`'s difference."""
    control = assembler.control
    actuators = np.asarray(control.coupling_actuator, np.int64)
    if not len(actuators):
        return np.zeros(0, bool)
    out = _plain_controllers(control)[np.asarray(control.actuator_controller, np.int64)[actuators]]
    on_hinges = np.asarray(control.actuator_kind, np.int64)[actuators] == 0
    general = np.array([_position_and_rate_reads(assembler, k) is not None for k in range(len(control.controllers))],
                       bool)
    chain = _rates_chain_controllers(assembler)[np.asarray(control.actuator_controller, np.int64)[actuators]]
    return out | (on_hinges & general[np.asarray(control.actuator_controller, np.int64)[actuators]]) | chain


def _plain_controllers(control) -> np.ndarray:
    """(controllers,) bool: those of :func:`_joint_reads` (joints' angles and rates alone)."""
    return np.array([_joint_reads(control, k) is not None for k in range(len(control.controllers))], bool)


def exact_loads_by_rates(assembler) -> np.ndarray:
    """(loads,) bool: whether the point load's part of ∂(K w)/∂v is generated (:func:`_load_rates_part`): a load no
    continuous controller drives (its block does not move with the rates), or one whose driven components' controllers
    read joints' angles and rates alone (:func:`_joint_reads`) or are of :func:`_rates_chain_controllers`
    (:func:`_chain_load_rates_part`); otherwise its block stays in
    :func:`rates_rest_product`'s difference."""
    control = assembler.control
    out = np.ones(len(assembler.loads), bool)
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    if not np.any(kinds == 1):
        return out
    plain = _plain_controllers(control) | _rates_chain_controllers(assembler)
    for a in np.flatnonzero(kinds == 1):
        if not plain[control.actuator_controller[a]]:
            out[control.actuator_index[a]] = False
    return out


def _controller_at(control, k: int, state):
    """(reads' values less their origins, t) of continuous controller ``k`` of :func:`_joint_reads` at ``state``,
    or None while its output is saturated (∂y/∂s = 0 about the state, and its derivatives)."""
    first, angles, rates = _joint_reads(control, k)
    indices = np.asarray(control.sensor_index[first:first + len(angles) + len(rates)])
    reads_rate = np.zeros(len(indices), bool)
    reads_rate[list(rates)] = True
    values = [float(state.theta_dot[i] if by_rate else state.theta[i]) - float(control.sensor_origin[first + m])
              for m, (by_rate, i) in enumerate(zip(reads_rate, indices))]
    t = float(state.t)
    lo, hi = control.limits[k]
    return (values, t) if lo <= float(control.controllers[k].functions()[0](t, *values)) <= hi else None


def _coupling_rates_part(assembler, state, w: np.ndarray, exact: np.ndarray | None = None):
    """(rows, cols, values) of the couplings' part of ∂(K w)/∂v for the entries of :func:`exact_couplings_by_rates`:
    K's entry K_rj = −a ∂y/∂θ_j (a = ∂τ/∂y of the hinge's law a y + b, 1 for the controller's name alone; 0 while
    the output is saturated, csrc/evaluate.c controller_outputs) moves with the rate of a rate sensor i by
    −a ∂²y/∂θ_j∂θ̇_i: Σ_j of it times w_j in row r, column i. ``exact`` (couplings,) bool: the entries taken (default
    :func:`exact_couplings_by_rates`; :func:`linked_rates_tangent`'s, a subset of it)."""
    control, model = assembler.control, assembler.model
    n = model.n_dofs
    dofs = np.asarray(model.hinge_dofs, np.int64)
    out_rows, out_cols, out_values = [], [], []
    exact = exact_couplings_by_rates(assembler) if exact is None else exact
    actuators = np.unique(np.asarray(control.coupling_actuator, np.int64)[exact])
    for a in actuators[np.asarray(control.actuator_kind)[actuators] == 0]:   # a load's: :func:`_load_rates_part`
        k = int(control.actuator_controller[a])
        if _joint_reads(control, k) is None:   # a controller of positions and rates: _general_coupling_rates_part
            continue
        first, angles, rates = _joint_reads(control, k)
        indices = np.asarray(control.sensor_index[first:first + len(angles) + len(rates)])
        columns = dofs[indices[list(angles)]]
        along = np.where(columns < n, w[np.minimum(columns, n - 1)], 0.0)
        at = _controller_at(control, k, state) if len(rates) and np.any(along) else None
        if at is None:   # no rate read, no w on its angles, or saturated
            continue
        controller = control.controllers[k]
        mixed = np.asarray(_output_mixed(controller, angles, rates)(at[1], *at[0]), float).reshape(len(angles),
                                                                                                    len(rates))
        gain = float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0
        out_rows.append(np.full(len(rates), int(dofs[control.actuator_index[a]]), np.int64))
        out_cols.append(dofs[indices[list(rates)]])
        out_values.append(-gain * (mixed.T @ along))
    if not out_rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(out_rows), np.concatenate(out_cols), np.concatenate(out_values)


def _driven_component(assembler, state, a: int, full: np.ndarray, columns: np.ndarray) -> tuple:
    """(the load's node rows (6,), K_l(a e_c) w (6,), g = ``point_load``'s force at a e_c (6,)) of driven load
    component ``a`` (an actuator of kind 1; a the gain of its law a y + b, 1 for the controller's name alone) at
    ``state``, w on the load's columns ``columns`` of ``full`` (a global load's block without its frame half,
    csrc/evaluate.c): the generated ``point_load_stiffness_D_q`` and ``point_load`` (:func:`_load_rates_part`,
    :func:`_chain_load_rates_part`)."""
    control, model, loads = assembler.control, assembler.model, assembler.loads
    l = int(control.actuator_index[a])
    gain = float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0
    unit = np.zeros(6)
    unit[int(control.actuator_component[a])] = gain
    follower = loads[l].frame != "global"
    along = full[columns[l]].copy()
    if not follower:
        along[3:] = 0.0   # a global load's block has no frame half (csrc/evaluate.c)
    node, frame = int(assembler._load_nodes[l]), int(assembler._load_frames[l])
    rows = lambda a_: np.ascontiguousarray(np.reshape(a_, (1, -1)), dtype=float)  # noqa: E731
    T, r, R = rows(state.T[node]), rows(assembler._load_offsets[l]), rows(state.T[frame] if follower else np.eye(3))
    block = np.asarray(assembler.kernels.point_load_stiffness_D_q(T, r, rows(unit), R, rows(along))[0]).reshape(6)
    force = np.asarray(assembler.kernels.point_load(T, r, rows(unit), R, rows(np.zeros(6)))[0]).reshape(6)
    return _scattered(model.node_dofs[node], model.n_total), block, force


def _load_rates_part(assembler, state, w: np.ndarray):
    """(rows, cols, values) of the driven point loads' part of ∂(K w)/∂v for the loads of :func:`exact_loads_by_rates`:
    a component a y + b (a = 1 for the controller's name alone) of a controller of :func:`_joint_reads` moves with
    its rate sensor i by a ∂y/∂θ̇_i, so the load's block (linear in its values) by K_l(e_c a ∂y/∂θ̇_i) w — the
    generated ``point_load_stiffness_D_q``'s ``load_stiffness_along`` at those values — and its coupling entries
    g ∂y/∂θ_j (g = ``point_load``'s ``load_force`` at a e_c, csrc/evaluate.c controller_couplings) by
    g ∂²y/∂θ_j∂θ̇_i (:func:`_output_mixed`), times w_j: both on the load's node rows, column i. 0 while saturated."""
    control, model = assembler.control, assembler.model
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    driven = np.flatnonzero(kinds == 1)
    exact = exact_loads_by_rates(assembler)
    n = model.n_dofs
    full = np.zeros(model.n_total + 1)
    full[:n] = w
    dofs = np.asarray(model.hinge_dofs, np.int64)
    columns = _scattered(assembler._load_columns(), model.n_total)
    out_rows, out_cols, out_values = [], [], []
    for a in driven:
        l, k = int(control.actuator_index[a]), int(control.actuator_controller[a])
        plain = exact[l] and _joint_reads(control, k) is not None   # else :func:`_chain_load_rates_part`'s
        first, angles, rates = _joint_reads(control, k) if plain else (0, (), ())
        at = _controller_at(control, k, state) if len(rates) else None
        if at is None:   # not generated here (the rest), no rate read, or saturated
            continue
        controller = control.controllers[k]
        indices = np.asarray(control.sensor_index[first:first + len(angles) + len(rates)])
        node_rows, block, force = _driven_component(assembler, state, int(a), full, columns)
        slopes = np.asarray(_output_rate_slopes(controller, rates)(at[1], *at[0]), float).reshape(len(rates))
        angle_columns = dofs[indices[list(angles)]]
        on_angles = np.where(angle_columns < n, w[np.minimum(angle_columns, n - 1)], 0.0)
        mixed = np.asarray(_output_mixed(controller, angles, rates)(at[1], *at[0]), float).reshape(len(angles),
                                                                                                    len(rates))
        for m, i in enumerate(rates):
            out_rows.append(node_rows)
            out_cols.append(np.full(6, dofs[indices[i]], np.int64))
            out_values.append(slopes[m] * block + force * float(mixed[:, m] @ on_angles))
    if not out_rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(out_rows), np.concatenate(out_cols), np.concatenate(out_values)


#: the sensor kinds whose moves along the rates :func:`_read_moves` gives: a joint's angle and rate, a node's position
#: and velocity component, a point's position at an offset and in a body's axes, a cable's length and an element's
#: section force (their gradient along q holds no rate), a point's velocity at an offset (v + ω × T r: its value and
#: its gradient by the node's turn linear in the node's rates) and relative to a body (``point_velocity_in_body``,
#: linear in both nodes' rates), a cable's tension (affine in its ends' rates) and a free joint's force (its laws'
#: rates, where :func:`exact_hinges_by_rates` has the hinge)
_RATE_MOVED_SENSORS = (0, 1, 2, 3, 5, 6, 7, 8, 11, 12, 13, 14)


def _rates_chain_controllers(assembler, linked: bool = False) -> np.ndarray:
    """(controllers,) bool: the continuous controllers whose coupling entries' and driven loads' move along the rates
    :func:`_chain_rates_moves` generates, on a model without rigid links or guides (``linked``: with them too,
    :func:`_linked_chain_controllers`): those of
    :func:`_exact_controllers` reading sensors of :data:`_RATE_MOVED_SENSORS`, inputs, sampled controllers' held
    outputs, their own states and earlier controllers of this kind alone, with every second derivative of the output
    by the sensors and controllers it reads a function (:func:`_output_curvature` over them all, the rates'
    included)."""
    from latdyn.assembly.control import CONTROLLER

    control = assembler.control
    out = np.zeros(len(control.controllers), bool)
    if assembler.model.links is not None and not linked:
        return out
    exact = _exact_controllers(assembler)
    model = assembler.model
    by_rates = dict(zip((int(j) for j in model.free_hinges), exact_hinges_by_rates(assembler)))
    for k, controller in enumerate(control.controllers):
        reads = _controller_reads(control, k)
        if not exact[k] or not all(kind is None or (kind in _RATE_MOVED_SENSORS and (kind != 14 or by_rates.get(index)))
                                   or (kind == CONTROLLER and out[index]) for kind, index, _ in reads):
            continue
        moving = tuple(p for p, (kind, _, _) in enumerate(reads) if kind is not None)
        out[k] = _output_curvature(controller, moving) is not None
    return out


def _read_moves(assembler, state, kind: int, index: int, sensor: int, full: np.ndarray):
    """(G, V, M) of a sensor of :data:`_RATE_MOVED_SENSORS` at ``state`` along ``full`` (w on the assembled
    coordinates, 0 on the slot n_total): G = ∂s/∂q · w (the gradient csrc/evaluate.c couples, :func:`_sensor_kinematics`,
    at the state's rates), V = ∂s/∂v (n_total + 1,) and M = ∂(∂s/∂q · w)/∂v (n_total + 1,) over the rates (numbered as
    the coordinates). A point's velocity is linear and homogeneous in the rates it reads, value and gradient along q
    alike, so V is its value and M its gradient's product at each unit rate: at an offset, s = e_cᵀ(v + ω × T r), V on
    the node's [v; ω] is [e_c; T r × e_c] and the gradient by the node's turn at ω = e_i is ``point_load``'s moment
    rows at the values −(e_c × e_i) (as :func:`_sensor_kinematics`); relative to a body, V is ``point_velocity_in_body``'s
    ∂s/∂[v_n, ω_n, v_b, ω_b] and M its ∂s/∂q · w at the twelve unit rates."""
    model = assembler.model
    V, M = np.zeros(model.n_total + 1), np.zeros(model.n_total + 1)
    if kind == 1:
        V[model.hinge_dofs[index]] = 1.0
        return 0.0, V, M
    if kind == 3:
        V[model.node_dofs[index // 3, index % 3]] = 1.0
        return 0.0, V, M
    dofs = _sensor_dofs(assembler, kind, index, sensor)
    if kind == 0:
        return float(full[dofs[0]]), V, M
    if kind == 13:
        control = assembler.control
        node, c, body = index // 3, index % 3, int(control.sensor_frame_node[sensor])
        geometry = np.concatenate([state.x[node], state.x[body], np.reshape(state.T[node], 9),
                                   control.sensor_offset[sensor], np.reshape(state.T[body], 9)])
        velocity = np.concatenate([state.v[node], state.w[node], state.v[body], state.w[body]])
        at = assembler.kernels.point_velocity_in_body(np.ascontiguousarray(geometry[None], dtype=float),
                                                      np.ascontiguousarray(velocity[None], dtype=float))
        units = assembler.kernels.point_velocity_in_body(np.ascontiguousarray(np.tile(geometry, (12, 1)), dtype=float),
                                                         np.eye(12))[1]
        gradient = np.asarray(at[1], float).reshape(3, 12)[c]
        np.add.at(V, dofs, np.asarray(at[2], float).reshape(3, 12)[c])
        np.add.at(M, dofs, np.asarray(units, float).reshape(12, 3, 12)[:, c] @ full[dofs])
        return float(gradient @ full[dofs]), V, M
    if kind == 11:   # N = N_el + c ℓ̇, affine in the ends' rates: ∂N/∂q at the unit rates less at none
        geometry, velocity, section, taut = _cable_inputs(assembler, state, np.array([index]))
        if not taut[0]:
            return 0.0, V, M   # slack: 0, its gradients too (csrc/evaluate.c)
        at = assembler.kernels.cable_tension(geometry, velocity, section)
        rows = lambda a: np.ascontiguousarray(np.repeat(a, 13, axis=0))  # noqa: E731
        units = np.asarray(assembler.kernels.cable_tension(rows(geometry), np.vstack([np.eye(12), np.zeros(12)]),
                                                           rows(section))[1], float).reshape(13, 12)
        np.add.at(V, dofs, np.asarray(at[2], float).reshape(12))
        np.add.at(M, dofs, (units[:12] - units[12]) @ full[dofs])
        return float(np.asarray(at[1], float).reshape(12) @ full[dofs]), V, M
    if kind == 14:   # s = −f of the joint's laws: ∂s/∂θ̇ = −C_jj, and −K_jj moves with θ̇ by −∂K_jj/∂θ̇
        states, laws, curvatures, contacts = _hinge_rows(assembler, state, [index], "d_rate")
        kernels = assembler.kernels
        force = kernels.hinge_force(states, laws, contacts)
        by_rate = np.asarray(kernels.hinge_stiffness_by_rate(states, laws, curvatures, contacts)[0]).reshape(1)
        V[dofs[0]] = -float(np.asarray(force[2]).reshape(1)[0])
        M[dofs[0]] = -float(by_rate[0]) * full[dofs[0]]
        return -float(np.asarray(force[1]).reshape(1)[0]) * full[dofs[0]], V, M
    gradient = _sensor_kinematics(assembler, state, kind, index, sensor)[0]
    if kind == 6:
        node, c = index // 3, index % 3
        unit = np.eye(3)[c]
        rates = _scattered(np.asarray(model.node_dofs[node], np.int64), model.n_total)
        np.add.at(V, rates, np.concatenate([unit, np.cross(state.T[node] @ assembler.control.sensor_offset[sensor],
                                                           unit)]))
        values = np.concatenate([-np.cross(unit, np.eye(3)), np.zeros((3, 3))], axis=1)
        lever = _point_load(assembler, state.T[node], assembler.control.sensor_offset[sensor], values, np.eye(3))[0]
        np.add.at(M, rates[3:], lever[:, 3:] @ full[dofs])
    return float(gradient @ full[dofs]), V, M


def _chain_rates_moves(assembler, state, w: np.ndarray, full: np.ndarray | None = None, linked: bool = False) -> dict:
    """{k: (G_k, V_k, M_k, y_k)} for the controllers of :func:`_rates_chain_controllers` at ``state`` along ``w``
    (n,), in their order: with a_p the arguments of f_k that are sensors (:func:`_read_moves`) or earlier such
    controllers' outputs (their own G, V, M), inputs and states held,

        G_k = Σ_p ∂f/∂a_p G_p                 (∂y_k/∂q · w, the coupling's product K w up to −a),
        V_k = Σ_p ∂f/∂a_p V_p                 (∂y_k/∂v),
        M_k = Σ_pr ∂²f/∂a_p∂a_r G_p V_r + Σ_p ∂f/∂a_p M_p    (∂(∂y_k/∂q · w)/∂v),

    SymPy's first and second derivatives of the output by all its moving reads (:func:`_output_curvature`) at the
    arguments the evaluation reads (as :func:`_controller_curvatures`); all three 0 while the output is saturated
    (csrc/evaluate.c controller_outputs), y_k after saturation. ``linked``, ``full``: the controllers of
    :func:`_linked_chain_controllers` on a model with rigid links or guides, along u = P w on every assembled
    coordinate (n_total + 1,), V and M over the assembled rates (:func:`linked_chain_rates_product`)."""
    from latdyn.assembly.control import CONTROLLER

    control, model, scene = assembler.control, assembler.model, assembler.model.scene
    chain = _rates_chain_controllers(assembler, linked)
    if not np.any(chain):
        return {}
    n = model.n_dofs
    if full is None:
        full = np.zeros(model.n_total + 1)
        full[:n] = w
    native = assembler.native()
    held = scene.controller_outputs
    kept = held.values.copy()
    native.controller_outputs_at(state)
    held.values[:] = kept
    sensed = np.array(native.buffers["sensor_values"], float)
    inputs = getattr(scene, "inputs", None)
    states = control.states.values if control.states is not None else np.zeros(0)
    t = float(state.t)
    out = {}
    for k in np.flatnonzero(chain):
        values, moves = [], []
        for kind, index, sensor in _controller_reads(control, int(k)):
            if kind is None:
                values.append(float(inputs[index] if inputs is not None and index in inputs else held[index]))
            elif kind == CONTROLLER:
                values.append(out[index][3])
                moves.append(out[index][:3])
            else:
                values.append(float(state.theta[index] - control.sensor_origin[sensor]) if kind == 0 else
                              float(state.theta_dot[index] - control.sensor_origin[sensor]) if kind == 1 else
                              float(sensed[sensor]))
                moves.append(_read_moves(assembler, state, kind, index, sensor, full))
        arguments = (t, *values, *states[control.state_slot[control.state_start[k]:control.state_start[k + 1]]])
        m = len(moves)
        derivatives = np.asarray(_output_curvature(control.controllers[k], tuple(
            p for p, (kind, _, _) in enumerate(_controller_reads(control, int(k))) if kind is not None))(*arguments),
            float).reshape(-1)
        y = float(derivatives[0])
        lo, hi = control.limits[k]
        zero = np.zeros(model.n_total + 1)
        if y < lo or y > hi or not m:
            out[int(k)] = (0.0, zero, zero, float(min(max(y, lo), hi)))
            continue
        slope, second = derivatives[1:1 + m], derivatives[1 + m:].reshape(m, m)
        G = np.array([g for g, _, _ in moves])
        V = np.array([v for _, v, _ in moves])
        M = np.array([mm for _, _, mm in moves])
        out[int(k)] = (float(slope @ G), slope @ V, (second @ V).T @ G + slope @ M, y)
    return out


def _chain_coupling_rates_part(assembler, state, w: np.ndarray, moves: dict | None = None):
    """(rows, cols, values) of the couplings' part of ∂(K w)/∂v for a hinge's force driven by a controller of
    :func:`_rates_chain_controllers` that neither :func:`_coupling_rates_part` (joints alone) nor
    :func:`_general_coupling_rates_part` (positions and plain rates) takes: K's row of the hinge, −a ∂y/∂q, times w
    moves with the rates by −a M_k (:func:`_chain_rates_moves`) in the rates' columns."""
    control, model = assembler.control, assembler.model
    n = model.n_dofs
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    chain = _rates_chain_controllers(assembler)
    taken = [(int(a), int(control.actuator_controller[a])) for a in np.flatnonzero(kinds == 0)
             if chain[control.actuator_controller[a]] and _joint_reads(control, int(control.actuator_controller[a]))
             is None and _position_and_rate_reads(assembler, int(control.actuator_controller[a])) is None
             and model.hinge_dofs[control.actuator_index[a]] < n]
    if not taken:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    moves = _chain_rates_moves(assembler, state, w) if moves is None else moves
    out_rows, out_cols, out_values = [], [], []
    for a, k in taken:
        columns = np.flatnonzero(moves[k][2][:n])
        gain = float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0
        out_rows.append(np.full(len(columns), int(model.hinge_dofs[control.actuator_index[a]]), np.int64))
        out_cols.append(columns.astype(np.int64))
        out_values.append(-gain * moves[k][2][columns])
    return np.concatenate(out_rows), np.concatenate(out_cols), np.concatenate(out_values)


def _chain_load_rates_part(assembler, state, w: np.ndarray, moves: dict | None = None):
    """(rows, cols, values) of the driven point loads' part of ∂(K w)/∂v for a component a y + b driven by a
    controller of :func:`_rates_chain_controllers` not of joints alone (those are :func:`_load_rates_part`'s): as
    there, the load's block by K_l(a e_c) w times ∂y/∂v = V_k and its coupling entries g ∂y/∂q (g = ``point_load``'s
    force at a e_c) times w by g M_k (:func:`_chain_rates_moves`), on the load's node rows, in the rates' columns."""
    control, model = assembler.control, assembler.model
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    chain = _rates_chain_controllers(assembler)
    taken = [int(a) for a in np.flatnonzero(kinds == 1)
             if chain[control.actuator_controller[a]] and _joint_reads(control, int(control.actuator_controller[a]))
             is None]
    if not taken:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    moves = _chain_rates_moves(assembler, state, w) if moves is None else moves
    n = model.n_dofs
    full = np.zeros(model.n_total + 1)
    full[:n] = w
    columns = _scattered(assembler._load_columns(), model.n_total)
    out_rows, out_cols, out_values = [], [], []
    for a in taken:
        l, k = int(control.actuator_index[a]), int(control.actuator_controller[a])
        _, V, M, _ = moves[k]
        on = np.flatnonzero((V[:n] != 0.0) | (M[:n] != 0.0))
        if not len(on):
            continue
        node_rows, block, force = _driven_component(assembler, state, int(a), full, columns)
        for j in on:
            out_rows.append(node_rows)
            out_cols.append(np.full(6, j, np.int64))
            out_values.append(V[j] * block + force * M[j])
    if not out_rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(out_rows), np.concatenate(out_cols), np.concatenate(out_values)


def rates_tangent_of_weight(assembler, state, w: np.ndarray):
    """∂(K w)/∂v (n × n, sparse as :func:`configuration_tangent_of_weight`'s H; applied by :func:`times`,
    :func:`transposed_times`) of the hinges', the couplings' and the driven loads' parts generated
    (:func:`_hinge_rates_part`, :func:`_coupling_rates_part`, :func:`_load_rates_part`,
    :func:`_general_coupling_rates_part`, :func:`_chain_coupling_rates_part`, :func:`_chain_load_rates_part`) at
    ``state``, a model
    without rigid links or guides (module docstring, "Along the rates"); the taut cables' part is
    :func:`cable_stiffness_by_rates`'s, the rest :func:`rates_rest_product`'s."""
    n = assembler.model.n_dofs
    hinge_rows, hinge_values = _hinge_rates_part(assembler, state, w)
    coupling_rows, coupling_cols, coupling_values = _coupling_rates_part(assembler, state, w)
    load_rows, load_cols, load_values = _load_rates_part(assembler, state, w)
    general_rows, general_cols, general_values = _general_coupling_rates_part(assembler, state, w)
    moves = _chain_rates_moves(assembler, state, w) if np.any(_rates_chain_controllers(assembler)) else {}
    chain_rows, chain_cols, chain_values = _chain_coupling_rates_part(assembler, state, w, moves)
    driven_rows, driven_cols, driven_values = _chain_load_rates_part(assembler, state, w, moves)
    return _sparse(np.concatenate([hinge_rows, coupling_rows, load_rows, general_rows, chain_rows, driven_rows]),
                   np.concatenate([hinge_rows, coupling_cols, load_cols, general_cols, chain_cols, driven_cols]),
                   np.concatenate([hinge_values, coupling_values, load_values, general_values, chain_values,
                                   driven_values]), n)


def linked_rates_tangent(assembler, state, w: np.ndarray):
    """∂(K_gen w)/∂v (n × n, sparse as :func:`rates_tangent_of_weight`'s; None: no block of W_gen moves with the
    rates) on a model with rigid links or guides: the generated hinges' and couplings' entries of W_gen
    (:func:`linked_exact_hinges`, :func:`linked_exact_couplings`) that move with the rates the reduction's move
    carries — a hinge of :func:`linked_rate_moving_hinges` by (∂K_jj/∂θ̇_j) w_j (:func:`_hinge_rates_part`), a coupling
    whose output mixes an angle and a rate by −a ∂²y/∂θ_j∂θ̇_i w_j (:func:`_coupling_rates_part`). Their rows,
    columns and rates are hinges' coordinates and rates, free ones (P = [I; J] is the identity there, and
    ∂(J v)/∂q δq moves dependent rows alone), so Pᵀ s ∂(K u)/∂v_all δv_all = s (this matrix) δv, u = P w: exact, no
    evaluation (``TransientSensitivities._linked_weight_derivative``). The damped cables' move is
    :func:`linked_cable_rates_product`'s; the loads a controller drives stay differenced."""
    hinges = linked_exact_hinges(assembler) & linked_rate_moving_hinges(assembler)
    couplings = np.asarray(linked_exact_couplings(assembler), bool).copy()
    if np.any(couplings):
        couplings &= exact_couplings_by_rates(assembler)
    if not np.any(hinges) and not np.any(couplings):
        return None
    n = assembler.model.n_dofs
    hinge_rows, hinge_values = _hinge_rates_part(assembler, state, w, exact=hinges)
    coupling_rows, coupling_cols, coupling_values = _coupling_rates_part(assembler, state, w, exact=couplings)
    return _sparse(np.concatenate([hinge_rows, coupling_rows]), np.concatenate([hinge_rows, coupling_cols]),
                   np.concatenate([hinge_values, coupling_values]), n)


def rates_rest_needed(assembler, moving: tuple) -> bool:
    """Whether a block of K that moves with the rates (``moving``: :func:`stiffness_moving_with_rates`'s names) has
    a part not generated along them (:func:`rates_rest_product`): a hinge outside :func:`exact_hinges_by_rates`, a
    load outside :func:`exact_loads_by_rates` (its values move with its controller's rate sensors), a coupling
    outside :func:`exact_couplings_by_rates`."""
    return bool(("joints" in moving and not np.all(exact_hinges_by_rates(assembler)))
                or ("loads and cables" in moving and not np.all(exact_loads_by_rates(assembler)))
                or ("controllers' couplings" in moving and not np.all(exact_couplings_by_rates(assembler))))


def rates_rest_product(assembler, state, w: np.ndarray) -> np.ndarray:
    """(K_rest w) (n,) at ``state``: the evaluation's K with only the blocks whose derivative along the rates is not
    generated (:func:`rates_rest_needed`): the hinges outside :func:`exact_hinges_by_rates`, the loads outside
    :func:`exact_loads_by_rates`, the couplings outside :func:`exact_couplings_by_rates`; the elements' and the joint
    bodies' (which do not move with the rates), the other hinges', loads' and couplings' and every cable element's (the
    generated ones) out. ``TransientSensitivities._stiffness_by_rates`` differences it along δv."""
    stiffness = assembler.evaluate(state, matrices=True).flat_blocks("stiffness")
    hinges = np.where(exact_hinges_by_rates(assembler), 0.0, stiffness[2])
    driven = np.broadcast_to(~exact_loads_by_rates(assembler)[:, None, None], (len(assembler.loads), 6, 6))
    cable_blocks = int(np.count_nonzero(assembler._cable_mask))
    differenced = np.concatenate([driven[assembler._load_mask], np.zeros(cable_blocks, bool)])
    loads = np.where(differenced, stiffness[3], 0.0)
    couplings = np.where(exact_couplings_by_rates(assembler)[assembler._coupling_mask], 0.0, stiffness[4])
    return np.asarray(assembler.assemble([0.0 * stiffness[0], 0.0 * stiffness[1], hinges, loads, couplings]) @ w)


def _linked_weight(assembler, ev, scale: float, mass: bool, exact: np.ndarray, generated: bool):
    """W_gen (``generated``) or W_rest on the assembled coordinates (n_assembled², free and dependent; dense or CSR as
    :meth:`latdyn.assembly.assembler.Assembler.assemble`) of a model with rigid links or guides, from the blocks of
    ``ev`` before the reduction (latdyn/assembly/linked.py ``LinkedEvaluation.blocks``): W_gen c_m M + s K of the
    elements, the joint bodies, the free hinges whose part of H is generated (``exact``:
    :func:`linked_exact_hinges`), the point loads of :func:`linked_generated_loads`, the cable elements and the
    couplings of :func:`linked_exact_couplings` (:func:`_linked_split`); W_rest the other blocks' (the other hinges', the loads a
    controller drives, the other couplings); W_gen + W_rest = c_m M + s K before the reduction (the mass has no
    entry in the hinges', loads' and couplings' blocks: latdyn.assembly.assembler.Assembler.evaluation_in)."""
    from latdyn.assembly.evaluation import Evaluation

    raw = Evaluation(residual=None, reaction=None, blocks=ev.blocks, assembler=assembler)
    stiffness, inertia = raw.flat_blocks("stiffness"), raw.flat_blocks("mass")
    cm = 1.0 if mass else 0.0
    split = _linked_split(assembler, exact)
    if generated:
        return assembler.assemble([cm * inertia[0] + scale * stiffness[0], cm * inertia[1] + scale * stiffness[1]]
                                  + [np.where(taken, scale * b, 0.0) for taken, b in zip(split, stiffness[2:])])
    return assembler.assemble([0.0 * stiffness[0], 0.0 * stiffness[1]]
                              + [np.where(taken, 0.0, scale * b) for taken, b in zip(split, stiffness[2:])])


def linked_has_rest(assembler) -> bool:
    """Whether a model with rigid links or guides has blocks whose part of H is not generated (W_rest of
    :func:`_linked_weight`): a point load a continuous controller drives (not :func:`linked_generated_loads`), a
    coupling not in :func:`linked_exact_couplings`, or a free hinge not in :func:`linked_exact_hinges`. Without them
    W_rest is 0 and its difference takes no evaluation."""
    return bool(not np.all(linked_generated_loads(assembler)) or not np.all(linked_exact_couplings(assembler))
                or not np.all(linked_exact_hinges(assembler)))


def linked_rest_product(assembler, ev, w: np.ndarray, scale: float, mass: bool) -> np.ndarray:
    """Pᵀ W_rest P w (n,) at the linked evaluation ``ev``: the blocks not generated (:func:`_linked_weight`), whose
    derivative along δq stays a difference (``TransientSensitivities._linked_weight_derivative``); computed on its own
    (the reduced W w less the exact part carried that part's round-off, 1e-8 of H δq over the step on the
    slider-crank)."""
    P = ev.projection
    W_rest = _linked_weight(assembler, ev, scale, mass, linked_exact_hinges(assembler), generated=False)
    return np.asarray(P.T @ (W_rest @ np.asarray(P @ w))).reshape(-1)


def linked_cable_rates_product(assembler, state, w: np.ndarray, dq: np.ndarray, scale: float, rates) -> np.ndarray:
    """Pᵀ s ∂(K_c u)/∂v_all δv_all (n, k) of the damped cable elements taut at ``state`` on a model with rigid links or
    guides, u = P w: W_gen's part that moves with the rates along each column's move (δq, the free rates along
    ``rates`` = (δv, δv̇); None: none moved), the dependent nodes' rates following, δv_all = P δv + ∂(J v)/∂q δq
    (the compiled links' buffers, as :func:`linked_geometric_derivative` moves them). K_c is affine in the rates
    (the damper's c ℓ̇): K_c(δv_all) u − K_c(0) u from the generated ``cable_stiffness_D_q``'s
    ``cable_stiffness_along``, exactly (:func:`cable_stiffness_by_rates`'s construction on the assembled
    coordinates). None where no taut cable element is damped (one evaluation otherwise, for ∂(J v)/∂q)."""
    model, cables = assembler.model, assembler.model.cables
    if cables is None or not np.any(np.asarray(cables.damping) != 0.0):
        return None
    taut = _taut_cables(assembler, state)
    if taut is None or not np.any(taut[3][:, 3] != 0.0):
        return None
    n_asm, k = model.n_assembled, dq.shape[1]
    P, u, moves = _linked_rates_moves(assembler, state, w, dq, rates)
    grown = _cable_rates_product(assembler, taut, u, moves)
    return scale * np.column_stack([np.asarray(P.T @ grown[:n_asm, c]).reshape(-1) for c in range(k)])


def _linked_rates_moves(assembler, state, w: np.ndarray, dq: np.ndarray, rates):
    """(P, u = P w on every assembled coordinate (n_total + 1,), the assembled rates' move of each column
    δv_all = P δv + ∂(J v)/∂q δq (n_total + 1, k)) at ``state`` on a model with rigid links or guides (the compiled
    links' buffers; one evaluation): what :func:`linked_cable_rates_product` and :func:`linked_coupling_rates_product`
    move their blocks along."""
    model = assembler.model
    n, n_asm, k = model.n_dofs, model.n_assembled, dq.shape[1]
    ev = assembler.evaluate(state, matrices=True, inertia_tangent=True)
    P, (by_velocity, _), dependent = ev.projection, ev.rates_tangent, ev.dependent_rows
    u = np.zeros(model.n_total + 1)
    u[:n_asm] = np.asarray(P @ w).reshape(-1)
    moves = np.zeros((model.n_total + 1, k))
    for c in range(k):
        moves[:n_asm, c] = np.asarray(P @ (rates[0][:, c] if rates is not None else np.zeros(n))).reshape(-1)
        moves[dependent, c] += np.asarray(by_velocity @ dq[:, c]).reshape(-1)
    return P, u, moves


def linked_coupling_rates_product(assembler, state, w: np.ndarray, dq: np.ndarray, scale: float, rates):
    """Pᵀ s ∂(K_y u)/∂v_all δv_all (n, k) of the couplings of :func:`_linked_rate_controllers` on a model with rigid
    links or guides, u = P w: their entries K_rc = −a Σ_p ∂f/∂s_p ∂s_p/∂q_c move with each rate sensor's s_r by
    −a Σ_p ∂²f/∂s_p∂s_r ∂s_p/∂q_c (:func:`_general_coupling_rates_part` on the assembled coordinates: SymPy's mixed
    second derivatives, the position sensors' gradients of :func:`_sensor_kinematics`), s_r the rate of an assembled
    coordinate (a joint's, a node's velocity component, dependent ones too) moving along each column's move with
    δv_all = P δv + ∂(J v)/∂q δq (the compiled links' buffers, as :func:`linked_cable_rates_product`). Exact, one
    evaluation (for P and ∂(J v)/∂q); None where no such coupling exists."""
    model = assembler.model
    if not any(_linked_rate_controllers(assembler)):
        return None
    n, n_asm, k = model.n_dofs, model.n_assembled, dq.shape[1]
    P, u, moves = _linked_rates_moves(assembler, state, w, dq, rates)
    rows, cols, values = _general_coupling_rates_part(assembler, state, w, full=u, linked=True)
    if not len(rows):
        return None
    grown = np.zeros((model.n_total + 1, k))
    np.add.at(grown, rows, values[:, None] * moves[cols])
    return scale * np.asarray(P.T @ grown[:n_asm]).reshape(n, k)


def _linked_chain_controllers(assembler) -> list:
    """(controllers,) bool: on a model with rigid links or guides, the continuous controllers of
    :func:`_rates_chain_controllers` (``linked``): those of :func:`_exact_controllers` reading sensors of
    :data:`_RATE_MOVED_SENSORS` (a point's velocity at an offset or relative to a body, a cable's tension, an element's
    section force, a free joint's force whose laws are generated along the rates, beside angles, positions, lengths
    and rates; on a dependent node too), inputs, sampled controllers' held outputs, their own states and earlier such
    controllers alone, every second derivative of the output a function. Their couplings and the loads they drive are
    in W_gen (:func:`linked_exact_couplings`, :func:`linked_generated_loads`): along P δq the unlinked parts on the
    assembled coordinates (:func:`_coupling_part`, :func:`_load_part`, :func:`_driven_load_part` at u = P w: the
    sensors' second derivatives at the state's rates, dependent nodes' completed), along the rates the reduction's
    move carries :func:`linked_chain_rates_product` (linkedhand; 40bf44a differenced them, :func:`linked_rest_product`).
    Empty (all False) without links."""
    if assembler.model.links is None:
        return [False] * len(assembler.control.controllers)
    return [bool(c) for c in _rates_chain_controllers(assembler, linked=True)]


def linked_chain_rates_product(assembler, state, w: np.ndarray, dq: np.ndarray, scale: float, rates):
    """Pᵀ s ∂(K u)/∂v_all δv_all (n, k) on a model with rigid links or guides, u = P w, of the blocks of W_gen that the
    controllers of :func:`_linked_chain_controllers` make and no other product moves along the rates (the couplings of
    controllers of joints alone are :func:`linked_rates_tangent`'s, of positions and plain rates
    :func:`linked_coupling_rates_product`'s): with G_k, V_k, M_k of each controller along u (:func:`_chain_rates_moves`
    on the assembled coordinates: V_k = ∂y_k/∂v_all, M_k = ∂(∂y_k/∂q_all · u)/∂v_all) and δv_all = P δv + ∂(J v)/∂q δq
    (:func:`_linked_rates_moves`, the compiled links' buffers),

        a hinge's row (a coupling −a ∂y_k/∂q_all):           −a M_k · δv_all
        a driven load component's node rows (a y_k + b):    K_l(a e_c) u (V_k · δv_all) + g (M_k · δv_all)

    (g = ``point_load``'s force at a e_c, K_l(a e_c) u its block along u: :func:`_driven_component`, as unlinked
    :func:`_chain_coupling_rates_part`, :func:`_chain_load_rates_part`). Exact, one evaluation; None where no such
    block exists."""
    control, model = assembler.control, assembler.model
    chain = _linked_chain_controllers(assembler)
    if not any(chain):
        return None
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    moved_by_others = _linked_rate_controllers(assembler)
    loads = linked_generated_loads(assembler)
    taken = [int(a) for a in range(len(kinds)) if chain[int(control.actuator_controller[a])] and (
        (kinds[a] == 0 and _joint_reads(control, int(control.actuator_controller[a])) is None
         and not moved_by_others[int(control.actuator_controller[a])])
        or (kinds[a] == 1 and loads[int(control.actuator_index[a])]))]
    if not taken:
        return None
    n, n_asm, k = model.n_dofs, model.n_assembled, dq.shape[1]
    P, u, moves = _linked_rates_moves(assembler, state, w, dq, rates)
    chain_moves = _chain_rates_moves(assembler, state, w, full=u, linked=True)
    columns = _scattered(assembler._load_columns(), model.n_total)
    grown = np.zeros((model.n_total + 1, k))
    for a in taken:
        _, V, M, _ = chain_moves[int(control.actuator_controller[a])]
        gain = float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0
        if kinds[a] == 0:
            grown[int(model.hinge_dofs[control.actuator_index[a]])] += -gain * (M @ moves)
            continue
        if not np.any(V) and not np.any(M):
            continue
        node_rows, block, force = _driven_component(assembler, state, a, u, columns)
        np.add.at(grown, node_rows, np.outer(block, V @ moves) + np.outer(force, M @ moves))
    return scale * np.asarray(P.T @ grown[:n_asm]).reshape(n, k)


def geometric_product(assembler, state, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """∂(Pᵀ y)/∂q at fixed y, times w (n,), at ``state`` (its dependent nodes completed: J of it in the links'
    buffers): the forward step's geometric term of y's dependent rows (y on the assembled coordinates), csrc/links.c
    ``geometric_term`` through ``latdyn_linked_geometric_product`` (csrc/linked_weight.c)."""
    import ctypes

    model = assembler.model
    n, size = model.n_dofs, model.n_total + 1
    full, vector, marked, out = np.zeros(size), np.zeros(size), np.zeros(size, np.int64), np.zeros(size)
    full[:len(y)] = y
    vector[:n] = w
    marked[:n] = 1
    native = assembler.native()
    native.library.latdyn_linked_geometric_product(native.model_ref, ctypes.byref(native.configuration(state)),
                                                   full.ctypes.data, marked.ctypes.data, vector.ctypes.data,
                                                   out.ctypes.data)
    return out[:n]


#: the generated second derivatives of the links' wrench kernels (codegen/joints.py) that
#: csrc/linked_weight_second.c composes, in the order of its ``second`` argument
SECOND_KERNELS = ("hinge_wrench_D_q_D_q", "slide_wrench_D_q_D_q", "slider_closure_wrench_D_q_D_q",
                  "rod_closure_wrench_D_q_D_q")


def geometric_second_product(assembler, state, y: np.ndarray, w: np.ndarray, along: np.ndarray) -> np.ndarray:
    """The move of :func:`geometric_product`'s ∂(Pᵀ y)/∂q · w at fixed y and w along ``along`` (n_total + 1: a move of
    the free coordinates δq, or of the prescribed ones q̇_p, the move in time), exactly (n,):

        d/dε [∂(Pᵀ y)/∂q (q ⊕ ε along) · w] at ε = 0

    — the links' second derivatives, at ``state`` (its dependent nodes completed: J of it in the links' buffers):
    csrc/links.c ``geometric_term`` differentiated along the tree by the product rule (csrc/linked_weight_second.c,
    whose header has the equations), from the generated edge kernels' ``*_rates_D_q`` (the slots' maps J moved,
    δJ_c = δ(transfer) J_p + transfer δJ_p) and the wrench kernels' second derivatives :data:`SECOND_KERNELS`."""
    import ctypes

    from latdyn.assembly.native_model import _kernel_address

    model = assembler.model
    n, size = model.n_dofs, model.n_total + 1
    full, vector, marked, moved, out = (np.zeros(size), np.zeros(size), np.zeros(size, np.int64),
                                        np.zeros(size), np.zeros(size))
    full[:len(y)] = y
    vector[:n] = w
    marked[:n] = 1
    moved[:len(along)] = along
    second = (ctypes.c_void_p * 4)(*(_kernel_address(assembler.kernels, name) for name in SECOND_KERNELS))
    native = assembler.native()
    links = native.links.data
    scratch = np.zeros((6 * links.width + 12) * links.n_slots)
    native.library.latdyn_linked_geometric_second(native.model_ref, ctypes.byref(native.configuration(state)),
                                                  full.ctypes.data, marked.ctypes.data, vector.ctypes.data,
                                                  moved.ctypes.data, ctypes.addressof(second), scratch.ctypes.data,
                                                  out.ctypes.data)
    return out[:n]


def linked_geometric_derivative(assembler, state, w: np.ndarray, dq: np.ndarray, scale: float, rates) -> np.ndarray:
    """The derivative of the reduction's geometric term in W w, s ∂(Pᵀ r_all)/∂q[w] (module docstring, "Rigid links
    and guides"), along each column's move (δq, the free rates along ``rates`` = (δv, δv̇), the dependent ones
    following; None: none moved, the dependent ones still following the configuration) (n, k), exactly:

        s ∂(Pᵀ δr_all)/∂q[w] + s ∂/∂q (∂(Pᵀ r)/∂q[w]) δq at fixed r = r_all

    the first with δr_all = K_all δq_all + C_all δv_all + M_all δa_all, the blocks before the reduction with the
    inertia tangent (the exact ∂r_all/∂q), δq_all = P δq, δv_all = P δv + ∂(J v)/∂q δq,
    δa_all = P δv̇ + ∂(J a + c)/∂q δq + ∂c/∂v δv (the compiled links' buffers, as csrc/linked_prescribed_rates.c
    moves the dependent nodes), through the geometric term of δr_all (:func:`geometric_product`); the second the
    links' second derivatives, the geometric term of the fixed r_all moved along δq (:func:`geometric_second_product`,
    generated kernels composed in C)."""
    model = assembler.model
    n = model.n_dofs
    ev = assembler.evaluate(state, matrices=True, inertia_tangent=True)
    P, r_all = ev.projection, ev.assembled_residual
    K_all, C_all, M_all = (ev.combined_before_reduction(*c, True) for c in ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0),
                                                                             (1.0, 0.0, 0.0)))
    by_velocity, by_acceleration = ev.rates_tangent   # dense, or sparse on a sparse storage: applied, not converted
    convective = ev.velocity_derivative
    dependent = ev.dependent_rows
    out = np.zeros((n, dq.shape[1]))
    for c in range(dq.shape[1]):
        along = dq[:, c]
        dv = rates[0][:, c] if rates is not None else np.zeros(n)
        dvdot = rates[1][:, c] if rates is not None else np.zeros(n)
        dq_all = np.asarray(P @ along).reshape(-1)
        dv_all = np.asarray(P @ dv).reshape(-1)
        da_all = np.asarray(P @ dvdot).reshape(-1)
        dv_all[dependent] += np.asarray(by_velocity @ along).reshape(-1)
        da_all[dependent] += np.asarray(by_acceleration @ along + convective @ dv).reshape(-1)
        moved_residual = K_all @ dq_all + C_all @ dv_all + M_all @ da_all
        out[:, c] = geometric_product(assembler, state, moved_residual, w)
        if np.any(along):
            out[:, c] += geometric_second_product(assembler, state, r_all, w, along)
    return scale * out


def linked_geometric_rate_in_time(assembler, state, y: np.ndarray, w: np.ndarray,
                                  motion_rates: np.ndarray) -> np.ndarray:
    """∂/∂t (∂(Pᵀ y)/∂q[w]) at fixed y and fixed free coordinates (n,): the reduction's geometric term of y moved in
    time by the prescribed motions (P hangs the dependent nodes from the prescribed coordinates too) — the links'
    second derivatives ∂²(Pᵀ y)/∂q[w]∂q_p q̇_p, exactly: :func:`geometric_second_product` along the prescribed
    coordinates' rates ``motion_rates`` (n_total + 1: q̇_p at t on the prescribed coordinates, 0 elsewhere,
    :meth:`latdyn.analyses.prescribed_rates.PrescribedRates.rates`; all 0: the term is 0). An event's weight at
    t_e + δt_e takes it with y the inertia forces' part of r_all (module docstring, "Rigid links and guides";
    ``TransientSensitivities._geometric_derivative``)."""
    if not np.any(motion_rates) or not np.any(y):
        return np.zeros(assembler.model.n_dofs)
    return geometric_second_product(assembler, state, y, w, motion_rates)


def _rates_jacobian_derivative(assembler, state, w: np.ndarray, prescribed: np.ndarray | None = None) -> np.ndarray:
    """∂(J w)/∂q (6 n_dep × n) at ``state``: the dependent nodes' rates' derivative by the free coordinates at fixed
    free rates w, every other rate (the prescribed coordinates') 0 — ∂P/∂q[δq] w is its product with δq on the
    dependent rows (P = [I; J]). ``prescribed`` (n_total + 1,): the prescribed coordinates' rates instead of 0 (with
    w = 0, ∂(J_·p q̇_p)/∂q: the move in time of the dependent nodes moved along q, ``linked_prescribed_along`` of
    latdyn/analyses/parameter_stiffness.py). The compiled links' own (csrc/links.c ``dependent_rates_tangent``: the
    generated edge kernels' ``*_rates_D_q`` composed along the tree) at a copy of the state with those rates; the
    links' buffers completed again at the state after it."""
    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.linked import _rates_tangent

    model = assembler.model
    links = model.links
    moved = state.copy()
    for name in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot"):
        getattr(moved, name)[...] = 0.0
    unpack_free(model, w, moved.v, moved.w, moved.theta_dot)
    if prescribed is not None:   # a prescribed node's rates on its coordinates (spatial ω on its turns), an angle's
        on = set(int(d) for d in model.prescribed_coordinates())
        for i, dofs in enumerate(model.node_dofs):
            for k, d in enumerate(dofs):
                if int(d) in on:
                    (moved.v if k < 3 else moved.w)[i, k % 3] = prescribed[d]
        for j, d in enumerate(model.hinge_dofs):
            if int(d) in on:
                moved.theta_dot[j] = prescribed[d]
    native = assembler.native()
    native.complete_links(moved)
    columns = links.columns(model)
    by_velocity, _ = _rates_tangent(assembler, moved, native.links, links, columns, columns < model.n_dofs, True)
    native.complete_links(state.copy())   # the links' buffers (∂c/∂v moves with the rates) at the state again
    return by_velocity


def linked_configuration_tangent(assembler, state, w: np.ndarray, dq: np.ndarray, scale: float,
                                 mass: bool) -> np.ndarray:
    """∂(Pᵀ W_gen P w)/∂q δq (n, k) for each column of ``dq`` on a model with rigid links or guides, exactly (module
    docstring, "Rigid links and guides"): W_gen the generated blocks on the assembled coordinates
    (:func:`_linked_weight`), P = [I; J] the reduction's projection, u = P w, y = W_gen u:

        Pᵀ H_gen (P δq) + ∂(Pᵀ y)/∂q δq + Pᵀ W_gen (∂(J w)/∂q δq)

    with H_gen = ∂(W_gen u)/∂q_all the generated elements' and joint bodies' parts at u on every assembled coordinate
    (:func:`_generated`), the point loads' (:func:`_load_part` of :func:`linked_generated_loads`: a load on a
    dependent node on its dependent turns, a global load's zero frame half skipped), the taut cable elements'
    (:func:`_cable_part`, between dependent nodes too; a slack one's zero), the couplings' of
    :func:`linked_exact_couplings` (:func:`_coupling_part`) and the generated hinges' diagonal (:func:`_hinge_part`
    of :func:`linked_exact_hinges`; a hinge's coordinate is free, so P does not move its row), ∂(Pᵀ y)/∂q at fixed y
    the reduction's geometric term of y (the forward step's, csrc/links.c ``geometric_term``, times δq: ``latdyn_linked_geometric_product``, csrc/linked_weight.c), and
    ∂(J w)/∂q the compiled links' rates' derivative at rates w (:func:`_rates_jacobian_derivative`)."""
    import ctypes

    model = assembler.model
    n, n_asm, size = model.n_dofs, model.n_assembled, model.n_total + 1
    ev = assembler.evaluate(state, matrices=True)
    P = ev.projection
    hinges = linked_exact_hinges(assembler)
    W_gen = _linked_weight(assembler, ev, scale, mass, hinges, generated=True)
    u = np.zeros(size)
    u[:n_asm] = np.asarray(P @ w).reshape(-1)
    y = np.zeros(size)
    y[:n_asm] = np.asarray(W_gen @ u[:n_asm]).reshape(-1)
    parts = [_generated(assembler, state, w, scale, mass, full=u),
             _load_part(assembler, state, w, scale, full=u, exact=linked_generated_loads(assembler)),
             _cable_part(assembler, state, w, scale, full=u),
             _coupling_part(assembler, state, w, scale, exact=linked_exact_couplings(assembler), full=u),
             _driven_load_part(assembler, state, w, scale, full=u, exact=linked_generated_loads(assembler))]
    rows, cols, values = (np.concatenate([part[i] for part in parts]) for i in range(3))
    keep = (rows < n_asm) & (cols < n_asm)
    H_gen = csr.CSR.from_coo(values[keep], rows[keep], cols[keep], (n_asm, n_asm))
    hinge_rows, hinge_values = _hinge_part(assembler, state, w, scale, exact=hinges)
    by_rates = _rates_jacobian_derivative(assembler, state, w)
    dependent_rows = model.node_dofs[model.links.dependent].ravel()
    native = assembler.native()
    configuration = native.configuration(state)
    marked = np.zeros(size, np.int64)
    marked[:n] = 1
    vector, product = np.zeros(size), np.zeros(size)
    out = np.zeros((n, dq.shape[1]))
    for c in range(dq.shape[1]):
        along = dq[:, c]
        moved_all = np.asarray(P @ along).reshape(-1)
        moved_w = np.zeros(n_asm)
        moved_w[dependent_rows] = by_rates @ along
        inner = csr.times(H_gen, moved_all) + np.asarray(W_gen @ moved_w).reshape(-1)
        column = np.asarray(P.T @ inner).reshape(-1)
        column[hinge_rows] += hinge_values * along[hinge_rows]
        vector[:n] = along
        native.library.latdyn_linked_geometric_product(native.model_ref, ctypes.byref(configuration), y.ctypes.data,
                                                       marked.ctypes.data, vector.ctypes.data, product.ctypes.data)
        out[:, c] = column + product[:n]
    return out
