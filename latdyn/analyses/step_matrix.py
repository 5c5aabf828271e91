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
the pattern) and, for the forward step, its right-hand sides −(∂r/∂p + K δq⁰ + C δv⁰) and their solves:
all of it one native call, ``latdyn_sensitivity_step`` of csrc/sensitivity_step.c (no NumPy or SciPy in
between), the pattern's maps built here once per numbering.
"""
from __future__ import annotations

import ctypes

import numpy as np

from latdyn.assembly.factorization import Factorization
from latdyn.assembly.library import SensitivityStepStructure, native_library
from latdyn.numerics.csr import CSR

__all__ = ["ExactStepMatrix", "turns_about_one_axis"]


class ExactStepMatrix:
    """S = β′M + γ′C + K J on n free coordinates (module docstring), for K's pattern (``indptr``,
    ``indices``) and the free nodes' rotation coordinates ``slots`` (f, 3; ≥ n: not a coordinate); ``kind``:
    the factorization's storage (:class:`~latdyn.assembly.factorization.Factorization`; None: chosen for
    the pattern, as the run's own)."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, n: int, slots: np.ndarray, kind: str | None = None):
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
        self.factorization = Factorization(self.rows, self.cols, n, kind=kind)
        indptr = np.asarray(indptr, np.int64)
        #: the native call's pattern (csrc/sensitivity_step.c ``SensitivityStep``), its arrays held here
        self._held = [np.ascontiguousarray(a, np.int64) for a in (
            indptr, cols, self._into, self._plain, self._term_entry, self._term_block, self._term_place,
            self.factorization.position(self.rows, self.cols))]
        self._summed, self._work = np.zeros(self.size), np.zeros(0)
        self._structure = SensitivityStepStructure(
            n, nnz, self.size, len(self._plain), len(self._term_place), *(a.ctypes.data for a in self._held),
            ctypes.pointer(self.factorization.structure))
        self._library = native_library()
        #: the values of C and K of the last :meth:`factor` or :meth:`solve_step` on K's pattern (replaced in
        #: place each step), and C and K as latdyn.numerics.csr's CSR sharing them (:attr:`damping`,
        #: :attr:`stiffness`: the adjoint's Cᵀ and Kᵀ, the sparse LU's failed pivot), whose products are SciPy's
        #: to the bit: importing scipy.sparse costs a fresh run ≈ 0.1 s of CPU (docs/performance.md, "A
        #: sensitivity run's start (issue 34)", "Sensitivity rows in the loop and the adjoint without SciPy's
        #: sparse package (issue 34)")
        self._held_values = np.zeros((2, nnz))
        self._held_matrices = tuple(CSR((n, n), indptr, cols, values) for values in self._held_values)

    @property
    def damping(self) -> CSR:
        """C of the last :meth:`factor` (CSR on K's pattern sharing the held values: the adjoint's Cᵀ)."""
        return self._held_matrices[0]

    @property
    def stiffness(self) -> CSR:
        """K of the last :meth:`factor` (CSR on K's pattern sharing the held values: the adjoint's Kᵀ)."""
        return self._held_matrices[1]

    def values(self, values: np.ndarray, blocks: np.ndarray, beta_p: float, gamma_p: float) -> np.ndarray:
        """S's values on its pattern (``rows``, ``cols``) from ``values`` (3, nnz: M, C, K on K's pattern)
        and the rotation blocks J_f (f, 3, 3), summed alone (``latdyn_sensitivity_step`` with k < 0)."""
        self._native(values, blocks, beta_p, gamma_p, -1)
        return self._summed.copy()

    def factor(self, values: np.ndarray, blocks: np.ndarray, beta_p: float, gamma_p: float) -> Factorization:
        """Factorize S (:meth:`values`) in one native call and keep C and K for the right-hand sides
        (``damping``, ``stiffness``); returns the factorization (``solve`` and ``solve_transposed`` its
        columns: the adjoint's reverse step). Raises ``np.linalg.LinAlgError`` for a singular S."""
        self._held_values[:] = values[1:3]
        self._factored(self._native(values, blocks, beta_p, gamma_p, 0))
        return self.factorization

    def solve_step(self, values: np.ndarray, blocks: np.ndarray, beta_p: float, gamma_p: float,
                   explicit: np.ndarray, dq0: np.ndarray, dv0: np.ndarray) -> np.ndarray:
        """z = S⁻¹(−(explicit + K dq0 + C dv0)) (n, k), each (n, k): S summed, factorised and the k columns
        formed and solved in one native call (the forward step's fixed part; C and K kept as :meth:`factor`
        keeps them). Where the sparse LU's pivot fails, the band LU with pivoting that
        :class:`~latdyn.assembly.factorization.Factorization` falls back to solves the same right-hand sides
        (formed by latdyn.numerics.csr's products: the one path the native call does not cover). Raises ``np.linalg.LinAlgError``
        for a singular S."""
        self._held_values[:] = values[1:3]
        k = explicit.shape[1]
        z = np.empty((self.n, k))
        info = self._native(values, blocks, beta_p, gamma_p, k, (explicit, dq0, dv0), z)
        if info == 0:
            return z
        self._factored(info)
        return self.factorization.solve(-(explicit + self.stiffness @ dq0 + self.damping @ dv0))

    def _native(self, values, blocks, beta_p, gamma_p, k, columns=None, z=None) -> int:
        """``latdyn_sensitivity_step`` (csrc/sensitivity_step.c): S summed into ``_summed``; k ≥ 0: loaded and
        factorised in the factorization's storage; k > 0: the columns (explicit, dq0, dv0) solved into z.
        Returns the factorization's info (0: factorised)."""
        mck = np.ascontiguousarray(values, dtype=float)
        blocks = np.ascontiguousarray(blocks, dtype=float)
        f = self.factorization
        pointers = [None] * 4
        if k > 0:
            columns = [np.ascontiguousarray(c, dtype=float) for c in columns]
            if self._work.size < 3 * self.n * k:
                self._work = np.empty(3 * self.n * k)
            pointers = [c.ctypes.data for c in columns] + [self._work.ctypes.data]
        return int(self._library.latdyn_sensitivity_step(
            ctypes.byref(self._structure), mck.ctypes.data, blocks.ctypes.data, beta_p, gamma_p,
            self._summed.ctypes.data, f.values.ctypes.data, f.pivots.ctypes.data, k, *pointers,
            None if z is None else z.ctypes.data))

    def _factored(self, info: int) -> None:
        """After the native factorization: its info 0, or the band LU with pivoting where the sparse LU's
        pivot failed, or ``np.linalg.LinAlgError`` (:meth:`Factorization.factored`)."""
        self.factorization.factored(info, self._summed.copy() if info else None)


def turns_about_one_axis(slots: np.ndarray, n: int) -> bool:
    """Whether every free node has at most one rotation coordinate among its rotation ``slots`` (f × 3; ≥ n: not
    a coordinate): a planar model, whose step maps R and J are the identity on the coordinates
    (:meth:`latdyn.analyses.transient_sensitivities.TransientSensitivities._rotation_operators`; the loop of steps likewise, sensitivities_in_loop)."""
    return bool(np.all(np.sum(slots < n, axis=1) <= 1))
