"""latdyn's cost per Newton iteration on the lattice of ``peers.py`` from 10² to 10⁵ elements,
and what a 2·10⁵-coordinate model over 500 s simulated would take on this machine.

    python benchmarks/lattice_scaling.py                       # 8 … 8334 bays, 1 element a member
    python benchmarks/lattice_scaling.py --bays 8,64,512 --steps 3
    python benchmarks/lattice_scaling.py --markdown benchmarks/results/lattice_scaling.json

The model is the clamped truss beam of ``benchmarks/lattice.py`` (12 members a bay, one
element a member: 12·N elements, 24·N coordinates; 8334 bays = 100 008 elements = 200 016
coordinates, the size of an AstroMesh-class model), at its own tip pulse and dt = T/50.  For
each size and formulation (``cr4402``, the benchmark's fastest, and ``default``) the compiled
step (latdyn.step.compiled.CompiledGeneralizedAlpha, as ``latdyn.run`` builds it) takes
``--steps`` steps after one untimed step, twice:

- *full Newton*: every iteration evaluates the elements with their tangents, assembles and
  factorizes the iteration matrix and solves: "full iteration";
- *modified Newton* with the factorization held: the iterations of the steps that did not
  refactorize evaluate the residual only and solve: "held iteration".

Their difference is the tangent part of an iteration (element tangents, the scatter into the
matrix, the LU).  The LU alone is timed besides: LAPACK ``dgbtrf`` + ``dgbtrs`` (SciPy) on a
band matrix of the step's size and bandwidth (reverse Cuthill–McKee, as the compiled step
uses it: the truss beam is chain-like, its bandwidth stays ~50 at any length), BLAS on one
thread as in the step.  Wall time, medians over the steps; the 1-minute load average with
every row.  The element part runs on the runtime's default threads (OpenMP from 10³ elements;
``--serial`` forces one thread).

The extrapolation (printed and stored, labelled so) multiplies: steps = 500 s / dt, with dt
= T_res / k — k the steps per period of the fastest latdyn setting within 1 % in
``benchmarks/results/peers.json`` at its largest lattice, T_res the shortest period the run must
resolve (an assumption: 1 s and 0.1 s are tabulated) — × Newton iterations per step and
factorizations per step of that same matched run × the measured full/held iteration costs at
200 016 coordinates.  It assumes the deployment converges as the benchmark's small-amplitude
vibration does (same iterations per step), no step cuts, and no results written.

The scene loader's element limit (latdyn.scene.loader.MAX_ELEMENTS, 10⁴) is raised for the
run; ``latdyn run`` on a scene file refuses more than 10⁴ elements.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from peers import latdyn  # noqa: E402  (latdyn of this checkout)

import lattice  # noqa: E402
from step_scaling import timed_steps  # noqa: E402
import latdyn.scene.loader  # noqa: E402
from latdyn.assembly.prepare import prepare  # noqa: E402
from latdyn.step.compiled import CompiledGeneralizedAlpha  # noqa: E402
from latdyn.step.integrators import AlphaParameters  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "lattice_scaling.json"
BAYS = (8, 32, 128, 512, 2084, 8334)
STEPS_PER_T = 50
T_RES = (1.0, 0.1)      # s: periods a 500 s deployment run resolves (assumption, tabulated)
SIMULATED = 500.0       # s
EXTRAPOLATION_ASSUMPTIONS = (
    "steps = 500 s / (T_res / k), k the steps per period of latdyn's fastest setting within 1 % at the largest "
    "lattice of peers.json; its Newton iterations and factorizations per step; a factorizing iteration costs the "
    "measured full iteration, the others the held one, at the largest model measured; the deployment converges "
    "like the benchmark's vibration (no step cuts, same iterations per step), no results written.")


def band_lu_seconds(n: int, kl: int, ku: int, repeats: int = 3) -> float:
    """dgbtrf + dgbtrs of a random diagonally dominant band matrix (n, kl, ku), one BLAS thread."""
    from scipy.linalg import lapack
    from threadpoolctl import threadpool_limits

    rng = np.random.default_rng(0)
    ab = np.zeros((2 * kl + ku + 1, n), order="F")
    ab[kl:, :] = rng.standard_normal((kl + ku + 1, n))
    ab[kl + ku, :] += 4 * (kl + ku + 1)
    rhs = rng.standard_normal(n)
    samples = []
    work = np.empty_like(ab, order="F")
    with threadpool_limits(limits=1, user_api="blas"):
        for _ in range(repeats):
            np.copyto(work, ab)   # in place, untimed: the step factorizes its own preallocated buffer
            t0 = time.perf_counter()
            lu, piv, info = lapack.dgbtrf(work, kl, ku, overwrite_ab=1)
            lapack.dgbtrs(lu, kl, ku, rhs, piv)
            samples.append(time.perf_counter() - t0)
    return float(np.median(samples))


def measure(bays: int, formulation: str, steps: int, serial: bool) -> dict:
    eq = lattice.equivalent_beam(bays)
    h = eq["T"] / STEPS_PER_T
    t0 = time.perf_counter()
    scene = latdyn.load_scene(lattice.latdyn_scene(bays, 1, h, formulation=formulation))
    prepared = prepare(scene)
    build_s = time.perf_counter() - t0
    model = prepared.model
    params = AlphaParameters.for_method("generalized-alpha", 0.8)
    row = {"bays": bays, "elements": len(model.element_nodes), "coordinates": int(model.n_dofs),
           "formulation": formulation, "threads": "serial" if serial else "default", "dt": h,
           "build_s": build_s}
    parallel = {"parallel_elements": 0} if serial else {}
    for newton in ("full", "modified"):
        step = CompiledGeneralizedAlpha(prepared.assembler, params, 1e-8, 8, eq["L"], newton=newton, **parallel)
        step._setup()
        f = step.factorization
        row["solver"] = f.kind
        if f.kind == "band":
            row["kl"], row["ku"] = f.kl, f.ku
        step.start(prepared.state)
        t0 = time.perf_counter()
        # per timed step (wall s, iterations, factorizations, converged)
        samples = [(wall, max(stats.iterations, 1),
                    stats.factorizations if stats.factorizations is not None else stats.iterations,
                    bool(stats.converged)) for wall, _, stats in timed_steps(step, prepared.state, h, steps)]
        row[f"{newton}_wall_s"] = time.perf_counter() - t0
        if newton == "full":
            per = [w / it for w, it, _, _ in samples]
            row["full_iteration_s"] = float(np.median(per))
            row["full_iterations_per_step"] = float(np.mean([it for _, it, _, _ in samples]))
        else:
            held = [w / it for w, it, f, _ in samples if f == 0]
            row["held_iteration_s"] = float(np.median(held)) if held else None
            row["held_steps"] = len(held)
        row[f"{newton}_converged"] = f"{sum(c for *_, c in samples)}/{len(samples)}"
    if row.get("kl") is not None:
        row["band_lu_s"] = band_lu_seconds(row["coordinates"], row["kl"], row["ku"])
    if row.get("held_iteration_s"):
        row["tangent_part_s"] = row["full_iteration_s"] - row["held_iteration_s"]
    row["us_per_element_full_iteration"] = 1e6 * row["full_iteration_s"] / row["elements"]
    if row.get("held_iteration_s"):
        row["us_per_element_held_iteration"] = 1e6 * row["held_iteration_s"] / row["elements"]
    row["load_average"] = os.getloadavg()[0]
    return row


def matched_setting(peers_json: Path) -> dict | None:
    """The fastest latdyn lattice setting within tolerance at the largest size in peers.json."""
    if not peers_json.exists():
        return None
    doc = json.loads(peers_json.read_text())
    matched = [m for m in doc.get("matched", []) if m.get("problem") == "lattice" and m.get("latdyn_setting")]
    if not matched:
        return None
    m = max(matched, key=lambda x: x["bays"])
    row = next(r for r in doc["rows"] if r["problem"] == "lattice" and r["code"] == "latdyn"
               and r["setting"] == m["latdyn_setting"])
    full = [r for r in doc["rows"] if r["problem"] == "lattice" and r["code"] == "latdyn" and r.get("candidate")
            and r["bays"] == row["bays"] and r["newton"].startswith("full")]
    return {"bays": row["bays"], "setting": row["setting"], "steps_per_T": row["steps_per_T"],
            "full_newton_setting": full[0]["setting"] if full else None,
            "full_newton_iterations_per_step": full[0]["newton_iterations"] / full[0]["steps"] if full else None,
            "iterations_per_step": row["newton_iterations"] / row["steps"],
            "factorizations_per_step": (row["jacobian_updates"] or row["newton_iterations"]) / row["steps"],
            "error": row["error"], "source": f"{peers_json.name} ({doc.get('created')})"}


def extrapolate(rows: list, setting: dict) -> list:
    """Wall time of a 500 s run of the largest measured model at the matched setting (labelled)."""
    out = []
    for formulation in dict.fromkeys(r["formulation"] for r in rows):
        mine = [r for r in rows if r["formulation"] == formulation]
        big = max(mine, key=lambda r: r["coordinates"])
        it, fact = setting["iterations_per_step"], setting["factorizations_per_step"]
        held = big.get("held_iteration_s") or big["full_iteration_s"]
        # a factorizing iteration costs a full iteration, the others a held one
        per_step = fact * big["full_iteration_s"] + max(it - fact, 0.0) * held
        for T in T_RES:
            steps = SIMULATED / (T / setting["steps_per_T"])
            out.append({"kind": "extrapolation", "formulation": formulation, "coordinates": big["coordinates"],
                        "elements": big["elements"], "T_res_s": T, "dt_s": T / setting["steps_per_T"],
                        "steps": steps, "iterations_per_step": it, "factorizations_per_step": fact,
                        "seconds_per_step": per_step, "wall_s": steps * per_step,
                        "wall_h": steps * per_step / 3600.0,
                        "full_newton_iterations_per_step": setting.get("full_newton_iterations_per_step"),
                        "full_newton_wall_h": (steps * setting["full_newton_iterations_per_step"] *
                                               big["full_iteration_s"] / 3600.0)
                        if setting.get("full_newton_iterations_per_step") else None})
    return out


def markdown(doc: dict) -> str:
    lines = [f"Machine: {doc['machine']['cpu']}, {doc['machine']['cores']} cores; load average "
             f"{doc['machine']['load_average_before'][0]:.2f} before, {doc['machine']['load_average_after'][0]:.2f} "
             f"after; {doc['steps']} timed steps a setting, dt = T/{STEPS_PER_T}.", "",
             "| bays | elements | coordinates | formulation | threads | LU | full iteration ms | held iteration ms "
             "| tangent part ms | band LU ms | µs / element, full | µs / element, held | build s | load |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        lu = r["solver"] + (f" (kl {r['kl']})" if r.get("kl") is not None else "")
        f = lambda x, s=".2f": "–" if x is None else format(x, s)  # noqa: E731
        lines.append(f"| {r['bays']} | {r['elements']} | {r['coordinates']} | {r['formulation']} | {r['threads']} | "
                     f"{lu} | {f(1e3 * r['full_iteration_s'])} | "
                     f"{f(r.get('held_iteration_s') and 1e3 * r['held_iteration_s'])} | "
                     f"{f(r.get('tangent_part_s') and 1e3 * r['tangent_part_s'])} | "
                     f"{f(r.get('band_lu_s') and 1e3 * r['band_lu_s'])} | {f(r['us_per_element_full_iteration'])} | "
                     f"{f(r.get('us_per_element_held_iteration'))} | {f(r['build_s'], '.1f')} | "
                     f"{r['load_average']:.2f} |")
    if doc.get("extrapolation"):
        s = doc["matched_setting"]
        lines += ["", f"**Extrapolation** (not measured: products of measured factors): the matched setting "
                      f"{s['setting']} (error {s['error']:.2e}; {s['iterations_per_step']:.2f} Newton iterations and "
                      f"{s['factorizations_per_step']:.3f} factorizations a step; {s['source']}), "
                      f"{SIMULATED:g} s simulated, dt = T_res/{s['steps_per_T']:g}:", "",
                  "| formulation | coordinates | T_res s | dt s | steps | s / step | wall h | wall h, full Newton "
                  f"({s.get('full_newton_iterations_per_step') or float('nan'):.2f} it./step, "
                  f"{s.get('full_newton_setting')}) |",
                  "|---|---|---|---|---|---|---|---|"]
        for x in doc["extrapolation"]:
            lines.append(f"| {x['formulation']} | {x['coordinates']} | {x['T_res_s']:g} | {x['dt_s']:.3g} | "
                         f"{x['steps']:.3g} | {x['seconds_per_step']:.3f} | {x['wall_h']:.1f} | "
                         f"{'–' if x['full_newton_wall_h'] is None else format(x['full_newton_wall_h'], '.1f')} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bays", default=",".join(map(str, BAYS)))
    ap.add_argument("--formulations", default="cr4402,default")
    ap.add_argument("--steps", type=int, default=4)
    ap.add_argument("--serial", action="store_true", help="element part on one thread")
    ap.add_argument("--peers", default=str(ROOT / "benchmarks" / "results" / "peers.json"))
    ap.add_argument("--out", default=str(OUT))
    ap.add_argument("--markdown", metavar="JSON")
    ap.add_argument("--extrapolate-only", action="store_true",
                    help="recompute the extrapolation of --out from its rows and the current --peers file")
    args = ap.parse_args(argv)
    if args.markdown:
        print(markdown(json.loads(Path(args.markdown).read_text())))
        return 0
    if args.extrapolate_only:
        doc = json.loads(Path(args.out).read_text())
        setting = matched_setting(Path(args.peers))
        doc["matched_setting"] = setting
        doc["extrapolation"] = extrapolate(doc["rows"], setting)
        Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")
        print(markdown(doc))
        return 0
    bays = [int(b) for b in args.bays.split(",")]
    latdyn.scene.loader.MAX_ELEMENTS = max(latdyn.scene.loader.MAX_ELEMENTS, 12 * max(bays) + 12)
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if "model name" in line), "?")
    from peers import _git

    machine = {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(), "git": _git(),
               "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS"), "load_average_before": os.getloadavg()}
    rows = []
    for b in bays:
        for formulation in args.formulations.split(","):
            row = measure(b, formulation, args.steps, args.serial)
            rows.append(row)
            print(f"{b:6d} bays {row['elements']:7d} el {row['coordinates']:7d} coords {formulation:8s} "
                  f"{row['solver']}{'' if row.get('kl') is None else ' kl ' + str(row['kl'])}: full "
                  f"{1e3 * row['full_iteration_s']:9.2f} ms/it, held "
                  f"{1e3 * (row.get('held_iteration_s') or float('nan')):9.2f} ms/it, band LU "
                  f"{1e3 * (row.get('band_lu_s') or float('nan')):8.2f} ms, build {row['build_s']:.1f} s, "
                  f"converged {row['full_converged']} / {row['modified_converged']}, load {row['load_average']:.2f}",
                  flush=True)
    machine["load_average_after"] = os.getloadavg()
    doc = {"schema": "latdyn-lattice-scaling/1", "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
           "machine": machine, "steps": args.steps, "steps_per_T": STEPS_PER_T, "rows": rows}
    setting = matched_setting(Path(args.peers))
    doc["extrapolation_assumptions"] = EXTRAPOLATION_ASSUMPTIONS
    if setting is not None:
        doc["matched_setting"] = setting
        doc["extrapolation"] = extrapolate(rows, setting)

    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")
    print(markdown(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
