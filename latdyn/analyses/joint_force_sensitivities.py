"""Exact sensitivities of the joint-force probes ``{hinge: BEAM.start|end, quantity: torque}`` and
``{guide: NAME, quantity: force}`` (SCENE.md: the generalized force the joint applies on its coordinate;
latdyn/results/probes.py ``ProbeSet.joint_forces``; docs/parameters.md, "Joint forces").

The probe is one of two things, and so is its derivative by a parameter p along the carried sensitivities
(δq, δv, δv̇) of the transient step (latdyn/analyses/transient_sensitivities.py):

- a free joint applies its law, −f(θ, θ̇, t; p) (spring, damper, applied torque or force, compliant
  stops): δ(−f) = −(∂f/∂θ δθ + ∂f/∂θ̇ δθ̇ + ∂f/∂p), ∂f/∂θ and ∂f/∂θ̇ as the generated ``hinge_force``
  gives them to the evaluation (its Newton matrix's hinge entries), ∂f/∂p from the parameters' derivative
  laws through the same kernel (:meth:`ParameterDerivatives._hinge_force`, the compliant stops'
  ``contact_force_D_law``);
- a joint without a coordinate (latched, prescribed) applies the reaction that holds it, the residual
  r_d of its coordinate d (its law included):

      δr_d = K_d δq + C_d δv + M_d δv̇ + ∂r_d/∂p,

  K_d, C_d, M_d the rows of the EXACT matrices on that coordinate, its columns the free coordinates
  (:meth:`latdyn.assembly.assembler.Assembler.exact_rows`: K with the elements' and joint bodies' inertia
  tangent), ∂r_d/∂p the row of ∂r/∂p on all coordinates (with the inertia forces). Its own coordinate
  moves with no parameter (a latch holds θ at lock_at at rest; a prescribed angle follows its law).

After a latch the reaction is differentiable in p at the rows after the event time (whose derivative the
step's size carries); at the event it jumps from −f to the reaction.

Not differentiated (refused by :func:`refusal`, naming ``solve.sensitivities``): a joint whose torque or
force a controller drives or whose force probe a controller reads, and the reaction of a guide's latch or
rigid stop, or of a held hinge in a model with guides (the reduction's row on a constrained coordinate: not
assembled yet); static paths (a static row's joint force is the one evaluation of csrc/rows.c
``latdyn_joint_forces``, whose applied torques and loads are at load factor 1, not the row's λ).
"""
from __future__ import annotations

import numpy as np

__all__ = ["is_joint_force", "joint_of", "refusal", "joint_force_derivatives"]


def is_joint_force(probe) -> bool:
    """Whether ``probe`` is a joint-force probe (a hinge's torque, a guide's force)."""
    return probe.kind in ("hinge", "guide") and probe.quantity in ("torque", "force")


def joint_of(model, probe) -> int:
    """The model's index of the joint (hinge or guide) that ``probe`` reads."""
    return model.hinge_index(probe.beam, probe.end) if probe.kind == "hinge" else model.hinge_index(probe.body, "guide")


def refusal(scene, probe) -> str | None:
    """Why the joint-force ``probe``'s sensitivities are not exact here, or None (module docstring)."""
    if probe.kind == "hinge":
        joint = next(h for beam, which, h in scene.hinges if (beam, which) == (probe.beam, probe.end))
        law, where = joint.torque, f"beams.{probe.beam}.{probe.end}.hinge.torque"
    else:
        joint = scene.bodies[probe.body].guide
        law, where = joint.force, f"bodies.{probe.body}.guide.force"
    controllers = set(getattr(scene, "controllers", None) or {})
    named = sorted(controllers & set(getattr(law, "input_names", ()) or ()))
    if named:
        return (f"the joint-force probe {probe.name!r}: controller {named[0]!r} drives {where}, whose output's "
                "derivative is not part of the joint's force derivative yet")
    readers = sorted(c.name for c in (getattr(scene, "controllers", None) or {}).values() if probe.name in c.reads)
    if readers:
        return (f"controller {readers[0]!r} reads the joint-force probe {probe.name!r}: a sensor's derivative by a "
                "joint force is not computed yet")
    return None


