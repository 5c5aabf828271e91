"""The velocities at t = 0: the scene's rigid motion (``initial_velocity``) carried onto every
coordinate, through hinges, flexible beams and rigid links alike, with the rates of prescribed
bodies and prescribed hinge angles (docs/initial_state.md).

The structure is cut into *parts*: each joint body and each beam (flexible or rigid link).  A
beam end joined to a body is a joint from its parent to its child along the beam's direction
(``from`` body → beam → ``to`` body, as for rigid links, latdyn/model/links.py).  Twists are
spatial, V = (v_O, ω) with the velocity of a point y equal to v_O + ω × y; a hinge with axis g
at the point o has the joint twist ξ = (o × g, g), and the beam end turns relative to its body
by θ̇ ξ.

*Targets.*  Every part that is neither fixed nor prescribed moves with the rigid motion V₀ of
``initial_velocity`` plus the motion Δ that the prescribed motions carry into it:

    Δ = the law's twist on a prescribed body when the scene gives no ``initial_velocity``
        (a given rigid motion is absolute: the parts a prescribed body holds move with it
        only when the scene says nothing), 0 on a fixed body and on a part without parent,
    Δ_child = Δ_parent (+ θ̇_p ξ for the beam, − θ̇_p ξ for the body) across a joint,

θ̇_p the rate of a prescribed hinge angle (0 on a clamped end and on a free hinge: a free hinge
passes its parent's motion on as a clamp would, the rigid motion V₀ being the same on both
sides).  So a rotor behind a hinge with ``angle: 20*t`` spins at 20 rad/s relative to its arm,
a beam clamped to a hub with a prescribed rotation turns with the hub (unless the scene gives
its initial rigid rotation), and a structure clamped to a fixed body starts in V₀ all the same
(an impulsively loaded cantilever) — the fixed body adds nothing.  A joint that closes a loop
asks the same relation of its two sides: the free hinges and guides take the rates of least norm
that close each loop where rates do, each independent loop on its own (a Cardan joint driven at
its input shaft starts in its own motion, the beam closing the loop unstrained); where none close
a loop, a part of it reached twice takes the first Δ it is reached with, and a transient run warns,
naming the loop's joints (:func:`_carried_motion`, :func:`unclosed_loop_warning`).

A guide (``bodies.NAME.guide``) is a joint from ``on`` (without it, from the ground: a part at
rest, :data:`GROUND`) to the guided body with the joint twist ξ = (g, 0), so that a slider guided
on the ground closes the loop of a slider-crank; a free guide takes the slide rate
ṡ = g·(v_target − v_on) at the body's reference point: the component along the axis of its target
velocity relative to ``on``.

*Coordinates.*  A free node takes its part's target twist exactly: v = v_O + ω × x, w = ω (the
elastic coordinates of flexible beams included).  A free hinge takes the rate that turns its
beam end closest to the target: θ̇ = g·(ω_beam − ω_body) (least squares on the end frame's
angular velocity), with the target of whichever side the hinge positions and the actual motion
of the side that positions it — in tree order for rigid links, where the child's motion then
follows from the hinge rate (:meth:`latdyn.assembly.assembler.Assembler.complete_links`).  A rod hinged to
a fixed body with V₀ = ω thus turns about its hinge at θ̇ = ω·g, as a rigid link or as a
flexible beam.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from latdyn.model.model import FIXED, PRESCRIBED
from latdyn.numerics.so3 import cross


#: The ground as the parent of a guide with no ``on`` body: a part that stays at rest (Δ = 0).
GROUND = ("ground",)


def _hinge_of(model) -> dict:
    """(beam, end) -> hinge index, for the beam ends that have a hinge."""
    return {(hinge.beam, hinge.end): k for k, hinge in enumerate(model.hinges)}


def _joints(model, state, hinge_of: dict) -> list:
    """(parent part, child part, hinge index or −1, sign of θ̇ ξ on the child, ξ, the joint's name as
    a warning gives it) of every beam end joined to a body; parts are body names and
    ``("beam", name)``."""
    out = []
    for name, beam in model.scene.beams.items():
        for end, spec in (("start", beam.start), ("end", beam.end)):
            if spec.body is None:
                continue
            node = model.body_node[spec.body]
            h = hinge_of.get((name, end), -1)
            xi = np.zeros(6)
            if h >= 0:
                g = state.T[node] @ model.hinges[h].axis
                o = state.x[node] + state.T[node] @ np.asarray(spec.offset, float)
                xi = np.concatenate([cross(o, g), g])
            beam_part = ("beam", name)
            label = f"{model.hinges[h].kind} {model.hinges[h].name}" if h >= 0 else f"{name}.{end} (clamped)"
            if end == "start":
                out.append((spec.body, beam_part, h, 1.0, xi, label))
            else:
                out.append((beam_part, spec.body, h, -1.0, xi, label))
    for name, body in model.scene.bodies.items():  # guides: a slide ṡ (g, 0) from ``on`` (or the ground)
        if body.guide is not None and (name, "guide") in hinge_of:  # (a rigid loop's closure has no slide)
            h = hinge_of[(name, "guide")]
            on = body.guide.on if body.guide.on is not None else GROUND
            g = model.hinges[h].axis if on == GROUND else state.T[model.body_node[on]] @ model.hinges[h].axis
            out.append((on, name, h, 1.0, np.concatenate([g, np.zeros(3)]),
                        f"{model.hinges[h].kind} {model.hinges[h].name}"))
    return out


def _node_twist(state, node: int) -> np.ndarray:
    """The spatial twist (v_O, ω) of a node's frame."""
    return np.concatenate([state.v[node] - cross(state.w[node], state.x[node]), state.w[node]])


