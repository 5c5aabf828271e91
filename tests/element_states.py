"""Random element states for derivative and invariance checks.

An element end is a joint body (reference point x, rotation T_j), a grid point
at body offset r_g, a hinge of body axis a with angle θ, and the nodal frame
E0 of the undeformed element in body axes, so T_e = T_j R(a, θ) E0 (Eq. 17).
Coordinates change as x ← x + Δd, T_j ← exp(skew Δπ) T_j, θ ← θ + Δθ.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation


def skew(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def expm_so3(w):
    return Rotation.from_rotvec(np.asarray(w, dtype=float)).as_matrix()


@dataclass
class End:
    x: np.ndarray
    body: np.ndarray  # T_j
    offset: np.ndarray  # r_g in body axes
    axis: np.ndarray  # hinge axis in body axes (unit) or zero
    frame0: np.ndarray  # E0: nodal frame at θ = 0 in body axes
    theta: float = 0.0

    def nodal_frame(self):
        hinge = expm_so3(self.axis * self.theta)
        return self.body @ hinge @ self.frame0

    def moved(self, dq):
        return replace(self, x=self.x + dq[0:3], body=expm_so3(dq[3:6]) @ self.body, theta=self.theta + dq[6])


@dataclass
class ElementState:
    end1: End
    end2: End
    section: np.ndarray  # (10,) L0 EA EIy EIz GJ rhoA rhoIy rhoIz 1/GAy 1/GAz

    def geometry(self):
        e1, e2 = self.end1, self.end2
        return np.concatenate([
            e1.x, e2.x, e1.body @ e1.offset, e2.body @ e2.offset,
            e1.nodal_frame().ravel(), e2.nodal_frame().ravel(),
            e1.body @ e1.axis, e2.body @ e2.axis,
        ])[None, :]

    def moved(self, dq):
        dq = np.asarray(dq, dtype=float)
        return replace(self, end1=self.end1.moved(dq[0:7]), end2=self.end2.moved(dq[7:14]))


#: 1/GAy, 1/GAz of the random states: shear parameters Φ = 12 EI/(GA L²) ≈ 0.3 for L = 1.7 (EIz = 30,
#: EIy = 20), so every derivative check runs with shear-deformable (IIE) sections
SHEAR_COMPLIANCES = (1 / 400.0, 1 / 300.0)


def undeformed(rng, length=1.7, offsets=True, hinges=True, section=None):
    """An element lying undeformed between two joint bodies, with offsets and hinge axes."""
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    y = np.cross(rng.normal(size=3), direction)
    y /= np.linalg.norm(y)
    frame0 = np.column_stack([direction, y, np.cross(direction, y)])
    g1 = rng.normal(size=3)
    g2 = g1 + length * direction
    r1 = rng.normal(size=3) * 0.3 if offsets else np.zeros(3)
    r2 = rng.normal(size=3) * 0.3 if offsets else np.zeros(3)
    a1 = rng.normal(size=3) if hinges else np.zeros(3)
    a2 = rng.normal(size=3) if hinges else np.zeros(3)
    if hinges:
        a1 /= np.linalg.norm(a1)
        a2 /= np.linalg.norm(a2)
    if section is None:
        section = np.array([length, 3.0e3, 20.0, 30.0, 15.0, 1.3, 0.02, 0.03, *SHEAR_COMPLIANCES])
    return ElementState(
        End(g1 - r1, np.eye(3), r1, a1, frame0), End(g2 - r2, np.eye(3), r2, a2, frame0), section
    )


#: Families of random states for the derivative checks: ``deformation`` scales the end
#: rotations (≈ 1.6·deformation rad) and displacements against the element's rigid motion.
#: "near_identity" puts the log map's argument x = 1 − cos θ at ≈ 1e-14 (its series branch),
#: "moderate" at ≈ 1e-2 (series), "large" at ≈ 0.3 (closed form, local rotations up to ≈ 70°).
REGIMES = {"near_identity": 1e-7, "moderate": 0.05, "large": 0.4}


def random_state(rng, deformation=0.05, **kw):
    """Large rigid rotation (> 90°), non-zero hinge angles, elastic deformation of size ``deformation``."""
    state = undeformed(rng, **kw)
    rigid = Rotation.from_rotvec(rng.normal(size=3) * 0.5 + np.array([2.0, 0.0, 0.0])).as_matrix()
    shift = rng.normal(size=3)

    def move(end, theta):
        body = rigid @ expm_so3(rng.normal(size=3) * deformation)
        x = rigid @ end.x + shift + rng.normal(size=3) * deformation
        return replace(end, x=x, body=body, theta=theta)

    t1, t2 = (rng.normal(size=2) * 0.8) if np.any(state.end1.axis) else (0.0, 0.0)
    # a hinge angle of the body frame must be compensated so the element stays mildly deformed
    e1 = move(state.end1, t1)
    e1 = replace(e1, body=e1.body @ expm_so3(-state.end1.axis * t1))
    e2 = move(state.end2, t2)
    e2 = replace(e2, body=e2.body @ expm_so3(-state.end2.axis * t2))
    return replace(state, end1=e1, end2=e2)


def bent_state(rng, angle, in_plane=False, length=1.7, section=None):
    """Ends turned by ``angle`` (rad) against the chord, under a random rigid motion; no offsets or hinges.

    ``in_plane``: end 1 stays on the chord and end 2 turns about the element's z axis,
    so T_cᵀT_e is I at end 1 and exactly the rotation ``angle`` about z at end 2.
    Otherwise both ends turn by ``angle`` about random axes.
    """
    state = undeformed(rng, length=length, offsets=False, hinges=False, section=section)
    rigid = expm_so3(rng.normal(size=3) * 1.5)
    z = state.end1.frame0[:, 2]
    ends = []
    for k, end in enumerate((state.end1, state.end2)):
        if in_plane:
            turn = expm_so3(angle * z) if k == 1 else np.eye(3)
        else:
            axis = rng.normal(size=3)
            turn = expm_so3(angle * axis / np.linalg.norm(axis))
        ends.append(replace(end, x=rigid @ end.x, body=rigid @ turn))
    return replace(state, end1=ends[0], end2=ends[1])
