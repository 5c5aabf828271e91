"""The Newton tolerance: where round-off ends and the discretisation error begins.

    python benchmarks/newton_tolerance.py [--t-end-spinup 10] [--t-end-cantilever 10]

Newton stops when the increment is small in ``latdyn.step.integrators.increment_size``
(per node |Δd|/ℓ and |Δπ| in radians, per hinge |Δθ|).  For each tolerance the
spin-up (4 elements, dt 0.01, EA/EI = 2e3), a stiff spin-up (EA/EI = 2e5, so axial
round-off is amplified a hundredfold in bending) and the right-angle cantilever
(D2, 20 elements, dt 0.05) are run; the table gives steps, Newton iterations,
steps cut, and the largest difference of the tip probe from the tightest
tolerance that converged everywhere.  A tolerance is too tight when steps get cut
(the increment cannot fall below the round-off floor), too loose when its
difference approaches the time-discretisation error (8e-4 m for the spin-up at
dt 0.01, from issue 8's converged reference).
"""
from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np
import yaml

import latdyn
from latdyn.errors import SolverError

ROOT = Path(__file__).resolve().parents[1]
TOLERANCES = (1e-5, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14)


def spinup(t_end: float, stiff: bool = False) -> dict:
    scene = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
    scene["beams"]["arm"]["elements"] = 4
    scene["solve"].update(t_end=t_end, dt=0.01)
    scene["output"] = {"every": 0.1, "probes": {"tip": scene["output"]["probes"]["tip_v"]}}
    if stiff:
        scene["sections"]["arm"]["EA"] = 2.8e9
    return scene


def cantilever(t_end: float) -> dict:
    scene = yaml.safe_load((ROOT / "examples" / "benchmarks" / "D2_right_angle_cantilever.yaml").read_text())
    scene["solve"].update(t_end=t_end)
    scene["output"] = {"every": 0.1, "probes": {"tip": scene["output"]["probes"]["tip_u3"]}}
    return scene


def sweep(name: str, build) -> list[dict]:
    rows, reference = [], None
    for tol in sorted(TOLERANCES):
        scene = build()
        scene["solve"]["tol"] = tol
        t0 = time.perf_counter()
        try:
            result = latdyn.run(scene)
            status = "solved"
        except SolverError as exc:
            result, status = None, f"failed: {str(exc).splitlines()[0]}"
        wall = time.perf_counter() - t0
        row = {"problem": name, "tol": tol, "status": status, "wall_s": wall}
        if result is not None:
            s = result.summary
            row.update(steps=s["steps"], newton_iterations=s["newton_iterations"], cuts=s.get("newton_cuts", 0))
            if reference is None and row["cuts"] == 0:
                reference = result.probes["tip"]
            row["tip"] = result.probes["tip"]
        rows.append(row)
    for row in rows:
        if "tip" in row:
            row["difference"] = float(np.max(np.abs(row.pop("tip") - reference))) if reference is not None else None
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end-spinup", type=float, default=10.0)
    parser.add_argument("--t-end-cantilever", type=float, default=10.0)
    args = parser.parse_args()
    rows = (sweep("spin-up", lambda: spinup(args.t_end_spinup))
            + sweep("spin-up, EA x100", lambda: spinup(args.t_end_spinup, stiff=True))
            + sweep("right-angle cantilever", lambda: cantilever(args.t_end_cantilever)))
    print(f"machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}")
    print(f"{'problem':24s} {'tol':>7s} {'steps':>6s} {'Newton':>7s} {'cuts':>5s} {'|Δtip| vs tightest':>19s}  status")
    for r in rows:
        diff = r.get("difference")
        print(f"{r['problem']:24s} {r['tol']:7.0e} {r.get('steps', '-'):>6} {r.get('newton_iterations', '-'):>7} "
              f"{r.get('cuts', '-'):>5} {('%.2e' % diff) if diff is not None else '-':>19s}  {r['status']}")
    out = ROOT / "benchmarks" / "results"
    out.mkdir(exist_ok=True)
    (out / "newton_tolerance.json").write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
