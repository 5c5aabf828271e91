"""Planar scenes (``solve.planar``, SCENE.md): detect them and restrict the model to the plane.

A scene *stays in a plane* x_n = c (n a global axis) when every input that could push it out
is zero by construction: every point lies in the plane; every hinge axis, prescribed rotation
axis and initial angular velocity is along n; forces, gravity, prescribed translations and the
initial linear velocity have no n-component; moments have only one; every body's centre of
mass lies in the plane and n is a principal axis of its inertia; and every beam section has a
principal axis along n (local y or z ±n, or an isotropic section: EIy = EIz, ρIy = ρIz). By
the reflection symmetry about the plane, the motion from such a start then stays in it, and
the out-of-plane coordinates (d_n, π_i, π_j of every node) are not needed: the model drops
them (:meth:`latdyn.model.model.Model.number_coordinates`) and uses the planar kernels, generated
from the same element with the planar values put in before differentiation
(codegen/formulation.py ``Plane``).

Adaptive runs (``solve.adaptive``) of the two models take different steps: the controller's
error norm (:func:`latdyn.numerics.inertia.joint_norms`) scales a node's translations by the mean of
its translational mass entries, over 3 coordinates in 3D and 2 in the plane, which differ
where the consistent mass is anisotropic (axial against transverse). Both runs keep their
local error within ``error_tol``; fixed-step runs agree to round-off.

Only coordinate planes are detected (a scene in an oblique plane runs in 3D). Under
``planar: auto`` modal analysis stays 3D: the out-of-plane modes of a planar structure are
modes too. Whether the planar motion is *stable* against out-of-plane disturbances (lateral
buckling) is a question the planar model cannot ask; ``planar: off`` asks it.
"""
from __future__ import annotations

import numpy as np

from latdyn.scene.expressions import TimeFunction

#: Out-of-plane components below this, relative to the scene's size (points) or to 1 (unit
#: vectors), count as zero.
PLANE_TOLERANCE = 1e-12

AXIS_NAMES = "xyz"
PLANE_NAMES = {0: "yz", 1: "zx", 2: "xy"}


def _zero(value) -> bool:
    """A scene scalar (number or law of time) that is identically zero."""
    if isinstance(value, TimeFunction):
        return value.is_constant and value.value(0.0) == 0.0
    return float(value) == 0.0


def _blocker(scene, normal: int) -> str | None:
    """The first input that takes the scene out of the plane normal to ``normal``, or None."""
    i, j = (normal + 1) % 3, (normal + 2) % 3
    points = _points(scene)
    size = max(1.0, float(np.ptp(points, axis=0).max(initial=0.0)))
    level = points[0, normal] if len(points) else 0.0
    for body in scene.bodies.values():
        if abs(body.at[normal] - level) > PLANE_TOLERANCE * size:
            return f"bodies.{body.name}.at is off the plane"
        if abs(body.com[normal]) > PLANE_TOLERANCE * size:
            return f"bodies.{body.name}.com is off the plane"
        if max(abs(body.inertia[normal, i]), abs(body.inertia[normal, j])) > \
                PLANE_TOLERANCE * max(1.0, float(np.abs(body.inertia).max())):
            return f"bodies.{body.name}.inertia couples the plane's normal"
        if body.rotation_axis is not None and max(abs(body.rotation_axis[i]), abs(body.rotation_axis[j])) > \
                PLANE_TOLERANCE:
            return f"bodies.{body.name}.motion.rotation.axis is not the normal"
        if body.translation is not None and not _zero(body.translation[normal]):
            return f"bodies.{body.name}.motion.translation leaves the plane"
        if body.guide is not None:  # a guided body is a dependent node with all 6 coordinates (links.py)
            return f"bodies.{body.name}.guide: scenes with guides run in 3D"
    for beam in scene.beams.values():
        if beam.rigid:  # rigid links map dependent nodes with all 6 coordinates (latdyn/model/links.py)
            return f"beams.{beam.name}.rigid: scenes with rigid links run in 3D"
        for which in ("start", "end"):
            end = getattr(beam, which)
            if abs(end.point[normal] - level) > PLANE_TOLERANCE * size:
                return f"beams.{beam.name}.{'from' if which == 'start' else 'to'} is off the plane"
            if end.hinge is not None and max(abs(end.hinge.axis[i]), abs(end.hinge.axis[j])) > PLANE_TOLERANCE:
                return f"beams.{beam.name}.{which}.hinge.axis is not the normal"
        y = beam.y_axis
        s = beam.section
        along = abs(y[normal])
        if PLANE_TOLERANCE < along < 1.0 - PLANE_TOLERANCE and not (
                s.EIy == s.EIz and s.rhoIy == s.rhoIz and s.GAy == s.GAz):
            return f"beams.{beam.name}.y_axis: the section's principal axes are oblique to the plane"
    for cable in getattr(scene, "cables", {}).values():
        for key, end in (("from", cable.start), ("to", cable.end)):
            if abs(end.point[normal] - level) > PLANE_TOLERANCE * size:
                return f"cables.{cable.name}.{key} is off the plane"
    for k, load in enumerate(scene.loads):
        if load.force is not None and not _zero(load.force[normal]):
            return f"loads[{k}].force has an out-of-plane component"
        if load.moment is not None and not (_zero(load.moment[i]) and _zero(load.moment[j])):
            return f"loads[{k}].moment has an in-plane component"
    if abs(scene.gravity[normal]) > 0.0:
        return "gravity has an out-of-plane component"
    iv = scene.initial_velocity
    if abs(iv.linear[normal]) > 0.0 or abs(iv.angular[i]) > 0.0 or abs(iv.angular[j]) > 0.0:
        return "initial_velocity leaves the plane"
    return None


