"""Which of a scene's loads are follower loads (non-conservative), and when an eigenvalue is real.

A load in the axes of a moving body (``frame: BODY``) turns with it: its load stiffness is
unsymmetric and the static stability test of a conservative problem (the symmetric part of the
tangent) means nothing for it (issue 30, item 1; :mod:`latdyn.analyses.stability`).  The static
path (:mod:`latdyn.analyses.continuation`) and the buckling analysis both ask this.
"""
from __future__ import annotations

from latdyn.model.model import DEPENDENT, FREE

#: An eigenvalue μ of the stability pencil is real when |Im μ| <= REAL_TOL · max(1, |μ|).
REAL_TOL = 1e-7


def follower_loads(model) -> list[int]:
    """Indices of the scene's loads that turn with a moving body (``frame: BODY``, the body free or
    carried by a rigid link): follower loads, non-conservative.  Loads in global axes, gravity and
    hinge springs and torques are conservative (a load in the axes of a fixed or prescribed body
    does not turn with the structure)."""
    out = []
    for i, load in enumerate(model.scene.loads):
        if load.frame == "global":
            continue
        if model.nodes[model.body_node[load.frame]].kind in (FREE, DEPENDENT):
            out.append(i)
    return out
