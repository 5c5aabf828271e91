"""A joint that comes to rest on its rigid stop is locked there (latdyn/timeloop/events.py
settle_on_stops) until its reaction would pull it off the stop (release_from_stops): its torque probe
and ``joint_peaks`` while it rests are the reaction of the locked model, exact — static, the load's
moment about the joint's axis — planar and 3D, and it leaves the stop when a load reverses that
reaction. (Before, the joint was projected back onto the stop at every step and its probe was the
residual with its own acceleration zeroed while the other joints kept the free step's accelerations:
27.96 N·m for the planar arm below, whose static reaction is 14.46 N·m; a warning said so.)"""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.optimize import brentq

import latdyn

from cli_runs import latdyn_run, probe_columns, summary_of

G = 9.81
#: upper link (rigid) from the pivot to the elbow body, whose hinge has the stops; lower link (rigid)
#: from the elbow to the hand body on a critically damped elbow spring; the links' sections carry
#: mass (rhoA 0.2, at their midpoints). Released at rest, the arm falls onto its lower stop.
ARM = """
gravity: [0, -9.81, 0]
sections:
  link: {{EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.2}}
bodies:
  pivot: {{at: [0, 0, 0], fixed: true}}
  elbow: {{at: [0.6, 0, 0], mass: 1.5, inertia: [0.01, 0.01, 0.01]}}
  hand: {{at: [1.0, 0.2, 0], mass: 0.5, inertia: [0.01, 0.01, 0.01]}}
beams:
  upper: {{from: pivot, to: elbow, section: link, rigid: true,
          start: {{hinge: {{axis: [0, 0, 1], limits: [-0.3, 0.5]{torque}}}}}}}
  lower: {{from: elbow, to: hand, section: link, rigid: true,
          start: {{hinge: {{axis: [0, 0, 1], stiffness: 50.0, damping: 4.5}}}}}}
solve: {{t_end: {t_end}, dt: 0.005}}
output:
  probes:
    R: {{hinge: upper.start, quantity: torque}}
    angle: {{hinge: upper.start, quantity: angle}}
    elbow_angle: {{hinge: lower.start, quantity: angle}}
    ex: {{point: elbow, quantity: position, component: x}}
    hx: {{point: hand, quantity: position, component: x}}
"""
MASS = {"elbow": 1.5, "hand": 0.5, "link": 0.2}


def planar_static_reaction(ex: float, hx: float) -> float:
    """The torque about z at the pivot that holds the arm still: Σ m_i g x_i over the bodies and the links'
    midpoints (the links' masses ρA ℓ, lengths fixed: 0.6 and |(0.4, 0.2)|)."""
    upper, lower = 0.2 * 0.6, 0.2 * float(np.hypot(0.4, 0.2))
    return G * (MASS["elbow"] * ex + MASS["hand"] * hx + upper * ex / 2 + lower * (ex + hx) / 2)


def planar_elbow_angle() -> float:
    """The elbow's static angle with the upper link on its stop at −0.3: k φ equals the moment of the hand
    and the lower link's weight about the elbow, −g (m_h + m_l/2) L₂ cos(−0.3 + α₀ + φ)."""
    L2, alpha0 = float(np.hypot(0.4, 0.2)), float(np.arctan2(0.2, 0.4))
    weight = G * (MASS["hand"] + MASS["link"] * L2 / 2) * L2
    return brentq(lambda phi: 50.0 * phi + weight * np.cos(-0.3 + alpha0 + phi), -1.5, 1.5, xtol=1e-15)


def test_arm_resting_on_its_stop_reports_the_static_reaction_cli(tmp_path):
    """Planar, through the CLI: the arm falls onto its stop (one impact) and rests there; at the end (the
    elbow settled) the elbow's angle is the static one (measured 1.6e-16 rad off) and the stop's
    reaction is the weight's moment about the pivot from the recorded positions (measured 1.6e-15
    relative; main reported 27.96 for 14.46), and no warning; the energy balance error 5e-5 (main: 0.023,
    flagged)."""
    completed, out = latdyn_run(tmp_path, ARM.format(torque="", t_end=2.0), quiet=True)
    assert completed.returncode == 0, completed.stderr
    probes, summary = probe_columns(out), summary_of(out)
    assert [(e["joint"], e["kind"]) for e in summary["events"]] == [("upper.start", "stop")]
    assert not summary.get("warnings")
    assert summary["energy_balance_error"] < 1e-3
    assert probes["angle"][-1] == -0.3  # held exactly on the stop
    assert probes["elbow_angle"][-1] == pytest.approx(planar_elbow_angle(), abs=1e-10)
    expected = planar_static_reaction(probes["ex"][-1], probes["hx"][-1])
    assert expected > 14.0
    assert probes["R"][-1] == pytest.approx(expected, rel=1e-10)
    peak = summary["joint_peaks"]["upper.start"]
    assert peak["peak"] == pytest.approx(probes["R"].max(), rel=1e-12) and peak["peak"] >= expected


