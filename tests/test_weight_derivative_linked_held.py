"""An event's time shift through prescribed motions on models with rigid links or guides, generated through the
reduction (issue 34; latdyn/analyses/parameter_stiffness.py ``linked_prescribed_along``, ``time_shift_along``;
docs/parameters.md, "The impulse weight's derivative").

An impulse or restart at t_e + δt_e weighs with W = M + s K at the moved time: (∂K/∂p) w holds the static residual's
∂(∂r_min/∂t)/∂q w δt_e, and a prescribed motion moves r_min = Pᵀ r_all through the prescribed coordinates, the
dependent nodes that hang from them (J_·p q̇_p) and P itself. 5a68b93 took a central difference of the whole static
∂r/∂p along w there (two evaluations at each weighing), which held the elements' gravity tangent's move along w that W's
K does not hold: the whole runs' sensitivities on the cart below were 1.8e-7 (k), 1.1e-7 (m) off Richardson.

On 3D YAML scenes: the gimbal of rigid links on skew hinges on a slewing and shaking base latching
(tests/test_sensitivities_in_loop_linked2.py), and a cart on a skew guide on a slewing base, under gravity, carrying a
flexible boom, driven out by a force until it latches (its node hangs from the prescribed base). The exact part against
Richardson-extrapolated central differences of the same quantity at a turned state (the cart without gravity there: the
difference holds the gravity tangent's move); at the events no difference taken; whole runs against Richardson
differences of whole runs, the adjoint against the forward method, through ``latdyn run`` with the difference
forbidden and the loop of steps off."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run_switched, summary_of, the_loop_off_writes_the_same
from tests.test_adjoint_in_loop_links import _adjoint, _largest_gap
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_in_loop_linked2 import GIMBAL_SLEW
from tests.test_weight_derivative_linked_parameters import _FORBIDDEN, _counting, parameter_part_and_reference

#: a cart on a skew guide on a slewing, shaking base (its node hangs from the prescribed base through the guide), under
#: gravity, carrying a flexible boom of three elements, pushed out by F until it latches at 0.02 (t = 0.104)
CART = """
title: a cart on a skew guide on a slewing base, carrying a flexible boom, latching
parameters: {k: 30.0, c: 0.2, m: 0.5, EI: 25.0, F: 2.0}
gravity: [0, 0, -9.81]
sections:
  s: {EA: 100000.0, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.6, rhoIy: 0.001, rhoIz: 0.0013}
bodies:
  base: {at: [0, 0, 0], motion: {translation: ["0.04*sin(4*t)", 0, 0],
                                 rotation: {axis: [0.3, -0.2, 1.0], angle: "0.9*t**2"}}}
  cart: {at: [0.3, 0.1, 0.05], mass: "m", inertia: [0.002, 0.003, 0.0025],
         guide: {'on': base, axis: [1, 0.5, -0.2], stiffness: "k", damping: "c", force: "F", lock_at: 0.02}}
  tip: {at: [0.7, 0.45, 0.35], mass: 0.1, inertia: [0.0002, 0.0003, 0.0002]}
beams:
  boom: {from: cart, to: tip, section: s, elements: 3}
solve: {analysis: transient, dt: 0.005, t_end: 0.25, sensitivities: [k, m, EI, F]}
output:
  every: 0.01
  probes:
    s: {guide: cart, quantity: position}
    s_rate: {guide: cart, quantity: rate}
    tip_z: {point: tip, quantity: position, component: z}
    tip_y: {point: tip, quantity: displacement, component: y}
    cart_x: {point: cart, quantity: position, component: x}
