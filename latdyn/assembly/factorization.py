"""The one LU factorization: of the compiled step's Newton iteration matrix and of every linear
solve of the analyses driven from Python.

:class:`Factorization` is made from a matrix's pattern (rows, cols, n) and chooses its storage as
:mod:`latdyn.numerics.linalg` documents: dense up to ``DENSE_LIMIT`` coordinates (LAPACK
getrf/getrs) unless the bandwidth after a reverse Cuthill–McKee order is at most
``SMALL_BAND_FRACTION`` of n (a chain of beams), else banded after that order while the
bandwidth is at most ``BAND_LIMIT`` (gbtrf/gbtrs), else the supernodal sparse LU of ``csrc/sparse_lu.c`` with its
analysis made once per pattern (:mod:`latdyn.assembly.sparse_lu`). It holds the storage, the
permutation into the factor's order, the pivots and :meth:`Factorization.position` (where an
entry (row, col) of the matrix lies in the storage). Factorization and solves are the C functions
``latdyn_factor`` and ``latdyn_solve`` of ``csrc/factorization.c``, with SciPy's LAPACK and BLAS
behind them and OpenBLAS held to one thread around each call.

The compiled step (:mod:`latdyn.step.compiled`) assembles its iteration matrix in C straight into
a factorization's storage (its ``values`` and ``pivots`` are the step's Work buffers) and calls the
same C functions; :meth:`Factorization.factor` and :meth:`Factorization.solve` do it from Python,
for one or many right-hand sides with the factors held. :func:`solve_linear` factorizes and solves
in one call, reusing the factorization (the analysis of its pattern) while the pattern lasts.
"""
from __future__ import annotations

import ctypes
from collections import OrderedDict

import numpy as np

from latdyn.assembly.library import (FactorizationStructure, LapackRoutines, lapack_address, native_library,
                                    numpy_lapack)
from latdyn.assembly.sparse_lu import PivotError, SupernodalAnalysis, blas_kernels
from latdyn.numerics.csr import CSR
from latdyn.numerics.linalg import (BAND_LIMIT, DENSE_LIMIT, SMALL_BAND_FRACTION, issparse, openblas_thread_functions,
                                    rcm_band, small_rcm_band)

#: The storages whose LU takes NumPy's OpenBLAS where it is loaded (:func:`~latdyn.assembly.library.numpy_lapack`):
#: the band LU, whose factors are those of SciPy's to the bit on the models measured; not the dense LU,
#: whose factors from NumPy's OpenBLAS (another version) differ from SciPy's in the last place from
#: n = 60 on (benchmarks/lapack_builds.py), so a dense model's files would change.
NUMPY_LAPACK_KINDS = ("band",)

#: The storages, in the order of csrc/factorization.c's ``kind``.
KINDS = ("dense", "band", "sparse")


