"""The generated joint-body and point-load kernels (codegen/joints.py, generated/joints.*):
every derivative against central differences under the update T ← exp(skew Δπ) T, the
Newton–Euler equations against a hand computation (the formulas the runtime held before the
kernels were generated), both backends equal, and follower loads whose exact tangent makes
Newton converge as fast as under a fixed load (issue 22)."""
from __future__ import annotations

import numpy as np
import pytest

from latdyn.model.kernels import load_kernels
from latdyn.numerics.so3 import expm_so3, skew

RNG = np.random.default_rng(20261125)


def rotation():
    return expm_so3(RNG.normal(size=3) * 1.3)


def body_inputs(n=4):
    T = np.array([rotation() for _ in range(n)])
    motion = RNG.normal(size=(n, 9))
    A = RNG.normal(size=(n, 3, 3))
    inertia = A @ np.transpose(A, (0, 2, 1)) + np.eye(3)
    body = np.concatenate([RNG.uniform(0.5, 2.0, (n, 1)), RNG.normal(size=(n, 3)), inertia.reshape(n, 9)], axis=1)
    gravity = RNG.normal(size=(n, 3)) * 9.81
    return T.reshape(n, 9), motion, body, gravity


def newton_euler(T, motion, body, gravity):
    """[f; τ] and −[W; r_c × W] by hand (the runtime's formulas before codegen/joints.py)."""
    T = T.reshape(3, 3)
    w, a, alpha = motion[:3], motion[3:6], motion[6:]
    m, c, inertia = body[0], body[1:4], body[4:].reshape(3, 3)
    rc, J = T @ c, T @ inertia @ T.T
    S = skew(rc)
    M = np.block([[m * np.eye(3), -m * S], [m * S, J - m * S @ S]])
    centripetal = m * np.cross(w, np.cross(w, rc))
    g = np.concatenate([centripetal, np.cross(rc, centripetal) + np.cross(w, J @ w)])
    W = m * gravity
    return M @ np.concatenate([a, alpha]) + g, -np.concatenate([W, np.cross(rc, W)]), M


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_joint_body_against_newton_euler_and_differences(backend):
    ks = load_kernels(backend, "default")
    T, motion, body, gravity = body_inputs()
    force, mass, gyroscopic, gravity_stiffness = ks.joint_body(T, motion, body, gravity)
    (inertia_stiffness,) = ks.joint_body_inertia_stiffness(T, motion, body, gravity)
    eps = 1e-6
    for b in range(len(T)):
        inertia_part, weight_part, M = newton_euler(T[b], motion[b], body[b], gravity[b])
        assert np.allclose(force[b], inertia_part + weight_part, rtol=1e-12, atol=1e-12)
        assert np.allclose(mass[b], M, rtol=1e-12, atol=1e-12)
        for k in range(3):  # ∂/∂ω, ∂/∂π by central differences
            step = np.eye(3)[k] * eps
            up, down = motion[b].copy(), motion[b].copy()
            up[k] += eps
            down[k] -= eps
            fd = (newton_euler(T[b], up, body[b], gravity[b])[0] - newton_euler(T[b], down, body[b], gravity[b])[0])
            assert np.allclose(gyroscopic[b][:, 3 + k], fd / (2 * eps), atol=1e-7 * max(1.0, np.abs(fd).max() / eps))
            turned_up = (expm_so3(step) @ T[b].reshape(3, 3)).ravel()
            turned_down = (expm_so3(-step) @ T[b].reshape(3, 3)).ravel()
            i_up, w_up, _ = newton_euler(turned_up, motion[b], body[b], gravity[b])
            i_down, w_down, _ = newton_euler(turned_down, motion[b], body[b], gravity[b])
            scale = max(1.0, np.abs(i_up).max())
            assert np.allclose(gravity_stiffness[b][:, 3 + k], (w_up - w_down) / (2 * eps), atol=1e-7 * scale)
            assert np.allclose(inertia_stiffness[b][:, 3 + k], (i_up - i_down) / (2 * eps), atol=1e-7 * scale)
        assert not np.any(gyroscopic[b][:, :3]) and not np.any(gravity_stiffness[b][:, :3])


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_joint_body_derivative_by_the_centre_of_mass_against_differences(backend):
    """joint_body_D_com, ∂([f; τ] − [W; r_c × W])/∂c, against central differences of the hand
    Newton–Euler rows in c (a polynomial of degree two in c: the difference has no truncation error;
    measured ≤ 1.8e-13 of the row's scale with a step of 1e-3, the round-off of the difference)."""
    ks = load_kernels(backend, "default")
    T, motion, body, gravity = body_inputs()
    (by_com,) = ks.joint_body_D_com(T, motion, body, gravity)
    by_com = np.asarray(by_com).reshape(len(T), 6, 3)
    eps = 1e-3
    worst = 0.0
    for b in range(len(T)):
        for k in range(3):
            up, down = body[b].copy(), body[b].copy()
            up[1 + k] += eps
            down[1 + k] -= eps
            fd = (sum(newton_euler(T[b], motion[b], up, gravity[b])[:2])
                  - sum(newton_euler(T[b], motion[b], down, gravity[b])[:2])) / (2 * eps)
            scale = max(1.0, np.abs(sum(newton_euler(T[b], motion[b], up, gravity[b])[:2])).max())
            worst = max(worst, np.abs(by_com[b][:, k] - fd).max() / scale)
    assert worst <= 1e-11, worst


