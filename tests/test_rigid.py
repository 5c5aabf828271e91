"""Rigid links (``rigid: true``) in minimum coordinates: latdyn/model/links.py.

Exact references: the compound pendulum's period (complete elliptic integral), a direct
Lagrangian ODE of the double compound pendulum (scipy, 1e-11), static equilibria and small-
oscillation frequencies in closed form; invariants: energy, invariance under a rigid motion of
the whole scene; and finite differences of the tangent on the minimum coordinates.
"""
from __future__ import annotations


import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipk

import latdyn
from latdyn.assembly.assembler import free_acceleration, free_velocity, unpack_free
from latdyn.errors import SceneError
from latdyn.model.model import Model
from latdyn.scene.loader import load_scene
from latdyn.assembly.prepare import prepare

G = 9.81
#: the plane of the pendulums: normal n (tilted against gravity), gravity along −z
NORMAL = np.array([1.0, 2.0, 2.0]) / 3.0
PIVOT = np.array([0.3, -0.2, 0.5])


def rotation(axis, angle):
    A = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * A + (1 - np.cos(angle)) * A @ A


def in_plane_down():
    """The downward direction in the tilted plane and the gravity that acts in it."""
    g = np.array([0.0, 0.0, -G])
    down = g - g @ NORMAL * NORMAL
    return down / np.linalg.norm(down), float(np.linalg.norm(down))


def section(rhoA, **more):
    return {"EA": 1.0, "EIy": 1.0, "EIz": 1.0, "GJ": 1.0, "rhoA": rhoA, **more}


def pendulum_scene(theta0, length=1.0, rhoA=2.0, t_end=1.0, dt=0.004, method="newmark"):
    down, _ = in_plane_down()
    tip = PIVOT + length * rotation(NORMAL, theta0) @ down
    return {
        "gravity": [0, 0, -G],
        "sections": {"rod": section(rhoA)},
        "bodies": {"base": {"at": PIVOT.tolist(), "fixed": True}},
        "beams": {"link": {"from": "base", "to": tip.tolist(), "section": "rod", "rigid": True,
                           "start": {"hinge": {"axis": NORMAL.tolist()}}}},
        "solve": {"t_end": t_end, "dt": dt, "tol": 1e-12, "method": method},
        "output": {"probes": {"angle": {"hinge": "link.start", "quantity": "angle"},
                              "total": {"energy": "total"}, "kinetic": {"energy": "kinetic"},
                              "tip": {"point": "link.node[1]", "quantity": "position", "component": "z"}}},
    }


def crossings(t, signal):
    """Times at which ``signal`` changes sign (linear interpolation)."""
    i = np.flatnonzero(np.sign(signal[:-1]) * np.sign(signal[1:]) < 0)
    return t[i] - signal[i] * (t[i + 1] - t[i]) / (signal[i + 1] - signal[i])


def test_compound_pendulum_period_and_energy():
    """Large amplitude (θ0 = 2 rad = 115°) in a tilted plane: T = 4 sqrt(I_O/(m g' L/2)) K(sin θ0/2)."""
    theta0, length, rhoA = 2.0, 1.0, 2.0
    _, g_plane = in_plane_down()
    mass, pivot_inertia = rhoA * length, rhoA * length ** 3 / 3
    period = 4 * np.sqrt(pivot_inertia / (mass * g_plane * length / 2)) * ellipk(np.sin(theta0 / 2) ** 2)
    result = latdyn.run(pendulum_scene(theta0, length, rhoA, t_end=0.85 * period, dt=0.004))
    t, angle = np.asarray(result.t), np.asarray(result.probes["angle"])
    bottom = crossings(t, theta0 + angle)  # the link passes the lowest point every half period
    assert len(bottom) == 2
    assert bottom[0] == pytest.approx(period / 4, rel=2e-4)
    assert bottom[1] - bottom[0] == pytest.approx(period / 2, rel=2e-4)
    assert np.min(theta0 + angle) == pytest.approx(-theta0, abs=2e-3)  # swings up to the mirror angle
    total = np.asarray(result.probes["total"])
    assert np.ptp(total) < 2e-4 * np.max(result.probes["kinetic"])


