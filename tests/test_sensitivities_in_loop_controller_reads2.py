"""A controller reading a free joint's torque whose own laws a parameter moves, in the sensitivities' loop of steps
(issue 34 item 2): the force's ∂F/∂p enters the controller's slope through ∂f/∂s (ControllerTerms.sensed_force_slopes
on the Python path; csrc/sensitivity_loop.c ``controller_parameter_forces`` with the joint's row of the hinge laws'
∂r/∂p, the generated hinge_force's, as ``hinge_parameter_forces`` left it: latdyn/analyses/sensitivities_in_loop.py
``SensitivityLoop._sensed_force_slopes``). The reader's output is compiled (derivative_laws.ControllerPartials), its
∂f/∂s the compiled law's on both paths. Each scene is tests/test_sensitivities_in_loop_controller_reads.py's 3D arm
whose skew hinge's torque a clipped controller reads; the loop's sensitivities are the per-step Python path's (the
private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, and they agree with Richardson-extrapolated central
differences. On a model with rigid links too: the gimbal's PD on a force between a dependent and a free node and on a
rigid ring's hinge torque. A cable's tension whose laws a parameter moves keeps the Python path; a section force's
takes the loop (tests/test_sensitivities_in_loop_controller_reads.py, tests/test_sensitivities_in_loop_states_more.py)."""
from __future__ import annotations

import pytest

import latdyn

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_in_loop_controller_reads import ARM_TORQUE, TORQUE_K, _agree, _scene
from tests.test_linked_cables import LINKED_CABLES
from tests.test_sensitivities_in_loop_linked_controllers import POINT_PD
from tests.test_sensitivities_in_loop_state_laws import _run, _same

#: the read hinge's damping, its applied torque (a law of t) and its rest angle by parameters, beside the gain
TORQUE_LAWS = (ARM_TORQUE.replace("Kt: 0.4}", "Kt: 0.4, c0: 0.2, T: 1.5, a0: 0.1}")
               .replace("stiffness: 30.0, damping: 0.2}",
                        'stiffness: 30.0, damping: "c0", torque: "T*sin(4*t)", rest_angle: "a0"}')
               .replace("sensitivities: [E, F, Kt]", "sensitivities: [c0, T, a0, Kt]"))
#: the hinge's stiffness 30 E (E in the section values too) read by an unclipped controller without parameters
TORQUE_K_ONLY = (TORQUE_K.replace('"Kt*tq + 0.2*hinge", limits: [-6, 6]}', '"0.4*tq + 0.2*hinge"}')
                 .replace("sensitivities: [E, F, Kt]", "sensitivities: [E]"))
#: tests/test_sensitivities_in_loop_linked_controllers.py's 3D gimbal of two rigid rings whose PD also reads the
#: flexible boom's first element's axial force (between the inner ring, a rigid link's body: a dependent node, and a
#: free node) and the outer ring's hinge's torque, whose stiffness k1 is a parameter
LINKED_FORCES = (POINT_PD.replace('"Kp*(ref - outer_y) - Kd*vo + 0.5*Kp*iz"',
                                  '"Kp*(ref - outer_y) - Kd*vo + 0.5*Kp*iz + 0.002*ax + 0.05*tq1"')
                 .replace("    a1: {hinge", '    ax: {element: "boom.element[0]", quantity: axial_force}\n'
                                            "    tq1: {hinge: gim1.start, quantity: torque}\n    a1: {hinge")
                 .replace("sensitivities: [Kp, Kd, ref, k1, m, EI]", "sensitivities: [Kp, k1, m]"))
