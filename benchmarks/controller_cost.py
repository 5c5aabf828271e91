"""What a controller costs a step: a beam of 8 elements on a hinge, 2000 steps of 0.002 s.

    python benchmarks/controller_cost.py [--repeat 3] [--cases none,p,pi,sampled100,sampled500]

The hinge torque is none (the free hinge, coasting from a slow turn), a continuous P controller on
the hinge angle, a continuous PI (its state integrated with the step: docs/control.md), or a sampled
P at 100 Hz or 500 Hz (every step). Through ``latdyn.run`` in process, kernels and laws cached (a
first run of each case, not timed, compiles them); per case the best of ``--repeat`` of
``summary.json`` ``solver_s`` per step and the wall time of ``latdyn.run``, with the Newton
iterations and ``time_loop``. The sampled cases' ``solver_s`` holds their samples and the restarts
after them where the loop of steps takes them (csrc/sampling.c); a checkout that takes them in
Python between calls leaves them out of it: compare the wall times. Run from another checkout (``PYTHONPATH``) for the before; a case the
checkout cannot run is reported as such. The 1-minute load average is printed: read the times with it.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import yaml

import latdyn

SCENE = """
{controllers}
sections:
  s: {{EA: 1.0e6, EIy: 100.0, EIz: 100.0, GJ: 80.0, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
beams:
  arm: {{from: hub, to: [2, 0, 0], section: s, elements: 8, start: {{hinge: {{axis: [0, 0, 1], torque: "{torque}"}}}}}}
initial_velocity: {{angular: [0, 0, 0.05]}}
solve: {{t_end: 4.0, dt: 0.002}}
output:
  every: 0.1
  probes:
    th: {{hinge: arm.start, quantity: angle}}
"""
CASES = {
    "none": ("", "0"),
    "p": ('controllers:\n  ctl: {output: "-20*(th - 0.2)"}', "ctl"),
    "pi": ('controllers:\n  ctl: {output: "-20*(th - 0.2) - 5*S", states: {S: "th - 0.2"}}', "ctl"),
    "sampled100": ('controllers:\n  ctl: {output: "-20*(th - 0.2)", rate: 100}', "ctl"),
    "sampled500": ('controllers:\n  ctl: {output: "-20*(th - 0.2)", rate: 500}', "ctl"),
}


def once(case: str) -> tuple[float, float, int, str]:
    controllers, torque = CASES[case]
    scene = latdyn.load_scene(yaml.safe_load(SCENE.format(controllers=controllers, torque=torque)))
    with tempfile.TemporaryDirectory() as folder:
        started = time.perf_counter()
        result = latdyn.run(scene, Path(folder))
        wall = time.perf_counter() - started
        summary = result.summary
    return summary["solver_s"] / summary["steps"], wall, summary["newton_iterations"], summary["time_loop"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--cases", default=",".join(CASES))
    args = parser.parse_args()
    print(f"latdyn from {Path(latdyn.__file__).parent}; load average {os.getloadavg()[0]:.1f}")
    for case in args.cases.split(","):
        try:
            once(case)  # compile and warm up
        except Exception as error:  # noqa: BLE001 - a checkout without the feature: say so
            print(f"{case:>11}: not run by this checkout ({type(error).__name__}: {str(error)[:90]})")
            continue
        runs = [once(case) for _ in range(args.repeat)]
        best = min(runs)
        print(f"{case:>11}: solver {1e6 * best[0]:6.0f} µs/step, wall {min(r[1] for r in runs):5.2f} s, "
              f"{best[2]} Newton iterations, time loop {best[3]} (load {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