def double_pendulum_scene(phi1, phi2, t_end, dt, method, lengths=(1.0, 0.8), masses=(2.0, 1.2)):
    down, _ = in_plane_down()
    elbow = PIVOT + lengths[0] * rotation(NORMAL, phi1) @ down
    tip = elbow + lengths[1] * rotation(NORMAL, phi2) @ down
    return {
        "gravity": [0, 0, -G],
        "sections": {"upper": section(masses[0] / lengths[0]), "lower": section(masses[1] / lengths[1])},
        "bodies": {"base": {"at": PIVOT.tolist(), "fixed": True}, "elbow": {"at": elbow.tolist()}},
        "beams": {"upper": {"from": "base", "to": "elbow", "section": "upper", "rigid": True,
                            "start": {"hinge": {"axis": NORMAL.tolist()}}},
                  "lower": {"from": "elbow", "to": tip.tolist(), "section": "lower", "rigid": True,
                            "start": {"hinge": {"axis": NORMAL.tolist()}}}},
        "solve": {"t_end": t_end, "dt": dt, "tol": 1e-12, "method": method},
        "output": {"probes": {**{c: {"point": "lower.end", "quantity": "position", "component": c} for c in "xyz"},
                              "total": {"energy": "total"}, "kinetic": {"energy": "kinetic"}}},
    }


def double_pendulum_reference(phi1, phi2, times, lengths=(1.0, 0.8), masses=(2.0, 1.2)):
    """Tip positions from the Lagrangian ODE of the double compound pendulum (absolute angles from
    the in-plane downward direction), DOP853 at rtol 1e-11."""
    (L1, L2), (m1, m2) = lengths, masses
    down, g = in_plane_down()

    def rhs(_, y):
        p1, p2, w1, w2 = y
        c, s = np.cos(p1 - p2), np.sin(p1 - p2)
        A = [[m1 * L1 ** 2 / 3 + m2 * L1 ** 2, m2 * L1 * L2 / 2 * c], [m2 * L1 * L2 / 2 * c, m2 * L2 ** 2 / 3]]
        b = [-m2 * L1 * L2 / 2 * s * w2 ** 2 - (m1 / 2 + m2) * g * L1 * np.sin(p1),
             m2 * L1 * L2 / 2 * s * w1 ** 2 - m2 * g * L2 / 2 * np.sin(p2)]
        return [w1, w2, *np.linalg.solve(A, b)]

    sol = solve_ivp(rhs, (0, times[-1]), [phi1, phi2, 0, 0], t_eval=times, rtol=1e-11, atol=1e-12, method="DOP853")
    return np.array([PIVOT + L1 * rotation(NORMAL, a) @ down + L2 * rotation(NORMAL, b) @ down
                     for a, b in sol.y[:2].T])


def test_double_pendulum_against_lagrangian_reference():
    """Two rigid links through a massless joint body (dependent node): tip against the direct ODE
    over 1 s of large motion; second order in dt."""
    errors = []
    for dt in (0.004, 0.002):
        result = latdyn.run(double_pendulum_scene(2.0, 2.6, 1.0, dt, "generalized-alpha"))
        tip = np.column_stack([result.probes[c] for c in "xyz"])
        errors.append(np.abs(tip - double_pendulum_reference(2.0, 2.6, np.asarray(result.t))).max())
        assert result.summary["engine"] == "compiled"  # the C Newton iteration, reduced by callbacks
    assert errors[1] < 6e-5
    assert 3.3 < errors[0] / errors[1] < 4.7  # second order


