"""The discrete adjoint of transient runs (latdyn/analyses/adjoint_sensitivities.py,
``solve.sensitivity_method: adjoint``).

Reference: the forward method (latdyn/analyses/transient_sensitivities.py) on the same scene — both are
the exact derivative of the same discrete solution, so each probe's end, max and min derivatives agree to
round-off (asserted ≤ 1e-10 of each output's largest derivative where both runs take the same steps);
and Richardson-extrapolated central differences of whole runs (the helpers of
tests/test_sensitivities_transient.py). Genuinely 3D (a hinge axis in no coordinate plane, a joint body
with its centre of mass off its node, a load turning with it, gravity, a spin at t = 0) with rotary
inertia and without (from rest), by the initial velocity, planar with each implicit method and Newton
variant, on the sparse storage; the CLI's files; checkpoint and resume; the refusals."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.results.result import Result
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_transient import FROM_REST_3D, LONG_3D, PLANAR, SWING_3D, _richardson, _run
from tests.resumed_runs import interrupted_and_whole

#: SWING_3D whose rigid motion at t = 0 is a parameter's (linear and angular), with a load and a hinge law
BY_INITIAL_VELOCITY = (SWING_3D.replace("parameters: {", "parameters: {W: 2.0, ")
                       .replace("initial_velocity: {angular: [0, 0, 2.0]}",
                                'initial_velocity: {angular: [0, "0.3*W", "W"], linear: ["0.1*W", 0, 0]}')
                       .replace("sensitivities: [F, k, c, th0, EI, G, rho, m, cx, J]", "sensitivities: [W, F, k, J]"))


#: SWING_3D with its hinge axis in no coordinate plane (SWING_3D's lies in the y-z plane)
SKEW_AXIS = SWING_3D.replace("axis: [0, 0.6, 0.8]", "axis: [0.36, 0.48, 0.8]")


def _adjoint(text: str) -> str:
    """``text`` with ``solve.sensitivity_method: adjoint``; a scene spelt otherwise (no ``analysis:
    transient,`` in a flow mapping) fails here rather than compare the forward method with itself."""
    switched = text.replace("analysis: transient,", "analysis: transient, sensitivity_method: adjoint,")
    assert switched != text and yaml.safe_load(switched)["solve"]["sensitivity_method"] == "adjoint", \
        "the scene's solve is not spelt '{analysis: transient, ...}': the adjoint was not switched on"
    return switched


def _disagreement(forward: dict, adjoint: dict) -> float:
    """The largest difference of two ``probe_sensitivities``, relative to each output's largest
    derivative (by the parameters)."""
    assert forward.keys() == adjoint.keys()
    worst = 0.0
    for probe, outputs in forward.items():
        assert set(outputs) == set(adjoint[probe]) == {"end", "max", "min"}
        for which, by_name in outputs.items():
            f = np.array([by_name[name] for name in by_name])
            a = np.array([adjoint[probe][which][name] for name in by_name])
            scale = np.abs(f).max()
            if scale == 0.0:   # a row at t = 0 (δq_0 = 0)
                assert not np.any(a), (probe, which)
                continue
            worst = max(worst, float(np.abs(a - f).max() / scale))
    return worst


@pytest.mark.parametrize("text", [SWING_3D, SKEW_AXIS, FROM_REST_3D, BY_INITIAL_VELOCITY],
                         ids=["3d-rotary-inertia-spinning", "3d-skew-hinge-axis", "3d-without-rotary-inertia-from-rest",
                              "3d-initial-velocity"])
def test_the_adjoint_equals_the_forward_method_in_3d(text):
    """Every parameter kind (load, hinge stiffness law, damping, rest angle, section EI, GJ, ρ, body mass,
    centre of mass, inertia; the initial velocity): measured 3.0e-15 (spinning), 2.9e-15 (its hinge axis in
    no coordinate plane), 5.3e-15 (from rest: the
    start's transposed split into directions with and without inertia), 5.3e-15 (initial velocity)."""
    forward = _run(text)
    adjoint = _run(_adjoint(text))
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10
    for (probe, name), values in adjoint.sensitivities.items():   # Result.sensitivities: the end row alone
        assert values.shape == (1,)
        assert values[0] == adjoint.summary["probe_sensitivities"][probe]["end"][name]


@pytest.mark.parametrize("method", ["generalized-alpha", "hht-alpha", "newmark"])
@pytest.mark.parametrize("newton", ["full", "exact", "modified"])
def test_the_adjoint_equals_the_forward_method_planar_for_each_implicit_method(method, newton):
    """Planar: load force and moment, hinge stiffness law, damping and torque in t, section EI and ρ, body
    mass and inertia. Full and exact Newton: measured ≤ 6.1e-15. Modified Newton: the forward method's
    own solves refactorise the matrix modified Newton holds (one factorization more on this run), so its
    converged states differ from the adjoint's (which are the run's without sensitivities, to the bit) by
    ≈ 1e-13, and the derivatives by 7.6e-11, 1.5e-11, 1.3e-10 (generalized-α, HHT, Newmark; relative);
    asserted 1e-8 there."""
    text = PLANAR.replace("analysis: transient,", f"analysis: transient, method: {method}, newton: {newton},")
    forward = _run(text)
    adjoint = _run(_adjoint(text))
    tolerance = 1e-8 if newton == "modified" else 1e-10
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= tolerance


def test_the_adjoint_run_is_the_run_without_sensitivities():
    """The forward pass only stores: its probes are the per-step run's without sensitivities, to the bit."""
    from latdyn.timeloop import transient

    text = PLANAR.replace("analysis: transient,", "analysis: transient, newton: modified,")
    adjoint = _run(_adjoint(text))
    data = yaml.safe_load(text)
    del data["solve"]["sensitivities"]
    transient.COMPILED_LOOP = False
    try:
        plain = latdyn.run(latdyn.load_scene(data))
    finally:
        transient.COMPILED_LOOP = True
    for probe, values in plain.probes.items():
        np.testing.assert_array_equal(adjoint.probes[probe], values)


def test_the_adjoint_on_the_sparse_storage_equals_the_forward_method():
    """Past the dense limit (the forward method's band factors solved transposed): measured 1.6e-15."""
    from latdyn.numerics.linalg import DENSE_LIMIT

    forward, adjoint = _run(LONG_3D), _run(_adjoint(LONG_3D))
    assert adjoint.summary["coordinates"] > DENSE_LIMIT
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-12


@pytest.mark.parametrize("name", ["k", "J", "rho"])
def test_the_adjoint_agrees_with_richardson_central_differences_in_3d(name):
    """End, max and min of every probe of the spinning 3D arm with its hinge axis in no coordinate plane
    against Richardson-extrapolated central differences of whole runs at the forward pass's rows
    (measured 4.6e-9, 1.2e-8, 1.0e-8 of each probe's largest derivative; the other kinds: th0 4.3e-9,
    cx 8.3e-9, m 1.8e-9, EI 3.9e-9, G 2.1e-8, F 1.3e-10, c 5.6e-9)."""
    adjoint = _run(_adjoint(SKEW_AXIS))
    expected = _richardson(SKEW_AXIS, name)
    for probe, values in adjoint.probes.items():
        derivatives = expected[probe]
        scale = np.abs(derivatives).max()
        assert scale > 1e-9
        for which, row in (("end", -1), ("max", int(np.argmax(values))), ("min", int(np.argmin(values)))):
            got = adjoint.summary["probe_sensitivities"][probe][which][name]
            assert abs(got - derivatives[row]) <= 1e-6 * scale, (probe, which, got, derivatives[row])


def test_the_cli_writes_the_end_row_and_the_summary(tmp_path):
    """``python -m latdyn run``: sensitivities.csv holds the end row alone; summary.json
    ``probe_sensitivities`` is the API's; Result.load reads the end row back."""
    text = _adjoint(PLANAR.replace("[P, k, c, tau, Mz, EI, rho, m, J]", "[P, rho]"))
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 0, run.stderr
    lines = (out / "sensitivities.csv").read_text().splitlines()
    assert lines[0] == "t,tip_y/P,tip_y/rho,tip_x/P,tip_x/rho,hinge/P,hinge/rho" and len(lines) == 2
    assert float(lines[1].split(",")[0]) == pytest.approx(0.2)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["event_sensitivities"] == []
    api = _run(text)
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]
    result = Result.load(out)
    for (probe, name), values in result.sensitivities.items():
        assert values.shape == (1,) and values[0] == summary["probe_sensitivities"][probe]["end"][name]


