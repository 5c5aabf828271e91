"""An event's time shift through a reel and a continuous controller's output in t, generated (latdyn/analyses/
parameter_stiffness.py ``time_stiffness_along``, docs/parameters.md "The impulse weight's derivative"): at an event
moved in time by δt_e the weight's parameter part holds ∂(∂r/∂t)/∂q w δt_e; on 40bf44a every parameter of a run with
a reel or a controller naming t took the central difference of the whole static ∂r/∂p along w for it. On the 3D
latching boom of tests/test_weight_derivative_parameters.py with its stay paid out by a reel (rest length
0.9 + 0.05 t, taut through the latch at 0.79 s), and on the boom driven by a PD whose reference is a ramp in t (its
damping gain growing with t) latching at 1.03 s and, its hinge given a rigid stop instead, bouncing off it: the time
shift's part is Richardson's of ∂r/∂t along w, no parameter takes the difference, each column of (∂K/∂p) w agrees with
Richardson's, and through the events the whole runs' sensitivities agree with Richardson differences of whole runs
(API and ``latdyn run``), the loop of steps on and off giving the same bits, the adjoint the forward method's. A
moved hinge axis (the 3D boom through its latch, its root hinge's axis tilted by a parameter; the knee onto its rigid
stop): its (∂K/∂p) w column is generated — ``beam_stiffness_D_reference``'s product holds the axis's turn moving
with θ, which 40bf44a differenced — and agrees with Richardson's, the whole runs with Richardson's of whole runs, the
adjoint with the forward method."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses import parameter_stiffness
from latdyn.analyses.parameter_stiffness import exact_parameters, time_generated, time_stiffness_along
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import runs_with_the_loop_on_and_off
from tests.test_adjoint_geometry import BOOM_LATCH, _richardson_error
from tests.test_sensitivities_adjoint import _disagreement
from tests.test_sensitivities_events import _agree
from tests.test_weight_derivative_geometry import KNEE_STOP, _loop_keeps_the_bits
from tests.test_weight_derivative_geometry import _runs_through_the_generated_path as _runs_through_the_geometry_kernel
from tests.test_weight_derivative_parameters import PARAMETER_BOOM, _richardson_along
from tests.test_weight_derivative_rest import CONTROLLED_BOOM, _boom_state

#: the 3D latching boom of every generated kind, its stay paid out by a reel (taut through the latch at 0.79 s)
REEL_BOOM = (PARAMETER_BOOM.replace("rest_length: 0.9", 'rest_length: "0.9 + 0.05*t"', 1)
             .replace("title: a wheel", "title: a reeled wheel", 1)
             .replace("dt: 0.01,", "dt: 0.01, tol: 1.0e-10,", 1))
#: the controlled boom, its PD's reference a ramp 0.3 + 0.2 t and its damping growing with t: latches at 1.03 s
RAMP_BOOM = (CONTROLLED_BOOM.replace('"-Kp*sin(angle - 0.3)', '"-Kp*sin(angle - 0.3 - 0.2*t)', 1)
             .replace("Kd*rate*(1 + angle**2)", "Kd*rate*(1 + angle**2 + 0.5*t*angle**2)", 1)
             .replace("title: a wheel", "title: a ramp-driven wheel", 1)
             .replace("dt: 0.01,", "dt: 0.01, tol: 1.0e-10,", 1))
#: the same hinge onto a rigid stop at 0.5 rad (restitution 0.5, at 1.028 s), ended before the wheel comes back
RAMP_STOP = (RAMP_BOOM.replace("lock_at: 0.5", "limits: [-10, 0.5], restitution: 0.5", 1)
             .replace("t_end: 1.1", "t_end: 1.04", 1))
assert REEL_BOOM.count("0.05*t") == 1 and RAMP_BOOM.count("0.2*t") == 1 and "limits" in RAMP_STOP
assert REEL_BOOM.count("1.0e-10") == RAMP_BOOM.count("1.0e-10") == 1
STATES = {"reel": REEL_BOOM, "ramp": RAMP_BOOM}


def _richardson_of_the_time_rate(owner, state, w: np.ndarray, eta: float) -> np.ndarray:
    """∂(∂r/∂t)/∂q w (n,) of the static residual as Richardson-extrapolated central differences along w (steps η,
    η/2 relative to ℓ/|w|_∞) of ExplicitTime's ∂r/∂t without the inertia forces."""
    step = eta * (owner.length or 1.0) / float(np.max(np.abs(w)))
    advance = owner.assembler.advance

    def rate(moved):
        return owner.explicit_time(moved, False)

    central = [(rate(advance(state, h * w)) - rate(advance(state, -h * w))) / (2 * h) for h in (step, step / 2)]
    return (4 * central[1] - central[0]) / 3


