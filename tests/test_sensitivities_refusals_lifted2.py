"""Issue 34: gradients the forward method refused on 86d57d9, now computed (docs/parameters.md, "Transient
sensitivities").

1. A point's velocity beside guides (in the global frame and in a body's, of the guided body itself, of a free node in
the guided body's axes, read by a controller that drives the guide): a guided body is a dependent node of the links'
reduction, whose rates δv_dep = P δv + ∂(J v)/∂q δq come from the generated ``prismatic_link_edge_rates_D_q``
(latdyn/analyses/link_sensitivities.py ``dependent_rates``, which the rigid links' velocities and the guided energies
already took). Against Richardson-extrapolated central differences of whole runs (``solve.tol`` 1e-12), the loop of
steps on and off to the bit, the adjoint against the forward method, the CLI against the API.

Every case here was refused on 86d57d9 (SceneError naming ``solve.sensitivities``)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, the_loop_off_writes_the_same
from tests.reference_runs import reference_runs
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_sensitivities_guides import GUIDE_3D, STOP_3D
from tests.test_sensitivities_refusals_lifted import BEAD_ON_GIMBAL, _adjoint_error, _both

#: a point's velocity: the guided slider's in the global frame and in the arm tip's axes, the tip's and the arm's
#: middle node's in the slider's axes
_VELOCITIES = ("    slider_vz: {point: slider, quantity: velocity, component: z}\n"
               "    slider_vx: {point: slider, quantity: velocity, component: x}\n"
               "    slider_vt: {point: slider, quantity: velocity, frame: tip, component: y}\n"
               "    tip_vs: {point: tip, quantity: velocity, frame: slider, component: x}\n"
               "    mid_vs: {point: \"arm.node[1]\", quantity: velocity, frame: slider, component: z}\n")
_SLIDE = "    s: {guide: slider, quantity: position}\n"
#: the mass on a skew guide at the tip of the flexible 3D arm with the velocity probes, the guide's force a controller
#: of the slider's and the tip's velocities (gain Kv)
GUIDE_VELOCITY = (GUIDE_3D.replace("parameters: {k:", "parameters: {Kv: 0.8, k:")
                  .replace('rest: "rest"}}', 'rest: "rest", force: "damp"}}')
                  .replace("solve: {", 'controllers:\n  damp: {output: "-Kv*slider_vz - 0.3*Kv*tip_vy"}\nsolve: {')
                  .replace(_SLIDE, _SLIDE + _VELOCITIES + "    tip_vy: {point: tip, quantity: velocity, component: y}\n")
                  .replace("sensitivities: [k, m, EI, rest]", "sensitivities: [Kv, k, m, EI]"))
#: the slider hitting its rigid stop (e = 0.5) with the velocity probes
STOP_VELOCITY = STOP_3D.replace(_SLIDE, _SLIDE + _VELOCITIES)
#: the bead on a skew guide on the gimbal's inner ring (rigid links), hitting its stops three times, its velocity probed
BEAD_VELOCITY = BEAD_ON_GIMBAL.replace(
    "    bead_y:", "    bead_vy: {point: bead, quantity: velocity, component: y}\n"
    "    bead_vz: {point: bead, quantity: velocity, component: z}\n"
    "    tip_vb: {point: tip, quantity: velocity, frame: bead, component: x}\n    bead_y:")
assert "damp:" in GUIDE_VELOCITY and "slider_vt" in STOP_VELOCITY and "bead_vy" in BEAD_VELOCITY


def _run(text: str, **parameters):
    """``text`` through the API at ``parameters``, Newton's tolerance 1e-12 (the references' runs too)."""
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    data["solve"]["tol"] = 1e-12
    return latdyn.run(latdyn.load_scene(data))


def _richardson_error(text: str, result, name: str, relative: float = 1e-4) -> float:
    """The largest error of ``result``'s sensitivities by ``name`` (each probe over its rows, relative to its largest)
    against Richardson-extrapolated central differences of whole runs (steps ``relative`` and half of it); the event
    times' derivatives (summary.json event_sensitivities) likewise, relative to the largest."""
    p0 = yaml.safe_load(text)["parameters"][name]
    run = reference_runs(text, result, lambda **moved: _run(text, **moved))
    central, times = [], []
    for step in (relative * abs(p0), relative / 2 * abs(p0)):
        up, down = run(**{name: p0 + step}), run(**{name: p0 - step})
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]]
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"],
                                                                              down.summary["events"])]))
    worst = 0.0
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        worst = max(worst, np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max())
    if len(times[0]):
        expected = (4 * times[1] - times[0]) / 3
        computed = np.array([event["dt"][name] for event in result.summary["event_sensitivities"]])
        worst = max(worst, np.abs(computed - expected).max() / np.abs(expected).max())
    return worst


# ------------------------------------------------------------------------------ 1. a point's velocity beside guides
@pytest.mark.parametrize("text, names, events", [
    (GUIDE_VELOCITY, ["Kv", "m"], []), (STOP_VELOCITY, ["EI"], ["stop"]), (BEAD_VELOCITY, ["ks"], ["stop"] * 3)],
    ids=["guide-controller", "guide-stop", "guide-on-links-stops"])
def test_a_points_velocity_beside_guides_agrees_with_richardson_central_differences(text, names, events):
    """Measured (every probe's worst over the rows, relative to its largest; the event times too): the guide with the
    controller Kv 4.0e-8, k 2.1e-9, m 2.5e-9, EI 3.6e-9 (the body frames' velocities without the controller k 9.3e-9,
    m 6.1e-9, EI 2.3e-9); the stop k 2.8e-9, m 2.7e-9, EI 3.4e-9; the bead on the gimbal ks 7.5e-9, k1 8.5e-10,
    ms 1.9e-9."""
    result = _run(text)
    assert [e["kind"] for e in result.summary["events"]] == events
    for name in names:
        assert _richardson_error(text, result, name) <= 1e-6, name


@pytest.mark.parametrize("text", [GUIDE_VELOCITY, STOP_VELOCITY, BEAD_VELOCITY],
                         ids=["guide-controller", "guide-stop", "guide-on-links-stops"])
def test_a_points_velocity_beside_guides_is_the_same_with_the_loop_on_and_off(text):
    """The loop of steps takes the smooth steps (80 of 80, 59 of 61, 27 of 33) and writes the per-step Python path's
    sensitivities to the bit; the adjoint gives the forward method's (measured 7.0e-13, 5.3e-14, 2.5e-12)."""
    runs = runs_with_the_loop_on_and_off(text)
    assert_same_sensitivities(runs[True], runs[False], nonzero="some")
    assert runs[True].summary["sensitivity_steps_in_loop"] > 0
    forward, adjoint = _both(text)
    assert _adjoint_error(forward, adjoint) <= 1e-10


def test_a_points_velocity_beside_guides_through_the_cli_equals_the_api(tmp_path):
    """``latdyn run`` of the guide with the controller: summary.json's probe sensitivities those of ``latdyn.run`` on
    the same text to the bit, sensitivities.csv's end row too; the loop off in a fresh process writes the same files."""
    run, out = latdyn_run(tmp_path, GUIDE_VELOCITY)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(GUIDE_VELOCITY)))
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]
    header, *_, last = (out / "sensitivities.csv").read_text().splitlines()
    columns = dict(zip(header.split(","), (float(x) for x in last.split(","))))
    assert columns["slider_vz/Kv"] == api.summary["probe_sensitivities"]["slider_vz"]["end"]["Kv"]
    the_loop_off_writes_the_same(tmp_path, out)
