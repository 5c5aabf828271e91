"""Sparse step matrices in the transient sensitivities' loop of steps (issue 34, items 2 and 6).

    python benchmarks/sparse_sensitivities_loop.py [--grid N] [--counts 1,10,100] [--repeats 3] [--check DIR]

A 3D space frame — a square-on-square offset double-layer grid (the roof lattice of a hall): a top layer of N × N
joints 1 m apart, a bottom layer of (N − 1) × (N − 1) joints 0.7 m below, under the top layer's cell centres; the
top and bottom chords along both directions and four diagonals from each bottom joint to its cell's top corners,
aluminium tubes of one element each, every member its own section whose EA is the parameter ``F<i>``; the top
layer's four corners fixed, the joints rigid bodies of 0.2 kg; a load at the centre of the top layer growing in time
and its vertical displacement the probe, a row every 5 steps. Its step matrices' bandwidth after reverse
Cuthill–McKee is above BAND_LIMIT from N = 7 (288 members, 678 coordinates): S takes the supernodal sparse LU
(latdyn/assembly/factorization.py) on both the run's iteration matrix and the sensitivities' step (step_matrix.py).

Measured per case, cases interleaved ``--repeats`` times, in process (``latdyn.run`` on the loaded scene, kernels
compiled before): the run without sensitivities, with ``[F0..F(k-1)]`` by the forward method in the loop of steps
(latdyn/analyses/sensitivities_in_loop.py) and from Python (its private switch off), and the adjoint; wall and CPU
(``time.process_time``) medians, and each median's ratio to the run without. ``--check DIR``: each k's forward run
written with the loop on and off, the sha-256 of sensitivities.csv, probes.csv and summary.json's sensitivities.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import time
from pathlib import Path

import latdyn

#: an aluminium tube of 40 mm outside, 2 mm wall (E 70 GPa, G 26 GPa, ρ 2700 kg/m³)
TUBE = {"EA": 1.67e7, "EIy": 2.97e3, "EIz": 2.97e3, "GJ": 2.2e3, "rhoA": 0.645, "rhoIy": 1.15e-4, "rhoIz": 1.15e-4}


def members(n: int) -> list[tuple[str, str, str]]:
    """(name, from, to) of the double-layer grid's members: top chords, bottom chords, diagonals."""
    out = []
    for i in range(n):
        for j in range(n):
            if i + 1 < n:
                out.append((f"tx{i}_{j}", f"t{i}_{j}", f"t{i + 1}_{j}"))
            if j + 1 < n:
                out.append((f"ty{i}_{j}", f"t{i}_{j}", f"t{i}_{j + 1}"))
    for i in range(n - 1):
        for j in range(n - 1):
            if i + 1 < n - 1:
                out.append((f"bx{i}_{j}", f"b{i}_{j}", f"b{i + 1}_{j}"))
            if j + 1 < n - 1:
                out.append((f"by{i}_{j}", f"b{i}_{j}", f"b{i}_{j + 1}"))
            for di, dj in ((0, 0), (1, 0), (0, 1), (1, 1)):
                out.append((f"d{i}_{j}_{di}{dj}", f"b{i}_{j}", f"t{i + di}_{j + dj}"))
    return out


def space_frame(names: list[str], n: int = 7, *, dt: float = 0.001, t_end: float = 0.02,
                method: str | None = None) -> dict:
    """The scene (module docstring) with ``names`` the parameters differentiated (none: a run without)."""
    joints = {f"t{i}_{j}": [1.0 * i, 1.0 * j, 0.0] for i in range(n) for j in range(n)}
    joints.update({f"b{i}_{j}": [1.0 * i + 0.5, 1.0 * j + 0.5, -0.7] for i in range(n - 1) for j in range(n - 1)})
    corners = {f"t{i}_{j}" for i in (0, n - 1) for j in (0, n - 1)}
    bars = members(n)
    centre = f"t{n // 2}_{n // 2}"
    solve = {"analysis": "transient", "dt": dt, "t_end": t_end, **({"sensitivities": names} if names else {}),
             **({"sensitivity_method": method} if method else {})}
    return {"title": f"a {n} x {n} double-layer space frame, {len(bars)} members",
            "parameters": {f"F{i}": TUBE["EA"] for i in range(len(bars))},
            "sections": {name: {**TUBE, "EA": f"F{i}"} for i, (name, _, _) in enumerate(bars)},
            "bodies": {name: ({"at": at, "fixed": True} if name in corners else
                              {"at": at, "mass": 0.2, "inertia": [1e-4, 1e-4, 1e-4]}) for name, at in joints.items()},
            "beams": {name: {"from": a, "to": b, "section": name, "elements": 1} for name, a, b in bars},
            "loads": [{"at": centre, "force": [0, "3000*t", "-20000*t"]}], "solve": solve,
            "output": {"every": 5 * dt, "paraview_every": 0,
                       "probes": {"sag": {"point": centre, "quantity": "displacement", "component": "z"},
                                  "drift": {"point": centre, "quantity": "displacement", "component": "y"}}}}


