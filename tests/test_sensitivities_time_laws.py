"""Transient sensitivities through events when a load, a hinge law, a prescribed motion or a reel depends on t
(latdyn/analyses/transient_sensitivities.py, ExplicitTime; docs/parameters.md, "Laws in time"): an event
moves the end of the step that lands on it, and of the steps after it up to the next grid point, in time by
δt_e, so each of those steps carries ∂r/∂t δt_{n+1}. Checked against Richardson-extrapolated central
differences of whole runs (the perturbation varied, 1e-4 and 5e-5 relative, the step fixed: the helpers of
tests/test_sensitivities_events.py and tests/test_sensitivities_cables.py), and a reel's taut time against
its closed form. Each check fails without ∂r/∂t (measured 6.4e-4 for the torque, 0.62 for the hub, 1.3e-2
for the reel). Together about 22 s at a load of 4.4 on 2 cores."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

import tests.test_sensitivities_cables as cables
import tests.test_sensitivities_events as events
import tests.test_sensitivities_guides as guides
from tests.cli_runs import latdyn_run

#: the planar hinged arm of tests/test_sensitivities_events.py, driven open by a motor torque 0.5 t as well
#: as its spring, latching at 0.4459 s
TORQUE_LATCH = events.LATCH_PLANAR.replace('damping: "c",', 'damping: "c", torque: "0.5*t",').replace(
    "sensitivities: [k, c, EI, rho, m]", "sensitivities: [k, EI]")

#: the 3D wheel of tests/test_sensitivities_events.py on an arm clamped to a hub turning by the prescribed angle
#: 0.2 t² about a skew axis; the wheel bounces off its stop (restitution 0.9) at 0.9933 s; the run ends
#: before it comes back (1.019 s)
HUB_STOP = events.WHEEL_3D.format(what="a stop, its arm on a turning hub",
                                  event="limits: [-10, 0.5], restitution: 0.9", t_end=1.015, every=0.01).replace(
    "base: {at: [0, 0, 0], fixed: true}",
    'base: {at: [0, 0, 0], motion: {rotation: {axis: [0.3, -0.2, 1.0], angle: "0.2*t**2"}}}').replace(
    "sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [J, k]")

#: the two planar arms of tests/test_sensitivities_events.py, the fore arm's hinge angle prescribed −0.8 t²
#: (``angle``: no coordinate), the arm latching at 0.7248 s
ANGLE_LATCH = events.TWO_LATCHES.replace('stiffness: "k2", rest_angle: -2.0, lock_at: -0.6', 'angle: "-0.8*t**2"').replace(
    "sensitivities: [k2]", "sensitivities: [k]").replace("k2: 1.0, ", "")

#: the mass dropped on a slack cable paid out by a reel, rest length L + 0.2 t: taut when the free fall
#: 0.5 + g t²/2 reaches it, t_e = (0.2 + √(0.04 + 2 g (L − 0.5)))/g, dt_e/dL = 1/(g t_e − 0.2); slack again later
REEL = cables.DROP.replace('rest_length: "L"', 'rest_length: "L + 0.2*t"')
#: the same with the cable's damper (its tension N = N_el + c ℓ̇ the gap)
DAMPED_REEL = cables.DAMPED.replace('rest_length: "L"', 'rest_length: "L + 0.2*t"')


def test_a_planar_arm_driven_by_a_torque_in_t_latching_agrees_with_richardson_differences():
    """Through the latch at 0.4459 s (measured ≤ 3.2e-9 for k, 2.3e-8 for EI, of each probe's largest
    sensitivity; the event time to 1e-7)."""
    result = events._run(TORQUE_LATCH)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    for name in ("k", "EI"):
        assert events._agree(result, TORQUE_LATCH, name) <= 1e-7


def test_the_cli_runs_the_torque_latch_and_writes_the_api_s_sensitivities(tmp_path):
    """``python -m latdyn run`` of the same scene (no refusal now): sensitivities.csv and
    event_sensitivities equal to the API's."""
    run, out = latdyn_run(tmp_path, TORQUE_LATCH, quiet=True)
    assert run.returncode == 0, run.stderr
    api = events._run(TORQUE_LATCH)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["event_sensitivities"] == api.summary["event_sensitivities"]
    table = np.loadtxt(out / "sensitivities.csv", delimiter=",", skiprows=1)
    assert np.allclose(table[:, 1:2].ravel(), api.sensitivities[("tip_x", "k")], rtol=1e-12, atol=1e-15)


def test_a_3d_arm_on_a_prescribed_turning_hub_bouncing_off_its_stop_agrees_with_richardson_differences():
    """The hub's prescribed rotation moves the residual in t through the clamped arm; through the bounce
    (measured ≤ 2.8e-9 for J; 4.8e-10 for k; the event time to 1e-7)."""
    result = events._run(HUB_STOP)
    assert [e["kind"] for e in result.summary["events"]] == ["stop"]
    assert events._agree(result, HUB_STOP, "J") <= 1e-7


def test_a_prescribed_hinge_angle_beside_a_latching_arm_agrees_with_richardson_differences():
    """The prescribed angle moves the residual in t through the fore arm; at the latch the impulse's weight
    M + dt²K takes the static K's time derivative (with the inertia forces' it was 1.0e-7 off; measured
    1.3e-9 for k, 5.9e-10 for m)."""
    result = events._run(ANGLE_LATCH)
    assert [(e["joint"], e["kind"]) for e in result.summary["events"]] == [("arm.start", "latch")]
    assert events._agree(result, ANGLE_LATCH, "k") <= 1e-8


