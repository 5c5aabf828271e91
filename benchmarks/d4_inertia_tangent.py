"""D4 very flexible pendulum as published (ρI = 0): Newton with and without the inertia tangent.

    python benchmarks/d4_inertia_tangent.py [--quick]

Runs examples/benchmarks/D4_flexible_pendulum.yaml (8 elements, Newmark, log-map element) to
1 s with ``solve.newton`` full (the inertia tangent taken from the first Newton failure on)
and exact (from the start), at dt 1, 0.5 and 0.25 ms, and prints per run: the time reached,
the energy drift max|E − E₀| / max|potential|, the largest out-of-plane displacement of a node,
steps, Newton iterations, rejected steps and when the inertia tangent was switched on.
The numbers of docs/verification.md ("D4 very flexible pendulum as published") come from
these settings; ``--quick`` runs dt 1 ms only.
"""
from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np
import yaml

import latdyn
from latdyn.errors import SolverError

SCENE = Path(__file__).resolve().parents[1] / "examples" / "benchmarks" / "D4_flexible_pendulum.yaml"


def run(newton: str, dt: float, method: str = "newmark", elements: int = 8) -> dict:
    raw = yaml.safe_load(SCENE.read_text())
    raw["solve"].update(newton=newton, dt=dt, method=method, planar="off")  # the 3D model
    raw["beams"]["pendulum"]["elements"] = elements
    probes = raw["output"]["probes"]
    for i in range(1, elements + 1):
        probes[f"z{i}"] = {"point": f"pendulum.node[{i}]", "quantity": "position", "component": "z"}
    out = Path(tempfile.mkdtemp(prefix="d4-"))
    error = None
    try:
        latdyn.run(latdyn.load_scene(raw), out)
    except SolverError as exc:
        error = str(exc).splitlines()[0]
    rows = np.genfromtxt(out / "probes.csv", delimiter=",", names=True)
    summary = json.loads((out / "summary.json").read_text())
    z = np.max(np.abs(np.column_stack([rows[f"z{i}"] for i in range(1, elements + 1)])), axis=1)
    energy = rows["energy"]
    return {"newton": newton, "dt": dt, "method": method, "elements": elements, "t_reached": float(rows["t"][-1]),
            "drift": float(np.max(np.abs(energy - energy[0])) / np.max(np.abs(rows["potential"]))),
            "max_z": float(z.max()), "steps": summary["steps"], "iterations": summary["newton_iterations"],
            "rejected": summary["rejected_steps"], "inertia_tangent_from": summary.get("inertia_tangent_from"),
            "solver_s": summary.get("solver_s"), "error": error}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    steps = [1e-3] if args.quick else [1e-3, 5e-4, 2.5e-4]
    print(f"{'newton':>6s} {'dt':>8s} {'t reached':>9s} {'drift':>9s} {'max|z| m':>9s} {'steps':>6s} {'iter.':>6s} "
          f"{'rejected':>8s} {'tangent from':>12s}")
    for newton in ("exact", "full"):
        for dt in steps:
            r = run(newton, dt)
            start = "-" if r["inertia_tangent_from"] is None else f"{r['inertia_tangent_from']:.4f}"
            print(f"{newton:>6s} {dt:8.2e} {r['t_reached']:9.4f} {r['drift']:9.2e} {r['max_z']:9.1e} {r['steps']:6d} "
                  f"{r['iterations']:6d} {r['rejected']:8d} {start:>12s}" + (f"  ({r['error']})" if r["error"] else ""),
                  flush=True)


if __name__ == "__main__":
    main()
