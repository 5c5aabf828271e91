"""Linked models beside controllers and explicit time dependence beside events in the transient sensitivities' loop
of steps (issue 34 item 2; latdyn/analyses/sensitivities_in_loop.py ``model_refusal``, csrc/sensitivity_loop.c
``controller_parameter_forces``, ``explicit_time_columns``): on a model with rigid links or guides the controllers'
columns of ∂r/∂p are reduced by Pᵀ with the others and ∂r/∂t by Pᵀ alone, as the per-step Python path's
``_on_free_coordinates`` reduces them, and the sensitivities are that path's to the bit, through the API (a
slider-crank with a PD controller on its crank hinge between its slider's stops; a 3D gimbal of rigid links with a
PD controller on its inner hinge, latching; the gimbal with loads and a hinge torque of t, latching; the
slider-crank with a guide force of t between stops) and the CLI (the PD slider-crank), and agree with
Richardson-extrapolated central differences. A rigid link's own section values (its joint body's mass and inertia:
link_sensitivities.add_link_section_forces) take the loop too, through the generated joint_body as the joint bodies
do (the 3D gimbal's rings by rho, under gravity; the slider-crank's crank by its rhoA, rhoIy and rhoIz)."""
from __future__ import annotations

import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_in_loop_links import \
    test_the_linked_steps_in_the_loop_are_the_python_paths as _the_linked_steps_are_the_python_paths
from tests.test_sensitivities_rigid_links import GIMBAL, LATCH, SLIDER_CRANK

#: the slider-crank whose crank a PD controller drives towards ``ref`` (its hinge's angle and rate read), the slider
#: bouncing once off its guide's stop; by the gains, the set point, the slider's mass and the guide's stiffness
CRANK_PD = (SLIDER_CRANK.replace("parameters: {tau: 2.0, m: 1.0, k: 30.0}",
                                 "parameters: {tau: 2.0, m: 1.0, k: 30.0, Kp: 2.0, Kd: 0.1, ref: 1.0}")
            .replace('start: {hinge: {axis: [0, 0, 1], torque: "tau"}}}', 'start: {hinge: {axis: [0, 0, 1], torque: "pd"}}}')
            .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - ang) - Kd*om"}\nsolve: {')
            .replace("    crank: {hinge: crank.start, quantity: angle}\n",
                     "    ang: {hinge: crank.start, quantity: angle}\n    om: {hinge: crank.start, quantity: rate}\n")
            .replace("sensitivities: [tau, m]", "sensitivities: [Kp, Kd, ref, m, k]"))
#: the 3D gimbal latching (its inner ring at −0.1 rad) with a PD controller on the inner ring's hinge
GIMBAL_PD = (LATCH.replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, Kd: 0.05, ref: 0.3, k1: 6.0,")
             .replace('stiffness: "k2", damping: "c2", lock_at: -0.1}}}',
                      'stiffness: "k2", damping: "c2", torque: "pd", lock_at: -0.1}}}')
             .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - a2) - Kd*r2"}\nsolve: {')
             .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, Kd, ref, k1, m, EI]"))
