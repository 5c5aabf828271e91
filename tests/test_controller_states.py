"""States of continuous controllers (SCENE.md ``controllers.NAME.states`` without ``rate``): dS/dt = EXPR.

Exact references on the rigid hub of tests/test_controllers.py (a link to a tip mass on a hinge,
J θ̈ = u + d): a PI loop u = −kp θ − kd θ̇ − ki S, Ṡ = θ, under a constant disturbance torque d is
the linear system ẋ = A x + b, x = [θ, θ̇, S], whose exact solution is x(t) = A⁻¹(e^{At} − I) b
(and its steady state θ = 0: no steady-state error, S = d/ki); a first-order low-pass filter
Ḟ = (θ − F)/τ of θ = c t² (the hub under a constant torque alone) is
F = c (t² − 2τt + 2τ²(1 − e^{−t/τ})). Planar (axis z, through the CLI) and 3D (axis [0, 1, 1]/√2,
through the API)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from scipy.linalg import expm

import latdyn
from cli_runs import latdyn_run, probe_columns
from test_controllers import PLANAR, SPATIAL, J, hub, linear_model_of

PI = """
  ctl:
    output: "-kp*th - kd*om - ki*S"
    states: {S: "th"}
"""
GAINS = "inputs: {kp: 6.0, kd: 2.0, ki: 3.0}"
KP, KD, KI, D = 6.0, 2.0, 3.0, 0.8


def disturbed(text: str, axis: str) -> str:
    """``text`` with a constant moment D about the hinge axis on the tip (a torque D about the hinge)."""
    a = np.array(yaml.safe_load(axis), float)
    return text + "loads:\n  - {at: tip, moment: [%r, %r, %r]}\n" % tuple(float(x) for x in D * a)


def pi_exact(t: np.ndarray) -> np.ndarray:
    A = np.array([[0, 1, 0], [-KP / J, -KD / J, -KI / J], [1, 0, 0]])
    b = np.array([0, D / J, 0])
    return np.array([np.linalg.solve(A, (expm(A * s) - np.eye(3)) @ b) for s in t])


def pi_scene(axis: str, dt: float = 0.005, t_end: float = 4.0) -> str:
    return disturbed(hub(PI, inputs=GAINS, axis=axis, solve=f"{{t_end: {t_end}, dt: {dt}}}",
                         probes="    u: {controller: ctl}\n    Sp: {controller: ctl, state: S}"), axis)


def check_pi(t, p, tolerance):
    exact = pi_exact(t)
    for k, name in enumerate(("th", "om", "Sp")):
        assert np.max(np.abs(p[name] - exact[:, k])) < tolerance, name
    u = -KP * exact[:, 0] - KD * exact[:, 1] - KI * exact[:, 2]
    assert np.max(np.abs(p["u"] - u)) < 6 * tolerance


def test_pi_with_a_disturbance_planar_cli(tmp_path):
    """Planar, through the CLI: θ, θ̇, S and u against the exact solution (measured at dt = 0.005:
    θ 2.2e-6, θ̇ 4.9e-6, S 9.4e-7, u 1.2e-5; at dt = 0.01 four times these: second order), in the
    compiled loop; and the error is driven out: S → d/ki (the integral action)."""
    completed, out = latdyn_run(tmp_path, pi_scene(PLANAR, t_end=2.0))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    check_pi(p["t"], p, 3e-6 * 2)
    # the slowest root −0.617: e^(−0.617·30) = 9e-9 of the transient left at t = 30 (measured at dt = 0.1:
    # θ 4.8e-9, S − d/ki −8.3e-9)
    long = latdyn.run(latdyn.load_scene(yaml.safe_load(pi_scene(PLANAR, dt=0.1, t_end=30.0))))
    assert abs(long.probes["th"][-1]) < 1e-7 and abs(long.probes["Sp"][-1] - D / KI) < 1e-7


def test_pi_with_a_disturbance_3d_api_second_order():
    """3D (axis [0, 1, 1]/√2), through the API, at dt = 0.01 and 0.005: the same errors as planar, and
    their ratio 4 (the trapezoidal rule of the states beside generalized-α: second order kept)."""
    errors = []
    for dt in (0.01, 0.005):
        result = latdyn.run(latdyn.load_scene(yaml.safe_load(pi_scene(SPATIAL, dt=dt))))
        assert result.summary["time_loop"] == "compiled"
        errors.append(np.max(np.abs(result.probes["th"] - pi_exact(result.t)[:, 0])))
    assert errors[1] < 2.5e-6
    assert 3.5 < errors[0] / errors[1] < 4.5


FILTER = """
  lp:
    output: "F"
    states: {F: "(th - F)/tau"}
