"""The discrete adjoint through continuous controllers with states and seeded by controller probes (issue 34;
latdyn/analyses/adjoint_controller_states.py; docs/parameters.md, "The discrete adjoint").

The reverse pass carries the states' bars S̄, f̄ beside the structure's and applies the transposes of the forward
method's pieces (ControllerStates.after_step, the held part's ∂r/∂p, begin_step, start); a controller probe seeds
its state's S̄ or its output's forms. Each scene is genuinely 3D (hinge axes and points out of the coordinate planes)
and typed as YAML. References: the forward method's sensitivities (≤ 1e-10 relative, every probe's end, max and min
by every parameter) and Richardson-extrapolated central differences of whole runs of each probe's end value
(≤ 1e-6 relative to the largest over the probes, the perturbation varied, the time step fixed). Sampled controllers
(a zero-order hold): ȳ, the adjoint of the held δy, and the sampled states' S̄ carried back through the samples and the
restarts after them. Before this change (86d57d9) every scene here was refused (exit 2 naming
solve.sensitivity_method)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_cables import CABLE_3D
from tests.test_sensitivities_in_loop_controller_integral import BOOM, WHEEL_STOP
from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both, _richardson_end

#: a slewing boom: a hub turning about a tilted axis (0.2, 0.1, 1) carries a flexible four-element boom out of the
#: coordinate planes to a tip mass; a PI of the hub's angle toward 0.5 rad, Kp (0.5 − θ) + Ki E (the hub's damping
#: 0.8) with dE/dt = 0.5 − θ (E from 0.05), drives the hub's torque; the gains and the boom's bending stiffness EI (a
#: section value) are the parameters; the controller's output and its integral state are probed
SLEW_BOOM = """
title: a slewing boom on a tilted hub under a PI of the hub's angle
parameters: {Kp: 4.0, Ki: 3.0, EI: 60.0}
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "EI", GJ: 40.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.8, 0.3, 0.25], mass: 0.4, inertia: [0.01, 0.01, 0.01]}
beams:
  boom: {from: hub, to: tip, section: s, elements: 4,
         start: {hinge: {axis: [0.2, 0.1, 1], damping: 0.8, torque: "slew"}}}
controllers:
  slew: {output: "Kp*(0.5 - th) + Ki*E", states: {E: "0.5 - th"}, initial: {E: 0.05}}
solve: {analysis: transient, t_end: 0.6, dt: 0.01, sensitivities: [Kp, Ki, EI]}
output:
  every: 0.01
  probes:
    th: {hinge: boom.start, quantity: angle}
    w: {hinge: boom.start, quantity: rate}
    tip_z: {point: tip, quantity: position, component: z}
    mid_y: {point: "boom.node[2]", quantity: displacement, component: y}
    torque: {controller: slew}
    integral: {controller: slew, state: E}
