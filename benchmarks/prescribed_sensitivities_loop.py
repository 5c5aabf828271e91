"""Time of forward sensitivity runs through prescribed motions beside events (docs/performance.md, "Prescribed motions
and reels in the sensitivity loop (issue 34)"): the scenes of tests/test_sensitivities_in_loop_prescribed.py.

    python benchmarks/prescribed_sensitivities_loop.py --write DIR [--linked]
        the scenes as YAML files in DIR (boom.yaml, angle.yaml, truss.yaml; *-plain.yaml without sensitivities);
        --linked: those of tests/test_sensitivities_in_loop_linked2.py instead (crank.yaml, gimbal.yaml, crankpd.yaml:
        docs/performance.md, "Linked models' prescribed motions and work accounts in the sensitivity loop (issue 34)")
    python benchmarks/prescribed_sensitivities_loop.py --scene FILE --repeats 7 [--off]
        in this process (the tree on PYTHONPATH): one warm-up run, then the runs timed (wall and
        time.process_time); prints the minimum and the median of each; --off: the sensitivities' loop of steps
        off (the private switch SENSITIVITIES_IN_LOOP: every step from Python)
    python benchmarks/prescribed_sensitivities_loop.py --user 5 --trees A,B --scenes DIR
        as a user runs it: fresh ``python -m latdyn run FILE -o OUT -q`` per tree (its root on PYTHONPATH), the trees
        alternating in each round, under ``chrt -f 10`` where it is allowed; medians of wall and of the child's CPU
        (user + system)

Run it under ``chrt -f 10`` on a loaded machine and state the load (``uptime``)."""
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


def write(folder: Path, linked: bool = False) -> None:
    import yaml

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    if linked:
        from tests.test_sensitivities_in_loop_linked2 import CRANK_PD, CRANK_STOP, GIMBAL_SLEW

        scenes = (("crank", CRANK_STOP), ("gimbal", GIMBAL_SLEW), ("crankpd", CRANK_PD))
    else:
        from tests.test_sensitivities_in_loop_prescribed import ANGLE_LATCH, BOOM_SLEW, REEL_TRUSS

        scenes = (("boom", BOOM_SLEW), ("angle", ANGLE_LATCH), ("truss", REEL_TRUSS))
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in scenes:
        (folder / f"{name}.yaml").write_text(text)
        plain = yaml.safe_load(text)
        plain["solve"].pop("sensitivities")
        (folder / f"{name}-plain.yaml").write_text(yaml.safe_dump(plain, sort_keys=False))


def in_process(scene: Path, repeats: int, off: bool = False) -> None:
    import yaml

    import latdyn
    import latdyn.analyses.sensitivities_in_loop as loop

    if off:
        loop.SENSITIVITIES_IN_LOOP = False
    data = yaml.safe_load(scene.read_text())
    latdyn.run(latdyn.load_scene(data))
    walls, cpus, result = [], [], None
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        result = latdyn.run(latdyn.load_scene(data))
        cpus.append(time.process_time() - c)
        walls.append(time.perf_counter() - w)
    print(f"{scene.name}: steps {result.summary['steps']}, in loop {result.summary.get('sensitivity_steps_in_loop')}; "
          f"wall min {min(walls) * 1e3:.1f} ms median {statistics.median(walls) * 1e3:.1f} ms; "
          f"CPU min {min(cpus) * 1e3:.1f} ms median {statistics.median(cpus) * 1e3:.1f} ms")


def as_user(trees: list[str], scenes: Path, rounds: int) -> None:
    fifo = ["chrt", "-f", "10"] if subprocess.run(["chrt", "-f", "10", "true"], capture_output=True).returncode == 0 \
        else []
    files = sorted(scenes.glob("*.yaml"))
    times = {(tree, f.name): ([], []) for tree in trees for f in files}
    with tempfile.TemporaryDirectory() as out:
        for _ in range(rounds):
            for f in files:
                for tree in trees:
                    env = {**os.environ, "PYTHONPATH": tree}
                    before = resource.getrusage(resource.RUSAGE_CHILDREN)
                    start = time.perf_counter()
                    subprocess.run([*fifo, sys.executable, "-m", "latdyn", "run", str(f), "-o", out, "-q"], env=env,
                                   check=True, cwd=tree)
                    wall = time.perf_counter() - start
                    after = resource.getrusage(resource.RUSAGE_CHILDREN)
                    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
                    times[(tree, f.name)][0].append(wall)
                    times[(tree, f.name)][1].append(cpu)
    for (tree, name), (walls, cpus) in times.items():
        print(f"{tree} {name}: wall median {statistics.median(walls):.3f} s, CPU median {statistics.median(cpus):.3f} s"
              f" ({len(walls)} runs)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--write", type=Path)
    parser.add_argument("--scene", type=Path)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--off", action="store_true")
    parser.add_argument("--linked", action="store_true")
    parser.add_argument("--user", type=int)
    parser.add_argument("--trees")
    parser.add_argument("--scenes", type=Path)
    args = parser.parse_args()
    if args.write:
        write(args.write, args.linked)
    elif args.scene:
        in_process(args.scene, args.repeats, args.off)
    elif args.user:
        as_user(args.trees.split(","), args.scenes, args.user)
    else:
        parser.error("one of --write, --scene, --user")


if __name__ == "__main__":
    main()
