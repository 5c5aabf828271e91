"""A geometry parameter's part of an event's impulse weight derivative, (∂K/∂p) w, generated
(latdyn/analyses/parameter_stiffness.py ``_geometry``, docs/parameters.md "The impulse weight's derivative"): the new
kernel ``beam_stiffness_D_reference``, ∂(K_e v)/∂X along a variation of the reference data, against Richardson
differences of the product K_e v it differentiates (3D and ``default_xy``); on genuinely 3D scenes — the boom of
tests/test_adjoint_geometry.py swung into its latch, its hinge point (the base's ``at``, the root's offset) moved, and
the knee of tests/test_sensitivities_geometry.py whose hinge hits a rigid stop, a load at the moved offset — and on a
planar latch, no geometry parameter takes the central difference along w and each column agrees with Richardson
differences of the static ∂r/∂p along w; through the 3D events the whole runs' sensitivities agree with Richardson
differences of whole runs (API and ``latdyn run``), the loop of steps on and off giving the same bits."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import element_states as es
import latdyn
from latdyn.analyses import parameter_stiffness
from latdyn.analyses.parameter_stiffness import exact_parameters
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.assembly.prepare import prepare
from latdyn.model.kernels import load_kernels
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import runs_with_the_loop_on_and_off
from tests.test_adjoint_geometry import BOOM_LATCH, _richardson_error
from tests.test_sensitivities_events_gravity import LATCH_PLANAR_GRAVITY
from test_planar import planar_state, planar_velocity
from tests.test_sensitivities_geometry import KNEE_3D, _agree, _planar_reference, _reference_moved
from tests.test_weight_derivative_parameters import _richardson_along
from tests.test_weight_derivative_rest import _boom_state

#: the boom through its latch by the forward method (the event's (∂K/∂p) w is the forward method's; the adjoint takes
#: the same block, latdyn/analyses/adjoint_sensitivities.py)
BOOM = BOOM_LATCH.replace("sensitivity_method: adjoint, ", "").replace("title: a 3D boom", "title: a forward 3D boom")

#: the knee whose hinge stops rigidly at 0.07 rad (restitution 0.5, at t = 0.053 s) as the loads swing the hinged
#: beam, a load at the hinged beam's moved offset
KNEE_STOP = (KNEE_3D.replace("rest_angle: 0.1}}", "rest_angle: 0.1, limits: [-1.0, 0.07], restitution: 0.5}}", 1)
             .replace("  - {at: knee, force:", '  - {at: b.start, force: ["0.5*F", 0, "-F"], frame: knee}\n'
                      "  - {at: knee, force:", 1)
             .replace("t_end: 0.04", "t_end: 0.08", 1))

#: tests/test_sensitivities_events_gravity.py's planar arm latching under gravity, its tip body's x (the arm's length)
#: L a geometry parameter beside the others (``default_xy``)
PLANAR_LATCH = LATCH_PLANAR_GRAVITY.replace("sensitivities: [k, c, EI, rho, m]", "sensitivities: [k, L, EI, rho, m]", 1)


def test_the_stiffness_by_the_reference_is_richardsons_of_the_stiffness_along_v():
    """``beam_stiffness_D_reference`` at random 3D states, directions and reference variations is the derivative of
    ``beam_stiffness_D_q``'s K v along the variation (reference points, offsets, frames turned, L0, axes moved;
    Richardson, steps 1e-4 and 5e-5; measured ≤ 5.5e-12 relative)."""
    kernels = load_kernels(backend="auto", variant="default")
    rng = np.random.default_rng(34)
    for _ in range(4):
        state = es.random_state(rng)
        reference = rng.normal(size=25)
        reference[18] *= 0.1
        v = rng.normal(size=14)

        _assert_richardsons_of_the_stiffness_along(kernels, state, reference, v)


def _assert_richardsons_of_the_stiffness_along(kernels, state, reference, v) -> None:
    """``beam_stiffness_D_reference``'s ∂(K v)/∂X along ``reference`` at ``state`` is Richardson's extrapolation of
    central differences of ``beam_stiffness_D_q``'s K v with the reference moved (steps 1e-4, 5e-5), to 1e-7."""
    def along(eps):
        geometry, section = _reference_moved(state, reference, eps)
        return np.asarray(kernels.beam_stiffness_D_q(geometry, v[None], section)[0])[0]

    computed = np.asarray(kernels.beam_stiffness_D_reference(state.geometry(), v[None], state.section[None],
                                                             reference[None])[1]).reshape(14)
    h = 1e-4
    central = [(along(s) - along(-s)) / (2 * s) for s in (h, h / 2)]
    numeric = (4 * central[1] - central[0]) / 3
    assert np.abs(computed - numeric).max() <= 1e-7 * np.abs(numeric).max()


def test_the_planar_stiffness_by_the_reference_is_richardsons_of_the_stiffness_along_v():
    """``default_xy``: the same along in-plane variations (moved fixed ends, offsets, frames turned about z, L0) at
    random planar states with hinges and offsets, along in-plane directions (measured ≤ 4.3e-12 relative)."""
    kernels = load_kernels(backend="auto", variant="default_xy")
    rng = np.random.default_rng(35)
    for _ in range(3):
        state = planar_state(rng, 2, deformation=0.3)
        reference, v = _planar_reference(rng, 2), planar_velocity(rng, 2)

        _assert_richardsons_of_the_stiffness_along(kernels, state, reference, v)


