"""The links' second derivatives generated (latdyn/analyses/weight_derivative.py, "Rigid links and guides";
docs/parameters.md, "The impulse weight's derivative"): an event's impulse-weight derivative on a model with rigid
links or guides holds the reduction's geometric term ∂(Pᵀ y)/∂q[w] moved along the configuration (δq) and, at an event
moved in time, along the prescribed motions (q̇_p). They were Richardson-extrapolated central differences of the links'
kinematics alone (10be92c: ``LINKS_STEP``); now csrc/linked_weight_second.c composes them along the tree of edges from
the generated edge kernels' ``*_rates_D_q`` and the wrench kernels' second derivatives ``hinge_wrench_D_q_D_q``,
``slide_wrench_D_q_D_q``, ``slider_closure_wrench_D_q_D_q``, ``rod_closure_wrench_D_q_D_q`` (codegen/joints.py).

Checked here: the four kernels against central differences of their first derivatives; the composed term against
tighter Richardson references on the 3D gimbal of skew hinges, the slider-crank on a guide, the slider-crank closed by a
rod, a mass on a skew guide at a flexible arm's tip (along δq) and the gimbal on its slewing base (in t); and a whole
run of the slewing gimbal latching through the CLI and the API with no move of the links at its event (measured in
docs/performance.md, "The links' second derivatives generated (issue 34)")."""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.prepare import prepare
from tests.cli_runs import latdyn_run, summary_of
from tests.test_sensitivities_guides import GUIDE_3D
from tests.test_sensitivities_in_loop_linked2 import CRANK_STOP, GIMBAL_SLEW
from tests.test_sensitivities_rigid_links import CLOSED_SLIDER_CRANK, GIMBAL, SLIDER_CRANK
from tests.test_sensitivities_slewing_latch import SLEWING_HINGE_PD


def _turned(T: np.ndarray, k: int, eps: float) -> np.ndarray:
    from latdyn.numerics.so3 import expm_so3

    return (expm_so3(eps * np.eye(3)[k]) @ T.reshape(3, 3)).ravel()


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_the_wrench_kernels_second_derivatives_against_differences(backend):
    """hinge_wrench_D_q_D_q and slide_wrench_D_q_D_q (random parents, edges, wrenches): ∂(D_q)_i/∂δ′_k by the parent's
    position, its frame's spatial turn (T_p ← exp(skew δπ) T_p) and the wrench's point, at fixed (f, m), against central
    differences of the kernels' own D_q; slider_ / rod_closure_wrench_D_q_D_q (a slider-crank's pin in a turned plane)
    by the pin's position. Step 1e-6; measured ≤ 3.1e-10, 6.7e-11, 6.0e-10, 3.6e-11 of the largest entry (both
    backends alike)."""
    from latdyn.model.kernels import load_kernels

    from test_slider_crank import TURN

    kernels = load_kernels(backend, "default")
    rng = np.random.default_rng(17)
    eps = 1e-6
    for kind in ("hinge_wrench", "slide_wrench"):
        for _ in range(3):
            T = _turned(np.eye(3).ravel(), 0, 0.0)
            for k in range(3):
                T = _turned(T, k, rng.normal())
            parent = np.concatenate([rng.normal(size=3), T])
            axis = rng.normal(size=3)
            edge = np.concatenate([axis / np.linalg.norm(axis), rng.normal(size=3), [rng.choice([-1.0, 1.0])]])
            wrench = rng.normal(size=9)
            first = lambda p, y: getattr(kernels, kind)(p[None], edge[None], y[None])[1][0].ravel()  # noqa: E731
            exact = getattr(kernels, f"{kind}_D_q_D_q")(parent[None], edge[None], wrench[None])[0][0].reshape(9, 9)
            columns = []
            for k in range(9):
                moved = []
                for sign in (1.0, -1.0):
                    p, y = parent.copy(), wrench.copy()
                    if k < 3:
                        p[k] += sign * eps
                    elif k < 6:
                        p[3:12] = _turned(parent[3:12], k - 3, sign * eps)
                    else:
                        y[k - 6] += sign * eps
                    moved.append(first(p, y))
                columns.append((moved[0] - moved[1]) / (2 * eps))
            numeric = np.column_stack(columns)
            assert np.abs(numeric).max() > 0.1, kind
            assert np.abs(exact - numeric).max() <= 1e-7 * np.abs(numeric).max(), kind
    a, b, n = TURN[:, 0], TURN[:, 1], TURN[:, 2]
    closure = np.concatenate([0.4 * a, a, n, [0.3, 1.0, 0.0, 0.0]])
    for kind in ("slider_closure_wrench", "rod_closure_wrench"):
        for _ in range(3):
            pin = 0.1 * (np.cos(rng.uniform(0, 6.3)) * a + np.sin(rng.uniform(0, 6.3)) * b) + 0.01 * rng.normal(size=3)
            wrench = rng.normal(size=6)
            first = lambda p: getattr(kernels, kind)(p[None], closure[None], wrench[None])[1][0].ravel()  # noqa: E731
            exact = getattr(kernels, f"{kind}_D_q_D_q")(pin[None], closure[None], wrench[None])[0][0].reshape(9, 3)
            numeric = np.column_stack([(first(pin + eps * e) - first(pin - eps * e)) / (2 * eps) for e in np.eye(3)])
            assert np.abs(numeric).max() > 0.1, kind
            assert np.abs(exact - numeric).max() <= 1e-7 * np.abs(numeric).max(), kind


