"""The parameter part of an event's impulse weight on models with rigid links or guides beside controllers, generated
through the reduction (issue 34; latdyn/analyses/parameter_stiffness.py ``linked_controller_parameter_along``,
transient_sensitivities.py ``_linked_stiffness_along``; docs/parameters.md, "The impulse weight's derivative").

K_red = Pᵀ K_all P + ∂Pᵀ/∂q · r_all is ∂r/∂q at every assembled rate held, so (∂K_red/∂p) w = Pᵀ (∂K_all/∂p)(P w) +
∂Pᵀ/∂q[w] · ∂r_all/∂p: the parameters' own generated terms and the controllers' (SymPy's mixed second derivatives
times the sensors' generated gradients by the assembled coordinates, a dependent node's too) along u = P w, projected
by Pᵀ, and the reduction's geometric term of the static ∂r_all/∂p. 0d1fc61 took a central difference of the whole
static ∂r/∂p along w (two evaluations a parameter's columns at each event).

On 3D YAML scenes: the gimbal of rigid links on skew hinges latching, a PD of a point at an offset on its inner ring
(a dependent node: position, velocity, velocity in the tip's axes); the guided mass on a skew guide bouncing on its
stop, a PD of its slide and rate driving a follower force and moment and a global force on it; the deploying chain of
rigid bays latching twice, a PD of points' positions and velocities; the same chain with a PI (a controller state)
and its first hinge against a compliant stop."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run_switched, summary_of, the_loop_off_writes_the_same
from tests.test_adjoint_in_loop_links import _adjoint, _largest_gap
from tests.test_sensitivities_events import _agree
from tests.test_weight_derivative_linked_controllers import CHAIN_VELOCITY
from tests.test_weight_derivative_linked_last import BEAD_PD, GIMBAL_VELOCITY

#: the chain of rigid bays latching, its first hinge against a compliant stop at 0.95 rad, a PI (its state E the
#: integral of the second point's x error) of points' positions and velocities driving the second hinge
CHAIN_PI = (CHAIN_VELOCITY
            .replace("rest_angle: pi/3 + 0.3, lock_at: pi/3}",
                     "rest_angle: pi/3 + 0.3, limits: [-1.0, 0.95],\n"
                     "                           contact: {stiffness: 400.0, exponent: 2, damping: 0.5}}")
            .replace("parameters: {Kp: 0.4,", "parameters: {Ki: 2.0, Kp: 0.4,")
            .replace('pd: {output: "Kp*(0.45 - s2x) - Kd*v1z*(1 + 4*s2x) - Kd*v2x*s1z + 2*Kd*v1z**2*s1z"}',
                     'pd: {output: "Kp*(0.45 - s2x) + Ki*E*(1 + s1z) - Kd*v1z*(1 + 4*s2x) - Kd*v2x*s1z", '
                     'states: {E: "0.45 - s2x"}}')
            .replace("sensitivities: [Kd, Kp, k, m]", "sensitivities: [Ki, Kd, Kp, k]"))
assert "contact: {stiffness: 400.0" in CHAIN_PI and "states: {E" in CHAIN_PI and "[Ki, Kd, Kp, k]" in CHAIN_PI

#: {name: (scene, its events, the parameters whose whole runs are compared with Richardson)}
SCENES = {"the gimbal's PD of a point's velocities": (GIMBAL_VELOCITY, ["latch"], ["Kp", "k1"]),
          "the guided mass's PD-driven loads": (BEAD_PD, ["stop"], ["Kc", "k"]),
          "the chain's PD of points' positions and velocities": (CHAIN_VELOCITY, ["latch", "latch"], ["Kd", "k"]),
          "the chain's PI at a stop": (CHAIN_PI, ["latch"], ["Ki", "Kp"])}


def _difference_at(owner, state, w, step: float) -> np.ndarray:
    """0d1fc61's (∂K/∂p) w: the central difference of the static ∂r/∂p along w at the assembled rates held
    (``_stiffness_derivative`` with no parameter exact), its step ``step`` ℓ/|w|_∞."""
    from latdyn.analyses import transient_sensitivities as ts

    exact, weight_step = ts.exact_parameters, ts.WEIGHT_STEP
    ts.exact_parameters = lambda o: np.zeros(len(o.names), bool)
    ts.WEIGHT_STEP = step
    try:
        return owner._stiffness_derivative(state, w)
    finally:
        ts.exact_parameters, ts.WEIGHT_STEP = exact, weight_step


def turned(text: str, seed: int = 11, size: float = 0.05) -> tuple:
    """(the scene's TransientSensitivities, its initial state turned and deformed by ``size`` times a normal draw with
    random rates and accelerations, a random w)."""
    from latdyn.analyses.transient_sensitivities import TransientSensitivities
    from latdyn.assembly.prepare import prepare
    from tests.test_weight_derivative_linked import turned_state

    _, state, rng = turned_state(text, seed, size)
    owner = TransientSensitivities(prepare(latdyn.load_scene(yaml.safe_load(text))))
    owner.assembler.complete_links(state)
    return owner, state, rng.normal(size=owner.model.n_dofs)


def parameter_part_and_reference(owner, state, w) -> tuple:
    """(0d1fc61's single central difference of (∂K/∂p) w at ``state`` along ``w``, the Richardson reference of the
    same quantity): the central differences of the static ∂r/∂p along w at the assembled rates held, steps 4e-4 and
    2e-4 ℓ/|w|_∞, extrapolated (h⁴ truncation left; round-off ε |∂r/∂p| / 2e-4)."""
    from latdyn.analyses.transient_sensitivities import WEIGHT_STEP

    single = _difference_at(owner, state, w, WEIGHT_STEP)
    d1, d2 = (_difference_at(owner, state, w, step) for step in (4e-4, 2e-4))
    return single, (4 * d2 - d1) / 3


def relative_errors(names, computed, reference) -> dict:
    """{parameter: the largest error of its column relative to the reference's largest entry}."""
    largest = float(np.max(np.abs(reference)))
    return {p: float(np.max(np.abs(computed[:, c] - reference[:, c]))) / largest for c, p in enumerate(names)}


def _counting(monkeypatch) -> list:
    """The evaluations of the static ∂r/∂p the difference takes (each at a configuration advanced along ±w,
    ``_advanced_at_held_rates``), counted."""
    from latdyn.analyses.transient_sensitivities import TransientSensitivities

    held, calls = TransientSensitivities._advanced_at_held_rates, []

    def counted(self, *args, **kwargs):
        calls.append(1)
        return held(self, *args, **kwargs)

    monkeypatch.setattr(TransientSensitivities, "_advanced_at_held_rates", counted)
    return calls


@pytest.mark.parametrize("name", list(SCENES))
def test_the_parameter_part_is_generated_through_the_reduction(name, monkeypatch):
    """(∂K/∂p) w at a turned state with random rates, no evaluation of the static ∂r/∂p along w taken (0d1fc61: two
    a call), against the Richardson reference of the same quantity (relative to its largest entry): measured
    1.2e-13 (gimbal), 1.3e-15 – 8.6e-13 (guided mass), 8.9e-14 – 4.6e-12 (chains); 0d1fc61's single difference
    4.1e-12 – 7.5e-12, 4.6e-12 – 2.4e-10, 9.8e-12 – 7.0e-11."""
    owner, state, w = turned(SCENES[name][0])
    calls = _counting(monkeypatch)
    computed = owner._stiffness_derivative(state, w)
    assert not calls
    _, reference = parameter_part_and_reference(owner, state, w)
    errors = relative_errors(owner.names, computed, reference)
    assert max(errors.values()) <= 2e-11, errors


@pytest.mark.parametrize("name", list(SCENES))
def test_the_events_take_no_difference(name, monkeypatch):
    """Through the API at every event no evaluation of the static ∂r/∂p along w (0d1fc61: 2 on the gimbal, 4 on the
    guided mass, 4 on the chain latching twice, 2 on the chain's PI: two a weighing)."""
    text, events, _ = SCENES[name]
    calls = _counting(monkeypatch)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert [e["kind"] for e in result.summary["events"]] == events
    assert not calls


@pytest.mark.parametrize("name", ["the gimbal's PD of a point's velocities", "the chain's PI at a stop"])
def test_whole_runs_agree_with_richardson_and_the_adjoint(name, monkeypatch):
    """The adjoint's derivatives (it takes the forward method's (∂K/∂p) w) against the forward method's ≤ 1e-10, with
    no difference taken; the gimbal's whole runs by Kp against Richardson central differences of whole runs
    (measured 1.0e-7; the chain's PI by Ki 1.7e-7, not run here for the suite's time; both the same on 0d1fc61 to two
    digits)."""
    text, _, parameters = SCENES[name]
    calls = _counting(monkeypatch)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(_adjoint(text))))
    assert not calls
    if parameters[0] == "Kp":
        assert _agree(result, text, parameters[0], tolerance=1e-6) < 1e-6
    assert _largest_gap(adjoint.summary["probe_sensitivities"], result.summary["probe_sensitivities"]) <= 1e-10