"""
#: the cart without gravity: the difference of the static ∂r/∂p along w then holds nothing W's K does not
CART_WEIGHTLESS = CART.replace("gravity: [0, 0, -9.81]", "gravity: [0, 0, 0]")
assert "guide: {'on': base" in CART and "gravity: [0, 0, 0]" in CART_WEIGHTLESS


def turned_in_motion(text: str, t: float = 0.23, seed: int = 11, size: float = 0.05) -> tuple:
    """(the scene's TransientSensitivities, its initial state with the prescribed motion at ``t`` (its rates not 0),
    turned and deformed by ``size`` times a normal draw, random rates and accelerations, a random w)."""
    from latdyn.analyses.transient_sensitivities import TransientSensitivities
    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    owner = TransientSensitivities(prepared)
    assembler, model = owner.assembler, owner.model
    state = prepared.state
    assembler.apply_prescribed(state, t)
    rng = np.random.default_rng(seed)
    n = model.n_dofs
    state = assembler.advance(state, size * rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    assembler.complete_links(state)
    return owner, state, rng.normal(size=n)


@pytest.mark.parametrize("text", [GIMBAL_SLEW, CART_WEIGHTLESS], ids=["gimbal on a slewing base", "weightless cart"])
def test_the_time_shifts_part_is_generated_through_the_reduction(text, monkeypatch):
    """The time shift's part of (∂K/∂p) w (with δt_e less without) at a turned state moving in time, no evaluation of
    the static ∂r/∂p along w (5a68b93: two), against the Richardson reference of the same quantity relative to its
    largest: measured 8.3e-13 (gimbal), 6.7e-12 (cart); 5a68b93's single difference 9.8e-10, 2.9e-9."""
    owner, state, w = turned_in_motion(text)
    parts = []
    for shift in (np.linspace(0.3, 1.1, len(owner.names)), None):
        owner.time_shift = shift
        calls = _counting(monkeypatch)
        computed = owner._stiffness_derivative(state, w)
        assert not calls
        parts.append((computed, parameter_part_and_reference(owner, state, w)[1]))
    computed, reference = parts[0][0] - parts[1][0], parts[0][1] - parts[1][1]
    assert float(np.max(np.abs(computed - reference))) <= 1e-10 * float(np.max(np.abs(reference)))


@pytest.fixture(scope="module")
def cart_runs():
    """The cart's forward run (no difference of the static ∂r/∂p taken: the count) and its adjoint run."""
    from latdyn.analyses.transient_sensitivities import TransientSensitivities

    held, calls = TransientSensitivities._advanced_at_held_rates, []

    def counted(self, *args, **kwargs):
        calls.append(1)
        return held(self, *args, **kwargs)

    TransientSensitivities._advanced_at_held_rates = counted
    try:
        forward = latdyn.run(latdyn.load_scene(yaml.safe_load(CART)))
        adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(_adjoint(CART))))
    finally:
        TransientSensitivities._advanced_at_held_rates = held
    return forward, adjoint, len(calls)


def test_the_carts_latch_takes_no_difference_and_the_adjoint_agrees(cart_runs):
    """Through the latch no difference of the static ∂r/∂p (5a68b93: 2, and 2 more in the adjoint's shift
    coefficient), the adjoint's derivatives the forward method's (measured 3.2e-13; 3.6e-13 on 5a68b93)."""
    forward, adjoint, calls = cart_runs
    assert [e["kind"] for e in forward.summary["events"]] == ["latch"]
    assert calls == 0
    assert _largest_gap(adjoint.summary["probe_sensitivities"], forward.summary["probe_sensitivities"]) <= 1e-10


def test_the_carts_whole_run_agrees_with_richardson(cart_runs):
    """The whole run's sensitivities by the cart's mass against Richardson central differences of whole runs, every
    probe to 3e-8 of its largest (measured 6.2e-9; 1.1e-7 on 5a68b93, whose difference held the elements' gravity
    tangent's move along w; k 3.1e-8 and F 3.5e-9, 1.8e-7 and 1.0e-7 there)."""
    assert _agree(cart_runs[0], CART, "m", tolerance=3e-8) < 3e-8


def test_the_cart_through_the_cli_loop_on_and_off(tmp_path):
    """``latdyn run`` of the cart with the difference forbidden (5a68b93 fails there), its event sensitivities the
    API's, and the loop of steps off writing the same bytes."""
    (tmp_path / "scene.yaml").write_text(CART)
    out = tmp_path / "out"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", out, _FORBIDDEN)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert [e["kind"] for e in summary["events"]] == ["latch"]
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(CART)))
    assert json.loads(json.dumps(result.summary["event_sensitivities"])) == summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)
