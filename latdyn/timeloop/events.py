"""Events of the time loop: hinges that latch at ``lock_at``, impacts on hinge stops, joints that
come to rest on their stops (locked there until the load pulls them off), and joints that stick and
slip by friction; the fraction of a step at which the first one happens (the loop
shortens the step onto it)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from latdyn.assembly.assembler import State, free_acceleration, free_velocity, unpack_free
from latdyn.assembly.factorization import solve_linear
from latdyn.assembly.prepare import Prepared
from latdyn.model.cables import cable_tolerance
from latdyn.model.model import Model, lock_tolerance
from latdyn.timeloop.impulse import hinge_directions, impulse_response, jump


#: The flags of a hinge's events over a step (csrc/newton_step.c hinge_crossings, the loop of steps' own test,
#: through :func:`hinge_flags`): it started on its lock_at or ends within the tolerance of it; else crossed it; it
#: crossed its lower or upper stop from inside; it ends on or beyond its lower or upper stop moving into it, a rigid
#: stop (a compliant one, with ``contact``, is a force, no impact: it never has these two).
LOCK_REACHED, LOCK_CROSSED, LOWER_CROSSED, UPPER_CROSSED, LOWER_HIT, UPPER_HIT = 1, 2, 4, 8, 16, 32
CROSSED, HIT = {-1: LOWER_CROSSED, 1: UPPER_CROSSED}, {-1: LOWER_HIT, 1: UPPER_HIT}


def hinge_flags(assembler, old: State, new: State) -> np.ndarray:
    """Per hinge, its events over the step old → new (the flags above; 0 for hinges not free), by the loop of
    steps' own test (``NativeModel.hinge_crossings``), with the tolerances of :func:`lock_tolerance`."""
    return assembler.native().hinge_crossings(old, new)


def lock_events(assembler, old: State, new: State, flags: np.ndarray | None = None) -> tuple[list[int], list[tuple[int, float]]]:
    """Free hinges with a lock_at, over the step old → new: those that reach it (started on
    it, or ended within tolerance), and those that cross it with the fraction of the step
    at the crossing (linear interpolation of the angle); ``flags``: :func:`hinge_flags` of the step, if taken."""
    model = assembler.model
    latches = [k for k in model.free_hinges if model.hinges[k].lock_at is not None]
    if not latches:
        return [], []
    flags = hinge_flags(assembler, old, new) if flags is None else flags
    reached, crossing = [], []
    for k in latches:
        if flags[k] & LOCK_REACHED:
            reached.append(k)
        elif flags[k] & LOCK_CROSSED:
            lock = model.hinges[k].lock_at
            before, after = old.theta[k] - lock, new.theta[k] - lock
            crossing.append((k, before / (before - after)))
    return reached, crossing


def crossing_fraction(assembler, old: State, new: State, cables: bool = False, cable_floor: float = 0.0) -> float | None:
    """The fraction of the step at which the first hinge crosses its lock_at or a stop, or (with ``cables``) a
    cable element goes slack or taut (an element that changes back, having changed at the step's start, never
    below ``cable_floor``: see :data:`CABLE_LANDING`), or None."""
    model = assembler.model
    fractions = []
    if any(model.hinges[k].lock_at is not None or model.hinges[k].limits is not None for k in model.free_hinges):
        flags = hinge_flags(assembler, old, new)
        fractions += [f for _, f in lock_events(assembler, old, new, flags)[1]]
        fractions += [f for _, _, f in stop_crossings(assembler, old, new, flags)]
    if cables and assembler.model.cables is not None:
        fractions += [max(f, cable_floor) if back else f for _, f, back in cable_crossings(assembler, old, new)]
    return min(fractions) if fractions else None


