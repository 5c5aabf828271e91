"""The parameters' part of an event's impulse weight derivative, (∂K/∂p) w, generated (latdyn/analyses/
parameter_stiffness.py, docs/parameters.md "The impulse weight's derivative"): on a genuinely 3D latching boom under
a skew gravity whose parameters use every kind with a generated part — a hinge's stiffness and damping laws of θ, its
rest angle, its torque of θ and t, a follower load's component of t, the wheel's mass and centre of mass, a damped
cable's EA and damping — no parameter takes the central difference along w, with the event's time shift too, and
each column agrees with Richardson-extrapolated central differences of the static ∂r/∂p (with its time shift's term)
along w; a massless cable's rest length too (generated since: tests/test_weight_derivative_parameters2.py); through
the latch the sensitivities agree with Richardson differences of whole runs, and the loop of steps on and off (API
and ``latdyn run``) give the same bits."""
from __future__ import annotations

import numpy as np
import pytest

from latdyn.analyses.parameter_stiffness import exact_parameters
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import runs_with_the_loop_on_and_off
from tests.test_sensitivities_events import _agree
from tests.test_weight_derivative_rest import BOOM, _boom_state

#: the boom of tests/test_weight_derivative_rest.py (a wheel latching at 0.5 rad at the end of a 3D arm, a spar, a
#: follower load at an offset, a global load, a damped taut cable to an anchor) under a skew gravity, with the
#: hinge's laws of θ (and t), its rest angle, the follower load's component of t, the wheel's mass and centre of
#: mass and the cable's EA and damping named by parameters
PARAMETER_BOOM = (BOOM.replace("EA: 2.0, P: 0.3}", "EA: 2.0, P: 0.3, cd: 0.4, q: 0.2, r: 1.0, xc: 0.05}", 1)
                  .replace('mass: "m", com: [0.05, 0, 0]', 'mass: "m", com: ["xc", 0.02, -0.01]', 1)
                  .replace('stiffness: "k", damping: "c", rest_angle: 1.0',
                           'stiffness: "k*(1 + 0.5*theta**2)", damping: "c*(1 + theta**2)", rest_angle: "r", '
                           'torque: "q*sin(theta) + 0.1*t*theta"', 1)
                  .replace('force: ["P", -0.2, 0.4]', 'force: ["P*(1 + 0.2*t)", -0.2, 0.4]', 1)
                  .replace('damping: 0.4}', 'damping: "cd"}', 1)
                  .replace("sections: {s:", "gravity: [1.0, -2.0, -9.81]\nsections: {s:", 1)
                  .replace("sensitivities: [EA, P, k]", "sensitivities: [EA, P, k, c, m, xc, cd, q, r]"))


def _richardson_along(owner, state, w: np.ndarray, eta: float) -> np.ndarray:
    """(∂K/∂p) w as Richardson-extrapolated central differences along w (steps η, η/2 relative to ℓ/|w|_∞) of the
    static ∂r/∂p without the section values' and the elements' gravity load (with the time shift's term where the
    owner's is set), plus the section values' generated part: the old difference's quantity, to truncation O(η⁴)."""
    step = eta * (owner.length or 1.0) / float(np.max(np.abs(w)))

    def static(moved):
        return owner.residual_derivatives(moved, 1.0, sections=False, element_gravity=False)

    advance = owner.assembler.advance
    central = [(static(advance(state, h * w)) - static(advance(state, -h * w))) / (2 * h) for h in (step, step / 2)]
    return (4 * central[1] - central[0]) / 3 + owner._section_stiffness_along(state, w)


@pytest.mark.parametrize("shifted", [False, True])
def test_every_kinds_stiffness_derivative_is_generated_and_agrees_with_richardson(shifted):
    """No parameter of the boom takes the difference (with a random time shift δt_e too: the laws' rates in t are
    generated), and each column of (∂K/∂p) w agrees with the Richardson reference to 5e-11 of its largest entry
    (measured ≤ 1e-11; the central difference it replaces, step 1e-5, 3e-12 to 4.5e-10 off, the cable's EA 7.5e-11)."""
    prepared, state, rng = _boom_state(PARAMETER_BOOM)
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=prepared.model.n_dofs)
    if shifted:
        owner.time_shift = rng.normal(size=len(owner.names))
    assert exact_parameters(owner).all()
    computed = owner._stiffness_derivative(state, w)
    reference = _richardson_along(owner, state, w, 1e-3)
    scales = np.abs(reference).max(axis=0)
    assert np.all(scales > 1e-3)   # every kind moves K w here
    errors = np.abs(computed - reference).max(axis=0) / scales
    assert errors.max() <= 5e-11, dict(zip(owner.names, errors))


