"""Prescribed motions beside events in the sensitivities' loop of steps (issue 34 item 2; latdyn/analyses/
prescribed_rates.py, csrc/prescribed_rates.c): ∂r/∂t through a prescribed body's translation and rotation or a
prescribed hinge angle is exact on both paths, the blocks of M, C and the exact K coupling every row to the
prescribed coordinates times the motion laws' exact rate, acceleration and jerk (it was a five-point difference in t
of the residual), and the runs take the loop: their sensitivities are the per-step Python path's (the private switch
``SENSITIVITIES_IN_LOOP`` off) to the bit, through the API and the CLI, every step in the loop but an event's and the
landing after it. Scenes: a 3D boom whose root is prescribed (a slew about a skew axis and a translation in t)
deploying its wheel to a latch; the 3D arm on a prescribed turning hub bouncing off its stop and the prescribed hinge
angle beside a latching arm of tests/test_sensitivities_time_laws.py; that angle beside a stop.

Reels (a cable's rest length L0(t)) beside the cables' slack/taut events: ∂r/∂t = ∂F/∂L0 · share · L0′(t) at each
element held taut, the generated ``cable_force_D_rest_length`` (CableSensitivities.reel_forces on the Python path;
csrc/cable_forces.c's rest-length use with L0′(t) tabulated per grid point in the loop): the shipped 3D cable truss
(examples/cable_deploying_truss.yaml, its reel paying out, its cables taut and slack again) cut to 0.3 s and the
damped reel of tests/test_sensitivities_time_laws.py take the loop, bit for bit; the steps of the events and those
ending near a cable's change from Python.

Laws of the state and t beside events (a hinge torque in θ, θ̇ and t): their ∂f/∂t at fixed θ, θ̇ a law of the state
itself (transient_sensitivities._time_rate_law: SymPy's derivative's text), compiled with the parameters' derivative
laws of the state (latdyn/analyses/derivative_laws.py) and called from C on both paths: the planar arm driven open
by a torque 0.5 t (1 + 0.2 sin θ) and the 3D wheel driven by 0.3 sin 4t cos θ + 0.1 t θ̇, each latching, take the
loop, bit for bit, and agree with Richardson differences."""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

import latdyn
import tests.test_sensitivities_events as events
from tests.cli_runs import latdyn_run, summary_of
from tests.test_sensitivities_in_loop_cables import truss
from tests.test_sensitivities_in_loop_linked2 import difference_in_t
from tests.test_sensitivities_time_laws import ANGLE_LATCH, DAMPED_REEL, HUB_STOP, TORQUE_LATCH

#: the 3D wheel latching of tests/test_sensitivities_events.py on a boom whose root is prescribed: a slew
#: 0.5 t² − 0.1 t³ about a skew axis and a translation in t (sin and t²: every rate, acceleration and jerk nonzero);
#: the wheel latches at 1.0578 s
BOOM_SLEW = events.LATCH_3D.replace(
    "base: {at: [0, 0, 0], fixed: true}",
    'base: {at: [0, 0, 0], motion: {translation: ["0.05*sin(3*t)", 0, "0.02*t**2"], '
    'rotation: {axis: [0.2, 0.1, 1.0], angle: "0.5*t**2 - 0.1*t**3"}}}').replace(
    "sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [k, J, EI]")
assert "0.5*t**2 - 0.1*t**3" in BOOM_SLEW and "[k, J, EI]" in BOOM_SLEW

#: the prescribed hinge angle beside the arm of tests/test_sensitivities_time_laws.py, the arm's latch a stop
#: (restitution 0.9) met at 0.7248 s; the run ends before it comes back onto it (0.7307 s)
ANGLE_STOP = ANGLE_LATCH.replace("lock_at: 0.8", "limits: [-10, 0.8], restitution: 0.9").replace(
    "t_end: 1.0", "t_end: 0.73")
assert "restitution: 0.9" in ANGLE_STOP and "t_end: 0.73" in ANGLE_STOP

SCENES = {"3D boom slewing to a latch": (BOOM_SLEW, ["latch"]), "3D arm on a turning hub, a stop": (HUB_STOP, ["stop"]),
          "prescribed angle beside a latch": (ANGLE_LATCH, ["latch"]),
          "prescribed angle beside a stop": (ANGLE_STOP, ["stop"])}


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


@pytest.mark.parametrize("name", list(SCENES))
def test_prescribed_motions_beside_events_take_the_loop(name, monkeypatch):
    """Every smooth step in the loop (all but the event's and the landing after it), the sensitivities, the probes'
    and the event's the Python path's to the bit."""
    text, kinds = SCENES[name]
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == kinds
    assert python.summary["sensitivity_steps_in_loop"] == 0
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - 2 > 0
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


#: the shipped cable truss by its cables' EA and its longerons' EIy (tests/test_sensitivities_in_loop_cables.py) with
#: its reel, cut to 0.3 s: both cables taut at 0.158 s and slack at 0.274 s
REEL_TRUSS = truss(reel=True).replace("t_end: 0.5", "t_end: 0.3")
assert "t_end: 0.3" in REEL_TRUSS and "0.5*t" in REEL_TRUSS


