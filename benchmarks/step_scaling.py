"""Cost of one Newton iteration of the compiled step against model size, 10 to 10⁵ elements.

    python benchmarks/step_scaling.py [--max 100000] [--formulation cr4402]

A free–free beam (3D, both section stiffnesses and a twist, no rotary inertia) in a slow
tumble, meshed into 10, 10², 10³, 10⁴, 10⁵ elements; a few generalized-α steps of the
compiled step (latdyn/engine.py) after a warm-up, full Newton; the time of each step
divided by its Newton iterations (wall and CPU time of the process), median over the steps (a step that does not converge
within ITERATIONS is timed all the same: the cost of an iteration is what is measured,
and the table says how many steps converged). Small models use the dense LU,
the larger ones the band LU after reverse Cuthill–McKee (bandwidth stays ~11 for a beam).
The scene loader's element limit (latdyn.scene.MAX_ELEMENTS) is raised for the run.
The table and the machine go to benchmarks/results/step_scaling.json.
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
import latdyn.scene
from latdyn.engine import CompiledGeneralizedAlpha
from latdyn.integrators import AlphaParameters
from latdyn.solve import prepare


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


def measure(elements: int, formulation: str, steps: int) -> dict:
    prepared = prepare(latdyn.load_scene(beam(elements, formulation)))
    model = prepared.model
    step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                    1e-8, ITERATIONS, 10.0)
    step.start(prepared.state)
    state = previous = prepared.state
    samples, cpu_samples, iterations, converged = [], [], [], []
    for k in range(steps + 1):
        started, started_cpu = time.perf_counter(), time.process_time()
        state, stats = step.step(state, 1e-3)
        elapsed, elapsed_cpu = time.perf_counter() - started, time.process_time() - started_cpu
        done = stats.iterations if stats.converged else ITERATIONS
        if stats.converged:
            step.accept()
            converged.append(True)
        else:  # the cost of an iteration is what is measured: go on from the same state
            state = previous
            converged.append(False)
        previous = state
        if k:  # the first step sets up the scatter maps and buffers
            samples.append(elapsed / done)
            cpu_samples.append(elapsed_cpu / done)
            iterations.append(done)
    per_iteration = float(np.median(samples))
    return {"elements": elements, "coordinates": model.n_dofs, "band": bool(step._model.band),
            "bandwidth": int(step._model.kl) if step._model.band else None,
            "iterations_per_step": float(np.mean(iterations)), "steps_converged": int(sum(converged[1:])),
            "steps": len(converged) - 1, "s_per_iteration": per_iteration,
            "us_per_element_iteration": 1e6 * per_iteration / elements,
            "cpu_s_per_iteration": float(np.median(cpu_samples))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max", type=int, default=100_000)
    parser.add_argument("--formulation", default="cr4402")
    parser.add_argument("--steps", type=int, default=5)
    args = parser.parse_args()
    latdyn.scene.MAX_ELEMENTS = max(latdyn.scene.MAX_ELEMENTS, args.max)
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
