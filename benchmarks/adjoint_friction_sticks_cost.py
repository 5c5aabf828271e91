"""What the discrete adjoint costs through sticking friction (issue 34; docs/performance.md, "The adjoint through
sticking friction (issue 34)").

    python benchmarks/adjoint_friction_sticks_cost.py [--repeats 5]

The scenes of tests/test_adjoint_friction_sticks.py (a 3D arm slewing on a skew friction hinge under a sinusoidal
torque that sticks and slips again, 7 parameters; the same arm braked hard, four sticks, 5 parameters; a gimbal ring
and the arm it carries, both on friction hinges, each sticking and slipping, 6 parameters), each run without sensitivities, by the forward
method and by the adjoint, kernels and laws compiled before, interleaved ``--repeats`` times; printed: the median wall
and CPU (``time.process_time``) times of ``latdyn.run`` and their ratios to the run without and, for the adjoint, to
the forward method; the 1-minute load average. Run it under ``chrt -f 10`` on a loaded machine.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import yaml

import latdyn

ROOT = Path(__file__).resolve().parents[1]


def variants(text: str) -> dict:
    """{without, forward, adjoint}: the scene's mapping without sensitivities and with each method."""
    out = {}
    for method in ("without", "forward", "adjoint"):
        data = yaml.safe_load(text)
        if method == "without":
            del data["solve"]["sensitivities"], data["solve"]["sensitivity_method"]
        else:
            data["solve"]["sensitivity_method"] = method
        out[method] = data
    return out


def timed(data: dict) -> tuple[float, float]:
    """(wall, CPU) seconds of one ``latdyn.run``."""
    scene = latdyn.load_scene(data)
    wall, cpu = time.perf_counter(), time.process_time()
    latdyn.run(scene)
    return time.perf_counter() - wall, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    sys.path += [str(ROOT), str(ROOT / "tests")]   # after PYTHONPATH (the build measured); the tests' scenes
    from tests.test_adjoint_friction_sticks import BRAKED, GIMBAL, SLEW_SINE

    scenes = {"slewing, sticks and slips again": SLEW_SINE, "braked arm, four sticks": BRAKED,
              "gimbal, ring and arm sticking": GIMBAL}
    for name, text in scenes.items():
        cases = variants(text)
        for data in cases.values():   # compiled before
            timed(data)
        times = {method: [] for method in cases}
        for _ in range(args.repeats):
            for method, data in cases.items():
                times[method].append(timed(data))
        wall = {m: statistics.median(t[0] for t in v) for m, v in times.items()}
        cpu = {m: statistics.median(t[1] for t in v) for m, v in times.items()}
        print(f"{name} (load {os.getloadavg()[0]:.1f}): without {wall['without'] * 1e3:.0f} ms wall, "
              f"{cpu['without'] * 1e3:.0f} ms CPU; forward {cpu['forward'] / cpu['without']:.2f} x CPU "
              f"({wall['forward'] / wall['without']:.2f} x wall); adjoint {cpu['adjoint'] / cpu['without']:.2f} x CPU "
              f"({wall['adjoint'] / wall['without']:.2f} x wall), {cpu['adjoint'] / cpu['forward']:.2f} x the forward "
              f"method's CPU ({wall['adjoint'] / wall['forward']:.2f} x wall)", flush=True)


if __name__ == "__main__":
    main()
