"""The point loads', cable elements' and controllers' couplings' part of an event's impulse weight derivative
H = ∂(W w)/∂q, generated (latdyn/analyses/weight_derivative.py, docs/parameters.md "The impulse weight's derivative"):
``point_load_stiffness_D_q`` and ``cable_stiffness_D_q`` (codegen/joints.py) against central differences of the
blocks ``point_load`` and ``cable_force`` give, along the configuration's own update (turns on SO(3), a damped cable at random rates); on a
genuinely 3D latching boom (a wheel on a hinge at the end of an arm, a follower load at an offset turning with the
wheel, a global load and a damped taut cable) no central difference is left in H and the loads' and cable's blocks
of H agree with Richardson-extrapolated differences of their K w; a slack cable adds nothing; a load a continuous
controller drives keeps the difference along its coordinates; through the latch the sensitivities agree with
Richardson differences of whole runs, through the API and ``latdyn run``, and the loop of steps on and off give the
same bits. The continuous controllers' couplings of joint angles and rates: a PD controller nonlinear in the angle
driving the boom's hinge, its coupling's part of H SymPy's second derivative of the scene's output, none when
saturated, the difference kept beside an input; through the latch as above."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.weight_derivative import (_cable_part, _load_part, _sparse, configuration_tangent_of_weight,
                                               exact_loads, rest_support, times)
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.prepare import prepare
from latdyn.model.kernels import load_kernels
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import runs_with_the_loop_on_and_off
from tests.test_sensitivities_controllers import WHEEL as CONTROLLED_WHEEL
from tests.test_sensitivities_events import WHEEL_3D, _agree

#: the wheel of the event tests latching at 0.5 rad (3D: arm along (2, 1, 2)/3, hinge axis (1, −2, 0)/√5), with a
#: spar from an offset on the wheel, a follower load at the spar's start (an offset from the wheel's node) turning
#: with the wheel, a global load on the wheel, and a damped cable from an offset on the wheel to a fixed anchor,
#: taut throughout (pull ≈ 0.3 at the latch, t ≈ 1.08 s)
BOOM = (WHEEL_3D.format(what="its latch", event="lock_at: 0.5", t_end=1.1, every=0.02)
        .replace("EI: 1.0e4, rho: 1.0}", "EI: 1.0e4, rho: 1.0, EA: 2.0, P: 0.3}", 1)
        .replace("  wheel: {", "  anchor: {at: [1.2, -0.4, 1.1], fixed: true}\n  wheel: {", 1)
        .replace("\nsolve:", """
  spar: {from: {body: wheel, offset: [0.0, 0.15, 0.1]}, to: [0.7, 0.6, 0.9], section: s, elements: 1}
cables:
  stay: {from: {body: wheel, offset: [0.1, 0.05, -0.03]}, to: anchor, EA: "EA", rest_length: 0.9, damping: 0.4}
loads:
  - {at: spar.start, force: ["P", -0.2, 0.4], moment: [0.05, 0.02, -0.03], frame: wheel}
  - {at: wheel, force: [0.0, 0.1, -0.2], frame: global}
