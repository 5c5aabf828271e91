"""Compressed sparse rows in NumPy, for what a run does with sparse matrices before its first step
(the held check, the consistent accelerations at t = 0) and at a latch or an impact (the impulse,
latdyn.timeloop.impulse) on a model whose step needs no SciPy sparse
matrix (a band LU up to :data:`latdyn.numerics.linalg.RCM_IN_PYTHON` coordinates): importing
``scipy.sparse`` alone costs ≈0.1 s of CPU, more than the 16-bay lattice's whole step
(docs/performance.md, "Where a run's time goes").

The products are SciPy's to the last bit, so that a run's results do not depend on which of the
two computed them: :meth:`CSR.matvec` and :meth:`CSR.rmatvec` add the products of a row (a column)
in the stored order from 0, as ``csr_matvec`` and ``csc_matvec`` of SciPy's sparsetools do, and
:func:`transposed_product` computes Aᵀ B as SciPy computes ``A.T @ B`` for CSR A and B (``A.T`` is
CSC: B is converted to CSC and ``csr_matmat`` forms Bᵀ A, each entry the sum of its products in
the order of the rows of A and B, from 0, exact zeros dropped). np.bincount adds its weights in
their order, one after another, from 0: the same additions. tests/test_light_run.py compares them
with SciPy bit for bit.
"""
from __future__ import annotations

import numpy as np

from latdyn.records import record


#: Products of at most this many entries (p × q) add their terms into a dense array of sums (8 bytes an
#: entry) instead of sorting the terms' keys first: 0.4 ms instead of 5 ms for the 16-bay lattice's start.
DIRECT_KEYS = 4_000_000


