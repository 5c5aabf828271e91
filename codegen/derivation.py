"""Derivation: the element's kernels as SymPy expressions (stage 2 of the pipeline).

From :mod:`codegen.formulation` (definitions) to :class:`codegen.ir.KernelSpec`
(expressions per output), by differentiation only:

* B-matrices (Eqs. 33, 39, 42) are first derivatives of Ψ under a virtual
  change δq^e = [δd1, δπ1, δθ1, δd2, δπ2, δθ2] applied as
  T_e ← exp(skew δπ) exp(δθ skew h) T_e, x ← x + δd.
* The tangent ∂F_i/∂q is the mixed derivative of U(Ψ) under a Newton
  increment Δq applied *before* the virtual change (the configuration update
  is T ← exp(skew Δπ) T): exact, and not symmetric away from equilibrium.
* Velocities and the quadratic-velocity terms come from the motion
  x(t) = x + t v, T_j(t) = exp(t skew ω) T_j, θ(t) = θ + t θ̇ (constant
  spatial velocities: q̈ = 0), differentiated twice in t at t = 0.

All geometry is differentiated in SymEngine; results cross to SymPy once.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import symengine as se
import sympy as sp

from . import conventions as cv
from . import formulation as fm
from .ir import KernelSpec, Output, Tangent

VARIANTS: dict[str, str] = {name: f.description for name, f in fm.FORMULATIONS.items()}

N = cv.N_ELEMENT_COORDINATES


def _end_coordinates(symbols):
    """Split 14 symbols into per-end (Δd, Δπ, Δθ)."""
    return (
        (fm.vector(symbols[0:3]), fm.vector(symbols[3:6]), symbols[6]),
        (fm.vector(symbols[7:10]), fm.vector(symbols[10:13]), symbols[13]),
    )


@dataclass
class Kinematics:
    """Everything the kernels need about the element's motion, in SymPy."""

    psi: list  # Ψ, Eq. 46
    frame: list  # T_c row-major, Eqs. 18–21
    grid1: list  # x_g1
    B: list  # ∂Ψ/∂q^e, 6×14 (Eqs. 33, 39, 42)
    #: Σ_k w_k ∂²Ψ_k/∂(virtual)∂(increment), 14×14, in the weights :data:`PSI_WEIGHTS` and the
    #: intermediates :attr:`geometric_definitions` (which use the weights too)
    geometric: list
    geometric_definitions: list
    #: intermediates of Ψ̈ and its q̇-derivative (they use the velocities): for kernels with a velocity block
    rate_definitions: list
    omega_map: list  # C: ω_c = C q̇, 3×14 (spatial angular velocity of S_c)
    psi_ddot: list  # Ψ̈ at q̈ = 0 (6), quadratic in q̇
    omega_dot: list  # ω̇_c at q̈ = 0 (3), spatial
    frame_dot: list  # Ṫ_c row-major (9), linear in q̇
    grid1_dot: list  # ẋ_g1 (3)
    grid1_ddot: list  # ẍ_g1 at q̈ = 0 (3): the χ^e term of Eq. 61
    velocity: list  # the q̇ symbols (SymPy)
    convective: list  # J̇q̇ at q̈ = 0 (12): d/dt of [v̂, ω̂, Ψ̇]
    convective_D_qdot: list  # ∂(J̇q̇)/∂q̇, 12×14
    #: named scalars the expressions above use, defined first in every kernel:
    #: for the "log" measure x_i = 1 − cos θ_i and f, f′, f″ of θ/sin θ at x_i (LOG_JET)
    auxiliary: list = field(default_factory=list)


#: f⁽ᵏ⁾(x_i), k = 0, 1, 2, of f = θ/sin θ at end i: symbols of the log-map jet
LOG_JET = [[se.Symbol(f"logmap_f{k}_{i}") for k in range(3)] for i in (1, 2)]
LOG_ARGUMENT = [se.Symbol(f"logmap_x_{i}") for i in (1, 2)]


#: w_k, the weights of Σ_k w_k ∂²Ψ_k/∂(virtual)∂(increment) (:attr:`Kinematics.geometric`): the kernels put ∂U/∂Ψ_k
PSI_WEIGHTS = [se.Symbol(f"psi_weight_{k}") for k in range(6)]


def _named(definitions: list, name: str, value):
    """``value`` as a new named intermediate appended to ``definitions`` (numbers stay numbers)."""
    if value.is_Number or value.is_Symbol:
        return value
    symbol = se.Symbol(name)
    definitions.append((symbol, value))
    return symbol


def _jet_scale(jet, xbar):
    """f(x) as its second-order jet about x̄: exact value, first and second derivatives at x = x̄."""
    def scale(x):
        d = x - xbar
        return jet[0] + jet[1] * d + jet[2] * d * d / 2
    return scale


def _corotational_frame(end1, end2, L0, planar, frame_choice):
    """T_c (row-major) of the ends at rest, Eqs. 18–21."""
    cor = fm.corotational(end1.x + end1.offset, end1.frame, end2.x + end2.offset, end2.frame, L0, "sine",
                          None, planar, frame_choice)
    return [cor.frame[i, j] for i in range(3) for j in range(3)]


def _diff(expr, symbol):
    """∂expr/∂symbol, zero for a coordinate the variant does not have (symbol 0)."""
    return se.Integer(0) if symbol == 0 else se.diff(expr, symbol)


def _planar_ends(end1, end2, plane: fm.Plane | None):
    """The ends' inputs in a configuration of ``plane`` (unchanged for the 3D element)."""
    if plane is None:
        return end1, end2
    values = plane.geometry_values([se.Symbol(str(s)) for s in cv.GEOMETRY.symbols()])
    values = {key: se.sympify(value) for key, value in values.items()}
    return tuple(fm.EndInputs(x=end.x.subs(values), offset=end.offset.subs(values),
                              frame=end.frame.subs(values), axis=end.axis.subs(values)) for end in (end1, end2))


def _coordinates(name: str, plane: fm.Plane | None) -> list:
    """The 14 symbols of a change of q^e, with 0 where the variant has no coordinate."""
    out = set(plane.out_of_plane_coordinates()) if plane is not None else set()
    return [se.Integer(0) if k in out else se.Symbol(f"{name}_{k}") for k in range(N)]


