"""Transient sensitivities with continuous controllers in the loop (latdyn/analyses/sensitivities.py,
ControllerTerms; docs/parameters.md, "Controllers").

A continuous controller's output y = clip(f(t, sensors; p)) drives a hinge torque; its derivatives by
the sensors are in the step's matrix already, so a parameter inside its output adds ∂f/∂p (through
the chain of controllers, zero while clipped) to ∂r/∂p. Reference: central differences of whole runs
at p ± h and p ± h/2, Richardson-extrapolated, the time step fixed."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError

#: a wheel (centre of mass off the hinge) on a hinge at the end of an arm, out of the coordinate planes;
#: ``lead`` sets a moving target, ``pd`` (reading it, the hinge angle and the wheel's x) turns the wheel
#: towards it through the hinge torque 2 pd + 0.1 (pd is clipped at 2.32 from 0.15 s to 0.20 s); ``push``
#: (reading the wheel's x and pd) drives a force and a moment turning with the wheel
WHEEL = """
title: a wheel on a hinge at the end of a stiff arm, turned by two chained controllers
parameters: {Kp: 4.0, a0: 0.5, g: 0.3, k: 1.0, Kl: 30.0}
sections: {s: {EA: 1.0e6, EIy: 1.0e4, EIz: 1.0e4, GJ: 8.0e3, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  wheel: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 1.0, com: [0.05, 0, 0],
          inertia: [1.0, 1.0, 1.2]}
beams:
  arm: {from: base, to: wheel, section: s, elements: 2,
        end: {hinge: {axis: [1, -2, 0], stiffness: "k", damping: 0.3, torque: "2*pd + 0.1"}}}
controllers:
  lead: {output: "a0 + g*sin(3*t)"}
  pd: {output: "Kp*(lead - angle) - 0.5*(tip_x - 0.66)", limits: [-5, 2.32]}
  push: {output: "Kl*(0.7 - tip_x) + 0.2*pd"}
loads:
  - {at: wheel, force: [0, "2*push", 0], moment: ["0.5*push", 0, 0], frame: wheel}
solve: {analysis: transient, t_end: 0.5, dt: 0.01, sensitivities: [Kp, a0, g, k, Kl]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.end, quantity: angle}
    tip_x: {point: wheel, quantity: position, component: x}
    mid_z: {point: "arm.node[1]", quantity: displacement, component: z}
"""


def _run(names, **parameters):
    data = yaml.safe_load(WHEEL)
    data["parameters"].update(parameters)
    data["solve"]["sensitivities"] = list(names)
    if not names:
        del data["solve"]["sensitivities"]
    return latdyn.run(latdyn.load_scene(data))


@pytest.fixture(scope="module")
def wheel():
    return _run(["Kp", "a0", "g", "k", "Kl"])


def test_another_gain_runs_another_controller():
    """The compiled controller laws are keyed by the expressions as read (the parameters' values in
    them), not by the text as written: before, a run with Kp = 40 reused the law compiled for Kp = 4
    (the same angles to the last bit)."""
    low, high = _run([], Kp=4.0).probes["angle"], _run([], Kp=40.0).probes["angle"]
    assert np.abs(high - low).max() > 1e-2


@pytest.mark.parametrize("name, relative", [("Kp", 1e-4), ("g", 1e-4), ("k", 1e-3), ("Kl", 1e-3)])
def test_sensitivities_through_continuous_controllers_agree_with_richardson_differences(wheel, name, relative):
    """Kp: a gain of pd (no derivative while it is clipped: without that rule the check is off by 0.2 of
    the angle's, 1.0 of the wheel's x); g: a gain of lead, which pd reads (the chain rule); k: the hinge
    spring, beside the controllers; Kl: push's gain, a load's. Measured, of each probe's largest
    sensitivity: Kp 2.6e-8, a0 2.6e-8, g 6.8e-8, k 5.4e-8, Kl 5.4e-8 (at 1e-4 relative k's and Kl's
    small tip derivatives, 1e-5 and 1e-6, see the differences' noise: Kl 2.8e-7)."""
    p0 = yaml.safe_load(WHEEL)["parameters"][name]
    h = relative * abs(p0)
    central = []
    for step in (h, h / 2):
        up, down = _run([name], **{name: p0 + step}), _run([name], **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        scale = np.abs(expected).max()
        assert scale > 0, (probe, name)
        error = np.abs(wheel.sensitivities[(probe, name)] - expected).max() / scale
        assert error <= 1e-6, (probe, name, error)


@pytest.mark.parametrize("change, expected", [
    (lambda d: d["controllers"]["pd"].update(rate=100.0), "the sampled controller pd, which reads another"),
    (lambda d: (d["controllers"].update(integral={"output": "i", "states": {"i": "angle*t"}}),
                d["beams"]["arm"]["end"]["hinge"].update(lock_at=1.0, torque="integral")), "states' rates name t"),
    (lambda d: (d.update(inputs={"u": 0.0}), d["controllers"].update(digital={"output": "u", "rate": 100.0})),
     "the sampled controller digital, which reads another controller or an input"),
    (lambda d: d["loads"][0].update(moment=["0.5*push + Kl", 0, 0]), "a law that names a controller"),
])
def test_what_controllers_cannot_be_differentiated_through_is_refused(change, expected):
    data = yaml.safe_load(WHEEL)
    change(data)
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities" and expected in info.value.expected, info.value.expected


def test_a_gain_in_the_torque_that_names_the_controller_is_differentiated():
    """The torque ``Kp*pd`` (refused on 86d57d9, "a law that names a controller"): Kp's ∂τ/∂Kp = pd at fixed output
    beside pd's own dy/dKp times a = Kp (tests/test_sensitivities_refusals_lifted2.py). Against Richardson-extrapolated
    central differences of whole runs (tests/test_sensitivities_events.py ``_agree``): measured 7.2e-8 (tip_x)."""
    from tests.test_sensitivities_events import _agree
    from tests.test_sensitivities_events import _run as _run_text

    text = WHEEL.replace('torque: "2*pd + 0.1"', 'torque: "Kp*pd"')
    assert _agree(_run_text(text, "Kp"), text, "Kp", tolerance=1e-6) >= 0.0