def load_reference(T, r, values, R, velocity):
    """The load's residual rows and power by hand."""
    T, R = T.reshape(3, 3), R.reshape(3, 3)
    rg = T @ r
    F, Mo = R @ values[:3], R @ values[3:]
    force = -np.concatenate([F, np.cross(rg, F) + Mo])
    return force, F @ (velocity[:3] + np.cross(velocity[3:], rg)) + Mo @ velocity[3:]


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_point_load_against_differences(backend):
    ks = load_kernels(backend, "default")
    n = 5
    T = np.array([rotation() for _ in range(n)]).reshape(n, 9)
    R = np.array([rotation() for _ in range(n)]).reshape(n, 9)
    r, values, velocity = RNG.normal(size=(n, 3)), RNG.normal(size=(n, 6)), RNG.normal(size=(n, 6))
    force, power, by_node, by_frame = ks.point_load(T, r, values, R, velocity)
    eps = 1e-6
    for j in range(n):
        f, p = load_reference(T[j], r[j], values[j], R[j], velocity[j])
        assert np.allclose(force[j], f, atol=1e-12) and np.isclose(power[j], p, atol=1e-12)
        for k in range(3):
            step = np.eye(3)[k] * eps
            up = load_reference((expm_so3(step) @ T[j].reshape(3, 3)).ravel(), r[j], values[j], R[j], velocity[j])[0]
            down = load_reference((expm_so3(-step) @ T[j].reshape(3, 3)).ravel(), r[j], values[j], R[j],
                                  velocity[j])[0]
            assert np.allclose(by_node[j][:, k], (up - down) / (2 * eps), atol=1e-8)
            up = load_reference(T[j], r[j], values[j], (expm_so3(step) @ R[j].reshape(3, 3)).ravel(), velocity[j])[0]
            down = load_reference(T[j], r[j], values[j], (expm_so3(-step) @ R[j].reshape(3, 3)).ravel(),
                                  velocity[j])[0]
            assert np.allclose(by_frame[j][:, k], (up - down) / (2 * eps), atol=1e-8)


FRAME = """\
title: {title}
sections:
  s: {{EA: 2.0e5, EIy: 40.0, EIz: 60.0, GJ: 30.0, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  elbow: {{at: [1, 0, 0], mass: 0.0}}
  tip: {{at: [1, 0.8, 0.3], mass: 0.5, inertia: [0.01, 0.01, 0.01]}}
beams:
  column: {{from: base, to: elbow, section: s, elements: 4}}
  arm: {{from: elbow, to: tip, section: s, elements: 4}}
loads:
  - {{at: tip, force: [0.0, 0.0, -3.0], moment: [0.4, 0.0, 0.0], frame: {frame}}}
solve: {{analysis: static, steps: 4}}
output:
  probes:
    tip_z: {{point: tip, quantity: position, component: z}}
"""


