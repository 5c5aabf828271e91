"""Issue 34: the forward method's sensitivities of a hinge resting on its rigid stop in a model with rigid links
(latdyn/analyses/transient_sensitivities.py ``_settle_or_release``, ``_restart_before_settling``; docs/parameters.md,
"A hinge resting on its stop").

restlinks (the fifteenth session) took it where no guide, latch, cable, controller or geometry parameter is in the
model (REST below). benchmarks/fuzz_lifted.py then found seed 1 case 5 (FUZZ below) 3.0e-3 … 4.6e-2 off
Richardson-extrapolated central differences and it was refused (fuzznew). The cause (linkrest): at 0.155 s the run
releases the resting ring (its reaction at the step's accelerations pulls), restarts twice with it free
(``release_from_stops``, ``hinge_stops``), and ``settle_on_stops`` finds the stop holding it at the restarted
accelerations and locks it again: ``model.resting`` as before, the accelerations those of a third restart on the
locked model. The forward method saw no change and kept the step's δv̇ (the other ring's δθ̈ −246 against
Richardson's −50); it now differentiates the three restarts, the release known from the run's own test at the step's
end (``events.stop_holds``). PUT_BACK (FUZZ with a one-element boom) is released and settled again, released, put
back on its stop by the projection at a step's end and released again.

Against Richardson-extrapolated central differences of whole runs, stored in tests/linked_rest_richardson.json
(benchmarks/linked_rest_references.py writes them: the perturbation 1e-4 and 5e-5 relative, the time step fixed, the
perturbed runs with ``solve.sensitivities`` so their steps are the checked run's), each probe's rows relative to its
largest. Measured (linkrest): REST by k1, m, EI 1.3e-8, 9.1e-9, 8.8e-9; FUZZ by m, k1 1.2e-9, 7.9e-10; PUT_BACK by m
6.1e-9, its reference's runs landing to 1e-14 (its second landing grazes the stop at −6.4e-3 rad/s, where the
package's 1e-12 rad moves the landed time by 5.2e-6 of its derivative: 4.6e-7 against a reference landed so). Each
test but the adjoint's guard fails on bd00230b (the rest refused); with that refusal lifted there and the mend absent
FUZZ is off by 3.0e-3 … 4.6e-2."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.test_sensitivities_rigid_links import GIMBAL

#: the gimbal of tests/test_sensitivities_rigid_links.py as typed, the inner ring's hinge between rigid stops at
#: −0.1 and 1.0 rad with restitution 0: it lands on −0.1, rests, and is released before the run's end
REST = (GIMBAL.replace("carrying a flexible boom\n", "carrying a flexible boom, the inner ring resting on its stop\n")
        .replace('damping: "c2"}}}', 'damping: "c2", limits: [-0.1, 1.0],\n                         restitution: 0.0}}}')
        .replace("t_end: 0.3, sensitivities: [k1, m, P, EI, rho]", "t_end: 0.45, sensitivities: [k1, m, EI]"))
assert "resting on its stop" in REST and "restitution: 0.0}}}" in REST and "t_end: 0.45" in REST

#: fuzz_lifted seed 1 case 5 to 0.2 s: the inner ring of a skew gimbal lands on its stop at −0.1359 rad (t = 0.1066 s)
#: and leaves it, lands again at 0.1494 s and rests; at 0.155 s the run releases it and settles it again at once; it
#: is released at 0.16 s
FUZZ = """
title: fuzz_lifted seed 1 case 5, a gimbal's inner ring resting briefly on its stop and released
parameters: {k1: 7.3116, k2: 5.8849, c2: 0.0636, m: 0.3808, EI: 23.3758, P: 0.5231}
sections:
  ring: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 0.8, rhoIy: 0.0008, rhoIz: 0.001}
  boom: {EA: 1.0e5, EIy: "EI", EIz: "1.2*EI", GJ: "0.7*EI", rhoA: 0.4, rhoIy: 0.0004, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  outer: {at: [0.3247, 0.0523, 0.2196], mass: "m", inertia: [0.0028, 0.0019, 0.0026]}
  inner: {at: [0.482, -0.0722, 0.3905], mass: 0.2122, inertia: [0.0011, 0.0013, 0.0015]}
  tip: {at: [1.0653, 0.3193, 0.5227], mass: 0.1, inertia: [0.0002, 0.0002, 0.0002]}
beams:
  gim1: {from: base, to: outer, section: ring, rigid: true, y_axis: [-0.7106, 0.4898, -0.505],
         start: {hinge: {axis: [0.127, -0.2061, 1.0], stiffness: "k1", rest_angle: -0.4397}}}
  gim2: {from: outer, to: inner, section: ring, rigid: true, y_axis: [0.5782, -0.6507, -0.4922],
         start: {hinge: {axis: [1.0, 0.3568, 0.2355], stiffness: "k2", damping: "c2", limits: [-0.1359, 3.0],
                         restitution: 0.0}}}
  boom: {from: inner, to: tip, section: boom, elements: 2, y_axis: [0.4054, 0.539, 0.7383]}
loads:
  - {at: tip, force: [0, "P", "-0.5*P"]}
initial_velocity: {angular: [-0.4951, 0.2562, 2.1236]}
solve: {analysis: transient, dt: 0.005, t_end: 0.2, tol: 1.0e-12, rho_inf: 0.574, sensitivities: [m, k1]}
output:
  every: 0.01
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    a1: {hinge: gim1.start, quantity: angle}
    a2: {hinge: gim2.start, quantity: angle}
    r2: {hinge: gim2.start, quantity: rate}
"""

#: FUZZ with a one-element boom to 0.17 s: lands at 0.1020 s and leaves, lands again at 0.1062 s (grazing, −6.4e-3
#: rad/s) and rests, released and settled again at 0.115 s, released at 0.12 s, put back on its stop by the
#: projection at 0.125 s and resting, released at 0.145 s
PUT_BACK = (FUZZ.replace("elements: 2,", "elements: 1,").replace("t_end: 0.2,", "t_end: 0.17,")
            .replace("sensitivities: [m, k1]", "sensitivities: [m]")
            .replace("resting briefly on its stop and released", "released, settled again and put back on its stop"))

#: the parameters each scene is checked by
CHECKED = {"REST": ["k1", "m", "EI"], "FUZZ": ["m", "k1"], "PUT_BACK": ["m"]}

#: the stored Richardson references (benchmarks/linked_rest_references.py)
REFERENCES = Path(__file__).with_name("linked_rest_richardson.json")


def scene(name: str, **changes) -> dict:
    """The scene ``name`` of this module as a user types it, its solve keys changed by ``changes``."""
    data = yaml.safe_load(globals()[name])
    data["solve"].update(changes)
    return data


@pytest.fixture(scope="module")
def runs():
    return {name: latdyn.run(latdyn.load_scene(scene(name))) for name in CHECKED}


@pytest.fixture(scope="module")
def references():
    return json.loads(REFERENCES.read_text())


def test_the_runs_do_what_the_scenes_say(runs):
    """The events the scenes are about (a guard on the scenes: the stop landings as logged)."""
    assert [round(e["t"], 4) for e in runs["FUZZ"].summary["events"]] == [0.1066, 0.1494]
    assert [round(e["t"], 4) for e in runs["PUT_BACK"].summary["events"]] == [0.102, 0.1062]
    assert [e["kind"] for e in runs["REST"].summary["events"]] == ["stop"]


@pytest.mark.parametrize("name,parameter", [(name, p) for name, names in CHECKED.items() for p in names])
def test_a_rest_on_rigid_links_agrees_with_richardson(runs, references, name, parameter):
    """Every probe's rows within 1e-6 of its largest of the stored Richardson reference."""
    result, reference = runs[name], references[name][parameter]
    for probe, expected in reference.items():
        expected = np.asarray(expected)
        error = np.abs(result.sensitivities[(probe, parameter)] - expected).max() / np.abs(expected).max()
        assert error <= 1e-6, (name, probe, parameter, error)


def test_a_rest_beside_a_latch_on_rigid_links_is_refused_naming_the_stop():
    """Not checked there (restlinks' refusal): SceneError naming the stop's limits."""
    data = scene("REST")
    data["beams"]["gim1"]["start"]["hinge"]["lock_at"] = 5.0
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(data))
    assert "beams.gim2.start.hinge.limits" in str(refused.value) and "latches or cables" in str(refused.value)


def test_the_adjoint_still_refuses_it():
    """Guard: the discrete adjoint does not transpose a rest on a model with rigid links."""
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(scene("REST", sensitivity_method="adjoint")))
    assert "beams.gim2.start.hinge.limits" in str(refused.value) and "rigid links" in str(refused.value)
