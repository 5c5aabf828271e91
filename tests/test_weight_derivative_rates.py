"""The impulse weight's derivative along the rates, ∂(K w)/∂v δv, generated (issue 34; latdyn/analyses/
weight_derivative.py "Along the rates", docs/parameters.md "The impulse weight's derivative"): a hinge's
∂²f/∂θ∂θ̇ from the generated ``hinge_stiffness_by_rate`` (codegen/joints.py: its laws to second order in (θ, θ̇), a
compliant stop's Hunt–Crossley damping in contact) against central differences of ``hinge_force``'s ∂f/∂θ along the
rate; a continuous controller's couplings from SymPy's mixed second derivatives of its output by (angle, rate); at a
turned, moving state of genuinely 3D arms (a hinge law of θ and θ̇, a damped compliant stop in contact, a PD nonlinear
in angle and rate) the term with no evaluation of the model, against Richardson-extrapolated central differences of
the moving block's K w (the central difference of the whole K w it replaces was 5.5e-8 … 1.7e-7 off); loads a
controller of angles and rates drives, their block and couplings, the same; a hinge law naming an input, at the
input's value at the event, the same (86d57d9 differenced it); and whole runs through a latch and a rigid stop against
Richardson differences of whole runs (API and ``latdyn run``), the loop of steps on and off to the bit, the adjoint
with the forward method — each with no difference of K w along δv left at the events."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
import yaml

import latdyn
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.analyses.weight_derivative import STIFFNESS_BLOCKS
from latdyn.assembly.assembler import Assembler, free_velocity, unpack_free
from latdyn.model.kernels import load_kernels
from latdyn.scene.expressions import HingeLaw
from tests.cli_runs import latdyn_run, summary_of
from tests.sensitivity_equality import runs_with_the_loop_on_and_off
from tests.test_sensitivities_events import WHEEL_3D
from tests.test_sensitivities_fuzz_findings import _assert_adjoint_agrees, _richardson
from tests.test_sensitivities_rate_stiffness import (ARMS, CONTROLLER_OF_ANGLE_AND_RATE,
                                                      DAMPED_STOP_IN_CONTACT_AT_A_LATCH, FOLLOWER_LOAD_OF_A_RATE, LAW,
                                                      moving_state)

#: the 3D wheel of the event tests on a spring, a damper and a torque nonlinear in θ and θ̇: K = ∂f/∂θ holds
#: θ̇ ∂c/∂θ, which moves with the rate (its mixed ∂²c/∂θ∂θ̇ too)
LAWS = ('stiffness: "k*(1 + 0.5*sin(2*theta))", damping: "c*(1 + theta**2)*(1 + theta_dot**2)", '
        'torque: "0.3*cos(theta)"')
WHEEL_LATCH = WHEEL_3D.format(what="its latch", event="lock_at: 0.5", t_end=1.1, every=0.02).replace(
    'stiffness: "k", damping: "c"', LAWS)
#: the same wheel onto a rigid stop with restitution 0.9: two stops (t = 0.895 and 0.920 s)
WHEEL_STOP = WHEEL_3D.format(what="a stop", event="limits: [-10, 0.5], restitution: 0.9", t_end=0.95,
                             every=0.01).replace('stiffness: "k", damping: "c"', LAWS)
#: the two arms of tests/test_sensitivities_rate_stiffness.py, the second's torque a law of θ and θ̇
ARMS_HINGE_LAW = ARMS.replace(LAW, "torque: -8*theta - c*(1 + 30*theta**2)*theta_dot}")
#: the second arm on a damped compliant stop (Hunt–Crossley, n = 1.5), in contact at the state below
ARMS_DAMPED_STOP = ARMS.replace(LAW, "stiffness: 8, limits: [-0.005, 0.5], contact: {stiffness: 2000.0, "
                                     "exponent: 1.5, damping: 5.0}}")
#: the arms' follower load in d's axes driven by a controller nonlinear in the second arm's angle and rate: its block
#: and its couplings move with the rate; and the same load global, and through a law 2 y + 1
LOAD_OF_ANGLE_AND_RATE = FOLLOWER_LOAD_OF_A_RATE.replace('push: {output: "-c*r2*30 - 3.0"}',
                                                         'push: {output: "-c*r2*30*(1 + 20*a2**2) - 3.0 + 5*a2"}')
GLOBAL_LOAD_OF_ANGLE_AND_RATE = LOAD_OF_ANGLE_AND_RATE.replace("frame: d}", "frame: global}")
LOAD_LAW_OF_ANGLE_AND_RATE = LOAD_OF_ANGLE_AND_RATE.replace("force: [0, push, 0]", "force: [0, 2*push + 1, 0]")
#: the second arm's torque a law of θ, θ̇ and an input: generated since ctrlweight (its entry was differenced)
ARMS_INPUT_LAW = ARMS.replace(LAW, "torque: -8*theta - g*(1 + 30*theta**2)*theta_dot}") + "inputs: {g: 0.5}\n"


def _second_mixed(source: str, theta: float, rate: float) -> float:
    """∂²f/∂θ∂θ̇ of a law's text by SymPy, independently of the package."""
    th, r = sp.symbols("theta theta_dot")
    return float(sp.diff(sp.sympify(source, locals={"theta": th, "theta_dot": r}), th, r).subs({th: theta, r: rate}))


