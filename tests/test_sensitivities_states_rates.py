"""Controllers with states, and sampled ones, that read a rate (a hinge's rate, a point's velocity) differentiated
(issue 34; docs/parameters.md, "Controllers"; latdyn/analyses/sensitivities.py ``ControllerStates._sensed``,
``ControllerStates.restarted``, ``SampledTerms.sample``, ``_sensor_derivatives``).

The states' and samples' sensors move with δs = D_q δq + D_v δv, δv the step end's (or the sample's state's); after an
event's jump the integrator takes the states' rates anew at the jumped rates, so δf = ∂f/∂s δs⁺ + ∂f/∂S δS + ∂f/∂p
there. Each scene is genuinely 3D (hinge axes and points out of the coordinate planes, tests/test_adjoint_controllers_
states.py's, their controllers made to read rates) and typed as YAML. References: Richardson-extrapolated central
differences of whole runs (the perturbation varied, the time step fixed, ``solve.tol`` 1e-12), every probe over its
rows and the event times, ≤ 1e-6 relative. Before this change (ea72688) every scene here was refused (naming
solve.sensitivities, "reads the rate probe"). The adjoint takes them too (D_vᵀ and the restart's
δf⁺ transposed: tests/test_adjoint_states_rates.py).

Not covered, still refused: a controller with states or a sampled one reading a joint's force or torque
(latdyn/analyses/joint_force_sensitivities.py)."""
from __future__ import annotations

import json

import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, the_loop_off_writes_the_same
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_adjoint_controllers_states import BOOM_LATCH, GIMBAL_PID, SAMPLED_PD, SLEW_BOOM
from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both
from tests.test_sensitivities_refusals_lifted2 import _richardson_error, _run

#: the slewing boom on its tilted hub, its PI's output and integral reading the hub's rate w
SLEW_RATE = SLEW_BOOM.replace(
    'slew: {output: "Kp*(0.5 - th) + Ki*E", states: {E: "0.5 - th"}, initial: {E: 0.05}}',
    'slew: {output: "Kp*(0.5 - th) + Ki*E - 0.3*w", states: {E: "0.5 - th - 0.2*w"}, initial: {E: 0.05}}').replace(
    "t_end: 0.6", "t_end: 0.3")
#: the gimbal's two PIDs, each derivative a first-order filter D of its hinge's rate (time constant tf), one clipped
GIMBAL_RATE = GIMBAL_PID.replace(
    'yaw: {output: "Kp*(0.3 - a1) + Ki*I1 - Kd*(a1 - D1)/tf", states: {I1: "0.3 - a1", D1: "(a1 - D1)/tf"}}',
    'yaw: {output: "Kp*(0.3 - a1) + Ki*I1 - Kd*D1", states: {I1: "0.3 - a1", D1: "(w1 - D1)/tf"}}').replace(
    'pitch: {output: "Kp*(-0.2 - a2) + Ki*I2 - Kd*(a2 - D2)/tf", states: {I2: "-0.2 - a2", D2: "(a2 - D2)/tf"},',
    'pitch: {output: "Kp*(-0.2 - a2) + Ki*I2 - Kd*D2", states: {I2: "-0.2 - a2", D2: "(w2 - D2)/tf"},').replace(
    "    tip_x:", "    w1: {hinge: post.start, quantity: rate}\n    w2: {hinge: boom.start, quantity: rate}\n    tip_x:"
).replace("t_end: 0.5", "t_end: 0.3")
#: the arm on its skew hinge under a PD sampled at 50 Hz of the tip's vertical velocity, its state a filter of it
SAMPLED_VELOCITY = SAMPLED_PD.replace(
    'pd: {output: "Kp*(0.4 - th) - Kd*(th - P)*50", states: {P: "(th - P)*50"}, rate: 50}',
    'pd: {output: "Kp*(0.4 - th) + Kd*tip_vz - 0.5*P", states: {P: "(tip_vz - P)*50"}, rate: 50}').replace(
    "    tip_z:", "    tip_vz: {point: tip, quantity: velocity, component: z}\n    tip_z:")
#: the same arm bouncing off a stop at 0.0165 rad (restitution 0.5)
SAMPLED_STOP = SAMPLED_VELOCITY.replace('torque: "pd"}}}',
                                        'torque: "pd", limits: [-0.2, 0.0165], restitution: 0.5}}}')
#: the two-link boom whose elbow latches at 0.4 rad, its PI's integral reading the elbow's rate (which the latch stops)
LATCH_RATE = BOOM_LATCH.replace('states: {E: "a*(0.6 - elbow)"}', 'states: {E: "a*(0.6 - elbow) - 0.3*elbow_rate"}') \
    .replace("    shoulder:", "    elbow_rate: {hinge: fore.start, quantity: rate}\n    shoulder:").replace(
    "t_end: 1.0", "t_end: 0.5")
#: the boom with its tip's place a parameter (a geometry parameter: the hub's rate, a free coordinate's, holds no
#: reference)
SLEW_RATE_PLACED = SLEW_RATE.replace("tip: {at: [0.8, 0.3, 0.25]", 'tip: {at: ["Lx", 0.3, 0.25]').replace(
    "parameters: {Kp: 4.0,", "parameters: {Lx: 0.8, Kp: 4.0,").replace("sensitivities: [Kp, Ki, EI]",
                                                                       "sensitivities: [Lx, Kp]")
assert "Lx, Kp" in SLEW_RATE_PLACED and '"Lx"' in SLEW_RATE_PLACED
#: the boom's PI reading the tip's vertical velocity too (a node's velocity component)
SLEW_VELOCITY = SLEW_RATE.replace('states: {E: "0.5 - th - 0.2*w"}', 'states: {E: "0.5 - th - 0.2*w + 0.5*tip_vz"}') \
    .replace("    tip_z:", "    tip_vz: {point: tip, quantity: velocity, component: z}\n    tip_z:")
