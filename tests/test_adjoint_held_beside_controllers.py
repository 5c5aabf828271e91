"""The discrete adjoint through a friction stick beside a controller with states or a sampled one that drives the
stuck joint alone, and through a hinge resting on its rigid stop beside a PI (issue 34; latdyn/analyses/adjoint_sensitivities.py ``_friction_event_transposed``,
latdyn/analyses/adjoint_controller_states.py ``_held_sensed_transposed``; docs/parameters.md, "Friction by the
adjoint").

The forward method carries such a stick since stickstates: while the joint is stuck its angle is no free coordinate
but the held δθ, and the controllers' sensors read it (``_sensor_derivatives`` adds it: a state's δs, a sample's
δs), their held δS and δy enter the stick's and release's restarts (``ControllerStates.hold``, ``SampledTerms.held``).
The adjoint transposes those terms: θ̄ += D_θᵀ s̄ at each step's states and each sample, S̄ += Bᵀū and ȳ += A_yᵀū
at the friction events' restarts (with their weights' moves), and θ̄ += K_θᵀ ū at a sample's restart while stuck.

Scenes (3D): a flexible boom slewing on a skew friction hinge under τ = A sin 6t and a controller on that hinge — a PI
(its state integrating the angle) or a sampled PD at 25 Hz, four steps a period, so that a sample taken while the
joint is stuck is held through the release after it (with the period equal to dt the first sample after a release
replaces it, and the held angle's term there changes nothing: tests/test_sensitivities_sticks_beside.py). References:
the forward method on the same scene (every probe's end, max and min, relative to each output's largest; the event
sensitivities, none here: a stick's time does not move) and Richardson-extrapolated central differences of whole runs
(the parameter moved, the step fixed, ``tol: 1e-12``). Each scene was refused by the adjoint on 7fbef8b ("beside
controllers with states or sampled ones").

A hinge resting on its rigid stop (restitution 0: it lands, is locked there, is released at a step's end) beside a PI:
the forward method holds δS through the landing's restart on the locked model and the release's restart (B δS in their
∂r/∂p, its move in their weights); the adjoint transposes them as at a stop (``_held_through_restart``). Scene: a boom
driven onto its stop by a PI of its angle aiming beyond it and pulled off by a torque growing as t². Refused by the
adjoint on 7fbef8b (exit 1, "beside controllers with states or sampled ones")."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_adjoint import _disagreement
from tests.test_sensitivities_hinge_on_stop import BOOM
from tests.test_sensitivities_sticks_beside import PI_ON_A_LOAD

#: a flexible boom on a skew friction hinge at a fixed base under τ = A sin 6t and a PI on the hinge: stuck from t = 0
#: to 0.2, then sticking and slipping (stuck 0.31–0.34 and 0.355–0.58), slipping to the end (measured)
BOOM_PI = """
title: a flexible boom slewing on a skew friction hinge under a sinusoidal torque and a PI on the hinge; it sticks and slips
parameters: {Fc: 1.5, Fs: 2.0, cv: 0.05, EI: 200.0, m: 0.5, A: 3.0, Kp: 2.0, Ki: 4.0}
gravity: [0, 0, -9.81]
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.01, rhoIz: 0.013}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0.2, 0.1], mass: "m", com: [0.05, 0, 0], inertia: [0.02, 0.03, 0.04]}
beams:
  boom:
    from: base
    to: tip
    section: s
    elements: 2
    start: {hinge: {axis: [0.1, -0.2, 1], torque: "A*sin(6*t) + ctl",
                    friction: {coulomb: "Fc", static: "Fs", viscous: "cv"}}}
controllers:
  ctl: {output: "-Kp*angle - Ki*S", states: {S: "angle"}}
solve: {analysis: transient, sensitivity_method: adjoint, dt: 0.01, t_end: 0.65, tol: 1.0e-12,
        sensitivities: [Fc, EI, A, Kp, Ki]}
