"""The joint-force probes of a static path (SCENE.md: ``{hinge: BEAM.start|end, quantity: torque}``,
``{guide: NAME, quantity: force}``) at each row's load factor λ: the loads, gravity and applied torques the
path ramps are those of λ, not of λ = 1. A free hinge applies its law, −f = λ τ − k θ; a prescribed one
the reaction that holds it, here the moment of the ramped tip load about its axis."""
from __future__ import annotations

import numpy as np
import yaml

import latdyn
from tests.cli_runs import latdyn_run, probe_columns

ARM = """
sections:
  s: {{EA: 1.0e7, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [0.6, 0.0, 0.8], mass: 0.5}}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 2
    start: {{hinge: {{axis: [0, 0.6, 0.8], {law}}}}}
loads:
  - {{at: tip, force: [0, 0, -3.0]}}
solve: {{analysis: static, steps: 4}}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
    tq: {{hinge: arm.start, quantity: torque}}
    x: {{point: tip, quantity: position, component: x}}
    y: {{point: tip, quantity: position, component: y}}
    z: {{point: tip, quantity: position, component: z}}
"""


def test_a_free_hinges_torque_on_a_static_path_is_its_law_at_each_rows_load_factor(tmp_path):
    """Stiffness 40 and an applied torque 2 on a skew axis, a tip load: at each row the probe is λ·2 − 40 θ
    to round-off (it was 2 − 40 θ at every λ: the joint forces were evaluated at λ = 1). CLI."""
    completed, out = latdyn_run(tmp_path, ARM.format(law="stiffness: 40.0, torque: 2.0"))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    lam = p["load_factor"]
    assert np.allclose(lam, [0.0, 0.25, 0.5, 0.75, 1.0])
    assert np.max(np.abs(p["tq"] - (2.0 * lam - 40.0 * p["th"]))) < 1e-10


def test_a_prescribed_hinges_reaction_on_a_static_path_is_the_moment_of_the_ramped_load():
    """The same arm held at θ = 0 by a prescribed angle: the reaction balances the moment of the ramped tip
    load λ F about the hinge axis a at the deformed tip r, −λ (r × F)·a, at every row to round-off (API)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(ARM.format(law="angle: 0"))))
    lam, p = result.t, result.probes
    r = np.column_stack([p["x"], p["y"], p["z"]])
    moment = np.cross(r, [0.0, 0.0, -3.0]) @ np.array([0.0, 0.6, 0.8])
    assert abs(moment[-1]) > 1.0
    assert np.max(np.abs(p["tq"] + lam * moment)) < 1e-9 * abs(moment[-1])
