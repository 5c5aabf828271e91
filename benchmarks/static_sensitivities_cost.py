"""What exact static sensitivities cost: 0, 1 and 10 parameters.

    python benchmarks/static_sensitivities_cost.py [--repeats 7]

A 3D cantilever of 60 elements (EIy != EIz, tilted out of every coordinate plane) carries ten
point loads, the i-th of amplitude ``F<i>`` (a named parameter), ramped over 20 load steps
(load control); two probes at the tip. The same scene is run in process without sensitivities,
with ``solve.sensitivities: [F0]`` and with ``[F0, …, F9]``, kernels and laws compiled before, the
three interleaved ``--repeats`` times (the machine may be shared). Per recorded row the
sensitivities add one evaluation of the static Newton matrix at the converged configuration, one
factorization and k back-substitutions, and the generated load kernel once per load and
parameter (latdyn/analyses/sensitivities.py). Printed: the minimum and median wall time of
``latdyn.run`` and the ratio of the minima; the 1-minute load average is printed with them.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import latdyn


def scene(names: list[str]) -> dict:
    loads = [{"at": f"arm.node[{6 * (i + 1)}]", "force": [f"0.1*F{i}", f"-F{i}", f"0.3*F{i}"]} for i in range(10)]
    solve = {"analysis": "static", "steps": 20, **({"sensitivities": names} if names else {})}
    return {"parameters": {f"F{i}": 0.5 + 0.1 * i for i in range(10)},
            "sections": {"s": {"EA": 1e6, "EIy": 50.0, "EIz": 80.0, "GJ": 40.0, "rhoA": 1.0}},
            "bodies": {"base": {"at": [0, 0, 0], "fixed": True}},
            "beams": {"arm": {"from": "base", "to": [3.0, 1.0, 0.5], "section": "s", "elements": 60}},
            "loads": loads, "solve": solve,
            "output": {"probes": {"tip_z": {"point": "arm.end", "quantity": "position", "component": "z"},
                                  "tip_y": {"point": "arm.end", "quantity": "displacement", "component": "y"}}}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    cases = {k: latdyn.load_scene(scene([f"F{i}" for i in range(k)])) for k in (0, 1, 10)}
    for loaded in cases.values():
        latdyn.run(loaded)   # compile the kernels and laws once
    times: dict[int, list[float]] = {k: [] for k in cases}
    for _ in range(args.repeats):
        for k, loaded in cases.items():
            start = time.perf_counter()
            latdyn.run(loaded)
            times[k].append(time.perf_counter() - start)
    print(f"load average (1 min): {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    for k, measured in times.items():
        print(f"{k:2d} parameters: min {min(measured) * 1e3:7.1f} ms, median {statistics.median(measured) * 1e3:7.1f} ms,"
              f" {min(measured) / min(times[0]):.2f}x the run without (minima)")


if __name__ == "__main__":
    main()
