"""The discrete adjoint through controllers with states, and sampled ones, that read a rate (issue 34;
latdyn/analyses/adjoint_controller_states.py; docs/parameters.md, "The discrete adjoint").

The forward method moves such a controller's sensors by δs = D_q δq + D_v δv (δv the step end's, or the sample's
state's) and, after a latch's jump, takes the states' rates anew: δf⁺ = ∂f/∂s δs⁺ + ∂f/∂S δS + ∂f/∂p with δs⁺ of the
jumped rates (latdyn/analyses/sensitivities.py ``ControllerStates._sensed``, ``ControllerStates.restarted``,
``SampledTerms.sample``). The reverse pass transposes both: v̄ += D_vᵀ s̄ beside q̄ += D_qᵀ s̄ at each step's end
and each sample, and at each latch s̄ = ∂f/∂sᵀ f̄ onto q̄ and v̄ of the jumped state, S̄ += ∂f/∂Sᵀ f̄,
dy/dp += ∂f/∂pᵀ f̄, f̄ = 0 on the rows of the controllers reading a rate
(``StatesTransposed.restarted_transposed``); the step after the latch starts from the restarted (S, f). After a stop
the run keeps the states' rates (``sensitivities.rates_taken_anew``), and so, since this change, does the forward
method (before, it took them anew at stops too: wrong, a test below). Each scene is genuinely 3D (hinge axes and
points out of the coordinate planes) and typed as YAML. References: the forward method's sensitivities (≤ 1e-10
relative, every probe's end, max and min by every parameter and every event time's derivative: tests/test_sensitivities_refusals_lifted.py ``_adjoint_error``)
and Richardson-extrapolated central differences of whole runs (≤ 1e-6 relative to the largest over the probes, the
perturbation varied, the time step fixed, ``solve.tol`` 1e-12). Before this change (40bf44a) every adjoint scene here
was refused (exit 2 naming solve.sensitivity_method, "reads the rate probe"), and the forward method beside the stops
was off its references (6.9e-3)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, latdyn_run_switched, summary_of
from tests.test_adjoint_controllers_states import BOOM_LATCH, SAMPLED_PD, SLEW_BOOM
from tests.test_fuzz_run_findings5 import TAUT_STATE
from tests.test_sensitivities_in_loop_moving_sensors import BASE_STATE
from tests.test_sensitivities_in_loop_controller_integral import WHEEL_STOP
from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both
from tests.test_sensitivities_refusals_lifted2 import _richardson_error, _run
from tests.test_sensitivities_states_rates import GIMBAL_RATE, SAMPLED_STOP

#: the slewing boom on its tilted hub under a PI with a filtered rate measurement: Kp (0.5 − θ) + Ki E − Kd F, the
#: integral dE/dt = 0.5 − θ and F a first-order filter of the hub's rate w, dF/dt = (w − F)/tf; the gains, the
#: filter's constant and the boom's bending stiffness are the parameters, both states and the output probed
SLEW_FILTERED = SLEW_BOOM.replace(
    'slew: {output: "Kp*(0.5 - th) + Ki*E", states: {E: "0.5 - th"}, initial: {E: 0.05}}',
    'slew: {output: "Kp*(0.5 - th) + Ki*E - Kd*F", states: {E: "0.5 - th", F: "(w - F)/tf"}, initial: {E: 0.05}}'
).replace("parameters: {Kp: 4.0, Ki: 3.0,", "parameters: {Kp: 4.0, Ki: 3.0, Kd: 0.3, tf: 0.05,").replace(
    "sensitivities: [Kp, Ki, EI]", "sensitivities: [Kp, Ki, Kd, tf, EI]").replace(
    "    integral: {controller: slew, state: E}\n",
    "    integral: {controller: slew, state: E}\n    filtered: {controller: slew, state: F}\n").replace(
    "t_end: 0.6", "t_end: 0.4")
#: the two-link boom whose elbow latches at 0.4 rad under a PID: the derivative a state D filtering the elbow's rate,
#: dD/dt = (ω − D)/tf, which the latch stops (ω jumps to 0: D's rate is taken anew there)
LATCH_PID = BOOM_LATCH.replace(
    'ctl: {output: "Kp*(0.6 - elbow) + Ki*E", states: {E: "a*(0.6 - elbow)"}}',
    'ctl: {output: "Kp*(0.6 - elbow) + Ki*E - Kd*D", states: {E: "a*(0.6 - elbow)", D: "(elbow_rate - D)/tf"}}'
).replace("parameters: {Kp: 3.0, Ki: 4.0,", "parameters: {Kp: 3.0, Ki: 4.0, Kd: 0.2, tf: 0.05,").replace(
    "sensitivities: [Kp, Ki, a, k, EI]", "sensitivities: [Kp, Ki, Kd, tf, a, k, EI]").replace(
    "    shoulder:", "    elbow_rate: {hinge: fore.start, quantity: rate}\n"
    "    derivative: {controller: ctl, state: D}\n    shoulder:").replace("t_end: 1.0", "t_end: 0.5")
#: the wheel on its skew hinge bouncing twice off its stop (restitution 0.9) under a PI whose filter F reads the
#: hinge's rate (the rate reverses at each impact: F's rate taken anew there)
WHEEL_RATE_STOP = WHEEL_STOP.replace('F: "w*(angle - F)"', 'F: "w*(rate - F)"').replace(
    "    angle:", "    rate: {hinge: arm.end, quantity: rate}\n    angle:")
#: the sampled PD's arm at 50 Hz, its derivative a sampled filter P of its hinge's rate,
#: P_{k+1} = P_k + 10 (ω − P_k)/50, latching at 0.03 rad
SAMPLED_RATE_LATCH = SAMPLED_PD.replace(
    'pd: {output: "Kp*(0.4 - th) - Kd*(th - P)*50", states: {P: "(th - P)*50"}, rate: 50}',
    'pd: {output: "Kp*(0.4 - th) - Kd*P", states: {P: "(thd - P)*10"}, rate: 50}').replace(
    "    tip_z:", "    thd: {hinge: arm.start, quantity: rate}\n    tip_z:").replace(
    'torque: "pd"}}}', 'torque: "pd", lock_at: 0.03}}}')
assert "Kd*F" in SLEW_FILTERED and "filtered: {" in SLEW_FILTERED and "Kd, tf, EI" in SLEW_FILTERED
assert "(elbow_rate - D)/tf" in LATCH_PID and "elbow_rate: {" in LATCH_PID and "Kd, tf, a" in LATCH_PID
assert "w*(rate - F)" in WHEEL_RATE_STOP and "rate: {hinge" in WHEEL_RATE_STOP
assert "(thd - P)*10" in SAMPLED_RATE_LATCH and "thd: {" in SAMPLED_RATE_LATCH and "lock_at: 0.03" in SAMPLED_RATE_LATCH


def _adjoint(text: str) -> dict:
    data = yaml.safe_load(text)
    data["solve"]["sensitivity_method"] = "adjoint"
    return data


@pytest.mark.parametrize("text, events", [
    (SLEW_FILTERED, []), (GIMBAL_RATE, []), (LATCH_PID, ["latch"]), (WHEEL_RATE_STOP, ["stop", "stop"]),
    (SAMPLED_STOP, ["stop"]), (SAMPLED_RATE_LATCH, ["latch"])],
    ids=["boom PI with a filtered rate", "gimbal filtered-rate PIDs", "PID of a rate through a latch",
         "PI of a filtered rate beside two stops", "sampled PD of a velocity beside a stop",
         "sampled filter of a rate beside a latch"])
def test_the_adjoint_equals_the_forward_method_where_controller_states_read_rates(text, events):
    """Every probe's end, max and min (the controllers' outputs and states among them) by every parameter, and every
    event time's derivative: the forward method's to 1e-10 relative (tests/test_sensitivities_states_rates.py checks
    its boom's PI of the rate and its sampled PD of a velocity likewise). Measured: the boom's filtered rate 1.8e-11
    (on a row whose derivative is ~1e-5 of the probe's others: round-off), the gimbal 2.0e-13, the PID through the
    latch 3.8e-12, the wheel's two stops 9.5e-13, the sampled PD's stop 5.4e-13, the sampled filter's latch 2.6e-13.
    Without D_vᵀ the boom was 0.20 off, the latch 0.21, the wheel 0.24, the gimbal 2.6, the sampled ones 1.0; without
    the restart's δf⁺ transposed the latch 1.8e-2; with the step after the latch started from the f before the
    restart, the latch 0.17."""
    forward, adjoint = _both(text)
    assert [e["kind"] for e in adjoint.summary["event_sensitivities"]] == events
    assert _adjoint_error(forward, adjoint) <= 1e-10


def _richardson_end_error(text: str, adjoint, name: str, relative: float = 1e-4) -> float:
    """The largest error of ``adjoint``'s derivatives by ``name`` of every probe's end value (relative to the largest
    over the probes) and of every event time (relative to their largest) against Richardson-extrapolated central
    differences of whole runs (steps ``relative`` and half of it, ``solve.tol`` 1e-12)."""
    p0 = yaml.safe_load(text)["parameters"][name]
    central, times = [], []
    for step in (relative * abs(p0), relative / 2 * abs(p0)):
        up, down = _run(text, **{name: p0 + step}), _run(text, **{name: p0 - step})
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]]
        central.append({k: (up.probes[k][-1] - down.probes[k][-1]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"],
                                                                              down.summary["events"])]))
    expected = {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}
    computed = adjoint.summary["probe_sensitivities"]
    worst = max(abs(computed[k]["end"][name] - v) for k, v in expected.items()) / max(map(abs, expected.values()))
    if len(times[0]):
        expected_dt = (4 * times[1] - times[0]) / 3
        computed_dt = np.array([event["dt"][name] for event in adjoint.summary["event_sensitivities"]])
        worst = max(worst, float(np.abs(computed_dt - expected_dt).max() / np.abs(expected_dt).max()))
    return worst


def test_the_pid_through_the_latch_agrees_with_richardson_central_differences():
    """The adjoint's derivatives of every probe's end value and of the latch's time, by the derivative's gain and its
    filter's constant, against whole runs differenced (``solve.tol`` 1e-12 both). Measured (steps 1e-4 relative):
    Kd 7.5e-10, tf 1.2e-9 (1e-3: 4.0e-11, 9.5e-11)."""
    data = _adjoint(LATCH_PID)
    data["solve"].update(tol=1e-12, sensitivities=["Kd", "tf"])
    adjoint = latdyn.run(latdyn.load_scene(data))
    for name in ("Kd", "tf"):
        assert _richardson_end_error(LATCH_PID, adjoint, name) <= 1e-6, name


def test_the_cli_equals_the_api_bit_for_bit_and_the_loop_off_writes_the_same(tmp_path):
    """``python -m latdyn run`` of the PID through the latch by the adjoint writes the API's probe and event
    sensitivities to the bit; a fresh process with the adjoint's loop of steps off (its forward pass from Python) writes
    the same."""
    text = yaml.safe_dump(_adjoint(LATCH_PID), sort_keys=False)
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 0, completed.stderr
    written = summary_of(out)
    api = latdyn.run(latdyn.load_scene(_adjoint(LATCH_PID)))
    assert written["probe_sensitivities"] == api.summary["probe_sensitivities"]
    assert written["event_sensitivities"] == api.summary["event_sensitivities"]
    assert written["probe_sensitivities"]["derivative"]["end"]["tf"] != 0.0
    off = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", tmp_path / "off",
                              "import latdyn.analyses.adjoint_in_loop as m; m.ADJOINT_IN_LOOP = False")
    assert off.returncode == 0, off.stderr
    python = summary_of(tmp_path / "off")
    assert python["probe_sensitivities"] == written["probe_sensitivities"]
    assert python["event_sensitivities"] == written["event_sensitivities"]


@pytest.mark.parametrize("name", ["w", "Kp"])
def test_a_state_reading_a_rate_beside_a_stop_agrees_with_richardson_central_differences(name):
    """The forward method beside a rigid stop: the run keeps the states' rates f through a stop's jump
    (restart_accelerations restarts the accelerations alone; only after a latch does the integrator take f anew), so
    δf is the step's there too (``rates_taken_anew``). On 40bf44a the forward method took δf anew at the stops as well
    and was 6.9e-3 (by the filter's w) and 8.9e-5 (by Kp) off these references, reported as solved. Measured (every
    probe over its rows, relative to its largest; the stops' times too; steps 1e-4 relative, ``solve.tol`` 1e-12):
    w 2.3e-8, Kp 3.1e-9."""
    data = yaml.safe_load(WHEEL_RATE_STOP)
    data["solve"].update(tol=1e-12, sensitivities=[name])
    result = latdyn.run(latdyn.load_scene(data))
    assert [e["kind"] for e in result.summary["events"]] == ["stop", "stop"]
    assert _richardson_error(WHEEL_RATE_STOP, result, name) <= 1e-6


def test_a_controller_output_naming_t_at_the_latch_s_row_seeds_the_event_time():
    """A controller probe's output naming t, ``elbow − g t``, whose largest value is at the latch's row (no
    ``output.every``: every step a row, the latch's among them, its time t_e moving with p): the forward method's row
    adds ∂f/∂t δt_e = −g δt_e, which the adjoint seeds on t̄ there (refused on 40bf44a). Its max by every parameter but
    g is −g dt_e/dp (the elbow held at 0.4 from the latch on) and the forward method's to 1e-10. Measured: 2.2e-12;
    without the seed on t̄ 1.3e-2 (the max's derivatives by the gains 0)."""
    data = _adjoint(LATCH_PID)
    data["parameters"]["g"] = 0.05
    data["controllers"]["lead"] = {"output": "elbow - g*t"}
    data["output"]["probes"]["lead_out"] = {"controller": "lead"}
    data["solve"]["sensitivities"].append("g")
    del data["output"]["every"]
    adjoint = latdyn.run(latdyn.load_scene(data))
    data["solve"]["sensitivity_method"] = "forward"
    forward = latdyn.run(latdyn.load_scene(data))
    (latch,) = adjoint.summary["event_sensitivities"]
    largest = adjoint.summary["probe_sensitivities"]["lead_out"]["max"]
    assert forward.summary["events"][0]["t"] == latch["t"] == forward.t[int(np.argmax(forward.probes["lead_out"]))]
    for name in ("Kp", "Kd", "tf"):
        assert largest[name] == pytest.approx(-0.05 * latch["dt"][name], rel=1e-9, abs=0.0)
    assert _adjoint_error(forward, adjoint) <= 1e-10


@pytest.mark.parametrize("text", [TAUT_STATE, BASE_STATE], ids=["cable's length from a moving base", "base's place"])
def test_a_state_reading_a_prescribed_motion_beside_a_cable_s_change_equals_the_forward_method(text):
    """A filter state on a cable's length from a prescribed, moving base (tests/test_fuzz_run_findings5.py) and on the
    base's place (tests/test_sensitivities_in_loop_moving_sensors.py), through the cable's taut change: after it each
    step ends at t + δt, and the forward method moves the sensor by ∂s/∂t δt along the motion
    (``ControllerStates._sensed`` with ``moved``) and takes ∂r/∂t's prescribed part with the states condensed as in the
    step. The adjoint transposes both (t̄ += D_tᵀ s̄, ``StatesTransposed._sensed_transposed``; the condensed rate in
    ``AdjointSensitivities._step_transposed``): the forward method's to 1e-10. On 40bf44a the adjoint took these runs
    and was 2.8e-4 and 5.0e-4 off, reported as solved; measured now 1.4e-13 and 7.6e-13 (without D_tᵀ 2.9e-4, 5.0e-4;
    without the condensed rate 1.2e-5, 1.4e-6)."""
    forward, adjoint = _both(text)
    assert [e["kind"] for e in adjoint.summary["event_sensitivities"]] == ["taut"]
    assert _adjoint_error(forward, adjoint) <= 1e-10
