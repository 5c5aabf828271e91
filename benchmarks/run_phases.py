"""Where the time of one ``latdyn run`` goes, phase by phase (issue 31): wall and CPU ms of a fresh process.

    python benchmarks/run_phases.py SCENE [--repeat 5] [--json PATH]

Each of ``--repeat`` rounds starts a fresh interpreter that runs ``python -m latdyn run SCENE -o OUT -q``'s
own code (``latdyn.cli.main``) with timers put around the functions that make up a run (below). A
phase's time is exclusive: what a phase nested in it took is counted there, not in both. Every
``os.fsync`` is timed as its own phase wherever it is called. Outside the child:
``start`` is the interpreter's start up to the first line of the child's script (Python, ``site``; the child imports
only ``sys``, ``time``, ``os`` and ``json`` of its own before the run, so that the modules of this script's parent part
— argparse, statistics, subprocess, tempfile, pathlib: ≈ 20 ms — are neither counted as the start nor spared to the
run's imports; docs/performance.md, "Thirteenth pass"),
``exit`` from the child's last line to the end of the process (atexit, h5py, interpreter teardown; where the
command ends its process without the teardown, ``latdyn.cli._end_without_teardown``, the child ends as it does).
The rows are medians over the rounds; ``other`` is what the named phases leave of the child's time.
Kernels must be in the cache (run the scene once first): a compile would show as ``kernel load``.
"""
from __future__ import annotations

import time  # noqa: I001 - first: the child's first line

_FIRST = time.time(), time.process_time()

import json  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: (phase, module, attribute path) — the functions timed, in the order a run calls them.
PHASES = [
    ("import latdyn.solve and the loader (on use)", "latdyn.cli", "_module"),
    ("scene load (YAML + validation)", "latdyn.scene.loader", "load_scene"),
    ("model build", "latdyn.model.model", "Model.from_scene"),
    ("kernel load", "latdyn.model.kernels", "load_kernels"),
    ("assembler + initial state", "latdyn.assembly.assembler", "Assembler.__init__"),
    ("assembler + initial state", "latdyn.assembly.assembler", "Assembler.initial_state"),
    ("held check (evaluation + eigen/LU)", "latdyn.model.model", "Model.check_held"),
    ("held check (evaluation + eigen/LU)", "latdyn.assembly.assembler", "Assembler.evaluate"),
    ("held check (evaluation + eigen/LU)", "latdyn.assembly.evaluation", "Evaluation.combined"),
    ("probes set up", "latdyn.results.probes", "ProbeSet.__init__"),
    ("ParaView mesh", "latdyn.results.paraview", "parts"),
    ("result files created", "latdyn.results.writer", "ResultWriter.__init__"),
    ("step set up (integrator, native library)", "latdyn.timeloop.transient", "integrator_for"),
    ("loop start (first row, accelerations)", "latdyn.timeloop.loop", "TimeLoop.begin"),
    ("loop start: consistent accelerations", "latdyn.step.integrators", "consistent_acceleration"),
    ("C steps (advance)", "latdyn.step.compiled", "CompiledGeneralizedAlpha.advance"),
    ("rows (Python side of a block)", "latdyn.timeloop.loop", "TimeLoop._record_rows"),
    ("writers: probes.csv", "latdyn.results.probes_csv", "ProbesCsv.add_rows"),
    ("writers: probes.csv", "latdyn.results.probes_csv", "ProbesCsv.flush"),
    ("writers: probes.csv", "latdyn.results.probes_csv", "ProbesCsv.close"),
    ("writers: state.h5 (rows kept, file rewritten)", "latdyn.results.state_history", "StateHistory.add_rows"),
    ("writers: state.h5 (rows kept, file rewritten)", "latdyn.results.state_history", "StateHistory.write"),
    ("writers: ParaView frames", "latdyn.results.paraview", "ParaviewWriter.record_rows"),
    ("writers: ParaView frames", "latdyn.results.paraview", "ParaviewWriter.write_pending"),
    ("writers: ParaView frames", "latdyn.results.paraview", "ParaviewWriter.close"),
    ("writers: summary.json", "latdyn.results.writer", "write_summary"),
    ("checkpoints", "latdyn.timeloop.checkpoint", "Checkpointer.save"),
    ("close (summary, files)", "latdyn.results.writer", "ResultWriter.close"),
    ("fsync", "os", "fsync"),
]