output:
  probes:
    angle: {hinge: boom.start, quantity: angle}
    rate: {hinge: boom.start, quantity: rate}
    tip_y: {point: tip, quantity: position, component: y}
    tip_z: {point: tip, quantity: displacement, component: z}
    mid: {point: "boom.node[1]", quantity: displacement, component: norm}
"""

#: the same boom under a sampled PD at 25 Hz (period 4 dt) in place of the PI: stuck from t = 0 to 0.2, it slips and
#: sticks again eight times to 0.62 (measured)
BOOM_PD = (BOOM_PI
           .replace("and a PI on the hinge", "and a sampled PD on the hinge")
           .replace("Kp: 2.0, Ki: 4.0}", "Kp: 2.0, Kd: 0.2}")
           .replace('ctl: {output: "-Kp*angle - Ki*S", states: {S: "angle"}}',
                    'ctl: {output: "-Kp*angle - Kd*rate", rate: 25}')
           .replace("sensitivities: [Fc, EI, A, Kp, Ki]", "sensitivities: [Fc, EI, A, Kp, Kd]"))
assert BOOM_PD.count("rate: 25") == 1 and "Ki" not in BOOM_PD


#: the flexible boom of tests/test_sensitivities_hinge_on_stop.py (BOOM) deploying about a skew hinge at its root,
#: driven by a PI of its angle aiming at 0.7 rad beyond its rigid stop at 0.6 (restitution 0) and against its spring
#: and a torque −P t²: it lands at 0.945 s, rests on the stop and is pulled off at 0.98 s (measured)
BOOM_REST = (BOOM.replace(
    "a boom deploying about a skew hinge at its root onto its rigid stop, restitution 0, held there by its spring",
    "a boom driven onto its rigid stop by a PI of its angle, resting there, pulled off by a torque growing as t squared")
    .replace("c: 2.0, P: 2.0, m: 1.0, EI: 2.0e+6, rho: 0.5, zt: 1.0}",
             "c: 10.0, P: 2.0, m: 1.0, EI: 2.0e+4, rho: 0.5, zt: 1.0, Kp: 20.0, Ki: 2.0}")
    .replace("EA: 1.0e+8", "EA: 1.0e+6").replace('rest_angle: 2.0, torque: "P"', 'rest_angle: 0.0, torque: "-P*t*t + ctl"')
    .replace("solve: {analysis: transient, t_end: 1.5, dt: 0.01, tol: 1.0e-12, sensitivities: [k, c, P, m, rho, zt]}",
             'controllers:\n  ctl: {output: "-Kp*(angle - 0.7) - Ki*S", states: {S: "angle - 0.7"}}\n'
             "solve: {analysis: transient, sensitivity_method: adjoint, t_end: 1.1, dt: 0.01, tol: 1.0e-12,\n"
             "        sensitivities: [k, c, P, m, Kp, Ki]}"))
assert "ctl: {output" in BOOM_REST and "EA: 1.0e+6" in BOOM_REST and 'torque: "-P*t*t + ctl"' in BOOM_REST


def _run(text: str, method: str = "forward", only: str | None = None, **parameters):
    data = yaml.safe_load(text)
    data["solve"]["sensitivity_method"] = method
    data["parameters"].update(parameters)
    if only is not None:
        data["solve"]["sensitivities"] = [only]
    return latdyn.run(latdyn.load_scene(data))


@pytest.fixture(scope="module")
def forward_pd():
    return _run(BOOM_PD)


@pytest.mark.parametrize("text", [BOOM_PI, BOOM_PD], ids=["pi", "sampled_pd"])
def test_the_adjoint_through_sticks_beside_a_controller_on_the_joint_equals_the_forward_method(tmp_path, text,
                                                                                              forward_pd):
    """The boom sticks and slips under its controller: the CLI's adjoint (summary.json) equals the forward method
    through the API. Measured: PI 5.8e-14, sampled PD 3.7e-14 of each output's largest derivative (refused on
    7fbef8b). Left out, the held angles' terms of a sample's restart would have made 1.1 on the braked panel of
    tests/test_sensitivities_sticks_beside.py (its PD at 100 Hz)."""
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    adjoint = json.loads((out / "summary.json").read_text())
    forward = forward_pd if text is BOOM_PD else _run(text)
    rate = np.asarray(forward.probes["rate"])
    assert rate[0] == 0.0 and np.any(rate != 0.0) and np.sum((rate[1:] == 0.0) & (rate[:-1] != 0.0)) >= 2
    assert forward.summary.get("event_sensitivities", []) == adjoint.get("event_sensitivities", [])
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint["probe_sensitivities"]) <= 1e-9


def test_the_sampled_pd_s_forward_method_agrees_with_richardson_differences(forward_pd):
    """The forward method the adjoint equals, against Richardson-extrapolated central differences of whole runs by
    F_c (relative steps 1e-4 and 5e-5, the time step fixed): 6.9e-10 of each probe's largest (measured; EI 1.8e-8,
    A 2.7e-8, Kp 2.8e-8, Kd 8.4e-9, not run here). The held angle's term matters here: with a sample's δs leaving out
    the stuck joint's held δθ the derivatives by F_c are 1.4e-2 off (EI 1.8e-2, A 1.4e-2, Kp 1.1e-2, Kd 1.5e-2;
    the PI's 1.2e-3 – 3.6e-3: docs/parameters.md, "Friction by the adjoint"). A guard of the forward method (it took
    this scene on 7fbef8b too)."""
    p0 = yaml.safe_load(BOOM_PD)["parameters"]["Fc"]
    central = []
    for step in (1e-4 * p0, 5e-5 * p0):
        up, down = _run(BOOM_PD, only="Fc", Fc=p0 + step), _run(BOOM_PD, only="Fc", Fc=p0 - step)
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    errors = {}
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        errors[probe] = float(np.abs(forward_pd.sensitivities[(probe, "Fc")] - expected).max()
                              / np.abs(expected).max())
    assert max(errors.values()) <= 1e-6, errors


def test_a_stick_beside_a_pi_that_drives_another_coordinate_stays_refused_by_the_adjoint():
    """Guard: the PI reading the braked angle and pushing the panel by a load (a free coordinate) — the forward
    method's own refusal, which the adjoint keeps: refused at t = 0 naming the joint's friction."""
    with pytest.raises(SceneError) as refused:
        _run(PI_ON_A_LOAD, "adjoint")
    assert refused.value.key == "beams.arm.end.hinge.friction"
    assert "at t = 0 " in refused.value.expected and "drive another coordinate" in refused.value.expected


def test_a_hinge_resting_on_its_stop_beside_a_pi_equals_the_forward_method():
    """The boom lands on its stop, rests there under its PI and is pulled off: the adjoint equals the forward method
    (every probe's end, max and min, and the landing time's derivative). Measured: 1.7e-11 of each output's largest
    (refused on 7fbef8b); with the held δS of the restarts left out, 2.7e-4. The forward method against Richardson
    differences of whole runs (steps 1e-4 and 5e-5 relative): Kp 3.4e-10, Ki 8.3e-10, P 5.3e-10, k 1.2e-9."""
    adjoint, forward = _run(BOOM_REST, "adjoint"), _run(BOOM_REST)
    angle = np.asarray(forward.probes["angle"])
    resting = np.flatnonzero(np.abs(angle - 0.6) < 1e-12)
    assert len(resting) >= 2 and resting[-1] + 1 < len(angle) and angle[-1] < 0.6   # rested, then released
    events = forward.summary["event_sensitivities"]
    assert [e["kind"] for e in events] == ["stop"]
    for name, value in events[0]["dt"].items():
        assert abs(adjoint.summary["event_sensitivities"][0]["dt"][name] - value) <= 1e-9 * abs(value)
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-9
