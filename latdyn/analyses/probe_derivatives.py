"""Exact sensitivities of the element, cable and body-frame point probes (SCENE.md, "Parameters and
sensitivities": the derivative of each recorded probe; docs/parameters.md, "Section forces, cables and
body frames").

Each probe is a function y(q, v; p) of the configuration, the rates and the parameters, so along the
sensitivities (δq, δv) that the static path or the transient step carries (the update's coordinates:
translations δx, spatial rotations δπ with T ← exp(skew δπ) T, hinge angles δθ)

    δy = ∂y/∂q δq + ∂y/∂v δv + ∂y/∂p,

with ∂y/∂q and ∂y/∂v from the generated kernels, never differenced:

- an element's section force S = [N, T, M_y, M_z] at mid-element (``{element: BEAM.element[i], quantity:
  axial_force|torque|moment_y|moment_z}``, the strain-energy kernel's): ∂S/∂q = (∂S/∂Ψ) B from the
  generated ``beam_section_forces_D_q`` on the element's fourteen coordinates [x1, π1, θ1, x2, π2, θ2]; ∂S/∂p
  of a section value from the generated ``beam_section_forces_D_section`` (∂S by each section value, every
  formulation, shear-flexible sections too) contracted with the value's derivative, the planar model's quarter
  turns of the section axes undone as :func:`latdyn.model.planar.section_moments_back` undoes them. S reads no
  rate.
- a cable's tension N (its first element's; ``{cable: NAME, quantity: tension}``): while the element is
  taut (as the evaluation decides it: held taut, or on no side its gap positive) the generated
  ``cable_tension`` gives ∂N/∂[d1, π1, d2, π2] and ∂N/∂[v1, ω1, v2, ω2] (the damper c ℓ̇), and ∂N/∂p comes
  from the generated ``cable_force`` as :class:`latdyn.analyses.cable_sensitivities.CableSensitivities`
  takes it: linear in (EA, c), affine in 1/L0; while slack N = 0 and so is its derivative.
  Its length Σ ℓ (``quantity: length``): ∂ℓ/∂q is ``cable_tension``'s ∂N/∂q at EA = L0 = 1, c = 0
  (N = ℓ − 1 there); it reads no parameter but through q.
- a point in a body's frame (``{point: …, quantity: position|displacement|velocity, frame: BODY}``): with
  the body's node at x_b, its frame R_b, ω_b, the point p = x + T r and u = p − x_b, the value R_bᵀu (less
  its value at t = 0 for a displacement, which no parameter but a geometry one moves) moves by

      δ(R_bᵀu) = R_bᵀ(δp − δx_b − δπ_b × u),

  and the velocity in the body's axes R_bᵀV, V = ṗ − v_b − ω_b × u, ṗ = v + ω × T r, by
  R_bᵀ(δV − δπ_b × V), δV = δṗ − δv_b − δω_b × u − ω_b × δu, δṗ = δv + δω × T r + ω × (δπ × T r).

:func:`probe_derivatives` applies these to the columns (δx, δπ, δθ) and (δv, δω, δθ̇) of every parameter
(the forward method's rows, static and transient); :func:`probe_forms` gives the same as the forms
(c_q, c_v, explicit ∂y/∂p) the discrete adjoint seeds (latdyn/analyses/adjoint_sensitivities.py).

Geometry parameters (latdyn/analyses/geometry_sensitivities.py) move an element's reference data — its
section forces gain the generated ``beam_section_forces_D_reference`` along each parameter's variation
(:meth:`ReferenceGeometry.at_state`) — and a body frame's point: its offset at a beam's end (T δr), a fixed or
prescribed node (:meth:`ReferenceGeometry.held_moves`) and a displacement's start (δp_0 − δx_b,0: a body's axes
are the global ones at t = 0).

Refused (:func:`refusal`, exit 2 naming ``solve.sensitivities``): a point's velocity in a body frame in a
static path (as in the global frame; beside guides it is taken: the guided body's rates are a dependent node's,
latdyn/analyses/link_sensitivities.py ``dependent_rates``); by geometry parameters, a variant generated without
``beam_section_forces_D_reference`` (at run time, naming the variant to regenerate).
"""
from __future__ import annotations

