"""Sensitivities of models with rigid links (``beams.NAME.rigid``; docs/parameters.md, "Rigid links").

A rigid link is one rigid body on minimum coordinates (latdyn/model/links.py): its dependent nodes follow
their parents through the generated edge kernels, q_all = φ(z) (positions), v_all = B(z) ż (rates, B = P =
[I; J]), and the equations of motion are the projected residual Bᵀ r_all (latdyn/assembly/linked.py). The
sensitivities take the path that the guides' already take, with nothing added to it:

- ∂r/∂p is assembled on all coordinates (the dependent nodes' loads, masses and inertias included) and
  projected, Bᵀ ∂r_all/∂p (:meth:`latdyn.analyses.sensitivities.ParameterDerivatives._on_free_coordinates`);
- the step's matrix is the exact one of the reduced system, β′M + γ′C + K J with
  K = Bᵀ K_all B + ∂(Bᵀ r_all)/∂z at fixed r_all (the geometric term, from the generated wrench kernels) +
  Bᵀ(C_·dep ∂(J v)/∂z + M_·dep ∂(J a + c)/∂z) (the dependent rates' z-dependence at fixed ż, z̈, from the
  generated ``rigid_link_edge_rates_D_q`` composed along the tree in C):
  :meth:`latdyn.assembly.assembler.Assembler.exact_matrices`; the transient step takes M, C and that K dense
  from the compiled step's own reduction (up to DENSE_LIMIT free coordinates:
  :meth:`~latdyn.assembly.assembler.Assembler.linked_exact_matrix_values`, csrc/linked_matrices.c), the call its
  smooth steps make in the loop of steps (latdyn/analyses/sensitivities_in_loop.py);
- a probe on a dependent node moves by B δz (:meth:`ParameterDerivatives._dependent_motion`), its rates by
  B δż + ∂(J ż)/∂z δz (:func:`dependent_rates`: a point's velocity);
- the static paths solve with the reduced K (its geometric term included) the same way.

What this module adds is a rigid link's own mass and inertia by its section's values: the link is a joint
body on its link node with mass ρA L at mid-length and the slender rod's inertia
(:func:`latdyn.model.model.rigid_link_inertia`, the generated ``rigid_link_inertia``), linear in (ρA, ρIy, ρIz) at
its fixed centre of mass, so its ∂(inertia and gravity forces)/∂p is the generated ``joint_body`` with the block
(∂m/∂p, c, ∂I/∂p) of the generated ``rigid_link_inertia_D_section`` (:func:`link_section_block`,
:func:`add_link_section_forces`); a rigid link's EA, EIy, EIz and GJ move nothing (derivative 0).

Rigid links with guides (a slider-crank: a flexible rod on a guided slider, or the rigid rod that closes the
loop onto it, latdyn/model/links.py "Closure") take the same reduction and are differentiated alike, through
the guide's stops and latches too.

Arc length takes them too: its chain of rows is the reduced system's (the bordered matrix of the reduced K,
and :meth:`ArcLengthSensitivities.stiffness_derivative_along` moves the dependent nodes by P v at the start,
without which a beam hanging from a guided body was 6e6 off by its EI). It was refused while a 3D arc-length
run without sensitivities took another path than the one differentiated (summed rotation increments: 2.5e-2
off on the static gimbal, docs/parameters.md "Arc length"). Geometry parameters are refused
(latdyn/analyses/geometry_sensitivities.py: they move the links' edges). The discrete adjoint
(latdyn/analyses/adjoint_sensitivities.py) takes rigid links in the runs it takes: its reverse pass transposes
the reduced step, and a probe on a dependent node reads its output gradient on the coordinates the node moves
with (:func:`columns_moving`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["add_link_section_forces", "columns_moving", "dependent_rates", "held_linked_parts", "link_section_block"]

#: the columns of the generated ``rigid_link_inertia_D_section`` (codegen/joints.py LINK_SECTION), by section value
LINK_SECTION_VALUES = ("rhoA", "rhoIy", "rhoIz")


def link_section_uses(owner) -> list:
    """(link body index, link node, the section's value, {column: law}) of every use of a parameter by the
    ρA, ρIy or ρIz of a rigid link's section in ``owner`` (a ParameterDerivatives), found once."""
    if "_link_section_uses" in owner.__dict__:
        return owner._link_section_uses
    from latdyn.analyses.parameter_keys import SECTION_KEY as _SECTION_KEY

    model, scene = owner.model, owner.scene
    uses = []
    links = [beam for beam in scene.beams.values() if beam.rigid]
    for key, laws in owner.derivatives.items():
        section = _SECTION_KEY.match(key)
        if not section or section["value"] not in ("rhoA", "rhoIy", "rhoIz"):
            continue
        for beam in links:
            if beam.section.name != section["section"]:
                continue
            node = model.nodes.index(next(n for n in model.nodes if n.name == f"{beam.name}.link"))
            b = int(np.flatnonzero(model.body_nodes == node)[0])
            uses.append((beam, b, node, section["value"], laws))
    owner._link_section_uses = uses
    return uses


def link_section_block(kernels, beam, value: str, derivative: float, com: np.ndarray) -> np.ndarray:
    """(1, 13): the joint-body block (∂m/∂p, c, ∂I/∂p) of the rigid link ``beam`` whose section value ``value`` (ρA,
    ρIy or ρIz) moves by ``derivative`` = ∂value/∂p, at the link's fixed centre of mass ``com`` (node axes): the
    generated ``rigid_link_inertia_D_section`` (codegen/joints.py, "Rigid link's inertia") of ``kernels`` along it.
    The block ``joint_body`` takes for ∂(its row)/∂p, the row being linear in (m, I) at a fixed c."""
    from latdyn.model.model import rigid_link_rows

    (by_section,) = kernels.rigid_link_inertia_D_section(*rigid_link_rows(beam))
    block = by_section[0, :, LINK_SECTION_VALUES.index(value)] * derivative
    block[1:4] = com
    return block[None]


def add_link_section_forces(owner, state, total: np.ndarray, load_factor: float, inertia: bool) -> None:
    """Add ∂(a rigid link's joint-body force)/∂p into ``total`` (all coordinates) for the ρA, ρIy, ρIz of its
    section that name a parameter (module docstring): the generated ``joint_body`` with the block
    (∂m/∂p, c, ∂I/∂p) (:func:`link_section_block`), linear in (m, I) at the link's fixed centre of mass c; static
    (at rest) its λ-gravity alone."""
    uses = link_section_uses(owner)
    gravity = load_factor * np.asarray(owner.assembler.gravity, float)
    if not uses or (not inertia and not np.any(gravity)):
        return
    model = owner.model
    for beam, b, node, value, laws in uses:
        frame = np.ascontiguousarray(state.T[node].reshape(1, 9))
        motion = np.zeros((1, 9))
        if inertia:
            motion[0] = np.concatenate([state.w[node], state.a[node], state.alpha[node]])
        for column, law in laws.items():
            block = link_section_block(owner.kernels, beam, value, law.value(0.0, 0.0, state.t), model.body_com[b])
            force = np.asarray(owner.kernels.joint_body(frame, motion, block, gravity[None])[0]).reshape(6)
            total[model.node_dofs[node], column] += force


def columns_moving(model, node: int) -> np.ndarray:
    """The free coordinates node ``node`` moves with: its own where it is free; for a dependent node (it
    follows rigid links), its root's and the joints' on its path down the link tree (the columns of its
    rows of B), the ones below ``model.n_dofs`` (the discrete adjoint's output gradient reads a probe's
    derivative on them: latdyn/analyses/adjoint_sensitivities.py)."""
    links = model.links
    if links is None or node not in links.edge_of:
        columns = model.node_dofs[node]
    else:
        joints = [links.edges[k].hinge for k in links.path(node) if links.edges[k].hinge >= 0]
        columns = np.concatenate([model.node_dofs[links.root[node]], model.hinge_dofs[joints]]) if joints \
            else model.node_dofs[links.root[node]]
    columns = np.asarray(columns, np.int64)
    return np.unique(columns[columns < model.n_dofs])


def held_linked_parts(owner, state, rates: bool) -> tuple:
    """(P, ∂(J v)/∂q at fixed free rates or None) of the reduction at ``state`` (latdyn/assembly/linked.py): with
    ``rates`` from the evaluation with the inertia tangent and the dependent rates' term (:func:`dependent_rates`),
    else from the plain evaluation with matrices (``_dependent_motion``). Held per state while ``owner`` holds a
    ``_linked_parts_held`` dict (the discrete adjoint's outputs, several at one row: AdjointSensitivities.reverse),
    evaluated anew otherwise."""
    from latdyn.assembly.linked import evaluate_linked

    held = owner.__dict__.get("_linked_parts_held")
    key = (id(state), rates)
    if held is not None and key in held:
        return held[key][1]
    if rates:
        ev = evaluate_linked(owner.model.links, owner.assembler, state, True, 1.0, True, inertia_tangent=True,
                             rates_term=True)
        parts = (ev.projection, ev.rates_tangent[0])
    else:
        parts = (owner.assembler.evaluate(state, matrices=True).projection, None)
    if held is not None:   # copies (the next evaluation may reuse the buffers); the state held with them: its id stays
        parts = tuple(None if part is None else part.copy() for part in parts)
        held[key] = (state, parts)
    return parts


def dependent_rates(owner, state, dq: np.ndarray, dv: np.ndarray, dvel: np.ndarray, domega: np.ndarray) -> None:
    """(δv, δω) of the nodes that follow rigid links or guides into ``dvel``, ``domega`` (n_nodes, 3, k): their
    rates v_dep = J(q) v are moved by the free rates and by the configuration, δv_dep = J δv + ∂(J v)/∂q δq
    (``dq``, ``dv``: (n_dofs, k)), ∂(J v)/∂q at fixed free rates from the generated ``*_rates_D_q`` kernels
    composed along the link tree (latdyn/assembly/linked.py, ``rates_tangent``)."""
    model = owner.model
    projection, by_velocity = held_linked_parts(owner, state, rates=True)
    moved = np.asarray(projection @ dv)
    turned = np.asarray(by_velocity @ dq).reshape(-1, 6, dq.shape[1])   # one (v, ω) block per dependent node
    for i, node in enumerate(model.links.dependent):
        dofs = model.node_dofs[node]
        dvel[node] = moved[dofs[0:3]] + turned[i, 0:3]
        domega[node] = moved[dofs[3:6]] + turned[i, 3:6]
