"""Sensitivities by geometry parameters: a parameter that places the structure (docs/parameters.md,
"Geometry parameters").

A parameter used in a body's ``at``, a beam's free end ``from``/``to``, an end's ``offset``, a beam's
``y_axis`` or a hinge's ``axis`` (the last two in 3D models) moves the reference configuration X(p): every
node's position at t = 0 (a beam's inner nodes interpolate its grid points), each element's undeformed
length L0 and its nodal frame at θ = 0 in node axes E0 (from the beam's direction and ``y_axis``), the
grid-point offsets r_g and the hinge axes a. The model's state holds absolute positions and frames
(State.x, State.T; every node starts with T = I), so the solution depends on p

(a) through the start: δq_0 = (δX of the free nodes, δπ = 0, δθ = 0), and with the given rigid spin ω the
    velocities v_O + ω × x by δv_0 = ω × δX and the rate θ̇ = a·ω of a free hinge on a fixed or prescribed body
    (latdyn/assembly/initial.py: its beam turns with ω, its body does not) by δθ̇ = δa·ω where its axis moves
    (:meth:`ReferenceGeometry.initial_velocity_tangent`), and
(b) through the residual at a fixed state: ∂r/∂p = Σ_e (∂F^e/∂(reference data)) · δ(reference data)_e,
    the element's internal force, and with inertia or gravity M a + g − Q, differentiated along one
    variation of its reference data by the generated ``beam_internal_force_D_reference`` and
    ``beam_inertia_force_D_reference`` (codegen/derivation.py ``reference_first_variation``):

        δx_i  = δX of end i's node where it is fixed or prescribed (x = at + translation(t); a free
                node's position is the state's),
        δo_i  = T_j δr_g (the offset's global form moved),
        ψ_i   = T_j R(a, θ) φ = T_e E0ᵀ φ,  δE0 = skew(φ) E0 (the frame turned, spatial at the end),
                plus T_j J(θa) θ δa where the hinge axis moves (R(a, θ) = exp(θ skew a), J the left
                Jacobian of exp; the generated ``reference_variation_at_state``),
        δh_i  = T_j δa,  δa = (I − a aᵀ) δv/|v| of the axis v as given,
        δL0   = x̂ · (δB − δA) / n   (A, B the beam's grid points, n its elements).

φ is the turn of the beam's frame [x̂, ŷ, x̂ × ŷ]: x̂ = (B − A)/|B − A| and ŷ the loader's rule (``y_axis`` v
made unit, y_0 = v/|v|, less its x̂ part, or global z × x̂), so φ = ½ Σ e_k × δe_k with
δx̂ = (I − x̂x̂ᵀ)(δB − δA)/|B − A|, δy_0 = (I − y_0 y_0ᵀ)δv/|v| and δŷ from that rule; in a planar model the
frame is [x̂, n × x̂, n] and φ = x̂ × δx̂. A point probe at a beam's end moves with its offset (δ(x + T r)
gains T δr), a displacement's reference with δX + δr; a load there by the generated ``point_load_D_offset``
(the load is linear in its offset); displacement control's held displacement by the same
(:meth:`ReferenceGeometry.control_moves`). Through latches, rigid stops and compliant stops the event
machinery of latdyn/analyses/transient_sensitivities.py takes them as any parameter (its impulse weight's
∂/∂p from ∂r/∂p).

Beside rigid links and guides (:func:`_linked_refusal`) a parameter is taken where it moves each rigid link and each
guided body together with the part it hangs from (a rigid translation of every linked subtree, or none): the links'
and guides' reference geometry (an edge's o, b and a, latdyn/model/links.py; a link's inertia; a closure's data) is
then that of p, and so are the reduction's J and Pᵀ (translation-invariant). A dependent node moves with its root: at
a fixed state by nothing where the root is free (its position is the coordinates'), by the root's δX where the root is
fixed or prescribed (:attr:`ReferenceGeometry.held`: such a node's reference point in the elements' variations, in
:meth:`ReferenceGeometry.held_moves`); its δX of the start is its root's (:attr:`ReferenceGeometry.node_moves`, a
displacement's reference). A point's velocity v + ω × T r moves with its arm, not with a held root's δX. Of a link's or
guide's own geometry one move is taken: the point of an edge — a rigid link's start point on its body (o, fixed in the
parent A's axes), its end point on the body A it carries (b, that body moved the other way: the link keeps its length
and direction), a guide's origin (o, A the body it slides on) — moved with all that the edge carries
(:meth:`ReferenceGeometry._origin_move`), a translation of the subtree S below the edge by δo fixed in A's axes. Where A
never turns (fixed, prescribed, or sliding on guides from one: :func:`_never_turns`) S's rates, joint twists, J and the
links' inertia stay those of p and its nodes (held: their root is fixed or prescribed) move by δo. Where A turns, S
moves at a fixed state by d = T_A δo, its coordinate velocities by ω_A × d, its accelerations by α_A × d + ω_A × (ω_A ×
d) (A's rigid field), and J's columns that reach A (A's root's turn, the hinges above A: g × (x − o) of S's points moves
by g × d) move Pᵀ r by d × F_S on A's rotational rows, F_S the residual's forces on S before the reduction: ∂r/∂X = K d
+ C δv + M δa + that moment with the exact K, C, M before the reduction (:meth:`ReferenceGeometry._add_shifts`), on the
per-step path and in the loop of steps alike (csrc/turning_shifts.c); through latches and rigid stops, the impulse weight's
(∂K/∂p) w with ∂P/∂p's move along w (the inertia forces' and the elements' weight's d × F_S turned with A:
:meth:`ReferenceGeometry.moments_turned`; the static ∂r/∂p it differences holds neither, :meth:`ReferenceGeometry.add`),
beside friction slipping, compliant stops and
controllers of joints' angles and rates and points' positions (a sensed point's d carried by K d through the
controller's coupling, not again by ∂f/∂s: latdyn/analyses/sensitivities.py ``ControllerTerms._shift_sensed``);
refused beside other controllers and probes whose explicit part does not hold the shift (:func:`_turning_refusal`). A rigid link's length or direction is taken where the body at its end (and all it
carries) moves relative to its start and the link's own offsets, y_axis and hinge axes do not (a gimbal's ring offset):
the link's vector v = B − A is its end edge's o, fixed in the link node L's axes, so the subtree below shifts by T_L δv
as above (A = L, which turns), and the link's joint-body block (m = ρA L, c = v/2, I = E D Eᵀ about c,
latdyn/model/model.py ``rigid_link_inertia``) moves by (δm, δc, δI) (:func:`link_inertia_moved`, the generated
``rigid_link_inertia_D_ends``): its row moves by the
generated ``joint_body`` at (δm, c, δI) (linear in m and I at a fixed c) and ``joint_body_D_com`` along δc (degree two
in c) at L's fixed frame and motion (:meth:`ReferenceGeometry._add_link_inertia`), and its end point's offset by δv;
taken and refused beside events, controllers and other probes as a shift on a part that turns. The shifts' lines
(d = T_A δo, its rigid field, K d + C δv + M δa, d × F_S and the links' rows) are csrc/turning_shifts.c, which this
module calls and the loop of steps calls too (latdyn/analyses/sensitivities_in_loop.py: these runs' smooth steps in C,
not beside controllers that read other than joints' angles and rates).

Refused (:func:`geometry_refusal`, and :class:`ReferenceGeometry` where the model decides, which
:func:`model_refusal` finds from the scene before anything is compiled): ``y_axis`` and
hinge axes in a planar model, a point leaving a planar model's plane, prescribed rotations (a body's, a
hinge angle: the velocities they carry into the structure at t = 0 move with its points), a parameter that moves a
rigid link's or a guide's own geometry (a link's length or direction together with its own offsets, from a free end
point or closing a loop, its y_axis or hinge axes, a slider-crank's closed loop: the reduction's ∂J/∂X is not
generated), guides beside a
given initial_velocity.angular (the slides' initial rates move with the points), cables, controllers, arc length (its
first step's length moves with ∂K/∂p, not generated), a kernel variant generated without the reference derivatives.
The discrete adjoint takes geometry parameters wherever this module does: the start's move, ∂r/∂p and the probes'
moves of this module transposed (latdyn/analyses/adjoint_sensitivities.py), beside rigid links, guides and controllers
too (tests/test_adjoint_geometry_linked.py).
"""
from __future__ import annotations

import ctypes
import re

import numpy as np

from latdyn.analyses.parameter_keys import laws_naming
from latdyn.model.model import DEPENDENT, FIXED, FREE, PRESCRIBED

__all__ = ["GEOMETRY_KEY", "geometry_refusal", "model_refusal", "ReferenceGeometry"]

#: the generated kernels' reference block (codegen/conventions.py REFERENCE): dx1 dx2 doffset1 doffset2 psi1 psi2
#: dL0 daxis1 daxis2
WIDTH = 25

#: the generated kernels ∂r/∂p of a geometry parameter is made of (with a reference block of :data:`WIDTH`)
REFERENCE_KERNELS = ("beam_internal_force_D_reference", "beam_inertia_force_D_reference")

#: a number that places the structure: a body's reference point, a beam's free end point, an end's offset, a
#: beam's y_axis, a hinge's axis
GEOMETRY_KEY = re.compile(r"^(?:bodies\.(?P<body>[^.]+)\.at|beams\.(?P<beam>.+)\.(?:(?P<side>from|to)"
                          r"(?P<offset>\.offset)?|(?P<y>y_axis)|(?P<hinge>start|end)\.hinge\.axis))"
                          r"\[(?P<axis>[0-2])\]$")


