"""The impulse weight's derivative on models with rigid links or guides: the point loads', cables' and continuous
controllers' couplings' blocks generated through the reduction (latdyn/analyses/weight_derivative.py, "Rigid links and
guides"; docs/parameters.md, "The impulse weight's derivative"), where 10be92c differenced them (``linked_rest_product``,
two evaluations a parameter at each event).

On four 3D YAML scenes — the gimbal of rigid links latching with its tip load in the inner ring's frame, a follower
load on the outer ring (a dependent node) and a global one on the inner ring; a slider-crank on a guide with three
damped cables (one taut to the crank's pin, one taut between the pin and the guided slider, both dependent nodes, one
slack); a mass on a skew guide at a flexible arm's tip with a follower load on it and on the tip, bouncing on its
stop; a chain of rigid bays with a boom of 24 elements (band storage) whose second hinge a PD controller of the
hinges' angles and rate drives — the exact part against Richardson-extrapolated differences of Pᵀ W_gen P w at a
turned state with random rates, and at every event through the API no difference taken and ∂(W w)/∂q δq against the
Richardson reference of tests/test_weight_derivative_linked.py; a controller whose output mixes an angle and a rate and
reads an input keeps its entries in the difference, a hinge damper naming an input no longer
(ctrlweight); the slider-crank through
the CLI, loop on and off (the whole runs' sensitivities against Richardson central differences of whole runs are
measured in docs/performance.md, "The linked weight's loads, cables and couplings generated (issue 34)")."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses import weight_derivative
from latdyn.assembly.assembler import free_acceleration, free_velocity, unpack_free
from latdyn.assembly.prepare import prepare
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_linked_cables import LINKED_CABLES
from tests.test_sensitivities_guides import GUIDE_3D
from tests.test_sensitivities_in_loop_sparse import LONG_CHAIN
from tests.test_sensitivities_rigid_links import LATCH, SLIDER_CRANK
from tests.test_weight_derivative_linked import checked_against_the_reference, turned_state

#: the gimbal latching, its tip load in the inner ring's frame, a follower force and moment on the outer ring (a
#: dependent node: its turns follow the links) and a global force on the inner ring (its block zero)
GIMBAL_LOADS = LATCH.replace('  - {at: tip, force: [0, "P", "-0.5*P"]}\n',
                             '  - {at: tip, force: [0, "P", "-0.5*P"], frame: inner}\n'
                             '  - {at: outer, force: ["0.3*P", 0, "0.2*P"], moment: [0, 0.05, -0.02], frame: outer}\n'
                             '  - {at: inner, force: [0.1, -0.05, 0.08]}\n')
#: the slider-crank between its stops with three damped cables: from an anchor off the mechanism's plane to the
#: crank's pin (taut), from the pin to the guided slider (both dependent nodes; taut), from the anchor to the slider
#: (slack)
CRANK_CABLES = (SLIDER_CRANK.replace("parameters: {tau: 2.0, m: 1.0, k: 30.0}",
                                     "parameters: {tau: 2.0, m: 1.0, k: 30.0, L: 0.19}")
                .replace("  hub: {at: [0, 0, 0], fixed: true}\n",
                         "  hub: {at: [0, 0, 0], fixed: true}\n  anchor: {at: [0.15, 0.25, 0.12], fixed: true}\n")
                .replace("solve: {", "cables:\n"
                         '  tether: {from: anchor, to: {body: pin, offset: [0.01, 0, 0.02]}, EA: 30.0, rest_length: "L",'
                         " damping: 0.5}\n"
                         "  across: {from: pin, to: {body: slider, offset: [0, 0.05, 0.03]}, EA: 20.0, rest_length: 0.28,"
                         " damping: 0.2}\n"
                         "  loose: {from: anchor, to: slider, EA: 50.0, rest_length: 1.0, damping: 0.3}\nsolve: {")
                .replace("sensitivities: [tau, m]", "sensitivities: [tau, m, L]"))
#: a mass on a skew guide at the tip of a flexible arm, bouncing on its stop (t = 0.2296 s), a follower force and
#: moment on it (a dependent node) and a follower force on the arm's tip body
BEAD_FOLLOWER = (GUIDE_3D.replace('rest: "rest"}}', 'rest: "rest", limits: [-0.03, 0.03], restitution: 0.8}}')
                 .replace("t_end: 0.4", "t_end: 0.3")
                 .replace("solve: {", 'loads:\n  - {at: slider, force: [0.3, -0.2, "m"], moment: [0.01, 0, 0.02], '
                          'frame: slider}\n  - {at: tip, force: [0, 0.2, 0.1], frame: tip}\nsolve: {'))
#: the deploying chain of rigid bays with a boom of 24 elements (band storage), latching twice, a PD of the second
#: hinge's angle and rate (and the first's angle, nonlinear in the angles) driving the second hinge, the tip load
#: out of the bays' plane
CHAIN_PD = (LONG_CHAIN.replace("parameters: {k: 1.5,", "parameters: {Kp: 0.3, Kd: 0.02, k: 1.5,")
            .replace("rest_angle: 2*pi/3 + 0.3, lock_at", 'rest_angle: 2*pi/3 + 0.3, torque: "pd", lock_at')
            .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(2.2 - knee2) - Kd*rate2 + 0.5*Kp*(knee2 - 2)**2'
                     ' + 0.1*Kp*knee1**2"}\nsolve: {')
            .replace('  - {at: tip, force: [0, 0, "-F"]}\n', '  - {at: tip, force: [0, "0.3*F", "-F"]}\n')
            .replace("    knee2: {hinge: bay2.start, quantity: angle}\n",
                     "    knee2: {hinge: bay2.start, quantity: angle}\n    rate2: {hinge: bay2.start, quantity: rate}\n")
            .replace("sensitivities: [k, c, m, EI, F]", "sensitivities: [Kp, Kd, k, m, F]"))
#: the gimbal with loads, a controller of the inner hinge's angle and rate whose output mixes them (its entries move
#: with the rate: generated, tests/test_weight_derivative_linked_rates.py) driving the inner hinge
GIMBAL_MIXED = (GIMBAL_LOADS.replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, Kd: 0.05, k1: 6.0,")
                .replace('damping: "c2", lock_at', 'damping: "c2", torque: "pd", lock_at')
                .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(0.3 - a2) - Kd*r2*(1 + a2)"}\nsolve: {'))

#: the gimbal with loads, its outer hinge damped by 0.05 (1 + 4θ²): the hinge's K_jj = ∂f/∂θ holds c′(θ) θ̇, which
#: moves with the rate the reduction's move carries (∂K_jj/∂θ̇ generated: tests/test_weight_derivative_linked_rates.py)
GIMBAL_DAMPED = GIMBAL_LOADS.replace('stiffness: "k1", rest_angle: "rest"}}}',
                                     'stiffness: "k1", rest_angle: "rest", damping: "0.05*(1 + 4*theta**2)"}}}')
#: the same damper times an input g = 1 (its ∂K_jj/∂θ̇ generated at the input's value since ctrlweight)
GIMBAL_DAMPED_INPUT = GIMBAL_LOADS.replace('stiffness: "k1", rest_angle: "rest"}}}',
                                           'stiffness: "k1", rest_angle: "rest", damping: "0.05*g*(1 + 4*theta**2)"}}}'
                                           ) + "inputs: {g: 1.0}\n"
#: :data:`GIMBAL_MIXED` with its rate term times an input g = 1 (a controller reading an input: its entries' move with
#: the rates generated on linked models since linkedhand, ``linked_chain_rates_product``; 40bf44a differenced them)
GIMBAL_MIXED_INPUT = GIMBAL_MIXED.replace("Kd*r2*(1 + a2)", "g*Kd*r2*(1 + a2)") + "inputs: {g: 1.0}\n"

SCENES = {"the gimbal's loads in the rings' frames": (GIMBAL_LOADS, ["latch"], 5e-11),
          "the slider-crank's cables": (CRANK_CABLES, ["stop", "stop"], 1e-9),
          "the guided mass's follower load": (BEAD_FOLLOWER, ["stop"], 5e-11),
          "the rigid chain's PD": (CHAIN_PD, ["latch", "latch"], 1e-10)}


#: the scenes of the exact part's check at a turned state: :data:`SCENES`' and tests/test_linked_cables.py's free body
#: carrying a guided body and a rigid link under a skew gravity, three damped taut cables (to the guided body, to the
#: linked one, from the free body to the linked one) and loads with a moment (no events: no sensitivities)
TURNED = {**{name: text for name, (text, _, _) in SCENES.items()},
          "three damped cables on a guided and a linked body": LINKED_CABLES.replace("guide: {on: A,", "guide: {'on': A,")}


def _moved(assembler, state, h, dq, dv, dvdot):
    """``state`` moved by h along (δq, δv, δv̇), the dependent nodes completed (as TransientSensitivities._linked_move)."""
    model = assembler.model
    moved = assembler.advance(state, h * dq)
    unpack_free(model, free_velocity(model, state) + h * dv, moved.v, moved.w, moved.theta_dot)
    unpack_free(model, free_acceleration(model, state) + h * dvdot, moved.a, moved.alpha, moved.theta_ddot)
    assembler.complete_links(moved)
    return moved


@pytest.mark.parametrize("name", list(TURNED))
def test_the_loads_cables_and_couplings_are_generated_through_the_reduction(name):
    """Every block of W is generated on these scenes (W_rest = 0: no evaluation is differenced), and the exact part,
    ∂(Pᵀ W_gen P w)/∂q δq (``linked_configuration_tangent``) plus the damped taut cables' move with the rates
    (``linked_cable_rates_product``), at a turned state with random rates against Richardson-extrapolated central
    differences of Pᵀ W_gen P w along (δq, δv, δv̇) (steps 4e-5, 2e-5, 1e-5: the chain's elements of 0.021 m leave
    6e-8 of truncation at 4e-4), W = M + 1e-4 K and W = K (measured 5.5e-13 – 1.9e-11). On 10be92c
    W_rest held the loads', cables' and couplings' blocks."""
    from latdyn.analyses.weight_derivative import _linked_weight, linked_configuration_tangent, linked_has_rest

    assembler, state, rng = turned_state(TURNED[name], 7, 0.01)
    n = assembler.model.n_dofs
    hinges = np.ones(len(assembler.model.free_hinges), bool)   # every hinge's part generated on these scenes
    ev = assembler.evaluate(state, matrices=True)
    W_rest = _linked_weight(assembler, ev, 1.0, True, hinges, generated=False)
    assert not linked_has_rest(assembler) and not np.any(np.asarray(W_rest.todense() if hasattr(W_rest, "todense")
                                                                    else W_rest))
    from latdyn.analyses.weight_derivative import linked_cable_rates_product

    errors = []
    for mass, scale in ((True, 1e-4), (False, 1.0)):
        w, dq, dv, dvdot = rng.normal(size=n), rng.normal(size=(n, 1)), rng.normal(size=(n, 1)), rng.normal(size=(n, 1))
        exact = linked_configuration_tangent(assembler, state, w, dq, scale, mass)
        by_rates = linked_cable_rates_product(assembler, state, w, dq, scale, (dv, dvdot))
        if by_rates is not None:
            exact = exact + by_rates

        def product(h):
            moved = _moved(assembler, state, h, dq[:, 0], dv[:, 0], dvdot[:, 0])
            ev = assembler.evaluate(moved, matrices=True)
            W_gen = _linked_weight(assembler, ev, scale, mass, hinges, generated=True)
            return np.asarray(ev.projection.T @ (W_gen @ np.asarray(ev.projection @ w))).reshape(-1)

        d1, d2, d3 = ((product(h) - product(-h)) / (2 * h) for h in (4e-5, 2e-5, 1e-5))
        reference = (16 * (4 * d3 - d2) / 3 - (4 * d2 - d1) / 3) / 15
        errors.append(float(np.max(np.abs(exact[:, 0] - reference)) / np.max(np.abs(reference))))
    assert max(errors) <= 1e-10, errors


