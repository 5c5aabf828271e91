"""Newton-iteration linear solve: dense LU vs sparse LU, BLAS threads 1 vs 2.

For beam models of 10 … ~5000 elements — single free beams (the flying
spaghetti, banded) and 3D lattices of joint bodies joined by beams, some
through hinges (not banded) — this times what one Newton iteration of the
implicit integrators does with the linear system:

    S = β′M + γ′C + K   (``Evaluation.combined``, dense array or CSR)
    solve S Δx = −r

with each method below, under BLAS limits of 1 and 2 threads (threadpoolctl),
and writes medians to ``benchmarks/results/linear_solvers.json``:

  dense_numpy      combined(dense=True), numpy.linalg.solve (LAPACK gesv, numpy's OpenBLAS)
  dense_scipy      combined(dense=True), scipy.linalg.solve(overwrite_a, no finite check) (scipy's OpenBLAS)
  splu_COLAMD      combined(dense=False), scipy splu, permc_spec COLAMD (SuperLU default)
  splu_MMD_AT_PLUS_A, splu_MMD_ATA, splu_NATURAL   the other orderings
  splu_sym         MMD_AT_PLUS_A with SymmetricMode and diag_pivot_thresh 0.1 (S is
                   structurally symmetric and nearly so numerically)
  splu_sym_scaled  the same on D S D, D = |diag S|^(-1/2): with a unit diagonal the threshold
                   pivoting keeps to the diagonal and so to the ordering's fill
  splu_reuse       splu_sym_scaled with the fill-reducing permutation computed once, the
                   CSR values scattered straight into the permuted CSC by a precomputed map,
                   then splu NATURAL + SymmetricMode: ordering and transposition are not
                   repeated (SuperLU exposes no symbolic-only step)
  rcm_banded       reverse Cuthill–McKee once, a precomputed map from CSR values to LAPACK
                   band storage, then gbsv (scipy.linalg.solve_banded): a reused
                   symbolic analysis in the strict sense (skipped when the RCM bandwidth > 300)
  latdyn           latdyn.assembly.factorization.solve_linear on the matrix the Assembler makes: the policy chosen
                   from these numbers (dense LU up to DENSE_LIMIT, else band LU or reused SuperLU)

It also times the unheld-coordinate check (``Model.check_held``) at ~10⁴ coordinates.

Usage:  python benchmarks/linear_solvers.py [--quick] [--budget SECONDS] [--held-check-only]

The machine is named from lscpu; on a shared machine (2 cores, other jobs)
timings are noisy: medians of repeated solves, each case interleaving its
repetitions across thread counts.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import scipy
import scipy.linalg as sla
import scipy.sparse as sps
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from latdyn.assembly.assembler import Assembler, unpack_free  # noqa: E402
from latdyn.model.kernels import load_kernels  # noqa: E402
from latdyn.assembly.factorization import solve_linear  # noqa: E402
from latdyn.model.model import Model  # noqa: E402
from latdyn.assembly.factorization import Factorization  # noqa: E402
from latdyn.scene.loader import load_scene  # noqa: E402

try:  # normally installed alongside scipy
    from threadpoolctl import ThreadpoolController
except ImportError:  # pragma: no cover
    ThreadpoolController = None

RESULTS = ROOT / "benchmarks" / "results" / "linear_solvers.json"

# ----------------------------------------------------------------------------- models


def beam_scene(elements: int) -> dict:
    """The flying spaghetti of examples/benchmarks/D3 (free beam, a massless end body)."""
    return {
        "title": f"free beam, {elements} elements",
        "sections": {"s": {"EA": 1.0e4, "EIy": 500.0, "EIz": 500.0, "GJ": 500.0, "rhoA": 1.0,
                           "rhoIy": 10.0, "rhoIz": 10.0}},
        "bodies": {"a": {"at": [6, 0, 0]}},
        "beams": {"spaghetti": {"from": "a", "to": [0, 0, 8], "section": "s", "elements": elements}},
        "initial_velocity": {"angular": [0.3, 0.2, 1.0]},
        "solve": {"analysis": "transient", "t_end": 1.0, "dt": 0.01, "method": "newmark"},
    }


def lattice_scene(nx: int, ny: int, nz: int, per_beam: int) -> dict:
    """A 3D frame: joint bodies (mass, inertia) on an nx×ny×nz grid, the bottom layer
    fixed, beams along every grid edge (``per_beam`` elements each); beams along x
    end in a sprung hinge, so hinge coordinates couple the pattern too."""
    bodies, beams = {}, {}
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                bodies[f"j{i}_{j}_{k}"] = {"at": [float(i), float(j), float(k)], "mass": 2.0,
                                           "inertia": [0.01, 0.02, 0.03], "fixed": k == 0}
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                for d, (di, dj, dk) in enumerate(((1, 0, 0), (0, 1, 0), (0, 0, 1))):
                    a, b, c = i + di, j + dj, k + dk
                    if a >= nx or b >= ny or c >= nz or (k == 0 and dk == 0):
                        continue
                    beam = {"from": f"j{i}_{j}_{k}", "to": f"j{a}_{b}_{c}", "section": "s",
                            "elements": per_beam}
                    if d == 0:
                        beam["end"] = {"hinge": {"axis": [0, 1, 0], "stiffness": 50.0}}
                    beams[f"b{i}_{j}_{k}_{d}"] = beam
    return {
        "title": f"lattice {nx}x{ny}x{nz}, {per_beam} elements per beam",
        "sections": {"s": {"EA": 2.0e6, "EIy": 80.0, "EIz": 120.0, "GJ": 60.0, "rhoA": 0.5,
                           "rhoIy": 1e-3, "rhoIz": 1e-3}},
        "bodies": bodies, "beams": beams,
        "initial_velocity": {"angular": [0.0, 0.0, 0.5]},
        "solve": {"analysis": "transient", "t_end": 1.0, "dt": 0.01, "method": "newmark"},
    }


def lattice_for(elements: int) -> dict:
    """A roughly cubic lattice with about ``elements`` elements (4 per beam when large)."""
    best = None
    for per_beam in (1, 2, 4):
        for n in range(2, 16):
            for nz in (n, n + 1):
                count = per_beam * (n * n + 2 * n * (n - 1)) * (nz - 1)  # vertical + horizontal edges
                score = abs(np.log(count / elements)) + 0.05 * per_beam
                if best is None or score < best[0]:
                    best = (score, n, nz, per_beam)
    _, n, nz, per_beam = best
    return lattice_scene(n, n, nz, per_beam)


def build(raw: dict, seed: int = 0):
    """Model, assembler and an evaluation with matrices at a perturbed moving state."""
    scene = load_scene(raw)
    model = Model.from_scene(scene)
    assembler = Assembler(model, load_kernels(backend="auto", variant=scene.solve.formulation), scene.gravity)
    state = assembler.initial_state()
    rng = np.random.default_rng(seed)
    state = assembler.advance(state, 1e-3 * rng.standard_normal(model.n_dofs))
    v = 0.1 * rng.standard_normal(model.n_dofs)
    unpack_free(model, v, state.v, state.w, state.theta_dot)
    ev = assembler.evaluate(state, matrices=True)
    return model, assembler, ev


# ----------------------------------------------------------------------------- methods

H, BETA, GAMMA = 0.01, 0.25, 0.5  # Newmark at dt = 0.01, as in D3
BETA_P, GAMMA_P = 1.0 / (H * H * BETA), GAMMA / (H * BETA)


def combined(ev, dense):
    return ev.combined(BETA_P, GAMMA_P, 1.0, dense=dense)


def _scaled(S):
    """D S D with D = |diag S|^(-1/2) (unit diagonal), and D."""
    d = np.abs(S.diagonal())
    d[~(d > 0)] = 1.0
    scale = 1.0 / np.sqrt(d)
    rows = np.repeat(np.arange(S.shape[0]), np.diff(S.indptr))
    return sps.csr_matrix((S.data * scale[rows] * scale[S.indices], S.indices, S.indptr), shape=S.shape), scale


SYMMETRIC = {"diag_pivot_thresh": 0.1, "options": {"SymmetricMode": True}}


def _scaled_solve(ev, rhs):
    C, scale = _scaled(combined(ev, False))
    return scale * spla.splu(C.tocsc(), permc_spec="MMD_AT_PLUS_A", **SYMMETRIC).solve(scale * rhs)


def _reuse_setup(ev):
    """Ordering once; map from CSR value order to the permuted CSC value order."""
    C, _ = _scaled(combined(ev, False))
    # perm_c maps an old column to its new place (L U = Pr S Pc); SymmetricMode keeps Pr ≈ Pc
    perm = spla.splu(C.tocsc(), permc_spec="MMD_AT_PLUS_A", **SYMMETRIC).perm_c
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(perm))  # new place -> old index
    tag = sps.csr_matrix((np.arange(1, C.nnz + 1, dtype=float), C.indices, C.indptr), shape=C.shape)
    permuted = tag[inverse][:, inverse].tocsc()  # B = P S Pᵀ with B[i, j] = S[inverse[i], inverse[j]]
    permuted.sort_indices()
    order = permuted.data.astype(np.int64) - 1
    return {"order": order, "indices": permuted.indices.copy(), "indptr": permuted.indptr.copy(),
            "inverse": inverse, "shape": C.shape}


def _reuse_solve(ev, rhs, setup):
    C, scale = _scaled(combined(ev, False))
    B = sps.csc_matrix((C.data[setup["order"]], setup["indices"], setup["indptr"]), shape=setup["shape"])
    lu = spla.splu(B, permc_spec="NATURAL", **SYMMETRIC)
    y = lu.solve((scale * rhs)[setup["inverse"]])
    out = np.empty_like(y)
    out[setup["inverse"]] = y
    return scale * out


def _banded_setup(ev):
    S = combined(ev, False)
    perm = csgraph.reverse_cuthill_mckee(S, symmetric_mode=True)
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(len(perm))
    rows = np.repeat(np.arange(S.shape[0]), np.diff(S.indptr))
    i, j = inverse[rows], inverse[S.indices]
    lower, upper = int(np.max(i - j, initial=0)), int(np.max(j - i, initial=0))
    return {"lower": lower, "upper": upper, "band_rows": upper + i - j, "band_cols": j,
            "perm": perm, "n": S.shape[0]}


def _banded_solve(ev, rhs, setup):
    S = combined(ev, False)
    ab = np.zeros((setup["lower"] + setup["upper"] + 1, setup["n"]))
    ab[setup["band_rows"], setup["band_cols"]] = S.data
    y = sla.solve_banded((setup["lower"], setup["upper"]), ab, rhs[setup["perm"]], overwrite_ab=True,
                         overwrite_b=True, check_finite=False)
    out = np.empty_like(y)
    out[setup["perm"]] = y
    return out


def methods(ev, n, nnz, dense_max):
    """name -> (setup or None, solve(rhs, setup))."""
    out = {}
    if n <= dense_max:
        out["dense_numpy"] = (None, lambda b, s: np.linalg.solve(combined(ev, True), b))
        out["dense_scipy"] = (None, lambda b, s: sla.solve(combined(ev, True), b, overwrite_a=True,
                                                          check_finite=False))
    for spec in ("COLAMD", "MMD_AT_PLUS_A", "MMD_ATA", "NATURAL"):
        out[f"splu_{spec}"] = (None, lambda b, s, spec=spec: spla.splu(combined(ev, False).tocsc(),
                                                                         permc_spec=spec).solve(b))
    out["splu_sym"] = (None, lambda b, s: spla.splu(combined(ev, False).tocsc(), permc_spec="MMD_AT_PLUS_A",
                                                     **SYMMETRIC).solve(b))
    out["splu_sym_scaled"] = (None, lambda b, s: _scaled_solve(ev, b))
    out["splu_reuse"] = (_reuse_setup, lambda b, s: _reuse_solve(ev, b, s))
    if rcm_bandwidth(ev) <= 300:  # n b² work: hopeless beyond
        out["rcm_banded"] = (_banded_setup, lambda b, s: _banded_solve(ev, b, s))
    # the policy of latdyn/numerics/linalg.py, as the integrators call it (assembly form chosen by the Assembler)
    out["latdyn"] = (None, lambda b, s: solve_linear(ev.combined(BETA_P, GAMMA_P, 1.0), b))
    return out


# ----------------------------------------------------------------------------- timing


def machine() -> str:
    try:
        text = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        info = dict(line.split(":", 1) for line in text.splitlines() if ":" in line)
        name = info.get("Model name", "?").strip()
        cpus = info.get("CPU(s)", "?").strip()
        hyper = info.get("Hypervisor vendor", "").strip()
        return f"{name}, {cpus} CPUs" + (f" ({hyper} guest)" if hyper else "")
    except Exception:  # noqa: BLE001
        return platform.processor() or platform.machine()


def time_case(ev, n, nnz, threads, budget, dense_max, controller, rng):
    """Median seconds per solve of every method at every thread count, and the solution error."""
    rhs = rng.standard_normal(n)
    reference = None
    results = {}
    for name, (setup_fn, solve) in methods(ev, n, nnz, dense_max).items():
        t0 = time.perf_counter()
        setup = setup_fn(ev) if setup_fn else None
        setup_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        x = solve(rhs.copy(), setup)
        first_s = time.perf_counter() - t0
        if reference is None:
            reference = x
        error = float(np.max(np.abs(x - reference)) / max(np.max(np.abs(reference)), 1e-300))
        samples = {t: [] for t in threads}
        start = time.perf_counter()
        # interleave thread counts so that the load of other jobs hits both alike
        while True:
            for t in threads:
                if controller is not None:
                    with controller.limit(limits=t, user_api="blas"):
                        t1 = time.perf_counter()
                        solve(rhs.copy(), setup)
                        samples[t].append(time.perf_counter() - t1)
                else:
                    t1 = time.perf_counter()
                    solve(rhs.copy(), setup)
                    samples[t].append(time.perf_counter() - t1)
            count = len(samples[threads[0]])
            elapsed = time.perf_counter() - start
            if count >= 41 or (count >= 5 and elapsed > budget) or (count >= 2 and elapsed > 4 * budget) \
                    or first_s > 10 * budget:  # far too slow to matter: one sample each
                break
        results[name] = {"setup_s": setup_s, "first_call_s": first_s, "error": error,
                         "median_s": {str(t): float(np.median(v)) for t, v in samples.items()},
                         "min_s": {str(t): float(np.min(v)) for t, v in samples.items()},
                         "repeats": count}
    return results


def rcm_bandwidth(ev) -> int:
    S = combined(ev, False)
    perm = csgraph.reverse_cuthill_mckee(S, symmetric_mode=True)
    B = S[perm][:, perm].tocoo()
    return int(np.max(np.abs(B.row - B.col), initial=0))


def bandwidth(ev) -> int:
    S = combined(ev, False)
    rows = np.repeat(np.arange(S.shape[0]), np.diff(S.indptr))
    return int(np.max(np.abs(rows - S.indices), initial=0))


def held_check_timings(repeats: int = 3) -> list[dict]:
    """Seconds of the unheld-coordinate check (Model.check_held: sparse LU + inverse
    iteration) at ~10⁴ coordinates, and of evaluating M and K at rest before it."""
    from latdyn.errors import SceneError

    def held_beam(elements, fixed):
        raw = beam_scene(elements)
        raw["bodies"]["a"]["fixed"] = fixed
        raw["sections"]["s"].pop("rhoIy")
        raw["sections"]["s"].pop("rhoIz")  # massless twist: the hardest held case
        return raw

    cases = [("beam, clamped, no rotary inertia (held)", held_beam(1666, True)),
             ("beam, free, no rotary inertia (spin unheld)", held_beam(1666, False)),
             ("lattice (held)", lattice_scene(9, 9, 6, 2))]
    rows = []
    for label, raw in cases:
        scene = load_scene(raw)
        model = Model.from_scene(scene)
        assembler = Assembler(model, load_kernels(backend="auto", variant=scene.solve.formulation), scene.gravity)
        state = assembler.initial_state()
        evaluate, check, verdict = [], [], None
        for _ in range(repeats):
            t0 = time.perf_counter()
            ev = assembler.evaluate(state, matrices=True, load_factor=0.0)
            M, K = ev.mass, ev.stiffness
            t1 = time.perf_counter()
            try:
                model.check_held(M, K, "<bench>", Factorization)
                verdict = "held"
            except SceneError as error:
                verdict = str(error).split(": ", 1)[1][:100]
            t2 = time.perf_counter()
            evaluate.append(t1 - t0)
            check.append(t2 - t1)
        row = {"model": label, "n": model.n_dofs, "evaluate_s": float(np.median(evaluate)),
               "check_s": float(np.median(check)), "verdict": verdict}
        rows.append(row)
        print(f"held check: {label:45s} n={row['n']:6d}  M,K {1e3 * row['evaluate_s']:.0f} ms  "
              f"check {1e3 * row['check_s']:.0f} ms  -> {verdict}", flush=True)
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only")
    parser.add_argument("--budget", type=float, default=0.4, help="seconds of repeats per method and case")
    parser.add_argument("--dense-max", type=int, default=2500, help="largest system solved densely")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--held-check-only", action="store_true",
                        help="only time the unheld-coordinate check (~10⁴ coordinates), merged into --out")
    args = parser.parse_args(argv)
    if args.held_check_only:
        report = json.loads(args.out.read_text()) if args.out.exists() else {"machine": machine()}
        report["held_check"] = held_check_timings()
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(report, indent=1))
        return

    controller = ThreadpoolController() if ThreadpoolController is not None else None
    threads = (1, 2) if controller is not None else (0,)
    beams = (10, 16, 20, 24, 32, 48, 64, 100, 128, 200, 400, 800, 1600, 3200, 5000)
    lattices = (24, 60, 120, 250, 500, 1000, 2500, 5000)
    if args.quick:
        beams, lattices = (10, 32, 64, 128, 400), (24, 120, 500)
    cases = [("beam", e, beam_scene(e)) for e in beams] + [("lattice", e, lattice_for(e)) for e in lattices]
    rng = np.random.default_rng(1)
    rows = []
    for kind, target, raw in cases:
        model, _, ev = build(raw)
        S = combined(ev, False)
        n, nnz = model.n_dofs, S.nnz
        timings = time_case(ev, n, nnz, threads, args.budget, args.dense_max, controller, rng)
        row = {"kind": kind, "elements": len(model.element_nodes), "bodies": len(model.body_node),
               "hinges": len(model.free_hinges), "n": n, "nnz": int(nnz), "bandwidth": bandwidth(ev),
               "rcm_bandwidth": rcm_bandwidth(ev),
               "methods": timings}
        rows.append(row)
        print(_row_line(row, threads), flush=True)

    held = held_check_timings()
    blas = controller.select(user_api="blas").info() if controller is not None else []
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    report = {"machine": machine(), "cores": os.cpu_count(), "load_average_at_end": load,
              "shared_machine_note": "2 cores shared with other jobs: medians, noisy",
              "python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
              "blas": [{k: b.get(k) for k in ("filepath", "version", "num_threads", "architecture")} for b in blas],
              "newton": {"h": H, "beta_prime": BETA_P, "gamma_prime": GAMMA_P},
              "threads": list(threads), "rows": rows, "held_check": held}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=1))
    print()
    print(table(report))
    print(f"\nwritten {args.out}")


SHOWN = ("dense_numpy", "splu_COLAMD", "splu_sym", "splu_sym_scaled", "splu_reuse", "rcm_banded", "latdyn")


def _row_line(row, threads):
    parts = [f"{row['kind']:8s} {row['elements']:5d} el n={row['n']:6d} nnz={row['nnz']:8d} rcm bw={row['rcm_bandwidth']:5d}"]
    for name in SHOWN:
        m = row["methods"].get(name)
        if m is None:
            continue
        times = "/".join(f"{1e3 * m['median_s'][str(t)]:.3g}" for t in threads)
        parts.append(f"{name}={times}")
    return "  ".join(parts) + " ms"


def table(report) -> str:
    """Markdown table: median ms per Newton solve (assembly of S included), threads 1 / 2."""
    threads = report["threads"]
    head = "| model | elements | n | nnz | RCM bandwidth | " + " | ".join(SHOWN) + " |"
    lines = [f"machine: {report['machine']}; BLAS threads {' / '.join(map(str, threads))}; "
             "median ms per solve, assembly of S included", "", head,
             "|" + "---|" * (5 + len(SHOWN))]
    for row in report["rows"]:
        cells = []
        for name in SHOWN:
            m = row["methods"].get(name)
            cells.append("—" if m is None else " / ".join(f"{1e3 * m['median_s'][str(t)]:.3g}" for t in threads))
        lines.append(f"| {row['kind']} | {row['elements']} | {row['n']} | {row['nnz']} | {row['rcm_bandwidth']} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
