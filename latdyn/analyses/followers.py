"""Which of a scene's loads are follower loads (non-conservative), and when an eigenvalue is real.

A load in the axes of a moving body (``frame: BODY``) turns with it: its load stiffness is
unsymmetric and the static stability test of a conservative problem (the symmetric part of the
tangent) means nothing for it (issue 30, item 1; :mod:`latdyn.analyses.stability`).  So is a
moment fixed in space (``frame: global``) on a node that turns in 3D about more than one
direction: its work M·δθ over the node's spin is no variation of a potential once rotations leave
one axis (the "axial" moment of Argyris et al. 1979; Ziegler, Principles of Structural Stability,
1968), and its load stiffness on the free coordinates, M·(g_i × g_j), is not symmetric — unless
M is orthogonal to every g_i × g_j, as on a node that turns about one hinge axis fixed in space
(:func:`_moment_fixed_in_space_does_work_of_no_potential`). A cantilever under a dead axial
torque has no adjacent equilibrium at any torque (EI u'' = iM u' with u(0) = u'(0) = 0,
u = v + iw) and flutters from M = 0 on; the symmetric part
of its tangent loses definiteness at M = πEI/L, which was reported as buckling. In a planar model
a moment along the plane's normal is conservative (M θ). The static path
(:mod:`latdyn.analyses.continuation`) and the buckling analysis both ask this.
"""
from __future__ import annotations

import numpy as np

from latdyn.model.model import DEPENDENT, FREE

#: An eigenvalue μ of the stability pencil is real when |Im μ| <= REAL_TOL · max(1, |μ|).
REAL_TOL = 1e-7
#: Directions of turn are independent, and M·(g_i × g_j) is not zero, beyond this fraction (of 1, of |M|).
RANK_TOL = 1e-9


def follower_loads(model, state) -> list[int]:
    """Indices of the scene's non-conservative loads at ``state`` (the state the analysis starts
    from): those that turn with a moving body (``frame: BODY``, the body free or carried by a rigid
    link) — follower loads — and, in the 3D model, moments in global axes whose work on the turns
    of their node is no potential's variation (:func:`_moment_fixed_in_space_does_work_of_no_potential`).
    Forces in global axes, moments in a planar model, gravity and hinge springs and torques are
    conservative (a load in the axes of a fixed or prescribed body does not turn with the structure)."""
    out = []
    for i, load in enumerate(model.scene.loads):
        if load.frame == "global":
            if _moment_fixed_in_space_does_work_of_no_potential(model, state, load):
                out.append(i)
            continue
        if model.nodes[model.body_node[load.frame]].kind in (FREE, DEPENDENT):
            out.append(i)
    return out


def turning_directions(model, state, node: int) -> tuple[list[np.ndarray], int]:
    """The directions (unit, global axes) about which the node's frame turns as the free coordinates
    move at ``state``, from its root outward (the node's own rotations, or its root's, where it is
    free: the three global axes; each free hinge on the rigid links from its root: its axis, T_p a;
    a closure's rod: the loop's normal), and how many of them are its root's own."""
    def own_rotations(n: int) -> list[np.ndarray]:
        if model.nodes[n].kind != FREE:
            return []
        return [np.eye(3)[k] for k in range(3) if model.node_dofs[n, 3 + k] < model.n_dofs]
    links = model.links
    if links is None or node not in links.edge_of:
        found = own_rotations(node)
        return found, len(found)
    found = own_rotations(links.root[node])
    rooted = len(found)
    free = set(int(h) for h in model.free_hinges)
    for k in links.path(node):
        e = links.edges[k]
        if e.closure == "rod":
            found.append(np.asarray(e.closure_data[6:9], float))  # α(p) about the loop's normal n
        elif e.hinge in free and not e.prismatic and not e.closure:
            found.append(state.T[e.parent] @ e.axis)
    return [g / np.linalg.norm(g) for g in found], rooted


def _moment_fixed_in_space_does_work_of_no_potential(model, state, load) -> bool:
    """A moment M in global axes, in the 3D model, at a node that turns: its virtual work M·δθ on
    the node's turns δθ = Σ g_k δq_k (:func:`turning_directions`) is the variation of a potential
    where the 1-form Σ (M·g_k) dq_k is closed: its load stiffness on the free coordinates,
    ∂(M·g_j)/∂q_i = M·(g_i × g_j) for g_i before g_j, is then symmetric, M·(g_i × g_j) = 0 for
    every pair. So the node that turns about one direction only (a rigid arm on one hinge with its
    axis fixed in space) is conservative under any M (the work M·g θ); a node turning freely (the
    three axes: a flexible beam's node, Ziegler's torqued shaft) is not for any M ≠ 0; a gimbal
    (two hinges from a node that does not turn, the outer axis g₁ fixed in space, the inner one
    g₂(θ₁) = R(g₁, θ₁) g₂ turning with it) only where M·(g₁ × g₂(θ₁)) = 0 at every θ₁, that is,
    M along g₁ (the potential M·g₁ θ₁ + (M·g₂) θ₂) — a moment about the inner axis's direction
    at ``state`` has a symmetric load stiffness there, but not once the outer hinge turns. Other
    chains are judged at ``state``; a moment that varies in time, on two or more directions, is
    taken as non-conservative."""
    if model.plane is not None or load.moment is None:
        return False
    if all(c.is_constant and c.value(0.0) == 0.0 for c in load.moment):
        return False
    node, _ = model.point(load.at)
    if model.nodes[node].kind not in (FREE, DEPENDENT):
        return False
    directions, rooted = turning_directions(model, state, node)
    if len(directions) == 0 or np.linalg.matrix_rank(np.array(directions), tol=RANK_TOL) <= 1:
        return False  # no turn, or about one direction fixed in space: the work M·g θ
    if not all(c.is_constant for c in load.moment):
        return True
    M = np.array([c.value(0.0) for c in load.moment], float)
    size = float(np.linalg.norm(M))
    if rooted == 0 and len(directions) == 2:  # a gimbal: closed at every θ₁ only with M along g₁
        return float(np.linalg.norm(np.cross(M, directions[0]))) > RANK_TOL * size
    return any(abs(float(M @ np.cross(u, v))) > RANK_TOL * size
               for i, u in enumerate(directions) for v in directions[i + 1:])
