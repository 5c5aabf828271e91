"""Geometry parameters that move a rigid link's or a guide's own geometry (issue 34; latdyn/analyses/
geometry_sensitivities.py ``_linked_refusal`` and ``ReferenceGeometry._origin_move``, docs/parameters.md "Geometry
parameters").

Taken: the point of an edge moved together with everything that edge carries — a rigid link's start point on its body
(``beams.NAME.from.offset``), its end point on the body it carries (``to.offset``, that body moved the other way), a
guide's origin (the guided body's ``at``). On a body that never turns (fixed, prescribed: translating, or sliding on
guides from such a body) the subtree translates by a constant vector at a fixed state: no rate, no joint twist, no link
inertia and not the reduction's J moves, and the dependent nodes move with δo (held). On a part A that turns it
translates by T_A δ: ``ReferenceGeometry._add_shifts`` (K d + C δv + M δa before the reduction and the projection's
d × F_S on A's rotational rows), on the per-step path. Each case was refused on 40bf44a and is checked against
Richardson-extrapolated central differences of whole runs (≤ 1e-6 of each probe's largest), through the API and the
CLI (to the bit), the loop of steps on and off (to the bit). The discrete adjoint takes them (its derivatives the
forward method's: tests/test_adjoint_geometry_linked.py; refused, naming the rigid link, on 5a68b93).
Still refused, naming what moves: a hinge axis on a link, and beside a shift on a part that turns events, controllers
and probes other than points' (global axes), hinges' and guides' (a ring's offset, a link's length: taken since,
tests/test_geometry_sensitivities_link_length.py)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_sensitivities_events import _run as _api_run
from tests.test_sensitivities_guide_energies import _agree
from tests.test_sensitivities_guides import GUIDE_3D
from tests.test_sensitivities_rigid_links import GIMBAL

#: the gimbal's first hinge point on its fixed base (gim1's start offset) moved along (1, 0.5, −0.3) by X, both rings
#: and the boom's root with it (the boom's tip left where it is); at X = 0.1 the geometry is GIMBAL's
GIMBAL_HINGE_POINT = GIMBAL.replace("parameters: {k1: 6.0,", "parameters: {X: 0.1, k1: 6.0,").replace(
    "gim1: {from: base, to: outer,",
    'gim1: {from: {body: base, offset: ["X - 0.1", "0.5*X - 0.05", "0.03 - 0.3*X"]}, to: outer,').replace(
    "outer: {at: [0.3, 0.1, 0.2],", 'outer: {at: ["0.2 + X", "0.05 + 0.5*X", "0.23 - 0.3*X"],').replace(
    "inner: {at: [0.45, -0.05, 0.35],", 'inner: {at: ["0.35 + X", "-0.1 + 0.5*X", "0.38 - 0.3*X"],').replace(
    "sensitivities: [k1, m, P, EI, rho]", "sensitivities: [X, k1]")
#: the same on a base whose translation is prescribed (the links' root: x = at + translation(t))
GIMBAL_HINGE_CARRIED = GIMBAL_HINGE_POINT.replace(
    "base: {at: [0, 0, 0], fixed: true}",
    'base: {at: [0, 0, 0], motion: {translation: ["0.05*sin(3*t)", 0, "0.02*t*t"]}}')

#: a cart on a skew guide on the ground carrying a rigid pendulum on a skew hinge and a flexible arm to a tip mass,
#: under gravity and a tip load; X moves the cart (the guide's origin) along (1, 0.5, 0.3) and the pendulum's bob with
#: it, the arm's tip left where it is
CART = """
title: a cart on a skew ground guide carrying a rigid pendulum and a flexible arm to a tip mass
parameters: {X: 0.2, k: 30.0, c: 0.2, kh: 3.0, EI: 8.0}
gravity: [0, 0, -9.81]
sections:
  rod: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 0.6, rhoIy: 0.0006, rhoIz: 0.0006}
  arm: {EA: 1.0e5, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.3, rhoIy: 0.0003, rhoIz: 0.0004}
bodies:
  cart: {at: ["X", "0.1 + 0.5*X", "0.3*X"], mass: 0.5, inertia: [0.002, 0.003, 0.004],
         guide: {axis: [1, 0.4, -0.2], stiffness: "k", damping: "c", rest: 0.05}}
  bob: {at: ["X + 0.1", "0.5*X - 0.05", "0.3*X - 0.4"], mass: 0.3, inertia: [0.001, 0.0012, 0.0009]}
  tip: {at: [0.6, 0.1, -0.5], mass: 0.1, inertia: [0.0002, 0.0002, 0.0002]}
