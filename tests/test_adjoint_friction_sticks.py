"""The discrete adjoint through a joint that friction sticks (issue 34; latdyn/analyses/adjoint_sensitivities.py
``_friction_event_transposed``, docs/parameters.md "The discrete adjoint"): the forward method's stick (a stop's impulse
with restitution 0, the held angle's δθ = δq[θ_j] before it, a stop's restart with K's column of the held angle in its
∂r/∂p and weight), the steps while stuck (δθ held, K's column times δθ in ∂r/∂p) and the release (δq[θ_j] = δθ_j, a
stop's restart) transposed: the held angles' adjoints θ̄ run back beside the bars.

References: the forward method on the same scene (both are the exact derivative of the same discrete run: ≤ 1e-10 of
each output's largest derivative, every probe's end, max and min; ``event_sensitivities`` equal: a stick's time does
not move, no landing) and Richardson-extrapolated central differences of whole runs (the parameter moved, the step
fixed, Newton's tolerance 1e-12). Scenes, all 3D: a flexible arm slewing on a skew friction hinge under a sinusoidal
torque that sticks and slips again, the same arm braked hard (four sticks and three releases, one at the end of a step
cut after Newton failed) and a gimbal ring on a friction hinge, stuck from t = 0 and sticking and slipping five times
while the arm it carries swings on a skew spring hinge. Each was refused on 40bf44a when its joint stuck (exit 2,
"the discrete adjoint differentiates friction while the joints slip, not a stick or a release yet")."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses import adjoint_in_loop
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_adjoint_geometry import SLEWING, SLEWING_STOPS, _richardson_error
from tests.test_sensitivities_adjoint import _disagreement

#: tests/test_adjoint_geometry.py's slewing arm (a skew friction hinge, spun at t = 0) driven by τ = A sin 6t and braked
#: harder: it slips, sticks at t = 0.544 and slips again at t = 0.6 (measured)
SLEW_SINE = (SLEWING
             .replace("title: a flexible arm slewing on a friction hinge at a fixed base, spun at t = 0 and slowed by the "
                      "friction", "title: a flexible arm slewing on a skew friction hinge under a sinusoidal torque; it "
                      "sticks and slips again")
             .replace("parameters: {Fc: 0.3, Fs: 0.4, cv: 0.05, EI: 200.0, m: 0.5, W: 2.0}",
                      "parameters: {Fc: 1.5, Fs: 2.0, cv: 0.05, EI: 200.0, m: 0.5, A: 3.0, W: 1.0}")
             .replace("start: {hinge: {axis: [0.1, -0.2, 1], friction:",
                      "start: {hinge: {axis: [0.1, -0.2, 1], torque: \"A*sin(6*t)\", friction:")
             .replace("t_end: 0.3,", "t_end: 1.0,")
             .replace("sensitivities: [Fc, cv, EI, m, W]", "sensitivities: [Fc, Fs, cv, EI, m, A, W]")
             .replace("    torque: {hinge: arm.start, quantity: torque}\n",
                      "    tip_v: {point: tip, quantity: velocity, component: y}\n"))
assert SLEW_SINE.count("A*sin(6*t)") == 1 and "t_end: 1.0," in SLEW_SINE and "tip_v" in SLEW_SINE

#: a gimbal ring on a friction hinge about z (driven by 0.6 sin 4t) carrying a flexible arm on a spring hinge about
#: (1, 1, 0.3) with friction too, driven by A sin 5t, a load F on the tip: both stuck from t = 0; the arm released at
#: 0.025, the ring at 0.06; the ring sticks at 0.385 while the arm swings, the arm sticks at 0.397 while the ring is
#: stuck (its jump weighed with the ring's held angle), the arm slips at 0.41, the ring at 0.415, and the ring sticks
#: and slips six times more from 0.604 to 0.76 (measured)
GIMBAL = """
title: a gimbal ring on a friction hinge carrying a flexible arm on a skew spring hinge with friction; each sticks and slips
parameters: {Fc: 0.8, Fs: 1.0, cv: 0.02, EI: 150.0, k: 4.0, A: 1.5, m: 0.4, F: -0.2}
gravity: [0, 0, -9.81]
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "1.2*EI", GJ: "0.8*EI", rhoA: 0.4, rhoIy: 0.01, rhoIz: 0.012}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  ring: {at: [0, 0, 0.3], mass: 0.8, inertia: [0.05, 0.05, 0.08]}
  tip: {at: [0.8, 0.3, 0.2], mass: "m", com: [0.03, 0, 0], inertia: [0.01, 0.012, 0.014]}
