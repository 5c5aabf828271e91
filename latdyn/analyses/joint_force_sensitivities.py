"""Exact sensitivities of the joint-force probes ``{hinge: BEAM.start|end, quantity: torque}`` and
``{guide: NAME, quantity: force}`` (SCENE.md: the generalized force the joint applies on its coordinate;
latdyn/results/probes.py ``ProbeSet.joint_forces``; docs/parameters.md, "Joint forces").

The probe is one of two things, and so is its derivative by a parameter p along the carried sensitivities
(δq, δv, δv̇) of the transient step (latdyn/analyses/transient_sensitivities.py):

- a free joint applies its law, −f(θ, θ̇, t; p) (spring, damper, applied torque or force, compliant
  stops): δ(−f) = −(∂f/∂θ δθ + ∂f/∂θ̇ δθ̇ + ∂f/∂p), ∂f/∂θ and ∂f/∂θ̇ as the generated ``hinge_force``
  gives them to the evaluation (its Newton matrix's hinge entries), ∂f/∂p from the parameters' derivative
  laws through the same kernel (:meth:`ParameterDerivatives._hinge_force`, the compliant stops'
  ``contact_force_D_law``); a continuous controller's output a·y on the joint adds its sensors' derivatives
  (the coupling entries of the joint's row in K and C, latdyn/assembly/control.py) and its explicit ∂y/∂p
  (:meth:`latdyn.analyses.sensitivities.ControllerTerms.add`);
- a joint without a coordinate (latched, prescribed) applies the reaction that holds it, the residual
  r_d of its coordinate d (its law included):

      δr_d = K_d δq + C_d δv + M_d δv̇ + ∂r_d/∂p,

  K_d, C_d, M_d the rows of the EXACT matrices on that coordinate, its columns the free coordinates
  (:meth:`latdyn.assembly.assembler.Assembler.exact_rows`: K with the elements' and joint bodies' inertia
  tangent), ∂r_d/∂p the row of ∂r/∂p on all coordinates (with the inertia forces). Its own coordinate
  moves with no parameter (a latch holds θ at lock_at at rest; a prescribed angle follows its law).

After a latch the reaction is differentiable in p at the rows after the event time (whose derivative the
step's size carries); at the event it jumps from −f to the reaction.

With guides the reaction is a row of their reduction (:func:`_held_through_links`). The derivative is
linear in (δq, δv, δv̇): :func:`joint_force_forms` gives its forms, which the forward method applies to its
columns and the discrete adjoint seeds (latdyn/analyses/adjoint_sensitivities.py).

Not differentiated (refused by :func:`refusal`, naming ``solve.sensitivities``): a joint whose torque or
force a controller drives beside a controller with states or a sampled one, or in a model with guides; a joint
force a controller with states or a sampled one reads; static paths (their rows' joint forces are evaluated at the row's λ,
``ProbeSet.load_factor``, but their derivatives through λ along the path are not built).
"""
from __future__ import annotations

import numpy as np

__all__ = ["is_joint_force", "joint_of", "refusal", "joint_force_derivatives", "joint_force_forms",
           "held_reaction_columns", "held_sensor_forms"]


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
    controllers = getattr(scene, "controllers", None) or {}
    named = sorted(set(controllers) & set(getattr(law, "input_names", ()) or ()))
    remembering = sorted(c.name for c in controllers.values() if c.states or c.sampled)
    if named and remembering:
        return (f"the joint-force probe {probe.name!r}: controller {named[0]!r} drives {where}, and controller "
                f"{remembering[0]!r} has states or is sampled: the output's dependence on states and samples is not "
                "part of the joint's force derivative yet (continuous controllers without states are)")
    guides = sorted(name for name, body in scene.bodies.items() if body.guide is not None)
    if named and guides:
        return (f"the joint-force probe {probe.name!r}: controller {named[0]!r} drives {where} in a model with guides "
                f"(bodies.{guides[0]}.guide): its sensors' derivatives through the guides' reduction are not part of "
                "the joint's force derivative yet")
    # a continuous controller without states reading the force: its coupling is in K and C, its ∂f/∂p at the
    # force's value and ∂f/∂s ∂F/∂p (sensitivities.ControllerTerms.sensed_force_slopes); states and samples would
    # need δs along δq
    readers = sorted(c.name for c in (getattr(scene, "controllers", None) or {}).values()
                     if probe.name in c.reads and (c.states or c.sampled))
    if readers:
        return (f"controller {readers[0]!r} reads the joint-force probe {probe.name!r} and has states or is sampled: "
                "a sensor's derivative by a joint force is not computed there yet (a continuous controller without "
                "states may read it)")
    return None


