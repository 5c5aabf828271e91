"""The discrete adjoint's held controller states' block of an event's weight derivative on a model with rigid links
(issue 34; latdyn/analyses/adjoint_controller_states.py ``StatesTransposed._linked_held_stiffness_along``).

At an event the adjoint transposes the forward method's (∂K/∂p) w, whose held states' part is ∂(B δS)/∂q w (B = Pᵀ B_all,
the held δS's ∂r/∂p). With rigid links or guides the forward method takes it through the reduction at the assembled
rates held, Pᵀ ∂B_all/∂q[P w] + ∂Pᵀ/∂q[w] B_all (``controller_parameter_along`` at u = P w and the geometric term).
Until diffgen the adjoint took ``controller_parameter_along`` with w on the free coordinates alone and no geometric
term: a sensor on a dependent node did not move, and the block was 0 where it is 0.23 here (8.3 at the run's latch,
whose product with the impulse's adjoint is 4e-17 there: the whole run's adjoint agreed with the forward method's all
the same, tests/test_weight_derivative_linked_parameters.py).

The scene: tests/test_weight_derivative_linked_parameters.py's chain of rigid bays, a PI of points on the bays (its
state the integral of the second point's x error, its weight reading the first point's z) driving the second hinge,
the first against a compliant stop."""
from __future__ import annotations

import numpy as np

from tests.test_weight_derivative_linked_parameters import CHAIN_PI, turned


def _held_map_richardson(owner, held, state, w) -> np.ndarray:
    """Richardson-extrapolated central differences of the held map B along w at the assembled rates held (the forward
    method's K_red: ``TransientSensitivities._advanced_at_held_rates``), steps 4e-4 and 2e-4 ℓ/|w|_∞ (2e-4 and 1e-4
    give the same to 1.1e-12 of its largest)."""
    def central(relative):
        step = relative * (owner.length or 1.0) / float(np.max(np.abs(w)))
        with owner._at_held_rates():
            return (held.held_map(owner._advanced_at_held_rates(state, step * w))
                    - held.held_map(owner._advanced_at_held_rates(state, -step * w))) / (2 * step)

    return (4 * central(2e-4) - central(4e-4)) / 3


def test_the_held_states_block_moves_the_dependent_nodes_and_holds_the_geometric_term():
    """At a turned state with random rates, the adjoint's ∂(B δS)/∂q w against Richardson differences of B along w
    (relative to its largest, 0.23): measured 3.3e-13; before, 0 (the whole block missing: 1.0), and a single central
    difference (step 1e-5) 9.7e-11. Fails before."""
    from latdyn.analyses.adjoint_controller_states import StatesTransposed

    owner, state, w = turned(CHAIN_PI)
    held = StatesTransposed(owner)
    reference = _held_map_richardson(owner, held, state, w)
    scale = float(np.abs(reference).max())
    assert scale > 0.1
    assert np.abs(held.held_stiffness_along(state, w) - reference).max() <= 1e-11 * scale