def unique_keys(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(keys, return_inverse=True)`` by a stable sort: np.unique imports numpy.ma
    (≈18 ms on first use), which nothing else of such a run needs."""
    keys = np.asarray(keys, np.int64)
    order = np.argsort(keys, kind="stable")
    ordered = keys[order]
    first = np.ones(len(keys), bool)
    first[1:] = ordered[1:] != ordered[:-1]
    inverse = np.empty(len(keys), np.int64)
    inverse[order] = np.cumsum(first) - 1
    return ordered[first], inverse


@record
class CSR:
    """An n_rows × n_cols matrix in canonical compressed sparse rows (columns ascending in each row,
    no duplicates; explicit zeros kept where given)."""

    shape: tuple[int, int]
    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray

    @classmethod
    def from_coo(cls, values, rows, cols, shape) -> "CSR":
        """Entries (rows, cols, values), duplicates added in their order: SciPy's ``tocsr`` to the bit where
        an entry has at most two duplicates, as every caller's has (SciPy sorts a row of more than 16
        entries with an unstable sort, so three or more duplicates of one entry may be added in another
        order there and differ in the last bit)."""
        rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
        keys = rows * shape[1] + cols
        values = np.asarray(values, float)
        unique, inverse = unique_keys(keys)
        if len(unique) == len(keys):  # no duplicates: the values as they are (a −0.0 stays, as in SciPy)
            data = np.empty(len(keys))
            data[inverse.ravel()] = values
        else:  # SciPy adds a key's values to its first one: a sum of −0.0 alone is −0.0, not 0 + −0.0
            inverse = inverse.ravel()
            data = np.bincount(inverse, weights=values, minlength=len(unique))
            negative_zero = (values == 0.0) & np.signbit(values)
            all_negative_zero = np.bincount(inverse, weights=negative_zero, minlength=len(unique)) == \
                np.bincount(inverse, minlength=len(unique))
            data[all_negative_zero] = -0.0
        return cls._of_keys(unique, data, shape)

    @classmethod
    def _of_keys(cls, keys: np.ndarray, data: np.ndarray, shape) -> "CSR":
        rows = keys // max(shape[1], 1)
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=shape[0]))]).astype(np.int64)
        return cls(tuple(shape), indptr, (keys % max(shape[1], 1)).astype(np.int64), data)

    @property
    def rows(self) -> np.ndarray:
        """The row of every stored entry."""
        return np.repeat(np.arange(self.shape[0], dtype=np.int64), np.diff(self.indptr))

    def at(self, rows, cols) -> np.ndarray:
        """The entries (rows, cols) (broadcast shapes flattened), 0 where none is stored."""
        rows, cols = np.asarray(rows, np.int64).ravel(), np.asarray(cols, np.int64).ravel()
        keys = self.rows * self.shape[1] + self.indices
        wanted = rows * self.shape[1] + cols
        place = np.minimum(np.searchsorted(keys, wanted), max(len(keys) - 1, 0))
        found = (keys[place] == wanted) if len(keys) else np.zeros(len(wanted), bool)
        return np.where(found, self.data[place] if len(keys) else 0.0, 0.0)

    def diagonal(self) -> np.ndarray:
        n = min(self.shape)
        return self.at(np.arange(n), np.arange(n))

    def matvec(self, x: np.ndarray) -> np.ndarray:
        """A x (SciPy's ``csr_matvec``: each row's products added in the stored order from 0)."""
        x = np.asarray(x, float)
        return np.bincount(self.rows, weights=self.data * x[self.indices], minlength=self.shape[0])

    def rmatvec(self, x: np.ndarray) -> np.ndarray:
        """Aᵀ x (SciPy's ``A.T @ x``, ``csc_matvec`` on A's arrays: row by row of A, from 0)."""
        x = np.asarray(x, float)
        return np.bincount(self.indices, weights=self.data * x[self.rows], minlength=self.shape[1])

    def toarray(self) -> np.ndarray:
        """The matrix as a dense array (SciPy's ``toarray``: a stored zero is 0)."""
        dense = np.zeros(self.shape)
        dense[self.rows, self.indices] = self.data
        return dense

    def __matmul__(self, x):
        """A x for a vector or the columns of a matrix (:func:`times`), as ``A @ x`` of a SciPy matrix reads."""
        return times(self, x)


@record
class Transpose:
    """Aᵀ of a CSR A without a copy (SciPy's ``A.transpose(copy=False)``, a CSC on A's arrays): ``Aᵀ @ X`` is
    :func:`transposed_times` (SciPy's ``csc_matvecs``, the same additions) and ``.T`` is A again."""

    of: CSR

    @property
    def shape(self) -> tuple[int, int]:
        return self.of.shape[1], self.of.shape[0]

    @property
    def T(self) -> CSR:   # noqa: N802 - SciPy's and NumPy's name
        return self.of

    def __matmul__(self, x):
        return transposed_times(self.of, x)


def transposed_product(a: CSR, b: CSR) -> CSR:
    """Aᵀ B for CSR A (n × p) and B (n × q), as SciPy's ``A.T @ B`` computes it (module docstring):
    entry (i, k) is the sum over the rows j of A's column i, ascending, of A[j, i] B[j, k] — the
    terms in that order, from 0 — and exact zeros are not stored."""
    n, p = a.shape
    q = b.shape[1]
    # the entries of A column by column (rows ascending: SciPy's conversion of A to CSC)
    a_rows = a.rows
    order = np.lexsort((a_rows, a.indices))
    i_of, j_of, v_of = a.indices[order], a_rows[order], a.data[order]
    counts = (b.indptr[1:] - b.indptr[:-1])[j_of]
    entry = np.repeat(np.arange(len(order)), counts)
    first = np.repeat(b.indptr[j_of], counts)
    kk = first + np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    keys = i_of[entry] * q + b.indices[kk]
    products = v_of[entry] * b.data[kk]
    if p * q <= DIRECT_KEYS:  # every entry's sum in one pass (no sort); the same additions in the same order
        sums = np.bincount(keys, weights=products, minlength=p * q)
        touched = np.bincount(keys, minlength=p * q) > 0
        unique = np.flatnonzero(touched & (sums != 0))
        return CSR._of_keys(unique, sums[unique], (p, q))
    unique, inverse = unique_keys(keys)
    sums = np.bincount(inverse.ravel(), weights=products, minlength=len(unique))
    kept = sums != 0
    return CSR._of_keys(unique[kept], sums[kept], (p, q))


def transposed(a: CSR) -> CSR:
    """Aᵀ, canonical (SciPy's ``A.T.tocsr()``: the same entries)."""
    return CSR.from_coo(a.data, a.indices, a.rows, (a.shape[1], a.shape[0]))


def product(a: CSR, b: CSR) -> CSR:
    """A B, as SciPy computes ``A @ B`` where each entry's products are taken in ascending order of the
    inner index (a CSC A times B, which SciPy converts to CSC: the latch's ``Q_cᵀ K Q_c``): the sum from 0,
    exact zeros dropped (:func:`transposed_product` of Aᵀ)."""
    return transposed_product(transposed(a), b)


def nonzero(a: CSR) -> CSR:
    """A without its stored zeros: what SciPy keeps of a sum ``A + B`` of matrices of one pattern (its
    ``csr_plus_csr`` stores only the nonzero sums)."""
    kept = a.data != 0
    rows = a.rows[kept]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=a.shape[0]))]).astype(np.int64)
    return CSR(a.shape, indptr, a.indices[kept], a.data[kept])