def test_an_interrupted_and_resumed_adjoint_run_gives_the_same_derivatives(tmp_path, monkeypatch):
    """The stored trajectory rides in the checkpoint: the resumed run's files are the uninterrupted ones."""
    scene = yaml.safe_load(_adjoint(PLANAR.replace("[P, k, c, tau, Mz, EI, rho, m, J]", "[P, k, rho]")))
    out, whole = interrupted_and_whole(scene, tmp_path, monkeypatch, 0.12)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
    assert (json.loads((out / "summary.json").read_text())["probe_sensitivities"]
            == json.loads((whole / "summary.json").read_text())["probe_sensitivities"])


def test_the_adjoint_equals_the_forward_method_through_continuous_controllers():
    """Two chained controllers without states (one clipped for a while) turning a wheel out of the
    coordinate planes (tests/test_sensitivities_controllers.py WHEEL): gains in the outputs and a hinge
    spring, measured 7.8e-12 (the same trajectory to the bit; the two orders of the linear algebra
    through a stiff arm's 50 steps)."""
    from tests.test_sensitivities_controllers import WHEEL

    forward, adjoint = _run(WHEEL), _run(_adjoint(WHEEL))
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


def test_the_adjoint_equals_the_forward_method_through_a_controller_with_states():
    """The hub's PI (its integral state; tests/test_sensitivities_controller_states.py PI_HUB), refused until
    latdyn/analyses/adjoint_controller_states.py: the forward method's derivatives, measured 3.6e-12
    (tests/test_adjoint_controllers_states.py for 3D scenes)."""
    from tests.test_sensitivities_controller_states import PI_HUB

    forward, adjoint = _run(PI_HUB), _run(_adjoint(PI_HUB))
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


