"""The derivative of an event's impulse weight along the configuration, H = ∂(W w)/∂q, generated
(docs/parameters.md, "The impulse weight's derivative").

A latch, a rigid stop with restitution and a stick weigh the velocity jump with W = M + s K (s = dt²) at the state
before the jump, and a stop's restart with s K (latdyn/timeloop/impulse.py, latdyn/timeloop/events.py). The forward
sensitivities need δ(W w) = H δq + (∂W/∂p) w along each column's (δq, δp), the adjoint Hᵀū
(latdyn/analyses/transient_sensitivities.py ``_weight_derivative``, latdyn/analyses/adjoint_sensitivities.py
``_weight_derivative_transposed``). H is assembled once per event as an n × n sparse matrix on the free coordinates,
so one matrix serves both:

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
  there (csrc/evaluate.c ``hinge_forces``). A hinge with a law of θ that names an input or a controller, or whose
  ∂f/∂θ does not parse back as a law (:func:`exact_hinges`), keeps the difference below along its angle;
* the point loads' blocks K_l (the node's rows × the turns of the node and of the body the load turns with; a
  global load's frame half zero), along w_l on those columns: ``point_load_stiffness_D_q`` (codegen/joints.py: K_l w
  as the derivative of the load's force along the turns τ w at τ = 0, differentiated once more by the turns the
  node and the frame start from) at the load's values at the state's time (:func:`_load_part`). A load a
  continuous controller drives (alone or through a law a y + b) has values that move with the controller's
  sensors: its block keeps the difference below (:func:`exact_loads`);
* the cable elements' blocks K_c (both end nodes' [d, π], the damper's c ℓ̇ at the state's rates included), along
  w_c: ``cable_stiffness_D_q`` (the same construction on the taut law of ``cable_force``), for the elements taut at
  the state as csrc/evaluate.c ``cables`` decides (held taut, or on no side a positive gap min(N_el, N)); a slack
  element's K is the runtime's zero, its derivative too (:func:`_cable_part`);
* the continuous controllers' couplings on a joint's force from a controller that reads joints' angles and rates
  alone (:func:`exact_couplings`): K's entry −a ∂y/∂θ_j moves along q with −a ∂²y/∂θ_j∂θ_i (an angle sensor's own
  second derivative is 0; the rates are held), SymPy's second derivatives of the output's expression by its angles
  lambdified once per output in a process (:func:`_output_curvature`) and evaluated with NumPy at the event's sensor values; 0 while
  the output is saturated (:func:`_coupling_part`).

Not generated, H_rest: the other continuous controllers' couplings (a sensor of a point, a body, a cable, an
element or a joint's force, whose own second derivative through the kinematics is not generated; an input, a state
or another controller read; a load component driven) and the blocks of the loads they drive. Their product (W
without the generated blocks) w is differenced centrally along each coordinate those blocks are on
(:func:`rest_support`: those couplings' rows and columns, the driven loads' nodes and frame bodies, a hinge not in
:func:`exact_hinges`), two evaluations per coordinate, step
:data:`latdyn.analyses.transient_sensitivities.WEIGHT_STEP` √(ℓ L_min) (ℓ the length scale, L_min the shortest
element where shorter). A model with none of them has H exact with no evaluation.

Rigid links and guides: the reduced weight is W_red = Pᵀ W_all P + s ∂(Pᵀ r_all)/∂q (latdyn/assembly/linked.py: W_all
the blocks on the assembled coordinates, free and dependent, P = [I; J] the projection, r_all the residual before the
reduction, with the inertia forces at the state's rates). :func:`configuration_tangent_of_weight` does not take them
(its free coordinates are the assembled ones); ``TransientSensitivities._linked_weight_derivative`` splits W_red w:

* exact, the generated blocks W_gen (elements, joint bodies, the hinges of :func:`exact_hinges`) through the
  reduction, :func:`linked_configuration_tangent`: with u = P w, y = W_gen u,
  ∂(Pᵀ W_gen P w)/∂q δq = Pᵀ H_gen (P δq) + ∂(Pᵀ y)/∂q δq + Pᵀ W_gen (∂(J w)/∂q δq) — H_gen the generated H above
  on every assembled coordinate (the dependent nodes' elements and bodies too), ∂(Pᵀ y)/∂q at fixed y the forward
  step's geometric term of y (csrc/links.c ``geometric_term`` from the generated wrench kernels, times δq:
  csrc/linked_weight.c), ∂(J w)/∂q the compiled links' rates' derivative at rates w (csrc/links.c
  ``dependent_rates_tangent``, the generated edge kernels' ``*_rates_D_q``): the derivative of P along δq applied
  to w, exact for every edge kind (hinges, slides, closures), where a polarisation of the links' quadratic term
  would hold for their positions' rows alone (on the 3D gimbal of skew hinges ∂(J w)/∂q δq and ∂(J δq)/∂q w differ
  by 0.61 of the former on the rotations' rows, 2.3e-16 on the translations');
* the geometric term's own derivative, :func:`linked_geometric_derivative`: along (δq, δv, δv̇),
  s ∂(Pᵀ δr_all)/∂q[w] exactly (δr_all = K_all δq_all + C_all δv_all + M_all δa_all, the blocks before the reduction
  with the inertia tangent, the dependent rates following the links through their compiled buffers), plus
  s ∂/∂q(∂(Pᵀ r)/∂q[w]) δq at fixed r = r_all — the links' second derivatives, which no generated kernel holds: a
  Richardson-extrapolated central difference of the links alone (:data:`LINKS_STEP`; their kinematics completed at
  the moved configurations, the geometric term of the fixed r_all, no evaluation of the model); at an event moved
  in time (δt_e) with prescribed motions, P moves with the prescribed coordinates too: the geometric term of the
  inertia forces moved in time, ∂/∂t(∂(Pᵀ y)/∂q[w]) at fixed y, a difference of the links alone in t
  (:func:`linked_geometric_rate_in_time`; the static residual's part is in its ∂r/∂t differenced along w);
* differenced, the blocks not generated (as H_rest: loads, cables, couplings, hinges outside :func:`exact_hinges`),
  Pᵀ W_rest P w (:func:`linked_rest_product`, computed on its own: the reduced W w less the exact part carried that
  part's round-off, 1e-8 of H δq over the step on the slider-crank), centrally along each column's move (δq, the free
  rates along δv, δv̇, the dependent ones completed) as before, two evaluations a parameter — none where the model
  has no such block (:func:`linked_has_rest`).

Along the rates: W moves with them where K does, ∂(K w)/∂v δv (``TransientSensitivities._stiffness_by_rates``, two
evaluations a parameter; its transpose in the adjoint, two a free rate; generated where the damped taut cables' block
is the only one moving and no controller: :func:`cable_stiffness_by_rates`, K_c affine in the rates). Which terms of K move with the rates is
asked of the model's own evaluation, not of a list of the laws that can make them (:func:`stiffness_moving_with_rates`:
K's blocks at the state's rates and at rates moved, compared bit for bit): a damped cable's c ℓ̇ terms, a hinge law
whose ∂τ/∂θ holds θ̇, a compliant stop's Hunt–Crossley damping n δⁿ⁻¹ c δ̇ in contact, a continuous controller's
couplings whose ∂y/∂s holds a rate (an output nonlinear in an angle and a rate) and the block of a load in a body's
frame whose component a controller of a rate drives (found so at random rates:
tests/test_sensitivities_rate_stiffness.py); not the joint bodies' gyroscopic terms nor the elements' (the inertia
tangent, which the weight's K leaves out), nor friction (∂f/∂θ = 0: its level and engagement are functions of the
rate alone), nor a stop out of contact, an undamped one, an undamped cable or a controller linear in its sensors.
"""
from __future__ import annotations