#: the 3D gimbal latching under a tip load of t and a torque of t on its outer hinge (∂r/∂t beside the latch)
GIMBAL_T = (LATCH.replace('force: [0, "P", "-0.5*P"]', 'force: [0, "P*(1 + sin(12*t))", "-0.5*P*cos(7*t)"]')
            .replace('stiffness: "k1", rest_angle: "rest"', 'stiffness: "k1", rest_angle: "rest", torque: "0.05*sin(9*t)"')
            .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [k1, c2, m, P, EI]"))
#: the slider-crank between its stops with a force of t on its guide (a guide law of t: the hinge law it is)
CRANK_GUIDE_T = (SLIDER_CRANK.replace('guide: {axis: [1, 0, 0], stiffness: "k",',
                                      'guide: {axis: [1, 0, 0], stiffness: "k", force: "-0.8*sin(9*t)",')
                 .replace("sensitivities: [tau, m]", "sensitivities: [tau, m, k]"))
#: the 3D gimbal under gravity by its rigid rings' section value rho (rhoA and rhoIy), among other kinds
GIMBAL_RHO = GIMBAL.replace("initial_velocity:", "gravity: [0, 0, -9.81]\ninitial_velocity:")
#: the slider-crank between stops by its rigid crank's section values (rhoA, rhoIy, and rhoIz through 3*ri)
CRANK_RHO = (SLIDER_CRANK.replace("parameters: {tau: 2.0, m: 1.0, k: 30.0}",
                                  "parameters: {tau: 2.0, m: 1.0, k: 30.0, rc: 2.0, ri: 1.0e-4}")
             .replace("crank: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 2.0, rhoIy: 1.0e-4, rhoIz: 1.0e-4}",
                      'crank: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: "rc", rhoIy: "ri", rhoIz: "3*ri"}')
             .replace("sensitivities: [tau, m]", "sensitivities: [rc, ri, tau]"))
assert "gravity" in GIMBAL_RHO and "[k1, m, P, EI, rho]" in GIMBAL_RHO and '"3*ri"' in CRANK_RHO
assert 'torque: "pd"' in CRANK_PD and "om: {hinge" in CRANK_PD and "[Kp, Kd, ref, m, k]" in CRANK_PD
assert 'torque: "pd"' in GIMBAL_PD and "[Kp, Kd, ref, k1, m, EI]" in GIMBAL_PD
assert "sin(12*t)" in GIMBAL_T and "0.05*sin(9*t)" in GIMBAL_T and "[k1, c2, m, P, EI]" in GIMBAL_T
assert "sin(9*t)" in CRANK_GUIDE_T and "[tau, m, k]" in CRANK_GUIDE_T


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


@pytest.mark.parametrize("text, events", [(CRANK_PD, 1), (GIMBAL_PD, 1), (GIMBAL_T, 1), (CRANK_GUIDE_T, 2),
                                          (GIMBAL_RHO, 0), (CRANK_RHO, 2)],
                         ids=["PD slider-crank off a stop", "3D PD gimbal latching",
                              "3D gimbal latching under laws of t", "slider-crank with a guide force of t",
                              "3D gimbal by its rigid rings' section", "slider-crank by its rigid crank's section"])
def test_the_linked_steps_with_controllers_and_time_in_the_loop_are_the_python_paths(text, events, monkeypatch):
    """Every smooth step is differentiated in the loop of steps (the events' steps and the landings after them from
    Python) and the sensitivities are the per-step Python path's to the bit: rows, extremes and the events' time
    derivatives (test_sensitivities_in_loop_links.py's checks)."""
    _the_linked_steps_are_the_python_paths(text, events, monkeypatch)


@pytest.mark.parametrize("text, name", [(CRANK_PD, "Kp"), (GIMBAL_T, "P"), (GIMBAL_RHO, "rho")],
                         ids=["PD crank by Kp", "gimbal by P", "gimbal by its rings' rho"])
def test_the_loops_sensitivities_agree_with_richardson_central_differences(text, name, monkeypatch):
    """The sensitivities taken in the loop (through the event), against central differences of whole runs
    (Richardson-extrapolated) to 1e-6 (measured: 7.8e-10, 9.0e-9 and 4.0e-9 of each probe's largest), the event's
    time derivative too."""
    result = _run(text, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] >= result.summary["steps"] - 2
    _agree(result, text, name)


def test_the_cli_writes_the_pd_slider_cranks_python_path_files(tmp_path):
    """``latdyn run`` on the PD slider-crank takes the loop for its smooth steps; the same command with the switch
    off (in a process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's
    sensitivities."""
    completed, out = latdyn_run(tmp_path, CRANK_PD)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["steps"] - 2 <= summary["sensitivity_steps_in_loop"]
    the_loop_off_writes_the_same(tmp_path, out)
