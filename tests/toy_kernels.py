"""Toy kernels with the shape of the real derivation, for testing the emission stage.

This module has the interface of ``codegen.derivation`` (``VARIANTS``, ``build_kernels``)
so that ``python -m codegen --derivation tests.toy_kernels`` exercises the whole
pipeline without the CR-4402 element.  The expressions cover what the printers must get
right: sqrt, division, integer powers 2 and 3, negative powers, x**(3/2), a constant
output, an output identically zero, several outputs, a (3, 3) output.

:func:`big_kernels` builds a rotation-heavy 14×14 Hessian (thousands of operations) for
measuring CSE and printing speed.
"""
from __future__ import annotations

import sympy as sp

from codegen.conventions import GEOMETRY, SECTION, VELOCITY
from codegen.ir import KernelSpec, Output

VARIANTS = {
    "default": "toy kernels, stiffening on",
    "no_stiffening": "toy kernels, stiffening off",
}


def _symbols():
    return GEOMETRY.symbols(), SECTION.symbols(), VELOCITY.symbols()


def build_kernels(variant: str) -> list[KernelSpec]:
    """Small kernels exercising every printer rule; ``variant`` changes one coefficient."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}")
    g, s, v = _symbols()
    stiffening = 1 if variant == "default" else 0
    x1 = sp.Matrix(g[0:3])
    x2 = sp.Matrix(g[3:6])
    chord = x2 - x1
    length_sq = chord.dot(chord)
    length = sp.sqrt(length_sq)
    L0, EA = s[0], s[1]
    strain = (length - L0) / L0
    force = EA * strain * chord / length
    frame1 = sp.Matrix(3, 3, g[12:21])
    frame2 = sp.Matrix(3, 3, g[21:30])
    relative = frame1.T * frame2
    kernels = [
        KernelSpec(
            name="beam_deformation",
            doc="Axial strain, chord length and a few power forms.",
            inputs=[GEOMETRY, SECTION],
            outputs=[
                Output("strain", (1,), [strain], "axial strain"),
                Output(
                    "powers",
                    (6,),
                    [
                        length_sq**2,
                        g[0] ** 3 + g[1] ** 2,
                        1 / length_sq,
                        length_sq ** sp.Rational(3, 2),
                        length_sq ** sp.Rational(-1, 2) + length_sq ** sp.Rational(1, 3),
                        g[2] ** -2 + g[2] ** -3 + stiffening * s[2] / (s[3] + 2),
                    ],
                    "power forms",
                ),
            ],
            variant=variant,
            equations="Eq. 16 (toy)",
        ),
        KernelSpec(
            name="beam_internal_force",
            doc="Axial force vector, relative rotation, constant and zero outputs.",
            inputs=[GEOMETRY, SECTION],
            outputs=[
                Output("force", (3,), list(force), "axial force along the chord"),
                Output("relative_rotation", (3, 3), list(relative), "T1^T T2"),
                Output("constant", (2,), [sp.Integer(2), sp.Rational(1, 3)], "constants"),
                Output("zero", (2, 2), [sp.Integer(0)] * 4, "identically zero"),
            ],
            variant=variant,
            equations="Eq. 30, Eq. 31 (toy)",
        ),
        KernelSpec(
            name="beam_kinetic_energy",
            doc="Kinetic energy of the translational velocities (uses velocity, not geometry axes).",
            inputs=[GEOMETRY, VELOCITY, SECTION],
            outputs=[
                Output(
                    "energy",
                    (1,),
                    [s[5] * length / 6 * (sum(vi**2 for vi in v[0:3]) + sum(vi**2 for vi in v[7:10])
                                          + sum(a * b for a, b in zip(v[0:3], v[7:10])))],
                    "kinetic energy",
                ),
            ],
            variant=variant,
            equations="Eq. 50 (toy)",
        ),
    ]
    return kernels


JOINT_DESCRIPTION = "toy joints unit: one point-load-like kernel"


def build_joint_kernels(unit: str) -> list[KernelSpec]:
    """A small ``joints`` unit in place of :mod:`codegen.joints`'s (whose derivation takes ~10 s):
    the emission of a unit shared by every variant, exercised without the real joints."""
    g, s, _ = _symbols()
    arm = sp.Matrix(g[0:3])
    force = sp.Matrix(g[3:6])
    return [KernelSpec(
        name="toy_point_load",
        doc="A force and its moment about the origin (toy).",
        inputs=[GEOMETRY, SECTION],
        outputs=[Output("wrench", (6,), list(force) + list(arm.cross(force) * s[0]), "force and moment")],
        variant=unit,
        equations="Eq. 45 (toy)",
    )]


def _rotation(phi: sp.Matrix) -> sp.Matrix:
    """Rodrigues' formula exp(skew(phi)), with sqrt and division."""
    angle = sp.sqrt(phi.dot(phi))
    k = sp.Matrix([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    return sp.eye(3) + sp.sin(angle) / angle * k + (1 - sp.cos(angle)) / angle**2 * k * k


def big_kernels(variant: str = "default") -> list[KernelSpec]:
    """A corotational-style energy of 14 coordinates and its gradient and 14×14 Hessian.

    The coordinates are ``geometry_0 … geometry_13`` (positions and rotation vectors of two
    ends plus two hinge angles); differentiation is done in SymEngine for speed.
    """
    import symengine as se

    g, s, _ = _symbols()
    q = g[0:14]
    d1, phi1, th1 = sp.Matrix(q[0:3]), sp.Matrix(q[3:6]), q[6]
    d2, phi2, th2 = sp.Matrix(q[7:10]), sp.Matrix(q[10:13]), q[13]
    frame1 = _rotation(phi1) * sp.Matrix(3, 3, g[14:23])
    frame2 = _rotation(phi2) * sp.Matrix(3, 3, g[23:32])
    offset = sp.Matrix(g[32:35])
    x1 = d1 + frame1 * offset
    x2 = d2 + sp.Matrix([1, 0, 0]) + frame2 * offset
    chord = x2 - x1
    length = sp.sqrt(chord.dot(chord))
    e1 = chord / length
    relative = frame1.T * frame2
    twist = relative[2, 1] - relative[1, 2]
    bend_y = e1.dot(frame1[:, 2]) + e1.dot(frame2[:, 2])
    bend_z = e1.dot(frame1[:, 1]) + e1.dot(frame2[:, 1])
    L0, EA, EIy, EIz, GJ = s[0:5]
    energy = (EA / 2 * (length - L0) ** 2 / L0 + GJ / 2 * twist**2 / L0
              + EIy / 2 * bend_y**2 / L0 + EIz / 2 * bend_z**2 / L0
              + (th1 - th2) ** 2 * s[5])
    energy_se = se.sympify(energy)
    q_se = [se.sympify(x) for x in q]
    gradient = [energy_se.diff(x) for x in q_se]
    hessian = [gradient[i].diff(x) for i in range(14) for x in q_se]
    to_sympy = lambda e: sp.sympify(e)  # noqa: E731
    return [
        KernelSpec(
            name="beam_big_energy",
            doc="Energy, gradient and Hessian of a toy corotational energy.",
            inputs=[GEOMETRY, SECTION],
            outputs=[
                Output("energy", (1,), [energy], "energy"),
                Output("gradient", (14,), [to_sympy(e) for e in gradient], "gradient"),
                Output("hessian", (14, 14), [to_sympy(e) for e in hessian], "Hessian"),
            ],
            variant=variant,
            equations="toy",
        )
    ]


def medium_kernel() -> KernelSpec:
    """A rotation-heavy kernel small enough for quick tests: gradient of a toy energy."""
    g, s, _ = _symbols()
    phi = sp.Matrix(g[3:6])
    rotation = _rotation(phi)
    chord = sp.Matrix(g[0:3]) + rotation * sp.Matrix(g[6:9])
    length = sp.sqrt(chord.dot(chord))
    energy = s[1] / 2 * (length - s[0]) ** 2 / s[0] + s[2] * (rotation[2, 1] - rotation[1, 2]) ** 2
    gradient = [sp.diff(energy, x) for x in g[0:9]]
    return KernelSpec(
        name="beam_medium_gradient",
        doc="Gradient of a toy energy with a rotation vector.",
        inputs=[GEOMETRY, SECTION],
        outputs=[Output("energy", (1,), [energy]), Output("gradient", (9,), gradient)],
        equations="toy",
    )
