"""The impulse weight's derivative on models with rigid links or guides: the hinges whose K_jj moves with their rate,
the continuous controllers' couplings whose output mixes an angle and a rate and the couplings of controllers reading
points' positions (``_linked_position_controllers``), generated through the reduction
(latdyn/analyses/weight_derivative.py, "Rigid links and guides": ``linked_rates_tangent``; docs/parameters.md, "The
impulse weight's derivative"), where af426b0 differenced them (``linked_rest_product``, two evaluations a parameter
at each event).

On 3D YAML scenes of the gimbal of rigid links on skew hinges latching (its inner hinge locks; loads in the rings'
frames): its outer hinge damped by 0.05 (1 + 4θ²) (K_jj holds c′(θ) θ̇); its outer hinge with a torque law of θ and θ̇;
its outer hinge on a damped compliant stop (at a turned state in contact);
a PD of the inner hinge's angle and rate, nonlinear in both, driving the inner hinge; a PD of the outer hinge's angle
and rate, nonlinear in both, driving the outer hinge (its row stays free through the latch); the chain of rigid bays
latching twice with a PD of two points on the bays' bodies (dependent nodes) — the exact part against
Richardson-extrapolated differences of Pᵀ W_gen P w at a turned state with random rates, and at every event through
the API no difference taken and ∂(W w)/∂q δq against the Richardson reference of tests/test_weight_derivative_linked.py;
the outer PD through the CLI, loop on and off (the whole runs' sensitivities against Richardson central differences of
whole runs are measured in docs/performance.md, "The linked weight's rates generated (issue 34)")."""
from __future__ import annotations

import json

import numpy as np
import pytest

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_in_loop_links import CHAIN
from tests.test_weight_derivative_linked import turned_state
from tests.test_weight_derivative_linked_rest import GIMBAL_DAMPED, GIMBAL_LOADS, GIMBAL_MIXED, _at_events_once, _moved

#: the gimbal with loads, its outer hinge's torque a law of θ and θ̇ both (its ∂f/∂θ moves with θ̇)
GIMBAL_TORQUE = GIMBAL_LOADS.replace('stiffness: "k1", rest_angle: "rest"}}}',
                                     'stiffness: "k1", rest_angle: "rest", '
                                     'torque: "-0.3*(theta - 0.6)*(1 + 0.5*theta_dot**2)"}}}')
#: the gimbal with loads, a PD of the outer hinge's angle and rate whose output mixes them driving the outer hinge
#: (free through the latch: its coupling's row reaches the sensitivities)
GIMBAL_MIXED_OUTER = (GIMBAL_LOADS.replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, Kd: 0.05, k1: 6.0,")
                      .replace('stiffness: "k1", rest_angle: "rest"}}}',
                               'stiffness: "k1", rest_angle: "rest", torque: "pd"}}}')
                      .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(0.6 - a1) - Kd*r1*(1 + 2*a1**2)"}\n'
                               "solve: {")
                      .replace("    r2: {hinge: gim2.start, quantity: rate}\n",
                               "    r2: {hinge: gim2.start, quantity: rate}\n"
                               "    r1: {hinge: gim1.start, quantity: rate}\n")
                      .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, Kd, k1, m]"))

#: the gimbal with loads, its outer hinge on a damped compliant stop (Hunt–Crossley, n = 1.5), in contact at the turned
#: state of the exact part's check (θ = −0.046 below −0.01): n δⁿ⁻¹ c δ̇ in K_jj moves with the rate
GIMBAL_STOP = GIMBAL_LOADS.replace('stiffness: "k1", rest_angle: "rest"}}}',
                                   'stiffness: "k1", rest_angle: "rest", limits: [-0.01, 1.0], '
                                   'contact: {stiffness: 200.0, exponent: 1.5, damping: 5.0}}}}')

#: the deploying chain of rigid bays latching twice, a PD of two points on the bays' bodies (dependent nodes: their
#: positions' second derivatives by the assembled coordinates), nonlinear in them, driving the second hinge
CHAIN_POINTS = (CHAIN.replace("parameters: {k: 1.5,", "parameters: {Kp: 0.4, k: 1.5,")
                .replace('rest_angle: 2*pi/3 + 0.3, lock_at', 'rest_angle: 2*pi/3 + 0.3, torque: "pd", lock_at')
                .replace("solve: {", "controllers:\n"
                         '  pd: {output: "Kp*(0.45 - s2x) + 3*Kp*(s1z - 0.4)**2 + Kp*s2x*s1z"}\nsolve: {')
                .replace("    knee2: {hinge: bay2.start, quantity: angle}\n",
                         "    knee2: {hinge: bay2.start, quantity: angle}\n"
                         "    s2x: {point: s2, quantity: position, component: x}\n"
                         "    s1z: {point: s1, quantity: position, component: z}\n")
                .replace("sensitivities: [k, c, m, EI, F]", "sensitivities: [Kp, k, m, F]"))