# ----------------------------------------------------------------------------- cables
# A cable element is taut while its gap g = min(N_el, N) is positive: stretched (N_el = EA (ℓ − L0)/L0 > 0)
# and pulling (N = N_el + c ℓ̇ > 0; g is continuous in time). Each element is held on a side through a
# step, taut (+1) or slack (−1), in the model's ``cables.sides`` that the evaluation reads
# (latdyn/model/cables.py): Newton sees one smooth law in a step. A step that ends with an element's gap
# beyond cable_tolerance on the other side of zero is shortened to land on the zero (secant on the gap,
# as for hinge stops; the compiled loop hands such a step back: csrc/newton_step.c cable_event, whose test
# cable_crossed cable_crossings calls); the
# accepted step that reached the zero from its side, or crossed it, turns the element over
# (:func:`cable_events`). The velocities do not jump at the change, so there is no impulse
# (docs/cables.md measures this against a C¹ transition).
#: The shortest step that lands on a cable element's change back, as a fraction of the nominal step dt:
#: an element that changed side at the step's start (its gap within the tolerance there) and crosses
#: back closer than this to the start is taken to change back at this time instead (the side held a
#: little past its change: a tension that hovers at zero, where the force is zero on both sides or, at
#: the stretch's zero with a damper, jumps by c ℓ̇ ≈ 0). Every other change, the first of a bounce
#: among them, is landed on to the tolerance. Landing steps of 1e-7 s, where a damped
#: cable's tension grazes zero on a vibrating light part, carried Newton's tolerance over h² into the
#: algorithmic accelerations, and Newton failed in the steps after them: the example truss with
#: damped cables (c = 50 N·s/m on 0.1 kg stations, dt = 2e-3, 0.8 s) went through 291 cut steps and
#: 159 s of solver time with the landings from the step's start; 71 s with this floor alone; no cut and
#: 5.5 s with it, the regula falsi landing (latdyn/timeloop/loop.py ``_land_on_event``) and
#: :data:`TAUT_JUMP_STEP` (docs/cables.md).
CABLE_LANDING = 1e-3
#: The step after a damped cable element went taut, as a fraction of the nominal step dt (the steps after
#: it grow from there as after any shortened step): its tension jumps from 0 to c ℓ̇ there, and the
#: generalized-α step that follows a jump of the force carries an error of the order of its size (on
#: tests/test_cables.py's light drop with c = 2 N·s/m at dt = 1e-4, the next changes came 3.7e-5 s late
#: with a full step after the jump, 4.8e-6 s with this one).
TAUT_JUMP_STEP = 1e-2


def cable_gaps(assembler, state: State) -> tuple[np.ndarray, np.ndarray]:
    """(gap min(N_el, N), its tolerance) of every cable element at ``state``."""
    native = assembler.native()
    native.cable_state(state)
    return native.buffers["cable_gap"].copy(), cable_tolerance(assembler.model.cables.EA)


def cable_sides(assembler, state: State) -> list[int]:
    """+1 (taut: the gap beyond the tolerance) or −1 (slack) for every cable element at ``state``."""
    stretch, tol = cable_gaps(assembler, state)
    return [1 if s > t else -1 for s, t in zip(stretch, tol)]


def cable_crossings(assembler, old: State, new: State) -> list[tuple[int, float, bool]]:
    """(cable element, fraction of the step, back) for each element whose gap ends the step beyond its
    tolerance on the other side of zero from the side the step held it on (linear interpolation of the
    gap from ``old``); back: its gap was within the tolerance at ``old`` (it had just changed side, and
    changes back). Which crossed: csrc/newton_step.c cable_crossed, the loop of steps' own test
    (``NativeModel.cable_crossed``)."""
    after, tol = cable_gaps(assembler, new)
    crossed = assembler.native().cable_crossed(after)
    if not crossed.any():
        return []
    before, _ = cable_gaps(assembler, old)
    out = []
    for e in np.flatnonzero(crossed):
        span = before[e] - after[e]
        out.append((int(e), float(min(max(before[e] / span, 0.0), 1.0)) if span != 0.0 else 0.0,
                    bool(abs(before[e]) <= tol[e])))
    return out


