"""∂r/∂t through the prescribed motions, exactly (docs/parameters.md, "Sensitivities through events", "Laws in
time"; :class:`latdyn.analyses.transient_sensitivities.ExplicitTime`).

A prescribed body's translation x₀ + g(t) and rotation exp(skew(a g(t))) about its fixed axis a, and a prescribed
hinge angle or slide g(t), move the residual at fixed free coordinates, rates and accelerations through the
prescribed coordinates' values, rates and accelerations:

    ∂r/∂t = K_·p q̇_p + C_·p q̈_p + M_·p q⃛_p,

K (exact: the inertia tangent and the joint bodies' inertia stiffness with the inertia), C and M the blocks of one
native evaluation, their columns of the prescribed coordinates, and q̇_p, q̈_p, q⃛_p the motion laws' exact first,
second and third derivatives at t (SymPy's, as :class:`latdyn.scene.expressions.TimeFunction` takes the first two;
a table's slope and zeros). A rotation about a fixed axis moves T by exp(skew(a Δg)) T: its coordinates in the
spatial tangent space that K's rotation columns use are a ġ, a g̈, a g⃛. The products are one native call
(csrc/prescribed_rates.c ``latdyn_prescribed_time_rate``), which the sensitivities' loop of steps makes too.

A continuous controller whose sensor reads a prescribed coordinate adds its coupling entry (of K for a coordinate
or a rotation read, of C for a rate) times the motion's rate or acceleration, last (``couplings``).

With rigid links or guides (:meth:`PrescribedRates.linked`, csrc/linked_prescribed_rates.c) the dependent nodes that
hang from a prescribed coordinate move with it, at fixed free coordinates, rates and accelerations:
δq_dep = J_·p q̇_p, δv_dep = ∂(J v)/∂q_p q̇_p + J_·p q̈_p, δa_dep = ∂(J a + c)/∂q_p q̇_p + ∂c/∂v_p q̈_p + J_·p q⃛_p
(J, ∂c/∂v and the dependent rates' ∂/∂q of the compiled step's links, latdyn/assembly/linked.py); the blocks take
those moves as the prescribed coordinates' (∂r_all/∂t), and r_min = Pᵀ r_all moves as
Pᵀ ∂r_all/∂t + ∂(Pᵀ)/∂q_p q̇_p · r_all, the geometric term the forward step's own (csrc/links.c geometric_term) on
the prescribed columns. A controller reading a dependent coordinate adds its coupling there too.
"""
from __future__ import annotations

import ctypes

import numpy as np

from latdyn.scene.expressions import _PROBES, TimeFunction, _drop_deltas, cached_entry, keep_entry

__all__ = ["PrescribedRates", "linked_columns", "third_derivative"]


def third_derivative(law):
    """d³g/dt³ of a :class:`TimeFunction` as a function of t: SymPy's derivative of the law's second (deltas
    dropped, as its first two); 0 for a constant and a table (piecewise linear). Kept in the package's cache of
    what is derived from a text (``keep_entry``, kind "jerk"), so that a later process imports no SymPy for it, as
    the law's own value, rate and acceleration."""
    if law is None or not isinstance(law, TimeFunction) or law.kind != "expression":
        return lambda t: 0.0
    if not law._input_names:   # noqa: SLF001 - a law of t alone: the cache
        cached = cached_entry("jerk", law.source)
        if cached is not None and cached.get("numpy"):
            third = cached["numpy"][0]
            return lambda t: float(third(float(t)))
    import sympy as sp

    if getattr(law, "_derivative_cache", None) is None:
        law._symbolic()   # noqa: SLF001 - the law's own parse (its cache holds the lambdas alone)
    symbol, (_, _, second) = law._derivative_cache   # noqa: SLF001
    expression = _drop_deltas(sp.diff(second, symbol))
    if not law._input_names:   # noqa: SLF001
        third = sp.lambdify([symbol], expression, modules="numpy")
        keep_entry("jerk", law.source, {}, {"numpy": (third,)}, [(t,) for t in _PROBES])
        return lambda t: float(third(float(t)))
    third = sp.lambdify([symbol, *law._input_symbols()], expression, modules="numpy")   # noqa: SLF001
    return lambda t: float(third(float(t), *law._input_values()))   # noqa: SLF001