solve:""", 1)
        .replace("sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [EA, P, k]")
        .replace("    angle: {", "    pull: {cable: stay, quantity: tension}\n    angle: {", 1))

H = 1e-6


def _rotation(v: np.ndarray) -> np.ndarray:
    """exp(skew v) (Rodrigues)."""
    angle = float(np.linalg.norm(v))
    if angle == 0.0:
        return np.eye(3)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]) / angle
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def _row(a) -> np.ndarray:
    return np.ascontiguousarray(np.reshape(a, (1, -1)), dtype=float)


def test_the_generated_load_stiffness_derivative_is_the_central_difference_of_its_block_along_w():
    """``point_load_stiffness_D_q`` at random frames, offsets, values and directions: its K_l w is ``point_load``'s
    block times w, and its derivative by the node's and the frame's turns the central difference of that product
    with the frames turned (measured ≤ 1.3e-10 relative)."""
    kernels = load_kernels("auto", "default")
    rng = np.random.default_rng(34)
    for _ in range(3):
        T, R = _rotation(rng.normal(size=3)), _rotation(rng.normal(size=3))
        r, values, w = rng.normal(size=3), rng.normal(size=6), rng.normal(size=6)

        def along(node, frame):
            out = kernels.point_load(_row(node), _row(r), _row(values), _row(frame), _row(np.zeros(6)))
            return np.asarray(out[2]).reshape(6, 3) @ w[:3] + np.asarray(out[3]).reshape(6, 3) @ w[3:]

        product, derivative = (np.asarray(x)[0] for x in kernels.point_load_stiffness_D_q(
            _row(T), _row(r), _row(values), _row(R), _row(w)))
        np.testing.assert_allclose(product, along(T, R), rtol=0, atol=1e-13 * np.abs(product).max())
        derivative = derivative.reshape(6, 6)
        for k in range(6):
            turn = np.zeros(3)
            turn[k % 3] = H
            if k < 3:
                numeric = (along(_rotation(turn) @ T, R) - along(_rotation(-turn) @ T, R)) / (2 * H)
            else:
                numeric = (along(T, _rotation(turn) @ R) - along(T, _rotation(-turn) @ R)) / (2 * H)
            assert np.abs(derivative[:, k] - numeric).max() <= 1e-8 * np.abs(derivative).max()


def _moved_cable(geometry: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """The cable kernels' geometry [x1, x2, o1, o2] after the configuration update [d1, π1, d2, π2]: x_i += d_i,
    o_i ← exp(skew π_i) o_i."""
    out = geometry.copy()
    for k in range(2):
        out[3 * k:3 * k + 3] += delta[6 * k:6 * k + 3]
        out[6 + 3 * k:9 + 3 * k] = _rotation(delta[6 * k + 3:6 * k + 6]) @ geometry[6 + 3 * k:9 + 3 * k]
    return out


def test_the_generated_cable_stiffness_derivative_is_the_central_difference_of_k_w():
    """``cable_stiffness_D_q`` of a damped, stretched element at random rates: its K w is ``cable_force``'s K times w,
    and its derivative by the 12 end coordinates the central difference of K w along the configuration's update
    (measured ≤ 6.6e-10 relative)."""
    kernels = load_kernels("auto", "default")
    rng = np.random.default_rng(35)
    for _ in range(3):
        geometry = np.concatenate([rng.normal(size=3), rng.normal(size=3) + [2.0, 0, 0], 0.2 * rng.normal(size=6)])
        velocity, w = rng.normal(size=12), rng.normal(size=12)
        section = np.array([1.5, 0.1, 300.0, 2.5])

        def along(g):
            return np.asarray(kernels.cable_force(_row(g), _row(velocity), _row(section))[1]).reshape(12, 12) @ w

        product, derivative = (np.asarray(x)[0] for x in kernels.cable_stiffness_D_q(
            _row(geometry), _row(velocity), _row(section), _row(w)))
        np.testing.assert_allclose(product, along(geometry), rtol=0, atol=1e-12 * np.abs(product).max())
        derivative = derivative.reshape(12, 12)
        for k in range(12):
            step = np.zeros(12)
            step[k] = H
            numeric = (along(_moved_cable(geometry, step)) - along(_moved_cable(geometry, -step))) / (2 * H)
            assert np.abs(derivative[:, k] - numeric).max() <= 1e-7 * np.abs(derivative).max()


def _boom_state(text: str = BOOM, seed: int = 3, move: float = 0.01):
    """The boom's start turned and deformed a little along a random direction, at small random rates (the cable
    stays taut: its damper does not cancel the stretch) and random accelerations."""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, model = prepared.assembler, prepared.model
    rng = np.random.default_rng(seed)
    state = assembler.advance(prepared.state, move * rng.normal(size=model.n_dofs))
    unpack_free(model, 0.1 * rng.normal(size=model.n_dofs), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=model.n_dofs), state.a, state.alpha, state.theta_ddot)
    return prepared, state, rng


def _loads_and_cables_product(assembler, state, w: np.ndarray) -> np.ndarray:
    """K_lc w: the evaluation's loads' and cable elements' blocks of K alone, times w."""
    stiffness = assembler.evaluate(state, matrices=True).flat_blocks("stiffness")
    parts = [0.0 * b for b in stiffness[:3]] + [stiffness[3], 0.0 * stiffness[4]]
    return np.asarray(assembler.assemble(parts) @ w)


