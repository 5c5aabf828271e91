"""The rest of the continuous controllers' part of an event's impulse weight derivative generated
(latdyn/analyses/weight_derivative.py, docs/parameters.md "The impulse weight's derivative"): a controller reading a
point's velocity relative to a body, in its axes (sensor kind 13), whose value and gradient csrc/evaluate.c now takes
from the generated ``point_velocity_in_body`` (codegen/joints.py) and whose move along δq the generated
``point_velocity_in_body_D_q_D_q`` gives: the kernels against central differences under the configuration's update
(turns on SO(3)); on the genuinely 3D latching boom of tests/test_weight_derivative_rest.py a PD reading the spar's
tip's velocity relative to the wheel and to the root body takes no central difference any more, its block of H
agrees with Richardson-extrapolated differences of its K w, and through the latch the sensitivities agree with
Richardson differences of whole runs, through the API and ``latdyn run``, with the loop of steps on and off giving
the same bits."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.weight_derivative import (_coupling_part, _driven_load_part, _hinge_part, _sparse, exact_couplings,
                                               exact_hinges, exact_hinges_by_rates, linked_exact_hinges, rest_support,
                                               times, transposed_times)
from latdyn.assembly.prepare import prepare
from latdyn.model.kernels import load_kernels
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_fuzz_findings import _richardson
from tests.test_sensitivities_in_loop_linked_control import GIMBAL_PD
from tests.test_weight_derivative_couplings import \
    test_a_sensors_second_derivative_is_the_central_difference_of_its_gradient as _the_sensors_check
from tests.test_weight_derivative_couplings import \
    test_through_the_latch_the_sensitivities_agree_and_the_loop_keeps_the_bits as _through_the_latch
from tests.test_weight_derivative_linked_rest import _at_events
from tests.test_weight_derivative_rates import WHEEL_STOP, _evaluations_in_the_rates_term, _rates_term, _richardson_by_rates
from tests.test_weight_derivative_rest import CONTROLLED_BOOM, _boom_state, _rotation, _row

#: the controlled boom's PD of the arm's hinge reading, beside its angle and rate, the spar's tip's velocity relative
#: to the wheel (y in the wheel's axes) and the arm's middle node's relative to the root body (z), nonlinear in them
RELATIVE = (CONTROLLED_BOOM.replace('  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
                                    '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) '
                                    '- 0.4*tip_v*(1 + angle**2) - 0.3*tip_v**2 + 0.2*mid_v*angle"}', 1)
            .replace("    angle: {", "    tip_v: {point: spar.end, quantity: velocity, frame: wheel, component: y}\n"
                     '    mid_v: {point: "arm.node[1]", quantity: velocity, frame: base, component: z}\n'
                     "    angle: {", 1))
#: the spar on a hinge of its own at the wheel, driven by ``sc``: the spar's tip's velocity relative to the wheel (x)
#: and to the root body (y), with the spar's angle; that hinge stays free through the arm's latch, so its coupling's
#: row reaches the sensitivities (the latching hinge's own row leaves the numbering at the latch)
SPAR = (CONTROLLED_BOOM.replace("section: s, elements: 1}",
                                'section: s, elements: 1,\n         start: {hinge: {axis: [0, 1, 1], stiffness: 3.0, '
                                'torque: "sc"}}}', 1)
        .replace("\nsolve:", '\n  sc: {output: "-Ks*sin(spar_angle - 0.1) - 0.8*tip_v*(1 + spar_angle**2) '
                              '+ 0.5*tip_b*tip_v - 0.3*tip_b**2"}\nsolve:', 1)
        .replace("Kp: 0.4, Kd: 0.05}", "Kp: 0.4, Kd: 0.05, Ks: 0.8}", 1)
        .replace("    angle: {", "    spar_angle: {hinge: spar.start, quantity: angle}\n"
                 "    tip_v: {point: spar.end, quantity: velocity, frame: wheel, component: x}\n"
                 "    tip_b: {point: spar.end, quantity: velocity, frame: base, component: y}\n    angle: {", 1))

#: the boom's latching hinge's torque a law a y + b(θ) naming the PD (its ∂²/∂θ² is b's: y moves through the couplings)
HINGE_NAMING_A_CONTROLLER = CONTROLLED_BOOM.replace('torque: "pd"', 'torque: "0.5*pd + 0.3*sin(2*theta)"', 1)
#: the 3D gimbal of rigid links latching (its inner ring) with a PD on the inner hinge, the outer hinge's torque a law
#: of its angle naming the PD's output (free through the latch: its row reaches the sensitivities)
GIMBAL_TORQUE_NAMING_A_CONTROLLER = GIMBAL_PD.replace(
    'stiffness: "k1", rest_angle: "rest"}}}',
    'stiffness: "k1", rest_angle: "rest", torque: "0.6*pd + 0.4*sin(2*theta) + 0.3*theta**2"}}}', 1)
#: the wheel onto its rigid stop (restitution 0.9) on laws of θ and θ̇, its damper times an input g = 1
WHEEL_STOP_INPUT = (WHEEL_STOP.replace('damping: "c*(1 + theta**2)', 'damping: "g*c*(1 + theta**2)', 1)
                    + "inputs: {g: 1.0}\n")
#: the controlled boom's PD mixing points' positions (global at the wheel, at an offset, in the wheel's axes) with the
#: hinge's rate and the wheel's velocity: its couplings move with the rates through ∂²y/∂s_p∂s_r
PD_OF_POINTS_AND_RATES = (CONTROLLED_BOOM.replace(
    '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}',
    '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) - 2*(tip_x - 0.6)*rate '
    '+ 3*sin(spar_y)*wheel_vz + 0.5*mid_w*rate*wheel_vz"}', 1)
    .replace("    angle: {", "    spar_y: {point: spar.start, quantity: position, component: y}\n"
             '    mid_w: {point: "arm.node[1]", quantity: displacement, component: x, frame: wheel}\n'
             "    wheel_vz: {point: wheel, quantity: velocity, component: z}\n    angle: {", 1))
#: the spar on a hinge of its own driven by a controller of its angle and rate, the tip's and the spar's start's
#: positions and the wheel's velocity (free through the arm's latch: its row reaches the sensitivities)
SPAR_OF_POINTS_AND_RATES = (CONTROLLED_BOOM.replace(
    "section: s, elements: 1}", 'section: s, elements: 1,\n         start: {hinge: {axis: [0, 1, 1], stiffness: 3.0, '
    'torque: "sc"}}}', 1)
    .replace("\nsolve:", '\n  sc: {output: "-Ks*sin(spar_angle - 0.1) - 0.5*(tip_x - 0.6)*spar_rate '
                         '+ 0.8*spar_y*wheel_vz*(1 + spar_rate)"}\nsolve:', 1)
    .replace("Kp: 0.4, Kd: 0.05}", "Kp: 0.4, Kd: 0.05, Ks: 0.8}", 1)
    .replace("    angle: {", "    spar_angle: {hinge: spar.start, quantity: angle}\n"
             "    spar_rate: {hinge: spar.start, quantity: rate}\n"
             "    spar_y: {point: spar.start, quantity: position, component: y}\n"
             "    wheel_vz: {point: wheel, quantity: velocity, component: z}\n    angle: {", 1))
assert '"0.5*pd + 0.3' in HINGE_NAMING_A_CONTROLLER and "0.6*pd" in GIMBAL_TORQUE_NAMING_A_CONTROLLER
assert "g*c*(1" in WHEEL_STOP_INPUT

def _velocity_in_body(geometry, velocity):
    """s = T_bᵀ (v_n + ω_n × T_n r − v_b − ω_b × (x_n + T_n r − x_b)) (codegen/joints.py point_velocity_in_body)."""
    x_n, x_b, T_n, r, T_b = geometry[:3], geometry[3:6], geometry[6:15].reshape(3, 3), geometry[15:18], \
        geometry[18:].reshape(3, 3)
    v_n, w_n, v_b, w_b = velocity.reshape(4, 3)
    o = T_n @ r
    return T_b.T @ (v_n + np.cross(w_n, o) - v_b - np.cross(w_b, x_n + o - x_b))


def _moved(geometry, delta):
    """The geometry updated by [d_n, π_n, d_b, π_b]: x += d, T ← exp(skew π) T (turns on SO(3))."""
    out = geometry.copy()
    out[:3] += delta[:3]
    out[3:6] += delta[6:9]
    out[6:15] = (_rotation(delta[3:6]) @ geometry[6:15].reshape(3, 3)).reshape(9)
    out[18:] = (_rotation(delta[9:12]) @ geometry[18:].reshape(3, 3)).reshape(9)
    return out


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_the_generated_relative_velocity_and_its_derivatives_are_central_differences(backend):
    """``point_velocity_in_body`` at random frames, points and rates: its value the formula's, its gradient by
    [d_n, π_n, d_b, π_b] the central difference of the value under the update, by the rates the formula's (linear);
    ``point_velocity_in_body_D_q_D_q``'s gradient the same to round-off and its
    second derivative the central difference of
    that gradient, on both backends (measured 1.6e-16, 2.4e-10 and 1.9e-10 of the largest at step 1e-6)."""
    kernels = load_kernels(backend, "default")
    rng = np.random.default_rng(13)
    for _ in range(3):
        geometry = np.concatenate([rng.normal(size=6), _rotation(rng.normal(size=3)).reshape(9), rng.normal(size=3),
                                   _rotation(rng.normal(size=3)).reshape(9)])
        velocity = rng.normal(size=12)
        value, by_q, by_rate = (np.asarray(x)[0]
                                for x in kernels.point_velocity_in_body(_row(geometry), _row(velocity)))
        np.testing.assert_allclose(value, _velocity_in_body(geometry, velocity), rtol=1e-13, atol=1e-13)
        by_q, by_rate = by_q.reshape(3, 12), by_rate.reshape(3, 12)
        eye, h = np.eye(12), 1e-6
        numeric = np.column_stack([(_velocity_in_body(_moved(geometry, h * eye[i]), velocity)
                                    - _velocity_in_body(_moved(geometry, -h * eye[i]), velocity)) / (2 * h)
                                   for i in range(12)])
        assert np.abs(by_q - numeric).max() <= 1e-8 * np.abs(by_q).max()
        rates = np.column_stack([_velocity_in_body(geometry, eye[i]) - _velocity_in_body(geometry, 0 * eye[i])
                                 for i in range(12)])
        np.testing.assert_allclose(by_rate, rates, rtol=1e-13, atol=1e-13)
        gradient, second = (np.asarray(x)[0] for x in kernels.point_velocity_in_body_D_q_D_q(_row(geometry),
                                                                                                _row(velocity)))
        np.testing.assert_allclose(gradient.reshape(3, 12), by_q, rtol=1e-14, atol=1e-14)
        second = second.reshape(3, 12, 12)

        def gradient_at(g):
            return np.asarray(kernels.point_velocity_in_body(_row(g), _row(velocity))[1]).reshape(3, 12)

        for i in range(12):
            moved = (gradient_at(_moved(geometry, h * eye[i])) - gradient_at(_moved(geometry, -h * eye[i]))) / (2 * h)
            assert np.abs(second[:, :, i] - moved).max() <= 1e-8 * np.abs(second).max()


def test_the_sensors_gradient_is_csrc_evaluates_and_its_second_derivative_the_difference_of_it():
    """The boom's PD's two relative velocities at a moving state (tests/test_weight_derivative_couplings.py's check):
    the gradient the weight derivative takes is the one csrc/evaluate.c computes (``sensor_jacobian``'s columns of K,
    to the bit), and its derivative along each of their coordinates the central difference of that gradient
    (measured 4.4e-11 of its largest; relative to the root body, fixed, the arm's middle node's is 0 there)."""
    _the_sensors_check(RELATIVE, [13, 13])


def _couplings_product(assembler, state, w: np.ndarray) -> np.ndarray:
    """The evaluation's controllers' couplings' block of K alone, times w."""
    k = assembler.evaluate(state, matrices=True).flat_blocks("stiffness")
    return np.asarray(assembler.assemble([0.0 * k[0], 0.0 * k[1], 0.0 * k[2], 0.0 * k[3], k[4]]) @ w)


@pytest.mark.parametrize("text", [RELATIVE, SPAR], ids=["arm", "spar"])
def test_a_controller_reading_a_points_velocity_relative_to_a_body_takes_no_difference(text):
    """The PDs reading the relative velocities: no coordinate left to difference (86d57d9 differenced all 19), and
    the couplings' part of H along random δq at random w agrees with Richardson-extrapolated differences of the
    couplings' K w (measured 1.1e-11, 2.2e-12 on the arm's, 7.0e-11, 3.3e-11 on the spar's, of the block's largest;
    86d57d9's difference: docs/performance.md "Controllers' weight derivatives generated (issue 34)")."""
    prepared, state, rng = _boom_state(text)
    assembler, n = prepared.assembler, prepared.model.n_dofs
    assert exact_couplings(assembler).all() and len(rest_support(assembler)) == 0
    state.theta[0] = 0.35
    for _ in range(2):
        w, dq = rng.normal(size=n), rng.normal(size=n)
        exact = (times(_sparse(*_coupling_part(assembler, state, w, 1.0), n), dq)
                 + times(_sparse(*_driven_load_part(assembler, state, w, 1.0), n), dq))
        central = [(_couplings_product(assembler, assembler.advance(state, h * dq), w)
                    - _couplings_product(assembler, assembler.advance(state, -h * dq), w)) / (2 * h)
                   for h in (1e-4, 5e-5)]
        numeric = (4 * central[1] - central[0]) / 3
        assert np.abs(numeric).max() > 0.0
        assert np.abs(exact - numeric).max() <= 2e-10 * np.abs(numeric).max()


def test_through_the_latch_the_sensitivities_agree_and_the_loop_keeps_the_bits():
    """Through the arm's latch with the spar's hinge driven by the relative velocities: the sensitivities by Ks agree
    with Richardson differences of whole runs (measured 5.9e-6, 86d57d9's difference 5.7e-6: the reference's own error,
    the two trees' sensitivities 3.7e-10 apart), and the loop of steps on and off give the same bits, with steps in
    the loop (tests/test_weight_derivative_couplings.py's check, no difference left in H)."""
    _through_the_latch(SPAR, "Ks", 1e-5)


def test_latdyn_run_of_the_relative_velocity_pd_agrees_and_the_loop_off_writes_the_same(tmp_path):
    """``latdyn run`` of the boom whose arm's PD reads the relative velocities, through its latch: no difference
    left in H, the event sensitivities by Kp in summary.json the API's, agreeing with Richardson differences of whole
    runs (the event's dt to 1e-7; the probes measured ≤ 1.7e-7 but the tip's relative velocity, 1.1e-4, 86d57d9's
    8.9e-5: there the reference's own two Richardson estimates, from h, h/2 and h/2, h/4, differ by 4.1e-4; the two
    trees' sensitivities 3.4e-8 apart), and the loop of steps off writes the same files byte for byte."""
    text = RELATIVE.replace("sensitivities: [Kp, k]", "sensitivities: [Kp]")
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert len(rest_support(_boom_state(text)[0].assembler)) == 0
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 0, run.stderr
    assert summary_of(out)["event_sensitivities"] == result.summary["event_sensitivities"]
    assert _agree(result, text, "Kp", 2e-4) < 2e-4
    the_loop_off_writes_the_same(tmp_path, out)


def _hinges_and_couplings_product(assembler, state, w: np.ndarray) -> np.ndarray:
    """The evaluation's hinges' and controllers' couplings' blocks of K alone, times w."""
    k = assembler.evaluate(state, matrices=True).flat_blocks("stiffness")
    return np.asarray(assembler.assemble([0.0 * k[0], 0.0 * k[1], k[2], 0.0 * k[3], k[4]]) @ w)


def test_a_hinge_torque_naming_a_controller_takes_no_difference():
    """The boom's latching hinge's torque 0.5 pd + 0.3 sin 2θ: its part of H is the generated
    ``hinge_stiffness_by_angle`` with the law's second derivative b″(θ) (86d57d9 differenced its angle), and with the
    PD's couplings it agrees with Richardson differences of their K w (measured 1.3e-12, 5.8e-12 on the hinge's row;
    86d57d9's difference 7.1e-11)."""
    prepared, state, rng = _boom_state(HINGE_NAMING_A_CONTROLLER)
    assembler, n = prepared.assembler, prepared.model.n_dofs
    assert exact_hinges(assembler).all() and len(rest_support(assembler)) == 0
    state.theta[0] = 0.35
    row = int(prepared.model.hinge_dofs[0])
    for _ in range(2):
        w, dq = rng.normal(size=n), rng.normal(size=n)
        rows, values = _hinge_part(assembler, state, w, 1.0)
        exact = times(_sparse(rows, rows, values, n), dq) + times(_sparse(*_coupling_part(assembler, state, w, 1.0),
                                                                          n), dq)
        central = [(_hinges_and_couplings_product(assembler, assembler.advance(state, h * dq), w)
                    - _hinges_and_couplings_product(assembler, assembler.advance(state, -h * dq), w)) / (2 * h)
                   for h in (1e-4, 5e-5)]
        numeric = (4 * central[1] - central[0]) / 3
        assert abs(exact[row] - numeric[row]) <= 1e-10 * abs(numeric[row])


def test_the_gimbals_torque_naming_a_controller_takes_no_difference_at_its_latch(monkeypatch):
    """The 3D gimbal of rigid links, its outer hinge's torque 0.6 pd + 0.4 sin 2θ + 0.3 θ² beside the PD on the
    latching inner hinge: both hinges generated through the reduction, no difference of W_rest at the latch (86d57d9
    took 12), ∂(W w)/∂q δq agreeing with the Richardson reference of tests/test_weight_derivative_linked.py (measured
    1.3e-11 on both)."""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(GIMBAL_TORQUE_NAMING_A_CONTROLLER)))
    assert linked_exact_hinges(prepared.assembler).all()
    result, errors, differences = _at_events(GIMBAL_TORQUE_NAMING_A_CONTROLLER, monkeypatch)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"] and differences == 0
    assert errors and max(errors) < 5e-11, errors