import numpy as np

from latdyn.results.probes import SECTION_QUANTITIES

__all__ = ["is_probe_here", "refusal", "probe_derivatives", "probe_forms"]


def is_probe_here(probe) -> bool:
    """Whether this module differentiates ``probe``: an element's section force, a cable's tension or
    length, a point in a body's frame."""
    return probe.kind in ("element", "cable") or (probe.kind == "point" and probe.frame != "global")


def refusal(scene, probe) -> str | None:
    """Why ``probe``'s sensitivities are not exact here, or None (module docstring)."""
    what = (f"probe {probe.name!r} ({probe.kind} {probe.quantity}"
            f"{', frame ' + probe.frame if probe.kind == 'point' else ''})")
    if probe.kind == "point" and probe.quantity == "velocity":
        if scene.solve.analysis != "transient":
            return f"{what}: a velocity is differentiated in transient runs only"
    return None


# ---------------------------------------------------------------------------------------------- the rows
def probe_derivatives(owner, probe, state, dx, dpi, dtheta, rates=None, explicit: bool = True) -> list:
    """The derivatives of ``probe`` at ``state`` along the columns (δx, δπ, δθ) of every node and hinge
    ((n_nodes, 3, k), (n_nodes, 3, k), (n_hinges, k): :meth:`ParameterDerivatives._by_parameter`) and the
    rates' (δv, δω, δθ̇) (``rates``; None: at rest), plus, with ``explicit``, ∂y/∂p of the k parameters (the
    columns are then the parameters'; without it any columns, such as the adjoint's unit ones)."""
    if probe.kind == "element":
        values = _section_force(owner, probe, state, dx, dpi, dtheta, explicit)
    elif probe.kind == "cable":
        values = _cable(owner, probe, state, dx, dpi, rates, explicit)
    else:
        return _in_body_frame(owner, probe, state, dx, dpi, rates, explicit)
    return [float(v) for v in values]


def probe_forms(owner, probe, state) -> tuple:
    """(c_q, c_v, c_v̇ (n,) each, explicit (k,)) on the free coordinates: ``probe``'s derivative at ``state`` is
    c_qᵀδq + c_vᵀδv + explicit (c_v̇ = 0), for the discrete adjoint's seeds; :func:`probe_derivatives` on
    the unit columns of the free coordinates it moves with (:func:`_columns_read`), and on k zero columns for the
    explicit part. With rigid links or guides a node that follows them moves with its root's and its joints'
    coordinates, its rates by P δv + ∂(J v)/∂q δq (the forward method's ``_rates_by_parameter`` with δq)."""
    n, k = owner.model.n_dofs, len(owner.names)
    dofs = _columns_read(owner, probe)
    c_q, c_v = np.zeros(n), np.zeros(n)
    if len(dofs):
        units = np.zeros((n, len(dofs)))
        units[dofs, np.arange(len(dofs))] = 1.0
        still = np.zeros_like(units)
        c_q[dofs] = probe_derivatives(owner, probe, state, *owner._by_parameter(units, state),  # noqa: SLF001
                                      owner._rates_by_parameter(still, units, state), explicit=False)  # noqa: SLF001
        if probe.quantity in ("velocity", "tension"):
            c_v[dofs] = probe_derivatives(owner, probe, state, *owner._by_parameter(still, state),  # noqa: SLF001
                                          owner._rates_by_parameter(units, still, state), explicit=False)  # noqa: SLF001
    zero = np.zeros((n, k))
    moved = owner._by_parameter(zero, state)   # noqa: SLF001
    explicit = np.asarray(probe_derivatives(owner, probe, state, *moved, owner._rates_by_parameter(zero)), float)  # noqa: SLF001
    return c_q, c_v, np.zeros(n), explicit


