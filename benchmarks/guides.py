"""Guides (sliding joints) per step: the guided slider-crank and the bead on a turning rod (issue 31 item 2,
issue 32 item 2).

The scenes: ``examples/slider_crank.yaml`` (a crank of a rigid link driven through its hinge, a flexible
rod of 4 elements, a slider of 1 kg on a ground guide; dt = 0.002) and the bead of tests/test_guides.py
(a bead sliding on a rod turning at 2 rad/s about [1, 1, 1]: one coordinate; dt = 0.004, tol 1e-12), a
row every 0.01 s and 0.04 s as the scenes ask. Measured for each, in-process
(``latdyn.run(latdyn.load_scene(path), folder)``): the cost per step as the difference between a long and
a short run over their difference of steps (fixed costs cancel), and the solver's (``summary.json``
``solver_s`` over the steps of the long run).

Medians of ``--repeat`` runs; the 1-minute load average before and after is printed with them.
``python benchmarks/guides.py [--repeat 3] [--json out.json]``, from the checkout to measure
(``PYTHONPATH`` selects another one: docs/performance.md compares the turn before native guides).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import tempfile
import time
from pathlib import Path

import latdyn

SLIDER_CRANK = (Path(__file__).resolve().parents[1] / "examples" / "slider_crank.yaml").read_text()

BEAD = """
title: bead on a frictionless rod turning at a constant rate
bodies:
  rod:
    at: [0, 0, 0]
    motion:
      rotation: {axis: [1, 1, 1], angle: "2*t"}
  bead:
    at: [0.1, -0.1, 0]
    mass: 0.5
    guide: {on: rod, axis: [1, -1, 0]}
solve: {t_end: 0.8, dt: 0.004, tol: 1e-12}
output:
  every: 0.04
  probes:
    s: {guide: bead, quantity: position}
    rate: {guide: bead, quantity: rate}
    r: {point: bead, quantity: position, component: norm}
"""

#: scene text, the long and the short run's t_end
SCENES = {"slider_crank": (SLIDER_CRANK, 0.6, 0.1), "bead": (BEAD, 0.8, 0.16)}


def in_process(text: str, t_end: float) -> tuple[float, dict]:
    text = re.sub(r"t_end: [0-9.]+", f"t_end: {t_end}", text, count=1)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "scene.yaml")
        with open(path, "w") as handle:
            handle.write(text)
        started = time.perf_counter()
        result = latdyn.run(latdyn.load_scene(path), os.path.join(folder, "out"))
        return time.perf_counter() - started, result.summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    out = {"latdyn": latdyn.__file__, "load_before": os.getloadavg()[0]}
    for name, (text, long_t, short_t) in SCENES.items():
        in_process(text, short_t / 5)  # laws compiled, modules imported
        long, short = [], []
        for _ in range(args.repeat):
            seconds, summary = in_process(text, long_t)
            long.append(seconds)
            seconds_short, summary_short = in_process(text, short_t)
            short.append(seconds_short)
        steps = summary["steps"] - summary_short["steps"]
        per_step = (statistics.median(long) - statistics.median(short)) / steps
        out[name] = {"steps": summary["steps"], "newton_iterations": summary["newton_iterations"],
                     "in_process_s": long, "in_process_short_s": short, "per_step_ms": 1e3 * per_step,
                     "solver_per_step_ms": 1e3 * summary.get("solver_s", float("nan")) / summary["steps"]}
        print(f"{name}: {summary['steps']} steps, {summary['newton_iterations']} iterations; in-process median "
              f"{statistics.median(long):.3f} s, {1e3 * per_step:.3f} ms a step, solver "
              f"{out[name]['solver_per_step_ms']:.3f} ms a step")
    out["load_after"] = os.getloadavg()[0]
    print(f"load average (1 min): {out['load_before']:.2f} before, {out['load_after']:.2f} after")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(out, handle, indent=1)


if __name__ == "__main__":
    main()
