"""A continuous controller that reads a free joint's torque or force (SCENE.md ``{hinge: BEAM.start|end,
quantity: torque}``, ``{guide: NAME, quantity: force}``; ``controllers``; docs/control.md): sensor kind 14
of csrc/evaluate.c, the joint's own law −f(θ, θ̇, t) (spring, damper, applied torque or force, compliant
stops) with −∂f/∂θ (K) and −∂f/∂θ̇ (C) from the generated ``hinge_force`` and the compiled laws.

Exact references (ODEs integrated by ``solve_ivp`` to 1e-12):

- a guided mass on a spring and damper with an applied force F0 sin 3t, the guide's force F = F0 sin 3t − k s
  − c ṡ fed back as a load y = g F on the mass: m s̈ = (1 + g) F (planar, CLI);
- a rigid arm with a tip body on a hinge on a skew axis with a nonlinear spring k (1 + θ²) θ and a damper,
  its torque τ fed back as a moment y = g τ about the hinge's axis on the tip: J θ̈ = (1 + g) τ (3D, API);
- the closed loop's linear model A = A_ol + B K C on the output F;
- what is a reaction (prescribed, latching, rigid stops, friction), a law naming a continuous controller and a
  static path are refused at the controller's output key.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml
from scipy.integrate import solve_ivp

import latdyn
from cli_runs import latdyn_run, probe_columns
from test_controllers import linear_model_of

GUIDED = """
inputs: {{g: 1.5, u: 0.0}}
controllers:
  ctl: {{output: "{output}"}}
bodies:
  cart: {{at: [0.3, -0.2, 0.1], mass: 2.0, inertia: [1, 1, 1],
         guide: {{axis: [1, 0, 0], stiffness: 30.0, damping: 0.8, force: "5*sin(3*t)"{guide}}}}}
loads:
  - {{at: cart, force: ["{load}", 0, 0]}}
solve: {solve}
output:
  probes:
    s: {{guide: cart, quantity: position}}
    v: {{guide: cart, quantity: rate}}
    F: {{guide: cart, quantity: force}}
"""


def guided(output="g*F", load="ctl", guide="", solve="{t_end: 1.5, dt: 0.002}") -> str:
    return GUIDED.format(output=output, load=load, guide=guide, solve=solve)


def test_guide_force_feedback_cli_planar(tmp_path):
    """m s̈ = (1 + g)(F0 sin 3t − k s − c ṡ) from rest: s against solve_ivp (measured 6.5e-6 of its 0.49
    swing at dt 0.002), the probe F against the law (measured 0.0), Newton in at most two iterations a
    step (measured 1.81)."""
    completed, out = latdyn_run(tmp_path, guided())
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)

    def rhs(t, x):
        return [x[1], 2.5 * (5 * math.sin(3 * t) - 30.0 * x[0] - 0.8 * x[1]) / 2.0]

    reference = solve_ivp(rhs, (0, 1.5), [0.0, 0.0], t_eval=p["t"], rtol=1e-12, atol=1e-14, method="DOP853")
    assert np.ptp(p["s"]) > 0.1
    assert np.max(np.abs(p["s"] - reference.y[0])) < 2e-5
    assert np.max(np.abs(p["F"] - (5 * np.sin(3 * p["t"]) - 30.0 * p["s"] - 0.8 * p["v"]))) < 1e-12
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


AXIS = np.array([0.0, 0.6, 0.8])
ARM = f"""
inputs: {{g: 0.8}}
controllers:
  ctl: {{output: "g*tau"}}
sections:
  s: {{EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [0.5, 0, 0], mass: 4.0, inertia: [0.1, 0.1, 0.1]}}
beams:
  arm: {{from: hub, to: tip, section: s, rigid: true,
        start: {{hinge: {{axis: {[float(x) for x in AXIS]}, stiffness: "6*(1 + theta**2)", damping: 0.3, torque: "2*cos(t)"}}}}}}