@pytest.mark.parametrize("text", [REEL_TRUSS, DAMPED_REEL], ids=["3D cable truss with its reel", "damped reel"])
def test_reels_beside_cable_events_take_the_loop(text, monkeypatch):
    """The smooth steps in the loop (the events' steps and those ending near a cable's change from Python), the
    sensitivities, the probes' and the events' the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    kinds = {e["kind"] for e in native.summary["events"]}
    assert kinds == {"taut", "slack"}
    assert python.summary["sensitivity_steps_in_loop"] == 0
    assert 0.8 * native.summary["steps"] < native.summary["sensitivity_steps_in_loop"] < native.summary["steps"]
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


#: the planar arm of tests/test_sensitivities_time_laws.py driven open by a torque of the state and t, latching
STATE_TIME_LATCH = TORQUE_LATCH.replace('torque: "0.5*t"', 'torque: "0.5*t*(1 + 0.2*sin(theta))"')
assert "sin(theta))" in STATE_TIME_LATCH
#: the 3D wheel latching of tests/test_sensitivities_events.py driven by a torque in θ, θ̇ and t as well
STATE_TIME_3D = events.LATCH_3D.replace(
    'damping: "c",', 'damping: "c", torque: "0.3*sin(4*t)*cos(theta) + 0.1*t*theta_dot",').replace(
    "sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [k, J]")
assert "cos(theta)" in STATE_TIME_3D and "[k, J]" in STATE_TIME_3D


@pytest.mark.parametrize("text, name, tolerance", [(STATE_TIME_LATCH, "k", 1e-8), (STATE_TIME_3D, "J", 1e-8)],
                         ids=["planar arm, torque in theta and t", "3D wheel, torque in theta, theta_dot and t"])
def test_laws_of_the_state_and_t_beside_a_latch_take_the_loop(text, name, tolerance, monkeypatch):
    """Every step in the loop but the latch's and the landing after it, the Python path's to the bit, and against
    Richardson differences of whole runs (measured 3.2e-9 for the planar arm's k, 8.1e-10 for the wheel's J)."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == ["latch"]
    assert python.summary["sensitivity_steps_in_loop"] == 0
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - 2 > 0
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
    assert events._agree(native, text, name) <= tolerance


def test_a_law_of_the_state_and_t_s_rate_is_exact():
    """_time_rate_law's compiled-form law against the derivative written out, and against _TimeRate's lambda."""
    from latdyn.analyses.transient_sensitivities import _time_rate_law, _TimeRate
    from latdyn.scene.expressions import HingeLaw

    scene = latdyn.load_scene(yaml.safe_load(STATE_TIME_3D))
    law = HingeLaw("0.3*sin(4*t)*cos(theta) + 0.1*t*theta_dot")
    rate = _time_rate_law(law, scene, "torque")
    theta, theta_dot, t = 0.3, -0.7, 0.45
    expected = 1.2 * math.cos(4 * t) * math.cos(theta) + 0.1 * theta_dot
    assert rate.value(theta, theta_dot, t) == pytest.approx(expected, rel=1e-14)
    assert _TimeRate(law).value(theta, theta_dot, t) == pytest.approx(expected, rel=1e-14)


def test_the_boom_slewing_to_its_latch_agrees_with_richardson_differences(monkeypatch):
    """The run through the loop against Richardson-extrapolated central differences of whole runs (the helpers of
    tests/test_sensitivities_events.py) for the hinge spring's k: the probes and the latch time (measured 5.5e-9
    of each probe's largest; 5.3e-9 on the Python path with the five-point difference in t: the differences of whole
    runs, not ∂r/∂t, set that floor)."""
    result = _run(BOOM_SLEW, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"] - 2
    assert events._agree(result, BOOM_SLEW, "k") <= 2e-8


@pytest.mark.parametrize("text, beside", [(BOOM_SLEW, 2), (REEL_TRUSS, 6)], ids=["slewing boom", "truss with its reel"])
def test_the_cli_writes_the_python_paths_files(text, beside, tmp_path):
    """``latdyn run`` on the slewing boom and on the truss with its reel takes the loop; the same command with the switch
    off (a process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's
    sensitivities."""
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] == summary["steps"] - beside
    from tests.cli_runs import the_loop_off_writes_the_same

    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("name", ["3D boom slewing to a latch", "prescribed angle beside a stop"])
def test_the_exact_rate_in_t_equals_the_five_point_difference(name, monkeypatch):
    """ExplicitTime.through_prescribed (exact) against the five-point difference in t of the residual
    (tests/test_sensitivities_in_loop_linked2.py ``difference_in_t``, truncation (ηω)⁴/30, round-off ε|r|/η) at
    every state the run asks it at, on the free coordinates and on all (measured ≤ 7.3e-9 of the largest entry on
    the boom, 116 calls; 1.1e-12 on the angle, 81 calls; the hub of tests/test_sensitivities_time_laws.py 1.7e-8)."""
    from latdyn.analyses import transient_sensitivities as ts

    worst, calls = [0.0], [0]
    exact = ts.ExplicitTime.through_prescribed

    def compared(self, state, inertia=True, on_all=False):
        value = exact(self, state, inertia, on_all)
        difference = difference_in_t(self, state, inertia, on_all)
        worst[0] = max(worst[0], np.abs(value - difference).max() / np.abs(difference).max())
        calls[0] += 1
        return value

    monkeypatch.setattr(ts.ExplicitTime, "through_prescribed", compared)
    _run(SCENES[name][0], monkeypatch, False)
    assert calls[0] > 50 and worst[0] <= 1e-7


def test_the_motion_laws_third_derivative_is_exact():
    """prescribed_rates.third_derivative against the derivatives written out: an expression, a table and a
    constant (zeros)."""
    from latdyn.analyses.prescribed_rates import third_derivative
    from latdyn.scene.expressions import TimeFunction

    t = 0.45
    assert third_derivative(TimeFunction("0.5*t**2 - 0.1*t**3"))(t) == pytest.approx(-0.6, rel=1e-14)
    assert third_derivative(TimeFunction("0.05*sin(3*t)"))(t) == pytest.approx(-1.35 * math.cos(3 * t), rel=1e-14)
    assert third_derivative(TimeFunction({"table": [[0, 0], [1, 2]]}))(t) == 0.0
    assert third_derivative(TimeFunction(2.0))(t) == 0.0
