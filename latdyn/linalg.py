"""Linear solves of the Newton iteration matrix, and the null direction of a PSD pencil.

Policy, chosen by measurement (``python benchmarks/linear_solvers.py``, table in
benchmarks/results/linear_solvers.json; AMD EPYC, 2 cores of a KVM guest shared
with other jobs, medians in ms of one Newton solve *including* the assembly of
S = β′M + γ′C + K, BLAS threads 1 / 2):

    model         n      dense LU       SuperLU (MMD AᵀA+A,   band LU after
                                        symmetric mode)       RCM (bandwidth)
    beam 10 el    66     0.066 / 0.066  0.31                  0.20   (11)
    beam 20 el    126    0.33 / 0.34    0.47                  0.33   (11)
    beam 32 el    198    0.76 / 254     0.43                  0.25   (11)
    beam 64 el    390    12 / 44        0.70                  0.46   (11)
    beam 400 el   2406   691 / 1070     8.2                   2.2    (11)
    beam 5000 el  30006  —              97                    70     (11)
    lattice 32 el 148    0.35 / 0.34    0.29                  0.32   (53)
    lattice 63 el 180    0.52 / 0.51    0.64                  0.71   (65) / 147 at 2 threads
    lattice 120   324    2.3 / 317      1.6                   1.6    (80)
    lattice 260   680    74 / 758       13 (7.1 reused order) 13     (141)
    lattice 480   1230   142 / 653      22                    48     (190) / 1780 at 2 threads
    lattice 931   2352   656 / 1140     106                   247    (434)

(the rows are from the run recorded in the json; that run shared the machine
with several other jobs, so single entries are noisy by ×2, but every ordering
below held in every run.)

* **Dense only for small systems.** Dense LU costs ⅔n³ and a zero-filled n×n
  array; sparse solves carry a fixed ~0.15–0.3 ms of Python and SuperLU set-up.
  They cross between n ≈ 130 (a beam: 17 nonzeros a row) and n ≈ 200 (a 3D
  lattice: 30 a row) → ``DENSE_LIMIT = 150``.  The former limit, 600, made the
  64-element flying spaghetti (390 coordinates) a dense model: 2–12 ms a solve
  on one thread against 0.5 ms sparse.
* **BLAS pinned to one thread around LAPACK calls** (dense ``gesv`` and banded
  ``gbsv``): with two threads on a machine where another job holds a core,
  OpenBLAS waits on its second thread: n = 198 dense 0.76 → 254 ms, the
  lattice band solve 48 → 1780 ms.  Even unloaded, these sizes are too small
  for a second thread to pay.  SuperLU does not use threaded BLAS here (1 and 2
  threads time alike).  The pin is taken and released around each call through
  threadpoolctl when it is installed (≈1 µs), so the caller's own BLAS setting
  is untouched; without threadpoolctl nothing is pinned.
* **Sparse: band LU when the reverse Cuthill–McKee bandwidth is small, else
  SuperLU with a reused ordering.**  A chain of beams has bandwidth 11 after
  RCM whatever its length, and LAPACK's band LU (partial pivoting) beats
  SuperLU 1.5–4×.  A 3D lattice's bandwidth grows like n^⅔ and the band solve
  falls behind from bandwidth ≈ 150 (lattice 1230: 48 vs 22 ms) →
  ``BAND_LIMIT = 64``.  Otherwise SuperLU, ordered by minimum degree on AᵀA + A
  in symmetric mode with threshold pivoting 0.1 (S is structurally symmetric
  and nearly so in value): COLAMD, SuperLU's default, fills 1.6× more and is
  2–5× slower on lattices.  Both analyses are done once per sparsity pattern
  (RCM order and the band scatter map; the SuperLU column order) and reused
  while the pattern stays the same (it changes only when a hinge latches).

``solve_linear(matrix, rhs)`` dispatches on the matrix: a NumPy array is
solved densely; a SciPy sparse matrix densely when n ≤ DENSE_LIMIT, else as
above.  ``Assembler.assemble`` returns a dense array exactly when
n ≤ DENSE_LIMIT, so the iteration matrix is assembled in the form it is solved in.

``psd_null_direction(A)`` finds a direction x with xᵀAx ≈ 0 for a sparse
symmetric positive semi-definite A with unit diagonal (the held-coordinate
check of the scene, see :meth:`latdyn.model.Model.check_held`), by inverse
iteration with a sparse LU of A + δI: at any size, without a dense eigen-solve.
"""
from __future__ import annotations

from collections import OrderedDict
from contextlib import contextmanager

import numpy as np
import scipy.sparse as sps
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla
from scipy.linalg import lapack

#: Models with at most this many free coordinates use dense matrices and LU.
DENSE_LIMIT = 120

