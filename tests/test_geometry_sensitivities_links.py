"""Geometry parameters beside rigid links and guides (issue 34; latdyn/analyses/geometry_sensitivities.py
``_linked_refusal``, docs/parameters.md "Geometry parameters").

Taken: a parameter that moves each rigid link and each guided body together with the part it hangs from — a rigid
translation of every linked subtree, or none — while it moves flexible beams' ends: the links' and guides' reference
geometry (o, b, a, a guide's origin, a link's inertia) and so the reduction's J and closure equations are those of p; a
dependent node moves with its root (the state's where the root is free, δX of the root where it is fixed or
prescribed: ``ReferenceGeometry.held``). Each case was refused on 86d57d9 ("geometry sensitivities with rigid links or
guides are not computed yet") and is checked against Richardson-extrapolated central differences of whole runs
(≤ 1e-6 of each probe's largest), through the API and the CLI (to the bit), the loop of steps on and off (to the bit).
A parameter that moves a link's or a guide's own geometry (a ring's offset, a hinge axis) stays refused, naming the
link (hinge points and guide origins: tests/test_geometry_sensitivities_link_geometry.py)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_sensitivities_events import _agree as _event_agree
from tests.test_sensitivities_events import _run as _api_run
from tests.test_sensitivities_guide_energies import _agree
from tests.test_sensitivities_guides import GUIDE_3D
from tests.test_sensitivities_in_loop_controller_reads import ARM_TORQUE
from tests.test_sensitivities_refusals_lifted import PLACED_AXIAL, PLACED_PD
from tests.test_sensitivities_rigid_links import GIMBAL

#: the gimbal of rigid links on skew hinges (spinning at the start) with its fixed base, both rings and the boom's root
#: placed along the skew direction (1, 0.5, −0.3) by X, the boom's tip left where it is: X moves the flexible boom's
#: length and frame, the links' dependent nodes with their fixed root (held: δX at a fixed state)
GIMBAL_PLACED = GIMBAL.replace("parameters: {k1: 6.0,", "parameters: {X: 0.1, k1: 6.0,").replace(
    "base: {at: [0, 0, 0], fixed: true}", 'base: {at: ["X", "0.5*X", "-0.3*X"], fixed: true}').replace(
    "outer: {at: [0.3, 0.1, 0.2],", 'outer: {at: ["0.3 + X", "0.1 + 0.5*X", "0.2 - 0.3*X"],').replace(
    "inner: {at: [0.45, -0.05, 0.35],", 'inner: {at: ["0.45 + X", "-0.05 + 0.5*X", "0.35 - 0.3*X"],').replace(
    "sensitivities: [k1, m, P, EI, rho]", "sensitivities: [X, k1]")
#: the placed gimbal on a base whose translation is prescribed (the links' root prescribed: x = at + translation(t))
GIMBAL_CARRIED = GIMBAL_PLACED.replace('base: {at: ["X", "0.5*X", "-0.3*X"], fixed: true}',
                                       'base: {at: ["X", "0.5*X", "-0.3*X"], motion: {translation: ["0.05*sin(3*t)", 0, '
                                       '"0.02*t*t"]}}')
#: the mass on a skew guide at the tip of a flexible arm under gravity, the tip and the slider on it placed by L (the
#: arm's length; the guide's origin on the tip unmoved): the guided body's root, the tip, is free
GUIDE_PLACED = GUIDE_3D.replace("parameters: {k: 40.0,", "parameters: {L: 1.0, k: 40.0,").replace(
    "tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666],",
    'tip: {at: ["0.6666666666666666*L", "0.3333333333333333*L", "0.6666666666666666*L"],').replace(
    "slider: {at: [0.7, 0.35, 0.7],",
    'slider: {at: ["0.6666666666666666*L + 0.0333333333333333", "0.3333333333333333*L + 0.0166666666666667", '
    '"0.6666666666666666*L + 0.0333333333333333"],').replace("sensitivities: [k, m, EI, rest]", "sensitivities: [L, k]")
for _scene in (GIMBAL_PLACED, GIMBAL_CARRIED, GUIDE_PLACED):
    assert _scene.count('"') >= 6 and "sensitivities: [" in _scene
assert '"0.3 + X"' in GIMBAL_PLACED and "0.02*t*t" in GIMBAL_CARRIED and '"0.6666666666666666*L"' in GUIDE_PLACED


@pytest.mark.parametrize("text, name", [(GIMBAL_PLACED, "X"), (GIMBAL_CARRIED, "X"), (GUIDE_PLACED, "L")],
                         ids=["gimbal-placed", "gimbal-carried", "guide-placed"])
def test_a_geometry_parameter_beside_links_and_guides_agrees_with_richardson(text, name):
    """Refused on 86d57d9. Measured (every probe over the rows, relative to its largest): the placed gimbal 1.6e-8 (the
    rings' velocities 3.6 off while a held root's δX counted in them), on its prescribed base 3.3e-8, the guide placed
    by L 1.4e-9 (the gimbal's tip placed alone by Y, not run here, 9.1e-9)."""
    assert _agree(_api_run(text, name), text, name) <= 1e-6


@pytest.mark.parametrize("text", [GIMBAL_PLACED, GUIDE_PLACED], ids=["gimbal-placed", "guide-placed"])
def test_the_loop_of_steps_gives_the_per_step_paths_sensitivities(text):
    """The runs with the sensitivities' loop of steps on and off: every column, the probe sensitivities, to the bit; the
    loop took every step (30 and 80)."""
    runs = runs_with_the_loop_on_and_off(text)
    assert_same_sensitivities(runs[True], runs[False], nonzero="some", in_loop_but=0)


@pytest.mark.parametrize("name", ["GIMBAL_PLACED", "TORQUE_LATCH", "KNEE_LATCH"])
def test_the_placed_gimbal_through_the_cli_equals_the_api(tmp_path, name):
    """``latdyn run`` of the scene as typed (the placed gimbal; with a torque PD and a latch; the arm's PD of the placed
    knee's displacement with a latch): sensitivities.csv's columns and summary.json's probe and event sensitivities
    those of ``latdyn.run`` on the same text (to the bit)."""
    import json

    text = globals()[name]
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 0, run.stderr
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]
    assert summary.get("event_sensitivities") == api.summary.get("event_sensitivities")
    rows = [line.split(",") for line in (out / "sensitivities.csv").read_text().splitlines()]
    columns = ("tip_x/X", "vo/X", "a2/X", "a1/k1") if name != "KNEE_LATCH" else ("tip_z/X", "kx/X", "hinge/Kp")
    for column in columns:
        at = rows[0].index(column)
        assert np.array_equal([float(row[at]) for row in rows[1:]], api.sensitivities[tuple(column.split("/"))])