def _columns_read(owner, probe) -> np.ndarray:
    """The free coordinates (sorted) whose sensitivities ``probe``'s derivative reads: those of its nodes and
    hinges (:func:`_coordinates_read`) below n, and with rigid links or guides those each of its nodes moves with
    (:func:`latdyn.analyses.link_sensitivities.columns_moving`: a dependent node's root's and joints')."""
    from latdyn.analyses.link_sensitivities import columns_moving

    model = owner.model
    n = model.n_dofs
    dofs = _coordinates_read(owner, probe)
    found = [dofs[dofs < n]]
    if model.links is not None:
        found += [columns_moving(model, int(node)) for node in _nodes_read(owner, probe)]
    return np.unique(np.concatenate(found).astype(np.int64))


def _nodes_read(owner, probe) -> np.ndarray:
    """The nodes whose motion ``probe`` reads: an element's two, a cable's, a point's and its frame body's."""
    model = owner.model
    if probe.kind == "element":
        return model.element_nodes[int(model.beam_elements[probe.beam][probe.element])]
    if probe.kind == "cable":
        cables = model.cables
        return cables.nodes[cables.cable == cables.names.index(probe.beam)].ravel()
    node, _ = model.point(probe.point)
    return np.array([node, model.body_node[probe.frame]])


def _coordinates_read(owner, probe) -> np.ndarray:
    """The coordinates (all, n_total + 1 numbering) whose sensitivities ``probe``'s derivative reads."""
    model = owner.model
    if probe.kind == "element":
        return model.element_dofs[int(model.beam_elements[probe.beam][probe.element])].ravel()
    return model.node_dofs[_nodes_read(owner, probe)].ravel()


# ---------------------------------------------------------------------------------------------- section forces
def _section_force(owner, probe, state, dx, dpi, dtheta, explicit: bool) -> np.ndarray:
    """δS of an element probe (module docstring), (k,)."""
    model, kernels = owner.model, owner.kernels
    e = int(model.beam_elements[probe.beam][probe.element])
    which = SECTION_QUANTITIES.index(probe.quantity)
    geometry = _element_geometry(owner, state)
    at = np.ascontiguousarray(geometry[e:e + 1])
    out = kernels.beam_section_forces_D_q(at, np.ascontiguousarray(model.element_sections[e:e + 1]))
    by_q = _turned_back(model, e, np.asarray(out[1]).reshape(4, 14))[which]            # ∂S/∂q (14,)
    columns = []
    for end in (0, 1):
        node, hinge = int(model.element_nodes[e, end]), int(model.element_hinges[e, end])
        columns += [dx[node], dpi[node], (dtheta[hinge] if hinge >= 0 else np.zeros(dx.shape[2]))[None]]
    moved = by_q @ np.vstack(columns)                                                   # (k,)
    if explicit:
        moved = moved + _section_values(owner, state, e, which, at)
        if owner.geometry is not None:
            moved = moved + _section_reference(owner, state, e, which, at)
    return moved