def test_arm_leaves_its_stop_when_the_load_reverses_the_reaction(tmp_path):
    """Planar, through the API: a torque 6 t at the pivot lifts the resting arm; while it rests the
    reaction is the weight's moment less the torque, R = R_static − 6 t (measured 7.5e-13 relative, the
    elbow settled from t = 1.7), and the joint is released at the end of the first step after R reaches 0
    (t* = R_static/6 = 2.41), from when its probe is its law, the torque 6 t, and it leaves the stop."""
    import yaml

    scene = latdyn.load_scene(yaml.safe_load(ARM.format(torque=', torque: "6*t"', t_end=2.8)))
    result = latdyn.run(scene, out_dir=str(tmp_path / "out"))
    t, R, angle = (np.asarray(result.t), np.asarray(result.probes["R"]), np.asarray(result.probes["angle"]))
    ex, hx = np.asarray(result.probes["ex"]), np.asarray(result.probes["hx"])
    at = int(np.argmin(np.abs(t - 1.7)))  # resting, the elbow settled
    static = planar_static_reaction(ex[at], hx[at])
    t_release = static / 6.0
    assert static > 14.0 and angle[at] == -0.3
    held = (t >= 1.7) & (t < t_release)
    assert held.sum() >= 30 and np.all(angle[held] == -0.3)
    assert np.abs(R[held] - (static - 6.0 * t[held])).max() <= 1e-9 * static
    # released at the end of the first step after R reached 0: that row still on the stop, its probe the law
    off = int(np.flatnonzero(t >= t_release)[0])
    assert t[off] - t_release < 0.005 and angle[off] == -0.3
    after = t >= t_release
    assert np.all(angle[off + 1:] > -0.3)
    free = after & (angle < 0.5)  # until it reaches the upper stop
    assert free.sum() >= 20 and np.abs(R[free] - 6.0 * t[free]).max() <= 1e-12 * 6.0 * t[-1]
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert not summary.get("warnings")


#: The arm in 3D: pivot off the origin, skew axes, gravity out of every coordinate plane.
ARM_3D = """
gravity: [-3.0, -9.0, 1.0]
sections:
  link: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.2}
bodies:
  pivot: {at: [0.1, 0.2, -0.1], fixed: true}
  elbow: {at: [0.6, 0.1, 0.3], mass: 1.5, inertia: [0.01, 0.02, 0.03]}
  hand: {at: [1.0, 0.4, 0.2], mass: 0.5, inertia: [0.01, 0.01, 0.01]}
beams:
  upper: {from: pivot, to: elbow, section: link, rigid: true,
          start: {hinge: {axis: [0.3, 0.8, 0.5], limits: [-0.25, 0.6]}}}
  lower: {from: elbow, to: hand, section: link, rigid: true,
          start: {hinge: {axis: [-0.2, 0.4, 1.0], stiffness: 50.0, damping: 4.5}}}
solve: {t_end: 2.0, dt: 0.005}
output:
  probes:
    R: {hinge: upper.start, quantity: torque}
    angle: {hinge: upper.start, quantity: angle}
    elbow_angle: {hinge: lower.start, quantity: angle}
    ex: {point: elbow, quantity: position, component: x}
    ey: {point: elbow, quantity: position, component: y}
    ez: {point: elbow, quantity: position, component: z}
    hx: {point: hand, quantity: position, component: x}
    hy: {point: hand, quantity: position, component: y}
    hz: {point: hand, quantity: position, component: z}
"""


def test_arm_resting_on_its_stop_in_3d_reports_the_static_reaction(tmp_path):
    """3D, through the API: at rest on the stop the reaction is −a·Σ (x_i − p) × m_i g over the bodies and
    the links' midpoints about the pivot p and the hinge's axis a (from the recorded positions; measured
    5.7e-13 relative), and the elbow's spring balances the weight of what it carries,
    k φ = a₂·Σ (x_i − x_elbow) × m_i g (measured 1.0e-11 relative: the elbow still settling)."""
    import yaml

    result = latdyn.run(latdyn.load_scene(yaml.safe_load(ARM_3D)), out_dir=str(tmp_path / "out"))
    p = {k: np.asarray(v) for k, v in result.probes.items()}
    assert p["angle"][-1] == -0.25  # held on the lower stop
    g = np.array([-3.0, -9.0, 1.0])
    pivot = np.array([0.1, 0.2, -0.1])
    elbow = np.array([p["ex"][-1], p["ey"][-1], p["ez"][-1]])
    hand = np.array([p["hx"][-1], p["hy"][-1], p["hz"][-1]])
    upper, lower = 0.2 * np.linalg.norm(elbow - pivot), 0.2 * np.linalg.norm(hand - elbow)
    masses = [(elbow, MASS["elbow"]), (hand, MASS["hand"]), ((pivot + elbow) / 2, upper), ((elbow + hand) / 2, lower)]
    a1 = np.array([0.3, 0.8, 0.5]) / np.linalg.norm([0.3, 0.8, 0.5])
    expected = -a1 @ sum(np.cross(x - pivot, m * g) for x, m in masses)
    assert abs(expected) > 1.0
    assert p["R"][-1] == pytest.approx(expected, rel=1e-10)
    # the elbow's axis turns with the upper link (at −0.25 about a₁ from the start): its spring torque
    # −k φ balances the moment of the hand and the lower link's weight about it
    from scipy.spatial.transform import Rotation

    a2 = Rotation.from_rotvec(-0.25 * a1).apply(np.array([-0.2, 0.4, 1.0]) / np.linalg.norm([-0.2, 0.4, 1.0]))
    moment = a2 @ sum(np.cross(x - elbow, m * g) for x, m in masses[1::2])
    assert 50.0 * p["elbow_angle"][-1] == pytest.approx(moment, rel=1e-9)
