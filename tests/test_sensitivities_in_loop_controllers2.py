"""More controllers in the sensitivities' loop of steps (issue 34 item 2; csrc/sensitivity_loop.c
``controller_parameter_forces``, latdyn/analyses/sensitivities_in_loop.py ``_controller_refusal``): continuous
controllers without states that read points' positions and velocities (global, and in a body's axes), that read earlier
controllers (chains, through their compiled outputs' derivatives) and that drive load components, as well as hinge
torques, take the loop, and so do sampled controllers between their samples (each instant handed back to Python); the
results are the per-step Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the API
and the CLI. Controllers with states keep the Python path."""
from __future__ import annotations

import numpy as np
import pytest

from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_controllers import WHEEL
from tests.test_sensitivities_in_loop_state_laws import _run, _same
from tests.test_sensitivities_native_parts import ARM

#: a 3D arm (a flexible first beam to a knee body, a hinged second beam) slewed about the knee's skew hinge by a PD
#: controller on the hinge's angle and the tip's velocity (in the knee's axes and globally), which drives the hinge's
#: torque and a force and moment at the tip in the knee's axes; its gains, set point and a section value as parameters
SLEW = (ARM.replace("angular: [0, 0, 2.0]", "angular: [0, 0, 3.0]").replace("t_end: 0.04", "t_end: 0.3")
        .replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}",
                 "parameters: {E: 1.0, rho: 0.5, F: 2.0, Kp: 20.0, Kd: 1.5, ref: 0.4}")
        .replace("stiffness: 30.0, damping: 0.2}", 'stiffness: 2.0, damping: 0.2, torque: "pd"}')
        .replace('  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}\n',
                 '  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}\n'
                 '  - {at: b.end, force: [0, "0.3*pd", 0], moment: ["0.05*pd", 0, 0], frame: knee}\n')
        .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - angle) - Kd*tip_vy - 0.5*Kd*tip_w"}\nsolve: {')
        .replace("    hinge: {hinge: b.start, quantity: angle}\n",
                 "    angle: {hinge: b.start, quantity: angle}\n"
                 "    tip_vy: {point: b.end, quantity: velocity, frame: knee, component: y}\n"
                 "    tip_w: {point: b.end, quantity: velocity, component: z}\n"
                 "    tip_y: {point: b.end, quantity: position, frame: knee, component: y}\n")
        .replace("sensitivities: [E, rho, F]", "sensitivities: [E, Kp, Kd, ref]"))
#: the arm with a chain: an estimator of the angle from the hinge and the tip's place and velocity in the knee's axes
#: feeding a PD controller clipped at ±3 (saturated on the way), which feeds a controller that pushes the tip
CHAIN = (SLEW.replace('  pd: {output: "Kp*(ref - angle) - Kd*tip_vy - 0.5*Kd*tip_w"}',
                      '  est: {output: "angle + 0.1*tip_y + 0.02*tip_vy"}\n'
                      '  pd: {output: "Kp*(ref - est) - Kd*tip_vy", limits: [-3, 3]}\n'
                      '  push: {output: "0.5*pd + 0.2*tip_z"}')
         .replace('force: [0, "0.3*pd", 0]', 'force: [0, "0.3*push", 0]'))
#: the arm's PD controller sampled at 50 Hz (every fourth step; on the angle and the tip's place in the knee's axes: a
#: sample may not read a rate for sensitivities), driving the hinge and the load at the tip
SAMPLED = SLEW.replace('"Kp*(ref - angle) - Kd*tip_vy - 0.5*Kd*tip_w"}', '"Kp*(ref - angle) - Kd*tip_y", rate: 50}')
#: the continuous PD controller on the hinge beside a digital one at 40 Hz clipped at ±4 (reached on the way) that
#: drives the load at the tip
SAMPLED_BESIDE = (SLEW.replace('  pd: {output: "Kp*(ref - angle) - Kd*tip_vy - 0.5*Kd*tip_w"}',
                               '  pd: {output: "Kp*(ref - angle) - Kd*tip_vy"}\n'
                               '  dig: {output: "0.5*Kp*(0.2 - tip_y)", rate: 40, limits: [-4, 4]}')
                  .replace('force: [0, "0.3*pd", 0]', 'force: [0, "0.3*dig", 0]'))
#: the arm's controller on positions with an integral state (PI): it keeps the Python path
SLEW_PI = (SLEW.replace("ref: 0.4}", "ref: 0.4, Ki: 5.0}")
           .replace('"Kp*(ref - angle) - Kd*tip_vy - 0.5*Kd*tip_w"}',
                    '"Kp*(ref - angle) + Ki*I - Kd*tip_y", states: {I: "ref - angle"}}')
           .replace("[E, Kp, Kd, ref]", "[E, Kp, Kd, ref, Ki]"))
assert all(part in SLEW for part in ('torque: "pd"', '"0.3*pd"', "frame: knee, component: y", "[E, Kp, Kd, ref]"))
assert "est:" in CHAIN and '"0.3*push"' in CHAIN and "limits: [-3, 3]" in CHAIN
assert "rate: 50}" in SAMPLED and "rate: 40, limits: [-4, 4]" in SAMPLED_BESIDE and '"0.3*dig"' in SAMPLED_BESIDE
assert "states: {I:" in SLEW_PI


@pytest.mark.parametrize("text, steps", [(SLEW, 60), (CHAIN, 60), (WHEEL, 50), (SAMPLED, 60), (SAMPLED_BESIDE, 60)],
                         ids=["PD on velocities driving a load", "estimator, clipped PD, push", "the wheel's chain",
                              "sampled PD", "sampled beside a continuous PD"])
def test_controllers_reading_points_chained_driving_loads_or_sampled_take_the_loop(text, steps, monkeypatch):
    """Every step in the loop of steps, the Python path's sensitivities to the bit:
    - the 3D arm's PD controller reading the tip's velocity in the knee's axes and globally and driving the hinge and
      a load in the knee's axes;
    - the arm's chain estimator → clipped PD → push;
    - tests/test_sensitivities_controllers.py's 3D wheel on a skew hinge: a set point of t feeding a clipped controller
      (on the hinge's angle and the wheel's place) feeding a push on the wheel in its own axes, five parameters among
      them the hinge's stiffness;
    - the arm's PD sampled at 50 Hz, and a clipped digital controller at 40 Hz driving the tip's load beside the
      continuous PD on the hinge: the loop hands each sample instant back to Python (the sample and its restart
      differentiated there: TransientSensitivities.after_sample) and carries the held outputs' δy between them."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] == steps
    _same(native, python)


def test_the_cli_writes_the_python_paths_files_for_the_chain(tmp_path):
    """``latdyn run`` on the arm's chain of controllers takes the loop; the same command with the switch off (a process
    of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, CHAIN)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] == summary["steps"] == 60
    the_loop_off_writes_the_same(tmp_path, out)


def test_a_controller_with_a_state_reading_a_point_in_a_bodys_axes_takes_the_loop(monkeypatch):
    """The arm's controller with an integral state, reading the tip's place in the knee's axes: every step in the loop
    (tests/test_sensitivities_in_loop_states_more.py: a point in a body's axes), the Python path's to the bit."""
    result, python = _run(SLEW_PI, monkeypatch, True), _run(SLEW_PI, monkeypatch, False)
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"] > 0
    assert np.abs(result.sensitivities[("tip_z", "Ki")]).max() > 0.0
    _same(result, python)

