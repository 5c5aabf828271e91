"""Sensitivities of controller probes (latdyn/analyses/controller_probe_sensitivities.py; SCENE.md
``controllers``: probe ``{controller: NAME}`` records the output after saturation, ``{controller: NAME,
state: S}`` a state; docs/parameters.md, "Controllers").

A continuous controller's output y = clip(f(t, s, S; p)) moves by ∂f/∂s δs + ∂f/∂y_j δy_j + ∂f/∂S δS +
∂f/∂p (0 while clipped), its state by the carried δS; a sampled one's by the held δy_k, δS_{k+1}.
Reference: central differences of whole runs at p ± h and p ± h/2, Richardson-extrapolated, the time
step fixed (tests/test_sensitivities_events.py ``_agree``)."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run
from latdyn.errors import SceneError
from tests.test_sensitivities_events import _agree, _run

#: the flexible 3D arm (3 elements, out of the coordinate planes) on a hinge of axis (1, −2, 0): a PD
#: (reading the hinge's angle and rate and a moving target ``lead``, chained; clipped at 0.7 from 0.26 s)
#: drives the hinge torque, a PI of the tip's height (integral state I from 0.05) a vertical force on the tip
PI_PD_ARM = """
title: a flexible arm on a hinge driven by a chained PD and a PI
parameters: {Kf: 3.0, Ki: 2.0, Kp: 2.0, g: 0.3, k: 1.0}
sections: {s: {EA: 1.0e5, EIy: 40.0, EIz: 40.0, GJ: 30.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 0.5,
        inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: base, to: tip, section: s, elements: 3,
        start: {hinge: {axis: [1, -2, 0], stiffness: "k", damping: 0.3, torque: "pd + 0.4"}}}
controllers:
  lead: {output: "0.2 + g*sin(3*t)"}
  pd: {output: "Kp*(lead - angle) - 0.1*w", limits: [-3, 0.7]}
  pic: {output: "-Kf*(tip_z - 0.66) - Ki*I", states: {I: "tip_z - 0.66"}, initial: {I: 0.05}}
loads:
  - {at: tip, force: [0, 0, "0.5*pic"]}
solve: {analysis: transient, t_end: 0.4, dt: 0.01, sensitivities: [Kf, Ki, Kp, g, k]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.start, quantity: angle}
    w: {hinge: arm.start, quantity: rate}
    tip_z: {point: tip, quantity: position, component: z}
    pd_out: {controller: pd}
    pi_out: {controller: pic}
    pi_I: {controller: pic, state: I}
"""

#: the same arm under a PI of the tip's height sampled at 50 Hz, clipped below at −0.08 (reached
#: after about 0.1 s), driving the hinge torque 2 dig + 0.4 and a vertical force 0.5 dig on the tip:
#: its held output and its state are probed
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
    tip_z: {point: tip, quantity: position, component: z}
    dig_out: {controller: dig}
    dig_I: {controller: dig, state: I}
"""


@pytest.fixture(scope="module")
def pi_pd():
    return latdyn.run(latdyn.load_scene(yaml.safe_load(PI_PD_ARM)))


@pytest.mark.parametrize("name", ["Kf", "Ki", "Kp", "g", "k"])
def test_continuous_controller_probes_agree_with_richardson_differences(pi_pd, name):
    """The outputs (pd reading lead, the angle and the rate; pic its state I) and the state by every parameter
    ≤ 1e-6 relative (each probe's largest) to Richardson-extrapolated central differences."""
    assert _agree(pi_pd, PI_PD_ARM, name) <= 1e-6


@pytest.mark.parametrize("name", ["Kf", "c", "k"])
def test_sampled_controller_probes_agree_with_richardson_differences(name):
    """The held output (clipped from about 0.1 s: its derivative 0 there) and the state."""
    result = _run(SAMPLED_ARM, name)
    assert np.any(result.probes["dig_out"] == -0.08) and np.any(result.probes["dig_out"] > -0.08)
    assert _agree(result, SAMPLED_ARM, name) <= 1e-6


def test_cli_writes_the_controller_probes_sensitivities(tmp_path, pi_pd):
    """python -m latdyn run writes the controller probes' columns, the API's to round-off."""
    completed, out = latdyn_run(tmp_path, PI_PD_ARM)
    assert completed.returncode == 0, completed.stderr
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.DictReader(f))
    for probe in ("pi_out", "pi_I", "pd_out"):
        written = np.array([float(r[f"{probe}/Kf"]) for r in rows])
        assert np.abs(written - pi_pd.sensitivities[(probe, "Kf")]).max() <= 1e-12 * np.abs(written).max()


def test_static_controller_probes_are_refused_naming_the_probe(tmp_path):
    """A static path's controller probe: exit 2 naming solve.sensitivities and the probe as
    ``controller NAME output`` (never ``controller None``)."""
    data = yaml.safe_load(PI_PD_ARM)
    data["controllers"] = {"pd": {"output": "-0.2*angle + 0.1"}}
    data.pop("loads")
    data["beams"]["arm"]["start"]["hinge"]["torque"] = "pd"
    data["parameters"] = {"k": 1.0}
    data["solve"] = {"analysis": "static", "sensitivities": ["k"]}
    data["output"]["probes"] = {"angle": {"hinge": "arm.start", "quantity": "angle"}, "pd_out": {"controller": "pd"}}
    with pytest.raises(SceneError, match=r"solve\.sensitivities.*'pd_out' \(controller pd output\)"):
        latdyn.run(latdyn.load_scene(data))
    completed, _ = latdyn_run(tmp_path, yaml.safe_dump(data))
    assert completed.returncode == 2
    assert "solve.sensitivities" in completed.stderr and "controller pd output" in completed.stderr
    assert "None" not in completed.stderr and "Traceback" not in completed.stderr


def test_the_adjoint_is_seeded_by_controller_probes():
    """The discrete adjoint seeded by the arm's controller probes (refused until
    latdyn/analyses/adjoint_controller_states.py): the chained PD's output (clipped from 0.26 s, reading a rate and a
    controller whose output names t), the PI's output and its integral state, every probe's end, max and min by every
    parameter the forward method's to 1e-10 relative. Measured: 5.0e-12."""
    from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both

    forward, adjoint = _both(PI_PD_ARM)
    assert adjoint.summary["probe_sensitivities"]["pi_I"]["end"]["Ki"] != 0.0
    assert _adjoint_error(forward, adjoint) <= 1e-10