def cable_events(assembler, sides: list, old: State, new: State) -> tuple[list, list]:
    """The elements' sides after the accepted step old → new (from ``sides``, those it was held on) and
    the changes of whole cables, [(cable name, "taut" | "slack")]: an element turns over where its
    gap reached zero from its side (within the tolerance, moving towards it) or went past it; a
    cable is taut while any of its elements is."""
    after, tol = cable_gaps(assembler, new)
    before, _ = cable_gaps(assembler, old)
    new_sides = []
    for e, side in enumerate(sides):
        if side > 0 and after[e] <= tol[e] and after[e] < before[e]:
            side = -1
        elif side < 0 and after[e] >= -tol[e] and after[e] > before[e]:
            side = 1
        new_sides.append(side)
    cables = assembler.model.cables
    changes = []
    for k, name in enumerate(cables.names):
        elements = np.flatnonzero(cables.cable == k)
        was, now = any(sides[e] > 0 for e in elements), any(new_sides[e] > 0 for e in elements)
        if was != now:
            changes.append((name, "taut" if now else "slack"))
    return new_sides, changes


# ----------------------------------------------------------------------------- hard stops
# Hinge ``limits: [lo, hi]`` with ``restitution`` e are events, like lock_at: a step in which
# a hinge crosses a stop from inside is shortened to land on it (regula falsi on the step's size, as for
# latches: latdyn.timeloop.landing); then, for every free hinge on or beyond a stop and moving into it, the
# configuration is projected onto the stop, Δq = −X μ with Nᵀ(q + Δq) = stop, and the
# velocities jump so that the hinge rate reverses, θ̇⁺ = −e θ̇⁻ (Newton's impact law), by the
# impulse that conserves momentum, v⁺ = v⁻ + X λ, Nᵀv⁺ = −e Nᵀv⁻, X the impulse response of
# latdyn/timeloop/impulse.py (elements without inertia rigid through the jump, the other
# directions without inertia in their statics, the massive ones weighted by M + dt²K, with which
# modes faster than the nominal step dt take the impact quasi-statically); the accelerations
# restart from the equations of motion after the impact, with the same quasi-static treatment
# (:func:`restart_accelerations`). A hinge that an impact leaves on its stop without rate (e = 0, or
# a load that holds it there: it started the step on the stop) is locked there while the stop holds
# it, and released when the load would pull it off ("resting on a stop" below).
# Events rather than a penalty: exact landing on the stop and no contact stiffness that the
# step would have to resolve; rather than a complementarity solve inside Newton: the time
# step (shared with the compiled step of solve.py) stays as it is.
# A stop with ``contact`` is compliant instead: its Hunt–Crossley force is part of the hinge's force
# (the generated hinge_force, codegen/joints.py joint_contact) and no impulse applies; the step still
# lands on its onset (stop_crossings: δ = 0 within lock_tolerance), where the force law has its kink.
def stop_crossings(assembler, old: State, new: State, flags: np.ndarray | None = None) -> list[tuple[int, int, float]]:
    """(hinge, side, fraction of the step) for free hinges that crossed a stop from inside during the
    step (side −1 lower, +1 upper), the angle interpolated linearly; ``flags``: :func:`hinge_flags` of the step,
    if taken."""
    model = assembler.model
    stopped = [k for k in model.free_hinges if model.hinges[k].limits is not None]
    if not stopped:
        return []
    flags = hinge_flags(assembler, old, new) if flags is None else flags
    out = []
    for k in stopped:
        limits = model.hinges[k].limits
        for side, stop in ((-1, limits[0]), (1, limits[1])):
            if flags[k] & CROSSED[side]:
                before, after = side * (old.theta[k] - stop), side * (new.theta[k] - stop)  # > 0: beyond
                out.append((int(k), side, before / (before - after)))
    return out


