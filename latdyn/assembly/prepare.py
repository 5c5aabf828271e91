"""A run prepared: the scene validated, its model built, the kernels loaded, the initial state,
and coordinates that nothing holds refused (SCENE.md)."""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import Assembler, State
from latdyn.assembly.factorization import Factorization
from latdyn.model.kernels import load_kernels
from latdyn.model.model import Model
from latdyn.numerics.linalg import DENSE_LIMIT, RCM_IN_PYTHON
from latdyn.records import record
from latdyn.scene.loader import Scene, load_scene


@record
class Prepared:
    """What :func:`prepare` makes of a scene: the scene, its model, the assembler and the initial state."""

    scene: Scene
    model: Model
    assembler: Assembler
    state: State


def prepare(scene, backend: str = "auto") -> Prepared:
    """Validate, build the model and refuse coordinates that nothing holds."""
    scene = load_scene(scene)
    model = Model.from_scene(scene)
    kernels = load_kernels(backend=backend, variant=model.kernel_variant)
    assembler = Assembler(model, kernels, scene.gravity)
    state = assembler.initial_state()
    if model.n_dofs > 0:  # any size: inverse iterations on one sparse LU, or a dense eigenproblem (Model.check_held)
        at_rest = state.copy()
        at_rest.v[:] = at_rest.w[:] = 0.0
        at_rest.theta_dot[:] = 0.0
        # at rest without acceleration (K does not depend on it, but with rigid links the geometric
        # term ∂Jᵀ/∂q · r would carry the inertia forces of prescribed accelerations)
        at_rest.a[:] = at_rest.alpha[:] = 0.0
        at_rest.theta_ddot[:] = 0.0
        # material stiffness only: load terms (gravity, follower moments; with rigid links the forces at
        # the dependent nodes through ∂(Pᵀ)/∂q, which a pretensioned cable makes indefinite) hold nothing
        ev = assembler.evaluate(at_rest, matrices=True, load_factor=0.0)
        # dense where the dense LU serves the model (as the step assembles it), else sparse: without
        # SciPy (numerics.csr) where the step needs none (a band LU ordered in Python, no rigid links)
        if model.links is None and DENSE_LIMIT < model.n_assembled <= RCM_IN_PYTHON:
            model.check_held(ev.combined_csr(1.0, 0.0, 0.0), ev.combined_csr(0.0, 0.0, 1.0), scene.file, Factorization)
        else:
            material = {"geometric_term": False} if model.links is not None else {}
            model.check_held(ev.combined(1.0, 0.0, 0.0), ev.combined(0.0, 0.0, 1.0, **material), scene.file,
                             Factorization)
    if scene.solve.analysis == "transient" and model.cables is not None:
        _refuse_unbalanced_free_ends(scene, model, assembler, state)
    return Prepared(scene, model, assembler, state)


def _refuse_unbalanced_free_ends(scene, model: Model, assembler: Assembler, state: State) -> None:
    """A transient run whose massless cable pulls its free end at t = 0 with nothing to balance it is
    refused (exit 2 naming the cable's ``rest_length``): the end has no inertia, so the first step would
    snap it to the rest length and lose the pretension's energy (:func:`latdyn.model.cables.unbalanced_free_ends`;
    docs/cables.md)."""
    from latdyn.errors import SceneError
    from latdyn.model.cables import BALANCE, unbalanced_free_ends

    pulled = assembler.evaluate(state, matrices=False, inertia=False, load_factor=0.0).residual
    total = assembler.evaluate(state, matrices=False, inertia=False, load_factor=1.0).residual
    for name, point, pull, left in unbalanced_free_ends(model, pulled, total):
        raise SceneError(scene.file, f"cables.{name}.rest_length",
                         f"expected the free end {point} of the massless cable in equilibrium at t = 0 (it has no "
                         "mass: a force left on it snaps it within the first step, and the pretension's energy is "
                         f"lost); the cable pulls it with {pull:.6g} N (a rest length shorter than its length) and "
                         f"{left:.6g} N of that is not balanced by loads there (more than {BALANCE:g} of it): give a "
                         f"rest length equal to the initial distance of its ends, a load at {point} that balances "
                         "the pull, a mass per length (rhoA > 0), or end it at a body ({body: NAME}) (docs/cables.md)")


def length_scale(model: Model) -> float:
    """The size ℓ of the scene: twice the largest distance of a node from the centroid
    (invariant under rigid motions, unlike extents along the global axes)."""
    points = np.array([n.position for n in model.nodes]).reshape(-1, 3)
    if len(points) == 0:
        return 1.0
    span = 2.0 * float(np.max(np.linalg.norm(points - points.mean(axis=0), axis=1)))
    return max(span, 1e-3)