@lru_cache(maxsize=None)
def derive_kinematics(measure: str = "sine", plane: str | None = None, frame_choice: str = "first_node") -> Kinematics:
    restriction = fm.PLANES[plane] if plane is not None else None
    end1, end2 = _planar_ends(*fm.geometry_inputs(), restriction)
    section = fm.section_inputs()
    L0 = section["L0"]
    planar = restriction is not None
    log = measure == "log" and not planar  # the planar log measure is closed-form (formulation.corotational)

    # ---- B = ∂Ψ/∂q and the weighted second derivative Σ_k w_k ∂²Ψ_k/∂(virtual)∂(increment), by the chain
    # rule through the sixteen invariants ι (formulation.invariants): Ψ = F(ι), ι = ι(q) ----
    virtual = _coordinates("delta", restriction)
    increment = _coordinates("Delta", restriction)
    v1, v2 = _end_coordinates(virtual)
    i1, i2 = _end_coordinates(increment)
    g1, F1 = fm.moved_end(end1, [("increment", *i1, 1), ("virtual", *v1, 1)])
    g2, F2 = fm.moved_end(end2, [("increment", *i2, 1), ("virtual", *v2, 1)])
    at_rest = {s: 0 for s in virtual + increment if s != 0}
    moving = fm.invariants(g1, F1, g2, F2)
    iota = [se.Symbol(f"iota_{name}") for name in fm.INVARIANT_NAMES]
    definitions = [(symbol, value.subs(at_rest)) for symbol, value in zip(iota, moving)]
    # S = ∂ι/∂q (16×14): each row the first variation of one dot product of rigidly moving vectors
    dIota = [[_named(definitions, f"diota_{m}_{a}", _diff(value, d).subs(at_rest)) for a, d in enumerate(virtual)]
             for m, value in enumerate(moving)]
    # F(ι): Ψ, its Jacobian J_F = ∂Ψ/∂ι (6×16), and for weights w the gradient λ = J_Fᵀw and the Hessian
    # ∂²(w·F)/∂ι² (16×16).  The log map's θ/sin θ enters as its jet about x̄_i (LOG_JET), x̄_i = x_i(ι).
    xbar = [se.Symbol(f"logmap_xbar_{i}") for i in (1, 2)]
    scales = None
    if log:
        scales = tuple(_jet_scale(LOG_JET[i], xbar[i]) for i in range(2))
    psi_iota, arguments = fm.deformation_from_invariants(iota, L0, measure, scales, planar, frame_choice)
    auxiliary = list(definitions)
    rest_x = {}
    if log:
        for i in range(2):
            rest_x[xbar[i]] = arguments[i]
            auxiliary.append((se.Symbol(str(LOG_ARGUMENT[i])), arguments[i]))
            for k in range(3):
                auxiliary.append((LOG_JET[i][k], fm.log_scale(fm.to_sympy(LOG_ARGUMENT[i]), k)))
    at_x = lambda expr: expr.subs(rest_x)  # noqa: E731  (x − x̄ = 0 once differentiated)
    psi = [at_x(p) for p in psi_iota]
    jacobian_raw = [[se.diff(p, i) for i in iota] for p in psi_iota]
    jacobian = [[_named(auxiliary, f"dpsi_diota_{k}_{m}", at_x(value)) for m, value in enumerate(row)]
                for k, row in enumerate(jacobian_raw)]
    B = [[sum((jacobian[k][m] * dIota[m][a] for m in range(16)), se.Integer(0)) for a in range(N)] for k in range(6)]
    weighted = sum((w * p for w, p in zip(PSI_WEIGHTS, psi_iota)), se.Integer(0))
    weight_names = []
    adjoint = [_named(weight_names, f"adj_iota_{m}", sum((w * jacobian[k][m] for k, w in enumerate(PSI_WEIGHTS)),
                                                           se.Integer(0))) for m in range(16)]
    gradient = [se.diff(weighted, i) for i in iota]
    hessian = [[None] * 16 for _ in range(16)]
    for m in range(16):
        for n in range(m, 16):
            hessian[m][n] = hessian[n][m] = _named(weight_names, f"hess_iota_{m}_{n}", at_x(se.diff(gradient[m], iota[n])))
    # Σ_k w_k ∂²Ψ_k/∂δ∂Δ = Sᵀ [∂²(w·F)/∂ι²] S + Σ_m λ_m ∂²ι_m/∂δ∂Δ (the second term: the moving vectors' own
    # second variations, which carry the order of the configuration update)
    lifted = sum((lam * value for lam, value in zip(adjoint, moving)), se.Integer(0))
    second = [[_diff(_diff(lifted, d), D).subs(at_rest) for D in increment] for d in virtual]
    hS = [[_named(weight_names, f"hess_diota_{m}_{a}",
                  sum((hessian[m][n] * dIota[n][a] for n in range(16)), se.Integer(0))) for a in range(N)]
          for m in range(16)]
    symmetric = [[None] * N for _ in range(N)]  # Sᵀ [∂²(w·F)/∂ι²] S, one triangle
    for a in range(N):
        for c in range(a, N):
            symmetric[a][c] = symmetric[c][a] = _named(
                weight_names, f"hess_q_{a}_{c}", sum((dIota[m][a] * hS[m][c] for m in range(16)), se.Integer(0)))
    geometric = [[symmetric[a][c] + second[a][c] for c in range(N)] for a in range(N)]
    frame = _corotational_frame(end1, end2, L0, planar, frame_choice)
    grid1 = [(end1.x + end1.offset)[k] for k in range(3)]

    # ---- motion at constant spatial velocities (q̈ = 0) ----
    t = se.Symbol("time")
    qdot = fm.velocity_inputs()
    if restriction is not None:
        qdot = [se.Integer(0) if k in restriction.out_of_plane_coordinates() else q for k, q in enumerate(qdot)]
    m1, m2 = _end_coordinates([t * q for q in qdot])
    g1t, F1t = fm.moved_end(end1, [("time", *m1, 2)])
    g2t, F2t = fm.moved_end(end2, [("time", *m2, 2)])
    now = {t: 0}
    cor_t = fm.corotational(g1t, F1t, g2t, F2t, L0, "sine", None, planar, frame_choice)  # for T_c(t) only

    def rate(expr, order):
        for _ in range(order):
            expr = se.diff(expr, t)
        return expr.subs(now)

    # Ψ̈ = J_F ῑ + ι̇ᵀ(∂²F/∂ι²)ι̇ and ∂Ψ̈/∂q̇ = J_F ∂ῑ/∂q̇ + 2 [(∂²F/∂ι²) ι̇]ᵀ S, with ι̇ = S q̇ and ῑ the
    # invariants' second rate under the motion (quadratic in q̇): the chain of B, once more
    rates = []  # named intermediates that use the velocities
    moving_t = fm.invariants(g1t, F1t, g2t, F2t)
    iota_dot = [_named(rates, f"iota_dot_{m}", sum((dIota[m][a] * qdot[a] for a in range(N)), se.Integer(0)))
                for m in range(16)]
    iota_ddot_raw = [rate(value, 2) for value in moving_t]
    iota_ddot = [_named(rates, f"iota_ddot_{m}", value) for m, value in enumerate(iota_ddot_raw)]
    diota_ddot = [[_named(rates, f"diota_ddot_{m}_{a}", _diff(value, q)) for a, q in enumerate(qdot)]
                  for m, value in enumerate(iota_ddot_raw)]
    curvature = [[_named(rates, f"dpsi_diota_rate_{k}_{m}",
                         sum((at_x(se.diff(jacobian_raw[k][m], i)) * iota_dot[n] for n, i in enumerate(iota)),
                             se.Integer(0))) for m in range(16)] for k in range(6)]
    psi_ddot = [sum((jacobian[k][m] * iota_ddot[m] + curvature[k][m] * iota_dot[m] for m in range(16)), se.Integer(0))
                for k in range(6)]
    psi_ddot_D_qdot = [[sum((jacobian[k][m] * diota_ddot[m][a] + 2 * curvature[k][m] * dIota[m][a]
                             for m in range(16)), se.Integer(0)) for a in range(N)] for k in range(6)]
    Tc = cor_t.frame.subs(now)
    Tc_dot = cor_t.frame.diff(t).subs(now)
    Tc_ddot = cor_t.frame.diff(t).diff(t).subs(now)
    omega_c = fm.vee(Tc_dot * Tc.T)
    omega_dot = fm.vee(Tc_ddot * Tc.T + Tc_dot * Tc_dot.T)
    omega_map = [[_diff(omega_c[k], q) for q in qdot] for k in range(3)]
    grid1_dot = [rate(g1t[k], 1) for k in range(3)]
    grid1_ddot = [rate(g1t[k], 2) for k in range(3)]

    # J̇q̇ at q̈ = 0 (Eqs. 52–53, 61):
    #   d v̂/dt = Ṫ_cᵀ ẋ_g1 + T_cᵀ ẍ_g1 (ẍ_g1 = ω1×(ω1×o1): the χ^e term),
    #   d ω̂/dt = T_cᵀ ω̇_c (Ṫ_cᵀω_c = 0),   Ψ̈.
    convective = []
    for i in range(3):
        convective.append(sum((Tc_dot[k, i] * grid1_dot[k] + Tc[k, i] * grid1_ddot[k] for k in range(3)), se.Integer(0)))
    for i in range(3):
        convective.append(sum((Tc[k, i] * omega_dot[k] for k in range(3)), se.Integer(0)))
    convective_D_qdot = [[_diff(c, q) for q in qdot] for c in convective] + psi_ddot_D_qdot
    convective += psi_ddot

    S = fm.to_sympy
    if log:
        # the jets' (x − x̄) must vanish identically once differentiated: B has no f″, Ψ no f′
        for i in range(2):
            assert all(LOG_JET[i][2] not in b.free_symbols for row in B for b in row), "log jet left (x − x̄) in B"
            assert all(LOG_JET[i][1] not in p.free_symbols for p in psi), "log jet left (x − x̄) in Ψ"
    auxiliary = [(S(symbol), S(value)) for symbol, value in auxiliary]
    return Kinematics(
        auxiliary=auxiliary,
        convective=[S(c) for c in convective],
        convective_D_qdot=[[S(c) for c in row] for row in convective_D_qdot],
        psi=[S(p) for p in psi],
        frame=[S(x) for x in frame],
        grid1=[S(x) for x in grid1],
        B=[[S(b) for b in row] for row in B],
        geometric=[[S(g) for g in row] for row in geometric],
        geometric_definitions=[(S(symbol), S(value)) for symbol, value in weight_names],
        rate_definitions=[(S(symbol), S(value)) for symbol, value in rates],
        omega_map=[[S(c) for c in row] for row in omega_map],
        psi_ddot=[S(p) for p in psi_ddot],
        omega_dot=[S(w) for w in omega_dot],
        frame_dot=[S(Tc_dot[i, j]) for i in range(3) for j in range(3)],
        grid1_dot=[S(x) for x in grid1_dot],
        grid1_ddot=[S(x) for x in grid1_ddot],
        velocity=[S(q) for q in qdot],
    )


