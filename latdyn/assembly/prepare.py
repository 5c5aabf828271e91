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
    _refuse_joint_laws_not_finite_at_start(scene, model, state)
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


def _refuse_joint_laws_not_finite_at_start(scene, model: Model, state: State) -> None:
    """A hinge's or guide's law (``stiffness``, ``damping``, ``torque`` or a guide's ``force``) whose value or slope
    ∂f/∂θ or ∂f/∂θ̇ is not finite at the joint's start (θ_0, θ̇_0, t = 0) is refused, SceneError naming its key: the
    slopes are the joint's entries of K and C in every step's iteration matrix, and of the check below of what holds
    the coordinates (an infinite one ended in "internal error: LinAlgError: Eigenvalues did not converge" there, with
    or without solve.sensitivities: ``torque: "k*sqrt(abs(theta))"`` at θ_0 = 0, tests/test_read_mends.py). A law's
    value is checked finite at θ = θ̇ = t = 0 where it is parsed (:class:`latdyn.scene.expressions.HingeLaw`); its
    slopes here, at the joint's own start."""
    from latdyn.errors import SceneError

    for j, joint in enumerate(model.hinges):
        theta, rate = float(state.theta[j]), float(state.theta_dot[j])
        prefix = f"bodies.{joint.beam}.guide" if joint.kind == "guide" else f"beams.{joint.beam}.{joint.end}.hinge"
        driving, angle, rate_name = ("force", "s", "s_dot") if joint.kind == "guide" else ("torque", "theta",
                                                                                         "theta_dot")
        for name, law in (("stiffness", joint.stiffness), ("damping", joint.damping), (driving, joint.torque)):
            if law is None:
                continue
            bad = []
            for what, at in (("its value", law.value), (f"its slope in {angle}", law.d_theta),
                             (f"its slope in {rate_name}", law.d_rate)):
                try:
                    value = at(theta, rate, 0.0)
                except (ArithmeticError, TypeError, ValueError) as exc:   # Python's 0.0 ** -(2/3)
                    bad.append(f"{what} not a number ({type(exc).__name__}: {exc})")
                    continue
                if not np.isfinite(value):
                    bad.append(f"{what} {value}")
            if bad:
                raise SceneError(scene.file, f"{prefix}.{name}",
                                 f"expected a law finite, with finite slopes in {angle} and {rate_name}, at the joint's "
                                 f"start ({angle} = {theta:g}, {rate_name} = {rate:g}, t = 0: they are its stiffness and "
                                 f"damping in every step's matrix), got {law.source!r} with " + ", ".join(bad)
                                 + " there")


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
