"""The argument blocks shared by every generated kernel (see docs/architecture.md).

Changing an entry here changes the ABI of every backend at once: the NumPy and
C printers and the runtime's packing code all index these blocks.
"""
from __future__ import annotations

from .ir import Argument

GEOMETRY = Argument(
    "geometry",
    36,
    "x1[3] x2[3] offset1[3] offset2[3] frame1[9] frame2[9] axis1[3] axis2[3]: reference points of "
    "the joint bodies, global offsets to the grid points (Eq. 2), nodal frames T_e^i row-major "
    "(Eq. 17), global unit hinge axes (zero for a clamped end)",
)
VELOCITY = Argument(
    "velocity",
    14,
    "[v1[3] w1[3] thetadot1 v2[3] w2[3] thetadot2]: reference-point velocities, spatial angular "
    "velocities of the joint bodies, hinge rates (order of q^e, Eq. 59)",
)
SECTION = Argument(
    "section",
    10,
    "L0 EA EIy EIz GJ rhoA rhoIy rhoIz cGAy cGAz: undeformed length, stiffnesses, inertia per length, and "
    "shear compliances cGAy = 1/GAy (deflection along local y, paired with EIz) and cGAz = 1/GAz "
    "(along local z, paired with EIy); 0 = shear-rigid (Euler-Bernoulli)",
)
ACCELERATION = Argument(
    "acceleration",
    14,
    "[a1[3] alpha1[3] thetaddot1 a2[3] alpha2[3] thetaddot2]: accelerations of the reference points, spatial "
    "angular accelerations of the joint bodies, hinge accelerations (order of q^e, Eq. 59)",
)
GRAVITY = Argument("gravity", 3, "uniform gravity acceleration, global")
REFERENCE = Argument(
    "reference",
    25,
    "[dx1[3] dx2[3] doffset1[3] doffset2[3] psi1[3] psi2[3] dL0 daxis1[3] daxis2[3]]: one variation of the "
    "element's reference data at a fixed configuration: the reference points moved (ends whose node is no "
    "coordinate), the global offsets to the grid points moved, the nodal frames turned by exp(skew psi_i) "
    "(spatial), the undeformed length changed, the global hinge axes moved (geometry parameters, "
    "docs/parameters.md)",
)

# Slices into the geometry block.
X1, X2 = slice(0, 3), slice(3, 6)
OFFSET1, OFFSET2 = slice(6, 9), slice(9, 12)
FRAME1, FRAME2 = slice(12, 21), slice(21, 30)
AXIS1, AXIS2 = slice(30, 33), slice(33, 36)

# Slices into the reference-variation block.
REF_X1, REF_X2 = slice(0, 3), slice(3, 6)
REF_OFFSET1, REF_OFFSET2 = slice(6, 9), slice(9, 12)
REF_PSI1, REF_PSI2 = slice(12, 15), slice(15, 18)
REF_L0 = 18
REF_AXIS1, REF_AXIS2 = slice(19, 22), slice(22, 25)

# Slices into the element coordinate vector q^e (and velocity block).
D1, PI1, THETA1 = slice(0, 3), slice(3, 6), 6
D2, PI2, THETA2 = slice(7, 10), slice(10, 13), 13
N_ELEMENT_COORDINATES = 14

SECTION_NAMES = ("L0", "EA", "EIy", "EIz", "GJ", "rhoA", "rhoIy", "rhoIz", "cGAy", "cGAz")
