"""What a continuous controller may read and where it may act (SCENE.md ``controllers``; docs/control.md):
a guide's slide and rate as sensors, and a controller inside an expression a y + b of a guide force,
a hinge torque or a load component.

Exact references: a guided mass m (a body on a prismatic joint) under a PD on its slide,
m s̈ = a (−kp (s − ref) − kd ṡ) + b, is a damped oscillator about s* = ref + b/(a kp) with the closed
form below; a rigid hub J θ̈ = a y + b − c θ̇ likewise. The closed loop's linear model against
A_ol + B K C of the open loop (static output feedback, K = a [−kp, −kd]). Planar (axis x, CLI) and
genuinely 3D (axis [0, 1, 1]/√2, API)."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns
from test_controllers import linear_model_of

GUIDED = """
inputs: {{kp: 40.0, kd: 8.0, ref: 1.0, u: 0.0}}
controllers:
{controllers}
bodies:
  cart: {{at: [0.3, -0.2, 0.1], mass: 2.0, inertia: [1, 1, 1], guide: {{axis: {axis}, force: "{force}"}}}}
solve: {solve}
output:
  probes:
    x: {{guide: cart, quantity: position}}
    v: {{guide: cart, quantity: rate}}
{probes}
"""
PD = '  ctl: {output: "-kp*(x - ref) - kd*v"}'
PLANAR, SPATIAL = "[1, 0, 0]", "[0, 0.7071067811865476, 0.7071067811865476]"


def guided(force: str, *, axis: str = PLANAR, controllers: str = PD, solve: str = "{t_end: 1.5, dt: 0.004}",
           probes: str = "") -> str:
    return GUIDED.format(force=force, axis=axis, controllers=controllers, solve=solve, probes=probes)


def oscillator(t, stiffness, damping, mass, target):
    """x(t) of mass ẍ = −stiffness (x − target) − damping ẋ from rest at 0 (underdamped)."""
    wn, zeta = math.sqrt(stiffness / mass), damping / (2 * math.sqrt(stiffness * mass))
    wd = wn * math.sqrt(1 - zeta ** 2)
    return target * (1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t)))


def test_pd_on_a_guided_mass_cli_planar(tmp_path):
    """A PD on a guide's slide and rate probes, driving the guide force inside an expression
    2 y + 0.1: 2 s̈ = 2 (−40 (s − 1) − 8 ṡ) + 0.1 against the closed form (generalized-α's O(h²);
    measured 3.4e-5 at dt = 0.004); the derivatives exact: at most two Newton iterations a step."""
    completed, out = latdyn_run(tmp_path, guided("2*ctl + 0.1", probes="    y: {controller: ctl}"))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    exact = oscillator(p["t"], 80.0, 16.0, 2.0, 1.0 + 0.1 / 80.0)
    assert np.max(np.abs(p["x"] - exact)) < 4e-5
    assert np.max(np.abs(p["y"] - (-40 * (p["x"] - 1) - 8 * p["v"]))) < 1e-9
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


def test_pd_on_a_guided_mass_api_3d():
    """The same loop on a skew guide (axis [0, 1, 1]/√2) through the API, the force the name alone."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(guided("ctl", axis=SPATIAL))))
    assert np.max(np.abs(result.probes["x"] - oscillator(result.t, 40.0, 8.0, 2.0, 1.0))) < 4e-5


def test_guide_sensor_closed_loop_is_open_loop_plus_bkc():
    """Static output feedback on [s, ṡ] through the force 2 y + u, planar and 3D: the closed loop's
    A = A_ol + B K C with K = 2 [−kp, −kd] (B the input u's column of the open loop), to round-off."""
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [u], outputs: [x, v]}}"
    for axis in (PLANAR, SPATIAL):
        closed = linear_model_of(guided("2*ctl + u", axis=axis, solve=modes))
        opened = linear_model_of(guided("u", axis=axis, solve=modes, controllers='  other: {output: "0"}'))
        expected = opened["A"] + opened["B"] @ np.array([[-80.0, -16.0]]) @ opened["C"]
        assert np.max(np.abs(closed["A"] - expected)) <= 1e-10 * np.max(np.abs(expected))
        assert np.max(np.abs(closed["B"] - opened["B"])) <= 1e-12 * np.max(np.abs(opened["B"]))


