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
        if joint.lock_at is not None or joint.limits is not None:
            return (f"the force probe {probe.name!r} of the guide of {probe.body} with lock_at or limits: the "
                    "reaction of a guide's latch or rigid stop is not differentiated yet (a free guide's law is)")
    guides = [name for name, body in scene.bodies.items() if body.guide is not None]
    if probe.kind == "hinge" and guides and (joint.lock_at is not None or joint.angle is not None
                                             or (joint.limits is not None and joint.contact is None)):
        return (f"the torque probe {probe.name!r} of a hinge that a latch, a rigid stop or a prescribed angle holds, "
                f"in a model with guides (bodies.{guides[0]}.guide): its reaction is a row of the guides' reduction, "
                "not assembled on constrained coordinates yet")
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
    if held:   # the reaction: the exact rows of its coordinate along (δq, δv, δv̇), and ∂r_d/∂p
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