beams:
  pend: {from: cart, to: bob, section: rod, rigid: true,
         start: {hinge: {axis: [0.3, 1.0, 0.2], stiffness: "kh"}}}
  arm: {from: bob, to: tip, section: arm, elements: 3}
loads:
  - {at: tip, force: [0.5, 0, 0.3]}
solve: {analysis: transient, dt: 0.005, t_end: 0.3, sensitivities: [X, k]}
output:
  every: 0.01
  probes:
    s: {guide: cart, quantity: position}
    s_rate: {guide: cart, quantity: rate}
    f: {guide: cart, quantity: force}
    th: {hinge: pend.start, quantity: angle}
    bob_x: {point: bob, quantity: position, component: x}
    bob_v: {point: bob, quantity: velocity, component: z}
    tip_z: {point: tip, quantity: displacement, component: z}
    tip_y: {point: tip, quantity: position, component: y}
"""
#: the same cart on a guide on a fixed rail body (``on: rail``), the rail unmoved
RAIL = CART.replace("bodies:\n", "bodies:\n  rail: {at: [-0.2, 0.3, 0.1], fixed: true}\n").replace(
    "guide: {axis:", "guide: {'on': rail, axis:")
#: the pendulum's hinge point on the cart (which slides on its ground guide, so never turns) moved by X with the bob
CART_HINGE = CART.replace('cart: {at: ["X", "0.1 + 0.5*X", "0.3*X"],', "cart: {at: [0.2, 0.2, 0.06],").replace(
    "pend: {from: cart,", 'pend: {from: {body: cart, offset: ["X - 0.2", "0.5*X - 0.1", "0.3*X - 0.06"]},')
#: a carriage on a cross guide on the cart carrying the pendulum: X moves the carriage's origin on the cart, and the bob
TABLE = CART.replace('cart: {at: ["X", "0.1 + 0.5*X", "0.3*X"],', "cart: {at: [0.2, 0.2, 0.06],").replace(
    "  bob:", '  carriage: {at: ["X", "0.1 + 0.5*X", "0.3*X"], mass: 0.2, inertia: [0.001, 0.001, 0.001],\n'
    "             guide: {'on': cart, axis: [-0.3, 1, 0.5], stiffness: 20.0, damping: 0.1}}\n  bob:").replace(
    "pend: {from: cart,", "pend: {from: carriage,")
#: the mass on the skew guide at the flexible arm's tip, the guide's origin on the tip (which turns) moved by X alone
#: (refused on 40bf44a by tests/test_geometry_sensitivities_links.py's "guide-origin" case)
GUIDE_ORIGIN = GUIDE_3D.replace("slider: {at: [0.7, 0.35, 0.7],", 'slider: {at: ["X", 0.35, 0.7],').replace(
    "parameters: {k", "parameters: {X: 0.7, k").replace("sensitivities: [k,", "sensitivities: [X, k,").replace(
    "    mid_x:",
    "    sv: {point: slider, quantity: velocity, component: x}\n    gf: {guide: slider, quantity: force}\n    mid_x:")
#: the inner ring's hinge point on the outer ring (which turns: gim2's start offset) moved with the inner ring and the
#: boom's root along (1, 0.5, −0.3) by X
INNER_POINT = GIMBAL.replace("parameters: {k1", "parameters: {X: 0.1, k1").replace(
    "gim2: {from: outer,", 'gim2: {from: {body: outer, offset: ["X - 0.1", "0.5*X - 0.05", "0.03 - 0.3*X"]},').replace(
    "inner: {at: [0.45, -0.05, 0.35],", 'inner: {at: ["0.35 + X", "-0.1 + 0.5*X", "0.38 - 0.3*X"],').replace(
    "sensitivities: [k1, m, P, EI, rho]", "sensitivities: [X, k1]")
#: gim1's end point on the outer ring (its ``to`` offset) moved along (1, 0.5, −0.3) by X and the outer ring, the inner
#: ring and the boom's root the other way, so that the link's end point stays: the edge's b moves, fixed in the outer
#: ring's axes (a part that turns)
END_OFFSET = GIMBAL.replace("parameters: {k1", "parameters: {X: 0.1, k1").replace(
    "to: outer,", 'to: {body: outer, offset: ["X - 0.1", "0.5*X - 0.05", "0.03 - 0.3*X"]},').replace(
    "outer: {at: [0.3, 0.1, 0.2],", 'outer: {at: ["0.4 - X", "0.15 - 0.5*X", "0.17 + 0.3*X"],').replace(
    "inner: {at: [0.45, -0.05, 0.35],", 'inner: {at: ["0.55 - X", "-0.5*X", "0.32 + 0.3*X"],').replace(
    "sensitivities: [k1, m, P, EI, rho]", "sensitivities: [X, k1]")
assert '"0.55 - X"' in END_OFFSET and "to: {body: outer" in END_OFFSET
assert '"X", 0.35' in GUIDE_ORIGIN and "gf: {guide" in GUIDE_ORIGIN and "{body: outer, offset" in INNER_POINT
for _scene in (GIMBAL_HINGE_POINT, GIMBAL_HINGE_CARRIED, RAIL, CART_HINGE, TABLE):
    assert '"X - 0.1"' in _scene or "'on': rail" in _scene or '"X - 0.2"' in _scene or "'on': cart" in _scene
assert "0.02*t*t" in GIMBAL_HINGE_CARRIED


@pytest.mark.parametrize("text", ["GIMBAL_HINGE_POINT", "GIMBAL_HINGE_CARRIED", "CART", "RAIL", "CART_HINGE",
                                  "TABLE", "GUIDE_ORIGIN", "INNER_POINT", "END_OFFSET"])
def test_a_moved_hinge_point_or_guide_origin_agrees_with_richardson(text):
    """Refused on 40bf44a. Measured (every probe over the rows, relative to its largest): the gimbal's hinge point
    1.9e-8, on its prescribed base 9.4e-8, the cart's guide origin on the ground 1.7e-9, on the fixed rail 1.8e-9, the
    pendulum's hinge point on the sliding cart 1.7e-9, the carriage's origin on the cart 2.2e-9; on parts that turn
    (ReferenceGeometry._add_shifts): the guide's origin on the arm's tip 1.9e-9 (its slider's velocity and guide force
    included), the inner ring's hinge point on the outer ring 2.7e-8, gim1's end point on the outer ring 2.5e-8."""
    scene = globals()[text]
    result = _api_run(scene, "X")
    assert all(np.any(result.sensitivities[(probe, "X")] != 0.0) for probe in result.probes if probe != "t")
    assert _agree(result, scene, "X") <= 1e-6


@pytest.mark.parametrize("text", ["GIMBAL_HINGE_POINT", "CART", "TABLE"])
def test_the_loop_of_steps_gives_the_per_step_paths_sensitivities(text):
    """The runs with the sensitivities' loop of steps on and off: every column and the probe sensitivities to the bit,
    the loop taking every step."""
    runs = runs_with_the_loop_on_and_off(globals()[text])
    assert_same_sensitivities(runs[True], runs[False], nonzero="some", in_loop_but=0)


@pytest.mark.parametrize("text", ["GUIDE_ORIGIN", "INNER_POINT"])
def test_a_shift_on_a_part_that_turns_keeps_the_per_step_path_both_ways(text):
    """The loop of steps refuses these (the shift's ∂r/∂X is formed in Python from the evaluation's matrices): the runs
    with the loop on and off take the per-step path and agree to the bit."""
    runs = runs_with_the_loop_on_and_off(globals()[text])
    assert_same_sensitivities(runs[True], runs[False], nonzero="some")


@pytest.mark.parametrize("text", ["CART", "GUIDE_ORIGIN"])
def test_through_the_cli_equals_the_api(tmp_path, text):
    """``latdyn run`` of the scene as typed: sensitivities.csv's columns by X and summary.json's probe sensitivities
    those of ``latdyn.run`` on the same text, to the bit."""
    columns = ("s/X", "f/X", "th/X", "bob_v/X", "tip_z/X", "s/k") if text == "CART" else (
        "s/X", "gf/X", "sv/X", "slider_z/X", "mid_x/X", "s/k")
    assert_the_cli_equals_the_api(tmp_path, globals()[text], columns)


def assert_the_cli_equals_the_api(tmp_path, scene: str, columns) -> None:
    """``latdyn run`` of ``scene`` as typed: summary.json's probe sensitivities and sensitivities.csv's ``columns``
    ("probe/parameter") those of ``latdyn.run`` on the same text, to the bit."""
    import json

    run, out = latdyn_run(tmp_path, scene)
    assert run.returncode == 0, run.stderr
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(scene)))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]
    rows = [line.split(",") for line in (out / "sensitivities.csv").read_text().splitlines()]
    for column in columns:
        at = rows[0].index(column)
        assert np.array_equal([float(row[at]) for row in rows[1:]], api.sensitivities[tuple(column.split("/"))])


#: what stays refused: the guide's origin on the arm's tip beside a section-force probe (the inner ring's hinge point on
#: the outer ring beside its latch is taken since: tests/test_geometry_sensitivities_turning_events.py; the outer ring
#: moved without the inner one, gim2's length: tests/test_geometry_sensitivities_link_length.py END_AND_LENGTH)
@pytest.mark.parametrize("text, expected", [
    (GUIDE_ORIGIN.replace("    mid_x:", '    moment: {element: "arm.element[0]", quantity: moment_y}\n    mid_x:'),
     "the guide of 'slider' on 'tip', a part that turns, beside the probe 'moment'"),
], ids=["guide-origin-beside-a-section-probe"])
def test_what_a_links_own_geometry_moves_stays_refused_where_not_exact(tmp_path, text, expected):
    """Named (the link or the guided body, what moves), through the API (SceneError naming solve.sensitivities) and the
    CLI (exit 2, no traceback)."""
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert refused.value.key == "solve.sensitivities" and expected in str(refused.value), str(refused.value)
    run, _ = latdyn_run(tmp_path, text)
    assert run.returncode == 2 and "solve.sensitivities" in run.stderr and "Traceback" not in run.stderr


#: the pendulum's hinge point on the sliding cart, the cart's guide latching at s = 0.01 (t = 0.0649 s)
CART_LATCH = CART_HINGE.replace('stiffness: "k", damping: "c", rest: 0.05}',
                                'stiffness: "k", damping: "c", rest: 0.05, lock_at: 0.01}')
assert "lock_at: 0.01" in CART_LATCH


def test_the_hinge_point_on_the_sliding_cart_through_its_latch_agrees_with_richardson():
    """Through the guide's latch (the event machinery's impulse weight from this ∂r/∂X): every probe and the latch's
    time against Richardson (the time to 1e-6 relative). Measured 3.6e-8."""
    from tests.test_sensitivities_guides import _agree as _with_events

    result = _api_run(CART_LATCH, "X")
    assert [event["kind"] for event in result.summary["events"]] == ["latch"]
    assert _with_events(result, CART_LATCH, "X") <= 1e-6


#: the carriage on the cart statically under gravity (load control, 3 steps), without the guides' and rates' probes
STATIC_TABLE = "\n".join(line for line in TABLE.replace(
    "solve: {analysis: transient, dt: 0.005, t_end: 0.3, sensitivities: [X, k]}",
    "solve: {analysis: static, method: load-control, steps: 3, sensitivities: [X, k]}").splitlines()
    if not line.lstrip().startswith(("s_rate:", "bob_v:", "s:", "f:"))) + "\n"
assert "method: load-control" in STATIC_TABLE and "s_rate:" not in STATIC_TABLE


def _static_path_agrees(text: str, value: float) -> None:
    """Every row's sensitivity by X of the static run ``text`` against Richardson-extrapolated central differences of
    whole static runs (1e-4 and 5e-5 of X's ``value``), relative to each probe's largest (≤ 1e-6)."""
    result = _api_run(text, "X")
    central = []
    for step in (1e-4 * value, 5e-5 * value):
        up, down = _api_run(text, "X", X=value + step), _api_run(text, "X", X=value - step)
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes if k != "t"})
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        assert np.abs(expected).max() > 0.0, probe
        assert np.abs(result.sensitivities[(probe, "X")] - expected).max() <= 1e-6 * np.abs(expected).max(), probe


def test_the_carriage_origin_on_a_static_path_agrees_with_richardson():
    """Load control, by X. Measured 1.4e-10."""
    _static_path_agrees(STATIC_TABLE, 0.2)


#: the guide's origin on the arm's tip statically under gravity (load control, 3 steps), without the guide's probes
STATIC_GUIDE_ORIGIN = "\n".join(line for line in GUIDE_ORIGIN.replace(
    "solve: {analysis: transient, dt: 0.005, t_end: 0.4, sensitivities: [X, k, m, EI, rest]}",
    "solve: {analysis: static, method: load-control, steps: 3, sensitivities: [X, k]}").splitlines()
    if not line.lstrip().startswith(("s: {guide", "s_rate:", "sv:", "gf:"))) + "\n"
assert "method: load-control" in STATIC_GUIDE_ORIGIN and "gf:" not in STATIC_GUIDE_ORIGIN


def test_the_guide_origin_on_the_turning_tip_on_a_static_path_agrees_with_richardson():
    """Load control (the shift's K d and the projection's d × F_S, without rates), by X. Measured 4.5e-10."""
    _static_path_agrees(STATIC_GUIDE_ORIGIN, 0.7)