beams:
  post:
    from: base
    to: ring
    section: s
    elements: 1
    end: {hinge: {axis: [0, 0, 1], torque: "0.6*sin(4*t)", friction: {coulomb: "Fc", static: "Fs", viscous: "cv"}}}
  arm:
    from: ring
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [1, 1, 0.3], stiffness: "k", damping: 0.05, torque: "A*sin(5*t)",
                    friction: {coulomb: 0.3, static: 0.5, viscous: 0.01}}}
loads:
  - {at: tip, force: [0, "F", "-0.5*F"]}
solve: {analysis: transient, sensitivity_method: adjoint, dt: 0.005, t_end: 0.8, tol: 1.0e-12,
        sensitivities: [Fc, cv, EI, k, A, m, F]}
output:
  every: 0.01
  probes:
    ring: {hinge: post.end, quantity: angle}
    ring_rate: {hinge: post.end, quantity: rate}
    swing: {hinge: arm.start, quantity: angle}
    swing_rate: {hinge: arm.start, quantity: rate}
    tip_y: {point: tip, quantity: position, component: y}
    tip_z: {point: tip, quantity: displacement, component: z}
    tip_in_ring: {point: tip, quantity: position, frame: ring, component: x}
"""

#: tests/test_adjoint_geometry.py's arm braked ten times harder, without its torque probe: it sticks at t = 0.284 (the
#: end of a step cut after Newton failed), 0.333, 0.406 and 0.446 and slips at 0.3, 0.395 and 0.43 (measured)
BRAKED = SLEWING_STOPS.replace("    torque: {hinge: arm.start, quantity: torque}\n", "")
assert BRAKED != SLEWING_STOPS


def _run(text: str, method: str = "adjoint"):
    data = yaml.safe_load(text)
    data["solve"]["sensitivity_method"] = method
    return latdyn.run(latdyn.load_scene(data))


def _equal_to_the_forward_method(text: str, adjoint) -> float:
    forward = _run(text, "forward")
    assert forward.summary.get("event_sensitivities", []) == adjoint.summary.get("event_sensitivities", [])
    return _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"])


@pytest.fixture(scope="module")
def slewing():
    return _run(SLEW_SINE)


def test_a_slewing_arm_that_sticks_and_slips_again_equals_the_forward_method(slewing, tmp_path):
    """The arm's hinge slips, sticks at t = 0.544 and slips again at 0.6: the adjoint by the friction's levels, the
    arm's EI, the tip's mass, the torque's amplitude and the initial spin equals the forward method's to 1.7e-12 of each
    output's largest derivative (measured); the CLI's summary.json is the API's to the bit."""
    rate = np.asarray(slewing.probes["rate"])
    stuck = np.flatnonzero(rate == 0.0)
    assert len(stuck) and stuck[-1] + 1 < len(rate) and np.all(rate[stuck[-1] + 1:] != 0.0)   # stuck, then slipping
    assert _equal_to_the_forward_method(SLEW_SINE, slewing) <= 1e-10
    completed, out = latdyn_run(tmp_path, SLEW_SINE, quiet=True)
    assert completed.returncode == 0, completed.stderr
    assert json.loads((out / "summary.json").read_text())["probe_sensitivities"] == \
        slewing.summary["probe_sensitivities"]


