"""Issue 34: the forward method's sensitivities of a hinge resting on its rigid stop (docs/parameters.md,
"Sensitivities through events", "A hinge resting on its stop").

A hinge that lands on its rigid stop with restitution 0 is locked there while the stop holds it and released at the
first step's end where its reaction would pull it off (latdyn/timeloop/events.py, "resting on a stop"); one that
started a step on the stop and ends it beyond is put back on it at that step's end by the projection
q⁺ = q ∘ exp(−X(NᵀX)⁻¹(θ − stop)). Differentiated (latdyn/analyses/transient_sensitivities.py
``_settle_or_release``, ``_projected``): the landing and its impulse as a stop's with e = 0, the restart on the
locked model, the locked angle's δθ = 0, the release's restart at a step's end (δt 0), and the projection's
δ[X(NᵀX)⁻¹](θ − stop) through the impulse weight's derivative. Every test here fails on 40bf44a, where each scene
was refused (SolverError "meet a hinge resting on its stop", exit 1, naming no key), checked by running this file
there.

Against Richardson-extrapolated central differences of whole runs (the perturbation 1e-4 and 5e-5 relative, not the
time step; ``solve.tol`` 1e-12 in the scenes, so the references' Newton tolerance does not show; the reference runs
keep ``solve.sensitivities``, so their steps land on the stop as the differentiated run's), relative to each probe's
largest; the event times' derivatives too; the CLI against the API to the bit. The discrete adjoint's are the forward
method's (tests/test_adjoint_hinge_on_stop.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run
from tests.resumed_runs import interrupted_and_whole
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_sensitivities_events import _agree, _run
from tests.test_sensitivities_guides import STOP_3D as GUIDE_STOP

#: a flexible boom deploying about a skew hinge at its root (axis (1, −2, 0.5)), driven by its spring and a torque
#: onto its rigid stop at 0.6 rad with restitution 0 (at 0.839 s), where its spring and torque hold it to the end but
#: for three rattles early on (its vibration pulling it off at a step's end, the next step's end putting it back)
BOOM = """
title: a boom deploying about a skew hinge at its root onto its rigid stop, restitution 0, held there by its spring
parameters: {k: 2.0, c: 2.0, P: 2.0, m: 1.0, EI: 2.0e+6, rho: 0.5, zt: 1.0}
sections: {s: {EA: 1.0e+8, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.01*rho"}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0.5, "zt"], mass: "m", inertia: [0.02, 0.03, 0.025]}
beams:
  boom: {from: base, to: tip, section: s, elements: 3,
         start: {hinge: {axis: [1, -2, 0.5], stiffness: "k", damping: "c", rest_angle: 2.0, torque: "P",
                         limits: [-10, 0.6], restitution: 0.0}}}
solve: {analysis: transient, t_end: 1.5, dt: 0.01, tol: 1.0e-12, sensitivities: [k, c, P, m, rho, zt]}
output:
  every: 0.01
  probes:
    angle: {hinge: boom.start, quantity: angle}
    tip_z: {point: tip, quantity: position, component: z}
    mid_y: {point: "boom.node[2]", quantity: displacement, component: y}
"""

#: the boom pushed onto its stop by a torque P (1.5 − t) against its spring (rest angle 0): it comes to rest there at
#: 0.981 s and rattles on it, its vibration pulling it off at a step's end (released: 1.00, 1.02, … 1.24 s) and the
#: next step's end putting it back (the projection: 1.01, 1.03, … 1.25 s), 13 times, until the falling torque lets
#: it go for good at 1.26 s (measured)
RELEASE = (BOOM.replace('rest_angle: 2.0, torque: "P"', 'rest_angle: 0.0, torque: "P*(1.5 - t)"')
           .replace("P: 2.0,", "P: 4.0,").replace("t_end: 1.5", "t_end: 1.6")
           .replace("held there by its spring", "held there, then pulled off as its torque falls"))

#: the boom less stiff (EI 2e5): it comes to rest at 0.993 s, its rebound pulls it off at 1.01 s, it lands again at
#: 1.073 s (not held there), is put back at the ends of the steps to 1.08 and 1.10 s (released at 1.09 s between)
#: and rests from 1.10 s
REBOUND = (BOOM.replace("P: 2.0, m: 1.0, EI: 2.0e+6", "P: 0.5, m: 1.0, EI: 2.0e+5").replace("EA: 1.0e+8", "EA: 1.0e+6")
           .replace("held there by its spring", "its rebound pulling it off and back"))

#: a gimbal of flexible posts: the outer ring turns about (0, 0.2, 1) under its torque T while the inner ring's hinge
#: (axis (1, 0, 0.3)) is pushed onto its upper stop (0.3 rad, restitution 0, at 0.308 s) by P and held there
GIMBAL = """
title: a gimbal, its inner ring held on its rigid stop by a torque while the outer ring turns under its own
parameters: {k1: 1.0, c1: 0.5, T: 2.0, k2: 1.0, c2: 1.0, P: 1.5, m: 2.0, EI: 1.0e+6}
sections: {s: {EA: 1.0e+8, EIy: "EI", EIz: "EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.005, rhoIz: 0.005}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  outer: {at: [0, 0, 0.4], mass: 1.0, inertia: [0.05, 0.05, 0.08]}
  inner: {at: [0.5, 0.2, 0.6], mass: "m", com: [0.05, 0.02, 0], inertia: [0.03, 0.04, 0.05]}
beams:
  post: {from: base, to: outer, section: s, elements: 2,
         start: {hinge: {axis: [0, 0.2, 1], stiffness: "k1", damping: "c1", rest_angle: 0.0, torque: "T"}}}
  ring: {from: outer, to: inner, section: s, elements: 2,
         start: {hinge: {axis: [1, 0, 0.3], stiffness: "k2", damping: "c2", rest_angle: 0.0, torque: "P",
                         limits: [-0.5, 0.3], restitution: 0.0}}}
solve: {analysis: transient, t_end: 1.2, dt: 0.01, tol: 1.0e-12, sensitivities: [k1, T, c2, P, m]}
output:
  every: 0.01
  probes:
    angle: {hinge: ring.start, quantity: angle}
    kinetic: {energy: kinetic}
    strain: {energy: strain}
    outer: {hinge: post.start, quantity: angle}
    inner_x: {point: inner, quantity: position, component: x}
    ring_z: {point: "ring.node[1]", quantity: displacement, component: z}
"""


@pytest.fixture(scope="module")
def runs():
    return {}


def _checked(runs, text):
    if text not in runs:
        runs[text] = _run(text)
    return runs[text]


def _rests_to_the_end(result, stop: float) -> None:
    """The hinge ends the run on its stop (locked there: its angle the stop's to the bit)."""
    assert result.probes["angle"][-1] == stop


@pytest.mark.parametrize("name", ["k", "P", "rho", "zt"])
def test_a_boom_landing_on_its_stop_and_resting_there_agrees_with_richardson(runs, name):
    """Comes to rest at 0.839 s (restitution 0), its vibration pulling it off and the projection putting it back three
    times (released at 0.85, 0.88, 0.92 s, put back at 0.86, 0.89, 0.93 s), then rests to 1.5 s: by the spring, the
    torque, a section value and the tip's height (geometry). Measured: k 9.8e-11, c 2.4e-10, P 9.0e-11, m 7.5e-11, rho 2.5e-10 of each probe's largest; the
    landing time's derivative to 2.5e-10."""
    result = _checked(runs, BOOM)
    assert [e["kind"] for e in result.summary["events"]] == ["stop"]
    _rests_to_the_end(result, 0.6)
    _agree(result, BOOM, name)


@pytest.mark.parametrize("name", ["k", "P"])
def test_a_hinge_held_on_its_stop_then_released_by_its_reversing_torque_agrees_with_richardson(runs, name):
    """Rattling on the stop from 0.981 s (13 releases and projections), released for good at 1.26 s, swung back off the
    stop. Measured: k 1.8e-8, P 7.1e-10 (EI 1.5e-7, its derivative small)."""
    result = _checked(runs, RELEASE)
    assert [e["kind"] for e in result.summary["events"]] == ["stop"]
    angle = result.probes["angle"]
    assert 0.6 - angle[-1] > 1e-2 and max(angle) == 0.6
    _agree(result, RELEASE, name)


@pytest.mark.parametrize("name", ["c", "P"])
def test_a_hinge_put_back_on_its_stop_at_a_steps_end_agrees_with_richardson(runs, name):
    """The rebound pulls the boom off its stop (1.01 s); it lands again (1.073 s, not held), and is projected back onto
    the stop at the ends of the steps to 1.08 and 1.10 s, having started them on it (δ[X(NᵀX)⁻¹](θ − stop) differentiated). Measured: c 5.3e-9, P 7.6e-10; without the projection's δX μ term
    (``_projected``'s weight derivative left out) c 3.2e-5, P 2.9e-5."""
    result = _checked(runs, REBOUND)
    assert [e["kind"] for e in result.summary["events"]] == ["stop", "stop"]
    _rests_to_the_end(result, 0.6)
    _agree(result, REBOUND, name)


@pytest.mark.parametrize("name", ["T", "m"])
def test_a_gimbal_ring_held_on_its_stop_while_the_other_turns_agrees_with_richardson(runs, name):
    """The inner ring rests on its stop from 0.308 s while the outer ring turns; with the kinetic and strain energies.
    Measured: T 1.9e-8 (kinetic 1.3e-8, strain 1.6e-8), P 1.8e-7, m 3.1e-8 (the kinetic energy; the others ≤ 1.2e-8)."""
    result = _checked(runs, GIMBAL)
    assert [e["kind"] for e in result.summary["events"]] == ["stop"]
    _rests_to_the_end(result, 0.3)
    assert abs(result.probes["outer"][-1] - result.probes["outer"][-20]) > 1e-2   # the outer ring still turns
    _agree(result, GIMBAL, name)


def test_the_held_hinges_torque_agrees_with_richardson():
    """The hinge's torque probe (while it rests, the stop's reaction R of the locked model) of the released boom by
    k, against Richardson at steps 1e-3 and 5e-4 relative: measured 2.1e-7 of its largest (at 1e-4 the reaction's
    round-off shows: 2.3e-6; at 1e-5 1.8e-5)."""
    text = RELEASE.replace("    mid_y:", "    torque: {hinge: boom.start, quantity: torque}\n    mid_y:")
    result = _run(text, "k")
    central = []
    for step in (2e-3, 1e-3):
        up, down = _run(text, "k", k=2.0 + step), _run(text, "k", k=2.0 - step)
        central.append((up.probes["torque"] - down.probes["torque"]) / (2 * step))
    expected = (4 * central[1] - central[0]) / 3
    assert np.abs(result.sensitivities[("torque", "k")] - expected).max() <= 1e-6 * np.abs(expected).max()


def test_the_cli_equals_the_api_on_the_released_hinge(runs, tmp_path):
    """``python -m latdyn run`` of RELEASE: exit 0 (1 on 40bf44a), summary.json's probe and event sensitivities
    ``latdyn.run``'s to the bit."""
    completed, out = latdyn_run(tmp_path, RELEASE, quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    api = _checked(runs, RELEASE).summary
    assert summary["probe_sensitivities"] == api["probe_sensitivities"]
    assert summary["event_sensitivities"] == api["event_sensitivities"]


@pytest.mark.parametrize("text", [BOOM, REBOUND], ids=["rests", "put-back"])
def test_the_loop_of_steps_on_and_off_gives_the_same_sensitivities(text):
    """The loop of steps takes the steps before the landing; those the hinge rests (checked for release) from Python:
    the same sensitivities to the bit as the per-step path."""
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = ["k", "zt"]
    runs = runs_with_the_loop_on_and_off(data)
    assert_same_sensitivities(runs[True], runs[False], nonzero="each")
    assert runs[True].summary["sensitivity_steps_in_loop"] > 0


def test_the_adjoint_through_a_hinge_resting_on_its_stop_is_the_forward_methods():
    """The discrete adjoint transposes the rest (refused on int22 0d1fc61): by k its derivatives are the forward
    method's on BOOM (more, and its bound: tests/test_adjoint_hinge_on_stop.py)."""
    from tests.test_adjoint_events import _disagreement

    data = yaml.safe_load(BOOM)
    data["solve"]["sensitivities"] = ["k"]
    forward = latdyn.run(latdyn.load_scene(data))
    data["solve"]["sensitivity_method"] = "adjoint"
    adjoint = latdyn.run(latdyn.load_scene(data))
    assert _disagreement(forward.summary, adjoint.summary) <= 1e-9


def test_a_guide_coming_to_rest_on_its_stop_is_refused_naming_its_limits(tmp_path):
    """A guided slider landing on its rigid stop with restitution 0 (at 0.240 s) comes to rest in a model with guides,
    whose reduction's restart is not differentiated there: ``latdyn run`` exits 2 naming the guide's ``limits`` and
    the file (exit 1, a SolverError naming neither, on 40bf44a)."""
    text = GUIDE_STOP.replace("restitution: 0.5", "restitution: 0.0")
    assert text != GUIDE_STOP
    completed, _ = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 2, completed.stderr
    assert "scene.yaml" in completed.stderr and "bodies.slider.guide.limits" in completed.stderr
    assert "in a model with guides" in completed.stderr and "Traceback" not in completed.stderr


def test_a_run_interrupted_while_the_hinge_rests_resumes_to_the_same_sensitivities(tmp_path, monkeypatch):
    """Interrupted (Ctrl-C) at 1.1 s, the hinge resting on its stop (locked there: the checkpoint keeps
    ``resting``), and resumed: sensitivities.csv byte for byte and summary.json's probe and event sensitivities
    those of the run uninterrupted, through the release at ≈ 1.3 s."""
    scene = yaml.safe_load(RELEASE)
    scene["solve"]["sensitivities"] = ["k", "zt"]
    out, whole = interrupted_and_whole(scene, tmp_path, monkeypatch, 1.1)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
    resumed, uninterrupted = (json.loads((path / "summary.json").read_text()) for path in (out, whole))
    assert resumed["probe_sensitivities"] == uninterrupted["probe_sensitivities"]
    assert resumed["event_sensitivities"] == uninterrupted["event_sensitivities"]