#: Sparse systems whose half-bandwidth after reverse Cuthill–McKee is at most
#: this use LAPACK band LU; wider ones SuperLU.
BAND_LIMIT = 100

#: SuperLU options: minimum degree on AᵀA + A, diagonal pivots preferred.
SUPERLU_OPTIONS = {"diag_pivot_thresh": 0.1, "options": {"SymmetricMode": True}}


# ----------------------------------------------------------------------------- BLAS threads

_blas = None  # list of threadpoolctl library controllers, [] when unavailable


def _blas_controllers() -> list:
    global _blas
    if _blas is None:
        try:
            from threadpoolctl import ThreadpoolController

            _blas = list(ThreadpoolController().select(user_api="blas").lib_controllers)
        except Exception:  # noqa: BLE001 - threadpoolctl missing or unable to inspect: leave BLAS alone
            _blas = []
    return _blas


@contextmanager
def single_thread_blas():
    """Limit the BLAS libraries (NumPy's and SciPy's) to one thread inside the block."""
    saved = []
    for lib in _blas_controllers():
        try:
            k = lib.get_num_threads()
            if k is not None and k != 1:
                lib.set_num_threads(1)
                saved.append((lib, k))
        except Exception:  # noqa: BLE001
            pass
    try:
        yield
    finally:
        for lib, k in saved:
            lib.set_num_threads(k)


# ----------------------------------------------------------------------------- solves


def use_dense(n: int) -> bool:
    """Whether a system of n coordinates is assembled and solved densely."""
    return n <= DENSE_LIMIT


def solve_linear(matrix, rhs: np.ndarray) -> np.ndarray:
    """Solve ``matrix @ x = rhs``: dense LU for arrays and small systems, band LU or
    SuperLU beyond (see the module docstring).  Raises ``np.linalg.LinAlgError``
    or ``RuntimeError`` for a singular matrix."""
    rhs = np.asarray(rhs, float)
    if isinstance(matrix, np.ndarray):
        with single_thread_blas():
            return np.linalg.solve(matrix, rhs)
    if use_dense(matrix.shape[0]):
        with single_thread_blas():
            return np.linalg.solve(matrix.toarray(), rhs)
    A = matrix if matrix.format == "csr" else matrix.tocsr()
    if not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()
    return _plan_for(A).solve(A, rhs)


class _Plan:
    """The symbolic analysis of one sparsity pattern (CSR indptr/indices), reused."""

    def __init__(self, A):
        n = A.shape[0]
        self.n = n
        self.indptr = A.indptr.copy()
        self.indices = A.indices.copy()
        self.rows = np.repeat(np.arange(n), np.diff(A.indptr))
        on_diagonal = np.flatnonzero(self.rows == self.indices)
        self.diagonal = np.full(n, -1, dtype=np.int64)  # position of (i, i) in the values, or −1
        self.diagonal[self.rows[on_diagonal]] = on_diagonal
        pattern = sps.csr_matrix((np.ones(A.nnz), A.indices, A.indptr), shape=A.shape)
        perm = csgraph.reverse_cuthill_mckee(pattern, symmetric_mode=False)
        new = np.empty_like(perm)
        new[perm] = np.arange(n)  # old index -> place in RCM order
        i, j = new[self.rows], new[A.indices]
        lower = int(np.max(i - j, initial=0))
        upper = int(np.max(j - i, initial=0))
        self.bandwidth = max(lower, upper)
        if self.bandwidth <= BAND_LIMIT:
            self.kind = "band"
            self.perm, self.lower, self.upper = perm, lower, upper
            # LAPACK gbsv storage: row kl + ku + i − j of a (2kl + ku + 1) × n array
            self.band_rows = lower + upper + i - j
            self.band_cols = j
        else:
            self.kind = "superlu"
            self.order = None  # set by the first factorization

    def solve(self, A, rhs):
        if self.kind == "band":
            return self._band(A, rhs)
        return self._superlu(A, rhs)

    def _band(self, A, rhs):
        ab = np.zeros((2 * self.lower + self.upper + 1, self.n))
        ab[self.band_rows, self.band_cols] = A.data
        b = rhs[self.perm]
        with single_thread_blas():
            _, _, x, info = _gbsv(self.lower, self.upper, ab, b, overwrite_ab=1, overwrite_b=1)
        if info != 0:
            raise np.linalg.LinAlgError(f"band LU: singular matrix (gbsv info {info})")
        out = np.empty_like(x)
        out[self.perm] = x
        return out

    def _superlu(self, A, rhs):
        """SuperLU on D A D, D = |diag A|^(-1/2): unit diagonal, so that threshold pivoting
        keeps to the diagonal and the symmetric ordering's fill (lattice of 6210
        coordinates: 2.1 M nonzeros in L + U against 4.9 M unscaled, 5× faster)."""
        d = np.ones(self.n)
        has = self.diagonal >= 0
        d[has] = np.abs(A.data[self.diagonal[has]])
        d[~(d > 0) | ~np.isfinite(d)] = 1.0
        s = 1.0 / np.sqrt(d)
        data = A.data * s[self.rows] * s[self.indices]
        b = s * rhs
        if self.order is None:
            C = sps.csr_matrix((data, self.indices, self.indptr), shape=A.shape).tocsc()
            lu = spla.splu(C, permc_spec="MMD_AT_PLUS_A", **SUPERLU_OPTIONS)
            self._remember_order(A.shape, lu.perm_c)
            return s * lu.solve(b)
        B = sps.csc_matrix((data[self.order], self.B_indices, self.B_indptr), shape=A.shape)
        lu = spla.splu(B, permc_spec="NATURAL", **SUPERLU_OPTIONS)
        out = np.empty(self.n)
        out[self.inverse] = lu.solve(b[self.inverse])
        return s * out

    def _remember_order(self, shape, perm_c):
        """B = P A Pᵀ in CSC with the first factorization's column order (old column c
        goes to place perm_c[c]), and the map from A's CSR values to B's CSC values."""
        inverse = np.empty_like(perm_c)
        inverse[perm_c] = np.arange(len(perm_c))  # place -> old index
        nnz = len(self.indices)
        tag = sps.csr_matrix((np.arange(1, nnz + 1, dtype=float), self.indices, self.indptr), shape=shape)
        B = tag[inverse][:, inverse].tocsc()
        B.sort_indices()
        self.order = B.data.astype(np.int64) - 1
        self.B_indices, self.B_indptr = B.indices.copy(), B.indptr.copy()
        self.inverse = inverse