def geometry_refusal(scene, name: str, used: str) -> str | None:
    """Why the sensitivity by ``name``, used at the geometry key ``used``, is not computed exactly here, or
    None (module docstring)."""
    solve = scene.solve
    where = f"parameter {name!r} is used at {used}, a number that places the structure"
    if solve.analysis == "static" and solve.method not in ("load-control", "displacement-control"):
        return (f"{where}: geometry sensitivities of static paths are computed under load control and displacement "
                f"control only, not {solve.method} (its first step's length moves with ∂K/∂p, not generated)")
    turning = [f"bodies.{name}.motion.rotation" for name, body in scene.bodies.items()
               if body.prescribed and getattr(body, "rotation_angle", None) is not None]
    turning += [f"beams.{beam}.{which}.hinge.angle" for beam, which, hinge in scene.hinges if hinge.angle is not None]
    if turning:
        return (f"{where}: with a prescribed rotation ({turning[0]}) the initial velocities carried through the "
                "joints move with the points, which is not differentiated yet (prescribed translations are: "
                "x = at + translation(t))")
    moving = [f"bodies.{name}.motion.translation" for name, body in scene.bodies.items() if body.translation is not None]
    free_joints = any(hinge.angle is None for _, _, hinge in scene.hinges) or any(
        body.guide is not None and body.guide.position is None for body in scene.bodies.values())
    if moving and free_joints and _closed_loop(scene):
        return (f"{where}: with a prescribed translation ({moving[0]}) driving a closed loop with free joints, the "
                "joint rates that close the loop at t = 0 move with the points (latdyn/assembly/initial.py), which "
                "is not differentiated yet")
    why = _vertical_frame_refusal(scene, name) or _linked_refusal(scene, name)
    if why is not None:
        return f"{where}: {why}"
    if scene.cables:
        return f"{where}: geometry sensitivities with cables (their attachment points move) are not computed yet"
    if getattr(scene, "controllers", None):
        why = _controllers_refusal(scene)
        if why is not None:
            return f"{where}: geometry sensitivities with controllers {why} are not computed yet"
    return None


def _vertical_frame_refusal(scene, name: str) -> str | None:
    """Why ``name`` is not differentiable through a vertical beam's frame (a phrase), or None. Without a ``y_axis``
    the loader takes ŷ = Z × x̂ (latdyn/scene/loader.py ``beam``), and e_y where x̂ is vertical: there the frame jumps
    (a tilt of the chord along y turns ŷ by 90° about x̂; along x it is continuous, a flip of ŷ and ẑ at most), so a
    section whose y and z values differ (EIy, EIz; rhoIy, rhoIz; GAy, GAz) has no derivative by a move that tilts
    the chord along y — the generated blocks take the rule held (:func:`_frame_turn`, ``rigid_link_inertia_D_ends``),
    central differences see the same jump on both sides: both would report a number."""
    moves = _scene_moves(scene, name)
    for beam in scene.beams.values():
        if beam.y_given is not None:
            continue
        chord = np.asarray(beam.end.point, float) - np.asarray(beam.start.point, float)
        x = chord / np.linalg.norm(chord)
        if np.hypot(x[0], x[1]) >= 1e-9:
            continue
        tilt = moves["point"][(beam.name, "to")] - moves["point"][(beam.name, "from")]
        s = beam.section
        symmetric = s.EIy == s.EIz and s.rhoIy == s.rhoIz and s.GAy == s.GAz
        if tilt[1] != 0.0 and not symmetric:
            return (f"it tilts the vertical beam {beam.name!r} along y, whose frame the loader's rule for ŷ (no "
                    "y_axis given) turns by a jump there while its section's y and z values differ: no derivative "
                    f"exists; expected a y_axis for beams.{beam.name}")
    return None


def _scene_moves(scene, name: str) -> dict:
    """The moves by ``name`` of the numbers that place the structure, from the scene alone: {"at": {body: δat},
    "point": {(beam, side): δ(grid point)}, "offset": {(beam, side): δoffset}, "y": {beam: δy_axis},
    "axis": {(beam, end): δaxis}} (side "from"/"to", end "start"/"end"; a grid point at a body moves with its
    ``at`` and its offset, a free one with its ``from``/``to``)."""
    moves = {"at": {}, "point": {}, "offset": {}, "y": {}, "axis": {}, "free": {}}
    for key in scene.parameters.depending_on(name):
        m = GEOMETRY_KEY.match(key)
        if m is None:
            continue
        slope, axis = _slope(scene, key, name), int(m["axis"])
        if m["body"] is not None:
            target = moves["at"].setdefault(m["body"], np.zeros(3))
        elif m["y"] is not None:
            target = moves["y"].setdefault(m["beam"], np.zeros(3))
        elif m["hinge"] is not None:
            target = moves["axis"].setdefault((m["beam"], m["hinge"]), np.zeros(3))
        else:
            target = moves["offset" if m["offset"] else "free"].setdefault((m["beam"], m["side"]), np.zeros(3))
        target[axis] += slope
    for beam in scene.beams.values():
        for side, end in (("from", beam.start), ("to", beam.end)):
            moved = (moves["at"].get(end.body, np.zeros(3)) + moves["offset"].get((beam.name, side), np.zeros(3))
                     if end.body is not None else moves["free"].get((beam.name, side), np.zeros(3)))
            moves["point"][(beam.name, side)] = moved
    return moves


def _linked_refusal(scene, name: str) -> str | None:
    """Why the geometry parameter ``name`` is not exact beside rigid links and guides (a phrase), or None. Taken:
    a parameter that moves each rigid link and each guided body together with the part it hangs from (a rigid
    translation of every linked subtree, or none), so that no link's or guide's reference geometry — a link's
    offset from its parent body (o), its arm (b) and length, its hinge axes and inertia, a guide's origin on the
    body it slides on — moves with it: the reduction's J, its closure equations and the links' bodies are then
    those of p, a dependent node moving with its root (:class:`ReferenceGeometry`). Taken too: an edge's own point o
    (a link's start or end offset, a guide's origin) moved with all the edge carries, a translation of that subtree (on
    a part that turns: :func:`_turning_refusal`), and a link's length or direction alone: its end edge's o moved with
    all the edge carries and the link's inertia block with it (module docstring). Other moves of that reference geometry
    (∂J/∂X and the closure's ∂/∂X, not generated yet) are refused, naming what moves."""
    rigid = [beam for beam in scene.beams.values() if beam.rigid]
    guided = [body for body in scene.bodies.values() if body.guide is not None]
    if not (rigid or guided):
        return None
    moves = _scene_moves(scene, name)
    unmoved = np.zeros(3)
    if guided and np.any(np.asarray(scene.initial_velocity.angular, float) != 0.0):
        return ("with guides and a given initial_velocity.angular, the slides' initial rates move with the points, "
                "which is not differentiated yet")
    closing = {beam.end.body for beam in rigid if beam.end.body is not None and
               scene.bodies[beam.end.body].guide is not None}
    turning = []   # the edges whose own point o moves on a part that turns (ReferenceGeometry.turning)
    for beam in rigid:
        start, end = moves["point"][(beam.name, "from")], moves["point"][(beam.name, "to")]
        what = None
        # the link's start point on its body (its edge's o) may move: the link and what it carries translate
        sides = () if beam.end.body not in closing else ("from", "to")
        if not sides and np.any(moves["offset"].get((beam.name, "from"), unmoved) != 0.0) and \
                not _never_turns(scene, beam.start.body, closing):
            turning.append(f"rigid link {beam.name!r}'s start point on {beam.start.body!r}")
        if not sides and np.any(moves["offset"].get((beam.name, "to"), unmoved) != 0.0):
            turning.append(f"rigid link {beam.name!r}'s end point on {beam.end.body!r}")
        own = any(np.any(moves["offset"].get((beam.name, side), unmoved) != 0.0) for side in ("from", "to")) or \
            np.any(moves["y"].get(beam.name, unmoved) != 0.0) or \
            any(np.any(moves["axis"].get((beam.name, end), unmoved) != 0.0) for end in ("start", "end"))
        if np.any(end != start) and not sides and not own and beam.start.body is not None and \
                beam.end.body is not None:
            # its length or direction: its end edge's o (the link's vector) moves with all the link carries, fixed
            # in the link's axes (ReferenceGeometry._origin_move), and its inertia block with it (_add_link_inertia)
            turning.append(f"rigid link {beam.name!r}'s length or direction")
        elif np.any(end != start):
            what = ("its length or direction (its end points moved apart) together with its own offsets, y_axis or "
                    "hinge axes, from a free end point or closing a slider-crank loop")
        elif any(np.any(moves["offset"].get((beam.name, side), unmoved) != 0.0) for side in sides):
            what = "an end's offset (the link's point on a body of the slider-crank loop it closes)"
        elif np.any(moves["y"].get(beam.name, unmoved) != 0.0):
            what = "its y_axis (its inertia's axes)"
        elif any(np.any(moves["axis"].get((beam.name, end), unmoved) != 0.0) for end in ("start", "end")):
            what = "a hinge axis"
        elif beam.end.body in closing and np.any(start != 0.0):
            what = "the slider-crank loop it closes (its pin or slider moved)"
        if what is not None:
            return (f"it moves the rigid link {beam.name!r}'s reference geometry ({what}): geometry sensitivities "
                    "that move the geometry of rigid links or guides (the reduction's ∂J/∂X) are not computed yet; "
                    "taken: a parameter that moves each rigid link with the part it hangs from, a link's start "
                    "point on its body together with all the link carries, or the body at a link's end with all it "
                    "carries relative to its start (the link's own offsets, y_axis and hinge axes unmoved)")
    for body in guided:
        parent = moves["at"].get(body.guide.on, unmoved) if body.guide.on is not None else unmoved
        moved = moves["at"].get(body.name, unmoved)
        # its origin may move (but a closing slider's): the guided body and what it carries translate
        if np.any(moved != parent) and body.name not in closing and body.guide.on is not None and \
                not _never_turns(scene, body.guide.on, closing):
            turning.append(f"the guide of {body.name!r} on {body.guide.on!r}")
        if body.name in closing and np.any(moved != 0.0):
            on = repr(body.guide.on) if body.guide.on is not None else "the ground"
            return (f"it moves the guide of {body.name!r} relative to {on} (the guide's origin): geometry "
                    "sensitivities that move the geometry of rigid links or guides (the reduction's ∂J/∂X) are not "
                    "computed yet; taken: a parameter that moves each guided body with the part it slides on, or a "
                    "guide's origin (but a slider's a rigid rod closes a loop onto)")
    return _turning_refusal(scene, turning[0]) if turning else None