def test_double_pendulum_chaotic_energy():
    """A chaotic run (4 s from near the top, the lower link flipping over) with the trapezoidal
    rule, which conserves energy only to O(dt²) in a nonlinear system: measured 1.2e-3 of the
    largest kinetic energy at dt = 0.004, bounded (no drift)."""
    result = latdyn.run(double_pendulum_scene(2.4, 3.0, 4.0, 0.004, "newmark"))
    total = np.asarray(result.probes["total"])
    kinetic = np.max(result.probes["kinetic"])
    assert np.ptp(total) < 2e-3 * kinetic
    assert abs(total[-1] - total[0]) < 1e-3 * kinetic
    assert result.summary["newton_iterations_per_step"] < 4


def link_with_flexible_beam(gravity=(0.0, 0.0, -G), transform=None):
    """A rigid link hinged at a fixed base carries body B (dependent, with mass) through a second,
    skew hinge; a flexible beam hangs from B. ``transform`` = (Q, c) moves the scene rigidly."""
    Q, c = (np.eye(3), np.zeros(3)) if transform is None else transform

    def at(p):
        return (Q @ np.asarray(p, float) + c).tolist()

    def along(v):
        return (Q @ np.asarray(v, float)).tolist()

    return {
        "gravity": along(gravity),
        "sections": {"rod": section(3.0, rhoIy=0.002, rhoIz=0.001),
                     "flex": {"EA": 5e4, "EIy": 40.0, "EIz": 60.0, "GJ": 30.0, "rhoA": 0.8,
                              "rhoIy": 1e-3, "rhoIz": 1e-3}},
        "bodies": {"base": {"at": at([0, 0, 0]), "fixed": True},
                   "B": {"at": at([0.9, 0.3, -0.2]), "mass": 0.5, "com": along([0.05, 0, 0]),
                         "inertia": (Q @ np.diag([2e-3, 3e-3, 4e-3]) @ Q.T).tolist()}},
        "beams": {"link": {"from": {"body": "base", "offset": along([0.05, 0, 0])}, "to": "B", "section": "rod",
                           "rigid": True, "y_axis": along([0, 0, 1]),
                           "start": {"hinge": {"axis": along([0, 0.3, 1]), "damping": 0.0}},
                           "end": {"hinge": {"axis": along([1, 0.2, 0.4]), "stiffness": 2.0}}},
                  "flex": {"from": "B", "to": at([1.4, 0.9, -0.5]), "section": "flex", "elements": 3,
                           "y_axis": along([0, 0, 1])}},
        "initial_velocity": {"angular": along([0.5, -1.0, 2.0]), "about": at([0, 0, 0])},
        "solve": {"t_end": 0.3, "dt": 0.002, "tol": 1e-10, "method": "newmark"},
        "output": {"probes": {"a1": {"hinge": "link.start", "quantity": "angle"},
                              "a2": {"hinge": "link.end", "quantity": "angle"},
                              **{f"tip_{k}": {"point": "flex.end", "quantity": "position", "frame": "base",
                                              "component": k} for k in "xyz"},
                              **{f"B_{k}": {"point": "B", "quantity": "velocity", "component": k} for k in "xyz"},
                              "total": {"energy": "total"}, "kinetic": {"energy": "kinetic"},
                              "strain": {"energy": "strain"}}},
    }


def test_link_carrying_flexible_beam_energy():
    """Energy of the trapezoidal rule, O(dt²): measured 3.1e-3 of the largest kinetic energy at
    dt = 0.002 and 0.96e-3 at 0.001 over 0.2 s (the same scene with the link as a stiff flexible
    beam: 1.6e-3 and 0.52e-3)."""
    result = latdyn.run(link_with_flexible_beam())
    total = np.asarray(result.probes["total"])
    assert np.max(result.probes["strain"]) > 1e-3 * np.max(result.probes["kinetic"])  # the beam bends
    assert np.ptp(total) < 4e-3 * np.max(result.probes["kinetic"])
    assert result.summary["energy_balance_error"] < 3e-3