class PrescribedRates:
    """∂r/∂t through the prescribed motions of ``owner``'s model (a TransientSensitivities; module docstring)."""

    def __init__(self, owner):
        self.owner = owner
        model = owner.model
        scene = model.scene
        #: (node, slot, law, its third derivative, factor): each prescribed coordinate's law, in the model's order
        self.motions = []
        for i in model.prescribed_nodes():
            body = scene.bodies[model.nodes[i].body]
            if body.translation is not None:
                for axis, law in enumerate(body.translation):
                    if isinstance(law, TimeFunction) and not law.is_constant:
                        self.motions.append(("node", i, axis, law, third_derivative(law), 1.0))
            angle = body.rotation_angle
            if isinstance(angle, TimeFunction) and not angle.is_constant:
                jerk = third_derivative(angle)
                for axis, factor in enumerate(np.asarray(body.rotation_axis, float)):
                    if factor != 0.0:
                        self.motions.append(("node", i, 3 + axis, angle, jerk, float(factor)))
        for j, hinge in enumerate(model.hinges):
            if isinstance(hinge.angle, TimeFunction) and not hinge.angle.is_constant:
                self.motions.append(("hinge", j, 0, hinge.angle, third_derivative(hinge.angle), 1.0))

    def couplings(self) -> np.ndarray | None:
        """(2 n_couplings,) int64: the continuous controllers' coupling rows, then their columns (the numbering
        now), or None without them: csrc/prescribed_rates.c takes each entry whose column the motions move."""
        return coupling_entries(self.owner.assembler)

    def coordinates(self) -> np.ndarray:
        """Every prescribed coordinate (the numbering now), laws or none."""
        model = self.owner.model
        return model.prescribed_coordinates()

    def _moved(self) -> list:
        """The motions whose coordinate is one (a planar model's out-of-plane slots are not), in their order."""
        model = self.owner.model
        out = []
        for kind, index, slot, law, jerk, factor in self.motions:
            d = model.node_dofs[index, slot] if kind == "node" else model.hinge_dofs[index]
            if d < model.n_total:
                out.append((int(d), law, jerk, factor))
        return out

    def motion_coordinates(self) -> np.ndarray:
        """(n_motions,) int64: the coordinate each motion law moves (the numbering now)."""
        return np.array([d for d, *_ in self._moved()], np.int64)

    def values(self, t: float) -> np.ndarray:
        """(3, n_motions): each motion law's rate, acceleration and jerk at t, times its axis's factor."""
        moved = self._moved()
        out = np.zeros((3, len(moved)))
        for q, (_, law, jerk, factor) in enumerate(moved):
            out[0, q] = factor * law.rate(t)
            out[1, q] = factor * law.accel(t)
            out[2, q] = factor * jerk(t)
        return out

    def rates(self, t: float) -> np.ndarray:
        """(3, n_total + 1): q̇_p, q̈_p, q⃛_p at t on the prescribed coordinates, zero elsewhere (:meth:`values`
        scattered, as csrc/sensitivity_loop.c prescribed_time_rate scatters its table's row)."""
        out = np.zeros((3, self.owner.model.n_total + 1))
        out[:, self.motion_coordinates()] = self.values(t)
        return out

    def mask(self) -> np.ndarray:
        """(n_total + 1,) int64: 1 on the prescribed coordinates."""
        model = self.owner.model
        out = np.zeros(model.n_total + 1, np.int64)
        out[self.coordinates()] = 1
        return out

    def load_columns(self) -> np.ndarray:
        """(n_loads, 6) int64: each load block's columns (Assembler._load_columns), contiguous."""
        return load_block_columns(self.owner.assembler)

    def __call__(self, state, inertia: bool = True, rates: np.ndarray | None = None) -> np.ndarray:
        """∂r/∂t (n_total + 1,) through the prescribed motions at ``state`` (every coordinate's row; the caller
        takes the free ones or reduces): one native evaluation with the blocks, then latdyn_prescribed_time_rate;
        with rigid links or guides see :meth:`linked`."""
        if self.owner.model.links is not None:
            return self.linked(state, inertia, rates)[0]
        native, pointers, _ = self._evaluated(state, inertia, rates)
        out = np.empty(self.owner.model.n_total + 1)
        native.library.latdyn_prescribed_time_rate(native.model_ref, native.work_ref, pointers[0], pointers[1],
                                                   int(bool(inertia)), *pointers[2:], out.ctypes.data)
        return out

    def _evaluated(self, state, inertia: bool, rates: np.ndarray | None, mask: np.ndarray | None = None) -> tuple:
        """The native model evaluated at ``state`` with the blocks (the inertia tangent with ``inertia``), and the
        addresses of the mask (default :meth:`mask`), the rates, the joint bodies' inertia stiffness (or None), the
        loads' columns and the couplings (or None) that the C calls take, the arrays held until the next call; and the
        evaluation's residual and reactions (n_total + 1,)."""
        assembler, model = self.owner.assembler, self.owner.model
        native = assembler.native(True)
        residual, _ = native.evaluate(state, True, 1.0, inertia, inertia)
        body = None
        if inertia and len(model.body_nodes):
            body = np.ascontiguousarray(assembler.joint_body_inertia_stiffness(state, 1.0), float)
        rates = np.ascontiguousarray(self.rates(float(state.t)) if rates is None else rates, float)
        mask = self.mask() if mask is None else np.ascontiguousarray(mask, np.int64)
        self._held = arrays = (mask, rates, body, self.load_columns(), self.couplings())
        return native, tuple(None if a is None else a.ctypes.data for a in arrays), residual

    def blocks_times(self, state, mask: np.ndarray, moves: np.ndarray, gravity_tangent: bool) -> np.ndarray:
        """K[:, mask] δq + C[:, mask] δv (n_total + 1,) at ``state``, ``moves`` (3, n_total + 1) the columns' δq, δv
        (δa unread), every block csrc/prescribed_rates.c ``latdyn_prescribed_time_rate`` takes (elements, joint
        bodies' weight, hinges, loads, cables, couplings): products of the static ∂r_all/∂t's own blocks along other
        columns (latdyn/analyses/parameter_stiffness.py ``linked_prescribed_along``). K the static residual's tangent
        with ``gravity_tangent`` (the elements' −∂Q/∂q in it, csrc/evaluate.c), else the impulse weight's, of the
        evaluation with the inertia forces (its tangent without the elements' gravity tangent, which that
        evaluation holds in the inertia tangent: W's K)."""
        native, pointers, _ = self._evaluated(state, not gravity_tangent, moves, mask)
        out = np.empty(self.owner.model.n_total + 1)
        native.library.latdyn_prescribed_time_rate(native.model_ref, native.work_ref, pointers[0], pointers[1], 0,
                                                   *pointers[2:], out.ctypes.data)
        return out

    def linked(self, state, inertia: bool = True, rates: np.ndarray | None = None) -> tuple:
        """(∂r_all/∂t (n_total + 1,), every coordinate's row before the reduction; ∂r_min/∂t (n,)) through the
        prescribed motions of a model with rigid links or guides at ``state``: the dependent nodes that hang from a
        prescribed coordinate move with it (module docstring; csrc/linked_prescribed_rates.c
        ``latdyn_linked_prescribed_time_rate``, which the loop of steps calls too)."""
        total, out, _, _ = self.linked_moves(state, inertia, rates)
        return total, out

    def linked_moves(self, state, inertia: bool = True, rates: np.ndarray | None = None,
                     along: np.ndarray | None = None) -> tuple:
        """:meth:`linked`'s (∂r_all/∂t, ∂r_min/∂t), the move in time of every coordinate it took, (3, n_total + 1):
        δq, δv, δa on the prescribed coordinates (their laws' rates) and the dependent ones (J_·p q̇_p, …), 0
        elsewhere, and, of the same evaluation, (K[:, on] along (n_total + 1,), on where ``along`` is not 0, the
        residual and reactions r_all (n_total + 1,)) with ``along`` (without ``inertia`` the static K, the elements'
        gravity tangent in it: :meth:`blocks_times`), else None."""
        from latdyn.assembly.linked import linked_pattern

        assembler, model = self.owner.assembler, self.owner.model
        linked_pattern(assembler, assembler.native(True))   # its links laid out for the numbering now (evaluate_linked)
        assembler.complete_links(state)
        native, pointers, residual = self._evaluated(state, inertia, rates)
        size = model.n_total + 1
        scratch_mask, moved = np.empty(size, np.int64), np.empty(3 * size)
        total, out = np.empty(size), np.empty(size)
        native.library.latdyn_linked_prescribed_time_rate(
            native.model_ref, native.work_ref, ctypes.byref(native.configuration(state)), pointers[0], pointers[1],
            int(bool(inertia)), *pointers[2:], scratch_mask.ctypes.data, moved.ctypes.data, total.ctypes.data,
            out.ctypes.data)
        moves = moved.reshape(3, size).copy()
        moves[:, scratch_mask == 0] = 0.0
        if along is None:
            return total, out[:model.n_dofs].copy(), moves, None
        on = np.ascontiguousarray(along != 0.0, np.int64)
        columns = np.ascontiguousarray(np.stack([along, np.zeros(size), np.zeros(size)]))
        by_along = np.empty(size)
        native.library.latdyn_prescribed_time_rate(native.model_ref, native.work_ref, on.ctypes.data,
                                                   columns.ctypes.data, int(bool(inertia)), *pointers[2:],
                                                   by_along.ctypes.data)
        return total, out[:model.n_dofs].copy(), moves, (by_along, residual)