def test_an_input_named_hinge_law_beside_a_stop_takes_no_difference_along_the_rates(monkeypatch):
    """The wheel onto its rigid stop, its damper g c (1 + θ²)(1 + θ̇²) with g an input: its ∂K_jj/∂θ̇ is the generated
    ``hinge_stiffness_by_rate`` at the input's value (86d57d9 differenced K w along δv, two evaluations a parameter at
    each stop), and through both stops the sensitivities by c agree with Richardson differences of whole runs (every
    row within 1e-7 of its probe's largest; measured 1.7e-9; 86d57d9 stopped at the first stop with a traceback,
    :func:`test_an_empty_generated_part_multiplies_to_floats`)."""
    data = yaml.safe_load(WHEEL_STOP_INPUT)
    data["solve"]["sensitivities"] = ["c"]
    text = yaml.safe_dump(data)
    prepared = prepare(latdyn.load_scene(data))
    assert exact_hinges_by_rates(prepared.assembler).all()
    counts = _evaluations_in_the_rates_term(monkeypatch)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert [e["kind"] for e in result.summary["events"]] == ["stop", "stop"]
    assert counts and not any(counts), counts
    monkeypatch.undo()
    expected = _richardson(text, "c", 1e-3 * data["parameters"]["c"])
    for probe in ("angle", "tip_x", "mid_z"):
        computed = result.sensitivities[(probe, "c")]
        assert np.abs(computed - expected[probe]).max() <= 1e-7 * np.abs(expected[probe]).max(), probe