def _section_reference(owner, state, e: int, which: int, at: np.ndarray) -> np.ndarray:
    """∂S/∂p (k,) of element ``e``'s section force ``which`` by the geometry parameters: the generated
    ``beam_section_forces_D_reference`` along each parameter's variation of the element's reference data
    (:meth:`latdyn.analyses.geometry_sensitivities.ReferenceGeometry.at_state`)."""
    from latdyn.analyses.geometry_sensitivities import WIDTH

    kernels, k = owner.kernels, len(owner.names)
    info = getattr(kernels, "info", {}) or {}
    name = "beam_section_forces_D_reference"
    if name not in info or dict(info[name]["inputs"]).get("reference") != WIDTH:
        from latdyn.errors import SceneError
        raise SceneError(owner.scene.file, "solve.sensitivities",
                         f"section-force probes by geometry parameters need the kernel {name} (reference block of "
                         f"{WIDTH}), which the generated variant {kernels.variant!r} does not hold yet (python -m "
                         f"codegen --variant {kernels.variant})")
    variation = owner.geometry.at_state(state, np.array([e]), at)                      # (1, WIDTH, k)
    rows = np.ascontiguousarray(variation[0].T)                                         # (k, WIDTH)
    tile = lambda a: np.ascontiguousarray(np.repeat(a, k, axis=0))  # noqa: E731
    out = kernels.beam_section_forces_D_reference(tile(at), tile(owner.model.element_sections[e:e + 1]), rows)
    return _turned_back(owner.model, e, np.asarray(out[1]).reshape(k, 4).T)[which]


def _element_geometry(owner, state) -> np.ndarray:
    """The element kernels' geometry block at ``state`` (one native call per state, held for the row)."""
    held = owner.__dict__.get("_probe_geometry")
    # keyed on the configuration itself (a static path's rows all have t = 0, and a freed state's id is reused)
    key = (float(state.t), state.x.tobytes(), state.T.tobytes(), state.theta.tobytes())
    if held is None or held[0] != key:
        held = (key, owner.assembler.native().element_inputs(state)[0])
        owner.__dict__["_probe_geometry"] = held
    return held[1]


def _section_values(owner, state, e: int, which: int, at: np.ndarray) -> np.ndarray:
    """∂S/∂p (k,) of element ``e``'s section force ``which`` by the parameters of its section's values: the
    generated ``beam_section_forces_D_section`` (the forces' derivatives by the section values, exact for every
    formulation and shear-flexible sections) contracted with each use's ∂(section block)/∂p."""
    k = len(owner.names)
    blocks = owner._section_derivative_blocks(state)   # noqa: SLF001
    out = np.zeros(k)
    if blocks is None:
        return out
    elements, columns, rows = blocks
    on = np.flatnonzero(elements == e)
    if not len(on):
        return out
    by_section = np.asarray(owner.kernels.beam_section_forces_D_section(
        np.ascontiguousarray(at), np.ascontiguousarray(owner.model.element_sections[e:e + 1]))[1]).reshape(4, 9)
    turned = _turned_back(owner.model, e, by_section @ rows[on, 1:].T)[which]
    np.add.at(out, columns[on], turned)
    return out


def _turned_back(model, e: int, forces: np.ndarray) -> np.ndarray:
    """Rows [N, T, M_y', M_z'] (4, …) of element ``e`` in its turned section axes → the beam's own
    (:func:`latdyn.model.planar.section_moments_back`, linear: applied to derivatives as to values)."""
    beta = float(model.section_turns[e]) if model.section_turns is not None else 0.0
    if beta == 0.0:
        return forces
    c, s = np.cos(beta), np.sin(beta)
    out = np.array(forces, float, copy=True)
    out[2] = c * forces[2] - s * forces[3]
    out[3] = s * forces[2] + c * forces[3]
    return out


# ---------------------------------------------------------------------------------------------- cables
def _cable_terms(owner):
    """The cables' law of the sensitivities (the transient owner's, or one made for a static path)."""
    terms = getattr(owner, "cables", None)
    if terms is None:
        terms = owner.__dict__.get("_probe_cables")
        if terms is None:
            from latdyn.analyses.cable_sensitivities import CableSensitivities
            terms = CableSensitivities(owner)
            owner.__dict__["_probe_cables"] = terms
    return terms