def linked_columns(assembler, state, coordinates, inertia: bool) -> tuple:
    """(∂r_min/∂q_c (len(coordinates), n_dofs), ∂r_all/∂q_c (len(coordinates), n_total + 1), every coordinate's row
    before the reduction) of a model with rigid links or guides at ``state`` for each coordinate
    c of ``coordinates`` that is no free one (a held joint's angle), at fixed free coordinates, rates and
    accelerations and q̇_c = q̈_c = 0 — the exact reduced K's column of c had it been free (with ``inertia`` the
    inertia tangent and the dependent rates' term: K_min = Pᵀ K_all P + ∂Pᵀ/∂q · r_all + Pᵀ(C_·dep ∂(J v)/∂q +
    M_·dep ∂(J a + c)/∂q), latdyn/assembly/linked.py; without it the static residual's). The prescribed motions'
    path at the unit rate on c (module docstring, csrc/linked_prescribed_rates.c): the dependent nodes that hang from
    c move by J_·c, their rates by ∂(J v)/∂q_c and accelerations by ∂(J a + c)/∂q_c, the blocks take those moves as
    c's own, and r_min = Pᵀ r_all adds the geometric term ∂Pᵀ/∂q_c · r_all. One native evaluation with the blocks,
    then one call per coordinate."""
    from latdyn.assembly.linked import linked_pattern

    model = assembler.model
    native = assembler.native(True)
    linked_pattern(assembler, native)   # its links laid out for the numbering now (evaluate_linked)
    assembler.complete_links(state)
    native.evaluate(state, True, 1.0, inertia, inertia)
    body = None
    if inertia and len(model.body_nodes):
        body = np.ascontiguousarray(assembler.joint_body_inertia_stiffness(state, 1.0), float)
    size = model.n_total + 1
    loads, couplings = load_block_columns(assembler), coupling_entries(assembler)
    scratch_mask, moved, total, column = np.empty(size, np.int64), np.empty(3 * size), np.empty(size), np.empty(size)
    out, assembled = np.zeros((len(coordinates), model.n_dofs)), np.zeros((len(coordinates), size))
    for i, c in enumerate(coordinates):
        mask, unit = np.zeros(size, np.int64), np.zeros(3 * size)
        mask[c], unit[c] = 1, 1.0
        native.library.latdyn_linked_prescribed_time_rate(
            native.model_ref, native.work_ref, ctypes.byref(native.configuration(state)), mask.ctypes.data,
            unit.ctypes.data, int(bool(inertia)), None if body is None else body.ctypes.data, loads.ctypes.data,
            None if couplings is None else couplings.ctypes.data, scratch_mask.ctypes.data, moved.ctypes.data,
            total.ctypes.data, column.ctypes.data)
        out[i], assembled[i] = column[:model.n_dofs], total
    return out, assembled


def load_block_columns(assembler) -> np.ndarray:
    """(n_loads, 6) int64: each load block's columns (Assembler._load_columns), contiguous, as the C that takes an
    evaluation's blocks by row or column reads them (csrc/prescribed_rates.c, csrc/drive_sensitivities.c)."""
    columns = assembler._load_columns()   # noqa: SLF001
    return np.ascontiguousarray(np.asarray(columns, np.int64).reshape(-1, 6) if len(columns) else
                                np.zeros((1, 6), np.int64))


def coupling_entries(assembler) -> np.ndarray | None:
    """(2 n_couplings,) int64: the continuous controllers' coupling rows, then their columns (the numbering now), or
    None without them (csrc/prescribed_rates.c, csrc/drive_sensitivities.c)."""
    control = assembler.control
    rows = np.asarray(getattr(control, "coupling_rows", np.zeros(0)), np.int64)
    if not len(rows):
        return None
    return np.ascontiguousarray(np.concatenate([rows, np.asarray(control.coupling_cols, np.int64)]))
