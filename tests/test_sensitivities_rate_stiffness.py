"""Which terms of K move with the rates, at an event (issue 34; docs/parameters.md, "The discrete adjoint", "the
jump"): the impulse's weight W = M + dt² K moves with δv where K does, and both the forward method and the adjoint
take ∂(K w)/∂v δv there — asked of the model's own evaluation, one predicate for both
(:func:`latdyn.analyses.weight_derivative.stiffness_moving_with_rates`).

Before it, the forward method differenced K w along δv at every event (2k evaluations an event, a latching boom's
included), and the adjoint took the term only beside a damped cable and hinge laws whose ∂τ/∂θ holds θ̇ (a list of
the scene's keys): beside a latch, a continuous controller whose coupling in K holds a rate — an output nonlinear in
an angle and a rate, or a follower load in a body's axes driven by a rate — left its end rows 3.2e-4 and 2.3e-4 off
the Richardson differences of whole runs (the same at h = 1e-2, 1e-3, 1e-4 |p|), reported as solved. A damped
compliant stop in contact at a latch (its Hunt–Crossley ∂F/∂δ = n δⁿ⁻¹ (k + c δ̇)) both methods take (the adjoint its
onset too since tests/test_adjoint_events_more.py): without the term its rows 3.2e-6 off (benchmarks/fuzz_sensitivity_scenes/
q_latch_beside_a_damped_compliant_stop.yaml, r_adjoint_latch_beside_a_controller_of_angle_and_rate.yaml,
s_adjoint_latch_beside_a_follower_load_of_a_rate.yaml).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses import transient_sensitivities
from latdyn.analyses.weight_derivative import stiffness_moving_with_rates
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.prepare import prepare
from tests.cli_runs import latdyn_run, summary_of
from tests.test_sensitivities_events import LATCH_PLANAR
from tests.test_sensitivities_fuzz_findings import (LATCH_BESIDE_A_RATE_STIFFNESS, _assert_adjoint_agrees,
                                                    _assert_agree, _run)

#: the two hinged arms in 3D of LATCH_BESIDE_A_RATE_STIFFNESS, the first latching at 0.01 rad (t = 0.047 s) on a
#: spring and damper; the second's torque a controller's output whose ∂y/∂(angle) = −8 − 60 c a2 r2 holds the rate:
#: its coupling in K moves with the rates
CONTROLLER_OF_ANGLE_AND_RATE = (LATCH_BESIDE_A_RATE_STIFFNESS
                                .replace("torque: -k*theta - c*(1 + 40*theta**2)*theta_dot + 4.0, lock_at: 0.01",
                                         "stiffness: k, damping: 0.5, torque: 4.0, lock_at: 0.01")
                                .replace("torque: -8*theta - c*(1 + 30*theta**2)*theta_dot - 2.0}}}",
                                         'torque: ctl}}}\ncontrollers:\n  ctl: {output: "-8*a2 - c*(1 + 30*a2**2)*r2 - 2.0"}')
                                .replace("    y: {point: d,", "    r2: {hinge: fore.start, quantity: rate}\n    y: {point: d,"))

#: the same arms, the second free on a spring and damper, pushed at d by a force in d's axes that a controller of
#: its rate drives (linear): the load's block of K, ∂(T f)/∂π, is proportional to the output, so moves with the rate
FOLLOWER_LOAD_OF_A_RATE = (CONTROLLER_OF_ANGLE_AND_RATE
                           .replace("torque: ctl}}}", "stiffness: 8, damping: 0.2}}}\nloads:\n"
                                    "  - {at: d, force: [0, push, 0], moment: [0, 0, 0], frame: d}")
                           .replace('ctl: {output: "-8*a2 - c*(1 + 30*a2**2)*r2 - 2.0"}',
                                    'push: {output: "-c*r2*30 - 3.0"}'))

#: the first arm latching at 0.03 rad (t = 0.167 s) while the second's compliant stop (Hunt–Crossley, n = 1.5,
#: damping c = 5) is in contact, 0.008 rad past its lower limit
DAMPED_STOP_IN_CONTACT_AT_A_LATCH = (CONTROLLER_OF_ANGLE_AND_RATE
                                     .replace("c: 0.5}", "c: 5.0}")
                                     .replace("lock_at: 0.01", "lock_at: 0.03")
                                     .replace("torque: ctl}}}", "stiffness: 8, damping: 0.2, torque: -3.0, limits: "
                                              "[-0.004, 0.5],\n        contact: {stiffness: 2000.0, exponent: 1.5, "
                                              "damping: c}}}}")
                                     .replace('controllers:\n  ctl: {output: "-8*a2 - c*(1 + 30*a2**2)*r2 - 2.0"}\n',
                                              "")
                                     .replace("    r2: {hinge: fore.start, quantity: rate}\n",
                                              "    tq2: {hinge: fore.start, quantity: torque}\n"))


def _moving_terms(monkeypatch) -> list:
    """Record what the predicate finds at each event's weight derivative, and how often K w is differenced along
    δv: ([names found, …], [calls])."""
    found, differenced = [], []
    predicate = transient_sensitivities.stiffness_moving_with_rates
    by_rates = transient_sensitivities.TransientSensitivities._stiffness_by_rates

    def recorded(assembler, state):
        found.append(predicate(assembler, state))
        return found[-1]

    def counted(self, state, w, dv):
        differenced.append(dv.shape[1])
        return by_rates(self, state, w, dv)

    monkeypatch.setattr(transient_sensitivities, "stiffness_moving_with_rates", recorded)
    monkeypatch.setattr(transient_sensitivities.TransientSensitivities, "_stiffness_by_rates", counted)
    return found, differenced


def test_the_predicate_names_the_terms_of_k_that_move_with_the_rates_and_skips_the_rest(monkeypatch):
    """At the deploying arm's latch (a constant spring and damper, five parameters) nothing of K moves with the
    rates: no difference along δv (before: 2 × 5 evaluations at the latch). Beside a controller of an angle and a
    rate, its couplings; beside a follower load a controller of a rate drives, the load's block; beside a damped
    compliant stop in contact, the joint's entry — and there the term is taken."""
    found, differenced = _moving_terms(monkeypatch)
    result = _run(LATCH_PLANAR)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert found == [()] and differenced == []
    for text, terms in ((CONTROLLER_OF_ANGLE_AND_RATE, ("controllers' couplings",)),
                        (FOLLOWER_LOAD_OF_A_RATE, ("loads and cables",)),
                        (DAMPED_STOP_IN_CONTACT_AT_A_LATCH, ("joints",))):
        found.clear(), differenced.clear()
        result = _run(text)
        assert [e["kind"] for e in result.summary["events"]] == ["latch"]
        assert found == [terms] and differenced == [2], (found, differenced)