@pytest.mark.parametrize("name", list(STATES))
def test_the_time_shifts_part_is_generated_and_is_richardsons_of_the_rate_in_t_along_w(name):
    """At a deformed, moving state the time shift's part ∂(∂r/∂t)/∂q w — the reel's ∂(K_c w)/∂L0 · share · L0′ from
    ``cable_stiffness_D_rest_length``, the PD's ∂²(∂y/∂t)/∂θ² through its actuator from SymPy — is the Richardson
    reference of ∂r/∂t along w (steps 1e-3, 5e-4 ℓ/|w|_∞) to 1e-11 (measured 1.5e-13, 8.7e-13; on 40bf44a the
    function left both out: the difference of the whole ∂r/∂p took them, step 1e-5, 2.9e-12 and 4.6e-11 off)."""
    prepared, state, rng = _boom_state(STATES[name])
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=prepared.model.n_dofs)
    assert time_generated(owner)
    computed = owner._on_free_coordinates(state, time_stiffness_along(owner, state, w)[:, None])[:, 0]
    reference = _richardson_of_the_time_rate(owner, state, w, 1e-3)
    assert np.abs(reference).max() > 1e-3
    assert np.abs(computed - reference).max() <= 1e-11 * np.abs(reference).max()


@pytest.mark.parametrize("name", list(STATES))
def test_with_a_time_shift_no_parameter_takes_the_difference_and_each_column_agrees_with_richardson(name):
    """With a random time shift δt_e every parameter's (∂K/∂p) w is generated (on 40bf44a none: the central
    difference of the static ∂r/∂p along w) and agrees with the Richardson reference of that quantity with its time
    shift's term (steps 1e-3, 5e-4) to 5e-11 of each column's largest (measured ≤ 5.4e-12; the difference 1.4e-12 …
    3.1e-10)."""
    _assert_every_column_generated_and_richardsons(STATES[name], 1e-3, 5e-11, shifted=True)


def _assert_every_column_generated_and_richardsons(text: str, eta: float, bound: float, shifted: bool) -> None:
    """At ``text``'s deformed, moving state (with a random time shift where ``shifted``) every parameter's (∂K/∂p) w
    is generated and each column is within ``bound`` of its largest off the Richardson reference (steps η, η/2)."""
    prepared, state, rng = _boom_state(text)
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=prepared.model.n_dofs)
    if shifted:
        owner.time_shift = rng.normal(size=len(owner.names))
    assert exact_parameters(owner).all(), dict(zip(owner.names, exact_parameters(owner)))
    computed = owner._stiffness_derivative(state, w)
    reference = _richardson_along(owner, state, w, eta)
    scales = np.abs(reference).max(axis=0)
    assert np.all(scales > 0.0)
    errors = np.abs(computed - reference).max(axis=0) / scales
    assert errors.max() <= bound, dict(zip(owner.names, errors))


def _through_the_generated_path(run):
    """``run()``'s value, each event's time shift asserted to have taken the generated part (``time_stiffness_along``
    called at a shifted event, every parameter exact; on 40bf44a it is not called there: the difference along w)."""
    calls = []
    generated = parameter_stiffness.time_stiffness_along

    def spy(owner, state, w, full=None):
        calls.append(bool(np.any(owner.time_shift)) and exact_parameters(owner).all())
        return generated(owner, state, w, full=full)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(parameter_stiffness, "time_stiffness_along", spy)
        out = run()
    assert calls and all(calls), calls
    return out