SCENES = {"the outer hinge's damper of θ": GIMBAL_DAMPED,
          "the outer hinge's torque of θ and θ̇": GIMBAL_TORQUE,
          "the inner hinge's PD of its angle and rate": GIMBAL_MIXED,
          "the outer hinge's PD of its angle and rate": GIMBAL_MIXED_OUTER,
          "the chain's PD of two points": CHAIN_POINTS}


#: the gimbal with loads, a controller of the inner ring's position in the outer ring's axes (both dependent bodies)
#: and the tip's displacement driving the outer hinge
GIMBAL_BODY_FRAME = (GIMBAL_LOADS.replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, k1: 6.0,")
                     .replace('stiffness: "k1", rest_angle: "rest"}}}',
                              'stiffness: "k1", rest_angle: "rest", torque: "pd"}}}')
                     .replace("solve: {", "controllers:\n"
                              '  pd: {output: "Kp*(0.3 - ox) + Kp*ox**2 + 2*Kp*tz*ox"}\nsolve: {')
                     .replace("    a1: {", "    ox: {point: inner, quantity: position, component: x, frame: outer}\n"
                              "    tz: {point: tip, quantity: displacement, component: z}\n    a1: {"))
#: the scenes whose controllers read positions alone (nothing of theirs moves with the rates)
POSITIONS = ("the chain's PD of two points", "the gimbal's PD of a ring's position in the other's axes")
#: the scenes of the exact part's check at a turned state: :data:`SCENES`, the damped compliant stop and the body frame
TURNED = {**SCENES, "the outer hinge's damped compliant stop": GIMBAL_STOP, POSITIONS[1]: GIMBAL_BODY_FRAME}


def richardson_of_the_generated_product(assembler, state, hinges, w, dq, dv, dvdot, scale: float, mass: bool):
    """Richardson-extrapolated central differences (steps 4e-5, 2e-5, 1e-5) of Pᵀ W_gen P w along the move
    (δq, δv, δv̇) (first columns), the dependent nodes completed: the reference of the exact part's checks."""
    from latdyn.analyses import weight_derivative as wd

    def product(h):
        moved = _moved(assembler, state, h, dq[:, 0], dv[:, 0], dvdot[:, 0])
        ev = assembler.evaluate(moved, matrices=True)
        W_gen = wd._linked_weight(assembler, ev, scale, mass, hinges, generated=True)
        return np.asarray(ev.projection.T @ (W_gen @ np.asarray(ev.projection @ w))).reshape(-1)

    d1, d2, d3 = ((product(h) - product(-h)) / (2 * h) for h in (4e-5, 2e-5, 1e-5))
    return (16 * (4 * d3 - d2) / 3 - (4 * d2 - d1) / 3) / 15


@pytest.mark.parametrize("name", list(TURNED))
def test_the_hinges_and_couplings_moving_with_the_rates_are_generated_through_the_reduction(name):
    """W_rest = 0 (``linked_has_rest`` False: af426b0 differenced these entries), and the exact part —
    ∂(Pᵀ W_gen P w)/∂q δq plus the hinges' and couplings' move with the free rates, s ``linked_rates_tangent`` δv
    (none on the chain and the body frame's: their controllers read positions alone) — at a turned state with random
    rates against Richardson-extrapolated central differences of Pᵀ W_gen P w along (δq, δv, δv̇) (steps 4e-5, 2e-5,
    1e-5), W = M + 1e-4 K and W = K."""
    from latdyn.analyses import weight_derivative as wd

    from latdyn.assembly.control import ANGLE, BODY_FRAME, POSITION

    positions = name in POSITIONS
    assembler, state, rng = turned_state(TURNED[name], 11, 0.05 if positions else 0.3)
    assert not wd.linked_has_rest(assembler)
    n = assembler.model.n_dofs
    hinges = wd.linked_exact_hinges(assembler)
    moving = wd.linked_rates_tangent(assembler, state, np.ones(n))
    if positions:   # positions alone (no velocity sensor among the kinds taken): nothing moves with the rates
        assert {ANGLE, POSITION, BODY_FRAME} <= set(wd._LINKED_POSITION_SENSORS)   # the kinds measured here
        assert moving is None and any(wd._linked_position_controllers(assembler))
    else:
        assert moving is not None and np.any(wd.times(moving, np.ones((n, 1))))
    errors = []
    for mass, scale in ((True, 1e-4), (False, 1.0)):
        w, dq, dv, dvdot = rng.normal(size=n), rng.normal(size=(n, 1)), rng.normal(size=(n, 1)), rng.normal(size=(n, 1))
        exact = wd.linked_configuration_tangent(assembler, state, w, dq, scale, mass)
        if moving is not None:
            exact = exact + scale * wd.times(wd.linked_rates_tangent(assembler, state, w), dv)
        reference = richardson_of_the_generated_product(assembler, state, hinges, w, dq, dv, dvdot, scale, mass)
        errors.append(float(np.max(np.abs(exact[:, 0] - reference)) / np.max(np.abs(reference))))
    assert max(errors) <= 1e-9, errors


