"""Events of the time loop: hinges that latch at ``lock_at`` and impacts on hinge stops, the
fraction of a step at which the first one happens (the loop shortens the step onto it)."""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import State, free_velocity, pack, unpack_free
from latdyn.assembly.factorization import solve_linear
from latdyn.assembly.prepare import Prepared
from latdyn.model.model import Model


def lock_tolerance(lock: float) -> float:
    return 1e-7 * max(1.0, abs(lock))


def lock_events(model: Model, old: State, new: State) -> tuple[list[int], list[tuple[int, float]]]:
    """Free hinges with a lock_at, over the step old → new: those that reach it (started on
    it, or ended within tolerance), and those that cross it with the fraction of the step
    at the crossing (linear interpolation of the angle)."""
    reached, crossing = [], []
    for k in model.free_hinges:
        lock = model.hinges[k].lock_at
        if lock is None:
            continue
        before, after = old.theta[k] - lock, new.theta[k] - lock
        if before == 0.0 or abs(after) <= lock_tolerance(lock):
            reached.append(k)
        elif before * after < 0.0:
            crossing.append((k, before / (before - after)))
    return reached, crossing


def crossing_fraction(model: Model, old: State, new: State) -> float | None:
    """The fraction of the step at which the first hinge crosses its lock_at or a stop, or None."""
    _, crossing = lock_events(model, old, new)
    fractions = [f for _, f in crossing] + [f for _, _, f in stop_crossings(model, old, new)]
    return min(fractions) if fractions else None


# ----------------------------------------------------------------------------- hard stops
# Hinge ``limits: [lo, hi]`` with ``restitution`` e are events, like lock_at: a step in which
# a hinge crosses a stop from inside is shortened to land on it (secant on the angle, as for
# latches); then, for every free hinge on or beyond a stop and moving into it, the
# configuration is projected onto the stop, Δq = −A⁻¹N μ with Nᵀ(q + Δq) = stop, and the
# velocities jump so that the hinge rate reverses, θ̇⁺ = −e θ̇⁻ (Newton's impact law), by the
# impulsive projection that conserves momentum, v⁺ = v⁻ − A⁻¹N λ, Nᵀv⁺ = −e Nᵀv⁻, A = M + dt²K (M alone may be singular; directions
# without inertia and modes faster than the nominal step dt take the impact quasi-statically,
# as in the integrator's own iteration matrix); the hinge's acceleration is set to zero. A hinge pushed against its stop (e = 0, or a load that holds it there) ends
# each step slightly beyond it and is put back with θ̇ = 0: a unilateral constraint enforced
# by projection at the end of every step, released by itself as soon as the load pulls away.
# Events rather than a penalty: exact landing on the stop and no contact stiffness that the
# step would have to resolve; rather than a complementarity solve inside Newton: the time
# step (shared with the compiled step of solve.py) stays as it is.
def stop_crossings(model: Model, old: State, new: State) -> list[tuple[int, int, float]]:
    """(hinge, side, fraction of the step) for free hinges that crossed a stop from inside during the
    step (side −1 lower, +1 upper), the angle interpolated linearly."""
    out = []
    for k in model.free_hinges:
        limits = model.hinges[k].limits
        if limits is None:
            continue
        for side, stop in ((-1, limits[0]), (1, limits[1])):
            before, after = side * (old.theta[k] - stop), side * (new.theta[k] - stop)  # > 0: beyond
            if before < -lock_tolerance(stop) and after > lock_tolerance(stop):
                out.append((int(k), side, before / (before - after)))
    return out