def joint_force_derivatives(owner, state, dq: np.ndarray, dv: np.ndarray, dvdot: np.ndarray) -> dict:
    """{joint index: (k,) derivatives of its force by every parameter} for the joints the probes of
    ``owner`` (a :class:`latdyn.analyses.sensitivities.ParameterDerivatives`) read at ``state``, along the
    free-coordinate sensitivities ``dq``, ``dv``, ``dvdot`` (n, k) of the transient step: each joint's
    :func:`joint_force_forms` applied to them."""
    return {j: c_q @ dq + c_v @ dv + c_vdot @ dvdot + explicit
            for j, (c_q, c_v, c_vdot, explicit) in joint_force_forms(owner, state).items()}


def joint_force_forms(owner, state, joints=None) -> dict:
    """{joint index: (c_q, c_v, c_v̇ (n,) each, explicit (k,))}: the derivative of the force of each joint the
    probes of ``owner`` read (or of ``joints``) at ``state`` is c_q·δq + c_v·δv + c_v̇·δv̇ + explicit, linear in
    the free coordinates' sensitivities (module docstring); the forward method applies it to its columns
    (:func:`joint_force_derivatives`), the adjoint seeds its reverse pass with it."""
    model, assembler, k = owner.model, owner.assembler, len(owner.names)
    n = model.n_dofs
    if joints is None:
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
        wiring = assembler.control
        driven = len(wiring.coupling_rows) > 0   # a continuous controller's output on a joint or load
        native.evaluate(state, driven, 1.0, True, False)   # the hinge loop writes the slopes either way
        slope, damping = native.buffers["hinge_d_theta"].copy(), native.buffers["hinge_d_rate"].copy()
        if driven:
            couplings = (native.buffers["coupling_stiffness"].copy(), native.buffers["coupling_damping"].copy())
        laws = np.zeros((model.n_total + 1, k))
        for key, by_column in owner.derivatives.items():
            _, hinge = owner._key_kinds(key)   # a hinge's or guide's law (its compliant stops': below)
            if hinge:
                j = model.hinge_index(hinge["beam"], hinge["end"])
                if j in free:
                    for column, law in by_column.items():
                        laws[model.hinge_dofs[j], column] += owner._hinge_force(state, j, hinge["law"], law, 1.0)
        owner._contact_forces(state, laws)
        if owner.controllers is not None:   # a continuous controller's output on the joint: its explicit ∂/∂p
            owner.controllers.add(state, laws)
        for j in free:
            d = model.hinge_dofs[j]
            c_q, c_v = np.zeros(n), np.zeros(n)
            c_q[d], c_v[d] = -slope[j], -damping[j]
            if driven:   # and its sensors: the coupling entries of the joint's row (∂(−a y)/∂q, ∂(−a y)/∂v)
                on = (wiring.coupling_rows == d) & (wiring.coupling_cols < n)
                np.subtract.at(c_q, wiring.coupling_cols[on], couplings[0][on])
                np.subtract.at(c_v, wiring.coupling_cols[on], couplings[1][on])
            out[j] = (c_q, c_v, np.zeros(n), -laws[d])
    if held and model.links is not None:   # the reaction through the guides' reduction
        out.update(_held_through_links(owner, state, held))
    elif held:   # the reaction: the exact rows of its coordinate along (δq, δv, δv̇), and ∂r_d/∂p
        rows = model.hinge_dofs[held]
        M, C, K = assembler.exact_rows(state, rows)
        explicit = owner.residual_derivatives(state, 1.0, inertia=True, on_all=True)[rows]
        out.update({j: (K[i], C[i], M[i], explicit[i]) for i, j in enumerate(held)})
    return out


def held_sensor_forms(owner, state, joints: list, stuck: np.ndarray) -> dict:
    """{joint index: (s,)} for the free ``joints`` whose force a continuous controller drives from the angle of a joint
    of ``stuck`` (s joints friction holds): the force −a y moves with each held angle's δθ by −a ∂y/∂θ, the coupling
    entry of the joint's row in the held angle's column (latdyn/assembly/control.py), which :func:`joint_force_forms`
    leaves out (it reads the couplings on the free coordinates; a held angle is none). The forward method adds it times
    the carried δθ (``TransientSensitivities._joint_forces``), the adjoint seeds it on θ̄ (``_held_forms``). A held
    joint's rate and its δθ̇ are 0: the damping couplings add nothing. Joints without such a coupling are left out."""
    model, wiring = owner.model, owner.assembler.control
    held_dofs = model.hinge_dofs[np.asarray(stuck, np.int64)]
    driven = {j: (wiring.coupling_rows == model.hinge_dofs[j]) & np.isin(wiring.coupling_cols, held_dofs)
              for j in joints}
    driven = {j: on for j, on in driven.items() if np.any(on)}
    if not driven:
        return {}
    native = owner.assembler.native()
    native.evaluate(state, True, 1.0, True, False)
    stiffness = native.buffers["coupling_stiffness"]
    out = {}
    for j, on in driven.items():
        column = np.zeros(len(held_dofs))
        for entry in np.flatnonzero(on):
            column[np.flatnonzero(held_dofs == wiring.coupling_cols[entry])] -= stiffness[entry]
        out[j] = column
    return out