def _at_events(text, monkeypatch):
    """The scene run through the API, each event's ∂(W w)/∂q δq's error against tests/test_weight_derivative_linked's
    Richardson reference (relative to its largest) and the count of the differences of W_rest taken."""
    rest = weight_derivative.linked_rest_product
    errors, differences = checked_against_the_reference(monkeypatch), []

    def counted(*args, **kwargs):
        differences.append(1)
        return rest(*args, **kwargs)

    monkeypatch.setattr("latdyn.analyses.transient_sensitivities.linked_rest_product", counted)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    return result, errors, len(differences)


#: {scene text: _at_events' result}, for the scenes two tests check (the slider-crank's cables: its events through
#: the API, and its CLI run against the API's), run once in a process (the checks read the result, never change it)
_RUNS_AT_EVENTS: dict = {}


def _at_events_once(text):
    """:func:`_at_events` of ``text``, run the first time it is asked for in this process."""
    if text not in _RUNS_AT_EVENTS:
        with pytest.MonkeyPatch.context() as patch:
            _RUNS_AT_EVENTS[text] = _at_events(text, patch)
    return _RUNS_AT_EVENTS[text]


@pytest.mark.parametrize("name", list(SCENES))
def test_the_events_take_no_difference_and_agree_with_richardson(name):
    """At every event of the scene (through the API) no difference of W_rest is taken (10be92c took two evaluations a
    parameter), and ∂(W w)/∂q δq agrees with the Richardson reference within :data:`SCENES`' tolerance (measured
    2.3e-12, 2.2e-10, 5.1e-13, 2.8e-11: the links' second derivatives' difference and the reference's own error
    dominate)."""
    text, events, tolerance = SCENES[name]
    result, errors, differences = _at_events_once(text)
    assert [e["kind"] for e in result.summary["events"]] == events
    assert differences == 0
    assert errors and max(errors) < tolerance, errors


