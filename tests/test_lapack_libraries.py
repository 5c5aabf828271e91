"""The band LU's and the held check's LAPACK from NumPy's own OpenBLAS, whichever integer width that
library takes (issue 31): the width read from the library loaded, both widths factorizing and solving
to round-off, and a band model's run loading no SciPy at all, its results those of SciPy's LAPACK."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from latdyn.assembly import factorization as factorization_module
from latdyn.assembly.factorization import Factorization
from latdyn.assembly.library import numpy_lapack
from latdyn.numerics.csr import CSR

ROOT = Path(__file__).resolve().parents[1]


def _numpy_openblas_configuration() -> str | None:
    blas = np.show_config(mode="dicts").get("Build Dependencies", {}).get("blas", {})
    return blas.get("openblas configuration") if "openblas" in str(blas.get("name", "")) else None


def _with_library(monkeypatch, width: int) -> None:
    """Factorizations made after this take the LAPACK of the given width: 8 NumPy's (ILP64 here) for
    the dense LU too, 4 SciPy's cython_lapack for the band LU too."""
    if width == 8:
        if numpy_lapack() is None or numpy_lapack().integer_bytes != 8:
            pytest.skip("no ILP64 OpenBLAS of NumPy's loaded in this process")
        monkeypatch.setattr(factorization_module, "NUMPY_LAPACK_KINDS", ("dense", "band"))
    else:
        pytest.importorskip("scipy.linalg.cython_lapack")
        monkeypatch.setattr(factorization_module, "numpy_lapack", lambda: None)


def test_the_integer_width_is_the_loaded_librarys_own():
    """NumPy's wheel OpenBLAS, found loaded, with the width its own build configuration states."""
    configuration = _numpy_openblas_configuration()
    if configuration is None or not sys.platform.startswith("linux"):
        pytest.skip("NumPy here is not built on its wheel's OpenBLAS, or no /proc/self/maps")
    routines = numpy_lapack()
    if "USE64BITINT" not in configuration:   # a 32-bit one is left to SciPy's (test below)
        assert routines is None
        return
    assert routines is not None and routines.integer_bytes == 8
    assert set(routines.addresses) == {"dgetrf", "dgetrs", "dgbtrf", "dgbtrs", "dpbtrf"}
    assert all(routines.addresses.values()) and all(routines.blas_threads)


def test_a_32_bit_openblas_of_numpys_is_left_to_scipys_lapack(monkeypatch):
    """Reviewer B: csrc/factorization.c's 32-bit path calls getrs / gbtrs without the hidden length of their
    character argument, as SciPy's cython_lapack takes them, while NumPy's are Fortran symbols that take
    one (the 64-bit path and dpbtrf pass it). A 32-bit OpenBLAS of NumPy's is therefore not taken: the band
    LU falls to SciPy's and solves A x = b to round-off. (The routines found are relabelled 32-bit here, as a
    NumPy built without USE64BITINT reads; none of them is called.)"""
    pytest.importorskip("scipy.linalg.cython_lapack")
    from latdyn.assembly import library as library_module
    from latdyn.assembly.library import LapackRoutines, lapack_address

    found = library_module._find_numpy_lapack() or LapackRoutines({"dgbtrf": 1}, 8, (None, None))
    monkeypatch.setattr(library_module, "_find_numpy_lapack", lambda: found._replace(integer_bytes=4))
    monkeypatch.setattr(library_module, "_numpy_lapack", False)
    assert numpy_lapack() is None
    n = 40
    A = _band_matrix(n, 2, 3, seed=7)
    rows, cols = np.nonzero(A)
    f = Factorization(rows, cols, n, kind="band")
    assert f.integer_bytes == 4 and f.structure.gbtrf == lapack_address("dgbtrf")
    f.factor(A[rows, cols])
    b = np.random.default_rng(2).standard_normal(n)
    assert np.max(np.abs(f.solve(b) - np.linalg.solve(A, b))) <= 1e-12 * np.max(np.abs(np.linalg.solve(A, b)))


