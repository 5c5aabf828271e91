"""A compiled controller law that reads an earlier controller's output takes it as its argument (codegen/laws.py
``_block``), not from the scene's controller-output array, which holds the outputs at the step's state.

Before, a law variable named like a controller read that array even where it was passed as an argument ``s[m]``: the
compiled output partials (latdyn/analyses/derivative_laws.py ``ControllerPartials``) evaluated at a moved state read a
stale earlier output (kpstops: Kp 1.26e-6 off Richardson differences through the wheel's rigid stops), mended then by
refilling the array around the callers (``TransientSensitivities._controller_outputs_at``), which now refills it only
where a hinge law (θ, θ̇, t) names a controller. The wheel of tests/test_controller_stop_sensitivities.py: ``lead =
a0 + 0.3*angle`` read by ``pd = Kp*(lead - angle) - ...``, the hinge's torque ``Kt*pd + 0.1*Kt*Kt``, two rigid
stops."""
from __future__ import annotations

import contextlib

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from tests.test_controller_stop_sensitivities import CHAINED, NONLINEAR
from tests.test_sensitivities_refusals_lifted2 import _richardson_error, _run


def _owners_at_events(monkeypatch, text: str) -> list:
    """``text`` through the API, recording (the forward method, the state) at each event's weighing."""
    seen, original = [], TransientSensitivities._terms_beside_stiffness_along

    def spy(self, state, w):
        seen.append((self, state))
        return original(self, state, w)

    monkeypatch.setattr(TransientSensitivities, "_terms_beside_stiffness_along", spy)
    latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    monkeypatch.undo()
    return seen


@pytest.mark.parametrize("text", [CHAINED, NONLINEAR], ids=["chained", "nonlinear"])
def test_a_compiled_law_at_a_moved_state_reads_its_arguments_not_the_stale_array(monkeypatch, text):
    """pd's compiled output, ∂pd/∂(lead, angle) and ∂pd/∂Kp at arguments other than the step's, the scene's array
    deliberately stale (lead's entry 10³): equal to SymPy's lambdas of the same arguments to 1e-14 relative (measured
    equal, 0.0). Before, the compiled law read lead = 10³ from the array: off by 10³ in the output and in ∂pd/∂Kp = lead −
    angle (fails before)."""
    seen = _owners_at_events(monkeypatch, text)
    owner, state = seen[0]
    terms, compiled = owner.controllers, owner.controllers.compiled
    assert compiled is not None   # the C kernels: the compiled partials
    pd = next(c for c in terms.continuous if c.name == "pd")
    assert "lead" in pd.reads
    outputs = owner.scene.controller_outputs
    stale = outputs.values.copy()
    outputs.values[list(outputs.names).index("lead")] = 1.0e3
    try:
        for lead, angle in ((0.05, 0.18), (-0.3, 0.21)):
            values = {"lead": lead, "angle": angle}
            arguments = [state.t, *[values.get(r, 0.0) for r in pd.reads], *terms.state_values(pd)]
            expected = float(pd.functions()[0](*arguments))
            assert compiled.output(pd, arguments) == pytest.approx(expected, rel=1e-14, abs=1e-300)
            gradient = np.asarray(pd.output_gradient(*arguments), float)
            assert np.abs(compiled.gradient(pd, arguments) - gradient).max() <= 1e-14 * np.abs(gradient).max()
            for column, partial in terms.partials["pd"].items():
                exact = float(partial(*arguments))
                assert compiled.value(partial, arguments) == pytest.approx(exact, rel=1e-14, abs=1e-300), column
    finally:
        outputs.values[:] = stale


@contextlib.contextmanager
def _as_they_are(self, moved):
    """No refill: the scene's controller outputs left at the step's values."""
    yield


#: Kp in the hinge's torque too (beside pd's output): its (∂K/∂p) w is the difference of the static ∂r/∂p along the
#: jump's w (a hinge law naming a controller is not generated), which evaluates the compiled partials at moved states
KP_IN_TORQUE = CHAINED.replace('torque: "Kt*pd + 0.1*Kt*Kt"', 'torque: "Kt*pd + 0.1*Kt*Kp"')
assert "0.1*Kt*Kp" in KP_IN_TORQUE