def _point_velocity(twist: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The velocity of the point y of a body moving with the spatial twist (v_O, ω)."""
    return twist[:3] + cross(twist[3:], y)


def _carried_motion(model, state, joints: list, given: bool) -> tuple[dict, list[list[str]]]:
    """(Δ of every part, the loops that do not close: the names of their joints). The prescribed
    motion carried through the joints, breadth first from the prescribed bodies, then from the
    fixed ones, the parts without parent and any part not reached yet (Δ = 0 there). A joint not
    followed (its child reached already, or fixed or prescribed) closes a loop: Δ_child = Δ_parent
    + sign θ̇ ξ must hold there too. Δ is carried as an affine function of the rates of the free
    hinges and guides on the way, and each loop (:func:`_independent_loops`: the closures that share
    free rates, with those rates) closes on its own where its rates can close it (a mechanism driven
    through a loop: a Cardan joint, a four-bar): they take the rates of least norm that close it —
    the mechanism's own motion. Without loops, or where a loop closes at rest, those rates are 0;
    where no rates close a loop (a structure, not a mechanism, strained by its prescribed motion),
    its rates stay 0, a part reached twice keeps the first Δ, and the loop is returned, so that the
    run says so."""
    scene = model.scene
    free = np.zeros(len(model.hinges), dtype=bool)
    free[model.free_hinges] = True
    column = {h: k for k, h in enumerate(sorted({j[2] for j in joints if j[2] >= 0 and free[j[2]]}))}
    children = {}  # each joint walked both ways: parent → child (+sign), child → parent (−sign)
    for e, (parent, child, h, sign, xi, label) in enumerate(joints):
        children.setdefault(parent, []).append((e, child, h, sign, xi, label))
        children.setdefault(child, []).append((e, parent, h, -sign, xi, label))
    kind = {name: model.nodes[model.body_node[name]].kind for name in scene.bodies} | {GROUND: FIXED}
    parts = [GROUND] + list(scene.bodies) + [("beam", name) for name in scene.beams]
    has_parent = {j[1] for j in joints}
    starts = ([p for p in parts if kind.get(p) == PRESCRIBED] + [p for p in parts if kind.get(p) == FIXED]
              + [p for p in parts if p not in has_parent] + parts)  # the last: loops of free parts

    def own(part) -> np.ndarray:  # Δ of a start: a prescribed body's twist unless a rigid motion is given
        held = kind.get(part) == PRESCRIBED and not given
        return _node_twist(state, model.body_node[part]) if held else np.zeros(6)

    def across(h, sign, xi) -> tuple[np.ndarray, np.ndarray]:  # sign θ̇ ξ: (its prescribed part, per free rate)
        turn = np.zeros((6, len(column)))
        if h in column:
            turn[:, column[h]] = sign * xi
        prescribed_rate = state.theta_dot[h] if h >= 0 and model.hinges[h].angle is not None else 0.0
        return sign * prescribed_rate * xi, turn

    # part -> (Δ at zero free rates, ∂Δ/∂rates, the joints on its way as a chain (the way to the parent,
    # the last joint), None at a start); each loop's closure (b, A, the two ways that meet): A rates = b
    carried, closures, walked = {}, [], set()
    for start in starts:
        if start in carried:
            continue
        carried[start] = (own(start), np.zeros((6, len(column))), None)
        queue = deque([start])
        while queue:
            parent = queue.popleft()
            for e, child, h, sign, xi, label in children.get(parent, []):
                if e in walked:  # each joint once, whichever way it was reached first
                    continue
                walked.add(e)
                turn0, turn = across(h, sign, xi)
                to = (carried[parent][0] + turn0, carried[parent][1] + turn, (carried[parent][2], label))
                if child in carried or kind.get(child) in (FIXED, PRESCRIBED):
                    reached = carried.get(child) or (own(child), np.zeros((6, len(column))), None)
                    closures.append((reached[0] - to[0], to[1] - reached[1], (to[2], reached[2])))
                    continue
                carried[child] = to
                queue.append(child)
    rates, unclosed = np.zeros(len(column)), []
    carried_scale = max((float(np.abs(d).max()) for d, _, _ in carried.values()), default=0.0)  # once, not per loop
    for loop in _independent_loops(closures):
        A = np.vstack([closures[i][1] for i in loop])
        b = np.concatenate([closures[i][0] for i in loop])
        moved = np.flatnonzero(np.abs(A).max(axis=0) > 0)
        solved = np.linalg.lstsq(A[:, moved], b, rcond=None)[0] if len(moved) else np.zeros(0)
        scale = max(float(np.abs(b).max()), carried_scale)
        if np.linalg.norm(A[:, moved] @ solved - b) <= 1e-9 * max(scale, 1e-300):  # the loop closes
            rates[moved] = solved
        else:
            unclosed.append(list(dict.fromkeys(label for i in loop for label in _ways(*closures[i][2]))))
    motion = {part: delta + slope @ rates for part, (delta, slope, _) in carried.items()}
    return motion, unclosed


def _joints_on(way) -> tuple:
    """The joints of a way carried by :func:`_carried_motion` (a chain (the way before, the last joint),
    None where it starts), from its start."""
    joints = []
    while way is not None:
        way, label = way
        joints.append(label)
    return tuple(reversed(joints))


def _ways(to, reached) -> tuple:
    """The joints of the loop that two ways close (those they do not share: the way up to the start
    shared is not the loop's), each way's own from its start. Only a loop that does not close is named:
    the ways are made into joints then, not for every closure (the 16-bay lattice closes 128 loops at rest,
    along two ways of 35 joints on average: 0.5 ms of its run's start; docs/performance.md, "Eleventh pass")."""
    to, reached = _joints_on(to), _joints_on(reached)
    return tuple(j for j in to if j not in reached) + tuple(j for j in reached if j not in to)


def _independent_loops(closures: list) -> list[list[int]]:
    """The closures grouped into independent loops: closures that share a free rate (a non-zero
    column of their A) are one loop, whose rates close it or not together; a closure with no free
    rate is a loop of its own (it closes at rest or not at all)."""
    group = list(range(len(closures)))

    def root(i: int) -> int:
        while group[i] != i:
            group[i] = group[group[i]]
            i = group[i]
        return i
    owner = {}
    for i, (_, A, _) in enumerate(closures):
        for k in np.flatnonzero(np.abs(A).max(axis=0) > 0):
            if k in owner:
                group[root(i)] = root(owner[k])
            else:
                owner[k] = i
    loops = {}
    for i in range(len(closures)):
        loops.setdefault(root(i), []).append(i)
    return list(loops.values())


def unclosed_loop_warning(joints: list[str]) -> str:
    """The warning of a loop whose free joints cannot carry the prescribed motion round it."""
    return (f"the initial velocity does not close the loop through {', '.join(joints)}: no rates of its "
            "free joints carry the motion round it (a structure strained by its prescribed motion, not a "
            "mechanism), so its parts start in the motion they are first reached with, which the loop's "
            "other side does not share: the loop is strained from the first step")


def _moves_nothing(model) -> bool:
    """Whether the scene sets nothing in motion at t = 0: no ``initial_velocity``, no prescribed body and
    no prescribed hinge angle or guide position. Then every part's Δ is 0 (:func:`_carried_motion`
    starts each with 0 and adds only prescribed rates), every loop closes at rest (its b is 0), and each
    target is the rigid motion, +0.0 in every component (``rigid_motion + 0`` adds a zero of either sign
    to +0.0): the velocities are those the carried motion gives, bit for bit, without walking the
    joints (≈ 4 ms of the 16-bay lattice's start: 128 closures; docs/performance.md, "Twelfth pass")."""
    return (not model.scene.initial_velocity.given and all(node.kind != PRESCRIBED for node in model.nodes)
            and all(hinge.angle is None for hinge in model.hinges))


class _NothingCarried(dict):
    """Δ = 0 for every part (:func:`_moves_nothing`)."""

    def __missing__(self, part) -> np.ndarray:
        return np.zeros(6)


_NOTHING_CARRIED = _NothingCarried()


def initial_velocities(model, state, complete_links) -> list[str]:
    """Set the free coordinates' velocities of ``state`` (t = 0, prescribed motion applied) from the
    scene's rigid motion and the prescribed rates, in place (module docstring); the dependent
    nodes of rigid links are completed from them by ``complete_links(state)``
    (:meth:`latdyn.assembly.assembler.Assembler.complete_links`). Returns the warnings of the loops
    that do not close (:func:`unclosed_loop_warning`)."""
    scene = model.scene
    iv = scene.initial_velocity
    omega0 = np.asarray(iv.angular, float)
    rigid_motion = np.concatenate([np.asarray(iv.linear, float) - np.cross(omega0, iv.about), omega0])
    hinge_of = _hinge_of(model)
    if _moves_nothing(model):  # every Δ is 0 and every loop closes at rest: nothing to carry
        carried, unclosed = _NOTHING_CARRIED, []
    else:
        carried, unclosed = _carried_motion(model, state, _joints(model, state, hinge_of), iv.given)

    def target(part) -> np.ndarray:
        if part in scene.bodies:
            node = model.body_node[part]
            if model.nodes[node].kind in (FIXED, PRESCRIBED):
                return _node_twist(state, node)
        return rigid_motion + carried[part]

    # free nodes: their part's target
    node_part = {model.body_node[name]: name for name in scene.bodies}
    for name in scene.beams:
        for node in model.beam_nodes[name]:
            node_part.setdefault(int(node), ("beam", name))
    for node in model.free_nodes:
        if model.translation_only is not None and model.translation_only[node]:
            # a cable's own node (translations only): the scene's rigid motion at its point
            state.w[node] = 0.0
            state.v[node] = rigid_motion[:3] + cross(rigid_motion[3:], state.x[node])
            continue
        twist = target(node_part[int(node)])
        state.w[node] = twist[3:]
        state.v[node] = twist[:3] + cross(twist[3:], state.x[node])
    free = np.zeros(len(model.hinges), dtype=bool)
    free[model.free_hinges] = True
    # rigid links in tree order: a free hinge turns its child towards the child's target
    links = model.links
    omega = {int(i): state.w[i].copy() for i in range(len(model.nodes))}
    if links is not None:
        for e in links.edges:
            child_part = node_part[e.child]  # the link's beam for its link node, else the body at its end
            if e.prismatic:  # a guide: the slide rate that gives the child its target velocity along g
                if free[e.hinge]:
                    complete_links(state)  # the parent's actual motion (edges before this one are set)
                    g = state.T[e.parent] @ e.axis
                    x_c = state.x[e.child]
                    relative = (_point_velocity(target(child_part), x_c)
                                - _point_velocity(_node_twist(state, e.parent), x_c))
                    state.theta_dot[e.hinge] = float(g @ relative)
                omega[e.child] = omega[e.parent]
            elif e.hinge >= 0:
                g = state.T[e.parent] @ e.axis
                if free[e.hinge]:
                    state.theta_dot[e.hinge] = e.sign * float(g @ (target(child_part)[3:] - omega[e.parent]))
                omega[e.child] = omega[e.parent] + e.sign * state.theta_dot[e.hinge] * g
            else:
                omega[e.child] = omega[e.parent]
        complete_links(state)
    # flexible beams: a free hinge turns the beam end towards the beam's target
    for name, beam in scene.beams.items():
        if beam.rigid:
            continue
        for end in ("start", "end"):
            h = hinge_of.get((name, end), -1)
            if h >= 0 and free[h]:
                node = model.hinges[h].node
                g = state.T[node] @ model.hinges[h].axis
                state.theta_dot[h] = float(g @ (target(("beam", name))[3:] - state.w[node]))
    return [unclosed_loop_warning(joints) for joints in unclosed]
