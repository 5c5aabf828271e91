"""Could the step's LAPACK come from NumPy's OpenBLAS instead of SciPy's (issue 31)? The LU factors of
both, compared bit for bit.

The compiled step calls ``dgetrf``/``dgetrs`` (dense) and ``dgbtrf``/``dgbtrs`` (band) through SciPy's
``cython_lapack`` capsules (:func:`latdyn.assembly.library.lapack_address`), which loads SciPy's top
package and its OpenBLAS (≈ 15 ms of CPU, 25–30 ms of wall time at a run's start). NumPy's wheel
carries an OpenBLAS of its own, but an ILP64 one (``scipy_dgetrf_64_``: 64-bit integers, another ABI
than the step's) and of another version. This script factorizes the same random dense (n = 6 … 300)
and band (kl = ku = 3, 11, 50) matrices with each library, one thread, and prints whether the factors
are equal to the bit::

    OPENBLAS_NUM_THREADS=1 python benchmarks/lapack_builds.py

Measured (NumPy 2.4.6's OpenBLAS 0.3.31, SciPy 1.17.1's 0.3.30, AMD EPYC, SkylakeX kernels): the
band LU equal on every case, the dense LU not from n = 60 on (one unit in the last place,
pivots equal), so a dense model's files would not be the same: the step keeps SciPy's LAPACK
(docs/performance.md, "Where a run's time goes").
"""
from __future__ import annotations

import ctypes
import glob
import os

import numpy as np

from latdyn.assembly.library import lapack_address


def _numpy_openblas():
    found = glob.glob(os.path.join(os.path.dirname(np.__file__), "..", "numpy.libs", "libscipy_openblas64_*.so"))
    return ctypes.CDLL(found[0]) if found else None


def _address(a: np.ndarray):
    return a.ctypes.data_as(ctypes.c_void_p)


def _band_storage(B: np.ndarray, kl: int, ku: int) -> np.ndarray:
    """LAPACK's band storage of B with room for the fill of pivoting (ldab = 2 kl + ku + 1)."""
    n = len(B)
    ab = np.zeros((2 * kl + ku + 1, n), order="F")
    for j in range(n):
        for i in range(max(0, j - ku), min(n, j + kl + 1)):
            ab[kl + ku + i - j, j] = B[i, j]
    return ab


def main() -> int:
    lib = _numpy_openblas()
    if lib is None:
        print("NumPy's wheel OpenBLAS (numpy.libs/libscipy_openblas64_*.so) not found")
        return 1
    numpy_getrf, numpy_gbtrf = lib.scipy_dgetrf_64_, lib.scipy_dgbtrf_64_
    scipy_getrf = ctypes.CFUNCTYPE(None, *[ctypes.c_void_p] * 6)(lapack_address("dgetrf"))
    scipy_gbtrf = ctypes.CFUNCTYPE(None, *[ctypes.c_void_p] * 8)(lapack_address("dgbtrf"))
    rng = np.random.default_rng(1)
    for n in (6, 24, 60, 120, 300):
        A = np.asfortranarray(rng.standard_normal((n, n)) + n * rng.random() * np.eye(n))
        a64, a32 = A.copy(order="F"), A.copy(order="F")
        p64, p32 = np.zeros(n, np.int64), np.zeros(n, np.int32)
        n64, n32, i64, i32 = np.array([n], np.int64), np.array([n], np.int32), np.zeros(1, np.int64), np.zeros(1, np.int32)
        numpy_getrf(*map(_address, (n64, n64, a64, n64, p64, i64)))
        scipy_getrf(*map(_address, (n32, n32, a32, n32, p32, i32)))
        print(f"dgetrf n={n:3d}: factors equal to the bit {np.array_equal(a64, a32)}, pivots equal "
              f"{np.array_equal(p64, p32)}, largest difference {np.max(np.abs(a64 - a32)):.2e}")
        for k in (3, 11, 50):
            if k >= n:
                continue
            B = sum(np.diag(rng.standard_normal(n - abs(d)), d) for d in range(-k, k + 1))
            b64, b32 = _band_storage(B, k, k), _band_storage(B, k, k)
            ld = 3 * k + 1
            numpy_gbtrf(*map(_address, (n64, n64, np.array([k], np.int64), np.array([k], np.int64), b64,
                                        np.array([ld], np.int64), p64, i64)))
            scipy_gbtrf(*map(_address, (n32, n32, np.array([k], np.int32), np.array([k], np.int32), b32,
                                        np.array([ld], np.int32), p32, i32)))
            print(f"dgbtrf n={n:3d} kl=ku={k:2d}: factors equal to the bit {np.array_equal(b64, b32)}, "
                  f"largest difference {np.max(np.abs(b64 - b32)):.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
