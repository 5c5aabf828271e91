"""Geometry parameters (numbers that place the structure) in the sensitivities' loop of steps in C
(latdyn/analyses/sensitivities_in_loop.py, csrc/geometry_forces.c; issue 34 item 2): a 3D lattice by a joint's
coordinates, a cantilever by its length, the 3D knee by its joint, offset, free end and hinge axis take every smooth
step in the loop, and the sensitivities are the per-step Python path's (the private switch ``SENSITIVITIES_IN_LOOP``
off) to the bit, through the API and through ``latdyn run``, loads at a moved offset among them; between events
too. Shifts on a part that turns (csrc/turning_shifts.c, which the Python path calls too): the gimbal's ring offset (a
rigid link's length and direction, its joint body's block moved), a guide's origin on a turning arm's tip, and the
inner ring's hinge point on the turning outer ring through its latch, the ring offset beside a PD and a PI of joints'
angles and rates through its latch (refused by the loop on bd00230b: every step from Python)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_geometry_sensitivities_link_geometry import GUIDE_ORIGIN
from tests.test_geometry_sensitivities_link_length import RING
from tests.test_geometry_sensitivities_turning_events import INNER_LATCH, PI_LATCH, RING_PD_LATCH
from tests.test_sensitivities_geometry import (CONTACT_BY_PLACE, KNEE_3D, KNEE_SPINNING, LATCH_BY_LENGTH, PLANAR_SWING,
                                                STOP_BY_PLACE, _hinge_axis_scene, _loaded_at_the_offset)

#: a 3D lattice: a pyramid of four legs from fixed feet to a joint (a body with mass) and a ring of four beams between
#: the feet' neighbours' mid-height joints; the top joint's three coordinates the parameters, a load in t at the top
LATTICE = """
title: 3D lattice pyramid, its top joint placed by X, Y, H
parameters: {X: 0.1, Y: -0.05, H: 1.2}
gravity: [0, 0, -9.81]
sections:
  s: {EA: 2.0e4, EIy: 8.0, EIz: 12.0, GJ: 6.0, rhoA: 0.4, rhoIy: 0.002, rhoIz: 0.003}
bodies:
  f1: {at: [1, 0, 0], fixed: true}
  f2: {at: [0, 1, 0], fixed: true}
  f3: {at: [-1, 0, 0], fixed: true}
  f4: {at: [0, -1, 0], fixed: true}
  top: {at: ["X", "Y", "H"], mass: 0.5, inertia: [0.01, 0.01, 0.01]}
beams:
  l1: {from: f1, to: top, section: s, elements: 2}
  l2: {from: f2, to: top, section: s, elements: 2}
  l3: {from: f3, to: top, section: s, elements: 2}
  l4: {from: f4, to: top, section: s, elements: 2, end: {hinge: {axis: [1, 1, 0], stiffness: 5.0, damping: 0.1}}}
loads:
  - {at: top, force: ["3*sin(40*t)", "2*t", "-4*t"]}
solve: {analysis: transient, dt: 0.004, t_end: 0.06, sensitivities: [X, Y, H]}
output:
  every: 0.012
  probes:
    top_x: {point: top, quantity: position, component: x}
    top_z: {point: top, quantity: displacement, component: z}
    mid_y: {point: "l2.node[1]", quantity: position, component: y}
    hinge: {hinge: l4.end, quantity: angle}
"""

#: a planar cantilever swinging under a tip load in t, its length L the parameter (its tip body's place)
CANTILEVER = """
title: planar cantilever by its length
parameters: {L: 1.5}
sections:
  s: {EA: 1.0e4, EIy: 3.0, EIz: 3.0, GJ: 2.0, rhoA: 0.3, rhoIy: 0.001, rhoIz: 0.001}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: ["L", 0, 0], mass: 0.2}
beams:
  arm: {from: base, to: tip, section: s, elements: 4}
loads:
  - {at: tip, force: [0, "-2*t", 0]}
solve: {analysis: transient, dt: 0.005, t_end: 0.08, sensitivities: [L]}
output:
  every: 0.02
  probes:
    tip_y: {point: tip, quantity: displacement, component: y}
    tip_x: {point: tip, quantity: position, component: x}
