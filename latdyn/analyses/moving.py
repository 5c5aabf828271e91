"""What moves in a scene at t = 0 and after: prescribed motions and the initial velocity.

A modal analysis ``about: initial`` (SCENE.md, "Linearisation") linearises about the
configuration at t = 0 *at rest*: the centrifugal stiffening, the gyroscopic coupling and the
prescribed motion of a scene that moves are left out.  :func:`motions` names what moves, so that
such a run says so (stderr and ``summary.json`` ``warnings``) instead of returning the
frequencies of the structure at rest silently (issue 22, item 5).
"""
from __future__ import annotations

import numpy as np


def _vector(v) -> str:
    return "[" + ", ".join(f"{float(c):g}" for c in v) + "]"


def motions(scene) -> list[str]:
    """One phrase per motion of ``scene``: bodies with a prescribed translation or rotation that
    changes with t, hinges with a prescribed angle that changes with t, a non-zero initial velocity."""
    out = []
    for body in scene.bodies.values():
        if body.translation is not None and not all(f.is_constant for f in body.translation):
            out.append(f"body {body.name!r} has a prescribed translation")
        if body.rotation_angle is not None and not body.rotation_angle.is_constant:
            out.append(f"body {body.name!r} has a prescribed rotation about {_vector(body.rotation_axis)}")
    for beam, end, hinge in scene.hinges:
        if hinge.angle is not None and not hinge.angle.is_constant:
            out.append(f"hinge {beam}.{end} has a prescribed angle")
    for body in scene.bodies.values():
        if body.guide is not None and body.guide.position is not None and not body.guide.position.is_constant:
            out.append(f"guide {body.name!r} has a prescribed position")
    v = scene.initial_velocity
    if np.any(v.linear) or np.any(v.angular):
        out.append(f"initial_velocity is linear {_vector(v.linear)}, angular {_vector(v.angular)}")
    return out


def modes_warning(scene) -> str | None:
    """The warning of a modal analysis about the initial configuration of a scene that moves."""
    moving = motions(scene)
    if not moving:
        return None
    return ("modes about the initial configuration (about: initial) are those of the structure at rest "
            f"at t = 0, but the scene moves: {'; '.join(moving)}. Centrifugal stiffening, gyroscopic "
            "terms and the prescribed motion are left out of these frequencies.")


#: A structure turning in the frame of the modes faster than this fraction of its lowest (non-zero)
#: natural angular frequency is flagged by :func:`turning_warning`.
TURNING_FRACTION = 1e-2


def _turns_about_its_symmetry_axis(model, state, i: int, rate) -> bool:
    """Whether node ``i``, turning at ``rate`` (global) relative to the frame, carries what it carries
    symmetrically about that axis, so that the turning leaves its equations as they are (a disc
    spinning on its axle): every rigid body at it (joint bodies, rigid links' mass) with its centre of
    mass on the axis and inertia of revolution about it, every beam element at it along the axis with
    an isotropic section (EIy = EIz, rhoIy = rhoIz)."""
    size = float(np.linalg.norm(rate))
    if size == 0.0:
        return True
    axis, T = rate / size, state.T[i]
    for b in np.flatnonzero(model.body_nodes == i):
        inertia, com = T @ model.body_inertia[b] @ T.T, T @ model.body_com[b]
        scale = max(float(np.abs(inertia).max()), 1e-300)
        across = np.eye(3) - np.outer(axis, axis)
        if model.body_mass[b] > 0 and np.linalg.norm(across @ com) > 1e-9 * max(np.linalg.norm(com), 1e-300):
            return False
        if np.linalg.norm(across @ inertia @ axis) > 1e-9 * scale:
            return False
        plane = across @ inertia @ across  # its two moments across the axis must be equal
        if np.linalg.norm(plane - 0.5 * np.trace(plane) * across) > 1e-9 * scale:
            return False
    for e in np.flatnonzero((model.element_nodes == i).any(axis=1)):
        a, b = model.element_nodes[e]
        chord = state.x[b] - state.x[a]
        EIy, EIz, rhoIy, rhoIz = model.element_sections[e][[2, 3, 6, 7]]
        if (np.linalg.norm(np.cross(chord, axis)) > 1e-9 * np.linalg.norm(chord)
                or abs(EIy - EIz) > 1e-12 * max(EIy, EIz) or abs(rhoIy - rhoIz) > 1e-12 * max(rhoIy, rhoIz, 1e-300)):
            return False
    return True


def turning_warning(model, state, frame, found, t: float) -> str | None:
    """The warning of modes ``about: {t: T}`` whose state turns in the frame of the modes.

    The linearisation is frozen at T (docs/linearisation.md).  A structure that turns in that frame
    (a free body tumbling in the inertial frame, a link swinging about its hinge) has equations that
    change as it turns unless it is symmetric about the axis it turns about, so the frozen modes
    do not judge its motion: a free body spinning steadily about its intermediate principal axis
    diverges, yet its frozen modes are all zero; about its minor axis they miss its nutation.  Flagged
    where a free (or rigidly linked) node turns relative to the frame at more than
    :data:`TURNING_FRACTION` of the lowest natural angular frequency among the modes found (any
    rate at all, above round-off, where every mode found is zero), unless it turns about an axis of
    symmetry of what it carries (:func:`_turns_about_its_symmetry_axis`).  ``found``: the modes
    (:class:`latdyn.analyses.linearisation.Mode`)."""
    from latdyn.model.model import DEPENDENT, FREE

    nodes = [i for i, node in enumerate(model.nodes) if node.kind in (FREE, DEPENDENT)
             and not _turns_about_its_symmetry_axis(model, state, i, state.w[i] - frame.omega)]
    if not nodes:
        return None
    relative = np.linalg.norm(state.w[nodes] - frame.omega, axis=1)
    k = int(np.argmax(relative))
    omegas = np.array([2 * np.pi * m.natural_frequency_hz for m in found]) if found else np.zeros(1)
    top = float(omegas.max())
    lowest = omegas[omegas > 1e-6 * max(top, relative[k])]  # the others are zero to round-off
    floor = max(TURNING_FRACTION * float(lowest.min()) if lowest.size else 0.0, 1e-9 * top, 1e-300)
    if relative[k] <= floor:
        return None
    against = (f"its lowest natural frequency {float(lowest.min()):.6g} rad/s" if lowest.size
               else "modes that are all zero")
    return (f"modes about {{t: {t:g}}}: the structure turns in the frame of the modes at t = {t:g} "
            f"({model.nodes[nodes[k]].name} at {relative[k]:.6g} rad/s relative to it, against "
            f"{against}). These are the modes of the equations frozen at that instant, which change as "
            "it turns unless it is symmetric about the axis it turns about; they do not judge the "
            "stability of the motion (a free body spinning about its intermediate principal axis "
            "diverges, yet its frozen modes are all zero). Only a state steady in the frame has modes "
            "that do: about: steady, or {t: T} of a structure turning with its prescribed bodies.")
