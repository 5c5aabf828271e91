"""The impulse weight's derivative on models with rigid links or guides: the last blocks 40bf44a still differenced
(``linked_rest_product``, two evaluations a parameter at each event) generated through the reduction — the couplings of
controllers reading a point's velocity at an offset or relative to a body, a free joint's force, a rate beside an
input or another controller, and the loads controllers drive with their coupling entries
(latdyn/analyses/weight_derivative.py, "Rigid links and guides": ``_linked_chain_controllers``,
``linked_chain_rates_product``; docs/parameters.md, "The impulse weight's derivative").

On 3D YAML scenes: the gimbal of rigid links on skew hinges latching, its boom starting at an offset from the inner ring
(a dependent node), its outer hinge driven by a PD of that point's position, its velocity (v + ω × T r) and its velocity
in the tip body's axes, nonlinear in them; a mass on a skew guide at the tip of a flexible arm bouncing on its stop, a
PD of its slide and rate driving a follower force and moment on it and a global force on it (a dependent node); the
deploying chain of rigid bays latching, its first hinge in contact with a compliant stop, a PD of that hinge's torque
(its spring, damper and contact), an input and another controller of the angles and a rate driving the second hinge
(a controller with states reading a force is refused by the sensitivities). The exact part against
Richardson-extrapolated differences of Pᵀ W_gen P w at a turned state with random rates; at every event through the API
no difference taken and ∂(W w)/∂q δq against the Richardson reference of tests/test_weight_derivative_linked.py; the
whole runs' sensitivities against Richardson central differences of whole runs and the adjoint's against the forward
method's; the guided mass through the CLI, loop on and off."""
from __future__ import annotations

import numpy as np
import pytest

from tests.test_sensitivities_in_loop_links import CHAIN
from tests.test_weight_derivative_linked import turned_state
from tests.test_weight_derivative_linked_controllers import (GIMBAL_OFFSET, cli_writes_the_apis_event_sensitivities,
                                                             events_take_no_difference_and_runs_agree)
from tests.test_weight_derivative_linked_rates import richardson_of_the_generated_product
from tests.test_weight_derivative_linked_rest import BEAD_FOLLOWER

#: the gimbal latching, a PD of the boom's start (an offset from the inner ring, a dependent node): its global y, its
#: velocity's y (v + ω × T r, sensor kind 6) and its velocity's z in the tip body's axes (kind 13), nonlinear in them
GIMBAL_VELOCITY = (GIMBAL_OFFSET
                   .replace('pd: {output: "Kp*(0.1 - by) + 4*Kp*by**2 + 2*Kp*by*bz"}',
                            'pd: {output: "Kp*(0.1 - by) + 4*Kp*by**2 - 0.3*Kp*vy*(1 + 2*by) - 0.2*Kp*vy**2 '
                            '+ 0.4*Kp*vr*bz"}')
                   .replace("    bz: {point: boom.start, quantity: position, component: z}\n",
                            "    bz: {point: boom.start, quantity: position, component: z}\n"
                            "    vy: {point: boom.start, quantity: velocity, component: y}\n"
                            "    vr: {point: boom.start, quantity: velocity, frame: tip, component: z}\n"))
#: the guided mass bouncing on its stop, a PD of its slide s and rate s_rate driving its follower force's y, its
#: follower moment's z and a global force's x on it
BEAD_PD = (BEAD_FOLLOWER
           .replace("parameters: {k: 40.0,", "parameters: {Kc: 0.5, k: 40.0,")
           .replace('force: [0.3, -0.2, "m"], moment: [0.01, 0, 0.02], frame: slider}',
                    'force: [0.3, "push", "m"], moment: [0.01, 0, "0.02 + 0.1*push"], frame: slider}')
           .replace("  - {at: tip, force: [0, 0.2, 0.1], frame: tip}\n",
                    '  - {at: tip, force: [0, 0.2, 0.1], frame: tip}\n  - {at: slider, force: ["0.5*push", 0, 0]}\n')
           .replace("solve: {", "controllers:\n"
                    '  push: {output: "Kc*(0.01 - s)*(1 + 20*s) - 0.1*Kc*s_rate*(1 + 10*s)"}\nsolve: {')
           .replace("sensitivities: [k, m, EI, rest]", "sensitivities: [Kc, k, m]"))
#: the chain of rigid bays latching (t = 0.0916 s), its first hinge against a compliant stop at 0.95 rad, a PD of that
#: hinge's torque t1, an input g and a controller of both angles and the second hinge's rate driving the second hinge
CHAIN_FORCE = (CHAIN.replace("rest_angle: pi/3 + 0.3, lock_at: pi/3}",
                             "rest_angle: pi/3 + 0.3, limits: [-1.0, 0.95],\n"
                             "                           contact: {stiffness: 400.0, exponent: 2, damping: 0.5}}")
               .replace("parameters: {k: 1.5,", "parameters: {Kp: 0.3, Ki: 2.0, k: 1.5,")
               .replace("rest_angle: 2*pi/3 + 0.3, lock_at", 'rest_angle: 2*pi/3 + 0.3, torque: "drive", lock_at')
               .replace('  - {at: tip, force: [0, 0, "-F"]}\n', '  - {at: tip, force: [0, "0.3*F", "-F"]}\n')
               .replace("solve: {", "controllers:\n"
                        '  inner: {output: "Ki*r2*(knee2 - 2.0) + 0.1*knee1**2"}\n'
                        '  drive: {output: "-Kp*t1*(1 + 0.5*knee2) - g*inner - 0.2*Kp*t1**2 + 0.1*t1*r2"}\n'
                        "solve: {")
               .replace("    knee2: {hinge: bay2.start, quantity: angle}\n",
                        "    knee2: {hinge: bay2.start, quantity: angle}\n"
                        "    t1: {hinge: bay1.start, quantity: torque}\n    r2: {hinge: bay2.start, quantity: rate}\n")
               .replace("sensitivities: [k, c, m, EI, F]", "sensitivities: [Kp, Ki, k, m]")
               .replace("t_end: 0.5", "t_end: 0.1") + "inputs: {g: 1.2}\n")