class Factorization:
    """The LU of n × n matrices with the pattern (rows, cols) (see the module docstring).

    ``kind``: "dense", "band" or "sparse", chosen from n and the pattern unless given;
    ``new[i]``: the place of coordinate i in the factor's order; ``values``: the storage of
    ``size`` doubles, the matrix before :meth:`factor`, its factors after; ``pivots``: LAPACK's
    row pivots (dense and band)."""

    def __init__(self, rows, cols, n: int, kind: str | None = None):
        rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
        self.n, self.rows, self.cols = n, rows, cols
        self.kl = self.ku = 0
        self.analysis = None
        if kind is None and n <= DENSE_LIMIT:  # dense, or band where the matrix is a narrow band
            _, new, kl, ku = small_rcm_band(rows, cols, n)
            kind = "band" if 0 < n and max(kl, ku) <= SMALL_BAND_FRACTION * n else "dense"
        elif kind != "dense":
            _, new, kl, ku = (small_rcm_band if n <= DENSE_LIMIT else rcm_band)(rows, cols, n)
            if kind is None:
                kind = "band" if max(kl, ku) <= BAND_LIMIT else "sparse"
        if kind == "dense":
            self.new, self.ldab, self.size = np.arange(n, dtype=np.int64), n, n * n
        elif kind == "band":
            self.new, self.kl, self.ku = new, kl, ku
            self.ldab = 2 * kl + ku + 1  # LAPACK gbtrf's storage, room for the fill of pivoting
            self.size = self.ldab * n
        elif kind == "sparse":
            self.analysis = SupernodalAnalysis(rows, cols, n)
            self.new, self.ldab, self.size = self.analysis.new, 0, max(self.analysis.size, 1)
        else:
            raise ValueError(f"Factorization: kind {kind!r}, not one of {KINDS}")
        self.kind = kind
        self.values = np.zeros(self.size)
        self.pivots = np.zeros(max(n, 1), np.int32)
        self._pattern_positions = None
        self._band = self._pivoted = None  # the band LU that stands in where a sparse pivot fails
        self._permutation = self.new if n else np.zeros(1, np.int64)
        self.integer_bytes, self.wide_pivots, getrf, getrs, gbtrf, gbtrs, blas_threads = self._lapack(kind, n)
        self.structure = FactorizationStructure(
            n=n, kind=KINDS.index(kind), kl=self.kl, ku=self.ku, ldab=self.ldab, size=self.size,
            permutation=self._permutation.ctypes.data, getrf=getrf, getrs=getrs, gbtrf=gbtrf, gbtrs=gbtrs,
            sparse_lu=ctypes.pointer(self.analysis.structure(*blas_kernels())) if kind == "sparse" else None,
            get_blas_threads=blas_threads[0] if blas_threads[1] else None, set_blas_threads=blas_threads[1],
            integer_bytes=self.integer_bytes, wide_pivots=self.wide_pivots.ctypes.data)
        self._library = native_library()

    @staticmethod
    def _lapack(kind: str, n: int):
        """The LAPACK behind this storage: the band LU's from NumPy's own OpenBLAS where it is loaded
        (:func:`~latdyn.assembly.library.numpy_lapack`, its integer width read from the library: no
        SciPy to load; :data:`NUMPY_LAPACK_KINDS`), else, and for the dense LU, SciPy's cython_lapack (32-bit integers);
        the thread functions of the same library. Returns (integer_bytes, wide_pivots: n int64 for an
        ILP64 library, getrf, getrs, gbtrf, gbtrs, (get, set) thread functions)."""
        routines = numpy_lapack() if kind in NUMPY_LAPACK_KINDS else None
        if routines is None:
            # SciPy's LAPACK loaded first: the OpenBLAS pinned to one thread must be the one behind it
            # (asked before, the only OpenBLAS loaded was NumPy's, and getrs ran threaded beside it)
            lapack = {name: lapack_address(name) for name in ("dgetrf", "dgetrs", "dgbtrf", "dgbtrs")}
            routines = LapackRoutines(lapack, 4, openblas_thread_functions())
        get = routines.addresses.get
        wide_pivots = np.zeros(max(n, 1) if routines.integer_bytes == 8 else 1, np.int64)
        return (routines.integer_bytes, wide_pivots, get("dgetrf"), get("dgetrs"), get("dgbtrf"), get("dgbtrs"),
                routines.blas_threads)

    def position(self, rows, cols) -> np.ndarray:
        """Offsets in ``values`` of the matrix entries (rows, cols) (broadcast); −1 where a row or
        column is ≥ n (a constrained coordinate). Entries must lie in the pattern."""
        rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
        n = self.n
        if self.kind == "sparse":
            return self.analysis.position(rows, cols)
        ok = (rows < n) & (cols < n)
        if self.kind == "dense":
            return np.where(ok, rows + cols * n, -1)
        i, j = self.new[np.where(ok, rows, 0)], self.new[np.where(ok, cols, 0)]
        return np.where(ok, (self.kl + self.ku + i - j) + j * self.ldab, -1)

    def factor(self, matrix) -> "Factorization":
        """Factorize ``matrix`` (as :meth:`load` takes it), in place in ``values``. Raises
        ``np.linalg.LinAlgError`` (:class:`~latdyn.assembly.sparse_lu.PivotError` for the sparse LU)
        for a singular matrix."""
        self.load(matrix)
        info = self._library.latdyn_factor(ctypes.byref(self.structure), self.values.ctypes.data,
                                           self.pivots.ctypes.data)
        return self.factored(info, matrix)

    def factored(self, info: int, matrix) -> "Factorization":
        """After ``matrix`` was loaded and factorized natively in this storage (:meth:`factor`, or a native
        call that factorizes it, latdyn/analyses/step_matrix.py) with LAPACK's or the sparse LU's ``info``:
        0, the factors are those in ``values``; the sparse LU's failed pivot, the band LU with pivoting
        stands in (:meth:`_factor_pivoted`); else ``np.linalg.LinAlgError``."""
        self._pivoted = None
        if info != 0:
            if self.kind == "sparse":
                return self._factor_pivoted(matrix, PivotError(self.analysis.pivot_failure()))
            raise np.linalg.LinAlgError(f"{self.kind} LU: singular matrix (LAPACK info {info})")
        return self

    def load(self, matrix) -> None:
        """``matrix`` into ``values``, not factorized (the compiled step factorizes what is loaded):
        a SciPy sparse matrix whose entries lie in the pattern, the values of the pattern (a vector,
        in the order of rows and cols, duplicates summed) or, for dense storage, a NumPy array."""
        if self.kind == "dense" and (issparse(matrix) or np.ndim(matrix) == 2):
            dense = matrix.toarray() if issparse(matrix) else np.asarray(matrix, float)
            self.values[:] = dense.ravel(order="F")
        else:
            if issparse(matrix):
                coo = matrix.tocoo()
                same = np.array_equal(coo.row, self.rows) and np.array_equal(coo.col, self.cols)
                positions = self._positions() if same else self.position(coo.row, coo.col)
                data = coo.data
            elif np.ndim(matrix) == 1:
                positions, data = self._positions(), np.asarray(matrix, float)
            else:
                raise TypeError(f"a {self.kind} factorization takes a sparse matrix or the values of its pattern")
            self.values[:] = np.bincount(positions, weights=data, minlength=self.size)

    def _factor_pivoted(self, matrix, failure: PivotError) -> "Factorization":
        """The sparse LU does not pivot: where a pivot fails (an indefinite matrix, e.g. a static
        stiffness past a limit point), the band LU with LAPACK's partial pivoting on the same
        pattern and order, slower at this bandwidth but exact; :meth:`solve` then uses it. Raises
        ``failure`` when that matrix is singular too."""
        if self._band is None:
            self._band = Factorization(self.rows, self.cols, self.n, kind="band")
        try:
            self._pivoted = self._band.factor(matrix)
        except np.linalg.LinAlgError:
            raise failure from None
        return self

    def solve(self, rhs) -> np.ndarray:
        """x with A x = rhs for the matrix last factorized (:meth:`factor`, or the compiled step
        whose storage this is): one right-hand side (a vector) or many (the columns of a matrix)."""
        if self._pivoted is not None:
            return self._pivoted.solve(rhs)
        b = np.asarray(rhs, float)
        columns = b.reshape(self.n, -1)
        x = np.empty((columns.shape[1], self.n))  # each right-hand side contiguous, in the factor's order
        x[:, self.new] = columns.T
        if self.n:
            self._library.latdyn_solve(ctypes.byref(self.structure), self.values.ctypes.data, self.pivots.ctypes.data,
                                       columns.shape[1], x.ctypes.data)
        return x[:, self.new].T.reshape(b.shape)

    def solve_transposed(self, rhs) -> np.ndarray:
        """x with Aᵀ x = rhs for the matrix A last factorized, from A's factors (``latdyn_solve_transposed``:
        LAPACK's getrs and gbtrs with 'T', the sparse LU's factors read the other way; the pivoted band
        LU where a sparse pivot failed): the discrete adjoint's solves without factorizing Aᵀ."""
        if self._pivoted is not None:
            return self._pivoted.solve_transposed(rhs)
        b = np.asarray(rhs, float)
        columns = b.reshape(self.n, -1)
        x = np.empty((columns.shape[1], self.n))
        x[:, self.new] = columns.T
        if self.n:
            self._library.latdyn_solve_transposed(ctypes.byref(self.structure), self.values.ctypes.data,
                                                  self.pivots.ctypes.data, columns.shape[1], x.ctypes.data)
        return x[:, self.new].T.reshape(b.shape)

    @staticmethod
    def positive_definite(matrix: CSR, shift: float) -> bool | None:
        """Whether the symmetric part of ``matrix`` (n × n, a :class:`latdyn.numerics.csr.CSR`) less
        ``shift`` · I is positive definite: LAPACK's banded Cholesky (``dpbtrf``, one thread) in the
        pattern's reverse Cuthill–McKee order (:func:`latdyn.numerics.linalg.rcm_band`, the order the LU of
        the same pattern finds, found once a pattern): True where it completes, False where a pivot is not
        positive; None where the band is wider than ``BAND_LIMIT`` (not decided here). Completing proves
        λ_min > ``shift`` − e, e the factorization's backward error (≤ (kd + 1)² ε for a unit diagonal, kd
        the band: ≈ 1e-12 at the widest band) — the held check's proof that no direction is unheld
        (:meth:`latdyn.model.model.Model.check_held`)."""
        n = matrix.shape[0]
        if n == 0:
            return True
        rows, cols = matrix.rows, np.asarray(matrix.indices, np.int64)
        _, new, kl, ku = (small_rcm_band if n <= DENSE_LIMIT else rcm_band)(rows, cols, n)
        kd = max(kl, ku)
        if kd > BAND_LIMIT:
            return None
        i, j = new[rows], new[cols]
        low, high = np.minimum(i, j), np.maximum(i, j)
        # LAPACK's lower band storage, column-major: AB(1 + i − j, j) at band[j, i − j]; each off-diagonal
        # entry gives half of itself to the symmetric part, the diagonal all of itself
        weights = np.where(i == j, 1.0, 0.5) * matrix.data
        band = np.bincount(low * (kd + 1) + (high - low), weights=weights, minlength=n * (kd + 1))
        band[::kd + 1] -= shift
        numpy_routines = numpy_lapack()
        routines = numpy_routines or LapackRoutines({"dpbtrf": lapack_address("dpbtrf")}, 4, openblas_thread_functions())
        integer = ctypes.c_int64 if routines.integer_bytes == 8 else ctypes.c_int
        size, width, leading, info = integer(n), integer(kd), integer(kd + 1), integer(0)
        pointer = ctypes.POINTER(integer)
        # NumPy's is the Fortran symbol: uplo's hidden length (gfortran's size_t) passed after the others
        hidden = (ctypes.c_size_t,) if numpy_routines else ()
        dpbtrf = ctypes.CFUNCTYPE(None, ctypes.c_char_p, pointer, pointer, ctypes.c_void_p, pointer, pointer, *hidden)(
            routines.addresses["dpbtrf"])
        get, put = routines.blas_threads
        threads = ctypes.CFUNCTYPE(ctypes.c_int)(get)() if get and put else None
        if threads is not None and threads != 1:
            ctypes.CFUNCTYPE(None, ctypes.c_int)(put)(1)
        try:
            dpbtrf(b"L", ctypes.byref(size), ctypes.byref(width), band.ctypes.data, ctypes.byref(leading),
                   ctypes.byref(info), *(1,) * len(hidden))
        finally:
            if threads is not None and threads != 1:
                ctypes.CFUNCTYPE(None, ctypes.c_int)(put)(threads)
        return info.value == 0

    def _positions(self) -> np.ndarray:
        """The positions of the pattern's entries (made on first use)."""
        if self._pattern_positions is None:
            self._pattern_positions = self.position(self.rows, self.cols)
        return self._pattern_positions