import numpy as np

from latdyn.numerics import csr
from latdyn.numerics.csr import CSR
from latdyn.numerics.linalg import RCM_IN_PYTHON

__all__ = ["cable_stiffness_by_rates", "configuration_tangent_of_weight", "exact_couplings", "exact_hinges", "exact_loads",
           "geometric_product", "linked_configuration_tangent", "linked_geometric_derivative",
           "linked_geometric_rate_in_time", "linked_has_rest", "linked_rest_moves", "linked_rest_product",
           "needs_the_kernel",
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
#: (output's text, symbols, angle reads) -> its :func:`_output_curvature`, made once per process
_CURVATURES: dict = {}


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
    """H x for :func:`configuration_tangent_of_weight`'s H (either storage; the same sums)."""
    return csr.times(H, x) if isinstance(H, CSR) else np.asarray(H @ x)


def transposed_times(H, x: np.ndarray) -> np.ndarray:
    """Hᵀ x for :func:`configuration_tangent_of_weight`'s H (either storage; the same sums)."""
    return csr.transposed_times(H, x) if isinstance(H, CSR) else np.asarray(H.T @ x)


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
    """(loads,) bool: whether the point load's part of H is generated (:func:`_load_part`): none of its components
    is driven by a continuous controller (alone or through a law a y + b; latdyn.assembly.control: its values then
    move with the controller's sensors, the couplings' columns, and its block stays in :func:`rest_support`'s
    difference)."""
    control = assembler.control
    out = np.ones(len(assembler.loads), bool)
    kinds = np.asarray(getattr(control, "actuator_kind", np.zeros(0, np.int64)))
    out[np.asarray(getattr(control, "actuator_index", np.zeros(0, np.int64)))[kinds == 1]] = False
    return out


def _scattered(dofs: np.ndarray, n_total: int) -> np.ndarray:
    """``dofs`` with the slots that are no coordinate (negative) on n_total, the slot :func:`_sparse` drops and a
    direction reads 0 at."""
    return np.where(dofs < 0, n_total, dofs)


def _law_value(component, t: float) -> float:
    """A load component's value at t: its law of time, or a constant."""
    return float(component.value(t)) if hasattr(component, "value") else float(component)


def _load_part(assembler, state, w: np.ndarray, scale: float):
    """(rows, cols, values) of the point loads' part of H: s ∂(K_l w_l)/∂[π_node, π_frame] for each load of
    :func:`exact_loads` with w on its block's columns, from the generated ``point_load_stiffness_D_q``
    (codegen/joints.py) at the load's values at the state's time (its laws of t; the evaluation's load factor 1)."""
    model, loads = assembler.model, assembler.loads
    full = np.zeros(model.n_total + 1)
    full[:model.n_dofs] = w
    follower = np.array([load.frame != "global" for load in loads], bool)
    columns = _scattered(assembler._load_columns(), model.n_total)
    along = full[columns]
    along[~follower, 3:] = 0.0   # a global load has no frame: its block's frame half is zero (csrc/evaluate.c)
    on = np.flatnonzero(exact_loads(assembler) & np.any(along != 0.0, axis=1))
    if not len(on):
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    t = float(state.t)
    values = np.array([[_law_value(c, t) for c in (loads[l].force or [0.0] * 3)]
                       + [_law_value(c, t) for c in (loads[l].moment or [0.0] * 3)] for l in on], float)
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


def cable_stiffness_by_rates(assembler, state, w: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """∂(K w)/∂v δv (n, k) of the cable elements taut at ``state`` (as :func:`_cable_part` finds them), each column of
    ``dv`` (n, k) a move of the free rates: K_c is affine in the rates (the damper's c ℓ̇, ℓ̇ linear in the ends'
    velocities), so K_c(δv) w − K_c(0) w from the generated ``cable_stiffness_D_q``'s ``cable_stiffness_along`` is
    it exactly (``TransientSensitivities._stiffness_by_rates`` where the cables' block is the only one of K moving
    with the rates, :func:`stiffness_moving_with_rates`, and no controller drives a load)."""
    model = assembler.model
    n, k = dv.shape
    taut = _taut_cables(assembler, state)
    if taut is None or not k:
        return np.zeros((n, k))
    dofs, geometry, _, section = taut
    full, moves = np.zeros(model.n_total + 1), np.zeros((model.n_total + 1, k))
    full[:n], moves[:n] = w, dv
    along = full[dofs]                                          # (e, 12)
    m = len(dofs)
    rows = lambda a: np.ascontiguousarray(np.reshape(a, (m * k, -1)), dtype=float)  # noqa: E731
    repeated = lambda a: np.repeat(a[:, None], k, axis=1)  # noqa: E731   (e, k, ·)
    velocity = np.transpose(moves[dofs], (0, 2, 1))            # (e, k, 12): each column's move on the element
    kernel = assembler.kernels.cable_stiffness_D_q
    at = (rows(repeated(geometry)), rows(repeated(section)), rows(repeated(along)))
    moved = np.asarray(kernel(at[0], rows(velocity), at[1], at[2])[0]).reshape(m, k, 12)
    still = np.asarray(kernel(at[0], rows(np.zeros_like(velocity)), at[1], at[2])[0]).reshape(m, k, 12)
    grown = np.zeros((model.n_total + 1, k))
    np.add.at(grown, dofs, np.transpose(moved - still, (0, 2, 1)))
    return grown[:n]


def _taut_cables(assembler, state):
    """(dofs (e, 12) with n_total for no coordinate, geometry (e, 12), velocity (e, 12), section (e, 4)) of the cable
    elements taut at ``state`` (csrc/evaluate.c ``cables``: held taut, or on no side a positive gap min(N_el, N)), the
    generated cable kernels' inputs; None where there is none."""
    from latdyn.analyses.cable_sensitivities import _turned

    model, cables = assembler.model, assembler.model.cables
    if cables is None or not len(cables.nodes):
        return None
    t = float(state.t)
    on = np.arange(len(cables.nodes))
    nodes = cables.nodes
    geometry = np.array([np.concatenate([state.x[a], state.x[b], _turned(state.T[a], cables.offsets[e, 0]),
                                         _turned(state.T[b], cables.offsets[e, 1])])
                         for e, (a, b) in zip(on, nodes)])
    velocity = np.concatenate([state.v[nodes[:, 0]], state.w[nodes[:, 0]], state.v[nodes[:, 1]], state.w[nodes[:, 1]]],
                              axis=1)
    rest = [cables.rest_length[cables.cable[e]] for e in on]
    section = np.column_stack([cables.share * [r.value(t) for r in rest],
                               cables.share * [r.rate(t) for r in rest], cables.EA, cables.damping])
    rows = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    law = np.asarray(assembler.kernels.cable_force(rows(geometry), rows(velocity), rows(section))[3]).reshape(-1, 5)
    sides = np.asarray(cables.sides, float)
    taut = (sides > 0) | ((sides == 0) & (np.minimum(law[:, 3], law[:, 4]) > 0.0))
    if not np.any(taut):
        return None
    dofs = _scattered(assembler.cable_dofs(), model.n_total)
    return dofs[taut], geometry[taut], velocity[taut], section[taut]


def _cable_part(assembler, state, w: np.ndarray, scale: float):
    """(rows, cols, values) of the cable elements' part of H: s ∂(K_e w_e)/∂[d1, π1, d2, π2] for each element taut
    at the state (:func:`_taut_cables`; a slack one's K is zero, its derivative too) with w on its coordinates, from
    the generated ``cable_stiffness_D_q`` (codegen/joints.py: the taut law, the damper's c ℓ̇ at the state's rates
    included)."""
    model = assembler.model
    taut = _taut_cables(assembler, state)
    if taut is None:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    dofs, geometry, velocity, section = taut
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


def _output_curvature(controller, angles: tuple):
    """SymPy's ∂²f/∂s_i∂s_j of a continuous controller's output f before saturation by its reads at the positions
    ``angles`` (its angle sensors; the rates' never enter W), lambdified once per output's text, reads and angles in a
    process (:data:`_CURVATURES`: a scene loaded again reuses it), a function of ``(t, *reads values)`` giving the
    (angles, angles) matrix; None where a second derivative is not a function (DiracDelta of a kink, an unevaluated
    derivative)."""
    reads = controller.symbols[1:1 + len(controller.reads)]
    key = (str(controller.output_expr), tuple(str(x) for x in controller.symbols), tuple(angles))
    if key not in _CURVATURES:
        import sympy as sp

        first = [sp.diff(controller.output_expr, reads[i]) for i in angles]
        second = [[sp.diff(first[a], reads[j]) if b >= a else None for b, j in enumerate(angles)]
                  for a in range(len(angles))]
        second = [[second[a][b] if b >= a else second[b][a] for b in range(len(angles))] for a in range(len(angles))]
        singular = any(e.has(sp.DiracDelta, sp.Derivative, sp.Subs) for row in second for e in row)
        _CURVATURES[key] = None if singular else sp.lambdify(controller.symbols[:1 + len(reads)], second,
                                                             modules=["math", "numpy"])
    return _CURVATURES[key]


def exact_couplings(assembler) -> np.ndarray:
    """(couplings,) bool: whether a continuous controller's coupling entry of K has its part of H generated
    (:func:`_coupling_part`): its actuator is a hinge's or guide's force, and its controller reads joints' angles
    and rates alone (no input, no other controller, no state) with an output whose second derivatives by them are
    functions (:func:`_output_curvature`). Its entry −a ∂y/∂s (sensor s an angle: the sensor's own second
    derivative is 0) then moves along q with ∂²y/∂s² alone; the others keep the difference (:func:`rest_support`)."""
    from latdyn.assembly.control import ANGLE, RATE

    control = assembler.control
    rows = np.asarray(control.coupling_rows)
    out = np.zeros(len(rows), bool)
    if not len(rows):
        return out
    plain = []
    for k, controller in enumerate(control.controllers):
        kinds = control.sensor_kind[control.sensor_start[k]:control.sensor_start[k + 1]]
        plain.append(not controller.states and len(kinds) == len(controller.reads)
                     and bool(np.all((kinds == ANGLE) | (kinds == RATE)))
                     and _output_curvature(controller, tuple(np.flatnonzero(kinds == ANGLE))) is not None)
    for e, a in enumerate(np.asarray(control.coupling_actuator)):
        out[e] = control.actuator_kind[a] == 0 and plain[control.actuator_controller[a]]
    return out


def _coupling_part(assembler, state, w: np.ndarray, scale: float):
    """(rows, cols, values) of the couplings' part of H for the entries of :func:`exact_couplings`: K's entry
    K_rj = −a ∂y/∂θ_j (a = ∂τ/∂y of the hinge's law a y + b, 1 for the controller's name alone; 0 while the output
    is saturated, csrc/evaluate.c controller_outputs) along w: s Σ_j ∂K_rj/∂θ_i w_j = −s a Σ_j ∂²f/∂θ_j∂θ_i w_j
    in column i, for the angle sensors i, j of the actuator's controller (rates held: W has no C)."""
    from latdyn.assembly.control import ANGLE

    control, model = assembler.control, assembler.model
    exact = exact_couplings(assembler)
    n = model.n_dofs
    out_rows, out_cols, out_values = [], [], []
    done = set()
    for e in np.flatnonzero(exact):
        a = int(control.coupling_actuator[e])
        if a in done:
            continue
        done.add(a)
        k = int(control.actuator_controller[a])
        controller = control.controllers[k]
        first, last = int(control.sensor_start[k]), int(control.sensor_start[k + 1])
        kinds, indices = control.sensor_kind[first:last], control.sensor_index[first:last]
        values = [float(state.theta[i] if kind == ANGLE else state.theta_dot[i])
                  - float(control.sensor_origin[first + m]) for m, (kind, i) in enumerate(zip(kinds, indices))]
        t = float(state.t)
        y = float(controller.functions()[0](t, *values))
        lo, hi = control.limits[k]
        if y < lo or y > hi:   # saturated: ∂y/∂s = 0 about the state, its derivative too
            continue
        angles = np.flatnonzero(kinds == ANGLE)
        columns = np.asarray(model.hinge_dofs, np.int64)[indices[angles]]
        along = np.where(columns < n, w[np.minimum(columns, n - 1)], 0.0)
        if not np.any(along):
            continue
        second = _output_curvature(controller, tuple(angles))
        curvature = np.asarray(second(t, *values), float).reshape(len(angles), len(angles))
        gain = float(control.actuator_gain[a]) if control.actuator_gain[a] != 0.0 else 1.0
        row = int(model.hinge_dofs[control.actuator_index[a]])
        out_rows.append(np.full(len(angles), row, np.int64))
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


def exact_hinges(assembler) -> np.ndarray:
    """(free hinges,) bool: whether the free hinge's part of H is generated (:func:`_hinge_part`): each of its laws
    is constant, of t alone, or of θ with a second derivative (:func:`_angle_slope_law`) and naming no input or
    controller (their values are the runtime's, read by the compiled laws); otherwise its angle stays in
    :func:`rest_support`, differenced as before."""
    model = assembler.model
    out = np.ones(len(model.free_hinges), bool)
    for i, j in enumerate(model.free_hinges):
        for key, law in _hinge_laws(assembler, int(j)):
            if law is None or "theta" not in law.depends_on:
                continue
            if getattr(law, "input_names", ()) or _slope_law(law, model.scene,
                                                             f"joints.{model.hinges[j].name}.{key}") is None:
                out[i] = False
    return out


def _hinge_part(assembler, state, w: np.ndarray, scale: float):
    """(rows, values) of the hinges' part of H, on its diagonal: s (∂K_jj/∂θ_j) w_j for each free hinge j with
    w_j ≠ 0, K_jj = ∂f/∂θ of its laws and its compliant stop (the generated ``hinge_stiffness_by_angle``,
    codegen/joints.py, from the laws' values, first and second derivatives in θ at the state; a hinge driven by a
    continuous controller alone has no torque law there, as csrc/evaluate.c hinge_forces)."""
    from latdyn.assembly.native_model import joint_contact_rows

    model = assembler.model
    n = model.n_dofs
    free = np.asarray(model.free_hinges, np.int64)
    dofs = np.asarray(model.hinge_dofs, np.int64)[free] if len(free) else np.zeros(0, np.int64)
    on = [(j, d) for j, d, exact in zip(free, dofs, exact_hinges(assembler)) if exact and d < n and w[d] != 0.0]
    if not on:
        return np.zeros(0, np.int64), np.zeros(0)
    kernels, scene = assembler.kernels, model.scene
    contact_rows = joint_contact_rows(model.hinges)
    states, laws, curvatures, contacts = [], [], [], []
    for j, _ in on:
        hinge = model.hinges[j]
        theta, rate, t = float(state.theta[j]), float(state.theta_dot[j]), float(state.t)
        row, curvature = np.zeros(9), np.zeros(3)
        for slot, (key, law) in enumerate(_hinge_laws(assembler, int(j))):
            if law is None:
                continue
            row[3 * slot:3 * slot + 3] = law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t)
            if "theta" in law.depends_on:
                curvature[slot] = _slope_law(law, scene, f"joints.{hinge.name}.{key}").d_theta(theta, rate, t)
        states.append([theta, rate, hinge.rest_angle, 1.0])
        laws.append(row)
        curvatures.append(curvature)
        contacts.append(contact_rows[j])
    rows = lambda a: np.ascontiguousarray(np.asarray(a, float))  # noqa: E731
    by_angle = np.asarray(kernels.hinge_stiffness_by_angle(rows(states), rows(laws), rows(curvatures),
                                                           rows(contacts))[0]).reshape(-1)
    hinge_rows = np.array([d for _, d in on], np.int64)
    return hinge_rows, scale * by_angle * w[hinge_rows]


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
    rows, cols, values = (np.concatenate([rows, hinge_rows, load_rows, cable_rows, coupling_rows]),
                          np.concatenate([cols, hinge_rows, load_cols, cable_cols, coupling_cols]),
                          np.concatenate([values, hinge_values, load_values, cable_values, coupling_values]))
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


def _linked_weight(assembler, ev, scale: float, mass: bool, exact: np.ndarray, generated: bool):
    """W_gen (``generated``) or W_rest on the assembled coordinates (n_assembled², free and dependent; dense or CSR as
    :meth:`latdyn.assembly.assembler.Assembler.assemble`) of a model with rigid links or guides, from the blocks of
    ``ev`` before the reduction (latdyn/assembly/linked.py ``LinkedEvaluation.blocks``): W_gen c_m M + s K of the
    elements, the joint bodies and the free hinges whose part of H is generated (``exact``: :func:`exact_hinges`),
    W_rest the other blocks' (the other hinges', the loads' and cables', the controllers' couplings', as
    :func:`_rest_product`'s); W_gen + W_rest = c_m M + s K before the reduction."""
    from latdyn.assembly.evaluation import Evaluation

    raw = Evaluation(residual=None, reaction=None, blocks=ev.blocks, assembler=assembler)
    stiffness, inertia = raw.flat_blocks("stiffness"), raw.flat_blocks("mass")
    cm = 1.0 if mass else 0.0
    if generated:
        return assembler.assemble([cm * inertia[0] + scale * stiffness[0], cm * inertia[1] + scale * stiffness[1],
                                   np.where(exact, scale * stiffness[2], 0.0), 0.0 * stiffness[3], 0.0 * stiffness[4]])
    rest = [0.0 * stiffness[0], 0.0 * stiffness[1], np.where(exact, 0.0, scale * stiffness[2])] + \
        [scale * b for b in stiffness[3:]]
    if mass:
        rest = rest[:2] + [p + m for p, m in zip(rest[2:], inertia[2:])]
    return assembler.assemble(rest)


def linked_has_rest(assembler) -> bool:
    """Whether a model with rigid links or guides has blocks whose part of H is not generated (W_rest of
    :func:`_linked_weight`): point loads, cable elements, continuous controllers' couplings, or a free hinge not in
    :func:`exact_hinges`. Without them W_rest is 0 and its difference takes no evaluation."""
    return bool(len(assembler.loads) or len(assembler.cable_dofs()) or len(assembler.control.coupling_rows)
                or not np.all(exact_hinges(assembler)))


def linked_rest_moves(assembler, state, scale: float, mass: bool) -> bool:
    """Whether W_rest (:func:`linked_has_rest`) may move along a column's move at ``state``: False where its only blocks
    are global point loads' and they are zero there — a global load's block, −skew(F(t)) skew(T r) of its force at the
    offset r, is then zero at every configuration and rate (no offset, or no force at t), and the difference of
    ``TransientSensitivities._linked_weight_derivative`` would add exact zeros at two evaluations a column (a load at a
    gimbal's tip: 80 % of the adjoint's cost of an event, which differences 3n unit moves)."""
    if len(assembler.cable_dofs()) or len(assembler.control.coupling_rows) or not np.all(exact_hinges(assembler)):
        return True
    if any(load.frame != "global" for load in assembler.loads):
        return True
    ev = assembler.evaluate(state, matrices=True)
    W_rest = _linked_weight(assembler, ev, scale, mass, exact_hinges(assembler), generated=False)
    values = W_rest.data if hasattr(W_rest, "data") and not isinstance(W_rest, np.ndarray) else W_rest
    return bool(np.any(np.asarray(values) != 0.0))


def linked_rest_product(assembler, ev, w: np.ndarray, scale: float, mass: bool) -> np.ndarray:
    """Pᵀ W_rest P w (n,) at the linked evaluation ``ev``: the blocks not generated (:func:`_linked_weight`), whose
    derivative along δq stays a difference (``TransientSensitivities._linked_weight_derivative``); computed on its own
    (the reduced W w less the exact part carried that part's round-off, 1e-8 of H δq over the step on the
    slider-crank)."""
    P = ev.projection
    W_rest = _linked_weight(assembler, ev, scale, mass, exact_hinges(assembler), generated=False)
    return np.asarray(P.T @ (W_rest @ np.asarray(P @ w))).reshape(-1)


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


#: the configuration step of the links' own difference in :func:`linked_geometric_derivative` (its second
#: derivatives: no generated kernel), relative to the length scale over the move's size, and Richardson-extrapolated
#: from it and its half: the links' kinematics alone, no evaluation, so a step far above round-off
LINKS_STEP = 1e-3


def linked_geometric_derivative(assembler, state, w: np.ndarray, dq: np.ndarray, scale: float, rates,
                                length: float) -> np.ndarray:
    """The derivative of the reduction's geometric term in W w, s ∂(Pᵀ r_all)/∂q[w] (module docstring, "Rigid links
    and guides"), along each column's move (δq, the free rates along ``rates`` = (δv, δv̇), the dependent ones
    following; None: none moved, the dependent ones still following the configuration) (n, k):

        s ∂(Pᵀ δr_all)/∂q[w] + s ∂/∂q (∂(Pᵀ r)/∂q[w]) δq at fixed r = r_all

    the first exact — δr_all = K_all δq_all + C_all δv_all + M_all δa_all, the blocks before the reduction with the
    inertia tangent (the exact ∂r_all/∂q), δq_all = P δq, δv_all = P δv + ∂(J v)/∂q δq,
    δa_all = P δv̇ + ∂(J a + c)/∂q δq + ∂c/∂v δv (the compiled links' buffers, as csrc/linked_prescribed_rates.c
    moves the dependent nodes), through the geometric term of δr_all (:func:`_geometric_product`) — the second the
    links' second derivatives, which no kernel holds: a Richardson-extrapolated central difference of the geometric
    term at fixed r along δq (:data:`LINKS_STEP`), the links completed at each configuration, no evaluation."""
    model = assembler.model
    n, n_asm = model.n_dofs, model.n_assembled
    ev = assembler.evaluate(state, matrices=True, inertia_tangent=True)
    P, r_all = ev.projection, ev.assembled_residual
    K_all, C_all, M_all = ev._assembled(0.0, 0.0, 1.0, True), ev._assembled(0.0, 1.0, 0.0, True), \
        ev._assembled(1.0, 0.0, 0.0, True)
    by_velocity, by_acceleration = ev.rates_tangent   # dense, or sparse on a sparse storage: applied, not converted
    convective = ev.velocity_derivative
    dependent = ev.dependent_rows
    native = assembler.native()
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

    def links_term(along, eta):   # the geometric term at fixed r_all, the links completed at the moved configuration
        moved = assembler.advance(state, eta * along)
        native.complete_links(moved)
        return geometric_product(assembler, moved, r_all, w)

    for c in range(dq.shape[1]):   # after every exact column: this moves the links' buffers off the state
        along = dq[:, c]
        size = float(np.max(np.abs(along), initial=0.0))
        if size == 0.0:
            continue
        h = LINKS_STEP * length / size
        central = [(links_term(along, step) - links_term(along, -step)) / (2 * step) for step in (h, h / 2)]
        out[:, c] += (4 * central[1] - central[0]) / 3
    native.complete_links(state)
    return scale * out


def linked_geometric_rate_in_time(assembler, state, y: np.ndarray, w: np.ndarray, motion_rates: np.ndarray,
                                  length: float) -> np.ndarray:
    """∂/∂t (∂(Pᵀ y)/∂q[w]) at fixed y and fixed free coordinates (n,): the reduction's geometric term of y moved in
    time by the prescribed motions (P hangs the dependent nodes from the prescribed coordinates too) — the links'
    second derivatives ∂²(Pᵀ y)/∂q[w]∂q_p q̇_p, which no kernel holds: a Richardson-extrapolated central difference
    in t of the geometric term (:func:`geometric_product`) at the prescribed coordinates moved to their laws at
    t ± η (the dependent nodes completed, no evaluation), η = :data:`LINKS_STEP` ℓ over the motions' largest rate
    ``motion_rates`` (their q̇_p at t; all 0: the term is 0). An event's weight at t_e + δt_e takes it with y the
    inertia forces' part of r_all (module docstring, "Rigid links and guides";
    ``TransientSensitivities._geometric_derivative``)."""
    size = float(np.max(np.abs(motion_rates), initial=0.0))
    if size == 0.0 or not np.any(y):
        return np.zeros(assembler.model.n_dofs)

    def at(shift):   # the prescribed coordinates at their laws at t + shift, the free ones held
        moved = state.copy()
        assembler.apply_prescribed(moved, state.t + shift)
        return geometric_product(assembler, moved, y, w)

    h = LINKS_STEP * length / size
    central = [(at(step) - at(-step)) / (2 * step) for step in (h, h / 2)]
    assembler.complete_links(state)   # the links' buffers at the state again
    return (4 * central[1] - central[0]) / 3


def _rates_jacobian_derivative(assembler, state, w: np.ndarray) -> np.ndarray:
    """∂(J w)/∂q (6 n_dep × n) at ``state``: the dependent nodes' rates' derivative by the free coordinates at fixed
    free rates w, every other rate (the prescribed coordinates') 0 — ∂P/∂q[δq] w is its product with δq on the
    dependent rows (P = [I; J]). The compiled links' own (csrc/links.c ``dependent_rates_tangent``: the generated
    edge kernels' ``*_rates_D_q`` composed along the tree) at a copy of the state with those rates; the links'
    buffers completed again at the state after it."""
    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.linked import _rates_tangent

    model = assembler.model
    links = model.links
    moved = state.copy()
    for name in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot"):
        getattr(moved, name)[...] = 0.0
    unpack_free(model, w, moved.v, moved.w, moved.theta_dot)
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
    (:func:`_generated`) and the generated hinges' diagonal (:func:`_hinge_part`; a hinge's coordinate is free, so P
    does not move its row), ∂(Pᵀ y)/∂q at fixed y the reduction's geometric term of y (the forward step's,
    csrc/links.c ``geometric_term``, times δq: ``latdyn_linked_geometric_product``, csrc/linked_weight.c), and
    ∂(J w)/∂q the compiled links' rates' derivative at rates w (:func:`_rates_jacobian_derivative`)."""
    import ctypes

    model = assembler.model
    n, n_asm, size = model.n_dofs, model.n_assembled, model.n_total + 1
    ev = assembler.evaluate(state, matrices=True)
    P = ev.projection
    W_gen = _linked_weight(assembler, ev, scale, mass, exact_hinges(assembler), generated=True)
    u = np.zeros(size)
    u[:n_asm] = np.asarray(P @ w).reshape(-1)
    y = np.zeros(size)
    y[:n_asm] = np.asarray(W_gen @ u[:n_asm]).reshape(-1)
    rows, cols, values = _generated(assembler, state, w, scale, mass, full=u)
    keep = (rows < n_asm) & (cols < n_asm)
    H_gen = csr.CSR.from_coo(values[keep], rows[keep], cols[keep], (n_asm, n_asm))
    hinge_rows, hinge_values = _hinge_part(assembler, state, w, scale)
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
