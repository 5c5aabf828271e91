"""Cables: tension-only axial members between points of nodes (SCENE.md ``cables``).

A cable of ``elements`` equal elements runs from a point of one node to a point of another
(a body's grid point, or a free end node of its own at a point ``[x, y, z]``) through
``elements − 1`` inner nodes. Each element pulls its two end points together with

    N = EA (ℓ − L0)/L0 + c ℓ̇   while ℓ > L0 and N > 0,   0 otherwise (slack),

ℓ the distance of its end points, L0 = L(t)/elements its share of the cable's rest length L(t) (a
number or a law of time: a reel), c the axial damping. The taut law, its exact derivatives by the
end coordinates and by their rates, the strain energy ½ EA (ℓ − L0)²/L0, the rest length's
generalized force ∂U/∂L0 (a reel's work ∫ ∂U/∂L0 dL0 is external work) and the damper's force are
generated (``cable_force`` of codegen/joints.py); the evaluation (csrc/evaluate.c ``cables``) takes
them where the element is taut and zero where it is slack; the time loop integrates the reel's work
and the damper's dissipation over each step's ΔL0 and Δℓ (latdyn.timeloop.progress.cable_work).

The change between slack and taut is an event, located like a hinge stop: the time loop holds each
element taut or slack through a step (:attr:`CableElements.sides`, read by the evaluation in place)
and shortens a step in which the element's gap min(N_el, N) changes sign to land on the change
(latdyn.timeloop.events), so that every step sees one smooth law; docs/cables.md gives the
measurements that chose this over a C¹ transition.

Mass: ``rhoA`` times the rest length at t = 0, lumped: each element's half at each of its end
points, as point masses (joint bodies without rotary inertia, centred on the point). Inner nodes
and free end nodes have translations only (their rotations are no coordinates,
:attr:`latdyn.model.model.Model.translation_only`).
"""
from __future__ import annotations

import numpy as np

from latdyn.records import record

__all__ = ["CableElements", "add_cables", "cable_tolerance", "slack_and_unheld", "unbalanced_free_ends", "BALANCE"]

#: A massless cable's free end is in equilibrium at t = 0 when the force left on it is at most this
#: fraction of the cable's pull there (:func:`unbalanced_free_ends`): the snap of the rest releases
#: (1e-6)² of the pretension's strain energy along the cable, about (1e-6)²/ε sideways (ε the pretension's
#: strain: sideways only T/ℓ holds the end)
BALANCE = 1e-6



def cable_tolerance(EA: np.ndarray) -> np.ndarray:
    """The gap (a force) within which a cable element of axial stiffness ``EA`` is on its change between
    slack and taut (latdyn.timeloop.events; the loop of steps in C reads it per element from the native
    model, ``cable_tolerance``, made here: csrc/newton_step.c cable_event): a stretch of 1e-9 of its rest length."""
    return 1e-9 * EA


@record
class CableElements:
    """The cable elements of a model, as arrays (``ce`` elements in all)."""

    nodes: np.ndarray  # (ce, 2) node of each end
    offsets: np.ndarray  # (ce, 2, 3) the end point from the node's reference point, in node axes
    share: np.ndarray  # (ce,) its share of its cable's rest length (1/elements)
    EA: np.ndarray  # (ce,)
    damping: np.ndarray  # (ce,)
    cable: np.ndarray  # (ce,) index of its cable in :attr:`names`
    names: list  # cable names, scene order
    rest_length: list  # each cable's TimeFunction
    first: np.ndarray  # (n_cables,) index of each cable's first element
    #: per cable, the points of its free end nodes that only its tension holds (``CABLE.start``,
    #: ``CABLE.end``: an end given as a point ``[x, y, z]`` of a massless cable), empty for the others
    held_by_tension: list = None
    #: (ce,) float: the side the time loop holds each element on through a step, +1 taut, −1 slack; 0 (every
    #: other analysis): the stretch decides (latdyn.timeloop.events; read by the C evaluation in place)
    sides: np.ndarray = None

    def __len__(self) -> int:
        return len(self.nodes)