HUB = """
inputs: {{kp: 40.0, kd: 8.0}}
controllers:
  ctl: {{output: "-kp*(th - 1) - kd*om"}}
sections:
  s: {{EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [0.5, 0, 0], mass: 4.0}}
beams:
  arm: {{from: hub, to: tip, section: s, rigid: true,
        start: {{hinge: {{axis: [0, 0.7071067811865476, 0.7071067811865476], torque: "{torque}"}}}}}}
solve: {{t_end: 1.5, dt: 0.004}}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
    om: {{hinge: arm.start, quantity: rate}}
"""


def test_controller_inside_a_hinge_torque_expression_3d():
    """torque: "2*ctl + 0.1 - 0.5*theta_dot" on a skew hinge (J = 1): θ̈ = −80 (θ − θ*) − 16.5 θ̇,
    θ* = 1 + 0.1/80 (measured 5.7e-5 at dt = 0.004, 1.4e-5 at 0.002: generalized-α's O(h²)); the hinge law's own θ̇ derivative and the
    coupling 2 ∂y/∂(θ, θ̇) both in Newton's matrix: at most two iterations a step."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(HUB.format(torque="2*ctl + 0.1 - 0.5*theta_dot"))))
    assert np.max(np.abs(result.probes["th"] - oscillator(result.t, 80.0, 16.5, 1.0, 1.0 + 0.1 / 80.0))) < 6e-5
    assert result.summary["newton_iterations"] <= 2 * result.summary["steps"]


FREE_BODY = """
inputs: {{kp: 30.0, kd: 6.0}}
controllers:
  ctl: {{output: "-kp*z - kd*w"}}
bodies:
  b: {{at: [0.2, 0.4, -0.3], mass: 1.5, inertia: [0.2, 0.3, 0.4]}}
loads:
  - {{at: b, force: [0, 0, "3*ctl + 0.6"]}}
solve: {solve}
output:
  probes:
    z: {{point: b, quantity: displacement, component: z}}
    w: {{point: b, quantity: velocity, component: z}}
"""


def test_controller_inside_a_load_component():
    """A load component "3*ctl + 0.6" on a free body, the controller a PD on its own z: 1.5 z̈ =
    −90 z − 18 ż + 0.6 against the closed form (a law of time, read again after the outputs: measured
    3.1e-7 of 0.0067 at dt = 0.004); at most two Newton iterations a step."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(FREE_BODY.format(solve="{t_end: 1.5, dt: 0.004}"))))
    assert np.max(np.abs(result.probes["z"] - oscillator(result.t, 90.0, 18.0, 1.5, 0.6 / 90.0))) < 1e-6
    assert result.summary["newton_iterations"] <= 2 * result.summary["steps"]


def test_static_equilibrium_through_an_expression_is_ramped_with_the_loads():
    """A static path of the guided mass under the force 2 y + 0.1: the expression is a load, ramped
    with λ (its coupling λ a ∂y/∂s); λ (2 (−40 (s − 1)) + 0.1) = 0 at every λ > 0: s = 1 + 0.1/80 on
    every row, exact (measured 0), planar and 3D, one Newton iteration a row (linear, exact matrix)."""
    for axis in (PLANAR, SPATIAL):
        static = latdyn.run(latdyn.load_scene(yaml.safe_load(guided("2*ctl + 0.1", axis=axis,
                                                                     solve="{analysis: static, steps: 4}"))))
        assert np.max(np.abs(static.probes["x"][1:] - (1 + 0.1 / 80))) < 1e-13
        assert static.summary["newton_iterations"] <= 5


