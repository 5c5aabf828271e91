"""The generated CR-4402 element against finite differences, invariances and patch values.

Every derivative kernel is checked by central differences, with rotations
perturbed through the exponential map (T ← exp(skew h e_k) T), at random
configurations with large rotations (> 90°), non-zero hinge angles and offsets.
"""
from __future__ import annotations

import numpy as np
import pytest

import element_states as es
from latdyn.kernels import load_kernels

H = 1e-6
RELATIVE = 1e-6  # error allowed, relative to the norm of the checked Jacobian


@pytest.fixture(scope="module", params=["default", "no_stiffening"])
def kernels(request):
    return load_kernels(backend="auto", variant=request.param)


def states(seed, count=3, **kw):
    rng = np.random.default_rng(seed)
    return [es.random_state(rng, **kw) for _ in range(count)]


def unit(k, n=14):
    e = np.zeros(n)
    e[k] = 1.0
    return e


def central(f, state, k):
    return (f(state.moved(H * unit(k))) - f(state.moved(-H * unit(k)))) / (2 * H)


def assert_close(actual, expected, what):
    scale = max(np.linalg.norm(expected), 1e-300)
    error = np.linalg.norm(actual - expected) / scale
    assert error <= RELATIVE, f"{what}: relative error {error:.2e}"


def test_internal_force_is_gradient_of_strain_energy(kernels):
    for s in states(1):
        energy = lambda st: kernels.beam_strain_energy(st.geometry(), st.section[None])[0][0]  # noqa: E731
        (force,) = kernels.beam_internal_force(s.geometry(), s.section[None])
        numeric = np.array([central(energy, s, k) for k in range(14)])
        assert_close(force[0], numeric, "F_i vs ∂U/∂q")


def test_tangent_is_derivative_of_internal_force(kernels):
    for s in states(2):
        force = lambda st: kernels.beam_internal_force(st.geometry(), st.section[None])[0][0]  # noqa: E731
        _, tangent = kernels.beam_internal_force_D_q(s.geometry(), s.section[None])
        numeric = np.column_stack([central(force, s, k) for k in range(14)])
        assert_close(tangent[0], numeric, "∂F_i/∂q")


def test_quadratic_velocity_derivative(kernels):
    rng = np.random.default_rng(3)
    for s in states(3):
        qdot = rng.normal(size=14)
        g = lambda v: kernels.beam_quadratic_velocity(s.geometry(), v[None], s.section[None])[0][0]  # noqa: E731
        (exact,) = kernels.beam_quadratic_velocity_D_qdot(s.geometry(), qdot[None], s.section[None])
        numeric = np.column_stack([(g(qdot + H * unit(k)) - g(qdot - H * unit(k))) / (2 * H) for k in range(14)])
        assert_close(exact[0], numeric, "∂g/∂q̇")


def test_dynamics_kernel_matches_separate_kernels(kernels):
    rng = np.random.default_rng(4)
    s = states(4, count=1)[0]
    qdot = rng.normal(size=(1, 14))
    geometry, section = s.geometry(), s.section[None]
    combined = kernels.beam_dynamics(geometry, qdot, section)
    separate = [kernels.beam_internal_force(geometry, section)[0],
                kernels.beam_internal_force_D_q(geometry, section)[1],
                kernels.beam_mass_matrix(geometry, section)[0],
                kernels.beam_quadratic_velocity(geometry, qdot, section)[0],
                kernels.beam_quadratic_velocity_D_qdot(geometry, qdot, section)[0]]
    for a, b in zip(combined, separate):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())