def test_the_booms_loads_and_cable_take_no_difference_and_agree_with_richardson():
    """The 3D boom: no coordinate left to difference (the follower load at an offset, the global load and the damped
    cable generated; the old central difference took 6), and their part of H δq is Richardson-extrapolated central
    differences of K_lc w along δq (measured ≤ 7.9e-13 relative; the central difference it replaces, step 1e-5,
    5.0e-9 and 2.4e-8 off)."""
    prepared, state, rng = _boom_state()
    assembler, n = prepared.assembler, prepared.model.n_dofs
    assert len(rest_support(assembler)) == 0 and exact_loads(assembler).all()
    assert assembler.native().cable_state(state)[0, 4] > 0   # taut
    for _ in range(2):
        w, dq = rng.normal(size=n), rng.normal(size=n)
        parts = [_load_part(assembler, state, w, 1.0), _cable_part(assembler, state, w, 1.0)]
        assert all(len(p[2]) for p in parts)
        exact = sum(times(_sparse(*p, n), dq) for p in parts)

        def product(eta):
            return _loads_and_cables_product(assembler, assembler.advance(state, eta * dq), w)

        eta = 1e-4
        central = [(product(h) - product(-h)) / (2 * h) for h in (eta, eta / 2)]
        numeric = (4 * central[1] - central[0]) / 3
        assert np.abs(exact - numeric).max() <= 2e-11 * np.abs(numeric).max()


def test_a_slack_cable_adds_nothing_to_h():
    """The boom's cable made slack (its rest length longer than the span): the cable's part of H is empty, as its K
    is the runtime's zero."""
    prepared, state, rng = _boom_state(BOOM.replace("rest_length: 0.9", "rest_length: 1.5"))
    assert prepared.assembler.native().cable_state(state)[0, 4] == 0.0
    assert len(_cable_part(prepared.assembler, state, rng.normal(size=prepared.model.n_dofs), 1.0)[2]) == 0


def test_a_load_a_chain_of_controllers_of_a_point_drives_is_generated():
    """The controlled wheel's load (two components driven by a chain of continuous controllers reading the wheel's
    position and the hinge's angle: its values move with the sensors) is generated now, its block and the
    couplings' (tests/test_weight_derivative_couplings.py; 10be92c differenced the wheel's turn among their
    coordinates); H agrees with Richardson-extrapolated differences of the evaluation's W w."""
    from tests.test_weight_derivative import _check_model

    prepared = prepare(latdyn.load_scene(yaml.safe_load(CONTROLLED_WHEEL)))
    assembler = prepared.assembler
    assert exact_loads(assembler).all() and len(rest_support(assembler)) == 0
    assert _check_model(CONTROLLED_WHEEL, 5) < 1e-8


def _assert_h_is_richardsons(assembler, state, rng, n: int) -> None:
    """H (W = M + 1e-4 K, and W = K) along a random δq at a random w agrees with Richardson-extrapolated central
    differences of the evaluation's W w to 1e-9 of their largest."""
    for mass, scale in ((True, 1e-4), (False, 1.0)):
        w, dq = rng.normal(size=n), rng.normal(size=n)
        exact = times(configuration_tangent_of_weight(assembler, state, w, scale, mass, 1e-5), dq)

        def product(eta):
            ev = assembler.evaluate(assembler.advance(state, eta * dq), matrices=True)
            return np.asarray(ev.combined(1.0 if mass else 0.0, 0.0, scale) @ w)

        central = [(product(h) - product(-h)) / (2 * h) for h in (1e-4, 5e-5)]
        numeric = (4 * central[1] - central[0]) / 3
        assert np.abs(exact - numeric).max() <= 1e-9 * np.abs(numeric).max()


