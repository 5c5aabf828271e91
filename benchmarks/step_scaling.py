"""Cost of one Newton iteration of the compiled step against model size, 10 to 10⁵ elements.

    python benchmarks/step_scaling.py [--max 100000] [--formulation cr4402]
    python benchmarks/step_scaling.py --sizes 30,100,300,1000,10000,100000 --threads 1,2 --repeats 3


A free–free beam (3D, both section stiffnesses and a twist, no rotary inertia) in a slow
tumble, meshed into 10, 10², 10³, 10⁴, 10⁵ elements; a few generalized-α steps of the
compiled step (latdyn/step/compiled.py) after a warm-up, full Newton; the time of each step
divided by its Newton iterations (wall and CPU time of the process), median over the steps (a step that does not converge
within ITERATIONS is timed all the same: the cost of an iteration is what is measured,
and the table says how many steps converged). Small models use the dense LU,
the larger ones the band LU after reverse Cuthill–McKee (bandwidth stays ~11 for a beam).
The scene loader's element limit (latdyn.scene.loader.MAX_ELEMENTS) is raised for the run.
The table and the machine go to benchmarks/results/step_scaling.json.

``--threads 1,2``: each size is timed with the element part of the step (geometry and
kernels, csrc/newton_step.c) on 1 thread (serial, threshold 0) and on each thread count
given (threshold 1, i.e. forced on), ``--repeats`` rounds with the thread counts
interleaved so that a change of load falls on all alike; the speed-up is the median wall
time per iteration on 1 thread over that on n, and the 1-minute load average is recorded
with every row (on a shared machine it is the first thing to read). Results go to
benchmarks/results/step_scaling_threads.json.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

import latdyn
import latdyn.scene.loader
from latdyn.step.compiled import CompiledGeneralizedAlpha
from latdyn.step.integrators import AlphaParameters
from latdyn.assembly.prepare import prepare


#: Newton iterations a step may take here (a step that does not converge in them is timed
#: all the same, and counted in ``steps_converged``).
ITERATIONS = 6


def beam(elements: int, formulation: str) -> dict:
    length = 10.0
    return {
        "sections": {"s": {"EA": 2.8e7, "EIy": 1.4e4, "EIz": 2.1e4, "GJ": 1.0e4, "rhoA": 1.2}},
        "initial_velocity": {"angular": [0.1, 0.3, 1.0], "linear": [0.0, 0.5, 0.1]},
        "bodies": {"a": {"at": [0, 0, 0], "mass": 1.0, "inertia": [0.1, 0.1, 0.1]}},
        "beams": {"b": {"from": "a", "to": [length, 0.3, 0.2], "section": "s", "elements": elements}},
        "solve": {"analysis": "transient", "t_end": 1.0, "dt": 1e-3, "formulation": formulation,
                  "engine": "compiled"},
        "output": {"probes": {}},
    }


def timed_steps(step, state, h: float, steps: int) -> list:
    """``steps`` steps of the started ``step`` after one untimed (the first sets up the scatter
    maps and buffers), each from the last converged state (a step that does not converge is
    timed all the same: the cost of an iteration is what is measured): per timed step
    (wall s, CPU s of the process, its StepStats)."""
    out = []
    for k in range(steps + 1):
        started, started_cpu = time.perf_counter(), time.process_time()
        new, stats = step.step(state, h)
        wall, cpu = time.perf_counter() - started, time.process_time() - started_cpu
        if stats.converged:
            step.accept()
            state = new
        if k:
            out.append((wall, cpu, stats))
    return out


def measure(elements: int, formulation: str, steps: int, threads: int | None = None, prepared=None) -> dict:
    """Time ``steps`` steps (after one untimed); ``threads``: None = the runtime's default
    threshold, 1 = serial, n > 1 = the element part forced onto n threads."""
    if prepared is None:
        prepared = prepare(latdyn.load_scene(beam(elements, formulation)))
    model = prepared.model
    parallel = {} if threads is None else {"parallel_elements": 0 if threads == 1 else 1,
                                           "threads": 0 if threads == 1 else threads}
    step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                    1e-8, ITERATIONS, 10.0, **parallel)
    step.start(prepared.state)
    timed = timed_steps(step, prepared.state, 1e-3, steps)
    iterations = [stats.iterations if stats.converged else ITERATIONS for _, _, stats in timed]
    per_iteration = float(np.median([wall / done for (wall, _, _), done in zip(timed, iterations)]))
    return {"elements": elements, "coordinates": model.n_dofs, "band": step.factorization.kind == "band",
            "bandwidth": step.factorization.kl if step.factorization.kind == "band" else None,
            "iterations_per_step": float(np.mean(iterations)),
            "steps_converged": int(sum(stats.converged for _, _, stats in timed)),
            "steps": len(timed), "s_per_iteration": per_iteration,
            "us_per_element_iteration": 1e6 * per_iteration / elements,
            "cpu_s_per_iteration": float(np.median([cpu / done for (_, cpu, _), done in zip(timed, iterations)])),
            "threads": threads, "load_average": os.getloadavg()[0]}


def thread_table(sizes: list[int], counts: list[int], formulation: str, steps: int, repeats: int) -> list[dict]:
    """Per size: wall and CPU per iteration on each thread count, rounds interleaved."""
    rows = []
    print(f"{'elements':>9s} {'threads':>7s} {'wall ms/it':>11s} {'CPU ms/it':>10s} {'speed-up':>9s} {'load':>6s}"
          f"  (median of {repeats} rounds of {steps} steps)")
    for size in sizes:
        prepared = prepare(latdyn.load_scene(beam(size, formulation)))
        samples = {n: [] for n in counts}
        for _ in range(repeats):
            for n in counts:
                samples[n].append(measure(size, formulation, steps, threads=n, prepared=prepared))
        serial = float(np.median([r["s_per_iteration"] for r in samples[1]])) if 1 in samples else None
        for n in counts:
            wall = float(np.median([r["s_per_iteration"] for r in samples[n]]))
            cpu = float(np.median([r["cpu_s_per_iteration"] for r in samples[n]]))
            load = [r["load_average"] for r in samples[n]]
            row = {"elements": size, "threads": n, "s_per_iteration": wall, "cpu_s_per_iteration": cpu,
                   "s_per_iteration_all": [r["s_per_iteration"] for r in samples[n]],
                   "speed_up": serial / wall if serial else None,
                   "load_average": [min(load), max(load)]}
            rows.append(row)
            print(f"{size:9d} {n:7d} {1e3 * wall:11.3f} {1e3 * cpu:10.3f} "
                  f"{row['speed_up'] if row['speed_up'] else float('nan'):9.2f} {max(load):6.2f}", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max", type=int, default=100_000)
    parser.add_argument("--formulation", default="cr4402")
    parser.add_argument("--steps", type=int, default=5)
    parser.add_argument("--threads", help="thread counts to compare, e.g. 1,2 (adds the threads table)")
    parser.add_argument("--sizes", help="element counts for the threads table, e.g. 100,1000,10000")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    latdyn.scene.loader.MAX_ELEMENTS = max(latdyn.scene.loader.MAX_ELEMENTS, args.max)
    if args.threads:
        from latdyn.assembly.library import openmp_threads, parallel_threshold

        counts = [int(n) for n in args.threads.split(",")]
        sizes = [int(n) for n in args.sizes.split(",")] if args.sizes else [10, 100, 1000, 10_000, 100_000]
        latdyn.scene.loader.MAX_ELEMENTS = max(latdyn.scene.loader.MAX_ELEMENTS, max(sizes))
        machine = {"cores": os.cpu_count(), "python": platform.python_version(),
                   "openmp_threads": openmp_threads(), "threshold": parallel_threshold(),
                   "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS"),
                   "load_average_before": os.getloadavg()}
        print(f"{os.cpu_count()} cores, OpenMP threads {machine['openmp_threads']}, load {machine['load_average_before']}")
        rows = thread_table(sizes, counts, args.formulation, args.steps, args.repeats)
        machine["load_average_after"] = os.getloadavg()
        out = Path(__file__).resolve().parent / "results" / "step_scaling_threads.json"
        out.write_text(json.dumps({"machine": machine, "formulation": args.formulation, "rows": rows}, indent=1))
        print(f"wrote {out}")
        return
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if "model name" in line), "?")
    machine = {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
               "load_average_before": os.getloadavg()}
    print(f"CPU {cpu}, {os.cpu_count()} cores; load {machine['load_average_before']}; formulation {args.formulation}")
    print(f"{'elements':>9s} {'coords':>8s} {'LU':>6s} {'it/step':>8s} {'ms/iteration':>13s} {'µs/element-it':>14s} "
          f"{'CPU ms/it':>10s}")
    rows = []
    size = 10
    while size <= args.max:
        row = measure(size, args.formulation, args.steps)
        rows.append(row)
        lu = f"band{row['bandwidth']}" if row["band"] else "dense"
        print(f"{row['elements']:9d} {row['coordinates']:8d} {lu:>6s} {row['iterations_per_step']:8.1f} "
              f"{1e3 * row['s_per_iteration']:13.3f} {row['us_per_element_iteration']:14.2f} "
              f"{1e3 * row['cpu_s_per_iteration']:10.3f} "
              f"converged {row['steps_converged']}/{row['steps']}", flush=True)
        size *= 10
    machine["load_average_after"] = os.getloadavg()
    out = Path(__file__).resolve().parent / "results" / "step_scaling.json"
    out.write_text(json.dumps({"machine": machine, "formulation": args.formulation, "rows": rows}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