#: what stays refused: the inner ring's hinge axis, the whole arm with a spin and a guide (the slider placed alone on
#: the tip, the guide's origin, is taken since: tests/test_geometry_sensitivities_link_geometry.py GUIDE_ORIGIN; the
#: outer ring placed alone, gim1's and gim2's lengths, too: tests/test_geometry_sensitivities_link_length.py OUTER)
@pytest.mark.parametrize("text, expected", [
    (GIMBAL.replace("axis: [1.0, -0.4, 0.3]", 'axis: [1.0, "X", 0.3]').replace(
        "parameters: {k1", "parameters: {X: -0.4, k1").replace("sensitivities: [k1,", "sensitivities: [X, k1,"),
     "rigid link 'gim2'"),
    (GUIDE_PLACED.replace("solve:", "initial_velocity: {angular: [0, 0, 1.0]}\nsolve:"), "initial_velocity.angular"),
], ids=["hinge-axis", "spin-with-guide"])   # the guide's origin: test_geometry_sensitivities_link_geometry
def test_what_moves_a_links_or_guides_geometry_stays_refused(tmp_path, text, expected):
    """Named (the link or the guided body, what moves), through the API (SceneError naming solve.sensitivities) and
    the CLI (exit 2, no traceback)."""
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert refused.value.key == "solve.sensitivities" and expected in str(refused.value), str(refused.value)
    run, _ = latdyn_run(tmp_path, text)
    assert run.returncode == 2 and "solve.sensitivities" in run.stderr and "Traceback" not in run.stderr


