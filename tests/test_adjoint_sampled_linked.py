"""The discrete adjoint's held outputs of a sampled controller through an event on a model with rigid links (issue 34;
latdyn/analyses/adjoint_controller_states.py ``SamplesTransposed._linked_held_stiffness_along``).

At an event the adjoint transposes the forward method's (∂K/∂p) w, whose sampled held outputs' part is ∂(A_y δy)/∂q w
(A_y = Pᵀ A_y,all, the held δy's ∂r/∂p). With rigid links or guides the forward method takes it through the reduction,
Pᵀ ∂A_y,all/∂q[P w] + ∂Pᵀ/∂q[w] A_y,all (``sampled_held_along`` at u = P w and the geometric term); the adjoint took a
central difference of A_y along w (two configuration moves at each weight met) until diffgen, and takes the forward
method's path now.

The scene: the 3D gimbal of rigid links on skew hinges, a digital PD at 50 Hz of the inner angle and the outer ring's
place driving the inner hinge and a global force on the inner ring (a dependent node: its row of A_y,all moves through
Pᵀ), the inner ring latching at −0.1 rad."""
from __future__ import annotations

import numpy as np

from tests.test_sensitivities_in_loop_linked_controllers import SAMPLED
from tests.test_adjoint_in_loop_links import _largest_gap
from tests.test_sensitivities_refusals_lifted import _both
from tests.test_weight_derivative_controllers_held import _assert_exact, _counted, _richardson

#: the sampled PD on the gimbal (tests/test_sensitivities_in_loop_linked_controllers.py), its set point −0.3 driving the
#: inner ring onto a latch at −0.1 rad (t = 0.2391 s)
SAMPLED_LATCH = (SAMPLED.replace('damping: "c2", torque: "pd"}}}', 'damping: "c2", torque: "pd", lock_at: -0.1}}}')
                 .replace("t_end: 0.3", "t_end: 0.4").replace("ref: 0.3,", "ref: -0.3,"))
assert "lock_at: -0.1" in SAMPLED_LATCH and "ref: -0.3," in SAMPLED_LATCH and '"0.5*pd"]' in SAMPLED_LATCH


def test_the_adjoints_linked_sampled_block_is_exact_and_the_adjoint_gives_the_forward_methods(monkeypatch):
    """At the latch the adjoint's ∂(A_y δy)/∂q w takes no configuration move (two before) and is Richardson
    differences of A_y along w (steps 4e-4 and 2e-4 ℓ/|w|_∞) to 1e-11 of its largest: measured 3.4e-12 (the difference
    it replaces 1.7e-11); the adjoint's sensitivities the forward method's (tests/test_adjoint_in_loop_links.py ``_largest_gap``: measured
    2.4e-12, the same before; the inner ring's z, a probe no parameter moves, is round-off both ways). Fails
    before (the moves)."""
    from latdyn.analyses.adjoint_controller_states import SamplesTransposed

    seen, original = [], SamplesTransposed.held_stiffness_along

    def spy(self, state, w):
        block, moves = _counted(self.owner.assembler, lambda: original(self, state, w))
        if np.any(w):
            seen.append((block, moves, _richardson(self.held_map, self.owner.assembler, state, w,
                                                   self.owner.length or 1.0, relative=4e-4)))
        return block

    monkeypatch.setattr(SamplesTransposed, "held_stiffness_along", spy)
    forward, adjoint = _both(SAMPLED_LATCH)
    assert [event["kind"] for event in forward.summary["events"]] == ["latch"]
    assert seen
    _assert_exact(seen, 1e-11)
    assert _largest_gap(adjoint.summary["probe_sensitivities"], forward.summary["probe_sensitivities"]) <= 1e-10