def test_invariance_under_rigid_motion():
    """The 3D scene above moved by a random rigid motion: hinge angles equal, positions equal in
    the moved frame (probes in the base frame are rotated back by Q), velocities rotated by Q."""
    rng = np.random.default_rng(7)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    Q *= np.sign(np.linalg.det(Q))
    c = rng.normal(size=3)
    scene = link_with_flexible_beam()
    scene["solve"]["t_end"] = 0.1
    moved = link_with_flexible_beam(transform=(Q, c))
    moved["solve"]["t_end"] = 0.1
    a, b = latdyn.run(scene), latdyn.run(moved)
    for k in ("a1", "a2"):
        np.testing.assert_allclose(b.probes[k], a.probes[k], atol=1e-9)
    # the potential of gravity, −m g·x, changes by a constant with the origin
    np.testing.assert_allclose(np.asarray(b.probes["total"]) - b.probes["total"][0],
                               np.asarray(a.probes["total"]) - a.probes["total"][0], atol=1e-9)
    tip_a = np.column_stack([a.probes[f"tip_{k}"] for k in "xyz"])
    tip_b = np.column_stack([b.probes[f"tip_{k}"] for k in "xyz"])  # base frame = global axes of each scene
    np.testing.assert_allclose(tip_b, tip_a @ Q.T, atol=1e-8)
    vel_a = np.column_stack([a.probes[f"B_{k}"] for k in "xyz"])
    vel_b = np.column_stack([b.probes[f"B_{k}"] for k in "xyz"])
    np.testing.assert_allclose(vel_b, vel_a @ Q.T, atol=1e-8)


# ----------------------------------------------------------------------------- tangent


def tree_scene():
    """A free root body, two links (one to a dependent body B), loads and gravity: everything the
    map J touches, in 3D."""
    return {
        "gravity": [0.3, -1.0, -9.81],
        "sections": {"s": section(1.5, rhoIy=0.01, rhoIz=0.02)},
        "bodies": {"A": {"at": [0, 0, 0], "mass": 3, "inertia": [0.2, 0.3, 0.4], "com": [0.1, 0, 0.05]},
                   "B": {"at": [1, 0.5, 0.3], "mass": 0.7, "inertia": [0.01, 0.02, 0.03], "com": [0, 0.1, 0]}},
        "beams": {"l1": {"from": {"body": "A", "offset": [0.1, 0, 0]}, "to": {"body": "B", "offset": [0, -0.1, 0.05]},
                         "section": "s", "rigid": True,
                         "start": {"hinge": {"axis": [0.2, 0.3, 1], "stiffness": 5.0}},
                         "end": {"hinge": {"axis": [1, -0.5, 0.2]}}},
                  "l2": {"from": "B", "to": [1.5, 1.2, 0.0], "section": "s", "rigid": True,
                         "start": {"hinge": {"axis": [0, 1, 1]}}}},
        "loads": [{"at": "l1.end", "force": [1, 2, 3], "moment": [0.3, -0.2, 0.1]},
                  {"at": "l2.end", "force": [0, -4, 1]}],
        "solve": {"analysis": "static"},
    }