def test_the_forward_method_takes_the_rates_term_of_a_controller_and_of_a_damped_stop_at_a_latch():
    """Against Richardson differences of whole runs (h = 1e-2 |p|), every row within 1e-7 of the probe's largest
    sensitivity. Measured: the controller by c 1.5e-10, the damped stop by k 6.2e-10 (1.7e-9 at h = 1e-3 |k|, 1.6e-8 at
    1e-4); with the rates' term gated by the former list of keys (which names neither) 8.4e-6 (h = 1e-2 |c|) and 3.2e-6
    (the same at h = 1e-2, 1e-3, 1e-4 |k|). The forward method differenced the term at every event before, so these
    passed then too: they hold the gate open where it must be."""
    _assert_agree(_run(CONTROLLER_OF_ANGLE_AND_RATE), CONTROLLER_OF_ANGLE_AND_RATE, ("torque", "a2", "y"), "c", 0.005)
    _assert_agree(_run(DAMPED_STOP_IN_CONTACT_AT_A_LATCH), DAMPED_STOP_IN_CONTACT_AT_A_LATCH,
                  ("torque", "a2", "tq2", "y"), "k", 0.2)


def test_the_adjoint_takes_a_latch_beside_controllers_whose_couplings_move_with_the_rates():
    """Before: 3.2e-4 (y by k) and 2.3e-4 (y by k) off the differences and the forward method, at every h, reported as
    solved. Now the adjoint's summary within 1e-8 of the forward method's (measured 3.6e-13 and 1.8e-12)."""
    _assert_adjoint_agrees(CONTROLLER_OF_ANGLE_AND_RATE, ("k", "c"))
    _assert_adjoint_agrees(FOLLOWER_LOAD_OF_A_RATE, ("k", "c"))


