"""The exact iteration matrix of the transient sensitivities' step, S = β′M + γ′C + K J, assembled
from value arrays on a pattern built once per numbering and factorized with the held storage of
:class:`latdyn.assembly.factorization.Factorization` (no SciPy in the step).

M, C and K come as the values of the assembler's pattern (its CSR indptr and indices, structural zeros
kept: :meth:`latdyn.assembly.assembler.Assembler.exact_matrix_values`). J = dexp(hΔq) is the identity
off the free nodes' rotation coordinates and a 3 × 3 block J_f on node f's rotations s_f = (s_0, s_1,
s_2), so K J equals K except in the rotation columns, where

    (K J)[r, s_j] = Σ_i K[r, s_i] J_f[i, j]       (i, j over the node's free rotation coordinates).

The pattern of S is K's with, in each row, every rotation column of a node where K has one (the same
pattern but where a row meets a node's rotations in part, as a controller's coupling may). Per step:
S's values are β′M + γ′C + K off the rotation columns plus one gather–multiply–add of the products
above, in the order SciPy's ``β′M + γ′C + K @ J`` adds them (so the same values, bit for bit where the
patterns agree); then the factorization of that storage (dense, band or the supernodal LU, chosen for
the pattern) and the solves of its columns.
"""
from __future__ import annotations

import numpy as np

from latdyn.assembly.factorization import Factorization

__all__ = ["ExactStepMatrix"]


class ExactStepMatrix:
    """S = β′M + γ′C + K J on n free coordinates (module docstring), for K's pattern (``indptr``,
    ``indices``) and the free nodes' rotation coordinates ``slots`` (f, 3; ≥ n: not a coordinate)."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, n: int, slots: np.ndarray):
        self.n = n
        rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
        cols = np.asarray(indices, np.int64)
        nnz = len(cols)
        node, place = np.full(n + 1, -1, np.int64), np.full(n + 1, -1, np.int64)
        on = slots < n
        node[slots[on]], place[slots[on]] = np.nonzero(on)
        rotation = node[cols] >= 0
        # K's entries in a rotation column s_i of node f: one term K[r, s_i] J_f[i, j] for each j
        entry = np.flatnonzero(rotation)
        f, i = node[cols[entry]], place[cols[entry]]
        term_rows = np.repeat(rows[entry], 3)
        term_cols = slots[f].ravel()
        term_entry = np.repeat(entry, 3)
        term_block = (f * 9 + i * 3)[:, None] + np.arange(3)
        keep = term_cols < n
        keys = np.concatenate([rows * n + cols, term_rows[keep] * n + term_cols[keep]])
        unique, inverse = np.unique(keys, return_inverse=True)
        inverse = inverse.ravel()
        self.rows, self.cols = unique // max(n, 1), unique % max(n, 1)
        self.size = len(unique)
        #: where M, C and K's entries lie in S's values; K's off the rotation columns
        self._into = inverse[:nnz]
        self._plain = np.flatnonzero(~rotation)
        #: the products' K entries, J entries (in the blocks flattened) and places in S's values, ordered
        #: by place, then by K's column (SciPy's order of the sum)
        term_place = inverse[nnz:]
        order = np.argsort(term_place, kind="stable")
        self._term_entry = term_entry[keep][order]
        self._term_block = term_block.ravel()[keep][order]
        self._term_place = term_place[order]
        self.factorization = Factorization(self.rows, self.cols, n)
        import scipy.sparse as sps   # on use, as in latdyn.assembly.assembler

        indptr = np.asarray(indptr, np.int64)
        #: C and K of the last :meth:`factor` (SciPy CSR on K's pattern: their values replaced each step)
        self.damping, self.stiffness = (sps.csr_matrix((np.zeros(nnz), cols, indptr), shape=(n, n)) for _ in range(2))

    def values(self, values: np.ndarray, blocks: np.ndarray, beta_p: float, gamma_p: float) -> np.ndarray:
        """S's values on its pattern (``rows``, ``cols``) from ``values`` (3, nnz: M, C, K on K's pattern)
        and the rotation blocks J_f (f, 3, 3)."""
        M, C, K = values
        S = np.zeros(self.size)
        S[self._into] = beta_p * M + gamma_p * C
        products = np.bincount(self._term_place, weights=K[self._term_entry] * blocks.reshape(-1)[self._term_block],
                               minlength=self.size)
        products[self._into[self._plain]] += K[self._plain]
        S += products
        return S

    def factor(self, values: np.ndarray, blocks: np.ndarray, beta_p: float, gamma_p: float) -> Factorization:
        """Factorize S (:meth:`values`) and keep C and K for the right-hand sides (``damping``,
        ``stiffness``); returns the factorization (``solve`` its columns). Raises
        ``np.linalg.LinAlgError`` for a singular S."""
        self.damping.data[:], self.stiffness.data[:] = values[1], values[2]
        return self.factorization.factor(self.values(values, blocks, beta_p, gamma_p))