def test_an_empty_generated_part_multiplies_to_floats():
    """A model whose generated part along the rates is empty (every hinge's entry differenced, no coupling) multiplies
    to float zeros, to which the difference is added in place (86d57d9: NumPy's integer ``bincount`` of nothing, a
    traceback ``Cannot cast ufunc 'add' output from dtype('float64') to dtype('int64')`` at the wheel's stop with a
    damper naming an input)."""
    empty = _sparse(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), 4)
    for product in (times, transposed_times):
        out = product(empty, np.ones((4, 2)))
        assert out.dtype == np.float64 and not out.any()
        out[:, 0] += 0.5


@pytest.mark.parametrize("text", [PD_OF_POINTS_AND_RATES, SPAR_OF_POINTS_AND_RATES], ids=["arm", "spar"])
def test_a_controller_of_points_and_rates_moves_with_the_rates_without_a_difference(monkeypatch, text):
    """The PDs mixing points' positions with rates (a hinge's, the wheel's velocity): at a turned, moving state their
    couplings' ∂(K w)/∂v δv (3 columns) is SymPy's mixed second derivatives times the sensors' generated gradients,
    with no evaluation of the model (86d57d9 differenced it, two evaluations a column), within 1e-9 of the Richardson
    reference's largest entry (measured 2.5e-14 on the arm's; 86d57d9's difference 2.0e-11)."""
    prepared, state, w, dv, computed, counts, moving = _rates_term(monkeypatch, text)
    assert counts == [0]
    reference = _richardson_by_rates(prepared, state, w, dv, moving)
    assert np.abs(reference).max() > 0.0
    assert np.abs(computed - reference).max() <= 1e-9 * np.abs(reference).max()