def columns(a: CSR, start: int, stop: int) -> CSR:
    """The columns start ≤ j < stop of A (SciPy's ``A[:, start:stop]``: the stored entries, zeros kept)."""
    kept = (a.indices >= start) & (a.indices < stop)
    rows = a.rows[kept]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=a.shape[0]))]).astype(np.int64)
    return CSR((a.shape[0], stop - start), indptr, a.indices[kept] - start, a.data[kept])


def blocks(top_left: CSR, top_right: CSR, bottom_left: CSR, bottom_right: CSR) -> CSR:
    """[[A, B], [C, D]] (SciPy's ``bmat(..., format="csr")``: the blocks' stored entries)."""
    m, n = top_left.shape
    parts = ((top_left, 0, 0), (top_right, 0, n), (bottom_left, m, 0), (bottom_right, m, n))
    shape = (m + bottom_left.shape[0], n + top_right.shape[1])
    return CSR.from_coo(np.concatenate([p.data for p, _, _ in parts]),
                        np.concatenate([p.rows + r for p, r, _ in parts]),
                        np.concatenate([p.indices + c for p, _, c in parts]), shape)


def of_dense(*arrays: np.ndarray) -> list[CSR]:
    """Dense matrices of one shape as CSR on the union of their nonzeros (rows ascending, then columns; zeros kept
    where another has an entry): SciPy's ``csr_matrix(A)`` of each, but on one pattern, so that their sums are
    those of SciPy's sums of them where :func:`nonzero` drops the sums' zeros."""
    shape = arrays[0].shape
    rows, cols = np.nonzero(np.any([a != 0 for a in arrays], axis=0))
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=shape[0]))]).astype(np.int64)
    return [CSR(tuple(shape), indptr, cols.astype(np.int64), np.asarray(a, float)[rows, cols]) for a in arrays]


def _column_by_column(product, rows: int, x: np.ndarray) -> np.ndarray:
    """``product`` (a vector's product, ``rows`` long) of a vector or of each column of a matrix ``x``."""
    x = np.asarray(x, float)
    if x.ndim == 1:
        return product(x)
    if x.shape[1] == 0:
        return np.zeros((rows, 0))
    return np.stack([product(x[:, j]) for j in range(x.shape[1])], axis=1).reshape(rows, x.shape[1])


def times(a: CSR, x: np.ndarray) -> np.ndarray:
    """A X for a vector or the columns of a matrix X (:meth:`CSR.matvec` column by column: SciPy's
    ``csr_matvecs`` adds each row's products in the same order)."""
    return _column_by_column(a.matvec, a.shape[0], x)


def transposed_times(a: CSR, x: np.ndarray) -> np.ndarray:
    """Aᵀ X for a vector or the columns of a matrix X (:meth:`CSR.rmatvec` column by column: SciPy's
    ``A.T @ X``, ``csc_matvecs``, adds in the same order)."""
    return _column_by_column(a.rmatvec, a.shape[1], x)


__all__ = ["CSR", "DIRECT_KEYS", "Transpose", "blocks", "columns", "nonzero", "of_dense", "product", "times", "transposed",
           "transposed_product", "transposed_times", "unique_keys"]