def _held_through_links(owner, state, held: list) -> dict:
    """:func:`joint_force_forms` of the held joints ``held`` of a model with guides or rigid links: the forms of the
    reactions on their coordinates (:func:`reaction_forms_through_links`), by joint."""
    forms = reaction_forms_through_links(owner, state, owner.model.hinge_dofs[held])
    return dict(zip(held, forms))


def held_reaction_columns(owner, state, joints: list, stuck: np.ndarray) -> dict:
    """{joint: (s,)}: for each held joint of ``joints`` on a model with rigid links, its reaction's move with each held
    angle of ``stuck`` (s joints friction holds), which :func:`reaction_forms_through_links` leaves out (its forms are
    on the free coordinates; a held angle is none and its δθ is carried apart). The reaction on d = θ_j is
    r_d = r_all,d + Σ_c J_c,dᵀ r_c, so along θ_i at fixed free coordinates, rates and accelerations

        ∂r_d/∂θ_i = ∂r_all,d/∂θ_i + Σ_c (J_c,dᵀ ∂r_c/∂θ_i + ∂(J_c,dᵀ r_c)/∂θ_i at fixed r_c),

    ∂r_all/∂θ_i the exact column on every assembled row (the dependent nodes moved with θ_i, their rates and
    accelerations too: latdyn/analyses/prescribed_rates.py :func:`linked_columns`) and the last the geometric term's
    row d on θ_i's column (:func:`_edge_wrench_derivative`). The forward method adds it times the carried δθ
    (``TransientSensitivities._joint_forces``). Without it the gimbal's stuck inner ring's torque was 64 times its
    sensitivity off Richardson differences (tests/test_sensitivities_linked_sticks.py)."""
    from latdyn.analyses.prescribed_rates import linked_columns
    from latdyn.assembly.linked import evaluate_linked

    model, assembler = owner.model, owner.assembler
    held_dofs = [int(d) for d in model.hinge_dofs[np.asarray(stuck, np.int64)]]
    _, moved = linked_columns(assembler, state, held_dofs, True)
    ev = evaluate_linked(model.links, assembler, state, True, 1.0, True, inertia_tangent=True, rates_term=True)
    J, columns, dep = ev.jacobian, ev.jacobian_columns, ev.dependent_rows
    r_dep = assembler.evaluate_assembled(state, False, 1.0, True).residual[dep]   # the wrenches r_c
    out = {}
    for j in joints:
        d = int(model.hinge_dofs[j])
        column = moved[:, d].copy()
        at = np.flatnonzero(columns == d)
        if len(at):
            column += moved[:, dep] @ J[:, at[0]]
            column += _edge_wrench_derivative(owner, state, j, r_dep)[held_dofs]
        out[j] = column
    return out


