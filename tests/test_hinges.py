"""Hinges for deployables: rest angles, laws in θ, θ̇ and t, hard stops (SCENE.md "Hinge additions").

Every test compares with a closed-form result for a hinged pendulum: a stiff, light arm
from a fixed pivot, hinged there about z, to a joint body of mass ``m`` at distance ``L``;
I = m L² + ρA L³/3 about the hinge. The arm's bending modes (about 5·10⁴ rad/s) are far
above the pendulum's (a few rad/s), so the pendulum is rigid to about 1e-7.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import latdyn
from latdyn.assembly.assembler import Assembler
from latdyn.numerics.so3 import expm_so3
from latdyn.errors import SceneError
from latdyn.model.kernels import load_kernels
from latdyn.model.model import Model

M_BOB, L, RHO_A, G = 1.0, 1.0, 0.01, 9.81
INERTIA = M_BOB * L**2 + RHO_A * L**3 / 3


def pendulum(hinge: dict, gravity: float = 0.0, solve: dict | None = None) -> dict:
    """The pendulum points along +x at θ = 0; gravity along −y."""
    return {
        "gravity": [0, -gravity, 0],
        "sections": {"arm": {"EA": 1e10, "EIy": 1e9, "EIz": 1e9, "GJ": 1e9, "rhoA": RHO_A}},
        "bodies": {"pivot": {"at": [0, 0, 0], "fixed": True},
                   "bob": {"at": [L, 0, 0], "mass": M_BOB}},
        "beams": {"arm": {"from": "pivot", "to": "bob", "section": "arm",
                          "start": {"hinge": {"axis": [0, 0, 1], **hinge}}}},
        "solve": solve or {"analysis": "static", "steps": 10},
        "output": {"probes": {"angle": {"hinge": "arm.start", "quantity": "angle"},
                              "rate": {"hinge": "arm.start", "quantity": "rate"},
                              "kinetic": {"energy": "kinetic"}, "total": {"energy": "total"},
                              "work": {"energy": "external_work"}}},
    }


@pytest.mark.parametrize("stiffness, law", [
    (40.0, lambda th: 40.0),
    ("40*(1 + theta**2)", lambda th: 40.0 * (1 + th**2)),
])
def test_preloaded_spring_with_rest_angle_holds_the_exact_static_equilibrium(stiffness, law):
    """k(θ)(θ − θ_r) + W cos θ = 0 with W = (m L + ρA L²/2) g, the gravity moment about the pivot."""
    rest = 1.2
    result = latdyn.run(pendulum({"stiffness": stiffness, "rest_angle": rest}, gravity=G))
    weight_moment = (M_BOB * L + RHO_A * L**2 / 2) * G
    exact = brentq(lambda th: law(th) * (th - rest) + weight_moment * math.cos(th), -1.0, rest)
    assert result.probes["angle"][-1] == pytest.approx(exact, abs=2e-6)
    assert 0.3 < exact < rest  # the spring is preloaded: gravity holds it well short of its rest angle


def test_angle_dependent_stiffness_oscillates_at_the_exact_small_oscillation_frequency():
    """f = k(θ)(θ − θ_r) − τ0 with k = k0 (1 + θ)², θ_r = −1/2 and τ0 = k0/2 balancing it at θ = 0:
    ∂f/∂θ(0) = k(0) − θ_r k′(0) = 2 k0, so ω = √(2 k0 / I). A step of δτ = 1e-4 k0 starts the
    small oscillation; the modal analysis gives the same frequency from the tangent."""
    k0 = 30.0
    omega = math.sqrt(2 * k0 / INERTIA)
    period = 2 * math.pi / omega
    hinge = {"stiffness": "30*(1 + theta)**2", "rest_angle": -0.5, "torque": 0.5 * k0 + 1e-4 * k0}
    scene = pendulum(hinge, solve={"analysis": "transient", "t_end": 3 * period, "dt": period / 400,
                                   "rho_inf": 1.0})
    result = latdyn.run(scene)
    angle = result.probes["angle"] - 0.5e-4  # about the shifted equilibrium δτ / (2 k0)
    t = result.t
    up = np.flatnonzero((angle[:-1] < 0) & (angle[1:] >= 0))
    crossings = t[up] - angle[up] * (t[up + 1] - t[up]) / (angle[up + 1] - angle[up])
    measured = np.mean(np.diff(crossings))
    assert len(crossings) >= 2
    assert measured == pytest.approx(period, rel=1e-3)
    modes = latdyn.run(pendulum(hinge, solve={"analysis": "modes", "count": 1})).modes
    # 3.2e-5 measured: round-off of the stiff arm (K up to 1e10) in the eigenproblem
    assert modes[0] == pytest.approx(omega / (2 * math.pi), rel=1e-4)


def stop_scene(restitution: float) -> dict:
    """No gravity; a spring with rest angle θ_r = 1 drives the pendulum from θ = 0 into the stop at 0.5."""
    hinge = {"stiffness": 10.0, "rest_angle": 1.0, "limits": [-0.1, 0.5], "restitution": restitution}
    return pendulum(hinge, solve={"analysis": "transient", "t_end": 1.2, "dt": 1e-3})


@pytest.mark.parametrize("restitution", [1.0, 0.5])
def test_stop_with_restitution_reverses_the_rate_and_keeps_the_energy_it_should(restitution):
    """Energy: ½ I θ̇⁺² = e² k (θ_r² − (θ_r − hi)²)/2, so the rebound turns at
    (θ_r − θ_min)² = (θ_r − hi)² + e² (θ_r² − (θ_r − hi)²): θ_min = 0 for e = 1."""
    result = latdyn.run(stop_scene(restitution))
    angle, rate = result.probes["angle"], result.probes["rate"]
    assert angle.max() <= 0.5 + 1e-7
    hit = int(np.argmax(angle))
    after = slice(hit + 1, hit + 1 + int(np.argmax(rate[hit + 1:] > 0)))  # up to the rebound's turning point
    theta_min = 1.0 - math.sqrt(0.25 + restitution**2 * (1.0 - 0.25))
    assert angle[after].min() == pytest.approx(theta_min, abs=2e-3)
    rate_in = math.sqrt(10.0 * (1.0 - 0.25) / INERTIA)  # energy of the spring from θ = 0 to the stop
    assert rate[hit + 1] == pytest.approx(-restitution * rate_in, rel=1e-2)
    if restitution == 1.0:
        total = result.probes["total"]
        # 2.1e-3 measured over the two impacts: the dt²K part of the projection (stiff arm modes,
        # taken quasi-statically) is not kinetic-energy neutral as A = M alone would be
        assert np.ptp(total) <= 4e-3 * total.max()


def test_stop_without_restitution_kills_the_rate_and_holds_the_hinge():
    result = latdyn.run(stop_scene(0.0))
    angle, rate = result.probes["angle"], result.probes["rate"]
    hit = int(np.argmax(angle >= 0.5 - 1e-7))
    assert hit > 0
    np.testing.assert_allclose(angle[hit:], 0.5, atol=1e-7)
    np.testing.assert_allclose(rate[hit:], 0.0, atol=1e-9)
    assert result.probes["kinetic"][hit + 5:].max() <= 1e-6 * result.probes["kinetic"].max()


def test_a_resting_hinge_leaves_its_stop_when_the_load_pulls_it_away():
    """The spring pushes into the upper stop; from t = 0.5 a torque of 20 > k (θ_r − hi) = 5 pulls
    back: the stop releases and the pendulum swings towards the lower stop."""
    scene = stop_scene(0.0)
    scene["beams"]["arm"]["start"]["hinge"]["torque"] = "-20*Heaviside(t - 0.5)"
    result = latdyn.run(scene)
    angle, t = result.probes["angle"], result.t
    np.testing.assert_allclose(angle[(t > 0.45) & (t < 0.5)], 0.5, atol=1e-7)
    assert angle[-1] < 0.3


def test_hinge_tangent_matches_finite_differences():
    """∂r/∂θ (K) and ∂r/∂θ̇ (C) of the whole residual, hinge laws in θ, θ̇ and t included."""
    hinge = {"stiffness": "5*(1 + theta**2)*(1 + 0.1*t)", "damping": "0.3 + theta_dot**2 + 0.2*theta",
             "torque": "2*sin(theta) + theta_dot*cos(t)", "rest_angle": 0.2}
    scene = latdyn.load_scene(pendulum(hinge, gravity=G, solve={"analysis": "transient", "t_end": 1, "dt": 0.1}))
    model = Model.from_scene(scene)
    assembler = Assembler(model, load_kernels("c"), scene.gravity)
    state = assembler.initial_state()
    k, bob = model.hinge_dofs[0], model.body_node["bob"]
    # the pendulum turned rigidly by 0.4 rad (a strained stiff arm would bury the FD in round-off)
    state.theta[0], state.T[bob] = 0.4, expm_so3(np.array([0, 0, 0.4]))
    state.x[bob] = state.T[bob] @ [L, 0, 0]
    state.theta_dot[0], state.w[bob], state.v[bob] = 0.7, [0, 0, 0.7], 0.7 * state.T[bob] @ [0, L, 0]
    state.t = 0.3
    ev = assembler.evaluate(state, matrices=True, inertia=False)
    eps = 1e-6
    plus = assembler.evaluate(assembler.advance(state, np.eye(model.n_dofs)[k] * eps), matrices=False, inertia=False)
    minus = assembler.evaluate(assembler.advance(state, -np.eye(model.n_dofs)[k] * eps), matrices=False, inertia=False)
    fd_k = (plus.residual - minus.residual) / (2 * eps)
    np.testing.assert_allclose(ev.combined(0, 0, 1, dense=True)[:, k], fd_k, rtol=1e-6, atol=1e-6 * np.abs(fd_k).max())
    ev = assembler.evaluate(state, matrices=True)
    rates = []
    for sign in (1, -1):
        moved = state.copy()
        moved.theta_dot[0] += sign * eps
        rates.append(assembler.evaluate(moved, matrices=False).residual)
    fd_c = (rates[0] - rates[1]) / (2 * eps)
    np.testing.assert_allclose(ev.combined(0, 1, 0, dense=True)[:, k], fd_c, rtol=1e-6,
                               atol=1e-6 * np.abs(fd_c).max())
    assert abs(fd_k[k]) > 1.0 and abs(fd_c[k]) > 0.5  # the laws contribute


@pytest.mark.parametrize("stiffness", ["20*(1 + theta**2)", "20*(1 + 0.5*sin(3*t))"])
def test_energy_balance_with_nonlinear_and_time_varying_springs(stiffness):
    """A law k(θ) stores ∫ k(s)(s − θ_r) ds; a law in t does work counted as external work:
    either way total − external_work stays constant without damping."""
    scene = pendulum({"stiffness": stiffness, "rest_angle": 0.8}, gravity=G,
                     solve={"analysis": "transient", "t_end": 1.0, "dt": 1e-3, "rho_inf": 1.0})
    result = latdyn.run(scene)
    assert result.summary["energy_balance_error"] < 2e-4
    assert np.ptp(result.probes["angle"]) > 0.3


@pytest.mark.parametrize("hinge, key, expected", [
    ({"limits": [0.1, 1]}, "limits", "lo <= 0 <= hi"),
    ({"limits": [0, 1, 2]}, "limits", "[lo, hi]"),
    ({"restitution": 0.5}, "restitution", "limits"),
    ({"limits": [-1, 1], "restitution": 1.5}, "restitution", "[0, 1]"),
    ({"limits": [-1, 1], "lock_at": 2}, "lock_at", "within the limits"),
    ({"stiffness": "theta.real"}, "stiffness", "theta (hinge angle)"),
    ({"stiffness": "omega*theta"}, "stiffness", "not allowed"),
    ({"torque": "1/theta"}, "torque", "finite at theta"),
    ({"stiffness": -2}, "stiffness", ">= 0"),
])
def test_bad_hinge_additions_name_the_key(hinge, key, expected):
    with pytest.raises(SceneError) as info:
        latdyn.load_scene(pendulum(hinge))
    assert f"beams.arm.start.hinge.{key}" in str(info.value) and expected in str(info.value)


def test_hinge_laws_keep_numbers_and_time_functions_as_before():
    scene = latdyn.load_scene(pendulum({"stiffness": "2*pi", "damping": 0.5, "torque": "sin(t)",
                                        "rest_angle": "pi/4"}))
    hinge = scene.beams["arm"].start.hinge
    assert hinge.stiffness == pytest.approx(2 * math.pi) and hinge.damping == 0.5
    assert hinge.torque.value(1.0) == pytest.approx(math.sin(1.0)) and hinge.rest_angle == pytest.approx(math.pi / 4)
    law = latdyn.load_scene(pendulum({"torque": "theta_dot*t"})).beams["arm"].start.hinge.torque
    assert law.value(0.0, 2.0, 3.0) == 6.0 and law.d_rate(0.0, 2.0, 3.0) == 3.0

