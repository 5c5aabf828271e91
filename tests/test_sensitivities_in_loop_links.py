"""Rigid links and guides in the transient sensitivities' loop of steps (issue 34 item 2; latdyn/analyses/
sensitivities_in_loop.py, csrc/linked_matrices.c): a model with rigid links or guides takes its smooth steps'
sensitivities in the loop of steps, M, C and the exact K on the minimum coordinates and ∂r/∂p reduced by the
compiled step's own reduction (csrc/links.c), the per-step Python path calling the same C: equal to the bit through
the API (a 3D gimbal of rigid links, latching; a slider-crank between stops; a guided body on a spring on a
flexible 3D arm; a deploying chain of rigid bays latching twice, which also agrees with Richardson-extrapolated
central differences) and the CLI (the shipped slider-crank with parameters); a linked run interrupted inside the
loop resumes to the same files (a rigid link's own section values: test_sensitivities_in_loop_linked_control.py)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import ROOT, latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.resumed_runs import resumed_inside_the_loop_is_whole
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_guides import GUIDE_3D
from tests.test_sensitivities_rigid_links import GIMBAL, LATCH, SLIDER_CRANK

#: the gimbal by its hinges' springs, damper and rest angle, a joint body's mass, the tip load and the boom's EI
#: (the rigid links' own section: tests/test_sensitivities_in_loop_linked_control.py)
GIMBAL_JOINTS = GIMBAL.replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [k1, k2, c2, rest, m, P, EI]")
GIMBAL_LATCH = LATCH.replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [k1, c2, m, P, EI]")
#: the slider-crank bouncing twice between its guide's stops, by the crank's torque, the slider's mass and the
#: guide's stiffness (a guide law: the hinge law it is, on the slide)
CRANK_STOPS = SLIDER_CRANK.replace("sensitivities: [tau, m]", "sensitivities: [tau, m, k]")
#: the guided mass on a spring on the flexible 3D arm, by the guide's stiffness, damping and rest, the mass and EI
GUIDED = GUIDE_3D.replace("sensitivities: [k, m, EI, rest]", "sensitivities: [k, c, m, EI, rest]")

#: a deploying chain of two rigid bays, each swung open by its hinge's preloaded spring and latching in line
#: (t = 0.251 s and 0.340 s), a flexible boom with a tip body and a load beyond them
CHAIN = """
title: a deploying chain of rigid bays latching in line, a flexible boom at its tip
parameters: {k: 1.5, c: 0.02, m: 0.1, EI: 30.0, F: 0.2}
sections:
  bay: {EA: 1.0e7, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 0.5, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
  boom: {EA: 1.0e6, EIy: "EI", EIz: "EI", GJ: 20.0, rhoA: 0.3, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  root: {at: [0, 0, 0], fixed: true}
  s1: {at: [0.25, 0, 0.433013], mass: "m", inertia: [0.001, 0.001, 0.001]}
  s2: {at: [0.5, 0, 0], mass: 0.1, inertia: [0.001, 0.001, 0.001]}
  tip: {at: [1.0, 0, 0], mass: 0.05, inertia: [0.0005, 0.0005, 0.0005]}
beams:
  bay1: {from: root, to: s1, section: bay, rigid: true,
         start: {hinge: {axis: [0, 1, 0], stiffness: "k", damping: "c", rest_angle: pi/3 + 0.3, lock_at: pi/3}}}
  bay2: {from: s1, to: s2, section: bay, rigid: true,
         start: {hinge: {axis: [0, -1, 0], stiffness: "k", rest_angle: 2*pi/3 + 0.3, lock_at: 2*pi/3}}}
  boom: {from: s2, to: tip, section: boom, elements: 3}
loads:
  - {at: tip, force: [0, 0, "-F"]}
solve: {analysis: transient, t_end: 0.5, dt: 0.005, sensitivities: [k, c, m, EI, F]}
output:
  every: 0.05
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    tip_z: {point: tip, quantity: position, component: z}
    knee1: {hinge: bay1.start, quantity: angle}
    knee2: {hinge: bay2.start, quantity: angle}
"""


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


@pytest.mark.parametrize("text, events", [(GIMBAL_JOINTS, 0), (GIMBAL_LATCH, 1), (CRANK_STOPS, 2), (GUIDED, 0),
                                          (CHAIN, 2)],
                         ids=["3D gimbal of rigid links", "the gimbal latching", "slider-crank between stops",
                              "guided mass on a 3D arm", "rigid chain latching twice"])
def test_the_linked_steps_in_the_loop_are_the_python_paths(text, events, monkeypatch):
    """Every smooth step of a model with rigid links or guides is differentiated in the loop of steps (the events'
    steps and the landings after them from Python) and the sensitivities are the per-step Python path's to the bit:
    rows, extremes and the events' time derivatives."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert native.summary["time_loop"] == "compiled" and python.summary["sensitivity_steps_in_loop"] == 0
    assert len(native.summary["events"]) == events
    assert (in_loop == steps > 0) if events == 0 else (steps - 2 * events <= in_loop < steps)
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert any(np.abs(values).max() > 0.0 for values in python.sensitivities.values())
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


@pytest.mark.parametrize("name", ["k", "m"])
def test_the_rigid_chains_sensitivities_from_the_loop_agree_with_richardson_central_differences(name, monkeypatch):
    """The deploying chain's sensitivities, taken in the loop of steps through both latches, against central
    differences of whole runs (Richardson-extrapolated) to 1e-6, the latches' time derivatives too."""
    result = _run(CHAIN, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] >= result.summary["steps"] - 4
    _agree(result, CHAIN, name)


def _shipped_slider_crank() -> str:
    """examples/slider_crank.yaml with parameters: the rod's EI and rhoA, the slider's mass, a load on it and a
    spring and damper on its guide (rotary inertia on the sections: the start is not at rest)."""
    text = (ROOT / "examples" / "slider_crank.yaml").read_text()
    changed = (text.replace("sections:\n", "parameters: {EI: 50.0, rho: 0.5, m: 1.0, F: 2.0, kg: 40.0, cg: 0.3}\n"
                                           "sections:\n", 1)
               .replace("rhoA: 2.0}", "rhoA: 2.0, rhoIy: 1.0e-4, rhoIz: 1.0e-4}")
               .replace("EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 0.5}",
                        'EIy: "EI", EIz: "EI", GJ: 40.0, rhoA: "rho", rhoIy: 1.0e-4, rhoIz: 1.0e-4}')
               .replace("    mass: 1.0\n    guide: {axis: [1, 0, 0]}",
                        '    mass: "m"\n    guide: {axis: [1, 0, 0], stiffness: "kg", damping: "cg"}')
               .replace("solve: {analysis: transient, t_end: 1.5, dt: 0.002}",
                        'loads:\n  - {at: slider, force: ["-F*sin(5*t)", 0, 0]}\n'
                        "solve: {analysis: transient, t_end: 0.2, dt: 0.002, sensitivities: [EI, rho, m, F, kg, cg]}"))
    assert changed.count('"EI"') == 2 and 'stiffness: "kg"' in changed and "sensitivities: [EI" in changed
    return changed


def test_the_cli_writes_the_shipped_slider_cranks_python_path_files(tmp_path):
    """``latdyn run`` on the shipped slider-crank with parameters of five kinds takes the loop for every step; the
    same command with the switch off (in a process of its own) writes the same sensitivities.csv and probes.csv, byte
    for byte, and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, _shipped_slider_crank())
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] == summary["steps"] == 100
    the_loop_off_writes_the_same(tmp_path, out)


def test_a_linked_run_interrupted_inside_the_loop_resumes_to_the_same_files(tmp_path, monkeypatch):
    """The rigid chain interrupted (Ctrl-C) as a loop of steps starts at t ≥ 0.3 s, after its first latch (a
    renumbering) and before its second, and resumed from its checkpoint: its sensitivities' files and its count of
    steps in the loop are the uninterrupted run's, byte for byte."""
    resumed_inside_the_loop_is_whole(yaml.safe_load(CHAIN), tmp_path, monkeypatch, 0.3)