def test_a_controller_mixing_an_angle_and_a_rate_and_reading_an_input_is_generated(monkeypatch):
    """The gimbal with loads and a PD whose output holds g Kd r2 a2, g an input (its coupling's entry −∂y/∂a2 moves with
    the rate r2, which the reduction's move carries): since linkedhand its entry is generated
    (``_linked_chain_controllers``, ``linked_chain_rates_product``; 40bf44a kept it alone in W_rest and took the
    difference at the latch): W_rest is empty, no difference is taken at the latch, and ∂(W w)/∂q δq agrees with the
    Richardson reference."""
    from latdyn.analyses.weight_derivative import _linked_weight, exact_hinges, linked_exact_couplings

    prepared = prepare(latdyn.load_scene(yaml.safe_load(GIMBAL_MIXED_INPUT)))
    assembler = prepared.assembler
    ev = assembler.evaluate(prepared.state, matrices=True)
    W_rest = _linked_weight(assembler, ev, 1.0, True, exact_hinges(assembler), generated=False)
    W_rest = np.asarray(W_rest.todense() if hasattr(W_rest, "todense") else W_rest)
    assert not np.any(W_rest) and np.all(linked_exact_couplings(assembler))
    result, errors, differences = _at_events(GIMBAL_MIXED_INPUT, monkeypatch)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"] and differences == 0
    assert errors and max(errors) < 5e-11, errors


