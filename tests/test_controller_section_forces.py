"""A continuous controller that reads an element's section force (SCENE.md ``controllers``: "A continuous
controller may read point, hinge, guide, cable and element probes"; docs/control.md): a strain gauge.

The sensor is the probe's value, the mid-element section force [N, T, M_y, M_z] of the strain-energy kernel
(a planar model's turned moments back in the beam's axes), with its exact derivative by the element's
fourteen coordinates, ∂S/∂q = (∂S/∂Ψ) B, from the generated ``beam_section_forces_D_q`` (codegen/derivation.py).
Exact references:

- a massless bar (EA, length L) with a tip mass m pulled by y = F0 − g N: N = EA u/L exactly (a straight
  bar: Ψ's α = ℓ − L), so m ü = −(1 + g)(EA/L) u + F0, undamped, in closed form (planar, CLI);
- a massless shaft on a skew axis with a tip body of isotropic inertia J twisted by a moment y = M0 − g T
  about the axis: T = GJ φ/L exactly at any angle (the log map's twist of a pure rotation), so
  J φ̈ = −(1 + g)(GJ/L) φ + M0, through 1.6 rad (genuinely 3D, API);
- the closed loop's linear model A = A_ol + B K C of a flexible cantilever whose base hinge is driven by its
  root moment (planar and 3D).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

import element_states as es
import latdyn
from cli_runs import latdyn_run, probe_columns
from latdyn.model.kernels import load_kernels
from test_controller_sensors import oscillator
from test_controllers import linear_model_of

BAR = """
inputs: {{g: 2.0, F0: 30.0}}
controllers:
  ctl: {{output: "F0 - g*N"}}
sections:
  s: {{EA: 400.0, EIy: 10.0, EIz: 10.0, GJ: 10.0, rhoA: 0}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [1, 0, 0], mass: 2.0, inertia: [1, 1, 1]}}
beams:
  bar: {{from: base, to: tip, section: s, elements: 1}}
loads:
  - {{at: tip, force: ["ctl", 0, 0]}}
solve: {solve}
output:
  probes:
    N: {{element: "bar.element[0]", quantity: axial_force}}
    u: {{point: tip, quantity: displacement, component: x}}
"""

AXIS = np.array([1.0, 2.0, 2.0]) / 3.0
SHAFT = f"""
inputs: {{g: 1.5, M0: 4.0}}
controllers:
  ctl: {{output: "M0 - g*T"}}
sections:
  s: {{EA: 1.0e4, EIy: 50.0, EIz: 80.0, GJ: 3.0, rhoA: 0}}
bodies:
  base: {{at: [0.2, -0.1, 0.3], fixed: true}}
  tip: {{at: {[float(x) for x in np.array([0.2, -0.1, 0.3]) + 1.5 * AXIS]}, mass: 1.0, inertia: [0.4, 0.4, 0.4]}}
beams:
  shaft: {{from: base, to: tip, section: s, elements: 1}}
loads:
  - {{at: tip, moment: ["{AXIS[0]}*ctl", "{AXIS[1]}*ctl", "{AXIS[2]}*ctl"]}}
solve: {{t_end: 1.5, dt: 0.002}}
output:
  probes:
    T: {{element: "shaft.element[0]", quantity: torque}}
"""

CANTILEVER = """
inputs: {{kp: 0.5, u: 0.0}}
controllers:
  ctl: {{output: "{output}"}}
