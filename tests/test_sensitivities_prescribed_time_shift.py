"""An event's time shift through prescribed motions, generated (latdyn/analyses/parameter_stiffness.py
``_prescribed_along``, docs/parameters.md "The impulse weight's derivative"); hinge laws whose slope in θ is not
finite at θ = θ̇ = t = 0 (issue 34).

At an event moved in time by δt_e the weight's parameter part holds ∂(∂r/∂t)/∂q w δt_e. Through a prescribed motion
the static ∂r/∂t is K_·p q̇_p + C_·p q̈_p, so along w it is ∂(K u)/∂q w at u = q̇_p on the prescribed coordinates (and
∂(K w)/∂v a at a = q̈_p for a damped cable): the H parts' kernels with their direction on every coordinate. On 0d1fc61
every parameter of a run with a prescribed motion took the central difference of the whole static ∂r/∂p along w.
Scenes (3D YAML): a boom deployed about its root by a prescribed hinge angle, latching its wheel's hinge; the arm onto
its stop with its base translated by a prescribed motion; the boom slewing on a prescribed base
(tests/test_sensitivities_in_loop_prescribed.py). The time part is Richardson's of ∂r/∂t along w, no parameter takes
the difference, each column of (∂K/∂p) w agrees with Richardson's, the whole runs agree with Richardson differences of
whole runs (API and ``latdyn run``), the loop of steps on and off give the same bits, the adjoint the forward method's.

Four hinge laws whose slope ∂f/∂θ did not parse back as a law (``HingeLaw`` checked it finite at θ = θ̇ = t = 0, where
a slope is never evaluated) are exact now; a slope law whose second derivative is infinite at the event's state is
refused with a message naming the law, not carried into the sensitivities as inf or nan."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
import tests.test_sensitivities_events as events
from latdyn.analyses import parameter_stiffness
from latdyn.analyses.parameter_stiffness import exact_parameters, time_generated, time_stiffness_along
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.analyses.weight_derivative import _angle_slope_law
from latdyn.errors import SceneError
from latdyn.scene.expressions import HingeLaw
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import runs_with_the_loop_on_and_off
from tests.test_sensitivities_adjoint import _disagreement
from tests.test_sensitivities_in_loop_prescribed import BOOM_SLEW
from tests.test_sensitivities_time_shift_exact import _richardson_of_the_time_rate
from tests.test_weight_derivative_parameters import PARAMETER_BOOM, _richardson_along
from tests.test_weight_derivative_rest import CONTROLLED_BOOM, _boom_state

#: the 3D latching wheel's arm deployed about its root by a prescribed hinge angle 0.4 t² + 0.1 sin 2t (a skew
#: axis), its wheel's hinge latching at 1.057 s
HINGE_DEPLOY = events.LATCH_3D.replace(
    "arm: {from: base, to: wheel, section: s, elements: 2,",
    "arm: {from: base, to: wheel, section: s, elements: 2, "
    'start: {hinge: {axis: [0.2, 0.1, 1.0], angle: "0.4*t**2 + 0.1*sin(2*t)"}},', 1).replace(
    "sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [k, c, J]").replace(
    "dt: 0.01,", "dt: 0.01, tol: 1.0e-10,", 1)
#: the 3D arm onto its rigid stop (restitution 0.5, at 1.058 s), its base translated by a prescribed motion
BASE_STOP = events.STOP_3D.replace(
    "base: {at: [0, 0, 0], fixed: true}",
    'base: {at: [0, 0, 0], motion: {translation: ["0.05*sin(3*t)", "0.03*t**2", "0.02*t**2"]}}').replace(
    "sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [k, c, J]").replace(
    "dt: 0.01,", "dt: 0.01, tol: 1.0e-10,", 1)
assert HINGE_DEPLOY.count("0.4*t**2") == BASE_STOP.count("0.03*t**2") == 1
assert HINGE_DEPLOY.count("1.0e-10") == BASE_STOP.count("1.0e-10") == 1
#: the 3D boom of every generated kind (tests/test_weight_derivative_parameters.py), its damped stay's anchor moved by
#: a prescribed translation: the stay's C_·p q̈_p moves along w too
MOVING_ANCHOR = PARAMETER_BOOM.replace(
    "anchor: {at: [1.2, -0.4, 1.1], fixed: true}",
    'anchor: {at: [1.2, -0.4, 1.1], motion: {translation: ["0.02*t**2", "0.1*t**3", "0.05*sin(2*t)"]}}', 1)
assert "0.1*t**3" in MOVING_ANCHOR
#: the boom whose latching hinge a PD of its angle and rate drives (tests/test_weight_derivative_rest.py), on a base
#: slewing by a prescribed rotation: the couplings are on free columns alone, no part of K_·p
CONTROLLED_SLEW = CONTROLLED_BOOM.replace(
    "base: {at: [0, 0, 0], fixed: true}",
    'base: {at: [0, 0, 0], motion: {rotation: {axis: [0.3, -0.2, 1.0], angle: "0.2*t**2"}}}', 1)
assert "0.2*t**2" in CONTROLLED_SLEW
STATES = {"hinge deploy": HINGE_DEPLOY, "base stop": BASE_STOP, "slewing boom": BOOM_SLEW,
          "moving anchor": MOVING_ANCHOR, "controlled slew": CONTROLLED_SLEW}


def _adjoint(text: str) -> str:
    out = text.replace("solve: {analysis: transient,", "solve: {analysis: transient, sensitivity_method: adjoint,", 1)
    assert out != text
    return out


@pytest.fixture
def prescribed_shifts(monkeypatch):
    """The owners whose time shift's part ``time_stiffness_along`` took with a prescribed motion (the forward
    method's and the adjoint's callers spied)."""
    seen = []
    original = parameter_stiffness.time_stiffness_along

    def spy(owner, state, w, full=None):
        if owner.explicit_time.prescribed:
            seen.append(owner)
        return original(owner, state, w, full=full)

    # the forward method and the adjoint take it through parameter_stiffness.time_shift_along
    monkeypatch.setattr(parameter_stiffness, "time_stiffness_along", spy)
    return seen


@pytest.mark.parametrize("name", list(STATES))
def test_the_prescribed_motions_time_part_is_generated_and_is_richardsons_of_the_rate_in_t_along_w(name):
    """At a deformed, moving state at t = 0.7 the time shift's part ∂(∂r/∂t)/∂q w — through the prescribed hinge
    angle, base translation, base slew, the damped stay's moving anchor, the PD-driven boom's slewing base — is the
    Richardson reference of ∂r/∂t along w (steps 1e-3, 5e-4 ℓ/|w|_∞) to 1e-10 of its largest entry (measured 1.7e-12,
    2.0e-11, 1.1e-11, 4.4e-13, 2.7e-12, about the reference's own spread between step pairs; the central difference
    of 0d1fc61, step 1e-5, 2.7e-10, 5.9e-10, 4.5e-10, 9.2e-11 off; without the stay's ∂(C a)/∂q w the anchor's was
    0.35 off)."""
    prepared, state, rng = _boom_state(STATES[name])
    state.t = 0.7
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=prepared.model.n_dofs)
    assert owner.explicit_time.prescribed and time_generated(owner)
    computed = owner._on_free_coordinates(state, time_stiffness_along(owner, state, w)[:, None])[:, 0]
    reference = _richardson_of_the_time_rate(owner, state, w, 1e-3)
    assert np.abs(reference).max() > 0.1
    assert np.abs(computed - reference).max() <= 1e-10 * np.abs(reference).max()


@pytest.mark.parametrize("name", ["hinge deploy", "base stop", "moving anchor", "controlled slew"])
def test_with_a_time_shift_every_parameter_is_generated_and_each_column_agrees_with_richardson(name):
    """With a random δt_e no parameter takes the difference, and each column of (∂K/∂p) w agrees with the
    Richardson reference of the static ∂r/∂p (its time shift's term included) along w to 1e-10 of its largest
    entry."""
    prepared, state, rng = _boom_state(STATES[name])
    state.t = 0.7
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=prepared.model.n_dofs)
    owner.time_shift = rng.normal(size=len(owner.names))
    assert exact_parameters(owner).all()
    computed = owner._stiffness_derivative(state, w)
    reference = _richardson_along(owner, state, w, 1e-3)
    scales = np.abs(reference).max(axis=0)
    assert np.all(scales > 1e-3)
    errors = np.abs(computed - reference).max(axis=0) / scales
    assert errors.max() <= 1e-10, dict(zip(owner.names, errors))


@pytest.mark.parametrize(("name", "parameter", "kind"), [("hinge deploy", "k", "latch"), ("base stop", "J", "stop")])
def test_whole_runs_agree_with_richardson_through_the_event_the_loop_on_and_off_the_same(name, parameter, kind,
                                                                                        prescribed_shifts):
    """Through the latch (1.057 s) and the stop (1.058 s) the sensitivities agree with Richardson differences of
    whole runs to 1e-7 of each probe's largest (measured 3.2e-10 for k, 5.1e-9 for J; 0d1fc61's difference gave the
    same digits), the event time to 1e-7; the generated path taken; the loop on and off the same bits."""
    text = STATES[name]
    runs = runs_with_the_loop_on_and_off(text)
    assert prescribed_shifts
    result = runs[True]
    assert [e["kind"] for e in result.summary["events"]] == [kind]
    for key, values in runs[False].sensitivities.items():
        np.testing.assert_array_equal(result.sensitivities[key], values, err_msg=str(key))
    assert result.summary["event_sensitivities"] == runs[False].summary["event_sensitivities"]
    assert events._agree(result, text, parameter, tolerance=1e-7) <= 1e-7


def test_latdyn_run_writes_the_apis_event_sensitivities_and_the_loop_off_the_same(tmp_path, prescribed_shifts):
    """``latdyn run`` of the hinge-deployed boom: exit 0, its event sensitivities the API's (whose time shift took
    the generated path), and with the loop of steps off the same files."""
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(HINGE_DEPLOY)))
    assert prescribed_shifts
    run, out = latdyn_run(tmp_path, HINGE_DEPLOY, quiet=True)
    assert run.returncode == 0, run.stderr
    assert summary_of(out)["event_sensitivities"] == api.summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("name", ["hinge deploy", "base stop"])
def test_the_adjoint_equals_the_forward_method(name, prescribed_shifts):
    """The adjoint's time shift (latdyn/analyses/adjoint_time.py ``shift_stiffness_along``) takes the same generated
    path: the two methods' probe sensitivities agree to 1e-10 (measured 1.1e-13, 9.4e-12)."""
    text = STATES[name]
    forward = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    prescribed_shifts.clear()
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(_adjoint(text))))
    assert prescribed_shifts
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