loads:
  - {{at: tip, moment: ["{AXIS[0]}*ctl", "{AXIS[1]}*ctl", "{AXIS[2]}*ctl"]}}
solve: {{t_end: 2.0, dt: 0.002}}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
    tau: {{hinge: arm.start, quantity: torque}}
"""


def test_hinge_torque_feedback_api_3d():
    """J θ̈ = (1 + g)(2 cos t − 6 (1 + θ²) θ − 0.3 θ̇), J = m r² + I: the arm's radius about the skew axis
    r² = |x − (x·a) a|² = 0.25 (a ⊥ x): θ against solve_ivp (measured 4.7e-6 rad of its 0.78 rad swing at
    dt 0.002), Newton in at most two iterations a step (measured 1.65)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(ARM)))
    J = 4.0 * 0.25 + 0.1

    def rhs(t, x):
        return [x[1], 1.8 * (2 * math.cos(t) - 6 * (1 + x[0] ** 2) * x[0] - 0.3 * x[1]) / J]

    reference = solve_ivp(rhs, (0, 2.0), [0.0, 0.0], t_eval=result.t, rtol=1e-12, atol=1e-14, method="DOP853")
    assert np.ptp(result.probes["th"]) > 0.3
    assert np.max(np.abs(result.probes["th"] - reference.y[0])) < 2e-5
    assert result.summary["newton_iterations"] <= 2 * result.summary["steps"]


def test_guide_force_closed_loop_is_open_loop_plus_bkc():
    """Static output feedback on the guide's force through the load "ctl + u", y = g F: A = A_ol + B K C
    with K = g, C the open loop's output F (by s and ṡ: the spring and the damper): measured 5.9e-18 of the
    largest entry."""
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [u], outputs: [F]}}"
    closed = linear_model_of(guided(load="ctl + u", solve=modes))
    opened = linear_model_of(guided(output="0", load="u", solve=modes))
    expected = opened["A"] + opened["B"] @ np.array([[1.5]]) @ opened["C"]
    assert np.max(np.abs(closed["A"] - expected)) <= 1e-10 * np.max(np.abs(expected))
    assert np.count_nonzero(opened["C"]) >= 2


@pytest.mark.parametrize("guide, says", [
    (", position: \"0.1*t\"", "it is prescribed"),
    (", lock_at: 0.5", "it latches"),
    (", limits: [-1, 1]", "rigid stops"),
    (", friction: {coulomb: 0.1}", "friction"),
], ids=["prescribed", "latch", "rigid stops", "friction"])
def test_a_joint_force_that_is_a_reaction_is_refused(tmp_path, guide, says):
    """Exit 2 at controllers.ctl.output naming why (through the CLI, no traceback)."""
    completed, _ = latdyn_run(tmp_path, guided(guide=guide))
    assert completed.returncode == 2, completed.stderr
    assert "controllers.ctl.output" in completed.stderr and says in completed.stderr, completed.stderr
    assert "Traceback" not in completed.stderr


def test_a_joint_force_driven_by_a_continuous_controller_or_on_a_static_path_is_refused():
    from latdyn.errors import SceneError

    for text, says in ((guided().replace('force: "5*sin(3*t)"', 'force: "other"').replace(
            '  ctl: {output: "g*F"}', '  other: {output: "-2*v"}\n  ctl: {output: "g*F"}'), "'other'"),
                       (guided(solve="{analysis: static, steps: 2}"), "static path")):
        with pytest.raises(SceneError) as refused:
            latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
        assert "controllers.ctl.output" in str(refused.value) and says in str(refused.value), str(refused.value)


