"""Transient sensitivities through events (latdyn/analyses/transient_sensitivities.py, "Events"): a
hinge latching (planar and genuinely 3D) and a stop with restitution 0.5, against Richardson-
extrapolated central differences of whole runs (the perturbation varied, small enough that the
event must stay inside the same step of the grid, else the step sequence changes with p; 1e-4 and
5e-5 relative: at 1e-3 the differences' own truncation error after an impact reached 8e-5), the
event time's derivative (summary.json event_sensitivities) against the differences of the event times.
The reference runs ask for sensitivities too: with them the step lands exactly on the event (1e-12)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.reference_runs import reference_runs
from tests.resumed_runs import interrupted_and_whole

LATCH_PLANAR = """
title: planar hinged arm swung open by its spring, latching
parameters: {k: 2.0, c: 0.05, EI: 20.0, rho: 0.5, m: 0.3}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "EI", GJ: 10.0, rhoA: "rho", rhoIy: "0.001*rho", rhoIz: "0.001*rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0, 0], mass: "m", inertia: [0.01, 0.01, 0.01]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: "k", damping: "c", rest_angle: 2.0, lock_at: 0.8}}
solve: {analysis: transient, dt: 0.01, t_end: 0.6, sensitivities: [k, c, EI, rho, m]}
output:
  every: 0.05
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    tip_y: {point: tip, quantity: position, component: y}
    hinge: {hinge: arm.start, quantity: angle}
"""

#: a wheel with its centre of mass off the hinge, on a hinge at the end of a stiff arm with mass and
#: rotary inertia, out of the coordinate planes (arm along (2, 1, 2)/3, hinge axis (1, −2, 0)/√5)
WHEEL_3D = """
title: a wheel on a hinge at the end of a stiff arm, its spring driving it into {what}
parameters: {{k: 1.0, c: 0.05, J: 1.0, m: 1.0, EI: 1.0e4, rho: 1.0}}
sections: {{s: {{EA: 1.0e6, EIy: "EI", EIz: "EI", GJ: "0.8*EI", rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.01*rho"}}}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  wheel: {{at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: "m", com: [0.05, 0, 0],
          inertia: ["J", "J", "1.2*J"]}}
beams:
  arm: {{from: base, to: wheel, section: s, elements: 2,
        end: {{hinge: {{axis: [1, -2, 0], stiffness: "k", damping: "c", rest_angle: 1.0, {event}}}}}}}
solve: {{analysis: transient, t_end: {t_end}, dt: 0.01, sensitivities: [k, c, J, m, EI, rho]}}
output:
  every: {every}
  probes:
    angle: {{hinge: arm.end, quantity: angle}}
    tip_x: {{point: wheel, quantity: position, component: x}}
    mid_z: {{point: "arm.node[1]", quantity: displacement, component: z}}
"""
LATCH_3D = WHEEL_3D.format(what="its latch", event="lock_at: 0.5", t_end=1.1, every=0.02)
#: ends before the wheel comes back onto the stop (1.072 s), where it would rest on it
#: (tests/test_sensitivities_hinge_on_stop.py differentiates that)
STOP_3D = WHEEL_3D.format(what="a stop", event="limits: [-10, 0.5], restitution: 0.5", t_end=1.07, every=0.01)


def _run(text: str, only: str | None = None, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    if only is not None:
        data["solve"]["sensitivities"] = [only]
    return latdyn.run(latdyn.load_scene(data))


def _agree(result, text: str, name: str, tolerance: float = 1e-6, event_tolerance: float = 1e-7) -> float:
    """The largest error of ``result``'s sensitivities by ``name`` (probes over the rows, relative to each
    probe's largest; the event time, relative) against Richardson-extrapolated central differences (of whole runs
    without sensitivities where they write ``result``'s probes: tests/reference_runs.py)."""
    p0 = yaml.safe_load(text)["parameters"][name]
    h = 1e-4 * abs(p0)
    run = reference_runs(text, result, lambda **moved: _run(text, name, **moved))
    central, times = [], []
    for step in (h, h / 2):
        up, down = run(**{name: p0 + step}), run(**{name: p0 - step})
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]]
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"],
                                                                              down.summary["events"])]))
    worst = 0.0
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        error = np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max()
        assert error <= tolerance, (probe, name, error)
        worst = max(worst, error)
    expected_dt = (4 * times[1] - times[0]) / 3
    computed_dt = [event["dt"][name] for event in result.summary["event_sensitivities"]]
    assert computed_dt == pytest.approx(expected_dt, rel=event_tolerance, abs=1e-9), name
    return worst


@pytest.fixture(scope="module")
def latch_planar():
    return _run(LATCH_PLANAR)


@pytest.mark.parametrize("name", ["k", "EI"])
def test_planar_latch_sensitivities_agree_with_richardson_central_differences(latch_planar, name):
    """Through the latch at t = 0.4575 (measured ≤ 1.2e-8 of each probe's largest sensitivity; the event
    time to 3e-9)."""
    assert [e["kind"] for e in latch_planar.summary["events"]] == ["latch"]
    _agree(latch_planar, LATCH_PLANAR, name)


