"""Continuous controllers with states (a PI's integral, a filter) in the sensitivities' loop of steps (issue 34 item 2;
csrc/controller_states.c, latdyn/analyses/sensitivities_in_loop.py ``_states_refusal``): the loop carries δS, δf and
the accepted (S, f) at each step's start (states reading hinge and guide angles and nodes' positions), evaluates the
step's matrices with the states condensed from (S_n, f_n) as the step does, and takes the states' rates' ∂f/∂s, ∂f/∂S
from the step's own compiled controller law and their ∂f/∂p from the compiled partials — the same C the per-step
Python path (ControllerStates) calls. The results are the Python path's
(the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the API and the CLI, after a resume too, and
Richardson central differences of whole runs'."""
from __future__ import annotations

import pytest
import yaml

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.resumed_runs import interrupted_and_whole
from tests.test_sensitivities_events import STOP_3D, _agree
from tests.test_sensitivities_in_loop_state_laws import _run, _same

#: a two-link boom out of the coordinate planes (its elbow's hinge about (1, −2, 1)), the elbow driven by a PI loop on
#: its angle, Kp (0.6 − θ) + Ki E with dE/dt = a (0.6 − θ), latching at 0.4 rad; the gains, the parameter inside the
#: state's rate, the shoulder's spring and a section value
BOOM = """
title: a two-link boom on skew hinges, its elbow driven by a PI loop on the elbow's angle, latching at 0.4 rad
parameters: {Kp: 3.0, Ki: 4.0, a: 1.0, k: 2.0, EI: 300.0}
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "EI", GJ: "0.8*EI", rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  elbow: {at: [0.6, 0.2, 0.3], mass: 0.3, inertia: [0.01, 0.01, 0.01]}
  tip: {at: [1.1, 0.5, 0.4], mass: 0.5, inertia: [0.01, 0.01, 0.01]}
beams:
  upper: {from: base, to: elbow, section: s, elements: 2,
          start: {hinge: {axis: [0, 0, 1], stiffness: "k", damping: 0.2}}}
  fore: {from: elbow, to: tip, section: s, elements: 2,
         start: {hinge: {axis: [1, -2, 1], damping: 0.1, torque: "ctl", lock_at: 0.4}}}
controllers:
  ctl: {output: "Kp*(0.6 - elbow) + Ki*E", states: {E: "a*(0.6 - elbow)"}}
solve: {analysis: transient, t_end: 1.0, dt: 0.01, sensitivities: [Kp, Ki, a, k, EI]}
output:
  every: 0.02
  probes:
    elbow: {hinge: fore.start, quantity: angle}
    shoulder: {hinge: upper.start, quantity: angle}
    tip_z: {point: tip, quantity: position, component: z}
"""
#: the boom's PI clipped at [−0.5, 1.5] (at the start and after the latch: the output's law decides the clip on both
#: paths), HHT-α
BOOM_CLIPPED = (BOOM.replace('states: {E: "a*(0.6 - elbow)"}}', 'states: {E: "a*(0.6 - elbow)"}, limits: [-0.5, 1.5]}')
                .replace("dt: 0.01,", "dt: 0.01, method: hht-alpha,"))
#: tests/test_sensitivities_events.py's 3D wheel on a skew hinge beside its stop (restitution 0.9, two hits), its hinge
#: driven by a PI on a filtered angle: two states, E (the integral) and F (a first-order filter of rate w)
WHEEL_STOP = (STOP_3D.replace("t_end: 1.07", "t_end: 1.0").replace("restitution: 0.5", "restitution: 0.9")
              .replace("parameters: {k: 1.0,", "parameters: {Kp: 0.5, Ki: 1.0, w: 20.0, k: 1.0,")
              .replace("rest_angle: 1.0, limits", 'rest_angle: 1.0, torque: "ctl", limits')
              .replace("solve: {", 'controllers:\n  ctl: {output: "Kp*(0.6 - F) + Ki*E", '
                       'states: {E: "0.3 - angle", F: "w*(angle - F)"}}\nsolve: {')
              .replace("sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [Kp, Ki, w, k, EI]"))