assert "0.5*tip_vz" in SLEW_VELOCITY and "tip_vz: {" in SLEW_VELOCITY
assert "0.2*w" in SLEW_RATE and "(w2 - D2)" in GIMBAL_RATE and "(tip_vz - P)" in SAMPLED_VELOCITY
assert "restitution: 0.5" in SAMPLED_STOP and "elbow_rate: {" in LATCH_RATE


@pytest.mark.parametrize("text, names, events, relative", [
    (SLEW_RATE, ["Kp", "EI"], [], 1e-4), (SLEW_VELOCITY, ["Ki"], [], 1e-4), (SLEW_RATE_PLACED, ["Lx"], [], 1e-4), (GIMBAL_RATE, ["Kd", "tf"], [], 1e-4),
    (SAMPLED_VELOCITY, ["Kd"], [], 1e-3), (SAMPLED_STOP, ["Kd"], ["stop"], 1e-4),
    (LATCH_RATE, ["Kp"], ["latch"], 1e-4)],
    ids=["slewing boom PI of the rate", "and of the tip's velocity", "the boom's tip placed by a parameter", "gimbal filtered-rate PIDs",
         "sampled PD of a velocity", "sampled PD of a velocity beside a stop", "PI of a rate beside a latch"])
def test_states_reading_rates_agree_with_richardson_central_differences(text, names, events, relative):
    """Measured (every probe's worst over the rows, relative to its largest; the event times too; perturbations of
    1e-4 relative): the boom Kp 1.4e-9, Ki 8.7e-9, EI 2.0e-9 (its tip's place Lx 4.6e-10; reading the tip's
    velocity too Kp 7.8e-9, Ki 1.1e-7, EI 1.2e-8); the gimbal Kp 3.7e-9,
    Ki 1.1e-7, Kd 5.0e-9, tf 1.3e-8, EI 1.3e-9; the sampled PD Kp 1.7e-9, EI 1.9e-9, Kd 6.0e-7 (4.5e-8 at 1e-3,
    3.9e-6 at 1e-5: the differences' round-off, hence 1e-3 here); beside the stop Kp 3.6e-10, Kd 7.3e-8, EI 6.1e-10;
    beside the latch Kp 4.0e-9, Ki 5.1e-8, a 2.1e-8, EI 1.4e-9, k 1.0e-6 (8.4e-8 at 1e-3, 7.4e-6 at 1e-5). Without
    D_v δv the sensitivities were 0.86 (boom), 1.3 (gimbal), 1.0 (sampled) relative off; without δf taken anew after
    the latch, the integral 0.4 off."""
    result = _run(text)
    assert [e["kind"] for e in result.summary["events"]] == events
    for name in names:
        assert _richardson_error(text, result, name, relative) <= 1e-6, name


@pytest.mark.parametrize("text, smooth", [(SLEW_RATE, 30), (SLEW_VELOCITY, 30), (GIMBAL_RATE, 30),
                                          (SLEW_RATE_PLACED, 30), (LATCH_RATE, 49), (SAMPLED_VELOCITY, 50),
                                          (SAMPLED_STOP, 49)],
                         ids=["boom PI of the rate", "and of the tip's velocity", "gimbal filtered-rate PIDs",
                              "the boom's tip placed", "PI beside a latch", "sampled PD of a velocity",
                              "sampled PD beside a stop"])
def test_states_reading_rates_are_the_same_with_the_loop_on_and_off(text, smooth):
    """The loop of steps takes the smooth steps (a joint's rate's or a node's velocity's δs its row of δv,
    csrc/controller_states.c ``controller_state_sensed``; a sampled controller's between its samples) and writes the
    per-step Python path's sensitivities to the bit (the events' steps and the restart's δf on the Python path both
    ways)."""
    runs = runs_with_the_loop_on_and_off(text)
    assert runs[True].summary["sensitivity_steps_in_loop"] == smooth
    assert_same_sensitivities(runs[True], runs[False], nonzero="some")


def test_a_pi_reading_a_rate_through_the_cli_equals_the_api(tmp_path):
    """``latdyn run`` of the boom's latch: summary.json's probe and event sensitivities those of ``latdyn.run`` to the
    bit; the loop off in a fresh process writes the same files."""
    run, out = latdyn_run(tmp_path, LATCH_RATE)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(LATCH_RATE)))
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]
    assert summary["event_sensitivities"] == api.summary["event_sensitivities"]
    assert summary["probe_sensitivities"]["integral"]["end"]["Kp"] != 0.0
    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("text, probe", [(SLEW_RATE, "torque"), (SAMPLED_VELOCITY, "last_angle")],
                         ids=["states", "sampled"])
def test_the_adjoint_takes_states_reading_rates(text, probe):
    """Refused by the adjoint on 40bf44a (it transposed D_q of the states' sensors, not D_v); now D_vᵀ onto v̄ and the
    restart's δf⁺ transposed (tests/test_adjoint_states_rates.py): every probe's end, max and min by every parameter
    the forward method's to 1e-10 relative. Measured: the boom's PI of the rate 1.8e-11 (on a row whose derivative is
    ~1e-5 of the probe's others: round-off), the sampled PD of a velocity 4.6e-13."""
    forward, adjoint = _both(text)
    assert adjoint.summary["probe_sensitivities"][probe]["end"]["Kp"] != 0.0
    assert _adjoint_error(forward, adjoint) <= 1e-10
