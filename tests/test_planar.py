"""The planar model (``solve.planar``): generated planar kernels and in-plane coordinates.

Kernels: at a configuration of a coordinate plane, the planar variant's in-plane rows and
columns equal the 3D element's (codegen/formulation.py ``Plane``), its out-of-plane ones are
zero, and its derivatives agree with finite differences along the in-plane coordinates.
Runtime: a scene that stays in a plane gives the same answer with ``planar: auto`` as with
``planar: off``, in all three coordinate planes, with its out-of-plane coordinates removed.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import element_states as es
from latdyn.kernels import PLANE_SUFFIXES, known_variants, load_kernels, planar_variant

FORMULATIONS = ("default", "cr4402", "no_stiffening")
H = 1e-6


def in_plane_coordinates(normal: int) -> np.ndarray:
    """Indices of q^e that stay in the plane: d_i, d_j, π_n, θ per end."""
    i, j = (normal + 1) % 3, (normal + 2) % 3
    return np.array([base + k for base in (0, 7) for k in (i, j, 3 + normal, 6)])


def planar_state(rng, normal: int, deformation: float = 0.3, hinges=(True, True)):
    """A random element state in the plane x_normal = c: bodies turned about n, in-plane offsets,
    hinge axes ±n (or none), nodal frames with local z = +n, local rotations ≈ ``deformation`` rad."""
    i, j = (normal + 1) % 3, (normal + 2) % 3
    n = np.zeros(3)
    n[normal] = 1.0

    def in_plane(vector2):
        v = np.zeros(3)
        v[i], v[j] = vector2
        return v

    level = rng.normal()
    alpha = rng.uniform(-np.pi, np.pi)
    direction = in_plane((np.cos(alpha), np.sin(alpha)))
    frame0 = np.column_stack([direction, np.cross(n, direction), n])
    length = 1.3
    g1 = in_plane(rng.normal(size=2)) + level * n
    g2 = g1 + length * direction + in_plane(rng.normal(size=2)) * 0.1 * deformation
    ends = []
    for g, hinge in zip((g1, g2), hinges):
        turn = rng.uniform(-np.pi, np.pi)
        body = es.expm_so3(turn * n)
        offset = in_plane(rng.normal(size=2) * 0.3)  # body axes: turning about n keeps it in the plane
        axis = n * rng.choice([-1.0, 1.0]) if hinge else np.zeros(3)
        theta = rng.normal() * 0.7 if hinge else 0.0
        # the nodal frame body·R(a, θ)·E0 = frame0 turned by a small local rotation
        local = rng.normal() * deformation
        E0 = es.expm_so3(-axis * theta) @ body.T @ es.expm_so3(local * n) @ frame0
        ends.append(es.End(g - body @ offset, body, offset, axis, E0, theta))
    section = np.array([length, 3.0e3, 20.0, 30.0, 15.0, 1.3, 0.02, 0.03])
    return es.ElementState(ends[0], ends[1], section)


def planar_velocity(rng, normal):
    qdot = np.zeros(14)
    qdot[in_plane_coordinates(normal)] = rng.normal(size=8)
    return qdot


CASES = [(f, normal) for f in FORMULATIONS for normal in PLANE_SUFFIXES]


def test_every_formulation_has_planar_variants():
    variants = known_variants()
    for formulation, normal in CASES:
        assert planar_variant(formulation, normal) in variants


@pytest.fixture(scope="module", params=CASES, ids=[f"{f}_{PLANE_SUFFIXES[n]}" for f, n in CASES])
def pair(request):
    formulation, normal = request.param
    return normal, load_kernels("numpy", formulation), load_kernels("numpy", planar_variant(formulation, normal))


def test_planar_kernels_equal_the_3d_element_in_the_plane(pair):
    normal, full, planar = pair
    rng = np.random.default_rng(normal)
    keep = in_plane_coordinates(normal)
    out = np.setdiff1d(np.arange(14), keep)
    for hinges in ((True, True), (False, True), (False, False)):
        s = planar_state(rng, normal, hinges=hinges)
        geometry, section = s.geometry(), s.section[None]
        qdot = planar_velocity(rng, normal)[None]
        gravity = np.zeros((1, 3))
        gravity[0, (normal + 1) % 3], gravity[0, (normal + 2) % 3] = rng.normal(size=2)
        pairs = [
            (full.beam_deformation(geometry, section), planar.beam_deformation(geometry, section), None),
            (full.beam_strain_energy(geometry, section), planar.beam_strain_energy(geometry, section), None),
            (full.beam_internal_force_D_q(geometry, section), planar.beam_internal_force_D_q(geometry, section),
             "vector-matrix"),
            (full.beam_mass_matrix(geometry, section), planar.beam_mass_matrix(geometry, section), "matrix"),
            (full.beam_quadratic_velocity(geometry, qdot, section),
             planar.beam_quadratic_velocity(geometry, qdot, section), "vector"),
            (full.beam_quadratic_velocity_D_qdot(geometry, qdot, section),
             planar.beam_quadratic_velocity_D_qdot(geometry, qdot, section), "matrix"),
            (full.beam_kinetic_energy(geometry, qdot, section), planar.beam_kinetic_energy(geometry, qdot, section),
             None),
            (full.beam_gravity(geometry, section, gravity), planar.beam_gravity(geometry, section, gravity),
             "vector"),
        ]
        for expected_outputs, actual_outputs, kind in pairs:
            for k, (expected, actual) in enumerate(zip(expected_outputs, actual_outputs)):
                expected, actual = expected[0], actual[0]
                shape = "matrix" if (kind == "matrix" or (kind == "vector-matrix" and k == 1)) else (
                    "vector" if kind else None)
                scale = max(np.abs(expected).max(), 1e-300)
                if shape == "matrix":
                    np.testing.assert_allclose(actual[np.ix_(keep, keep)], expected[np.ix_(keep, keep)],
                                               rtol=0, atol=1e-11 * scale)
                    assert not np.any(actual[out, :]) and not np.any(actual[:, out])
                elif shape == "vector" and expected.shape == (14,):
                    np.testing.assert_allclose(actual[keep], expected[keep], rtol=0, atol=1e-11 * scale)
                    assert not np.any(actual[out])
                else:
                    np.testing.assert_allclose(actual, expected, rtol=0, atol=1e-11 * scale)


def test_planar_derivatives_against_finite_differences(pair):
    """F = ∂U/∂q, ∂F/∂q and ∂g/∂q̇ along the in-plane coordinates (the planar kernels are derived
    with the out-of-plane values put in before differentiation)."""
    normal, _, planar = pair
    rng = np.random.default_rng(10 + normal)
    keep = in_plane_coordinates(normal)
    for _ in range(3):
        s = planar_state(rng, normal, deformation=0.5)
        section = s.section[None]

        def moved(k, h):
            dq = np.zeros(14)
            dq[k] = h
            return s.moved(dq).geometry()

        energy = lambda g: planar.beam_strain_energy(g, section)[0][0]  # noqa: E731
        force, tangent = (x[0] for x in planar.beam_internal_force_D_q(s.geometry(), section))
        numeric_force = np.array([(energy(moved(k, H)) - energy(moved(k, -H))) / (2 * H) for k in keep])
        np.testing.assert_allclose(force[keep], numeric_force, rtol=0, atol=1e-6 * np.abs(force).max())
        internal = lambda g: planar.beam_internal_force(g, section)[0][0]  # noqa: E731
        numeric_tangent = np.column_stack([(internal(moved(k, H)) - internal(moved(k, -H))) / (2 * H)
                                           for k in keep])
        np.testing.assert_allclose(tangent[:, keep], numeric_tangent, rtol=0, atol=1e-6 * np.abs(tangent).max())
        qdot = planar_velocity(rng, normal)
        g = lambda v: planar.beam_quadratic_velocity(s.geometry(), v[None], section)[0][0]  # noqa: E731
        (exact,) = planar.beam_quadratic_velocity_D_qdot(s.geometry(), qdot[None], section)
        unit = np.eye(14)
        numeric = np.column_stack([(g(qdot + H * unit[k]) - g(qdot - H * unit[k])) / (2 * H) for k in keep])
        np.testing.assert_allclose(exact[0][:, keep], numeric, rtol=0, atol=1e-6 * np.abs(exact).max())