#: GIMBAL_PLACED statically under gravity (load control, 3 steps), without its spin and its rate probes
STATIC_PLACED = "\n".join(line for line in GIMBAL_PLACED.replace(
    "solve: {analysis: transient, dt: 0.01, t_end: 0.3, sensitivities: [X, k1]}",
    "gravity: [0, 0, -9.81]\nsolve: {analysis: static, method: load-control, steps: 3, sensitivities: [X, k1]}").replace(
    "initial_velocity: {angular: [0.5, -0.3, 2.0]}\n", "").splitlines()
    if not line.lstrip().startswith(("vo:", "vi:", "r2:"))) + "\n"
assert "method: load-control" in STATIC_PLACED and "angular" not in STATIC_PLACED and "vo:" not in STATIC_PLACED


def test_the_placed_gimbal_under_gravity_agrees_with_richardson_on_a_static_path():
    """Load control: every row's sensitivities by X against Richardson-extrapolated central differences of whole static
    runs (1e-3 and 5e-4 of X), relative to each probe's largest. Measured 2.9e-10 (the first ring's angle)."""
    result = _api_run(STATIC_PLACED, "X")
    central = []
    for step in (1e-4, 5e-5):
        up, down = _api_run(STATIC_PLACED, "X", X=0.1 + step), _api_run(STATIC_PLACED, "X", X=0.1 - step)
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        assert np.abs(result.sensitivities[(probe, "X")] - expected).max() <= 1e-6 * np.abs(expected).max(), probe


#: controllers reading points that a geometry parameter moves at a fixed state: the 3D arm's hinge PD also reading the
#: knee's displacement along x (X places the knee: the displacement's reference moves by δX); the arm's axial-force
#: feedback reading its tip's height instead of the hinge (b's free end: its position is the state's, so its explicit
#: part is nothing); the placed gimbal's inner hinge driven by a PD of the outer ring's height (a node that follows the
#: links from the fixed base: it moves by the base's δX at a fixed state)
PD_KNEE = PLACED_PD.replace('"Kp*(ref - hinge) - Kd*rate + ff*ref"', '"Kp*(ref - hinge) - Kd*rate + ff*ref - 30*kx"').replace(
    "    rate: {hinge: b.start, quantity: rate}\n",
    "    rate: {hinge: b.start, quantity: rate}\n    kx: {point: knee, quantity: displacement, component: x}\n")
AXIAL_TIP = PLACED_AXIAL.replace('"-Ka*ax - 2*hinge"', '"-Ka*ax - 2*tip_z"')
GIMBAL_PD = GIMBAL_PLACED.replace('damping: "c2"}}}', 'damping: "c2", torque: "pd"}}}').replace(
    "solve:", 'controllers:\n  pd: {output: "-3*(outer_y - 0.15) - 0.5*a2"}\nsolve:')
assert "30*kx" in PD_KNEE and "2*tip_z" in AXIAL_TIP and "outer_y - 0.15" in GIMBAL_PD


@pytest.mark.parametrize("text", [PD_KNEE, AXIAL_TIP, GIMBAL_PD], ids=["pd-knee-displacement", "axial-tip-height",
                                                                       "gimbal-pd-ring-height"])
def test_a_controller_reading_a_placed_point_agrees_with_richardson(text):
    """Refused on 86d57d9 ("reading point probes"). The point's ∂s/∂X at a fixed state (its probe's explicit part,
    ReferenceGeometry.point_moves) through ∂f/∂s (ControllerTerms.sensed_force_slopes); the per-step path (the loop of
    steps refuses it, naming the point). Measured: the knee's displacement 2.1e-8, the tip's height 3.7e-9, the gimbal's ring 2.8e-8; without
    the point's ∂s/∂X 15.1 and 0.50 off (the tip's the same: nothing)."""
    result = _api_run(text, "X")
    assert result.summary["sensitivity_steps_in_loop"] == 0
    assert _agree(result, text, "X") <= 1e-6


#: the placed gimbal's inner ring latching at −0.1 rad (t = 0.2558 s)
LATCH_PLACED = GIMBAL_PLACED.replace('damping: "c2"}}}', 'damping: "c2", lock_at: -0.1}}}').replace(
    "t_end: 0.3", "t_end: 0.4")
assert "lock_at: -0.1" in LATCH_PLACED


