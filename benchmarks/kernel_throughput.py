"""Throughput of the generated element kernels against this machine's limit.

    python benchmarks/kernel_throughput.py [n_elements] [--variant default] [--json PATH]
    python benchmarks/kernel_throughput.py --whole-solver [--repeat 5] [--against CHECKOUT]

For every element kernel of a variant: operations after CSE (the generator's count: each
add, multiply, divide, square root or call counts one), µs per element on the NumPy and C
backends (medians of 7 calls on ``n_elements`` realistic elements), the C kernels' achieved
rate in G operations/s and its fraction of one core's peak. Then the kernels of one Newton
iteration of a 3D element as the compiled step calls them (internal force and tangent, mass
matrix, quadratic-velocity vector and its q̇-derivative: ``beam_internal_force_D_q`` +
``beam_mass_matrix`` + ``beam_quadratic_velocity_D_qdot``), summed. The step's own cost per
element-iteration (geometry, scatter, factorisation too) is ``benchmarks/step_scaling.py``.

``--whole-solver``: the whole solver time per element-iteration of two runs, issue 31's measure
against the turn-4 build: ``solver_s / (newton_iterations × elements)`` from summary.json (the
steps' wall time: assembly, kernels, factorizations, rows; not preparing the model) of the
260-member truss (``benchmarks/linear_solvers.py``'s ``lattice_for(260)``: 5×5×5 joints with mass,
one element a member, Newmark, dt 0.01 to 1 s) and the 16-element right-angle cantilever
(``examples/benchmarks/D2_right_angle_cantilever.yaml`` with 8 elements a leg, 30 s at dt 0.01, as
``peers_as_user.py`` runs it), each ``latdyn.run`` in process without a results folder after one
warm-up run, medians of ``--repeat``, in a fresh process per checkout (``--against``: another
checkout's latdyn, in the same rounds; its child imports that checkout's latdyn first, and says
which it imported). Also the 16-bay lattice of ``peers_as_user.py`` (modified Newton, a row every
step), and for each run the CPU time of the whole ``latdyn.run`` (``run_cpu_s``: scene preparation
included; on a shared machine less disturbed by the other jobs than the wall time).

Peak: SIMD lanes × 2 FMA pipes × 2 operations × the clock /proc/cpuinfo reports now (an
assumption stated in the output: AMD Zen 2-4 and Intel since Haswell have two FMA pipes; a
Zen 4 core runs AVX-512 on 256-bit halves, so its lanes are counted as 4).
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

#: the checkout whose latdyn is measured: this one, or ``--against``'s in its child process (CHECKOUT_VARIABLE)
CHECKOUT_VARIABLE = "LATDYN_THROUGHPUT_CHECKOUT"
CHECKOUT = Path(os.environ.get(CHECKOUT_VARIABLE) or Path(__file__).resolve().parents[1])
sys.path.insert(0, str(CHECKOUT / "tests"))
sys.path.insert(0, str(CHECKOUT))  # that checkout's latdyn (and latdyn_generated), before PYTHONPATH
from test_backends import realistic_inputs  # noqa: E402

from latdyn import native  # noqa: E402
from latdyn.model.kernels import load_kernels  # noqa: E402

#: The element kernels one Newton iteration of the compiled step calls (csrc/newton_step.c, element_range).
NEWTON_ITERATION = ("beam_internal_force_D_q", "beam_mass_matrix", "beam_quadratic_velocity_D_qdot")


def median_time(function, arrays, repeats=7):
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        function(*arrays)
        samples.append(time.perf_counter() - start)
    return float(np.median(samples))


def machine_peak() -> dict:
    """One core's peak in G operations/s, with what it assumes (see the module doc)."""
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if "model name" in line), "?")
    mhz = [float(line.split(":", 1)[1]) for line in open("/proc/cpuinfo") if line.startswith("cpu MHz")]
    flags = native.vector_flags()
    macros = native.isa_macros()
    width = 8 if "__AVX512F__" in macros else 4 if "__AVX__" in macros else 2  # as c_source.c.j2 chooses
    zen = "EPYC" in cpu or "Ryzen" in cpu
    pipe_width = min(width, 4) if zen else width  # Zen 4 splits a 512-bit operation into two 256-bit halves
    clock = max(mhz) / 1e3 if mhz else float("nan")
    return {"cpu": cpu, "cores": os.cpu_count(), "clock_ghz": clock, "simd_doubles": width,
            "peak_gops_per_core": pipe_width * 2 * 2 * clock, "compile_flags": list(flags),
            "assumes": f"{pipe_width} doubles per FMA pipe, 2 FMA pipes, 2 operations per FMA, {clock:.2f} GHz"}


def whole_solver_scenes() -> dict:
    """The two scenes of ``--whole-solver`` (see the module docstring), as dictionaries."""
    import yaml

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "benchmarks"))
    from linear_solvers import lattice_for
    from peers_as_user import SETTINGS, latdyn_scene

    cantilever = yaml.safe_load((root / "examples" / "benchmarks" / "D2_right_angle_cantilever.yaml").read_text())
    cantilever["beams"]["leg1"]["elements"] = cantilever["beams"]["leg2"]["elements"] = 8
    cantilever["solve"].update(t_end=30.0, dt=0.01)
    return {"truss_260": lattice_for(260), "cantilever_16": cantilever,
            "lattice_16": latdyn_scene("lattice", SETTINGS["lattice"]["latdyn"])}


