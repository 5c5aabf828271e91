"""Findings of benchmarks/fuzz_combined4.py (session 2026-11-28 twelfth, helper fuzz8), each a 3D YAML scene through
the front door.

A cable whose end is carried by rigid links from a prescribed hinge angle: the time of its change (slack or taut)
moves with a parameter by −(∂g/∂p)/(dg/dt), and dg/dt holds the gap's motion through the prescribed angle at fixed
free coordinates (CableSensitivities.prescribed_rate). af426b0 took that part only for ends on bodies whose motion is
prescribed, 0 for ends on the links' dependent nodes: fuzz seed 1 case 6 (a cable to the prescribed crank's pin,
benchmarks/fuzz_combined4.py --seed 1, the swing's CRANK_STOP) ended with "meet cables.c8 changing side while its gap
barely moves (its rate 0 …)", and with the cable to a free swing's bob on that pin the run was reported solved with
the change's time derivative by the rest length 3613.5 where central differences give −5.14, by ks 1.3e-4 for
−1.8e-7."""
from __future__ import annotations

import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of
from tests.test_sensitivities_rigid_links import SLIDER_CRANK

#: a rigid crank turned by a prescribed angle 2t + t², a rigid swing on its pin (a free hinge of stiffness ks), a cable
#: of rest length Lc from a fixed anchor to the pin, taut at the start and going slack at t = 0.0306 as the pin
#: comes closer
CABLE_TO_THE_PIN = """
title: a prescribed crank carrying a free swing, a cable from an anchor to the crank's pin going slack
parameters: {ks: 2.0, mb: 0.2, Lc: 0.2369}
sections:
  crank: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 2.0, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  pin: {at: [0.1, 0.05, 0], mass: 0.5, inertia: [0.001, 0.001, 0.001]}
  bob: {at: [0.1, -0.1, 0], mass: "mb", inertia: [0.001, 0.001, 0.001]}
  anchor: {at: [0.056, 0.289, 0.015], fixed: true}
beams:
  crank: {from: hub, to: pin, section: crank, rigid: true, start: {hinge: {axis: [0, 0, 1], angle: "2.0*t + 1.0*t**2"}}}
  swing: {from: pin, to: bob, section: crank, rigid: true, start: {hinge: {axis: [0, 0, 1], stiffness: "ks"}}}
cables:
  c: {from: anchor, to: pin, EA: 36.2, rest_length: "Lc"}
solve: {analysis: transient, t_end: 0.1, dt: 0.005, tol: 1.0e-12, sensitivities: [ks, Lc]}
output:
  every: 0.005
  probes:
    sw: {hinge: swing.start, quantity: angle}
    ten: {cable: c, quantity: tension}
"""
#: the same cable to the swing's bob (rest length 0.385 of 0.392): its gap moves with the swing's free angle and with
#: the crank's prescribed one; slack at t = 0.0365
CABLE_TO_THE_BOB = (CABLE_TO_THE_PIN.replace("c: {from: anchor, to: pin,", "c: {from: anchor, to: bob,")
                    .replace("Lc: 0.2369", "Lc: 0.385").replace("the crank's pin going slack", "the swing's bob going slack"))


def _event_times(text: str, name: str, value: float) -> list[float]:
    data = yaml.safe_load(text)
    data["parameters"][name] = value
    del data["solve"]["sensitivities"]
    return [e["t"] for e in latdyn.run(latdyn.load_scene(data)).summary["events"]]


def _richardson(text: str, name: str) -> float:
    """The change's time derivative by ``name``: Richardson's (4 D(h/2) − D(h))/3 of central differences D of whole
    runs' event times (h = 1e-3 of the value)."""
    value = yaml.safe_load(text)["parameters"][name]
    h = 1e-3 * value

    def central(step):
        [plus], [minus] = _event_times(text, name, value + step), _event_times(text, name, value - step)
        return (plus - minus) / (2 * step)

    return (4 * central(h / 2) - central(h)) / 3