@pytest.mark.parametrize("theta", [-0.35, -0.201, 0.4, 2.3], ids=["lower_contact", "near_contact", "free", "upper"])
@pytest.mark.parametrize("exponent", [1.0, 1.5, 2.5])
def test_the_generated_stiffness_by_rate_is_the_central_difference_of_the_hinge_stiffness(theta, exponent):
    """``hinge_stiffness_by_rate`` at random rates against Richardson-extrapolated central differences along θ̇ of
    ``hinge_force``'s ∂f/∂θ with the laws moved (measured ≤ 9.7e-11 relative), in and out of a damped compliant stop
    (out of contact the stop adds exactly 0)."""
    kernels = load_kernels("auto", "default")
    sources = ("2*(1 + 0.5*sin(2*theta)) + 0.1*theta_dot*theta", "0.05*(1 + theta**2)*(1 + theta_dot**2)",
               "0.3*cos(theta)*theta_dot")
    laws = [HingeLaw(s) for s in sources]
    contact = np.array([-0.2, 2.0, 50.0, exponent, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])

    def stiffness(rate):
        row = np.array([[f(theta, rate, 0.0) for law in laws for f in (law.value, law.d_theta, law.d_rate)]])
        return float(np.asarray(kernels.hinge_force(np.array([[theta, rate, 0.3, 1.0]]), row,
                                                    contact[None])[1]).ravel()[0])

    rng = np.random.default_rng(34)
    for rate in rng.normal(size=3):
        row = np.array([[f(theta, rate, 0.0) for law in laws for f in (law.value, law.d_theta, law.d_rate)]])
        mixed = np.array([[_second_mixed(s, theta, rate) for s in sources]])
        exact = float(np.asarray(kernels.hinge_stiffness_by_rate(np.array([[theta, rate, 0.3, 1.0]]), row, mixed,
                                                                 contact[None])[0]).ravel()[0])
        central = [(stiffness(rate + e) - stiffness(rate - e)) / (2 * e) for e in (1e-4, 5e-5)]
        numeric = (4 * central[1] - central[0]) / 3
        assert np.isfinite(exact) and abs(exact - numeric) <= 1e-8 * max(abs(numeric), 1.0), (exact, numeric)


def _richardson_by_rates(prepared, state, w: np.ndarray, dv: np.ndarray, blocks: tuple, h: float = 1e-2):
    """∂(K w)/∂v δv of K's ``blocks`` alone (the others do not move with the rates) by central differences along
    each column of δv at h, h/2, h/4 (relative to the column's size), extrapolated twice."""
    model, assembler = prepared.model, prepared.assembler
    v0 = free_velocity(model, state)

    def product(v):
        moved = state.copy()
        unpack_free(model, v, moved.v, moved.w, moved.theta_dot)
        stiffness = assembler.evaluate(moved, matrices=True).flat_blocks("stiffness")
        return np.asarray(assembler.assemble([b if name in blocks else 0.0 * b
                                              for name, b in zip(STIFFNESS_BLOCKS, stiffness)]) @ w)

    out = np.zeros_like(dv)
    for c in range(dv.shape[1]):
        size = float(np.max(np.abs(dv[:, c])))
        central = [(product(v0 + e * dv[:, c]) - product(v0 - e * dv[:, c])) / (2 * e)
                   for e in (h / size, h / 2 / size, h / 4 / size)]
        once = [(4 * central[i + 1] - central[i]) / 3 for i in range(2)]
        out[:, c] = (16 * once[1] - once[0]) / 15
    return out