# ----------------------------------------------------------------------------- a controller reading another
CHAIN = """
inputs: {{kd: 8.0, ref: 1.0}}
controllers:
{controllers}
sections:
  s: {{EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [0.5, 0, 0], mass: 4.0}}
beams:
  arm: {{from: hub, to: tip, section: s, rigid: true, start: {{hinge: {{axis: {axis}, torque: "{torque}"}}}}}}
solve: {solve}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
    om: {{hinge: arm.start, quantity: rate}}
    y: {{controller: ctl}}
"""
HINGE_PLANAR, HINGE_SPATIAL = "[0, 0, 1]", "[0, 0.7071067811865476, 0.7071067811865476]"
TWO_LEVELS = """  a: {output: "-20*(th - ref)"}
  b: {output: "0.5*a"}
  ctl: {output: "4*b - kd*om"}"""


def chain(controllers=TWO_LEVELS, *, torque="ctl", axis=HINGE_PLANAR, solve="{t_end: 1.5, dt: 0.004}") -> str:
    return CHAIN.format(controllers=controllers, torque=torque, axis=axis, solve=solve)


def test_a_controller_reading_earlier_ones_cli_planar(tmp_path):
    """ctl = 4 b − kd θ̇, b = 0.5 a, a = −20 (θ − 1): the PD θ̈ = −40 (θ − 1) − 8 θ̇ (J = 1) against the
    closed form (measured 3.4e-5 at dt = 0.004, as the PD written in one output); the chain rule's
    coupling entries exact: at most two Newton iterations a step."""
    completed, out = latdyn_run(tmp_path, chain())
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    assert np.max(np.abs(p["th"] - oscillator(p["t"], 40.0, 8.0, 1.0, 1.0))) < 4e-5
    assert np.max(np.abs(p["y"] - (-40 * (p["th"] - 1) - 8 * p["om"]))) < 1e-9
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


def test_a_nonlinear_chain_closed_loop_is_open_loop_plus_bkc_3d():
    """A nonlinear chain a = −20 sin(θ − ref), ctl = 2 a + a²/100 − kd θ̇ inside the torque 0.5 ctl + u,
    linearised at rest (θ = 0): K = 0.5 [(2 + 2a/100)(−20 cos 1), −kd] with a = 20 sin 1, and B of the input
    ref through the chain, 0.5 (2 + 2a/100)(20 cos 1) × B of u: A = A_ol + B K C to round-off, planar and 3D."""
    controllers = '  a: {output: "-20*sin(th - ref)"}\n  ctl: {output: "2*a + a*a/100 - kd*om"}'
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [u, ref], outputs: [th, om]}}"
    a = 20 * math.sin(1.0)
    slope = 2 + 2 * a / 100
    for axis in (HINGE_PLANAR, HINGE_SPATIAL):
        closed = linear_model_of(chain(controllers, torque="0.5*ctl + u", axis=axis, solve=modes).replace(
            "inputs: {kd", "inputs: {u: 0.0, kd"))
        opened = linear_model_of(chain('  ctl: {output: "0"}', torque="u", axis=axis, solve=modes).replace(
            "inputs: {kd", "inputs: {u: 0.0, kd"))
        K = 0.5 * np.array([[slope * -20 * math.cos(1.0), -8.0]])
        expected = opened["A"] + opened["B"][:, :1] @ K @ opened["C"]
        assert np.max(np.abs(closed["A"] - expected)) <= 1e-10 * np.max(np.abs(expected))
        B_ref = 0.5 * slope * 20 * math.cos(1.0) * opened["B"][:, 0]
        assert np.max(np.abs(closed["B"][:, 1] - B_ref)) <= 1e-12 * np.max(np.abs(B_ref))


def test_a_chain_with_states_is_refused():
    """States in a chain of continuous controllers are not built: refused at the reader's output key."""
    from latdyn.errors import SceneError

    controllers = '  a: {output: "-20*th - S", states: {S: "th"}}\n  ctl: {output: "a - kd*om"}'
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(chain(controllers))))
    assert "controllers.ctl.output" in str(refused.value) and "with states" in str(refused.value)