#: the boom's PI less a filtered tip height H (a state reading a point's position), dH/dt = 20 (z_tip − 0.4 − H)
BOOM_FILTER = BOOM.replace('"Kp*(0.6 - elbow) + Ki*E", states: {E: "a*(0.6 - elbow)"}}',
                           '"Kp*(0.6 - elbow) + Ki*E - 2*H", '
                           'states: {E: "a*(0.6 - elbow)", H: "20*(tip_z - 0.4 - H)"}}')
assert "H: " in BOOM_FILTER
#: the boom differentiated by the parameter inside the state's rate alone (no parameter in a controller's output)
BOOM_RATE = BOOM.replace("sensitivities: [Kp, Ki, a, k, EI]", "sensitivities: [a, k]")
assert "[a, k]" in BOOM_RATE
assert "limits: [-0.5, 1.5]}" in BOOM_CLIPPED and "method: hht-alpha" in BOOM_CLIPPED
assert 'torque: "ctl", limits' in WHEEL_STOP and "[Kp, Ki, w, k, EI]" in WHEEL_STOP and "F: " in WHEEL_STOP


@pytest.mark.parametrize("text, events", [(BOOM, ["latch"]), (BOOM_RATE, ["latch"]), (BOOM_CLIPPED, ["latch"]),
                                          (BOOM_FILTER, ["latch"]), (WHEEL_STOP, ["stop", "stop"])],
                         ids=["PI beside a latch", "by the state's rate alone", "clipped PI, HHT-alpha",
                              "a filter on the tip's height", "PI on a filter beside a stop"])
def test_controllers_with_states_take_the_loop(text, events, monkeypatch):
    """Every smooth step in the loop of steps (all but the events' and the landings after them), the Python path's
    sensitivities and event time derivatives to the bit: the 3D boom's PI beside its latch (by its gains, the parameter
    inside its state's rate, a spring and a section value; and by the rate's parameter alone), the same PI clipped (part
    of the run) under HHT-α, the PI less a filtered tip height (a state reading a point's position), and the 3D wheel's
    PI on a filtered angle (two states) beside its stop, hit twice."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps = native.summary["steps"]
    assert native.summary["time_loop"] == "compiled"
    assert steps - 2 * len(events) <= native.summary["sensitivity_steps_in_loop"] < steps
    assert [event["kind"] for event in native.summary["events"]] == events
    _same(native, python)


def test_the_clipped_pi_is_clipped_part_of_the_run(monkeypatch):
    """The clipped boom's output sits on its limit for part of the run and off it for another (a guard of the scene:
    both branches of the clip are taken in the loop)."""
    text = BOOM_CLIPPED.replace("  probes:\n", "  probes:\n    torque: {controller: ctl}\n")
    data = yaml.safe_load(text)
    del data["solve"]["sensitivities"]
    import latdyn

    torque = latdyn.run(latdyn.load_scene(data)).probes["torque"]
    assert (torque == 1.5).any() and ((torque > -0.5) & (torque < 1.5)).any()


def test_the_boom_through_the_cli_writes_the_python_paths_bytes(tmp_path):
    """``latdyn run`` of the boom as a user types it: the smooth steps in the loop, and the same command with the switch
    off (a process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's
    probe and event sensitivities."""
    completed, out = latdyn_run(tmp_path, BOOM)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] >= summary["steps"] - 2
    the_loop_off_writes_the_same(tmp_path, out)


def test_an_interrupted_and_resumed_boom_has_the_same_sensitivities(tmp_path, monkeypatch):
    """δS, δf and the accepted (S, f) handed from the loop to the carried sensitivities ride in the checkpoint: the
    resumed run's sensitivities.csv is the uninterrupted one's, byte for byte (interrupted before the latch)."""
    out, whole = interrupted_and_whole(yaml.safe_load(BOOM), tmp_path, monkeypatch, 0.17)
    assert summary_of(whole)["sensitivity_steps_in_loop"] > 0
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()


@pytest.mark.parametrize("name", ["Ki", "a"])
def test_the_boom_agrees_with_richardson_differences(name, monkeypatch):
    """The loop's sensitivities by the integral gain and by the parameter inside the state's rate against Richardson
    central differences of whole runs (the latch time's derivative too)."""
    data = yaml.safe_load(BOOM)
    data["solve"]["sensitivities"] = [name]
    result = _run(yaml.safe_dump(data), monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] > 0
    assert _agree(result, BOOM, name, tolerance=1e-6) <= 1e-6