"""


@pytest.mark.parametrize("axis", [PLANAR, SPATIAL], ids=["planar", "3d"])
def test_low_pass_filter_state(axis):
    """A filter state F of θ = c t² (c = τ_d/2J under the constant torque τ_d = D) against its closed form
    (measured 2.5e-6 of F(1) = 0.249 at dt = 0.01, 6.1e-7 at dt = 0.005: the trapezoidal rule's second order;
    θ exact to 2e-16; the filter reads the hinge angle and drives nothing)."""
    text = disturbed(hub(FILTER, torque="0", inputs="inputs: {tau: 0.25}", axis=axis,
                         solve="{t_end: 1.0, dt: 0.01}", probes="    Fp: {controller: lp, state: F}\n"
                                                                "    y: {controller: lp}"), axis)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    t, tau, c = result.t, 0.25, D / (2 * J)
    assert np.max(np.abs(result.probes["th"] - c * t ** 2)) < 1e-10
    exact = c * (t ** 2 - 2 * tau * t + 2 * tau ** 2 * (1 - np.exp(-t / tau)))
    assert np.max(np.abs(result.probes["Fp"] - exact)) < 3e-6
    assert np.max(np.abs(result.probes["y"] - result.probes["Fp"])) == 0.0


@pytest.mark.parametrize("axis", [PLANAR, SPATIAL], ids=["planar", "3d"])
def test_closed_loop_linear_model_with_integral_action(axis):
    """``linear_model`` with the PI: x = [θ, θ̇, S], A = [[A_ol + B K C, B (−ki)], [C_θ, 0]] of the
    open-loop model (K = [−kp, −kd] on y = [θ, θ̇]), to round-off; the modes are its eigenvalues."""
    spec = '{analysis: modes, count: 3, linear_model: {inputs: [arm.start], outputs: [th, om, Sp]}}'
    closed = linear_model_of(hub(PI, inputs=GAINS, axis=axis, solve=spec,
                                 probes="    Sp: {controller: ctl, state: S}"))
    opened = linear_model_of(hub("  other: {output: 0}", torque="0", inputs=GAINS, axis=axis,
                                 solve='{analysis: modes, count: 1, linear_model: {inputs: [arm.start], '
                                       'outputs: [th, om]}}'))
    A_ol, B, C = opened["A"], opened["B"], opened["C"]
    expected = np.block([[A_ol + B @ np.array([[-KP, -KD]]) @ C, -KI * B], [C[:1], np.zeros((1, 1))]])
    assert closed["A"].shape == (3, 3)
    assert np.max(np.abs(closed["A"] - expected)) < 1e-12 * np.max(np.abs(expected))
    hand = np.array([[0, 1, 0], [-KP / J, -KD / J, -KI / J], [1, 0, 0]])
    assert np.max(np.abs(closed["A"] - hand)) < 1e-12 * np.max(np.abs(hand))
    assert np.allclose(closed["C"][2], [0, 0, 1]) and list(closed["states"])[-1] == "controller ctl.S"


def test_modes_of_the_closed_loop_with_a_state(tmp_path):
    """``modes`` of the PI loop: its three roots (a pair and a real one) from A, in modes.csv."""
    out = tmp_path / "out"
    latdyn.run(latdyn.load_scene(yaml.safe_load(hub(PI, inputs=GAINS, solve="{analysis: modes, count: 3}"))), out)
    roots = np.linalg.eigvals(np.array([[0, 1, 0], [-KP / J, -KD / J, -KI / J], [1, 0, 0]]))
    natural = sorted({round(abs(r) / (2 * math.pi), 12) for r in roots})
    table = np.genfromtxt(out / "modes.csv", delimiter=",", names=True)
    assert np.allclose(sorted(table["natural_frequency_hz"]), natural, rtol=1e-9)


def test_controller_state_resumes_bit_for_bit(tmp_path, monkeypatch):
    """Interrupted and resumed, a run with the PI's state gives probes.csv equal to the uninterrupted
    run's (the states and their rates are in the checkpoint)."""
    from test_checkpoint import interrupt_at

    scene = yaml.safe_load(pi_scene(PLANAR, dt=0.01, t_end=1.5))
    full, out = tmp_path / "full", tmp_path / "out"
    latdyn.run(scene, full)
    with monkeypatch.context() as m:
        interrupt_at(m, 0.737)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    assert (out / "probes.csv").read_text() == (full / "probes.csv").read_text()


NONLINEAR = """
  ctl:
    output: "-kp*th - kd*om - ki*S*(1 + S**2)"
    states: {S: "sin(th) - S*om"}
    initial: {S: 0.3}
"""


