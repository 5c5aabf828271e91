"""The initial velocity carried through a joint whichever way its beam is written (latdyn.assembly.initial).

Found by review: a hub turning at ``angle: 10*t`` and a beam ``from: tip, to: hub`` gave the tip
v(0) = 0, the same beam ``from: hub, to: tip`` gave ω × r: the motion was carried only parent → child.
The reference: a part rigidly carried by the hub starts at v = ω n × r (n the hub's unit axis, r the
tip from the axis's point), genuinely 3D here (a skew axis, the tip off every plane of it).
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns

SCENE = """\
sections:
  rod: {EA: 1.0e7, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 1.0}
bodies:
  hub: {at: [0, 0, 0], motion: {rotation: {axis: [1, -2, 2], angle: "10*t"}}}
  tip: {at: [0.8, 0.4, 0.3], mass: 0.1}
beams:
  blade: {from: FROM, to: TO, section: rod, elements: 2}
solve: {t_end: 0.002, dt: 0.001}
output:
  probes:
    vx: {point: tip, quantity: velocity, component: x}
    vy: {point: tip, quantity: velocity, component: y}
    vz: {point: tip, quantity: velocity, component: z}
"""
EXACT = 10.0 * np.cross(np.array([1.0, -2.0, 2.0]) / 3.0, [0.8, 0.4, 0.3])


@pytest.mark.parametrize("ends", [("hub", "tip"), ("tip", "hub")], ids=["hub-to-tip", "tip-to-hub"])
def test_the_tip_of_a_turning_hub_starts_at_omega_cross_r_whichever_way_the_beam_is_written(ends):
    text = SCENE.replace("FROM", ends[0]).replace("TO", ends[1])
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    v0 = np.array([result.probes[k][0] for k in ("vx", "vy", "vz")])
    assert np.max(np.abs(v0 - EXACT)) < 1e-12


def test_the_tip_written_first_starts_at_omega_cross_r_through_the_cli(tmp_path):
    process, out = latdyn_run(tmp_path, SCENE.replace("FROM", "tip").replace("TO", "hub"))
    assert process.returncode == 0, process.stderr
    rows = probe_columns(out)
    v0 = np.array([rows[k][0] for k in ("vx", "vy", "vz")])
    assert np.max(np.abs(v0 - EXACT)) < 1e-12