# ----------------------------------------------------------------------------- a point offset from its node
OFFSET = """
inputs: {{kp: 40.0, kd: 8.0, ref: 1.0}}
controllers:
  ctl: {{output: "-kp*(asin({scale}*yp/0.8) - ref) - kd*om"}}
sections:
  s: {{EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}}
  stub: {{EA: 1.0e4, EIy: 100, EIz: 100, GJ: 100, rhoA: 0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
  plate: {{at: [0.5, 0, 0], mass: 4.0}}
beams:
  arm: {{from: hub, to: plate, section: s, rigid: true, start: {{hinge: {{axis: {axis}, torque: "ctl"}}}}}}
  stub: {{from: {{body: plate, offset: [0.3, 0, 0]}}, to: [1.2, 0, 0], section: stub, elements: 1}}
solve: {solve}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
    om: {{hinge: arm.start, quantity: rate}}
    yp: {{point: stub.start, quantity: {quantity}, component: y}}
"""


def offset_scene(axis=HINGE_PLANAR, quantity="displacement", solve="{t_end: 1.5, dt: 0.004}") -> str:
    scale = "1" if axis == HINGE_PLANAR else "sqrt(2)"
    return OFFSET.format(axis=axis, scale=scale, quantity=quantity, solve=solve)


def test_a_point_offset_from_its_node_cli_planar(tmp_path):
    """The y of a point 0.3 past the plate's node (0.8 from the hinge: y = 0.8 sin θ) fed back as
    asin(y/0.8) = θ: the loop is the PD θ̈ = −40 (θ − 1) − 8 θ̇ exactly, whatever the angle; against its
    closed form (measured 3.4e-5 at dt = 0.004) in at most two Newton iterations a step (the sensor's
    gradient by the node's rotation, Jᵀ e_y from the generated point-load kernel, exact)."""
    completed, out = latdyn_run(tmp_path, offset_scene())
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    assert np.max(np.abs(p["th"] - oscillator(p["t"], 40.0, 8.0, 1.0, 1.0))) < 4e-5
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


def test_a_point_in_a_body_s_axes_cli(tmp_path):
    """The same offset point's y in the axes of the (fixed) hub body, `frame: hub`: the PD's closed form
    again (measured 3.4e-5), through the CLI."""
    completed, out = latdyn_run(tmp_path, offset_scene().replace("quantity: displacement, component: y",
                                                                 "quantity: displacement, frame: hub, component: y"))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    assert np.max(np.abs(p["th"] - oscillator(p["t"], 40.0, 8.0, 1.0, 1.0))) < 4e-5
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


def test_a_point_offset_from_its_node_api_3d():
    """The same on the skew hinge (axis [0, 1, 1]/√2: y = 0.8 sin θ/√2), the position probe."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(offset_scene(HINGE_SPATIAL, "position"))))
    assert np.max(np.abs(result.probes["th"] - oscillator(result.t, 40.0, 8.0, 1.0, 1.0))) < 4e-5
    assert result.summary["newton_iterations"] <= 2 * result.summary["steps"]


def test_a_point_offset_from_its_node_closed_loop_is_open_loop_plus_bkc():
    """Linearised at rest the loop is u = −kp (y √s/0.8) − kd θ̇: A = A_ol + B K C on the outputs [yp, om]
    (C by central differences of the probes, independent of the sensor's gradient), planar and 3D."""
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [arm.start], outputs: [yp, om]}}"
    for axis, scale in ((HINGE_PLANAR, 1.0), (HINGE_SPATIAL, math.sqrt(2))):
        closed = linear_model_of(offset_scene(axis, solve=modes))
        opened = linear_model_of(offset_scene(axis, solve=modes).replace('torque: "ctl"', 'torque: "0"'))
        K = np.array([[-40.0 * scale / 0.8, -8.0]])
        expected = opened["A"] + opened["B"] @ K @ opened["C"]
        assert np.max(np.abs(closed["A"] - expected)) <= 1e-9 * np.max(np.abs(expected))