def test_sensitivities_through_a_joint_force_read_by_a_controller_with_states_are_refused(tmp_path):
    """Exit 2 naming solve.sensitivities: a controller with states would need the joint force's derivative along δq
    in its states' step (a stateless reader is differentiated, by its gain and the joint's own laws:
    tests/test_sensitivities_in_loop_controller_reads.py)."""
    text = guided().replace("inputs: {g: 1.5, u: 0.0}", "parameters: {g: 1.5, k: 30.0}").replace(
        "solve: {t_end: 1.5, dt: 0.002}", "solve: {t_end: 0.1, dt: 0.002, sensitivities: [g, k]}").replace(
        "stiffness: 30.0", 'stiffness: "k"').replace('ctl: {output: "g*F"}', 'ctl: {output: "g*F + I", states: {I: "F"}}')
    assert "states: {I:" in text
    completed, _ = latdyn_run(tmp_path, text)
    assert completed.returncode == 2, completed.stderr
    assert "solve.sensitivities" in completed.stderr and "with states that reads a force" in completed.stderr
    assert "Traceback" not in completed.stderr


def test_joint_force_coupling_against_central_differences_in_a_compliant_stop():
    """A guide with a nonlinear spring 30 (1 + s²) s, a damper 0.8 + 0.5 ṡ² and a compliant stop at 0.1
    (Hunt–Crossley, k 500, n 1.5, c 2) pressed 0.03 into it and moving at 0.4: the coupling entries of a load
    "ctl" with y = 0.2 F + 0.01 F² on the cart, by s (K) and ṡ (C), against central differences of the
    output (measured 1.9e-10 and 3.0e-11 relative), and the probe against the law by hand (measured 0.0)."""
    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    text = guided(output="0.2*F + 0.01*F**2", guide=", limits: [-0.1, 0.1], contact: {stiffness: 500.0, "
                  "exponent: 1.5, damping: 2.0}").replace("stiffness: 30.0, damping: 0.8",
                                                         'stiffness: "30*(1 + s**2)", damping: "0.8 + 0.5*s_dot**2"')
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, state, scene = prepared.assembler, prepared.state.copy(), prepared.scene
    model = assembler.model
    j = model.hinge_index("cart", "guide")
    dof, row = int(model.hinge_dofs[j]), int(model.node_dofs[model.body_node["cart"], 0])
    state = assembler.advance(state, 0.13 * np.eye(model.n_dofs)[dof])
    state.theta_dot[j] = 0.4
    state.t = 0.3
    slot = scene.controller_outputs.index("ctl")

    def output(slide=0.0, rate=0.0):
        moved = assembler.advance(state, slide * np.eye(model.n_dofs)[dof])
        moved.theta_dot[j] += rate
        assembler.evaluate(moved, matrices=False)
        return scene.controller_outputs.values[slot]

    assembler.evaluate(state, matrices=True)
    control, buffers = assembler.control, assembler.native().buffers
    entries = [(k, c) for k, c, r, col in zip(buffers["coupling_stiffness"], buffers["coupling_damping"],
                                              control.coupling_rows, control.coupling_cols) if r == row and col == dof]
    K, C = sum(k for k, _ in entries), sum(c for _, c in entries)
    e = 1e-6
    by_slide = (output(slide=e) - output(slide=-e)) / (2 * e)
    by_rate = (output(rate=e) - output(rate=-e)) / (2 * e)
    assert abs(K + by_slide) < 1e-8 * abs(K) and abs(C + by_rate) < 1e-8 * abs(C), (K, by_slide, C, by_rate)
    force = ProbeSet(assembler, assembler.initial_state()).values(state.copy())[2]
    s, rate, depth = 0.13, 0.4, 0.03  # the law by hand: applied, spring, damper, Hunt–Crossley stop
    law = 5 * math.sin(0.9) - 30 * (1 + s ** 2) * s - (0.8 + 0.5 * rate ** 2) * rate \
        - (500.0 * depth ** 1.5 + 2.0 * depth ** 1.5 * rate)
    assert abs(force - law) < 1e-12 * abs(law)
    assert abs(output() - (0.2 * force + 0.01 * force ** 2)) < 1e-12 * force ** 2