#: ``latdyn run`` with the difference of the static ∂r/∂p along w forbidden (raises where it is taken)
_FORBIDDEN = ("import latdyn.analyses.transient_sensitivities as t; "
              "t.TransientSensitivities._advanced_at_held_rates = "
              "lambda *a, **k: (_ for _ in ()).throw(AssertionError('the static dr/dp differenced'))")


def test_the_chains_pi_through_the_cli_loop_on_and_off(tmp_path):
    """``latdyn run`` of the chain's PI with the difference forbidden (0d1fc61 fails there), its event sensitivities
    the API's, and the loop of steps off writing the same bytes (the events take the Python path on both)."""
    text = SCENES["the chain's PI at a stop"][0]
    (tmp_path / "scene.yaml").write_text(text)
    out = tmp_path / "out"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", out, _FORBIDDEN)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert [e["kind"] for e in summary["events"]] == ["latch"]
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert json.loads(json.dumps(result.summary["event_sensitivities"])) == summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)


#: the guided mass with its follower moment's y a law in t (0.05 sin 4t, in the slider's axes, a dependent node): an
#: event's time shift moves it, ∂(∂r/∂t)/∂q w δt_e turning with the node
BEAD_IN_TIME = BEAD_PD.replace('moment: [0.01, 0, "0.02 + 0.1*push"]',
                               'moment: [0.01, "0.05*sin(4*t)", "0.02 + 0.1*push"]')