def test_a_massless_cables_rest_length_is_generated():
    """The cable's rest length (K is not linear in L0: ``cable_stiffness_D_rest_length``, tests/
    test_weight_derivative_parameters2.py) takes the generated path beside the others; its column agrees with the
    Richardson reference of the static ∂r/∂p along w (a massless cable: its rest length moves no weight) to 5e-11 of
    its largest entry (measured 1.4e-12; the difference it replaced, 1e-9)."""
    text = (PARAMETER_BOOM.replace("rest_length: 0.9", 'rest_length: "L"', 1)
            .replace("xc: 0.05}", "xc: 0.05, L: 0.9}", 1).replace("cd, q, r]", "cd, q, r, L]", 1))
    prepared, state, rng = _boom_state(text)
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=prepared.model.n_dofs)
    assert exact_parameters(owner).all()
    computed = owner._stiffness_derivative(state, w)
    reference = _richardson_along(owner, state, w, 1e-3)
    column = owner.names.index("L")
    assert np.abs(computed[:, column] - reference[:, column]).max() <= 5e-11 * np.abs(reference[:, column]).max()


@pytest.fixture(scope="module")
def boom_runs():
    """The boom's sensitivities with the loop of steps on and off (API)."""
    return runs_with_the_loop_on_and_off(PARAMETER_BOOM)


def test_through_the_latch_the_sensitivities_agree_with_richardson_and_the_loop_keeps_the_bits(boom_runs):
    """Through the latch (its (∂K/∂p) w generated for every parameter) the sensitivities by the rest angle agree with
    Richardson-extrapolated differences of whole runs, and the loop of steps on and off give the same bits, with
    steps in the loop."""
    native, python = boom_runs[True], boom_runs[False]
    assert [e["kind"] for e in native.summary["events"]] == ["latch"]
    assert native.summary["sensitivity_steps_in_loop"] > 0 == python.summary["sensitivity_steps_in_loop"]
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
    assert _agree(native, PARAMETER_BOOM, "r", 1e-6) < 1e-6


def test_latdyn_run_writes_the_apis_sensitivities_and_the_loop_off_the_same(tmp_path, boom_runs):
    """``latdyn run`` of the boom: the latch's event sensitivities in summary.json are the API's, and the loop of
    steps off writes the same files byte for byte."""
    run, out = latdyn_run(tmp_path, PARAMETER_BOOM)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert summary["event_sensitivities"] == boom_runs[True].summary["event_sensitivities"]
    assert summary["sensitivity_steps_in_loop"] > 0
    the_loop_off_writes_the_same(tmp_path, out)


def test_a_damped_cables_stiffness_along_the_rates_is_generated():
    """The boom of tests/test_weight_derivative_rest.py (its damped taut cable the only block of K moving with the
    rates): ∂(K w)/∂v δv from the generated cable kernel (K_c affine in the rates) agrees with a central difference of
    K w at a large step (exact for an affine K w but for round-off: 6.5e-8 absolute at 0.1, 2.4e-6 at 1e-3), to 1e-6 of
    its largest entry; the difference it replaces, step 1e-5 of the rates' size, was 3.5e-4 of it off (K w of the
    stiff arm, 1e6, carries its round-off over the step)."""
    from latdyn.assembly.assembler import free_velocity, unpack_free

    prepared, state, rng = _boom_state(BOOM)
    owner = TransientSensitivities(prepared)
    model = prepared.model
    w, dv = rng.normal(size=model.n_dofs), rng.normal(size=(model.n_dofs, 2))
    assert owner.stiffness_moves_with_rates(state) and owner._rates_moving[1] == ("loads and cables",)
    computed = owner._stiffness_by_rates(state, w, dv)
    v0 = free_velocity(model, state)

    def product(v):
        moved = state.copy()
        unpack_free(model, v, moved.v, moved.w, moved.theta_dot)
        return prepared.assembler.evaluate(moved, matrices=True).combined(0.0, 0.0, 1.0) @ w

    h = 0.1
    numeric = np.column_stack([(product(v0 + h * dv[:, c]) - product(v0 - h * dv[:, c])) / (2 * h) for c in range(2)])
    assert np.abs(computed - numeric).max() <= 1e-6 * np.abs(numeric).max()
