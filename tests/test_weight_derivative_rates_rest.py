"""The rest of the rates' part of an event's impulse-weight derivative generated (latdyn/analyses/weight_derivative.py,
"Along the rates"; docs/parameters.md "The impulse weight's derivative"): the couplings of continuous controllers that
read points' velocities at an offset or relative to a body, cables' tensions, elements' section forces, free joints'
forces, inputs, states and other controllers, and the point loads such controllers drive, move with the rates by
SymPy's second derivatives of the outputs times the sensors' generated gradients and their rate derivatives
(``_chain_rates_moves``): ∂(K w)/∂v δv takes no evaluation of the model any more (ea72688 differenced them, two
evaluations a column), agrees with Richardson-extrapolated differences of K w along the rates on the genuinely 3D
latching boom, and through the latch ``latdyn run`` and the API give the same event sensitivities, agreeing with
Richardson differences of whole runs, the loop of steps off writing the same bytes."""
from __future__ import annotations

import numpy as np
import pytest

import latdyn
import yaml
from tests.test_weight_derivative_controllers_rest import RELATIVE, SPAR
from tests.test_weight_derivative_couplings import FORCE, LOAD, latdyn_run_through_the_latch_agrees
from tests.test_weight_derivative_force_sensors import SECTION, TENSION
from tests.test_weight_derivative_rates import _evaluations_in_the_rates_term, _rates_term, _richardson_by_rates
from tests.test_weight_derivative_rest import CONTROLLED_BOOM

PD = '  pd: {output: "-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2)"}'
#: the spar's start's velocity: a point at an offset from the wheel's node (sensor kind 6, v + ω × T r)
OFFSET_V = "    off_v: {point: spar.start, quantity: velocity, component: y}\n"


def _pd(output: str, before: str = "", probes: str = "") -> str:
    """The controlled boom with the arm's PD's output ``output``, controllers ``before`` it and probes ``probes``."""
    return (CONTROLLED_BOOM.replace(PD, before + '  pd: {output: "' + output + '"}', 1)
            .replace("    angle: {", probes + "    angle: {", 1))


#: the PD reading the spar's start's velocity (at an offset from the wheel's node), nonlinear in it and the angle
OFFSET_VELOCITY = _pd("-Kp*sin(angle - 0.3) - Kd*rate*(1 + angle**2) - 0.5*off_v*(1 + angle**2) - 0.3*off_v**2",
                      probes=OFFSET_V)
#: the PD of another controller reading the angle, the rate and the offset velocity
CHAIN = _pd("-inner*(1 + 0.5*inner) - Kd*rate*(1 + angle**2)",
            before='  inner: {output: "Kp*sin(angle - 0.3) + 0.4*rate*angle + 0.3*off_v*angle"}\n', probes=OFFSET_V)
#: the PD with an integral state z and an input g, mixing z, the angle and the rate
INPUT_STATE = (_pd("-Kp*sin(angle - 0.3)*(1 + z) - g*Kd*rate*(1 + angle**2) - 0.3*z*angle*rate")
               .replace('- 0.3*z*angle*rate"}', '- 0.3*z*angle*rate",\n       states: {z: "angle - 0.4"}, '
                        'initial: {z: 0.2}}', 1) + "inputs: {g: 1.3}\n")
#: the spar's hinge's force probe read beside the arm's rate, the spar's damper a law of its angle
DAMPED_FORCE = (FORCE.replace("damping: 0.2}", 'damping: "0.2*(1 + theta**2)"}', 1)
                .replace("+ 0.2*spar_torque**2", "+ 0.2*spar_torque**2 + 0.3*spar_torque*rate", 1))
PUSH = '"Kc*(sin(angle - 0.3) + 0.5*angle**2 + 0.1*rate*angle)"'
#: the boom's driven loads, their controller reading the offset velocity and the spar's tip's velocity in the wheel's
#: axes
LOAD_VELOCITY = (LOAD.replace(PUSH, '"Kc*(sin(angle - 0.3) + 0.5*angle**2 + 0.1*rate*angle + 0.8*off_v*angle '
                              '+ 0.3*rel_v**2)"', 1)
                 .replace("    angle: {", OFFSET_V + "    rel_v: {point: spar.end, quantity: velocity, frame: wheel, "
                          "component: x}\n    angle: {", 1))
#: the driven loads' controller reading another controller of the angle and the wheel's velocity
LOAD_CHAIN = (LOAD.replace("  push: {output: " + PUSH + "}",
                           '  inner: {output: "0.5*sin(angle) + 0.2*wheel_vz*angle"}\n'
                           '  push: {output: "Kc*(sin(angle - 0.3) + 0.5*angle**2 + 0.1*rate*inner + inner**2)"}', 1)
              .replace("    angle: {", "    wheel_vz: {point: wheel, quantity: velocity, component: z}\n    angle: {", 1))
#: the driven loads' controller reading the stay's tension (its damper's c ℓ̇ moving with the rates)
LOAD_TENSION = LOAD.replace(PUSH, '"Kc*(sin(angle - 0.3) + 0.5*angle**2 + 0.1*rate*angle + 0.3*pull*angle '
                                  '+ 0.2*pull**2)"', 1)
