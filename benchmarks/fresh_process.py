"""A fresh ``latdyn run`` as a user starts it: wall and CPU time of whole processes (issue 31, item 5).

The scene is the shipped spin-up (``examples/spinup.yaml``, 8 elements, 24 coordinates: the
dense LU) cut to ``--steps`` steps of its dt, one row a step. Each of ``--repeat`` rounds runs
``python -m latdyn run SCENE -o OUT -q`` in a new process with the kernels already in the cache
(a first, untimed run puts them there) and records its wall time and its CPU time (user + system
of the child, ``resource.getrusage(RUSAGE_CHILDREN)``, which includes the compiler a process may
start). Baselines in the same rounds: ``python -c pass`` and ``python -c "import numpy"``.
Medians, minima and the 1-minute load average are printed (docs/performance.md, "First run").

    python benchmarks/fresh_process.py                      # 20 rounds, 5 steps
    python benchmarks/fresh_process.py --repeat 10 --importtime   # and where the imports go
    python benchmarks/fresh_process.py --against /tmp/base  # and another checkout's latdyn, same rounds
                                                            # (e.g. git worktree add /tmp/base <commit>)
    python benchmarks/fresh_process.py --scene S.yaml --against /tmp/base   # a whole scene of one's own
                                                            # (e.g. the ones peers_as_user.py writes)

Byte-compiled modules are assumed (a user's case after the first import): run it without
``PYTHONDONTWRITEBYTECODE``, once, before timing.
"""
from __future__ import annotations

import argparse
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


def _timed(command: list[str], environment: dict, folder: str) -> tuple[float, float]:
    """(wall s, CPU s) of one process, started in ``folder`` (``python -m`` puts the current folder
    first on the path: in the repository it would shadow the checkout of ``environment``)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=environment,
                   cwd=folder)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _importtime(command: list[str], environment: dict, folder: str, top: int) -> None:
    """The largest self import times (µs summed by top-level package; latdyn by subpackage)."""
    done = subprocess.run([sys.executable, "-X", "importtime", *command[1:]], capture_output=True, text=True,
                          env=environment, check=True, cwd=folder)
    totals: dict[str, int] = {}
    for line in done.stderr.splitlines():
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        self_us, _, name = line[len("import time:"):].split("|")
        parts = name.strip().split(".")
        key = ".".join(parts[:2]) if parts[0] == "latdyn" else parts[0]
        totals[key] = totals.get(key, 0) + int(self_us)
    print(f"imports, self time by package (one process, {sum(totals.values()) / 1000:.0f} ms in all):")
    for key, us in sorted(totals.items(), key=lambda kv: -kv[1])[:top]:
        print(f"  {us / 1000:7.1f} ms  {key}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=20, help="processes of each command (default 20)")
    parser.add_argument("--steps", type=int, default=5, help="steps of the spin-up (default 5)")
    parser.add_argument("--importtime", action="store_true", help="also list where the imports go")
    parser.add_argument("--against", type=Path, help="a checkout whose latdyn is timed too, in the same rounds")
    parser.add_argument("--scene", type=Path, help="run this scene file as it is instead of the spin-up's steps")
    args = parser.parse_args(argv)

    if args.scene is None:
        scene = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
        dt = float(scene["solve"]["dt"])
        scene["solve"]["t_end"] = args.steps * dt
        scene["output"]["every"] = dt
        what = f"spin-up of {args.steps} steps"
    else:
        what = str(args.scene)
    def environment_of(root: Path) -> dict:  # byte code cached, as a user's installation has it
        return {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"},
                "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}

    environment = environment_of(ROOT)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "spinup_steps.yaml"
        if args.scene is None:
            path.write_text(yaml.safe_dump(scene))
        else:
            path.write_bytes(args.scene.read_bytes())
        run = [sys.executable, "-m", "latdyn", "run", str(path), "-o", str(Path(folder) / "out"), "-q"]
        commands = {"latdyn run": (run, environment), "python -c pass": ([sys.executable, "-c", "pass"], environment),
                    "python -c 'import numpy'": ([sys.executable, "-c", "import numpy"], environment)}
        if args.against is not None:
            commands[f"latdyn run ({args.against})"] = (run, environment_of(args.against.resolve()))
        for name, (command, env) in commands.items():
            if name.startswith("latdyn run"):
                _timed(command, env, folder)  # kernels and laws into the cache, modules byte-compiled
        times: dict[str, list[tuple[float, float]]] = {name: [] for name in commands}
        loads = [os.getloadavg()[0]]
        for _ in range(args.repeat):  # interleaved, so that a change of load touches all alike
            for name, (command, env) in commands.items():
                times[name].append(_timed(command, env, folder))
        loads.append(os.getloadavg()[0])
        print(f"{args.repeat} fresh processes each, {what}, load {loads[0]:.1f} -> "
              f"{loads[1]:.1f}, {os.cpu_count()} CPUs")
        for name, rows in times.items():
            walls, cpus = [w for w, _ in rows], [c for _, c in rows]
            print(f"  {name:26s} wall median {statistics.median(walls):.3f} s (min {min(walls):.3f})   "
                  f"CPU median {statistics.median(cpus):.3f} s (min {min(cpus):.3f})")
        if args.importtime:
            _importtime(run, environment, folder, 15)
    return 0


if __name__ == "__main__":
    sys.exit(main())