@pytest.mark.parametrize("text", [CABLE_TO_THE_PIN, CABLE_TO_THE_BOB], ids=["to the pin", "to the bob"])
def test_a_cable_carried_by_a_prescribed_crank_changes_at_the_time_richardson_gives(text):
    """The change's time derivatives (summary.json event_sensitivities) against Richardson differences of the
    event times, to 1e-6 of the largest (measured 3.4e-12 for the pin, 2.0e-7 for the bob, whose reference runs
    without sensitivities land on the change to the events' tolerance); af426b0 ended the pin's run (grazing,
    rate 0) and reported the bob's 3613.5 for Lc where Richardson gives −5.14."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert result.summary["status"] == "solved"
    [event] = result.summary["event_sensitivities"]
    assert event["kind"] == "slack"
    expected = {name: _richardson(text, name) for name in ("ks", "Lc")}
    scale = max(abs(v) for v in expected.values())
    for name, value in expected.items():
        assert abs(event["dt"][name] - value) <= 1e-6 * scale, (name, event["dt"][name], value)


def test_latdyn_run_of_the_cable_to_the_pin_solves_and_writes_the_apis_derivatives(tmp_path):
    """Through the CLI: exit 0 (af426b0: exit 1, "the solver failed: … barely moves (its rate 0 …)") and the API's
    event time derivatives."""
    run, out = latdyn_run(tmp_path, CABLE_TO_THE_PIN, quiet=True)
    assert run.returncode == 0, run.stderr
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(CABLE_TO_THE_PIN))).summary["event_sensitivities"]
    assert summary_of(out)["event_sensitivities"] == api


#: fuzz seed 2 case 24 (benchmarks/fuzz_combined4.py --seed 2, SLIDER_CRANK + cable, compliant stop), cut to
#: t_end 0.04: tests/test_sensitivities_rigid_links.py's slider-crank (a rigid crank, the slider on a guide between
#: stops) whose rod's end hinge has a compliant stop (Hunt–Crossley, damping cd), and a damped cable of two elements
#: (ρA 0.011) from an anchor to the slider, slack at the start (0.2485 of 0.25), taut at t = 0.0293
SLIDER_CRANK_TWO_ELEMENT_CABLE = (
    SLIDER_CRANK.replace("parameters: {tau: 2.0, m: 1.0, k: 30.0}",
                         "parameters: {tau: 2.0, m: 1.0, k: 30.0, Lc: 0.25, rc: 0.011, cd: 3.52}")
    .replace("  hub: {at: [0, 0, 0], fixed: true}\n",
             "  hub: {at: [0, 0, 0], fixed: true}\n  anchor: {at: [0.454, 0.206, 0.128], fixed: true}\n")
    .replace("end: {hinge: {axis: [0, 0, 1]}}}",
             'end: {hinge: {axis: [0, 0, 1], limits: [-0.02, 0.02], contact: {stiffness: 2000.0, exponent: 1.5, '
             'damping: "cd"}}}}')
    .replace("solve: {analysis: transient, t_end: 0.22, dt: 0.005, sensitivities: [tau, m]}",
             'cables:\n  c: {from: anchor, to: slider, EA: 45.0, rest_length: "Lc", damping: 0.34, rhoA: "rc", '
             "elements: 2}\nsolve: {analysis: transient, t_end: 0.04, dt: 0.005, tol: 1.0e-12, sensitivities: [Lc]}"))


@pytest.mark.xfail(strict=True, reason="not mended (fuzz8): the two-element cable's first change beside the "
                   "compliant stop, its time's derivative by Lc reported 6.68 where central differences of the same "
                   "runs (with solve.sensitivities) give 1.4e-5 (reported as solved)")
def test_a_two_element_cable_going_taut_beside_a_compliant_stop_changes_at_the_time_differences_give():
    """The cable's first change (taut, t = 0.029287): its time's derivative by the rest length against central
    differences of the event times of the same runs, with solve.sensitivities (h = 1e-6 of Lc; the runs at Lc ± h
    land it at the same 0.029287 to 7e-12 s).
    Measured on af426b0 and this branch: the package 6.678 against 1.4e-5 (h = 1e-4 … 1e-7 agree), the next two
    changes 12.88 against 3.43 and 11.57 against 7.01, the crank's angle at t = 0.22 (the fuzz scene) by Lc −0.3217
    against −0.0705. The same scene without solve.sensitivities changes at 0.025877 (differences 7.867), as does
    the scene without the compliant stop, with or without them (derivative 7.867478, differences 7.867478); with one
    element every change agrees with the differences to 1e-6 (measured). Not found here: why the run with
    sensitivities passes the change at 0.0259 and lands at 0.0293, whose time Lc does not move (its landing,
    TransientSensitivities.land and latdyn/timeloop/loop.py _land_on_event, beside the compliant stop's contact
    and the cable's inner node)."""
    def first_change(value):
        data = yaml.safe_load(SLIDER_CRANK_TWO_ELEMENT_CABLE)
        data["parameters"]["Lc"] = value
        return latdyn.run(latdyn.load_scene(data)).summary["event_sensitivities"][0]

    first = first_change(0.25)
    assert first["kind"] == "taut"
    h = 1e-6 * 0.25
    expected = (first_change(0.25 + h)["t"] - first_change(0.25 - h)["t"]) / (2 * h)
    assert abs(first["dt"]["Lc"] - expected) <= 1e-5 * max(abs(first["dt"]["Lc"]), abs(expected)), (
        first["dt"]["Lc"], expected)
