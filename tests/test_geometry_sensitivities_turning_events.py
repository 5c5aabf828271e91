"""A shift on a part that turns beside latches, rigid stops, friction, compliant stops and controllers of joints and
points (issue 34; latdyn/analyses/geometry_sensitivities.py ``_turning_refusal``, ``ReferenceGeometry.moments_turned``;
latdyn/analyses/transient_sensitivities.py ``_shifts_turned``; latdyn/analyses/sensitivities.py
``ControllerTerms._shift_sensed``; docs/parameters.md "Geometry parameters").

A gimbal's ring offset (the rings moved by X, gim1's length and direction) or the inner ring's hinge point on the outer
ring (gim2's start point on a part that turns) shifts the subtree below by d = T_A δ, fixed in A's axes; the reduction's
P moves with it (its columns that reach A move the subtree's points by g × d: the moment d × F_S on A's rows). At an
event the impulse weight W = M + dt²K (K of the reduction, with its geometric term ∂Pᵀ/∂q · r_all) moves with p, and its
(∂K/∂p) w is the static ∂r/∂p differenced along w plus the inertia forces' geometric term: that difference holds d × F_S
of the static forces, turned with A, but the inertia forces' d × F_S turns with A along w too, (Δπ_A × d) × F_S, which
nothing held. Without it the gimbal's W w by X at its latch was 3.3e-6 off and every probe after the latch 1e-4 off
Richardson differences of whole runs (the event times right: the hinge's angle holds no reference). A controller
reading a point on the shifted part: ∂r/∂X's K d (K on the assembled coordinates, the controller's coupling to the
sensed node among its blocks) moves its output with the point's d, and its explicit ∂f/∂s ∂s/∂X held d again (0.35 off).
Each whole-run case was refused on 5a68b93 (SceneError naming solve.sensitivities, "beside latches", "beside
controllers"); the weight's check fails there."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.prepare import prepare
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_geometry_sensitivities_link_geometry import GUIDE_ORIGIN, INNER_POINT, assert_the_cli_equals_the_api
from tests.test_geometry_sensitivities_link_length import RING
from tests.test_sensitivities_events import _agree, _run

#: the ring offset, the inner ring latching at −0.1 rad (t = 0.2791 s)
RING_LATCH = RING.replace('damping: "c2"}}}', 'damping: "c2", lock_at: -0.1}}}').replace("t_end: 0.3", "t_end: 0.4")
#: the ring offset, the inner ring bouncing twice off a rigid stop at −0.1 rad (e = 0.8; t = 0.2791 s, 0.2993 s)
RING_STOP = RING.replace('damping: "c2"}}}', 'damping: "c2", limits: [-0.1, 1.0], restitution: 0.8}}}')
#: the inner ring's hinge point on the outer ring (which turns) moved with the inner ring, latching at −0.1 rad
INNER_LATCH = INNER_POINT.replace('damping: "c2"}}}', 'damping: "c2", lock_at: -0.1}}}').replace("t_end: 0.3",
                                                                                                 "t_end: 0.4")
#: the ring offset latching, the outer hinge driven by a PD of its angle and rate (t = 0.2667 s)
RING_PD_LATCH = (RING_LATCH.replace("parameters: {X: 0.1,", "parameters: {X: 0.1, Kp: 0.8, Kd: 0.5,")
                 .replace('stiffness: "k1", rest_angle: "rest"}}}', 'stiffness: "k1", rest_angle: "rest", torque: "pd"}}}')
                 .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(0.1 - a1) - Kd*r1"}\nsolve: {')
                 .replace("    a1: {", "    r1: {hinge: gim1.start, quantity: rate}\n    a1: {"))
#: RING_PD_LATCH's PD reading the outer ring's x (a point on the shifted part) instead of the outer hinge's angle
POINT_PD_LATCH = RING_PD_LATCH.replace("Kp*(0.1 - a1)", "Kp*(0.3 - ox)").replace(
    "    r1: {", "    ox: {point: outer, quantity: position, component: x}\n    r1: {")
#: the ring offset latching, the outer hinge driven by a PI of its angle (a state: a leaking integral of the error)
PI_LATCH = (RING_LATCH.replace("parameters: {X: 0.1,", "parameters: {X: 0.1, Kp: 0.8, Ki: 2.0,")
            .replace('stiffness: "k1", rest_angle: "rest"}}}', 'stiffness: "k1", rest_angle: "rest", torque: "ctl"}}}')
            .replace("solve: {", 'controllers:\n  ctl: {output: "Kp*(0.1 - a1) + Ki*E", states: {E: "0.1 - a1 - 0.5*E"}}\n'
                                 "solve: {"))
#: the ring offset, the outer hinge slipping under Coulomb and viscous friction, the inner ring meeting a compliant stop
#: at −0.1 rad (in contact from t ≈ 0.25 s)
SOFT_SLIP = RING.replace(
    'damping: "c2"}}}', 'damping: "c2", limits: [-0.1, 1.0], contact: {stiffness: 30.0, exponent: 1.5, damping: 0.1}}}}'
).replace('rest_angle: "rest"}}}', 'rest_angle: "rest", friction: {coulomb: 0.02, static: 0.03, viscous: 0.01}}}}')
#: the guide's origin on a flexible arm's tip (a part that turns), the slider latching at s = −0.03 (t = 0.1934 s)
GUIDE_LATCH = GUIDE_ORIGIN.replace('rest: "rest"}}', 'rest: "rest", lock_at: -0.03}}')
assert "lock_at: -0.03" in GUIDE_LATCH
assert "Kp*(0.3 - ox)" in POINT_PD_LATCH and "ox: {point: outer" in POINT_PD_LATCH and "states: {E" in PI_LATCH
assert "contact: {stiffness: 30.0" in SOFT_SLIP and "coulomb: 0.02" in SOFT_SLIP
assert "lock_at: -0.1" in RING_LATCH and "t_end: 0.4" in RING_LATCH and "restitution: 0.8" in RING_STOP
assert "lock_at: -0.1" in INNER_LATCH and '"0.35 + X"' in INNER_LATCH and "{body: outer, offset" in INNER_LATCH
assert RING_PD_LATCH.count("pd") == 2 and "r1: {hinge" in RING_PD_LATCH and "lock_at" in RING_PD_LATCH


@pytest.mark.parametrize("text, events", [
    ("RING_LATCH", ["latch"]), ("RING_STOP", ["stop", "stop"]), ("INNER_LATCH", ["latch"]),
    ("RING_PD_LATCH", ["latch"]), ("POINT_PD_LATCH", ["latch"]), ("PI_LATCH", ["latch"]), ("SOFT_SLIP", []),
    ("GUIDE_LATCH", ["latch"]),
], ids=["ring-offset-latch", "ring-offset-stop", "hinge-point-latch", "ring-offset-pd-latch", "point-pd-latch",
        "pi-latch", "friction-and-compliant-stop", "guide-origin-latch"])
def test_through_events_agrees_with_richardson(text, events):
    """Every probe's rows by X (relative to its largest; ≤ 1e-6) and each event time (≤ 1e-7 relative) against
    Richardson-extrapolated central differences of whole runs (1e-4 and 5e-5 of X). Refused on 5a68b93. Measured: the
    ring offset's latch 2.8e-8 (its time 8.9e-10), its two impacts 1.7e-8 (5.9e-9), the hinge point's latch 2.7e-8
    (5.3e-10), the PD's latch 2.8e-8 (2.0e-9), the PD of the point's latch 2.5e-8 (1.5e-9), the PI's latch 2.3e-8
    (1.5e-9), friction and the compliant stop 1.7e-8, the guide's origin on the turning tip through its slider's latch
    2.5e-8 (2.3e-10); without the shift's turn in the impulse weight 9.6e-5, 2.0e-4,
    1.7e-4, 1.6e-4 (the event times as right); the PD of the point with its d counted twice (through K d and ∂f/∂s)
    0.35 (without events too)."""
    scene = globals()[text]
    result = _run(scene, "X")
    assert [event["kind"] for event in result.summary["events"]] == events
    _agree(result, scene, "X")


#: the accelerations of :func:`_weight_stiffness_by_x`'s state, times a normal draw: inertia forces large beside the
#: elements' stiffness, whose (∂K/∂X) w the term at stake (the inertia forces' moment turned) would otherwise hide in
#: the difference's truncation (2.9e-9 of the column at any size)
ACCELERATION = 100.0
#: the step in X of :func:`_weight_stiffness_by_x`'s reference (1e-4 gives the same to 3e-11)
STEP = 1e-5


def _moved_state(prepared, seed: int):
    """(a state, the draw that made it): the scene's initial state turned and deformed by 0.05 times a normal draw of
    ``np.random.default_rng(seed)``, random rates, and accelerations of :data:`ACCELERATION` times a normal draw."""
    assembler, model = prepared.assembler, prepared.model
    rng = np.random.default_rng(seed)
    n = model.n_dofs
    state = assembler.advance(prepared.state, 0.05 * rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, ACCELERATION * rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    return state, rng


def _weight_stiffness_by_x(text: str):
    """(the package's (∂K/∂X) w, its Richardson reference) at the scene's initial state turned and deformed by 0.05
    times a normal draw, random rates, accelerations (:data:`ACCELERATION`) and w: K the impulse's (the evaluation's
    reduced K, its geometric term with the inertia forces at those rates), the reference its K w of the scene prepared
    at X ± h, X ± h/2 (h = :data:`STEP`) at that state (the dependent nodes completed by each), extrapolated."""
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = ["X"]
    prepared = prepare(latdyn.load_scene(data))
    assembler, model = prepared.assembler, prepared.model
    state, rng = _moved_state(prepared, 7)
    n = model.n_dofs
    assembler.complete_links(state)
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=n)
    computed = (owner._stiffness_derivative(state, w) + owner._geometric_derivative(state, w))[:, 0]

    def product(value):
        moved = yaml.safe_load(text)
        moved["parameters"]["X"] = value
        evaluation = prepare(latdyn.load_scene(moved)).assembler.evaluate(state.copy(), matrices=True)
        return np.asarray(evaluation.combined(0.0, 0.0, 1.0) @ w).reshape(-1)

    x, h = data["parameters"]["X"], STEP
    d1, d2 = ((product(x + s) - product(x - s)) / (2 * s) for s in (h, h / 2))
    return computed, (4 * d2 - d1) / 3


@pytest.mark.parametrize("text", ["RING_LATCH", "INNER_LATCH"], ids=["ring-offset", "hinge-point"])
def test_the_impulse_weights_stiffness_derivative_holds_the_shifts_turn(text):
    """(∂K/∂X) w against Richardson differences of the evaluation's K w by X (relative to its largest; ≤ 1e-7).
    Measured 2.9e-9 both (the static ∂r/∂p's difference along w; the same at accelerations 100 times smaller); without
    ``_shifts_turned`` (5a68b93) 2.2e-6 (ring offset) and 1.8e-6 (hinge point)."""
    computed, reference = _weight_stiffness_by_x(globals()[text])
    assert np.max(np.abs(computed - reference)) <= 1e-7 * np.max(np.abs(reference))


def test_through_the_cli_equals_the_api(tmp_path):
    """``latdyn run`` of the ring offset's latch as typed: summary.json's probe sensitivities and sensitivities.csv's
    columns those of ``latdyn.run`` on the same text, to the bit."""
    assert_the_cli_equals_the_api(tmp_path, RING_LATCH, ("tip_x/X", "a1/X", "vi/X", "r2/k1"))


#: RING_PD_LATCH's PD reading the inner hinge's spring torque too (a joint's force: not checked with the shift)
TORQUE_PD = RING_PD_LATCH.replace("Kp*(0.1 - a1)", "Kp*(0.1 - a1) - 0.1*t2").replace(
    "    r1: {", "    t2: {hinge: gim2.start, quantity: torque}\n    r1: {")
assert "0.1*t2" in TORQUE_PD and "t2: {hinge: gim2.start" in TORQUE_PD


def test_a_controller_reading_a_joints_force_stays_refused(tmp_path):
    """Named (what moves, the controller and its sensor), through the API (SceneError naming solve.sensitivities) and
    the CLI (exit 2, no traceback). A guard: 5a68b93 refused every controller beside the shift."""
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(TORQUE_PD)))
    expected = ("rigid link 'gim1''s length or direction, a part that turns, beside controller 'pd' reading the hinge "
                "probe 't2' (torque)")
    assert refused.value.key == "solve.sensitivities" and expected in str(refused.value), str(refused.value)
    run, _ = latdyn_run(tmp_path, TORQUE_PD)
    assert run.returncode == 2 and "solve.sensitivities" in run.stderr and "Traceback" not in run.stderr


def test_the_shifts_matrices_from_one_native_scatter_are_the_evaluations_blocks():
    """The turning shift's K, C, M and r_all on the assembled coordinates at a moved state of the ring offset's gimbal,
    from one native evaluation and scatter (``ReferenceGeometry._assembled_exact`` at the steps' load factor 1 with the
    inertia: ``Assembler.assembled_exact_values``), are those of the evaluation's blocks before the reduction
    (latdyn/assembly/linked.py ``evaluate_before_reduction``, which the static path and the events' weights take) to
    the bit. A guard (turncost: the scatter replaced the blocks' assembly on the steps' path)."""
    from latdyn.assembly.linked import evaluate_before_reduction
    from latdyn.numerics.csr import CSR

    prepared = prepare(latdyn.load_scene(yaml.safe_load(RING_LATCH)))
    assembler, model = prepared.assembler, prepared.model
    state, _ = _moved_state(prepared, 3)
    owner = TransientSensitivities(prepared)
    residual, (indptr, pattern, values) = owner.geometry._assembled_exact(state, 1.0, True)
    n_asm = model.n_assembled
    matrices = [CSR((n_asm, n_asm), indptr, pattern, part).toarray() for part in values]   # M, C, K
    blocks, _ = evaluate_before_reduction(assembler, state, True, 1.0, True, inertia_tangent=True)
    assert np.array_equal(residual, blocks.residual)
    for matrix, coefficients in zip(matrices, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))):
        assert np.array_equal(matrix, blocks.combined(*coefficients, dense=True))
    assert np.any(matrices[0] != 0.0) and np.any(matrices[2] != 0.0)


@pytest.mark.parametrize("load_factor, inertia", [(1.0, True), (0.5, False)], ids=["steps", "static"])
def test_the_shifts_columns_in_c_are_their_formula(load_factor, inertia):
    """``ReferenceGeometry._add_shifts`` and ``_add_link_inertia`` (csrc/turning_shifts.c, which the loop of steps calls
    too) at a moved state of the ring offset's gimbal (the rings shifted on the turning link node, the link's block
    moved) are their formula written out here in NumPy: d = T_A δo, δv = ω_A × d, δa = α_A × d + ω_A × (ω_A × d) on the
    subtree, K d + C δv + M δa with the dense exact matrices before the reduction, d × F_S on A's rotational rows, and
    the link's row the generated joint_body at (δm, c, δI) plus joint_body_D_com along δc (NumPy kernels' calls). To
    round-off. A guard (turnloop moved these lines from NumPy to C)."""
    from latdyn.assembly.linked import evaluate_before_reduction
    from latdyn.numerics.so3 import cross

    prepared = prepare(latdyn.load_scene(yaml.safe_load(RING_LATCH)))
    assembler, model = prepared.assembler, prepared.model
    state, _ = _moved_state(prepared, 5)
    assembler.complete_links(state)
    geometry = TransientSensitivities(prepared).geometry
    assert geometry.turning and geometry.link_moves
    computed = np.zeros((model.n_total + 1, geometry.k))
    geometry._add_shifts(state, computed, load_factor, inertia)
    geometry._add_link_inertia(state, computed, load_factor, inertia)

    blocks, _ = evaluate_before_reduction(assembler, state, True, load_factor, inertia, inertia_tangent=True)
    matrices = [np.asarray(blocks.combined(*c, dense=True)) for c in ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))]
    expected = np.zeros_like(computed)
    for index, column, moved, anchor in geometry.turning:
        d = state.T[anchor] @ moved
        w, alpha = state.w[anchor], state.alpha[anchor]
        rows = model.node_dofs[geometry._below(index)][:, 0:3]
        for matrix, move in zip(matrices[:3 if inertia else 1], (d, cross(w, d), cross(alpha, d) + cross(w, cross(w, d)))):
            on = np.zeros(model.n_assembled)
            on[rows] = move
            expected[:model.n_assembled, column] += matrix @ on
        expected[model.node_dofs[anchor][3:6], column] += cross(d, np.asarray(blocks.residual)[rows].sum(axis=0))
    gravity = load_factor * np.asarray(assembler.gravity, float)[None]
    for (_, node, column, _), (moved_block, block, dc) in zip(geometry.link_moves, geometry._link_blocks()):
        frame = state.T[node].reshape(1, 9)
        motion = np.concatenate([state.w[node], state.a[node], state.alpha[node]])[None] * float(inertia)
        force = np.asarray(geometry.kernels.joint_body(frame, motion, moved_block, gravity)[0]).reshape(6)
        by_com = np.asarray(geometry.kernels.joint_body_D_com(frame, motion, block, gravity)[0]).reshape(6, 3)
        expected[model.node_dofs[node], column] += force + by_com @ dc
    assert np.abs(expected).max() > 0.0
    np.testing.assert_allclose(computed, expected, rtol=0.0, atol=1e-13 * np.abs(expected).max())