def _moving_state(text: str, seed: int):
    """The scene's model at a turned, deformed configuration with random rates and accelerations, its links completed."""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, model = prepared.assembler, prepared.model
    rng = np.random.default_rng(seed)
    n = model.n_dofs
    state = assembler.advance(prepared.state, 0.05 * rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    assembler.complete_links(state)
    return assembler, model, state, rng


def _richardson(term, h: float) -> np.ndarray:
    """Richardson's extrapolation of central differences of ``term`` at steps h, h/2, h/4 (error O(h⁶))."""
    d1, d2, d3 = ((term(s) - term(-s)) / (2 * s) for s in (h, h / 2, h / 4))
    return (16 * (4 * d3 - d2) / 3 - (4 * d2 - d1) / 3) / 15


@pytest.mark.parametrize("text", [GIMBAL, SLIDER_CRANK, CLOSED_SLIDER_CRANK, GUIDE_3D],
                         ids=["3D gimbal of skew hinges", "slider-crank on a guide", "slider-crank closed by a rod",
                              "mass on a skew guide at a flexible arm's tip"])
def test_the_links_second_derivatives_along_the_configuration_are_richardsons(text):
    """``linked_geometric_derivative``'s second part: s ∂/∂q(∂(Pᵀ r)/∂q[w]) δq at fixed r (a generic r: the state's
    r_all plus a random vector, so that every dependent row carries a wrench) — with δv = δv̇ = 0 and r_all's own move
    taken out (its geometric term of K δq_all + M ∂(J a + c)/∂q δq + C ∂(J v)/∂q δq, exact before) — against
    Richardson-extrapolated central differences of the geometric term of the fixed r at the moved configurations, the
    links completed there (steps 2e-4, 1e-4, 5e-5). Measured 5.1e-13 – 4.7e-12 of the term's largest entry (the
    reference's round-off; the 10be92c difference 1.5e-12 – 2.8e-12 at another draw), and the event's derivative
    takes no move of the configuration (10be92c: four per column)."""
    from latdyn.analyses import weight_derivative as wd

    assembler, model, state, rng = _moving_state(text, 7)
    n = model.n_dofs
    ev = assembler.evaluate(state, matrices=True, inertia_tangent=True)
    r = ev.assembled_residual
    w, dq = rng.normal(size=n), rng.normal(size=(n, 1))
    moves = []
    original = assembler.advance
    assembler.advance = lambda *args, **kw: moves.append(1) or original(*args, **kw)
    try:
        both = wd.linked_geometric_derivative(assembler, state, w, dq, 1.0, None)[:, 0]
    finally:
        del assembler.advance
    assert moves == []   # no difference: the links' second derivatives are generated

    K_all, C_all, M_all = (ev.combined_before_reduction(*c, True)
                           for c in ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)))
    by_velocity, by_acceleration = ev.rates_tangent
    dq_all, dv_all, da_all = (np.asarray(ev.projection @ dq[:, 0]).reshape(-1), np.zeros(len(r)), np.zeros(len(r)))
    dv_all[ev.dependent_rows] = np.asarray(by_velocity @ dq[:, 0]).reshape(-1)
    da_all[ev.dependent_rows] = np.asarray(by_acceleration @ dq[:, 0]).reshape(-1)
    first = wd.geometric_product(assembler, state, K_all @ dq_all + C_all @ dv_all + M_all @ da_all, w)
    second = both - first

    def term(h):
        moved = assembler.advance(state, h * dq[:, 0])
        assembler.native().complete_links(moved)
        return wd.geometric_product(assembler, moved, r, w)

    reference = _richardson(term, 2e-4 / np.max(np.abs(dq)))
    assembler.native().complete_links(state)
    size = float(np.max(np.abs(reference)))
    if text is CLOSED_SLIDER_CRANK:
        assert size > 0.0
    else:
        assert size > 1.0
    assert np.max(np.abs(second - reference)) <= 1e-10 * size


