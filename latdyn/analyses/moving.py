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