def test_a_latch_on_the_placed_gimbal_agrees_with_richardson():
    """Refused on 86d57d9. The latch's time and every probe over the rows by X against Richardson-extrapolated central
    differences of whole runs (tests/test_sensitivities_events.py ``_agree``: the event time to 1e-7 relative). Measured
    3.5e-8 (a rigid stop there instead, four impacts, 1.5e-8: not run here)."""
    result = _api_run(LATCH_PLACED, "X")
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert _event_agree(result, LATCH_PLACED, "X") <= 1e-6


#: a free joint's torque as the sensor and a load as the actuator beside a geometry parameter: the placed gimbal's inner
#: hinge driven by a PD of the outer hinge's spring torque (a law of θ: no reference in it); the 3D arm's hinge torque
#: read by a clipped controller that drives a load at the second beam's free end (its offset unmoved), the knee placed
#: by X
GIMBAL_TORQUE = GIMBAL_PLACED.replace('damping: "c2"}}}', 'damping: "c2", torque: "pd"}}}').replace(
    "solve:", 'controllers:\n  pd: {output: "-0.8*tq1 - 0.5*a2"}\nsolve:').replace(
    "    a1: {hinge: gim1.start, quantity: angle}\n",
    "    a1: {hinge: gim1.start, quantity: angle}\n    tq1: {hinge: gim1.start, quantity: torque}\n")
TORQUE_TO_LOAD = ARM_TORQUE.replace("parameters: {E: 1.0,", "parameters: {X: 1.0, E: 1.0,").replace(
    "knee: {at: [1, 0, 0]", "knee: {at: [X, 0, 0]").replace("sensitivities: [E, F, Kt]", "sensitivities: [X, Kt]")
assert "0.8*tq1" in GIMBAL_TORQUE and "at: [X, 0, 0]" in TORQUE_TO_LOAD and "[X, Kt]" in TORQUE_TO_LOAD


@pytest.mark.parametrize("text", [GIMBAL_TORQUE, TORQUE_TO_LOAD], ids=["gimbal-torque-sensor", "torque-to-load"])
def test_a_joint_force_sensor_and_a_load_actuator_beside_geometry(text):
    """Refused on 86d57d9 ("reading hinge probes", "driving loads[2]…"). Against Richardson-extrapolated central
    differences of whole runs (measured 2.1e-8 and 1.9e-8), and the loop of steps (every step) to the bit with the
    per-step path."""
    runs = runs_with_the_loop_on_and_off(text)
    assert_same_sensitivities(runs[True], runs[False], nonzero="each", in_loop_but=0)
    assert _agree(runs[True], text, "X") <= 1e-6


def test_a_load_actuator_at_a_moved_offset_stays_refused(tmp_path):
    """TORQUE_TO_LOAD with its actuated load at the first beam's end, whose offset on the knee X moves (the load's arm
    moves with X and its values are the controller's: not differentiated there), named through the API and the CLI."""
    text = TORQUE_TO_LOAD.replace("a: {from: base, to: knee,", 'a: {from: base, to: {body: knee, offset: [0, 0, "0.05*X"]},')
    text = text.replace('- {at: b.end, force: [0, "0.3*relief"', '- {at: a.end, force: [0, "0.3*relief"')
    assert "0.05*X" in text and 'at: a.end, force: [0, "0.3*relief"' in text
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert refused.value.key == "solve.sensitivities" and "a load at an end whose offset" in str(refused.value)
    run, _ = latdyn_run(tmp_path, text)
    assert run.returncode == 2 and "loads[2]" in run.stderr and "Traceback" not in run.stderr


#: controllers with states beside a geometry parameter, reading joints alone: the placed arm's hinge PI (its integral
#: Z of the angle's error, leaking) and the placed gimbal's inner hinge driven by an integral Q of both hinges' angles
PI_ARM = PLACED_PD.replace('pd: {output: "Kp*(ref - hinge) - Kd*rate + ff*ref"}',
                           'pd: {output: "Kp*(ref - hinge) + ff*ref + 6*Z", states: {Z: "ref - hinge - 0.3*Z"}}')
GIMBAL_INTEGRAL = GIMBAL_PLACED.replace('damping: "c2"}}}', 'damping: "c2", torque: "integ"}}}').replace(
    "solve:", 'controllers:\n  integ: {output: "-2*a2 - 4*Q", states: {Q: "a2 + 0.1*a1"}}\nsolve:')
assert "6*Z" in PI_ARM and "4*Q" in GIMBAL_INTEGRAL