def whole_solver_child(repeat: int) -> None:
    """In a fresh process: each scene run ``repeat`` times after a warm-up; JSON on stdout."""
    import copy

    import latdyn

    out = {"latdyn": str(Path(latdyn.__file__).resolve().parents[1])}
    for name, raw in whole_solver_scenes().items():
        rows, cpu = [], []
        for k in range(repeat + 1):
            start = time.process_time()
            summary = latdyn.run(latdyn.load_scene(copy.deepcopy(raw))).summary
            if k:
                rows.append(summary)
                cpu.append(time.process_time() - start)
        per = [1e6 * r["solver_s"] / (r["newton_iterations"] * r["elements"]) for r in rows]
        out[name] = {"elements": rows[0]["elements"], "newton_iterations": rows[0]["newton_iterations"],
                     "steps": rows[0]["steps"], "solver_s": float(np.median([r["solver_s"] for r in rows])),
                     "us_per_element_iteration": float(np.median(per)), "all": per,
                     "run_cpu_s": float(np.median(cpu))}
    print(json.dumps(out))


def whole_solver(repeat: int, against: Path | None) -> dict:
    import subprocess

    roots = {"this checkout": Path(__file__).resolve().parents[1]}
    if against is not None:
        roots[str(against)] = against.resolve()
    load = [os.getloadavg()[0]]
    results = {}
    for label, root in roots.items():
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]),
               CHECKOUT_VARIABLE: str(root)}
        done = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--whole-solver-child", str(repeat)],
                              capture_output=True, text=True, env=env, check=True, cwd=root)
        results[label] = json.loads(done.stdout.strip().splitlines()[-1])
    load.append(os.getloadavg()[0])
    cpu = machine_peak()["cpu"]
    print(f"whole solver time per element-iteration (µs), medians of {repeat}; {cpu}; load {load[0]:.1f} -> {load[1]:.1f}")
    for label, rows in results.items():
        print(f"  {label}: latdyn from {rows['latdyn']}")
        for name, row in rows.items():
            if name == "latdyn":
                continue
            print(f"  {label:>20s} {name:14s} {row['elements']:4d} elements, {row['newton_iterations']:6d} iterations, "
                  f"solver_s {row['solver_s']:.3f}: {row['us_per_element_iteration']:.2f} µs; "
                  f"the whole run {row['run_cpu_s']:.3f} s of CPU")
    return {"load_average": load, "cpu": cpu, "results": results}


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("n", nargs="?", type=int, default=10_000)
    parser.add_argument("--variant", default="default")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--whole-solver", action="store_true", help="issue 31's whole solver time per element-iteration")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--against", type=Path, help="--whole-solver: another checkout, timed in the same run")
    parser.add_argument("--whole-solver-child", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.whole_solver_child:
        return whole_solver_child(args.whole_solver_child)
    if args.whole_solver:
        result = whole_solver(args.repeat, args.against)
        if args.json:
            args.json.write_text(json.dumps(result, indent=1) + "\n")
        return result
    n = args.n
    inputs = realistic_inputs(n, seed=1)
    sets = {"numpy": load_kernels("numpy", args.variant), "c": load_kernels("c", args.variant)}
    peak = machine_peak()
    print(f"{n} elements, variant {args.variant}; {platform.python_implementation()} {platform.python_version()}; "
          f"CPU {peak['cpu']}; load {os.getloadavg()[0]:.2f}")
    print(f"peak {peak['peak_gops_per_core']:.1f} G operations/s per core ({peak['assumes']}); "
          f"C flags {' '.join(peak['compile_flags']) or '(none)'}")
    print(f"{'kernel':34s} {'ops':>7s} {'numpy µs':>9s} {'C µs':>8s} {'C Gop/s':>8s} {'of peak':>8s}")
    rows = {}
    for name, meta in sets["numpy"].info.items():
        if not all(arg in inputs for arg, _ in meta["inputs"]):  # the joints unit: per body, load, end, hinge
            continue
        arrays = [inputs[arg] for arg, _ in meta["inputs"]]
        seconds = {b: median_time(getattr(k, name), arrays) / n for b, k in sets.items()}
        ops = int(meta.get("op_count", 0))
        rows[name] = {"ops": ops, "numpy_us": seconds["numpy"] * 1e6, "c_us": seconds["c"] * 1e6,
                      "c_gops": ops / seconds["c"] / 1e9}
    iteration = {"ops": sum(rows[k]["ops"] for k in NEWTON_ITERATION),
                 "numpy_us": sum(rows[k]["numpy_us"] for k in NEWTON_ITERATION),
                 "c_us": sum(rows[k]["c_us"] for k in NEWTON_ITERATION)}
    iteration["c_gops"] = iteration["ops"] / iteration["c_us"] / 1e3
    for name, row in [*rows.items(), ("Newton iteration (3 kernels)", iteration)]:
        print(f"{name:34s} {row['ops']:7d} {row['numpy_us']:9.3f} {row['c_us']:8.3f} {row['c_gops']:8.2f} "
              f"{row['c_gops'] / peak['peak_gops_per_core']:8.1%}")
    result = {"n": n, "variant": args.variant, "machine": peak, "load_average": os.getloadavg(),
              "kernels": rows, "newton_iteration": iteration}
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    return result


if __name__ == "__main__":
    main()