def _runs_through_the_generated_path(text: str) -> dict:
    """The runs of ``text`` with the loop of steps on and off (:func:`_through_the_generated_path`)."""
    return _through_the_generated_path(lambda: runs_with_the_loop_on_and_off(text))


@pytest.fixture(scope="module")
def reel_runs():
    return _runs_through_the_generated_path(REEL_BOOM)


@pytest.fixture(scope="module")
def stop_runs():
    return _runs_through_the_generated_path(RAMP_STOP)


@pytest.mark.parametrize("name", ["EA", "k"])
def test_through_the_latch_the_reeled_boom_agrees_with_richardson_of_whole_runs(reel_runs, name):
    """Through the latch at 0.79 s, the stay reeled out, each probe by the stay's EA and the hinge's k agrees with
    Richardson differences of whole runs (steps 1e-4, 5e-5 of the value) to 1e-6, the latch's time to 1e-7, the loop
    on and off the same bits."""
    assert [e["kind"] for e in reel_runs[True].summary["events"]] == ["latch"]
    _loop_keeps_the_bits(reel_runs)
    assert _agree(reel_runs[True], REEL_BOOM, name) <= 1e-6


@pytest.mark.parametrize("name", ["Kp", "k"])
def test_through_the_rigid_stop_the_ramp_driven_boom_agrees_with_richardson_of_whole_runs(stop_runs, name):
    """Through the rigid stop at 1.028 s, the PD's reference ramping in t, each probe by Kp and k agrees with
    Richardson differences of whole runs to 1e-6, the stop's time to 1e-7, the loop on and off the same bits."""
    assert [e["kind"] for e in stop_runs[True].summary["events"]] == ["stop"]
    _loop_keeps_the_bits(stop_runs)
    assert _agree(stop_runs[True], RAMP_STOP, name) <= 1e-6


def test_latdyn_run_writes_the_apis_event_sensitivities(tmp_path, stop_runs):
    """``latdyn run`` of the ramp-driven boom onto its stop: summary.json's event sensitivities are the API's; the
    loop off writes the same."""
    run, out = latdyn_run(tmp_path, RAMP_STOP)
    assert run.returncode == 0, run.stderr
    assert summary_of(out)["event_sensitivities"] == stop_runs[True].summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("text", [REEL_BOOM, RAMP_BOOM], ids=["reel", "ramp"])
def test_the_adjoint_is_the_forward_method(text):
    """The adjoint (latdyn/analyses/adjoint_time.py ``shift_stiffness_along``: the forward method's generated time
    shift's part, ``time_stiffness_along``, taken alone) is the forward method's through the latch: every probe's end,
    max and min to 1e-10 of that output's largest derivative (measured 2.9e-12, 2.4e-11; 3.0e-12, 2.4e-11 on 40bf44a
    with the difference)."""
    forward = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    data = yaml.safe_load(text)
    data["solve"]["sensitivity_method"] = "adjoint"
    calls = []
    generated = parameter_stiffness.time_stiffness_along

    def spy(owner, state, w, full=None):
        calls.append(True)
        return generated(owner, state, w, full=full)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(parameter_stiffness, "time_stiffness_along", spy)
        adjoint = latdyn.run(latdyn.load_scene(data))
    assert calls   # the reverse pass's events took the generated time shift's part
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


# ---------------------------------------------------------------------------------------------- a moved hinge axis
#: the 3D boom of tests/test_adjoint_geometry.py swung into its latch at 0.41 s by the forward method, its root hinge's
#: axis tilted by a parameter az (its z component)
AXIS_BOOM = (BOOM_LATCH.replace("sensitivity_method: adjoint, ", "")
             .replace("axis: [1, -2, 0.5]", 'axis: [1, -2, "az"]', 1)
             .replace("k: 20.0}", "k: 20.0, az: 0.5}", 1)
             .replace("sensitivities: [bx, oy, oz, k]", "sensitivities: [az, bx, k]", 1)
             .replace("title: a 3D boom", "title: a tilted 3D boom", 1))
