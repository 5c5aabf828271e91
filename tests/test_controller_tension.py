"""A continuous controller that reads a cable's tension (SCENE.md ``controllers``: "A continuous controller
may read point, hinge, guide, cable and element probes"; docs/control.md).

The sensor is the probe's value, the tension N = EA (ℓ − L0)/L0 + c ℓ̇ of the cable's first element while
taut (0 slack), with N's exact derivatives by the end coordinates (K) and rates (C: the damper) from the
generated ``cable_tension`` kernel (codegen/joints.py). Exact references:

- a guided mass m at distance 1 + s from an anchor on its axis, held by a taut massless cable
  (k = EA/L0, damper c), pushed by y = −kp (N − N_ref): m s̈ = −(1 + kp)(k (1 − L0 + s) + c ṡ) + kp N_ref,
  a damped oscillator in closed form (planar, CLI);
- the same with the anchor off the (skew) axis: a nonlinear 1-DOF ODE integrated by ``solve_ivp`` to
  1e-11 (genuinely 3D, API);
- the closed loop's linear model A = A_ol + B K C;
- a sampled controller reading the tension holds the probe's value at its instants.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns
from latdyn.model.kernels import load_kernels
from test_cables import cable_inputs, moved
from test_controller_sensors import CABLED, oscillator
from test_controllers import linear_model_of

MASS, EA, REST, DAMPING, KP, N_REF = 2.0, 50.0, 0.8, 0.5, 3.0, 10.0
HELD = """
inputs: {{kp: {kp}, ref: {ref}, u: 0.0}}
controllers:
  ctl: {{output: "{output}"}}
{sampled}
cables:
  tie: {{from: anchor, to: cart, EA: {EA}, damping: {c}, rest_length: {L0}}}
bodies:
  anchor: {{at: {anchor}, fixed: true}}
  cart: {{at: {at}, mass: {m}, inertia: [1, 1, 1], guide: {{axis: {axis}, force: "{force}"}}}}
