"""More continuous controllers with states in the sensitivities' loop of steps (issue 34 item 2; latdyn/analyses/
sensitivities_in_loop.py ``_states_refusal``, csrc/controller_states.c ``controller_state_sensed``): a state reading a
point offset from its node or a point in a body's axes (its value the evaluation's sensor_value, its δs that
sensor's gradient times δq — the C the per-step Python path's ControllerStates._sensed calls too), and a state
reading a prescribed body's position or a point in its axes beside an event (δt is 0 at every step the loop takes,
so the sensors' ∂s/∂t δt is nothing there on either path), states on models with rigid links or guides whose sensors
are not on a rigid link's body or a guided body, and a controller reading a joint's torque whose compliant stops' law a
parameter moves (its ∂F/∂p the joint's row of the hinge laws' and the stops' ∂r/∂p: csrc/sensitivity_loop.c
``joint_law_force_slopes``) or an element's section force whose section values a parameter moves (its ∂S/∂p
csrc/parameter_forces.c ``section_force_slope``, on both paths) or a cable's tension whose laws a parameter moves
(csrc/cable_forces.c ``cable_tension_slope``). The loop's results are the Python path's (the private switch ``SENSITIVITIES_IN_LOOP``
off) to the bit, through the API and the CLI, and agree with Richardson differences."""
from __future__ import annotations

import pytest

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_fuzz_run_findings5 import _rows_against_richardson
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_in_loop_controller_integral import BOOM
from tests.test_sensitivities_in_loop_controller_reads import AXIAL_E, ARM_TORQUE, CABLE_LIMIT
from tests.test_sensitivities_in_loop_linked_controllers import _GAINS, BEAD
from tests.test_sensitivities_in_loop_moving_sensors import BASE_STATE
from tests.test_sensitivities_in_loop_state_laws import _run
from tests.sensitivity_equality import assert_same_sensitivities

#: the 3D boom (tests/test_sensitivities_in_loop_controller_integral.py) whose fore beam ends at a grid point offset
#: from the tip body, its PI's integral also reading that point's height (a point offset from its node)
BOOM_OFFSET = (BOOM.replace("fore: {from: elbow, to: tip,",
                            "fore: {from: elbow, to: {body: tip, offset: [0.05, 0.08, -0.04]},")
               .replace('E: "a*(0.6 - elbow)"', 'E: "a*(0.6 - elbow) + 0.5*(tip_o - 0.45)"')
               .replace("  probes:\n", "  probes:\n    tip_o: {point: fore.end, quantity: position, component: z}\n"))
#: the boom's integral reading the tip's height in the elbow's axes (a point in a body's axes)
BOOM_BODY = (BOOM.replace('E: "a*(0.6 - elbow)"', 'E: "a*(0.6 - elbow) + 0.1*(tip_e - 0.4)"')
             .replace("  probes:\n", "  probes:\n    tip_e: {point: tip, quantity: position, frame: elbow, component: z}\n"))
#: both, and a filter H of the offset point's displacement in the elbow's axes (offset and in a body's axes)
BOOM_BOTH = (BOOM_OFFSET.replace('"Kp*(0.6 - elbow) + Ki*E", states: {E: "a*(0.6 - elbow) + 0.5*(tip_o - 0.45)"}}',
                                 '"Kp*(0.6 - elbow) + Ki*E - 2*H", states: {E: "a*(0.6 - elbow) + 0.5*(tip_o - 0.45)", '
                                 'H: "20*(tip_d - H)"}}')
             .replace("  probes:\n",
                      "  probes:\n    tip_d: {point: fore.end, quantity: displacement, frame: elbow, component: y}\n"))
#: the same clipped at [−0.5, 1.5], HHT-α
BOTH_CLIPPED = (BOOM_BOTH.replace('H: "20*(tip_d - H)"}}', 'H: "20*(tip_d - H)"}, limits: [-0.5, 1.5]}')
                .replace("dt: 0.01,", "dt: 0.01, method: hht-alpha,"))
#: fuzz6's 3D boom whose filter state reads the prescribed base's x (tests/test_sensitivities_in_loop_moving_sensors.py)
#: with the base turning too, the state reading the b1 beam's end in the base's axes, through the cable's taut event
BASE_FRAME = (BASE_STATE.replace("      translation: [0.05*sin(3*t), 0, 0.02*t**2]\n",
                                 "      translation: [0.05*sin(3*t), 0, 0.02*t**2]\n"
                                 "      rotation: {axis: [0.3, 0.2, 1.0], angle: 0.4*t}\n")
              .replace("states: {Sf: wf*(bx - Sf)}", "states: {Sf: wf*(n2b - Sf)}")
              .replace("    bx: {point: base",
                       "    n2b: {point: b1.end, quantity: position, frame: base, component: y}\n    bx: {point: base"))