@pytest.mark.parametrize("text", [BOOM, KNEE_STOP, PLANAR_LATCH], ids=["boom", "knee", "planar_latch"])
def test_no_geometry_parameter_takes_the_difference_and_each_column_agrees_with_richardson(text):
    """At a deformed, turned state of each scene every geometry parameter's (∂K/∂p) w is generated (before: the
    central difference of the static ∂r/∂p along w, step 1e-5 ℓ/|w|_∞) and agrees with the Richardson reference
    of that quantity (steps 3e-4 and 1.5e-4 ℓ/|w|_∞) to 2e-11 of each column's largest entry (measured ≤ 4.2e-12;
    the difference it replaces 1.3e-10 – 6.5e-9; the planar latch's L, ``default_xy``, 1.5e-13 where the difference
    was 4.1e-10)."""
    prepared, state, rng = _boom_state(text)
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=prepared.model.n_dofs)
    assert exact_parameters(owner).all(), dict(zip(owner.names, exact_parameters(owner)))
    computed = owner._stiffness_derivative(state, w)
    reference = _richardson_along(owner, state, w, 3e-4)
    scales = np.abs(reference).max(axis=0)
    moving = scales > 0.0   # a parameter that moves no K w here (the planar latch's load and mass): 0 both ways
    assert moving[[owner.names.index(name) for name in owner.names if name in ("bx", "oy", "oz", "X", "Y", "tz",
                                                                              "dy", "L")]].all()
    assert not np.any(computed[:, ~moving])
    errors = np.abs(computed[:, moving] - reference[:, moving]).max(axis=0) / scales[moving]
    assert errors.max() <= 2e-11, dict(zip(np.array(owner.names)[moving], errors))


def test_a_hinge_axis_is_generated_beside_the_others():
    """A moved hinge axis is generated as the other geometry parameters beside it (``beam_stiffness_D_reference``'s
    second variation holds its nodal frame's turn T_j θ J(θa) δa moving with θ: the column against Richardson,
    tests/test_sensitivities_time_shift_exact.py; it kept the difference on 40bf44a)."""
    text = (KNEE_STOP.replace("axis: [0, 0.6, 0.8]", 'axis: [0, "ay", 0.8]', 1)
            .replace("F: 2.0}", "F: 2.0, ay: 0.6}", 1).replace("sensitivities: [X, Y, tz, dy]",
                                                                "sensitivities: [X, ay, dy]", 1))
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    owner = TransientSensitivities(prepared)
    assert dict(zip(owner.names, exact_parameters(owner))) == {"X": True, "ay": True, "dy": True}


def _runs_through_the_generated_path(text: str) -> dict:
    """The runs of ``text`` with the loop of steps on and off, each event's (∂K/∂p) w asserted to have taken the
    geometry's generated part (``parameter_stiffness._geometry`` called with a direction, every column exact; on
    ea72688 there is none: the difference along w)."""
    calls = []
    generated = parameter_stiffness._geometry

    def spy(owner, state, full, total):
        if getattr(owner, "geometry", None) is not None:   # not the laws' rates in t (no geometry there)
            calls.append(bool(np.any(full)) and exact_parameters(owner).all())
        return generated(owner, state, full, total)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(parameter_stiffness, "_geometry", spy)
        runs = runs_with_the_loop_on_and_off(text)
    assert calls and all(calls), calls
    return runs


@pytest.fixture(scope="module")
def boom_runs():
    return _runs_through_the_generated_path(BOOM)


@pytest.fixture(scope="module")
def knee_runs():
    return _runs_through_the_generated_path(KNEE_STOP)


def _loop_keeps_the_bits(runs):
    native, python = runs[True], runs[False]
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


@pytest.mark.parametrize("name", ["bx", "oz"])
def test_through_the_latch_the_boom_agrees_with_richardson_of_whole_runs(boom_runs, name):
    """Through the latch at 0.41 s (generated (∂K/∂p) w) each probe's end by the base's x and the offset's z agrees
    with Richardson differences of whole runs landing on the latch (steps 1e-4 and 5e-5, as
    tests/test_adjoint_geometry.py), the loop on and off the same bits."""
    assert [e["kind"] for e in boom_runs[True].summary["events"]] == ["latch"]
    _loop_keeps_the_bits(boom_runs)
    assert _richardson_error(boom_runs[True].summary["probe_sensitivities"], BOOM, name, 1e-4, landed=True) <= 1e-6


@pytest.mark.parametrize("name", ["X", "dy"])
def test_through_the_rigid_stop_the_knee_agrees_with_richardson_of_whole_runs(knee_runs, name):
    """Through the hinge's rigid stop the sensitivities by the knee's x and the moved offset (a load at it) agree
    with Richardson differences of whole runs landing on the stop, the loop on and off the same bits."""
    assert [e["kind"] for e in knee_runs[True].summary["events"]] == ["stop"]
    _loop_keeps_the_bits(knee_runs)
    assert _agree(knee_runs[True], KNEE_STOP, name, 1e-6, landed=True) <= 1e-6


def test_latdyn_run_writes_the_apis_event_sensitivities(tmp_path, knee_runs):
    """``latdyn run`` of the knee: summary.json's event sensitivities are the API's; the loop off writes the same."""
    run, out = latdyn_run(tmp_path, KNEE_STOP)
    assert run.returncode == 0, run.stderr
    assert summary_of(out)["event_sensitivities"] == knee_runs[True].summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)