# ----------------------------------------------------------------------------- one-off solves

_held: "OrderedDict[tuple, list[Factorization]]" = OrderedDict()
_MAX_HELD = 4  # the iteration matrix, the mass and massless blocks, one spare


def solve_linear(matrix, rhs) -> np.ndarray:
    """Solve ``matrix @ x = rhs`` for one right-hand side or many (the columns of ``rhs``): a
    NumPy array densely, a SciPy sparse matrix in the storage :class:`Factorization` chooses for
    its pattern, whose analysis is kept for the next matrices of that pattern. Raises
    ``np.linalg.LinAlgError`` for a singular matrix."""
    return factorization_for(matrix).factor(matrix).solve(rhs)


def solve_linear_csr(matrix: CSR, rhs) -> np.ndarray:
    """:func:`solve_linear` of a :class:`latdyn.numerics.csr.CSR` (no SciPy): the same storage, order
    and factors as for the SciPy CSR matrix of the same entries, so the same solution to the bit."""
    n = matrix.shape[0]
    rows = matrix.rows
    held = _held_for((n, len(matrix.indices)), (rows, matrix.indices), lambda: Factorization(rows, matrix.indices, n))
    return held.factor(matrix.data).solve(rhs)


def factorization_for(matrix) -> Factorization:
    """A factorization for ``matrix``'s pattern (compared exactly; dense for a NumPy array), the
    one held for that pattern or a new one, not yet factorized."""
    if isinstance(matrix, np.ndarray):
        return _held_for(("dense", matrix.shape[0]), None,
                         lambda: Factorization((), (), matrix.shape[0], kind="dense"))
    A = matrix if matrix.format == "csr" else matrix.tocsr()
    if not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()
    n = A.shape[0]
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr))
    return _held_for((n, A.nnz), (rows, A.indices), lambda: Factorization(rows, A.indices, n))


def _held_for(key, pattern, make) -> Factorization:
    for held in _held.get(key, ()):
        if pattern is None or (np.array_equal(held.rows, pattern[0]) and np.array_equal(held.cols, pattern[1])):
            _held.move_to_end(key)
            return held
    made = make()
    _held.setdefault(key, []).append(made)
    _held.move_to_end(key)
    while sum(len(v) for v in _held.values()) > _MAX_HELD:
        _held.popitem(last=False)
    return made


__all__ = ["KINDS", "Factorization", "factorization_for", "solve_linear", "solve_linear_csr"]