#: hinge laws whose slope ∂f/∂θ is not finite at θ = 0 (0d1fc61: the slope did not parse back as a law, the hinge's
#: angle differenced)
SLOPES_INFINITE_AT_ZERO = ["sqrt(abs(theta))", "abs(theta)**0.5", "theta**0.5", "theta**theta"]


@pytest.mark.parametrize("law", SLOPES_INFINITE_AT_ZERO)
def test_a_slope_infinite_at_zero_parses_as_a_law_of_the_state(law):
    """The law's slope parses back as a law of the state (``_angle_slope_law``; not checked finite at
    θ = θ̇ = t = 0, where it is never evaluated): at θ = 0.3 its value is the law's ∂f/∂θ and its own ∂/∂θ, the
    ∂²f/∂θ² H takes, is the Richardson difference of ∂f/∂θ (steps 1e-3, 5e-4) to 1e-9. (At the level of the law:
    a hinge whose own ∂f/∂θ is infinite at its start angle 0 cannot be prepared at all.)"""
    scene = latdyn.load_scene(yaml.safe_load(events.LATCH_3D))
    user = HingeLaw(f"1 + 0.2*{law}", scene.file, "beams.arm.end.hinge.stiffness")
    slope = _angle_slope_law(user, scene, "beams.arm.end.hinge.stiffness")
    assert slope is not None
    theta = 0.3
    assert slope.value(theta, 0.0, 0.0) == pytest.approx(user.d_theta(theta, 0.0, 0.0), rel=1e-14)
    central = [(user.d_theta(theta + h, 0.0, 0.0) - user.d_theta(theta - h, 0.0, 0.0)) / (2 * h) for h in (1e-3, 5e-4)]
    reference = (4 * central[1] - central[0]) / 3
    assert slope.d_theta(theta, 0.0, 0.0) == pytest.approx(reference, rel=1e-9)


#: the arm onto its stop at 0.5 rad with a torque 0.01 |θ − 0.5|^1.5: its ∂²f/∂θ² is infinite at the stop
INFINITE_AT_THE_STOP = events.STOP_3D.replace('damping: "c"', 'damping: "c", torque: "0.01*abs(theta - 0.5)**1.5"',
                                              1).replace("sensitivities: [k, c, J, m, EI, rho]", "sensitivities: [k]")
assert "abs(theta - 0.5)**1.5" in INFINITE_AT_THE_STOP


def test_a_second_derivative_infinite_at_the_event_is_refused_with_a_clear_message(tmp_path):
    """Through the API a SceneError naming solve.sensitivities, the law and the state (0d1fc61 carried inf or nan);
    through ``latdyn run`` exit 2, the message naming the file, no traceback."""
    with pytest.raises(SceneError, match=r"solve\.sensitivities.*abs\(theta - 0\.5\)\*\*1\.5.*not finite"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(INFINITE_AT_THE_STOP)))
    run, _ = latdyn_run(tmp_path, INFINITE_AT_THE_STOP, quiet=True)
    assert run.returncode == 2, run.stderr
    assert "scene.yaml" in run.stderr and "not finite" in run.stderr and "Traceback" not in run.stderr
