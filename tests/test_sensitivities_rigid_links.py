"""Sensitivities of scenes with rigid links (``beams.NAME.rigid``) and with inputs
(latdyn/analyses/link_sensitivities.py; docs/parameters.md, "Rigid links" and "Inputs"), against
Richardson-extrapolated central differences of whole runs (the helpers of tests/test_sensitivities_events.py
and tests/test_sensitivities.py): a 3D gimbal of two rigid links on skew hinges carrying a flexible boom,
spinning, by a hinge spring, a body's mass, a load, the boom's section and the rigid links' own section
(their mass); through a latch and a stop with restitution on a link's hinge and a cable going taut on a
node that follows the links (and one going slack on a guided body); a planar four-bar of two rigid links and
a flexible coupler; slider-cranks (rigid links with a guide, and the loop closed by a rigid rod); the gimbal
at rest under gravity and a load (load control); the CLI against the API; the discrete adjoint against the
forward method; a planar arm driven by inputs through a load and a controller. And what stays refused,
naming the key."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.results.result import Result
from tests.cli_runs import latdyn_run
from tests.test_sensitivities import _richardson
from tests.test_sensitivities_events import _agree, _run

#: a gimbal: the outer ring (a rigid link) turns about a skew axis on the fixed base, the inner one (a rigid
#: link) about another skew axis on it, and carries a flexible boom with a tip body; started spinning
#: (initial_velocity) with the outer hinge's spring preloaded (rest_angle), a load on the tip
GIMBAL = """
title: a gimbal of two rigid links on skew hinges carrying a flexible boom
parameters: {k1: 6.0, k2: 4.0, c2: 0.05, m: 0.3, P: 0.4, EI: 20.0, rest: 0.6, rho: 0.8}
sections:
  ring: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: "rho", rhoIy: "0.001*rho", rhoIz: 0.001}
  boom: {EA: 1.0e5, EIy: "EI", EIz: "1.2*EI", GJ: "0.7*EI", rhoA: 0.4, rhoIy: 0.0004, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  outer: {at: [0.3, 0.1, 0.2], mass: "m", inertia: [0.002, 0.003, 0.0025]}
  inner: {at: [0.45, -0.05, 0.35], mass: 0.2, inertia: [0.001, 0.0012, 0.0015]}
  tip: {at: [1.0, 0.25, 0.55], mass: 0.1, inertia: [0.0002, 0.0002, 0.0002]}
beams:
  gim1: {from: base, to: outer, section: ring, rigid: true,
         start: {hinge: {axis: [0.2, 0.3, 1.0], stiffness: "k1", rest_angle: "rest"}}}
  gim2: {from: outer, to: inner, section: ring, rigid: true,
         start: {hinge: {axis: [1.0, -0.4, 0.3], stiffness: "k2", damping: "c2"}}}
  boom: {from: inner, to: tip, section: boom, elements: 3}
loads:
  - {at: tip, force: [0, "P", "-0.5*P"]}
initial_velocity: {angular: [0.5, -0.3, 2.0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.3, sensitivities: [k1, m, P, EI, rho]}
output:
  every: 0.05
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    tip_z: {point: tip, quantity: displacement, component: z}
    outer_y: {point: outer, quantity: position, component: y}
    a1: {hinge: gim1.start, quantity: angle}
    a2: {hinge: gim2.start, quantity: angle}
    r2: {hinge: gim2.start, quantity: rate}
    vo: {point: outer, quantity: velocity, component: y}
    vi: {point: gim1.end, quantity: velocity, component: z}
"""

#: the inner ring latching at −0.1 rad (t = 0.2791 s), and bouncing twice off a rigid stop there (e = 0.8)
LATCH = GIMBAL.replace('damping: "c2"}}}', 'damping: "c2", lock_at: -0.1}}}').replace("t_end: 0.3", "t_end: 0.4")
STOP = GIMBAL.replace('damping: "c2"}}}', 'damping: "c2", limits: [-0.1, 1.0], restitution: 0.8}}}')

#: the gimbal tethered by a cable from a fixed anchor to the inner ring (a node that follows the links), slack at
#: the start (0.455 m apart, rest length 0.5 m) and going taut at t = 0.145 s
TETHER = GIMBAL.replace("parameters: {k1: 6.0,", "parameters: {L: 0.5, k1: 6.0,").replace(
    "  base: {at: [0, 0, 0], fixed: true}\n",
    "  base: {at: [0, 0, 0], fixed: true}\n  anchor: {at: [0.6, -0.3, 0.0], fixed: true}\n").replace(
    "loads:", "cables:\n  tether: {from: anchor, to: inner, EA: 300.0, rest_length: \"L\", damping: 0.1}\nloads:").replace(
    "sensitivities: [k1, m, P, EI, rho]", "sensitivities: [L, k1]")

#: a planar four-bar: crank and rocker rigid links on the ground, a flexible coupler hinged to both, the crank
#: driven by a torque against a spring
FOUR_BAR = """
title: a planar four-bar, crank and rocker rigid links, a flexible coupler, a torque on the crank
parameters: {tau: 0.8, k: 2.0, m: 0.3, EI: 40.0, rho: 0.6}
sections:
  link: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: "rho", rhoIy: 1.0e-4, rhoIz: 1.0e-4}
  coupler: {EA: 1.0e5, EIy: "EI", EIz: "EI", GJ: 30.0, rhoA: 0.3, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  A: {at: [0, 0, 0], fixed: true}
  D: {at: [1.0, 0, 0], fixed: true}
  B: {at: [0.2, 0.4, 0], mass: "m", inertia: [0.001, 0.001, 0.001]}
  C: {at: [1.1, 0.6, 0], mass: 0.2, inertia: [0.001, 0.001, 0.001]}
beams:
  crank: {from: A, to: B, section: link, rigid: true,
          start: {hinge: {axis: [0, 0, 1], stiffness: "k", torque: "tau"}}}
  rocker: {from: D, to: C, section: link, rigid: true, start: {hinge: {axis: [0, 0, 1], damping: 0.02}}}
  coupler: {from: B, to: C, section: coupler, elements: 2,
            start: {hinge: {axis: [0, 0, 1]}}, end: {hinge: {axis: [0, 0, 1]}}}
solve: {analysis: transient, dt: 0.01, t_end: 0.5, sensitivities: [tau, rho]}
output:
  every: 0.05
  probes:
    crank: {hinge: crank.start, quantity: angle}
    rocker: {hinge: rocker.start, quantity: angle}
    Cx: {point: C, quantity: position, component: x}
    By: {point: B, quantity: position, component: y}
    mid: {point: "coupler.node[1]", quantity: displacement, component: y}
"""

#: a slider-crank: a rigid crank driven by a torque, a flexible rod hinged to it and to a slider on a guide along
#: x held by a spring, the slider bouncing twice between its stops (e = 0.5)
SLIDER_CRANK = """
title: a slider-crank, rigid crank, flexible rod, a slider on a guide between stops, driven by a torque
parameters: {tau: 2.0, m: 1.0, k: 30.0}
sections:
  crank: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 2.0, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
  rod: {EA: 1.0e6, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 0.5, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  pin: {at: [0.1, 0.05, 0], mass: 0.5, inertia: [0.001, 0.001, 0.001]}
  slider: {at: [0.4, 0, 0], mass: "m", inertia: [0.001, 0.001, 0.001],
           guide: {axis: [1, 0, 0], stiffness: "k", limits: [-0.05, 0.03], restitution: 0.5}}
beams:
  crank: {from: hub, to: pin, section: crank, rigid: true, start: {hinge: {axis: [0, 0, 1], torque: "tau"}}}
  rod: {from: pin, to: slider, section: rod, elements: 3,
        start: {hinge: {axis: [0, 0, 1]}}, end: {hinge: {axis: [0, 0, 1]}}}
solve: {analysis: transient, t_end: 0.22, dt: 0.005, sensitivities: [tau, m]}
output:
  every: 0.05
  probes:
    slide: {guide: slider, quantity: position}
    crank: {hinge: crank.start, quantity: angle}
    px: {point: pin, quantity: position, component: x}
"""

#: the same mechanism closed by a rigid rod (latdyn/model/links.py "Closure": the slider and the rod follow the
#: pin, no coordinate of their own), the slider free on its guide
CLOSED_SLIDER_CRANK = SLIDER_CRANK.replace("rod: {from: pin, to: slider, section: rod, elements: 3,",
                                           "rod: {from: pin, to: slider, section: rod, rigid: true,").replace(
    'guide: {axis: [1, 0, 0], stiffness: "k", limits: [-0.05, 0.03], restitution: 0.5}', "guide: {axis: [1, 0, 0]}").replace(
    "    slide: {guide: slider, quantity: position}\n", "    sx: {point: slider, quantity: position, component: x}\n")

#: the gimbal at rest under gravity (the rigid links' mass by rho) and the tip load, load control
STATIC = GIMBAL.replace("initial_velocity: {angular: [0.5, -0.3, 2.0]}\n", "gravity: [0, 0, -9.81]\n").replace(
    "solve: {analysis: transient, dt: 0.01, t_end: 0.3, sensitivities: [k1, m, P, EI, rho]}",
    "solve: {analysis: static, method: load-control, steps: 4, sensitivities: [k1, m, P, EI, rest, rho]}").replace(
    'damping: "c2"', 'damping: 0.0').replace("    r2: {hinge: gim2.start, quantity: rate}\n", "").replace(
    "    vo: {point: outer, quantity: velocity, component: y}\n    vi: {point: gim1.end, quantity: velocity, component: z}\n",
    "")

#: a planar arm whose hinge a controller drives towards the input ``target`` (and by the input u), and whose
#: tip a load of the input u pushes
INPUTS = """
title: a planar hinged arm driven by inputs through a load and a controller
parameters: {P: 2.0, g: 3.0, k: 5.0}
inputs: {u: 0.4, target: 0.3}
sections:
  s: {EA: 1.0e4, EIy: 8.0, EIz: 8.0, GJ: 4.0, rhoA: 0.5, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0.2, 0], mass: 0.3, inertia: [0.01, 0.01, 0.01]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: "k", damping: 0.2, torque: "servo"}}
controllers:
  servo: {output: "g*(target - angle) + 0.5*u*g"}
loads:
  - {at: tip, force: ["P*u", "-P*u*u + 0.1*P", 0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.3, sensitivities: [P, g, k]}
output:
  every: 0.05
  probes:
    angle: {hinge: arm.start, quantity: angle}
    tip_y: {point: tip, quantity: displacement, component: y}
    tip_x: {point: tip, quantity: position, component: x}
"""


@pytest.fixture(scope="module")
def gimbal():
    return _run(GIMBAL)


@pytest.mark.parametrize("name", ["k1", "m", "P", "EI", "rho"])
def test_a_3d_gimbal_of_rigid_links_agrees_with_richardson_central_differences(gimbal, name):
    """The outer hinge's spring, the outer ring's body mass, the tip load, the boom's section, the rigid
    links' own section (their mass and inertia, rho): measured k1 3.5e-9, m 2.7e-9, P 8.6e-9, EI 7.5e-9,
    rho 1.1e-9 of each probe's largest sensitivity (the hinge rate r2 and the velocities of points that
    follow the links, vo and vi, among the probes: δv_dep = P δv + ∂(J v)/∂q δq)."""
    assert gimbal.summary["events"] == []
    assert abs(gimbal.probes["a1"][-1] - gimbal.probes["a1"][0]) > 0.5   # it turns
    _agree(gimbal, GIMBAL, name, tolerance=1e-6)


@pytest.mark.parametrize("text, kind, name", [(LATCH, "latch", "k2"), (STOP, "stop", "m")], ids=["latch-k2", "stop-m"])
def test_the_gimbal_latching_or_bouncing_on_a_rigid_links_hinge_agrees_with_richardson_central_differences(
        text, kind, name):
    """The inner ring's latch (t = 0.2791 s) and stop with restitution (two bounces): the jump of δv through
    the impulse with the reduction's weight M + dt²K, the event time's derivative; measured latch k2 9.5e-9
    (3.3e-6 before the impulse weight's central difference stepped each move in its own units), m 4.6e-9;
    stop m 6.4e-9, k1 2.0e-9; the event times to 1e-7 relative (asserted)."""
    result = _run(text, name)
    assert {e["kind"] for e in result.summary["events"]} == {kind}
    assert result.summary["events"][0]["joint"] == "gim2.start"
    _agree(result, text, name, tolerance=1e-6)


@pytest.mark.parametrize("name", ["L"])
def test_a_cable_going_taut_on_a_node_that_follows_the_links_agrees_with_richardson_central_differences(name):
    """The cable's taut event: its gap's gradient reduced onto the free coordinates (δq_all = P δq, δv_all =
    P δv + ∂(J v)/∂q δq; without it the event time's derivative divided by zero and every sensitivity after
    the event was NaN). Measured L 3.7e-8 (and k1 4.0e-8, not run here; the hinge rate r2 the largest), the
    event time to 1e-7 relative."""
    result = _run(TETHER, name)
    assert [(e["joint"], e["kind"]) for e in result.summary["events"]] == [("tether", "taut")]
    _agree(result, TETHER, name, tolerance=1e-6)


def test_a_cable_going_slack_on_a_guided_body_agrees_with_richardson_central_differences():
    """The same reduction on a guide: the skew-guided slider of tests/test_sensitivities_guides.py held by a
    pretensioned cable from a fixed anchor that goes slack at t = 0.029 s. Measured k 4.5e-8 (NaN before
    the gap's gradient was reduced)."""
    from tests.test_sensitivities_guides import GUIDE_3D

    text = GUIDE_3D.replace("  base: {at: [0, 0, 0], fixed: true}\n",
                            "  base: {at: [0, 0, 0], fixed: true}\n  anchor: {at: [0.7, 0.35, 0.3], fixed: true}\n").replace(
        "beams:", "cables:\n  tether: {from: anchor, to: slider, EA: 300.0, rest_length: 0.395}\nbeams:").replace(
        "sensitivities: [k, m, EI, rest]", "sensitivities: [k]").replace("t_end: 0.4", "t_end: 0.1")
    result = _run(text, "k")
    assert [(e["joint"], e["kind"]) for e in result.summary["events"]] == [("tether", "slack")]
    _agree(result, text, "k", tolerance=1e-6)


@pytest.fixture(scope="module")
def four_bar():
    return _run(FOUR_BAR)


@pytest.mark.parametrize("name", ["tau"])
def test_a_planar_four_bar_of_rigid_links_agrees_with_richardson_central_differences(four_bar, name):
    """Measured tau 3.7e-10 (and rho 4.4e-9, EI 5.6e-8, not run here)."""
    assert four_bar.probes["crank"][-1] > 0.4 and four_bar.probes["rocker"][-1] > 0.25   # the linkage turns
    _agree(four_bar, FOUR_BAR, name, tolerance=1e-6)


@pytest.mark.parametrize("text, name", [(SLIDER_CRANK, "m"), (CLOSED_SLIDER_CRANK, "tau")],
                         ids=["guide-stops-m", "closed-tau"])
def test_slider_cranks_of_rigid_links_and_guides_agree_with_richardson_central_differences(text, name):
    """Rigid links with guides: the rigid crank and the slider's guide in one reduction, through the slider's
    two bounces on its stops; and the loop closed by a rigid rod (closure edges). Measured: with stops m
    2.3e-9 (and tau 8.9e-10, not run here; the event times to 1e-7 relative); closed tau 3.4e-9 (and m
    3.1e-9; over 0.3 s, 1.3e-8 and 8.5e-9)."""
    result = _run(text, name)
    assert result.probes["crank"][-1] > 0.5   # the crank turns (2.9 rad when the loop is closed)
    if text is SLIDER_CRANK:
        assert [e["kind"] for e in result.summary["events"]] == ["stop"] * 2
    _agree(result, text, name, tolerance=1e-6)


@pytest.fixture(scope="module")
def static_gimbal():
    return latdyn.run(latdyn.load_scene(yaml.safe_load(STATIC)))


@pytest.mark.parametrize("name", ["k1", "m", "P", "EI", "rest", "rho"])
def test_the_gimbal_at_rest_under_load_control_agrees_with_richardson_central_differences(static_gimbal, name):
    """The reduced static Newton matrix (its geometric term ∂(Bᵀ r)/∂z included): measured k1 1.0e-10,
    m 2.0e-9, P 1.1e-11, EI 7.4e-8, rest 3.5e-11, rho 4.5e-11 of each probe's largest sensitivity."""
    for probe, expected in _richardson(STATIC, name).items():
        scale = np.abs(expected).max()
        assert scale > 1e-8, (probe, name)
        assert np.abs(static_gimbal.sensitivities[(probe, name)] - expected).max() <= 1e-6 * scale, (probe, name)


def test_the_cli_writes_the_gimbals_sensitivities_and_the_api_gives_the_same(tmp_path, gimbal):
    """``python -m latdyn run`` on the gimbal as typed: sensitivities.csv and summary.json's
    probe_sensitivities are the API's."""
    run, out = latdyn_run(tmp_path, GIMBAL)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["probe_sensitivities"] == gimbal.summary["probe_sensitivities"]
    result = Result.load(out)
    assert set(result.sensitivities) == set(gimbal.sensitivities)
    for key, values in gimbal.sensitivities.items():
        np.testing.assert_array_equal(result.sensitivities[key], values)


@pytest.fixture(scope="module")
def driven():
    return _run(INPUTS)


@pytest.mark.parametrize("name", ["P", "g"])
def test_a_run_driven_by_inputs_agrees_with_richardson_central_differences_at_the_inputs_held(driven, name):
    """The inputs keep their values (latdyn run), which do not depend on the parameters: a load P·u and a
    controller g·(target − angle) + 0.5 u g differentiated with u and target held. Measured P 9.6e-10,
    g 1.3e-9 (and k 1.0e-9, not run here)."""
    _agree(driven, INPUTS, name, tolerance=1e-6)


def test_the_derivative_reads_the_inputs_current_values():
    """The same at other input values (u = −0.5, target = 0.1): the derivative laws of P·u and −P·u² read
    the inputs' values as the laws themselves do (a derivative taken at the scene's first values would miss
    here by far). Measured 6.5e-9."""
    text = INPUTS.replace("inputs: {u: 0.4, target: 0.3}", "inputs: {u: -0.5, target: 0.1}")
    _agree(_run(text, "P"), text, "P", tolerance=1e-6)


#: the gimbal with its outer body placed by a parameter X: a geometry parameter, which moves the links' edges (gim1's
#: and gim2's lengths: differentiated now, tests/test_geometry_sensitivities_link_length.py OUTER against Richardson)
PLACED = GIMBAL.replace("parameters: {k1: 6.0,", "parameters: {X: 0.3, k1: 6.0,").replace(
    "outer: {at: [0.3, 0.1, 0.2]", "outer: {at: [X, 0.1, 0.2]").replace(
    "sensitivities: [k1, m, P, EI, rho]", "sensitivities: [k1, m, P, EI, rho, X]")
#: PLACED with gim1's end offset moved as well (a link's length together with its own offset: refused)
PLACED_OFFSET = PLACED.replace("to: outer,", 'to: {body: outer, offset: ["X - 0.3", 0, 0]},')
assert "offset: [" in PLACED_OFFSET


def test_what_rigid_links_do_not_differentiate_yet_is_refused_naming_the_key():
    """(PLACED, refused here before, is differentiated now: tests/test_geometry_sensitivities_link_length.py.)"""
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(PLACED_OFFSET)))
    assert refused.value.key == "solve.sensitivities" and "rigid links" in str(refused.value)


def test_a_refusal_exits_2_through_the_cli_naming_the_key(tmp_path):
    """(Arc length with rigid links, refused here before, is differentiated now:
    tests/test_sensitivities_arc_3d.py; PLACED too: tests/test_geometry_sensitivities_link_length.py.)"""
    run, out = latdyn_run(tmp_path, PLACED_OFFSET)
    assert run.returncode == 2, run.stderr
    assert "solve.sensitivities" in run.stderr and "rigid links" in run.stderr
    assert "Traceback" not in run.stderr


def test_the_adjoint_through_rigid_links_gives_the_forward_methods_derivatives(gimbal):
    """``solve.sensitivity_method: adjoint`` on the gimbal: the transposed recurrence over the reduced step
    (its matrices the forward method's) and each probe's output gradient on the coordinates its node moves
    with (a node that follows the links: its root's and its joints'); each probe's end, max and min by every
    parameter equal the forward method's to 1e-8 relative (measured 1.6e-10; the four-bar 5.8e-13)."""
    data = yaml.safe_load(GIMBAL)
    data["solve"]["sensitivity_method"] = "adjoint"
    adjoint = latdyn.run(latdyn.load_scene(data)).summary["probe_sensitivities"]
    forward = gimbal.summary["probe_sensitivities"]
    assert set(adjoint) == set(forward)
    for probe, rows in forward.items():
        for which, by_name in rows.items():
            for name, value in by_name.items():
                assert adjoint[probe][which][name] == pytest.approx(value, rel=1e-8, abs=1e-14), (probe, which, name)
    assert forward["outer_y"]["end"]["m"] != 0.0   # a probe on a node that follows the links


#: the gimbal with its energies' and the work's probes, a load on the outer ring too (a node that follows
#: the links: its power needs the dependent rates' derivative), cut to 0.1 s
WORKING = GIMBAL.replace("t_end: 0.3, sensitivities: [k1, m, P, EI, rho]", "t_end: 0.1, sensitivities: [k1, m, P]").replace(
    '  - {at: tip, force: [0, "P", "-0.5*P"]}\n',
    '  - {at: tip, force: [0, "P", "-0.5*P"]}\n  - {at: outer, force: ["0.5*P", 0, "P"]}\n').replace(
    "    tip_x: {point: tip, quantity: position, component: x}\n",
    "    tip_x: {point: tip, quantity: position, component: x}\n    W: {energy: external_work}\n"
    "    T: {energy: kinetic}\n    H: {momentum: angular, component: z}\n")


@pytest.mark.parametrize("name", ["k1", "m", "P"])
def test_the_work_and_energies_of_a_gimbal_agree_with_richardson_central_differences(name):
    """Found in review: the external work's derivative took the links' dependent coordinates for prescribed
    drives (≈ 200 times off: by P −40 against 0.186) and the loads' power on a node that follows the links
    without its rates' ∂(J v)/∂q δq term (k1 2.0e-3 against 1.5e-3)."""
    _agree(_run(WORKING), WORKING, name, tolerance=1e-6)


def test_energies_by_a_links_section_agree_with_richardson_central_differences():
    """Found in review: energies and momenta by a rigid link's ρ missed the link's own mass (kinetic energy
    −0.145 against 0.038): refused until 86d57d9, built since (energy_sensitivities._StateForms._link_blocks; the
    whole case in tests/test_sensitivities_refusals_lifted2.py). The kinetic energy by the rings' rho against
    Richardson-extrapolated central differences of whole runs (every probe): measured 1.3e-9. The adjoint's seeds of section
    forces, body frames and energies, which missed the links' reduction (a root moment 2.30 against 0.163), are built
    too (tests/test_sensitivities_refusals_lifted.py)."""
    text = GIMBAL.replace("    tip_x:", "    T: {energy: kinetic}\n    tip_x:")
    assert _agree(_run(text, "rho"), text, "rho", tolerance=1e-6) >= 0.0
