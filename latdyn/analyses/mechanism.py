"""Mechanisms: the coordinates that nothing holds, named when a static path cannot go on.

A static equilibrium of r(q, λ) = f_int(q) − λ q_ref(q) = 0 (:mod:`latdyn.analyses.continuation`)
needs the tangent K = ∂r/∂q to hold every direction.  The structure's own tangent
K₀ = ∂f_int/∂q (λ = 0: beams, hinge springs, everything but the loads) has a null space where the
structure is a mechanism: a hinge with no stiffness, a body on no support, a free-floating
structure, a slack cable's nodes (it carries nothing: :func:`slack_cables`, named as such).
Along such a direction n (K₀ n = 0, left null vector u) the loads either push, uᵀq_ref ≠ 0 —
then there is no equilibrium near the state at all, for any λ > 0: the loads turn the mechanism
until something holds it, which is motion (a transient run), not a limit point — or they do not,
and the tangent is singular though the loads might hold the mechanism once they act (a tensile
load on a hinged arm).  Either way the message names the coordinates, not a limit
point.  Stops (hinge ``limits``) are events of the time loop; a static analysis does not see them.

The null space is that of the scaled tangent S K₀ S, S = diag(1/√W) (W the weights of the path's
norm: translations over the scene's size ℓ, rotations and hinge angles in radians), so that a
direction is free when its stiffness is at the round-off of the largest (singular values below
:data:`FREE_RATIO` of the largest), whatever the units.
"""
from __future__ import annotations

import numpy as np

from latdyn.numerics.linalg import single_thread_blas

#: A scaled singular value below this fraction of the largest is a free direction (the round-off
#: of K₀ is about 1e-16 of its largest entry; a hinge spring 10⁻¹² of a beam's EA/L still holds).
FREE_RATIO = 1e-13
#: Largest model whose unloaded tangent is decomposed (dense SVD) to find its free directions.
SIZE_LIMIT = 2000
#: A coordinate is named when its share of a free direction is at least this fraction of the largest.
NAMED_SHARE = 0.2


