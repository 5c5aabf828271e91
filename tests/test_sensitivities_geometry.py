"""Geometry parameters (docs/parameters.md, "Geometry parameters"): sensitivities by a parameter that moves
the reference configuration — a body's ``at``, a beam's free end, an end's offset.

The generated derivatives of the element forces along a variation of the reference data
(``beam_internal_force_D_reference``, ``beam_inertia_force_D_reference``) against central differences of the
forces, planar and 3D; then whole runs, static and transient, planar and genuinely 3D, against Richardson
central differences of whole runs in the parameter (tests/test_sensitivities_transient.py's ``_richardson``).
"""
from __future__ import annotations

import numpy as np
import pytest

import element_states as es
from latdyn.model.kernels import load_kernels
from test_planar import planar_state, planar_velocity

H = 1e-6


def _reference_moved(state, reference: np.ndarray, eps: float):
    """(geometry (1, 36), section (1, 10)) of ``state`` with its reference data moved by ``eps`` times the
    variation ``reference`` (codegen/conventions.py REFERENCE): reference points and global offsets
    translated, nodal frames turned by exp(skew eps ψ_i) (spatial), L0 changed; hinge axes kept."""
    g = state.geometry()[0].copy()
    r = eps * reference
    g[0:6] += r[0:6]
    g[6:12] += r[6:12]
    for frame, psi in ((slice(12, 21), r[12:15]), (slice(21, 30), r[15:18])):
        g[frame] = (es.expm_so3(psi) @ g[frame].reshape(3, 3)).ravel()
    section = state.section.copy()
    section[0] += r[18]
    return g[None], section[None]


def _planar_reference(rng, normal: int) -> np.ndarray:
    """A random reference variation that keeps the plane: in-plane translations, turns about n."""
    i, j = (normal + 1) % 3, (normal + 2) % 3
    r = np.zeros(19)
    for block in (0, 3, 6, 9):
        r[block + i], r[block + j] = rng.normal(size=2)
    r[12 + normal], r[15 + normal] = rng.normal(size=2)
    r[18] = rng.normal() * 0.1
    return r


def _check_reference_derivatives(kernels, state, reference, qdot, acceleration, gravity):
    """Both kernels' derivatives along ``reference`` against central differences of their forces."""
    def internal(eps):
        geometry, section = _reference_moved(state, reference, eps)
        return kernels.beam_internal_force(geometry, section)[0][0]

    def inertial(eps):
        geometry, section = _reference_moved(state, reference, eps)
        return kernels.beam_inertia_tangent(geometry, qdot[None], acceleration[None], section, gravity[None])[0][0]

    geometry, section = state.geometry(), state.section[None]
    force, derivative = kernels.beam_internal_force_D_reference(geometry, section, reference[None])
    np.testing.assert_allclose(force[0], internal(0.0), rtol=0, atol=1e-12 * np.abs(force).max())
    numeric = (internal(H) - internal(-H)) / (2 * H)
    assert np.linalg.norm(derivative[0][:, 0] - numeric) <= 1e-6 * np.linalg.norm(numeric)
    force, derivative = kernels.beam_inertia_force_D_reference(geometry, qdot[None], acceleration[None], section,
                                                               gravity[None], reference[None])
    np.testing.assert_allclose(force[0], inertial(0.0), rtol=0, atol=1e-12 * np.abs(force).max())
    numeric = (inertial(H) - inertial(-H)) / (2 * H)
    assert np.linalg.norm(derivative[0][:, 0] - numeric) <= 1e-6 * np.linalg.norm(numeric)


def test_planar_reference_derivatives_against_finite_differences():
    """default_xy: ∂F/∂(reference) and ∂(M a + g − Q)/∂(reference) along in-plane variations (moved fixed
    ends, offsets, frames turned about z, L0) at random planar states with hinges and offsets."""
    kernels = load_kernels(backend="auto", variant="default_xy")
    rng = np.random.default_rng(34)
    for _ in range(3):
        state = planar_state(rng, 2, deformation=0.3)
        gravity = np.array([rng.normal(), rng.normal(), 0.0]) * 9.81
        _check_reference_derivatives(kernels, state, _planar_reference(rng, 2), planar_velocity(rng, 2),
                                     planar_velocity(rng, 2), gravity)


def test_3d_reference_derivatives_against_finite_differences():
    """default (3D): the same at random states with large rigid rotations, hinges, offsets and shear."""
    kernels = load_kernels(backend="auto", variant="default")
    rng = np.random.default_rng(35)
    for regime in es.REGIMES.values():
        state = es.random_state(rng, deformation=regime)
        reference = rng.normal(size=19)
        reference[18] *= 0.1
        _check_reference_derivatives(kernels, state, reference, rng.normal(size=14), rng.normal(size=14),
                                     rng.normal(size=3) * 9.81)