def _child(scene: str, out: str) -> int:
    """In the timed process: the timers, then ``latdyn.cli.main`` as ``python -m latdyn run`` calls it."""
    first_wall, first_cpu = _FIRST
    exclusive: dict[str, list[float]] = {}
    stack: list[list[float]] = []  # [child wall, child cpu] accumulated by nested phases

    def timed(name, function):
        def wrapper(*args, **kwargs):
            stack.append([0.0, 0.0])
            w0, c0 = time.perf_counter(), time.process_time()
            try:
                return function(*args, **kwargs)
            finally:
                dw, dc = time.perf_counter() - w0, time.process_time() - c0
                inner = stack.pop()
                total = exclusive.setdefault(name, [0.0, 0.0, 0])
                total[0] += dw - inner[0]
                total[1] += dc - inner[1]
                total[2] += 1
                if stack:
                    stack[-1][0] += dw
                    stack[-1][1] += dc
        wrapper.__wrapped__ = function
        return wrapper

    def phase(name, started):
        w, c = time.perf_counter() - started[0], time.process_time() - started[1]
        total = exclusive.setdefault(name, [0.0, 0.0, 0])
        total[0] += w
        total[1] += c
        total[2] += 1

    import importlib

    started = (time.perf_counter(), time.process_time())
    import latdyn.cli as cli  # noqa: E402

    # as the command does for ``run`` before anything imports NumPy (one OpenBLAS thread; a tree without it: nothing)
    getattr(cli, "one_blas_thread", lambda: False)()
    phase("import latdyn.cli", started)
    started = (time.perf_counter(), time.process_time())
    modules = {}
    for name, module, path in PHASES:
        if module not in modules:
            modules[module] = importlib.import_module(module)
    phase("import the run's modules", started)
    for name, module, path in PHASES:
        owner = modules[module]
        parts = path.split(".")
        for part in parts[:-1]:
            owner = getattr(owner, part)
        original = getattr(owner, parts[-1])
        if isinstance(original, (staticmethod, classmethod)):
            continue
        raw = owner.__dict__.get(parts[-1], original) if isinstance(owner, type) else original
        if isinstance(raw, classmethod):
            setattr(owner, parts[-1], classmethod(timed(name, raw.__func__)))
        else:
            setattr(owner, parts[-1], timed(name, original))
        # the names imported from the module elsewhere (``from x import f``) point at the original
        for other in list(sys.modules.values()):
            if other is not None and other is not modules[module] and getattr(other, parts[0], None) is original \
                    and len(parts) == 1 and getattr(other, "__name__", "").startswith("latdyn"):
                setattr(other, parts[0], getattr(owner, parts[-1]))
    w0, c0 = time.perf_counter(), time.process_time()
    sys.argv = ["latdyn", "run", scene, "-o", out, "-q"]
    code = cli.main()  # as python -m latdyn calls it (argv None: the end of the process too)
    total_wall, total_cpu = time.perf_counter() - w0, time.process_time() - c0
    named_wall = sum(v[0] for k, v in exclusive.items() if not k.startswith("import"))
    named_cpu = sum(v[1] for k, v in exclusive.items() if not k.startswith("import"))
    exclusive["other (cli, solve, loop bookkeeping)"] = [total_wall - named_wall, total_cpu - named_cpu, 1]
    print(json.dumps({"code": code, "first_wall": first_wall, "first_cpu": first_cpu, "end_wall": time.time(),
                      "end_cpu": time.process_time(),
                      "phases": {k: v[:3] for k, v in exclusive.items()}}), flush=True)
    # as the command ends its process (a tree without it, or a run that holds a file open: by returning)
    end = getattr(cli, "_end_without_teardown", None)
    if end is not None and getattr(cli, "_RAN", [False])[0]:
        end(code)
    return code


def main(argv=None) -> int:
    import argparse
    import statistics
    import subprocess
    import tempfile
    from pathlib import Path

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return _child(*args.child)
    environment = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    environment["PYTHONPATH"] = os.pathsep.join([ROOT] + [p for p in environment.get("PYTHONPATH", "").split(
        os.pathsep) if p])
    rounds = []
    loads = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory() as folder:
        command = [sys.executable, str(Path(__file__).resolve()), "x", "--child", str(Path(args.scene).resolve()),
                   str(Path(folder) / "out")]
        subprocess.run(command, check=True, capture_output=True, env=environment, cwd=folder)  # warm: caches
        for _ in range(args.repeat):
            import resource

            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            spawned = time.time()
            done = subprocess.run(command, check=True, capture_output=True, text=True, env=environment, cwd=folder)
            ended = time.time()
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            info = json.loads(done.stdout.strip().splitlines()[-1])
            cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
            phases = {"start (interpreter, site)": [info["first_wall"] - spawned, info["first_cpu"], 1],
                      **info["phases"],
                      "exit (atexit, teardown)": [ended - info["end_wall"], cpu - info["end_cpu"], 1]}
            rounds.append({"process_wall_s": ended - spawned, "process_cpu_s": cpu, "phases": phases})
    loads.append(os.getloadavg()[0])
    names = list(rounds[0]["phases"])
    table = {name: {"wall_ms": 1e3 * statistics.median(r["phases"].get(name, [0, 0, 0])[0] for r in rounds),
                    "cpu_ms": 1e3 * statistics.median(r["phases"].get(name, [0, 0, 0])[1] for r in rounds),
                    "calls": rounds[0]["phases"].get(name, [0, 0, 0])[2]} for name in names}
    whole = {"wall_s": statistics.median(r["process_wall_s"] for r in rounds),
             "cpu_s": statistics.median(r["process_cpu_s"] for r in rounds)}
    print(f"{args.scene}: {args.repeat} fresh processes, whole process wall {whole['wall_s']:.3f} s, "
          f"CPU {whole['cpu_s']:.3f} s (medians); load {loads[0]:.1f} -> {loads[1]:.1f}")
    print("| phase | calls | wall ms | CPU ms |\n|---|---|---|---|")
    for name, row in table.items():
        print(f"| {name} | {row['calls']} | {row['wall_ms']:.1f} | {row['cpu_ms']:.1f} |")
    if args.json:
        args.json.write_text(json.dumps({"scene": args.scene, "whole": whole, "phases": table, "load": loads,
                                         "rounds": rounds}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    if sys.argv[-3:-2] == ["--child"]:  # the timed process: no argparse (the parent gives ``x --child SCENE OUT``)
        sys.exit(_child(*sys.argv[-2:]))
    sys.exit(main())