FREE_WITH_OFFSET = """
controllers:
  a: {output: "-20*sin(yp) + 3*zp - 2*wp*wp"}
  ctl: {output: "2*a + a*a/100 - 4*xq"}
sections:
  s: {EA: 1.0e4, EIy: 50.0, EIz: 80.0, GJ: 40.0, rhoA: 0.5}
bodies:
  b: {at: [0.2, 0.1, 0.0], mass: 2.0, inertia: [0.1, 0.2, 0.3]}
beams:
  stub: {from: {body: b, offset: [0.3, 0.1, -0.2]}, to: [1.5, 0.4, 0.3], section: s, elements: 1}
loads:
  - {at: b, force: [0, 0, "0.5*ctl + 1"]}
solve: {t_end: 0.1, dt: 0.01}
output:
  probes:
    yp: {point: stub.start, quantity: displacement, component: y}
    zp: {point: stub.start, quantity: position, component: z}
    xq: {point: stub.end, quantity: position, component: x}
    wp: {point: stub.start, quantity: velocity, component: z}
"""


def test_coupling_entries_against_central_differences_3d():
    """At a random moving 3D state (the body turned by a random rotation, displaced, moving), the
    evaluation's coupling entries of a load "0.5*ctl + 1" (row z of the body: ∂r/∂q and ∂r/∂v, the
    load's part of the residual −F) by every free coordinate (K) and rate (C) against −0.5 × central
    differences of the controller's output: a chain ctl(a, xq), a(yp, zp, wp) reading an offset point's
    displacement, position and velocity (their gradients by the body's rotation and rates from the
    point-load kernel) and the free end of a beam (measured 8.8e-12 of the largest entry of K, 8.3e-11 of C)."""
    from scipy.spatial.transform import Rotation

    from latdyn.assembly.assembler import pack, unpack_free
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(yaml.safe_load(FREE_WITH_OFFSET)))
    assembler, state, scene = prepared.assembler, prepared.state.copy(), prepared.scene
    model = assembler.model
    node = model.body_node["b"]
    random = np.random.default_rng(7)
    state.T[node] = Rotation.from_rotvec(random.normal(size=3) * 0.6).as_matrix()
    state.x[node] += random.normal(size=3) * 0.1
    state.v[node], state.w[node] = random.normal(size=3), random.normal(size=3)
    slot = scene.controller_outputs.index("ctl")

    def output(step=None, rates=None):
        moved = assembler.advance(state, step) if step is not None else state.copy()
        if rates is not None:
            unpack_free(model, pack(model, state.v, state.w, state.theta_dot)[:model.n_dofs] + rates,
                        moved.v, moved.w, moved.theta_dot)
        assembler.evaluate(moved, matrices=False)
        return scene.controller_outputs.values[slot]

    assembler.evaluate(state, matrices=True)
    control, buffers = assembler.control, assembler.native().buffers
    row = int(model.node_dofs[node, 2])
    exact = {}
    for name in ("coupling_stiffness", "coupling_damping"):
        exact[name] = np.zeros(model.n_dofs)
        for value, r, c in zip(buffers[name], control.coupling_rows, control.coupling_cols):
            if r == row and c < model.n_dofs:
                exact[name][c] += value
    e = 1e-6
    units = np.eye(model.n_dofs)
    by_coordinate = np.array([(output(e * u) - output(-e * u)) / (2 * e) for u in units])
    by_rate = np.array([(output(rates=e * u) - output(rates=-e * u)) / (2 * e) for u in units])
    # ∂r/∂q and ∂r/∂v of the residual, whose load part is −F = −(0.5 ctl + 1) on the row
    K, C = exact["coupling_stiffness"], exact["coupling_damping"]
    assert np.max(np.abs(K + 0.5 * by_coordinate)) < 1e-8 * np.max(np.abs(K))
    assert np.max(np.abs(C + 0.5 * by_rate)) < 1e-8 * np.max(np.abs(C))
    assert np.count_nonzero(K) == 6  # the body's y, z and rotations (yp, zp, wp) and the beam end's x (xq)
    assert np.count_nonzero(C) == 3  # the body's z rate and the rates about x and y (wp)


