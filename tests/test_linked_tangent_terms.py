"""What the reduced (linked) stiffness K = ∂r/∂q holds, decided by step-size studies of central
differences: a term the matrix misses does not shrink with the step, differences' truncation error
shrinks as h² (then round-off grows as 1/h).

- The flexible slider-crank of examples/slider_crank.yaml (a rigid crank, a flexible rod of four
  elements, a guided slider) in motion: the Newton matrix's reduction, without the elements' inertia
  tangent (which the time step's matrix leaves out by design: latdyn.step.integrators), is off by a
  constant 2.5 of 2.7e8 (1e-8 relative) at every step below 1e-6; with it (``inertia_tangent=True``)
  the reduction equals the differences to their truncation error (∝ h²).
- Where a dependent node's frame moves with the coordinates (a guide on a free body, a link off a
  moving one, a pendulum's bob), its rates J v and accelerations J a + c(v) change with q at fixed
  independent rates: K holds Pᵀ(C_·dep ∂(J v)/∂q + M_·dep ∂(J a + c)/∂q) (the generated edge factors
  ``*_rates_D_q`` composed along the tree in csrc/links.c). Without it the reduced K of a 3D guided and
  linked model in motion was 17 % of max|K| off; of a rigid pendulum m θ̇² r².
"""
from __future__ import annotations

import numpy as np
import pytest

import latdyn

from test_rigid import finite_difference
from test_rigid_native import scene_yaml