#: the placed arm's hinge driven by a sampled (50 Hz) proportional controller of its angle
SAMPLED_ARM = PLACED_PD.replace('pd: {output: "Kp*(ref - hinge) - Kd*rate + ff*ref"}',
                                'pd: {output: "Kp*(0.4 - hinge)", rate: 50}')
assert "rate: 50}" in SAMPLED_ARM


@pytest.mark.parametrize("text, in_loop", [(PI_ARM, 0), (GIMBAL_INTEGRAL, 30), (SAMPLED_ARM, 60)],
                         ids=["arm-pi", "gimbal-integral", "arm-sampled"])
def test_controller_states_reading_joints_beside_geometry(text, in_loop):
    """Refused on 86d57d9 ("with states or sampled"). Against Richardson-extrapolated central differences of whole runs
    (measured 3.0e-8, 2.2e-8 and 1.4e-8; the placed gimbal's inner hinge under a 40 Hz sampled controller of both
    angles, not run here, 3.1e-8); the loop of steps on and off to the bit (the gimbal's 30 steps and the sampled arm's
    60 in it, the arm's PI on the per-step path on both)."""
    runs = runs_with_the_loop_on_and_off(text)
    assert runs[True].summary["sensitivity_steps_in_loop"] == in_loop
    assert_same_sensitivities(runs[True], runs[False], nonzero="each")
    assert _agree(runs[True], text, "X") <= 1e-6


def test_states_beside_a_controller_reading_a_placed_point_stay_refused():
    """With states, a sensor that holds the reference (a point) is refused, naming the state's controller."""
    text = PD_KNEE.replace('"Kp*(ref - hinge) - Kd*rate + ff*ref - 30*kx"', '"Kp*(ref - hinge) + ff*ref - 30*kx + 6*Z", '
                           'states: {Z: "ref - hinge - 0.3*Z"}')
    assert "6*Z" in text
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert refused.value.key == "solve.sensitivities" and "with states or sampled (pd)" in str(refused.value)


#: events beside controllers and a geometry parameter: the placed gimbal's spring-torque PD with its inner hinge
#: latching at −0.1 rad; the PD reading the placed knee's displacement with the arm's hinge latching at 0.3 rad; the
#: placed gimbal's integral with its inner hinge bouncing twice off a rigid stop at −0.1 rad (e = 0.8)
TORQUE_LATCH = GIMBAL_TORQUE.replace('damping: "c2", torque', 'damping: "c2", lock_at: -0.1, torque').replace(
    "t_end: 0.3", "t_end: 0.4")
KNEE_LATCH = PD_KNEE.replace('stiffness: 2.0, damping: 0.2, torque: "pd"}',
                             'stiffness: 2.0, damping: 0.2, torque: "pd", lock_at: 0.3}')
INTEGRAL_STOP = GIMBAL_INTEGRAL.replace('damping: "c2", torque',
                                        'damping: "c2", limits: [-0.1, 1.0], restitution: 0.8, torque')
assert "lock_at: -0.1" in TORQUE_LATCH and "lock_at: 0.3" in KNEE_LATCH and "restitution: 0.8" in INTEGRAL_STOP


@pytest.mark.parametrize("text, events, in_loop", [(TORQUE_LATCH, ["latch"], 39), (KNEE_LATCH, ["latch"], 0),
                                                   (INTEGRAL_STOP, ["stop", "stop"], 28)],
                         ids=["torque-pd-latch", "knee-pd-latch", "integral-stop"])
def test_controllers_beside_geometry_through_events(text, events, in_loop):
    """Refused on 86d57d9 ("beside events", or rigid links). The probes and the events' times by X against
    Richardson-extrapolated central differences of whole runs (tests/test_sensitivities_events.py ``_agree``): measured
    1.1e-8, 2.7e-8, 3.0e-8; the loop of steps on and off to the bit (its steps but those at and after the events in it,
    the point-reading PD's on the per-step path)."""
    runs = runs_with_the_loop_on_and_off(text)
    assert [e["kind"] for e in runs[True].summary["events"]] == events
    assert runs[True].summary["sensitivity_steps_in_loop"] == in_loop
    assert_same_sensitivities(runs[True], runs[False], nonzero="each")
    assert _event_agree(runs[True], text, "X") <= 1e-6
