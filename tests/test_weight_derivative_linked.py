"""The impulse weight's derivative on models with rigid links and guides (latdyn/analyses/weight_derivative.py,
"Rigid links and guides"; docs/parameters.md, "The impulse weight's derivative"): the generated blocks' part
∂(Pᵀ W_gen P w)/∂q δq (the generated elements', joint bodies' and hinges' H on the assembled coordinates, the
reduction's geometric term of W_gen P w, the links' ∂(J w)/∂q) and the geometric term's s ∂(Pᵀ r_all)/∂q[w] moved
along the configuration and the rates against Richardson-extrapolated central differences on a 3D gimbal of skew
hinges, a slider-crank on a guide and one closed by a rigid rod (closure edges); and the whole
∂(W w)/∂q δq at the events of YAML scenes run through the API (the gimbal latching and bouncing, the slider-crank
between its stops, a swing on a prescribed crank), against Richardson-extrapolated differences of the reduced
W w, closer than the single central difference of W w that it replaces (measured in docs/performance.md, "The impulse weight's
derivative on linked models exact (issue 34)")."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.prepare import prepare
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_in_loop_linked2 import CRANK_STOP
from tests.test_sensitivities_rigid_links import CLOSED_SLIDER_CRANK, GIMBAL, LATCH, SLIDER_CRANK, STOP


def _generated_product(assembler, state, w, scale, mass):
    """Pᵀ W_gen P w at ``state`` (the part whose derivative is exact)."""
    from latdyn.analyses.weight_derivative import _linked_weight, exact_hinges

    ev = assembler.evaluate(state, matrices=True)
    W_gen = _linked_weight(assembler, ev, scale, mass, exact_hinges(assembler), generated=True)
    P = ev.projection
    return np.asarray(P.T @ (W_gen @ np.asarray(P @ w))).reshape(-1)


def turned_state(text: str, seed: int, size: float) -> tuple:
    """(assembler, state, the random generator after its draws): the scene's initial state turned and deformed by
    ``size`` times a normal draw on every free coordinate, with normal rates and accelerations, the links completed."""
    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, model = prepared.assembler, prepared.model
    rng = np.random.default_rng(seed)
    n = model.n_dofs
    state = assembler.advance(prepared.state, size * rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    assembler.complete_links(state)
    return assembler, state, rng


@pytest.mark.parametrize("text", [GIMBAL, SLIDER_CRANK, CLOSED_SLIDER_CRANK],
                         ids=["3D gimbal of skew hinges", "slider-crank on a guide", "slider-crank closed by a rod"])
def test_the_exact_part_is_the_richardson_difference_of_the_generated_product(text):
    """∂(Pᵀ W_gen P w)/∂q δq (``linked_configuration_tangent``) at a turned, deformed state with random rates, random
    w and δq, W = M + 1e-4 K and W = K, against Richardson-extrapolated central differences of Pᵀ W_gen P w along δq
    (measured 2e-13 – 5e-11; 6e-12 – 1.4e-11 at the events of the gimbal and the slider-crank)."""
    from latdyn.analyses.weight_derivative import linked_configuration_tangent

    assembler, state, rng = turned_state(text, 3, 0.05)
    n = assembler.model.n_dofs
    compared = []
    for mass, scale in ((True, 1e-4), (False, 1.0)):
        w, dq = rng.normal(size=n), rng.normal(size=(n, 1))
        exact = linked_configuration_tangent(assembler, state, w, dq, scale, mass)[:, 0]

        def central(h):
            ahead, behind = (_generated_product(assembler, assembler.advance(state, s * h * dq[:, 0]), w, scale, mass)
                             for s in (1.0, -1.0))
            return (ahead - behind) / (2 * h)

        d1, d2, d3 = central(4e-4), central(2e-4), central(1e-4)
        reference = (16 * (4 * d3 - d2) / 3 - (4 * d2 - d1) / 3) / 15
        compared.append(float(np.max(np.abs(reference))))
        assert np.max(np.abs(exact - reference)) <= 1e-9 * compared[-1]
    assert max(compared) > 0.0   # the closed slider-crank's rigid rod: no element, no K of its own (W = K: 0)


def _reference(owner, state, w, dq, scale, mass, rates):
    """Richardson-extrapolated central differences (steps 400, 200, 100 × the package's: the differences of W w are
    round-off below, 9e-8 of H δq at 4, 2, 1 × on the slider-crank) of the reduced W w along each
    column's move (δq, the free rates along δv, δv̇: ``TransientSensitivities._linked_move``), as the package took
    ∂(W w)/∂q δq before its generated part was exact."""
    model, assembler = owner.model, owner.assembler
    out = np.zeros((model.n_dofs, dq.shape[1]))

    def product(eta, c):
        moved = owner._linked_move(state, dq, rates, c, eta)
        return np.asarray(assembler.evaluate(moved, matrices=True).combined(1.0 if mass else 0.0, 0.0, scale) @ w)

    for c in range(dq.shape[1]):
        step = owner._linked_move_step(dq, rates, c)
        if step is None:
            continue
        d1, d2, d3 = ((product(h, c) - product(-h, c)) / (2 * h) for h in (400 * step, 200 * step, 100 * step))
        out[:, c] = (16 * (4 * d3 - d2) / 3 - (4 * d2 - d1) / 3) / 15
    return out


def checked_against_the_reference(monkeypatch) -> list:
    """``TransientSensitivities._linked_weight_derivative`` patched to compare each call's result with
    :func:`_reference` at the same arguments (its result unchanged): the list each call's error goes into (relative
    to the reference's largest; none where the reference is 0)."""
    method = TransientSensitivities._linked_weight_derivative
    errors = []

    def checked(self, state, w, dq, scale, mass, rates):
        out = method(self, state, w, dq, scale, mass, rates)
        reference = _reference(self, state, w, dq, scale, mass, rates)
        size = float(np.max(np.abs(reference)))
        if size > 0.0:
            errors.append(float(np.max(np.abs(out - reference))) / size)
        return out

    monkeypatch.setattr(TransientSensitivities, "_linked_weight_derivative", checked)
    return errors