#: LATCH_PLANAR with a second arm hinged at the tip body, latching first (the coordinates renumbered twice)
TWO_LATCHES = (LATCH_PLANAR.replace("title: planar hinged arm swung open by its spring, latching",
                                    "title: two planar arms swung open by their springs, latching in turn")
               .replace("tip: {at: [1.0, 0, 0]", "knee: {at: [1.0, 0, 0]")
               .replace("    to: tip\n", "    to: knee\n").replace("elements: 3", "elements: 2")
               .replace("parameters: {k: 2.0,", "parameters: {k2: 1.0, k: 2.0,")
               .replace("bodies:\n", "bodies:\n  tip: {at: [1.0, 0.8, 0], mass: 0.2, inertia: [0.01, 0.01, 0.01]}\n")
               .replace("solve:", "  fore:\n    from: knee\n    to: tip\n    section: s\n    elements: 2\n"
                                  "    start: {hinge: {axis: [0, 0, 1], stiffness: \"k2\", rest_angle: -2.0, "
                                  "lock_at: -0.6}}\nsolve:")
               .replace("t_end: 0.6, sensitivities: [k, c, EI, rho, m]", "t_end: 1.0, sensitivities: [k2]"))


def test_two_latches_one_after_the_other_agree_with_richardson_central_differences():
    """The fore arm latches at 0.27 s, the arm at 0.71 s: both event times' derivatives and the probes
    through both (measured ≤ 1.7e-8)."""
    result = _run(TWO_LATCHES)
    assert [(e["joint"], e["kind"]) for e in result.summary["events"]] == [("fore.start", "latch"),
                                                                          ("arm.start", "latch")]
    _agree(result, TWO_LATCHES, "k2")


def test_event_sensitivities_in_the_summary_name_the_event_and_every_parameter(latch_planar):
    (event,) = latch_planar.summary["event_sensitivities"]
    assert event["joint"] == "arm.start" and event["kind"] == "latch"
    assert event["t"] == latch_planar.summary["events"][0]["t"]
    assert set(event["dt"]) == {"k", "c", "EI", "rho", "m"}
    assert event["dt"]["k"] < 0 < event["dt"]["m"]   # a stiffer spring latches sooner, a heavier tip later
    # after the latch the angle is the lock_at whatever the parameters
    after = latch_planar.t > event["t"]
    assert np.all(latch_planar.sensitivities[("hinge", "k")][after] == 0.0)


@pytest.mark.parametrize("name", ["J"])
def test_3d_latch_sensitivities_agree_with_richardson_central_differences(name):
    """A wheel latching on a hinge out of the coordinate planes (measured ≤ 1.1e-9; the event time to
    1e-10)."""
    _agree(_run(LATCH_3D), LATCH_3D, name)


def test_3d_stop_with_restitution_sensitivities_agree_with_richardson_central_differences():
    """The same wheel bouncing off its stop with restitution 0.5 (measured ≤ 9e-9; the event time to
    1e-10)."""
    result = _run(STOP_3D)
    assert [e["kind"] for e in result.summary["events"]] == ["stop"]
    _agree(result, STOP_3D, "J")


def test_events_behind_directions_without_inertia_are_refused():
    """Without rotary inertia the beams' twist has no inertia: the impulse response's static part is not
    differentiated, so the run is refused naming solve.sensitivities (exit 2 from the CLI)."""
    text = LATCH_3D.replace(', rhoIy: "0.01*rho", rhoIz: "0.01*rho"', "")
    with pytest.raises(SceneError, match="solve.sensitivities"):
        _run(text)


def test_the_cli_writes_the_event_sensitivities_and_the_api_gives_the_same(tmp_path, latch_planar):
    """Through ``python -m latdyn run``: summary.json ``event_sensitivities`` and sensitivities.csv, equal
    to the API's run."""
    import json

    from latdyn.results.result import Result
    from tests.cli_runs import latdyn_run

    run, out = latdyn_run(tmp_path, LATCH_PLANAR)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["event_sensitivities"] == latch_planar.summary["event_sensitivities"]
    assert summary["events"] == [{k: v for k, v in e.items() if k != "dt"} for e in summary["event_sensitivities"]]
    result = Result.load(out)
    for key, values in latch_planar.sensitivities.items():
        np.testing.assert_array_equal(values, result.sensitivities[key])


def test_a_run_interrupted_after_the_latch_resumes_to_the_same_sensitivities(tmp_path, monkeypatch):
    """The event's sensitivities ride in the checkpoint with the rest: resumed after the latch,
    sensitivities.csv is the uninterrupted one byte for byte."""
    import json

    scene = yaml.safe_load(LATCH_PLANAR)
    scene["solve"]["sensitivities"] = ["k", "m"]
    out, whole = interrupted_and_whole(scene, tmp_path, monkeypatch, 0.52)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
    assert (json.loads((out / "summary.json").read_text())["event_sensitivities"]
            == json.loads((whole / "summary.json").read_text())["event_sensitivities"])


def test_a_landing_that_misses_the_event_is_flagged(latch_planar, monkeypatch):
    """The event-time derivative assumes the step ends on the event: four passes of the regula falsi leave it
    7.9e-8 past it, which summary.json ``warnings`` says; the default landing (to 1e-12) says nothing. (One or two
    passes keep a step short of the latch, whose size the derivative does not take: refused,
    tests/test_sensitivities_fuzz_findings.py.)"""
    import latdyn.analyses.transient_sensitivities as transient_sensitivities

    assert not any("landed" in w for w in latch_planar.summary.get("warnings", []))
    monkeypatch.setattr(transient_sensitivities, "LANDING_PASSES", 4)
    (warning,) = [w for w in _run(LATCH_PLANAR, "k").summary["warnings"] if "landed" in w]
    assert "arm.start" in warning and "not exact" in warning