def add_cables(scene, body_node: dict, new_node, beam_nodes: dict, beam_grid_offsets: dict,
               point_masses: list) -> CableElements | None:
    """Make the cables' own nodes with ``new_node(name, position) -> index`` (free end nodes and inner
    nodes: free, translations only), register each cable's node chain and end offsets as a
    beam's (``CABLE.start``, ``CABLE.node[i]``, ``CABLE.end`` resolve like a beam's points), and its
    lumped mass as point masses ``(node, mass, offset)``; None without cables."""
    if not scene.cables:
        return None
    rows = {"nodes": [], "offsets": [], "share": [], "EA": [], "damping": [], "cable": []}
    first, held_by_tension = [], []
    for k, cable in enumerate(scene.cables.values()):
        ends = []
        for which, spec in (("start", cable.start), ("end", cable.end)):
            if spec.body is not None:
                ends.append((body_node[spec.body], np.array(spec.offset, float)))
            else:
                ends.append((new_node(f"{cable.name}.{which}", np.array(spec.point, float)), np.zeros(3)))
        held_by_tension.append([f"{cable.name}.{which}" for which, spec in (("start", cable.start), ("end", cable.end))
                                if spec.body is None and cable.rhoA == 0.0])
        n = cable.elements
        start, end = cable.start.point, cable.end.point
        chain = [ends[0][0]]
        for i in range(1, n):
            chain.append(new_node(f"{cable.name}.node[{i}]", start + (end - start) * i / n))
        chain.append(ends[1][0])
        beam_nodes[cable.name] = np.array(chain, dtype=np.int64)
        beam_grid_offsets[cable.name] = (ends[0][1], ends[1][1])
        first.append(len(rows["nodes"]))
        element_mass = cable.rhoA * float(cable.rest_length.value(0.0)) / n
        for i in range(n):
            o1 = ends[0][1] if i == 0 else np.zeros(3)
            o2 = ends[1][1] if i == n - 1 else np.zeros(3)
            rows["nodes"].append((chain[i], chain[i + 1]))
            rows["offsets"].append((o1, o2))
            rows["share"].append(1.0 / n)
            rows["EA"].append(cable.EA)
            rows["damping"].append(cable.damping)
            rows["cable"].append(k)
            if element_mass > 0.0:
                point_masses.append((chain[i], 0.5 * element_mass, o1))
                point_masses.append((chain[i + 1], 0.5 * element_mass, o2))
    return CableElements(
        nodes=np.array(rows["nodes"], np.int64).reshape(-1, 2),
        offsets=np.array(rows["offsets"], float).reshape(-1, 2, 3),
        share=np.array(rows["share"], float), EA=np.array(rows["EA"], float),
        damping=np.array(rows["damping"], float), cable=np.array(rows["cable"], np.int64),
        names=list(scene.cables), rest_length=[c.rest_length for c in scene.cables.values()],
        first=np.array(first, np.int64), sides=np.zeros(len(rows["nodes"])), held_by_tension=held_by_tension)


def slack_and_unheld(cables: CableElements, sides) -> list[tuple[str, list]]:
    """(cable name, its free end points) of each cable that is slack in all its elements (``sides``, +1
    taut, −1 slack, per element) and has a free end node that only its tension holds: a massless
    cable's end given as a point has no inertia and nothing but the cable attached, so that while
    the cable is slack nothing holds it (its coordinates have no equation: SCENE.md, a coordinate
    nothing holds). The start of a run refuses this (:meth:`latdyn.model.model.Model.check_held`);
    a run in which such a cable goes slack ends there (latdyn.timeloop.loop)."""
    sides = np.asarray(sides, float)
    return [(name, cables.held_by_tension[k]) for k, name in enumerate(cables.names)
            if cables.held_by_tension[k] and not np.any(sides[cables.cable == k] > 0)]


def unbalanced_free_ends(model, pulled: np.ndarray, total: np.ndarray) -> list[tuple[str, str, float, float]]:
    """(cable name, free end point, the cable's pull on it, the force left on it) of each free end that
    only a massless cable's tension holds (:attr:`CableElements.held_by_tension`) and that is not in
    equilibrium: ``pulled`` and ``total`` are the static residual at the state (t = 0) without loads and
    with them (the cable's force on the end, and that force with the loads at the end). Such an end has
    no inertia: a force left on it moves it within the first step, whatever the step, and the strain
    energy it releases (a pretensioned cable's) goes nowhere (SCENE.md: the end is *at* ``[x, y, z]`` at
    t = 0). Unbalanced: the force left exceeds :data:`BALANCE` of the pull (an end the cable pulls;
    an end it does not pull, slack or at its rest length, is another check's: :func:`slack_and_unheld`)."""
    cables = model.cables
    out = []
    if cables is None:
        return out
    names = {node.name: i for i, node in enumerate(model.nodes)}
    for k, name in enumerate(cables.names):
        for point in cables.held_by_tension[k]:
            rows = model.node_dofs[names[point]]   # its translations (the only coordinates it has)
            rows = rows[(rows >= 0) & (rows < model.n_dofs)]
            pull, left = float(np.linalg.norm(pulled[rows])), float(np.linalg.norm(total[rows]))
            if pull > 0.0 and left > BALANCE * pull:
                out.append((name, point, pull, left))
    return out
