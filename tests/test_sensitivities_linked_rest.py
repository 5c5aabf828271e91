"""The forward method through a hinge that comes to rest on its rigid stop in a model with rigid links, rests
there and is released (latdyn/analyses/transient_sensitivities.py ``_settle_or_release``, ``_restart``;
docs/parameters.md, "Sensitivities through events"), against Richardson-extrapolated central differences of whole
runs: a 3D gimbal of two rigid rings on skew hinges carrying a flexible boom, the inner ring's hinge landing on
its stop at −0.1 rad with restitution 0 (t = 0.2791 s), resting there and released at t = 0.38 s when the load
pulls it off. The run restarts the accelerations twice at the release (the release's, then the stop's that finds
the hinge on it) and at the landing (the impact's with the hinge free, then the locked model's), and with rigid
links the second differs from the first (W reads the accelerations); differentiating one of them left the
derivatives 5.6e-4 (k1) to 1.8e-3 (m) off. What stays refused: the discrete adjoint, and a rest beside a latch.

The release is refused since fuzznew: benchmarks/fuzz_lifted.py (seed 1 case 5, FUZZ_RELEASE below) found the
derivatives after a release 4.6e-2 (m; k1 3.7e-2) of each probe's largest off Richardson differences (h = 1e-4 p
against h/2 within 6e-6): a gimbal whose inner ring lands at 0.1494 s, rests three steps and is released at 0.16 s;
right before the release 2.6e-10. The cause is not found. The landing and the rest stay taken (REST to 0.37 s, before
its release; three fuzz_lifted cases resting to the end agreed within 1e-6)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_events import _agree, _run

#: the gimbal of tests/test_sensitivities_rigid_links.py as typed, the inner ring's hinge between rigid stops at
#: −0.1 and 1.0 rad with restitution 0: it lands on −0.1, rests, and is released before the run's end
REST = """
title: a gimbal of two rigid links on skew hinges carrying a flexible boom, the inner ring resting on its stop
parameters: {k1: 6.0, k2: 4.0, c2: 0.05, m: 0.3, P: 0.4, EI: 20.0, rest: 0.6, rho: 0.8}
sections:
  ring: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: "rho", rhoIy: "0.001*rho", rhoIz: 0.001}
  boom: {EA: 1.0e5, EIy: "EI", EIz: "1.2*EI", GJ: "0.7*EI", rhoA: 0.4, rhoIy: 0.0004, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  outer: {at: [0.3, 0.1, 0.2], mass: "m", inertia: [0.002, 0.003, 0.0025]}
  inner: {at: [0.45, -0.05, 0.35], mass: 0.2, inertia: [0.001, 0.0012, 0.0015]}
  tip: {at: [1.0, 0.25, 0.55], mass: 0.1, inertia: [0.0002, 0.0002, 0.0002]}
beams:
  gim1: {from: base, to: outer, section: ring, rigid: true,
         start: {hinge: {axis: [0.2, 0.3, 1.0], stiffness: "k1", rest_angle: "rest"}}}
  gim2: {from: outer, to: inner, section: ring, rigid: true,
         start: {hinge: {axis: [1.0, -0.4, 0.3], stiffness: "k2", damping: "c2", limits: [-0.1, 1.0],
                         restitution: 0.0}}}
  boom: {from: inner, to: tip, section: boom, elements: 3}
loads:
  - {at: tip, force: [0, "P", "-0.5*P"]}
initial_velocity: {angular: [0.5, -0.3, 2.0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.45, sensitivities: [k1, m, EI]}
output:
  every: 0.05
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    tip_z: {point: tip, quantity: displacement, component: z}
    outer_y: {point: outer, quantity: position, component: y}
    a1: {hinge: gim1.start, quantity: angle}
    a2: {hinge: gim2.start, quantity: angle}
    r2: {hinge: gim2.start, quantity: rate}
    vo: {point: outer, quantity: velocity, component: y}
    vi: {point: gim1.end, quantity: velocity, component: z}
"""

#: REST up to 0.37 s: landed and resting, not yet released
RESTING = REST.replace("t_end: 0.45", "t_end: 0.37")
assert "t_end: 0.37" in RESTING

#: fuzz_lifted seed 1 case 5: the inner ring of a skew gimbal on a spinning base lands on its stop at −0.1359 rad
#: (t = 0.1066 s) and leaves it, lands again at 0.1494 s, rests and is released at the step's end at 0.16 s
FUZZ_RELEASE = """
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
solve: {analysis: transient, dt: 0.005, t_end: 0.4, rho_inf: 0.574, sensitivities: [m]}
output:
  every: 0.01
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    a2: {hinge: gim2.start, quantity: angle}
"""

#: the same with a latch on the outer ring's hinge that it never reaches: the rest beside it is refused
BESIDE_A_LATCH = REST.replace('rest_angle: "rest"}}}', 'rest_angle: "rest", lock_at: 3.0}}}')


@pytest.fixture(scope="module")
def resting():
    return _run(RESTING)


def test_the_inner_ring_lands_and_rests(resting):
    """The run the derivatives go through: one impact on the stop, the angle held at −0.1 over the rows 0.3 and
    0.35 s (released at 0.38 s, after this run's end)."""
    assert [(e["kind"], e["joint"]) for e in resting.summary["events"]] == [("stop", "gim2.start")]
    assert resting.summary["events"][0]["t"] == pytest.approx(0.2791, abs=1e-4)
    angle = dict(zip(np.round(resting.t, 6), resting.probes["a2"]))
    assert angle[0.3] == pytest.approx(-0.1, abs=1e-9) and angle[0.35] == pytest.approx(-0.1, abs=1e-9)


@pytest.mark.parametrize("name", ["k1", "m", "EI"])
def test_the_derivatives_through_the_landing_and_rest_are_richardsons(resting, name):
    """Every probe's derivative over the rows, and the landing's δt, within 1e-6 of Richardson differences (with
    the landing's one restart on the locked model 2.8e-6 by EI: the landing restarts twice too). The release at
    0.38 s agreed too (restlinks; 5.6e-4 … 1.8e-3 off with one of its two restarts) but is refused since fuzznew."""
    assert _agree(resting, RESTING, name, tolerance=1e-6) <= 1e-6


def test_the_cli_writes_the_apis_sensitivities(tmp_path, resting):
    """``python -m latdyn run`` on the scene as typed: summary.json's probe_sensitivities are the API's."""
    run, out = latdyn_run(tmp_path, RESTING)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["probe_sensitivities"] == resting.summary["probe_sensitivities"]


@pytest.mark.parametrize("text", ["REST", "FUZZ_RELEASE"])
def test_a_release_from_the_rest_on_rigid_links_is_refused_naming_the_stop(text):
    """Taken on 7fbef8b: FUZZ_RELEASE 4.6e-2 off after its release (REST's release agreed within 1.3e-8)."""
    with pytest.raises(SceneError) as refused:
        _run(globals()[text])
    message = str(refused.value)
    assert "beams.gim2.start.hinge.limits" in message and "leaves its stop in a model with rigid links" in message


def test_a_rest_beside_a_latch_is_refused_naming_the_stop():
    with pytest.raises(SceneError) as refused:
        _run(BESIDE_A_LATCH)
    message = str(refused.value)
    assert "beams.gim2.start.hinge.limits" in message and "latches or cables" in message


def test_the_adjoint_still_refuses_it():
    """Guard: the discrete adjoint does not transpose a rest on a model with rigid links."""
    data = yaml.safe_load(REST)
    data["solve"]["sensitivity_method"] = "adjoint"
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(data))
    assert "beams.gim2.start.hinge.limits" in str(refused.value) and "rigid links" in str(refused.value)