def test_h_of_the_boom_is_the_central_difference_of_w_w():
    """The whole H of the boom (elements, the wheel's mass, the hinge, the loads and the cable: all generated)
    against Richardson-extrapolated central differences of the evaluation's W w (measured 1.1e-12 with the mass,
    2.8e-11 without; the same with the old differences: the elements dominate it)."""
    prepared, state, rng = _boom_state()
    assembler, n = prepared.assembler, prepared.model.n_dofs
    _assert_h_is_richardsons(assembler, state, rng, n)


@pytest.fixture(scope="module")
def boom_runs():
    """The boom's sensitivities by EA, P and k with the loop of steps on and off (API)."""
    return runs_with_the_loop_on_and_off(BOOM)


def test_through_the_latch_the_booms_sensitivities_agree_with_richardson(boom_runs):
    """Through the latch (its H with the loads' and cable's blocks generated) the sensitivities by the cable's EA
    agree with Richardson-extrapolated differences of whole runs (measured 3.5e-8, the event time 4.1e-9; by P
    3.9e-7, by k 4.1e-7: the same as with the difference, whose error lies far below the reference's)."""
    result = boom_runs[True]
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert _agree(result, BOOM, "EA", 1e-6) < 1e-6


def test_the_loop_of_steps_keeps_the_python_paths_bits_through_the_latch(boom_runs):
    """The boom with the loop of steps on and off: the same sensitivities, probe and event sensitivities to the bit
    (the latch's H, exact now, is the Python path's on both), with steps in the loop."""
    native, python = boom_runs[True], boom_runs[False]
    assert native.summary["sensitivity_steps_in_loop"] > 0 == python.summary["sensitivity_steps_in_loop"]
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


def test_latdyn_run_of_the_boom_writes_the_apis_sensitivities_and_the_loop_off_the_same(tmp_path, boom_runs):
    """``latdyn run`` of the boom: the latch's event sensitivities in summary.json are the API's, and the same
    scene with the loop of steps off writes the same files byte for byte."""
    run, out = latdyn_run(tmp_path, BOOM)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert summary["event_sensitivities"] == boom_runs[True].summary["event_sensitivities"]
    assert summary["sensitivity_steps_in_loop"] > 0
    the_loop_off_writes_the_same(tmp_path, out)


#: the boom's hinge driven by a PD controller nonlinear in the angle, ``pd`` = −Kp sin(θ − 0.3) − Kd θ̇ (1 + θ²),
#: its output the hinge's torque: K's coupling −∂pd/∂θ moves along θ with ∂²pd/∂θ² = Kp sin(θ − 0.3) − 2 Kd θ̇
CONTROLLED_BOOM = (BOOM.replace("rest_angle: 1.0, lock_at: 0.5", 'rest_angle: 1.0, lock_at: 0.5, torque: "pd"')
                   .replace("\nsolve:", "\ncontrollers:\n"
                                        '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}\nsolve:', 1)
                   .replace("EA: 2.0, P: 0.3}", "EA: 2.0, P: 0.3, Kp: 0.4, Kd: 0.05}", 1)
                   .replace("sensitivities: [EA, P, k]", "sensitivities: [Kp, k]")
                   .replace("    angle: {", "    rate: {hinge: arm.end, quantity: rate}\n    angle: {", 1))