def test_a_controller_reads_an_earlier_one_through_its_probe():
    """A probe {controller: a} read by name is a's output: the chain a = −40 (θ − ref), ctl = ua − kd θ̇
    (ua the probe) is the PD (measured 3.4e-5, as the chain by name), and B of ref through it is kp × B
    of the torque (to 1e-12)."""
    controllers = '  a: {output: "-40*(th - ref)"}\n  ctl: {output: "ua - kd*om"}'
    text = chain(controllers).replace("    y: {controller: ctl}", "    y: {controller: ctl}\n    ua: {controller: a}")
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert np.max(np.abs(result.probes["th"] - oscillator(result.t, 40.0, 8.0, 1.0, 1.0))) < 4e-5
    assert np.max(np.abs(result.probes["ua"] - (-40 * (result.probes["th"] - 1)))) < 1e-12
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [arm.start, ref], outputs: [th]}}"
    B = linear_model_of(chain(controllers, solve=modes).replace(
        "    y: {controller: ctl}", "    y: {controller: ctl}\n    ua: {controller: a}"))["B"]
    assert np.max(np.abs(B[:, 1] - 40.0 * B[:, 0])) <= 1e-12 * np.max(np.abs(B[:, 1]))


BODY_AXES = """
controllers:
  ctl: {output: "-30*sin(rb) + 2*rb*rb - 5*db"}
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
    rb: {point: arm.end, quantity: position, frame: a, component: z}
    db: {point: b, quantity: displacement, frame: a, component: x}
"""


def test_body_axes_sensor_against_central_differences_3d():
    """A point's position and displacement in the axes of another body (rb: the offset end of a beam on
    body b in body a's axes; db: body b's reference point), a and b turned by random rotations and
    displaced: the coupling entries of a load "0.5*ctl" on a (row y) by every free coordinate against
    −0.5 × central differences of the output (the point's node's and the body's twelve columns;
    measured 2.9e-10 of the largest entry, the differences' own truncation error with e = 1e-6); the
    output equals the one from the probes' values computed in Python (1e-12)."""
    from scipy.spatial.transform import Rotation

    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    prepared = prepare(latdyn.load_scene(yaml.safe_load(BODY_AXES)))
    assembler, state, scene = prepared.assembler, prepared.state.copy(), prepared.scene
    model = assembler.model
    random = np.random.default_rng(11)
    for name in ("a", "b"):
        node = model.body_node[name]
        state.T[node] = Rotation.from_rotvec(random.normal(size=3) * 0.5).as_matrix()
        state.x[node] += random.normal(size=3) * 0.05
    slot = scene.controller_outputs.index("ctl")

    def output(step):
        assembler.evaluate(assembler.advance(state, step), matrices=False)
        return scene.controller_outputs.values[slot]

    assembler.evaluate(state, matrices=True)
    control, buffers = assembler.control, assembler.native().buffers
    row = int(model.node_dofs[model.body_node["a"], 1])
    K = np.zeros(model.n_dofs)
    for value, r, c in zip(buffers["coupling_stiffness"], control.coupling_rows, control.coupling_cols):
        if r == row and c < model.n_dofs:
            K[c] += value
    e = 1e-6
    by_coordinate = np.array([(output(e * u) - output(-e * u)) / (2 * e) for u in np.eye(model.n_dofs)])
    assert np.max(np.abs(K + 0.5 * by_coordinate)) < 1e-8 * np.max(np.abs(K))
    assert np.count_nonzero(K) == 12  # both bodies' six coordinates
    # the value (and a displacement's origin) as the probes compute it, in Python
    probes = ProbeSet(assembler, assembler.initial_state())
    values = dict(zip(probes.names, probes.values(state.copy())))
    assembler.evaluate(state, matrices=False)
    y = scene.controller_outputs.values[slot]
    assert abs(y - (-30 * math.sin(values["rb"]) + 2 * values["rb"] ** 2 - 5 * values["db"])) < 1e-12


