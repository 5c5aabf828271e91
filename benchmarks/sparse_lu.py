"""The compiled sparse LU (csrc/sparse_lu.c) against SuperLU, and the compiled step it enables.

    python benchmarks/sparse_lu.py [--quick] [--steps 4]

3D lattices of joint bodies and beams (benchmarks/linear_solvers.py's ``lattice_for``, some
beams hinged), from 120 to ~5000 elements (324 to ~12 000 coordinates).  Two tables, both
written to benchmarks/results/sparse_lu.json with the machine and its load average:

1. *The linear solve alone*, on the iteration matrix S = β′M + γ′C + K of a perturbed moving
   state (Newmark, h = 0.01): the fill (nonzeros of L + U, the diagonal once) of the node-graph
   minimum degree (latdyn/assembly/sparse_lu.py) against SuperLU's MMD on AᵀA + A of the Jacobi-scaled
   matrix (latdyn.numerics.linalg's setting; COLAMD for reference), the analysis time (once per
   pattern), and the median time of one factorization + solve: the C sparse LU (values
   scattered into the factor storage, factorized, solved) against SuperLU with the order reused
   (benchmarks/linear_solvers.py splu_reuse, what the analyses driven from Python used before
   latdyn.assembly.factorization).  "1/2": BLAS (dgemm, dtrsm)
   pinned to one thread around the factorization, as the compiled step does, / left on
   OpenBLAS's two threads; two rounds, interleaved, the better median of each kept.
2. *One Newton iteration of a time step*, everything included (configuration update, element
   kernels, assembly, factorization, solve): the compiled step (band LU while the RCM
   bandwidth ≤ BAND_LIMIT, else the sparse LU; with ``--compare-band`` also each forced to the
   other, and free beams of 64–5000 elements, RCM bandwidth 11, on the band and the sparse LU),
   generalized-α, full Newton, h = 1e-3: the wall
   and CPU time of a step over its iterations, median over ``--steps`` steps after one untimed,
   the fastest of ``--rounds`` such timings.  The results of 2026-11 also hold the Python step
   (SuperLU), which issue 17 removed: the compiled step's Newton iteration is the only one now.
   The compiled step's element part runs serially here (``parallel_elements=0``): the timings are of one core's
   work, and OpenMP threads on this shared 2-core machine swing by 2–9× with the other jobs'
   load (docs/performance.md, "Threads").
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import scipy
import scipy.sparse.linalg as spla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import latdyn  # noqa: E402
from latdyn.assembly import factorization  # noqa: E402
import latdyn.step.compiled as engine  # noqa: E402
from latdyn.step.integrators import AlphaParameters  # noqa: E402
from latdyn.numerics.linalg import SUPERLU_OPTIONS, rcm_band  # noqa: E402
from latdyn.assembly.prepare import prepare  # noqa: E402
from latdyn.assembly.factorization import Factorization  # noqa: E402
from latdyn.assembly.sparse_lu import SupernodalAnalysis  # noqa: E402
from linear_solvers import (_reuse_setup, _reuse_solve, _scaled, beam_scene, build, combined, lattice_for,  # noqa: E402
                            machine)
from step_scaling import timed_steps  # noqa: E402

try:
    from threadpoolctl import ThreadpoolController
except ImportError:  # pragma: no cover
    ThreadpoolController = None

RESULTS = ROOT / "benchmarks" / "results" / "sparse_lu.json"
LATTICES = (120, 250, 500, 1000, 2500, 5000)
BEAMS = (64, 400, 5000)  # --compare-band: free beams, RCM bandwidth 11


def _median_time(function, budget: float, at_least: int = 5, at_most: int = 41) -> float:
    samples, started = [], time.perf_counter()
    while len(samples) < at_most and (len(samples) < at_least or time.perf_counter() - started < budget):
        t0 = time.perf_counter()
        function()
        samples.append(time.perf_counter() - t0)
    return float(np.median(samples))


def linear_solve_row(elements: int, budget: float, controller) -> dict:
    model, _, ev = build(lattice_for(elements))
    S = combined(ev, False).tocsr()
    n = S.shape[0]
    rows = np.repeat(np.arange(n), np.diff(S.indptr))
    bandwidth = max(rcm_band(rows, S.indices, n)[2:])
    t0 = time.perf_counter()
    SupernodalAnalysis(rows, S.indices, n)
    analysis_s = time.perf_counter() - t0
    lu = Factorization(rows, S.indices, n, kind="sparse").factor(S)
    pinned = lu.structure.get_blas_threads  # None: the C factorization leaves OpenBLAS's threads alone
    reused = _reuse_setup(ev)
    scaled, _ = _scaled(S)
    superlu = spla.splu(scaled.tocsc(), permc_spec="MMD_AT_PLUS_A", **SUPERLU_OPTIONS)
    colamd = spla.splu(S.tocsc(), permc_spec="COLAMD")
    rhs = np.random.default_rng(0).standard_normal(n)
    reference = _reuse_solve(ev, rhs, reused)
    error = float(np.max(np.abs(lu.solve(rhs) - reference)) / np.max(np.abs(reference)))
    # "1": BLAS pinned to one thread around the factorization, as the compiled step does;
    # "2": OpenBLAS left on its two threads (SuperLU pins nothing it uses: the same both ways)
    times = {"sparse_lu": {}, "superlu_reused": {}}
    for _ in range(2):  # two rounds, settings interleaved; the better median of each is kept
        for threads in (1, 2):
            lu.structure.get_blas_threads = pinned if threads == 1 else None
            with (controller.limit(limits=2, user_api="blas") if controller else _nothing()):
                for name, solve in (("sparse_lu", lambda: lu.factor(S).solve(rhs)),
                                    ("superlu_reused", lambda: _reuse_solve(ev, rhs, reused))):
                    t = _median_time(solve, budget)
                    times[name][str(threads)] = min(t, times[name].get(str(threads), np.inf))
    a = lu.analysis
    columns = np.diff(a.first)
    return {"elements": len(model.element_nodes), "n": n, "nnz": int(S.nnz), "rcm_bandwidth": int(bandwidth),
            "nodes": a.nodes, "supernodes": a.n_supernodes, "largest_supernode": int(columns.max()),
            "fill_sparse_lu": a.nonzeros, "fill_superlu_mmd_scaled": int(superlu.L.nnz + superlu.U.nnz - n),
            "fill_superlu_colamd": int(colamd.L.nnz + colamd.U.nnz - n), "analysis_s": analysis_s,
            "factor_solve_s": times, "relative_difference": error, "load_average": os.getloadavg()[0]}


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def step_timing(elements: int, engine_kind: str, steps: int, band_limit: int | None = None,
                raw: dict | None = None) -> dict:
    """Wall and CPU seconds per Newton iteration of `steps` steps (after one untimed) of the
    lattice of about ``elements`` elements (or of ``raw``); ``band_limit`` replaces
    factorization.BAND_LIMIT (0: the sparse LU forced, huge: the band LU forced)."""
    raw = lattice_for(elements) if raw is None else raw
    raw["solve"]["method"] = "generalized-alpha"
    prepared = prepare(latdyn.load_scene(raw))
    params = AlphaParameters.for_method("generalized-alpha", 0.8)
    saved = factorization.BAND_LIMIT
    if band_limit is not None:
        factorization.BAND_LIMIT = band_limit
    try:
        step = engine.CompiledGeneralizedAlpha(prepared.assembler, params, 1e-8, 8, 1.0, parallel_elements=0)
        step._setup()  # serial element part (see the docstring)
        solver = step.factorization.kind
        step.start(prepared.state)
        timed = timed_steps(step, prepared.state, 1e-3, steps)
        iterations = [max(stats.iterations, 1) for _, _, stats in timed]
        wall = [w / done for (w, _, _), done in zip(timed, iterations)]
        cpu = [c / done for (_, c, _), done in zip(timed, iterations)]
    finally:
        factorization.BAND_LIMIT = saved
    return {"elements": elements, "n": prepared.model.n_dofs, "engine": engine_kind, "solver": solver,
            "wall_s_per_iteration": float(np.median(wall)), "cpu_s_per_iteration": float(np.median(cpu)),
            "iterations_per_step": float(np.mean(iterations)), "load_average": os.getloadavg()[0]}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="lattices up to ~1000 elements")
    parser.add_argument("--steps", type=int, default=4)
    parser.add_argument("--budget", type=float, default=0.5, help="seconds of repeats per solve timing")
    parser.add_argument("--compare-band", action="store_true",
                        help="also time the compiled step with the band and sparse LU forced")
    parser.add_argument("--rounds", type=int, default=2, help="timings of each case; the fastest is kept")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    latdyn.scene.loader.MAX_ELEMENTS = max(latdyn.scene.loader.MAX_ELEMENTS, 10_000)
    lattices = tuple(e for e in LATTICES if not args.quick or e <= 1000)
    controller = ThreadpoolController() if ThreadpoolController is not None else None
    report = {"machine": machine(), "cores": os.cpu_count(), "load_average_before": os.getloadavg(),
              "numpy": np.__version__, "scipy": scipy.__version__,
              "blas": controller.select(user_api="blas").info() if controller else None}
    print(f"{report['machine']}; load {report['load_average_before']}")
    print(f"{'el':>5s} {'n':>6s} {'bw':>4s} {'nodes':>5s} {'sn':>5s} {'max':>4s} {'fill LU':>9s} {'SuperLU':>9s} "
          f"{'COLAMD':>9s} {'anal ms':>7s} {'LU 1/2 ms':>14s} {'SuperLU 1/2 ms':>14s}")
    rows = []
    for elements in lattices:
        r = linear_solve_row(elements, args.budget, controller)
        rows.append(r)
        t, s = r["factor_solve_s"]["sparse_lu"], r["factor_solve_s"]["superlu_reused"]
        print(f"{r['elements']:5d} {r['n']:6d} {r['rcm_bandwidth']:4d} {r['nodes']:5d} {r['supernodes']:5d} "
              f"{r['largest_supernode']:4d} {r['fill_sparse_lu']:9d} {r['fill_superlu_mmd_scaled']:9d} "
              f"{r['fill_superlu_colamd']:9d} {1e3 * r['analysis_s']:7.0f} "
              f"{1e3 * t['1']:6.2f}/{1e3 * t['2']:<7.2f} {1e3 * s['1']:6.2f}/{1e3 * s['2']:<7.2f}", flush=True)
    report["linear_solve"] = rows

    steps = []
    print(f"\n{'model':>7s} {'el':>5s} {'n':>6s} {'engine':>8s} {'solver':>8s} {'wall ms/it':>10s} "
          f"{'CPU ms/it':>10s} {'it/step':>7s} {'load':>5s}")
    cases = []
    for elements in lattices:
        cases += [("lattice", elements, "compiled", None)]
        if args.compare_band and elements <= 1000:  # band LU at bandwidth ~ n^⅔: hopeless beyond
            cases += [("lattice", elements, "compiled", 0), ("lattice", elements, "compiled", 10 ** 9)]
    if args.compare_band:  # chains, RCM bandwidth 11: the band LU's home ground
        cases += [("beam", e, "compiled", limit) for e in BEAMS for limit in (None, 0)]
    step_timing(lattices[0], "compiled", 2)  # warm-up: the first timings of a process run slow
    seen = {}
    for model, elements, kind, limit in cases:
        raw = beam_scene(elements) if model == "beam" else None
        rounds = [step_timing(elements, kind, args.steps, limit, raw=raw) for _ in range(args.rounds)]
        row = min(rounds, key=lambda r: r["wall_s_per_iteration"])
        row.update(model=model, rounds_wall_s=[r["wall_s_per_iteration"] for r in rounds])
        key = (model, elements, kind, row["solver"])
        if key in seen:
            continue  # a forced solver that is the policy's own choice
        seen[key] = row
        steps.append(row)
        print(f"{model:>7s} {elements:5d} {row['n']:6d} {kind:>8s} {row['solver']:>8s} "
              f"{1e3 * row['wall_s_per_iteration']:10.2f} {1e3 * row['cpu_s_per_iteration']:10.2f} "
              f"{row['iterations_per_step']:7.1f} {row['load_average']:5.2f}", flush=True)
    report["newton_iteration"] = steps
    report["load_average_after"] = os.getloadavg()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=1))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