def _rates_term(monkeypatch, text: str):
    """(prepared, state, w, δv (3 columns), ∂(K w)/∂v δv, the evaluations it made, the blocks moving) at a turned,
    moving state of ``text``."""
    prepared, state, rng = moving_state(text)
    owner = TransientSensitivities(prepared)
    n = prepared.model.n_dofs
    w, dv = rng.normal(size=n), rng.normal(size=(n, 3))
    assert owner.stiffness_moves_with_rates(state) and "controllers' couplings" in owner._rates_moving[1]
    counts = _evaluations_in_the_rates_term(monkeypatch)
    computed = owner._stiffness_by_rates(state, w, dv)
    monkeypatch.undo()
    return prepared, state, w, dv, computed, counts, owner._rates_moving[1]


def _evaluations_in_the_rates_term(monkeypatch) -> list:
    """[the model's evaluations made inside each call of ``TransientSensitivities._stiffness_by_rates``] (the
    adjoint's transpose calls it too)."""
    counts, inside = [], []
    evaluate, by_rates = Assembler.evaluate, TransientSensitivities._stiffness_by_rates

    def counted_evaluate(self, *args, **kwargs):
        if inside:
            counts[-1] += 1
        return evaluate(self, *args, **kwargs)

    def counted_by_rates(self, *args, **kwargs):
        counts.append(0)
        inside.append(True)
        try:
            return by_rates(self, *args, **kwargs)
        finally:
            inside.pop()

    monkeypatch.setattr(Assembler, "evaluate", counted_evaluate)
    monkeypatch.setattr(TransientSensitivities, "_stiffness_by_rates", counted_by_rates)
    return counts


@pytest.mark.parametrize("text, blocks, evaluations", [
    (ARMS_HINGE_LAW, ("joints",), 0), (ARMS_DAMPED_STOP, ("joints",), 0),
    (CONTROLLER_OF_ANGLE_AND_RATE, ("controllers' couplings",), 0),
    (FOLLOWER_LOAD_OF_A_RATE, ("loads and cables",), 0),
    (LOAD_OF_ANGLE_AND_RATE, ("loads and cables", "controllers' couplings"), 0),
    (GLOBAL_LOAD_OF_ANGLE_AND_RATE, ("controllers' couplings",), 0),
    (LOAD_LAW_OF_ANGLE_AND_RATE, ("loads and cables", "controllers' couplings"), 0),
    (ARMS_INPUT_LAW, ("joints",), 0),
], ids=["hinge law of angle and rate", "damped stop in contact", "pd of angle and rate", "follower load of a rate",
        "follower load of angle and rate", "global load of angle and rate", "load law of angle and rate",
        "hinge law naming an input"])
def test_the_rates_term_agrees_with_richardson_generated_or_differenced_alone(monkeypatch, text, blocks, evaluations):
    """At a turned, moving state, ∂(K w)/∂v δv (3 columns) within 1e-9 of the Richardson reference's largest entry.
    Generated, without an evaluation of the model: a torque law of θ and θ̇, a damped compliant stop in contact, a
    PD of angle and rate, a follower load a controller of a rate drives, loads (follower, global, through a law) a
    controller of angle and rate drives (measured 3.3e-13, 3.9e-11, 3.3e-13, 2.3e-14, 2.7e-14, 1.8e-14, 2.3e-14; the
    difference of the whole K w it replaces, two evaluations a column, 5.5e-8, 1.7e-7, 5.5e-8, 2.7e-7, 3.7e-7,
    1.9e-7, 1.5e-7); a hinge law naming an input, at the input's value at the event (measured 3.3e-13; 86d57d9
    differenced its own K w alone, two evaluations a column, 4.3e-11, the whole K w's difference before 5.5e-8)."""
    prepared, state, rng = moving_state(text)
    owner = TransientSensitivities(prepared)
    n = prepared.model.n_dofs
    w, dv = rng.normal(size=n), rng.normal(size=(n, 3))
    assert owner.stiffness_moves_with_rates(state) and owner._rates_moving[1] == blocks
    counts = _evaluations_in_the_rates_term(monkeypatch)
    computed = owner._stiffness_by_rates(state, w, dv)
    assert counts == [evaluations]
    monkeypatch.undo()
    reference = _richardson_by_rates(prepared, state, w, dv, blocks)
    assert np.abs(computed - reference).max() <= 1e-9 * np.abs(reference).max()


