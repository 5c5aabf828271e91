"""Which of a scene's loads are follower loads (non-conservative), and when an eigenvalue is real.

A load in the axes of a moving body (``frame: BODY``) turns with it: its load stiffness is
unsymmetric and the static stability test of a conservative problem (the symmetric part of the
tangent) means nothing for it (issue 30, item 1; :mod:`latdyn.analyses.stability`).  So is a
moment fixed in space (``frame: global``) on a node that turns in 3D: its work M·δθ over the
node's spin is no variation of a potential once rotations leave one axis (the "axial" moment of
Argyris et al. 1979; Ziegler, Principles of Structural Stability, 1968), and its load stiffness
is not symmetric. A cantilever under a dead axial torque has no adjacent equilibrium at any torque
(EI u'' = iM u' with u(0) = u'(0) = 0, u = v + iw) and flutters from M = 0 on; the symmetric part
of its tangent loses definiteness at M = πEI/L, which was reported as buckling. In a planar model
a moment along the plane's normal is conservative (M θ). The static path
(:mod:`latdyn.analyses.continuation`) and the buckling analysis both ask this.
"""
from __future__ import annotations

from latdyn.model.model import DEPENDENT, FREE

#: An eigenvalue μ of the stability pencil is real when |Im μ| <= REAL_TOL · max(1, |μ|).
REAL_TOL = 1e-7


def follower_loads(model) -> list[int]:
    """Indices of the scene's non-conservative loads: those that turn with a moving body (``frame:
    BODY``, the body free or carried by a rigid link) — follower loads — and, in the 3D model,
    moments in global axes at a node that turns.  Forces in global axes, moments in a planar
    model, gravity and hinge springs and torques are conservative (a load in the axes of a fixed or
    prescribed body does not turn with the structure)."""
    out = []
    for i, load in enumerate(model.scene.loads):
        if load.frame == "global":
            if _moment_fixed_in_space_on_a_turning_node(model, load):
                out.append(i)
            continue
        if model.nodes[model.body_node[load.frame]].kind in (FREE, DEPENDENT):
            out.append(i)
    return out


def _moment_fixed_in_space_on_a_turning_node(model, load) -> bool:
    """A moment in global axes (not identically zero) at a node that turns (free or carried by a
    rigid link), in the 3D model: non-conservative (module docstring)."""
    if model.plane is not None or load.moment is None:
        return False
    if all(c.is_constant and c.value(0.0) == 0.0 for c in load.moment):
        return False
    node, _ = model.point(load.at)
    return model.nodes[node].kind in (FREE, DEPENDENT)
