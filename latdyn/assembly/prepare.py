"""A run prepared: the scene validated, its model built, the kernels loaded, the initial state,
and coordinates that nothing holds refused (SCENE.md)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latdyn.assembly.assembler import Assembler, State
from latdyn.assembly.factorization import Factorization
from latdyn.model.kernels import load_kernels
from latdyn.model.model import Model
from latdyn.numerics.linalg import DENSE_LIMIT, RCM_IN_PYTHON
from latdyn.scene.loader import Scene, load_scene


@dataclass
class Prepared:
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
    return Prepared(scene, model, assembler, state)


def length_scale(model: Model) -> float:
    """The size ℓ of the scene: twice the largest distance of a node from the centroid
    (invariant under rigid motions, unlike extents along the global axes)."""
    points = np.array([n.position for n in model.nodes]).reshape(-1, 3)
    if len(points) == 0:
        return 1.0
    span = 2.0 * float(np.max(np.linalg.norm(points - points.mean(axis=0), axis=1)))
    return max(span, 1e-3)