def reaction_forms_through_links(owner, state, rows: np.ndarray) -> list:
    """[(c_q, c_v, c_v̇ (n,) each, explicit (k,))] of the reactions on the constrained coordinates ``rows`` of a model
    with guides or rigid links (their reduction, latdyn/assembly/linked.py; a held joint's angle or slide, a prescribed
    hinge's or guide's, a prescribed body's six): the reaction on d is the reduced residual's row of d,

        r_d = r_all,d + Σ_c J_c,dᵀ r_c,

    r_all the residual on all coordinates before the reduction, r_c the wrench at each dependent node c whose
    motion the coordinate moves (J_c,d its column of the dependent node's J: a guide's slide moves its body,
    and the nodes below it, along the slide's axis; a root's six move every node of its tree). Its derivative along
    (δq, δv, δv̇):

        δr_d = δr_all,d + Σ_c (J_c,dᵀ δr_c + δ(J_c,d)ᵀ r_c),

    δr_all on rows d and c from the exact rows before the reduction (:meth:`Assembler.exact_rows`) along the
    assembled coordinates' δq_all = P δq, δv_all = P δv + ∂(J v)/∂q δq and δv̇_all = P δv̇ + ∂(J a + c)/∂q δq +
    ∂c/∂v δv (the dependent rates' derivatives, as the exact reduced K and C hold them) plus ∂r_all/∂p there;
    δ(J_c,d)ᵀ r_c as the reduction's geometric stiffness takes it on the free coordinates' rows (csrc/links.c
    geometric_term): on a joint's coordinate from the generated ``slide_wrench`` or ``hinge_wrench``
    (:func:`_edge_wrench_derivative`), on a root's from the generated ``root_wrench`` (:func:`_root_wrench_derivative`)."""
    from latdyn.assembly.linked import evaluate_linked

    model, assembler, links = owner.model, owner.assembler, owner.model.links
    rows = np.asarray(rows, np.int64)
    ev = evaluate_linked(links, assembler, state, True, 1.0, True, inertia_tangent=True, rates_term=True)
    P, dep = ev.projection, ev.dependent_rows
    by_velocity, by_acceleration = ev.rates_tangent
    every = np.concatenate([rows, dep])
    M, C, K = assembler.exact_rows(state, every)
    explicit = owner.residual_derivatives(state, 1.0, inertia=True, on_all=True)[every]
    # the forms of rows d and c on the free coordinates, through δq_all, δv_all, δv̇_all
    c_q = _dense(K @ P) + _dense(C[:, dep] @ by_velocity) + _dense(M[:, dep] @ by_acceleration)
    c_v = _dense(C @ P) + _dense(M[:, dep] @ ev.velocity_derivative)
    c_vdot = _dense(M @ P)
    J, columns = ev.jacobian, ev.jacobian_columns
    r_dep = assembler.evaluate_assembled(state, False, 1.0, True).residual[dep]   # the wrenches r_c
    joint_of_row = {int(d): j for j, d in enumerate(model.hinge_dofs)}
    root_of_row = {int(d): (node, i) for node in set(links.root.values()) for i, d in enumerate(model.node_dofs[node])}
    out = []
    m = len(rows)
    for i, d in enumerate(rows):
        form = [c_q[i].copy(), c_v[i].copy(), c_vdot[i].copy(), explicit[i].copy()]
        at = np.flatnonzero(columns == int(d))
        if len(at):
            through = J[:, at[0]]
            for part, values in zip(form, (c_q, c_v, c_vdot, explicit)):
                part += through @ values[m:]
            if int(d) in joint_of_row:
                form[0] += _edge_wrench_derivative(owner, state, joint_of_row[int(d)], r_dep)[:model.n_dofs]
            elif int(d) in root_of_row:
                form[0] += _root_wrench_derivative(owner, state, *root_of_row[int(d)], r_dep)
        out.append(tuple(form))
    return out


def _root_wrench_derivative(owner, state, root: int, i: int, r_dep: np.ndarray) -> np.ndarray:
    """Σ_c ∂(J_c,dᵀ r_c)/∂q at fixed r_c (n,) for the coordinate ``i`` (of six) of the root node ``root`` of a links'
    tree: the generated ``root_wrench``'s row i, (f, m + (x_c − x_r) × f), by each dependent node c's δx_c chained with
    its J (the root's own δx_r: its own columns, as csrc/links.c geometric_term takes it on the free rows)."""
    model, links, kernels = owner.model, owner.model.links, owner.kernels
    native, n = owner.assembler.native().links, model.n_dofs
    out = np.zeros(n)
    for c_index, c in enumerate(links.dependent):
        r = r_dep[6 * c_index:6 * c_index + 6]
        if links.root[int(c)] != root or not np.any(r):
            continue
        wrench = np.concatenate([state.x[root], state.x[int(c)], r])[None]
        D = np.asarray(kernels.root_wrench(wrench)[1]).reshape(6, 6)
        s = native.slot_of_node[int(c)]
        Jc = native.jacobian[s, :, :native.count[s]]
        row = D[i, 3:] @ Jc[:3]
        row[:3] += D[i, :3]
        slot_columns = native.columns[s, :native.count[s]]
        keep = slot_columns < n
        np.add.at(out, slot_columns[keep], row[keep])
    return out


def _dense(product) -> np.ndarray:
    """A product of a dense array and a (possibly SciPy sparse) matrix, as a dense array."""
    return product.toarray() if hasattr(product, "toarray") else np.asarray(product)


def _edge_wrench_derivative(owner, state, j: int, r_dep: np.ndarray) -> np.ndarray:
    """Σ_c ∂(J_c,dᵀ r_c)/∂q at fixed r_c (n_total + 1,: every column of the slots, a held joint's angle too) for the
    joint ``j`` of an edge of the links' tree: the generated ``slide_wrench`` (``hinge_wrench`` for a revolute edge) at
    each dependent node c below it, its derivative by the edge parent's δx, δπ and c's δx chained with their J (as
    csrc/links.c's geometric term (assemble_linked_into) takes it for the free coordinates' rows)."""
    model, links, kernels = owner.model, owner.model.links, owner.kernels
    native, n = owner.assembler.native().links, model.n_total
    out = np.zeros(n + 1)
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
            np.add.at(out, slot_columns[keep], row[keep])
    return out
