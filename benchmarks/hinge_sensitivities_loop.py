"""Hinge laws' and joint bodies' parameters in the loop of steps in C: what a gradient run costs, and its equality.

    python benchmarks/hinge_sensitivities_loop.py [--scene boom|arm|stop|friction] [--repeats 5]
    python benchmarks/hinge_sensitivities_loop.py --scene boom --check DIR
    python benchmarks/hinge_sensitivities_loop.py --scene boom --user 5 [--trees ROOT_A,ROOT_B]

``--scene boom``: the design run of examples/deploying_boom_sensitivities.py (the planar two-panel boom deploying on
its hinge's spring k and damper c and latching at π; 2.5 s, dt = 0.005, a row every 0.01 s), ``solve.sensitivities:
[k, c]``. ``--scene arm``: a smooth 3D arm (tests/test_sensitivities_native_parts.py's: a hinged second beam, a joint
body off its node, gravity, loads in a body's frame and in t, spinning; 0.3 s, dt = 0.005, a row every 0.01 s) with
its hinge's stiffness, damping and rest angle and its joint body's mass and inertia as parameters ``[k, c, r, M, J]``.

In process (default): the run without sensitivities, the forward run (its smooth steps' sensitivities in the loop of
steps where the build takes them: latdyn/analyses/sensitivities_in_loop.py) and the forward run with every step from
Python (the private switch ``SENSITIVITIES_IN_LOOP`` off), interleaved ``--repeats`` times, kernels and laws compiled
before; printed per case the minimum and median of the process's CPU time (``time.process_time``) and of the wall
time of ``latdyn.run``, the ratio of the CPU minima to the run without's, and the steps differentiated in the loop
(summary.json ``sensitivity_steps_in_loop``) of all steps. Run it with each build's root first on PYTHONPATH to
compare builds (the script reads only ``SENSITIVITIES_IN_LOOP``, which 635b9a2 has).

``--check DIR``: the forward run written under DIR with the switch on and off; printed the sha-256 of
sensitivities.csv, probes.csv and summary.json's probe_sensitivities and event_sensitivities of each.

``--user N``: as a user runs it, ``python -m latdyn run SCENE -o OUT -q`` in fresh processes, with and without
``solve.sensitivities``, N rounds, each tree of ``--trees`` (roots put first on PYTHONPATH; default this checkout) in
turn within a round; printed per tree and case the median wall time and the median CPU time of the child (user +
system, ``getrusage``), and their ratios to the run without of the same tree.
"""
from __future__ import annotations

import argparse
import copy
import hashlib
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



def _boom() -> str:
    """The design run's scene, examples/deploying_boom_sensitivities.py's SCENE, as YAML text."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("boom_design", ROOT / "examples" / "deploying_boom_sensitivities.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    return yaml.safe_dump(example.SCENE, sort_keys=False)


def _arm() -> str:
    """tests/test_sensitivities_native_parts.py's 3D arm over 0.3 s, its hinge's stiffness, damping and rest angle and
    its joint body's mass and inertia named (section values and loads as numbers)."""
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    from tests.test_sensitivities_native_parts import ARM

    return (ARM.replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}", "parameters: {E: 1.0, rho: 0.5, F: 2.0, k: 30.0, "
                        "c: 0.2, r: 0.1, M: 0.8, J: 0.01}")
            .replace("stiffness: 30.0, damping: 0.2}", 'stiffness: "k", damping: "c", rest_angle: "r"}')
            .replace("mass: 0.8, com: [0.05, 0, -0.05], inertia: [0.01, 0.01, 0.02]",
                     'mass: "M", com: [0.05, 0, -0.05], inertia: ["J", 0.01, 0.02]')
            .replace("t_end: 0.04", "t_end: 0.3").replace("sensitivities: [E, rho, F]", "sensitivities: [k, c, r, M, J]"))


def _from_tests(module: str, name: str):
    """A scene of the tests (``--scene stop``: tests/test_sensitivities_contact.py's WHEEL, the 3D wheel driven into its
    compliant stop, by the stop's kc, nc, cc and the spring's k; ``--scene friction``: tests/test_sensitivities_friction.py's
    SKEW, a panel slipping on a skew hinge with friction, by Fc, Fs, vs, cv, v0, EI, F)."""
    def text() -> str:
        sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
        import importlib

        return getattr(importlib.import_module(f"tests.{module}"), name)
    return text


SCENES = {"boom": _boom, "arm": _arm, "stop": _from_tests("test_sensitivities_contact", "WHEEL"),
          "friction": _from_tests("test_sensitivities_friction", "SKEW")}


def _without(data: dict) -> dict:
    data = copy.deepcopy(data)
    del data["solve"]["sensitivities"]
    return data


