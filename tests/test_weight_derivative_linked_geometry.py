"""A geometry parameter's part of an event's impulse weight on models with rigid links or guides, generated through the
reduction (issue 34; latdyn/analyses/parameter_stiffness.py ``_geometry_generated``, ``_geometry``;
transient_sensitivities.py ``_linked_stiffness_along``; docs/parameters.md, "The impulse weight's derivative").

A geometry parameter taken beside rigid links or guides translates each linked subtree rigidly, or not at all
(geometry_sensitivities.py ``_linked_refusal``): its static ∂r_all/∂p is the elements' internal forces along their
reference variations (``beam_internal_force_D_reference``) and the loads' moved arms, so (∂K_red/∂p) w = Pᵀ (∂K_all/∂p)
(P w) + ∂Pᵀ/∂q[w] · ∂r_all/∂p is ``beam_stiffness_D_reference`` along u = P w, reduced, and the reduction's geometric
term of that column — the path the other parameters take since linkedparam. Before, every geometry parameter on such a
model took the central difference of the whole static ∂r/∂p along w (step WEIGHT_STEP ℓ/|w|_∞, two evaluations at each
event). A parameter that shifts a subtree on a part that turns or moves a rigid link's vector (a gimbal's ring
offset) keeps that difference: the shift's K d + C δv + M δa + d × F_S along w is not generated.

On the 3D YAML scenes of tests/test_geometry_sensitivities_links.py and _link_geometry.py: the gimbal of rigid links
placed by X, latching; the mass on a skew guide at a flexible arm's tip placed by L; the pendulum's hinge point on the
sliding cart, latching."""
from __future__ import annotations

import numpy as np
import pytest

from latdyn.analyses.parameter_stiffness import exact_parameters
from tests.test_geometry_sensitivities_link_geometry import CART_LATCH
from tests.test_geometry_sensitivities_links import GUIDE_PLACED, LATCH_PLACED
from tests.test_geometry_sensitivities_turning_events import RING_LATCH
from tests.test_weight_derivative_linked_parameters import _counting, _difference_at, relative_errors, turned

#: {name: (scene, its geometry parameter)}
SCENES = {"the placed gimbal": (LATCH_PLACED, "X"), "the placed guide": (GUIDE_PLACED, "L"),
          "the hinge point on the cart": (CART_LATCH, "X")}


def _richardson(owner, state, w) -> np.ndarray:
    """(∂K/∂p) w as Richardson-extrapolated central differences of the static ∂r/∂p along w at the assembled rates held
    (the difference the generated path replaced), steps 2e-4 and 1e-4 ℓ/|w|_∞: at 4e-4 and 2e-4 the cart's hinge point
    is 1.7e-11 off the finer pair (h⁴ truncation), 1.4e-12 – 1.9e-12 at the three pairs from 4e-4 down to 5e-5 (the
    gimbal, the guide alike: round-off)."""
    coarse, fine = (_difference_at(owner, state, w, step) for step in (2e-4, 1e-4))
    return (4 * fine - coarse) / 3


@pytest.mark.parametrize("name", list(SCENES))
def test_a_translating_geometry_parameter_is_generated_through_the_reduction(name, monkeypatch):
    """At a turned state with random rates and accelerations, every parameter's (∂K/∂p) w generated, no evaluation
    of the static ∂r/∂p along w taken (the base: two, the geometry parameter differenced), against the Richardson
    reference of the same quantity (:func:`_richardson`; relative to its largest entry): measured 1.4e-12 (gimbal),
    4.9e-13 (guide), 1.8e-12 (cart); the single difference it replaces 4.7e-10, 3.4e-10, 2.3e-9."""
    text, parameter = SCENES[name]
    owner, state, w = turned(text)
    assert exact_parameters(owner).all(), dict(zip(owner.names, exact_parameters(owner)))
    calls = _counting(monkeypatch)
    computed = owner._stiffness_derivative(state, w)
    assert not calls
    reference = _richardson(owner, state, w)
    assert np.max(np.abs(reference[:, owner.names.index(parameter)])) > 0.0
    errors = relative_errors(owner.names, computed, reference)
    assert max(errors.values()) <= 1e-11, errors


def test_a_shift_on_a_part_that_turns_keeps_the_difference():
    """The gimbal's ring offset (the rings moved by X, gim1's length and direction: a shift on a part that turns and
    a moved link vector) is differenced, its other parameter generated. A guard: the base differenced both."""
    owner, _, _ = turned(RING_LATCH)
    assert dict(zip(owner.names, exact_parameters(owner))) == {"X": False, "k1": True}