def find_plane(scene) -> tuple[int | None, str]:
    """The normal axis of the coordinate plane the scene stays in (or None), and why, for
    ``latdyn check``. Tries the xy, zx, yz planes in turn."""
    if scene.solve.planar == "off":
        return None, "off (solve.planar: off): 3D model"
    if scene.solve.analysis in ("modes", "buckling"):
        return None, f"no: {'modal' if scene.solve.analysis == 'modes' else 'buckling'} analysis keeps the " \
                     "out-of-plane modes (3D model)"
    reasons = []
    for normal in (2, 1, 0):
        blocker = _blocker(scene, normal)
        if blocker is None:
            points = _points(scene)
            level = float(points[0, normal]) if len(points) else 0.0
            return normal, (f"{PLANE_NAMES[normal]} plane ({AXIS_NAMES[normal]} = {level:g}): "
                            f"in-plane coordinates only")
        reasons.append(f"{PLANE_NAMES[normal]}: {blocker}")
    return None, "no, 3D model (" + "; ".join(reasons) + ")"


def _points(scene) -> np.ndarray:
    """(n, 3) the bodies' reference points and the beams' and cables' end points at t = 0."""
    points = [body.at for body in scene.bodies.values()]
    points += [end.point for beam in scene.beams.values() for end in (beam.start, beam.end)]
    points += [end.point for cable in getattr(scene, "cables", {}).values() for end in (cable.start, cable.end)]
    return np.array(points, float).reshape(-1, 3)


def section_turn(frame: np.ndarray, normal: int) -> float:
    """The angle β about local x that turns a section frame [x y z] (x in the plane) so that its
    z axis is +n: z' = −sin β y + cos β z = n."""
    return float(np.arctan2(-frame[normal, 1], frame[normal, 2]))


def restrict_to_plane(model, normal: int) -> None:
    """Make ``model`` planar about axis ``normal``: turn each element's section axes about its
    x axis so that local z is +n (swapping the y and z section values when the turn is a
    quarter), and set :attr:`Model.plane`; the caller numbers the coordinates."""
    frames = model.element_frames0  # (e, 2, 3, 3) in node axes (= global at t = 0)
    for e in range(len(frames)):
        beta = section_turn(frames[e, 0], normal)
        c, s = np.cos(beta), np.sin(beta)
        turn = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
        frames[e] = frames[e] @ turn
        if abs(s) > 0.5:  # a quarter turn: y' = ±z, z' = ∓y
            section = model.element_sections[e]
            section[[2, 3]] = section[[3, 2]]  # EIy, EIz
            section[[6, 7]] = section[[7, 6]]  # ρIy, ρIz
            section[[8, 9]] = section[[9, 8]]  # 1/GAy, 1/GAz (model.SECTION_WIDTH)
        model.section_turns[e] = beta
    model.plane = normal


def section_moments_back(model, forces: np.ndarray) -> np.ndarray:
    """Section forces [N, T, M_y', M_z'] in the turned axes (:func:`restrict_to_plane`) → the
    beam's own local axes: M_y = cos β M_y' − sin β M_z', M_z = sin β M_y' + cos β M_z'."""
    beta = model.section_turns
    if not np.any(beta):
        return forces
    c, s = np.cos(beta), np.sin(beta)
    out = forces.copy()  # (n_elem, 4), or with leading row axes (rows recorded in a block)
    out[..., 2] = c * forces[..., 2] - s * forces[..., 3]
    out[..., 3] = s * forces[..., 2] + c * forces[..., 3]
    return out