def test_the_slider_cranks_cables_through_the_cli_loop_on_and_off(tmp_path):
    """The slider-crank with its cables through ``latdyn run``: steps in the loop, the loop off writing the same bytes,
    and the API's event sensitivities the CLI's, made without a difference of W_rest (10be92c took one at each
    event; the whole runs' sensitivities against Richardson central differences of whole runs are measured in
    docs/performance.md: 3.4e-10 – 2.0e-9 of each probe's largest on both)."""
    run, out = latdyn_run(tmp_path, CRANK_CABLES, quiet=True)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] > 0 and [e["kind"] for e in summary["events"]] == ["stop", "stop"]
    the_loop_off_writes_the_same(tmp_path, out)
    result, _, differences = _at_events_once(CRANK_CABLES)
    assert json.loads(json.dumps(result.summary["event_sensitivities"])) == summary["event_sensitivities"]
    assert differences == 0


def test_a_hinge_whose_stiffness_moves_with_its_rate_through_a_law_naming_an_input_is_generated(monkeypatch):
    """The gimbal with loads and its outer hinge damped by 0.05 g (1 + 4θ²), g an input (K_jj holds c′(θ) θ̇; its
    ∂K_jj/∂θ̇ generated at the input's value, tests/test_weight_derivative_controllers_rest.py): no difference taken
    at the latch (86d57d9 took 10, its entry differenced along the move), the latch's ∂(W w)/∂q δq agreeing with the
    Richardson reference (measured 5.7e-12 on both), where 10be92c, whose generated hinges' part left the rate's move
    out, was 1.7e-4 off (the same damper without the input)."""
    result, errors, differences = _at_events(GIMBAL_DAMPED_INPUT, monkeypatch)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"] and differences == 0
    assert errors and max(errors) < 5e-11, errors
    from latdyn.analyses.weight_derivative import linked_exact_hinges

    prepared = prepare(latdyn.load_scene(yaml.safe_load(GIMBAL_DAMPED_INPUT)))
    assert linked_exact_hinges(prepared.assembler).tolist() == [True, True]