@pytest.mark.parametrize("name", list(SCENES))
def test_the_events_take_no_difference_and_agree_with_richardson(name):
    """At the latch (through the API) no difference of W_rest is taken (af426b0 took two evaluations a parameter), and
    ∂(W w)/∂q δq agrees with tests/test_weight_derivative_linked's Richardson reference."""
    result, errors, differences = _at_events_once(SCENES[name])
    assert [e["kind"] for e in result.summary["events"]] == ["latch"] * (2 if "chain" in name else 1)
    assert differences == 0
    assert errors and max(errors) < 5e-11, errors


def test_the_outer_pd_through_the_cli_loop_on_and_off(tmp_path):
    """The gimbal with the outer hinge's mixed PD through ``latdyn run``: the loop off writing the same bytes, and the
    API's event sensitivities the CLI's, made without a difference of W_rest."""
    run, out = latdyn_run(tmp_path, GIMBAL_MIXED_OUTER, quiet=True)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert [e["kind"] for e in summary["events"]] == ["latch"]
    the_loop_off_writes_the_same(tmp_path, out)
    result, _, differences = _at_events_once(GIMBAL_MIXED_OUTER)   # the events test's run, when this process made it
    assert json.loads(json.dumps(result.summary["event_sensitivities"])) == summary["event_sensitivities"]
    assert differences == 0


#: the gimbal with loads, the tip load's z component driven by a controller of the outer hinge's angle
GIMBAL_DRIVEN_LOAD = (GIMBAL_LOADS.replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, k1: 6.0,")
                      .replace('  - {at: tip, force: [0, "P", "-0.5*P"], frame: inner}\n',
                               '  - {at: tip, force: [0, "P", "pd"], frame: inner}\n')
                      .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(0.3 - a1) + Kp*a1**2"}\nsolve: {'))


def test_a_driven_loads_coupling_entries_are_generated_with_its_block():
    """A load a controller of joints' angles drives: its block and its coupling entries F(e_p) ∂y/∂q are in W_gen
    together since linkedhand (``linked_generated_loads``, ``linked_exact_couplings`` True for a load's entries; their
    move along q ``_driven_load_part``'s at u = P w): the exact part against Richardson's difference of Pᵀ W_gen P w
    at this turned state, measured 1.2e-11. (af426b0 put the entries alone in W_gen, whose exact part then left their
    derivative out, 3.1e-8 off; 40bf44a differenced the block and the entries.)"""
    from latdyn.analyses import weight_derivative as wd

    assembler, state, rng = turned_state(GIMBAL_DRIVEN_LOAD, 11, 0.3)
    assert not wd.linked_has_rest(assembler) and np.all(wd.linked_exact_couplings(assembler))
    n = assembler.model.n_dofs
    hinges = wd.linked_exact_hinges(assembler)
    w, dq, dv, dvdot = rng.normal(size=n), rng.normal(size=(n, 1)), rng.normal(size=(n, 1)), rng.normal(size=(n, 1))
    exact = wd.linked_configuration_tangent(assembler, state, w, dq, 1.0, False)
    moved = wd.linked_chain_rates_product(assembler, state, w, dq, 1.0, (dv, dvdot))
    if moved is not None:   # a controller of an angle alone: no move along the rates
        exact = exact + moved
    reference = richardson_of_the_generated_product(assembler, state, hinges, w, dq, dv, dvdot, 1.0, False)
    assert np.max(np.abs(exact[:, 0] - reference)) / np.max(np.abs(reference)) <= 1e-9
