"""Impacts on hinge stops and latches next to directions without inertia (latdyn/timeloop/impulse.py).

An impact is an impulsive velocity jump that only the directions with inertia take; the
directions without inertia (massless beams) stay in their statics through it. The jump was the
projection weighted by M + dt²K, in which a massless beam end took part of the jump with weight
dt²K against the body's inertia: a body bounced off a stop behind a massless beam came out with
θ(1.5) = 0.41, 0.50, 0.50 at dt = 0.01, 0.005, 0.0025 against 0.361 in closed form, and a latch
behind massless beams left the latched bodies turning.

References in closed form: a joint body on a hinge spring bounced off a stop (Newton's impact law,
restitution e) about the axis of a massless shaft; two bodies on massless shafts latched together
(conservation of angular momentum); the energy an impact removes, (1 − e²) times the kinetic
energy of the impacting motion.
"""
from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn

STEPS = (0.01, 0.005, 0.0025)
K, REST, STOP, E = 1.0, 1.0, 0.5, 0.5  # hinge spring, its rest angle, the stop, the restitution


def bounce(t: float, compliance: float = 0.0) -> float:
    """θ(t) of a body of inertia 1 on the hinge spring (k = 1, rest angle 1), from rest into the stop
    at 0.5 with restitution e. Behind a shaft of torsional compliance c = kL/GJ the body's turn is
    φ = θ − c (1 − θ) = (1 + c) θ − c, so I (1 + c) θ̈ = k (1 − θ), and the shaft, without
    inertia, twists at once: θ(0) = c / (1 + c). Then θ = 1 − A cos ωt,
    A = 1 − θ(0), ω = (1 + c)^−½, to the stop at t₁ (A cos ωt₁ = ½), and after it
    θ = 1 − ½ cos ωs − e (A sin ωt₁) sin ωs, s = t − t₁ (the rigid shaft: c = 0)."""
    omega = 1.0 / np.sqrt(1.0 + compliance)
    amplitude = 1.0 - compliance / (1.0 + compliance)
    t1 = np.arccos((REST - STOP) / amplitude) / omega
    if t <= t1:
        return REST - amplitude * np.cos(omega * t)
    s = t - t1
    return REST - (REST - STOP) * np.cos(omega * s) - E * amplitude * np.sin(omega * t1) * np.sin(omega * s)


TWIST = """
sections: {{massless: {{EA: 1.0e7, EIy: 1.0e5, EIz: 1.0e5, GJ: 1.0e5, rhoA: 0.0}}}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  wheel: {{at: [1, 0, 0], mass: 1.0, inertia: [1.0, 1.0, 1.0]}}
beams:
  arm: {{from: base, to: wheel, section: massless,
        end: {{hinge: {{axis: [1, 0, 0], stiffness: 1.0, rest_angle: 1.0, limits: [-10, 0.5], restitution: 0.5}}}}}}
solve: {{t_end: 1.5, dt: {dt}}}
output: {{every: 1.5, probes: {{angle: {{hinge: arm.end, quantity: angle}}}}}}
"""


def test_a_stop_behind_a_massless_beam_converges_to_the_closed_form():
    """The body spins about the axis of a massless beam (its twist, GJ = 1e5: c = 1e-5) into the
    stop: θ(1.5) converges to the closed form at order two (errors 0.05–0.14 that did not fall
    with dt before)."""
    exact = bounce(1.5, compliance=K * 1.0 / 1.0e5)
    angles = np.array([latdyn.run(yaml.safe_load(TWIST.format(dt=dt))).probes["angle"][-1] for dt in STEPS])
    errors = np.abs(angles - exact)
    assert errors[0] / errors[1] > 3.0 and errors[1] / errors[2] > 3.0
    assert errors[2] < 1e-6
    assert abs(angles[2] - bounce(1.5)) < 1e-5  # the rigid shaft's answer, to the beam's compliance


def run_cli(text: str, tmp_path: Path) -> dict[str, np.ndarray]:
    """A scene typed as YAML, run through the CLI; its probes.csv as columns."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(text)
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out)],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    with open(out / "probes.csv") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def test_a_stop_behind_a_massless_beam_removes_one_minus_e_squared_of_the_kinetic_energy(tmp_path):
    """Through the CLI: the impact keeps e² of the body's kinetic energy and records (1 − e²) of it
    as dissipated energy (the massless shaft holds none)."""
    text = TWIST.format(dt=0.005).replace(
        "output: {every: 1.5, probes: {angle: {hinge: arm.end, quantity: angle}}}",
        "output: {paraview_every: 0, probes: {kinetic: {energy: kinetic}, dissipated: {energy: dissipated}}}")
    probes = run_cli(text, tmp_path)
    hit = int(np.argmax(probes["dissipated"] > 0))
    before = probes["kinetic"][hit] + probes["dissipated"][hit]
    assert probes["dissipated"][hit] == pytest.approx((1 - E**2) * before, rel=1e-9)
    assert before == pytest.approx(0.5 * (1 - 0.25), rel=1e-4)  # ½ I θ̇², θ̇² = 1 − (½)² at the stop


#: two joint bodies on one axis, on massless shafts: ``a`` on a free hinge at the base, ``b`` on a
#: hinge at the end of the shaft from ``a``; a unit torque in that hinge drives them apart
#: (angular momentum 0) until it latches at 0.3
SHAFTS = """
sections: {{massless: {{EA: 1.0e7, EIy: 1.0e5, EIz: 1.0e5, GJ: 1.0e5, rhoA: 0.0}}}}
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
    assert abs(p["turn"][-1]) == pytest.approx(0.2, abs=1e-4)
    # what is left is the vibration of the two bodies on the shaft between them, released from the
    # torque's twist τL/GJ = 1e-5 by the latch (ω ≈ 390 rad/s): rates of 2e-3 (0.63 before the latch)
    assert np.abs(p["rate"][-20:]).max() < 5e-3
    assert p["kinetic"][-1] < 1e-4 * kinetic_in
    assert p["dissipated"][-1] == pytest.approx(kinetic_in, rel=1e-3)