"""

#: KNEE_3D with its hinge axis the parameter too (the nodal frame's turn through exp(θ skew a))
KNEE_AXIS = _hinge_axis_scene(KNEE_3D)
#: KNEE_3D with a global load and one turning with the knee at the hinged beam's start, whose offset is the parameter
KNEE_LOADED = _loaded_at_the_offset(KNEE_3D)


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


@pytest.mark.parametrize("text", [LATTICE, CANTILEVER, KNEE_3D, KNEE_SPINNING, KNEE_AXIS, KNEE_LOADED, PLANAR_SWING,
                                  RING, GUIDE_ORIGIN],
                         ids=["3D lattice by a joint", "planar cantilever by its length",
                              "3D knee by its joint, offset and free end", "3D knee spinning", "3D hinge axis",
                              "3D loads at a moved offset", "planar swing by its fixed base",
                              "gimbal's ring offset on a part that turns", "guide's origin on a turning tip"])
def test_geometry_parameters_take_the_loop_and_are_the_python_paths(text, monkeypatch):
    """Every step in the loop of steps, the sensitivities the per-step Python path's to the bit (rows, extremes)."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled" and python.summary["time_loop"] == "python"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] > 0
    assert python.summary["sensitivity_steps_in_loop"] == 0
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert max(np.abs(values).max() for values in python.sensitivities.values()) > 0.0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]


@pytest.mark.parametrize("text", [LATCH_BY_LENGTH, STOP_BY_PLACE, CONTACT_BY_PLACE, INNER_LATCH, RING_PD_LATCH,
                                  PI_LATCH],
                         ids=["planar latch by the tip's place", "3D stop with restitution by the wheel's place",
                              "3D compliant stop by the wheel's place", "hinge point on a turning ring, its latch",
                              "ring offset beside a PD of joints, its latch", "ring offset beside a PI, its latch"])
def test_geometry_parameters_between_events_are_the_python_paths(text, monkeypatch):
    """Through a latch, a rigid stop's bounce and a compliant stop's onset and release (their steps from Python), the
    smooth steps in the loop; the sensitivities and the events' time derivatives the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert 0.8 * steps < in_loop < steps and python.summary["sensitivity_steps_in_loop"] == 0
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


def test_the_cli_writes_the_python_paths_files(tmp_path):
    """``latdyn run`` on the 3D lattice takes the loop; with the switch off (a process of its own) it writes the same
    sensitivities.csv and probes.csv, byte for byte, and summary.json's probe sensitivities."""
    completed, out = latdyn_run(tmp_path, LATTICE)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] == summary["steps"] == 15
    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_the_two_generated_kernels_against_their_formulas(backend):
    """The generated ``reference_variation_at_state`` (ψ = T_e E0ᵀ φ + T_j θ J(θa) δa, δo = T_j δr, δh = T_j δa) and
    ``point_load_D_offset`` (−[0; (T δr) × R f]) against those formulas in NumPy, with J latdyn.numerics.so3's
    dexp_so3, on random frames and hinges (angles across the series' switch at θ = 0.1), to 1e-13."""
    from latdyn.model.kernels import load_kernels
    from latdyn.numerics.so3 import dexp_so3, expm_so3

    rng = np.random.default_rng(20261128)
    kernels = load_kernels(backend, "default")
    n = 12
    frames = np.array([expm_so3(rng.normal(size=3) * 1.3) for _ in range(4 * n)]).reshape(4, n, 3, 3)
    axes = rng.normal(size=(n, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    angles = rng.choice([0.0, 1e-4, 0.0999, 0.1001, 0.9, 2.7], size=n) * rng.choice([-1.0, 1.0], size=n)
    held = rng.normal(size=(n, 9))
    (out,) = kernels.reference_variation_at_state(frames[0].reshape(n, 9), frames[1].reshape(n, 9),
                                                  frames[2].reshape(n, 9), np.column_stack([axes, angles]), held)
    out = np.asarray(out).reshape(n, 9)
    for i in range(n):
        T_e, E0, T = frames[0, i], frames[1, i], frames[2, i]
        psi = T_e @ E0.T @ held[i, :3] + T @ (angles[i] * (dexp_so3(angles[i] * axes[i]) @ held[i, 6:]))
        np.testing.assert_allclose(out[i], np.concatenate([psi, T @ held[i, 3:6], T @ held[i, 6:]]), rtol=0,
                                   atol=1e-13 * (1 + np.abs(held[i]).max() * 4))
    values, moves = rng.normal(size=(n, 6)), rng.normal(size=(n, 3))
    (moved,) = kernels.point_load_D_offset(frames[0].reshape(n, 9), moves, values, frames[3].reshape(n, 9))
    moved = np.asarray(moved).reshape(n, 6)
    for i in range(n):
        force = frames[3, i] @ values[i, :3]
        np.testing.assert_allclose(moved[i], -np.concatenate([np.zeros(3), np.cross(frames[0, i] @ moves[i], force)]),
                                   rtol=0, atol=1e-13 * 10)