def _cable(owner, probe, state, dx, dpi, rates, explicit: bool) -> np.ndarray:
    """δN of a cable's first element or δ(Σ ℓ) of its elements (module docstring), (k,)."""
    terms = _cable_terms(owner)
    cables = owner.model.cables
    k_cable = cables.names.index(probe.beam)
    if probe.quantity == "tension":
        e = int(cables.first[k_cable])
        if not terms.taut(state)[e]:
            return np.zeros(dx.shape[2])          # slack: N = 0 about the computed solution
        by_q, by_v = _tension_gradients(owner, terms, state, e)
        moved = by_q @ _end_columns(cables, e, dx, dpi)
        if rates is not None:
            moved = moved + by_v @ _end_columns(cables, e, rates[0], rates[1])
        if explicit:
            moved = moved + _tension_by_parameters(owner, terms, state, e) + _tension_in_time(owner, terms, state, e)
        return moved
    moved = np.zeros(dx.shape[2])
    for e in np.flatnonzero(cables.cable == k_cable):
        by_q, _ = _tension_gradients(owner, terms, state, int(e), unit=True)
        moved = moved + by_q @ _end_columns(cables, int(e), dx, dpi)
    return moved


def _end_columns(cables, e: int, linear, angular) -> np.ndarray:
    """(12, k): element ``e``'s end nodes' columns [d1, π1, d2, π2] (or [v1, ω1, v2, ω2])."""
    a, b = (int(n) for n in cables.nodes[e])
    return np.vstack([linear[a], angular[a], linear[b], angular[b]])


def _tension_gradients(owner, terms, state, e: int, unit: bool = False):
    """(∂N/∂[d1, π1, d2, π2], ∂N/∂[v1, ω1, v2, ω2]) of element ``e`` from the generated ``cable_tension``; with
    ``unit`` at EA = L0 = 1, c = 0, where ∂N/∂q is ∂ℓ/∂q."""
    cables = terms.cables
    nodes = cables.nodes[e]
    geometry = np.concatenate([state.x[nodes[0]], state.x[nodes[1]],
                               state.T[nodes[0]] @ cables.offsets[e, 0], state.T[nodes[1]] @ cables.offsets[e, 1]])
    velocity = np.concatenate([state.v[nodes[0]], state.w[nodes[0]], state.v[nodes[1]], state.w[nodes[1]]])
    if unit:
        section = np.array([1.0, 0.0, 1.0, 0.0])
    else:
        rest = cables.rest_length[cables.cable[e]]
        share = cables.share[e]
        section = np.array([share * rest.value(state.t), share * rest.rate(state.t), cables.EA[e], cables.damping[e]])
    out = owner.kernels.cable_tension(*(np.ascontiguousarray(a[None]) for a in (geometry, velocity, section)))
    return np.asarray(out[1]).reshape(12), np.asarray(out[2]).reshape(12)


def _tension_in_time(owner, terms, state, e: int) -> np.ndarray:
    """∂N/∂t δt (k,) of taut element ``e`` at a row whose time moves with p (δt ≠ 0: an event's row, the rows
    after it until a step lands on the grid): a reel's rest length L0(t) moves N by ∂N/∂L0 · share · L0′(t) (the
    law reads no L̇0, :meth:`CableSensitivities.reel_forces`); an end on a prescribed body moves through δx
    already (``TransientSensitivities._prescribed_in_time``). Zero elsewhere (static paths carry no δt)."""
    moved = np.asarray((getattr(owner, "carried_accounts", None) or {}).get("dt", 0.0), float)
    rest = terms.cables.rest_length[terms.cables.cable[e]]
    if rest.is_constant or not np.any(moved):
        return np.zeros(len(owner.names))
    rate = terms._rest_length_derivative(state, e, 3)[4] * terms.cables.share[e] * rest.rate(state.t)  # noqa: SLF001
    return rate * moved