def test_the_adjoint_equals_the_forward_method_through_a_sampled_controller():
    """The hub's PI sampled at 100 Hz, its gains lowered (at Kp 6 the held output makes the run unbounded), refused
    until latdyn/analyses/adjoint_controller_states.py SamplesTransposed: the forward method's derivatives, measured
    2.0e-12."""
    from tests.test_sensitivities_controller_states import PI_HUB

    sampled = (PI_HUB.replace('initial: {S: 0.2}}', 'initial: {S: 0.2}, rate: 100}')
               .replace("parameters: {Kp: 6.0, Ki: 3.0}", "parameters: {Kp: 1.0, Ki: 0.5}"))
    assert "rate: 100" in sampled and "Kp: 1.0" in sampled
    forward, adjoint = _run(sampled), _run(_adjoint(sampled))
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


def test_a_latch_beside_a_law_in_t_is_taken_by_the_cli_as_the_forward_method(tmp_path):
    """A latch (lock_at) beside a law in t (the hinge's torque, whose time would move with the event's; refused, exit
    2, on 86d57d9: tests/test_adjoint_events_more.py lifted it): exit 0, summary.json the API's bit for bit and the
    forward method's within 1e-10."""
    text = _adjoint(PLANAR.replace("torque: \"tau*sin(20*t)\"}", "torque: \"tau*sin(20*t)\", lock_at: 1.0}"))
    assert "lock_at" in text
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(text))).summary
    assert summary["probe_sensitivities"] == adjoint["probe_sensitivities"]
    forward = latdyn.run(latdyn.load_scene(yaml.safe_load(
        PLANAR.replace("torque: \"tau*sin(20*t)\"}", "torque: \"tau*sin(20*t)\", lock_at: 1.0}")))).summary
    assert _disagreement(forward["probe_sensitivities"], adjoint["probe_sensitivities"]) <= 1e-10


@pytest.mark.parametrize("solve, expected", [
    ({"sensitivity_method": "reverse"}, "expected forward or adjoint"),
    ({"sensitivity_method": "adjoint", "sensitivities": None}, "expected it with solve.sensitivities"),
    ({"sensitivity_method": "adjoint", "analysis": "static", "steps": 2}, "transient runs only"),
])
def test_a_bad_sensitivity_method_is_refused(solve, expected):
    data = yaml.safe_load(PLANAR)
    data["solve"].update(solve)
    if solve.get("sensitivities", 0) is None:
        del data["solve"]["sensitivities"]
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(data))
    assert refused.value.key == "solve.sensitivity_method" and expected in str(refused.value)


def test_the_adjoint_of_rate_probes_equals_the_forward_method():
    """Hinge rates and point velocities (tests/test_sensitivities_rates.py: the offset point's ω × (δπ × T r))
    read δv and δq: their adjoint seeds both; the spinning 3D arm, and with its initial velocity a parameter
    (a rate's row at t = 0 moves by δv_0 alone); the planar arm under a PD that reads the rate."""
    from tests.test_sensitivities_rates import PD_PLANAR, RATES_3D

    by_initial_velocity = (RATES_3D.replace("parameters: {", "parameters: {W: 2.0, ")
                           .replace("initial_velocity: {angular: [0, 0, 2.0]}",
                                    'initial_velocity: {angular: [0, "0.3*W", "W"], linear: ["0.1*W", 0, 0]}')
                           .replace("sensitivities: [F, k, rho, cx]", "sensitivities: [W, F, k, rho, cx]"))
    for text in (RATES_3D, by_initial_velocity, PD_PLANAR):
        forward = _run(text)
        adjoint = _run(_adjoint(text))
        assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