#: scene, the events, and the largest error of ∂(W w)/∂q δq at its events relative to the largest |∂(W w)/∂q δq|
#: asserted: measured 1.3e-12, 1.3e-11, 6.4e-10, 2.0e-8 (the last at a restart after a stop, δq = 0: the rates' move
#: alone; the reference's own error there, 2.0e-8 against steps 100 × the package's, 8.6e-9 against 300 ×); the single
#: central difference of W w it replaced (6cda559): 1.7e-10, 1.2e-9, 6.8e-8, 1.3e-6
EVENTS = {"the gimbal latching": (LATCH, ["latch"], 1e-11),
          "the gimbal bouncing on a stop": (STOP, ["stop", "stop"], 5e-11),
          "the slider-crank between its stops": (SLIDER_CRANK, ["stop", "stop"], 3e-9),
          "a swing on a prescribed crank": (CRANK_STOP, ["stop", "stop"], 1e-7)}


@pytest.mark.parametrize("name", list(EVENTS))
def test_the_weight_derivative_at_linked_events_agrees_with_richardson_closer_than_one_difference(name, monkeypatch):
    """At every event of the scene (through the API), the package's ∂(W w)/∂q δq against the test's
    Richardson-extrapolated differences of the reduced W w: within the tolerance of :data:`EVENTS`, which the
    single central difference of W w (6cda559) exceeded."""
    text, events, tolerance = EVENTS[name]
    errors = checked_against_the_reference(monkeypatch)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert [e["kind"] for e in result.summary["events"]] == events
    assert errors and max(errors) < tolerance, errors


@pytest.mark.parametrize("text", [GIMBAL, SLIDER_CRANK, CLOSED_SLIDER_CRANK],
                         ids=["3D gimbal of skew hinges", "slider-crank on a guide", "slider-crank closed by a rod"])
def test_the_geometric_terms_derivative_is_the_richardson_difference_along_configuration_and_rates(text):
    """s ∂(Pᵀ r_all)/∂q[w] moved along (δq, δv, δv̇) (``linked_geometric_derivative``: r_all's move exact, the links'
    second derivatives a Richardson difference of the links alone) at a turned, deformed state with random rates and
    accelerations, against Richardson-extrapolated central differences of the geometric term of each moved state's
    own r_all (closure edges on the closed slider-crank); measured 5.2e-14, 1.6e-14, 1.6e-12."""
    from latdyn.analyses.weight_derivative import geometric_product, linked_geometric_derivative

    prepared = prepare(latdyn.load_scene(yaml.safe_load(text)))
    assembler, model = prepared.assembler, prepared.model
    rng = np.random.default_rng(5)
    n = model.n_dofs
    state = assembler.advance(prepared.state, 0.05 * rng.normal(size=n))
    v, a = rng.normal(size=n), rng.normal(size=n)
    unpack_free(model, v, state.v, state.w, state.theta_dot)
    unpack_free(model, a, state.a, state.alpha, state.theta_ddot)
    assembler.complete_links(state)
    w, dq, dv, dvdot = (rng.normal(size=(n, 1)) for _ in range(4))
    exact = linked_geometric_derivative(assembler, state, w[:, 0], dq, 1.0, (dv, dvdot))[:, 0]

    def term(h):
        moved = assembler.advance(state, h * dq[:, 0])
        unpack_free(model, v + h * dv[:, 0], moved.v, moved.w, moved.theta_dot)
        unpack_free(model, a + h * dvdot[:, 0], moved.a, moved.alpha, moved.theta_ddot)
        ev = assembler.evaluate(moved, matrices=True)   # the links completed at the moved state
        return geometric_product(assembler, moved, ev.assembled_residual, w[:, 0])

    d1, d2, d3 = ((term(h) - term(-h)) / (2 * h) for h in (4e-4, 2e-4, 1e-4))
    reference = (16 * (4 * d3 - d2) / 3 - (4 * d2 - d1) / 3) / 15
    assert np.max(np.abs(reference)) > 0.0
    assert np.max(np.abs(exact - reference)) <= 1e-10 * np.max(np.abs(reference))


def test_the_gimbal_bouncing_through_the_cli_writes_the_apis_sensitivities_loop_on_and_off(tmp_path):
    """A guard (it passes on 6cda559 too: the events take the Python path on both sides of the loop's switch): the 3D
    gimbal bouncing twice on its inner ring's stop through ``latdyn run`` — steps in the loop, the loop off writing the
    same files byte for byte (and the same event sensitivities), the API's event sensitivities the CLI's."""
    run, out = latdyn_run(tmp_path, STOP, quiet=True)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] > 0 and [e["kind"] for e in summary["events"]] == ["stop", "stop"]
    the_loop_off_writes_the_same(tmp_path, out)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(STOP)))
    assert json.loads(json.dumps(result.summary["event_sensitivities"])) == summary["event_sensitivities"]
