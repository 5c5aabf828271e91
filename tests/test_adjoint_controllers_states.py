"""The discrete adjoint through continuous controllers with states and seeded by controller probes (issue 34;
latdyn/analyses/adjoint_controller_states.py; docs/parameters.md, "The discrete adjoint").

The reverse pass carries the states' bars S̄, f̄ beside the structure's and applies the transposes of the forward
method's pieces (ControllerStates.after_step, the held part's ∂r/∂p, begin_step, start); a controller probe seeds
its state's S̄ or its output's forms. Each scene is genuinely 3D (hinge axes and points out of the coordinate planes)
and typed as YAML. References: the forward method's sensitivities (≤ 1e-10 relative, every probe's end, max and min
by every parameter) and Richardson-extrapolated central differences of whole runs of each probe's end value
(≤ 1e-6 relative to the largest over the probes, the perturbation varied, the time step fixed). Before this change
(86d57d9) every scene here was refused (exit 2 naming solve.sensitivity_method)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both, _richardson_end

#: a slewing boom: a hub turning about a tilted axis (0.2, 0.1, 1) carries a flexible four-element boom out of the
#: coordinate planes to a tip mass; a PI of the hub's angle toward 0.5 rad, Kp (0.5 − θ) + Ki E (the hub's damping 0.8) with
#: dE/dt = 0.5 − θ (E from 0.05), drives the hub's torque; the gains and the boom's bending stiffness EI (a section
#: value) are the parameters; the controller's output and its integral state are probed
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


def _adjoint(text: str) -> str:
    data = yaml.safe_load(text)
    data["solve"]["sensitivity_method"] = "adjoint"
    return yaml.safe_dump(data, sort_keys=False)


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


@pytest.mark.parametrize("text, names, index", [(SLEW_BOOM, ["Ki", "EI"], 0), (GIMBAL_PID, ["tf", "Kd"], 1)],
                         ids=["slewing boom", "gimbal"])
def test_the_adjoints_end_values_agree_with_richardson_central_differences(slew_boom, gimbal_pid, text, names, index):
    """The adjoint's derivative of each probe's last value (controller probes too) against whole runs differenced,
    relative to the largest over the probes. Measured: see the ids' assertions' messages."""
    adjoint = (slew_boom, gimbal_pid)[index][1]
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


@pytest.mark.parametrize("change, expected", [
    (lambda d: d["beams"]["boom"]["start"]["hinge"].update(lock_at=0.3),
     r"controllers with states beside events.*controllers\.slew"),
    (lambda d: d["controllers"]["slew"].update(rate=50.0), r"sampled controller.*slew"),
], ids=["beside a latch", "sampled"])
def test_what_the_adjoint_does_not_take_stays_refused(tmp_path, change, expected):
    """An integral controller beside a latch and a sampled controller: exit 2 naming solve.sensitivity_method and the
    controller, never a traceback."""
    data = yaml.safe_load(_adjoint(SLEW_BOOM))
    change(data)
    with pytest.raises(SceneError, match=expected) as refused:
        latdyn.run(latdyn.load_scene(data))
    assert refused.value.key == "solve.sensitivity_method"
    completed, _ = latdyn_run(tmp_path, yaml.safe_dump(data))
    assert completed.returncode == 2 and "solve.sensitivity_method" in completed.stderr
    assert "Traceback" not in completed.stderr
