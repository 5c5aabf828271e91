"""Controllers on models with rigid links or guides in the transient sensitivities' loop of steps (issue 34 item 2;
latdyn/analyses/sensitivities_in_loop.py ``_controller_refusal``, csrc/sensitivity_loop.c
``controller_parameter_forces``, ``sampled_parameter_forces``): controllers reading points on a rigid link's body or a
guided body (dependent nodes, which the step's evaluation completes before its sensors are read: positions, velocities,
points at an offset, in a body's axes), chains of controllers, controllers driving loads on a rigid link's body (their
columns reduced by Pᵀ with the others, ``latdyn_linked_reduce_columns``, the C the per-step Python path calls too) and
sampled controllers take the loop, beside events and prescribed motions that move the sensed points too; the
sensitivities are the per-step Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the
API and the CLI, and agree with Richardson-extrapolated central differences."""
from __future__ import annotations

import pytest

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_in_loop_linked2 import CRANK_STOP, GIMBAL_SLEW, _exact_against_difference
from tests.test_sensitivities_in_loop_sparse import LONG_CHAIN
from tests.test_sensitivities_in_loop_state_laws import _run, _same
from tests.test_sensitivities_rigid_links import CLOSED_SLIDER_CRANK, GIMBAL, SLIDER_CRANK

#: the 3D gimbal of two rigid rings with gains and a set point, and a probe of the inner ring's place in the outer's
#: axes
_GAINS = (GIMBAL.replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, Kd: 0.05, ref: 0.3, k1: 6.0,")
          .replace("    vi: {point: gim1.end, quantity: velocity, component: z}\n",
                   "    vi: {point: gim1.end, quantity: velocity, component: z}\n"
                   "    iz: {point: inner, quantity: position, frame: outer, component: z}\n"))
#: a PD controller on the inner hinge reading the outer ring's place and velocity (a rigid link's body: a dependent
#: node) and the inner ring's place in the outer's axes
POINT_PD = (_GAINS.replace('damping: "c2"}}}', 'damping: "c2", torque: "pd"}}}')
            .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - outer_y) - Kd*vo + 0.5*Kp*iz"}\nsolve: {')
            .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, Kd, ref, k1, m, EI]"))
#: POINT_PD latching (the inner ring at −0.1 rad, pushed there by the set point)
LATCHING_PD = (POINT_PD.replace('damping: "c2", torque: "pd"}}}', 'damping: "c2", torque: "pd", lock_at: -0.1}}}')
               .replace("t_end: 0.3", "t_end: 0.4").replace("ref: 0.3,", "ref: -0.3,"))
#: the boom hung at an offset from the inner ring, the PD reading that point's place and velocity (a point offset from a
#: dependent node) and the inner ring's velocity in the outer's axes
OFFSET_PD = (POINT_PD.replace("boom: {from: inner, to: tip,",
                              "boom: {from: {body: inner, offset: [0.05, 0.0, 0.02]}, to: tip,")
             .replace('"Kp*(ref - outer_y) - Kd*vo + 0.5*Kp*iz"', '"Kp*(ref - bx) - Kd*bvz - Kd*ivy"')
             .replace("    a1: {hinge", "    bx: {point: boom.start, quantity: position, component: x}\n"
                      "    bvz: {point: boom.start, quantity: velocity, component: z}\n"
                      "    ivy: {point: inner, quantity: velocity, frame: outer, component: y}\n    a1: {hinge"))
#: a controller on the inner hinge's angle and rate driving a force and moment on the inner ring and a force on the
#: outer one in its own axes (loads on rigid links' bodies)
LOAD_PUSH = (_GAINS.replace("solve: {", 'controllers:\n  push: {output: "Kp*(ref - a2) - Kd*r2"}\nsolve: {')
             .replace('  - {at: tip, force: [0, "P", "-0.5*P"]}\n',
                      '  - {at: tip, force: [0, "P", "-0.5*P"]}\n'
                      '  - {at: inner, force: [0, 0, "0.5*push"], moment: ["0.02*push", 0, 0]}\n'
                      '  - {at: outer, force: [0, "0.2*push", 0], frame: outer}\n')
             .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, Kd, ref, k1, m]"))