def test_follower_loads_converge_like_fixed_loads(tmp_path):
    """Issue 22: with the exact tangent of a load that turns with its body, Newton takes as many
    iterations as under the same load fixed in space (it took 6.8 against 4.0 per step before)."""
    import latdyn

    iterations = {}
    for frame in ("global", "tip"):
        path = tmp_path / f"{frame}.yaml"
        path.write_text(FRAME.format(title=f"frame under a {frame} load", frame=frame))
        result = latdyn.run(latdyn.load_scene(path), tmp_path / f"{frame}_out")
        iterations[frame] = result.summary["newton_iterations"] / result.summary["steps"]
    assert iterations["tip"] <= iterations["global"] + 0.5, iterations


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_hinge_force_against_differences(backend):
    """f = k s + c θ̇ − λτ with laws in θ and θ̇: the kernel's ∂f/∂θ and ∂f/∂θ̇ from the laws'
    values and derivatives equal central differences of f, and the powers are −k s θ̇ and λ τ θ̇, and
    the damper's dissipation c θ̇²."""
    ks = load_kernels(backend, "default")

    def laws(theta, rate):  # smooth laws with their partial derivatives
        k = (2.0 + np.sin(theta) * rate, np.cos(theta) * rate, np.sin(theta))
        c = (0.3 + 0.1 * theta**2 + 0.05 * rate**2, 0.2 * theta, 0.1 * rate)
        tau = (np.exp(0.3 * theta) - rate, 0.3 * np.exp(0.3 * theta), -1.0)
        return np.array([*k, *c, *tau])

    def force(theta, rate, rest, factor):
        k, c, tau = laws(theta, rate)[[0, 3, 6]]
        return k * (theta - rest) + c * rate - factor * tau

    n = 6
    states = np.column_stack([RNG.normal(size=n), RNG.normal(size=n), RNG.normal(size=n), RNG.uniform(0.2, 1.5, n)])
    values = np.array([laws(th, rt) for th, rt, _, _ in states])
    none = np.tile([0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1.0], (n, 1))  # no compliant stop, no friction
    f, d_theta, d_rate, spring_torque, applied_torque, damper_torque, contact_energy = ks.hinge_force(states, values,
                                                                                                       none)
    assert not np.any(contact_energy)
    eps = 1e-6
    for j, (theta, rate, rest, factor) in enumerate(states):
        assert np.isclose(f[j], force(theta, rate, rest, factor), rtol=1e-13, atol=1e-13)
        fd_theta = (force(theta + eps, rate, rest, factor) - force(theta - eps, rate, rest, factor)) / (2 * eps)
        fd_rate = (force(theta, rate + eps, rest, factor) - force(theta, rate - eps, rest, factor)) / (2 * eps)
        assert np.isclose(d_theta[j], fd_theta, rtol=1e-7, atol=1e-8)
        assert np.isclose(d_rate[j], fd_rate, rtol=1e-7, atol=1e-8)
        # the torques whose work the energy balance integrates over Δθ (progress.hinge_work): with the
        # residual they make up, f = k s + c θ̇ − λ τ
        assert np.isclose(spring_torque[j], values[j, 0] * (theta - rest), rtol=1e-13, atol=1e-13)
        assert np.isclose(applied_torque[j], factor * values[j, 6], rtol=1e-13, atol=1e-13)
        assert np.isclose(damper_torque[j], values[j, 3] * rate, rtol=1e-13, atol=1e-13)
        assert np.isclose(spring_torque[j] + damper_torque[j] - applied_torque[j], f[j], rtol=1e-13, atol=1e-13)


