"""One evaluation of the equations of motion: the residual on the free coordinates, the reactions
on the constrained ones, the power of the point loads, the hinges' torques whose work the energy
balance integrates, and the element, body, hinge and load blocks
of the mass, damping and stiffness matrices, assembled on demand, separately or combined
(``combined(cm, cc, ck)`` = cm·M + cc·C + ck·K)."""
from __future__ import annotations

from dataclasses import field

import numpy as np

from latdyn.records import record


class SeparateMatrices:
    """M, C and K one by one (sparse), from an evaluation's ``combined(cm, cc, ck)``."""

    @property
    def mass(self):
        return self.combined(1.0, 0.0, 0.0, dense=False)

    @property
    def damping(self):
        return self.combined(0.0, 1.0, 0.0, dense=False)

    @property
    def stiffness(self):
        return self.combined(0.0, 0.0, 1.0, dense=False)


@record
class Evaluation(SeparateMatrices):
    """Residual, reactions, and (on request) the blocks of M, C = ∂r/∂v and K = ∂r/∂q.

    K omits the derivative of the inertia forces with respect to q (see
    integrators.py).  Matrices on the free coordinates are assembled on demand:
    ``mass``, ``damping``, ``stiffness``, or ``combined(cm, cc, ck)`` = cm M + cc C + ck K
    in one scatter (the Newton iteration matrix).
    """

    residual: np.ndarray  # (n_dofs,)
    reaction: np.ndarray  # (n_total - n_dofs,) generalized force needed on constrained coordinates
    external_power: float = 0.0  # the power of point loads on the current velocities
    #: per cable element (ce, 4): [ℓ, L0, ∂U/∂L0, f], its length and share of the rest length, the
    #: rest length's generalized force (a reel's) and its damper's dissipative force
    #: (latdyn.timeloop.progress.cable_work)
    cable_work: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    #: per hinge: the torque that does external work (λ τ and a continuous controller's output, less
    #: k s of a spring that is not conservative) and the dissipative torque (c θ̇, a compliant stop's
    #: damping, friction) (latdyn.timeloop.progress.hinge_work)
    hinge_work_torque: np.ndarray = field(default_factory=lambda: np.zeros(0))
    hinge_damper_torque: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: kind -> [element (e,14,14), body (b,6,6), hinge diag, load and cable element blocks, controller couplings (c,)]
    blocks: dict | None = None
    assembler: object = None  # the Assembler that made it: its scatter maps assemble the blocks

    def combined(self, cm: float, cc: float, ck: float, dense: bool | None = None):
        return self.assembler.assemble(self._combined_parts(cm, cc, ck), dense)

    def combined_csr(self, cm: float, cc: float, ck: float):
        """:meth:`combined` as a :class:`latdyn.numerics.csr.CSR` (no SciPy; no rigid links)."""
        return self.assembler.assemble_csr(self._combined_parts(cm, cc, ck))

    def _combined_parts(self, cm: float, cc: float, ck: float) -> list:
        parts = None
        for coefficient, kind in ((cm, "mass"), (cc, "damping"), (ck, "stiffness")):
            if coefficient == 0.0:
                continue
            scaled = [coefficient * np.asarray(b) for b in self._flat(kind)]
            parts = scaled if parts is None else [a + b for a, b in zip(parts, scaled)]
        if parts is None:
            parts = [0.0 * np.asarray(b) for b in self._flat("stiffness")]
        return parts

    def flat_blocks(self, kind: str) -> list:
        """The blocks of ``kind`` ("mass", "damping", "stiffness") masked to the free coordinates, in the order
        :meth:`latdyn.assembly.assembler.Assembler.assemble` scatters them: [elements, bodies, hinges, loads and
        cable elements, controller couplings] (latdyn/analyses/weight_derivative.py assembles a part of them)."""
        return [np.asarray(b) for b in self._flat(kind)]

    def _flat(self, kind):
        element, body, hinge, loads, couplings = self.blocks[kind]
        a = self.assembler
        return [element[a._elem_mask], body[a._body_mask], hinge, np.ravel(loads), couplings]
