"""The spin-up example (SCENE.md) with each integrator: wall time and Newton iterations per step.

    python benchmarks/integrators.py

The explicit method needs a step below its stability limit (the axial mode of
an 1.25 m element with EA = 2.8e7, ρA = 1.2: ω ≈ 2·sqrt(EA/ρA)/L ≈ 7.7e3 rad/s),
so it runs at dt = 1e-4 on a 2 s window; the implicit ones run the full 20 s at 0.005.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import yaml

import latdyn

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "spinup.yaml"


def scene(method, t_end=20.0, dt=0.005):
    raw = yaml.safe_load(EXAMPLE.read_text())
    raw["sections"]["arm"] = {k: float(v) for k, v in raw["sections"]["arm"].items()}
    raw["solve"].update(method=method, t_end=t_end, dt=dt)
    return raw


def main():
    latdyn.run(scene("generalized-alpha", t_end=0.05))  # compile/load the kernels once
    print(f"{'method':20s} {'t_end':>6s} {'dt':>8s} {'wall s':>8s} {'steps':>6s} {'iter/step':>9s} {'tip_v(end)':>11s}")
    for method, t_end, dt in [("generalized-alpha", 20.0, 0.005), ("hht-alpha", 20.0, 0.005),
                              ("newmark", 20.0, 0.005), ("explicit", 2.0, 1e-4),
                              ("generalized-alpha", 2.0, 0.005)]:
        walls = []
        for _ in range(3 if t_end <= 2 else 1):
            start = time.perf_counter()
            result = latdyn.run(scene(method, t_end, dt))
            walls.append(time.perf_counter() - start)
        s = result.summary
        tip = result.probes["tip_v"][-1]
        print(f"{method:20s} {t_end:6.1f} {dt:8.4f} {np.median(walls):8.2f} {s['steps']:6d} "
              f"{s['newton_iterations'] / max(s['steps'], 1):9.2f} {tip:11.6f}")


if __name__ == "__main__":
    main()