def test_the_adjoint_takes_a_damped_compliant_stop_at_a_latch(tmp_path):
    """The adjoint differentiates a compliant stop's onset (tests/test_adjoint_events_more.py; refused, exit 2, on
    86d57d9): through the command line it exits 0, and its summary is the forward method's within 1e-10 (measured
    2.7e-13)."""
    text = DAMPED_STOP_IN_CONTACT_AT_A_LATCH.replace("tol: 1.0e-12,", "tol: 1.0e-12, sensitivity_method: adjoint,")
    done, out = latdyn_run(tmp_path, text)
    assert done.returncode == 0, done.stderr
    assert latdyn.load_scene(tmp_path / "scene.yaml").solve.sensitivity_method == "adjoint"
    forward = _run(DAMPED_STOP_IN_CONTACT_AT_A_LATCH).summary
    adjoint = summary_of(out)
    assert [e["kind"] for e in adjoint["events"]] == ["latch"]
    for probe, by in forward["probe_sensitivities"].items():
        for which, values in by.items():
            scale = max(abs(v) for v in values.values())
            worst = max(abs(adjoint["probe_sensitivities"][probe][which][name] - v) for name, v in values.items())
            assert worst <= 1e-10 * scale, (probe, which, worst / scale)
    for mine, theirs in zip(adjoint["event_sensitivities"], forward["event_sensitivities"], strict=True):
        assert max(abs(mine["dt"][n] - v) for n, v in theirs["dt"].items()) <= 1e-10 * max(map(abs, theirs["dt"].values()))


#: the two arms without the controller: the second hinge's law written in place of ``LAW``
ARMS = CONTROLLER_OF_ANGLE_AND_RATE.replace('controllers:\n  ctl: {output: "-8*a2 - c*(1 + 30*a2**2)*r2 - 2.0"}\n', "")
LAW = "torque: ctl}"
DAMPED_CABLE = (Path(__file__).resolve().parents[1] / "benchmarks" / "fuzz_sensitivity_scenes"
                / "m_damped_cable_through_a_latch.yaml").read_text()


@pytest.mark.parametrize("text, terms", [
    (ARMS.replace(LAW, "stiffness: 8, friction: {coulomb: 0.3, static: 0.5, stribeck_rate: 0.1, viscous: 0.2}}"), ()),
    (ARMS.replace(LAW, "stiffness: 8}") + "gravity: [0, 0, -9.81]\n", ()),
    (ARMS.replace(LAW, "stiffness: 8, limits: [-0.5, 0.5], contact: {stiffness: 2000.0, exponent: 1.5, damping: 5.0}}"),
     ()),
    (ARMS.replace(LAW, "stiffness: 8, limits: [-0.005, 0.5], contact: {stiffness: 2000.0, exponent: 1.5}}"), ()),
    (ARMS.replace(LAW, "stiffness: 8, limits: [-0.005, 0.5], contact: {stiffness: 2000.0, exponent: 1.5, "
                       "damping: 5.0}}"), ("joints",)),
    (ARMS.replace(LAW, "torque: -8*theta - c*(1 + 30*theta**2)*theta_dot}"), ("joints",)),
    (CONTROLLER_OF_ANGLE_AND_RATE.replace("-8*a2 - c*(1 + 30*a2**2)*r2 - 2.0", "-8*a2 - c*r2"), ()),
    (CONTROLLER_OF_ANGLE_AND_RATE, ("controllers' couplings",)),
    (FOLLOWER_LOAD_OF_A_RATE, ("loads and cables",)),
    (DAMPED_CABLE, ("loads and cables",)),
    (DAMPED_CABLE.replace("damping: 3.0", "damping: 0.0"), ()),
    (LATCH_PLANAR, ()),
], ids=["friction", "joint bodies spinning under gravity", "damped stop out of contact", "undamped stop in contact",
        "damped stop in contact", "hinge law", "controller linear", "controller of angle and rate",
        "follower load of a rate", "damped cable", "undamped cable", "planar arm"])
def test_the_terms_of_k_that_move_with_the_rates_at_random_rates(text, terms):
    """The predicate at a turned configuration with random rates (every hinge at −0.05 rad: a stop at −0.005 in
    contact): the joints' entry where a law's ∂τ/∂θ holds θ̇ or a damped stop is in contact, the couplings of a
    controller nonlinear in an angle and a rate, the block of a follower load a controller of a rate drives, a damped
    cable's; nothing for friction (∂f/∂θ = 0), the joint bodies' gyroscopic terms (the inertia tangent, which the
    impulse's K leaves out), a stop out of contact or undamped, a linear controller, an undamped cable."""
    prepared, state, _ = moving_state(text)
    assert stiffness_moving_with_rates(prepared.assembler, state) == terms


def moving_state(text: str):
    """(prepared, a turned state with random rates, every hinge at −0.05 rad — a stop at −0.005 in contact —, the
    random generator after them) of the scene ``text`` (also tests/test_weight_derivative_rates.py's)."""
    rng = np.random.default_rng(3)
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    model = prepared.model
    state = prepared.assembler.advance(prepared.state, 0.02 * rng.standard_normal(model.n_dofs))
    unpack_free(model, rng.standard_normal(model.n_dofs), state.v, state.w, state.theta_dot)
    state.theta[:] = -0.05
    return prepared, state, rng