def _turning_refusal(scene, what: str) -> str | None:
    """Why a parameter that moves ``what`` (a hinge point or guide origin on a part that turns, a rigid link's length or
    direction: its subtree shifted in the part's axes, :meth:`ReferenceGeometry._add_shifts`) is not exact here, or
    None. Taken in transient runs and static paths with point (in global axes), hinge and guide probes, through latches
    and rigid stops (the event's time from the joint's coordinate, which holds no reference; the impulse weight's
    ∂/∂X with the shift's own move along w, :meth:`ReferenceGeometry.moments_turned`), beside friction slipping and
    compliant stops (forces of the joint's coordinate; a stick beside rigid links is refused when it comes,
    latdyn/analyses/transient_sensitivities.py ``_refuse_what_a_held_angle_moves``), beside controllers whose sensors
    :func:`_sensor_taken_shifted` takes, inputs and other controllers. Not beside controllers reading anything else
    (joints' forces, velocities: not checked with the shift), or other probes (sections', bodies' axes, energies: their
    explicit parts do not hold it). Through latches and rigid stops under gravity too: the shifted elements' weight
    is in the impulse weight's (∂K/∂X) w with the inertia forces (``ReferenceGeometry.add`` at ``weight_factor`` 0,
    latdyn/analyses/transient_sensitivities.py ``_shifts_turned``; refused before that, 49e0f6c)."""
    probes = {p.name: p for p in scene.output.probes}
    for controller in scene.controllers.values():
        sensor = next((probes[read] for read in controller.reads if read in probes and not _sensor_taken_shifted(
            probes[read])), None)
        if sensor is not None:
            return (f"it moves {what}, a part that turns, beside controller {controller.name!r} reading the "
                    f"{sensor.kind} probe {sensor.name!r} ({sensor.quantity}): with that shift, controllers reading "
                    "joints' angles and rates, points' positions and displacements (in global axes), inputs and "
                    "other controllers are taken")
    other = next((p.name for p in scene.output.probes if not (
        p.kind in ("hinge", "guide") or (p.kind == "point" and p.frame == "global"))), None)
    if other is not None:
        return (f"it moves {what}, a part that turns, beside the probe {other!r}: only points' (in global axes), "
                "hinges' and guides' probes are differentiated with that shift yet")
    return None


def _sensor_taken_shifted(probe) -> bool:
    """Whether a controller's sensor ``probe`` is differentiated beside a shift on a part that turns: a joint's angle or
    rate (a coordinate: no reference in it), a point's position or displacement in global axes (its move d by the
    shift carried by ∂r/∂X's K d through the controller's coupling, the rest of its explicit part through ∂f/∂s:
    ``sensitivities.ControllerTerms._shift_sensed``)."""
    if probe.kind in ("hinge", "guide"):
        return probe.quantity in ("angle", "position", "rate")
    return probe.kind == "point" and probe.frame == "global" and probe.quantity in ("position", "displacement")


def _never_turns(scene, name, closing: set) -> bool:
    """Whether body ``name`` never turns and its position is a held part's and slides: it is fixed, or prescribed (a
    translation: prescribed rotations are refused beside geometry parameters, :func:`geometry_refusal`), or it slides
    on a guide on the ground or on such a body (a guide keeps its parent's orientation; not a slider a rigid rod
    closes a loop onto, ``closing``). An edge from it (a rigid link's start hinge, a guide on it) whose own point o
    moves translates the subtree it carries by that constant vector at a fixed state: no rate, joint twist, J or
    inertia of the links moves (module docstring; :meth:`ReferenceGeometry._origin_move` the same on the model)."""
    if name is None:
        return False
    body = scene.bodies[name]
    if body.guide is not None:
        return name not in closing and (body.guide.on is None or _never_turns(scene, body.guide.on, closing))
    return bool(body.fixed or body.prescribed)


def _controllers_refusal(scene) -> str | None:
    """What of ``scene``'s controllers keeps geometry sensitivities from being exact (a phrase completing "with
    controllers …"), or None. Taken: continuous controllers (with states, and sampled ones, too where every controller
    reads joints' angles and rates, inputs or controllers alone: no sensor that holds the reference), in transient runs
    (through latches and rigid stops too: the events' machinery takes them as any parameter), that read section
    forces (their ∂S/∂X from the generated ``beam_section_forces_D_reference`` through ∂f/∂s:
    latdyn/analyses/sensitivities.py ``ControllerTerms.sensed_force_slopes``), points' positions and displacements
    (their ∂s/∂X at a fixed state the probe's explicit part, :meth:`ReferenceGeometry.point_moves`, through ∂f/∂s
    alike: ``sensitivities.is_placed_point``), hinge and guide angles and rates (free coordinates: no reference in
    them), free joints' torques and forces (:func:`_free_joint_force`: laws of θ, θ̇, t), inputs and earlier
    controllers, and drive hinge torques or guide forces (a joint's coordinate: no reference either) or loads at points
    whose offset no parameter moves (their nodes' rows, as without geometry). Other sensors (points' velocities, cables,
    prescribed or frictional joints' forces), loads at a moved offset (its arm moves, its values are the controller's)
    and static paths are not differentiated by geometry yet."""

    controllers = scene.controllers
    if scene.solve.analysis != "transient":
        return "on a static path (transient runs take them)"
    probes = {p.name: p for p in scene.output.probes}
    stated = [c.name for c in controllers.values() if c.states or c.sampled]
    for c in controllers.values():
        for read in c.reads:
            probe = probes.get(read)
            if probe is None:   # an input or an earlier controller
                continue
            joint = probe.kind in ("hinge", "guide") and probe.quantity in ("angle", "position", "rate")
            if stated and not joint:
                return (f"with states or sampled ({stated[0]}) beside a controller reading a {probe.kind} probe "
                        f"({c.name} reads {read!r}: with states or samples, joints' angles and rates, inputs and "
                        "controllers are taken)")
            point = probe.kind == "point" and probe.quantity in ("position", "displacement")
            if not (joint or point or probe.kind == "element" or _free_joint_force(scene, probe)):
                return (f"reading {probe.kind} probes ({c.name} reads {read!r}: section forces, joint angles and rates, "
                        "free joints' torques and forces, points' positions and displacements are taken)")
    moved_ends = {end for name in scene.solve.sensitivities
                  for end, offset in _scene_moves(scene, name)["offset"].items() if np.any(offset != 0.0)}
    for key in laws_naming(scene, set(controllers)):
        load = re.match(r"^loads\[(\d+)\]\.", key)
        if load is not None:
            at = scene.loads[int(load[1])].at
            end = None if getattr(at, "beam", None) is None else (
                at.beam, "from" if at.node == 0 else "to" if at.node == scene.beams[at.beam].elements else None)
            if end not in moved_ends:
                continue
            return (f"driving {key}, a load at an end whose offset a parameter moves (hinge torques, guide forces and "
                    "loads at unmoved offsets are taken)")
        if not (key.endswith(".hinge.torque") or key.endswith(".guide.force")):
            return f"driving {key} (hinge torques, guide forces and loads are taken)"
    return None


def _free_joint_force(scene, probe) -> bool:
    """Whether ``probe`` reads a free joint's torque or force: its law's value f(θ, θ̇, t), which holds no reference
    (no geometry parameter moves it at a fixed state; its laws' own parameters: ``sensitivities.moved_forces``), not a
    prescribed joint's reaction, nor a joint with friction (its stick is a reaction)."""
    if probe.quantity not in ("torque", "force"):
        return False
    if probe.kind == "hinge":
        joint = next((h for beam, end, h in scene.hinges if (beam, end) == (probe.beam, probe.end)), None)
        return joint is not None and joint.angle is None and joint.friction is None
    if probe.kind == "guide":
        joint = scene.bodies[probe.body].guide
        return joint is not None and joint.position is None and joint.friction is None
    return False


def _closed_loop(scene) -> bool:
    """Whether the joints close a loop: beams joining bodies, guides joining theirs to ``on`` (or the
    ground), every fixed or prescribed body being the ground."""
    root = {}

    def find(part):
        while root.setdefault(part, part) != part:
            part = root[part]
        return part

    def ground_or(name):
        body = scene.bodies[name]
        return "ground" if body.fixed or body.prescribed else name
    for beam, spec in scene.beams.items():
        for end in (spec.start, spec.end):
            if end.body is not None:
                a, b = find(("beam", beam)), find(ground_or(end.body))
                if a == b:
                    return True
                root[a] = b
    for name, body in scene.bodies.items():
        if body.guide is not None:
            a, b = find(ground_or(name)), find(ground_or(body.guide.on) if body.guide.on else "ground")
            if a == b:
                return True
            root[a] = b
    return False