def stop_hits(assembler, new: State, old: State | None = None) -> tuple[list, list, list, list]:
    """The free hinges on or beyond a rigid stop at ``new`` and moving into it: (hinges, their stops, the
    restitution each takes, whether each rests there: started the step from ``old`` on it, restitution 0)."""
    model = assembler.model
    stopped = [k for k in model.free_hinges if model.hinges[k].limits is not None]  # rigid or not: the flags say
    hits, stops, restitution, rests = [], [], [], []
    if not stopped:
        return hits, stops, restitution, rests
    flags = hinge_flags(assembler, new if old is None else old, new)
    for k in stopped:
        limits = model.hinges[k].limits
        for side, stop in ((-1, limits[0]), (1, limits[1])):
            if flags[k] & HIT[side]:
                resting = old is not None and side * (old.theta[k] - stop) >= -lock_tolerance(stop)
                hits.append(int(k))
                stops.append(stop)
                restitution.append(0.0 if resting else model.hinges[k].restitution)
                rests.append(resting)
    return hits, stops, restitution, rests


def first_crossing(assembler, old: State, new: State) -> tuple[int, float] | None:
    """(hinge, the lock_at or stop it crosses or reached) of the first hinge event over the step old → new
    (the earliest crossing; else a hinge that reached its lock_at), or None: what a landing aims at."""
    model = assembler.model
    reached, crossing = lock_events(assembler, old, new)
    found = [(f, k, model.hinges[k].lock_at) for k, f in crossing]
    found += [(f, k, model.hinges[k].limits[0 if side < 0 else 1]) for k, side, f in stop_crossings(assembler, old, new)]
    if found:
        _, k, at = min(found)
        return int(k), float(at)
    if reached:
        return int(reached[0]), float(model.hinges[reached[0]].lock_at)
    return None


def hinge_stops(prepared: Prepared, integrator, new: State, old: State | None = None,
                log: list | None = None, hits: tuple | None = None) -> tuple[float, bool] | None:
    """Impacts on hinge stops at the end of an accepted step from ``old`` (see above): the energy
    they removed (:func:`hinge_events`) and whether every joint that met its stop rests there (started
    the step on it), or None when no hinge hit a stop.

    A hinge that started the step on its stop and ends it on or beyond it again rests on the stop:
    it takes restitution 0 there. Its bounce, if any, was shorter than the step: the Zeno limit of
    a stop with restitution resting on it (bounces ever shorter, at ever closer instants) is rest,
    which is where the sequence ends; the step keeps no bounce of e·(the rate gained in one step)
    that would show a rate at rest and re-trigger the stop at every step."""
    model, assembler = prepared.model, prepared.assembler
    hits, stops, restitution, rests = stop_hits(assembler, new, old) if hits is None else hits
    if log is not None:  # the impacts; a hinge resting on its stop is no new event
        log.extend((model.hinges[k].name, "stop") for k, resting in zip(hits, rests) if not resting)
    if not hits:
        return None
    before = kinetic_energy(assembler, new)
    target = -np.array(restitution) * new.theta_dot[hits]
    N = hinge_directions(model, hits)
    X = impulse_response(model, assembler.evaluate(new, matrices=True), N, prepared.scene.solve.dt)
    # the configuration onto the stops along the same directions: the directions without inertia
    # stay in their statics, so that the massless parts are not strained to hold the hinge there
    moved = assembler.advance(new, -X @ np.linalg.solve(N.T @ X, new.theta[hits] - np.array(stops)))
    for name in ("x", "T", "theta"):  # in place: the compiled step may view this state's arrays
        np.copyto(getattr(new, name), getattr(moved, name))
    new.theta[hits] = stops
    unpack_free(model, jump(X, N, free_velocity(model, new), target), new.v, new.w, new.theta_dot)
    restart_accelerations(prepared, integrator, new, prepared.scene.solve.dt)
    return before - kinetic_energy(assembler, new), all(rests)