CABLED = """
controllers:
  ctl: {output: "-40*(L - 1.2) + 3*(L - 1.2)**2"}
sections:
  s: {EA: 1.0e4, EIy: 50.0, EIz: 80.0, GJ: 40.0, rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  a: {at: [1, 0, 0], mass: 2.0, inertia: [0.1, 0.2, 0.3]}
  b: {at: [1.5, 0.8, 0.2], mass: 1.0, inertia: [0.2, 0.1, 0.3]}
beams:
  post: {from: base, to: a, section: s, elements: 1}
cables:
  tether: {from: {body: a, offset: [0.1, 0.2, 0]}, to: {body: b, offset: [-0.2, 0.1, 0.3]}, EA: 100.0,
           rhoA: 0.1, elements: 3}
loads:
  - {at: b, force: [0, 0, "ctl"]}
solve: {t_end: 0.1, dt: 0.01}
output:
  probes:
    L: {cable: tether, quantity: length}
"""


def test_cable_length_sensor_against_central_differences_3d():
    """A cable of three elements (inner nodes of its own) between offset points of two bodies turned by
    random rotations, its length fed back: the coupling entries of a load on b (row z) by every free
    coordinate against −central differences of the output (both bodies' six coordinates and the inner
    nodes' translations; measured 9.8e-11 of the largest entry), and the output against the probe's
    value (1e-12)."""
    from scipy.spatial.transform import Rotation

    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    prepared = prepare(latdyn.load_scene(yaml.safe_load(CABLED)))
    assembler, state, scene = prepared.assembler, prepared.state.copy(), prepared.scene
    model = assembler.model
    random = np.random.default_rng(5)
    for name in ("a", "b"):
        node = model.body_node[name]
        state.T[node] = Rotation.from_rotvec(random.normal(size=3) * 0.5).as_matrix()
        state.x[node] += random.normal(size=3) * 0.05
    slot = scene.controller_outputs.index("ctl")

    def output(step):
        assembler.evaluate(assembler.advance(state, step), matrices=False)
        return scene.controller_outputs.values[slot]

    assembler.evaluate(state, matrices=True)
    control, buffers = assembler.control, assembler.native().buffers
    row = int(model.node_dofs[model.body_node["b"], 2])
    K = np.zeros(model.n_dofs)
    for value, r, c in zip(buffers["coupling_stiffness"], control.coupling_rows, control.coupling_cols):
        if r == row and c < model.n_dofs:
            K[c] += value
    e = 1e-6
    by_coordinate = np.array([(output(e * u) - output(-e * u)) / (2 * e) for u in np.eye(model.n_dofs)])
    assert np.max(np.abs(K + by_coordinate)) < 1e-8 * np.max(np.abs(K))
    assert np.count_nonzero(K) == 18  # both bodies' six coordinates, the two inner nodes' three
    probes = ProbeSet(assembler, assembler.initial_state())
    length = probes.values(state.copy())[0]
    assembler.evaluate(state, matrices=False)
    assert abs(scene.controller_outputs.values[slot] - (-40 * (length - 1.2) + 3 * (length - 1.2) ** 2)) < 1e-12


def test_pd_on_a_cable_length_cli(tmp_path):
    """A guided mass at x = 1 (axis x) tied to the origin by a slack cable (rest length 5: it never pulls),
    its length L = 1 + s fed back: 2 s̈ = −40 (L − 2) − 8 ṡ against the PD's closed form about s = 1
    (measured 2.1e-5 at dt = 0.004, two Newton iterations a step), through the CLI."""
    text = guided("ctl", controllers='  ctl: {output: "-kp*(L - 1 - ref) - kd*v"}').replace(
        "bodies:", "cables:\n  tie: {from: anchor, to: cart, EA: 50.0, rest_length: 5.0}\n"
        "bodies:\n  anchor: {at: [0, 0, 0], fixed: true}").replace(
        "at: [0.3, -0.2, 0.1]", "at: [1, 0, 0]") + "    L: {cable: tie, quantity: length}\n"
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    assert np.max(np.abs(p["x"] - oscillator(p["t"], 40.0, 8.0, 2.0, 1.0))) < 4e-5
    assert np.max(np.abs(p["L"] - (1 + p["x"]))) < 1e-12
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