"""

#: a gimbal: a post turning about z (yaw) carries a ring, on which a flexible three-element boom turns about the skew
#: axis (0.6, −0.8, 0.3) (pitch) to a tip mass under gravity; each hinge under a PID whose derivative is filtered: with
#: states I (the integral) and D (a first-order filter of the angle, time constant tf), Kp e + Ki I − Kd (a − D)/tf;
#: the gains, the filter's constant (inside the states' rates) and a section value are the parameters
GIMBAL_PID = """
title: a gimbal's two hinges each under a PID with a filtered derivative
parameters: {Kp: 3.0, Ki: 2.0, Kd: 0.4, tf: 0.05, EI: 80.0}
sections:
  post: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.001}
  boom: {EA: 1.0e5, EIy: "EI", EIz: "EI", GJ: 50.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  ring: {at: [0.05, 0.02, 0.3], mass: 0.3, inertia: [0.02, 0.02, 0.02]}
  tip: {at: [0.65, -0.25, 0.55], mass: 0.3, inertia: [0.01, 0.01, 0.01]}
beams:
  post: {from: base, to: ring, section: post, elements: 1,
         start: {hinge: {axis: [0, 0, 1], damping: 0.1, torque: "yaw"}}}
  boom: {from: ring, to: tip, section: boom, elements: 3,
         start: {hinge: {axis: [0.6, -0.8, 0.3], damping: 0.05, torque: "pitch"}}}
controllers:
  yaw: {output: "Kp*(0.3 - a1) + Ki*I1 - Kd*(a1 - D1)/tf", states: {I1: "0.3 - a1", D1: "(a1 - D1)/tf"}}
  pitch: {output: "Kp*(-0.2 - a2) + Ki*I2 - Kd*(a2 - D2)/tf", states: {I2: "-0.2 - a2", D2: "(a2 - D2)/tf"},
          limits: [-2.5, 2.5]}
gravity: [0, 0, -9.81]
solve: {analysis: transient, t_end: 0.5, dt: 0.01, sensitivities: [Kp, Ki, Kd, tf, EI]}
output:
  every: 0.01
  probes:
    a1: {hinge: post.start, quantity: angle}
    a2: {hinge: boom.start, quantity: angle}
    tip_x: {point: tip, quantity: position, component: x}
    pitch_out: {controller: pitch}
    filtered: {controller: yaw, state: D1}
"""

#: a flexible three-element arm out of the coordinate planes on a skew hinge (1, −2, 0.5) under gravity (4 m/s²),
#: turned by a PD sampled at 50 Hz (zero-order hold) whose derivative is the backward difference of the angle: its
#: state P holds the last sample's angle, S_{k+1} = S_k + 50 (θ − S_k)/50; the gains and the arm's bending stiffness
#: are the parameters, the held output and the state are probed
SAMPLED_PD = """
title: a flexible arm on a skew hinge under a sampled PD (zero-order hold)
parameters: {Kp: 6.0, Kd: 0.2, EI: 40.0}
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "EI", GJ: 30.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6, 0.3, 0.45], mass: 0.5, inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: base, to: tip, section: s, elements: 3,
        start: {hinge: {axis: [1, -2, 0.5], damping: 0.1, torque: "pd"}}}
controllers:
  pd: {output: "Kp*(0.4 - th) - Kd*(th - P)*50", states: {P: "(th - P)*50"}, rate: 50}
gravity: [0, 0, -4.0]
solve: {analysis: transient, t_end: 0.5, dt: 0.01, sensitivities: [Kp, Kd, EI]}
output:
  every: 0.01
  probes:
    th: {hinge: arm.start, quantity: angle}
    tip_z: {point: tip, quantity: position, component: z}
    mid_x: {point: "arm.node[1]", quantity: displacement, component: x}
    pd_out: {controller: pd}
    last_angle: {controller: pd, state: P}