def test_the_chained_set_point_at_stops_agrees_with_richardson_without_refilling_the_outputs(monkeypatch):
    """Kp through the wheel's two rigid stops, its column of (∂K/∂p) w a difference of the static ∂r/∂p along w, with
    the scene's controller outputs never refilled at the moved states (``_controller_outputs_at`` a no-op): against
    Richardson differences of whole runs ≤ 1e-8 (measured 5.4e-10, the same with the refill; before, with the refill
    off, 2.3e-6: the compiled partials read lead's stale output; fails before). Kt's torque law reads pd itself (a
    hinge law's arguments are θ, θ̇, t), so its column still needs the refill (5.7e-6 without it, 1.2e-9 with)."""
    monkeypatch.setattr(TransientSensitivities, "_controller_outputs_at", _as_they_are)
    result = _run(KP_IN_TORQUE)
    monkeypatch.undo()
    assert [e["kind"] for e in result.summary["events"]] == ["stop"] * 2
    assert _richardson_error(KP_IN_TORQUE, result, "Kp") <= 1e-8


# ------------------------------------------------------------------ the adjoint's weight: the time shift's term alone
def _shift_terms(monkeypatch, text: str) -> list:
    """The adjoint run of ``text`` (tests/test_adjoint_events_more.py's), recording at each weighing of
    ``adjoint_time.weight_transposed``: the forward method's ``_stiffness_derivative`` evaluations it took, its
    ``shift_stiffness_along`` and Richardson-extrapolated central differences of the static ∂r/∂t along w (steps 1e-3
    and 5e-4 ℓ/|w|_∞) on the free coordinates."""
    from latdyn.analyses import adjoint_time
    from tests.test_adjoint_events_more import _adjoint, _run

    seen, original = [], adjoint_time.weight_transposed

    def spy(owner, state, w, u_bar, scale, mass):
        calls, derivative = [], TransientSensitivities._stiffness_derivative

        def counted(self, *args, **kwargs):
            calls.append(1)
            return derivative(self, *args, **kwargs)

        monkeypatch.setattr(TransientSensitivities, "_stiffness_derivative", counted)
        try:
            out = original(owner, state, w, u_bar, scale, mass)
        finally:
            monkeypatch.setattr(TransientSensitivities, "_stiffness_derivative", derivative)
        if np.any(w):
            def rate(eta):
                ahead, behind = owner.assembler.advance(state, eta * w), owner.assembler.advance(state, -eta * w)
                return (np.asarray(owner.explicit_time(ahead, inertia=False), float)
                        - np.asarray(owner.explicit_time(behind, inertia=False), float)) / (2 * eta)

            eta = 1e-3 * (owner.length or 1.0) / float(np.max(np.abs(w)))
            reference = (4 * rate(eta / 2) - rate(eta)) / 3
            shift = getattr(adjoint_time, "shift_stiffness_along", None)   # (not on 40bf44a: counted there)
            seen.append((len(calls), None if shift is None else shift(owner, state, w), reference))
        return out

    monkeypatch.setattr(adjoint_time, "weight_transposed", spy)
    _run(_adjoint(text))
    monkeypatch.undo()
    return seen


def test_the_adjoints_time_shift_term_is_one_evaluation_against_richardson(monkeypatch):
    """The slewing arm's stop (a load in sin(2t), tests/test_adjoint_events_more.py SLEWING_STOP): the adjoint's
    weight reads the time shift's term alone (``adjoint_time.shift_stiffness_along``: the laws' rates in t generated,
    ``time_stiffness_along``), no evaluation of the forward method's whole (∂K/∂p) w (two before, at δt_e = 1 and 2,
    the first parameter's column: fails before), and it agrees with Richardson differences of the static ∂r/∂t along w
    to 1e-8 of its largest (measured 2.4e-11 and 2.6e-10 at its two weighings)."""
    from tests.test_adjoint_events_more import SLEWING_STOP

    seen = _shift_terms(monkeypatch, SLEWING_STOP)
    assert seen
    for calls, term, reference in seen:
        assert calls == 0
        assert np.abs(reference).max() > 0
        assert np.abs(term - reference).max() <= 1e-8 * np.abs(reference).max()