def finite_difference(prepared, state, what, eps=1e-6, **evaluate):
    model, assembler = prepared.model, prepared.assembler
    n = model.n_dofs
    out = np.zeros((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = eps
        residuals = []
        for sign in (1.0, -1.0):
            if what == "q":
                trial = assembler.advance(state, sign * e)
                for k in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot"):
                    setattr(trial, k, np.array(getattr(state, k)))
            else:
                trial = state.copy()
                if what == "v":
                    unpack_free(model, free_velocity(model, state) + sign * e, trial.v, trial.w, trial.theta_dot)
                else:
                    unpack_free(model, free_acceleration(model, state) + sign * e, trial.a, trial.alpha,
                                trial.theta_ddot)
            residuals.append(assembler.evaluate(trial, matrices=False, **evaluate).residual)
        out[:, j] = (residuals[0] - residuals[1]) / (2 * eps)
    return out


@pytest.mark.parametrize("seed", [1, 2])
def test_tangent_by_finite_differences(seed):
    """K = ∂r/∂q (static residual, with the geometric term ∂Jᵀ/∂q · r_all), C = ∂r/∂v (with
    M ∂(J̇v)/∂v) and M = ∂r/∂v̇ against central differences at a random large-rotation configuration."""
    rng = np.random.default_rng(seed)
    prepared = prepare(tree_scene())
    model, assembler = prepared.model, prepared.assembler
    n = model.n_dofs
    assert n == 6 + 3  # the free root and three hinges: B and the link nodes have no coordinates
    state = assembler.advance(prepared.state, rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    static = assembler.evaluate(state, matrices=True, inertia=False)
    K = static.combined(0.0, 0.0, 1.0, dense=True)
    K_fd = finite_difference(prepared, state, "q", inertia=False)
    assert np.abs(K - K_fd).max() < 1e-7 * np.abs(K_fd).max()
    dynamic = assembler.evaluate(state, matrices=True)
    for (cm, cc), what in (((0.0, 1.0), "v"), ((1.0, 0.0), "a")):
        exact = dynamic.combined(cm, cc, 0.0, dense=True)
        fd = finite_difference(prepared, state, what)
        assert np.abs(exact - fd).max() < 1e-7 * np.abs(fd).max()
    # without the geometric term the tangent is wrong: the test can see it
    assert np.abs(K - np.asarray(static.geometric) - K_fd).max() > 1e-3 * np.abs(K_fd).max()


def test_newton_converges_quadratically_in_a_static_solve():
    """Static equilibrium of the tree under its loads: Newton's increments square from step to step."""
    scene = tree_scene()
    scene["bodies"]["A"] = {"at": [0, 0, 0], "fixed": True}
    scene["beams"]["l1"]["end"]["hinge"]["stiffness"] = 3.0
    scene["beams"]["l2"]["start"]["hinge"]["stiffness"] = 4.0
    prepared = prepare(scene)
    assembler = prepared.assembler
    state = prepared.state
    for load_factor in (0.25, 0.5, 0.75, 1.0):  # load steps, the last one watched
        sizes = []
        for _ in range(20):
            ev = assembler.evaluate(state, matrices=True, inertia=False, load_factor=load_factor)
            dx = np.linalg.solve(ev.combined(0.0, 0.0, 1.0, dense=True), -ev.residual)
            state = assembler.advance(state, dx)
            sizes.append(np.abs(dx).max())
            if sizes[-1] < 1e-13:
                break
        assert sizes[-1] < 1e-12
    # quadratic: once in the basin, log(size) doubles
    tail = [s for s in sizes if 1e-11 < s < 1e-2]
    assert len(tail) >= 2 and all(b < 10 * a ** 2 for a, b in zip(tail, tail[1:]))


# ----------------------------------------------------------------------------- static and modes


def test_static_link_with_spring_against_closed_form():
    """A horizontal link on a spring hinge sags under gravity: k θ = m g (L/2) cos θ."""
    k, length, rhoA = 30.0, 1.2, 2.0
    scene = {
        "gravity": [0, 0, -G],
        "sections": {"rod": section(rhoA)},
        "bodies": {"base": {"at": [0, 0, 0], "fixed": True}},
        "beams": {"link": {"from": "base", "to": [length, 0, 0], "section": "rod", "rigid": True,
                           "start": {"hinge": {"axis": [0, 1, 0], "stiffness": k}}}},
        "solve": {"analysis": "static", "steps": 4},
        "output": {"probes": {"angle": {"hinge": "link.start", "quantity": "angle"},
                              "tip": {"point": "link.end", "quantity": "position", "component": "z"}}},
    }
    result = latdyn.run(scene)
    weight = rhoA * length * G
    theta = brentq(lambda th: k * th - weight * length / 2 * np.cos(th), 0.0, np.pi / 2)
    assert result.probes["angle"][-1] == pytest.approx(theta, rel=1e-9)  # +y axis: turning down is +θ
    assert result.probes["tip"][-1] == pytest.approx(-length * np.sin(theta), rel=1e-9)


def test_modes_small_oscillation():
    """Hanging link on a hinge in the tilted plane: ω² = m g' (L/2) / I_O = 3 g' / (2L)."""
    scene = pendulum_scene(0.0, length=0.7)
    scene["solve"] = {"analysis": "modes", "count": 1}
    _, g_plane = in_plane_down()
    frequency = np.sqrt(3 * g_plane / (2 * 0.7)) / (2 * np.pi)
    assert latdyn.run(scene).modes[0] == pytest.approx(frequency, rel=1e-10)


# ----------------------------------------------------------------------------- refusals and reports


def refused(scene, key):
    with pytest.raises(SceneError) as info:
        Model.from_scene(load_scene(scene))
    assert key in str(info.value)
    return str(info.value)


def test_closed_loop_of_rigid_links_is_refused():
    scene = {
        "sections": {"s": section(1.0)},
        "bodies": {"a": {"at": [0, 0, 0], "mass": 1}, "b": {"at": [1, 0, 0]}, "c": {"at": [0, 1, 0]}},
        "beams": {"ab": {"from": "a", "to": "b", "section": "s", "rigid": True},
                  "bc": {"from": "b", "to": "c", "section": "s", "rigid": True},
                  "ca": {"from": "c", "to": "a", "section": "s", "rigid": True}},
        "solve": {"analysis": "static"},
    }
    message = refused(scene, "beams.ca.rigid")
    assert "loop" in message and "flexible" in message
    scene["beams"]["ca"]["rigid"] = False  # a loop closed by a flexible beam is fine
    Model.from_scene(load_scene(scene))


def test_links_that_minimum_coordinates_cannot_express_are_refused():
    scene = {
        "sections": {"s": section(1.0)},
        "bodies": {"a": {"at": [0, 0, 0], "fixed": True}, "b": {"at": [1, 0, 0], "fixed": True},
                   "c": {"at": [0, 1, 0], "mass": 1}, "d": {"at": [1, 1, 0], "mass": 1}},
        "beams": {"ab": {"from": "a", "to": "b", "section": "s", "rigid": True}},
        "solve": {"analysis": "static"},
    }
    assert "fixed" in refused(scene, "beams.ab.rigid")
    scene["beams"] = {"ad": {"from": "a", "to": "d", "section": "s", "rigid": True},
                      "cd": {"from": "c", "to": "d", "section": "s", "rigid": True}}
    assert "two rigid links" in refused(scene, "beams.cd.rigid")
    scene["beams"] = {"self": {"from": "c", "to": {"body": "c", "offset": [1, 0, 0]}, "section": "s", "rigid": True}}
    assert "loop" in refused(scene, "beams.self.rigid")


def test_element_probe_of_a_link_is_refused():
    scene = pendulum_scene(0.5)
    scene["output"]["probes"]["n"] = {"element": "link.element[0]", "quantity": "axial_force"}
    with pytest.raises(SceneError, match="rigid link"):
        load_scene(scene)


def test_size_report_names_links():
    model = Model.from_scene(load_scene(double_pendulum_scene(0.3, 0.2, 0.01, 0.005, "generalized-alpha")))
    report = model.size_report()
    assert model.n_dofs == 2
    assert "rigid links: 2" in report and "1 bodies (elbow)" in report and "18 coordinates removed" in report


def test_free_start_link_equals_its_rigid_body():
    """A link from a free point to a free point is a free rigid body: the same run as a scene body
    with mass ρA·L at mid-length and the rod's inertia (ρA L³/12 transverse, ρI terms)."""
    start, end = np.array([0.2, -0.1, 0.3]), np.array([1.0, 0.4, 0.2])
    rhoA, rhoIy, rhoIz = 2.0, 0.01, 0.03
    length = float(np.linalg.norm(end - start))
    x = (end - start) / length
    y = np.array([-x[1], x[0], 0.0]) / np.hypot(x[0], x[1])  # the default y_axis: global Z × x
    frame = np.column_stack([x, y, np.cross(x, y)])
    rod = rhoA * length ** 3 / 12
    inertia = frame @ np.diag([(rhoIy + rhoIz) * length, rod + rhoIy * length, rod + rhoIz * length]) @ frame.T
    common = {
        "gravity": [0.0, -1.0, -G],
        "initial_velocity": {"linear": [0.1, 0.2, -0.1], "angular": [1.0, -2.0, 3.0]},
        "solve": {"t_end": 0.2, "dt": 0.005, "tol": 1e-12},
        "output": {"probes": {**{f"H{k}": {"momentum": "angular", "component": k} for k in "xyz"},
                              **{f"P{k}": {"momentum": "linear", "component": k} for k in "xyz"},
                              "total": {"energy": "total"}, "kinetic": {"energy": "kinetic"}}},
    }
    link = {"sections": {"s": section(rhoA, rhoIy=rhoIy, rhoIz=rhoIz)},
            "beams": {"bar": {"from": start.tolist(), "to": end.tolist(), "section": "s", "rigid": True}}, **common}
    body = {"bodies": {"bar": {"at": start.tolist(), "mass": rhoA * length, "com": (0.5 * (end - start)).tolist(),
                               "inertia": inertia.tolist()}}, **common}
    a, b = latdyn.run(link), latdyn.run(body)
    for k in b.probes:
        np.testing.assert_allclose(a.probes[k], b.probes[k], rtol=1e-10, atol=1e-10)


def test_prescribed_root_energy_balance_and_latch():
    """A double pendulum on a base that turns and shakes by law: the work of the drive reaches the
    links through J (reactions on the prescribed coordinates), so total − external work holds;
    and a link hinge latches at its lock_at like any hinge."""
    scene = double_pendulum_scene(1.0, 1.0, 0.3, 0.004, "generalized-alpha")
    scene["bodies"]["base"] = {"at": PIVOT.tolist(), "motion": {"rotation": {"axis": [0, 0, 1], "angle": "t**2"},
                                                                 "translation": ["0.1*sin(5*t)", 0, 0]}}
    result = latdyn.run(scene)
    assert result.summary["energy_balance_error"] < 1e-4  # measured 2.1e-5
    scene = pendulum_scene(1.0, t_end=1.3, dt=0.004)
    scene["beams"]["link"]["start"]["hinge"]["lock_at"] = -1.5
    result = latdyn.run(scene)
    assert result.probes["angle"][-1] == pytest.approx(-1.5, abs=1e-6)
    assert result.probes["kinetic"][-1] == 0.0


def test_linked_tangent_from_coloured_columns_equals_column_by_column(monkeypatch):
    """r_q of a model with a rigid link by differences (linearisation.tangent_q_by_differences: the
    analytic material tangent plus central differences of the rest) from columns perturbed together,
    coloured on the reduced pattern Pᵀ A P, equals the one taken column by column: the pattern bounds
    the dependence; and the exact r_q (tangent_q) equals them to the differences' error."""
    from latdyn.analyses import linearisation
    from latdyn.assembly.prepare import prepare

    raw = link_with_flexible_beam()
    raw["beams"]["flex"]["elements"] = 8
    prepared = prepare(load_scene(raw))
    a, state = prepared.assembler, prepared.state
    state.w[:] = [0.3, -0.5, 0.8]  # rates and accelerations at which the gyroscopic terms differ from zero
    state.alpha[:] = [1.0, 0.2, -0.4]
    groups = linearisation.column_groups(a)
    assert groups is not None and len(groups) < a.model.n_dofs / 2
    coloured = linearisation.tangent_q_by_differences(a, state)
    exact = linearisation.tangent_q(a, state)
    assert np.max(np.abs(coloured - exact)) <= 1e-8 * np.max(np.abs(exact))
    monkeypatch.setattr(linearisation, "column_groups", lambda assembler: None)
    alone = linearisation.tangent_q_by_differences(a, state)
    assert np.max(np.abs(coloured - alone)) <= 1e-8 * np.max(np.abs(alone))