@dataclass
class Builder:
    """Collects named intermediates so kernels stay structured (and CSE small)."""

    intermediates: list = field(default_factory=list)

    def define(self, name: str, expr) -> sp.Expr:
        expr = sp.sympify(expr)
        if expr.is_number or expr.is_Symbol:
            return expr
        symbol = sp.Symbol(name, real=True)
        self.intermediates.append((symbol, expr))
        return symbol

    def matrix(self, name: str, rows: list[list]) -> list[list]:
        return [[self.define(f"{name}_{i}_{j}", e) for j, e in enumerate(row)] for i, row in enumerate(rows)]

    def vector(self, name: str, items: list) -> list:
        return [self.define(f"{name}_{i}", e) for i, e in enumerate(items)]


def _section_sympy() -> dict[str, sp.Symbol]:
    return dict(zip(cv.SECTION_NAMES, cv.SECTION.symbols()))


def _matmul(A, B):
    return [[sp.Add(*[A[i][k] * B[k][j] for k in range(len(B))]) for j in range(len(B[0]))] for i in range(len(A))]


def _transpose(A):
    return [list(r) for r in zip(*A)]


def _flat(A):
    return [e for row in A for e in row]


def geometry_first_variation(plane: fm.Plane | None = None) -> dict:
    """∂(geometry block)/∂q^e: each of the 36 inputs' first variation under the configuration update.

    The update of one end by (Δd, Δπ, Δθ) is x ← x + Δd, T_j ← exp(skew Δπ) T_j, θ ← θ + Δθ (the
    runtime's q ∘ exp(Δ), latdyn_advance_free); through Eqs. 2, 9 and 17 it moves the block's
    offset o = T_j r_g, nodal frame T_e = T_j exp(θ skew a) E0 and hinge axis h = T_j a as

        δx = Δd,   δo = Δπ × o,   δT_e = skew(Δπ + Δθ h) T_e,   δh = Δπ × h

    (T_j exp((θ + Δθ) skew a) = exp(Δθ skew h) T_j exp(θ skew a)).  Returns {symbol: [14 expressions]}
    for the symbols that stay free in a configuration of ``plane`` (there the out-of-plane
    coordinates are not moved, and the planar values are put in).
    """
    g = cv.GEOMETRY.symbols()
    out = set(plane.out_of_plane_coordinates()) if plane is not None else set()
    delta = [sp.Integer(0) if k in out else sp.Symbol(f"Delta_{k}") for k in range(N)]
    values = plane.geometry_values(g) if plane is not None else {}
    variation = {}
    for end, (X, O, F, H) in enumerate(((cv.X1, cv.OFFSET1, cv.FRAME1, cv.AXIS1),
                                        (cv.X2, cv.OFFSET2, cv.FRAME2, cv.AXIS2))):
        d, pi, theta = delta[7 * end:7 * end + 3], sp.Matrix(delta[7 * end + 3:7 * end + 6]), delta[7 * end + 6]
        o, T, h = sp.Matrix(g[O]), sp.Matrix(3, 3, g[F]), sp.Matrix(g[H])
        spin = pi + theta * h
        W = sp.Matrix([[0, -spin[2], spin[1]], [spin[2], 0, -spin[0]], [-spin[1], spin[0], 0]])
        moved = list(sp.Matrix(d)) + list(pi.cross(o)) + list(W * T) + list(pi.cross(h))
        for symbol, change in zip(g[X] + g[O] + g[F] + g[H], moved):
            if symbol in values:
                continue  # not an input of the planar element (its value is put in)
            change = sp.expand(sp.sympify(change).xreplace(values))
            variation[symbol] = [sp.diff(change, D) if D != 0 else sp.Integer(0) for D in delta]
    return variation


def configuration_tangent(of: str, name: str, plane: fm.Plane | None, doc: str) -> Tangent:
    """The request for ∂(output ``of``)/∂q^e under the configuration update, as the output ``name``
    (forward mode of the lowered kernel, codegen/forward.py): seeded with the first variation of the
    geometry block (:func:`geometry_first_variation`), the log map's jet of θ/sin θ differentiated as
    a jet, ∂f⁽ᵏ⁾ = f⁽ᵏ⁺¹⁾ ∂x (its branch-free definition's |x − x_s| has none at the switch)."""
    seeds = {str(symbol): column for symbol, column in geometry_first_variation(plane).items()}
    # directions 0-2 seed the rigid translation of both ends (d1 = d2), under which the element's forces are
    # invariant: their tangents cancel line by line and are pruned, and ∂/∂d1 = (rigid) − ∂/∂d2
    d1, d2 = range(cv.D1.start, cv.D1.stop), range(cv.D2.start, cv.D2.stop)
    for column in seeds.values():
        for a, b in zip(d1, d2):
            column[a] = column[a] + column[b]
    columns = [{a: 1, b: -1} if a in d1 else {a: 1} for a, b in zip(range(N), [*d2, *range(3, N)])]
    partials, definitions = _log_jet_rules()
    return Tangent(of=of, name=name, seeds=seeds, directions=N, doc=doc, partials=partials, definitions=definitions,
                   columns=columns)


def _log_jet_rules() -> tuple[dict, dict]:
    """(partials, definitions) of a tangent through the log map's jet of θ/sin θ, differentiated as a jet,
    ∂f⁽ᵏ⁾ = f⁽ᵏ⁺¹⁾ ∂x (its branch-free definition's |x − x_s| has none at the switch): the same for every
    tangent of every variant, derived once a process (:func:`_log_jet_rules_derived`) and handed out as fresh
    dictionaries. Each tangent deriving them again was most of ``build_kernels``' time: CPU of default_xy, default,
    cr4402_xy in one process 17.0, 12.6, 18.1 s before, 9.1, 3.7, 8.1 s after (load 9, a core to itself); the specs
    are the same (``sp.srepr`` of every field of default_xy's and cr4402's)."""
    partials, definitions = _log_jet_rules_derived()
    return {name: dict(rule) for name, rule in partials.items()}, dict(definitions)


@lru_cache(maxsize=None)
def _log_jet_rules_derived() -> tuple[dict, dict]:
    """:func:`_log_jet_rules`, derived (``fm.log_scale`` of each order: SymPy's own cache misses them, each call
    differentiating about a fresh ``Dummy``)."""
    partials, definitions = {}, {}
    for i, (row, argument) in enumerate(zip(LOG_JET, LOG_ARGUMENT)):
        x = fm.to_sympy(argument)
        orders = [str(f) for f in row] + [f"logmap_f{len(row)}_{i + 1}"]
        for k in range(len(row)):
            partials[orders[k]] = {str(argument): sp.Symbol(orders[k + 1], real=True)}
        for k in range(1, len(orders)):
            definitions[orders[k]] = fm.log_scale(x, k)
    return partials, definitions