def test_kinetic_energy_and_power_identity(kernels):
    """½q̇ᵀMq̇ equals the kinetic-energy kernel, and dT/dt = q̇·g along q̈ = 0."""
    rng = np.random.default_rng(5)
    for s in states(5):
        qdot = rng.normal(size=14)
        (M,) = kernels.beam_mass_matrix(s.geometry(), s.section[None])
        T = lambda st: kernels.beam_kinetic_energy(st.geometry(), qdot[None], st.section[None])[0][0]  # noqa: E731
        assert T(s) == pytest.approx(0.5 * qdot @ M[0] @ qdot, rel=1e-10)
        np.testing.assert_allclose(M[0], M[0].T, atol=1e-12 * np.abs(M[0]).max())
        (g,) = kernels.beam_quadratic_velocity(s.geometry(), qdot[None], s.section[None])
        rate = (T(s.moved(H * qdot)) - T(s.moved(-H * qdot))) / (2 * H)
        assert rate == pytest.approx(qdot @ g[0], rel=1e-6, abs=1e-9 * abs(T(s)))


def test_quadratic_velocity_is_lagrangian_for_true_coordinates(kernels):
    """With only translations and hinge angles moving, g = Ṁq̇ − ½∂(q̇ᵀMq̇)/∂q on those coordinates."""
    rng = np.random.default_rng(6)
    true = [0, 1, 2, 6, 7, 8, 9, 13]
    for s in states(6):
        qdot = np.zeros(14)
        qdot[true] = rng.normal(size=len(true))
        M = lambda st: kernels.beam_mass_matrix(st.geometry(), st.section[None])[0][0]  # noqa: E731
        Mdot = (M(s.moved(H * qdot)) - M(s.moved(-H * qdot))) / (2 * H)
        T = lambda st: 0.5 * qdot @ M(st) @ qdot  # noqa: E731
        dT = np.array([central(T, s, k) for k in range(14)])
        lagrange = Mdot @ qdot - dT
        (g,) = kernels.beam_quadratic_velocity(s.geometry(), qdot[None], s.section[None])
        assert_close(g[0][true], lagrange[true], "g vs Lagrange")


def test_rigid_motion_is_strain_free(kernels):
    rng = np.random.default_rng(7)
    for _ in range(3):
        s = es.undeformed(rng)
        # any rigid translation and rotation of both ends together
        rotation = es.expm_so3(rng.normal(size=3) * 2.0)
        shift = rng.normal(size=3)
        for end in (s.end1, s.end2):
            end.x = rotation @ end.x + shift
            end.body = rotation @ end.body
        psi, _ = kernels.beam_deformation(s.geometry(), s.section[None])
        assert np.max(np.abs(psi)) < 1e-12
        (force,) = kernels.beam_internal_force(s.geometry(), s.section[None])
        assert np.max(np.abs(force)) < 1e-9


def test_rigid_virtual_motion_does_no_internal_work(kernels):
    for s in states(8):
        (force,) = kernels.beam_internal_force(s.geometry(), s.section[None])
        g = s.geometry()[0]
        x1, x2 = g[0:3], g[3:6]
        for k in range(3):
            c = unit(k, 3)
            translation = np.concatenate([c, 0 * c, [0], c, 0 * c, [0]])
            rotation = np.concatenate([np.cross(c, x1), c, [0], np.cross(c, x2), c, [0]])
            scale = np.linalg.norm(force) * (1 + np.linalg.norm(x1) + np.linalg.norm(x2))
            assert abs(force[0] @ translation) <= 1e-10 * scale
            assert abs(force[0] @ rotation) <= 1e-10 * scale


def _straight_x(length, section):
    """An undeformed element along global x between plain nodes (no offsets, no hinges)."""
    frame = np.eye(3)
    return es.ElementState(
        es.End(np.zeros(3), np.eye(3), np.zeros(3), np.zeros(3), frame),
        es.End(np.array([length, 0.0, 0.0]), np.eye(3), np.zeros(3), np.zeros(3), frame),
        np.array(section, float),
    )