def restart_accelerations(prepared: Prepared, integrator, new: State, dt: float) -> None:
    """The accelerations the integrator goes on from after an impact: those of the equations of
    motion at the state after it, with the directions that are stiff at the scale of the nominal
    step ``dt`` taken quasi-statically, as the impact's projection takes their velocities:

        (M + dt²K) v̇ = −r₀,   r₀ = r − M v̇⁻  (the residual at zero acceleration; r is affine in v̇)

    On the motion that strains nothing (K ≈ 0 there: the swing of a pendulum) this is M⁻¹f; on a
    direction with little inertia and a stiffness ω ≫ 1/dt (the rotation of a stiff beam's end node
    without rotary inertia, a hinge's own spin on a stiff beam) it is the acceleration of the motion
    it follows, not the force it is out of balance by over its inertia.  The accelerations of the
    step that led to the impact must not go on: that step was shortened onto the stop, as short as
    1e-7 s, and its algorithmic acceleration carries Newton's tolerance on those stiff directions
    over h² (1e4 rad/s² on a pendulum of EI = 1e9 falling at 10 rad/s²), which the next steps' rate
    update turned into a ringing rate that grew at every bounce until Newton failed.  Nor may the
    exact M⁻¹f: on those directions it is the same noise over their tiny inertia."""
    model, assembler = prepared.model, prepared.assembler
    ev = assembler.evaluate(new, matrices=True)
    vdot = free_acceleration(model, new)
    r0 = ev.residual - ev.combined(1.0, 0.0, 0.0) @ vdot
    vdot = -solve_linear(ev.combined(1.0, 0.0, dt * dt), r0)
    unpack_free(model, vdot, new.a, new.alpha, new.theta_ddot)
    if getattr(integrator, "a", None) is not None:  # the explicit step keeps no algorithmic acceleration
        integrator.a = vdot.copy()


def latch_hinges(prepared: Prepared, integrator, old: State, new: State, h: float,
                 log: list | None = None) -> float | None:
    """Latch every free hinge whose angle crossed its lock_at during the step.

    The latch is a perfectly plastic impulsive constraint θ̇ = 0: the free
    velocities jump by the impulse that conserves momentum,
    v⁺ = v⁻ − X (nᵀX)⁻¹ nᵀv⁻, X the impulse response of :mod:`latdyn.timeloop.impulse`
    weighted with the nominal step dt, as for stops. (It was weighted with the step h that
    landed on the latch, a fraction of dt that changes erratically with dt: θ(1) of the two-link
    arm of flexible beams in tests/test_initial_state.py came out 0.07029, 0.07001, 0.07039 at
    dt = 0.02, 0.01, 0.005; with dt, 0.06949, 0.07015, 0.07015.)
    Returns the energy the latch removed (:func:`hinge_events`), or None when no hinge latched.
    """
    model, assembler = prepared.model, prepared.assembler
    reached, crossing = lock_events(assembler, old, new)
    latched = reached + [k for k, _ in crossing]
    if not latched:
        return None
    if log is not None:
        log.extend((model.hinges[k].name, "latch") for k in latched)
    before = kinetic_energy(assembler, new)

    N = hinge_directions(model, latched)
    X = impulse_response(model, assembler.evaluate(new, matrices=True), N, prepared.scene.solve.dt)
    v = jump(X, N, free_velocity(model, new), np.zeros(len(latched)))
    unpack_free(model, v, new.v, new.w, new.theta_dot)
    for k in latched:
        model.locked[k] = True
        new.theta_dot[k] = new.theta_ddot[k] = 0.0
    model.number_coordinates()
    assembler.reindex()
    # the latch changed the equations (the hinge's moment is now a reaction): the accelerations
    # the integrator goes on from are those consistent with the latched model, as at t = 0
    integrator.start(new)
    return before - kinetic_energy(assembler, new)