@pytest.mark.parametrize("probe, says", [
    ("{guide: b, quantity: force}", "it latches"),
    ("{energy: kinetic}", "energy probe"),
    ("{momentum: linear, component: x}", "momentum probe"),
    ("{point: b, quantity: position, component: norm}", "is not one"),
], ids=["guide reaction", "energy", "momentum", "a norm"])
def test_what_a_continuous_controller_may_not_read_is_refused(probe, says):
    """Sensors not built (docs/control.md "Not built yet") are refused at the controller's output key."""
    from latdyn.errors import SceneError

    text = CABLED.replace("    L: {cable: tether, quantity: length}", f"    L: {probe}")
    if "guide" in probe:
        text = text.replace("b: {at: [1.5, 0.8, 0.2], mass: 1.0, inertia: [0.2, 0.1, 0.3]}",
                            "b: {at: [1.5, 0.8, 0.2], mass: 1.0, inertia: [0.2, 0.1, 0.3], "
                            "guide: {axis: [1, 0, 0], lock_at: 0.1}}")
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert "controllers.ctl.output" in str(refused.value) and says in str(refused.value), str(refused.value)


def test_a_refused_sensor_through_the_cli(tmp_path):
    completed, _ = latdyn_run(tmp_path, CABLED.replace("{cable: tether, quantity: length}", "{energy: kinetic}"))
    assert completed.returncode == 2
    assert "controllers.ctl.output" in completed.stderr and "energy" in completed.stderr
    assert "Traceback" not in completed.stderr


def test_a_chain_through_a_saturated_controller_against_an_independent_integration():
    """a = clip(−20 (θ − 1), ±3) read by ctl = a − 8 θ̇ on the hub (J = 1): θ against scipy's solve_ivp
    (DOP853, rtol 1e-10) of θ̈ = clip(−20 (θ − 1), −3, 3) − 8 θ̇ (the chain's derivative through a at its
    limit is 0: measured 4.2e-7 at dt = 0.002, 1.1 Newton iterations a step)."""
    from scipy.integrate import solve_ivp

    controllers = '  a: {output: "-20*(th - ref)", limits: [-3, 3]}\n  ctl: {output: "a - kd*om"}'
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(chain(controllers, solve="{t_end: 2.0, dt: 0.002}"))))

    def rhs(t, x):
        return [x[1], min(max(-20 * (x[0] - 1), -3.0), 3.0) - 8 * x[1]]

    reference = solve_ivp(rhs, (0, 2), [0.0, 0.0], t_eval=result.t, rtol=1e-10, atol=1e-12, method="DOP853")
    assert np.max(np.abs(result.probes["th"] - reference.y[0])) < 2e-6
    assert np.any(-20 * (result.probes["th"] - 1) > 3)  # a was at its limit (until θ = 0.85)


def test_cable_length_closed_loop_is_open_loop_plus_bkc():
    """The guided mass tied by the slack cable, force "ctl + u" with ctl = −kp (L − 1 − ref) − kd ṡ:
    A = A_ol + B K C on the outputs [L, v] with K = [−kp, −kd] (C of L by central differences of the
    probe, independent of the sensor's gradient; measured 7.8e-11 of the largest entry)."""
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [u], outputs: [L, v]}}"

    def scene(force, controllers):
        return guided(force, controllers=controllers, solve=modes).replace(
            "bodies:", "cables:\n  tie: {from: anchor, to: cart, EA: 50.0, rest_length: 5.0}\n"
            "bodies:\n  anchor: {at: [0, 0, 0], fixed: true}").replace(
            "at: [0.3, -0.2, 0.1]", "at: [1, 0, 0]") + "    L: {cable: tie, quantity: length}\n"

    closed = linear_model_of(scene("ctl + u", '  ctl: {output: "-kp*(L - 1 - ref) - kd*v"}'))
    opened = linear_model_of(scene("u", '  ctl: {output: "0"}'))
    expected = opened["A"] + opened["B"] @ np.array([[-40.0, -8.0]]) @ opened["C"]
    assert np.max(np.abs(closed["A"] - expected)) <= 1e-9 * np.max(np.abs(expected))
