"""What the discrete adjoint costs with geometry parameters: a 3D lattice whose interior node coordinates are the
parameters (issue 34; docs/performance.md, "The adjoint with geometry parameters (issue 34)").

    python benchmarks/adjoint_geometry_cost.py [--repeats 3] [--counts 10,30,60]

:func:`lattice_tower`: a 3D cantilever truss of triangular section along x — 9 stations of three joint bodies (27
nodes), station 0 fixed, 72 members of one element each (longerons, battens, diagonals; shear-deformable tubes with
rotary inertia), a tip load growing in time, 20 steps of generalized-α (dt = 0.002). The parameters are the
coordinates ``x<i><v>``, ``y<i><v>``, ``z<i><v>`` of the interior stations' bodies (i = 1 … 7, v = a, b, c: 63);
the probe the tip's displacement. The same scene is run without sensitivities (the loop of steps in C), and with
the first 10, 30 and 60 coordinates by the forward method and by the adjoint (``solve.sensitivity_method:
adjoint``), kernels and laws compiled before, the cases interleaved ``--repeats`` times; printed: the median and
minimum wall and CPU times of ``latdyn.run`` and their ratios to the run without and, for the adjoint, to the
forward method with as many parameters; the 1-minute load average. Run it under ``chrt -f 10`` on a loaded machine.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import latdyn

#: the triangle of a station in the (y, z) plane, its vertices a, b, c
TRIANGLE = {"a": (0.0, 0.0), "b": (0.2, 0.0), "c": (0.1, 0.17)}


def coordinate_names(stations: int = 9) -> list[str]:
    """The interior stations' body coordinates, station by station: x1a, y1a, z1a, x1b, …"""
    return [f"{axis}{i}{v}" for i in range(1, stations - 1) for v in TRIANGLE for axis in "xyz"]


def lattice_tower(names: list[str], stations: int = 9, bay: float = 0.25, t_end: float = 0.04) -> dict:
    """The scene (module docstring) as the mapping a user's YAML loads to, ``solve.sensitivities: names``."""
    parameters, bodies = {}, {}
    last = stations - 1
    for i in range(stations):
        for v, (y, z) in TRIANGLE.items():
            body = f"n{i}{v}"
            if 0 < i < last:
                for axis, value in zip("xyz", (bay * i, y, z)):
                    parameters[f"{axis}{i}{v}"] = value
                bodies[body] = {"at": [f"x{i}{v}", f"y{i}{v}", f"z{i}{v}"], "mass": 0.05}
            else:
                bodies[body] = {"at": [bay * i, y, z], **({"fixed": True} if i == 0 else {"mass": 0.05})}
    members = {}
    turn = {"a": "b", "b": "c", "c": "a"}
    for i in range(stations - 1):
        for v, w in turn.items():
            members[f"long{i}{v}"] = (f"n{i}{v}", f"n{i + 1}{v}")
            members[f"diag{i}{v}"] = (f"n{i}{v}", f"n{i + 1}{w}")
            members[f"batt{i + 1}{v}"] = (f"n{i + 1}{v}", f"n{i + 1}{w}")
    solve = {"analysis": "transient", "dt": 0.002, "t_end": t_end, **({"sensitivities": names} if names else {})}
    return {"title": "3D lattice tower, its interior node coordinates the parameters",
            "parameters": parameters,
            "sections": {"tube": {"EA": 2.0e6, "EIy": 40.0, "EIz": 40.0, "GJ": 30.0, "GAy": 5.0e5, "GAz": 5.0e5,
                                  "rhoA": 0.8, "rhoIy": 1.0e-4, "rhoIz": 1.0e-4}},
            "bodies": bodies,
            "beams": {m: {"from": a, "to": b, "section": "tube", "elements": 1} for m, (a, b) in members.items()},
            "loads": [{"at": f"n{last}c", "force": ["100*t", "-150*t", "-400*t"]}],
            "solve": solve,
            "output": {"every": 0.01, "probes": {
                "tip_z": {"point": f"n{last}c", "quantity": "displacement", "component": "z"},
                "tip": {"point": f"n{last}c", "quantity": "displacement", "component": "norm"}}}}


def _run(loaded) -> tuple[float, float]:
    start, cpu = time.perf_counter(), time.process_time()
    latdyn.run(loaded)
    return time.perf_counter() - start, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--counts", default="10,30,60")
    args = parser.parse_args()
    counts = [int(c) for c in args.counts.split(",")]
    names = coordinate_names()
    cases = {"without": latdyn.load_scene(lattice_tower([]))}
    for k in counts:
        for method in ("forward", "adjoint"):
            data = lattice_tower(names[:k])
            data["solve"]["sensitivity_method"] = method
            cases[f"{k} {method}"] = latdyn.load_scene(data)
    for loaded in cases.values():
        _run(loaded)   # compile the kernels and laws once
    wall: dict[str, list[float]] = {name: [] for name in cases}
    cpu: dict[str, list[float]] = {name: [] for name in cases}
    loads = []
    for _ in range(args.repeats):
        loads.append(os.getloadavg()[0])
        for name, loaded in cases.items():
            w, c = _run(loaded)
            wall[name].append(w)
            cpu[name].append(c)
    loads.append(os.getloadavg()[0])
    print(f"load average (1 min): {min(loads):.1f}-{max(loads):.1f} on {os.cpu_count()} CPUs")
    median = {name: (statistics.median(wall[name]), statistics.median(cpu[name])) for name in cases}
    for name in cases:
        w, c = median[name]
        line = (f"{name:12s} wall median {w * 1e3:8.1f} ms (min {min(wall[name]) * 1e3:8.1f}), CPU median "
                f"{c * 1e3:8.1f} ms (min {min(cpu[name]) * 1e3:8.1f}); x without: wall {w / median['without'][0]:5.2f},"
                f" CPU {c / median['without'][1]:5.2f}")
        if name.endswith("adjoint"):
            fw, fc = median[name.replace("adjoint", "forward")]
            line += f"; x forward: wall {w / fw:5.2f}, CPU {c / fc:5.2f}"
        print(line)


if __name__ == "__main__":
    main()