def _with(text: str, names: tuple) -> dict:
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = list(names)
    return data


@pytest.mark.parametrize("text, probes, name, kinds", [
    (WHEEL_LATCH, ("angle", "tip_x", "mid_z"), "c", ["latch"]),
    (WHEEL_STOP, ("angle", "tip_x", "mid_z"), "c", ["stop", "stop"]),
    (DAMPED_STOP_IN_CONTACT_AT_A_LATCH, ("torque", "a2", "tq2", "y"), "k", ["latch"]),
    (CONTROLLER_OF_ANGLE_AND_RATE, ("torque", "a2", "y"), "c", ["latch"]),
    (LOAD_OF_ANGLE_AND_RATE, ("torque", "a2", "y"), "c", ["latch"]),
], ids=["wheel latch", "wheel stop", "damped stop at a latch", "pd of angle and rate", "load of angle and rate"])
def test_whole_runs_through_events_agree_with_richardson_with_no_difference_along_the_rates(monkeypatch, text, probes,
                                                                                            name, kinds):
    """Through the events the sensitivities agree with Richardson differences of whole runs (h = 1e-3 |p|), every
    row within 1e-7 of its probe's largest (measured 7.1e-10, 1.7e-9, 1.7e-9, 1.9e-9, 1.8e-9 — as on 10be92c, whose
    difference's error lay below the reference's: the runs' sensitivities moved by ≤ 1.2e-11), and at each event the
    rates' term took no evaluation of the model (before: two a parameter)."""
    counts = _evaluations_in_the_rates_term(monkeypatch)
    result = latdyn.run(latdyn.load_scene(_with(text, (name,))))
    assert [e["kind"] for e in result.summary["events"]] == kinds
    assert counts and not any(counts), counts
    monkeypatch.undo()
    p0 = yaml.safe_load(text)["parameters"][name]
    expected = _richardson(yaml.safe_dump(_with(text, (name,))), name, 1e-3 * abs(p0))
    for probe in probes:
        computed = result.sensitivities[(probe, name)]
        assert np.abs(computed - expected[probe]).max() <= 1e-7 * np.abs(expected[probe]).max(), probe


def test_latdyn_run_writes_the_apis_event_sensitivities_and_the_loop_off_the_same_bits(monkeypatch, tmp_path):
    """The PD of angle and rate through its latch, by k and c: ``latdyn run``'s summary.json holds the API's event
    and probe sensitivities, and the loop of steps on and off give the same sensitivities to the bit (the event on
    the Python path on both), with no evaluation in the rates' term."""
    counts = _evaluations_in_the_rates_term(monkeypatch)
    runs = runs_with_the_loop_on_and_off(_with(CONTROLLER_OF_ANGLE_AND_RATE, ("k", "c")))
    assert counts == [0, 0]
    native, python = runs[True], runs[False]
    assert native.summary["sensitivity_steps_in_loop"] > 0 == python.summary["sensitivity_steps_in_loop"]
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
    monkeypatch.undo()
    done, out = latdyn_run(tmp_path, yaml.safe_dump(_with(CONTROLLER_OF_ANGLE_AND_RATE, ("k", "c"))))
    assert done.returncode == 0, done.stderr
    summary = summary_of(out)
    assert summary["event_sensitivities"] == native.summary["event_sensitivities"]
    assert summary["probe_sensitivities"] == native.summary["probe_sensitivities"]


@pytest.mark.parametrize("text, kinds", [(CONTROLLER_OF_ANGLE_AND_RATE, ("latch",)),
                                         (LOAD_OF_ANGLE_AND_RATE, ("latch",)),
                                         (WHEEL_STOP.replace("solve: {analysis: transient,",
                                                             "solve: {analysis: transient, tol: 1.0e-12,"),
                                          ("stop", "stop"))], ids=["pd of angle and rate", "load of angle and rate",
                                                                   "wheel stop"])
def test_the_adjoint_takes_the_generated_transpose(monkeypatch, text, kinds):
    """The adjoint's transposed term, (∂(K w)/∂v)ᵀ ū from the same generated matrix: its summary within 1e-8 of the
    forward method's (measured ≤ 1e-12), with no evaluation in the rates' term (before: two a free rate)."""
    counts = _evaluations_in_the_rates_term(monkeypatch)
    _assert_adjoint_agrees(text, ("k", "c"), kinds=kinds)
    assert counts and not any(counts), counts
