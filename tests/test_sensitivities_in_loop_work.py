"""The work accounts' sensitivities in the sensitivities' loop of steps (issue 34 item 2; latdyn/analyses/
sensitivities_in_loop.py ``_account_refusal``): the dissipated energy and the external work, sums over the steps
(energy_sensitivities._dissipated_step, external_work_step), carried by csrc/work_accounts.c, which the per-step Python
path calls too (``latdyn_damper_torques``, ``latdyn_dissipated_step``, ``latdyn_load_power``,
``latdyn_applied_torques``, ``latdyn_external_work_increment``), so the run takes the loop and its results are the
Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the API and the CLI, the accounts
handed back to Python at each loop's end, at each row recorded on the way and at the events (a latch, a stop with
restitution: external_work_after_event, from Python). The discrete adjoint keeps what it did (a damping law of the
state and a prescribed motion take the loop too: tests/test_sensitivities_in_loop_accounts2.py). Scenes: a 3D boom
(two hinges with springs and dampers, one damping a law in t, a tip load in t, gravity, a joint body, a spin) by its
section, hinge and load parameters; a planar hinged arm by its
damper and section; tests/test_sensitivities_in_loop.py's 3D arm whose spring is a law in t (not conservative: its
work external) with a torque in t, a rest angle and a follower load, by the spring's, torque's and rest angle's
parameters; tests/test_sensitivities_events.py's 3D wheel latching and bouncing off its stop with a load."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import assert_same_sensitivities
from tests.test_sensitivities_events import LATCH_3D, STOP_3D
from tests.test_sensitivities_in_loop import ARM_3D_JOINTS

#: a genuinely 3D boom: an inner beam on a hinge at the fixed base, an outer beam on a skew hinge at a joint body
#: whose damping is a law in t; a tip load in t, gravity, a spin at t = 0; the dissipated energy probed
BOOM_3D = """
title: 3D boom of two hinged beams with springs and dampers, a tip load in t
gravity: [0, 0, -9.81]
parameters: {EI: 20.0, rho: 0.5, k: 30.0, c: 0.4, F: 2.0}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "1.5*EI", GJ: 15.0, rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.02*rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0], mass: 0.8, com: [0.05, 0, -0.05], inertia: [0.01, 0.01, 0.02]}
beams:
  inner:
    from: base
    to: knee
    section: s
    elements: 2
    y_axis: [0, 1, 0]
    start: {hinge: {axis: [0, 0, 1], stiffness: 50.0, damping: 0.3}}
  outer:
    from: knee
    to: [1.6, 0.5, 0.4]
    section: s
    elements: 2
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: "k", damping: "c*(1 + 5*t)", rest_angle: 0.3}}
loads:
  - {at: outer.end, force: ["0.3*F*sin(20*t)", "-F", "0.5*F*t"]}
initial_velocity: {angular: [0, 0, 2.0]}
solve: {analysis: transient, dt: 0.005, t_end: 0.1, sensitivities: [EI, rho, k, c, F]}
output:
  every: 0.01
  probes:
    lost: {energy: dissipated}
    work: {energy: external_work}
    hinge: {hinge: outer.start, quantity: angle}
    tip_z: {point: outer.end, quantity: position, component: z}
"""

#: a planar arm of two beams swung by its hinge springs, both hinges damped, the outer's damper a parameter
PLANAR_ARM = """
title: planar arm of two hinged beams swung by their springs, damped
parameters: {c: 0.05, EI: 20.0, m: 0.3}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "EI", GJ: 10.0, rhoA: 0.5, rhoIy: 0.0005, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  elbow: {at: [1.0, 0, 0], mass: 0.2, inertia: [0.01, 0.01, 0.01]}
  tip: {at: [1.8, 0, 0], mass: "m", inertia: [0.01, 0.01, 0.01]}