#: the knee of tests/test_sensitivities_geometry.py onto its rigid stop, its hinge axis's y a parameter
AXIS_KNEE = (KNEE_STOP.replace("axis: [0, 0.6, 0.8]", 'axis: [0, "ay", 0.8]', 1)
             .replace("F: 2.0}", "F: 2.0, ay: 0.6}", 1)
             .replace("sensitivities: [X, Y, tz, dy]", "sensitivities: [X, ay, dy]", 1))
assert AXIS_BOOM.count('"az"') == 1 and "[az, bx, k]" in AXIS_BOOM and AXIS_KNEE.count('"ay"') == 1


@pytest.mark.parametrize("text", [AXIS_BOOM, AXIS_KNEE], ids=["boom", "knee"])
def test_a_moved_hinge_axis_takes_no_difference_and_agrees_with_richardson(text):
    """At a deformed, turned state every column — the hinge axis's too — is generated (on 40bf44a the axis's column
    took the central difference of the static ∂r/∂p along w: the axis's turn of the nodal frame, T_j θ J(θa) δa, was
    thought to move with θ beyond ``beam_stiffness_D_reference``'s second variation; measured, it does not) and
    agrees with the Richardson reference of (∂K/∂p) w (steps 3e-4, 1.5e-4 ℓ/|w|_∞) to 2e-11 of each column's largest
    (measured: the axis's column 4.7e-13 on the knee, 1.5e-13 on the boom)."""
    _assert_every_column_generated_and_richardsons(text, 3e-4, 2e-11, shifted=False)


@pytest.fixture(scope="module")
def axis_runs():
    """The tilted boom's runs, loop on and off, each event's geometry part generated for every parameter (on
    40bf44a the axis's column was not: tests/test_weight_derivative_geometry.py's spy)."""
    return _runs_through_the_geometry_kernel(AXIS_BOOM)


def test_through_the_latch_the_tilted_boom_agrees_with_richardson_of_whole_runs(axis_runs):
    """Through the latch at 0.41 s (the axis's (∂K/∂p) w generated) each probe's end by az agrees with Richardson
    differences of whole runs landing on the latch (steps 1e-4, 5e-5 of az) to 1e-6 of the largest, the loop on and
    off the same bits."""
    assert [e["kind"] for e in axis_runs[True].summary["events"]] == ["latch"]
    _loop_keeps_the_bits(axis_runs)
    assert _richardson_error(axis_runs[True].summary["probe_sensitivities"], AXIS_BOOM, "az", 1e-4,
                             landed=True) <= 1e-6


def test_latdyn_run_of_the_tilted_boom_writes_the_apis_event_sensitivities(tmp_path, axis_runs):
    """``latdyn run`` of the tilted boom: summary.json's event sensitivities are the API's; the loop off writes the
    same."""
    run, out = latdyn_run(tmp_path, AXIS_BOOM)
    assert run.returncode == 0, run.stderr
    assert summary_of(out)["event_sensitivities"] == axis_runs[True].summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)


def test_the_tilted_booms_adjoint_is_the_forward_method(axis_runs):
    """The adjoint through the tilted boom's latch (its transposes read the forward method's generated (∂K/∂p) w, the
    axis's column too) is the forward method's: every probe's end, max and min to 1e-10 of that output's largest
    derivative (measured 1.3e-12, as on 40bf44a with the axis's difference)."""
    adjoint = _runs_through_the_geometry_kernel(AXIS_BOOM.replace("solve: {analysis: transient, ",
                                                                  "solve: {analysis: transient, "
                                                                  "sensitivity_method: adjoint, ", 1))[True]
    forward = axis_runs[True].summary["probe_sensitivities"]
    assert _disagreement(forward, adjoint.summary["probe_sensitivities"]) <= 1e-10