@pytest.mark.parametrize("name, step", [("A", 1e-4), ("Fc", 1e-4)])
def test_the_slewing_arm_agrees_with_richardson_central_differences(slewing, name, step):
    """Each probe's end by the torque's amplitude and the Coulomb level, through the stick and the slip (runs asking
    the forward method's sensitivity by the one parameter, so that they step as the adjoint's run does)."""
    assert _richardson_error(slewing.summary["probe_sensitivities"], SLEW_SINE, name, step, landed=True) <= 1e-6


def test_a_gimbal_ring_sticking_while_the_arm_swings_equals_the_forward_method(monkeypatch):
    """The ring sticks while the arm swings and the arm sticks while the ring is stuck: the adjoint equals the forward
    method's to 4.1e-13 (measured; with the held ring's terms of the arm's jump left out 2.2e-7, of the restarts'
    weights 3.4e-4, of the stuck steps 23), and its forward pass's loop of steps and native reverse steps off give the
    same bits."""
    adjoint = _run(GIMBAL)
    ring, swing = (np.asarray(adjoint.probes[name]) for name in ("ring_rate", "swing_rate"))
    assert np.any((ring == 0.0) & (swing != 0.0)) and np.any((ring == 0.0) & (swing == 0.0) & (adjoint.t > 0.3))
    assert _equal_to_the_forward_method(GIMBAL, adjoint) <= 1e-10
    monkeypatch.setattr(adjoint_in_loop, "ADJOINT_IN_LOOP", False)
    monkeypatch.setattr(adjoint_in_loop, "REVERSE_NATIVE", False)
    assert _run(GIMBAL).summary["probe_sensitivities"] == adjoint.summary["probe_sensitivities"]


def test_a_braked_arm_sticking_four_times_equals_the_forward_method():
    """The braked arm sticks four times (the first at the end of a step cut after Newton failed) and slips three
    times: 2.7e-13 off the forward method (measured)."""
    assert _equal_to_the_forward_method(BRAKED, _run(BRAKED)) <= 1e-10


#: a block on a skew guide held by static friction from t = 0 (gravity's pull along it 3.27 N, F_s = 5 N) until a
#: growing push breaks it away
GUIDE = """
title: a block on a skew guide held by static friction, pushed off by a growing force
parameters: {Fc: 1.0, Fs: 5.0, P: 3.0}
gravity: [0, 0, -9.81]
bodies:
  block: {at: [0, 0, 0], mass: 1.0, inertia: [0.01, 0.01, 0.01],
          guide: {axis: [1, 1, -0.5], friction: {coulomb: "Fc", static: "Fs"}}}
loads:
  - {at: block, force: ["P*t", 0, 0]}
solve: {analysis: transient, sensitivity_method: adjoint, dt: 0.01, t_end: 1.0, sensitivities: [Fc, P]}
output:
  probes:
    x: {point: block, quantity: position, component: x}
"""


def test_a_stick_beside_geometry_parameters_or_on_a_guide_stays_refused():
    """Geometry parameters beside a stick (the held angle's terms of the start's move are not formed): the slewing arm
    whose tip's x names a parameter is refused when it sticks at t = 0.544, naming the hinge's friction. A guide's
    slider held by friction from t = 0, nothing else free: the adjoint refuses it at t = 0 naming the guide's friction
    and why (nothing else free; the forward method differentiates the held block and refuses its release:
    tests/test_read_mends.py)."""
    geometry = (SLEW_SINE.replace("tip: {at: [1.0, 0.2, 0.1]", 'tip: {at: ["L", 0.2, 0.1]')
                .replace("A: 3.0, W: 1.0}", "A: 3.0, W: 1.0, L: 1.0}")
                .replace("sensitivities: [Fc, Fs, cv, EI, m, A, W]", "sensitivities: [Fc, L]"))
    assert geometry.count('"L"') == 1
    with pytest.raises(SceneError) as raised:
        _run(geometry)
    assert raised.value.key == "beams.arm.start.hinge.friction" and "beside geometry parameters" in str(raised.value)
    with pytest.raises(SceneError) as raised:
        _run(GUIDE)
    assert raised.value.key == "bodies.block.guide.friction" and "nothing else free" in str(raised.value)