solve: {solve}
output:
  probes:
    s: {{guide: cart, quantity: position}}
    v: {{guide: cart, quantity: rate}}
    T: {{cable: tie, quantity: tension}}
{probes}
"""
AT = np.array([0.3, -0.2, 0.1])
SKEW = np.array([0.0, 1.0, 1.0]) / math.sqrt(2.0)


def held(*, axis=(1.0, 0.0, 0.0), anchor=None, output="-kp*(T - ref)", force="ctl", sampled="",
         solve="{t_end: 1.0, dt: 0.002}", probes="") -> str:
    axis = np.asarray(axis, float)
    anchor = AT - axis if anchor is None else anchor
    return HELD.format(kp=KP, ref=N_REF, output=output, sampled=sampled, EA=EA, c=DAMPING, L0=REST,
                       anchor=list(map(float, anchor)), at=list(map(float, AT)), m=MASS, axis=list(map(float, axis)),
                       force=force, solve=solve, probes=probes)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_cable_tension_kernel_against_differences(backend):
    """cable_tension's N_el, N against cable_force's state (the law the residual holds, to 1e-12) and its
    derivatives by [d, π] of both ends and by the rates against central differences of N (1e-7 of the
    largest; the differences' truncation error)."""
    ks = load_kernels(backend, "default")
    geometry, velocity, section = cable_inputs()
    tension, by_q, by_rate = ks.cable_tension(geometry, velocity, section)
    state = ks.cable_force(geometry, velocity, section)[3]
    assert np.allclose(tension, state[:, 3:5], rtol=1e-12, atol=1e-12)
    eps = 1e-6
    for b in range(len(geometry)):
        g, v, s = geometry[b], velocity[b], section[b]
        scale = max(1.0, np.abs(by_q[b]).max(), np.abs(by_rate[b]).max())
        for k in range(12):
            up = ks.cable_tension(moved(g, k, eps)[None], v[None], s[None])[0][0, 1]
            down = ks.cable_tension(moved(g, k, -eps)[None], v[None], s[None])[0][0, 1]
            assert abs(by_q[b, k] - (up - down) / (2 * eps)) < 1e-7 * scale, (b, k)
            dv = np.eye(12)[k] * eps
            up = ks.cable_tension(g[None], (v + dv)[None], s[None])[0][0, 1]
            down = ks.cable_tension(g[None], (v - dv)[None], s[None])[0][0, 1]
            assert abs(by_rate[b, k] - (up - down) / (2 * eps)) < 1e-7 * scale, (b, k)


def test_tension_sensor_coupling_against_central_differences_3d():
    """A damped cable of three elements between offset points of two bodies turned by random rotations and
    moving (random rates), its tension fed back through y = −0.4 N + 0.03 N² on a load on b (row z): the
    coupling entries of K and C by every free coordinate and rate against −central differences of the
    output (the first element's ends: body a's six, the inner node's three; measured 5.0e-11 (K) and
    1.5e-10 (C) of the largest entry), and the output against the probe's value in Python (1e-12)."""
    from scipy.spatial.transform import Rotation

    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    text = CABLED.replace("quantity: length", "quantity: tension").replace(
        '"-40*(L - 1.2) + 3*(L - 1.2)**2"', '"-0.4*L + 0.03*L**2"').replace(
        "rhoA: 0.1, elements: 3}", "rhoA: 0.1, elements: 3, damping: 7.0, rest_length: 0.6}")
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, state, scene = prepared.assembler, prepared.state.copy(), prepared.scene
    model = assembler.model
    random = np.random.default_rng(5)
    for name in ("a", "b"):
        node = model.body_node[name]
        state.T[node] = Rotation.from_rotvec(random.normal(size=3) * 0.5).as_matrix()
        state.x[node] += random.normal(size=3) * 0.05
    state.v[:] = random.normal(size=state.v.shape) * 0.3
    state.w[:] = random.normal(size=state.w.shape) * 0.3
    slot = scene.controller_outputs.index("ctl")

    def output(at):
        assembler.evaluate(at, matrices=False)
        return scene.controller_outputs.values[slot]

    def with_rates(step):
        moving = state.copy()
        for node, dofs in enumerate(model.node_dofs):
            for p, d in enumerate(dofs):
                if d < model.n_dofs:
                    (moving.v if p < 3 else moving.w)[node, p % 3] += step[d]
        return moving

    assembler.evaluate(state, matrices=True)
    control, buffers = assembler.control, assembler.native().buffers
    row = int(model.node_dofs[model.body_node["b"], 2])
    K, C = np.zeros(model.n_dofs), np.zeros(model.n_dofs)
    for k, c, r, col in zip(buffers["coupling_stiffness"], buffers["coupling_damping"], control.coupling_rows,
                            control.coupling_cols):
        if r == row and col < model.n_dofs:
            K[col] += k
            C[col] += c
    e, unit = 1e-6, np.eye(model.n_dofs)
    by_coordinate = np.array([(output(assembler.advance(state, e * u)) - output(assembler.advance(state, -e * u)))
                              / (2 * e) for u in unit])
    by_rate = np.array([(output(with_rates(e * u)) - output(with_rates(-e * u))) / (2 * e) for u in unit])
    assert np.max(np.abs(K + by_coordinate)) < 1e-8 * np.max(np.abs(K))
    assert np.max(np.abs(C + by_rate)) < 1e-8 * np.max(np.abs(C))
    assert np.count_nonzero(K) == 9 and np.count_nonzero(C) == 9  # body a's six, the inner node's three
    tension = ProbeSet(assembler, assembler.initial_state()).values(state.copy())[0]
    assert tension > 0.0
    assert abs(output(state) - (-0.4 * tension + 0.03 * tension ** 2)) < 1e-12


def test_tension_feedback_on_a_guided_mass_cli_planar(tmp_path):
    """m s̈ = −(1 + kp)(k (1 − L0 + s) + c ṡ) + kp N_ref from rest, the cable taut throughout: s against
    the closed form (measured 2.4e-5 of its 0.15 swing at dt 0.002; 9.5e-5, 2.4e-5, 5.9e-6 at dt 0.004,
    0.002, 0.001: second order), the probe T against the law (8.9e-15),
    and Newton in at most two iterations a step (measured 1.97: the coupling's K and C exact)."""
    completed, out = latdyn_run(tmp_path, held())
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    k = EA / REST
    target = KP * N_REF / (1 + KP) / k - (1 - REST)
    expected = oscillator(p["t"], (1 + KP) * k, (1 + KP) * DAMPING, MASS, target)
    assert np.max(np.abs(p["s"] - expected)) < 3e-5
    assert np.max(np.abs(p["T"] - (k * (1 - REST + p["s"]) + DAMPING * p["v"]))) < 1e-12
    assert np.min(p["T"]) > 0.0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


def test_tension_feedback_off_axis_api_3d():
    """The cart slides on the skew axis a = [0, 1, 1]/√2 with the anchor off it, so ℓ(s) = |p0 + s a − A|
    and the cable pulls along e: m s̈ = −N e·a + y, y = −kp (N − N_ref), N = k (ℓ − L0) + c ℓ̇,
    ℓ̇ = (e·a) ṡ. s against solve_ivp (DOP853, rtol 1e-11; measured 2.3e-5 of its 0.54 swing at dt 0.002),
    Newton in at most two iterations a step (measured 1.94)."""
    from scipy.integrate import solve_ivp

    anchor = AT + np.array([-0.6, -0.5, 0.3])
    scene = latdyn.load_scene(yaml.safe_load(held(axis=SKEW, anchor=anchor)))
    result = latdyn.run(scene)
    k = EA / REST

    def rhs(t, x):
        d = AT + x[0] * SKEW - anchor
        ell = np.linalg.norm(d)
        along = d @ SKEW / ell
        N = k * (ell - REST) + DAMPING * along * x[1]
        return [x[1], (-N * along - KP * (N - N_REF)) / MASS]

    reference = solve_ivp(rhs, (0, 1.0), [0.0, 0.0], t_eval=result.t, rtol=1e-11, atol=1e-13, method="DOP853")
    assert np.max(np.abs(result.probes["s"] - reference.y[0])) < 3e-5
    assert np.ptp(result.probes["s"]) > 0.05 and np.min(result.probes["T"]) > 0.0
    assert result.summary["newton_iterations"] <= 2 * result.summary["steps"]


def test_tension_closed_loop_is_open_loop_plus_bkc():
    """Static output feedback on the tension through the force "ctl + u", y = −kp (T − ref), planar and on
    the skew axis with the anchor off it: A = A_ol + B K C with K = −kp, C the open loop's output T
    (its damper's column too): measured 2.8e-11 (planar) and 9.8e-11 (skew) of the largest entry, the
    linear model's own differences."""
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [u], outputs: [T]}}"
    for axis, anchor in (((1.0, 0.0, 0.0), None), (SKEW, AT + np.array([-0.6, -0.5, 0.3]))):
        closed = linear_model_of(held(axis=axis, anchor=anchor, force="ctl + u", solve=modes))
        opened = linear_model_of(held(axis=axis, anchor=anchor, force="u", output="0", solve=modes))
        expected = opened["A"] + opened["B"] @ np.array([[-KP]]) @ opened["C"]
        assert np.max(np.abs(closed["A"] - expected)) <= 1e-10 * np.max(np.abs(expected))
        assert np.count_nonzero(opened["C"]) == 2  # the tension by s (the spring) and by ṡ (the damper)


