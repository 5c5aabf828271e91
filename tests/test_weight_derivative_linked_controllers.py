"""The impulse weight's derivative on models with rigid links or guides: the couplings of continuous controllers reading
a point at an offset from its node (x + T r), a cable's length, and positions beside nodes' velocities generated
through the reduction
(latdyn/analyses/weight_derivative.py, "Rigid links and guides": ``_linked_position_controllers``,
``_LINKED_POSITION_SENSORS``; docs/parameters.md, "The impulse weight's derivative"), where ea72688 differenced them
(``linked_rest_product``, two evaluations a parameter at each event).

On 3D YAML scenes: the gimbal of rigid links on skew hinges latching (loads in the rings' frames), its boom starting at
an offset from the inner ring (a dependent node) and its outer hinge driven by a PD of that point's y and z, nonlinear
in them; the deploying chain of rigid bays latching twice, a PD of two points' positions and velocities (dependent
nodes: their rates follow the links; ``_linked_rate_controllers``, ``linked_coupling_rates_product``); the guided
slider-crank between its stops with damped cables, its crank's torque tau + y of a controller of
two cables' lengths (the tether to the crank's pin and the cable between the pin and the slider, dependent nodes),
nonlinear in them — the exact part against Richardson-extrapolated differences of Pᵀ W_gen P w at a turned state with
random rates, at every event through the API no difference taken and ∂(W w)/∂q δq against the Richardson reference of
tests/test_weight_derivative_linked.py; the whole runs' sensitivities by the controllers' gains against Richardson
central differences of whole runs and the adjoint's against the forward method's; the slider-crank through the CLI,
loop on and off."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_adjoint_in_loop_links import _adjoint, _largest_gap
from tests.test_sensitivities_in_loop_links import CHAIN
from tests.test_sensitivities_events import _agree
from tests.test_weight_derivative_linked import turned_state
from tests.test_weight_derivative_linked_rates import richardson_of_the_generated_product
from tests.test_weight_derivative_linked_rest import CRANK_CABLES, GIMBAL_LOADS, _at_events_once

#: the gimbal latching with loads, its boom starting at an offset from the inner ring (a dependent node), a PD of that
#: point's global y and z (OFFSET_POSITION sensors, nonlinear in them) driving the outer hinge (free through the latch)
GIMBAL_OFFSET = (GIMBAL_LOADS.replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, k1: 6.0,")
                 .replace('stiffness: "k1", rest_angle: "rest"}}}',
                          'stiffness: "k1", rest_angle: "rest", torque: "pd"}}}')
                 .replace("boom: {from: inner, to: tip,",
                          "boom: {from: {body: inner, offset: [0.04, 0.03, -0.05]}, to: tip,")
                 .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(0.1 - by) + 4*Kp*by**2 + 2*Kp*by*bz"}\n'
                          "solve: {")
                 .replace("    a1: {", "    by: {point: boom.start, quantity: position, component: y}\n"
                          "    bz: {point: boom.start, quantity: position, component: z}\n    a1: {")
                 .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, k1, m]"))
#: the guided slider-crank between its stops with damped cables, the crank's torque tau + cl, cl a controller of the
#: cables' lengths (CABLE_LENGTH sensors on dependent nodes, nonlinear in them)
CRANK_LENGTH = (CRANK_CABLES.replace("parameters: {tau: 2.0,", "parameters: {Kc: 3.0, tau: 2.0,")
                .replace('torque: "tau"}}}', 'torque: "tau + cl"}}}')
                .replace("solve: {", 'controllers:\n  cl: {output: "Kc*(0.2 - len)*(1 + 3*len) + Kc*(ac - 0.3)**2*len"}\n'
                         "solve: {")
                .replace("    slide: {", "    len: {cable: across, quantity: length}\n"
                         "    ac: {cable: tether, quantity: length}\n    slide: {")
                .replace("sensitivities: [tau, m, L]", "sensitivities: [Kc, tau, m, L]"))
assert "torque: \"pd\"" in GIMBAL_OFFSET and "offset: [0.04" in GIMBAL_OFFSET and "Kp, k1, m" in GIMBAL_OFFSET
#: the deploying chain of rigid bays latching twice, its tip load out of the bays' plane, a PD of two points' positions
#: and two points' velocities (VELOCITY sensors on dependent nodes: their rates follow the links), its output mixing
#: them, driving the second hinge
CHAIN_VELOCITY = (CHAIN.replace("parameters: {k: 1.5,", "parameters: {Kp: 0.4, Kd: 0.05, k: 1.5,")
                  .replace('rest_angle: 2*pi/3 + 0.3, lock_at', 'rest_angle: 2*pi/3 + 0.3, torque: "pd", lock_at')
                  .replace('  - {at: tip, force: [0, 0, "-F"]}\n', '  - {at: tip, force: [0, "0.3*F", "-F"]}\n')
                  .replace("solve: {", "controllers:\n"
                           '  pd: {output: "Kp*(0.45 - s2x) - Kd*v1z*(1 + 4*s2x) - Kd*v2x*s1z + 2*Kd*v1z**2*s1z"}\n'
                           "solve: {")
                  .replace("    knee2: {hinge: bay2.start, quantity: angle}\n",
                           "    knee2: {hinge: bay2.start, quantity: angle}\n"
                           "    s2x: {point: s2, quantity: position, component: x}\n"
                           "    s1z: {point: s1, quantity: position, component: z}\n"
                           "    v1z: {point: s1, quantity: velocity, component: z}\n"
                           "    v2x: {point: s2, quantity: velocity, component: x}\n")
                  .replace("sensitivities: [k, c, m, EI, F]", "sensitivities: [Kd, Kp, k, m]"))
assert "tau + cl" in CRANK_LENGTH and "ac: {cable" in CRANK_LENGTH and "Kc, tau" in CRANK_LENGTH
assert "v2x: {point: s2" in CHAIN_VELOCITY and '"pd", lock_at' in CHAIN_VELOCITY and "Kd, Kp" in CHAIN_VELOCITY

#: {name: (scene, its events, the gain)}
SCENES = {"the gimbal's PD of a point at an offset": (GIMBAL_OFFSET, ["latch"], "Kp"),
          "the slider-crank's controller of two cables' lengths": (CRANK_LENGTH, ["stop"], "Kc"),
          "the chain's PD of points' positions and velocities": (CHAIN_VELOCITY, ["latch", "latch"], "Kd")}


@pytest.mark.parametrize("name", list(SCENES))
def test_the_couplings_are_generated_through_the_reduction(name):
    """W_rest = 0 (``linked_has_rest`` False: ea72688 differenced these couplings), every coupling entry generated, and
    the exact part ∂(Pᵀ W_gen P w)/∂q δq at a turned state with random rates against Richardson-extrapolated central
    differences of Pᵀ W_gen P w along (δq, δv, δv̇) (steps 4e-5, 2e-5, 1e-5), W = M + 1e-4 K and W = K (measured
    3.9e-12 – 4.9e-11)."""
    from latdyn.analyses import weight_derivative as wd

    assembler, state, rng = turned_state(SCENES[name][0], 11, 0.05)
    assert not wd.linked_has_rest(assembler)
    velocities = "velocities" in name
    assert np.all(wd.linked_exact_couplings(assembler))
    assert all(wd._linked_rate_controllers(assembler) if velocities else wd._linked_position_controllers(assembler))
    assert wd.linked_rates_tangent(assembler, state, np.ones(assembler.model.n_dofs)) is None   # no joints' rates
    n = assembler.model.n_dofs
    hinges = wd.linked_exact_hinges(assembler)
    errors = []
    for mass, scale in ((True, 1e-4), (False, 1.0)):
        w, dq, dv, dvdot = rng.normal(size=n), rng.normal(size=(n, 1)), rng.normal(size=(n, 1)), rng.normal(size=(n, 1))
        exact = wd.linked_configuration_tangent(assembler, state, w, dq, scale, mass)
        by_rates = wd.linked_coupling_rates_product(assembler, state, w, dq, scale, (dv, dvdot))
        assert (by_rates is not None) == velocities
        if velocities:   # the entries' move with the sensed rates, the dependent ones following the links
            exact = exact + by_rates
        reference = richardson_of_the_generated_product(assembler, state, hinges, w, dq, dv, dvdot, scale, mass)
        errors.append(float(np.max(np.abs(exact[:, 0] - reference)) / np.max(np.abs(reference))))
    assert max(errors) <= 1e-10, errors


@pytest.mark.parametrize("name", list(SCENES))
def test_the_events_take_no_difference_and_the_runs_agree_with_richardson(name):
    """At the events (through the API) no difference of W_rest is taken (ea72688 took 6 on the gimbal, 16 on the
    slider-crank, 16 on the chain), ∂(W w)/∂q δq agrees with tests/test_weight_derivative_linked's Richardson reference
    (measured 6.1e-12, 1.5e-9, 1.2e-12: the reference's own error), the whole run's sensitivities by the controller's
    gain agree with Richardson central differences of whole runs (measured 3.2e-8, 7.4e-9, 3.7e-8, as on ea72688) and
    the adjoint's with the forward method's (1.7e-12, 5.7e-12, 1.4e-11)."""
    text, events, gain = SCENES[name]
    events_take_no_difference_and_runs_agree(text, events, gain, 5e-9, 1e-6)


def events_take_no_difference_and_runs_agree(text: str, events: list, parameter: str, reference: float,
                                             richardson: float) -> None:
    """``text``'s run through the API (:func:`_at_events_once`): its events of the kinds ``events``, no difference of
    W_rest taken at them, ∂(W w)/∂q δq within ``reference`` of the Richardson reference, the whole run's sensitivities
    by ``parameter`` within ``richardson`` of Richardson central differences of whole runs, and the adjoint's within
    1e-10 of the forward method's."""
    result, errors, differences = _at_events_once(text)
    assert [e["kind"] for e in result.summary["events"]] == events
    assert differences == 0
    assert errors and max(errors) < reference, errors
    assert _agree(result, text, parameter, tolerance=richardson) < richardson
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(_adjoint(text))))
    assert _largest_gap(adjoint.summary["probe_sensitivities"], result.summary["probe_sensitivities"]) <= 1e-10


def test_the_slider_crank_through_the_cli_loop_on_and_off(tmp_path):
    """The slider-crank with the controller of cables' lengths through ``latdyn run``: the loop off writing the same
    bytes, and the API's event sensitivities the CLI's, made without a difference of W_rest."""
    cli_writes_the_apis_event_sensitivities(tmp_path, CRANK_LENGTH, ["stop"])


def cli_writes_the_apis_event_sensitivities(tmp_path, text: str, events: list) -> None:
    """``latdyn run`` of ``text``: its events of the kinds ``events``, the loop of steps off writing the same bytes,
    and the API's run (:func:`_at_events_once`, the events test's when this process made it) with the same event
    sensitivities, made without a difference of W_rest."""
    run, out = latdyn_run(tmp_path, text, quiet=True)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert [e["kind"] for e in summary["events"]] == events
    the_loop_off_writes_the_same(tmp_path, out)
    result, _, differences = _at_events_once(text)
    assert json.loads(json.dumps(result.summary["event_sensitivities"])) == summary["event_sensitivities"]
    assert differences == 0