#: a chain: an estimator on the inner angle and the outer ring's place and velocity feeding a PD clipped at ±0.3
#: (reached from t = 0.23 on) on the inner hinge, which feeds a push on the inner ring; the estimator's gain g and the
#: push's Kp term make the parameters' partials read the points (a chained controller's law reads the earlier ones'
#: outputs from the step's own: only a partial reads its sensors' values in the loop)
CHAIN = (_GAINS.replace("parameters: {Kp: 0.8,", "parameters: {g: 0.1, Kp: 0.8,")
         .replace('damping: "c2"}}}', 'damping: "c2", torque: "pd"}}}')
         .replace("solve: {", 'controllers:\n  est: {output: "a2 + g*outer_y + 0.02*vo"}\n'
                  '  pd: {output: "Kp*(ref - est) - Kd*r2", limits: [-0.3, 0.3]}\n'
                  '  push: {output: "0.5*pd + 0.25*Kp*iz"}\nsolve: {')
         .replace('  - {at: tip, force: [0, "P", "-0.5*P"]}\n',
                  '  - {at: tip, force: [0, "P", "-0.5*P"]}\n  - {at: inner, force: [0, 0, "push"]}\n')
         .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [g, Kp, Kd, ref, k1, m, EI]"))
#: a digital controller at 50 Hz (every second step) on the inner angle and the outer ring's place, driving the inner
#: hinge and a force on the inner ring
SAMPLED = (_GAINS.replace('damping: "c2"}}}', 'damping: "c2", torque: "pd"}}}')
           .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - a2) - 0.5*Kp*outer_y", rate: 50}\nsolve: {')
           .replace('  - {at: tip, force: [0, "P", "-0.5*P"]}\n',
                    '  - {at: tip, force: [0, "P", "-0.5*P"]}\n  - {at: inner, force: [0, 0, "0.5*pd"]}\n')
           .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, ref, k1, m, EI]"))
#: LATCHING_PD with a set point of t (∂r/∂t through the controller's output beside the latch)
POINT_PD_T = LATCHING_PD.replace('"Kp*(ref - outer_y)', '"Kp*(ref + 0.1*sin(5*t) - outer_y)')
#: the slider-crank's guided bead: a controller reading its slide and rate and the crank pin's place (a rigid link's
#: end) drives the crank, the guide's force and a force on the bead, which bounces off both stops
BEAD = (SLIDER_CRANK.replace("parameters: {tau: 2.0, m: 1.0, k: 30.0}",
                             "parameters: {tau: 2.0, m: 1.0, k: 30.0, Kp: 3.0, Kd: 0.2, ref: 0.02}")
        .replace('torque: "tau"}}}', 'torque: "ctl"}}}')
        .replace('guide: {axis: [1, 0, 0], stiffness: "k",',
                 'guide: {axis: [1, 0, 0], stiffness: "k", force: "0.5*ctl",')
        .replace("solve: {", 'loads:\n  - {at: slider, force: ["0.3*ctl", 0, 0]}\nsolve: {')
        .replace("solve: {", 'controllers:\n  ctl: {output: "tau + Kp*(ref - slide) - Kd*vs - 0.5*Kp*py"}\nsolve: {')
        .replace("    px: {point: pin, quantity: position, component: x}\n",
                 "    px: {point: pin, quantity: position, component: x}\n"
                 "    py: {point: pin, quantity: position, component: y}\n"
                 "    vs: {guide: slider, quantity: rate}\n")
        .replace("sensitivities: [tau, m]", "sensitivities: [Kp, Kd, ref, tau, m, k]"))
#: tests/test_sensitivities_in_loop_linked2.py's slider-crank turned by a prescribed angle, its swing driven by a
#: controller on the bob's place (a dependent node the prescribed crank moves: the coupling times the motion's rate in
#: ∂r/∂t, csrc/linked_prescribed_rates.c), bouncing off its stop twice
BOB_PD = (CRANK_STOP.replace("parameters: {", "parameters: {Kp: 0.05, Kd: 0.005, ")
          .replace('stiffness: "ks",', 'stiffness: "ks", torque: "pd",')
          .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(by + 0.1) - Kd*bx"}\nsolve: {')
          .replace("    sw: {hinge: swing.start, quantity: angle}\n",
                   "    sw: {hinge: swing.start, quantity: angle}\n"
                   "    bx: {point: bob, quantity: position, component: x}\n")
          .replace("sensitivities: [m, ks, mb]", "sensitivities: [Kp, Kd, ks, mb]"))