def in_process(text: str, repeats: int) -> None:
    import latdyn
    from latdyn.analyses import sensitivities_in_loop

    data = yaml.safe_load(text)
    cases = {"without": (_without(data), True), "forward": (data, True), "forward, every step from Python": (data, False)}
    cpu: dict[str, list] = {name: [] for name in cases}
    wall: dict[str, list] = {name: [] for name in cases}
    counts = {}
    for name, (scene, on) in cases.items():   # kernels and laws compiled before
        sensitivities_in_loop.SENSITIVITIES_IN_LOOP = on
        latdyn.run(latdyn.load_scene(copy.deepcopy(scene)))
    loads = [os.getloadavg()[0]]
    for _ in range(repeats):
        for name, (scene, on) in cases.items():
            loaded = latdyn.load_scene(copy.deepcopy(scene))
            sensitivities_in_loop.SENSITIVITIES_IN_LOOP = on
            try:
                start, clock = time.perf_counter(), time.process_time()
                result = latdyn.run(loaded)
                wall[name].append(time.perf_counter() - start)
                cpu[name].append(time.process_time() - clock)
            finally:
                sensitivities_in_loop.SENSITIVITIES_IN_LOOP = True
            counts[name] = (result.summary.get("sensitivity_steps_in_loop", 0), result.summary["steps"])
    loads.append(os.getloadavg()[0])
    print(f"{sys.modules['latdyn'].__file__}: load {loads[0]:.1f}–{loads[1]:.1f}, {repeats} rounds")
    base = min(cpu["without"])
    for name in cases:
        print(f"  {name:32s} CPU {min(cpu[name]) * 1e3:7.1f} ms (median {statistics.median(cpu[name]) * 1e3:7.1f}) "
              f"{min(cpu[name]) / base:5.2f}×  wall {min(wall[name]) * 1e3:7.1f} ms (median "
              f"{statistics.median(wall[name]) * 1e3:7.1f})  steps in the loop {counts[name][0]} of {counts[name][1]}")


def check(text: str, folder: str) -> None:
    import latdyn
    from latdyn.analyses import sensitivities_in_loop

    seen = {}
    for on in (True, False):
        out = Path(folder) / ("loop" if on else "python")
        sensitivities_in_loop.SENSITIVITIES_IN_LOOP = on
        try:
            latdyn.run(latdyn.load_scene(yaml.safe_load(text)), out)
        finally:
            sensitivities_in_loop.SENSITIVITIES_IN_LOOP = True
        summary = json.loads((out / "summary.json").read_text())
        seen[on] = ([hashlib.sha256((out / name).read_bytes()).hexdigest()[:16]
                     for name in ("sensitivities.csv", "probes.csv")]
                    + [hashlib.sha256(json.dumps(summary.get(key), sort_keys=True).encode()).hexdigest()[:16]
                       for key in ("probe_sensitivities", "event_sensitivities")])
        print(f"{'loop' if on else 'python':6s} {' '.join(seen[on])}  steps in the loop "
              f"{summary['sensitivity_steps_in_loop']} of {summary['steps']}")
    print("equal" if seen[True] == seen[False] else "DIFFERENT")


def as_a_user(text: str, rounds: int, trees: list[str]) -> None:
    folder = Path(tempfile.mkdtemp(prefix="hinge-loop-"))
    scenes = {"without": folder / "without.yaml", "forward": folder / "forward.yaml"}
    scenes["forward"].write_text(text)
    scenes["without"].write_text(yaml.safe_dump(_without(yaml.safe_load(text))))
    wall = {(tree, name): [] for tree in trees for name in scenes}
    cpu = {(tree, name): [] for tree in trees for name in scenes}
    loads = [os.getloadavg()[0]]
    for _ in range(rounds + 1):   # the first round warms the caches and is left out
        for tree in trees:
            for name, scene in scenes.items():
                env = dict(os.environ, PYTHONPATH=tree + os.pathsep + os.environ.get("PYTHONPATH", ""))
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                start = time.perf_counter()
                done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(folder / "out"),
                                       "-q"], env=env, cwd=folder, capture_output=True, text=True, check=False)
                elapsed = time.perf_counter() - start
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                if done.returncode != 0:
                    raise SystemExit(done.stderr)
                wall[tree, name].append(elapsed)
                cpu[tree, name].append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    loads.append(os.getloadavg()[0])
    print(f"as a user runs it: load {loads[0]:.1f}–{loads[1]:.1f}, medians of {rounds} processes")
    for tree in trees:
        base_wall = statistics.median(wall[tree, "without"][1:])
        base_cpu = statistics.median(cpu[tree, "without"][1:])
        for name in scenes:
            w, c = statistics.median(wall[tree, name][1:]), statistics.median(cpu[tree, name][1:])
            print(f"  {tree}: {name:8s} wall {w:.3f} s ({w / base_wall:.2f}×)  CPU {c:.3f} s ({c / base_cpu:.2f}×)")


def main(scenes: dict | None = None, default: str = "boom", description: str = __doc__) -> None:
    """The command line; ``scenes`` (name: a function giving the YAML text), ``default``: another script's
    (benchmarks/linked_sensitivities_loop.py)."""
    scenes = SCENES if scenes is None else scenes
    parser = argparse.ArgumentParser(description=description.splitlines()[0])
    parser.add_argument("--scene", choices=tuple(scenes), default=default)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--check", metavar="DIR")
    parser.add_argument("--user", type=int, metavar="N")
    parser.add_argument("--trees", default=str(ROOT))
    args = parser.parse_args()
    text = scenes[args.scene]()
    if args.check:
        check(text, args.check)
    elif args.user:
        as_a_user(text, args.user, args.trees.split(","))
    else:
        in_process(text, args.repeats)


if __name__ == "__main__":
    main()
