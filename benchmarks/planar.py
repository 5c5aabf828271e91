"""The planar model against the 3D model: same answer, and what it saves.

Run from the repository root::

    python benchmarks/planar.py            # spin-up (2, 4, 8 elements) and D4 (8 elements), 3 repeats
    python benchmarks/planar.py --repeats 5

For each scene and setting, ``solve.planar: auto`` (in-plane coordinates, planar kernels) and
``solve.planar: off`` (the 3D model) are run in turn with the compiled step, after one untimed
warm-up of each (kernels compiled and cached); the repeats are interleaved and the median
``solver_s`` (``summary.json``: the time inside the steps) and whole-call time are reported with
the number of coordinates, Newton iterations and the largest probe difference between the
two models, relative to the probe's range. The 1-minute load average is printed: the machine
may be shared. Results: ``benchmarks/results/planar.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import latdyn  # noqa: E402


def spinup(elements: int) -> dict:
    scene = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
    scene["beams"]["arm"]["elements"] = elements
    scene["solve"].update(t_end=10.0, dt=0.01)
    return scene


def pendulum(elements: int) -> dict:
    scene = yaml.safe_load((ROOT / "examples" / "benchmarks" / "D4_flexible_pendulum.yaml").read_text())
    scene["beams"]["pendulum"]["elements"] = elements
    # the 3D model of the published D4 (no rotary inertia) fails near 0.45 s (docs/verification.md);
    # 0.4 s is what both models solve
    scene["solve"]["t_end"] = 0.4
    return scene


CASES = [("spin-up, 2 el, dt 0.01, 10 s", spinup, 2), ("spin-up, 4 el, dt 0.01, 10 s", spinup, 4),
         ("spin-up, 8 el, dt 0.01, 10 s", spinup, 8), ("D4 pendulum, 8 el, dt 1 ms, 0.4 s", pendulum, 8)]


def run(scene: dict, planar: str):
    scene = json.loads(json.dumps(scene))
    scene["solve"]["planar"] = planar
    started = time.perf_counter()
    result = latdyn.run(scene)
    return result, time.perf_counter() - started


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "planar.json"))
    args = parser.parse_args(argv)
    rows = []
    for label, make, elements in CASES:
        scene = make(elements)
        timings = {"auto": [], "off": []}
        results = {}
        for planar in ("auto", "off"):
            results[planar], _ = run(scene, planar)  # warm-up: kernels compiled and cached
        for _ in range(args.repeats):
            for planar in ("auto", "off"):
                result, whole = run(scene, planar)
                timings[planar].append((result.summary["solver_s"], whole))
        difference = max(
            float(np.max(np.abs(results["auto"].probes[k] - results["off"].probes[k]))
                  / max(np.ptp(results["off"].probes[k]), 1e-300))
            for k in results["off"].probes)
        row = {"case": label, "max_probe_difference": difference}
        for planar in ("auto", "off"):
            s = results[planar].summary
            row[planar] = {"coordinates": s["coordinates"], "newton_iterations": s["newton_iterations"],
                           "engine": s.get("engine"),
                           "solver_s": statistics.median(t for t, _ in timings[planar]),
                           "run_s": statistics.median(w for _, w in timings[planar])}
        row["solver_gain"] = row["off"]["solver_s"] / row["auto"]["solver_s"]
        rows.append(row)
        print(f"{label:36s} coordinates {row['auto']['coordinates']:3d} vs {row['off']['coordinates']:3d}  "
              f"solver {row['auto']['solver_s']:.3f} vs {row['off']['solver_s']:.3f} s "
              f"(x{row['solver_gain']:.1f})  whole call {row['auto']['run_s']:.3f} vs {row['off']['run_s']:.3f} s  "
              f"iterations {row['auto']['newton_iterations']} vs {row['off']['newton_iterations']}  "
              f"max probe difference {difference:.1e}", flush=True)
    out = {"machine": {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
                       "python": platform.python_version(), "load_average_end": list(os.getloadavg())},
           "repeats": args.repeats, "rows": rows}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    print(f"load average {os.getloadavg()[0]:.2f}; written {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