def _timed(data: dict, in_loop: bool = True) -> tuple[float, float]:
    from latdyn.analyses import sensitivities_in_loop

    loaded = latdyn.load_scene(data)
    sensitivities_in_loop.SENSITIVITIES_IN_LOOP = in_loop
    try:
        start, cpu = time.perf_counter(), time.process_time()
        result = latdyn.run(loaded)
        return time.perf_counter() - start, time.process_time() - cpu, result.summary.get("sensitivity_steps_in_loop")
    finally:
        sensitivities_in_loop.SENSITIVITIES_IN_LOOP = True


def check(n: int, counts: list[int], folder: str) -> None:
    from latdyn.analyses import sensitivities_in_loop

    def digest(data: bytes) -> str:
        return hashlib.sha256(data).hexdigest()[:16]

    for k in counts:
        seen = {}
        for in_loop in (True, False):
            out = Path(folder) / f"{n}-{k}-{'loop' if in_loop else 'python'}"
            sensitivities_in_loop.SENSITIVITIES_IN_LOOP = in_loop
            try:
                latdyn.run(latdyn.load_scene(space_frame([f"F{i}" for i in range(k)], n)), out)
            finally:
                sensitivities_in_loop.SENSITIVITIES_IN_LOOP = True
            summary = json.loads((out / "summary.json").read_text())
            seen[in_loop] = ([digest((out / name).read_bytes()) for name in ("sensitivities.csv", "probes.csv")]
                             + [digest(json.dumps(summary.get(key), sort_keys=True).encode())
                                for key in ("probe_sensitivities", "event_sensitivities")],
                             summary["sensitivity_steps_in_loop"], summary["steps"])
        print(f"grid {n}, {k} parameters: {' '.join(seen[True][0])} (loop: {seen[True][1]} of {seen[True][2]} steps)"
              f" / {' '.join(seen[False][0])} (Python: {seen[False][1]}): "
              f"{'equal' if seen[True][0] == seen[False][0] else 'DIFFERENT'}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, default=7)
    parser.add_argument("--counts", default="1,10,100")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--check", default=None, metavar="DIR")
    parser.add_argument("--cases", default="without,forward,python,adjoint")
    args = parser.parse_args()
    counts = [int(k) for k in args.counts.split(",")]
    if args.check:
        check(args.grid, counts, args.check)
        return
    t_end = args.steps * 0.001
    cases = [("without", 0, None, True)]
    for k in counts:
        cases += [(f"forward {k}", k, None, True), (f"python {k}", k, None, False), (f"adjoint {k}", k, "adjoint", True)]
    wanted = args.cases.split(",")
    cases = [c for c in cases if c[0].split()[0] in wanted]
    data = {name: space_frame([f"F{i}" for i in range(k)], args.grid, t_end=t_end, method=method)
            for name, k, method, _ in cases}
    for name, _, _, in_loop in cases:   # kernels compiled, laws bound
        _timed(data[name], in_loop)
    seen = {name: [] for name, *_ in cases}
    for _ in range(args.repeats):
        for name, _, _, in_loop in cases:
            seen[name].append(_timed(data[name], in_loop))
    base = statistics.median(w for w, _, _ in seen["without"]), statistics.median(c for _, c, _ in seen["without"])
    print(f"grid {args.grid}: {len(members(args.grid))} members, {args.steps} steps, load {os.getloadavg()[0]:.1f}")
    for name, *_ in cases:
        wall, cpu = statistics.median(w for w, _, _ in seen[name]), statistics.median(c for _, c, _ in seen[name])
        print(f"  {name:12s} wall {wall:7.3f} s ({wall / base[0]:5.2f}x)  cpu {cpu:7.3f} s ({cpu / base[1]:5.2f}x)"
              f"  in loop {seen[name][0][2]}", flush=True)


if __name__ == "__main__":
    main()