def free_directions(K0, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(right, left) null vectors of K₀ in the scaled coordinates, as columns (none: 0 columns)."""
    dense = K0 if isinstance(K0, np.ndarray) else K0.toarray()
    scale = 1.0 / np.sqrt(weight)
    scaled = scale[:, None] * dense * scale[None, :]
    with single_thread_blas():
        U, sigma, Vt = np.linalg.svd(scaled)
    free = sigma < FREE_RATIO * max(float(sigma[0]), 1e-300) if len(sigma) else np.zeros(0, bool)
    return Vt[free].T, U[:, free]


def coordinate_names(model, directions: np.ndarray) -> list[str]:
    """The coordinates that the free ``directions`` (scaled columns) move: the hinges and guides among
    them first (a joint that nothing holds is the usual mechanism: ``hinge arm.start``, ``guide
    slider``), then the nodes with their components
    (``arm.end: dy, rz``)."""
    if directions.shape[1] == 0:
        return []
    share = np.sqrt(np.sum(directions ** 2, axis=1))
    named = np.flatnonzero(share >= NAMED_SHARE * share.max())
    names = model.dof_names()
    joints = [names[i] for i in named if ":" not in names[i]]   # a hinge's angle, a guide's slide
    if joints:
        return joints
    by_node: dict[str, list[str]] = {}
    for i in named:
        node, _, component = names[i].partition(":")
        by_node.setdefault(node, []).append(component)
    by_components: dict[tuple, list[str]] = {}  # nodes that move alike named together (a rigid-body motion)
    for node, components in by_node.items():
        by_components.setdefault(tuple(components), []).append(node)
    return [f"{', '.join(nodes)}: {', '.join(components)}" for components, nodes in by_components.items()]


def mechanism_message(path, state, load_factor: float) -> str | None:
    """The message of a static path (a :class:`latdyn.analyses.continuation.Path`) that cannot go on
    from its converged ``state`` at ``load_factor`` because the structure is a mechanism there
    (None: K₀ holds every direction, or the model is too large to look)."""
    model = path.model
    if model.n_dofs == 0 or model.n_dofs > SIZE_LIMIT:
        return None
    K0 = path.assembler.evaluate(state, matrices=True, load_factor=0.0, inertia=False).stiffness
    right, left = free_directions(K0, path.weight)
    names = coordinate_names(model, right)
    if not names:
        return None
    slack = slack_cables(path, state, right)
    if slack:
        return slack_cable_message(slack, names, load_factor)
    _, _, q_ref = path.evaluate(state, load_factor)
    scaled_load = q_ref / np.sqrt(path.weight)
    size = float(np.linalg.norm(scaled_load))
    pushed = size > 0 and float(np.linalg.norm(left.T @ scaled_load)) > 1e-8 * size
    free = " and ".join(names) if len(names) <= 3 else ", ".join(names[:3]) + f" and {len(names) - 3} more"
    stopped = {f"{h.kind} {h.name}" for h in model.hinges if h.limits is not None}
    holds = ("no stiffness, no support; a stop, hinge limits, acts in transient runs only"
             if stopped & set(names) else "no stiffness, no support")
    if pushed:
        return (f"static analysis: no equilibrium past load factor {load_factor:.6g}: the loads move {free}, "
                f"which nothing holds ({holds}): the structure is a mechanism there, whose motion a "
                "transient run follows (not a limit point)")
    return (f"static analysis: {free} {'is' if len(names) == 1 else 'are'} free at load factor "
            f"{load_factor:.6g}: nothing holds {'it' if len(names) == 1 else 'them'} ({holds}) and the "
            "tangent is singular there, though the loads do not move "
            f"{'it' if len(names) == 1 else 'them'}; give {'it' if len(names) == 1 else 'them'} a "
            "stiffness or a support")


def slack_cables(path, state, directions: np.ndarray) -> list[str]:
    """The cables slack at ``state`` (an element with N = 0: ℓ ≤ L₀) that touch a node the free
    ``directions`` move: a slack cable has no stiffness, so its own nodes are free in the tangent
    although the cable has an equilibrium (it hangs); empty without cables."""
    model, cables = path.model, path.model.cables
    if cables is None or directions.shape[1] == 0:
        return []
    share = np.sqrt(np.sum(directions ** 2, axis=1))
    moved = np.flatnonzero(share >= NAMED_SHARE * share.max())
    moved_nodes = np.flatnonzero(np.isin(model.node_dofs, moved).any(axis=1))
    tension = path.assembler.native().cable_state(state)[:, 4]
    slack_elements = (tension <= 0.0) & np.isin(cables.nodes, moved_nodes).any(axis=1)
    return [cables.names[i] for i in sorted(set(cables.cable[slack_elements].tolist()))]


def slack_cable_message(slack: list[str], names: list[str], load_factor: float) -> str:
    """The refusal of a static path held up by slack cables (:func:`slack_cables`)."""
    which = ", ".join(slack)
    free = " and ".join(names) if len(names) <= 3 else ", ".join(names[:3]) + f" and {len(names) - 3} more"
    return (f"static analysis: cable{'s' if len(slack) > 1 else ''} {which} {'are' if len(slack) > 1 else 'is'} "
            f"slack at load factor {load_factor:.6g} (not longer than {'their' if len(slack) > 1 else 'its'} "
            f"rest length), so {'they carry' if len(slack) > 1 else 'it carries'} no tension and the static "
            f"Newton has no stiffness in {free}: a hanging cable has an equilibrium, but not one reached "
            "from a straight slack start. Give it a pretension (a rest_length shorter than the distance of "
            "its ends, so that it is taut from the start), or find its hanging shape by a transient run "
            "(with damping, it settles)")
