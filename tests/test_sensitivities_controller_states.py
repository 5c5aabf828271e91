"""Transient sensitivities through controllers with states and sampled controllers
(latdyn/analyses/sensitivities.py, ControllerStates and SampledTerms; docs/parameters.md, "Controllers").

The step integrates a continuous controller's states dS/dt = f(t, s, S; p) by the trapezoidal rule
condensed into its output; the derivative carries δS from step to step beside (δq, δv, δv̇, δa). A
sampled controller's held output and states jump at the fixed instants k/rate; their derivatives jump
with them, and the restart after the sample is differentiated. Reference: central
differences of whole runs at p ± h and p ± h/2, Richardson-extrapolated, the time step fixed; the
error is the largest over the rows relative to each probe's largest sensitivity."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run
from latdyn.errors import SceneError
from tests.resumed_runs import interrupted_and_whole

#: a hub (a stiff one-element arm to a tip mass, on a hinge about z with damping as the rate feedback)
#: under a constant disturbance moment, held by a PI loop u = −Kp θ − Ki S, dS/dt = θ (S from 0.2)
PI_HUB = """
title: a PI loop on a hub under a constant disturbance
parameters: {Kp: 6.0, Ki: 3.0}
sections: {s: {EA: 1.0e7, EIy: 1.0e5, EIz: 1.0e5, GJ: 1.0e5, rhoA: 0.1, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.5, 0, 0], mass: 4.0, inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: hub, to: tip, section: s, elements: 1,
        start: {hinge: {axis: [0, 0, 1], damping: 2.0, torque: "ctl"}}}
controllers:
  ctl: {output: "-Kp*th - Ki*S", states: {S: "th"}, initial: {S: 0.2}}
loads:
  - {at: tip, moment: [0, 0, 0.8]}
solve: {analysis: transient, t_end: 1.0, dt: 0.01, sensitivities: [Kp, Ki]}
output:
  every: 0.01
  probes:
    th: {hinge: arm.start, quantity: angle}
    ty: {point: tip, quantity: position, component: y}
