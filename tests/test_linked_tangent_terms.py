"""What the reduced (linked) stiffness K = ∂r/∂q leaves out, decided by a step-size study of central
differences: a term the matrix misses does not shrink with the step, differences' truncation error
shrinks as h² (then round-off grows as 1/h).

The flexible slider-crank of examples/slider_crank.yaml (a rigid crank, a flexible rod of four
elements, a guided slider) in motion: the reduction of the Newton matrix (without the elements'
inertia tangent, which the time step's matrix leaves out by design: latdyn.step.integrators) is off by
a constant 2.5 of 2.7e8 (1e-8 relative) at every step below 1e-6: a real term, the elements' inertia
tangent; with it (``inertia_tangent=True``) the reduction equals the differences to their
truncation error (∝ h²) — no other term is missing there. (Its dependent nodes, the crank's pin and the
slider on a ground guide, have no J that moves with q. Where a dependent node's frame moves with the
coordinates — a guide on a free body, a link off a moving one — J v and J a + c(v) change with q at
fixed rates: tests/test_linked_cables.py compares K at rest for that reason.)"""
from __future__ import annotations

import numpy as np

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
