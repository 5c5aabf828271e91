"""A sensitivity run's start as a user meets it (issue 34; docs/performance.md, "A sensitivity run's start (issue 34)").

    python benchmarks/sensitivity_start.py [--rounds 5] [--trees ROOT_A,ROOT_B] [--fifo] [--scenes NAME,...]
    python benchmarks/sensitivity_start.py --modules [--trees ...]

The scenes: the planar lattice of benchmarks/transient_sensitivities_cost.py (25 bays, 100 member sections, 300
coordinates) and its 3D cantilever (30 elements, 180 coordinates), each without ``solve.sensitivities`` and with 1,
10 and 100 parameters, and the deploying boom's design run (examples/deploying_boom_sensitivities.py's scene, hinge
k and c; benchmarks/hinge_sensitivities_loop.py ``--scene boom``) without and with. Each is run as
``python -m latdyn run SCENE -o OUT -q`` in a fresh process, the kernels and laws cached (``LATDYN_CACHE_DIR`` as
set), ``OMP_NUM_THREADS=1``; the trees (roots put first on PYTHONPATH; default this checkout) alternate process by
process, their order turned round every round; a first round warms the caches and bytecode and is left out;
``--fifo``: each process under ``chrt -f 10`` (SCHED_FIFO: on a shared machine, in place of an idle core). Printed
per scene and tree: the median wall time and the median CPU time of the child (user + system, ``getrusage``), and
each's ratio to the run without of the same family and tree; the 1-minute load before and after.

``--modules``: per scene and tree, whether the fresh process imported scipy.sparse, and how many modules it imported.
``--adjoint``: the runs with parameters by the discrete adjoint (``solve.sensitivity_method: adjoint``).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import hinge_sensitivities_loop  # noqa: E402 - the benchmarks' scenes, beside this file
import transient_sensitivities_cost  # noqa: E402

def scenes(adjoint: bool = False) -> list[tuple[str, str, dict]]:
    """(name, family, scene) of every scene (module docstring); a family's run without is its ratios' denominator;
    ``adjoint``: the runs with parameters by the discrete adjoint."""
    made = []
    for family, build in (("lattice", transient_sensitivities_cost.lattice),
                          ("cantilever", transient_sensitivities_cost.scene)):
        for k in (0, 1, 10, 100):
            made.append((f"{family}{k}", family, build([f"F{i}" for i in range(k)])))
    boom = yaml.safe_load(hinge_sensitivities_loop._boom())
    made += [("boom0", "boom", hinge_sensitivities_loop._without(boom)), ("boom_kc", "boom", boom)]
    if adjoint:
        for _, _, scene in made:
            if "sensitivities" in scene["solve"]:
                scene["solve"]["sensitivity_method"] = "adjoint"
    return made


_MODULES_HOOK = """\
import atexit, json, os, sys
atexit.register(lambda: json.dump(sorted(sys.modules), open(os.environ["SENSITIVITY_START_MODULES"], "w")))
"""


def command(scene: Path, out: Path, fifo: bool) -> list[str]:
    """``latdyn run SCENE -o OUT -q`` in this interpreter (under ``chrt -f 10`` where ``fifo``)."""
    command = [sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"]
    return ["chrt", "-f", "10", *command] if fifo else command


def _environment(tree: str, extra: str = "") -> dict:
    path = os.pathsep.join(p for p in (extra, tree, os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path, "OMP_NUM_THREADS": "1"}


def as_a_user(folder: Path, chosen: list, trees: list[str], rounds: int, fifo: bool, command=command) -> None:
    wall, cpu = {}, {}
    loads = [os.getloadavg()[0]]
    for r in range(rounds + 1):
        for name, _, _ in chosen:
            for tree in (trees if r % 2 == 0 else trees[::-1]):
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                start = time.perf_counter()
                done = subprocess.run(command(folder / f"{name}.yaml", folder / "out", fifo), env=_environment(tree),
                                      cwd=folder, capture_output=True, text=True, check=False)
                elapsed = time.perf_counter() - start
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                if done.returncode != 0:
                    raise SystemExit(done.stderr)
                if r:
                    wall.setdefault((tree, name), []).append(elapsed)
                    cpu.setdefault((tree, name), []).append(after.ru_utime - before.ru_utime
                                                            + after.ru_stime - before.ru_stime)
    loads.append(os.getloadavg()[0])
    print(f"as a user runs it: load {loads[0]:.1f}–{loads[1]:.1f}, medians of {rounds} processes"
          f"{', chrt -f 10' if fifo else ''}")
    without = {family: name for name, family, scene in chosen if "sensitivities" not in scene["solve"]}
    for name, family, _ in chosen:
        for tree in trees:
            w, c = statistics.median(wall[tree, name]), statistics.median(cpu[tree, name])
            ratio = ""
            if family in without:
                w0, c0 = statistics.median(wall[tree, without[family]]), statistics.median(cpu[tree, without[family]])
                ratio = f"  × {w / w0:.2f} / {c / c0:.2f}"
            print(f"  {name:14s} {tree}: wall {w:.3f} s  CPU {c:.3f} s{ratio}")


def modules(folder: Path, chosen: list, trees: list[str], command=command) -> None:
    hook = folder / "hook"
    hook.mkdir(exist_ok=True)
    (hook / "sitecustomize.py").write_text(_MODULES_HOOK)
    listing = folder / "modules.json"
    for name, _, _ in chosen:
        for tree in trees:
            for _ in range(2):   # the first may compile the scene's laws
                done = subprocess.run(command(folder / f"{name}.yaml", folder / "out", False), cwd=folder,
                                      env={**_environment(tree, str(hook)), "SENSITIVITY_START_MODULES": str(listing)},
                                      capture_output=True, text=True, check=False)
                if done.returncode != 0:
                    raise SystemExit(done.stderr)
            imported = json.loads(listing.read_text())
            sparse = any(m == "scipy.sparse" for m in imported)
            print(f"  {name:14s} {tree}: {len(imported)} modules, scipy.sparse {'imported' if sparse else 'not imported'}")


def arguments(description: str = __doc__.splitlines()[0], adjoint: bool = True) -> argparse.ArgumentParser:
    """The options of this measurement (benchmarks/latch_start.py's too, without ``--adjoint``)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--trees", default=str(ROOT))
    parser.add_argument("--fifo", action="store_true", help="each process under chrt -f 10")
    parser.add_argument("--scenes", default=None, help="comma-separated scene names (default: all)")
    parser.add_argument("--modules", action="store_true")
    if adjoint:
        parser.add_argument("--adjoint", action="store_true", help="the runs with parameters by the discrete adjoint")
    return parser


def main() -> None:
    args = arguments().parse_args()
    measure(scenes(args.adjoint), args)


def measure(made: list, args, prefix: str = "sensitivity-start-", command=command) -> None:
    """The scenes ``made`` (name, family, scene) that ``args.scenes`` names (all without it), written to a new
    folder and measured as ``args`` asks: :func:`modules` or :func:`as_a_user`, each process's command line made by
    ``command(scene, out, fifo)`` (benchmarks/latch_start.py gives its own)."""
    chosen = [s for s in made if args.scenes is None or s[0] in args.scenes.split(",")]
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    for name, _, scene in chosen:
        (folder / f"{name}.yaml").write_text(yaml.safe_dump(scene))
    trees = args.trees.split(",")
    if args.modules:
        modules(folder, chosen, trees, command)
    else:
        as_a_user(folder, chosen, trees, args.rounds, args.fifo, command)


if __name__ == "__main__":
    main()
