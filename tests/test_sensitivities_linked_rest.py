"""A hinge that comes to rest on its rigid stop in a model with rigid links: refused (latdyn/analyses/
transient_sensitivities.py ``_refuse_a_linked_rest``; docs/parameters.md, "A hinge resting on its stop").

restlinks (the fifteenth session) took it where no guide, latch, cable, controller or geometry parameter is in the
model, checked on REST below (a 3D gimbal whose inner ring lands on its stop at −0.1 rad with restitution 0 at
t = 0.2791 s, rests and is released at 0.38 s: within 1.3e-8 of Richardson-extrapolated central differences of whole
runs by k1, m, EI, with the release's and the landing's two restarts each). benchmarks/fuzz_lifted.py found it wrong
on another gimbal (seed 1 case 5, FUZZ_RELEASE below: landing at 0.1066 s and leaving, landing again at 0.1494 s,
resting three steps, released at the step's end at 0.16 s): by m, the tip's x 3.0e-3 of its largest derivative off
Richardson differences (h = 1e-4 m against h/2 within 6e-6) from the second step of the rest on (2.6e-10 before), the
ring's angle 4.6e-2 after the release (k1: 3.7e-2). The cause is not found; three fuzz_lifted cases resting to their
end agreed within 1e-6, which the package cannot tell from this one. Refused until it is."""
from __future__ import annotations

import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_rigid_links import GIMBAL

#: the gimbal of tests/test_sensitivities_rigid_links.py as typed, the inner ring's hinge between rigid stops at
#: −0.1 and 1.0 rad with restitution 0: it lands on −0.1, rests, and is released before the run's end
REST = (GIMBAL.replace("carrying a flexible boom\n", "carrying a flexible boom, the inner ring resting on its stop\n")
        .replace('damping: "c2"}}}', 'damping: "c2", limits: [-0.1, 1.0],\n                         restitution: 0.0}}}')
        .replace("t_end: 0.3, sensitivities: [k1, m, P, EI, rho]", "t_end: 0.45, sensitivities: [k1, m, EI]"))
assert "resting on its stop" in REST and "restitution: 0.0}}}" in REST and "t_end: 0.45" in REST

#: fuzz_lifted seed 1 case 5: the inner ring of a skew gimbal lands on its stop at −0.1359 rad (t = 0.1066 s) and
#: leaves it, lands again at 0.1494 s, rests and is released at the step's end at 0.16 s
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

#: FUZZ_RELEASE ended during its rest (on 7fbef8b its end row, resting, 1.7e-2 of the tip's largest off Richardson)
FUZZ_RESTING = FUZZ_RELEASE.replace("t_end: 0.4,", "t_end: 0.16,")
assert "t_end: 0.16," in FUZZ_RESTING


@pytest.mark.parametrize("text", ["REST", "FUZZ_RELEASE", "FUZZ_RESTING"])
def test_a_rest_on_rigid_links_is_refused_naming_the_stop(text):
    """Named: the stop's limits, the time it comes to rest, rigid links (SceneError). Taken on 7fbef8b (REST right,
    FUZZ_RELEASE and FUZZ_RESTING wrong)."""
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(globals()[text])))
    message = str(refused.value)
    assert "beams.gim2.start.hinge.limits" in message and "a model with rigid links" in message, message


def test_through_the_cli_exit_2_without_a_traceback(tmp_path):
    run, _ = latdyn_run(tmp_path, FUZZ_RESTING)
    assert run.returncode == 2 and "limits" in run.stderr and "Traceback" not in run.stderr


def test_the_adjoint_still_refuses_it():
    """Guard: the discrete adjoint does not transpose a rest on a model with rigid links."""
    data = yaml.safe_load(REST)
    data["solve"]["sensitivity_method"] = "adjoint"
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(data))
    assert "beams.gim2.start.hinge.limits" in str(refused.value) and "rigid links" in str(refused.value)