beams:
  upper:
    from: base
    to: elbow
    section: s
    elements: 2
    start: {hinge: {axis: [0, 0, 1], stiffness: 3.0, damping: 0.02, rest_angle: 0.5}}
  lower:
    from: elbow
    to: tip
    section: s
    elements: 2
    start: {hinge: {axis: [0, 0, 1], stiffness: 2.0, damping: "c", rest_angle: 1.0}}
solve: {analysis: transient, dt: 0.01, t_end: 0.3, sensitivities: [c, EI, m]}
output:
  every: 0.05
  probes:
    lost: {energy: dissipated}
    tip_y: {point: tip, quantity: position, component: y}
"""




def _loaded(text: str) -> str:
    """tests/test_sensitivities_events.py's 3D wheel with a load of amplitude F on it (the external work's power) as a
    parameter beside the others, its external work probed."""
    return (text.replace("parameters: {k: 1.0,", "parameters: {F: 0.5, k: 1.0,")
            .replace("solve:", 'loads:\n  - {at: wheel, force: ["0.02*F", 0, "-0.1*F"]}\nsolve:')
            .replace("sensitivities: [k,", "sensitivities: [F, k,") + "    work: {energy: external_work}\n")


#: the 3D wheel latching, and bouncing off its stop with restitution 0.5, with a load: the external work through events
LATCH_WORK, STOP_WORK = _loaded(LATCH_3D), _loaded(STOP_3D)
assert "F: 0.5" in LATCH_WORK and "[F, k," in STOP_WORK and 'force: ["0.02*F"' in STOP_WORK


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def _same(native, python) -> None:
    """The two runs' sensitivities and the summary's, to the bit."""
    assert_same_sensitivities(native, python)


@pytest.mark.parametrize("text, probes", [
    (BOOM_3D, {"lost": ("EI", "rho", "k", "c", "F"), "work": ("EI", "rho", "k", "c", "F")}),
    (PLANAR_ARM, {"lost": ("c", "EI", "m")}),
    (ARM_3D_JOINTS + "    work: {energy: external_work}\n    lost: {energy: dissipated}\n",
     {"work": ("k", "r", "A", "cx"), "lost": ("c", "k")}),
], ids=["3D boom", "planar arm", "3D arm, a spring in t"])
def test_the_work_accounts_take_the_loop(text, probes, monkeypatch):
    """The dissipated energy and the external work by section, hinge and load parameters: every step in the loop of
    steps, the accounts handed back at each loop's end and at its rows, the Python path's sensitivities to the bit;
    their columns by every parameter nonzero."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] > 0
    _same(native, python)
    for probe, names in probes.items():
        for name in names:
            assert np.abs(native.sensitivities[(probe, name)]).max() > 0.0, (probe, name)


@pytest.mark.parametrize("text, event, beside", [(LATCH_WORK, "latch", 2), (STOP_WORK, "stop", 2)],
                         ids=["3D latch", "3D stop with restitution"])
def test_the_external_work_through_events(text, event, beside, monkeypatch):
    """The 3D wheel latching, and bouncing off its stop with restitution, with a load: every smooth step in the loop
    but the event's and the landing after it (from Python, external_work_after_event), the external work's
    sensitivities and the event's the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == [event]
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - beside > 0
    _same(native, python)
    assert np.abs(native.sensitivities[("work", "F")]).max() > 0.0


def test_the_cli_writes_the_python_paths_files_for_the_3d_boom(tmp_path):
    """``latdyn run`` on the 3D boom takes the loop for every step; the same command with the switch off (a process
    of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, BOOM_3D)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] == summary["steps"] == 20
    assert {"lost", "work"} <= set(summary["probe_sensitivities"])
    the_loop_off_writes_the_same(tmp_path, out)


def test_the_adjoint_still_refuses_the_work_accounts():
    """(A guard: it passed before the change too.) Under ``sensitivity_method: adjoint`` the work accounts (sums over
    the steps) are refused naming the key, as before."""
    text = BOOM_3D.replace("sensitivities: [", "sensitivity_method: adjoint, sensitivities: [")
    with pytest.raises(SceneError, match="sensitivity_method"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