_gbsv = lapack.get_lapack_funcs("gbsv", (np.zeros(1),))
_plans: "OrderedDict[tuple, list[_Plan]]" = OrderedDict()
_MAX_PLANS = 4  # the iteration matrix, the mass and massless blocks, one spare


def _plan_for(A) -> _Plan:
    """The cached plan of A's pattern (compared exactly), made on first sight."""
    key = (A.shape[0], A.nnz)
    for plan in _plans.get(key, ()):
        if np.array_equal(plan.indptr, A.indptr) and np.array_equal(plan.indices, A.indices):
            _plans.move_to_end(key)
            return plan
    plan = _Plan(A)
    _plans.setdefault(key, []).append(plan)
    _plans.move_to_end(key)
    while sum(len(v) for v in _plans.values()) > _MAX_PLANS:
        _plans.popitem(last=False)
    return plan


# ----------------------------------------------------------------------------- null directions


def psd_null_direction(A, tol: float = 1e-10, shift: float = 1e-9, iterations: int = 12,
                       seed: int = 0) -> tuple[float, np.ndarray]:
    """The smallest Rayleigh quotient found for a sparse symmetric PSD matrix with
    unit diagonal, and its vector (max-norm 1).

    Inverse iteration with one sparse LU of A + δI (δ = ``shift``; positive
    definite, so the factorization exists however singular A is): each step
    multiplies a null component by 1/δ and a held one, of eigenvalue λ, by
    1/(λ + δ).  The Rayleigh quotient xᵀAx/xᵀx is never below λ_min(A), so a
    result ≤ ``tol`` proves a near-null direction, and a held matrix (λ_min > tol)
    can never be reported unheld; with a null space the quotient falls to
    round-off (~1e-16) within two or three steps.  Iteration stops when the
    quotient is ≤ tol·1e-3 or no longer falls.
    """
    A = sps.csc_matrix(A)
    n = A.shape[0]
    if n == 0:
        return np.inf, np.zeros(0)
    shifted = (A + shift * sps.identity(n, format="csc")).tocsc()
    lu = spla.splu(shifted, permc_spec="MMD_AT_PLUS_A", **SUPERLU_OPTIONS)
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    x /= np.linalg.norm(x)
    best = (np.inf, x)
    for _ in range(iterations):
        y = lu.solve(x)
        norm = np.linalg.norm(y)
        if not np.isfinite(norm) or norm == 0.0:
            break
        x = y / norm
        rho = float(x @ (A @ x))
        previous = best[0]
        if rho < previous:
            best = (rho, x)
        if rho <= 1e-3 * tol or rho > 0.99 * previous:
            break
    rho, x = best
    return rho, x / np.max(np.abs(x))


__all__ = ["DENSE_LIMIT", "BAND_LIMIT", "use_dense", "solve_linear", "single_thread_blas", "psd_null_direction"]
