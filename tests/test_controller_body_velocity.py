"""A continuous controller that reads a point's velocity in a body's axes (SCENE.md ``output.probes``
``{point: P, quantity: velocity, frame: BODY, component: x|y|z}``: relative to the body, in its axes;
``controllers``; docs/control.md): sensor kind 13 of csrc/evaluate.c, s = b_c · (ṗ − v_b − ω_b × (p − x_b)).

Exact references: a cart on a fixed guide (axis a through p0) and a body turning at the constant rate Ω
about the axis k through the origin, the cart pushed by y = −kd s_x, s_x its velocity relative to the
turning body along the body's x axis,

    m s̈ = −kd (R(t) e_x) · (a ṡ − Ω k × (p0 + s a)),    R(t) = exp(Ω t k̂),

a linear time-varying ODE integrated by ``solve_ivp`` to 1e-12: in the plane (k = z, a = x; CLI) and on
skew axes (API). The coupling entries against central differences at a random moving 3D state.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import latdyn
from cli_runs import latdyn_run, probe_columns

OMEGA, KD, MASS = 2.0, 3.0, 1.5
TURNING = """
controllers:
  ctl: {{output: "-{kd}*vr"}}
bodies:
  frame: {{at: [0, 0, 0], motion: {{rotation: {{axis: {k}, angle: "{omega}*t"}}}}}}
  cart: {{at: {p0}, mass: {m}, inertia: [1, 1, 1], guide: {{axis: {a}, force: "ctl"}}}}
solve: {{t_end: 1.5, dt: 0.002}}
output:
  probes:
    s: {{guide: cart, quantity: position}}
    vr: {{point: cart, quantity: velocity, frame: frame, component: x}}
"""


def turning(k, a, p0) -> str:
    return TURNING.format(kd=KD, k=list(map(float, k)), omega=OMEGA, p0=list(map(float, p0)), m=MASS,
                          a=list(map(float, a)))


def reference(t, k, a, p0):
    """s(t) and the sensor s_x(t) of the module docstring's ODE (solve_ivp, DOP853, rtol 1e-12)."""
    k, a, p0 = (np.asarray(v, float) for v in (k, a, p0))
    k, a = k / np.linalg.norm(k), a / np.linalg.norm(a)

    def sensor(time, s, rate):
        axis = Rotation.from_rotvec(OMEGA * time * k).as_matrix()[:, 0]
        return axis @ (a * rate - OMEGA * np.cross(k, p0 + s * a))

    solution = solve_ivp(lambda time, x: [x[1], -KD * sensor(time, x[0], x[1]) / MASS], (0, t[-1]), [0.0, 0.0],
                         t_eval=t, rtol=1e-12, atol=1e-14, method="DOP853")
    return solution.y[0], np.array([sensor(time, s, v) for time, s, v in zip(t, *solution.y)])


def test_velocity_in_a_turning_frame_cli_planar(tmp_path):
    """k = z, a = x, p0 = (0.2, 0.5, 0): the slide against the reference (measured 1.6e-6 of its 0.92 swing
    at dt 0.002), the probe vr against the reference's sensor (3.7e-6 of 0.82), Newton in at most two
    iterations a step (measured 1.07)."""
    k, a, p0 = (0, 0, 1), (1, 0, 0), (0.2, 0.5, 0.0)
    completed, out = latdyn_run(tmp_path, turning(k, a, p0))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    s, sensed = reference(p["t"], k, a, p0)
    assert np.ptp(p["s"]) > 0.3
    assert np.max(np.abs(p["s"] - s)) < 1e-5
    assert np.max(np.abs(p["vr"] - sensed)) < 1e-4
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


def test_velocity_in_a_turning_frame_api_3d():
    """k = [1, 2, 2]/3, a = [0, 0.6, 0.8], p0 = (0.3, −0.4, 0.5): as the planar one (measured 3.9e-6 of its
    1.23 swing at dt 0.002, the sensor 2.8e-6 of 2.9), Newton in at most two iterations a step (measured
    1.42)."""
    k, a, p0 = (1 / 3, 2 / 3, 2 / 3), (0.0, 0.6, 0.8), (0.3, -0.4, 0.5)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(turning(k, a, p0))))
    s, sensed = reference(result.t, k, a, p0)
    assert np.ptp(result.probes["s"]) > 0.1
    assert np.max(np.abs(result.probes["s"] - s)) < 1e-5
    assert np.max(np.abs(result.probes["vr"] - sensed)) < 1e-4
    assert result.summary["newton_iterations"] <= 2 * result.summary["steps"]


MOVING = """
controllers:
  ctl: {output: "-3*sin(vb) + 2*vb*vb"}
sections:
  s: {EA: 1.0e4, EIy: 50.0, EIz: 80.0, GJ: 40.0, rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  a: {at: [1, 0, 0], mass: 2.0, inertia: [0.1, 0.2, 0.3]}
  b: {at: [1.5, 0.8, 0.2], mass: 1.0, inertia: [0.2, 0.1, 0.3]}
beams:
  post: {from: base, to: a, section: s, elements: 1}
  arm: {from: {body: a, offset: [0.1, 0.2, 0]}, to: {body: b, offset: [-0.2, 0.1, 0.3]}, section: s, elements: 1}
loads:
  - {at: a, force: [0, "0.5*ctl", 0]}
solve: {t_end: 0.1, dt: 0.01}
output:
  probes:
    vb: {point: arm.end, quantity: velocity, frame: a, component: COMPONENT}
"""


@pytest.mark.parametrize("component", ["x", "y", "z"])
def test_body_velocity_coupling_against_central_differences_3d(component):
    """The velocity of the offset end of a beam on body b relative to body a, in a's axes, a and b turned
    by random rotations, displaced and moving (random rates): the coupling entries of K and C of a load
    "0.5*ctl" on a (row y) by every free coordinate and rate against −0.5 × central differences of the
    output (the point's node's and the body's six columns of each; measured 1.5e-10, 6.3e-11, 1.2e-10 (K)
    and 1.3e-10, 9.5e-11, 1.4e-10 (C) of the largest entry for x, y, z), and the output against the
    probe's value in Python (1e-12)."""
    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    prepared = prepare(latdyn.load_scene(yaml.safe_load(MOVING.replace("COMPONENT", component))))
    assembler, state, scene = prepared.assembler, prepared.state.copy(), prepared.scene
    model = assembler.model
    random = np.random.default_rng(17)
    for name in ("a", "b"):
        node = model.body_node[name]
        state.T[node] = Rotation.from_rotvec(random.normal(size=3) * 0.5).as_matrix()
        state.x[node] += random.normal(size=3) * 0.05
    state.v[:] = random.normal(size=state.v.shape)
    state.w[:] = random.normal(size=state.w.shape)
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
    row = int(model.node_dofs[model.body_node["a"], 1])
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
    assert np.max(np.abs(K + 0.5 * by_coordinate)) < 1e-8 * np.max(np.abs(K))
    assert np.max(np.abs(C + 0.5 * by_rate)) < 1e-8 * np.max(np.abs(C))
    assert np.count_nonzero(K) == 12 and np.count_nonzero(C) == 12  # both bodies' six
    velocity = ProbeSet(assembler, assembler.initial_state()).values(state.copy())[0]
    assert abs(output(state) - (-3 * np.sin(velocity) + 2 * velocity ** 2)) < 1e-12
