"""What a controller costs a step: a beam of 8 elements on a hinge, 2000 steps of 0.002 s.

    python benchmarks/controller_cost.py [--repeat 3] [--cases none,p,pi,sampled100,sampled500,guided_none,guided_sampled100]

The hinge torque is none (the free hinge, coasting from a slow turn), a continuous P controller on
the hinge angle, a continuous PI (its state integrated with the step: docs/control.md), or a sampled
P at 100 Hz or 500 Hz (every step). The guided cases carry the beam on a cart that slides on a guide
(rigid links: the restart after a sample on the minimum coordinates), its force none or a sampled PD
at 100 Hz. Through ``latdyn.run`` in process, kernels and laws cached (a
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
#: A guided model: a cart on a guide along x (spring) carrying, through a rigid link on a hinge, the same
#: beam; the guide's force is none or a sampled PD on the slide at 100 Hz (the restart after each sample
#: on the minimum coordinates, csrc/sampling.c with csrc/links.c's reduced mass).
GUIDED = """
{controllers}
sections:
  s: {{EA: 1.0e6, EIy: 100.0, EIz: 100.0, GJ: 80.0, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  cart: {{at: [0, 0, 0], mass: 2.0, inertia: [0.1, 0.1, 0.1], guide: {{axis: [1, 0, 0], stiffness: 50.0, force: "{torque}"}}}}
  mast: {{at: [0, 0.3, 0], mass: 0.5, inertia: [0.01, 0.01, 0.01]}}
beams:
  post: {{from: cart, to: mast, section: s, rigid: true, start: {{hinge: {{axis: [0, 0, 1], stiffness: 20.0}}}}}}
  arm: {{from: mast, to: [2, 0.3, 0], section: s, elements: 8}}
initial_velocity: {{angular: [0, 0, 0.05]}}
solve: {{t_end: 4.0, dt: 0.002}}
output:
  every: 0.1
  probes:
    th: {{guide: cart, quantity: position}}
    thd: {{guide: cart, quantity: rate}}
"""
CASES = {
    "none": ("", "0"),
    "p": ('controllers:\n  ctl: {output: "-20*(th - 0.2)"}', "ctl"),
    "pi": ('controllers:\n  ctl: {output: "-20*(th - 0.2) - 5*S", states: {S: "th - 0.2"}}', "ctl"),
    "sampled100": ('controllers:\n  ctl: {output: "-20*(th - 0.2)", rate: 100}', "ctl"),
    "sampled500": ('controllers:\n  ctl: {output: "-20*(th - 0.2)", rate: 500}', "ctl"),
    "guided_none": ("", "0"),
    "guided_sampled100": ('controllers:\n  ctl: {output: "-40*(th - 0.05) - 5*thd", rate: 100}', "ctl"),
}


def once(case: str) -> tuple[float, float, int, str]:
    controllers, torque = CASES[case]
    text = GUIDED if case.startswith("guided") else SCENE
    scene = latdyn.load_scene(yaml.safe_load(text.format(controllers=controllers, torque=torque)))
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