# ----------------------------------------------------------------------------- stick and slip
# A joint with friction (static level F_s > 0) sticks by an event, not by its regularised law alone:
# at the end of a step in which its rate reversed or fell into the stick band (|θ̇| ≤ stick_rate and
# slowing), or at t = 0 and after the first step of a run that starts it at rest (stick_at_start), it is
# locked on trial, as a latch is
# (the momentum-conserving jump to θ̇ = 0, the coordinates renumbered), the accelerations restarted as
# after an impact (:func:`restart_accelerations`); it stays locked (``model.stuck``) while the
# reaction that holds it, |R| ≤ F_s, the breakaway level, and the trial is undone otherwise (state
# and integrator as they were). A stuck joint is released after the first step at whose end its
# reaction exceeds F_s; the regularised law (codegen/joints.py joint_contact) is its friction while
# it slips, until its rate reverses or slows into the band (not retried at once: on a flexible beam
# it chattered stuck/slipping at every step). The step is not shortened onto the reversal: a step
# that starts at θ̇ = 0, on the steepest part of the slip law, failed Newton at about one reversal in
# ten on a flexible boom (docs/contact.md), and the rate at the end of a reversing step is within one
# step's change of 0. The C loop of steps hands back every step that may stick a joint
# (newton_step.c hinge_event), and the loop takes the steps of a run with a stuck joint from Python,
# to check it.
def sticking_hinges(model: Model) -> list[int]:
    """The free hinges whose friction can hold them (static level > 0)."""
    return [int(k) for k in model.free_hinges
            if model.hinges[k].friction is not None and model.hinges[k].friction.static > 0.0]


def may_stick(assembler, k: int, old: State, new: State) -> bool:
    """Whether hinge k is tried for sticking at the end of the step: its rate reversed, or fell into
    the stick band, or it started the run at rest. Not a joint just released (rate 0 at the step's start,
    growing): it slips until it reverses. The loop of steps' own test (csrc/newton_step.c may_stick, through
    ``NativeModel.may_stick``): the steps it hands back are these."""
    return bool(assembler.native().may_stick(old, new)[k])


def stick_at_start(prepared: Prepared, integrator, state: State) -> None:
    """Stick, at t = 0, the joints with friction that start the run at rest and whose holding reaction is
    within their breakaway level (the trial of :func:`stick_and_slip` on the initial state itself). Tried
    only at the end of the first step, a joint held by static friction first slid over that step under
    the regularised law (0 at rate 0) and then stuck where it had got to: a block held on an incline
    moved ½ a dt² (1.8e-4 m at dt = 0.01; tests/test_literature_cases_heldout2.py)."""
    if any(state.theta_dot[k] == 0.0 for k in sticking_hinges(prepared.model)):
        if stick_and_slip(prepared, integrator, state, state) is not None and prepared.model.n_dofs:
            integrator.start(state)  # no jump at t = 0: the consistent accelerations of the model as it starts


def holding_reaction(prepared: Prepared, state: State, k: int) -> float:
    """The generalized force that holds locked hinge k at ``state`` (at its accelerations as restarted)."""
    model = prepared.model
    return float(prepared.assembler.evaluate(state, matrices=False).reaction[model.hinge_dofs[k] - model.n_dofs])


def _renumber(prepared: Prepared, integrator, state: State) -> None:
    """The coordinates renumbered after a joint stuck or slipped, and the accelerations restarted as
    after an impact (:func:`restart_accelerations`: the stiff directions quasi-static)."""
    prepared.model.number_coordinates()
    prepared.assembler.reindex()
    if prepared.model.n_dofs:
        restart_accelerations(prepared, integrator, state, prepared.scene.solve.dt)
    else:  # nothing left to move (the stuck joint was the only coordinate)
        integrator.start(state)