def contact_reference(theta, rate, row):
    """The force, potential and dissipative part of the force of a compliant stop and friction, restated from
    SCENE.md "Contact and friction at joints" (Hunt–Crossley k δⁿ + c δⁿ δ̇ clipped at 0; the slip law:
    Coulomb, Stribeck, viscous, regularised below the stick rate: docs/contact.md)."""
    lo, hi, k, n, c, fc, fs, inverse, smooth, cv, v0 = row
    force = potential = dissipative = 0.0
    for depth, depth_rate, side in ((theta - hi, rate, 1.0), (lo - theta, -rate, -1.0)):
        if depth > 0:
            hc = max(k * depth**n + c * depth**n * depth_rate, 0.0)
            force += side * hc
            potential += k * depth ** (n + 1) / (n + 1)
            dissipative += side * (hc - k * depth**n)  # the damping and the clip: all but k δⁿ
    decay = np.exp(-(rate * inverse) ** 2) if smooth else 0.0  # v_s = 0: F_s only as the breakaway (events)
    y = min(max(rate / v0, -1.0), 1.0)
    friction = (fc + (fs - fc) * decay) * y * (2 - abs(y)) + cv * rate
    return force + friction, potential, dissipative + friction


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_contact_and_friction_against_differences(backend):
    """The generated compliant stop (Hunt–Crossley, n = 1, 1.5, 2.3, with and without damping, the
    clip at 0 of a fast separation) and friction (Coulomb, Stribeck with v_s > 0, F_s only a
    breakaway level with v_s = 0, viscous): the force, potential and dissipation equal the restatement
    above, its ∂f/∂θ and ∂f/∂θ̇ central differences, away from the kinks (δ = 0, |θ̇| = v₀, the
    clip), where the law has no derivative."""
    ks = load_kernels(backend, "default")
    rows, states = [], []
    for n_exp, c, inverse, smooth in ((1.0, 0.0, 0.0, 0.0), (1.5, 3.0, 2.0, 1.0), (2.3, 40.0, 0.0, 0.0)):
        for theta in (-0.73, -0.41, 0.05, 0.27, 0.52):
            for rate in (-2.0, -0.3, -0.0004, 0.0007, 0.0015, 0.4, 1.9):
                rows.append([-0.4, 0.25, 70.0, n_exp, c, 0.8, 1.3, inverse, smooth, 0.15, 1e-3])
                states.append([theta, rate, 0.1, 1.0])
    rows, states = np.array(rows), np.array(states)
    laws = np.tile([2.0, 0, 0, 0.1, 0, 0, 0, 0, 0], (len(rows), 1))
    f, d_theta, d_rate, spring_torque, applied_torque, damper_torque, energy = ks.hinge_force(states, laws, rows)
    spring = 2.0 * (states[:, 0] - 0.1) + 0.1 * states[:, 1]
    clipped = 0
    for j, ((theta, rate, _, _), row) in enumerate(zip(states, rows)):
        force, potential, dissipative = contact_reference(theta, rate, row)
        lo, hi, k, n = row[:4]
        depth, depth_rate = (theta - hi, rate) if theta > hi else (lo - theta, -rate)
        if depth > 0 and k * depth**n + row[4] * depth**n * depth_rate < 0.0:  # a fast separation: clipped
            clipped += 1
            friction = contact_reference(0.5 * (lo + hi), rate, row)[0]  # inside the limits: friction alone
            assert abs(f[j] - spring[j] - friction) <= 1e-13 * max(1.0, abs(friction))  # the stop pushes 0
        assert np.isclose(f[j] - spring[j], force, rtol=1e-13, atol=1e-13)
        assert np.isclose(energy[j], potential, rtol=1e-13, atol=1e-15)
        # the dissipative torque (its work over Δθ is declared dissipation): the damper's c θ̇, the stop's
        # damping and clip and the friction, dissipating (power ≥ 0); the rest of f is the springs'
        assert np.isclose(damper_torque[j] - 0.1 * rate, dissipative, rtol=1e-12, atol=1e-13)
        assert dissipative * rate >= 0.0
        assert applied_torque[j] == 0.0
        assert np.isclose(spring_torque[j], 2.0 * (theta - 0.1), rtol=1e-13, atol=1e-13)
        conservative = force - dissipative  # the stop's k δⁿ
        assert np.isclose(f[j] - spring_torque[j] - damper_torque[j], conservative, rtol=1e-12, atol=1e-12)
        eps_theta, eps_rate = 1e-7, 1e-7 * min(1.0, abs(rate))
        fd_theta = (contact_reference(theta + eps_theta, rate, row)[0]
                    - contact_reference(theta - eps_theta, rate, row)[0]) / (2 * eps_theta)
        fd_rate = (contact_reference(theta, rate + eps_rate, row)[0]
                   - contact_reference(theta, rate - eps_rate, row)[0]) / (2 * eps_rate)
        assert np.isclose(d_theta[j] - 2.0, fd_theta, rtol=1e-6, atol=1e-6)
        assert np.isclose(d_rate[j] - 0.1, fd_rate, rtol=1e-6, atol=1e-5)
    # the clip of a fast separation (n = 2.3, c = 40: θ = 0.27, 0.52 at the rate −2.0; −0.41, −0.73 at 1.9)
    assert clipped == 4


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_so3_exp_against_the_matrix_exponential(backend):
    """The generated exponential of SO(3) (one source for the Python and the C configuration update)
    equals scipy's matrix exponential of skew(w) to round-off from 1e-12 rad to π, across its switch
    from the Taylor polynomials to the closed forms (θ = 0.1), and Rodrigues' closed form at the large
    angles a prescribed spin accumulates (to 10³ rad); it stays orthogonal."""
    from scipy.linalg import expm

    ks = load_kernels(backend, "default")
    for angle in (0.0, 1e-12, 1e-6, 1e-3, 0.0999999, 0.1, 0.1000001, 0.7, 2.0, 3.14, 31.7, 123.4, 987.6):
        w = RNG.normal(size=(8, 3))
        w *= angle / np.linalg.norm(w, axis=1)[:, None]
        (R,) = ks.so3_exp(w)
        for j in range(len(w)):
            if angle <= 3.14:
                reference = expm(skew(w[j]))
            else:
                W, theta = skew(w[j] / angle), np.linalg.norm(w[j])
                reference = np.eye(3) + np.sin(theta) * W + (1 - np.cos(theta)) * W @ W
            assert np.abs(R[j] - reference).max() < 1e-14 * max(1.0, angle)
            assert np.abs(R[j] @ R[j].T - np.eye(3)).max() < 4e-15


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_so3_dexp_is_the_derivative_of_the_exponential(backend):
    """The generated tangent operator J = dexp(w) (one source for the Python and the C sensitivity step):
    exp(skew(w + ε δ)) exp(skew w)ᵀ = exp(skew(ε J δ)) + O(ε²), so J δ is the central difference of
    log(exp(skew(w + ε δ)) exp(skew w)ᵀ) in ε, read as a rotation vector; checked across the switch from the
    Taylor polynomials to the closed forms (θ = 0.1) and at large angles, to 1e-8 of |δ| (the difference's
    own error at ε = 1e-5); and J = I + b W + c W² with b, c written out to round-off."""
    from scipy.spatial.transform import Rotation

    ks = load_kernels(backend, "default")
    for angle in (0.0, 1e-6, 1e-3, 0.0999999, 0.1, 0.1000001, 0.7, 2.0, 3.0, 31.7):
        w = RNG.normal(size=(6, 3))
        w *= angle / np.linalg.norm(w, axis=1)[:, None]
        (J,) = ks.so3_dexp(w)
        J = np.asarray(J).reshape(-1, 3, 3)
        for j in range(len(w)):
            delta, eps = RNG.normal(size=3), 1e-5
            turned = [Rotation.from_matrix(expm_so3(w[j] + s * eps * delta) @ expm_so3(w[j]).T).as_rotvec()
                      for s in (1.0, -1.0)]
            assert np.abs(J[j] @ delta - (turned[0] - turned[1]) / (2 * eps)).max() < 1e-8 * np.linalg.norm(delta)
            theta, W = np.linalg.norm(w[j]), skew(w[j])
            if theta > 0.1:
                b, c = (1 - np.cos(theta)) / theta ** 2, (theta - np.sin(theta)) / theta ** 3
                assert np.abs(J[j] - (np.eye(3) + b * W + c * W @ W)).max() < 1e-13 * max(1.0, theta)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_so3_log_increment_is_the_logarithm_of_the_turn(backend):
    """The generated log(T_{n+1} T_nᵀ) (one source for the Python and the C drive work: the element's branch-free
    log map, formulation.log_scale): for a turn w of a random rotation T_n, T_{n+1} = exp(skew w) T_n, it gives w back
    to round-off from 1e-12 rad (absolute: the round-off of T_{n+1} T_nᵀ's skew part), across the log map's switch
    from its Taylor polynomial to the closed form (1 − cos θ = 0.1, θ = 0.451), and towards π to 4e-15/(π − θ)²
    (the log map's conditioning in x = 1 − cos θ there: 1.3e-9 measured at π − 1e-3); past π it takes the branch of
    angle < π, w − 2π w/|w| (a turn of 3.3 rad read as 2.98 rad about the opposite axis); exp(log(R)) = R."""
    ks = load_kernels(backend, "default")
    switch = np.arccos(0.9)
    for angle in (0.0, 1e-12, 1e-6, 1e-3, 0.2, switch * (1 - 1e-7), switch, switch * (1 + 1e-7), 1.0, 2.0, 3.0,
                  np.pi - 1e-3, 3.3, 5.0):
        w = RNG.normal(size=(8, 3))
        w *= angle / np.linalg.norm(w, axis=1)[:, None]
        before = np.array([rotation() for _ in range(len(w))])
        after = expm_so3(w) @ before
        (phi,) = ks.so3_log_increment(before.reshape(-1, 9), after.reshape(-1, 9))
        phi = np.asarray(phi).reshape(-1, 3)
        expected = w if angle < np.pi else w - 2 * np.pi * w / angle
        tolerance = 2e-15 * max(1.0, angle) + 4e-15 / (np.pi - min(angle, 2 * np.pi - angle)) ** 2
        assert np.abs(phi - expected).max() < tolerance, angle
        assert np.abs(expm_so3(phi) - after @ np.transpose(before, (0, 2, 1))).max() < tolerance, angle