def hinge_stops(prepared: Prepared, integrator, new: State) -> bool:
    """Impacts on hinge stops at the end of an accepted step (see above); True when any."""
    model, assembler = prepared.model, prepared.assembler
    hits, stops = [], []
    for k in model.free_hinges:
        limits = model.hinges[k].limits
        if limits is None:
            continue
        for side, stop in ((-1, limits[0]), (1, limits[1])):
            if side * (new.theta[k] - stop) >= -lock_tolerance(stop) and side * new.theta_dot[k] >= 0.0:
                hits.append(int(k))
                stops.append(stop)
    if not hits:
        return False
    dt = prepared.scene.solve.dt
    target = -np.array([model.hinges[k].restitution for k in hits]) * new.theta_dot[hits]
    A = assembler.evaluate(new, matrices=True).combined(1.0, 0.0, dt * dt)
    N = np.zeros((model.n_dofs, len(hits)))
    N[model.hinge_dofs[hits], np.arange(len(hits))] = 1.0
    AiN = solve_linear(A, N)
    NtAiN = N.T @ AiN
    # the same projection onto the stops for the configuration: what is rigid at the scale of
    # the step moves with the hinge, so that no strain is made
    moved = assembler.advance(new, -AiN @ solve_linear(NtAiN, new.theta[hits] - np.array(stops)))
    for name in ("x", "T", "theta"):  # in place: the compiled step may view this state's arrays
        np.copyto(getattr(new, name), getattr(moved, name))
    new.theta[hits] = stops
    v = free_velocity(model, new)
    unpack_free(model, v - AiN @ solve_linear(NtAiN, N.T @ v - target), new.v, new.w, new.theta_dot)
    # the hinge's acceleration into the stop ends with the impact
    if getattr(integrator, "a", None) is not None:  # the explicit step keeps no algorithmic acceleration
        integrator.a[model.hinge_dofs[hits]] = 0.0
    new.theta_ddot[hits] = 0.0
    return True


def latch_hinges(prepared: Prepared, integrator, old: State, new: State, h: float) -> bool:
    """Latch every free hinge whose angle crossed its lock_at during the step.

    The latch is a perfectly plastic impulsive constraint θ̇ = 0: the free
    velocities jump by the projection that conserves momentum,
    v⁺ = v⁻ − A⁻¹n (nᵀA⁻¹n)⁻¹ nᵀv⁻, with A = M + h²K (M alone may be singular).
    """
    model, assembler = prepared.model, prepared.assembler
    reached, crossing = lock_events(model, old, new)
    latched = reached + [k for k, _ in crossing]
    if not latched:
        return False

    ev = assembler.evaluate(new, matrices=True)
    A = ev.combined(1.0, 0.0, h * h, dense=True)
    v = free_velocity(model, new)
    Nmat = np.zeros((model.n_dofs, len(latched)))
    for j, k in enumerate(latched):
        Nmat[model.hinge_dofs[k], j] = 1.0
    AiN = solve_linear(A, Nmat)
    lam = solve_linear(Nmat.T @ AiN, Nmat.T @ v)
    v = v - AiN @ lam
    unpack_free(model, v, new.v, new.w, new.theta_dot)
    # carry the algorithmic acceleration across the renumbering (the explicit step keeps none)
    algorithmic = getattr(integrator, "a", None)
    a_lin, a_ang, a_h = np.zeros_like(new.v), np.zeros_like(new.w), np.zeros_like(new.theta)
    if algorithmic is not None:
        unpack_free(model, algorithmic, a_lin, a_ang, a_h)
    for k in latched:
        model.locked[k] = True
        new.theta_dot[k] = new.theta_ddot[k] = 0.0
        a_h[k] = 0.0
    model.number_coordinates()
    assembler.reindex()
    if algorithmic is not None:
        integrator.a = pack(model, a_lin, a_ang, a_h)[: model.n_dofs]
    return True


def hinge_events(prepared: Prepared, integrator, old: State, new: State, h: float) -> tuple[bool, bool]:
    """The events at the end of the accepted step old → new of size ``h``: latches, then impacts on
    stops. (Whether any hinge latched or hit a stop, whether any hit a stop.)"""
    latched = latch_hinges(prepared, integrator, old, new, h)
    stopped = hinge_stops(prepared, integrator, new)
    return stopped or latched, stopped