def test_a_pd_controllers_coupling_in_h_is_sympys_second_derivative_and_no_difference_is_left():
    """The controlled boom at θ = 0.35 and a moving state: its couplings take no difference (6cda559 took 7
    coordinates), the hinge's entry of the couplings' part of H is −s (∂²pd/∂θ²) w_θ from the scene's output
    (measured 6.2e-16 relative; the central difference it replaces, step 1e-5, 1.4e-10), and the whole H agrees with
    Richardson-extrapolated differences of W w (measured 1.1e-12 with the mass, 2.8e-11 without)."""
    from latdyn.analyses.weight_derivative import _coupling_part, exact_couplings

    prepared, state, rng = _boom_state(CONTROLLED_BOOM)
    assembler, model, n = prepared.assembler, prepared.model, prepared.model.n_dofs
    assert exact_couplings(assembler).all() and len(rest_support(assembler)) == 0
    state.theta[0] = 0.35
    d = int(model.hinge_dofs[0])
    w = rng.normal(size=n)
    rows, cols, values = _coupling_part(assembler, state, w, 1e-4)
    assert list(rows) == [d] and list(cols) == [d]
    reference = -1e-4 * (0.4 * np.sin(0.35 - 0.3) - 2 * 0.05 * state.theta_dot[0]) * w[d]
    assert abs(values[0] - reference) <= 1e-14 * abs(reference)
    _assert_h_is_richardsons(assembler, state, rng, n)


def test_a_saturated_controller_adds_nothing_and_a_controller_of_a_relative_velocity_takes_no_difference():
    """The PD's output clipped at the state (limits [−0.01, 0.01]): its coupling's part of H is empty (∂y/∂s = 0
    about it, csrc/evaluate.c); the same controller reading a point's velocity in a body's axes is generated since
    ctrlweight, no difference along its couplings (86d57d9 kept one; a controller reading an input or a point:
    tests/test_weight_derivative_couplings.py; a cable's tension or a section force:
    tests/test_weight_derivative_force_sensors.py; a relative velocity:
    tests/test_weight_derivative_controllers_rest.py)."""
    from latdyn.analyses.weight_derivative import _coupling_part, exact_couplings

    clipped = CONTROLLED_BOOM.replace('(1 + angle**2)"}', '(1 + angle**2)", limits: [-0.01, 0.01]}')
    prepared, state, rng = _boom_state(clipped)
    state.theta[0] = 1.5
    assert exact_couplings(prepared.assembler).all()
    assert len(_coupling_part(prepared.assembler, state, rng.normal(size=prepared.model.n_dofs), 1.0)[2]) == 0
    with_relative = (CONTROLLED_BOOM.replace("- Kd*rate", "- (1 + spin)*Kd*rate")
                     .replace("    angle: {", '    spin: {point: "arm.node[1]", quantity: velocity, component: x, '
                              'frame: wheel}\n    angle: {', 1))
    assembler = prepare(latdyn.load_scene(yaml.safe_load(with_relative))).assembler
    assert exact_couplings(assembler).all() and not len(rest_support(assembler))


def test_through_the_latch_the_controlled_booms_sensitivities_agree_and_the_loop_keeps_the_bits(monkeypatch):
    """The controlled boom through its latch: the sensitivities by Kp agree with Richardson-extrapolated differences
    of whole runs (measured 1.5e-7, the event time 7.7e-9: as with the difference, whose error on the coupling's entry,
    1.4e-10 of it, lies far below the reference's), and the loop of steps on and off give the same bits, with steps
    in the loop."""
    runs = {}
    for in_loop in (True, False):
        with monkeypatch.context() as patch:
            patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
            runs[in_loop] = latdyn.run(latdyn.load_scene(yaml.safe_load(CONTROLLED_BOOM)))
    native, python = runs[True], runs[False]
    assert [e["kind"] for e in native.summary["events"]] == ["latch"]
    assert native.summary["sensitivity_steps_in_loop"] > 0 == python.summary["sensitivity_steps_in_loop"]
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
    assert _agree(native, CONTROLLED_BOOM, "Kp", 1e-6) < 1e-6