def test_patch_stiffness_values(kernels):
    L, EA, EIy, EIz, GJ = 2.0, 7.0e3, 11.0, 13.0, 5.0
    s = _straight_x(L, [L, EA, EIy, EIz, GJ, 1.0, 0.0, 0.0])
    _, K = kernels.beam_internal_force_D_q(s.geometry(), s.section[None])
    K = K[0]
    rz1, rz2, ry1, ry2, rx1, rx2, ux1, ux2 = 5, 12, 4, 11, 3, 10, 0, 7  # columns of q^e (Eq. 59)
    # bending about z: moments at the ends for unit end rotations (transverse displacements fixed)
    assert K[rz1, rz1] == pytest.approx(4 * EIz / L, rel=1e-10)
    assert K[rz1, rz2] == pytest.approx(2 * EIz / L, rel=1e-10)
    assert K[ry1, ry1] == pytest.approx(4 * EIy / L, rel=1e-10)
    assert K[ry2, ry1] == pytest.approx(2 * EIy / L, rel=1e-10)
    assert K[ux1, ux1] == pytest.approx(EA / L, rel=1e-10)
    assert K[ux1, ux2] == pytest.approx(-EA / L, rel=1e-10)
    assert K[rx2, rx2] == pytest.approx(GJ / L, rel=1e-10)
    assert K[rx1, rx2] == pytest.approx(-GJ / L, rel=1e-10)
    # transverse: 12EI/L³
    assert K[1, 1] == pytest.approx(12 * EIz / L**3, rel=1e-10)
    assert K[2, 2] == pytest.approx(12 * EIy / L**3, rel=1e-10)


def test_mass_at_rest_is_consistent_hermite_mass(kernels):
    L, rhoA = 2.0, 3.0
    s = _straight_x(L, [L, 1.0, 1.0, 1.0, 1.0, rhoA, 0.0, 0.0])
    (M,) = kernels.beam_mass_matrix(s.geometry(), s.section[None])
    M = M[0]
    c = rhoA * L / 420
    # transverse y with rotations about z: the standard consistent Hermite matrix
    idx = [1, 5, 8, 12]
    expected = c * np.array([[156, 22 * L, 54, -13 * L], [22 * L, 4 * L * L, 13 * L, -3 * L * L],
                             [54, 13 * L, 156, -22 * L], [-13 * L, -3 * L * L, -22 * L, 4 * L * L]])
    np.testing.assert_allclose(M[np.ix_(idx, idx)], expected, rtol=1e-10, atol=1e-12)
    # axial: linear interpolation, ρAL/6 [2 1; 1 2]
    np.testing.assert_allclose(M[np.ix_([0, 7], [0, 7])], rhoA * L / 6 * np.array([[2, 1], [1, 2]]), rtol=1e-10)


def test_rigid_spin_about_node_one(kernels):
    """½ṗᵀMṗ of a rigid spin about node 1 equals ½(ρA L³/3)ω²."""
    L, rhoA, omega = 1.5, 2.0, 0.7
    s = _straight_x(L, [L, 1.0, 1.0, 1.0, 1.0, rhoA, 0.0, 0.0])
    qdot = np.zeros(14)
    qdot[5] = qdot[12] = omega  # ω about z at both nodes
    qdot[8] = omega * L  # v2 = ω × (L, 0, 0)
    (T,) = kernels.beam_kinetic_energy(s.geometry(), qdot[None], s.section[None])
    assert T[0] == pytest.approx(0.5 * rhoA * L**3 / 3 * omega**2, rel=1e-12)


def test_gravity_load_and_potential(kernels):
    gravity = np.array([[0.3, -9.81, 1.2]])
    for s in states(9):
        force, potential, centre = kernels.beam_gravity(s.geometry(), s.section[None], gravity)
        V = lambda st: kernels.beam_gravity(st.geometry(), st.section[None], gravity)[1][0]  # noqa: E731
        numeric = np.array([central(V, s, k) for k in range(14)])
        assert_close(-force[0], numeric, "gravity load vs −∂V/∂q")