assert "tq1: {" in LINKED_FORCES and "sensitivities: [Kp, k1, m]" in LINKED_FORCES
#: tests/test_linked_cables.py's 3D guided body B and rigid link B–D with three cables: a clipped controller on the
#: hinge of the link reads a cable's tension (to D, a dependent node), another's length (A to D) and the guide's force,
#: whose stiffness k is a parameter; the cables go slack and taut again (6 changes)
LINKED_CABLE_FORCES = (
    LINKED_CABLES.replace("sections:", "parameters: {Kt: 0.002, k: 7.0}\nsections:", 1)
    .replace("guide: {on: A,", "guide: {'on': A,")
    .replace("stiffness: 7.0, damping: 0.3}", 'stiffness: "k", damping: 0.3}')
    .replace("start: {hinge: {axis: [0, 1, 1]}}",
             'start: {hinge: {axis: [0, 1, 1], stiffness: 2.0, damping: 0.1, torque: "ctl"}}')
    .replace("loads:", 'controllers:\n  ctl: {output: "Kt*pull + 0.5*span + 0.02*Fg", limits: [-3, 3]}\nloads:')
    .replace("solve: {t_end: 0.1, dt: 0.01}",
             "solve: {analysis: transient, t_end: 0.3, dt: 0.005, sensitivities: [Kt, k]}\n"
             "output:\n  every: 0.01\n  probes:\n    pull: {cable: linked, quantity: tension}\n"
             "    span: {cable: across, quantity: length}\n    Fg: {guide: B, quantity: force}\n"
             "    s: {guide: B, quantity: position}\n    dz: {point: D, quantity: position, component: z}\n"))
assert "sensitivities: [Kt, k]" in LINKED_CABLE_FORCES and "'on': A" in LINKED_CABLE_FORCES
assert 'rest_angle: "a0"' in TORQUE_LAWS and '"0.4*tq + 0.2*hinge"}' in TORQUE_K_ONLY


@pytest.mark.parametrize("text", [TORQUE_K, TORQUE_LAWS, TORQUE_K_ONLY],
                         ids=["hinge stiffness", "damping, torque of t, rest angle", "no partials, no limits"])
def test_a_parameter_in_the_read_joints_laws_takes_every_step_in_the_loop(text, monkeypatch):
    """Every step in the loop of steps (60 of 60); the Python path's sensitivities to the bit, every column nonzero."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] == 60
    _same(native, python)


@pytest.mark.parametrize("text, name", [(TORQUE_K, "E"), (TORQUE_LAWS, "a0")], ids=["stiffness", "rest angle"])
def test_the_loops_sensitivities_agree_with_differences(text, name):
    """By the parameter in the read hinge's laws, every probe over the rows, against Richardson-extrapolated central
    differences (steps 1e-4 and 5e-5 of the value): within 1e-6 of each probe's largest (measured 5.6e-8 by E, 1.6e-8
    by a0; by c0 3.8e-8, T 3.1e-8, Kt 3.0e-8, and E without partials 5.6e-8, not tests)."""
    result = latdyn.run(_scene(text, name))
    assert result.summary["sensitivity_steps_in_loop"] == 60
    _agree(result, text, name)


def test_the_cli_writes_the_python_paths_files(tmp_path):
    """``latdyn run`` on the scene of the hinge's damping, torque and rest angle takes the loop; the same command with
    the switch off (a process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and
    summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, TORQUE_LAWS)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] == summary["steps"] == 60
    the_loop_off_writes_the_same(tmp_path, out)


def test_force_sensors_on_a_linked_model_take_every_step_in_the_loop(monkeypatch):
    """The gimbal's PD on an element's axial force and a rigid ring's hinge torque (k1 in that hinge's law): every
    step in the loop (30 of 30), the Python path's sensitivities to the bit; by k1 against Richardson differences
    within 1e-6 of each probe's largest (measured 2.1e-7; by m 3.6e-7; by Kp 9e-7, 7e-8 at steps 1e-3 and 5e-4 of the
    value: the differences' round-off)."""
    native, python = _run(LINKED_FORCES, monkeypatch, True), _run(LINKED_FORCES, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] == 30
    _same(native, python)
    _agree(latdyn.run(_scene(LINKED_FORCES, "k1")), LINKED_FORCES, "k1")


def test_cables_and_a_guides_force_read_on_a_linked_model_take_the_smooth_steps_in_the_loop(monkeypatch):
    """The guided body's controller on two cables and the guide's force (k in that guide's law): the cables' changes
    and the steps near them from Python, the other steps in the loop (measured 54 of 77), the Python path's
    sensitivities to the bit (against Richardson differences by k 1.3e-8, by Kt 4.7e-8, measured, not a test)."""
    native, python = _run(LINKED_CABLE_FORCES, monkeypatch, True), _run(LINKED_CABLE_FORCES, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == ["slack", "slack", "slack", "taut", "slack", "taut"]
    assert native.summary["time_loop"] == "compiled"
    assert 50 <= native.summary["sensitivity_steps_in_loop"] < native.summary["steps"]
    _same(native, python)