assert "vr: {point: boom.start" in GIMBAL_VELOCITY and "0.4*Kp*vr*bz" in GIMBAL_VELOCITY
assert BEAD_PD.count("push") == 4 and "Kc, k, m" in BEAD_PD
assert "contact: {stiffness: 400.0" in CHAIN_FORCE and '"drive", lock_at' in CHAIN_FORCE and "t1: {hinge" in CHAIN_FORCE
assert "t_end: 0.1," in CHAIN_FORCE and "Kp, Ki, k, m" in CHAIN_FORCE

#: {name: (scene, its events, the parameter whose whole runs are compared with Richardson)}: the gimbal's by its gain
#: Kp (2.7e-4 off Richardson on 40bf44a and f3ab00e: the event's (∂K/∂p) w completed the dependent nodes' rates along
#: w, not the weight's H; tests/test_sensitivities_linked_controller_latch.py)
SCENES = {"the gimbal's PD of a point's velocities": (GIMBAL_VELOCITY, ["latch"], "Kp"),
          "the guided mass's driven loads": (BEAD_PD, ["stop"], "Kc"),
          "the chain's controller of a hinge's torque at a stop": (CHAIN_FORCE, ["latch"], "Kp")}


@pytest.mark.parametrize("name", list(SCENES))
def test_the_blocks_are_generated_through_the_reduction(name):
    """W_rest = 0 (``linked_has_rest`` False: 40bf44a differenced these couplings and loads), every coupling entry and
    load generated, and the exact part — ∂(Pᵀ W_gen P w)/∂q δq with the generated blocks' moves along the rates the
    reduction carries (``linked_chain_rates_product``) — at a turned state with random rates against
    Richardson-extrapolated central differences of Pᵀ W_gen P w along (δq, δv, δv̇) (steps 4e-5, 2e-5, 1e-5),
    W = M + 1e-4 K and W = K (measured 1.7e-12 – 7.7e-12)."""
    from latdyn.analyses import weight_derivative as wd

    assembler, state, rng = turned_state(SCENES[name][0], 11, 0.05)
    assert not wd.linked_has_rest(assembler)
    assert np.all(wd.linked_exact_couplings(assembler)) and np.all(wd.linked_generated_loads(assembler))
    assert all(wd._linked_chain_controllers(assembler))
    n = assembler.model.n_dofs
    hinges = wd.linked_exact_hinges(assembler)
    errors = []
    for mass, scale in ((True, 1e-4), (False, 1.0)):
        w, dq, dv, dvdot = rng.normal(size=n), rng.normal(size=(n, 1)), rng.normal(size=(n, 1)), rng.normal(size=(n, 1))
        exact = wd.linked_configuration_tangent(assembler, state, w, dq, scale, mass)
        for product in (wd.linked_coupling_rates_product, wd.linked_chain_rates_product,
                        wd.linked_cable_rates_product):
            moved = product(assembler, state, w, dq, scale, (dv, dvdot))
            if moved is not None:
                exact = exact + moved
        joints = wd.linked_rates_tangent(assembler, state, w)
        if joints is not None:
            exact = exact + scale * wd.times(joints, dv)
        reference = richardson_of_the_generated_product(assembler, state, hinges, w, dq, dv, dvdot, scale, mass)
        errors.append(float(np.max(np.abs(exact[:, 0] - reference)) / np.max(np.abs(reference))))
    assert max(errors) <= 1e-10, errors


@pytest.mark.parametrize("name", list(SCENES))
def test_the_events_take_no_difference_and_the_runs_agree_with_richardson(name):
    """At the events (through the API) no difference of W_rest is taken (40bf44a took 6 on the gimbal, 12 on the
    guided mass, 8 on the chain), ∂(W w)/∂q δq agrees with tests/test_weight_derivative_linked's Richardson reference
    (measured 9.1e-13, 5.4e-13, 1.2e-11: the reference's own error, the same on 40bf44a), the whole run's
    sensitivities agree with Richardson central differences of whole runs (measured 1.0e-7 by Kp — 2.7e-4 on f3ab00e —, 6.2e-7 by Kc,
    1.6e-8 by Kp, as on 40bf44a) and the adjoint's with the forward method's (8.8e-13, 6.8e-14, 1.6e-12)."""
    text, events, parameter = SCENES[name]
    events_take_no_difference_and_runs_agree(text, events, parameter, 5e-11, 2e-6)


def test_the_guided_mass_through_the_cli_loop_on_and_off(tmp_path):
    """The guided mass with its driven loads through ``latdyn run``: the loop off writing the same bytes, and the API's
    event sensitivities the CLI's, made without a difference of W_rest."""
    cli_writes_the_apis_event_sensitivities(tmp_path, BEAD_PD, ["stop"])