"""

#: a flexible arm (3 elements, out of the coordinate planes) on a hinge of axis (1, −2, 0) with a
#: spring k, turned by the tip's height filtered by a first-order low-pass state F (time constant tau)
FILTERED_ARM = """
title: a flexible arm on a hinge turned by a filtered tip feedback
parameters: {Kf: 3.0, tau: 0.05, k: 1.0}
sections: {s: {EA: 1.0e5, EIy: 40.0, EIz: 40.0, GJ: 30.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 0.5,
        inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: base, to: tip, section: s, elements: 3,
        start: {hinge: {axis: [1, -2, 0], stiffness: "k", damping: 0.3, torque: "lp + 0.4"}}}
controllers:
  lp: {output: "-Kf*F", states: {F: "(tip_z - 0.66 - F)/tau"}}
solve: {analysis: transient, t_end: 0.5, dt: 0.01, sensitivities: [Kf, tau, k]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.start, quantity: angle}
    tip_z: {point: tip, quantity: position, component: z}
    mid_y: {point: "arm.node[1]", quantity: displacement, component: y}
"""


def _run(text, names, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    data["solve"]["sensitivities"] = list(names)
    if not names:
        del data["solve"]["sensitivities"]
    return latdyn.run(latdyn.load_scene(data))


def _richardson_errors(text, result, name, relative) -> dict:
    """Each probe's largest difference from the Richardson-extrapolated central differences of whole
    runs, relative to its largest sensitivity."""
    p0 = yaml.safe_load(text)["parameters"][name]
    h = relative * abs(p0)
    central = []
    for step in (h, h / 2):
        up, down = _run(text, [], **{name: p0 + step}), _run(text, [], **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    errors = {}
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        scale = np.abs(expected).max()
        assert scale > 0, (probe, name)
        errors[probe] = np.abs(result.sensitivities[(probe, name)] - expected).max() / scale
    return errors


@pytest.fixture(scope="module")
def pi_hub():
    return _run(PI_HUB, ["Kp", "Ki"])


@pytest.fixture(scope="module")
def filtered_arm():
    return _run(FILTERED_ARM, ["Kf", "tau", "k"])


@pytest.mark.parametrize("name", ["Kp", "Ki"])
def test_pi_loop_on_a_hub_agrees_with_richardson_differences(pi_hub, name):
    """Kp multiplies the sensor, Ki the state (its ∂y/∂p holds S; δS carried by the trapezoidal rule's
    derivative). Measured: Kp 1.4e-10, Ki 7.2e-12 (hinge angle and tip y)."""
    for probe, error in _richardson_errors(PI_HUB, pi_hub, name, 1e-4).items():
        assert error <= 1e-6, (probe, name, error)


@pytest.mark.parametrize("name", ["Kf", "tau", "k"])
def test_filtered_tip_feedback_on_a_3d_flexible_arm_agrees_with_richardson_differences(filtered_arm, name):
    """A low-pass state F of the tip's height: Kf in the output, tau inside the state's rate
    (∂f/∂p), k the hinge spring beside the controller. Measured (worst over the hinge angle, the tip's
    z and the first node's y): Kf 3.3e-9, tau 1.4e-8, k 8.6e-9. Without the states condensed into
    the step's matrix from the step's start (the evaluation after the step holds S) tau's is 4.7e-3."""
    for probe, error in _richardson_errors(FILTERED_ARM, filtered_arm, name, 1e-4).items():
        assert error <= 1e-6, (probe, name, error)


def test_pi_loop_through_the_cli_writes_the_apis_sensitivities(tmp_path, pi_hub):
    """python -m latdyn run writes sensitivities.csv with the API's columns, equal to round-off."""
    completed, out = latdyn_run(tmp_path, PI_HUB)
    assert completed.returncode == 0, completed.stderr
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.DictReader(f))
    for probe in ("th", "ty"):
        for name in ("Kp", "Ki"):
            written = np.array([float(r[f"{probe}/{name}"]) for r in rows])
            assert np.abs(written - pi_hub.sensitivities[(probe, name)]).max() <= 1e-12 * np.abs(written).max()


#: a digital PD at 50 Hz on the hub (no disturbance, no hinge damping): the rate by the backward
#: difference of the angle, P holding the angle of the last sample (P_{k+1} = P_k + (θ_k − P_k))
DIGITAL_PD_HUB = """
title: a digital PD at 50 Hz on a hub
parameters: {Kp: 6.0, Kd: 1.5, r: 0.3}
sections: {s: {EA: 1.0e7, EIy: 1.0e5, EIz: 1.0e5, GJ: 1.0e5, rhoA: 0.1, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.5, 0, 0], mass: 4.0, inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: hub, to: tip, section: s, elements: 1,
        start: {hinge: {axis: [0, 0, 1], torque: "pd"}}}
controllers:
  pd: {output: "-Kp*(th - r) - Kd*(th - P)*50", states: {P: "(th - P)*50"}, rate: 50}
solve: {analysis: transient, t_end: 1.0, dt: 0.005, sensitivities: [Kp, Kd, r]}
output:
  every: 0.005
  probes:
    th: {hinge: arm.start, quantity: angle}
    ty: {point: tip, quantity: position, component: y}
"""

#: the 3D flexible arm under a PI of the tip's height sampled at 50 Hz, clipped below at −0.08 (reached
#: from about 0.1 s), driving the hinge torque 2 dig + 0.4 and a vertical force 0.5 dig on the tip;
#: c the hinge damping, k its spring
SAMPLED_ARM = """
title: a flexible arm on a hinge with a sampled tip feedback
parameters: {Kf: 3.0, c: 0.4, k: 1.0}
sections: {s: {EA: 1.0e5, EIy: 40.0, EIz: 40.0, GJ: 30.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 0.5,
        inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: base, to: tip, section: s, elements: 3,
        start: {hinge: {axis: [1, -2, 0], stiffness: "k", damping: "c", torque: "2*dig + 0.4"}}}
controllers:
  dig: {output: "-Kf*(tip_z - 0.66) - 0.2*I", states: {I: "tip_z - 0.66"}, rate: 50, limits: [-0.08, 0.4]}
loads:
  - {at: tip, force: [0, 0, "0.5*dig"]}
solve: {analysis: transient, t_end: 0.5, dt: 0.01, sensitivities: [Kf, c, k]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.start, quantity: angle}
    tip_z: {point: tip, quantity: position, component: z}
    mid_y: {point: "arm.node[1]", quantity: displacement, component: y}
"""


@pytest.fixture(scope="module")
def digital_pd():
    return _run(DIGITAL_PD_HUB, ["Kp", "Kd", "r"])


@pytest.fixture(scope="module")
def sampled_arm():
    return _run(SAMPLED_ARM, ["Kf", "c", "k"])


@pytest.mark.parametrize("name", ["Kp", "Kd", "r"])
def test_digital_pd_on_a_hub_agrees_with_richardson_differences(digital_pd, name):
    """The held output's δy_k = ∂f/∂s δs + ∂f/∂S δS_k + ∂f/∂p at each instant (4 steps a sample), the
    state's δS_{k+1}, the restart after the sample differentiated. Measured: Kp 1.7e-10, Kd 1.3e-10,
    r 2.2e-11; without the restart's derivative Kd's is 2.2e-3."""
    for probe, error in _richardson_errors(DIGITAL_PD_HUB, digital_pd, name, 1e-4).items():
        assert error <= 1e-6, (probe, name, error)


@pytest.mark.parametrize("name", ["Kf", "c", "k"])
def test_sampled_pi_on_a_3d_flexible_arm_agrees_with_richardson_differences(sampled_arm, name):
    """Held through a hinge torque 2 y + 0.4 and a load component 0.5 y, clipped (δy = 0 there).
    Measured (worst over the probes): Kf 1.4e-9, c 5.4e-9, k 1.2e-8."""
    for probe, error in _richardson_errors(SAMPLED_ARM, sampled_arm, name, 1e-4).items():
        assert error <= 1e-6, (probe, name, error)


#: the PI hub with a sampled feedforward beside it (20 Hz, reading the tip's y, a sine in t): the
#: continuous state is kept through each sample's restart
PI_AND_SAMPLED_HUB = PI_HUB.replace('torque: "ctl"', 'torque: "ctl + ff"').replace(
    "parameters: {Kp: 6.0, Ki: 3.0}", "parameters: {Kp: 6.0, Ki: 3.0, Kf: 0.7}").replace(
    'initial: {S: 0.2}}', 'initial: {S: 0.2}}\n  ff: {output: "Kf*(0.3 - ty) + 0.5*sin(7*t)", rate: 20}').replace(
    "sensitivities: [Kp, Ki]", "sensitivities: [Kp, Ki, Kf]")


def test_a_continuous_state_beside_a_sampled_controller_agrees_with_richardson_differences():
    """The restart after each sample holds the states (δS enters its ∂r/∂p through ∂y/∂S). Measured:
    Kp 3.3e-9, Ki 3.6e-9, Kf 1.1e-8; without δS held at the restart Ki's is 2.4e-3."""
    assert "ff:" in PI_AND_SAMPLED_HUB and "Kf" in PI_AND_SAMPLED_HUB
    result = _run(PI_AND_SAMPLED_HUB, ["Kp", "Ki", "Kf"])
    for name in ("Kp", "Ki", "Kf"):
        for probe, error in _richardson_errors(PI_AND_SAMPLED_HUB, result, name, 1e-4).items():
            assert error <= 1e-6, (probe, name, error)


def test_states_whose_rates_name_t_with_events_are_refused():
    """A latch moves the states' trapezoidal step in time, and a rate in t with it (not differentiated): refused,
    naming solve.sensitivities. (States whose rates do not name t are differentiated through events: below.)"""
    data = yaml.safe_load(PI_HUB)
    data["beams"]["arm"]["start"]["hinge"]["lock_at"] = 0.5
    data["controllers"]["ctl"]["states"]["S"] = "th*(1 + 0.1*t)"
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities" and "states' rates name t" in info.value.expected


#: the PI hub bouncing off a rigid stop at θ = 0.02 (restitution 0.5) at 0.5725 s, ending before it comes back
PI_STOP = PI_HUB.replace('torque: "ctl"}', 'torque: "ctl", limits: [-1.0, 0.02], restitution: 0.5}').replace(
    "t_end: 1.0", "t_end: 0.8")
#: the filtered 3D arm latching at θ = 0.03 (0.3646 s)
FILTERED_LATCH = FILTERED_ARM.replace('torque: "lp + 0.4"}', 'torque: "lp + 0.4", lock_at: 0.03}')


@pytest.mark.parametrize("text, kind, name", [(PI_STOP, "stop", "Ki"), (PI_STOP, "stop", "Kp"),
                                              (FILTERED_LATCH, "latch", "tau")],
                         ids=["pi-stop-Ki", "pi-stop-Kp", "filtered-3d-latch-tau"])
def test_states_through_events_agree_with_richardson_differences(text, kind, name):
    """Controllers with states through a stop and a latch (latdyn/analyses/sensitivities.py ControllerStates): the
    event's step size moves the trapezoidal step, δS_{n+1} += A⁻¹ ½(f_n + f_{n+1}) δh (its ∂r/∂h through ∂y/∂S in
    the step size's column), and δS is held through the jump and the restart. Measured: PI stop Ki 1.5e-9, Kp
    7.4e-9; filtered arm latch tau 3.0e-8 (Kf 9.9e-9, k 1.9e-8 not run here); event times to 1e-7 (the helper's
    references land on the event with sensitivities, as exactly)."""
    import test_sensitivities_events as events

    result = events._run(text, name)
    assert [e["kind"] for e in result.summary["events"]] == [kind]
    assert events._agree(result, text, name) <= 1e-7


def test_without_the_states_step_size_part_the_event_check_fails(monkeypatch):
    """The check can fail: with the states' derivative by the step size left out the PI stop is 2.8e-4 off."""
    import test_sensitivities_events as events
    from latdyn.analyses.sensitivities import ControllerStates

    monkeypatch.setattr(ControllerStates, "by_step_size", lambda self, state: np.zeros(self.terms.model.n_total + 1))
    kept = ControllerStates.after_step
    monkeypatch.setattr(ControllerStates, "after_step",
                        lambda self, state, dq, dh=None, moved=None, dv=None: kept(self, state, dq))
    result = events._run(PI_STOP, "Ki")
    with pytest.raises(AssertionError):
        events._agree(result, PI_STOP, "Ki", tolerance=1e-5, event_tolerance=1.0)


#: the digital PD hub latching at θ = 0.2 (0.5787 s), and bouncing off a stop there (restitution 0.5)
PD_LATCH = DIGITAL_PD_HUB.replace('torque: "pd"}', 'torque: "pd", lock_at: 0.2}').replace("t_end: 1.0", "t_end: 0.6")
PD_STOP = DIGITAL_PD_HUB.replace('torque: "pd"}', 'torque: "pd", limits: [-1.0, 0.2], restitution: 0.5}').replace(
    "t_end: 1.0", "t_end: 0.75")


@pytest.mark.parametrize("text, kind, name", [(PD_LATCH, "latch", "Kp"), (PD_STOP, "stop", "Kp")],
                         ids=["latch-Kp", "stop-Kp"])
def test_a_sampled_controller_through_events_agrees_with_richardson_differences(text, kind, name):
    """A sampled controller beside a latch and a stop: its instants are grid points, where the steps after an event
    land (δt = 0 there), so its held δy and δS and its restarts are as without events; the event's jump and restart
    take the held δy in ∂r/∂p. Measured: latch Kp 1.4e-9 (Kd 8.1e-9, r 8.8e-10 not run here); stop Kp 3.6e-7 (Kd
    1.4e-6 at a perturbation of 1e-4, 3.0e-7 at 1e-3, 9.4e-6 at 1e-5: the differences' noise after the impact)."""
    import test_sensitivities_events as events

    result = events._run(text, name)
    assert [e["kind"] for e in result.summary["events"]] == [kind]
    assert events._agree(result, text, name) <= 1e-6


@pytest.mark.parametrize("change, expected", [
    (lambda d: d["beams"]["arm"]["start"]["hinge"].update(stiffness="pd"), "named at beams.arm.start.hinge.stiffness"),
    (lambda d: d["beams"]["arm"]["start"]["hinge"].update(torque="pd*pd"), "named at beams.arm.start.hinge.torque"),
])
def test_what_sampled_controllers_cannot_be_differentiated_through_is_refused(change, expected):
    data = yaml.safe_load(DIGITAL_PD_HUB)
    change(data)
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities" and expected in info.value.expected, info.value.expected


@pytest.mark.parametrize("text", [PI_HUB, DIGITAL_PD_HUB], ids=["states", "sampled"])
def test_an_interrupted_and_resumed_run_has_the_same_sensitivities(tmp_path, monkeypatch, text):
    """δS, δf and the held δy ride in the checkpoint with the rest of the carried sensitivities: the
    resumed sensitivities.csv is the uninterrupted one, byte for byte (interrupted between samples)."""
    scene = yaml.safe_load(text)
    out, whole = interrupted_and_whole(scene, tmp_path, monkeypatch, 0.37)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
