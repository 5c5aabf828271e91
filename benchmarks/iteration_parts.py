"""Where one Newton iteration of the compiled step goes: each native call of the iteration timed alone.

    python benchmarks/iteration_parts.py [--problems truss cantilever lattice] [--reps 200]

The compiled step's iteration (``csrc/newton_step.c`` ``newton_iterations``) is, in order: the trial
configuration, ``evaluate`` with the matrices (element geometry and the generated element kernels,
the joint bodies, hinges, loads), ``assemble`` (S = β′M + γ′C + K scattered into the factor storage),
``latdyn_factor`` and ``latdyn_solve``, and the convergence test. Here the same native calls are
made from ctypes on the model of each scene (``benchmarks/linear_solvers.py build``: a perturbed
moving state, Newmark at h = 0.01), each repeated ``--reps`` times in 5 rounds: the process CPU time
per call, the minimum and the median of the rounds. ``factor`` includes restoring the assembled
matrix (a copy of the factor storage, timed alone as ``copy``). For a sparse LU, the analysis's
figures: supernodes, the largest, nonzeros of L + U, and the factorization's flops
(Σ over columns of 2 r² + r, r the column's entries below the diagonal).

The scenes are those of ``kernel_throughput.py --whole-solver``: the 260-member truss, the
16-element right-angle cantilever, the 16-bay lattice of ``peers_as_user.py``. Results on stdout
(docs/performance.md, "Sixth pass").
"""
from __future__ import annotations

import argparse
import copy
import ctypes
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT))

from kernel_throughput import whole_solver_scenes  # noqa: E402
from linear_solvers import BETA_P, GAMMA_P, build  # noqa: E402

from latdyn.assembly.library import native_library  # noqa: E402
from latdyn.step.compiled import hold_matrix  # noqa: E402

NAMES = {"truss": "truss_260", "cantilever": "cantilever_16", "lattice": "lattice_16"}


def factor_flops(analysis) -> float:
    """Flops of the supernodal LU: each column's rank-1 update of the entries below and right of it."""
    flops = 0.0
    for nc, nr in zip(np.diff(analysis.first), np.diff(analysis.rows_start)):
        r = np.arange(nc)[::-1] + nr  # entries below the diagonal of each column of the supernode
        flops += float(np.sum(2.0 * r * r + r))
    return flops


def timed(function, reps: int) -> tuple[float, float]:
    """(minimum, median) over 5 rounds of the CPU µs per call."""
    rounds = []
    for _ in range(5):
        start = time.process_time()
        for _ in range(reps):
            function()
        rounds.append((time.process_time() - start) / reps)
    return 1e6 * min(rounds), 1e6 * float(np.median(rounds))


def parts(raw: dict, reps: int) -> dict:
    model, assembler, _ = build(copy.deepcopy(raw))
    native = assembler.native(False)
    factorization = hold_matrix(assembler, native)
    library = native_library()
    state = assembler.initial_state()
    rng = np.random.default_rng(0)
    state = assembler.advance(state, 1e-3 * rng.standard_normal(model.n_dofs))
    configuration = native.configuration(state)
    control = native._control
    control.t, control.load_factor, control.inertia, control.matrices, control.inertia_tangent = 0.0, 1.0, 1, 1, 0
    m, w, c = native.model_ref, native.work_ref, ctypes.byref(configuration)
    structure = ctypes.pointer(factorization.structure)
    matrix, pivots = native.buffers["matrix"], native.buffers["pivots"]
    matrix_p, pivots_p = matrix.ctypes.data_as(ctypes.c_void_p), pivots.ctypes.data_as(ctypes.c_void_p)
    rhs = np.zeros(max(model.n_dofs, 1))
    rhs_p = rhs.ctypes.data_as(ctypes.c_void_p)

    def evaluate(matrices: int):
        control.matrices = matrices
        library.latdyn_evaluate(m, w, c, ctypes.byref(control))

    def assemble():
        library.latdyn_iteration_matrix(m, w, c, ctypes.c_double(BETA_P), ctypes.c_double(GAMMA_P), ctypes.c_int64(0))

    evaluate(1)
    assemble()
    assembled = matrix.copy()

    def copy_back():
        np.copyto(matrix, assembled)

    def factor():
        np.copyto(matrix, assembled)
        library.latdyn_factor(structure, matrix_p, pivots_p)

    def solve():
        rhs[:] = 1.0
        library.latdyn_solve(structure, matrix_p, pivots_p, ctypes.c_int64(1), rhs_p)

    out = {"coordinates": model.n_dofs, "kind": factorization.kind}
    analysis = factorization.analysis
    if analysis is not None:
        out.update(supernodes=analysis.n_supernodes, largest_supernode=int(np.diff(analysis.first).max()),
                   nonzeros=analysis.nonzeros, matrix_entries=len(factorization.rows),
                   factor_mflops=factor_flops(analysis) / 1e6)
    for name, function in (("evaluate with matrices", lambda: evaluate(1)),
                           ("evaluate without", lambda: evaluate(0)), ("assemble", assemble),
                           ("copy", copy_back), ("factor", factor), ("solve", solve)):
        out[name] = timed(function, reps)
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", nargs="*", default=list(NAMES))
    parser.add_argument("--reps", type=int, default=200)
    args = parser.parse_args(argv)
    scenes = whole_solver_scenes()
    load = os.getloadavg()[0]
    results = {}
    for name in args.problems:
        results[name] = r = parts(scenes[NAMES[name]], args.reps)
        facts = ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in r.items()
                          if not isinstance(v, tuple))
        print(f"{name}: {facts}")
        for key, value in r.items():
            if isinstance(value, tuple):
                print(f"  {key:24s} {value[0]:8.1f} µs (median of rounds {value[1]:.1f})")
    print(f"load {load:.1f} → {os.getloadavg()[0]:.1f}")
    return results


if __name__ == "__main__":
    main()