#: tests/test_sensitivities_in_loop_linked_controllers.py's 3D gimbal of two rigid rings carrying a flexible boom, its
#: inner hinge driven by a PI whose integral reads the hinge's angle and the boom's free tip (rigid links)
GIMBAL_PI = (_GAINS.replace("parameters: {Kp: 0.8,", "parameters: {Ki: 2.0, a: 1.0, Kp: 0.8,")
             .replace('damping: "c2"}}}', 'damping: "c2", torque: "pic"}}}')
             .replace("solve: {", 'controllers:\n  pic: {output: "Kp*(ref - a2) + Ki*E", '
                      'states: {E: "a*(ref - a2) + 0.5*(tip_x - 1.0)"}}\nsolve: {')
             .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, Ki, a, k1, m, EI]"))
#: the same PI also pushing the inner ring (a rigid link's body: its column reduced by Pᵀ) in the outer ring's axes
GIMBAL_PI_LOAD = GIMBAL_PI.replace("loads:\n", 'loads:\n  - {at: inner, force: [0, "0.2*pic", "-0.1*pic"], frame: outer}\n')
#: the slider-crank's guided bead (a guide) driven by a PI on its slide and the crank's angle, bouncing off its stops
BEAD_PI = (BEAD.replace("ref: 0.02}", "ref: 0.02, Ki: 20.0}")
           .replace('ctl: {output: "tau + Kp*(ref - slide) - Kd*vs - 0.5*Kp*py"}',
                    'ctl: {output: "tau + Kp*(ref - slide) + Ki*E", states: {E: "ref - slide + 0.2*crank"}}')
           .replace("sensitivities: [Kp, Kd, ref, tau, m, k]", "sensitivities: [Kp, ref, Ki, tau, m, k]"))
#: tests/test_sensitivities_in_loop_controller_reads.py's 3D arm whose skew hinge's torque a clipped controller reads,
#: the hinge now on compliant stops at [−0.03, 0.05] whose stiffness and damping are parameters (a joint's force whose
#: compliant stop's law a parameter moves)
TORQUE_STOPS = (ARM_TORQUE.replace("Kt: 0.4}", "Kt: 0.4, kc: 200.0, cc: 0.5}")
                .replace("stiffness: 30.0, damping: 0.2}",
                         'stiffness: 30.0, damping: 0.2, limits: [-0.03, 0.05], '
                         'contact: {stiffness: "kc", exponent: 1.5, damping: "cc"}}')
                .replace("sensitivities: [E, F, Kt]", "sensitivities: [kc, cc, Kt, F]"))
#: the same with the stops' exponent a parameter, the stops at [−0.035, 0.04], HHT-α
TORQUE_STOPS_N = (TORQUE_STOPS.replace("cc: 0.5}", "cc: 0.5, ne: 1.5}").replace("exponent: 1.5", 'exponent: "ne"')
                  .replace("limits: [-0.03, 0.05]", "limits: [-0.035, 0.04]")
                  .replace("dt: 0.005,", "dt: 0.005, method: hht-alpha,")
                  .replace("sensitivities: [kc, cc, Kt, F]", "sensitivities: [ne, kc, E]"))
#: tests/test_sensitivities_in_loop_controller_reads.py's 3D arm whose skew hinge a controller drives from the first
#: element's axial force, reading the second's moment_z and the b beam's first element's torque too, all by E, which
#: moves every section value (an element's section force whose section values a parameter moves)
MOMENT_E = (AXIAL_E.replace('ax: {element: "a.element[0]", quantity: axial_force}',
                            'ax: {element: "a.element[1]", quantity: moment_z}')
            .replace('"-Ka*ax - 2*hinge"', '"-Ka*ax - 2*hinge + 0.5*Ka*tz"')
            .replace("    hinge: {hinge: b.start, quantity: angle}\n",
                     '    hinge: {hinge: b.start, quantity: angle}\n    tz: {element: "b.element[0]", quantity: torque}\n'))