def moving_slider_crank():
    """The example's model at its initial configuration moved a little, with random rates and
    accelerations (the crank's hinge prescribed: its angle and rates are the law's)."""
    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.prepare import prepare

    raw = scene_yaml(open(__file__.rsplit("/tests/", 1)[0] + "/examples/slider_crank.yaml").read())
    raw["solve"] = {"analysis": "transient", "t_end": 0.1, "dt": 0.002}
    raw.pop("output")
    prepared = prepare(latdyn.load_scene(raw))
    model, assembler = prepared.model, prepared.assembler
    rng = np.random.default_rng(1)
    n = model.n_dofs
    state = assembler.advance(prepared.state, 1e-3 * rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, 10 * rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    return prepared, state


def test_reduced_stiffness_of_the_slider_crank_by_a_step_size_study():
    """Without the inertia tangent the error against the differences stays at 2.5 (measured 2.55 at
    h = 1e-6, 2.54 at 1e-7: it does not shrink); with it, 3.4e2 → 3.4 → 3.4e-2 at h = 1e-4, 1e-5, 1e-6
    (h²: the truncation error alone; 1.3e-10 of max|K| = 2.7e8 at 1e-6). The inertia tangent asked of a
    fresh assembler (whose native model is rebuilt with the tangent's buffers) reduces through the J of
    that state (main reduced through the J of the model before, never completed: 1.3e8 off)."""
    from latdyn.assembly.linked import evaluate_linked

    prepared, state = moving_slider_crank()
    model, assembler = prepared.model, prepared.assembler
    first = np.asarray(evaluate_linked(model.links, assembler, state, True, 1.0, True, True).combined(0, 0, 1,
                                                                                                    dense=True))
    plain = np.asarray(evaluate_linked(model.links, assembler, state, True, 1.0, True, False).combined(0, 0, 1,
                                                                                                    dense=True))
    tangent = np.asarray(evaluate_linked(model.links, assembler, state, True, 1.0, True, True).combined(0, 0, 1,
                                                                                                      dense=True))
    assert np.array_equal(first, tangent)
    scale = np.abs(tangent).max()
    plain_error, tangent_error = {}, {}
    for h in (1e-4, 1e-5, 1e-6, 1e-7):
        differences = finite_difference(prepared, state, "q", eps=h)
        plain_error[h] = np.abs(plain - differences).max()
        tangent_error[h] = np.abs(tangent - differences).max()
    assert plain_error[1e-6] > 1.0 and plain_error[1e-7] > 0.9 * plain_error[1e-6]  # a term that stays
    assert np.abs(tangent - plain).max() > 1.0  # that term
    for coarse, fine in ((1e-4, 1e-5), (1e-5, 1e-6)):  # h²: truncation alone
        assert 50.0 < tangent_error[coarse] / tangent_error[fine] < 200.0
    assert tangent_error[1e-6] <= 1e-9 * scale


def test_dependent_rates_term_of_a_guided_and_linked_model_in_3d():
    """tests/test_linked_cables.py's model (a free body A, a body B guided on it, a rigid link to D, damped
    pretensioned cables) at a random moving state: K with the inertia tangents (``inertia_tangent``:
    the elements' and the joint bodies') equals the differences to their truncation error (measured
    1.9e-8, 1.9e-10 of max|K| at h = 1e-4, 1e-5); without the dependent rates' term it is 7.9e-4 of
    max|K| off at every step (the cables' stiffness dominates K; without the cables, 17 %)."""
    from latdyn.assembly.linked import evaluate_linked
    from latdyn.assembly.prepare import prepare
    from test_linked_cables import LINKED_CABLES, random_moving_state

    prepared = prepare(latdyn.load_scene(scene_yaml(LINKED_CABLES)))
    model, assembler = prepared.model, prepared.assembler
    state = random_moving_state(prepared, 3)
    ev = evaluate_linked(model.links, assembler, state, True, 1.0, True, True)
    K = np.asarray(ev.combined(0.0, 0.0, 1.0, dense=True))
    without = np.asarray(evaluate_linked(model.links, assembler, state, True, 1.0, True, True, rates_term=False)
                         .combined(0.0, 0.0, 1.0, dense=True))
    scale = np.abs(K).max()
    error = {h: np.abs(K - finite_difference(prepared, state, "q", eps=h)).max() for h in (1e-4, 1e-5)}
    assert 30.0 < error[1e-4] / error[1e-5] < 300.0 and error[1e-5] <= 1e-9 * scale
    assert np.abs(without - K).max() > 1e-4 * scale


PENDULUM = """
sections:
  s: {EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.3, 0.4, 0], mass: 4.0}
beams:
  arm: {from: hub, to: tip, section: s, rigid: true, start: {hinge: {axis: [0, 0, 1], stiffness: 3.0}}}
solve: {t_end: 0.1, dt: 0.01}
"""


def test_rigid_pendulum_in_motion_holds_the_centripetal_term():
    """A point mass m = 4 on a massless rigid link r = 0.5 turning at θ̇ = 0.7 about a fixed axis, no
    gravity: r_θ = m r² θ̈ + k θ, so ∂r/∂θ = k = 3 at fixed θ̇, θ̈ — the geometric term's m θ̇² r² (the
    centripetal force through ∂Jᵀ/∂θ) cancelled by the bob's centripetal acceleration's turn, ∂(J a + c)/∂θ
    (measured: exact to round-off in the Python reduction and the compiled matrix with the inertia tangent;
    without the rates' term, as the default Newton matrix, 3 + m θ̇² r² = 3.49)."""
    from latdyn.assembly.linked import evaluate_linked
    from latdyn.assembly.prepare import prepare
    from test_linked_cables import compiled_iteration_matrix

    prepared = prepare(latdyn.load_scene(scene_yaml(PENDULUM)))
    model, assembler = prepared.model, prepared.assembler
    assert model.n_dofs == 1
    state = prepared.state.copy()
    state.theta_dot[0], state.theta_ddot[0] = 0.7, -1.3
    ev = evaluate_linked(model.links, assembler, state, True, 1.0, True, True)
    K = np.asarray(ev.combined(0.0, 0.0, 1.0, dense=True))
    assert K[0, 0] == pytest.approx(3.0, abs=1e-14)
    compiled, _ = compiled_iteration_matrix(assembler, state, 0.0, 0.0, exact=True)
    assert compiled[0, 0] == pytest.approx(3.0, abs=1e-14)
    default, _ = compiled_iteration_matrix(assembler, state, 0.0, 0.0)  # the Newton matrix without the tangent
    assert default[0, 0] == pytest.approx(3.0 + 4.0 * 0.49 * 0.25, abs=1e-14)
    without = evaluate_linked(model.links, assembler, state, True, 1.0, True, True, rates_term=False)
    assert np.asarray(without.combined(0.0, 0.0, 1.0, dense=True))[0, 0] == pytest.approx(3.0 + 4.0 * 0.49 * 0.25,
                                                                                           abs=1e-14)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_rates_D_q_kernels_against_differences(backend):
    """rigid_link_edge_rates_D_q, prismatic_link_edge_rates_D_q (random parents, edges, rates) and
    slider_ / rod_closure_edge_rates_D_q (a slider-crank's pin in a turned plane): ∂(v, w, a, alpha)_c by
    the parent's position, its frame's spatial turn (T_p ← exp(skew δπ) T_p) and the edge's coordinate,
    at fixed rates, against central differences of the edge kernels' child_rates (step 1e-6; measured
    ≤ 7.1e-11 of the largest entry)."""
    from latdyn.model.kernels import load_kernels
    from latdyn.numerics.so3 import expm_so3

    from test_rigid_native import edge_inputs
    from test_slider_crank import TURN

    kernels = load_kernels(backend, "default")
    rng = np.random.default_rng(11)
    a, b, n = TURN[:, 0], TURN[:, 1], TURN[:, 2]
    closure = np.concatenate([0.4 * a, a, n, [0.3, 1.0, 0.0, 0.0]])
    cases = [(kind, *edge_inputs()) for kind in ("rigid_link_edge", "prismatic_link_edge") for _ in range(3)]
    for kind in ("slider_closure_edge", "rod_closure_edge"):
        for _ in range(3):
            pin = 0.1 * (np.cos(rng.uniform(0, 6.3)) * a + np.sin(rng.uniform(0, 6.3)) * b)
            cases.append((kind, np.concatenate([pin, np.eye(3).ravel(), rng.normal(size=12)]), closure))
    eps = 1e-6
    for kind, parent, edge in cases:
        rates = lambda p, e: getattr(kernels, kind)(p[None], e[None])[2][0]  # noqa: E731
        exact = getattr(kernels, f"{kind}_rates_D_q")(parent[None], edge[None])[0][0].reshape(12, 7)
        columns = []
        for k in range(7):
            moved = []
            for sign in (1.0, -1.0):
                p, e = parent.copy(), edge.copy()
                if k < 3:
                    p[k] += sign * eps
                elif k < 6:
                    p[3:12] = (expm_so3(sign * eps * np.eye(3)[k - 3]) @ parent[3:12].reshape(3, 3)).ravel()
                elif "closure" not in kind:
                    e[10] += sign * eps
                moved.append(rates(p, e))
            columns.append((moved[0] - moved[1]) / (2 * eps))
        numeric = np.column_stack(columns)
        assert np.abs(numeric).max() > 0.1, kind
        assert np.abs(exact - numeric).max() <= 1e-7 * np.abs(numeric).max(), kind


@pytest.mark.parametrize("inertia", [True, False])
def test_linearisation_tangent_of_a_linked_model_against_differences(inertia):
    """The linearisation's r_q (linearisation.tangent_q: now the exact reduction, no longer differences)
    of tests/test_linked_cables.py's guided-and-linked 3D model with damped cables, at a random moving
    state and load factor 0.7, equals central differences of the reduced residual (step 1e-5; measured
    2.5e-10 of max|K| with inertia and without). The differences it replaced (the material tangent
    plus differences of the rest, tangent_q_by_differences) were 1.7e-4 off there: their material part
    missed the cables' dampers moving with the dependent rates."""
    from latdyn.analyses.linearisation import tangent_q, tangent_q_by_differences
    from latdyn.assembly.prepare import prepare
    from test_linked_cables import LINKED_CABLES, random_moving_state

    prepared = prepare(latdyn.load_scene(scene_yaml(LINKED_CABLES)))
    state = random_moving_state(prepared, 4)
    exact = tangent_q(prepared.assembler, state, 0.7, inertia=inertia)
    differences = finite_difference(prepared, state, "q", eps=1e-5, load_factor=0.7, inertia=inertia)
    assert np.abs(exact - differences).max() <= 1e-8 * np.abs(exact).max()
    if inertia:
        old = tangent_q_by_differences(prepared.assembler, state, 0.7, inertia=inertia)
        assert np.abs(old - differences).max() > 1e-5 * np.abs(exact).max()
