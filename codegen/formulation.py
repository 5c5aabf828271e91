"""The CR-4402 beam element, written from the paper's definitions.

Everything here is *formulation*: which quantities the paper defines and how
they depend on each other.  Differentiation and packaging into kernels live in
:mod:`codegen.derivation`.  Equation numbers refer to NASA CR-4402 (Chang & Wu
1991); where the printed equation disagrees with its own definitions, the
corrected form is used and the deviation is proved in ``docs/derivation.md``
(``latdyn-codegen --report``).

Conventions
-----------
* Element coordinates q^e = [d1, π1, θ1, d2, π2, θ2] (Eq. 59): translation of
  the joint-body reference point, *spatial* virtual rotation of the joint body
  (δT = skew(δπ) T), hinge angle; 14 in all.  The grid point sits at the offset
  ``o = T_j r_g`` from the reference point (Eq. 2), so offset compensation
  (Eqs. 59–62) is part of the kinematics and its χ^e term (Eq. 61) appears in
  the quadratic-velocity vector without further work.  With ``o = 0`` the
  coordinates are the paper's p^e (Eq. 33).
* The nodal frame is T_e = T_j Γ_gh T_h(θ) Γ_eh^T (Eq. 17), i.e. a rotation
  of the hinge angle about the spatial hinge axis h = T_j Γ_gh e_z; the kernels
  take T_e and h as inputs, so a change of θ acts as exp(δθ skew(h)) on T_e.
* Shear (not in CR-4402): the section block carries the compliances 1/GA_y,
  1/GA_z (0 = shear-rigid).  Bending + shear energy, the ½(v'² + w'²) stretching
  term and the inertia all use the interdependent interpolation element
  (:func:`interdependent_shapes`), polynomial in μ = 1/(1 + Φ); μ = 1 is the
  Euler–Bernoulli element exactly.  IIE rather than Hermite shapes in the
  stretching term and the inertia: with Hermite ones the buckling load and the
  frequencies converge to wrong limits (docs/verification.md, "Shear-deformable
  sections"), for +0–17 % operations in the kernels.
* Symbolic geometry is built in SymEngine (fast differentiation); the section
  integrals of the inertia are done in SymPy.  The single crossing point is
  :func:`to_sympy`.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import symengine as se
import sympy as sp

from . import conventions as cv


@dataclass(frozen=True)
class Formulation:
    """Switches that select a variant of the element from the same source."""

    name: str
    geometric_stiffening: bool = True  # the ½(v'² + w'²) term of Eq. 35
    rotary_inertia: bool = True  # cross-section terms y_c, z_c of Eq. 45 (ρI_y, ρI_z)
    #: how the local nodal rotations Ψ are read from R_i = T_cᵀ T_e^i:
    #: "sine"  Eqs. 14–16 literally (entries of R_i: sines, first order in the rotation),
    #: "log"   the rotation vector log(R_i) (exact; Battini & Pacoste 2002), see :func:`log_rotation`.
    rotation_measure: str = "log"
    #: how the corotational frame's t_c2, t_c3 are chosen about the chord (:func:`corotational`):
    #: "first_node" the paper's Eqs. 20–21 (from node 1's section); "mean" from the mean of both
    #: nodes' sections (twist-symmetric; docs/derivation.md, "Bending–twist coupling").
    corotational_frame: str = "first_node"
    #: None: the 3D element. "xy", "yz", "zx": the same element restricted to motion in that
    #: coordinate plane (:class:`Plane`), for scenes that stay in it (``solve.planar``).
    plane: str | None = None
    #: transverse shapes of the ½(v'² + w'²) stretching term and of the inertia when the section is
    #: shear-deformable (compliance 1/GA > 0); bending + shear energy always uses the interdependent
    #: interpolation (:func:`interdependent_shapes`).  "interdependent": the IIE deflection and section
    #: rotation; "hermite": the Euler–Bernoulli cubics of Eqs. 23–26 whatever the shear.  Both are the
    #: same when 1/GA = 0.  Every variant uses "interdependent": with "hermite" the frequencies of a
    #: Timoshenko beam converge to a limit 2.8 % off (mode 4) and the buckling load misses Engesser's;
    #: measurements and operation counts: docs/verification.md, "Shear-deformable sections".
    stiffening_shapes: str = "interdependent"
    inertia_shapes: str = "interdependent"
    description: str = ""

    def __post_init__(self):
        if self.rotation_measure not in ROTATION_MEASURES:
            raise ValueError(f"rotation_measure {self.rotation_measure!r} not in {ROTATION_MEASURES}")
        if self.corotational_frame not in COROTATIONAL_FRAMES:
            raise ValueError(f"corotational_frame {self.corotational_frame!r} not in {COROTATIONAL_FRAMES}")
        if self.plane is not None and self.plane not in PLANES:
            raise ValueError(f"plane {self.plane!r} not in {tuple(PLANES)}")
        for shapes in (self.stiffening_shapes, self.inertia_shapes):
            if shapes not in TRANSVERSE_SHAPES:
                raise ValueError(f"transverse shapes {shapes!r} not in {TRANSVERSE_SHAPES}")


ROTATION_MEASURES = ("log", "sine")
COROTATIONAL_FRAMES = ("first_node", "mean")
TRANSVERSE_SHAPES = ("interdependent", "hermite")

FORMULATIONS: dict[str, Formulation] = {
    "default": Formulation(
        "default",
        rotation_measure="log",
        corotational_frame="mean",
        description="exact local rotations (log map of T_cᵀT_e) about a twist-symmetric corotational frame, "
                    "geometric stiffening, cross-section rotary inertia, IIE shear where 1/GA > 0",
    ),
    "cr4402": Formulation(
        "cr4402",
        rotation_measure="sine",
        description="CR-4402 element: small-rotation measures of Eqs. 14–16, geometric stiffening, rotary inertia; "
                    "IIE shear where 1/GA > 0",
    ),
    "no_stiffening": Formulation(
        "no_stiffening",
        geometric_stiffening=False,
        rotation_measure="sine",
        description="cr4402 (Eqs. 14–16 measures) without the ½(v'²+w'²) stretching term (Eq. 35): no geometric stiffening",
    ),
}


# --------------------------------------------------------------------------
# Planar variants: the same element, restricted to one coordinate plane
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class Plane:
    """Motion in the coordinate plane normal to global axis ``normal`` (0, 1, 2 = x, y, z).

    A planar configuration is one where every grid point lies in a plane x_n = const, every
    nodal frame T_e turns about n only and has its third axis along +n (local z = +n; the
    model turns a section whose y or −z is normal into this form, ``latdyn.model``), every
    hinge axis is ±n, and velocities and gravity keep the motion in the plane.  The element
    is then the 3D element with these values put in *before* differentiation, and its
    variations restricted to the in-plane coordinates (d_i, d_j, π_n, θ per end, with
    (i, j, n) cyclic): the kernels keep the 3D argument blocks and the 14-wide outputs, with
    rows and columns of out-of-plane coordinates identically zero.  By the reflection
    symmetry about the plane, the in-plane rows and columns equal those of the 3D kernels
    at a planar configuration, which the tests check.
    """

    normal: int

    @property
    def in_plane(self) -> tuple[int, int]:
        """The two in-plane global axes (i, j), with (i, j, normal) cyclic."""
        return (self.normal + 1) % 3, (self.normal + 2) % 3

    def out_of_plane_coordinates(self) -> list[int]:
        """Indices into q^e (and the velocity block) that leave the plane: d_n, π_i, π_j per end."""
        i, j = self.in_plane
        out = []
        for base in (0, 7):
            out += [base + self.normal, base + 3 + i, base + 3 + j]
        return out

    def geometry_values(self, symbols) -> dict:
        """Values of the geometry block's ``symbols`` (any symbol type) in a planar configuration.

        x2_n = x1_n (the plane), o_n = 0; the nodal frame's local axes (columns) are
        x = c e_i + s e_j, y = n × x = −s e_i + c e_j, z = e_n (c = T_e[i, 0] and s = T_e[j, 0]
        stay symbols); h_i = h_j = 0 (h_n stays: ±1, or 0 for a clamped end).
        """
        g = symbols
        i, j = self.in_plane
        n = self.normal
        values = {g[cv.X2.start + n]: g[cv.X1.start + n]}
        for offset in (cv.OFFSET1, cv.OFFSET2):
            values[g[offset.start + n]] = 0
        for frame in (cv.FRAME1, cv.FRAME2):
            F = lambda row, col: g[frame.start + 3 * row + col]  # noqa: E731  (row: global axis, col: local)
            cosine, sine = F(i, 0), F(j, 0)
            values.update({F(n, 0): 0, F(i, 1): -sine, F(j, 1): cosine, F(n, 1): 0,
                           F(i, 2): 0, F(j, 2): 0, F(n, 2): 1})
        for axis in (cv.AXIS1, cv.AXIS2):
            values[g[axis.start + i]] = 0
            values[g[axis.start + j]] = 0
        return values

    def velocity_values(self, symbols) -> dict:
        """Out-of-plane velocity components (v_n, ω_i, ω_j per end) are zero."""
        return {symbols[k]: 0 for k in self.out_of_plane_coordinates()}

    def gravity_values(self, symbols) -> dict:
        return {symbols[self.normal]: 0}


#: Coordinate planes of the planar variants, by the index of their normal.
PLANES = {"yz": Plane(0), "zx": Plane(1), "xy": Plane(2)}


def _planar_variants(base: Formulation) -> dict[str, Formulation]:
    from dataclasses import replace

    return {
        f"{base.name}_{plane}": replace(base, name=f"{base.name}_{plane}", plane=plane,
                                        description=f"{base.description}; planar: motion in the {plane} plane only")
        for plane in PLANES
    }


for _base in list(FORMULATIONS.values()):
    FORMULATIONS.update(_planar_variants(_base))


# --------------------------------------------------------------------------
# Small vector helpers on SymEngine matrices
# --------------------------------------------------------------------------
def vector(symbols) -> se.DenseMatrix:
    return se.DenseMatrix(3, 1, list(symbols))


def skew(w) -> se.DenseMatrix:
    """The cross-product matrix, skew(w) v = w × v."""
    return se.DenseMatrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b) -> se.DenseMatrix:
    return vector([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def column(T, k) -> se.DenseMatrix:
    return vector([T[0, k], T[1, k], T[2, k]])


def vee(S):
    """The axial vector of a skew-symmetric matrix."""
    return vector([S[2, 1], S[0, 2], S[1, 0]])


def to_sympy(expr) -> sp.Expr:
    """The one boundary between SymEngine (geometry) and SymPy (IR, integrals)."""
    return sp.sympify(expr)


# --------------------------------------------------------------------------
# Inputs
# --------------------------------------------------------------------------
@dataclass
class EndInputs:
    """Current state of one element end, as symbols of the geometry block."""

    x: se.DenseMatrix  # reference point of the joint body
    offset: se.DenseMatrix  # o = T_j r_g, Eq. 2
    frame: se.DenseMatrix  # T_e, Eq. 17
    axis: se.DenseMatrix  # h, spatial hinge axis


def geometry_inputs() -> tuple[EndInputs, EndInputs]:
    g = [se.Symbol(str(s)) for s in cv.GEOMETRY.symbols()]

    def block(sl):
        return g[sl]

    ends = []
    for xs, os_, fs, hs in ((cv.X1, cv.OFFSET1, cv.FRAME1, cv.AXIS1), (cv.X2, cv.OFFSET2, cv.FRAME2, cv.AXIS2)):
        ends.append(
            EndInputs(
                x=vector(block(xs)),
                offset=vector(block(os_)),
                frame=se.DenseMatrix(3, 3, block(fs)),
                axis=vector(block(hs)),
            )
        )
    return ends[0], ends[1]


def section_inputs() -> dict[str, se.Symbol]:
    return {name: se.Symbol(str(s)) for name, s in zip(cv.SECTION_NAMES, cv.SECTION.symbols())}


def velocity_inputs() -> list[se.Symbol]:
    return [se.Symbol(str(s)) for s in cv.VELOCITY.symbols()]


def gravity_inputs() -> se.DenseMatrix:
    return vector([se.Symbol(str(s)) for s in cv.GRAVITY.symbols()])


# --------------------------------------------------------------------------
# Moving the inputs: virtual variations, Newton increments, time
# --------------------------------------------------------------------------
@dataclass
class EndMotion:
    """A change of one end's coordinates (d, π, θ), as a sequence of factors.

    ``rotations`` are (vector, order) pairs applied left to right:
    T_e ← exp(skew(w_1)) … exp(skew(w_k)) T_e, each exponential truncated at
    ``order``.  Offsets follow the joint-body factors only; the hinge factors
    rotate the nodal frame alone.
    """

    translation: se.DenseMatrix
    body_rotations: list
    hinge_rotations: list


def exp_truncated(w, order: int) -> se.DenseMatrix:
    """exp(skew(w)) to the given order in w (order 1: I + W; order 2: + W²/2)."""
    W = skew(w)
    E = se.eye(3) + W
    if order >= 2:
        E = E + W * W / 2
    return E


def moved_end(end: EndInputs, steps: list[tuple[str, se.DenseMatrix, se.DenseMatrix, object, int]]):
    """Grid point and nodal frame after a sequence of coordinate changes.

    Each step is (label, Δd, Δπ, Δθ, order).  Applying the steps in order
    k = 1…m to the current state gives, with the spatial hinge axis h rotating
    with the body (Eq. 9):

        T_e = E(Δπ_m)…E(Δπ_1) · E(Δθ_1 h)…E(Δθ_m h) · T_e⁰
        o   = E(Δπ_m)…E(Δπ_1) · o⁰,      x = x⁰ + ΣΔd

    (a later body rotation conjugates every earlier hinge rotation, which is
    what moves all hinge factors to the right of all body factors).
    """
    body = se.eye(3)
    hinge = se.eye(3)
    x = end.x
    for _, d, pi, theta, order in steps:
        body = exp_truncated(pi, order) * body
        hinge = hinge * exp_truncated(end.axis * theta, order)
        x = x + d
    frame = body * hinge * end.frame
    grid = x + body * end.offset
    return grid, frame


# --------------------------------------------------------------------------
# Deformation measures and corotational frame, Eqs. 12–21 and 46
# --------------------------------------------------------------------------
@dataclass
class Corotational:
    chord: se.DenseMatrix  # x_g2 − x_g1
    length: object  # ℓ, Eq. 12
    frame: se.DenseMatrix  # T_c = [t_c1 t_c2 t_c3], Eqs. 18–21 (exact orthonormal form)
    psi: list  # Ψ = [φy1, φz1, φy2, φz2, φx2, αx2], Eq. 46
    log_arguments: tuple = ()  # (x_1, x_2), x_i = 1 − cos|θ_i| = (3 − tr R_i)/2, for the "log" measure


def corotational(grid1, frame1, grid2, frame2, L0, measure: str = "sine", scales=None,
                 planar: bool = False, frame_choice: str = "first_node") -> Corotational:
    """Ψ and T_c from the two grid points and nodal frames.

    * α_x² = ‖x_g2 − x_g1‖ − L_e (Eqs. 12–13).
    * t_c1 is the unit chord (the x axis "passes through the two end nodes").
    * t_c2, t_c3 follow the first node's cross-section (Eqs. 20–21).  The paper
      prints their first-order forms; we use the exact orthonormal frame
      t_c2 = (t_e1(2) − (t_c1·t_e1(2)) t_c1)/‖·‖, t_c3 = t_c1 × t_c2, which agrees
      to first order in φ and keeps T_c a rotation (needed for exact rigid-body
      invariance).

    The local rotations are read from R_i = T_cᵀ T_e^i (Eq. 6: T_e = T_c R):

    * ``measure="sine"`` (the paper): φ_y^i = t_c1·t_e^i(3), φ_z^i = −t_c1·t_e^i(2)
      (Eqs. 14–15), φ_x² = t_c3·t_e²(2) (Eq. 16); φ_x¹ = 0 by the choice of t_c2.
      These are sines: first order in the rotation (report, item 7, 14–16).
    * ``measure="log"``: θ_i = log(R_i) (:func:`log_rotation`), the exact rotation
      vector, and Ψ = [θ_y¹, θ_z¹, θ_y², θ_z², θ_x² − θ_x¹, α].  With this T_c,
      θ_x¹ = −½θ_y¹θ_z¹ + O(θ³) is not zero, so the twist is the relative one.
      ``scales`` = (f_1, f_2): callables giving θ/sin θ as a function of
      x = 1 − cos θ at each end (default: :func:`log_scale_closed`, exact but not
      safe at R = I; the kernels use :func:`log_scale` through a jet).
    * ``frame_choice="mean"``: t_c2, t_c3 from m = t_e¹(2) + t_e²(2) instead of t_e¹(2),
      t_c2 = (m − (t_c1·m) t_c1)/‖·‖, t_c3 = t_c1 × t_c2 (Crisfield 1990; Battini & Pacoste 2002):
      the frame sits half-way between the two sections in twist, so both ends' bending
      rotations are read in the mid-element section and the twist splits ±½ between the ends.
      With the first node's frame, log(R_i) reads both ends' bending in a frame turned by
      about a quarter of the element's twist from the mid-section, which with EI_y ≠ EI_z
      couples bending and twist at O(h) (docs/derivation.md, "Bending–twist coupling").
      In a planar configuration both choices give t_c2 = n × t_c1, so the planar variants
      keep the first node's (cheaper) form.
    * ``planar`` (a configuration of a :class:`Plane`, local z = n): R_i turns about local z
      only, so log(R_i) = (0, 0, atan2(R_i[1, 0], R_i[0, 0])) exactly (|θ| < π): the same
      measure in closed form, without the series of θ/sin θ.  The sines are unchanged.
    """
    chord = grid2 - grid1
    length = se.sqrt(dot(chord, chord))
    e = chord / length
    a2, a3 = column(frame1, 1), column(frame1, 2)
    b2, b3 = column(frame2, 1), column(frame2, 2)
    s = dot(e, a2)  # = −φ_z¹
    n = se.sqrt(1 - s * s)  # ‖t_e1(2) − s t_c1‖ on SO(3)
    mean = frame_choice == "mean" and not planar
    if mean:
        m = a2 + b2  # twice the mean section axis; only its direction normal to the chord counts
        em = dot(e, m)
        nm = se.sqrt(2 + 2 * dot(a2, b2) - em * em)  # ‖m − (t_c1·m) t_c1‖, |t_e¹(2)| = |t_e²(2)| = 1
        t2 = (m - e * em) / nm
        t3 = cross(e, m) / nm
    elif frame_choice == "first_node" or planar:
        t2 = (a2 - e * s) / n
        t3 = cross(e, a2) / n
    else:
        raise ValueError(f"unknown corotational frame {frame_choice!r}")
    frame = se.DenseMatrix(3, 3, [e[0], t2[0], t3[0], e[1], t2[1], t3[1], e[2], t2[2], t3[2]])
    if measure == "sine":
        psi = [
            dot(e, a3),  # φ_y¹, Eq. 14
            -s,  # φ_z¹, Eq. 15
            dot(e, b3),  # φ_y², Eq. 14
            -dot(e, b2),  # φ_z², Eq. 15
            dot(t3, b2),  # φ_x², Eq. 16
            length - L0,  # α_x², Eq. 13
        ]
        return Corotational(chord, length, frame, psi)
    if measure != "log":
        raise ValueError(f"unknown rotation measure {measure!r}")
    if scales is None:
        scales = (log_scale_closed_se, log_scale_closed_se)
    # R_i = T_cᵀT_e^i (Eq. 6).  At node 1, t_c2 and t_c3 are built from t_e¹(2), so with c_k = t_c1·t_e¹(k)
    # and t_e¹(1) = t_e¹(2) × t_e¹(3) (a rotation) every entry is a function of c_1, c_2 = s, c_3 and n:
    # t_c2·t_e¹(k) = (δ_2k − s c_k)/n, t_c3·t_e¹(1) = −c_3/n, t_c3·t_e¹(2) = 0, t_c3·t_e¹(3) = c_1/n
    # (docs/derivation.md, item 14–16 (log)); fewer entries to differentiate than nine dot products.
    axes = (e, t2, t3)
    if mean:
        R1, R2 = _mean_frame_rotations(e, frame1, frame2)
    else:
        c1, c3 = dot(e, column(frame1, 0)), dot(e, a3)
        R1 = se.DenseMatrix(3, 3, [c1, s, c3, -s * c1 / n, n, -s * c3 / n, -c3 / n, 0, c1 / n])
        columns = [column(frame2, k) for k in range(3)]
        R2 = se.DenseMatrix(3, 3, [dot(axes[i], columns[j]) for i in range(3) for j in range(3)])
    if planar:
        # R_i[1,0] = t_c2·t_e^i(1) = n·(t_c1 × t_e^i(1)) and R_i[0,0] = t_c1·t_e^i(1), with t_c2 = n × t_c1
        # (the exact frame above for |θ_z¹| < 90°) and n = t_e^i(3); atan2 is blind to the positive
        # factor ℓ, so the unnormalised chord serves (fewer operations in the derivatives).
        zero = se.Integer(0)
        theta_z = [se.atan2(dot(column(F, 2), cross(chord, column(F, 0))), dot(chord, column(F, 0)))
                   for F in (frame1, frame2)]
        psi = [zero, theta_z[0], zero, theta_z[1], zero, length - L0]
        return Corotational(chord, length, frame, psi)
    thetas, arguments = [], []
    for R, scale in ((R1, scales[0]), (R2, scales[1])):
        x, _ = log_arguments(R)
        thetas.append(log_rotation(R, scale))
        arguments.append(x)
    (tx1, ty1, tz1), (tx2, ty2, tz2) = thetas
    psi = [ty1, tz1, ty2, tz2, tx2 - tx1, length - L0]
    return Corotational(chord, length, frame, psi, tuple(arguments))


def _mean_frame_rotations(e, frame1, frame2):
    """R_i = T_cᵀT_e^i for the mean frame, written with the orthonormality of T_e¹ and T_e².

    With c_k = t_c1·t_e¹(k), d_k = t_c1·t_e²(k) and G = T_e¹ᵀT_e² (G_jk = t_e¹(j)·t_e²(k)), in the
    nodes' own bases: m = t_e¹(2) + t_e²(2) has m·t_e¹(k) = δ_2k + G_k2, m·t_e²(k) = G_2k + δ_2k,
    ‖m − (t_c1·m)t_c1‖² = 2 + 2G_22 − (c_2 + d_2)², and (t_c1 × m)·t_e¹(k) = (c × G_:2)_k + (c_1δ_3k − c_3δ_1k),
    (t_c1 × m)·t_e²(k) = (d × G_2:)_k + (d_1δ_3k − d_3δ_1k).  The same matrices as the nine dot
    products of T_c's columns with each T_e^i's, in fewer operations to differentiate."""
    a = [column(frame1, k) for k in range(3)]
    b = [column(frame2, k) for k in range(3)]
    c = [dot(e, a[k]) for k in range(3)]
    d = [dot(e, b[k]) for k in range(3)]
    G = [[dot(a[j], b[k]) for k in range(3)] for j in range(3)]
    R1, R2 = _mean_frame_rotations_in(c, d, G)
    return se.DenseMatrix(3, 3, R1), se.DenseMatrix(3, 3, R2)


# --------------------------------------------------------------------------
# Ψ as a function of sixteen invariants of the two ends (the structured derivation)
# --------------------------------------------------------------------------
#: The invariants ι of the element's configuration that Ψ depends on, with c = x_g2 − x_g1 the chord
#: and a_k = t_e¹(k+1), b_k = t_e²(k+1) the nodal frames' axes: ι = [c·c, c·a_k, c·b_k, a_j·b_k]
#: (1 + 3 + 3 + 9).  Every one is a dot product of two vectors that move rigidly under a change of
#: coordinates, so its first and second derivatives in q^e are short; everything CR-4402 builds from
#: them (Eqs. 12–21, the log map, Eq. 46) is a function of these sixteen numbers alone, written with
#: the orthonormality of T_e¹ and T_e² (a_0 × a_1 = a_2, …), which every change of coordinates keeps.
INVARIANT_NAMES = (["chord_chord"] + [f"chord_a{k}" for k in range(3)] + [f"chord_b{k}" for k in range(3)]
                   + [f"a{j}_b{k}" for j in range(3) for k in range(3)])


def invariants(grid1, frame1, grid2, frame2) -> list:
    """ι = [c·c, c·a_k, c·b_k, a_j·b_k] (:data:`INVARIANT_NAMES`) of two grid points and nodal frames."""
    chord = grid2 - grid1
    a = [column(frame1, k) for k in range(3)]
    b = [column(frame2, k) for k in range(3)]
    return ([dot(chord, chord)] + [dot(chord, a[k]) for k in range(3)] + [dot(chord, b[k]) for k in range(3)]
            + [dot(a[j], b[k]) for j in range(3) for k in range(3)])


def deformation_from_invariants(iota, L0, measure: str = "sine", scales=None, planar: bool = False,
                                frame_choice: str = "first_node"):
    """Ψ (Eq. 46) as a function of the invariants ``iota`` (:func:`invariants`): the same Ψ as
    :func:`corotational`, in sixteen variables instead of the 36 of the geometry block.

    With ℓ = √(c·c) (Eq. 12), c_k = t_c1·a_k = (c·a_k)/ℓ, d_k = t_c1·b_k = (c·b_k)/ℓ and G_jk = a_j·b_k,
    R_i = T_cᵀT_e^i (Eq. 6) is written in (c, d, G) for both corotational frames: the first node's
    (t_c2·b_k = (G_1k − c_1 d_k)/n, t_c3·b_k = t_c1·(a_1 × b_k)/n = (c_0 G_2k − c_2 G_0k)/n, n = √(1 − c_1²))
    and the mean one (:func:`_mean_frame_rotations`, the same identities).  Returns (Ψ, (x_1, x_2)):
    the log map's arguments x_i = (3 − tr R_i)/2 for the "log" measure, else ().
    """
    chord2 = iota[0]
    p, q = iota[1:4], iota[4:7]
    G = [list(iota[7 + 3 * j: 10 + 3 * j]) for j in range(3)]
    length = se.sqrt(chord2)
    c = [pk / length for pk in p]
    d = [qk / length for qk in q]
    if planar and measure == "log":
        # the closed-form planar log (:func:`corotational`): θ_z^i = atan2(t_e^i(3)·(c × t_e^i(1)), c·t_e^i(1))
        # = atan2(−c·t_e^i(2), c·t_e^i(1)), as t_e^i(3) = n and t_e^i(1) × n = −t_e^i(2)
        zero = se.Integer(0)
        return [zero, se.atan2(-p[1], p[0]), zero, se.atan2(-q[1], q[0]), zero, length - L0], ()
    if frame_choice == "mean" and not planar:  # in a planar configuration both frames are the same
        R1, R2 = _mean_frame_rotations_in(c, d, G)
    elif frame_choice in ("first_node", "mean"):
        n = se.sqrt(1 - c[1] * c[1])
        R1 = [c[0], c[1], c[2], -c[1] * c[0] / n, n, -c[1] * c[2] / n, -c[2] / n, se.Integer(0), c[0] / n]
        R2 = (d + [(G[1][k] - c[1] * d[k]) / n for k in range(3)]
              + [(c[0] * G[2][k] - c[2] * G[0][k]) / n for k in range(3)])
    else:
        raise ValueError(f"unknown corotational frame {frame_choice!r}")
    if measure == "sine":
        # φ_y¹ = t_c1·t_e¹(3), φ_z¹ = −t_c1·t_e¹(2), φ_y², φ_z² likewise (Eqs. 14–15), φ_x² = t_c3·t_e²(2) (Eq. 16)
        return [R1[2], -R1[1], R2[2], -R2[1], R2[7], length - L0], ()
    if measure != "log":
        raise ValueError(f"unknown rotation measure {measure!r}")
    if scales is None:
        scales = (log_scale_closed_se, log_scale_closed_se)
    thetas, arguments = [], []
    for R, scale in ((R1, scales[0]), (R2, scales[1])):
        R = se.DenseMatrix(3, 3, R)
        x, _ = log_arguments(R)
        thetas.append(log_rotation(R, scale))
        arguments.append(x)
    (tx1, ty1, tz1), (tx2, ty2, tz2) = thetas
    return [ty1, tz1, ty2, tz2, tx2 - tx1, length - L0], tuple(arguments)


def _mean_frame_rotations_in(c, d, G):
    """R_1, R_2 of the mean frame (row-major lists) in c_k = t_c1·a_k, d_k = t_c1·b_k, G_jk = a_j·b_k
    (the identities of :func:`_mean_frame_rotations`)."""
    em = c[1] + d[1]
    nm = se.sqrt(2 + 2 * G[1][1] - em * em)
    across1 = cross(vector(c), vector([G[0][1], G[1][1], G[2][1]]))
    across2 = cross(vector(d), vector(G[1]))
    delta = lambda j, k: 1 if j == k else 0  # noqa: E731
    R1 = (list(c) + [(delta(1, k) + G[k][1] - em * c[k]) / nm for k in range(3)]
          + [(across1[k] + c[0] * delta(2, k) - c[2] * delta(0, k)) / nm for k in range(3)])
    R2 = (list(d) + [(G[1][k] + delta(1, k) - em * d[k]) / nm for k in range(3)]
          + [(across2[k] + d[0] * delta(2, k) - d[2] * delta(0, k)) / nm for k in range(3)])
    return R1, R2


# --------------------------------------------------------------------------
# The log map, θ = log(R), in a form that is finite and smooth at R = I
# --------------------------------------------------------------------------
#: below x_s = 1 − cos θ_s (θ_s ≈ 26°) θ/sin θ is its Taylor polynomial, above the closed form
LOG_SWITCH = sp.Rational(1, 10)
#: degree of that polynomial: truncation error (x_s/2)^17 ≈ 1e-22 in f, ≈ 1e-17 in f″ at x_s
LOG_SERIES_DEGREE = 16


def log_arguments(R):
    """x = 1 − cos θ = (3 − tr R)/2 and v = vee(R − Rᵀ)/2 = sin θ n, for R = exp(θ skew n)."""
    x = (3 - (R[0, 0] + R[1, 1] + R[2, 2])) / 2
    v = vee(R - R.T) / 2
    return x, v


def log_rotation(R, scale):
    """The rotation vector θ n = log(R) = f(x) v with f = θ/sin θ a function of x (Rodrigues).

    ``scale(x)`` returns f (or, in the derivation, a jet of f about the current x).
    Exact for 0 ≤ θ < π; at θ = π, v = 0 and the measure is undefined (a local
    rotation of 180° between an element end and its chord).
    """
    x, v = log_arguments(R)
    f = scale(x)
    return [f * v[0], f * v[1], f * v[2]]


def log_scale_closed(x):
    """θ/sin θ in x = 1 − cos θ: atan2(sin θ, cos θ)/sin θ with sin θ = √(x(2 − x)) (SymPy; 0/0 at x = 0)."""
    sine = sp.sqrt(x * (2 - x))
    return sp.atan2(sine, 1 - x) / sine


def log_scale_closed_se(x):
    """:func:`log_scale_closed` in SymEngine (for symbolic checks away from R = I)."""
    sine = se.sqrt(x * (2 - x))
    return se.atan2(sine, 1 - x) / sine


def log_scale_series(x, degree: int = LOG_SERIES_DEGREE):
    """Σ_{k≤degree} 2^k (k!)²/(2k+1)! x^k in Horner form: the Taylor series of θ/sin θ in x.

    With u = sin(θ/2) = √(x/2): θ/sin θ = asin(u)/(u√(1 − u²)), and
    asin(u)/√(1 − u²) = Σ 4^k (k!)²/(2k+1)! u^{2k+1}; converges for x < 2 (θ < π).
    """
    coefficients = [sp.Integer(2) ** k * sp.factorial(k) ** 2 / sp.factorial(2 * k + 1) for k in range(degree + 1)]
    poly = coefficients[-1]
    for c in reversed(coefficients[:-1]):
        poly = c + x * poly
    return poly


def log_scale(x, order: int = 0):
    """dᵏf/dxᵏ (k = ``order`` ≤ 2) of f(x) = θ/sin θ, branch-free and finite for 0 ≤ x < 2.

    With x̂ = max(x, x_s) = (x + x_s + |x − x_s|)/2 and P the Taylor polynomial
    (:func:`log_scale_series`):  f⁽ᵏ⁾ ≈ F⁽ᵏ⁾(x̂) + P⁽ᵏ⁾(x) − P⁽ᵏ⁾(x̂), F the closed
    form.  For x ≥ x_s this is F⁽ᵏ⁾(x); below, P⁽ᵏ⁾(x) plus the constant
    F⁽ᵏ⁾(x_s) − P⁽ᵏ⁾(x_s) (the truncation error at x_s).  The closed form is only
    ever evaluated at x̂ ≥ x_s, so there is no 0/0 and no cancellation near R = I.
    """
    t = sp.Dummy("t")
    closed = sp.diff(log_scale_closed(t), t, order)
    poly = sp.diff(sp.expand(log_scale_series(t)), t, order)
    clamped = (x + LOG_SWITCH + sp.Abs(x - LOG_SWITCH)) / 2
    horner = sp.horner(poly, wrt=t) if order else log_scale_series(t)
    return closed.subs(t, clamped) + horner.subs(t, x) - horner.subs(t, clamped)


# --------------------------------------------------------------------------
# Shape functions and the displacement field, Eqs. 22–26, 44–45
# --------------------------------------------------------------------------
xi, ys, zs = sp.symbols("xi y z", real=True)  # ξ = x_c ∈ [0, 1]; y, z physical section coordinates


def hermite():
    """a_1, a_2 of Eqs. 25–26, dimensionless (the printed L_e factor is a typo, see report)."""
    a1 = xi - 2 * xi**2 + xi**3
    a2 = -(xi**2) + xi**3
    return a1, a2


#: Φ = 12 EI/(GA L²) = 12 EI·(1/GA)/L², the shear parameter of one bending plane (Reddy 1997, Eq. 20)
SHEAR_PARAMETER = sp.Symbol("Phi", nonnegative=True)
#: μ = 1/(1 + Φ) ∈ (0, 1], the shear factor in which every IIE quantity is a polynomial (μ = 1: shear-rigid)
SHEAR_FACTOR = sp.Symbol("mu", positive=True)
#: μ_z (bending about z, deflection v along y: EI_z, 1/GA_y) and μ_y (about y, w along z: EI_y, 1/GA_z)
#: as symbols: the kernels define them once (:func:`shear_factor_definitions`) and the inertia
#: integrals keep them symbolic
SHEAR_FACTORS = sp.symbols("shear_factor_z shear_factor_y", real=True)


def _integrate_unit(expr):
    """∫₀¹ expr dξ for a polynomial in ξ (term by term: fast for symbolic coefficients)."""
    poly = sp.Poly(sp.expand(expr), xi)
    return sp.expand(sum(c / (k + 1) for (k,), c in poly.terms()))


@lru_cache(maxsize=None)
def interdependent_shapes():
    """Deflection and section-rotation shapes of the interdependent interpolation element (IIE).

    Returns ((n_1, n_2), (r_1, r_2)), polynomials in ξ and μ = 1/(1 + Φ) (:data:`SHEAR_FACTOR`),
    such that for end rotations φ_1, φ_2 of the section relative to the chord (and no end
    deflection, which the chord absorbs)

        v/L = n_1 φ_1 + n_2 φ_2   (deflection, cubic),   ψ = r_1 φ_1 + r_2 φ_2   (section rotation, quadratic).

    Derived, not copied: they are the exact solution of the static, unloaded linear
    Timoshenko beam (Friedman & Kosmatka 1993; Reddy 1997, Eqs. 15–21):

        M = EI ψ_x,   EI ψ_xx + GA γ = 0,   γ = v_x − ψ,   (GA γ)_x = 0,

    i.e. γ = −(Φ/12) ψ_ξξ in ξ = x/L, with v(0) = v(1) = 0, ψ(0) = φ_1, ψ(1) = φ_2.
    In Φ the coefficients carry 1/(1 + Φ); in μ they are linear, e.g.
    n_1 = μξ³ − (1 + 3μ)ξ²/2 + (1 + μ)ξ/2.  At μ = 1 (Φ = 0), γ = 0, n_k are the Hermite
    cubics a_k of Eqs. 25–26 and r_k = a_k′.
    """
    Phi, mu = SHEAR_PARAMETER, SHEAR_FACTOR
    a = sp.symbols("a_0:4")
    b = sp.symbols("b_0:3")
    phi1, phi2 = sp.symbols("phi_1 phi_2")
    deflection = sum(a[k] * xi**k for k in range(4))  # v/L
    rotation = sum(b[k] * xi**k for k in range(3))  # ψ
    shear_strain = sp.diff(deflection, xi) - rotation  # γ = v_x − ψ
    equilibrium = sp.Poly(shear_strain + Phi / 12 * sp.diff(rotation, xi, 2), xi).all_coeffs()
    conditions = equilibrium + [deflection.subs(xi, 0), deflection.subs(xi, 1),
                                rotation.subs(xi, 0) - phi1, rotation.subs(xi, 1) - phi2]
    solution = sp.solve(conditions, a + b, dict=True)[0]
    deflection, rotation = deflection.subs(solution), rotation.subs(solution)

    def shape(field, phi):
        coefficients = sp.Poly(sp.expand(sp.diff(field, phi)), xi).terms()
        in_mu = [(k, sp.cancel(c.subs(Phi, 1 / mu - 1))) for (k,), c in coefficients]
        assert all(c.is_polynomial(mu) for _, c in in_mu), "IIE shape not polynomial in μ"
        return sum(sp.expand(c) * xi**k for k, c in in_mu)

    n = (shape(deflection, phi1), shape(deflection, phi2))
    r = (shape(rotation, phi1), shape(rotation, phi2))
    assert all(sp.expand(nk.subs(mu, 1) - ak) == 0 for nk, ak in zip(n, hermite())), "IIE at Φ = 0 is not Hermite"
    return n, r


def shear_factor_definitions(section):
    """μ_z = 1/(1 + Φ_z) = L²/(L² + 12 EI_z/GA_y), μ_y = L²/(L² + 12 EI_y/GA_z), from the section block.

    ``section`` maps names of :data:`conventions.SECTION_NAMES` to symbols or numbers; a missing
    compliance (cGAy, cGAz) is 0, i.e. μ = 1.
    """
    L = section["L0"]
    cy, cz = section.get("cGAy", 0), section.get("cGAz", 0)
    return L**2 / (L**2 + 12 * section["EIz"] * cy), L**2 / (L**2 + 12 * section["EIy"] * cz)


def transverse_fields(psi, shear=(1, 1)):
    """v/L, w/L and the section rotations θ_z, θ_y along the element, as polynomials in ξ.

    ``shear`` = (μ_z, μ_y) (:func:`shear_factor_definitions`; 1 gives the Hermite cubics,
    Eqs. 23–24).  θ_z = v_x and θ_y = −w_x when μ = 1 (Euler–Bernoulli).
    """
    phi_y1, phi_z1, phi_y2, phi_z2, _, _ = psi
    (n1, n2), (r1, r2) = interdependent_shapes()
    fields = []
    for mu, phi1, phi2, sign in ((shear[0], phi_z1, phi_z2, 1), (shear[1], phi_y1, phi_y2, -1)):
        at = {SHEAR_FACTOR: mu}
        fields.append((sign * (n1.subs(at) * phi1 + n2.subs(at) * phi2), r1.subs(at) * phi1 + r2.subs(at) * phi2))
    (v, theta_z), (w, theta_y) = fields
    return v, w, theta_z, theta_y


def displacement_field(psi, L, rotary_inertia: bool, shear=(1, 1), twist_origin=0):
    """u_c = N Ψ (Eqs. 44–45, corrected), components along the corotational axes.

    v, w the Hermite cubics of Eqs. 23–24 (Euler–Bernoulli, ``shear`` = (1, 1)) or the
    IIE shapes (:func:`interdependent_shapes`, ``shear`` = (μ_z, μ_y)), a linear twist
    (Eq. 40's assumption) and a linear stretch; a plane section turns by its own
    rotations θ_z, θ_y (= v_x, −w_x without shear) and twists by (ξ − ξ₀) φx2 against T_c:

        u = ξ α − y θ_z + z θ_y,  v = L(n1 φz1 + n2 φz2) − z (ξ − ξ₀) φx2,
        w = −L(n1 φy1 + n2 φy2) + y (ξ − ξ₀) φx2

    ``twist_origin`` ξ₀ is where the section is untwisted against T_c: 0 for node 1's frame
    (φ_x¹ = 0 by Eq. 11), ½ for the mean frame (the ends at ∓½φx2 + O(θ³), docs/derivation.md,
    "Bending–twist coupling"; with ξ₀ = 0 there the twist rate of every section would be off by
    ½φ̇x2, and the kinetic energy by O(h)).
    """
    phi_x2, alpha = psi[4], psi[5]
    v, w, theta_z, theta_y = transverse_fields(psi, shear)
    v, w = L * v, L * w
    if rotary_inertia:
        u = xi * alpha - ys * theta_z + zs * theta_y
        v = v - zs * (xi - twist_origin) * phi_x2
        w = w + ys * (xi - twist_origin) * phi_x2
    else:
        u = xi * alpha
    return sp.Matrix([u, v, w])


# --------------------------------------------------------------------------
# Strain energy, Eqs. 22–43
# --------------------------------------------------------------------------
def bending_shear_energy(EI, mu, L, phi1, phi2):
    """Bending plus shear energy of one plane, (EI/2L)∫₀¹[ψ_ξ² + (Φ/12) ψ_ξξ²] dξ, with the IIE ψ.

    With GA γ = −EI ψ_xx (:func:`interdependent_shapes`), ½∫GAγ² dx = (EI Φ/24L)∫ψ_ξξ² dξ, so
    U = EI/(2L(1+Φ)) [(4+Φ)(φ_1² + φ_2²) + 2(2−Φ) φ_1 φ_2]   (Reddy 1997, Eq. 22; asserted here)
      = (EI/2L) [(1 + 3μ)(φ_1² + φ_2²) + 2(3μ − 1) φ_1 φ_2],   μ = 1/(1 + Φ).
    At μ = 1 this is the Euler–Bernoulli energy of Eqs. 28–31, (EI/2L)[4φ_1² + 4φ_1φ_2 + 4φ_2²].
    """
    Phi_, mu_ = SHEAR_PARAMETER, SHEAR_FACTOR
    _, (r1, r2) = interdependent_shapes()
    rotation = r1 * phi1 + r2 * phi2
    density = sp.diff(rotation, xi) ** 2 + (1 / mu_ - 1) / 12 * sp.diff(rotation, xi, 2) ** 2
    U = _integrate_unit(density) * EI / (2 * L)
    reddy = EI / (2 * L * (1 + Phi_)) * ((4 + Phi_) * (phi1**2 + phi2**2) + 2 * (2 - Phi_) * phi1 * phi2)
    assert sp.cancel(U - reddy.subs(Phi_, 1 / mu_ - 1)) == 0, "IIE energy differs from Reddy's closed form"
    U = EI / (2 * L) * ((1 + 3 * mu_) * (phi1**2 + phi2**2) + 2 * (3 * mu_ - 1) * phi1 * phi2)
    assert sp.cancel(U - reddy.subs(Phi_, 1 / mu_ - 1)) == 0
    return U.subs(mu_, mu)


def mean_axial_strain(psi, section, formulation: Formulation, shear=None):
    """ε̄ = ∫₀¹ ε^s dξ, ε^s = α/L + ½(v_x² + w_x²) (Eq. 35; without geometric stiffening α/L).

    The slopes v_x, w_x are those of the deflection (not the section rotation), from the
    shapes ``formulation.stiffening_shapes``: Hermite (Eqs. 23–26) or IIE with ``shear`` =
    (μ_z, μ_y) (default: :func:`shear_factor_definitions` of ``section``).  For Hermite slopes
    the mean is α/L + [4(φz1² + φy1²) − 2(φz1φz2 + φy1φy2) + 4(φz2² + φy2²)]/60.
    """
    alpha, L = psi[5], section["L0"]
    strain = alpha / L
    if not formulation.geometric_stiffening:
        return strain
    if formulation.stiffening_shapes == "hermite":
        shear = (1, 1)
    elif shear is None:
        shear = shear_factor_definitions(section)
    v, w, _, _ = transverse_fields(psi, shear)  # v/L, w/L: d/dξ gives v_x, w_x
    return strain + _integrate_unit((sp.diff(v, xi) ** 2 + sp.diff(w, xi) ** 2) / 2)


def strain_energy(psi, section, formulation: Formulation, shear=None) -> sp.Expr:
    """U(Ψ) whose gradient gives F_i^e (Eq. 43) through the B-matrices.

    * Bending and shear (Eqs. 28–31 generalised): per plane U = EI/(2L(1+Φ))[(4+Φ)(φ1² + φ2²)
      + 2(2−Φ)φ1φ2] (:func:`bending_shear_energy`), Φ_z = 12 EI_z/(GA_y L²) for φ_z (deflection
      along y), Φ_y = 12 EI_y/(GA_z L²) for φ_y; shear-rigid (1/GA = 0): Φ = 0, Euler–Bernoulli,
      U_b = (EI_z/2L)[4φz1² + 4φz1φz2 + 4φz2²] + (EI_y/2L)[same in φy].  ``shear`` = (μ_z, μ_y),
      μ = 1/(1 + Φ), as expressions or symbols (default: :func:`shear_factor_definitions`).
    * Stretching (Eqs. 34–38): ε^s = α/L + ½(v_x² + w_x²); we use its element
      mean ε̄ = ∫₀¹ ε^s dξ (:func:`mean_axial_strain`) and U_s = ½ EA L ε̄².  Its gradient is
      Eq. 37 with ε_m → ε̄ (same to first order) and is conservative, which Eq. 37's
      mixed use of ε_m and ε^s is not.  Without geometric stiffening ε̄ = α/L.
    * Twist (Eqs. 40–41): U_t = (GJ/2L) φx2².
    """
    phi_y1, phi_z1, phi_y2, phi_z2, phi_x2, alpha = psi
    L, EA, EIy, EIz, GJ = (section[k] for k in ("L0", "EA", "EIy", "EIz", "GJ"))
    mu_z, mu_y = shear_factor_definitions(section) if shear is None else shear
    U_bending = bending_shear_energy(EIz, mu_z, L, phi_z1, phi_z2) + bending_shear_energy(EIy, mu_y, L, phi_y1, phi_y2)
    U_stretch = EA * L * mean_axial_strain(psi, section, formulation, (mu_z, mu_y)) ** 2 / 2
    U_twist = GJ * phi_x2**2 / (2 * L)
    return U_bending + U_stretch + U_twist


def section_forces(psi, section, formulation: Formulation, shear=None):
    """Axial force EA ε̄, torque, bending moments about local y and z at mid-element.

    The moment EI ψ_x at ξ = ½ is EI(φ2 − φ1)/L for the Hermite and the IIE rotation alike
    (ψ is at most quadratic, and a quadratic's slope at mid-interval is its mean slope).
    """
    phi_y1, phi_z1, phi_y2, phi_z2, phi_x2, alpha = psi
    L, EA, EIy, EIz, GJ = (section[k] for k in ("L0", "EA", "EIy", "EIz", "GJ"))
    strain = mean_axial_strain(psi, section, formulation, shear)
    return [EA * strain, GJ * phi_x2 / L, EIy * (phi_y2 - phi_y1) / L, EIz * (phi_z2 - phi_z1) / L]


# --------------------------------------------------------------------------
# Inertia in the corotational frame, Eqs. 44–57
# --------------------------------------------------------------------------
def integrate_over_element(expr, section, L):
    """ρ∫_V expr dV for a polynomial in ξ, y, z: L∫₀¹dξ, and the section moments
    ∫ρ dA = ρA, ∫ρ y dA = ∫ρ z dA = ∫ρ yz dA = 0 (centroidal principal axes),
    ∫ρ y² dA = ρI_z, ∫ρ z² dA = ρI_y."""
    poly = sp.Poly(sp.expand(expr), xi, ys, zs)
    moments = {(0, 0): section["rhoA"], (2, 0): section["rhoIz"], (0, 2): section["rhoIy"]}
    total = sp.Integer(0)
    for (p, qy, qz), coeff in poly.terms():
        moment = moments.get((qy, qz))
        if moment is None:  # odd or mixed section moments vanish; none above second order occur
            continue
        total += coeff * moment * L / (p + 1)
    return sp.expand(total)


PSI = sp.symbols("psi_0:6", real=True)  # Ψ as plain symbols for the local (frame-free) expressions
QUASI_VELOCITY = sp.symbols("u_0:12", real=True)


def local_inertia(formulation: Formulation):
    """:func:`section_inertia` of the switches of ``formulation`` it depends on: variants that
    differ elsewhere (rotation measure, stiffening, plane) share one derivation per process."""
    return section_inertia(formulation.rotary_inertia, formulation.inertia_shapes,
                           TWIST_ORIGIN[formulation.corotational_frame])


#: ξ₀ of :func:`displacement_field` for each corotational frame: where the section is untwisted against T_c
TWIST_ORIGIN = {"first_node": 0, "mean": sp.Rational(1, 2)}


@lru_cache(maxsize=None)
def section_inertia(rotary_inertia: bool, inertia_shapes: str, twist_origin=0):
    """Mass matrix M̂(Ψ) and gyroscopic vector ĝ(Ψ, u) in the corotational frame.

    Quasi-velocities u = [v̂, ω̂, Ψ̇] (12): velocity of grid point 1 and angular
    velocity of S_c in corotational components, and deformation rates.  A
    material point sits at r* = L r_c + N Ψ (Eq. 47), so

        V̂ = Γ u,   Γ = [I, −skew(r*), N]                     (Eqs. 50–51)
        Â = Γ u̇ + Γ̇ u + ω̂ × Γ u,   Γ̇ = [0, −skew(NΨ̇), 0]        (Eqs. 52–53)
        M̂ = ρ∫ Γᵀ Γ dV,   ĝ = ρ∫ Γᵀ (Γ̇ u + ω̂ × Γ u) dV            (Eqs. 56–57)

    Expressions in :data:`PSI`, :data:`QUASI_VELOCITY`, the section symbols and, with
    ``inertia_shapes="interdependent"``, the shear factors :data:`SHEAR_FACTORS` (the IIE
    shapes of :func:`displacement_field`; μ = 1 gives the Hermite mass exactly); ``twist_origin``
    ξ₀ as in :func:`displacement_field` (:data:`TWIST_ORIGIN` of the corotational frame).
    Returns (M̂, ĝ, ∂ĝ/∂u, S, P) with S = ρ∫Γ dV (3×12, used by gravity) and
    P = ρ∫r* dV (mass × centroid offset in S_c).
    """
    from .conventions import SECTION, SECTION_NAMES

    section = dict(zip(SECTION_NAMES, SECTION.symbols()))
    psi, quasi_velocity = PSI, QUASI_VELOCITY
    L = section["L0"]
    # IIE shapes are polynomials in the shear factors μ_z, μ_y, which stay symbols (SHEAR_FACTORS)
    shear = SHEAR_FACTORS if inertia_shapes == "interdependent" else (1, 1)
    N_psi = displacement_field(psi, L, rotary_inertia, shear, twist_origin)
    if rotary_inertia:
        r_c = sp.Matrix([L * xi, ys, zs])
    else:
        r_c = sp.Matrix([L * xi, 0, 0])
    r_star = r_c + N_psi
    N = N_psi.jacobian(sp.Matrix(psi))
    def skew_sp(w):
        return sp.Matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    Gamma = sp.Matrix.hstack(sp.eye(3), -skew_sp(r_star), N)
    u = sp.Matrix(quasi_velocity)
    omega = u[3:6, 0]
    psi_dot = u[6:12, 0]
    Gamma_dot = sp.Matrix.hstack(sp.zeros(3, 3), -skew_sp(N * psi_dot), sp.zeros(3, 6))
    V = Gamma * u
    convective = Gamma_dot * u + omega.cross(V)
    mass = sp.zeros(12, 12)
    for i in range(12):
        for j in range(i, 12):
            mass[i, j] = mass[j, i] = integrate_over_element(Gamma[:, i].dot(Gamma[:, j]), section, L)
    gyroscopic = sp.Matrix([integrate_over_element(Gamma[:, i].dot(convective), section, L) for i in range(12)])
    first_moment = sp.Matrix(
        [[integrate_over_element(Gamma[k, i], section, L) for i in range(12)] for k in range(3)]
    )
    position_moment = sp.Matrix([integrate_over_element(r_star[k], section, L) for k in range(3)])
    gyroscopic_D_u = gyroscopic.jacobian(u)
    return mass, gyroscopic, gyroscopic_D_u, first_moment, position_moment