def reference_first_variation(plane: fm.Plane | None = None) -> dict:
    """The geometry block's and the undeformed length's first variation along one variation of the
    element's reference data (the block ``reference``, codegen/conventions.py), at a fixed configuration.

    A geometry parameter (docs/parameters.md, "Geometry parameters") moves the reference configuration:
    the reference point of an end whose node is no coordinate (fixed, prescribed) by δx, the grid-point
    offset r_g in node axes (so o = T_j r_g by δo = T_j δr_g), the nodal frame at θ = 0 in node axes
    E0 ← exp(skew φ) E0 (so T_e = T_j exp(θ skew a) E0 turns by exp(skew ψ), ψ = T_j exp(θ skew a) φ,
    spatial), and the undeformed length L0; the hinge axis h = T_j a does not move. Hence

        δx = δx_i,   δo = δo_i,   δT_e = skew(ψ_i) T_e,   δh = δh_i,   δL0 = δL0,

    a hinge axis a in node axes moved by δa giving δh = T_j δa (and its frame's turn through exp(θ skew a),
    which the caller adds to ψ_i). Returns {symbol name: [expression]} (one direction) for the inputs that stay
    free in a configuration of ``plane`` (there the reference variation's out-of-plane parts are zero: δx_n,
    δo_n, ψ_i, ψ_j, and the axes, ±n, do not move)."""
    g = cv.GEOMETRY.symbols()
    r = cv.REFERENCE.symbols()
    zero = set()
    if plane is not None:
        i, j = plane.in_plane
        zero = {cv.REF_X1.start + plane.normal, cv.REF_X2.start + plane.normal,
                cv.REF_OFFSET1.start + plane.normal, cv.REF_OFFSET2.start + plane.normal,
                cv.REF_PSI1.start + i, cv.REF_PSI1.start + j, cv.REF_PSI2.start + i, cv.REF_PSI2.start + j,
                *range(cv.REF_AXIS1.start, cv.REF_AXIS2.stop)}
    r = [sp.Integer(0) if k in zero else symbol for k, symbol in enumerate(r)]
    values = plane.geometry_values(g) if plane is not None else {}
    seeds = {}
    for X, O, F, H, RX, RO, RP, RH in (
            (cv.X1, cv.OFFSET1, cv.FRAME1, cv.AXIS1, cv.REF_X1, cv.REF_OFFSET1, cv.REF_PSI1, cv.REF_AXIS1),
            (cv.X2, cv.OFFSET2, cv.FRAME2, cv.AXIS2, cv.REF_X2, cv.REF_OFFSET2, cv.REF_PSI2, cv.REF_AXIS2)):
        psi = r[RP]
        W = sp.Matrix([[0, -psi[2], psi[1]], [psi[2], 0, -psi[0]], [-psi[1], psi[0], 0]])
        T = sp.Matrix(3, 3, g[F])
        moved = list(r[RX]) + list(r[RO]) + list(W * T) + list(r[RH])
        for symbol, change in zip(g[X] + g[O] + g[F] + g[H], moved):
            if symbol in values:
                continue  # not an input of the planar element (its value is put in)
            change = sp.expand(sp.sympify(change).xreplace(values))
            if change != 0:
                seeds[str(symbol)] = [change]
    seeds[str(cv.SECTION.symbols()[0])] = [r[cv.REF_L0]]
    return seeds


def reference_tangent(of: str, name: str, plane: fm.Plane | None, doc: str) -> Tangent:
    """The request for the derivative of output ``of`` along one variation of the reference data
    (:func:`reference_first_variation`), as the output ``name`` of shape (size of ``of``, 1): forward mode of
    the lowered kernel (codegen/forward.py), with the log map's jet rules (:func:`_log_jet_rules`)."""
    partials, definitions = _log_jet_rules()
    return Tangent(of=of, name=name, seeds=reference_first_variation(plane), directions=1, doc=doc,
                   partials=partials, definitions=definitions)


#: the section values a section tangent moves (codegen/conventions.py SECTION_NAMES without L0, a
#: reference datum: :func:`reference_first_variation`), its directions in this order
SECTION_VALUES = cv.SECTION_NAMES[1:]


def section_tangent(of: str, name: str, doc: str) -> Tangent:
    """The request for the derivative of output ``of`` by each section value of :data:`SECTION_VALUES` (EA,
    EIy, EIz, GJ, ρA, ρIy, ρIz and the shear compliances 1/GAy, 1/GAz) at a fixed configuration, as the
    output ``name`` of shape (size of ``of``, 9): forward mode of the lowered kernel (codegen/forward.py)
    seeded with the unit vectors of the section values. Exact whether or not the output is linear in them
    (a shear-flexible section's factors μ = 1/(1 + 12 EI/(GA L²)) are not; nor need a formulation's
    stiffening be); a value the output does not read gives a zero column, pruned in the program."""
    values = SECTION_VALUES
    seeds = {str(symbol): [sp.Integer(int(d == k)) for d in range(len(values))]
             for k, symbol in enumerate(cv.SECTION.symbols()[1:])}
    partials, definitions = _log_jet_rules()
    return Tangent(of=of, name=name, seeds=seeds, directions=len(values), doc=doc, partials=partials,
                   definitions=definitions)


def _section_value_kernels(add, elastic, inertia_force, section_forces, kin, shear_definitions) -> None:
    """The element's internal force, inertia force M a + g − Q and mid-element section forces with their
    derivatives by the section values (:func:`section_tangent`): ∂r/∂p of a parameter in a section value,
    and a section-force probe's, for every formulation and for shear-flexible sections
    (latdyn/analyses/sensitivities.py ``ParameterDerivatives._section_element_forces``)."""
    b = Builder(kin.auxiliary + shear_definitions)
    _, force, _ = elastic(b, with_tangent=False)
    add("beam_internal_force_D_section", "Internal force F_i^e = Bᵀ ∂U/∂Ψ and its derivative by the section "
        "values EA … 1/GAz (forward mode of the lowered force, codegen/forward.py)", "Eqs. 29-43",
        [cv.GEOMETRY, cv.SECTION], [Output("internal_force", (N,), force)], b,
        tangent=section_tangent("internal_force", "internal_force_D_section",
                                "∂F_i/∂(EA EIy EIz GJ rhoA rhoIy rhoIz cGAy cGAz), row-major (14, 9)"))
    b = Builder(kin.auxiliary + shear_definitions)
    psi = b.vector("psi", kin.psi)
    add("beam_section_forces_D_section", "Mid-element section forces [N, T, M_y, M_z] and their derivative by "
        "the section values EA … 1/GAz (forward mode of the lowered forces, codegen/forward.py)", "Eqs. 22-41",
        [cv.GEOMETRY, cv.SECTION], [Output("section_forces", (4,), section_forces(psi))], b,
        tangent=section_tangent("section_forces", "section_forces_D_section",
                                "∂S/∂(EA EIy EIz GJ rhoA rhoIy rhoIz cGAy cGAz), row-major (4, 9)"))
    b = Builder(kin.auxiliary + shear_definitions)
    force = inertia_force(b)
    add("beam_inertia_force_D_section", "Inertia force M a + g − Q of gravity and its derivative by the section "
        "values EA … 1/GAz at fixed rates and accelerations (forward mode of the lowered force, codegen/forward.py)",
        "Eqs. 50-58, 61-62", [cv.GEOMETRY, cv.VELOCITY, cv.ACCELERATION, cv.SECTION, cv.GRAVITY],
        [Output("inertia_force", (N,), force)], b,
        tangent=section_tangent("inertia_force", "inertia_force_D_section",
                                "∂(M a + g − Q)/∂(EA EIy EIz GJ rhoA rhoIy rhoIz cGAy cGAz), row-major (14, 9)"))


