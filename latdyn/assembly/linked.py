"""The equations of motion of a model with rigid links, on its minimum coordinates.

The blocks are assembled on the independent *and* the dependent nodes' coordinates, then
reduced by the projection P = [I; J] of :mod:`latdyn.model.links` (its module docstring has
the equations): r_min = Pᵀ r_all, M_min = Pᵀ M P, C_min = Pᵀ (C P + M_·dep ∂c/∂v),
K_min = Pᵀ K P + ∂(Pᵀ)/∂q · r_all.
"""
from __future__ import annotations

import numpy as np

from latdyn.assembly.evaluation import Evaluation, SeparateMatrices
from latdyn.numerics.linalg import DENSE_LIMIT


def _is_dense(dense, n):
    return n <= DENSE_LIMIT if dense is None else dense


class LinkedEvaluation(SeparateMatrices):
    """An :class:`latdyn.assembly.assembler.Evaluation` on the minimum coordinates of a model with rigid
    links: the blocks are assembled on the independent and dependent coordinates and reduced
    by the projection P (module docstring)."""

    def __init__(self, residual, reaction, external_power, blocks, assembler, hinge_work_torque=None,
                 hinge_damper_torque=None, dissipation_power: float = 0.0):
        self.residual, self.reaction, self.external_power = residual, reaction, external_power
        self.hinge_work_torque = np.zeros(0) if hinge_work_torque is None else hinge_work_torque
        self.hinge_damper_torque = np.zeros(0) if hinge_damper_torque is None else hinge_damper_torque
        self.dissipation_power = dissipation_power
        self.blocks, self.assembler = blocks, assembler
        self.projection = self.geometric = self.velocity_derivative = self.dependent_rows = None
        self._mass_all = self._dense = None

    def _assembled(self, cm, cc, ck, dense):
        raw = Evaluation(residual=None, reaction=None, blocks=self.blocks, assembler=self.assembler)
        return raw.combined(cm, cc, ck, dense=dense)

    def combined(self, cm: float, cc: float, ck: float, dense: bool | None = None):
        import scipy.sparse as sps  # on use: only models with rigid links need it

        P = self.projection
        n_asm, n = P.shape
        small = n_asm <= DENSE_LIMIT  # small models: dense products (sparse overhead dominates)
        if small:
            if self._dense is None:
                self._dense = (P.toarray(), self.geometric.toarray(), self.velocity_derivative.toarray())
            P, geometric, velocity_derivative = self._dense
        else:
            geometric, velocity_derivative = self.geometric, self.velocity_derivative
        out = P.T @ self._assembled(cm, cc, ck, small) @ P
        if cc != 0.0 and len(self.dependent_rows):
            if self._mass_all is None:
                self._mass_all = self._assembled(1.0, 0.0, 0.0, small)
            coupling = self._mass_all[:, self.dependent_rows] @ velocity_derivative  # M_·dep ∂c/∂v
            out = out + cc * (P.T @ coupling)
        if ck != 0.0:
            out = out + ck * geometric
        if _is_dense(dense, n):
            return out if small else out.toarray()
        return sps.csr_matrix(out)


def evaluate_linked(links, assembler, state, matrices: bool, load_factor: float, inertia: bool,
                    inertia_tangent: bool = False, length: float = 1.0):
    """The equations of motion on the minimum coordinates (module docstring)."""
    links.complete(state)
    full = assembler.evaluate_assembled(state, matrices, load_factor, inertia, inertia_tangent, length)
    return reduce_linked(links, assembler, state, full, matrices, inertia)


def reduce_linked(links, assembler, state, full, matrices: bool, inertia: bool) -> LinkedEvaluation:
    """``full``, the evaluation on the independent and dependent coordinates at ``state`` (its
    dependent nodes completed), reduced onto the minimum coordinates (module docstring)."""
    import scipy.sparse as sps  # on use: only models with rigid links need it

    model = assembler.model
    n, n_asm, n_total = model.n_dofs, model.n_assembled, model.n_total
    columns, twist = links.twists(model, state)
    n_dep = len(links.dependent)
    J = np.zeros((6 * n_dep, len(columns)))
    for k, c in enumerate(links.dependent):
        J[6 * k:6 * k + 3] = links.point_jacobian(twist[c], state.x[c])
        J[6 * k + 3:6 * k + 6] = twist[c][3:]
    dep_rows = model.node_dofs[links.dependent].ravel()  # n ≤ index < n_asm, in order
    assert np.all((dep_rows >= n) & (dep_rows < n_asm))
    r_dep = full.residual[dep_rows]  # tree order, like the rows of J
    free_cols = columns < n
    residual = full.residual[:n].copy()
    residual[columns[free_cols]] += J[:, free_cols].T @ r_dep
    reaction = np.zeros(n_total - n)
    reaction[n_asm - n:] = full.reaction
    constrained = columns >= n_asm
    reaction[columns[constrained] - n] += J[:, constrained].T @ r_dep
    out = LinkedEvaluation(residual=residual, reaction=reaction, external_power=full.external_power,
                           blocks=full.blocks, assembler=assembler,
                           hinge_work_torque=full.hinge_work_torque, hinge_damper_torque=full.hinge_damper_torque,
                           dissipation_power=full.dissipation_power)
    if matrices:
        Jf = J[:, free_cols]
        rows = np.concatenate([np.arange(n), dep_rows[np.repeat(np.arange(6 * n_dep), Jf.shape[1])]])
        cols = np.concatenate([np.arange(n), np.tile(columns[free_cols], 6 * n_dep)])
        P = sps.csr_matrix((np.concatenate([np.ones(n), Jf.ravel()]), (rows, cols)), shape=(n_asm, n))
        out.projection = P
        out.geometric = links.geometric_stiffness(model, state, columns, twist, full.residual, n)
        out.velocity_derivative = (links.convective_derivative(model, state, columns) if inertia
                                   else sps.csr_matrix((6 * n_dep, n)))
        out.dependent_rows = dep_rows
    return out