def joint_force_derivatives(owner, state, dq: np.ndarray, dv: np.ndarray | None, dvdot: np.ndarray | None,
                            load_factor: float = 1.0, inertia: bool = True) -> dict:
    """{joint index: (k,) derivatives of its force by every parameter} for the joints the probes of
    ``owner`` (a :class:`latdyn.analyses.sensitivities.ParameterDerivatives`) read at ``state``, along the
    free-coordinate sensitivities ``dq``, ``dv``, ``dvdot`` (n, k) of the transient step (module docstring);
    ``dv``, ``dvdot`` None and ``inertia`` False: a state at rest, of the residual at ``load_factor``."""
    model, assembler, k = owner.model, owner.assembler, len(owner.names)
    n = model.n_dofs
    joints = sorted({joint_of(model, p) for p in owner.probes if is_joint_force(p)})
    if not joints:
        return {}
    dofs = model.hinge_dofs[joints]
    free = [j for j, d in zip(joints, dofs) if d < n]
    held = [j for j, d in zip(joints, dofs) if d >= n]
    out = {}
    if free:   # −f: the law's slopes at the state (the evaluation's hinge entries) and its ∂f/∂p
        assembler.complete_links(state)
        native = assembler.native()
        native.evaluate(state, True, load_factor, inertia, False)
        slope, damping = native.buffers["hinge_d_theta"].copy(), native.buffers["hinge_d_rate"].copy()
        laws = np.zeros((model.n_total + 1, k))
        for key, by_column in owner.derivatives.items():
            _, hinge = owner._key_kinds(key)   # a hinge's or guide's law (its compliant stops': below)
            if hinge:
                j = model.hinge_index(hinge["beam"], hinge["end"])
                if j in free:
                    for column, law in by_column.items():
                        laws[model.hinge_dofs[j], column] += owner._hinge_force(state, j, hinge["law"], law,
                                                                              load_factor)
        owner._contact_forces(state, laws)
        for j in free:
            d = model.hinge_dofs[j]
            moved = slope[j] * dq[d] + (damping[j] * dv[d] if dv is not None else 0.0)
            out[j] = -(moved + laws[d])
    if held and model.links is not None:   # the reaction through the guides' reduction
        out.update(_held_through_links(owner, state, held, dq, dv, dvdot))
    elif held:   # the reaction: the exact rows of its coordinate along (δq, δv, δv̇), and ∂r_d/∂p
        rows = model.hinge_dofs[held]
        M, C, K = assembler.exact_rows(state, rows, load_factor, inertia)
        explicit = owner.residual_derivatives(state, load_factor, inertia=inertia, on_all=True)[rows]
        total = K @ dq + explicit
        if dv is not None:
            total = total + C @ dv
        if dvdot is not None and inertia:
            total = total + M @ dvdot
        out.update({j: total[i] for i, j in enumerate(held)})
    return {j: np.asarray(value, float).reshape(k) for j, value in out.items()}


