"""The discrete adjoint through events (latdyn/analyses/adjoint_sensitivities.py, "Events";
docs/parameters.md, "The discrete adjoint"): a hinge's rigid stop with restitution 0.5 (planar), a latch
(genuinely 3D: arm and hinge axis in no coordinate plane, the coordinates renumbered), a cable going taut then
slack, a compliant stop's onset (more: tests/test_adjoint_events_more.py), and the refusals that stay.

References: the forward method (latdyn/analyses/transient_sensitivities.py) on the same scene — both are the
exact derivative of the same discrete run, events included, so each probe's end, max and min derivatives and
each event time's agree to round-off and the central differences left in the impulse weight's derivative (the hinge
laws' blocks, the parameters other than section values: latdyn/analyses/weight_derivative.py; asserted ≤ 1e-10 of
each output's largest derivative, measured ≤ 2e-12); and Richardson-extrapolated central differences of
whole runs (the perturbation 1e-4 and 5e-5 relative, small enough that the event stays in its step of the grid;
the reference runs ask for the adjoint too, so that their steps land on the event as the differentiated run's)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run
from tests.resumed_runs import interrupted_and_whole
from tests.test_sensitivities_cables import DROP
from tests.test_sensitivities_events import LATCH_3D

#: a wheel on a hinge at the end of a stiff arm, its spring driving it into a rigid stop that throws it back
#: (restitution 0.5, at 0.526 s; it comes back onto the stop at 1.086 s, after the run's end)
STOP_PLANAR = """
title: a planar wheel on a hinge at the end of a stiff arm, its spring driving it into a rigid stop
parameters: {k: 4.0, c: 0.05, J: 1.0, m: 1.0, EI: 1.0e5, rho: 1.0}
sections: {s: {EA: 1.0e6, EIy: "EI", EIz: "EI", GJ: "0.8*EI", rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.01*rho"}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  wheel: {at: [1.0, 0, 0], mass: "m", inertia: ["0.8*J", "0.9*J", "J"]}
beams:
  arm: {from: base, to: wheel, section: s, elements: 2,
        end: {hinge: {axis: [0, 0, 1], stiffness: "k", damping: "c", rest_angle: 1.0, limits: [-10, 0.5],
                      restitution: 0.5}}}
solve: {analysis: transient, t_end: 0.9, dt: 0.01, sensitivities: [k, c, J, m, EI, rho]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.end, quantity: angle}
    rate: {hinge: arm.end, quantity: rate}
    tip_y: {point: wheel, quantity: position, component: y}
    mid_y: {point: "arm.node[1]", quantity: displacement, component: y}
"""


#: LATCH_3D with the latching hinge's torque (its law's while free, the reaction's once latched) and rate, and the
#: root element's bending moment: outputs the adjoint seeds on δv and δv̇ and through their explicit ∂/∂p too
LATCH_3D_PROBES = LATCH_3D.replace(
    "    angle: {hinge: arm.end, quantity: angle}\n",
    "    angle: {hinge: arm.end, quantity: angle}\n    torque: {hinge: arm.end, quantity: torque}\n"
    "    rate: {hinge: arm.end, quantity: rate}\n    moment: {element: \"arm.element[0]\", quantity: moment_y}\n")
#: DROP with the cable's tension and the mass's velocity
DROP_PROBES = DROP.replace(
    "    z: {point: bob, quantity: position, component: z}\n",
    "    z: {point: bob, quantity: position, component: z}\n    tension: {cable: rope, quantity: tension}\n"
    "    velocity: {point: bob, quantity: velocity, component: z}\n")


def _adjoint(text: str) -> str:
    """``text`` with ``solve.sensitivity_method: adjoint`` (its solve spelt ``{analysis: transient, ...}``)."""
    switched = text.replace("analysis: transient,", "analysis: transient, sensitivity_method: adjoint,")
    assert switched != text and yaml.safe_load(switched)["solve"]["sensitivity_method"] == "adjoint"
    return switched


def _run(text: str, only: str | None = None, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    if only is not None:
        data["solve"]["sensitivities"] = [only]
    return latdyn.run(latdyn.load_scene(data))


def _disagreement(forward: dict, adjoint: dict, events: bool = True) -> float:
    """The largest difference of two summaries' ``probe_sensitivities`` and ``event_sensitivities``, relative to
    each output's largest derivative (by the parameters); the events' joints, kinds and times must be the same, and
    with ``events`` there must be some."""
    worst = 0.0
    outputs = [(probe, which, by_name, adjoint["probe_sensitivities"][probe][which])
               for probe, by in forward["probe_sensitivities"].items() for which, by_name in by.items()]
    assert len(forward["event_sensitivities"]) == len(adjoint["event_sensitivities"]) >= (1 if events else 0)
    for f, a in zip(forward["event_sensitivities"], adjoint["event_sensitivities"]):
        assert (f["joint"], f["kind"], f["t"]) == (a["joint"], a["kind"], a["t"])
        outputs.append((f["joint"], f["kind"], f["dt"], a["dt"]))
    for _, _, f, a in outputs:
        assert f.keys() == a.keys()
        f_values, a_values = np.array(list(f.values())), np.array([a[name] for name in f])
        scale = np.abs(f_values).max()
        if scale:
            worst = max(worst, float(np.abs(a_values - f_values).max() / scale))
    return worst


@pytest.fixture(scope="module")
def stop_planar():
    """(forward, adjoint) results of STOP_PLANAR through the API."""
    return _run(STOP_PLANAR), _run(_adjoint(STOP_PLANAR))


def test_a_planar_stop_with_restitution_adjoint_equals_the_forward_method(stop_planar):
    """Through the stop at 0.526 s (e = 0.5), six parameters of four kinds (hinge spring and damper, the
    wheel's mass and inertia, the arm's EI and ρ): measured 1.9e-12 of each output's largest derivative (2.8e-12 with
    the impulse weight's derivative differenced along every coordinate, before latdyn/analyses/weight_derivative.py)."""
    forward, adjoint = stop_planar
    assert [e["kind"] for e in adjoint.summary["events"]] == ["stop"]
    assert _disagreement(forward.summary, adjoint.summary) <= 1e-11


def test_the_cli_writes_the_adjoints_event_sensitivities_as_the_api(tmp_path, stop_planar):
    """``python -m latdyn run``: summary.json ``event_sensitivities`` and ``probe_sensitivities`` as the API's
    adjoint gives them (to the digits JSON keeps), sensitivities.csv its end row."""
    completed, out = latdyn_run(tmp_path, _adjoint(STOP_PLANAR), quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    _, adjoint = stop_planar
    assert summary["event_sensitivities"] == adjoint.summary["event_sensitivities"]
    assert summary["probe_sensitivities"] == adjoint.summary["probe_sensitivities"]
    header, row = (out / "sensitivities.csv").read_text().splitlines()
    assert header.split(",")[:2] == ["t", "angle/k"]
    assert float(row.split(",")[1]) == pytest.approx(adjoint.summary["probe_sensitivities"]["angle"]["end"]["k"],
                                                     rel=1e-12)


@pytest.mark.parametrize("name", ["k", "J"])
def test_a_planar_stop_adjoint_agrees_with_richardson_central_differences(stop_planar, name):
    """Each probe's end, max and min derivative and the stop time's against central differences of whole runs
    at p ± h, p ± h/2 (h = 1e-4 p) extrapolated, relative to the probe's largest over the rows: measured
    k 1.4e-9, J 7.8e-10 (the event time, relative: k 5.6e-11, J 3.4e-11)."""
    _, adjoint = stop_planar
    p0 = yaml.safe_load(STOP_PLANAR)["parameters"][name]
    central, times = [], []
    for step in (1e-4 * p0, 0.5e-4 * p0):
        up, down = (_run(_adjoint(STOP_PLANAR), name, **{name: p0 + sign * step}) for sign in (1, -1))
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]] == ["stop"]
        central.append({probe: (up.probes[probe] - down.probes[probe]) / (2 * step) for probe in up.probes})
        times.append((up.summary["events"][0]["t"] - down.summary["events"][0]["t"]) / (2 * step))
    worst = 0.0
    for probe, by in adjoint.summary["probe_sensitivities"].items():
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        values = adjoint.probes[probe]
        for which, row in (("end", len(values) - 1), ("max", int(np.argmax(values))), ("min", int(np.argmin(values)))):
            error = abs(by[which][name] - expected[row]) / np.abs(expected).max()
            assert error <= 1e-8, (probe, which, error)
            worst = max(worst, error)
    expected_time = (4 * times[1] - times[0]) / 3
    assert adjoint.summary["event_sensitivities"][0]["dt"][name] == pytest.approx(expected_time, rel=1e-9)


def test_a_3d_latch_adjoint_equals_the_forward_method():
    """The wheel of tests/test_sensitivities_events.py latching at 1.058 s, its arm along (2, 1, 2)/3 and its
    hinge axis (1, −2, 0)/√5, the centre of mass off the hinge; the latched hinge's coordinate leaves the
    numbering (the reverse pass renumbers back). Six parameters (hinge spring and damper, inertia, mass, EI, ρ); the
    hinge's angle, rate and torque (the reaction once latched), the wheel's position, a node's displacement and the
    root element's bending moment: measured 9.2e-13 of each output's largest derivative."""
    assert LATCH_3D_PROBES != LATCH_3D
    forward, adjoint = _run(LATCH_3D_PROBES), _run(_adjoint(LATCH_3D_PROBES))
    assert [e["kind"] for e in adjoint.summary["events"]] == ["latch"]
    assert _disagreement(forward.summary, adjoint.summary) <= 1e-11


def test_a_cable_going_taut_then_slack_adjoint_equals_the_forward_method():
    """A mass dropped on a slack cable: taut at 0.319 s, slack at 0.394 s; by the rest length and EA (no jump
    there: the event times through the gap's forms, transposed); the mass's position and velocity and the cable's
    tension: measured 1.5e-15; the taut time's derivative by
    L has its closed form dt_e/dL = 1/(g t_e) (free fall from rest through L − 0.5)."""
    assert DROP_PROBES != DROP
    forward, adjoint = _run(DROP_PROBES), _run(_adjoint(DROP_PROBES))
    assert [e["kind"] for e in adjoint.summary["event_sensitivities"]] == ["taut", "slack"]
    assert _disagreement(forward.summary, adjoint.summary) <= 1e-10
    taut = adjoint.summary["event_sensitivities"][0]
    assert taut["dt"]["L"] == pytest.approx(1.0 / (9.81 * taut["t"]), rel=1e-9)


def test_a_run_interrupted_after_the_stop_resumes_to_the_same_adjoint(tmp_path, monkeypatch):
    """The stored trajectory with its events' numberings and states rides in the checkpoint: interrupted after
    the stop and resumed, the same summary.json sensitivities and sensitivities.csv byte for byte."""
    scene = yaml.safe_load(_adjoint(STOP_PLANAR))
    scene["solve"].update({"sensitivities": ["k", "J"], "t_end": 0.6})
    out, whole = interrupted_and_whole(scene, tmp_path, monkeypatch, 0.55)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
    resumed, uninterrupted = (json.loads((path / "summary.json").read_text()) for path in (out, whole))
    assert resumed["probe_sensitivities"] == uninterrupted["probe_sensitivities"]
    assert resumed["event_sensitivities"] == uninterrupted["event_sensitivities"]


def _compliant(text: str) -> str:
    """``text`` with the rigid stop made compliant (``contact`` in place of ``restitution``)."""
    changed = text.replace("restitution: 0.5}", "contact: {stiffness: 1.0e4, exponent: 1.5, damping: 0.1}}")
    assert changed != text
    return changed


def test_a_law_in_t_beside_a_stop_is_taken_by_the_adjoint_as_the_forward_method():
    """A hinge stiffness of t beside the stop (refused, naming the key, on 86d57d9; tests/test_adjoint_events_more.py
    lifted it): the adjoint equals the forward method, the stop time's derivative included (measured 1.6e-12)."""
    text = STOP_PLANAR.replace('stiffness: "k",', 'stiffness: "k*(1 + 0.1*t)",')
    assert text != STOP_PLANAR
    assert _disagreement(_run(text).summary, _run(_adjoint(text)).summary) <= 1e-10


def test_the_cli_takes_a_compliant_stop_with_the_adjoint_as_the_forward_method(tmp_path):
    """``python -m latdyn run`` on the planar wheel's compliant stop (exit 2, refused, on 86d57d9): exit 0, its
    summary.json the API's bit for bit and the forward method's within 1e-10 (measured 1.1e-11)."""
    completed, out = latdyn_run(tmp_path, _compliant(_adjoint(STOP_PLANAR)), quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    api = _run(_compliant(_adjoint(STOP_PLANAR))).summary
    assert summary["probe_sensitivities"] == api["probe_sensitivities"]
    forward = _run(_compliant(STOP_PLANAR)).summary
    assert forward["events"] == api["events"] == [] and forward["event_sensitivities"] == []
    for probe, by in forward["probe_sensitivities"].items():
        for which, values in by.items():
            scale = max(abs(v) for v in values.values())
            worst = max(abs(api["probe_sensitivities"][probe][which][name] - v) for name, v in values.items())
            assert worst <= 1e-10 * scale, (probe, which, worst / scale)


def test_a_planar_hinge_resting_on_its_stop_adjoint_equals_the_forward_method():
    """A rigid stop with restitution 0 leaves the hinge resting on it: the adjoint transposes its coming to rest and
    the steps it rests (refused on int22 0d1fc61, exit 1) and equals the forward method (more:
    tests/test_adjoint_hinge_on_stop.py)."""
    text = STOP_PLANAR.replace("restitution: 0.5", "restitution: 0.0")
    forward, adjoint = _run(text), _run(_adjoint(text))
    assert adjoint.summary["events"] == forward.summary["events"] and adjoint.summary["events"][0]["kind"] == "stop"
    assert _disagreement(forward.summary, adjoint.summary) <= 1e-10


def test_a_rest_beside_a_geometry_parameter_is_taken_by_the_adjoint_as_the_forward_method(tmp_path):
    """A rigid stop with restitution 0 leaves the hinge resting on it beside a geometry parameter (the wheel's x):
    refused by the adjoint inside the accepted step's events until adjgeo (exit 1 naming the stop's key), taken since,
    through the CLI: exit 0, and summary.json's probe and event sensitivities those of the forward method's run
    (measured 1.3e-12; tests/test_adjoint_geometry_linked.py: the round-off both carry on stiff members)."""
    text = (STOP_PLANAR.replace("restitution: 0.5", "restitution: 0.0").replace("rho: 1.0}", "rho: 1.0, xw: 1.0}")
            .replace('wheel: {at: [1.0, 0, 0]', 'wheel: {at: ["xw", 0, 0]').replace("EI, rho]", "EI, rho, xw]"))
    assert text.count("xw") == 3
    runs = {}
    for method, scene in (("forward", text), ("adjoint", _adjoint(text))):
        (tmp_path / method).mkdir()
        completed, out = latdyn_run(tmp_path / method, scene, quiet=True)
        assert completed.returncode == 0, completed.stderr
        runs[method] = json.loads((out / "summary.json").read_text())
    assert runs["adjoint"]["events"] == runs["forward"]["events"]
    assert any(abs(by["end"]["xw"]) > 1e-6 for by in runs["forward"]["probe_sensitivities"].values())
    assert _disagreement(runs["forward"], runs["adjoint"]) <= 1e-9


#: STOP_PLANAR with the hinge's torque from a stateless PD-like controller of the hinge's angle (no t in it)
STOP_PLANAR_CONTROLLED = STOP_PLANAR.replace("parameters: {k: 4.0,", "parameters: {Kp: 0.5, k: 4.0,").replace(
    "solve:", "controllers:\n  pd: {output: \"Kp*(0.3 - angle)\"}\nsolve:").replace(
    "damping: \"c\",", "damping: \"c\", torque: \"pd\",").replace("sensitivities: [k,", "sensitivities: [Kp, k,")


def test_a_stateless_controller_beside_a_stop_is_taken_by_the_adjoint_as_the_forward_method():
    """A hinge torque from a controller whose output names no t is no law in t: the adjoint takes it beside the
    stop (it was refused as "a law in t") and equals the forward method (measured 1.5e-11, the angle's end by J; 1.0e-11
    on main 2350dca in the same session); a controller whose output names t (refused on 86d57d9, naming the torque)
    is taken too since tests/test_adjoint_events_more.py: the same (measured 9.4e-12)."""
    assert STOP_PLANAR_CONTROLLED.count("Kp") == 3
    forward, adjoint = _run(STOP_PLANAR_CONTROLLED), _run(_adjoint(STOP_PLANAR_CONTROLLED))
    assert [e["kind"] for e in adjoint.summary["events"]] == ["stop"]
    assert adjoint.summary["probe_sensitivities"]["tip_y"]["end"]["Kp"] != 0.0
    assert _disagreement(forward.summary, adjoint.summary) <= 1e-10
    in_time = STOP_PLANAR_CONTROLLED.replace("\"Kp*(0.3 - angle)\"", "\"Kp*(0.3 - angle) + 0.01*t\"")
    assert in_time != STOP_PLANAR_CONTROLLED
    assert _disagreement(_run(in_time).summary, _run(_adjoint(in_time)).summary) <= 1e-10