@pytest.mark.parametrize("h", [0.0, 0.01], ids=["held", "in-a-step"])
def test_condensed_state_derivative_against_central_differences(h):
    """The evaluation's coupling entries of a controller with a state nonlinear in S and the sensors:
    in a step of size h (the trapezoidal rule condensed, h/2 in the Work's buffer) the output's total
    derivatives dy/dθ and dy/dθ̇ (the state solved again at each perturbed sensor) against central
    differences of the output the evaluation gives (measured 5.6e-11 and 7.0e-11 relative: dy/dθ =
    −6.01771, dy/dθ̇ = −1.99415, where the partials are −6 and −2); held (h = 0) the partials ∂y/∂s of
    the generated law (4.5e-11 and 2.9e-11 against the differences, exact against −kp and −kd)."""
    from latdyn.assembly.control import state_rates
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(yaml.safe_load(hub(NONLINEAR, inputs=GAINS))))
    assembler, state = prepared.assembler, prepared.state.copy()
    scene = prepared.scene
    state.theta[0], state.theta_dot[0] = 0.4, -0.7
    state_rates(scene)[:] = 0.25  # f_n of the step's start, as an accepted step leaves it
    native = assembler.native()
    native.buffers["controller_half_step"][0] = 0.5 * h
    slot = scene.controller_outputs.index("ctl")

    def output(theta, rate):
        s = state.copy()
        s.theta[0], s.theta_dot[0] = theta, rate
        assembler.evaluate(s, matrices=False)
        return scene.controller_outputs.values[slot]

    d = int(prepared.model.hinge_dofs[0])

    def residual(theta, rate):  # the hinge's row of the static residual: the controller's torque −y
        s = state.copy()
        s.theta[0], s.theta_dot[0] = theta, rate
        return assembler.evaluate(s, matrices=False, inertia=False).residual[d]

    try:
        ev = assembler.evaluate(state, matrices=True, inertia=False)
        K, C = (np.asarray(ev.combined(*c, dense=True)) for c in ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)))
        kinds = assembler.control.sensor_kind[assembler.control.coupling_sensor]
        coupling = native.buffers["coupling_stiffness"] + native.buffers["coupling_damping"]
        exact = {int(kind): -float(value) for kind, value in zip(kinds, coupling)}  # g = −1 on a hinge
        e = 1e-6
        by_angle = (output(0.4 + e, -0.7) - output(0.4 - e, -0.7)) / (2 * e)
        by_rate = (output(0.4, -0.7 + e) - output(0.4, -0.7 - e)) / (2 * e)
        r_theta = (residual(0.4 + e, -0.7) - residual(0.4 - e, -0.7)) / (2 * e)
        r_rate = (residual(0.4, -0.7 + e) - residual(0.4, -0.7 - e)) / (2 * e)
    finally:
        native.buffers["controller_half_step"][0] = 0.0
    # the evaluation's matrices carry the coupling on the hinge's row: K and C there are the static
    # residual's derivatives by θ and θ̇ (the controller's torque −y alone)
    assert abs(K[d, d] - r_theta) < 1e-8 * abs(r_theta) and abs(r_theta) > 1.0
    assert abs(C[d, d] - r_rate) < 1e-8 * abs(r_rate) and abs(r_rate) > 1.0
    assert abs(exact[0] - by_angle) < 1e-8 * abs(by_angle)
    assert abs(exact[1] - by_rate) < 1e-8 * abs(by_rate)
    if h == 0.0:  # the partials of the generated law at S = 0.3
        assert exact[0] == pytest.approx(-KP, rel=1e-14) and exact[1] == pytest.approx(-KD, rel=1e-14)


def test_non_collocated_integral_action_3d_linear_model():
    """3D, non-collocated: a force along z on body a from the z displacement of body b at the other end
    of an elastic beam, with integral action (u = −30 zb − 12 S, Ṡ = zb): the linear model's A is
    [[A_ol + B K C, −12 B], [C, 0]] of the open loop (a load actuator and a point sensor; measured
    8e-19 of the largest entry, 1.1e6; the state's row exactly C)."""
    from test_controllers import TWO_BODIES

    pi = 'controllers:\n  ctl: {output: "-30*zb - 12*S", states: {S: "zb"}}'
    closed = linear_model_of(TWO_BODIES.format(controllers=pi, force="ctl"))
    opened = linear_model_of(TWO_BODIES.format(controllers="", force="0"))
    A_ol, B, C = opened["A"], opened["B"], opened["C"]
    expected = np.block([[A_ol + B @ np.array([[-30.0]]) @ C, -12.0 * B], [C, np.zeros((1, 1))]])
    assert closed["A"].shape == expected.shape
    assert np.max(np.abs(closed["A"] - expected)) < 1e-8 * np.max(np.abs(expected))


def test_explicit_method_with_states_is_refused():
    """The states are integrated by the implicit step: ``solve.method: explicit`` is refused at the
    controller's ``states`` key."""
    from latdyn.errors import SceneError

    text = hub(PI, inputs=GAINS, solve="{t_end: 0.1, dt: 0.001, method: explicit}")
    with pytest.raises(SceneError, match=r"controllers\.ctl\.states.*generalized-alpha"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def test_python_stepping_with_a_state_equals_the_run():
    """``latdyn.Simulation`` advanced to 20 pauses on the grid gives the rows of ``latdyn.run``, the
    state and the output included, bit for bit (3D)."""
    text = pi_scene(SPATIAL, dt=0.01, t_end=1.0)
    reference = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    sim = latdyn.Simulation(latdyn.load_scene(yaml.safe_load(text)))
    for k in range(1, 21):
        sim.advance_to(0.05 * k)
    result = sim.close()
    assert np.array_equal(result.t, reference.t)
    for name in ("th", "om", "Sp", "u"):
        assert np.array_equal(result.probes[name], reference.probes[name]), name
