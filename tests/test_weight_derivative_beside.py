"""The controllers' terms of ∂r/∂p at an event's impulse weight, (∂K/∂p) w, exact
(latdyn/analyses/parameter_stiffness.py ``controller_parameter_along``, docs/parameters.md "The impulse weight's derivative"): SymPy's mixed second
derivatives of each continuous controller's output and of its parameters' partials by the reads that move along q,
times the sensors' generated gradients, through the chain of controllers reading controllers, a load actuator's
``point_load_stiffness_D_q``. Before, ``TransientSensitivities._terms_beside_stiffness_along`` took a central
difference of ``ControllerTerms.add`` along w (two evaluations an event; kpstops found it had dropped the chained
outputs' move). On the wheel out of the coordinate planes through its two rigid stops (a chained set point, a load in
the wheel's axes driven by a controller), the genuinely 3D boom's spar whose controller reads the tip's velocities
through the arm's latch, and a PI hub's stop (its states' held δS): no difference is taken, the hinge's row is the
closed form, and the block agrees with Richardson-extrapolated differences of the same block to round-off."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from tests.test_controller_stop_sensitivities import BY_RATE, CHAINED, NONLINEAR
from tests.test_sensitivities_controller_states import PI_STOP
from tests.test_weight_derivative_controllers_rest import SPAR

#: the PI hub's stop with the state's weight moving with the angle: ∂²y/∂S∂θ = −2 Ki, so its held δS's term of ∂r/∂p
#: moves along w
PI_MIXED = PI_STOP.replace("-Kp*th - Ki*S", "-Kp*th - Ki*S*(1 + 2*th)")
assert "Ki*S*(1 + 2*th)" in PI_MIXED


def _events_block(monkeypatch, text: str, reference: bool = False) -> list:
    """``text`` through the API (Newton's tolerance 1e-12), recording at each event (the owner, the state, w, the block
    ``_terms_beside_stiffness_along`` gave, the configuration moves it took, with ``reference`` the block's
    :func:`_richardson_of_the_block` there: a latch renumbers the coordinates after it)."""
    seen, original = [], TransientSensitivities._terms_beside_stiffness_along

    def spy(self, state, w):
        moves, advance = [], self.assembler.advance

        def counted(at, increment):
            moves.append(1)
            return advance(at, increment)

        self.assembler.advance = counted
        try:
            block = original(self, state, w)
        finally:
            del self.assembler.advance
        seen.append((self, state, np.array(w), block, len(moves),
                     _richardson_of_the_block(self, state, w) if reference else None))
        return block

    monkeypatch.setattr(TransientSensitivities, "_terms_beside_stiffness_along", spy)
    data = yaml.safe_load(text)
    data["solve"]["tol"] = 1e-12
    latdyn.run(latdyn.load_scene(data))
    monkeypatch.undo()
    return seen


def _richardson_of_the_block(owner, state, w: np.ndarray, relative: float = 1e-3) -> np.ndarray:
    """Richardson-extrapolated central differences (steps ``relative`` ℓ/|w|_∞ and half of it) along w of the
    controllers' terms of ∂r/∂p (``ControllerTerms.add``, the outputs moved with the state), on the free coordinates."""
    assembler, model = owner.assembler, owner.model

    def beside(moved):
        total = np.zeros((model.n_total + 1, len(owner.names)))
        with owner._controller_outputs_at(moved):
            owner.controllers.add(moved, total)
        return owner._on_free_coordinates(moved, total)

    def central(eta):
        return (beside(assembler.advance(state, eta * w)) - beside(assembler.advance(state, -eta * w))) / (2 * eta)

    eta = relative * (owner.length or 1.0) / float(np.max(np.abs(w)))
    return (4 * central(eta / 2) - central(eta)) / 3


@pytest.mark.parametrize("text, lead", [(CHAINED, lambda theta: 0.0), (BY_RATE, lambda theta: 0.0),
                                        (NONLINEAR, lambda theta: 0.5 + 0.3 * theta)],
                         ids=["chained", "lead-by-rate", "nonlinear"])