def _held_through_links(owner, state, held: list, dq: np.ndarray, dv: np.ndarray, dvdot: np.ndarray) -> dict:
    """{joint: (k,)} the reactions' derivatives of the held joints ``held`` of a model with guides (rigid links'
    reduction, latdyn/assembly/linked.py): the reaction on the constrained coordinate d is

        r_d = r_all,d + Σ_c J_c,dᵀ r_c,

    r_all the residual on all coordinates before the reduction, r_c the wrench at each dependent node c whose
    motion the coordinate moves (J_c,d its column of the dependent node's J: a guide's slide moves its body,
    and the nodes below it, along the slide's axis). Its derivative along (δq, δv, δv̇):

        δr_d = δr_all,d + Σ_c (J_c,dᵀ δr_c + δ(J_c,d)ᵀ r_c),

    δr_all on rows d and c from the exact rows before the reduction (:meth:`Assembler.exact_rows`) along the
    assembled coordinates' δq_all = P δq, δv_all = P δv + ∂(J v)/∂q δq and δv̇_all = P δv̇ + ∂(J a + c)/∂q δq +
    ∂c/∂v δv (the dependent rates' derivatives, as the exact reduced K and C hold them) plus ∂r_all/∂p there;
    δ(J_c,d)ᵀ r_c from the generated ``slide_wrench`` (the slide's generalized force a·f and its derivative by
    the edge parent's δx, δπ and the node's δx, chained with their J), as the reduction's geometric stiffness
    takes it on the free coordinates' rows."""
    from latdyn.assembly.linked import evaluate_linked

    model, assembler, links = owner.model, owner.assembler, owner.model.links
    k, n = len(owner.names), model.n_dofs
    ev = evaluate_linked(links, assembler, state, True, 1.0, True, inertia_tangent=True, rates_term=True)
    P, dep = ev.projection, ev.dependent_rows
    by_velocity, by_acceleration = ev.rates_tangent
    dq_all, dv_all, dvdot_all = (np.asarray(P @ x) for x in (dq, dv, dvdot))
    dv_all[dep] += np.asarray(by_velocity @ dq)
    dvdot_all[dep] += np.asarray(by_acceleration @ dq + ev.velocity_derivative @ dv)
    rows = model.hinge_dofs[held]
    M, C, K = assembler.exact_rows(state, np.concatenate([rows, dep]))
    explicit = owner.residual_derivatives(state, 1.0, inertia=True, on_all=True)[np.concatenate([rows, dep])]
    moved = K @ dq_all + C @ dv_all + M @ dvdot_all + explicit
    on_rows, on_dependent = moved[:len(rows)], moved[len(rows):]
    J, columns = ev.jacobian, ev.jacobian_columns
    r_dep = assembler.evaluate_assembled(state, False, 1.0, True).residual[dep]   # the wrenches r_c
    out = {}
    for i, j in enumerate(held):
        total = on_rows[i].copy()
        at = np.flatnonzero(columns == int(model.hinge_dofs[j]))
        if len(at):
            total += J[:, at[0]] @ on_dependent + _edge_wrench_derivative(owner, state, j, dq, r_dep)
        out[j] = total
    return out


def _edge_wrench_derivative(owner, state, j: int, dq: np.ndarray, r_dep: np.ndarray) -> np.ndarray:
    """Σ_c δ(J_c,d)ᵀ r_c along δq (k,) for the joint ``j`` of an edge of the links' tree: the generated
    ``slide_wrench`` (``hinge_wrench`` for a revolute edge) at each dependent node c below it, its derivative by
    the edge parent's δx, δπ and c's δx chained with their J (as :func:`latdyn.assembly.linked.geometric_stiffness`
    takes it for the free coordinates' rows)."""
    model, links, kernels = owner.model, owner.model.links, owner.kernels
    native, n = owner.assembler.native().links, model.n_dofs
    out = np.zeros(dq.shape[1])
    for c_index, c in enumerate(links.dependent):
        r = r_dep[6 * c_index:6 * c_index + 6]
        for e in links.path(int(c)):
            edge = links.edges[e]
            if edge.hinge != j or not np.any(r):
                continue
            parent = np.concatenate([state.x[edge.parent], state.T[edge.parent].reshape(9)])[None]
            data = np.concatenate([edge.axis, edge.point, [edge.sign]])[None]
            wrench = np.concatenate([state.x[int(c)], r])[None]
            kernel = kernels.slide_wrench if edge.prismatic else kernels.hinge_wrench
            D = np.asarray(kernel(parent, data, wrench)[1]).reshape(9)
            s, p = native.slot_of_node[int(c)], native.slot_of_node[int(edge.parent)]
            Jc, Jp = native.jacobian[s, :, :native.count[s]], native.jacobian[p, :, :native.count[p]]
            row = D[6:] @ Jc[:3]
            row[:Jp.shape[1]] += D[:6] @ Jp
            slot_columns = native.columns[s, :native.count[s]]
            keep = slot_columns < n
            out += row[keep] @ dq[slot_columns[keep]]
    return out