@pytest.mark.parametrize("text", [GIMBAL_SLEW, SLEWING_HINGE_PD, CRANK_STOP],
                         ids=["gimbal on a slewing base", "the same with a PD on its latching hinge",
                              "a swing on a crank of prescribed angle"])
def test_the_links_second_derivatives_in_time_are_richardsons(text):
    """``linked_geometric_rate_in_time``: ∂/∂t(∂(Pᵀ y)/∂q[w]) at fixed y and free coordinates along the prescribed
    base's rotation and translation (their exact rates, PrescribedRates.rates) against Richardson-extrapolated central
    differences in t of the geometric term at the prescribed coordinates moved to their laws (steps 2e-4, 1e-4, 5e-5
    over the largest rate): a prescribed base's rotation and translation, a prescribed hinge's angle (the crank). Measured
    6.4e-12, 2.7e-12, 3.1e-12 of the term's largest (the reference's round-off; the 10be92c difference, which took the
    motions' values and four moves in t, 2.5e-12 on the crank, 4.0e-12 on the first at another draw), and no move
    in t."""
    from latdyn.analyses.prescribed_rates import PrescribedRates
    from latdyn.analyses.weight_derivative import geometric_product, linked_geometric_rate_in_time

    assembler, model, state, rng = _moving_state(text, 11)
    state.t = 0.37
    assembler.apply_prescribed(state, state.t)
    assembler.complete_links(state)
    y = assembler.evaluate(state, matrices=True).assembled_residual + rng.normal(size=model.n_assembled)
    w = rng.normal(size=model.n_dofs)
    motions = PrescribedRates(SimpleNamespace(model=model, assembler=assembler))
    rates = motions.rates(state.t)[0]
    moves = []
    original = assembler.apply_prescribed
    assembler.apply_prescribed = lambda *args, **kw: moves.append(1) or original(*args, **kw)
    try:
        exact = linked_geometric_rate_in_time(assembler, state, y, w, rates)
    finally:
        del assembler.apply_prescribed
    assert moves == []   # no difference in t: generated

    def term(h):
        moved = state.copy()
        assembler.apply_prescribed(moved, state.t + h)
        return geometric_product(assembler, moved, y, w)

    reference = _richardson(term, 2e-4 / np.max(np.abs(motions.values(state.t)[0])))
    assembler.complete_links(state)
    size = float(np.max(np.abs(reference)))
    assert size > 0.1
    assert np.max(np.abs(exact - reference)) <= 1e-10 * size


def test_the_slewing_gimbal_latching_through_the_cli_and_the_api_moves_no_link_at_its_event(tmp_path, monkeypatch):
    """The gimbal with a PD on its latching hinge on its slewing base through ``latdyn run`` and ``latdyn.run``: the
    same event sensitivities, and at the latch the weight's derivative (both its parts of the links' second
    derivatives, along the configuration and in t, each called) moves neither the free coordinates nor the
    prescribed ones (10be92c: four moves each per column; its sensitivities against Richardson differences of whole
    runs: tests/test_sensitivities_slewing_latch.py, 7.2e-9 by m before and after)."""
    from latdyn.analyses import transient_sensitivities as ts
    from latdyn.assembly.assembler import Assembler

    run, out = latdyn_run(tmp_path, SLEWING_HINGE_PD, quiet=True)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert [e["kind"] for e in summary["events"]] == ["latch"]
    moves, calls = [], []

    def counted(name):
        original = getattr(Assembler, name)
        monkeypatch.setattr(Assembler, name, lambda self, *a, **k: moves.append((inside[0], name)) or
                            original(self, *a, **k))

    inside = [None]

    def watched(name):
        original = getattr(ts, name)

        def call(*args, **kwargs):
            inside[0] = name
            try:
                out = original(*args, **kwargs)
            finally:
                inside[0] = None
            calls.append((name, float(np.max(np.abs(out)))))
            return out

        monkeypatch.setattr(ts, name, call)

    for name in ("advance", "apply_prescribed"):
        counted(name)
    for name in ("linked_geometric_derivative", "linked_geometric_rate_in_time"):
        watched(name)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(SLEWING_HINGE_PD)))
    assert json.loads(json.dumps(result.summary["event_sensitivities"])) == summary["event_sensitivities"]
    assert {name for name, size in calls if size > 0.0} == {"linked_geometric_derivative",
                                                            "linked_geometric_rate_in_time"}
    assert [m for m in moves if m[0] is not None] == []