assert "0.05*sin(4*t)" in BEAD_IN_TIME


def test_the_time_shifts_part_is_generated_through_the_reduction(monkeypatch):
    """The event's time shift's part of (∂K/∂p) w on the guided mass with a follower moment in t (the difference of
    (∂K/∂p) w with δt_e less without), no evaluation of the static ∂r/∂p: against the Richardson reference of the
    same quantity measured 3.6e-12 of its largest (0d1fc61's single difference 1.0e-11); through the API the stop takes
    no difference (0d1fc61: 2 a weighing), the whole run by Kc agrees with Richardson differences of whole runs
    (6.4e-7, as on 0d1fc61) and the adjoint with the forward method (7.5e-14)."""
    owner, state, w = turned(BEAD_IN_TIME)
    parts = []
    for shift in (np.linspace(0.3, 1.1, len(owner.names)), None):
        owner.time_shift = shift
        calls = _counting(monkeypatch)
        computed = owner._stiffness_derivative(state, w)
        assert not calls
        parts.append((computed, parameter_part_and_reference(owner, state, w)[1]))
    computed, reference = parts[0][0] - parts[1][0], parts[0][1] - parts[1][1]
    assert float(np.max(np.abs(computed - reference))) <= 1e-11 * float(np.max(np.abs(reference)))
    calls = _counting(monkeypatch)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(BEAD_IN_TIME)))
    assert [e["kind"] for e in result.summary["events"]] == ["stop"]
    assert not calls
    assert _agree(result, BEAD_IN_TIME, "Kc", tolerance=2e-6) < 2e-6
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(_adjoint(BEAD_IN_TIME))))
    assert _largest_gap(adjoint.summary["probe_sensitivities"], result.summary["probe_sensitivities"]) <= 1e-10