assert all(PD in t or "off_v" in t for t in (OFFSET_VELOCITY, CHAIN)) and "states: {z" in INPUT_STATE
assert "0.3*spar_torque*rate" in DAMPED_FORCE and "rel_v**2" in LOAD_VELOCITY and "inner**2" in LOAD_CHAIN
assert "pull**2" in LOAD_TENSION

SCENES = {"offset_velocity": OFFSET_VELOCITY, "relative_velocity": RELATIVE, "spar_relative_velocity": SPAR,
          "chain": CHAIN, "input_state": INPUT_STATE, "tension": TENSION, "joint_force": DAMPED_FORCE,
          "load_velocity": LOAD_VELOCITY, "load_chain": LOAD_CHAIN, "load_tension": LOAD_TENSION}


@pytest.mark.parametrize("name", list(SCENES))
def test_the_rates_term_of_the_remaining_controllers_takes_no_evaluation_and_is_richardsons(monkeypatch, name):
    """At a turned, moving state (3 columns of δv): no evaluation of the model in the rates' term (ea72688: 6, a
    central difference of those couplings' and loads' K w), and within 2e-10 of the Richardson reference's largest
    entry (measured 4.8e-14 … 2.2e-11; ea72688's difference 2.0e-12 … 4.7e-10: docs/performance.md "The rates'
    weight derivative of the remaining controllers (issue 34)")."""
    prepared, state, w, dv, computed, counts, moving = _rates_term(monkeypatch, SCENES[name])
    assert counts == [0]
    reference = _richardson_by_rates(prepared, state, w, dv, moving)
    assert np.abs(reference).max() > 0.0
    assert np.abs(computed - reference).max() <= 2e-10 * np.abs(reference).max()


def test_a_section_force_pds_rates_term_is_its_mixed_derivative_exactly(monkeypatch):
    """The PD reading the arm's tip element's bending moment and torque beside its angle and rate: no evaluation
    (ea72688: 6), and the hinge's row is −∂²y/∂θ∂θ̇ w_θ δθ̇ = 2 Kd θ w_θ δθ̇ (the section forces do not read a rate)
    to 1e-14 (measured 0; ea72688's difference 4.0e-5 off, the Richardson reference itself 2.2e-7 off there: K w
    holds the section forces' large gradients), every other row 0."""
    prepared, state, w, dv, computed, counts, _ = _rates_term(monkeypatch, SECTION)
    assert counts == [0]
    d = int(prepared.model.hinge_dofs[0])
    exact = 2 * 0.05 * state.theta[0] * w[d] * dv[d]
    assert np.abs(computed[d] - exact).max() <= 1e-14 * np.abs(exact).max()
    assert not np.delete(computed, d, axis=0).any()


def test_latdyn_run_of_a_chain_of_velocity_controllers_agrees_and_the_loop_off_writes_the_same(monkeypatch, tmp_path):
    """``latdyn run`` of the boom whose PD reads a controller of the angle, the rate and the spar's start's velocity,
    through the arm's latch: the rates' term takes no evaluation at the event (ea72688: 2 a parameter), the event
    sensitivities by Kp in summary.json are the API's and agree with Richardson differences of whole runs (measured
    2.1e-7 on the probes, the event's dt 5.0e-9), and the loop of steps off writes the same files byte for byte."""
    text = CHAIN.replace("sensitivities: [Kp, k]", "sensitivities: [Kp]")
    counts = _evaluations_in_the_rates_term(monkeypatch)
    latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    monkeypatch.undo()
    assert counts and not any(counts)
    latdyn_run_through_the_latch_agrees(tmp_path, text, "Kp", 1e-6)


@pytest.mark.parametrize("name", ["chain", "load_velocity"])
def test_the_adjoint_takes_the_same_generated_matrix(monkeypatch, name):
    """The adjoint's transposed rates' term is the forward method's generated matrix times ū: no evaluation in the
    rates' term (ea72688: two a free rate), its summary's end rows within 1e-8 of the forward method's, relative to
    each probe's own (measured 4.8e-12 on the chain; 3.4e-9 on the driven loads, as ea72688's, on a probe whose end
    sensitivity is small) and the event's dt within 1e-10 (measured 6.1e-15, 7.2e-12)."""
    text = SCENES[name]
    parameter = "Kp" if name == "chain" else "Kc"
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = [parameter]
    forward = latdyn.run(latdyn.load_scene(data))
    data["solve"]["sensitivity_method"] = "adjoint"
    counts = _evaluations_in_the_rates_term(monkeypatch)
    adjoint = latdyn.run(latdyn.load_scene(data))
    monkeypatch.undo()
    assert counts and not any(counts), counts
    assert adjoint.summary["events"] == forward.summary["events"]
    for probe, by_name in forward.summary["probe_sensitivities"].items():
        expected = by_name["end"][parameter]
        computed = adjoint.summary["probe_sensitivities"][probe]["end"][parameter]
        assert abs(computed - expected) <= 1e-8 * max(abs(expected), 1e-12), probe
    for mine, theirs in zip(adjoint.summary["event_sensitivities"], forward.summary["event_sensitivities"]):
        assert abs(mine["dt"][parameter] - theirs["dt"][parameter]) <= 1e-10 * abs(theirs["dt"][parameter])