def model_refusal(scene, name: str, used: str):
    """The SceneError that :class:`ReferenceGeometry` raises where the model decides — the kernel variant
    without the reference derivatives, a ``y_axis`` or hinge ``axis`` in a planar model, a point moved
    off a planar model's plane — found from the scene alone (the plane of ``solve.planar: auto``, the
    generated kernels' metadata), so that ``latdyn check`` and a run refuse it before anything is
    compiled; None otherwise. ``used``: a geometry key of parameter ``name``."""
    from latdyn.model.kernels import generated_info, planar_variant
    from latdyn.model.planar import find_plane

    plane = find_plane(scene)[0]
    formulation = scene.solve.formulation
    variant = formulation if plane is None else planar_variant(formulation, plane)
    if not _holds_reference_derivatives(generated_info(variant)):
        return _without_kernels(scene, variant)
    match = GEOMETRY_KEY.match(used)
    if plane is None:
        return None
    if match["y"] is not None:
        return _planar_y_axis(scene, match["beam"])
    if match["hinge"] is not None:
        return _planar_hinge_axis(scene, match["beam"], match["hinge"])
    if int(match["axis"]) == plane and _slope(scene, used, name) != 0.0:
        return _off_the_plane(scene)
    return None


def _slope(scene, key: str, name: str) -> float:
    """∂(the number at ``key``)/∂``name`` at the parameters' values (a number as text read as it is: SymPy's parse,
    ≈ 0.3 ms, only for what is not one)."""
    text = scene.parameters.derivative(key, name)
    try:
        return float(text)
    except (TypeError, ValueError):
        import sympy as sp

        return float(sp.sympify(text))


def _holds_reference_derivatives(info: dict) -> bool:
    return all(name in info and dict(info[name]["inputs"]).get("reference") == WIDTH for name in REFERENCE_KERNELS)


def _without_kernels(scene, variant: str):
    from latdyn.errors import SceneError

    return SceneError(scene.file, "solve.sensitivities",
                      f"geometry parameters need the kernels {REFERENCE_KERNELS[0]} and {REFERENCE_KERNELS[1]} "
                      f"(reference block of {WIDTH}), which the generated variant {variant!r} does not hold yet "
                      f"(python -m codegen --variant {variant})")


def _planar_y_axis(scene, beam: str):
    from latdyn.errors import SceneError

    return SceneError(scene.file, "solve.sensitivities",
                      f"a parameter of beams.{beam}.y_axis in a planar model (whose section axes the plane sets); "
                      "expected solve.planar: off for it (docs/parameters.md, \"Geometry parameters\")")


def _planar_hinge_axis(scene, beam: str, end: str):
    from latdyn.errors import SceneError

    return SceneError(scene.file, "solve.sensitivities",
                      f"a parameter of beams.{beam}.{end}.hinge.axis in a planar model (whose hinge axes are its "
                      "normal); expected solve.planar: off for it (docs/parameters.md, \"Geometry parameters\")")


def _off_the_plane(scene):
    from latdyn.errors import SceneError

    return SceneError(scene.file, "solve.sensitivities",
                      "a geometry parameter moves a point off the plane of the planar model; expected "
                      "solve.planar: off for such a parameter (docs/parameters.md, \"Geometry parameters\")")