assert "moment_z" in MOMENT_E and "0.5*Ka*tz" in MOMENT_E
#: tests/test_sensitivities_in_loop_controller_reads.py's skew cable catching the 3D arm's tip, a clipped controller
#: reading its tension, by the cable's rest length and EA (a cable's tension whose laws a parameter moves)
CABLE_L = CABLE_LIMIT.replace("[Kp, Kt, EI, m]", "[L, Kt, EA]")
assert "[L, Kt, EA]" in CABLE_L
assert 'contact: {stiffness: "kc"' in TORQUE_STOPS and "hht-alpha" in TORQUE_STOPS_N and '"ne"' in TORQUE_STOPS_N
assert "tip_o - 0.45" in BOOM_OFFSET and "offset: [0.05" in BOOM_OFFSET and "frame: elbow" in BOOM_BODY
assert "H: " in BOOM_BOTH and "limits: [-0.5, 1.5]}" in BOTH_CLIPPED and "hht-alpha" in BOTH_CLIPPED
assert "rotation: {axis" in BASE_FRAME and "wf*(n2b - Sf)" in BASE_FRAME
assert 'torque: "pic"' in GIMBAL_PI and "0.2*pic" in GIMBAL_PI_LOAD and "0.2*crank" in BEAD_PI and "[Kp, ref, Ki, tau, m, k]" in BEAD_PI


@pytest.mark.parametrize("text, events, in_python", [
    (BOOM_OFFSET, ["latch"], 2), (BOOM_BODY, ["latch"], 2), (BOOM_BOTH, ["latch"], 2), (BOTH_CLIPPED, ["latch"], 2),
    (BASE_STATE, ["taut"], 2), (BASE_FRAME, ["taut"], 2), (GIMBAL_PI, [], 0), (GIMBAL_PI_LOAD, [], 0),
    (BEAD_PI, ["stop", "stop"], 4)],
    ids=["offset point", "in a body's axes", "offset and in a body's axes", "clipped, HHT-alpha",
         "prescribed base's position", "in a turning prescribed base's axes", "rigid links", "rigid links, a load",
         "a guide, its stops"])
def test_states_reading_points_take_the_loop(text, events, in_python, monkeypatch):
    """Every smooth step in the loop of steps (all but the event's and the landing after it), the Python path's
    sensitivities and event time derivatives to the bit: the 3D boom's PI integral reading a point offset from its node,
    a point in the elbow's axes, and both with a filter on the offset point's displacement in the elbow's axes (beside
    the latch; and clipped under HHT-α), and fuzz6's 3D boom's filter on the prescribed base's x, and on a point in the
    turning prescribed base's axes, through the cable's taut event; on models with rigid links or guides, the 3D
    gimbal's PI on its inner hinge's angle and the flexible boom's tip (and pushing the inner ring), and the
    slider-crank's guided bead's PI on its slide beside its stops."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert [event["kind"] for event in native.summary["events"]] == events
    assert_same_sensitivities(native, python, python_path=True, nonzero="some", in_loop_but=in_python)


def test_the_boom_reading_both_through_the_cli_writes_the_python_paths_bytes(tmp_path):
    """``latdyn run`` of the boom with both kinds of point as a user types it: the smooth steps in the loop, and the same
    command with the switch off (a process of its own) writes the same sensitivities.csv and probes.csv, byte for
    byte, and summary.json's probe and event sensitivities."""
    completed, out = latdyn_run(tmp_path, BOOM_BOTH)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] == summary["steps"] - 2
    the_loop_off_writes_the_same(tmp_path, out)


