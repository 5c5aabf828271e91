"""The beams' gravity tangent in the static Newton matrix (codegen ``beam_gravity_D_q``, csrc/evaluate.c).

The static Newton matrix under gravity is K − λ ∂Q/∂q, with ∂Q/∂q the generated exact tangent of the
beams' gravity load (its kernel is checked against central differences in tests/test_element.py and
tests/test_planar.py). Here, at a largely deformed 3D state under gravity (off equilibrium), the assembled static matrix against central differences
of the assembled residual (latdyn.analyses.linearisation.tangent_q: the material tangent plus central
differences of the load terms); and a column buckling under
its own weight against Greenhill's (q L³/EI)_cr = 7.8373474 (the first zero of J₋₁/₃(⅔√β)).
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.linearisation import tangent_q
from latdyn.assembly.native_model import has_gravity_tangent
from latdyn.assembly.prepare import prepare

FRAME_3D = """
title: a 3D frame under its own weight, a hinged member
sections:
  s: {EA: 1.0e5, EIy: 20.0, EIz: 30.0, GJ: 25.0, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.02}
bodies:
  a: {at: [0, 0, 0], fixed: true}
  c: {at: [0, 0, 1.5]}
  e: {at: [1.0, 1.2, 1.7]}
beams:
  post: {from: a, to: c, section: s, elements: 3, y_axis: [0.6, 0.8, 0]}
  arm:
    from: c
    to: e
    section: s
    elements: 4
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0.3, 0.5, 0.81], stiffness: 40.0}}
gravity: [0.8, -1.1, -9.81]
solve: {analysis: static, steps: 4}
output:
  probes:
    e_z: {point: e, quantity: displacement, component: z}
"""

#: Greenhill: a clamped column of length 1 and EI = 1 (its weaker plane) under its own weight q = ρA g
#: = 1: the buckling factor of the weight is (q L³/EI)_cr
GREENHILL = 7.83734743894348
COLUMN = """
title: a column under its own weight (Greenhill)
sections:
  col: {EA: 1.0e7, EIy: 1.0, EIz: 2.0, GJ: 1.0, rhoA: 0.1019367991845056}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  col: {from: base, to: [0, 0, 1], section: col, elements: 16}
gravity: [0, 0, -9.81]
solve: {analysis: buckling, steps: 4}
"""


def _deformed(text: str):
    """(prepared, the initial state moved by a skew increment of every free coordinate: a large
    deformation, off equilibrium)."""
    prepared = prepare(yaml.safe_load(text))
    increment = 0.1 * np.random.default_rng(7).normal(size=prepared.model.n_dofs)
    return prepared, prepared.assembler.advance(prepared.state, increment)


def test_the_static_matrix_under_gravity_is_the_derivative_of_the_residual():
    """K − λ ∂Q/∂q against the central differences of the assembled residual, 3D, a hinge: the gravity
    part of the matrix (K(λ) − K(0)) against the differences of r(λ) − r(0), within 1e-4 of its
    largest entry (measured 1.1e-5: the differences' round-off, r(λ) − r(0) cancelling elastic forces
    five orders larger at this large deformation; the kernel itself is checked to 1e-6 in
    tests/test_element.py). Before the gravity tangent the static matrix held none of it."""
    prepared, state = _deformed(FRAME_3D)
    assert has_gravity_tangent(prepared.assembler.kernels)
    assembler = prepared.assembler

    def matrix(load_factor):
        ev = assembler.evaluate(state, matrices=True, load_factor=load_factor, inertia=False)
        return np.asarray(ev.combined(0.0, 0.0, 1.0, dense=True))

    material = matrix(0.0)
    reference = tangent_q(assembler, state, 0.7, inertia=False) - material
    assert np.abs(reference).max() > 0.1
    assert np.abs((matrix(0.7) - material) - reference).max() <= 1e-4 * np.abs(reference).max()


def test_a_column_buckles_under_its_own_weight_at_greenhills_load():
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(COLUMN)))
    assert result.summary["buckling_factor"] == pytest.approx(GREENHILL, rel=1e-5)
    assert result.summary["linearised_buckling_factors"][0] == pytest.approx(GREENHILL, rel=1e-5)