def build_kernels(variant: str = "default") -> list[KernelSpec]:
    """All kernels of one variant (see :data:`VARIANTS`).

    ``beam_inertia_tangent`` and ``beam_gravity_D_q`` carry a tangent (``KernelSpec.tangent``): their
    derivative output is the forward-mode derivative of the lowered kernel, added by codegen/emit.py
    ``lower`` (codegen/forward.py), not an expression of the spec.
    """
    if variant not in fm.FORMULATIONS:
        raise ValueError(f"unknown variant {variant!r} (known: {', '.join(fm.FORMULATIONS)})")
    formulation = fm.FORMULATIONS[variant]
    kin = derive_kinematics(formulation.rotation_measure, formulation.plane, formulation.corotational_frame)
    plane = fm.PLANES[formulation.plane] if formulation.plane is not None else None
    section = _section_sympy()
    gravity = cv.GRAVITY.symbols()
    # a planar variant: inputs of a planar configuration (geometry, gravity), no out-of-plane coordinates
    planar_values = {}
    out_of_plane = set()
    if plane is not None:
        planar_values = {**plane.geometry_values(cv.GEOMETRY.symbols()), **plane.gravity_values(gravity)}
        out_of_plane = set(plane.out_of_plane_coordinates())
        gravity = [sp.sympify(g).xreplace(planar_values) for g in gravity]
    psi_symbols = fm.PSI
    # μ_z, μ_y = 1/(1 + Φ) of the two bending planes: named once per kernel, unused ones are dropped
    shear = fm.SHEAR_FACTORS
    shear_definitions = list(zip(shear, fm.shear_factor_definitions(section)))
    U = fm.strain_energy(psi_symbols, section, formulation, shear)
    dU = [sp.diff(U, p) for p in psi_symbols]
    ddU = [[sp.diff(d, p) for p in psi_symbols] for d in dU]

    def elastic(b: Builder, with_tangent: bool, shared=None):
        if shared is None:
            psi = b.vector("psi", kin.psi)
            Bm = b.matrix("B", kin.B)
        else:
            psi, Bm = shared["psi"], shared["B"]
        rename = dict(zip(psi_symbols, psi))
        force_psi = b.vector("dU_dpsi", [d.xreplace(rename) for d in dU])
        # Eq. 43: F_i = Bᵀ ∂U/∂Ψ (Eqs. 32, 37, 41 summed)
        force = [sp.Add(*[Bm[k][a] * force_psi[k] for k in range(6)]) for a in range(N)]
        if not with_tangent:
            return psi, force, None
        stiff_psi = b.matrix("d2U_dpsi2", [[e.xreplace(rename) for e in row] for row in ddU])
        KB = b.matrix("KB", _matmul(stiff_psi, Bm))
        material = [[None] * N for _ in range(N)]  # Bᵀ (∂²U/∂Ψ²) B, symmetric: one triangle
        for a in range(N):
            for c in range(a, N):
                material[a][c] = material[c][a] = b.define(
                    f"material_{a}_{c}", sp.Add(*[Bm[k][a] * KB[k][c] for k in range(6)]))
        # the geometric part Σ_k (∂U/∂Ψ_k) ∂²Ψ_k/∂q∂q, through the invariants (derive_kinematics)
        weights = dict(zip(map(fm.to_sympy, PSI_WEIGHTS), force_psi))
        for symbol, value in kin.geometric_definitions:
            b.intermediates.append((symbol, value.xreplace(weights)))
        tangent = [[material[a][c] + kin.geometric[a][c].xreplace(weights) for c in range(N)] for a in range(N)]
        return psi, force, tangent

    def inertia(b: Builder, with_velocity: bool):
        """J, M̂(Ψ) and friends; see formulation.local_inertia."""
        psi = b.vector("psi", kin.psi)
        Tc = b.vector("Tc", kin.frame)
        TcT = [[Tc[3 * j + i] for j in range(3)] for i in range(3)]  # T_cᵀ
        offset1 = [sp.sympify(o).xreplace(planar_values) for o in cv.GEOMETRY.symbols()[cv.OFFSET1]]
        # ẋ_g1 = v1 + ω1 × o1 = [I, −skew(o1)] (v1, ω1): Eqs. 2, 59
        o = offset1
        grid_map = [
            [1, 0, 0, 0, o[2], -o[1]] + [0] * 8,
            [0, 1, 0, -o[2], 0, o[0]] + [0] * 8,
            [0, 0, 1, o[1], -o[0], 0] + [0] * 8,
        ]
        grid_map = [[0 if a in out_of_plane else entry for a, entry in enumerate(row)] for row in grid_map]
        Bm = b.matrix("B", kin.B)
        C = b.matrix("C", kin.omega_map)
        J = b.matrix("J", _matmul(TcT, grid_map) + _matmul(TcT, C) + Bm)  # u = J q̇, 12×14
        u_symbols = fm.QUASI_VELOCITY
        mass_local, gyro_local, gyro_local_D_u, first_moment, position_moment = fm.local_inertia(formulation)
        rename = dict(zip(psi_symbols, psi))
        Mhat = b.matrix("Mhat", [[mass_local[i, j].xreplace(rename) for j in range(12)] for i in range(12)])
        parts = dict(psi=psi, B=Bm, Tc=Tc, TcT=TcT, J=J, Mhat=Mhat, first_moment=first_moment,
                     position_moment=position_moment, rename=rename)
        if not with_velocity:
            return parts
        qdot = kin.velocity
        b.intermediates.extend(kin.rate_definitions)
        u = b.vector("u", [sp.Add(*[J[i][a] * qdot[a] for a in range(N)]) for i in range(12)])
        Jdq = b.vector("Jdq", kin.convective)
        urename = dict(zip(u_symbols, u))
        ghat = b.vector("ghat", [gyro_local[i].xreplace({**rename, **urename}) for i in range(12)])
        parts.update(u=u, Jdq=Jdq, ghat=ghat, gyro_local_D_u=gyro_local_D_u,
                     urename=urename)
        return parts

    geometry_section = [cv.GEOMETRY, cv.SECTION]
    with_velocity = [cv.GEOMETRY, cv.VELOCITY, cv.SECTION]
    with_gravity = [cv.GEOMETRY, cv.SECTION, cv.GRAVITY]
    kernels: list[KernelSpec] = []

    def add(name, doc, equations, inputs, outputs, builder, tangent=None):
        if planar_values:  # inputs used directly (not through the kinematics) take their planar values too
            builder.intermediates = [(s, e.xreplace(planar_values)) for s, e in builder.intermediates]
            outputs = [Output(o.name, o.shape, [sp.sympify(e).xreplace(planar_values) for e in o.expressions], o.doc)
                       for o in outputs]
        kernels.append(
            KernelSpec(name=name, doc=doc, inputs=list(inputs), outputs=outputs, variant=variant,
                       equations=equations, intermediates=builder.intermediates, tangent=tangent)
        )

    # --- deformation ---
    b = Builder(kin.auxiliary + shear_definitions)
    add("beam_deformation", "Deformation vector Ψ = [φy1, φz1, φy2, φz2, φx2, αx2] and corotational frame T_c",
        "Eqs. 12-21, 46", geometry_section,
        [Output("psi", (6,), list(kin.psi)), Output("corotational_frame", (3, 3), list(kin.frame))], b)

    # --- strain energy and section forces ---
    b = Builder(kin.auxiliary + shear_definitions)
    psi = b.vector("psi", kin.psi)
    rename = dict(zip(psi_symbols, psi))
    add("beam_strain_energy", "Strain energy U and mid-element section forces [N, T, M_y, M_z]",
        "Eqs. 22-41", geometry_section,
        [Output("strain_energy", (), [U.xreplace(rename)]),
         Output("section_forces", (4,), [f.xreplace(rename) for f in fm.section_forces(psi_symbols, section, formulation, shear)])], b)

    # the section forces' exact derivative by the element's coordinates, ∂S/∂q = (∂S/∂Ψ) B (B = ∂Ψ/∂q, the
    # matrix of Eq. 43's F_i = Bᵀ ∂U/∂Ψ): a continuous controller's sensor (csrc/evaluate.c sensor_value)
    b = Builder(kin.auxiliary + shear_definitions)
    psi = b.vector("psi", kin.psi)
    Bm = b.matrix("B", kin.B)
    rename = dict(zip(psi_symbols, psi))
    sections = fm.section_forces(psi_symbols, section, formulation, shear)
    by_psi = b.matrix("dS_dpsi", [[sp.diff(f, p).xreplace(rename) for p in psi_symbols] for f in sections])
    add("beam_section_forces_D_q", "Mid-element section forces [N, T, M_y, M_z] and their exact derivative "
        "∂S/∂q = (∂S/∂Ψ) B by the element's coordinates", "Eqs. 22-43", geometry_section,
        [Output("section_forces", (4,), [f.xreplace(rename) for f in sections]),
         Output("section_forces_D_q", (4, N), _flat(_matmul(by_psi, Bm)))], b)

    # --- internal force ---
    b = Builder(kin.auxiliary + shear_definitions)
    _, force, _ = elastic(b, with_tangent=False)
    add("beam_internal_force", "Generalized internal force F_i^e = Bᵀ ∂U/∂Ψ", "Eqs. 29-43",
        geometry_section, [Output("internal_force", (N,), force)], b)

    b = Builder(kin.auxiliary + shear_definitions)
    _, force, tangent = elastic(b, with_tangent=True)
    add("beam_internal_force_D_q", "Internal force and its exact tangent ∂F_i/∂q (material + geometric)",
        "Eqs. 29-43", geometry_section,
        [Output("internal_force", (N,), force), Output("internal_force_D_q", (N, N), _flat(tangent))], b)

    # --- inertia ---
    def mass_matrix(b, p):
        MJ = b.matrix("MJ", _matmul(p["Mhat"], p["J"]))
        return _matmul(_transpose(p["J"]), MJ)  # Eq. 56: M = ρ∫BᵀB = Jᵀ M̂ J

    def quadratic_velocity(b, p):
        local = b.vector("glocal", [sp.Add(*[p["Mhat"][i][j] * p["Jdq"][j] for j in range(12)]) + p["ghat"][i]
                                    for i in range(12)])
        return [sp.Add(*[p["J"][i][a] * local[i] for i in range(12)]) for a in range(N)]  # Eq. 57 (+ Mχ, Eq. 62)

    def quadratic_velocity_D_qdot(b, p):
        # ∂g/∂q̇ = Jᵀ (M̂ ∂(J̇q̇)/∂q̇ + ∂ĝ/∂u J)
        dJdq = b.matrix("dJdq", kin.convective_D_qdot)
        both = {**p["rename"], **p["urename"]}
        dghat = b.matrix("dghat", [[p["gyro_local_D_u"][i, j].xreplace(both) for j in range(12)] for i in range(12)])
        inner = b.matrix("dglocal", [[a + c for a, c in zip(r1, r2)]
                                     for r1, r2 in zip(_matmul(p["Mhat"], dJdq), _matmul(dghat, p["J"]))])
        return _matmul(_transpose(p["J"]), inner)

    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=False)
    add("beam_mass_matrix", "Element mass matrix M^e", "Eqs. 44-56, 62", geometry_section,
        [Output("mass_matrix", (N, N), _flat(mass_matrix(b, p)))], b)

    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=True)
    add("beam_quadratic_velocity", "Quadratic-velocity vector g^e (centrifugal, Coriolis, offset χ^e)",
        "Eqs. 50-57, 61-62", with_velocity, [Output("quadratic_velocity", (N,), quadratic_velocity(b, p))], b)

    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=True)
    # g^e is a quadratic form in q̇ (J̇q̇ at q̈ = 0 and ĝ are quadratic, u = Jq̇ linear), so by Euler's theorem
    # g^e = ½ (∂g^e/∂q̇) q̇: a Newton iteration that needs the derivative gets the vector for 14² products
    derivative = b.matrix("dg_dqdot", quadratic_velocity_D_qdot(b, p))
    from_derivative = [sp.Add(*[derivative[a][c] * kin.velocity[c] for c in range(N)]) / 2 for a in range(N)]
    add("beam_quadratic_velocity_D_qdot", "Quadratic-velocity vector g^e = ½(∂g^e/∂q̇)q̇ and ∂g^e/∂q̇ (exact)",
        "Eqs. 50-57, 61-62", with_velocity,
        [Output("quadratic_velocity", (N,), from_derivative),
         Output("quadratic_velocity_D_qdot", (N, N), _flat(derivative))], b)

    # the three inertia blocks a Newton iteration needs, M^e, g^e and ∂g^e/∂q̇, in one kernel: the element's
    # kinematics (Ψ, B, T_c, J = ∂u/∂q̇) and M̂(Ψ), which the two kernels above each compute, once
    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=True)
    mass = mass_matrix(b, p)
    derivative = b.matrix("dg_dqdot", quadratic_velocity_D_qdot(b, p))
    from_derivative = [sp.Add(*[derivative[a][c] * kin.velocity[c] for c in range(N)]) / 2 for a in range(N)]
    add("beam_inertia_matrices", "Mass matrix M^e, quadratic-velocity vector g^e = ½(∂g^e/∂q̇)q̇ and ∂g^e/∂q̇ "
        "(exact) in one kernel: beam_mass_matrix and beam_quadratic_velocity_D_qdot sharing the element's "
        "kinematics and M̂", "Eqs. 44-57, 61-62", with_velocity,
        [Output("mass_matrix", (N, N), _flat(mass)), Output("quadratic_velocity", (N,), from_derivative),
         Output("quadratic_velocity_D_qdot", (N, N), _flat(derivative))], b)

    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=True)
    kinetic = sp.Add(*[p["u"][i] * p["Mhat"][i][j] * p["u"][j] for i in range(12) for j in range(12)]) / 2
    add("beam_kinetic_energy", "Kinetic energy ½ q̇ᵀ M q̇", "Eqs. 54-56", with_velocity,
        [Output("kinetic_energy", (), [kinetic])], b)

    # --- gravity ---
    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=False)
    TcT = p["TcT"]
    g_local = b.vector("gc", [sp.Add(*[TcT[i][k] * gravity[k] for k in range(3)]) for i in range(3)])
    S = p["first_moment"]
    Q_local = b.vector("Qc", [sp.Add(*[S[k, i].xreplace(p["rename"]) * g_local[k] for k in range(3)]) for i in range(12)])
    Q = [sp.Add(*[p["J"][i][a] * Q_local[i] for i in range(12)]) for a in range(N)]
    mass_total = section["rhoA"] * section["L0"]
    P = [p["position_moment"][k].xreplace(p["rename"]) for k in range(3)]
    centre = [mass_total * kin.grid1[k] + sp.Add(*[p["Tc"][3 * k + j] * P[j] for j in range(3)]) for k in range(3)]
    potential = -sp.Add(*[gravity[k] * centre[k] for k in range(3)])
    add("beam_gravity", "Generalized load of uniform gravity, its potential, and ρ∫x dV (mass × centre)",
        "Eqs. 47, 50, 58", with_gravity,
        [Output("gravity_force", (N,), Q), Output("gravity_potential", (), [potential]),
         Output("first_moment", (3,), centre)], b)

    # --- the inertia tangent: ∂(M a + g − Q)/∂q under the configuration update q ∘ exp(Δ), at fixed spatial
    # rates and accelerations: the term of Newton's matrix that K leaves out (latdyn/step/integrators.py).
    # r = M a + g − Q = Jᵀ [M̂ (J a + J̇q̇) + ĝ − Sᵀ T_cᵀ g_grav] (Eqs. 56–58, 62) is lowered as any kernel, and its
    # tangent is the forward-mode derivative of that program (codegen/forward.py), seeded with the first
    # variation of the geometry block (geometry_first_variation).
    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=True)
    acceleration = [0 if a in out_of_plane else symbol for a, symbol in enumerate(cv.ACCELERATION.symbols())]
    Ja = b.vector("Ja", [sp.Add(*[p["J"][i][a] * acceleration[a] for a in range(N)]) for i in range(12)])
    TcT = p["TcT"]
    g_local = b.vector("gc", [sp.Add(*[TcT[i][k] * gravity[k] for k in range(3)]) for i in range(3)])
    S = p["first_moment"]
    local = b.vector("inertia_local", [
        sp.Add(*[p["Mhat"][i][j] * (Ja[j] + p["Jdq"][j]) for j in range(12)]) + p["ghat"][i]
        - sp.Add(*[S[k, i].xreplace(p["rename"]) * g_local[k] for k in range(3)]) for i in range(12)])
    force = [sp.Add(*[p["J"][i][a] * local[i] for i in range(12)]) for a in range(N)]
    add("beam_inertia_tangent", "Inertia force M a + g − Q of gravity and its exact tangent ∂(M a + g − Q)/∂q "
        "at fixed spatial rates and accelerations (forward mode of the lowered force, codegen/forward.py)",
        "Eqs. 50-58, 61-62", [cv.GEOMETRY, cv.VELOCITY, cv.ACCELERATION, cv.SECTION, cv.GRAVITY],
        [Output("inertia_force", (N,), force)], b,
        tangent=configuration_tangent("inertia_force", "inertia_tangent", plane,
                                      "∂(M a + g − Q)/∂q, row-major: [r, d] = ∂r_r/∂q_d"))

    # --- the tangent of the gravity load: ∂Q/∂q under the configuration update q ∘ exp(Δ) ---
    # Q = Jᵀ Sᵀ(Ψ) T_cᵀ g (Eqs. 47, 50, 58) lowered as beam_gravity, its tangent the forward-mode derivative of
    # that program (codegen/forward.py) from the first variation of the geometry block (geometry_first_variation):
    # the term the static Newton matrix K − λ ∂Q/∂q needs besides ∂F_i/∂q.
    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=False)
    TcT = p["TcT"]
    g_local = b.vector("gc", [sp.Add(*[TcT[i][k] * gravity[k] for k in range(3)]) for i in range(3)])
    S = p["first_moment"]
    Q_local = b.vector("Qc", [sp.Add(*[S[k, i].xreplace(p["rename"]) * g_local[k] for k in range(3)]) for i in range(12)])
    Q = [sp.Add(*[p["J"][i][a] * Q_local[i] for i in range(12)]) for a in range(N)]
    add("beam_gravity_D_q", "Generalized load of uniform gravity Q and its exact tangent ∂Q/∂q "
        "(forward mode of the lowered load, codegen/forward.py)", "Eqs. 47, 50, 58", with_gravity,
        [Output("gravity_force", (N,), Q)], b,
        tangent=configuration_tangent("gravity_force", "gravity_force_D_q", plane,
                                      "∂Q/∂q, row-major: [r, d] = ∂Q_r/∂q_d"))

    # --- the forces' derivative by the reference configuration (geometry parameters, docs/parameters.md):
    # the internal force F and the inertia force M a + g − Q lowered as above, their derivatives along one
    # variation of the reference data (reference_first_variation: the ends' fixed reference points, the
    # grid-point offsets, the nodal frames' E0, L0) the forward-mode program of the lowered force.
    b = Builder(kin.auxiliary + shear_definitions)
    _, force, _ = elastic(b, with_tangent=False)
    add("beam_internal_force_D_reference", "Internal force F_i^e = Bᵀ ∂U/∂Ψ and its derivative along a "
        "variation of the reference data (forward mode of the lowered force, codegen/forward.py)", "Eqs. 29-43",
        [cv.GEOMETRY, cv.SECTION, cv.REFERENCE], [Output("internal_force", (N,), force)], b,
        tangent=reference_tangent("internal_force", "internal_force_D_reference", plane,
                                  "∂F_i/∂(reference data) along the variation given, (14, 1)"))

    # the section forces' derivative along the same variation of the reference data: a section-force probe's
    # sensitivity by a geometry parameter (latdyn/analyses/probe_derivatives.py)
    b = Builder(kin.auxiliary + shear_definitions)
    psi = b.vector("psi", kin.psi)
    rename = dict(zip(psi_symbols, psi))
    add("beam_section_forces_D_reference", "Mid-element section forces [N, T, M_y, M_z] and their derivative along "
        "a variation of the reference data (forward mode of the lowered forces, codegen/forward.py)", "Eqs. 22-41",
        [cv.GEOMETRY, cv.SECTION, cv.REFERENCE],
        [Output("section_forces", (4,), [f.xreplace(rename) for f in fm.section_forces(psi_symbols, section,
                                                                                       formulation, shear)])], b,
        tangent=reference_tangent("section_forces", "section_forces_D_reference", plane,
                                  "∂S/∂(reference data) along the variation given, (4, 1)"))

    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=True)
    Ja = b.vector("Ja", [sp.Add(*[p["J"][i][a] * acceleration[a] for a in range(N)]) for i in range(12)])
    TcT = p["TcT"]
    g_local = b.vector("gc", [sp.Add(*[TcT[i][k] * gravity[k] for k in range(3)]) for i in range(3)])
    S = p["first_moment"]
    local = b.vector("inertia_local", [
        sp.Add(*[p["Mhat"][i][j] * (Ja[j] + p["Jdq"][j]) for j in range(12)]) + p["ghat"][i]
        - sp.Add(*[S[k, i].xreplace(p["rename"]) * g_local[k] for k in range(3)]) for i in range(12)])
    force = [sp.Add(*[p["J"][i][a] * local[i] for i in range(12)]) for a in range(N)]
    add("beam_inertia_force_D_reference", "Inertia force M a + g − Q of gravity and its derivative along a "
        "variation of the reference data at fixed spatial rates and accelerations (forward mode of the lowered "
        "force, codegen/forward.py)", "Eqs. 50-58, 61-62",
        [cv.GEOMETRY, cv.VELOCITY, cv.ACCELERATION, cv.SECTION, cv.GRAVITY, cv.REFERENCE],
        [Output("inertia_force", (N,), force)], b,
        tangent=reference_tangent("inertia_force", "inertia_force_D_reference", plane,
                                  "∂(M a + g − Q)/∂(reference data) along the variation given, (14, 1)"))

    def inertia_force(b):   # M a + g − Q lowered as above (beam_inertia_tangent)
        p = inertia(b, with_velocity=True)
        Ja = b.vector("Ja", [sp.Add(*[p["J"][i][a] * acceleration[a] for a in range(N)]) for i in range(12)])
        TcT, S = p["TcT"], p["first_moment"]
        g_local = b.vector("gc", [sp.Add(*[TcT[i][k] * gravity[k] for k in range(3)]) for i in range(3)])
        local = b.vector("inertia_local", [
            sp.Add(*[p["Mhat"][i][j] * (Ja[j] + p["Jdq"][j]) for j in range(12)]) + p["ghat"][i]
            - sp.Add(*[S[k, i].xreplace(p["rename"]) * g_local[k] for k in range(3)]) for i in range(12)])
        return [sp.Add(*[p["J"][i][a] * local[i] for i in range(12)]) for a in range(N)]

    def forces_of_section(psi):
        rename = dict(zip(psi_symbols, psi))
        return [f.xreplace(rename) for f in fm.section_forces(psi_symbols, section, formulation, shear)]

    _section_value_kernels(add, elastic, inertia_force, forces_of_section, kin, shear_definitions)

    # the tangent stiffness along a direction v, K v (v read from the velocity block), and its derivative by the
    # section values: the arc length's first step's ∂K/∂p v (latdyn/analyses/sensitivities.py)
    b = Builder(kin.auxiliary + shear_definitions)
    _, _, stiffness = elastic(b, with_tangent=True)
    direction = [0 if a in out_of_plane else symbol for a, symbol in enumerate(cv.VELOCITY.symbols())]
    along = [sp.Add(*[stiffness[a][c] * direction[c] for c in range(N)]) for a in range(N)]
    add("beam_stiffness_D_section", "Tangent stiffness along a direction, (∂F_i/∂q) v (v in the velocity block), and "
        "its derivative by the section values EA … 1/GAz (forward mode of the lowered product, codegen/forward.py)",
        "Eqs. 29-43", [cv.GEOMETRY, cv.VELOCITY, cv.SECTION], [Output("stiffness_along", (N,), along)], b,
        tangent=section_tangent("stiffness_along", "stiffness_along_D_section",
                                "∂((∂F_i/∂q) v)/∂(EA EIy EIz GJ rhoA rhoIy rhoIz cGAy cGAz), row-major (14, 9)"))

    # the same product K v and its derivative by the element's coordinates, ∂((∂F_i/∂q) v)/∂q under the configuration
    # update at fixed v: the forward-mode program of the lowered product seeded with the geometry block's first
    # variation (configuration_tangent), the term an event's impulse weight M + dt²K needs along δq
    # (latdyn/analyses/weight_derivative.py: H = ∂(K w)/∂q, assembled once and used as H δq and Hᵀū)
    b = Builder(kin.auxiliary + shear_definitions)
    _, _, stiffness = elastic(b, with_tangent=True)
    along = [sp.Add(*[stiffness[a][c] * direction[c] for c in range(N)]) for a in range(N)]
    add("beam_stiffness_D_q", "Tangent stiffness along a direction, (∂F_i/∂q) v (v in the velocity block), and its "
        "exact derivative by the element's coordinates at fixed v (forward mode of the lowered product, "
        "codegen/forward.py)", "Eqs. 29-43", [cv.GEOMETRY, cv.VELOCITY, cv.SECTION],
        [Output("stiffness_along", (N,), along)], b,
        tangent=configuration_tangent("stiffness_along", "stiffness_along_D_q", plane,
                                      "∂((∂F_i/∂q) v)/∂q at fixed v, row-major: [r, d] = ∂(K v)_r/∂q_d"))

    # the same product K v and its derivative along one variation of the reference data at fixed v and configuration,
    # ∂((∂F_i/∂q) v)/∂X: the forward-mode program of the lowered product seeded with the reference data's first
    # variation (reference_tangent, as beam_internal_force_D_reference's), a geometry parameter's (∂K/∂p) w at an
    # event's impulse weight (latdyn/analyses/parameter_stiffness.py ``_geometry``)
    b = Builder(kin.auxiliary + shear_definitions)
    _, _, stiffness = elastic(b, with_tangent=True)
    along = [sp.Add(*[stiffness[a][c] * direction[c] for c in range(N)]) for a in range(N)]
    add("beam_stiffness_D_reference", "Tangent stiffness along a direction, (∂F_i/∂q) v (v in the velocity block), "
        "and its derivative along a variation of the reference data at fixed v and configuration (forward mode of "
        "the lowered product, codegen/forward.py)", "Eqs. 29-43", [cv.GEOMETRY, cv.VELOCITY, cv.SECTION, cv.REFERENCE],
        [Output("stiffness_along", (N,), along)], b,
        tangent=reference_tangent("stiffness_along", "stiffness_along_D_reference", plane,
                                  "∂((∂F_i/∂q) v)/∂(reference data) along the variation given, (14, 1)"))

    def section_forces_along() -> tuple:
        """(a builder, (∂S/∂q) a in it): the section forces' derivative along a direction a (in the velocity block),
        ∂S/∂ψ B a (Eqs. 22-43), the lowered product the two kernels below differentiate forward."""
        b = Builder(kin.auxiliary + shear_definitions)
        psi = b.vector("psi", kin.psi)
        Bm = b.matrix("B", kin.B)
        rename = dict(zip(psi_symbols, psi))
        by_psi = b.matrix("dS_dpsi", [[sp.diff(f, p).xreplace(rename) for p in psi_symbols] for f in sections])
        by_q = _matmul(by_psi, Bm)
        return b, [sp.Add(*[by_q[k][c] * direction[c] for c in range(N)]) for k in range(len(sections))]

    # the section forces' derivative along a direction, (∂S/∂q) a (a in the velocity block), and its derivative by the
    # element's coordinates, ∂((∂S/∂q) a)/∂q under the configuration update at fixed a: the forward-mode program of the
    # lowered product seeded as ``beam_stiffness_D_q``'s, the second derivative of a section-force sensor an event's
    # impulse weight needs along δq (latdyn/analyses/weight_derivative.py ``_sensor_kinematics``, kind 12)
    b, along = section_forces_along()
    add("beam_section_forces_D_q_D_q", "The section forces' derivative along a direction, (∂S/∂q) a (a in the "
        "velocity block), and its exact derivative by the element's coordinates at fixed a (forward mode of the "
        "lowered product, codegen/forward.py)", "Eqs. 22-43", [cv.GEOMETRY, cv.VELOCITY, cv.SECTION],
        [Output("section_forces_along", (4,), along)], b,
        tangent=configuration_tangent("section_forces_along", "section_forces_along_D_q", plane,
                                      "∂((∂S/∂q) a)/∂q at fixed a, row-major: [k, d] = ∂((∂S/∂q) a)_k/∂q_d"))

    # the same product (∂S/∂q) a and its derivative by the section values at fixed a and configuration,
    # ∂((∂S/∂q) a)/∂σ: the forward-mode program of the lowered product seeded with the section values' unit vectors
    # (section_tangent), the move along w of a section-force sensor's ∂S/∂p that an event's impulse weight needs for a
    # parameter in a section value, (∂²S/∂σ∂q) w δσ (latdyn/analyses/parameter_stiffness.py ``_section_force_along``);
    # exact whether or not S is linear in σ (a shear-flexible section's axial force reads EI through μ)
    b, along = section_forces_along()
    add("beam_section_forces_D_q_D_section", "The section forces' derivative along a direction, (∂S/∂q) a (a in the "
        "velocity block), and its exact derivative by the section values EA … 1/GAz at fixed a and configuration "
        "(forward mode of the lowered product, codegen/forward.py)", "Eqs. 22-43", [cv.GEOMETRY, cv.VELOCITY, cv.SECTION],
        [Output("section_forces_along", (4,), along)], b,
        tangent=section_tangent("section_forces_along", "section_forces_along_D_section",
                                "∂((∂S/∂q) a)/∂(EA EIy EIz GJ rhoA rhoIy rhoIz cGAy cGAz), row-major (4, 9)"))

    # the element's energies [U, T, V] (strain, kinetic, gravity potential) and their derivatives by the section
    # values: an energy probe's explicit ∂/∂p (latdyn/analyses/energy_sensitivities.py)
    b = Builder(kin.auxiliary + shear_definitions)
    p = inertia(b, with_velocity=True)
    kinetic = sp.Add(*[p["u"][i] * p["Mhat"][i][j] * p["u"][j] for i in range(12) for j in range(12)]) / 2
    P = [p["position_moment"][k].xreplace(p["rename"]) for k in range(3)]
    centre = [section["rhoA"] * section["L0"] * kin.grid1[k] + sp.Add(*[p["Tc"][3 * k + j] * P[j] for j in range(3)])
              for k in range(3)]
    energies = [U.xreplace(p["rename"]), kinetic, -sp.Add(*[gravity[k] * centre[k] for k in range(3)])]
    add("beam_energies_D_section", "Strain, kinetic and gravity potential energies [U, T, V] and their derivatives "
        "by the section values EA … 1/GAz (forward mode of the lowered energies, codegen/forward.py)", "Eqs. 22-58",
        [cv.GEOMETRY, cv.VELOCITY, cv.SECTION, cv.GRAVITY], [Output("energies", (3,), energies)], b,
        tangent=section_tangent("energies", "energies_D_section",
                                "∂[U, T, V]/∂(EA EIy EIz GJ rhoA rhoIy rhoIz cGAy cGAz), row-major (3, 9)"))
    return kernels