def test_the_boom_reading_both_agrees_with_richardson_differences(monkeypatch):
    """The loop's sensitivities by the shoulder's stiffness (measured 2.4e-7) against Richardson central differences
    of whole runs, the latch time's derivative too."""
    import yaml

    data = yaml.safe_load(BOOM_BOTH)
    data["solve"]["sensitivities"] = ["k"]
    result = _run(yaml.safe_dump(data), monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"] - 2
    assert _agree(result, BOOM_BOTH, "k", tolerance=1e-6) <= 1e-6


def test_the_turning_bases_frame_through_the_event_agrees_with_richardson_differences(monkeypatch):
    """The filter on a point in the turning prescribed base's axes through the taut event, in the loop: every row
    against Richardson differences (measured 2.3e-9)."""
    result = _run(BASE_FRAME, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"] - 2
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", True)
        assert _rows_against_richardson(BASE_FRAME, "c1") < 1e-7


def test_the_gimbal_pushing_its_ring_agrees_with_richardson_differences(monkeypatch):
    """The gimbal's PI pushing the inner ring, by the parameter inside the state's rate, in the loop (every step)
    against Richardson central differences of whole runs (measured 3.3e-8)."""
    import yaml

    data = yaml.safe_load(GIMBAL_PI_LOAD)
    data["solve"]["sensitivities"] = ["a"]
    result = _run(yaml.safe_dump(data), monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"] > 0
    assert _agree(result, GIMBAL_PI_LOAD, "a", tolerance=1e-6) <= 1e-6


def test_a_state_reading_a_rigid_links_body_keeps_the_python_path(monkeypatch):
    """A state reading the inner ring's place in the outer ring's axes (both follow the rigid links: its δs is P δq, the
    per-step path's NumPy) keeps every step on the Python path."""
    text = GIMBAL_PI.replace('0.5*(tip_x - 1.0)"', '0.5*(tip_x - 1.0) + 0.3*iz"')
    assert text != GIMBAL_PI
    result = _run(text, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == 0 and result.summary["time_loop"] == "python"


@pytest.mark.parametrize("text", [TORQUE_STOPS, TORQUE_STOPS_N], ids=["stops' stiffness and damping", "exponent, HHT"])
def test_a_joints_torque_whose_stops_law_a_parameter_moves_takes_the_loop(text, monkeypatch):
    """A controller reading the 3D arm's hinge torque, the hinge on compliant stops whose stiffness, damping or exponent
    is a parameter: the torque's ∂F/∂p is its row of the hinge laws' and of the stops' ∂r/∂p (the generated
    hinge_force and contact_force_D_law; csrc/sensitivity_loop.c ``joint_law_force_slopes``), as
    ControllerTerms.sensed_force_slopes sums them. All but the four steps at the stops' onsets in the loop (measured
    58 of 62), the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert native.summary["steps"] - 4 <= native.summary["sensitivity_steps_in_loop"] < native.summary["steps"]
    assert_same_sensitivities(native, python, python_path=True, nonzero="each", events_may_be_absent=True)


def test_the_stops_stiffness_read_through_the_torque_agrees_with_richardson_differences(monkeypatch):
    """The stops' stiffness in the loop against Richardson central differences of whole runs (measured 2.6e-8; the
    exponent 8.5e-9; the stops' damping 1.8e-5 on both paths, the damper's clip at a rate pulling away)."""
    import yaml

    data = yaml.safe_load(TORQUE_STOPS)
    data["solve"]["sensitivities"] = ["kc"]
    result = _run(yaml.safe_dump(data), monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] >= result.summary["steps"] - 4
    assert _agree(result, TORQUE_STOPS, "kc", tolerance=1e-6) <= 1e-6


@pytest.mark.parametrize("text, in_python", [(AXIAL_E, 0), (MOMENT_E, 0), (CABLE_L, 24)],
                         ids=["axial force", "a moment and a torque", "a cable's tension by L and EA"])
def test_forces_whose_own_laws_a_parameter_moves_take_the_loop(text, in_python, monkeypatch):
    """A controller on the 3D arm reading an element's axial force, or a moment and another element's torque, all of
    whose section values E moves: the force's ∂S/∂p (the generated beam_section_forces_D_section contracted with the
    section uses' rows, csrc/parameter_forces.c ``section_force_slope``, the C ControllerTerms.sensed_force_slopes
    calls) through the reader's ∂f/∂s; and one reading a skew cable's tension by its rest length and EA (its ∂N/∂p
    from the generated cable_force and cable_force_D_rest_length, csrc/cable_forces.c ``cable_tension_slope``, as
    probe_derivatives._tension_by_parameters forms it). Every smooth step in the loop (measured 60 of 60; the cable's
    45 of 69, the rest at and after its five changes), the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert_same_sensitivities(native, python, python_path=True, nonzero="each", in_loop_but=in_python,
                              events_may_be_absent=True)


def test_the_moment_read_by_e_agrees_with_richardson_differences(monkeypatch):
    """The arm reading a moment and a torque, by E, in the loop against Richardson central differences of whole runs
    (measured 4.9e-8; the axial force's 3.0e-8)."""
    import yaml

    data = yaml.safe_load(MOMENT_E)
    data["solve"]["sensitivities"] = ["E"]
    result = _run(yaml.safe_dump(data), monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"] > 0
    assert _agree(result, MOMENT_E, "E", tolerance=1e-6) <= 1e-6