"""

#: tests/test_sensitivities_in_loop_controller_integral.py's two-link 3D boom whose elbow, driven by a PI on its angle
#: (integral state E), latches at 0.4 rad; the PI's output and state probed
BOOM_LATCH = BOOM.replace("  probes:\n",
                          "  probes:\n    torque: {controller: ctl}\n    integral: {controller: ctl, state: E}\n")
#: tests/test_sensitivities_cables.py's skew cable catching a flexible arm's tip mass (five slack/taut changes), the
#: arm's root now a hinge of axis (1, −2, 0) under a PI of its angle; its state probed
CABLE_PI = (CABLE_3D.replace("arm: {from: base, to: tip, section: s, elements: 3}",
                             'arm: {from: base, to: tip, section: s, elements: 3, '
                             'start: {hinge: {axis: [1, -2, 0], damping: 0.1, torque: "ctl"}}}')
            .replace("parameters: {EA: 5000.0,", "parameters: {Kp: 2.0, Ki: 3.0, EA: 5000.0,")
            .replace("solve: {", 'controllers:\n  ctl: {output: "Kp*(0.1 - th) + Ki*E", states: {E: "0.1 - th"}}\n'
                     'solve: {')
            .replace("sensitivities: [EA, L, EI, c]", "sensitivities: [Kp, Ki, EA, L, EI, c]")
            .replace("  probes:\n", "  probes:\n    th: {hinge: arm.start, quantity: angle}\n"
                     "    integral: {controller: ctl, state: E}\n"))
#: the sampled PD's arm beside a stop at 0.012 rad (hit twice, restitution 0.5) and beside a latch there
SAMPLED_STOP = SAMPLED_PD.replace('torque: "pd"}}}', 'torque: "pd", limits: [-0.2, 0.012], restitution: 0.5}}}')
SAMPLED_LATCH = SAMPLED_PD.replace('torque: "pd"}}}', 'torque: "pd", lock_at: 0.012}}}')
assert "integral: {controller" in BOOM_LATCH and "Kp, Ki, EA" in CABLE_PI and 'torque: "ctl"' in CABLE_PI
assert "restitution: 0.5" in SAMPLED_STOP and "lock_at: 0.012" in SAMPLED_LATCH


def _adjoint(text: str) -> str:
    data = yaml.safe_load(text)
    data["solve"]["sensitivity_method"] = "adjoint"
    return yaml.safe_dump(data, sort_keys=False)


@pytest.fixture(scope="module")
def sampled_pd():
    return _both(SAMPLED_PD)


@pytest.fixture(scope="module")
def slew_boom():
    return _both(SLEW_BOOM)


@pytest.fixture(scope="module")
def gimbal_pid():
    return _both(GIMBAL_PID)


def test_the_slewing_boom_s_pi_adjoint_equals_the_forward_method(slew_boom):
    """Every probe's end, max and min (the controller's output and integral state among them) by the gains and the
    section value, the forward method's to 1e-10 relative. Measured: 1.3e-12."""
    forward, adjoint = slew_boom
    assert adjoint.summary["probe_sensitivities"]["integral"]["end"]["Ki"] != 0.0
    assert _adjoint_error(forward, adjoint) <= 1e-10


def test_the_gimbal_s_two_filtered_pids_adjoint_equals_the_forward_method(gimbal_pid):
    """Two controllers of two states each (the filter's constant inside the states' rates), one clipped part of the
    run: the forward method's to 1e-10 relative. Measured: 1.3e-12."""
    forward, adjoint = gimbal_pid
    assert adjoint.summary["probe_sensitivities"]["filtered"]["end"]["tf"] != 0.0
    assert _adjoint_error(forward, adjoint) <= 1e-10


def test_the_sampled_pd_s_adjoint_equals_the_forward_method(sampled_pd):
    """The held output's δy through the steps until the next sample, the samples and the restarts after them
    transposed; the held output and the state probed: the forward method's to 1e-10 relative. Measured: 9.3e-13."""
    forward, adjoint = sampled_pd
    assert adjoint.summary["probe_sensitivities"]["last_angle"]["end"]["Kd"] != 0.0
    assert _adjoint_error(forward, adjoint) <= 1e-10


def test_a_clipped_sampled_pi_s_adjoint_equals_the_forward_method():
    """tests/test_sensitivities_controller_probes.py's SAMPLED_ARM: a sampled PI clipped from about 0.1 s (its δy 0
    there) driving a hinge torque and a tip force, its held output and state probed. Measured: 6.2e-14."""
    from tests.test_sensitivities_controller_probes import SAMPLED_ARM

    forward, adjoint = _both(SAMPLED_ARM)
    assert np.any(adjoint.probes["dig_out"] == -0.08)
    assert _adjoint_error(forward, adjoint) <= 1e-10


@pytest.mark.parametrize("text, events", [(BOOM_LATCH, ["latch"]), (WHEEL_STOP, ["stop", "stop"]),
                                          (CABLE_PI, ["taut", "slack", "taut", "slack", "taut"]),
                                          (SAMPLED_STOP, ["stop", "stop"]), (SAMPLED_LATCH, ["latch"])],
                         ids=["integral beside a latch", "PI on a filter beside a stop", "PI beside a cable",
                              "sampled PD beside a stop", "sampled PD beside a latch"])