class ReferenceGeometry:
    """The reference configuration's derivative by the geometry parameters of a run (module docstring):
    :meth:`initial_tangent` (δq_0), :meth:`add` (∂r/∂p at a state) and :meth:`point_moves` (a probe
    point's offset and reference moved)."""

    def __init__(self, owner):
        self.owner = owner
        # what the methods below make once and keep (None: not made yet): the shifts at the anchors' last motion
        # (:meth:`_shifted`), the C layout per numbering (:meth:`shift_layout`), the assembler's pattern as int64
        # (:meth:`_assembled_exact`), the moved links' blocks (:meth:`_link_blocks`), the moved (column, element) pairs
        self._shifts_held = self._shift_layout_held = self._pattern_held = None
        self._link_blocks_held = self._moved_pairs = None
        self.scene, self.model, self.kernels = owner.scene, owner.model, owner.kernels
        model, k = self.model, len(owner.names)
        self.k = k
        #: column -> {key: dvalue/dp} of the geometry uses
        uses: dict[int, dict[str, float]] = {}
        for key, laws in owner.derivatives.items():
            if GEOMETRY_KEY.match(key):
                for column, law in laws.items():
                    uses.setdefault(column, {})[key] = float(law.value(0.0, 0.0, 0.0))
        self._refuse_without_kernels()
        n_nodes, n_elements = len(model.nodes), len(model.element_nodes)
        #: the nodes no coordinate carries: fixed and prescribed ones (x = at + translation(t)) and the dependent
        #: nodes of rigid links and guides whose root is one (they move with it: :func:`_linked_refusal`)
        links = model.links
        roots = links.root if links is not None else {}
        self.held = np.array([node.kind in (FIXED, PRESCRIBED) or (
            node.kind == DEPENDENT and model.nodes[roots[i]].kind in (FIXED, PRESCRIBED))
            for i, node in enumerate(model.nodes)], bool)
        #: δX of every node (n_nodes, 3, k), the elements' reference variations (n_elements, WIDTH, k) less the
        #: parts that depend on the state (ψ, δo and δh are in node axes here: φ, δr_g and δa), δr_g of the
        #: beams' ends
        self.node_moves = np.zeros((n_nodes, 3, k))
        #: δX of every node at a fixed state where no coordinate carries it and it is the same at every state (the
        #: node_moves less the shifts of edges on a part that turns, :attr:`turning`)
        self.fixed_moves = np.zeros((n_nodes, 3, k))
        #: (edge index, column, δ, anchor A) of the edges whose own point moves on a part A that turns: o by δ in the
        #: parent's axes (A the parent), a link end's b by δ in the child's (A the child) (:meth:`shifts`)
        self.turning: list[tuple[int, int, np.ndarray, int]] = []
        #: (link, link node, column, δv) of the rigid links whose vector v = B − A (their length or direction) moves by
        #: δv (global axes at t = 0): their joint body's mass, centre and inertia move with it (:meth:`_add_link_inertia`)
        self.link_moves: list[tuple[str, int, int, np.ndarray]] = []
        self.variations = np.zeros((n_elements, WIDTH, k))
        self.end_offsets: dict[tuple[str, int], np.ndarray] = {}
        #: δa (3, k) of the hinges whose axis moves, by their index in model.hinges
        self.axis_moves: dict[int, np.ndarray] = {}
        for column, by_key in uses.items():
            self._column(column, by_key)
        #: (load, node, the moved offset (3, k)) of the loads at a beam end whose offset moves
        self.moved_loads = []
        for index, load in enumerate(self.scene.loads):
            ref = load.at
            if getattr(ref, "beam", None) is not None and ref.node in (0, self.scene.beams[ref.beam].elements):
                moved = self.end_offsets.get((ref.beam, 0 if ref.node == 0 else 1))
                if moved is not None:
                    self.moved_loads.append((index, model.point(ref)[0], moved))
        if model.plane is not None and (np.any(self.node_moves[:, model.plane] != 0.0) or any(
                np.any(offset[model.plane] != 0.0) for offset in self.end_offsets.values())):
            raise _off_the_plane(self.scene)
        self.elements = np.flatnonzero(np.any(self.variations != 0.0, axis=(1, 2)))

    def _refuse_without_kernels(self) -> None:
        """Refuse (SceneError naming ``solve.sensitivities``) a kernel variant generated before the reference
        derivatives (or with another reference block): they are what ∂r/∂p is made of here."""
        if not _holds_reference_derivatives(getattr(self.kernels, "info", {}) or {}):
            raise _without_kernels(self.scene, self.kernels.variant)

    # ------------------------------------------------------------------ the reference data moved
    def _column(self, column: int, by_key: dict) -> None:
        scene, model = self.scene, self.model
        body_at: dict[str, np.ndarray] = {}
        end_point: dict[tuple[str, str], np.ndarray] = {}
        end_offset: dict[tuple[str, str], np.ndarray] = {}
        y_given: dict[str, np.ndarray] = {}
        for key, slope in by_key.items():
            m = GEOMETRY_KEY.match(key)
            axis = int(m["axis"])
            if m["body"] is not None:
                body_at.setdefault(m["body"], np.zeros(3))[axis] += slope
            elif m["y"] is not None:
                y_given.setdefault(m["beam"], np.zeros(3))[axis] += slope
            elif m["hinge"] is not None:
                self._hinge_axis(m["beam"], m["hinge"], axis, slope, column)
            else:
                target = end_offset if m["offset"] else end_point
                target.setdefault((m["beam"], m["side"]), np.zeros(3))[axis] += slope
        for body, moved in body_at.items():
            self.node_moves[model.body_node[body], :, column] += moved
        # the beams this column moves (an end at a moved body, a moved end point or offset, a turned y_axis): the
        # others' nodes and variations stay 0 (a lattice's node coordinate moves the few members at its node; every
        # beam a column cost 1.5 ms a parameter on 72 members)
        touched = {name for name, _ in end_point} | {name for name, _ in end_offset} | set(y_given) | {
            beam.name for beam in scene.beams.values() if beam.start.body in body_at or beam.end.body in body_at}
        for beam in scene.beams.values():
            if beam.rigid:   # its link node: free at a free start point, else it follows its parent (below)
                if beam.start.body is None:
                    self.node_moves[model.beam_nodes[beam.name][0], :, column] = end_point.get(
                        (beam.name, "from"), np.zeros(3))
                continue
            if beam.name not in touched:
                continue
            grid = []
            for side, end in (("from", beam.start), ("to", beam.end)):
                offset = end_offset.get((beam.name, side), np.zeros(3))
                point = (body_at.get(end.body, np.zeros(3)) + offset) if end.body is not None \
                    else end_point.get((beam.name, side), np.zeros(3))
                grid.append(point)
                if np.any(offset):
                    self.end_offsets.setdefault((beam.name, 0 if side == "from" else 1), np.zeros((3, self.k)))[
                        :, column] += offset
            nodes, elements = model.beam_nodes[beam.name], model.beam_elements[beam.name]
            n = len(elements)
            for i, node in enumerate(nodes[1:-1], start=1):   # inner nodes interpolate the grid points
                self.node_moves[node, :, column] = grid[0] + (grid[1] - grid[0]) * i / n
            for which, end in ((0, beam.start), (1, beam.end)):
                if end.body is None:
                    self.node_moves[nodes[-1 if which else 0], :, column] = grid[which]
            turned = y_given.get(beam.name, np.zeros(3))
            if not (np.any(grid[0]) or np.any(grid[1]) or np.any(turned)):
                continue
            if np.any(turned) and model.plane is not None:
                raise _planar_y_axis(scene, beam.name)
            chord = beam.end.point - beam.start.point
            length = float(np.linalg.norm(chord))
            x = chord / length
            moved = grid[1] - grid[0]
            dx = (moved - x * (x @ moved)) / length
            phi = np.cross(x, dx) if model.plane is not None else _frame_turn(beam, x, dx, turned)
            v = self.variations[elements, :, column]
            v[:, 12:15] = v[:, 15:18] = phi
            v[:, 18] = x @ moved / n
            v[0, 6:9] = end_offset.get((beam.name, "from"), np.zeros(3))
            v[-1, 9:12] = end_offset.get((beam.name, "to"), np.zeros(3))
            self.variations[elements, :, column] = v
        self.fixed_moves[:, :, column] = self.node_moves[:, :, column]
        if model.links is not None:   # a dependent node moves with its parent, and by its edge's own δo where that
            for index, edge in enumerate(model.links.edges):   # (_linked_refusal: others unmoved)
                moved, anchor = self._origin_move(edge, body_at, end_offset)
                self.node_moves[edge.child, :, column] = self.node_moves[edge.parent, :, column] + moved
                self.fixed_moves[edge.child, :, column] = self.fixed_moves[edge.parent, :, column]
                if not np.any(moved):
                    continue
                if edge.sign < 0 and anchor == edge.parent:   # the link's vector: its inertia block moves too
                    self.link_moves.append((edge.link, edge.parent, column, moved))
                    # its end point's offset from the link node (a point probe, a load there) moves by δv
                    self.end_offsets.setdefault((edge.link, 1), np.zeros((3, self.k)))[:, column] += moved
                if self._never_turns(anchor):
                    self.fixed_moves[edge.child, :, column] += moved
                else:
                    self.turning.append((index, column, moved, anchor))
        # the held ends' reference points (x = at + translation(t), and the links that follow them); a free
        # node's, and a dependent node's on a free root, is the state's
        fixed = self.held
        for end in (0, 1):
            ends = model.element_nodes[:, end]
            self.variations[:, 3 * end:3 * end + 3, column] = np.where(
                fixed[ends][:, None], self.fixed_moves[ends, :, column], 0.0)

    def _origin_move(self, edge, body_at: dict, end_offset: dict) -> tuple[np.ndarray, int]:
        """δo of ``edge`` (latdyn/model/links.py) in one column, in its parent's axes at t = 0 (the global ones;
        :func:`_linked_refusal` takes no other edge's o moved): a guide's origin, the guided body's ``at`` less its
        parent's (the ground's: 0), and a rigid link's start point on its body, the ``from`` offset, with the anchor A
        the parent; a link's end edge's b, −(the ``to`` offset), fixed in the child's axes (x_c = x_p + T_p o + T_c b),
        with A the child, or else its o, the link's vector B − A moved (its length or direction), with A the link
        node (the parent; :attr:`link_moves`); zero for a closure. The child and its subtree translate by it, at a fixed state by δ where A
        never turns and by T_A δ where it does (:attr:`turning`, :meth:`shifts`): (δ, A)."""
        model = self.model
        if edge.closure:
            return np.zeros(3), edge.parent
        if edge.prismatic:
            parent = model.nodes[edge.parent]
            on = body_at.get(parent.body, np.zeros(3)) if parent.body is not None else np.zeros(3)
            return body_at.get(edge.link, np.zeros(3)) - on, edge.parent
        if edge.sign > 0:   # the link's start edge: o is the start offset
            return end_offset.get((edge.link, "from"), np.zeros(3)), edge.parent
        # the link's end edge: b = −(the end's offset), fixed in the child's axes (x_c = x_p + T_p o + T_c b)
        arm = -end_offset.get((edge.link, "to"), np.zeros(3))
        if np.any(arm):
            return arm, edge.child
        # else its o, the link's vector B − A between its end points on their bodies (at + offset), fixed in the link
        # node's axes: the link's length or direction
        beam, unmoved = self.scene.beams[edge.link], np.zeros(3)
        start = body_at.get(beam.start.body, unmoved) + end_offset.get((edge.link, "from"), unmoved)
        return body_at.get(beam.end.body, unmoved) - start, edge.parent

    def _never_turns(self, node: int) -> bool:
        """Whether ``node`` is fixed or prescribed, or reached from such a node through prismatic edges alone (its
        frame the identity at every state: :func:`_never_turns` on the scene)."""
        links = self.model.links
        while node in links.edge_of:
            edge = links.edges[links.edge_of[node]]
            if not edge.prismatic:
                return False
            node = edge.parent
        return self.model.nodes[node].kind in (FIXED, PRESCRIBED)

    def _hinge_axis(self, beam: str, end: str, component: int, slope: float, column: int) -> None:
        """A hinge axis's component moved: a = v/|v| (the loader's unit axis, node axes = global at t = 0) by
        δa = (I − a aᵀ) δv/|v|, into its element end's daxis (node axes; :meth:`add` turns it and adds the
        frame's turn through exp(θ skew a))."""
        model = self.model
        if model.plane is not None:
            raise _planar_hinge_axis(self.scene, beam, end)
        spec = getattr(self.scene.beams[beam], end).hinge
        v = np.asarray(spec.axis_given, float)
        a = v / np.linalg.norm(v)
        dv = np.zeros(3)
        dv[component] = slope
        da = (dv - a * (a @ dv)) / np.linalg.norm(v)
        elements = model.beam_elements[beam]
        element, which = (elements[0], 0) if end == "start" else (elements[-1], 1)
        self.variations[element, 19 + 3 * which:22 + 3 * which, column] += da
        h = next(i for i, hinge in enumerate(model.hinges) if hinge.kind == "hinge" and (hinge.beam, hinge.end) == (beam, end))
        self.axis_moves.setdefault(h, np.zeros((3, self.k)))[:, column] += da

    # ------------------------------------------------------------------ what the analyses use
    def initial_tangent(self) -> np.ndarray:
        """δq_0 on the free coordinates (n_dofs, k): the free nodes' reference points moved."""
        model = self.model
        full = np.zeros((model.n_total + 1, self.k))
        free = np.array([node.kind == FREE for node in model.nodes], bool)
        slots = model.node_dofs[:, 0:3]
        keep = free[:, None] & (slots < model.n_dofs)
        full[slots[keep]] = self.node_moves[keep]
        return full[:model.n_dofs]

    def initial_velocity_tangent(self) -> np.ndarray:
        """δv_0 on the free coordinates (n_dofs, k): a free node's velocity v_O + ω × x at t = 0
        (latdyn/assembly/initial.py; without prescribed rotations, :func:`geometry_refusal`, the twist of every
        part is the given rigid motion's or a prescribed translation's) moves by ω × δX; its ω does not. A free
        hinge's rate θ̇ = a·(ω_beam − ω_body) is 0 between two parts that both turn with ω, and a·ω on a fixed or
        prescribed (translating) body, which does not turn: there it moves by δa·ω where the hinge's axis moves."""
        model = self.model
        omega = np.asarray(self.scene.initial_velocity.angular, float)
        full = np.zeros((model.n_total + 1, self.k))
        free = np.array([node.kind == FREE for node in model.nodes], bool)
        slots = model.node_dofs[:, 0:3]
        keep = free[:, None] & (slots < model.n_dofs)
        spun = np.cross(omega[None, :, None], self.node_moves, axisa=1, axisb=1, axisc=1)   # (n_nodes, 3, k)
        full[slots[keep]] = spun[keep]
        for h, da in self.axis_moves.items():
            hinge = model.hinges[h]
            if hinge.angle is None and model.nodes[hinge.node].kind in (FIXED, PRESCRIBED):
                full[model.hinge_dofs[h]] += omega @ da
        return full[:model.n_dofs]

    def held_moves(self, node: int) -> np.ndarray:
        """(3, k): δX of ``node`` where no coordinate carries it — a fixed or prescribed node (x = at +
        translation(t)) moves with its ``at`` at a fixed state, and a dependent node of rigid links or guides with
        its fixed or prescribed root (:attr:`held`) —, zero for a node whose position is the state's."""
        if self.held[node]:
            return self.fixed_moves[node]
        return np.zeros((3, self.k))

    def velocity_moves(self, state, node: int) -> tuple[np.ndarray, np.ndarray]:
        """(the node's move at a fixed state that its velocity v + ω × T r does not turn with: :meth:`held_moves` and a
        :attr:`turning` shift d, the move of its velocity by that shift: δv of :meth:`shifts`, None without one), (3, k)
        each."""
        if not self.turning:
            return self.held_moves(node), None
        d, dv, _ = self.shifts(state)
        return self.held_moves(node) + d[node], dv[node]

    def point_moves(self, probe, state) -> tuple[np.ndarray, np.ndarray]:
        """(δ of the point's current position at a fixed state, δ of its position at t = 0), (3, k) each, for a
        point probe: its offset r (node axes) moved at a beam's end (T δr) and a fixed or prescribed node's δX
        (:meth:`held_moves`), its reference by δX + δr."""
        node, _ = self.model.point(probe.point)
        ref = probe.point
        offset = np.zeros((3, self.k))
        if getattr(ref, "beam", None) is not None:
            last = len(self.model.beam_nodes[ref.beam]) - 1
            which = 0 if ref.node == 0 else 1 if ref.node == last else None
            if which is not None:
                offset = self.end_offsets.get((ref.beam, which), offset)
        current = state.T[node] @ offset + self.held_moves(node)
        if self.turning:
            current = current + self.shifts(state)[0][node]
        return current, self.node_moves[node] + offset

    def control_moves(self, state) -> np.ndarray:
        """∂c/∂p (k,) at a fixed state of displacement control's controlled displacement
        c = d·(x + T r − x_0 − r_0) (latdyn/analyses/continuation.py ``displacement_control``): its point's offset
        moved less its start moved, along the direction d."""
        from types import SimpleNamespace

        control = self.scene.solve.control
        offset_moved, reference_moved = self.point_moves(SimpleNamespace(point=control.point), state)
        return np.asarray(control.direction, float) @ (offset_moved - reference_moved)

    def add(self, state, total: np.ndarray, load_factor: float, inertia: bool,
            weight_factor: float | None = None) -> None:
        """Add ∂r/∂p of the geometry parameters at ``state`` into ``total`` (all coordinates, k columns): the
        generated derivatives of F and, with inertia or gravity, of M a + g − Q along each element's variation;
        the elements' gravity at ``weight_factor`` (the load factor unless given: 0 leaves the static −λQ out,
        ParameterDerivatives.residual_derivatives ``element_gravity``), the loads' arms at ``load_factor``. At
        ``weight_factor`` 0 the :attr:`turning` shifts' part leaves the elements' weight out too (their K d without
        −λ ∂Q/∂q d, their F_S without −λQ: ``NativeModel.without_element_gravity``): that static ∂r/∂p, differenced
        along w, is an impulse weight's (∂K/∂p) w, whose K does not hold the elements' gravity tangent
        (latdyn/analyses/transient_sensitivities.py ``_stiffness_derivative``; the weight's moment turned is in
        ``_shifts_turned``). With it there, a gimbal's inner hinge point moving its heavy boom under gravity was 1.9e-6
        off Richardson differences of (∂K/∂X) w and 3.3e-6 … 1.3e-5 after a latch
        (tests/test_geometry_sensitivities_turning_gravity.py)."""
        if weight_factor is None:
            weight_factor = load_factor
        if self.turning and weight_factor == 0.0 and load_factor != 0.0:
            with self.owner.assembler.native(True).without_element_gravity():
                self._add_shifts(state, total, load_factor, inertia)
        elif self.turning:
            self._add_shifts(state, total, load_factor, inertia)
        if self.link_moves:
            self._add_link_inertia(state, total, load_factor, inertia)
        elements = self.elements
        if not len(elements):
            return
        model, k = self.model, self.k
        inputs = self.owner.assembler.native().element_inputs(state)
        m = len(elements)
        variation = self.at_state(state, elements, inputs[0][elements])
        rows = np.ascontiguousarray(variation.transpose(2, 0, 1).reshape(k * m, WIDTH))
        forces = self.reference_forces(inputs, np.tile(elements, k), rows, inertia, weight_factor).reshape(k, m, 14)
        for column in range(k):
            np.add.at(total[:, column], model.element_dofs[elements], forces[column])
        self._load_arms(state, total, load_factor)

    def shifts(self, state) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(d, δv, δa), (n_nodes, 3, k) each: the moves at ``state`` of the nodes below the edges of :attr:`turning`
        (an edge's own point o moved by δo on a parent A that turns): the subtree translates by d = T_A δo, fixed in
        A's axes, so its coordinate velocities move by ω_A × d and its accelerations by α_A × d + ω_A × (ω_A × d)
        (A's rigid field); zero for every other node. csrc/turning_shifts.c ``latdyn_turning_shifts``, the one
        implementation (the loop of steps calls it too)."""
        return self._shifted(state)[1:]

    def _shifted(self, state) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(each edge's d = T_A δo (len(turning), 3), then :meth:`shifts`' d, δv, δa) at ``state``, held for the
        anchors' motion last asked (the probes of one row, its step)."""
        anchors = sorted({anchor for _, _, _, anchor in self.turning})
        key = b"".join(state.T[a].tobytes() + state.w[a].tobytes() + state.alpha[a].tobytes() for a in anchors)
        held = self._shifts_held
        if held is not None and held[0] == key:
            return held[1]
        data, arrays, library = self.shift_layout()
        motion = _motion(state)
        library.latdyn_turning_shifts(ctypes.addressof(data), self.k, *(a.ctypes.data for a in motion))
        moves = arrays["moves"]
        shifted = (arrays["shift"].copy(), moves[0].copy(), moves[1].copy(), moves[2].copy())
        self._shifts_held = (key, shifted)
        return shifted

    def shift_layout(self) -> tuple:
        """(csrc/turning_shifts.c's TurningShifts for :attr:`turning`, the arrays it points into, the library), made
        per numbering (a latch's renumbers the coordinates): each edge's anchor A, column, δo and subtree
        (:meth:`_below`), the nodes' coordinates, and the buffers of the shifts; the loop of steps adds its part
        (latdyn/analyses/sensitivities_in_loop.py)."""
        model, k, turning = self.model, self.k, self.turning
        numbering = (model.n_assembled, model.node_dofs.tobytes())
        held = self._shift_layout_held
        if held is not None and held[0] == numbering:
            return held[1]
        from latdyn.assembly.library import TurningShiftsData, native_library

        belows = [self._below(index) for index, _, _, _ in turning]
        n_nodes = len(model.nodes)
        arrays = {
            "anchor": np.array([anchor for _, _, _, anchor in turning], np.int64),
            "column": np.array([column for _, column, _, _ in turning], np.int64),
            "moved": np.ascontiguousarray([moved for _, _, moved, _ in turning], np.float64),
            "below_from": np.cumsum([0] + [len(below) for below in belows]).astype(np.int64),
            "below": np.ascontiguousarray(np.concatenate(belows) if belows else [], np.int64),
            "node_dofs": np.ascontiguousarray(model.node_dofs, np.int64),
            "shift": np.zeros((len(turning), 3)), "moves": np.zeros((3, n_nodes, 3, k)),
            "assembled": np.zeros((3, model.n_assembled, k))}
        links = self._link_blocks()
        arrays.update({
            "link_node": np.array([node for _, node, _, _ in self.link_moves], np.int64),
            "link_column": np.array([column for _, _, column, _ in self.link_moves], np.int64),
            "link_moved_block": np.ascontiguousarray([moved for moved, _, _ in links], np.float64).reshape(-1, 13),
            "link_block": np.ascontiguousarray([block for _, block, _ in links], np.float64).reshape(-1, 13),
            "link_com_move": np.ascontiguousarray([dc for _, _, dc in links], np.float64).reshape(-1, 3),
            "gravity": np.ascontiguousarray(self.owner.assembler.gravity, np.float64)})
        body_kernel, com_kernel = (self.kernels.address(name) for name in ("joint_body", "joint_body_D_com"))
        if self.link_moves and (body_kernel is None or com_kernel is None):   # (a model with links evaluates in C)
            raise RuntimeError(f"kernel variant {self.kernels.variant!r}: joint_body and joint_body_D_com without C "
                               "libraries (a rigid link's length or direction moved)")
        data = TurningShiftsData(n=len(turning), n_nodes=n_nodes, n_assembled=model.n_assembled,
                                 n_links=len(self.link_moves), body_kernel=body_kernel, com_kernel=com_kernel)
        for name, array in arrays.items():
            setattr(data, name, array.ctypes.data if array.size else None)
        self._shift_layout_held = (numbering, (data, arrays, native_library()))
        return self._shift_layout_held[1]

    def _below(self, index: int) -> np.ndarray:
        """The nodes of edge ``index``'s subtree (its child and every node whose path passes the edge)."""
        held = self.__dict__.setdefault("_subtrees", {})
        if index not in held:
            links = self.model.links
            held[index] = np.array([node for node in links.dependent if index in links.path(int(node))], np.int64)
        return held[index]

    def _add_shifts(self, state, total: np.ndarray, load_factor: float, inertia: bool) -> None:
        """Add ∂r/∂p of the :attr:`turning` shifts (module docstring) into ``total`` (all coordinates): with the
        subtree S below the edge moved by (d, δv, δa) at fixed coordinates and rates (:meth:`shifts`), the residual
        on the assembled coordinates moves by K d + C δv + M δa (the exact K, C, M before the reduction:
        :meth:`_assembled_exact`), and the projection Pᵀ itself by
        d × F_S on the anchor A's rotational rows (F_S the assembled residual's force rows of S summed): the columns
        of J that reach A (its root's turn, the hinges above it) move S's points by (g × d) per unit rate, whose work
        on S's forces is g·(d × F_S); the columns below A move S as a whole and stay."""
        residual, (indptr, pattern, values) = self._assembled_exact(state, load_factor, inertia)
        data, _, library = self.shift_layout()
        into = total if total.flags.c_contiguous and total.dtype == np.float64 else np.ascontiguousarray(total, float)
        motion, residual = _motion(state), np.ascontiguousarray(residual, np.float64)
        library.latdyn_turning_shift_forces(ctypes.addressof(data), self.k, int(inertia),
                                            *(a.ctypes.data for a in motion), indptr.ctypes.data, pattern.ctypes.data,
                                            pattern.size, values.ctypes.data, residual.ctypes.data, into.ctypes.data)
        if into is not total:
            total[...] = into

    def _assembled_exact(self, state, load_factor: float, inertia: bool) -> tuple[np.ndarray, tuple]:
        """(r_all (n_assembled,), (indptr, column indices, M, C and the exact K as values (3, nnz) of that CSR pattern on
        the assembled coordinates)) at ``state``: the exact K (the inertia tangent, the joint bodies' inertia stiffness)
        before the reduction, and C and M with the inertia (else zeros). At the steps' load factor 1 with the inertia
        one native evaluation and one native scatter of the three onto the assembler's pattern
        (``Assembler.assembled_exact_values``, as the loop of steps scatters them), else the evaluation's blocks
        assembled (latdyn/assembly/linked.py ``evaluate_before_reduction``) on the full dense pattern."""
        from latdyn.assembly.linked import evaluate_before_reduction

        assembler, n_asm = self.owner.assembler, self.model.n_assembled
        if load_factor == 1.0 and inertia:
            residual, values = assembler.assembled_exact_values(state)
            pattern = assembler.pattern()
            held = self._pattern_held
            if held is None or held[0] is not pattern[1]:   # per numbering
                held = self._pattern_held = (pattern[1], *(np.ascontiguousarray(a, np.int64) for a in pattern))
            return residual, (*held[1:], values)
        ev, _ = evaluate_before_reduction(assembler, state, True, load_factor, inertia, inertia_tangent=True)
        zero = np.zeros((n_asm, n_asm))
        parts = [np.asarray(ev.combined(*part, dense=True)) if inertia or part == (0.0, 0.0, 1.0) else zero
                 for part in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))]
        indptr = np.arange(0, n_asm * n_asm + 1, n_asm, dtype=np.int64)
        pattern = np.ascontiguousarray(np.tile(np.arange(n_asm, dtype=np.int64), n_asm))
        return np.asarray(ev.residual), (indptr, pattern, np.ascontiguousarray([p.reshape(-1) for p in parts]))

    def moments_turned(self, state, along: np.ndarray, forces: np.ndarray) -> np.ndarray:
        """(n_total + 1, k): the move of the :attr:`turning` shifts' moments d × F_S (:meth:`_add_shifts`) when the
        configuration moves along ``along`` (P w on the assembled coordinates: each anchor A turns by Δπ_A, its
        rotational rows) at fixed ``forces`` (the assembled residual's rows, whose force rows of S sum to F_S): the
        shift d = T_A δ is fixed in A's axes, so δd = Δπ_A × d and the moment moves by (Δπ_A × d) × F_S on A's
        rotational rows. With the inertia forces it is the part of ∂K/∂p w (K of the reduction, its geometric term
        ∂Pᵀ/∂q · r_all) that the static ∂r/∂p differenced along w does not hold (an event's impulse weight:
        latdyn/analyses/transient_sensitivities.py ``_geometric_derivative``; 3.3e-6 of the gimbal's W w by its ring
        offset at its latch without it, 9.1e-5 of its hinge angle's sensitivity after)."""
        from latdyn.numerics.so3 import cross

        model = self.model
        out = np.zeros((model.n_total + 1, self.k))
        shifts = self._shifted(state)[0]
        for (index, column, _, anchor), shift in zip(self.turning, shifts):
            turn = along[model.node_dofs[anchor][3:6]]
            force = forces[model.node_dofs[self._below(index)][:, 0:3]].sum(axis=0)
            out[model.node_dofs[anchor][3:6], column] += cross(cross(turn, shift), force)
        return out

    def _add_link_inertia(self, state, total: np.ndarray, load_factor: float, inertia: bool) -> None:
        """Add ∂r/∂p of the rigid links whose vector v moves (:attr:`link_moves`) into ``total`` (all coordinates): their
        joint body's row (the generated ``joint_body``, Eqs. 2, 59) at the link node's fixed frame and motion, by its
        block (m, c, I) moved by (δm, δc, δI) (:func:`link_inertia_moved`): linear in (m, I)
        at a fixed c, so ``joint_body`` with the block (δm, c, δI), and by c the generated ``joint_body_D_com`` (of
        degree two in c) along δc; static (at rest) its λ-gravity alone."""
        gravity = load_factor * np.asarray(self.owner.assembler.gravity, float)
        if not inertia and not np.any(gravity):
            return
        data, _, library = self.shift_layout()
        into = total if total.flags.c_contiguous and total.dtype == np.float64 else np.ascontiguousarray(total, float)
        motion = tuple(np.ascontiguousarray(a, np.float64) for a in (state.T, state.w, state.a, state.alpha))
        library.latdyn_link_inertia_forces(ctypes.addressof(data), self.k, int(inertia), gravity.ctypes.data,
                                           *(a.ctypes.data for a in motion), into.ctypes.data)
        if into is not total:
            total[...] = into

    def _link_blocks(self) -> list:
        """(the block (δm, c, δI), the block (m, c, I), δc) of each of :attr:`link_moves` (1 × 13 blocks as the generated
        ``joint_body`` reads them), the same at every state: made once."""
        held = self._link_blocks_held
        if held is None:
            model, held = self.model, []
            for link, node, column, moved in self.link_moves:
                beam = self.scene.beams[link]
                b = int(np.flatnonzero(model.body_nodes == node)[0])
                dm, dc, dI = link_inertia_moved(self.kernels, beam, moved)
                moved_block = np.concatenate([[dm], model.body_com[b], dI.reshape(9)])[None]
                block = np.concatenate([[model.body_mass[b]], model.body_com[b], model.body_inertia[b].reshape(9)])[None]
                held.append((moved_block, block, dc))
            self._link_blocks_held = held
        return held

    def transposed_product(self, state, w: np.ndarray, load_factor: float, inertia: bool,
                           weight_factor: float) -> np.ndarray:
        """(k, m): (∂r/∂p)ᵀ w of the geometry parameters at ``state`` for the m columns of ``w`` (n_total + 1, m; all
        coordinates), :meth:`add`'s ∂r/∂p transposed onto w without forming it: the same generated kernels on the same
        rows, but only the (element, parameter) pairs whose reference the parameter moves (:meth:`moved_pairs`: a node
        coordinate of a lattice moves the few members at that node, where :meth:`add` takes every moved element for
        every parameter), each pair's 14 forces dotted with w at its element's coordinates; the loads at a moved
        offset through :meth:`add`'s columns (few). For the discrete adjoint (latdyn/analyses/adjoint_sensitivities.py
        ``residual_transposed_product``), whose cost it keeps from growing with k as the kernels' rows did."""
        model, k = self.model, self.k
        out = np.zeros((k, w.shape[1]))
        elements, columns = self.moved_pairs()
        if len(elements):
            inputs = self.owner.assembler.native().element_inputs(state)
            variation = self.pairs_at_state(state, elements, columns, np.ascontiguousarray(inputs[0][elements]))
            forces = self.reference_forces(inputs, elements, variation, inertia, weight_factor)
            np.add.at(out, columns, np.einsum("pi,pim->pm", forces, w[model.element_dofs[elements]]))
        if self.moved_loads:
            total = np.zeros((model.n_total + 1, k))
            self._load_arms(state, total, load_factor)
            out += total.T @ w
        return out

    def reference_forces(self, inputs: tuple, elements: np.ndarray, variation: np.ndarray, inertia: bool,
                         weight_factor: float) -> np.ndarray:
        """(P, 14): one row of the generated ``beam_internal_force_D_reference`` per row of ``variation`` (P, WIDTH, at
        the state) of element ``elements[i]`` and, with ``inertia`` or gravity (at ``weight_factor``), of
        ``beam_inertia_force_D_reference`` for the elements with mass; ``inputs``: the state's element geometry, rates
        and accelerations (``element_inputs``). What :meth:`add` (its k × m rows) and :meth:`transposed_product` (its
        pairs' rows) are made of."""
        geometry, rates, accelerations = inputs
        at = np.ascontiguousarray(geometry[elements])
        sections = np.ascontiguousarray(self.model.element_sections[elements])
        forces = np.asarray(self.kernels.beam_internal_force_D_reference(at, sections, variation)[1])
        forces = forces.reshape(len(elements), 14)
        gravity = weight_factor * np.asarray(self.owner.assembler.gravity, float)
        massive = np.any(sections[:, 5:8] != 0.0, axis=1)
        if (inertia or np.any(gravity)) and np.any(massive):
            on = np.flatnonzero(massive)
            rate = rates[elements[on]] if inertia else np.zeros((len(on), 14))
            acceleration = accelerations[elements[on]] if inertia else np.zeros((len(on), 14))
            moved = self.kernels.beam_inertia_force_D_reference(
                np.ascontiguousarray(at[on]), np.ascontiguousarray(rate), np.ascontiguousarray(acceleration),
                np.ascontiguousarray(sections[on]), np.ascontiguousarray(np.tile(gravity[None], (len(on), 1))),
                np.ascontiguousarray(variation[on]))[1]
            forces[on] += np.asarray(moved).reshape(len(on), 14)
        return forces

    def moved_pairs(self) -> tuple[np.ndarray, np.ndarray]:
        """(elements, columns) (P,) each: the pairs whose held reference variation is not zero (ordered by column,
        then element), found once."""
        held = self._moved_pairs
        if held is None:
            columns, elements = np.nonzero(np.any(self.variations != 0.0, axis=1).T)
            held = self._moved_pairs = (elements.astype(np.int64), columns.astype(np.int64))
        return held

    def pairs_at_state(self, state, elements: np.ndarray, columns: np.ndarray, at: np.ndarray) -> np.ndarray:
        """(P, WIDTH): the reference variation of each pair (``elements[i]`` by parameter ``columns[i]``) at ``state``,
        as :meth:`at_state` takes it (the same generated ``reference_variation_at_state`` on the same rows)."""
        variation = np.ascontiguousarray(self.variations[elements, :, columns])            # (P, WIDTH)
        held = np.concatenate([np.concatenate([variation[:, part] for part in _turned_parts(end)], axis=1)
                               for end in (0, 1)])                                          # (2P, 9): both ends
        moved = np.asarray(self.kernels.reference_variation_at_state(
            *self.ends_inputs(state, elements, at), np.ascontiguousarray(held))[0]).reshape(2, len(elements), 9)
        for end in (0, 1):
            for i, part in enumerate(_turned_parts(end)):
                variation[:, part] = moved[end, :, 3 * i:3 * i + 3]
        return variation

    def at_state(self, state, elements: np.ndarray, at: np.ndarray) -> np.ndarray:
        """The reference variations of ``elements`` (m, WIDTH, k) at ``state``, whose element geometry blocks are
        ``at`` (m, G): the held parts with the state's frames applied (module docstring: ψ, δo and δh turned
        into global axes, a moved hinge axis's turn of the nodal frame) by the generated
        ``reference_variation_at_state``, one row per (column, end, element) in one call — the rows the loop of steps
        forms in C (csrc/geometry_forces.c, end by end), each row the same bits."""
        m, k = len(elements), self.k
        variation = self.variations[elements].copy()                        # (m, WIDTH, k)
        held = np.concatenate([np.concatenate([variation[:, part] for part in _turned_parts(end)], axis=1)
                               for end in (0, 1)])                          # (2m, 9, k): both ends
        rows = np.ascontiguousarray(held.transpose(2, 0, 1).reshape(k * 2 * m, 9))
        tiled = [np.ascontiguousarray(np.tile(a, (k, 1))) for a in self.ends_inputs(state, elements, at)]
        moved = np.asarray(self.kernels.reference_variation_at_state(*tiled, rows)[0]).reshape(k, 2, m, 9)
        moved = moved.transpose(1, 2, 3, 0)                                 # (2, m, 9, k)
        for end in (0, 1):
            for i, part in enumerate(_turned_parts(end)):
                variation[:, part] = moved[end, :, 3 * i:3 * i + 3]
        return variation

    def ends_inputs(self, state, elements: np.ndarray, at: np.ndarray) -> list:
        """:meth:`end_inputs` of both ends, end 0's rows then end 1's, (2m, 9), (2m, 9), (2m, 9), (2m, 4)."""
        return [np.concatenate(pair) for pair in zip(*(self.end_inputs(state, elements, at, end) for end in (0, 1)))]

    def end_inputs(self, state, elements: np.ndarray, at: np.ndarray, end: int) -> tuple:
        """The state's inputs of ``reference_variation_at_state`` at end ``end`` of ``elements``: the nodal frame
        T_e (from the geometry blocks ``at``), E0, the node's frame T_j, the hinge's axis and angle (0 without a
        hinge: its axis is zero there), (m, 9), (m, 9), (m, 9), (m, 4)."""
        model, m = self.model, len(elements)
        hinge = model.element_hinges[elements, end]
        theta = np.zeros(m)
        hinged = hinge >= 0
        theta[hinged] = state.theta[hinge[hinged]]
        return (np.ascontiguousarray(at[:, 12 + 9 * end:21 + 9 * end]),
                np.ascontiguousarray(model.element_frames0[elements, end].reshape(m, 9)),
                np.ascontiguousarray(state.T[model.element_nodes[elements, end]].reshape(m, 9)),
                np.ascontiguousarray(np.concatenate([model.element_axes[elements, end], theta[:, None]], axis=1)))

    def _load_arms(self, state, total: np.ndarray, load_factor: float) -> None:
        """Add ∂r/∂p of the loads at a moved offset: the generated ``point_load_D_offset``, the point load's
        derivative along δr (exact: it is linear in its offset r, −[F; T r × F + M])."""
        model, k = self.model, self.k
        for index, node, moved in self.moved_loads:
            values, frame_node = self.load_arm_values(state.t, index, load_factor), self.load_frame_node(index)
            frame = np.eye(3) if frame_node < 0 else state.T[frame_node]
            rows = lambda a: np.ascontiguousarray(np.tile(np.reshape(a, (1, -1)), (k, 1)), dtype=float)  # noqa: E731
            moves = np.asarray(self.kernels.point_load_D_offset(rows(state.T[node]), np.ascontiguousarray(moved.T),
                                                                rows(values), rows(frame))[0])
            total[model.node_dofs[node]] += moves.reshape(k, 6).T

    def load_arm_values(self, t: float, index: int, load_factor: float) -> np.ndarray:
        """The six values of load ``index`` of the scene at time ``t`` times ``load_factor`` (its force and moment in
        its frame's axes): the point load kernels' ``values``."""
        load = self.scene.loads[index]
        values = np.zeros(6)
        for offset, components in ((0, load.force), (3, load.moment)):
            for c, law in enumerate(components or ()):
                values[offset + c] = load_factor * law.value(t)
        return values

    def load_frame_node(self, index: int) -> int:
        """The node whose frame load ``index`` turns with, −1 for a global load."""
        load = self.scene.loads[index]
        return -1 if load.frame == "global" else int(self.model.body_node[load.frame])


