"""Exact sensitivities of rate probes in transient runs (docs/parameters.md, "Transient sensitivities"):
a hinge's or guide's rate δθ̇ and a point's velocity δ(v + ω × T r) = δv + δω × T r + ω × (δπ × T r),
from the step's carried δv — checked against Richardson central differences of whole runs
(tests/test_sensitivities_transient.py's reference), on the genuinely 3D spinning arm (a point off
its node: the ω × (δπ × T r) term; a hinge on a skew axis) and on a planar arm with a continuous PD
that reads the hinge's rate (its coupling in C), and with an integral state reading the rate."""
from __future__ import annotations

import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.test_sensitivities_transient import SWING_3D, _agree, _run

RATES_3D = SWING_3D.replace("""    hinge: {hinge: b.start, quantity: angle}
""", """    hinge: {hinge: b.start, quantity: angle}
    hinge_rate: {hinge: b.start, quantity: rate}
    tip_vx: {point: b.end, quantity: velocity, component: x}
    tip_vz: {point: b.end, quantity: velocity, component: z}
    knee_v: {point: knee, quantity: velocity, component: norm}
    offset_vy: {point: b.start, quantity: velocity, component: y}
    offset_v: {point: b.start, quantity: velocity, component: norm}
""").replace("sensitivities: [F, k, c, th0, EI, G, rho, m, cx, J]", "sensitivities: [F, k, rho, cx]")
# the velocity of a point offset from its node (b's start at the knee's offset: T r ≠ 0 there)
RATES_3D = RATES_3D.replace("  b:\n    from: knee", "  b:\n    from: {body: knee, offset: [0.05, 0.1, -0.05]}")

PD_PLANAR = """
title: planar hinged arm under a PD on its hinge angle and rate, pushed by a tip load
parameters: {kd: 0.8, P: 2.0}
controllers:
  pd: {output: "-6*(th - 0.1) - kd*om"}
sections:
  s: {EA: 1.0e4, EIy: 5.0, EIz: 5.0, GJ: 4.0, rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0.0, 0], mass: 0.4, inertia: [0.02, 0.02, 0.02]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: 2.0, torque: "pd"}}
loads:
  - {at: tip, force: [0, "-P*t", 0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.2, sensitivities: [kd, P]}
output:
  every: 0.05
  probes:
    th: {hinge: arm.start, quantity: angle}
    om: {hinge: arm.start, quantity: rate}
    tip_vy: {point: tip, quantity: velocity, component: y}
"""


@pytest.fixture(scope="module")
def rates_3d():
    return _run(RATES_3D)


@pytest.mark.parametrize("name", ["F", "k", "rho", "cx"])
def test_rate_probes_of_a_spinning_3d_arm_agree_with_richardson_differences(rates_3d, name):
    """Hinge rate, velocity components of a point offset from its node and a velocity norm, by a load, a
    hinge stiffness law, the section's mass and a body's centre of mass (measured ≤ 7.3e-8 of each probe's
    largest sensitivity; 1.7e-9 at the offset point, where dropping ω × (δπ × T r) fails it)."""
    assert _agree(rates_3d, RATES_3D, name, 1e-6) < 1e-6


def test_rate_probes_under_a_pd_that_reads_the_rate_agree_with_richardson_differences():
    """A continuous PD reading the hinge's rate: its coupling is in the step's C, its gain kd a parameter of
    its output (measured ≤ 1e-8)."""
    result = _run(PD_PLANAR)
    for name in ("kd", "P"):
        assert _agree(result, PD_PLANAR, name, 1e-6) < 1e-6


def test_a_controller_with_states_reading_a_rate_agrees_with_richardson_differences():
    """The PD with an integral state whose rate reads the hinge's rate: δs = D_q δq + D_v δv in the states'
    derivative (ControllerStates._sensed; refused before, tests/test_sensitivities_states_rates.py). Measured: kd
    1.8e-9, P 2.3e-11."""
    data = yaml.safe_load(PD_PLANAR)
    data["controllers"]["pd"] = {"output": "-6*(th - 0.1) - kd*om - 3*I", "states": {"I": "om + 0.5*kd*th"}}
    text = yaml.safe_dump(data)
    result = _run(text)
    for name in ("kd", "P"):
        assert _agree(result, text, name, 1e-6) < 1e-6


def test_velocities_in_a_body_frame_under_a_pd_that_reads_the_rate_agree():
    """A node's velocity in the tip body's axes (latdyn/analyses/probe_derivatives.py; the body frame turning
    with the arm) under the PD (measured: kd 8.3e-8, P 1.2e-7, the axial component's; y 3.3e-9, 8.5e-11)."""
    data = yaml.safe_load(PD_PLANAR)
    data["output"]["probes"] = {"rel_x": {"point": "arm.node[1]", "quantity": "velocity", "component": "x",
                                          "frame": "tip"},
                                "rel_y": {"point": "arm.node[1]", "quantity": "velocity", "component": "y",
                                          "frame": "tip"},
                                "om": {"hinge": "arm.start", "quantity": "rate"},
                                "th": {"hinge": "arm.start", "quantity": "angle"}}
    text = yaml.safe_dump(data)
    result = _run(text)
    for name in ("kd", "P"):
        assert _agree(result, text, name, 1e-6) < 1e-6


def test_the_cli_writes_the_rate_probes_sensitivities_as_the_api_gives_them(tmp_path):
    """`latdyn run` of the PD scene: sensitivities.csv's hinge-rate and velocity columns are the API's."""
    import csv

    import numpy as np

    from tests.cli_runs import latdyn_run

    completed, out = latdyn_run(tmp_path, PD_PLANAR)
    assert completed.returncode == 0, completed.stderr
    with open(out / "sensitivities.csv", newline="") as f:
        table = list(csv.reader(f))
    header, rows = table[0], np.array(table[1:], float)
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(PD_PLANAR)))
    for column in ("om/kd", "tip_vy/kd", "om/P", "tip_vy/P"):
        probe, name = column.split("/")
        assert np.array_equal(rows[:, header.index(column)], api.sensitivities[(probe, name)]), column
