"""Impacts on hinge stops and latches next to directions without inertia (latdyn/timeloop/impulse.py).

An impact is an impulsive velocity jump that only the directions with inertia take; the
directions without inertia (massless beams) stay in their statics through it. The jump was the
projection weighted by M + dt²K, in which a massless beam end took part of the jump with weight
dt²K against the body's inertia: a body bounced off a stop behind a massless beam came out with
θ(1.5) = 0.41, 0.50, 0.50 at dt = 0.01, 0.005, 0.0025 against 0.361 in closed form, and a latch
behind massless beams left the latched bodies turning.

References in closed form: a joint body on a hinge spring bounced off a stop (Newton's impact law,
restitution e) about the axis of a massless shaft (its twist) and across a massless arm (its
bending) in a scene turned out of the coordinate planes; two bodies on massless shafts latched together
(conservation of angular momentum); the energy an impact removes, (1 − e²) times the kinetic
energy of the impacting motion.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns

STEPS = (0.01, 0.005, 0.0025)
K, REST, STOP, E = 1.0, 1.0, 0.5, 0.5  # hinge spring, its rest angle, the stop, the restitution


def bounce(t: float) -> float:
    """θ(t) of a body of inertia 1 on the hinge spring (k = 1, rest angle 1) from rest at θ = 0 into
    the stop at 0.5 at t₁ = π/3, rebounding with restitution e: θ = 1 − cos t to t₁, then
    θ = 1 − ½ cos s − e sin(π/3) sin s, s = t − t₁ (the shafts and arms below are stiff: their
    compliance changes θ by ~1e-8)."""
    t1 = np.pi / 3
    if t <= t1:
        return REST - np.cos(t)
    s = t - t1
    return REST - (REST - STOP) * np.cos(s) - E * np.sin(t1) * np.sin(s)


TWIST = """
sections: {{massless: {{EA: 1.0e10, EIy: 1.0e8, EIz: 1.0e8, GJ: 1.0e8, rhoA: 0.0}}}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  wheel: {{at: [1, 0, 0], mass: 1.0, inertia: [1.0, 1.0, 1.0]}}
beams:
  arm: {{from: base, to: wheel, section: massless,
        end: {{hinge: {{axis: [1, 0, 0], stiffness: 1.0, rest_angle: 1.0, limits: [-10, 0.5], restitution: 0.5}}}}}}
solve: {{t_end: 1.5, dt: {dt}}}
output: {{every: 1.5, probes: {{angle: {{hinge: arm.end, quantity: angle}}}}}}
"""


@pytest.mark.parametrize("rho_a", [0.0, 1.0])
def test_a_stop_behind_a_massless_beam_converges_to_the_closed_form(rho_a):
    """The body spins about the axis of a shaft into the stop: the twist of the shaft has no
    inertia, massless (ρA = 0) or an Euler–Bernoulli beam without rotary inertia (ρA = 1).
    θ(1.5) converges to the closed form at order two, as the rigid link does (errors 0.05–0.14
    for the massless shaft of GJ = 1e5 that did not fall with dt before, and 5.9e-5, 2.3e-4,
    9.1e-4 here, growing as dt falls: the shaft's twist took part of the jump with weight dt²K)."""
    scene = TWIST.replace("rhoA: 0.0", f"rhoA: {rho_a}")
    angles = np.array([latdyn.run(yaml.safe_load(scene.format(dt=dt))).probes["angle"][-1] for dt in STEPS])
    errors = np.abs(angles - bounce(1.5))
    assert errors[0] / errors[1] > 3.0 and errors[1] / errors[2] > 3.0
    assert errors[2] < 3e-7


def run_cli(text: str, tmp_path: Path) -> dict[str, np.ndarray]:
    """A scene typed as YAML, run through the CLI; its probes.csv as columns."""
    done, out = latdyn_run(tmp_path, text, timeout=120)
    assert done.returncode == 0, done.stderr
    return probe_columns(out)


def test_a_stop_behind_a_massless_beam_removes_one_minus_e_squared_of_the_kinetic_energy(tmp_path):
    """Through the CLI: the impact keeps e² of the body's kinetic energy and records (1 − e²) of it
    as dissipated energy (the massless shaft holds none)."""
    text = TWIST.format(dt=0.005).replace(
        "output: {every: 1.5, probes: {angle: {hinge: arm.end, quantity: angle}}}",
        "output: {paraview_every: 0, probes: {kinetic: {energy: kinetic}, dissipated: {energy: dissipated}}}")
    probes = run_cli(text, tmp_path)
    hit = int(np.argmax(probes["dissipated"] > 0))
    before = probes["kinetic"][hit] + probes["dissipated"][hit]
    assert probes["dissipated"][hit] == pytest.approx((1 - E**2) * before, rel=1e-6)
    assert before == pytest.approx(0.5 * (1 - 0.25), rel=1e-4)  # ½ I θ̇², θ̇² = 1 − (½)² at the stop


#: the same body across a massless arm (the hinge bends it), the scene turned out of the
#: coordinate planes: arm along (2, 1, 2)/3, hinge axis (1, −2, 0)/√5
BENT = """
sections: {{massless: {{EA: 1.0e10, EIy: 1.0e8, EIz: 1.0e8, GJ: 1.0e8, rhoA: 0.0}}}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  wheel: {{at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 1.0, inertia: [1.0, 1.0, 1.0]}}
beams:
  arm: {{from: base, to: wheel, section: massless, elements: 2,
        end: {{hinge: {{axis: [1, -2, 0], stiffness: 1.0, rest_angle: 1.0, limits: [-10, 0.5], restitution: 0.5}}}}}}
solve: {{t_end: 1.5, dt: {dt}}}
output:
  paraview_every: 0
  probes:
    angle: {{hinge: arm.end, quantity: angle}}
    kinetic: {{energy: kinetic}}
    dissipated: {{energy: dissipated}}
"""


def test_a_stop_across_a_massless_arm_in_3d_converges_to_the_closed_form():
    """Across the arm: the hinge's moment bends it, and through the arm's statics the body's
    translation would turn the arm's end (1.5 rad per m): that statics cannot pass an impulse
    (it would take an impulsive bending), the arm is rigid through the jump and the body bounces
    as on a rigid link. θ(1.5) converges to the closed form at order two (errors 5.9e-5, 2.3e-4,
    9.1e-4 before, growing as dt fell, 5.6e-3, 2.2e-2, 7.6e-2 with EI = 1e6: the arm took part of
    the jump with weight dt²K; with the massless statics alone the jump made the body ring on
    the arm and the run ended unbounded)."""
    angles = np.array([latdyn.run(yaml.safe_load(BENT.format(dt=dt))).probes["angle"][-1] for dt in STEPS])
    errors = np.abs(angles - bounce(1.5))
    assert errors[0] / errors[1] > 3.0 and errors[1] / errors[2] > 3.0
    assert errors[2] < 3e-7


def test_a_stop_across_a_massless_arm_removes_one_minus_e_squared_of_the_kinetic_energy(tmp_path):
    """Through the CLI: the impact keeps e² of the body's kinetic energy ½ θ̇² = ½ (1 − ¼) and
    records (1 − e²) of it as dissipated energy."""
    probes = run_cli(BENT.format(dt=0.005), tmp_path)
    hit = int(np.argmax(probes["dissipated"] > 0))
    before = 0.5 * (1 - 0.25)
    assert probes["kinetic"][hit] == pytest.approx(E**2 * before, rel=1e-6)
    assert probes["dissipated"][hit] == pytest.approx((1 - E**2) * before, rel=1e-6)
    assert probes["angle"].max() <= STOP + 1e-7


#: two joint bodies on one axis, on massless shafts: ``a`` on a free hinge at the base, ``b`` on a
#: hinge at the end of the shaft from ``a``; a unit torque in that hinge drives them apart
#: (angular momentum 0) until it latches at 0.3
SHAFTS = """
sections: {{massless: {{EA: 1.0e10, EIy: 1.0e8, EIz: 1.0e8, GJ: 1.0e8, rhoA: 0.0}}}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  a: {{at: [1, 0, 0], mass: 1.0, inertia: [1.0, 1.0, 1.0]}}
  b: {{at: [2, 0, 0], mass: 1.0, inertia: [2.0, 1.0, 1.0]}}
beams:
  first: {{from: base, to: a, section: massless, start: {{hinge: {{axis: [1, 0, 0]}}}}}}
  second: {{from: a, to: b, section: massless, end: {{hinge: {{axis: [1, 0, 0], torque: 1.0, lock_at: 0.3}}}}}}
solve: {{t_end: 1.0, dt: {dt}}}
output:
  paraview_every: 0
  probes:
    turn: {{hinge: first.start, quantity: angle}}
    rate: {{hinge: first.start, quantity: rate}}
    kinetic: {{energy: kinetic}}
    dissipated: {{energy: dissipated}}
"""


def test_a_latch_between_bodies_on_massless_shafts_stops_them_both():
    """Relative acceleration τ (1/I_a + 1/I_b) = 1.5: the hinge latches at t_l = (0.6/1.5)^½, with
    a turned by τ t_l² / (2 I_a) = 0.2; the latch joins a and b with angular momentum 0: both
    stop, a stays turned by 0.2 and the latch removes all the kinetic energy (before, the massless shaft
    took part of the jump and both went on turning)."""
    p = latdyn.run(yaml.safe_load(SHAFTS.format(dt=0.005))).probes
    t_l = np.sqrt(0.4)
    kinetic_in = 0.5 * (1.0 * (t_l / 1.0) ** 2 + 2.0 * (t_l / 2.0) ** 2)  # ½ I ω², ω = τ t_l / I
    assert abs(p["turn"][-1]) == pytest.approx(0.2, abs=1e-5)
    assert np.abs(p["rate"][-20:]).max() < 1e-5  # 0.63 before the latch
    assert p["kinetic"][-1] < 1e-8 * kinetic_in
    assert p["dissipated"][-1] == pytest.approx(kinetic_in, rel=1e-3)