def _band_matrix(n: int, kl: int, ku: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    A = sum(np.diag(rng.standard_normal(n - abs(d)), d) for d in range(-kl, ku + 1))
    return A + np.diag(rng.choice([-1.0, 1.0], n) * rng.random(n))  # not diagonally dominant: rows swap


@pytest.mark.parametrize("kind", ["dense", "band"])
def test_both_integer_widths_factor_and_solve_to_round_off(monkeypatch, kind):
    """The C LU (csrc/factorization.c) through a 32-bit and a 64-bit LAPACK: A x = b and Aᵀ x = b
    against NumPy's solve to 1e-12 relative, both widths' pivots and factors the same, a singular
    matrix refused by both."""
    n, kl, ku = 90, 4, 6
    permutation = np.random.default_rng(3).permutation(n)  # the storage's order is not the caller's
    A = _band_matrix(n, kl, ku, seed=11)[np.ix_(permutation, permutation)]
    rows, cols = np.nonzero(A)
    b = np.random.default_rng(5).standard_normal((n, 3))
    expected, expected_t = np.linalg.solve(A, b), np.linalg.solve(A.T, b)
    found = {}
    for width in (4, 8):
        with monkeypatch.context() as patch:
            _with_library(patch, width)
            f = Factorization(rows, cols, n, kind=kind)
            assert f.integer_bytes == width
            if width == 8:  # the OpenBLAS held to one thread around the calls is the one behind them
                assert (f.structure.get_blas_threads, f.structure.set_blas_threads) == numpy_lapack().blas_threads
            f.factor(A[rows, cols])
            x, x_t = f.solve(b), f.solve_transposed(b)
            for got, want in ((x, expected), (x_t, expected_t)):
                assert np.max(np.abs(got - want)) <= 1e-12 * np.max(np.abs(want))
            found[width] = f.values.copy(), f.pivots.copy()
            singular = A.copy()
            singular[:, 7] = 0.0
            with pytest.raises(np.linalg.LinAlgError):
                Factorization(rows, cols, n, kind=kind).factor(singular[rows, cols])
    assert np.array_equal(found[4][1], found[8][1])
    assert np.max(np.abs(found[4][0] - found[8][0])) <= 1e-13 * np.max(np.abs(found[4][0]))


def test_the_banded_cholesky_decides_the_same_with_both_widths(monkeypatch):
    """positive_definite through either library: K − s·I of a spring chain (eigenvalues
    2 − 2 cos(kπ/(n+1)), the smallest ≈ 1.1e-3 at n = 90) positive definite just below the smallest
    eigenvalue, not just above it."""
    n = 90
    K = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    smallest = 2 - 2 * np.cos(np.pi / (n + 1))
    rows, cols = np.nonzero(K)
    matrix = CSR.from_coo(K[rows, cols], rows, cols, (n, n))
    for width in (4, 8):
        with monkeypatch.context() as patch:
            if width == 4:
                _with_library(patch, 4)
            elif numpy_lapack() is None or numpy_lapack().integer_bytes != 8:
                pytest.skip("no ILP64 OpenBLAS of NumPy's loaded in this process")
            assert Factorization.positive_definite(matrix, 0.99 * smallest) is True
            assert Factorization.positive_definite(matrix, 1.01 * smallest) is False


CHAIN_3D = """\
title: 3D chain under a tip force, 30 elements (180 coordinates, band LU)
sections:
  s: {EA: 1.0e7, EIy: 2.0e4, EIz: 1.0e4, GJ: 8.0e3, rhoA: 2.0, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
bodies:
  wall: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: wall, to: [2.0, 0.5, 0.3], section: s, elements: 30}
loads:
  - {at: arm.end, force: [0, 0, -10.0]}
solve: {analysis: transient, t_end: 0.02, dt: 0.002}
output:
  probes:
    w: {point: arm.end, quantity: displacement, frame: global, component: z}
"""

CHAIN_PLANAR = """\
title: planar chain under gravity and a tip force, 36 elements (108 coordinates, band LU)
sections:
  s: {EA: 1.0e6, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 1.0, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  wall: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: wall, to: [1.5, 0.4, 0], section: s, elements: 36}
loads:
  - {at: arm.end, force: [0, -2.0, 0]}
gravity: [0, -9.81, 0]
solve: {analysis: transient, t_end: 0.02, dt: 0.002}
output:
  probes:
    y: {point: arm.end, quantity: position, component: y}
"""


@pytest.mark.parametrize("text, without_scipy", [(CHAIN_3D, True), (CHAIN_PLANAR, False)], ids=["3d", "planar"])
def test_a_band_model_runs_without_scipy_its_results_those_of_scipys_lapack(tmp_path, text, without_scipy):
    """A band model's run, in a fresh process: the 3D chain loads no SciPy module (the step's band LU
    and the held check's Cholesky are NumPy's OpenBLAS; the planar chain's consistent start solves
    its inertia block by the dense LU, SciPy's); run again with SciPy's LAPACK (32-bit) for the band
    LU too, the probes the same to 1e-12 of the largest (measured here: to the bit)."""
    if numpy_lapack() is None:
        pytest.skip("NumPy's OpenBLAS is not found loaded here: SciPy's LAPACK serves every LU")
    scene = tmp_path / "scene.yaml"
    scene.write_text(text)
    code = textwrap.dedent(f"""
        import json, sys
        import numpy as np
        import latdyn
        from latdyn.assembly import factorization
        first = latdyn.run(latdyn.load_scene({str(scene)!r}))
        loaded = sorted(m for m in sys.modules if m == "scipy" or m.startswith("scipy."))
        factorization.numpy_lapack = lambda: None
        second = latdyn.run(latdyn.load_scene({str(scene)!r}))
        a, b = (np.column_stack([np.asarray(v, float) for v in r.probes.values()]) for r in (first, second))
        print(json.dumps({{"status": first.summary["status"], "coordinates": first.summary["coordinates"],
                          "loaded": loaded, "bits": bool(np.array_equal(a, b)),
                          "difference": float(np.max(np.abs(a - b)) / np.max(np.abs(a)))}}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["status"] == "solved"
    assert (found["loaded"] == []) is without_scipy
    assert found["difference"] <= 1e-12


def test_numpys_openblas_is_found_in_its_wheel_without_reading_the_maps(monkeypatch):
    """NumPy's wheel's OpenBLAS is the one file of ``numpy.libs``, opened without loading it again
    (``library._wheel_openblas``): the same routines as ``/proc/self/maps`` shows loaded from NumPy's folder,
    found without reading the maps (≈ 1 ms of a fresh run; docs/performance.md, "Twelfth pass")."""
    from latdyn.assembly import library as library_module
    from latdyn.numerics import linalg

    if library_module._wheel_openblas() is None:
        pytest.skip("NumPy carries no OpenBLAS of its own here (not a wheel's numpy.libs)")
    with monkeypatch.context() as patch:
        patch.setattr(library_module, "_wheel_openblas", lambda: None)
        from_maps = library_module._find_numpy_lapack()

    def no_maps(belongs):
        raise AssertionError("/proc/self/maps read")

    monkeypatch.setattr(linalg, "loaded_openblas", no_maps)
    assert from_maps is not None and library_module._find_numpy_lapack() == from_maps

