"""The relative equilibrium of a steady spin that a scene's initial configuration leads to.

SCENE.md, "Linearisation", ``about: steady``; docs/linearisation.md, "The steady state".  Every
prescribed body turns about one axis at one constant rate Ω; in the frame turning with it a
relative equilibrium is a configuration q at which r(q, v(q), v̇(q)) = 0 with the spin imposed
(v = Ω×(x − p), ω = Ω, v̇ = Ω×Ω×(x − p)): gravity, loads and the centrifugal forces balance.
Its Jacobian is the stiffness K of the linearisation in the spinning frame
(:func:`latdyn.analyses.linearisation.linearise`).

A spinning structure can have several relative equilibria (a rod hinged to a vertical shaft:
hanging, upright, and above the speed Ω_c² = 3g/2L the two cones cos φ = 3g/2LΩ²).  Newton
from the initial configuration converges to whichever its basin gives — from 45° on a shaft
above Ω_c that was the hanging rod, unstable at that speed (issue 30, item 2).  The search here
is instead a continuation in pseudo-time from the initial configuration (Kelley & Keyes 1998,
"pseudo-transient continuation"): the steps

    (K + σ M) Δq = −r,     |Δq| ≤ MAX_STEP (radians, or fractions of the scene's size ℓ)

are those of a heavily damped motion in the spinning frame, σ ≥ 0 the smallest shift (0 or
σ₀·2ᵏ) that makes the symmetric part of K + σM positive definite.  Where K is positive definite
(near a stable equilibrium) σ = 0 and the step is Newton's, quadratic; where it is not (near a
hanging rod above Ω_c) the step still goes downhill, away from the unstable equilibrium.  The
path so followed leads from the initial configuration to the equilibrium that a damped start
from it settles in: the side of a pitchfork is the start's, a fold is passed because no branch in
the spin rate is followed.  Continuation in the spin rate from rest cannot do this (at rest with
gravity every start hangs, and the hanging branch goes on through Ω_c); it is the fallback
(Ω² ramped in ``solve.steps`` stages, each a descent from the last) when the descent does not
converge in ``max_iter`` (200) steps, and then the run says so.

The state found is then judged by its modes (:func:`stability`): a root with a positive real
part (divergence, flutter) makes it unstable; ``summary.json`` ``steady_state`` and a warning on
stderr say so, as they say when the state was found by the fallback (not necessarily the one
the start leads to).  An exact start on an unstable equilibrium (a rod hanging exactly) stays
there: the residual is zero; it is reported, unstable.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latdyn.analyses.linearisation import Frame, linearise
from latdyn.assembly.factorization import solve_linear
from latdyn.assembly.prepare import length_scale
from latdyn.errors import SceneError, SolverError
from latdyn.step.integrators import increment_size

#: The largest step of the descent: radians of rotation, or fractions of the scene's size ℓ.
MAX_STEP = 0.1
#: Doublings of the shift σ tried before the descent gives up making K + σM positive definite.
SHIFT_DOUBLINGS = 80
#: A warning's words for an unstable relative equilibrium.
UNSTABLE = ("the relative equilibrium of the steady spin (about: steady) is unstable: a root of its "
            "modes has real part {growth:.4g} 1/s (a divergent or flutter mode, damping ratio < 0); "
            "the structure does not stay in it, and the modes are those of a state it leaves")
FALLBACK = ("the relative equilibrium of the steady spin (about: steady) was found by ramping the spin "
            "rate from the initial configuration, not by the descent from it ({why}): it may not be "
            "the one the initial configuration leads to")


@dataclass
class SteadySearch:
    """How the relative equilibrium was found and how far it lies from the initial configuration."""

    iterations: int
    found_by: str  # "descent" or "spin-rate ramp"
    largest_displacement: float  # the largest translation of a free node or guide slide from t = 0, length units
    largest_rotation: float  # the largest rotation of a node's frame or a hinge angle from t = 0, rad
    fallback_reason: str | None = None


def spin_of(prepared):
    """Ω and a point p of the axis of the scene's steady rotation (SCENE.md: prescribed rotations
    at constant rate), refusing scenes that have none or other prescribed motion."""
    from latdyn.model.model import PRESCRIBED

    scene, model = prepared.scene, prepared.model
    key = "solve.about"
    omega, point = None, None
    for node in model.nodes:
        if node.kind != PRESCRIBED:
            continue
        body = scene.bodies[node.body]
        if body.translation is not None and any(not g.is_constant for g in body.translation):
            raise SceneError(scene.file, key, f"steady needs rotations only; body {node.body!r} translates")
        if body.rotation_angle is None:
            raise SceneError(scene.file, key, f"steady needs every prescribed body to spin; {node.body!r} does not")
        angle = body.rotation_angle
        rate = angle.rate(0.0)
        if abs(angle.accel(0.0)) > 1e-12 * max(abs(rate), 1.0) or abs(angle.rate(1.0) - rate) > 1e-9 * max(abs(rate), 1):
            raise SceneError(scene.file, key, f"steady needs rotations at constant rate; body {node.body!r} "
                                              "accelerates (its angle is not linear in t)")
        w = body.rotation_axis * rate
        x = np.asarray(node.position, float)
        if omega is None:
            omega, point = w, x
        elif np.abs(w - omega).max() > 1e-12 * max(np.abs(omega).max(), 1.0) or \
                np.linalg.norm(np.cross(x - point, omega)) > 1e-9 * length_scale(model) * max(np.linalg.norm(omega), 1e-300):
            raise SceneError(scene.file, key, "steady needs all prescribed bodies to spin about one axis at one rate")
    for body_name, body in scene.bodies.items():
        if body.fixed and omega is not None and np.any(omega):
            raise SceneError(scene.file, key, f"steady: body {body_name!r} is fixed while others spin")
        if body.guide is not None and body.guide.on is None and omega is not None and np.any(omega):
            raise SceneError(scene.file, key, f"steady: body {body_name!r} slides on a guide on the ground while "
                                              "others spin")
    for hinge in model.hinges:
        if hinge.angle is not None and abs(hinge.angle.rate(0.0)) > 0:
            what = "angle of hinge" if hinge.kind == "hinge" else "position of guide"
            raise SceneError(scene.file, key, f"steady: the prescribed {what} {hinge.name} "
                                              "moves; prescribe the spin on a body instead")
    if omega is None:
        raise SceneError(scene.file, key, "steady needs a body with a prescribed rotation at constant rate "
                                          "(bodies.NAME.motion.rotation)")
    return omega, point


def spin(model, state, omega, point):
    """Set the free nodes on the steady spin: v = Ω×(x − p), ω = Ω, v̇ = Ω×Ω×(x − p), ω̇ = 0."""
    free = model.free_nodes
    r = state.x[free] - point
    state.v[free] = np.cross(omega, r)
    state.w[free] = omega
    state.a[free] = np.cross(omega, np.cross(omega, r))
    state.alpha[free] = 0.0
    state.theta_dot[model.free_hinges] = state.theta_ddot[model.free_hinges] = 0.0
    return state


def _definite_shift(K: np.ndarray, M: np.ndarray) -> float | None:
    """The smallest σ of 0, σ₀, 2σ₀, 4σ₀ … that makes the symmetric part of K + σM positive
    definite (σ₀ = 1e-9 of the largest ratio of their diagonals); None when none does (a
    direction without inertia that nothing holds)."""
    Ks = 0.5 * (K + K.T)
    diag_k, diag_m = np.abs(np.diag(Ks)), np.diag(M)
    massive = diag_m > 0
    top = float(np.max(diag_k[massive] / diag_m[massive], initial=0.0)) if np.any(massive) else 0.0
    sigma, start = 0.0, 1e-9 * max(top, 1e-300)
    for _ in range(SHIFT_DOUBLINGS + 1):
        try:
            np.linalg.cholesky(Ks + sigma * M)
            return sigma
        except np.linalg.LinAlgError:
            sigma = start if sigma == 0.0 else 2.0 * sigma
    return None


def _distance(model, start, state) -> tuple[float, float]:
    """(largest translation of a free node or slide of a free guide, largest rotation of a free
    node's frame or of a free hinge angle) from ``start`` to ``state``: a guide's coordinate is a
    length, a hinge's an angle."""
    free = model.free_nodes
    moved = np.linalg.norm(state.x[free] - start.x[free], axis=1)
    turned = []
    for i in free:
        R = state.T[i] @ start.T[i].T
        turned.append(np.arccos(np.clip(0.5 * (np.trace(R) - 1.0), -1.0, 1.0)))
    joints = np.asarray(model.free_hinges, dtype=int)
    is_guide = np.array([model.hinges[k].kind == "guide" for k in joints], dtype=bool)
    change = np.abs(state.theta[joints] - start.theta[joints])
    return (float(max(np.max(moved, initial=0.0), np.max(change[is_guide], initial=0.0))),
            float(max(np.max(turned, initial=0.0), np.max(change[~is_guide], initial=0.0))))


def steady_state(prepared, tol: float = 1e-10, max_iter: int = 200, stage_iter: int = 40):
    """(prepared, state, frame, :class:`SteadySearch`): the relative equilibrium the initial
    configuration leads to, by the descent of the module docstring at the full rate (at most
    ``max_iter`` steps), else by the spin rate ramped (Ω² in ``solve.steps`` stages, each a
    descent of at most ``stage_iter`` steps from the last)."""

    model, assembler = prepared.model, prepared.assembler
    omega, point = spin_of(prepared)
    length = length_scale(model)
    start = prepared.state.copy()
    assembler.apply_prescribed(start, 0.0)

    def descend(state, rate, limit):
        """(state, iterations, None) at the equilibrium, or (None, iterations, why not)."""
        frame = Frame(rate, np.zeros(3))
        for iteration in range(limit):
            spin(model, state, rate, point)
            residual = assembler.evaluate(state, matrices=False).residual
            lin = linearise(assembler, state, frame)
            shift = _definite_shift(lin.stiffness, lin.mass)
            if shift is None:
                return None, iteration, "no shift makes the tangent positive definite"
            dx = solve_linear(lin.stiffness + shift * lin.mass, -residual)
            if not np.all(np.isfinite(dx)):
                return None, iteration, "a singular tangent"
            size = increment_size(assembler, dx, length)
            if size > MAX_STEP:
                dx *= MAX_STEP / size
            state = assembler.advance(state, dx)
            if size <= tol:
                return spin(model, state, rate, point), iteration + 1, None
        return None, limit, f"no convergence in {limit} steps"

    state, iterations, why = descend(start.copy(), omega, max_iter)
    found_by = "descent"
    if state is None:
        found_by, steps, state = "spin-rate ramp", prepared.scene.solve.steps, start.copy()
        for k in range(1, steps + 1):
            state, its, failure = descend(state, omega * np.sqrt(k / steps), stage_iter)
            iterations += its
            if state is None:
                raise SolverError(f"about: steady: no relative equilibrium found: the descent from the "
                                  f"initial configuration failed ({why}), and so did the ramp of the spin "
                                  f"rate at {np.sqrt(k / steps):.3g} of the rate ({failure})")
    displacement, rotation = _distance(model, start, state)
    return prepared, state, Frame(omega, np.zeros(3)), SteadySearch(iterations, found_by, displacement,
                                                                    rotation, why)


def stability(found) -> dict:
    """``stable`` and ``growth_rate`` (1/s: the largest −ζ·|λ| of the modes — the real part of an
    oscillating pair, the positive root of a divergent one, the mean of the two roots of an
    overdamped pair; rigid-body and conservative pairs read 0) of a list of all the modes about a
    state."""
    growth = max((-m.damping_ratio * 2 * np.pi * m.natural_frequency_hz for m in found), default=0.0)
    return {"stable": bool(all(m.damping_ratio >= 0.0 for m in found)), "growth_rate": float(growth) + 0.0}


def steady_summary(search: SteadySearch, found_all) -> tuple[dict, list[str]]:
    """``summary.json`` ``steady_state`` (docs/linearisation.md) and the warnings of the search."""
    summary = {**stability(found_all), "found_by": search.found_by, "iterations": search.iterations,
               "largest_displacement": search.largest_displacement,
               "largest_rotation": search.largest_rotation}
    warnings = []
    if not summary["stable"]:
        warnings.append(UNSTABLE.format(growth=summary["growth_rate"]))
    if search.found_by != "descent":
        warnings.append(FALLBACK.format(why=search.fallback_reason))
    return summary, warnings