def test_a_3d_guide_pushed_by_a_force_in_t_latching_agrees_with_richardson_differences():
    """The skew guide at the tip of the flexible arm of tests/test_sensitivities_guides.py, its slider pushed by
    a force 0.8 t along the guide, latching at 0.2493 s (measured ≤ 5.2e-9 for m; 1.4e-8 for k)."""
    text = guides.LATCH_3D.replace('damping: "c",', 'damping: "c", force: "0.8*t",')
    result = guides._run(text, "m")
    assert [(e["joint"], e["kind"]) for e in result.summary["events"]] == [("slider", "latch")]
    assert guides._agree(result, text, "m") <= 1e-7


def test_a_reel_paying_out_a_cable_that_catches_a_mass_agrees_with_the_closed_form_and_differences():
    """The taut time and its derivative by L in closed form (measured 1e-12 relative: the free fall is exact
    in the discrete run), the probes through taut and slack against Richardson differences (measured ≤ 3.3e-9
    for L; 1.7e-9 damped)."""
    g = 9.81
    result = cables._run(REEL, "L")
    taut = result.summary["event_sensitivities"][0]
    assert taut["kind"] == "taut" and [e["kind"] for e in result.summary["events"]] == ["taut", "slack"]
    t_e = (0.2 + math.sqrt(0.04 + 2 * g * 0.5)) / g
    assert taut["t"] == pytest.approx(t_e, rel=1e-10)
    assert taut["dt"]["L"] == pytest.approx(1.0 / (g * t_e - 0.2), rel=1e-10)
    assert cables._agree(result, REEL, "L") <= 1e-7
    damped = cables._run(DAMPED_REEL, "L")
    assert cables._agree(damped, DAMPED_REEL, "L") <= 1e-7


def test_a_latch_driven_by_a_controller_in_t_equals_the_torque_law_and_agrees_with_differences(monkeypatch):
    """A continuous controller whose output names t (its explicit ∂y/∂t through the actuator, ExplicitTime): the
    controller 0.5 t on the hinge gives the torque law 0.5 t's sensitivities (measured 3.0e-12 of each probe's
    largest; event time 1e-14), and one that also reads the hinge angle, 0.5 t (1 + 0.2 θ) + 0.1 sin 4t, agrees
    with Richardson differences (measured k 3.2e-9; EI 2.3e-8 not run here). Without ∂y/∂t the first is far off."""
    from latdyn.analyses import transient_sensitivities

    data = yaml.safe_load(TORQUE_LATCH.replace('torque: "0.5*t"', 'torque: "drive"'))
    data["controllers"] = {"drive": {"output": "0.5*t"}}
    law, controlled = events._run(TORQUE_LATCH), events._run(yaml.safe_dump(data))
    for key, values in law.sensitivities.items():
        assert np.abs(controlled.sensitivities[key] - values).max() <= 1e-10 * np.abs(values).max(), key
    data["controllers"] = {"drive": {"output": "0.5*t*(1 + 0.2*hinge) + 0.1*sin(4*t)"}}
    text = yaml.safe_dump(data)
    result = events._run(text, "k")
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert events._agree(result, text, "k") <= 1e-7
    monkeypatch.setattr(transient_sensitivities, "_controller_time_rates", lambda owner: None)
    data["controllers"] = {"drive": {"output": "0.5*t"}}
    held = events._run(yaml.safe_dump(data))
    assert np.abs(held.sensitivities[("tip_x", "k")] - law.sensitivities[("tip_x", "k")]).max() > \
        1e-5 * np.abs(law.sensitivities[("tip_x", "k")]).max()


def test_a_latch_beside_a_sampled_controller_in_t_agrees_with_richardson_differences():
    """A sampled controller whose output names t (0.5 t + 0.2 θ at 50 Hz) on the latching arm: its samples are at
    fixed grid instants, where δt = 0, so its held output needs no time derivative (measured k 3.8e-8; EI 1.1e-7 not
    run here). (Events with controllers in t are no longer refused.)"""
    data = yaml.safe_load(TORQUE_LATCH.replace('torque: "0.5*t"', 'torque: "drive"'))
    data["controllers"] = {"drive": {"output": "0.5*t + 0.2*hinge", "rate": 50}}
    text = yaml.safe_dump(data)
    result = events._run(text, "k")
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert events._agree(result, text, "k") <= 1e-6


def test_the_laws_time_derivatives_are_exact():
    """∂f/∂t at fixed θ, θ̇ (transient_sensitivities._TimeRate) against the derivatives written out: a load
    expression, a table's slope, a hinge law in θ, θ̇ and t (SymPy's derivative, to round-off)."""
    from latdyn.analyses.transient_sensitivities import _TimeRate
    from latdyn.scene.expressions import HingeLaw, TimeFunction

    theta, rate, t = 0.3, -0.7, 0.45
    assert _TimeRate(TimeFunction("2*sin(5*t) + t**3")).value(0, 0, t) == pytest.approx(
        10 * math.cos(5 * t) + 3 * t * t, rel=1e-14)
    assert _TimeRate(TimeFunction({"table": [[0, 0], [1, 2], [2, 0]]})).value(0, 0, t) == 2.0
    law = HingeLaw("2*theta*t**2 + sin(3*t)*theta_dot")
    assert _TimeRate(law).value(theta, rate, t) == pytest.approx(4 * theta * t + 3 * math.cos(3 * t) * rate,
                                                                 rel=1e-14)
    assert _TimeRate(HingeLaw("3*theta + theta_dot")).value(theta, rate, t) == 0.0