#: the 3D gimbal on its slewing and translating base (a prescribed body), latching, a PD on the outer ring's place and
#: velocity driving the inner hinge and a push on the inner ring of the tip's place
SLEWING_PD = (GIMBAL_SLEW
              .replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, Kd: 0.05, ref: 0.3, k1: 6.0,")
              .replace('damping: "c2", lock_at', 'damping: "c2", torque: "pd", lock_at')
              .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - outer_y) - Kd*vo"}\n'
                       '  push: {output: "0.3*Kp*tip_x"}\nsolve: {')
              .replace('  - {at: tip, force: [0, "P", "-0.5*P"]}\n',
                       '  - {at: tip, force: [0, "P", "-0.5*P"]}\n  - {at: inner, force: [0, 0, "push"]}\n')
              .replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [Kp, Kd, ref, k1, m]"))
#: the slider-crank closed by a rigid rod (a closure), a controller on the guided slider's place and the crank pin's
#: driving the crank and pushing the slider (its sign keeps the controller's stiffness positive; the other sign was
#: refused before it started on 6cda559, model.check_held's "a coordinate that nothing holds": tests/test_held_check.py)
CLOSED_PD = (CLOSED_SLIDER_CRANK.replace("parameters: {tau: 2.0, m: 1.0, k: 30.0}",
                                         "parameters: {tau: 2.0, m: 1.0, k: 30.0, Kp: 3.0, Kd: 0.2}")
             .replace('torque: "tau"}}}', 'torque: "ctl"}}}')
             .replace("solve: {", 'loads:\n  - {at: slider, force: ["0.3*ctl", 0, 0]}\n'
                      'controllers:\n  ctl: {output: "tau + Kp*(sx - 0.35) - Kd*py"}\nsolve: {')
             .replace("    px: {point: pin, quantity: position, component: x}\n",
                      "    px: {point: pin, quantity: position, component: x}\n"
                      "    py: {point: pin, quantity: position, component: y}\n")
             .replace("sensitivities: [tau, m]", "sensitivities: [tau, m, Kp, Kd]"))
#: tests/test_sensitivities_in_loop_sparse.py's deploying chain of rigid bays with a boom of 24 elements (above
#: DENSE_LIMIT: S on the reduced pattern), a PD on the second bay's end (a dependent node) driving its hinge, latching,
#: and a push on the first bay's end of the tip's place (measured against Richardson at h = 1e-3 Kp: 4.6e-8)
SPARSE_PD = (LONG_CHAIN.replace("parameters: {k: 1.5,", "parameters: {Kp: 0.3, Kd: 0.02, k: 1.5,")
             .replace("rest_angle: 2*pi/3 + 0.3, lock_at", 'rest_angle: 2*pi/3 + 0.3, torque: "pd", lock_at')
             .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(0.2 - s2z) - Kd*s2v"}\n'
                      '  push: {output: "0.1*Kp*tip_z"}\nsolve: {')
             .replace('  - {at: tip, force: [0, 0, "-F"]}\n',
                      '  - {at: tip, force: [0, 0, "-F"]}\n  - {at: s1, force: ["push", 0, 0]}\n')
             .replace("    knee1:", "    s2z: {point: s2, quantity: position, component: z}\n"
                      "    s2v: {point: s2, quantity: velocity, component: x}\n    knee1:")
             .replace("sensitivities: [k, c, m, EI, F]", "sensitivities: [Kp, Kd, k, m, EI]"))
assert '"ctl"}}}' in CLOSED_PD and "py: {point" in CLOSED_PD and "[tau, m, Kp, Kd]" in CLOSED_PD
assert "s2v: {point" in SPARSE_PD and '["push", 0, 0]' in SPARSE_PD and 'torque: "pd", lock_at' in SPARSE_PD
assert 'torque: "pd",' in BOB_PD and "Kd*bx" in BOB_PD and "[Kp, Kd, ks, mb]" in BOB_PD
assert "motion: {" in SLEWING_PD and 'torque: "pd", lock_at' in SLEWING_PD and '"push"]' in SLEWING_PD
assert "iz: {point: inner" in _GAINS and "[Kp, Kd, ref, k1, m, EI]" in POINT_PD and 'torque: "pd"' in POINT_PD
assert "lock_at: -0.1" in LATCHING_PD and "ref: -0.3" in LATCHING_PD and "offset: [0.05" in OFFSET_PD
assert "Kd*ivy" in OFFSET_PD and "bvz: {point: boom.start" in OFFSET_PD and "frame: outer}" in LOAD_PUSH
assert '"push"]' in CHAIN and "g*outer_y" in CHAIN and "[g, Kp," in CHAIN
assert "rate: 50}" in SAMPLED and '"0.5*pd"]' in SAMPLED
assert "sin(5*t)" in POINT_PD_T and 'force: "0.5*ctl"' in BEAD and '"0.3*ctl"' in BEAD and "vs: {guide" in BEAD
assert 'torque: "ctl"' in BEAD and "[Kp, Kd, ref, tau, m, k]" in BEAD