def test_a_sampled_controller_holds_the_tension_the_probe_records(tmp_path):
    """A sampled controller y = T at 50 Hz beside the continuous tension feedback: at each sample instant
    its held output is the probe T's value there (measured 0.0 at 21 instants: the same C sensor)."""
    text = held(sampled='  hold: {output: "T", rate: 50}', solve="{t_end: 0.4, dt: 0.002}",
                probes="    held: {controller: hold}")
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    at_samples = np.isclose(np.round(p["t"] * 50), p["t"] * 50, atol=1e-9)
    assert np.count_nonzero(at_samples) >= 20
    assert np.max(np.abs(p["held"][at_samples] - p["T"][at_samples])) <= 1e-12 * np.max(np.abs(p["T"]))


def test_sensitivities_through_a_tension_read_by_a_controller_with_states_are_refused(tmp_path):
    """Exit 2 naming solve.sensitivities: a controller with states would need the tension's derivative along δq in
    its states' step (a stateless reader is differentiated, by its gain and the cable's own values:
    tests/test_sensitivities_in_loop_controller_reads.py)."""
    text = held(output="-kp*(T - ref) + I").replace("inputs: {kp: 3.0, ref: 10.0, u: 0.0}",
                                                    f"parameters: {{kp: 3.0, ref: 10.0, EA: {EA}}}")
    text = text.replace("solve: {t_end: 1.0, dt: 0.002}", "solve: {t_end: 0.1, dt: 0.002, sensitivities: [kp, EA]}")
    text = text.replace(f"EA: {EA}, damping", 'EA: "EA", damping').replace('"-kp*(T - ref) + I"}',
                                                                          '"-kp*(T - ref) + I", states: {I: "0.1*T"}}')
    assert "states: {I:" in text
    completed, _ = latdyn_run(tmp_path, text)
    assert completed.returncode == 2, completed.stderr
    assert "solve.sensitivities" in completed.stderr and "with states that reads a force" in completed.stderr
    assert "Traceback" not in completed.stderr