sections:
  s: {{EA: 1.0e4, EIy: 60.0, EIz: 40.0, GJ: 30.0, rhoA: 0.6, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
beams:
  arm: {{from: hub, to: {tip}, section: s, elements: 3,
        start: {{hinge: {{axis: {axis}, stiffness: 20.0, torque: "{torque}"}}}}}}
solve: {{analysis: modes, count: 1, linear_model: {{inputs: [u], outputs: [M]}}}}
output:
  probes:
    M: {{element: "arm.element[0]", quantity: {moment}}}
"""


def test_section_forces_kernel_against_differences():
    """beam_section_forces_D_q (default variant): its section forces are beam_strain_energy's (measured
    4.2e-16), its ∂S/∂q the central differences of them (rotations through the exponential map, as the
    configuration update; measured 3.2e-10 of the Jacobian's norm), in the three regimes of elastic
    rotation."""
    kernels = load_kernels(backend="auto", variant="default")
    H = 1e-6
    for regime in es.REGIMES.values():
        rng = np.random.default_rng(7)
        for s in [es.random_state(rng, deformation=regime) for _ in range(3)]:
            forces = lambda st: kernels.beam_strain_energy(st.geometry(), st.section[None])[1][0]  # noqa: E731
            values, by_q = kernels.beam_section_forces_D_q(s.geometry(), s.section[None])
            np.testing.assert_allclose(values[0], forces(s), rtol=1e-12, atol=1e-12 * np.abs(forces(s)).max())
            numeric = np.column_stack([(forces(s.moved(H * np.eye(14)[k])) - forces(s.moved(-H * np.eye(14)[k])))
                                       / (2 * H) for k in range(14)])
            error = np.linalg.norm(by_q[0] - numeric) / np.linalg.norm(numeric)
            assert error <= 1e-6, error


@pytest.mark.parametrize("quantity", ["axial_force", "torque", "moment_y", "moment_z"])
def test_section_force_coupling_against_central_differences_3d(quantity):
    """A three-element beam between two bodies turned by random rotations and displaced, the middle element's
    section force fed back through y = 0.3 S + 0.01 S² on a load on b (row z): the coupling entries by every
    free coordinate against −central differences of the output (measured 3.9e-11 (axial force), 1.2e-10
    (torque), 5.2e-11 (moment_y), 6.6e-11 (moment_z) of the largest entry), the output against the probe's
    value in Python (1e-12)."""
    from scipy.spatial.transform import Rotation

    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    text = f"""
controllers:
  ctl: {{output: "0.3*S + 0.01*S**2"}}
sections:
  s: {{EA: 1.0e3, EIy: 50.0, EIz: 80.0, GJ: 40.0, rhoA: 0.5, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  a: {{at: [0, 0, 0], mass: 2.0, inertia: [0.1, 0.2, 0.3]}}
  b: {{at: [1.2, 0.5, 0.3], mass: 1.0, inertia: [0.2, 0.1, 0.3]}}
beams:
  post: {{from: {{body: a, offset: [0.1, 0.0, 0.05]}}, to: b, section: s, elements: 3}}
loads:
  - {{at: b, force: [0, 0, "ctl"]}}
solve: {{t_end: 0.1, dt: 0.01}}
output:
  probes:
    S: {{element: "post.element[1]", quantity: {quantity}}}
"""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, state, scene = prepared.assembler, prepared.state.copy(), prepared.scene
    model = assembler.model
    random = np.random.default_rng(3)
    for node in range(len(model.nodes)):
        state.T[node] = Rotation.from_rotvec(random.normal(size=3) * 0.3).as_matrix()
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
    assert not np.any(buffers["coupling_damping"])
    e = 1e-6
    by_coordinate = np.array([(output(e * u) - output(-e * u)) / (2 * e) for u in np.eye(model.n_dofs)])
    assert np.max(np.abs(K + by_coordinate)) < 1e-8 * np.max(np.abs(K))
    assert np.count_nonzero(K) == 12  # the middle element's two nodes
    section = ProbeSet(assembler, assembler.initial_state()).values(state.copy())[0]
    assert abs(output(np.zeros(model.n_dofs)) - (0.3 * section + 0.01 * section ** 2)) < 1e-12 * max(1.0, abs(section))


@pytest.mark.parametrize("quantity", ["axial_force", "moment_y"])
def test_section_force_coupling_of_a_turned_planar_section(quantity):
    """A planar model in the xz plane (its sections turned a quarter about their axes, β = ±π/2, so that
    the in-plane bending is the kernel's M_z' and the probe's moment_y = cos β M_y' − sin β M_z'), at a
    random in-plane configuration: the coupling entries of a load on b (row z) against −central
    differences of the output (measured 2.3e-11 (axial force and moment_y) of the largest entry), zero outside
    the middle element's columns,
    and the output against the probe's value in Python (1e-12)."""
    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    text = f"""
controllers:
  ctl: {{output: "0.3*S + 0.01*S**2"}}
sections:
  s: {{EA: 1.0e3, EIy: 50.0, EIz: 80.0, GJ: 40.0, rhoA: 0.5, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  a: {{at: [0, 0, 0], mass: 2.0, inertia: [0.1, 0.2, 0.3]}}
  b: {{at: [1.2, 0, 0.5], mass: 1.0, inertia: [0.2, 0.1, 0.3]}}
beams:
  post: {{from: a, to: b, section: s, elements: 3}}
loads:
  - {{at: b, force: [0, 0, "ctl"]}}
solve: {{t_end: 0.1, dt: 0.01}}
output:
  probes:
    S: {{element: "post.element[1]", quantity: {quantity}}}
"""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, state, scene = prepared.assembler, prepared.state.copy(), prepared.scene
    model = assembler.model
    assert assembler.kernels.variant == "default_zx" and np.all(np.abs(np.sin(model.section_turns)) == 1.0)
    state = assembler.advance(state, np.random.default_rng(4).normal(size=model.n_dofs) * 0.05)
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
    element = model.element_dofs[int(model.beam_elements["post"][1])]
    assert not np.any(np.delete(K, element[element < model.n_dofs]))  # the middle element's columns alone
    section = ProbeSet(assembler, assembler.initial_state()).values(state.copy())[0]
    assert abs(section) > 1.0
    assert abs(output(np.zeros(model.n_dofs)) - (0.3 * section + 0.01 * section ** 2)) < 1e-12 * max(1.0, abs(section))


def test_axial_force_feedback_on_a_bar_cli_planar(tmp_path):
    """m ü = −(1 + g)(EA/L) u + F0 from rest (planar: the in-plane variant): u against the closed form
    through the CLI at dt 0.002 and the API at dt 0.001 (measured 1.24e-4 and 3.11e-5 of its 0.05 swing:
    second order, the ratio 4.0), N against EA u/L (measured 0.0), Newton in at most two iterations a step
    (measured 1.99)."""
    completed, out = latdyn_run(tmp_path, BAR.format(solve="{t_end: 1.0, dt: 0.002}"))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    k = 400.0
    coarse = np.max(np.abs(p["u"] - oscillator(p["t"], 3.0 * k, 0.0, 2.0, 30.0 / (3.0 * k))))
    assert coarse < 1.5e-4
    assert np.max(np.abs(p["N"] - k * p["u"])) < 1e-9
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]
    fine = latdyn.run(latdyn.load_scene(yaml.safe_load(BAR.format(solve="{t_end: 1.0, dt: 0.001}"))))
    error = np.max(np.abs(fine.probes["u"] - oscillator(fine.t, 3.0 * k, 0.0, 2.0, 30.0 / (3.0 * k))))
    assert 3.5 < coarse / error < 4.5


def test_torque_feedback_on_a_twisted_shaft_api_3d():
    """J φ̈ = −(1 + g)(GJ/L) φ + M0 from rest on the skew axis [1, 2, 2]/3, through φ = 1.6 rad: the probe
    T against (GJ/L) φ of the closed form (measured 3.4e-5 of its 3.2 swing at dt 0.002), Newton in at
    most two iterations a step (measured 1.92)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(SHAFT)))
    k = 3.0 / 1.5
    phi = oscillator(result.t, 2.5 * k, 0.0, 0.4, 4.0 / (2.5 * k))
    assert np.max(phi) > 1.5
    assert np.max(np.abs(result.probes["T"] - k * phi)) < 1e-4
    assert result.summary["newton_iterations"] <= 2 * result.summary["steps"]


@pytest.mark.parametrize("axis, tip, moment", [
    ("[0, 0, 1]", "[1.2, 0, 0]", "moment_z"),
    ("[0, 0.6, 0.8]", "[1.0, 0.48, -0.36]", "moment_y"),
], ids=["in-plane", "skew"])
def test_root_moment_closed_loop_is_open_loop_plus_bkc(axis, tip, moment):
    """A flexible cantilever (three elements, 19 coordinates: a modes analysis keeps all six of a node)
    whose base hinge is driven by y = −kp M, M the root element's bending moment about the hinge's axis,
    through the torque "ctl + u": A = A_ol + B K C with K = −kp (measured 1.2e-16 in the plane of the
    hinge and 1.4e-12 on the skew hinge, of the largest entry; the loop changes A by 5-7 %)."""
    def scene(output, torque):
        return CANTILEVER.format(output=output, torque=torque, axis=axis, tip=tip, moment=moment)

    closed = linear_model_of(scene("-kp*M", "ctl + u"))
    opened = linear_model_of(scene("0", "u"))
    expected = opened["A"] + opened["B"] @ np.array([[-0.5]]) @ opened["C"]
    assert np.max(np.abs(closed["A"] - expected)) <= 1e-8 * np.max(np.abs(expected))
    assert np.max(np.abs(closed["A"] - opened["A"])) > 1e-3 * np.max(np.abs(opened["A"]))  # the loop acts


def test_sensitivities_through_a_section_force_read_by_a_controller_with_states_are_refused(tmp_path):
    """Exit 2 naming solve.sensitivities: a controller with states would need the section force's derivative along
    δq in its states' step (a stateless reader is differentiated, by its gain and the section's own values:
    tests/test_sensitivities_in_loop_controller_reads.py)."""
    text = BAR.format(solve="{t_end: 0.1, dt: 0.002, sensitivities: [g, EA]}").replace(
        "inputs: {g: 2.0, F0: 30.0}", "parameters: {g: 2.0, F0: 30.0, EA: 400.0}").replace("EA: 400.0,", 'EA: "EA",')
    text = text.replace('ctl: {output: "F0 - g*N"}', 'ctl: {output: "F0 - g*N + I", states: {I: "0.1*N"}}')
    assert "states: {I:" in text
    completed, _ = latdyn_run(tmp_path, text)
    assert completed.returncode == 2, completed.stderr
    assert "solve.sensitivities" in completed.stderr and "with states that reads a force" in completed.stderr
    assert "Traceback" not in completed.stderr


def test_a_sampled_controller_holds_the_section_force_the_probe_records(tmp_path):
    """A sampled controller y = N at 50 Hz beside the continuous feedback on the bar: at each sample instant
    its held output is the probe N's value there (measured 0.0 at 11 instants: the same C sensor)."""
    text = BAR.format(solve="{t_end: 0.2, dt: 0.002}").replace(
        '  ctl: {output: "F0 - g*N"}', '  ctl: {output: "F0 - g*N"}\n  hold: {output: "N", rate: 50}') \
        + "    held: {controller: hold}\n"
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    at_samples = np.isclose(np.round(p["t"] * 50), p["t"] * 50, atol=1e-9)
    assert np.count_nonzero(at_samples) >= 10
    assert np.max(np.abs(p["held"][at_samples] - p["N"][at_samples])) <= 1e-12 * np.max(np.abs(p["N"]))
