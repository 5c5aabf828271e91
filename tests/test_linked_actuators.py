"""Continuous controllers whose actuators are loads on rigidly linked and guided bodies, in a linear
model (latdyn.analyses.linearise): the force of a controller's state on its actuators goes through
the same point path as the inputs' (the generated point_load kernel, and Jᵀ of the links' map at a
dependent node), so that the closed loop's A is the open loop's with B K C and B ∂y/∂S."""
from __future__ import annotations

import numpy as np

from test_controllers import linear_model_of

#: A body B guided along a skew axis on the ground (spring, damper) carrying a rigid link to a body D
#: (hinge with a spring, skew axis): both are dependent nodes. A continuous PI controller reading the
#: slide drives a load at D (three components, gains 0.6, −0.8, 0.5) and a load at B (y, gain 1).
LINKED_PI = """
{controllers}
sections:
  s: {{EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.5}}
bodies:
  B: {{at: [0.3, 0.1, 0.2], mass: 0.7, inertia: [0.01, 0.02, 0.03], com: [0, 0.05, 0],
      guide: {{axis: [1, 2, 2], stiffness: 40.0, damping: 0.5}}}}
  D: {{at: [0.8, -0.3, 0.6], mass: 0.4, inertia: [0.01, 0.01, 0.02]}}
beams:
  l: {{from: B, to: D, section: s, rigid: true, start: {{hinge: {{axis: [0.2, -1, 0.4], stiffness: 9.0}}}}}}
loads:
  - {{at: D, force: ["{x}", "{y}", "{z}"]}}
  - {{at: B, force: [0, "{b}", 0]}}
solve:
  analysis: modes
  count: 2
  linear_model: {{inputs: [D.force.x, D.force.y, D.force.z, B.force.y], outputs: [sB]}}
output:
  probes:
    sB: {{guide: B, quantity: position}}
"""
GAINS = np.array([0.6, -0.8, 0.5, 1.0])


def test_pi_on_loads_at_linked_and_guided_bodies_closed_loop_matrix():
    """3D: with u = −30 s − 12 S, Ṡ = s (s the slide), A of the closed loop is
    [[A_ol + B K C, −12 B g], [C, 0]], K = −30 g, g the actuators' gains, B and C those of the open loop
    (the same scene without the controller; measured 1.6e-16 of the largest entry, 91). The state's column
    is the controller's force through the links' Jᵀ at D and the guide's at B (on main it was zero:
    the actuator's force at a dependent node was dropped)."""
    pi = 'controllers:\n  ctl: {output: "-30*sB - 12*S", states: {S: "sB"}}'
    closed = linear_model_of(LINKED_PI.format(controllers=pi, x="0.6*ctl", y="-0.8*ctl", z="0.5*ctl", b="ctl"))
    opened = linear_model_of(LINKED_PI.format(controllers="", x="0", y="0", z="0", b="0"))
    A_ol, B, C = opened["A"], opened["B"], opened["C"]
    assert A_ol.shape == (4, 4) and np.abs(B[2:]).min() > 0.0  # the slide and the hinge, each input reaches both
    expected = np.block([[A_ol + B @ (-30.0 * GAINS[:, None]) @ C, -12.0 * B @ GAINS[:, None]],
                         [C, np.zeros((1, 1))]])
    assert closed["A"].shape == expected.shape
    assert np.abs(expected[:4, 4]).max() > 1.0  # the state's force on the structure counts
    assert np.max(np.abs(closed["A"] - expected)) <= 1e-12 * np.max(np.abs(expected))


def test_input_forces_at_linked_and_guided_bodies_against_residual_differences():
    """3D, at a displaced state of LINKED_PI with its loads driven by the scene's inputs: the generalized
    force of each input (the columns of F that B condenses: point inputs D.force.x … B.force.y and the
    scene inputs that the loads name) equals −∂r/∂u of the nonlinear residual by central differences
    (step 1e-3; the residual is affine in u: measured 1.1e-13 … 3.9e-13 of the largest); the point and the
    named inputs give the same columns (measured: identical)."""
    import latdyn
    import yaml

    from latdyn.analyses.linearise import _input_forces
    from latdyn.assembly.prepare import prepare

    text = LINKED_PI.format(controllers="inputs: {ux: 0.0, uy: 0.0, uz: 0.0, ub: 0.0}", x="ux", y="uy", z="uz", b="ub")
    raw = yaml.safe_load(text)
    raw["solve"]["linear_model"]["inputs"] += ["ux", "uy", "uz", "ub"]
    prepared = prepare(latdyn.load_scene(raw))
    model, assembler, scene = prepared.model, prepared.assembler, prepared.scene
    state = assembler.advance(prepared.state, np.array([0.05, -0.3]))  # the slide and the hinge moved
    F = _input_forces(model, state, scene.solve.linear_model["inputs"], assembler)
    assert F.shape == (2, 8)
    e = 1e-3
    for j, name in enumerate(["ux", "uy", "uz", "ub"]):
        residual = []
        for value in (e, -e):
            scene.inputs.set(name, value)
            residual.append(assembler.evaluate(state, matrices=False).residual[:model.n_dofs])
        scene.inputs.set(name, 0.0)
        by_differences = -(residual[0] - residual[1]) / (2 * e)
        assert np.abs(by_differences).max() > 0.1
        assert np.abs(F[:, 4 + j] - by_differences).max() <= 1e-9 * np.abs(by_differences).max(), name
        assert np.abs(F[:, j] - F[:, 4 + j]).max() <= 1e-14 * np.abs(F[:, j]).max(), name