LINKED = """
inputs: {u: 0.0}
controllers:
  ctl: {output: "OUTPUT"}
sections:
  s: {EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0, 0], mass: 2.0, inertia: [0.1, 0.1, 0.1]}
  anchor: {at: [1.0, -1.0, 0.3], fixed: true}
beams:
  arm: {from: hub, to: tip, section: s, rigid: true, start: {hinge: {axis: [0, 0.6, 0.8], torque: "TORQUE"}}}
cables:
  tie: {from: tip, to: anchor, EA: 200.0, damping: 1.0, rest_length: 0.9}
solve: SOLVE
output:
  probes:
    th: {hinge: arm.start, quantity: angle}
    T: {cable: tie, quantity: tension}
"""


def test_tension_feedback_through_a_rigid_link_and_slack_phases():
    """A rigid arm on a skew hinge held by a damped cable, its hinge driven by y = −0.05 N: the coupling goes
    through the rigid link's reduction onto θ. The run passes through slack phases (N = 0, the sensor's
    gradient 0) in at most 1.5 Newton iterations a step (measured 1.17), and the linear model at the
    start, taut, has A = A_ol + B K C with K = −0.05 (measured 1.5e-12 of the largest entry)."""
    def text(output, torque, solve):
        return LINKED.replace("OUTPUT", output).replace("TORQUE", torque).replace("SOLVE", solve)

    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text("-0.05*T", "ctl", "{t_end: 1.0, dt: 0.002}"))))
    assert np.min(result.probes["T"]) == 0.0 and np.max(result.probes["T"]) > 10.0
    assert result.summary["newton_iterations"] <= 1.5 * result.summary["steps"]
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [u], outputs: [T]}}"
    closed = linear_model_of(text("-0.05*T", "ctl + u", modes))
    opened = linear_model_of(text("0", "u", modes))
    expected = opened["A"] + opened["B"] @ np.array([[-0.05]]) @ opened["C"]
    assert np.max(np.abs(closed["A"] - expected)) <= 1e-10 * np.max(np.abs(expected))
    assert np.max(np.abs(closed["A"] - opened["A"])) > 1e-2 * np.max(np.abs(opened["A"]))