def stick_and_slip(prepared: Prepared, integrator, old: State, new: State) -> float | None:
    """Release the stuck hinges whose reaction exceeds the breakaway level, then stick those whose rate
    reached the stick band and whose holding reaction is within it (see above). Returns the kinetic
    energy the sticking jumps removed, or None when no hinge stuck or slipped."""
    model, assembler = prepared.model, prepared.assembler
    changed, loss = False, 0.0
    for k in np.flatnonzero(model.stuck):
        if abs(holding_reaction(prepared, new, int(k))) > model.hinges[k].friction.static:
            model.locked[k] = model.stuck[k] = False
            _renumber(prepared, integrator, new)
            changed = True
    for k in sticking_hinges(model):
        if not may_stick(assembler, k, old, new):
            continue
        saved = {name: getattr(new, name).copy() for name in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot")}
        saved_a = None if getattr(integrator, "a", None) is None else integrator.a.copy()
        before = kinetic_energy(assembler, new)
        N = hinge_directions(model, [k])
        X = impulse_response(model, assembler.evaluate(new, matrices=True), N, prepared.scene.solve.dt)
        unpack_free(model, jump(X, N, free_velocity(model, new), np.zeros(1)), new.v, new.w, new.theta_dot)
        model.locked[k] = model.stuck[k] = True
        new.theta_dot[k] = new.theta_ddot[k] = 0.0
        _renumber(prepared, integrator, new)
        if abs(holding_reaction(prepared, new, k)) <= model.hinges[k].friction.static:
            loss += before - kinetic_energy(assembler, new)
            changed = True
            continue
        model.locked[k] = model.stuck[k] = False  # it slips on: the trial undone
        model.number_coordinates()
        assembler.reindex()
        for name, value in saved.items():
            np.copyto(getattr(new, name), value)
        if saved_a is not None:
            integrator.a = saved_a
    return loss if changed else None


# ----------------------------------------------------------------------------- resting on a stop
# A joint that comes to rest on its rigid stop is locked there, as a latch or a sticking joint is: an
# impact that leaves it on the stop without rate (restitution 0, or a joint that started the step on
# the stop: a bounce shorter than the step, the Zeno limit of a chattering stop is rest; hinge_stops)
# locks it on trial (``model.resting``: the stop's side), the accelerations restarted as after an impact;
# it stays locked while the reaction that holds it pushes it away from the stop (side · R < 0: the stop
# can only push) and the trial is undone otherwise. A resting joint is released after the first step at
# whose end its reaction would pull it onto the stop's other side (the load reversed), then it moves
# away freely. While locked its coordinate is no unknown: its probe torque/force and ``joint_peaks`` are
# the reaction R of the locked model (exact: static, the load's moment). The steps of a run with a
# resting joint are taken from Python, to check it for release (latdyn/timeloop/loop.py).
def stops_left_at_rest(assembler, new: State, old: State, hits: tuple | None = None) -> list[tuple[int, int]]:
    """(hinge, side) of the free hinges whose impact at the end of the step old → new leaves them on their
    rigid stop without rate (:func:`stop_hits` with restitution 0, or ``hits``, its result): to be tried for
    resting there."""
    model = assembler.model
    hits, stops, restitution, _ = stop_hits(assembler, new, old) if hits is None else hits
    return [(int(k), -1 if stop == model.hinges[k].limits[0] else 1)
            for k, stop, e in zip(hits, stops, restitution) if e == 0.0]


def stop_holds(prepared: Prepared, state: State, k: int) -> bool:
    """Whether the rigid stop that locked hinge k rests on holds it at ``state``: its reaction pushes the
    joint away from the stop (or is zero)."""
    return float(prepared.model.resting[k]) * holding_reaction(prepared, state, k) <= 0.0


def settle_on_stops(prepared: Prepared, integrator, candidates: list[tuple[int, int]], new: State) -> float | None:
    """Lock each candidate (hinge, side) (:func:`stops_left_at_rest`) on its stop where the stop holds it,
    the trial undone where it would pull (see above). Returns the kinetic energy the locking removed (its
    rate is already zero: round-off), or None when no hinge settled."""
    model, assembler = prepared.model, prepared.assembler
    settled, loss = False, 0.0
    for k, side in candidates:
        if model.locked[k]:
            continue
        saved = {name: getattr(new, name).copy() for name in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot")}
        saved_a = None if getattr(integrator, "a", None) is None else integrator.a.copy()
        before = kinetic_energy(assembler, new)
        model.locked[k], model.resting[k] = True, side
        new.theta_dot[k] = new.theta_ddot[k] = 0.0
        _renumber(prepared, integrator, new)
        if stop_holds(prepared, new, k):
            loss += before - kinetic_energy(assembler, new)
            settled = True
            continue
        model.locked[k], model.resting[k] = False, 0  # the load pulls it off the stop: the trial undone
        model.number_coordinates()
        assembler.reindex()
        for name, value in saved.items():
            np.copyto(getattr(new, name), value)
        if saved_a is not None:
            integrator.a = saved_a
    return loss if settled else None


def release_from_stops(prepared: Prepared, integrator, new: State) -> bool:
    """Release every hinge resting on its stop whose reaction at ``new`` would pull it off (see above);
    whether any was."""
    model = prepared.model
    released = False
    for k in np.flatnonzero(model.resting):
        if not stop_holds(prepared, new, int(k)):
            model.locked[k], model.resting[k] = False, 0
            _renumber(prepared, integrator, new)
            released = True
    return released


def kinetic_energy(assembler, state: State) -> float:
    return assembler.energies(state)["kinetic"]


class HingeEvents(NamedTuple):
    """The events at the end of an accepted step."""

    any: bool  # a hinge latched, hit a stop, stuck or slipped
    stopped: bool  # a hinge hit a stop
    #: the energy the events removed (:func:`hinge_events`): declared dissipation
    loss: float
    #: the only event: joints that come to rest on their stops, put back where they started the step (so
    #: the step moved nothing there: its work and dissipation are those of the state after the projection)
    resting: bool
    #: (joint, kind) of each event: latch, stop (an impact)
    log: list


def hinge_events(prepared: Prepared, integrator, old: State, new: State, h: float) -> HingeEvents:
    """The events at the end of the accepted step old → new of size ``h``: latches, releases of joints
    resting on their stops, impacts on stops (and the joints they leave at rest there locked), sticking
    and slipping, and the energy they removed.

    Event loss: an impact with restitution e and a latch (e = 0) are declared losses of energy,
    the kinetic energy lost in the velocity jump — for a rigid impact on a hinge stop (1 − e²)
    times the kinetic energy of the hinge's motion before it. The time loop counts it as
    dissipated energy, so that the energy balance measures the integrator alone
    (docs/energy.md). A joint held against its stop (a load pushing it there) is put back where it
    started the step: the step moved nothing there, so neither the work of the load over the motion
    the projection undid nor the kinetic energy that motion gave is counted (``resting``: the time
    loop takes the step's end power after the projection; measured on a slider held on its stop by a
    constant force, the work F s to the events' landing tolerance (3e-8), where counting both grew the work by 15 % in 0.33 s at
    h = 0.01); what putting the rest of the configuration back changes of the strain and potential
    energy is not declared and stays in the balance. ``log``: the latches and stop impacts, (joint, kind)."""
    log = []
    latched = latch_hinges(prepared, integrator, old, new, h, log)
    released = release_from_stops(prepared, integrator, new)
    hits = stop_hits(prepared.assembler, new, old)  # the same for both: nothing moves between them
    at_rest = stops_left_at_rest(prepared.assembler, new, old, hits)
    stopped = hinge_stops(prepared, integrator, new, old, log, hits)
    settled = settle_on_stops(prepared, integrator, at_rest, new) if stopped is not None else None
    stuck = stick_and_slip(prepared, integrator, old, new)
    resting = stopped is not None and stopped[1] and latched is None and stuck is None
    # resting: the kinetic energy the step gave the joint past its stop came from the work of a motion the
    # projection undid; neither is counted (the time loop takes the step's power after the projection)
    loss = (latched or 0.0) + (stopped[0] if stopped is not None and not resting else 0.0) + (stuck or 0.0) \
        + (settled or 0.0)
    # a jump that raised the kinetic energy (a latch, an impact with e <= 1 or a sticking joint cannot,
    # exactly) created it: not a negative dissipation that would hide it from the balance, but energy
    # the balance keeps as created (tests/test_reported_defects.py: -93 J "dissipated" by one impact)
    loss = max(loss, 0.0)
    return HingeEvents(stopped is not None or latched is not None or stuck is not None or released, stopped is not None,
                       loss, resting, log)
