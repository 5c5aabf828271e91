"""A gimbal of rigid links against the same gimbal of stiff flexible beams, per step (issue 31, item 2).

The scene is the gyroscope of tests/test_initial_state.py (a post and an arm on two hinges, a rotor
spinning at a prescribed 20 rad/s, gravity, released at rest: 2 coordinates with rigid links, 14 with
one flexible beam per link), run for 2 s at dt = 0.005 (400 steps, a row every step), defaults
otherwise. Measured for each:

- in-process: ``latdyn.run(latdyn.load_scene(...), folder)``, the whole call, and the cost per step as
  the difference between the 2 s and the 0.2 s run over their 360 steps (fixed costs cancel);
- as a user runs it: ``python -m latdyn run scene.yaml -o folder`` in a fresh process (kernels and laws
  cached, byte code written), the whole command.

Medians of ``--repeat`` runs; the 1-minute load average before and after is printed with them.
``python benchmarks/rigid_links.py [--repeat 5] [--json out.json]``, from the checkout to measure
(``PYTHONPATH`` selects another one: docs/performance.md compares the turn before the native links).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import yaml

import latdyn

GIMBAL = """
gravity: [0, 0, -9.81]
sections:
  stiff: {{EA: 1.0e8, EIy: 1.0e6, EIz: 1.0e6, GJ: 1.0e6, rhoA: 0.01}}
bodies:
  base: {{at: [0, 0, -0.2], fixed: true}}
  gimbal: {{at: [0, 0, 0], mass: 0.01, inertia: [1.0e-4, 1.0e-4, 1.0e-4]}}
  rotor: {{at: [0.5, 0, 0], mass: 1.0, inertia: [1.0, 0.5, 0.5]}}
beams:
  post: {{from: base, to: gimbal, section: stiff, rigid: {rigid}, start: {{hinge: {{axis: [0, 0, 1]}}}}}}
  arm: {{from: gimbal, to: rotor, section: stiff, rigid: {rigid}, start: {{hinge: {{axis: [0, 1, 0]}}}},
        end: {{hinge: {{axis: [1, 0, 0], angle: "20*t"}}}}}}
solve: {{t_end: {t_end}, dt: 0.005}}
output:
  probes:
    precession: {{hinge: post.start, quantity: angle}}
    tilt: {{hinge: arm.start, quantity: angle}}
    kinetic: {{energy: kinetic}}
"""


def in_process(rigid: str, t_end: float) -> tuple[float, dict]:
    raw = yaml.safe_load(GIMBAL.format(rigid=rigid, t_end=t_end))
    with tempfile.TemporaryDirectory() as folder:
        started = time.perf_counter()
        result = latdyn.run(latdyn.load_scene(raw), os.path.join(folder, "out"))
        return time.perf_counter() - started, result.summary


def as_user(rigid: str, t_end: float) -> float:
    environment = dict(os.environ)
    environment.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's installation keeps its byte code
    with tempfile.TemporaryDirectory() as folder:
        scene = os.path.join(folder, "gimbal.yaml")
        with open(scene, "w") as handle:
            handle.write(GIMBAL.format(rigid=rigid, t_end=t_end))
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "latdyn", "run", scene, "-o", os.path.join(folder, "out")],
                       check=True, capture_output=True, env=environment)
        return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    out = {"latdyn": latdyn.__file__, "load_before": os.getloadavg()[0]}
    for rigid in ("true", "false"):
        in_process(rigid, 0.02)  # laws compiled, modules imported
        as_user(rigid, 0.02)  # byte code written
        long, short, user = [], [], []
        for _ in range(args.repeat):
            seconds, summary = in_process(rigid, 2.0)
            long.append(seconds)
            short.append(in_process(rigid, 0.2)[0])
            user.append(as_user(rigid, 2.0))
        steps = summary["steps"]
        per_step = (statistics.median(long) - statistics.median(short)) / (steps - 40)
        out[rigid] = {"coordinates": summary.get("coordinates"), "steps": steps,
                      "newton_iterations": summary["newton_iterations"], "in_process_s": long,
                      "in_process_short_s": short, "latdyn_run_s": user,
                      "in_process_median_s": statistics.median(long), "per_step_ms": 1e3 * per_step,
                      "latdyn_run_median_s": statistics.median(user),
                      "solver_s": summary.get("solver_s")}
        print(f"rigid: {rigid}: {steps} steps, {summary['newton_iterations']} iterations; in-process median "
              f"{statistics.median(long):.3f} s, {1e3 * per_step:.3f} ms a step; latdyn run median "
              f"{statistics.median(user):.3f} s")
    out["load_after"] = os.getloadavg()[0]
    print(f"load average (1 min): {out['load_before']:.2f} before, {out['load_after']:.2f} after")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(out, handle, indent=1)


if __name__ == "__main__":
    main()