#: a loaded arm beside an idle one whose tip never moves (its displacement and speed exactly 0 at every
#: row); Q = 0 loads the idle tip: Q moves it, P, EI and rho do not
IDLE_BESIDE = """
title: a loaded arm beside an idle one, whose tip stays at rest
parameters: {P: 3.0, Q: 0.0, EI: 5.0, rho: 0.5}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "EI", GJ: 4.0, rhoA: "rho", rhoIy: 0.001, rhoIz: 0.001}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  base2: {at: [0, 1, 0], fixed: true}
beams:
  arm: {from: base, to: [1.0, 0.2, 0.3], section: s, elements: 3}
  idle: {from: base2, to: [1.0, 1.0, 0.0], section: s, elements: 2}
loads:
  - {at: arm.end, force: ["0.2*P*t", "-P*t", "0.1*P*t"]}
  - {at: idle.end, force: [0, 0, "Q*t"]}
solve: {analysis: transient, dt: 0.01, t_end: 0.1, sensitivities: [P, Q, EI, rho]}
output:
  every: 0.05
  probes:
    arm_tip: {point: arm.end, quantity: displacement}
    idle_tip: {point: idle.end, quantity: displacement}
    idle_speed: {point: idle.end, quantity: velocity, component: norm}
"""


def test_a_norm_at_zero_takes_the_forward_methods_rule_through_the_cli(tmp_path):
    """A norm probe exactly 0 at its end row (|·| not differentiable there): the adjoint seeds its three
    components and takes the forward method's rule — 0 for a parameter that does not move the point (P, EI,
    rho), NaN (null in summary.json) for one that does (Q) — where it gave NaN for every parameter; the
    norm away from 0 (arm_tip) as the forward method, measured 1.0e-16. Both through ``python -m latdyn run``."""
    (tmp_path / "forward").mkdir()
    (tmp_path / "adjoint").mkdir()
    forward_run, forward_out = latdyn_run(tmp_path / "forward", IDLE_BESIDE)
    adjoint_run, adjoint_out = latdyn_run(tmp_path / "adjoint", _adjoint(IDLE_BESIDE))
    assert forward_run.returncode == 0 and adjoint_run.returncode == 0, forward_run.stderr + adjoint_run.stderr
    probes = np.loadtxt(adjoint_out / "probes.csv", delimiter=",", skiprows=1)
    assert np.all(probes[:, 2:] == 0.0) and np.all(probes[1:, 1] > 0.0)   # idle_tip, idle_speed: 0 at every row
    forward = json.loads((forward_out / "summary.json").read_text())["probe_sensitivities"]
    adjoint = json.loads((adjoint_out / "summary.json").read_text())["probe_sensitivities"]
    for probe in ("idle_tip", "idle_speed"):
        assert adjoint[probe] == forward[probe]
        assert adjoint[probe]["end"] == {"P": 0.0, "Q": None, "EI": 0.0, "rho": 0.0}
    for which, by_name in forward["arm_tip"].items():
        scale = max(abs(v) for v in by_name.values())
        assert scale > 0.0 or which == "min"
        for name, value in by_name.items():
            assert abs(adjoint["arm_tip"][which][name] - value) <= 1e-10 * max(scale, 1e-300)


@pytest.mark.parametrize("text", [SWING_3D, PLANAR], ids=["3d-every-kind", "planar"])
def test_the_batched_transposed_product_is_the_transposed_residual_derivative(text, monkeypatch):
    """``AdjointSensitivities.residual_transposed_product`` (sections' and loads' uses batched, the other
    kinds through ``residual_derivatives``) equals (∂r/∂p)ᵀw with ∂r/∂p formed, at the run's stored states
    for random w: measured ≤ 7.1e-17 of the product's largest entry (the same terms, summed in another
    order). SWING_3D: load, hinge laws, section EI, GJ, ρ, body mass, centre of mass, inertia."""
    from latdyn.analyses.adjoint_sensitivities import AdjointSensitivities

    taken = {}
    reverse = AdjointSensitivities.reverse

    def kept(self, carried, outputs):
        taken["owner"], taken["carried"] = self, carried
        return reverse(self, carried, outputs)

    monkeypatch.setattr(AdjointSensitivities, "reverse", kept)
    _run(_adjoint(text))
    owner, trajectory = taken["owner"], taken["carried"]["trajectory"]
    rng = np.random.default_rng(3)
    for entry in trajectory[::max(1, len(trajectory) // 4)]:
        state = entry["state"]
        w = rng.standard_normal((owner.model.n_dofs, 3))
        expected = owner.residual_derivatives(state, 1.0, inertia=True).T @ w
        got = owner.residual_transposed_product(state, w)
        assert np.abs(expected).max() > 0.0
        assert np.abs(got - expected).max() <= 1e-14 * np.abs(expected).max()