def _motion(state) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``state``'s frames, angular velocities and accelerations (n_nodes × 9, × 3, × 3) as csrc/turning_shifts.c reads
    them (contiguous: held by the caller over the call)."""
    return tuple(np.ascontiguousarray(a, np.float64) for a in (state.T, state.w, state.alpha))


def _turned_parts(end: int) -> tuple[slice, slice, slice]:
    """The slices of an element's reference variation (:data:`WIDTH`) that the state's frames turn at end ``end`` (0 or
    1), in the order ``reference_variation_at_state`` reads and writes them: ψ, δo, δh."""
    return slice(12 + 3 * end, 15 + 3 * end), slice(6 + 3 * end, 9 + 3 * end), slice(19 + 3 * end, 22 + 3 * end)


def _frame_turn(beam, x: np.ndarray, dx: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """φ with δE = skew(φ) E for the beam's frame E = [x̂, ŷ, x̂ × ŷ] (the loader's rule for ŷ,
    latdyn/scene/loader.py ``beam``) when x̂ moves by δx̂ and the ``y_axis`` v as given by δv (module
    docstring): y_0 = v/|v|, ŷ = (y_0 − (y_0·x̂)x̂)/|…|."""
    given = beam.y_given
    if given is None and np.hypot(x[0], x[1]) >= 1e-9:
        raw, draw = np.array([-x[1], x[0], 0.0]), np.array([-dx[1], dx[0], 0.0])
    else:
        v = np.array([0.0, 1.0, 0.0]) if given is None else np.asarray(given, float)
        y0 = v / np.linalg.norm(v)
        dy0 = (dv - y0 * (y0 @ dv)) / np.linalg.norm(v)
        raw, draw = y0 - (y0 @ x) * x, dy0 - (dy0 @ x) * x - (y0 @ dx) * x - (y0 @ x) * dx
    size = float(np.linalg.norm(raw))
    y = raw / size
    dy = (draw - y * (y @ draw)) / size
    z, dz = np.cross(x, y), np.cross(dx, y) + np.cross(x, dy)
    return 0.5 * (np.cross(x, dx) + np.cross(y, dy) + np.cross(z, dz))


def link_inertia_moved(kernels, beam, moved: np.ndarray) -> tuple:
    """(δm, δc, δI) of a rigid link's joint-body block (m = ρA L, c = v/2, I about c; latdyn/model/model.py
    ``rigid_link_inertia``) when its vector v = B − A moves by δv (``moved``, global axes at t = 0), the rule of its
    ŷ held (the loader's, :func:`_frame_turn`'s): the generated ``rigid_link_inertia_D_ends`` (codegen/joints.py, "Rigid
    link's inertia") along δB = δv, the block a function of v alone, of ``kernels`` (a KernelSet)."""
    from latdyn.model.model import rigid_link_rows

    (by_ends,) = kernels.rigid_link_inertia_D_ends(*rigid_link_rows(beam))
    change = by_ends[0, :, 3:6] @ moved
    return float(change[0]), change[1:4], change[4:13].reshape(3, 3)
