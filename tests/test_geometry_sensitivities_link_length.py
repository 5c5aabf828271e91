"""Geometry parameters that change a rigid link's length or direction (issue 34; latdyn/analyses/
geometry_sensitivities.py ``_linked_refusal``, ``ReferenceGeometry._origin_move`` and ``_add_link_inertia``,
docs/parameters.md "Geometry parameters").

Taken: the body at a rigid link's end (and all it carries) moved relative to the link's start, the link's own offsets,
y_axis and hinge axes unmoved — a gimbal's ring offset (``outer.at``). The link's vector v = B − A is its end edge's o,
fixed in the link node's axes (a part that turns): the subtree below translates by T_L δv (linkgeom2's shifts,
``ReferenceGeometry._add_shifts``), and the link's joint-body block (m = ρA L, c = v/2, I = E D Eᵀ) moves by
``link_inertia_moved``: the generated ``joint_body`` at (δm, c, δI) and ``joint_body_D_com`` along δc. Each case was
refused on 0d1fc61 and is checked against Richardson-extrapolated central differences of whole runs (≤ 1e-6 of each
probe's largest), through the API and the CLI (to the bit); the loop of steps refuses them (both runs take the per-step
path, to the bit); the discrete adjoint takes them (tests/test_adjoint_geometry_linked.py; refused on 5a68b93).
Still refused, naming what moves: a
link's length beside events, controllers and probes other than points' (global axes), hinges' and guides'; a length
moved together with the link's own offsets, from a free end point, or closing a slider-crank loop."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_geometry_sensitivities_link_geometry import CART, END_OFFSET, _static_path_agrees, \
    assert_the_cli_equals_the_api
from tests.test_sensitivities_events import _run as _api_run
from tests.test_sensitivities_guide_energies import _agree
from tests.test_sensitivities_rigid_links import GIMBAL, PLACED

#: the ring offset: the outer ring and the inner one moved along (1, 0.5, −0.3) by X, the base's hinge point where it is
#: (gim1's length and direction change, gim2's do not), the boom's root with the inner ring and its tip where it is
RING = GIMBAL.replace("parameters: {k1", "parameters: {X: 0.1, k1").replace(
    "outer: {at: [0.3, 0.1, 0.2],", 'outer: {at: ["0.2 + X", "0.05 + 0.5*X", "0.23 - 0.3*X"],').replace(
    "inner: {at: [0.45, -0.05, 0.35],", 'inner: {at: ["0.35 + X", "-0.1 + 0.5*X", "0.38 - 0.3*X"],').replace(
    "sensitivities: [k1, m, P, EI, rho]", "sensitivities: [X, k1]")
#: the outer ring placed alone by its x (fuzz8's gim1/gim2 ``outer.at``): gim1's vector and gim2's both change, in turn
#: (refused on 0d1fc61 by tests/test_geometry_sensitivities_links.py's "ring-offset" case and by
#: tests/test_sensitivities_rigid_links.py's refusal tests of this scene); every parameter beside it
OUTER = PLACED
#: gim1's end point on the outer ring moved with the ring the other way (its b), the inner ring left: gim2's length
#: (refused on 0d1fc61 by tests/test_geometry_sensitivities_link_geometry.py's "ring-offset" case)
END_AND_LENGTH = END_OFFSET.replace('inner: {at: ["0.55 - X", "-0.5*X", "0.32 + 0.3*X"],',
                                    "inner: {at: [0.45, -0.05, 0.35],")
#: the cart's rigid pendulum (a link on a body that never turns: the cart slides on its ground guide) lengthened: the
#: bob moved by X along x, the flexible arm's root with it
CART_BOB = CART.replace('cart: {at: ["X", "0.1 + 0.5*X", "0.3*X"],', "cart: {at: [0.2, 0.2, 0.06],").replace(
    'bob: {at: ["X + 0.1", "0.5*X - 0.05", "0.3*X - 0.4"],', 'bob: {at: ["X + 0.1", 0.15, -0.34],')
#: fuzz8's s4-6 (a ring offset: the outer ring's y, gim1's and gim2's lengths) without its latch and controllers: a
#: rate-dependent torque law at the first hinge, hht-alpha
FUZZ_RING = GIMBAL.replace("parameters: {k1", "parameters: {X: 0.1, cr: 0.068, k1").replace(
    "outer: {at: [0.3, 0.1, 0.2],", "outer: {at: [0.3, X, 0.2],").replace(
    'rest_angle: "rest"}}}', 'rest_angle: "rest", torque: "-cr*(1 + 10*theta**2)*theta_dot"}}}').replace(
    "solve: {analysis: transient, dt: 0.01, t_end: 0.3, sensitivities: [k1, m, P, EI, rho]}",
    "solve: {analysis: transient, dt: 0.01, t_end: 0.4, method: hht-alpha, sensitivities: [X, k2, cr, P]}")
assert "hht-alpha" in FUZZ_RING and "[0.3, X, 0.2]" in FUZZ_RING and "theta_dot" in FUZZ_RING
#: RING with a load at gim1's end point (its offset from the link node moves with the link's vector)
LOAD_END = RING.replace("loads:\n", "loads:\n  - {at: gim1.end, force: [0.2, -0.1, 0.3]}\n")
#: CART_BOB with the pendulum clamped to the cart (no hinge: the link node never turns)
CLAMPED = CART_BOB.replace("""pend: {from: cart, to: bob, section: rod, rigid: true,
         start: {hinge: {axis: [0.3, 1.0, 0.2], stiffness: "kh"}}}""", "pend: {from: cart, to: bob, section: rod, "
                           "rigid: true}").replace("    th: {hinge: pend.start, quantity: angle}\n", "")
assert "{at: gim1.end" in LOAD_END and "rigid: true}\n" in CLAMPED and "th:" not in CLAMPED
#: RING statically under gravity (load control, 3 steps), without its spin and its rate probes
STATIC_RING = "\n".join(line for line in RING.replace(
    "solve: {analysis: transient, dt: 0.01, t_end: 0.3, sensitivities: [X, k1]}",
    "gravity: [0, 0, -9.81]\nsolve: {analysis: static, method: load-control, steps: 3, sensitivities: [X, k1]}").replace(
    "initial_velocity: {angular: [0.5, -0.3, 2.0]}\n", "").splitlines()
    if not line.lstrip().startswith(("vo:", "vi:", "r2:"))) + "\n"
assert '"0.2 + X"' in RING and "[X, 0.1, 0.2]" in OUTER and "rho, X]" in OUTER and "[0.45, -0.05, 0.35]" in END_AND_LENGTH
assert '"X + 0.1", 0.15, -0.34' in CART_BOB and "load-control" in STATIC_RING and "vi:" not in STATIC_RING


@pytest.mark.parametrize("text", ["RING", "OUTER", "END_AND_LENGTH", "CART_BOB", "FUZZ_RING", "LOAD_END",
                                  "CLAMPED"])
def test_a_links_length_agrees_with_richardson(text):
    """Refused on 0d1fc61. Measured (every probe over the rows, relative to its largest): the ring offset 1.7e-8, the
    outer ring alone 1.0e-8 (gim1.end's velocity included: the link's end point moves on it), gim1's end point with
    gim2's length 1.3e-8, the pendulum on the sliding cart 8.1e-10, fuzz8's s4-6 without its events 6.1e-9, with a load at gim1's end point 1.7e-8, the pendulum
    clamped to the cart 9.2e-9. Without the link's inertia term 0.12, 0.27; without
    δI 0.031, 0.040; without δc 0.072, 0.23; without δm 0.018, 0.17 (RING, OUTER)."""
    scene = globals()[text]
    result = _api_run(scene, "X")
    assert all(np.any(result.sensitivities[(probe, "X")] != 0.0) for probe in result.probes if probe != "t")
    assert _agree(result, scene, "X") <= 1e-6


def test_a_links_length_on_a_static_path_agrees_with_richardson():
    """Load control under gravity: every row's sensitivity by X against Richardson of whole static runs (≤ 1e-6).
    Measured 2.9e-10."""
    _static_path_agrees(STATIC_RING, 0.1)


def test_the_links_inertia_block_moves_as_its_loaded_model():
    """``link_inertia_moved`` (δm, δc, δI of gim1 by X: the generated ``rigid_link_inertia_D_ends``) against central
    differences of the model the loader builds at X ± h (its joint-body block: the generated ``rigid_link_inertia`` at
    the moved geometry), to 1e-8."""
    from latdyn.analyses.geometry_sensitivities import link_inertia_moved
    from latdyn.model.kernels import load_kernels
    from latdyn.model.model import Model

    def block(x):
        data = yaml.safe_load(OUTER)
        data["parameters"]["X"] = x
        scene = latdyn.load_scene(data)
        model = Model.from_scene(scene)
        node = next(i for i, n in enumerate(model.nodes) if n.name == "gim1.link")
        b = int(np.flatnonzero(model.body_nodes == node)[0])
        return scene, model.body_mass[b], model.body_com[b], model.body_inertia[b]

    scene, m, c, inertia = block(0.3)
    dm, dc, dI = link_inertia_moved(load_kernels("c", "default"), scene.beams["gim1"], np.array([1.0, 0.0, 0.0]))
    h = 1e-5
    up, down = block(0.3 + h), block(0.3 - h)
    assert abs(dm - (up[1] - down[1]) / (2 * h)) <= 1e-8 * abs(dm)
    assert np.abs(dc - (up[2] - down[2]) / (2 * h)).max() <= 1e-8
    assert np.abs(dI - (up[3] - down[3]) / (2 * h)).max() <= 1e-8 * np.abs(dI).max()


@pytest.mark.parametrize("text", ["RING", "CART_BOB"])
def test_the_loop_of_steps_refuses_them_and_both_runs_agree(text):
    """The loop of steps refuses a link's length (the links' blocks moved in Python): the runs with the loop on and off
    take the per-step path and agree to the bit."""
    runs = runs_with_the_loop_on_and_off(globals()[text])
    assert_same_sensitivities(runs[True], runs[False], nonzero="some")


def test_through_the_cli_equals_the_api(tmp_path):
    """``latdyn run`` of OUTER as typed: sensitivities.csv's columns and summary.json's probe sensitivities those of
    ``latdyn.run`` on the same text, to the bit."""
    assert_the_cli_equals_the_api(tmp_path, OUTER, ("tip_x/X", "vi/X", "a1/X", "r2/X", "a2/rho"))


#: what stays refused: the ring offset beside a section probe on the boom; gim1's length moved together with its own end
#: offset (beside latches, stops, friction, compliant stops and controllers of joints and points it is taken since:
#: tests/test_geometry_sensitivities_turning_events.py)
@pytest.mark.parametrize("text, expected", [
    (RING.replace("    a1:", '    bm: {element: "boom.element[0]", quantity: moment_y}\n    a1:'),
     "rigid link 'gim1''s length or direction, a part that turns, beside the probe 'bm'"),
    (RING.replace("to: outer,", 'to: {body: outer, offset: ["0.1 - X", 0, 0]},'),
     "rigid link 'gim1''s reference geometry (its length or direction (its end points moved apart) together with "
     "its own offsets"),
], ids=["beside-a-section-probe", "with-its-own-offset"])
def test_what_a_links_length_moves_stays_refused_where_not_exact(tmp_path, text, expected):
    """Named (the link, what moves), through the API (SceneError naming solve.sensitivities) and the CLI (exit 2, no
    traceback)."""
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert refused.value.key == "solve.sensitivities" and expected in str(refused.value), str(refused.value)
    run, _ = latdyn_run(tmp_path, text)
    assert run.returncode == 2 and "solve.sensitivities" in run.stderr and "Traceback" not in run.stderr
