"""The continuous controllers' couplings in an event's impulse weight derivative H = ∂(W w)/∂q generated beyond the
controllers of joint angles and rates alone (latdyn/analyses/weight_derivative.py, docs/parameters.md "The impulse
weight's derivative"): a controller reading an input, another controller, its own state, points' positions (global,
at an offset, in a body's axes), a cable's length or a free joint's force (their second derivatives composed of the
generated ``point_load`` and hinge kernels), a hinge law naming an input, and the loads such a controller drives
take no central difference any more; on the genuinely 3D latching boom of tests/test_weight_derivative_rest.py their
blocks of H agree with Richardson-extrapolated differences of their K w, and through the latch the sensitivities
agree with Richardson differences of whole runs, through the API and ``latdyn run``, with the loop of steps on and
off giving the same bits."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.weight_derivative import (_cable_part, _coupling_part, _driven_load_part, _hinge_part,
                                               _load_part, _sensor_dofs, _sensor_kinematics, _sparse,
                                               exact_couplings, exact_hinges, exact_loads, rest_support, times)
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_sensitivities_events import _agree
from tests.test_weight_derivative_rest import BOOM, CONTROLLED_BOOM, _boom_state

#: the PD of the controlled boom on an input reference, with an input gain on the angle
INPUT_PD = (CONTROLLED_BOOM.replace("-Kp*sin(angle - 0.3)", "-Kp*sin(angle - ref)*(1 + g*angle)")
            .replace("sections:", "inputs: {ref: 0.3, g: 0.5}\nsections:", 1))
#: a chain of two controllers: ``inner`` of the arm's and the spar's hinge angles (the spar on a hinge of its own at
#: the wheel), ``pd`` of ``inner``, the spar's angle and the arm's angle and rate, driving the arm's hinge
CHAIN = (CONTROLLED_BOOM.replace("section: s, elements: 1}",
                                 "section: s, elements: 1,\n         start: {hinge: {axis: [0, 1, 1], stiffness: 3.0}}}", 1)
         .replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                  '  inner: {output: "Kp*sin(angle - 0.3) + 0.2*spar_angle*angle"}\n'
                  '  pd: {output: "-inner*(1 + 0.5*inner) - Kd*rate*(1 + angle**2) + 0.1*inner*spar_angle"}', 1)
         .replace("    angle: {", "    spar_angle: {hinge: spar.start, quantity: angle}\n    angle: {", 1))
#: the PD with an integral state z (dz/dt = θ − 0.4, z(0) = 0.2) in its output, nonlinear in z and θ
STATE = CONTROLLED_BOOM.replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                                '  pd: {output: "-Kp*sin(angle - 0.3)*(1 + z) - 0.3*z*angle**2",\n'
                                '       states: {z: "angle - 0.4"}, initial: {z: 0.2}}', 1)
#: the boom's hinge spring a law of θ naming an input
HINGE_INPUT = (BOOM.replace('stiffness: "k"', 'stiffness: "k*(1 + g*(theta - 0.2)**2)"', 1)
               .replace("sections:", "inputs: {g: 0.7}\nsections:", 1))
#: the boom's follower load (force y and moment y components) and its global load (force y) driven by a controller
#: of the hinge's angle and rate, ``push``, alone and through laws a y + b
LOAD = (BOOM.replace('  - {at: spar.start, force: ["P", -0.2, 0.4], moment: [0.05, 0.02, -0.03], frame: wheel}',
                     '  - {at: spar.start, force: ["P", "push", 0.4], moment: [0.05, "0.5*push + 0.01", -0.03], '
                     'frame: wheel}', 1)
        .replace("  - {at: wheel, force: [0.0, 0.1, -0.2], frame: global}",
                 '  - {at: wheel, force: [0.0, "0.3*push", -0.2], frame: global}', 1)
        .replace("\nsolve:", "\ncontrollers:\n"
                             '  push: {output: "Kc*(sin(angle - 0.3) + 0.5*angle**2 + 0.1*rate*angle)"}\nsolve:', 1)
        .replace("    angle: {", "    rate: {hinge: arm.end, quantity: rate}\n    angle: {", 1)
        .replace("EA: 2.0, P: 0.3}", "EA: 2.0, P: 0.3, Kc: 0.1}", 1)
        .replace("sensitivities: [EA, P, k]", "sensitivities: [Kc, k]"))


#: the controlled boom's PD reading the wheel's position (its node), the spar's start (an offset from the wheel's
#: node) and the arm's middle node's displacement in the wheel's axes, nonlinear in them
POINTS = (CONTROLLED_BOOM.replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                                  '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) - 2*(tip_x - 0.6)**2 '
                                  '+ 3*sin(spar_y)*mid_w + 0.5*mid_w**2"}', 1)
          .replace("    angle: {", "    spar_y: {point: spar.start, quantity: position, component: y}\n"
                   '    mid_w: {point: "arm.node[1]", quantity: displacement, component: x, frame: wheel}\n'
                   "    angle: {", 1)
          .replace("sensitivities: [Kp, k]", "sensitivities: [Kp]"))

#: the controlled boom's PD reading the spar's hinge torque (the spar on a hinge of its own at the wheel, its spring a
#: law of its angle): a free joint's force
FORCE = (CONTROLLED_BOOM.replace("section: s, elements: 1}",
                                 'section: s, elements: 1,\n         start: {hinge: {axis: [0, 1, 1], '
                                 'stiffness: "3.0*(1 + 4*theta**2)", damping: 0.2}}}', 1)
         .replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                  '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) + 0.5*spar_torque*angle '
                  '+ 0.2*spar_torque**2"}', 1)
         .replace("    angle: {", "    spar_torque: {hinge: spar.start, quantity: torque}\n    angle: {", 1))
#: the controlled boom's PD reading the stay's length, the stay of three elements (its inner nodes translations only)
LENGTH = (CONTROLLED_BOOM.replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                                  '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) '
                                  '+ 2*(stay_length - 0.95)**2*angle"}', 1)
          .replace("    angle: {", "    stay_length: {cable: stay, quantity: length}\n    angle: {", 1)
          .replace("rest_length: 0.9, damping: 0.4}", "rest_length: 0.9, damping: 0.4, elements: 3, rhoA: 0.05}", 1))

#: the controlled boom's PD reading the spar's start's velocity (an offset from the wheel's node: v + ω × T r)
VELOCITY = (CONTROLLED_BOOM.replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                                    '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) '
                                    '- 0.5*spar_vz*(1 + angle**2) - 0.3*spar_vz**2"}', 1)
            .replace("    angle: {", "    spar_vz: {point: spar.start, quantity: velocity, component: z}\n    angle: {", 1))

#: the chain with the spar's hinge driven by a controller of both angles and the spar's start at an offset (that
#: hinge stays free through the arm's latch)
SPAR = (CHAIN.replace("start: {hinge: {axis: [0, 1, 1], stiffness: 3.0}}}",
                      'start: {hinge: {axis: [0, 1, 1], stiffness: 3.0, torque: "sc"}}}', 1)
        .replace("\nsolve:", '\n  sc: {output: "-Ks*sin(spar_angle - 0.1)*(1 + angle**2) + 2*spar_y*angle**2 '
                              '- 0.3*spar_y**2"}\nsolve:', 1)
        .replace("Kp: 0.4, Kd: 0.05}", "Kp: 0.4, Kd: 0.05, Ks: 0.8}", 1)
        .replace("    angle: {", "    spar_y: {point: spar.start, quantity: position, component: y}\n    angle: {", 1))


def _blocks_product(assembler, state, w: np.ndarray) -> np.ndarray:
    """The evaluation's hinges', loads' and cables', and couplings' blocks of K (no elements, no joint bodies),
    times w."""
    k = assembler.evaluate(state, matrices=True).flat_blocks("stiffness")
    return np.asarray(assembler.assemble([0.0 * k[0], 0.0 * k[1], k[2], k[3], k[4]]) @ w)


def _assert_blocks_are_richardsons(text: str, tolerance: float = 1e-10) -> None:
    """At a moved state of the boom (the arm's hinge at 0.35), no coordinate left to difference, and the generated
    hinges', loads', cables' and couplings' parts of H along random δq at random w agree with Richardson-extrapolated
    central differences of those blocks' K w to ``tolerance`` of their largest."""
    prepared, state, rng = _boom_state(text)
    assembler, n = prepared.assembler, prepared.model.n_dofs
    assert len(rest_support(assembler)) == 0
    state.theta[0] = 0.35
    for _ in range(2):
        w, dq = rng.normal(size=n), rng.normal(size=n)
        hinge_rows, hinge_values = _hinge_part(assembler, state, w, 1.0)
        exact = times(_sparse(hinge_rows, hinge_rows, hinge_values, n), dq)
        for part in (_load_part, _cable_part, _coupling_part, _driven_load_part):
            exact += times(_sparse(*part(assembler, state, w, 1.0), n), dq)

        def product(eta):
            return _blocks_product(assembler, assembler.advance(state, eta * dq), w)

        central = [(product(h) - product(-h)) / (2 * h) for h in (1e-4, 5e-5)]
        numeric = (4 * central[1] - central[0]) / 3
        assert np.abs(exact - numeric).max() <= tolerance * np.abs(numeric).max()


@pytest.mark.parametrize("text", [INPUT_PD, CHAIN, STATE, SPAR], ids=["input", "chain", "state", "spar"])
def test_a_controller_reading_an_input_another_controller_or_its_state_is_generated(text):
    """A PD on an input reference, a chain of two controllers (the chain rule through the inner one's output, two
    angles), a PD with an integral state and the chain with the spar's hinge driven too (of a point as well): their
    couplings take no difference (10be92c differenced 1, 2, 1 and 8 coordinates) and H's blocks agree with
    Richardson differences (measured ≤ 3.1e-12 of the blocks with the cable's, the difference 7.9e-13 – 1.3e-11; the
    couplings' block alone of the first three 1.7e-12, 5.9e-13 and 1.1e-12, the difference 3.0e-11, 3.5e-11,
    3.1e-11)."""
    prepared, _, _ = _boom_state(text)
    assert exact_couplings(prepared.assembler).all()
    _assert_blocks_are_richardsons(text)


@pytest.mark.parametrize("text, kinds", [(POINTS, [5, 7]), (VELOCITY, [6]), (LENGTH, [8]), (FORCE, [14])],
                         ids=["points", "point_velocity", "cable_length", "joint_force"])
def test_a_sensors_second_derivative_is_the_central_difference_of_its_gradient(text, kinds):
    """The sensors the PDs read whose second derivatives are composed of generated kernels (a point at an offset
    from its node: kind 5; in a body's axes: 7; a point's velocity at an offset by its node's turn: 6; a cable of
    three elements' length: 8; a free joint's force: 14) at a moved state: their gradient is the one
    csrc/evaluate.c computes (``sensor_jacobian``'s columns of K, to the bit), and its derivative along each of
    their coordinates (the configuration's update: turns on SO(3)) the central difference of that gradient
    (measured 4.6e-11, 3.8e-11, 5.8e-11, 8.4e-11, 4.8e-10 of its largest)."""
    prepared, state, _ = _boom_state(text)
    assembler = prepared.assembler
    control, n = assembler.control, prepared.model.n_dofs
    native = assembler.native()
    held = prepared.model.scene.controller_outputs.values.copy()
    native.controller_outputs_at(state)
    prepared.model.scene.controller_outputs.values[:] = held
    jacobian = np.array(native.buffers["sensor_jacobian"])
    checked = []
    for sensor, (kind, index) in enumerate(zip(control.sensor_kind, control.sensor_index)):
        if kind not in kinds:
            continue
        gradient, second = _sensor_kinematics(assembler, state, int(kind), int(index), sensor)
        first = int(control.sensor_column_start[sensor]) + (6 if kind == 6 else 0)   # kind 6: after its six rates
        np.testing.assert_array_equal(gradient, jacobian[first:first + len(gradient)])
        dofs = _sensor_dofs(assembler, int(kind), int(index), sensor)
        for d in np.unique(dofs[dofs < n]):   # a node two elements share: both its columns
            unit = np.zeros(n)
            unit[d] = 1e-6
            ahead = _sensor_kinematics(assembler, assembler.advance(state, unit), int(kind), int(index), sensor)[0]
            behind = _sensor_kinematics(assembler, assembler.advance(state, -unit), int(kind), int(index), sensor)[0]
            moved = second[:, dofs == d].sum(axis=1)
            assert np.abs(moved - (ahead - behind) / 2e-6).max() <= 2e-9 * np.abs(second).max()
        checked.append(int(kind))
    assert sorted(checked) == kinds


@pytest.mark.parametrize("text, kinds", [(POINTS, [0, 1, 2, 5, 7]), (VELOCITY, [0, 1, 6]), (LENGTH, [0, 1, 8]),
                                         (FORCE, [0, 1, 14])],
                         ids=["points", "point_velocity", "cable_length", "joint_force"])
def test_a_controller_reading_points_a_cables_length_or_a_joints_force_is_generated(text, kinds):
    """The PD reading the wheel's position, the spar's start at an offset and the arm's middle in the wheel's axes;
    the spar's start's velocity; the stay's length (three elements); the spar's hinge torque: no coordinate left to
    difference (10be92c differenced 13, 7, 13 and 2) and H's blocks agree with Richardson differences (measured
    1.4e-12, 7.9e-13, 1.5e-12, 3.1e-12; the difference 3.0e-11, 7.9e-13, 2.5e-10, 1.6e-9)."""
    prepared, _, _ = _boom_state(text)
    assert exact_couplings(prepared.assembler).all()
    assert sorted(set(prepared.assembler.control.sensor_kind)) == kinds
    _assert_blocks_are_richardsons(text)


def test_a_hinge_law_naming_an_input_is_generated():
    """The boom's spring k (1 + g (θ − 0.2)²) with g an input: the hinge's part of H is the generated
    ``hinge_stiffness_by_angle`` at the input's value (10be92c differenced its angle), agreeing with Richardson
    differences (measured 6.5e-13 of the hinge's and the cable's blocks; the difference 1.1e-11)."""
    prepared, _, _ = _boom_state(HINGE_INPUT)
    assert exact_hinges(prepared.assembler).all()
    _assert_blocks_are_richardsons(HINGE_INPUT)


def test_a_load_a_controller_of_an_angle_drives_is_generated():
    """A follower load's force and moment components and a global load's driven by a controller of the hinge's
    angle and rate (alone, and in laws a y + b): their blocks at the driven values, the values' move and the
    couplings' two terms generated (10be92c differenced 7 coordinates), agreeing with Richardson differences
    (measured 6.7e-13; the difference 3.0e-12 of these blocks, which hold the cable's)."""
    prepared, _, _ = _boom_state(LOAD)
    assert exact_loads(prepared.assembler).all() and exact_couplings(prepared.assembler).all()
    _assert_blocks_are_richardsons(LOAD)


def test_a_saturated_inner_controller_adds_no_chain_term():
    """The chain's inner controller clipped at the state (limits [−0.01, 0.01]): its output is a constant about
    the state, so the outer's part of H is its own second derivative by the arm's angle alone (the spar's column
    and the chain's terms vanish), still Richardson's."""
    clipped = CHAIN.replace('0.2*spar_angle*angle"}', '0.2*spar_angle*angle", limits: [-0.01, 0.01]}')
    prepared, state, rng = _boom_state(clipped)
    assembler, model, n = prepared.assembler, prepared.model, prepared.model.n_dofs
    state.theta[0] = 0.35
    w = rng.normal(size=n)
    rows, cols, values = _coupling_part(assembler, state, w, 1.0)
    spar = int(model.hinge_dofs[model.hinge_index("spar", "start")])
    arm = int(model.hinge_dofs[model.hinge_index("arm", "end")])
    assert np.all(values[cols == spar] == 0.0) and np.any(values[cols == arm] != 0.0)
    _assert_blocks_are_richardsons(clipped)


@pytest.mark.parametrize("text, name, tolerance", [(SPAR, "Ks", 5e-6), (POINTS, "Kp", 1e-6)], ids=["spar", "points"])
def test_through_the_latch_the_sensitivities_agree_and_the_loop_keeps_the_bits(text, name, tolerance):
    """Through the arm's latch, no difference left in H: the chain with a controller of both angles and a point
    driving the spar's own hinge (its coupling's row stays in the numbering through the latch, where the latched
    hinge's row leaves it: the sensitivities move by 4.1e-12 of each column with the generated H), and the PD of
    points. The sensitivities agree with Richardson differences of whole runs (measured 2.7e-6 by Ks, 2.1e-7 by
    Kp, as with the difference at 10be92c: its error lies below the reference's), and the loop of steps on and off
    give the same bits, with steps in the loop."""
    prepared, _, _ = _boom_state(text)
    assert len(rest_support(prepared.assembler)) == 0
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = [name]
    text = yaml.safe_dump(data)
    runs = runs_with_the_loop_on_and_off(text)
    native, python = runs[True], runs[False]
    assert [e["kind"] for e in native.summary["events"]] == ["latch"]
    assert native.summary["sensitivity_steps_in_loop"] > 0
    assert_same_sensitivities(native, python)
    assert _agree(native, text, name, tolerance) < tolerance


def test_latdyn_run_of_the_driven_load_agrees_with_richardson_and_the_loop_off_writes_the_same(tmp_path):
    """``latdyn run`` of the boom with the driven loads through its latch: no difference left in H, the event
    sensitivities by Kc in summary.json the API's, agreeing with Richardson differences of whole runs (measured
    7.8e-7, as at 10be92c), and the loop of steps off writes the same files byte for byte."""
    latdyn_run_through_the_latch_agrees(tmp_path, LOAD.replace("sensitivities: [Kc, k]", "sensitivities: [Kc]"),
                                        "Kc", 2e-6)


def latdyn_run_through_the_latch_agrees(tmp_path, text: str, name: str, tolerance: float) -> None:
    """``latdyn run`` of the boom scene ``text`` through its latch with no difference left in H: the event
    sensitivities by ``name`` in summary.json are the API's, agree with Richardson differences of whole runs to
    ``tolerance``, and the loop of steps off writes the same files byte for byte."""
    prepared, _, _ = _boom_state(text)
    assert len(rest_support(prepared.assembler)) == 0
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert summary["event_sensitivities"] == result.summary["event_sensitivities"]
    assert _agree(result, text, name, tolerance) < tolerance
    the_loop_off_writes_the_same(tmp_path, out)