@pytest.mark.parametrize("text, events", [(LATCHING_PD, 1), (OFFSET_PD, 0), (LOAD_PUSH, 0), (CHAIN, 0), (SAMPLED, 0),
                                          (POINT_PD_T, 1), (BEAD, 2), (BOB_PD, 2), (SLEWING_PD, 1), (CLOSED_PD, 0),
                                          (SPARSE_PD, 1)],
                         ids=["3D PD on rigid rings' points, latching", "3D PD on offset points and a body's axes",
                              "3D loads on rigid rings", "3D chain, clipped, pushing a ring", "3D sampled at 50 Hz",
                              "3D set point of t, latching", "guided bead between stops", "bob on a prescribed crank",
                              "3D gimbal on a slewing base, latching", "closed slider-crank",
                              "3D rigid bays, sparse S, latching"])
def test_controllers_on_linked_models_take_the_loop(text, events, monkeypatch):
    """Every smooth step in the loop of steps (the events' steps and the landings after them from Python) and the
    Python path's sensitivities to the bit, every column nonzero, the events' time derivatives too."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert native.summary["time_loop"] == "compiled" and len(native.summary["events"]) == events
    assert (in_loop == steps > 0) if events == 0 else (steps - 2 * events <= in_loop < steps)
    _same(native, python)


@pytest.mark.parametrize("text, name", [(LATCHING_PD, "Kp"), (BEAD, "Kp"), (OFFSET_PD, "Kd")],
                         ids=["latching PD by Kp", "guided bead by Kp", "offset points by Kd"])
def test_the_loops_sensitivities_agree_with_richardson_central_differences(text, name, monkeypatch):
    """The sensitivities taken in the loop (through the events), against central differences of whole runs
    (Richardson-extrapolated) to 1e-6 of each probe's largest (measured: 3.5e-8, 4.1e-8, 2.5e-8), the events' time
    derivatives too."""
    result = _run(text, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] >= result.summary["steps"] - 4
    _agree(result, text, name)


def test_the_cli_writes_the_python_paths_files_for_the_guided_bead(tmp_path):
    """``latdyn run`` on the guided bead takes the loop for the smooth steps; the same command with the switch off (in a
    process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's
    sensitivities (the 3D scenes' files: benchmarks/linked_controller_sensitivities_loop.py --check)."""
    completed, out = latdyn_run(tmp_path, BEAD)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["steps"] - 4 <= summary["sensitivity_steps_in_loop"]
    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("text", [BOB_PD, SLEWING_PD],
                         ids=["bob on a prescribed crank", "3D gimbal on a slewing base, latching"])
def test_a_point_sensors_coupling_to_a_prescribed_motion_in_the_loop_is_exact(text, monkeypatch):
    """The loop takes the run (all but the events' steps and the landings after them), and the ∂r/∂t it carries
    beside the events, with the controllers' couplings of points on dependent nodes that the prescribed motion moves, is
    exact: the per-step path's (the same C), against the five-point difference in t at every state the run asks it at
    (tests/test_sensitivities_in_loop_linked2.py's check): measured ≤ 1.9e-12 of the largest entry on the bob (84
    calls), 9.9e-12 on the slewing gimbal (48 calls)."""
    result = _run(text, monkeypatch, True)
    events = len(result.summary["events"])
    assert result.summary["steps"] - 2 * events <= result.summary["sensitivity_steps_in_loop"] and events > 0
    calls, worst = _exact_against_difference(text, monkeypatch)
    assert calls > 20 and worst <= 1e-9
