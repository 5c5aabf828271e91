"""The rigid links' reduction written once: the analyses driven from Python (statics, modes, buckling, impulses,
events: latdyn/assembly/linked.py) reduce an evaluation by the compiled step's own C (csrc/links.c
``assemble_linked_into`` and ``reduce_total``, through csrc/linked_matrices.c), so that the residual and the
stiffness they see are the compiled Newton iteration's, bit for bit.

Before, linked.py reduced in NumPy (Pᵀ K P and its own geometric term), equal to the compiled matrix to round-off
only (tests/test_linked_cables.py measured 1.2e-16 … 2.8e-16 of the largest entry): these tests failed there."""
from __future__ import annotations

import ctypes

import numpy as np
import pytest

import latdyn

from test_linked_cables import LINKED_CABLES, random_moving_state
from test_rigid_native import scene_yaml
from test_slider_crank import rigid_slider_crank

SCENES = {
    # a guided body carrying a rigid link, three damped cables, joint bodies, gravity, loads; in 3D
    "cables on a guided and a linked body": lambda: latdyn.load_scene(scene_yaml(LINKED_CABLES)),
    # a closed loop of rigid links (closure edges: the slider and the rod functions of the pin), a crank torque, weight
    "rigid slider-crank": lambda: latdyn.load_scene(scene_yaml(rigid_slider_crank(
        crank="torque: 0.5", pin_mass=0.5, gravity="gravity: [0.5, -9.81, 0]"))),
}


def compiled_step(assembler, state, inertia: bool, exact: bool):
    """The compiled step's own reduction of the evaluation at ``state`` (``latdyn_iteration_matrix``, β′ = γ′ = 0:
    K): (K dense on the minimum coordinates, the reduced residual)."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha, matrix_pattern
    from latdyn.step.integrators import AlphaParameters

    n = assembler.model.n_dofs
    step = CompiledGeneralizedAlpha(assembler, AlphaParameters.for_method("generalized-alpha", 0.8), 1e-10, 25, 1.0)
    step.inertia_tangent = exact
    step._setup()
    native, factorization = step._native, step.factorization
    native.complete_links(state)
    native.evaluate(state, matrices=True, load_factor=1.0, inertia=inertia, inertia_tangent=exact)
    native.library.latdyn_iteration_matrix(native.model_ref, native.work_ref, ctypes.byref(native.configuration(state)),
                                           0.0, 0.0, int(exact))
    rows, cols = matrix_pattern(assembler)
    K = np.zeros((n, n))
    K[rows, cols] = factorization.values[factorization.position(rows, cols)]
    return K, native.buffers["total"][:n].copy()


@pytest.mark.parametrize("name", sorted(SCENES))
@pytest.mark.parametrize("inertia, exact", [(False, False), (True, False), (True, True)],
                         ids=["static", "with inertia", "the exact K"])
def test_python_sees_the_compiled_step_s_residual_and_stiffness(name, inertia, exact):
    """At a random moving state (every cable taut, the crank turned): the residual and K of the evaluation that the
    analyses driven from Python make (``evaluate_linked``; static, with inertia, and with the inertia tangent and the
    dependent rates' term, without the joint bodies' inertia stiffness, which the step does not add) equal the
    compiled step's at β′ = γ′ = 0, bit for bit; and K holds a geometric term (the test could see one left out)."""
    from latdyn.assembly.linked import evaluate_linked, reduce_linked
    from latdyn.assembly.prepare import prepare

    prepared = prepare(SCENES[name]())
    model, assembler = prepared.model, prepared.assembler
    state = random_moving_state(prepared, 5)
    if exact:  # reduce_linked: the evaluation just made, without the joint bodies' inertia stiffness
        assembler.native(True)
        evaluate_linked(model.links, assembler, state, True, 1.0, True, True)   # the storage held, the links laid out
        assembler.complete_links(state)
        full = assembler.evaluate_assembled(state, True, 1.0, True, True)
        python = reduce_linked(model.links, assembler, state, full, True, True, rates_term=True, inertia_tangent=True)
    else:
        python = evaluate_linked(model.links, assembler, state, True, 1.0, inertia)
    K = np.asarray(python.combined(0.0, 0.0, 1.0, dense=True))
    residual = python.residual.copy()
    geometric = np.asarray(python.geometric)
    compiled, compiled_residual = compiled_step(assembler, state, inertia, exact)
    assert np.array_equal(K, compiled)
    assert np.array_equal(residual, compiled_residual)
    assert np.abs(geometric).max() > 1e-3 * np.abs(K).max()