def test_controllers_with_states_beside_events_equal_the_forward_method(text, events):
    """Through each event's pieces with δS or δy held (the restart's B δS, A_y δy, the impulse's and the stop
    restart's weights' ∂(B δS)/∂q w, ∂(A_y δy)/∂q w) and the step size's column (the states' B by_h and δS_{n+1}'s
    by_h δh): every probe's end, max and min and every event time's derivative the forward method's to 1e-10
    relative. Measured: the boom's latch 7.6e-13, the wheel's two stops 9.3e-13, the cable's five changes 2.5e-13, the
    sampled PD's stops 2.5e-13 and latch 4.6e-13."""
    forward, adjoint = _both(text)
    assert [e["kind"] for e in adjoint.summary["event_sensitivities"]] == events
    assert _adjoint_error(forward, adjoint) <= 1e-10


@pytest.mark.parametrize("text, names, index", [(SLEW_BOOM, ["Ki", "EI"], 0), (GIMBAL_PID, ["tf", "Kd"], 1),
                                                (SAMPLED_PD, ["Kd", "EI"], 2), (BOOM_LATCH, ["Ki"], 3)],
                         ids=["slewing boom", "gimbal", "sampled PD", "integral beside a latch"])
def test_the_adjoints_end_values_agree_with_richardson_central_differences(slew_boom, gimbal_pid, sampled_pd, text,
                                                                          names, index):
    """The adjoint's derivative of each probe's last value (controller probes too) against whole runs differenced,
    relative to the largest over the probes. Measured (worst over the probes): the boom by Ki 9.7e-9, EI 4.7e-8 (the
    hub's rate); the gimbal by tf 3.8e-10, Kd 7.2e-10; the sampled PD by Kd 6.6e-8, EI 6.6e-9 (its held output); the
    latching boom by Ki 2.1e-11."""
    if index == 3:
        data = yaml.safe_load(text)
        data["solve"].update(sensitivity_method="adjoint", sensitivities=names)
        adjoint = latdyn.run(latdyn.load_scene(data))
    else:
        adjoint = (slew_boom, gimbal_pid, sampled_pd)[index][1]
    for name in names:
        expected = _richardson_end(text, name, adjoint)
        scale = max(abs(v) for v in expected.values())
        for probe, value in expected.items():
            error = abs(adjoint.summary["probe_sensitivities"][probe]["end"][name] - value) / scale
            assert error <= 1e-6, (probe, name, error)


def test_the_cli_equals_the_api_bit_for_bit(tmp_path, slew_boom):
    """python -m latdyn run writes the API's probe sensitivities to the bit."""
    completed, out = latdyn_run(tmp_path, _adjoint(SLEW_BOOM))
    assert completed.returncode == 0, completed.stderr
    written = json.loads((out / "summary.json").read_text())["probe_sensitivities"]
    assert written == slew_boom[1].summary["probe_sensitivities"]


def test_a_controller_probe_naming_t_beside_a_latch_equals_the_forward_method():
    """A controller probe's output beside an event where the controller's output names t: refused on 40bf44a (the row's
    time moves with the parameters: the forward method's ∂f/∂t δt was not transposed), now seeded on t̄ there
    (tests/test_adjoint_states_rates.py has one whose largest value is at the latch's row). Measured: 6.3e-13."""
    data = yaml.safe_load(_adjoint(SAMPLED_LATCH))
    data["parameters"]["g"] = 0.1
    data["controllers"]["lead"] = {"output": "0.2 + g*sin(3*t)"}
    data["output"]["probes"]["lead_out"] = {"controller": "lead"}
    data["solve"]["sensitivities"].append("g")
    adjoint = latdyn.run(latdyn.load_scene(data))
    data["solve"]["sensitivity_method"] = "forward"
    forward = latdyn.run(latdyn.load_scene(data))
    assert adjoint.summary["probe_sensitivities"]["lead_out"]["end"]["g"] != 0.0
    assert _adjoint_error(forward, adjoint) <= 1e-10
