"""The discrete adjoint through a joint that friction sticks beside other events, controllers and force probes (issue
34; latdyn/analyses/adjoint_sensitivities.py ``_refuse_a_stick``, ``_held_forms``, ``_friction_event_transposed``;
docs/parameters.md "Friction by the adjoint"): a latch and a rigid stop in a model whose joints stick and slip (the
forward method takes them where no joint is stuck at the event and no stick comes at its instant), a continuous
controller without states that reads a stuck joint's angle (K's column of the held angle holds its coupling), and a
stuck joint's torque and an element's bending moment (their forms of the held angle: the reaction's row of the held
forces, the section force through the element's angle slot).

References: the forward method on the same scene (≤ 1e-10 of each output's largest derivative, every probe's end, max
and min; each event time's derivative ≤ 1e-10 of its largest) and Richardson-extrapolated central differences of whole
runs (the parameter moved, the step fixed, Newton's tolerance 1e-12). Each scene here was refused on 5a68b93 when its
joint stuck (exit 2 naming its friction: "beside latches, stops or cables", "beside controllers", "beside probe
'torque'")."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_adjoint_friction_sticks import BRAKED, GIMBAL, SLEW_SINE
from tests.test_adjoint_geometry import _event_disagreement, _richardson_error
from tests.test_sensitivities_adjoint import _disagreement

#: tests/test_adjoint_friction_sticks.py's arm slewing on a skew friction hinge, under a PD on that hinge beside the
#: sinusoidal torque, latched at −0.03 rad on its way back, with the hinge's torque and the root element's bending
#: moment as probes: it slips, sticks at t = 0.55 and slips again at 0.6 (the PD's torque beside the friction), and
#: latches at 0.975 (measured)
BOOM = (SLEW_SINE
        .replace('torque: "A*sin(6*t)", ', 'torque: "pd + A*sin(6*t)", lock_at: -0.03, ')
        .replace("gravity:", "controllers:\n  pd: {output: \"Kp*(0.1 - angle) - Kd*rate\"}\ngravity:")
        .replace("A: 3.0, W: 1.0}", "A: 3.0, W: 1.0, Kp: 0.8, Kd: 0.1}")
        .replace("t_end: 1.0,", "t_end: 1.1,")
        .replace("sensitivities: [Fc, Fs, cv, EI, m, A, W]", "sensitivities: [Fc, cv, EI, m, A, W, Kp, Kd]")
        .replace("    tip_v:", "    torque: {hinge: arm.start, quantity: torque}\n"
                               "    moment: {element: \"arm.element[0]\", quantity: moment_y}\n    tip_v:"))
assert BOOM.count("lock_at: -0.03") == 1 and "Kp*(0.1 - angle)" in BOOM and "moment: {element" in BOOM

#: tests/test_adjoint_friction_sticks.py's gimbal ring on its friction hinge, the arm it carries without friction and
#: thrown back by a rigid stop at 0.75 rad (restitution 0.5, at t = 0.2905 while the ring slips), the ring's torque a
#: probe: the ring sticks at 0.34, 0.43 and 0.49 after the stop (measured)
GIMBAL_FREE = GIMBAL.replace(",\n                    friction: {coulomb: 0.3, static: 0.5, viscous: 0.01}}}", "}}")
GIMBAL_STOP = (GIMBAL_FREE
               .replace('torque: "A*sin(5*t)"}}', 'torque: "A*sin(5*t)", limits: [-1.0, 0.75], restitution: 0.5}}')
               .replace("t_end: 0.8,", "t_end: 0.5,")
               .replace("    tip_y:", "    ring_torque: {hinge: post.end, quantity: torque}\n    tip_y:"))
assert GIMBAL_FREE != GIMBAL and GIMBAL_STOP.count("restitution: 0.5") == 1

#: the gimbal (both joints with friction) with a PD on the arm's hinge reading the ring's angle, the arm's torque a probe:
#: while the ring is stuck the PD's coupling to its held angle is K's column of that angle and moves the arm's torque
GIMBAL_PD = (GIMBAL.replace('torque: "A*sin(5*t)"', 'torque: "pd + A*sin(5*t)"')
             .replace("loads:", "controllers:\n  pd: {output: \"Kp*(0.5*ring - swing) - Kd*swing_rate\"}\nloads:")
             .replace("m: 0.4, F: -0.2}", "m: 0.4, F: -0.2, Kp: 2.0, Kd: 0.2}")
             .replace("t_end: 0.8,", "t_end: 0.5,")
             .replace("sensitivities: [Fc, cv, EI, k, A, m, F]", "sensitivities: [Fc, cv, EI, k, A, m, F, Kp, Kd]")
             .replace("    tip_y:", "    arm_torque: {hinge: arm.start, quantity: torque}\n    tip_y:"))
assert "0.5*ring - swing" in GIMBAL_PD and "t_end: 0.5," in GIMBAL_PD and "arm_torque: {" in GIMBAL_PD

#: the braked arm (four sticks, three releases; it ends stuck) with its hinge's torque and the root element's moment
BRAKED_FORCES = BRAKED.replace("    tip_x:", "    torque: {hinge: arm.start, quantity: torque}\n"
                                             "    moment: {element: \"arm.element[0]\", quantity: moment_y}\n    tip_x:")
assert "torque: {hinge" in BRAKED_FORCES


def _run(text: str, method: str = "adjoint"):
    data = yaml.safe_load(text)
    data["solve"]["sensitivity_method"] = method
    return latdyn.run(latdyn.load_scene(data))


def _equal_to_the_forward_method(text: str, adjoint) -> float:
    forward = _run(text, "forward")
    events = forward.summary["event_sensitivities"]
    assert _event_disagreement(events, adjoint.summary["event_sensitivities"]) <= 1e-10
    return _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"])


@pytest.fixture(scope="module")
def boom():
    return _run(BOOM)


def test_a_boom_under_a_pd_that_sticks_slips_and_latches_equals_the_forward_method(boom, tmp_path):
    """The boom sticks and slips under its PD and latches after: the adjoint (its torque, the root's moment and the
    points and angle, by the friction, EI, the tip's mass, the drive and the PD's gains) equals the forward method's to
    8.1e-13 of each output's largest derivative and the latch time's to 1.6e-13 (measured); the CLI's summary.json is
    the API's to the bit."""
    rate = np.asarray(boom.probes["rate"])
    assert np.any((rate == 0.0) & (boom.t < 0.7))   # stuck before the latch
    assert [e["kind"] for e in boom.summary["event_sensitivities"]] == ["latch"]
    assert _equal_to_the_forward_method(BOOM, boom) <= 1e-10
    completed, out = latdyn_run(tmp_path, BOOM, quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["probe_sensitivities"] == boom.summary["probe_sensitivities"]
    assert summary["event_sensitivities"] == boom.summary["event_sensitivities"]


def test_the_boom_agrees_with_richardson_central_differences(boom):
    """Each probe's end by the PD's gain through the stick, the slip and the latch (measured 7.0e-10; by the drive's
    amplitude A 7.6e-7, not run here)."""
    assert _richardson_error(boom.summary["probe_sensitivities"], BOOM, "Kp", 1e-4, landed=True) <= 1e-6


def test_a_gimbal_ring_sticking_after_the_arm_hits_its_stop_equals_the_forward_method():
    """The arm hits its rigid stop at t = 0.2905 while the ring slips, the ring sticks three times after: 2.3e-13 off
    the forward method, the stop's time 1.8e-14 (measured); the ring's torque read while it is stuck."""
    adjoint = _run(GIMBAL_STOP)
    ring = np.asarray(adjoint.probes["ring_rate"])
    assert [e["kind"] for e in adjoint.summary["event_sensitivities"]] == ["stop"]
    assert np.any((ring == 0.0) & (adjoint.t > adjoint.summary["event_sensitivities"][0]["t"]))
    assert _equal_to_the_forward_method(GIMBAL_STOP, adjoint) <= 1e-10


@pytest.fixture(scope="module")
def gimbal_pd():
    return _run(GIMBAL_PD)


def test_a_pd_reading_a_stuck_ring_equals_the_forward_method(gimbal_pd):
    """The PD on the arm reads the ring's angle, held while the ring is stuck: 6.8e-13 off the forward method, the arm's
    torque the PD drives included (measured; the coupling left out of the held angle's column, 8.1e-2)."""
    assert np.any(np.asarray(gimbal_pd.probes["ring_rate"]) == 0.0)
    assert _equal_to_the_forward_method(GIMBAL_PD, gimbal_pd) <= 1e-10


def test_the_arm_torque_a_pd_drives_from_the_stuck_ring_agrees_with_richardson(gimbal_pd):
    """The arm's torque, −(the PD's output + A sin 5t), moves with the ring's held angle through the PD's sensor: the
    forward method's forms read the couplings on the free coordinates alone and left that out (4.0e-2 of the largest
    derivative by Kp off Richardson differences of whole runs at the rows the ring is stuck, 4.3e-8 while it slips, on
    5a68b93, measured over 0.8 s); with it (``held_sensor_forms``) every probe's end by Kp within 1e-6 (the ring stuck
    there)."""
    assert np.asarray(gimbal_pd.probes["ring_rate"])[-1] == 0.0
    assert _richardson_error(gimbal_pd.summary["probe_sensitivities"], GIMBAL_PD, "Kp", 1e-5, landed=True) <= 1e-6


def test_a_stuck_joints_torque_and_an_elements_moment_equal_the_forward_method():
    """The braked arm ends stuck: its torque (the reaction) and the root element's moment by the held angle equal the
    forward method's to 4.4e-13 (measured; their held-angle forms left out, 43 and 1.9 of the largest derivative)."""
    adjoint = _run(BRAKED_FORCES)
    assert np.asarray(adjoint.probes["rate"])[-1] == 0.0
    assert _equal_to_the_forward_method(BRAKED_FORCES, adjoint) <= 1e-10


def test_a_controller_probe_beside_a_stick_stays_refused(tmp_path):
    """A controller's output probe (its forms of the held angle are not formed): the adjoint refuses it when the ring
    is stuck (from t = 0), naming the ring's friction and the probe, exit 2 without a traceback from the CLI (a guard:
    refused on 5a68b93 as "beside controllers")."""
    text = GIMBAL_PD.replace("    tip_y:", "    pd_out: {controller: pd}\n    tip_y:").replace("t_end: 0.5,", "t_end: 0.05,")
    with pytest.raises(SceneError) as raised:
        _run(text)
    assert raised.value.key == "beams.post.end.hinge.friction" and "beside probe 'pd_out'" in str(raised.value)
    completed, _ = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 2 and "beams.post.end.hinge.friction" in completed.stderr
    assert "Traceback" not in completed.stderr
