"""The quadrature of a law spring's potential, written once (csrc/evaluate.c ``latdyn_law_spring_integral``):
latdyn_energies records ∫_{θ_r}^{θ} k(x)(x − θ_r) dx with it, and the energies' sensitivities
(latdyn/analyses/energy_sensitivities.py ``_law_integral``) take their parameter derivatives on it, the
law called back from C.

References: closed-form integrals of polynomial laws (16 Gauss points a piece are exact to degree 31), the
number of times the rule evaluates the law (16 a piece, pieces of at most 0.25 rad, at most 4096), and the
recorded strain energy of a hinged arm against its closed form. The energies' sensitivities through it
(tests/test_sensitivities_energies.py::test_spring_laws_agree) did not move by more than 1.8e-16 of each
probe's largest derivative when the Python copy of the rule gave way to it."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.energy_sensitivities import _law_integral
from latdyn.scene.expressions import HingeLaw


def _exact(rest: float, theta: float, moment: bool) -> float:
    """∫_{rest}^{theta} k(x)(x − rest)^moment dx of k(x) = 3 + 2 (x − rest)² − 0.5 x⁵."""
    def antiderivative(x):
        s = x - rest
        # ∫ 3 s^m + 2 s^(2+m) dx, and −0.5 ∫ x⁵ (x − rest)^m dx
        polynomial = 3 * s ** (1 + moment) / (1 + moment) + 2 * s ** (3 + moment) / (3 + moment)
        fifth = x ** 6 / 6 if not moment else x ** 7 / 7 - rest * x ** 6 / 6
        return polynomial - 0.5 * fifth
    return antiderivative(theta) - antiderivative(rest)


@pytest.mark.parametrize("rest, theta", [(0.1, 0.17), (0.1, 3.8), (-0.4, -2.9), (0.3, 0.3)])
@pytest.mark.parametrize("moment", [True, False])
def test_the_quadrature_is_exact_for_polynomial_laws(rest, theta, moment):
    """A degree-5 law (degree 6 with the moment): the closed form to round-off (measured ≤ 1.7e-16 relative)."""
    law = HingeLaw(f"3 + 2*(theta - {rest})**2 - 0.5*theta**5")
    value = _law_integral(law, rest, theta, moment)
    expected = _exact(rest, theta, moment)
    assert abs(value - expected) <= 1e-14 * max(abs(expected), 1.0), (value, expected)


class _Counted:
    """A law k(x) = cos(x) that counts its evaluations."""

    def __init__(self):
        self.calls = 0

    def value(self, x, rate, t):
        self.calls += 1
        return float(np.cos(x))


@pytest.mark.parametrize("turn, pieces", [(0.2, 1), (2.6, 11), (-100.0, 400), (5000.0, 4096)])
def test_the_pieces_are_at_most_a_quarter_radian_and_at_most_4096(turn, pieces):
    """16 evaluations a piece; ⌈|s|/0.25⌉ pieces up to the cap of 4096 (beyond 1024 rad they grow longer);
    on the smooth law cos x the value is the closed form ∫ cos x (x − θ_r) dx, measured ≤ 4.3e-16 relative
    with pieces of 0.25 rad and 6.7e-14 with the 4096 pieces of 1.22 rad at 5000 rad (round-off of the sum)."""
    law, rest = _Counted(), 0.2
    value = _law_integral(law, rest, rest + turn, moment=True)
    assert law.calls == 16 * pieces

    def antiderivative(x):   # ∫ cos x (x − rest) dx = (x − rest) sin x + cos x
        return (x - rest) * np.sin(x) + np.cos(x)
    exact = antiderivative(rest + turn) - antiderivative(rest)
    assert abs(value - exact) <= 1e-12 * max(1.0, abs(exact)), (value, exact)


def test_a_non_finite_angle_has_a_non_finite_integral():
    assert np.isnan(_law_integral(_Counted(), 0.0, np.nan, moment=True))
    assert _law_integral(_Counted(), 0.0, np.inf, moment=False) == np.inf


def test_a_law_undefined_at_a_point_of_the_rule_gives_nan_never_a_stale_value():
    """A law that raises where it is undefined (a real power of a negative angle: ``theta**1.5`` is complex
    there) cannot raise through the C frames; the integral is NaN — as the compiled law gives the recorded
    energy — and not the value the rule's previous point left behind (found in review: finite, made up)."""
    law = HingeLaw("3 + theta**1.5")
    with pytest.raises((TypeError, ValueError, ArithmeticError)):
        law.value(-0.3, 0.0, 0.0)
    assert np.isnan(_law_integral(law, -0.5, 0.5, moment=True))
    assert np.isfinite(_law_integral(law, 0.1, 0.5, moment=True))


HINGED_PAIR = """
title: a hinged arm whose spring's stiffness is a law, turned from its rest angle
gravity: [0, 0, 0]
sections:
  s: {EA: 1.0e4, EIy: 10.0, EIz: 10.0, GJ: 8.0, rhoA: 1.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1, 0, 0]}
beams:
  a:
    from: base
    to: tip
    section: s
    elements: 1
    start: {hinge: {axis: [0, 0, 1], stiffness: "3 + 2*(theta + 3.7)**2 - 0.5*theta**5", rest_angle: -3.7}}
solve: {analysis: transient, t_end: 1.0e-6, dt: 1.0e-6}
output:
  probes:
    strain: {energy: strain}
"""


def test_the_recorded_strain_energy_is_the_closed_form():
    """An arm at 3.7 rad from its spring's rest angle at t = 0 (15 pieces): the recorded strain energy at the
    first row is the spring's ∫ k(x)(x − θ_r) dx in closed form (the beam unstrained), measured 5e-16
    relative."""
    data = yaml.safe_load(HINGED_PAIR)
    result = latdyn.run(latdyn.load_scene(data))
    expected = _exact(-3.7, 0.0, True)
    assert abs(result.probes["strain"][0] - expected) <= 1e-13 * abs(expected), (result.probes["strain"][0], expected)
