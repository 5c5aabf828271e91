"""A joint resting on a rigid stop: its torque probe and joint_peaks there are not the stop's reaction
(the residual with the joint's own acceleration zeroed, its neighbours keeping the free step's
accelerations), so the run says so in summary.json ``warnings`` instead of reporting them as the load;
a compliant stop (``contact``) computes the load and is not flagged."""
from __future__ import annotations

import json

from cli_runs import latdyn_run

PENDULUM = """
title: a stiff pendulum falling onto its lower stop and resting there
gravity: [0, -9.81, 0]
sections:
  rod: {EA: 1.0e8, EIy: 1.0e5, EIz: 1.0e5, GJ: 1.0e5, rhoA: 1.0}
bodies:
  pivot: {at: [0, 0, 0], fixed: true}
beams:
  rod:
    from: pivot
    to: [1, 0, 0]
    section: rod
    elements: 2
    start: {hinge: {axis: [0, 0, 1], limits: [-0.2, 0.5]CONTACT}}
solve: {t_end: 1.5, dt: 0.002}
output:
  probes:
    torque: {hinge: rod.start, quantity: torque}
"""


def test_a_joint_resting_on_its_rigid_stop_is_flagged(tmp_path):
    completed, out = latdyn_run(tmp_path, PENDULUM.replace("CONTACT", ""))
    assert completed.returncode == 0, completed.stderr
    warnings = json.loads((out / "summary.json").read_text()).get("warnings", [])
    assert any("rod.start rests on its rigid stop" in w and "contact" in w for w in warnings), warnings


def test_a_compliant_stop_is_not_flagged(tmp_path):
    completed, out = latdyn_run(tmp_path, PENDULUM.replace("CONTACT", ", contact: {stiffness: 1.0e5, exponent: 1.5, damping: 0.5}"))
    assert completed.returncode == 0, completed.stderr
    warnings = json.loads((out / "summary.json").read_text()).get("warnings", [])
    assert not any("rests on its rigid stop" in w for w in warnings), warnings