def _tension_by_parameters(owner, terms, state, e: int) -> np.ndarray:
    """∂N/∂p (k,) of taut element ``e`` by its cable's EA, damping and rest length (``cable_force``'s state
    output: linear in (EA, c), affine in 1/L0; :class:`CableSensitivities`)."""
    out = np.zeros(len(owner.names))
    k_cable = int(terms.cables.cable[e])
    for k, value, column, law in terms.uses:
        if k != k_cable or value == "rhoA":
            continue
        derivative = law.value(0.0, 0.0, state.t)
        if derivative == 0.0:
            continue
        if value == "EA":
            slope = terms.law(state, e, EA=derivative, c=0.0)[3][4]
        elif value == "damping":
            slope = terms.law(state, e, EA=0.0, c=derivative)[3][4]
        else:   # rest_length: its share L0 = share · L
            slope = terms._rest_length_derivative(state, e, 3)[4] * terms.cables.share[e] * derivative  # noqa: SLF001
        out[column] += slope
    return out


# ---------------------------------------------------------------------------------------------- body frames
def _in_body_frame(owner, probe, state, dx, dpi, rates, explicit: bool = True) -> list:
    """δ of a point's position, displacement or velocity in a body's axes (module docstring), (k,); with
    ``explicit`` (the columns the parameters') the geometry parameters' moves of its offset, fixed nodes and
    start too."""
    model = owner.model
    node, offset = model.point(probe.point)
    b = model.body_node[probe.frame]
    R, arm = state.T[b], state.T[node] @ offset
    u = state.x[node] + arm - state.x[b]
    turned = np.cross(dpi[node], arm, axisa=0, axisc=0)                         # δ(T r) at a fixed r, (3, k)
    dx_n, dx_b, start = dx[node], dx[b], 0.0   # start: δ of a displacement's value at t = 0 (R_b = I there)
    if explicit and owner.geometry is not None:   # a geometry parameter moves the offset r, a fixed node, the start
        offset_moved, reference_moved = owner.geometry.point_moves(probe, state)
        held_n, held_b = owner.geometry.held_moves(node), owner.geometry.held_moves(b)
        turned = turned + offset_moved - held_n                                    # + T δr
        dx_n, dx_b = dx_n + held_n, dx_b + held_b
        start = reference_moved - owner.geometry.node_moves[b]
    dp = dx_n + turned                                                              # δp (3, k)
    du = dp - dx_b
    if probe.quantity == "velocity":
        dvel, domega, _ = rates
        w_n, w_b = state.w[node], state.w[b]
        V = state.v[node] + np.cross(w_n, arm) - state.v[b] - np.cross(w_b, u)
        dpdot = dvel[node] + np.cross(domega[node], arm, axisa=0, axisc=0) \
            + np.cross(w_n, turned, axisb=0, axisc=0)
        dV = dpdot - dvel[b] - np.cross(domega[b], u, axisa=0, axisc=0) - np.cross(w_b, du, axisb=0, axisc=0)
        value, moved = R.T @ V, R.T @ (dV - np.cross(dpi[b], V, axisa=0, axisc=0))
    else:
        value, moved = R.T @ u, R.T @ (du - np.cross(dpi[b], u, axisa=0, axisc=0))
        if probe.quantity == "displacement":   # less its value at t = 0 (R_bᵀ = I there)
            value = value - _initial_in_body(owner, probe)
            moved = moved - start
    if probe.component in (None, "norm"):
        size = float(np.linalg.norm(value))
        if size > 0:
            return [float(v) for v in value @ moved / size]
        return [0.0 if not np.any(moved[:, c]) else float("nan") for c in range(moved.shape[1])]
    return [float(v) for v in moved["xyz".index(probe.component)]]


def _initial_in_body(owner, probe) -> np.ndarray:
    """The point's position in the body's axes at t = 0 (a displacement's norm is taken of the difference)."""
    held = owner.__dict__.setdefault("_initial_in_body", {})
    if probe.name not in held:
        model = owner.model
        initial = owner.assembler.initial_state()
        node, offset = model.point(probe.point)
        b = model.body_node[probe.frame]
        held[probe.name] = initial.T[b].T @ (initial.x[node] + initial.T[node] @ offset - initial.x[b])
    return held[probe.name]
