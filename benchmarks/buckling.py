"""Buckling loads (``solve.analysis: buckling``, latdyn/analyses/linearise.py) against closed forms.

Run from the repository root::

    python benchmarks/buckling.py

- Euler column, clamped at the base, dead compressive tip load: P_cr = π²EI/(4L²)
  (a pinned–pinned column of length 2L has the same load);
- lateral–torsional buckling of a cantilever under a dead tip load at the centroid:
  P_cr = 4.0126 √(EI_weak GJ)/L² (Timoshenko & Gere, Theory of Elastic Stability, 2nd ed.,
  §6.3; EI_strong ≫ EI_weak), for EI_strong/EI_weak = 1000 and 100.

For each mesh: ``buckling_factor`` (where the tangent of the static path stops being positive
definite) and the first ``linearised_buckling_factors`` (classical estimate about the unloaded
configuration), both relative to the closed form, and the wall time of the run.
Writes ``benchmarks/results/buckling.json``.
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import latdyn  # noqa: E402


def column(elements: int) -> tuple[dict, float]:
    L, EI, P = 2.0, 100.0, 100.0
    scene = {"sections": {"col": {"EA": 1.0e6, "EIy": EI, "EIz": 2 * EI, "GJ": 80, "rhoA": 1.0}},
             "bodies": {"base": {"at": [0, 0, 0], "fixed": True}},
             "beams": {"col": {"from": "base", "to": [0, 0, L], "section": "col", "elements": elements}},
             "loads": [{"at": "col.end", "force": [0, 0, -P]}],
             "solve": {"analysis": "buckling", "steps": 4}}
    return scene, np.pi**2 * EI / (4 * L**2) / P


def lateral(elements: int, ratio: float) -> tuple[dict, float]:
    L, EI, GJ = 2.0, 1.0, 1.0
    scene = {"sections": {"s": {"EA": 1.0e7, "EIy": EI * ratio, "EIz": EI, "GJ": GJ, "rhoA": 1.0}},
             "bodies": {"base": {"at": [0, 0, 0], "fixed": True}},
             "beams": {"s": {"from": "base", "to": [L, 0, 0], "section": "s", "elements": elements}},
             "loads": [{"at": "s.end", "force": [0, 0, -1.0]}],
             "solve": {"analysis": "buckling"}}
    return scene, 4.0126 * np.sqrt(EI * GJ) / L**2


def main() -> None:
    rows = []
    cases = [("euler column, clamped-free", lambda n: column(n))]
    cases += [(f"lateral buckling, cantilever, EI ratio {r:g}", lambda n, r=r: lateral(n, r)) for r in (1000.0, 100.0)]
    for name, make in cases:
        for elements in (4, 8, 16):
            scene, closed_form = make(elements)
            started = time.perf_counter()
            result = latdyn.run(latdyn.load_scene(scene))
            seconds = time.perf_counter() - started
            s = result.summary
            linearised = (s["linearised_buckling_factors"] or [None])[0]
            row = {"problem": name, "elements": elements, "closed_form": closed_form,
                   "buckling_factor": s["buckling_factor"], "buckling_kind": s["buckling_kind"],
                   "relative_error": s["buckling_factor"] / closed_form - 1,
                   "linearised_factor": linearised,
                   "linearised_relative_error": None if linearised is None else linearised / closed_form - 1,
                   "wall_s": seconds}
            rows.append(row)
            print(f"{name:42s} {elements:3d}: {s['buckling_factor']:.6g} ({row['relative_error']:+.2e}); "
                  f"linearised {linearised:.6g} ({row['linearised_relative_error']:+.2e}); {seconds:.2f} s", flush=True)
    path = ROOT / "benchmarks" / "results" / "buckling.json"
    path.write_text(json.dumps({"rows": rows}, indent=1) + "\n")
    print(f"wrote {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