def test_the_wheels_hinge_row_is_the_closed_form_at_each_stop(monkeypatch, text, lead):
    """pd = Kp (lead − angle) (+ ½ Kp lead²), lead = a0 + 0.3 angle (+ 0.05 rate), τ = Kt pd: the hinge's row of the
    Kp column is −Kt ∂(∂pd/∂Kp)/∂q w = −Kt (0.3 (1 + lead) − 1) w_θ (lead's term in the nonlinear case). Measured
    within 1e-13 relative; the difference was 5.0e-12, 5.0e-12 and 1.5e-11 off it (fails before)."""
    seen = _events_block(monkeypatch, text)
    assert len(seen) == 4   # two impacts, each weighed before and after its jump
    for owner, state, w, block, _, _ in seen:
        j = 0
        d = int(owner.model.hinge_dofs[j])
        theta = float(state.theta[j])
        expected = -2.0 * (0.3 * (1.0 + lead(theta)) - 1.0) * w[d]
        column = owner.names.index("Kp")
        assert abs(block[d, column] - expected) <= 1e-13 * abs(expected)


@pytest.mark.parametrize("text, tolerance", [(CHAINED, 1e-12), (SPAR, 1e-12), (PI_STOP, 3e-14), (PI_MIXED, 2e-13)],
                         ids=["wheel-stops", "spar-latch", "pi-stop", "pi-stop-mixed"])
def test_the_block_is_exact_and_takes_no_difference(monkeypatch, text, tolerance):
    """No configuration move (two an event before) and the block against Richardson differences of it (every column,
    relative to its largest): the wheel's stops 1.4e-13 (the difference 3.5e-12, its load rows in the wheel's axes
    too), the spar's latch 1.6e-14 (6.2e-11; the block 0 after the latch), the PI's stop with its held δS 9.9e-16
    (3.1e-13), with the state's weight moving with the angle 9.1e-15 (5.5e-12). Fails before."""
    seen = _events_block(monkeypatch, text, reference=True)
    scales = []
    for _, _, _, block, moves, reference in seen:
        assert moves == 0
        scales.append(np.abs(reference).max())
        assert np.abs(block - reference).max() <= tolerance * scales[-1] + 1e-300
    assert max(scales) > 0


def test_a_tension_reader_by_its_ea_takes_no_difference_since_ctrlexact(monkeypatch):
    """A controller reading a cable's tension whose EA is a parameter kept the central difference until ctrlexact
    (its ∂N/∂p's move along q had no kernel); now formed by controller_parameter_along from the generated
    cable_tension gradient at (∂EA/∂p, ∂c/∂p): no configuration move at the events (more:
    tests/test_weight_derivative_controllers_sensed.py)."""
    from tests.test_weight_derivative_force_sensors import TENSION

    seen = _events_block(monkeypatch, TENSION.replace("sensitivities: [Kp, k]", "sensitivities: [EA, Kp]"))
    assert seen and all(moves == 0 for *_, moves, _ in seen)


def test_the_adjoints_held_states_block_is_exact_and_the_adjoint_gives_the_forward_methods(monkeypatch):
    """The adjoint's ∂(B δS)/∂q w at the PI hub's stop whose state's weight moves with the angle (B the held δS's use
    in ∂r/∂p, latdyn/analyses/adjoint_controller_states.py ``held_stiffness_along``) takes no configuration move (two
    before) and agrees with Richardson differences of B along w to 2e-13 of its largest (measured 3.8e-14 at both
    weighings; the difference it replaces 8.9e-13); the adjoint's sensitivities are the forward method's (measured
    4.0e-12, the same before). Fails before."""
    from latdyn.analyses.adjoint_controller_states import StatesTransposed
    from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both

    seen, original = [], StatesTransposed.held_stiffness_along

    def spy(self, state, w):
        moves, advance = [], self.owner.assembler.advance

        def counted(at, increment):
            moves.append(1)
            return advance(at, increment)

        self.owner.assembler.advance = counted
        try:
            block = original(self, state, w)
        finally:
            del self.owner.assembler.advance
        eta = 1e-3 * (self.owner.length or 1.0) / float(np.max(np.abs(w)))
        assembler = self.owner.assembler

        def central(h):
            return (self.held_map(assembler.advance(state, h * w)) - self.held_map(assembler.advance(state, -h * w))) \
                / (2 * h)

        seen.append((block, (4 * central(eta / 2) - central(eta)) / 3, len(moves)))
        return block

    monkeypatch.setattr(StatesTransposed, "held_stiffness_along", spy)
    forward, adjoint = _both(PI_MIXED)
    assert seen
    for block, reference, moves in seen:
        assert moves == 0
        assert np.abs(block - reference).max() <= 2e-13 * np.abs(reference).max()
    assert _adjoint_error(forward, adjoint) <= 1e-10
