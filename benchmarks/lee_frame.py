"""Lee's frame traced through its limit point and snap-back (issue 22, item 2).

    python benchmarks/lee_frame.py    # writes benchmarks/results/lee_frame.json, docs/verification/lee_frame.png

Lee, Manuel & Rossow (1968); the load–deflection curve of Simo & Vu-Quoc (1986) as digitized in
``benchmarks/references/benchmarks.json`` (``S4_lee_frame``).  L = 120 in, E = 7.2e6 psi,
A = 6 in², I = 2 in⁴ (kip, in), column base and beam far end pinned, rigid corner, a vertical
dead load of 40 kip × λ at 24 in from the corner.  For meshes of 10, 20 and 40 elements:

- ``arc-length`` (Crisfield's cylindrical arc length, latdyn/analyses/continuation.py): the limit load
  (the vertex of λ(s) about the turn), the snap-back minimum, path steps, Newton iterations per
  step, and the distance of the 65 digitized points to the traced path (a kip counted as 5 in);
- ``load-control`` to 20 kip, steps of 0.5 kip: where it stops (its last converged load), or, when
  it ends "solved", the far branch it jumped to;
- ``displacement-control`` of the load point's deflection, 0 … 56 in in 1 in steps: its maximum
  load.

Every run goes through ``latdyn.run`` on the YAML text a user would write.
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import latdyn  # noqa: E402
import latdyn.results.writer  # noqa: E402
from latdyn.errors import SolverError  # noqa: E402

SCENE = """\
title: Lee's frame, dead load at 24 in from the corner
sections:
  s: {{EA: 43200.0, EIy: 14400.0, EIz: 14400.0, GJ: 14400.0, rhoA: 1.0, rhoIy: 1.0, rhoIz: 1.0}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  corner: {{at: [0, 120, 0]}}
  load: {{at: [24, 120, 0]}}
  far: {{at: [120, 120, 0], fixed: true}}
beams:
  column: {{from: base, to: corner, section: s, elements: {column}, start: {{hinge: {{axis: [0, 0, 1]}}}}}}
  left: {{from: corner, to: load, section: s, elements: {left}}}
  right: {{from: load, to: far, section: s, elements: {right}, end: {{hinge: {{axis: [0, 0, 1]}}}}}}
loads:
  - {{at: load, force: [0, {force}, 0]}}
solve: {solve}
output:
  paraview_every: 0
  probes:
    u: {{point: load, quantity: displacement, component: x}}
    v: {{point: load, quantity: displacement, component: y}}
"""
P_REF = 40.0  # kip at λ = 1


def scene(elements: int, solve: str, force: float = -P_REF) -> dict:
    m = elements // 10
    import yaml

    return yaml.safe_load(SCENE.format(column=5 * m, left=m, right=4 * m, force=force, solve=solve))


def reference() -> dict:
    problems = json.loads((ROOT / "benchmarks" / "references" / "benchmarks.json").read_text())["problems"]
    return next(p for p in problems if p["id"] == "S4_lee_frame")["reference"]


def distance_to_path(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    a, b = path[:-1], path[1:]
    ab = b - a
    out = []
    for p in points:
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
        out.append(np.min(np.linalg.norm(p - (a + t[:, None] * ab), axis=1)))
    return np.array(out)


def main() -> None:
    ref = reference()
    curve = ref["digitized_curve_u3"]
    digitized = np.column_stack([curve["minus_u3_in"], 5.0 * np.asarray(curve["load_kip"])])
    rows, paths = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for elements in (10, 20, 40):
            started = time.perf_counter()
            result = latdyn.run(latdyn.load_scene(scene(elements, "{analysis: static, method: arc-length, steps: 20, "
                                                                  "max_steps: 400}")), Path(tmp) / "arc")
            wall = time.perf_counter() - started
            s = json.loads((Path(tmp) / "arc" / "summary.json").read_text())
            load, v, u = P_REF * np.asarray(result.t), -np.asarray(result.probes["v"]), np.asarray(result.probes["u"])
            paths[elements] = (load, v, u)
            distance = distance_to_path(digitized, np.column_stack([v, 5.0 * load]))
            limits = [P_REF * p["load_factor"] for p in s["limit_points"]]
            # load control: 40 steps to 20 kip; the last converged load is where it stops
            try:
                latdyn.run(latdyn.load_scene(scene(elements, "{analysis: static, steps: 40}", force=-20.0)),
                           Path(tmp) / "lc")
            except SolverError:
                pass
            lc = latdyn.results.writer.Result.load(Path(tmp) / "lc")
            lc_status = json.loads((Path(tmp) / "lc" / "summary.json").read_text())["status"]
            latdyn.run(latdyn.load_scene(scene(elements, "{analysis: static, method: displacement-control, "
                                                              "steps: 56, control: {point: load, direction: [0, -1, 0], "
                                                              "to: 56.0}}")), Path(tmp) / "dc")
            dc_s = json.loads((Path(tmp) / "dc" / "summary.json").read_text())
            rows.append({
                "elements": elements, "arc_length_steps": s["steps"], "newton_iterations": s["newton_iterations"],
                "iterations_per_step": s["newton_iterations"] / s["steps"], "rejected_steps": s["rejected_steps"],
                "wall_s": wall, "limit_load_kip": limits[0], "snap_back_minimum_kip": limits[1],
                "deflection_at_limit_step_in": float(v[s["limit_points"][0]["step"]]),
                "limit_points": len(limits), "bifurcation_points": len(s["bifurcation_points"]),
                "curve_distance_max_in": float(distance.max()),
                "curve_distance_rms_in": float(np.sqrt(np.mean(distance ** 2))),
                "load_control": {"status": lc_status, "last_load_kip": 20.0 * float(lc.t[-1]),
                                 "last_deflection_in": -float(lc.probes["v"][-1])},
                "displacement_control_max_kip": P_REF * dc_s["limit_points"][0]["load_factor"]
                if dc_s["limit_points"] else None,
            })
            print(json.dumps(rows[-1]))
    out = {"problem": "S4_lee_frame", "reference": {k: ref[k] for k in ("first_limit_load_kip", "limit_load_range_kip",
                                                                        "deflection_at_limit_in",
                                                                        "min_load_on_snapback_kip")},
           "distance_note": "distance of the 65 digitized points to the traced path in (deflection in, 5 x load kip)",
           "rows": rows}
    (ROOT / "benchmarks" / "results").mkdir(exist_ok=True)
    (ROOT / "benchmarks" / "results" / "lee_frame.json").write_text(json.dumps(out, indent=1) + "\n")
    plot(paths, curve)


def plot(paths: dict, curve: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    load, v, u = paths[10]
    ax[0].plot(v, load, "-", lw=1.2, label="latdyn arc length, 10 elements")
    ax[0].plot(paths[40][1], paths[40][0], "--", lw=1.0, label="latdyn arc length, 40 elements")
    ax[0].plot(curve["minus_u3_in"], curve["load_kip"], "o", ms=3.5, mfc="none",
               label="Simo & Vu-Quoc (1986), digitized")
    ax[0].set(xlabel="vertical deflection of the load point −v [in]", ylabel="load P [kip]",
              title="Lee's frame: load against vertical deflection")
    ax[1].plot(u, load, "-", lw=1.2, label="latdyn arc length, 10 elements")
    ax[1].plot(paths[40][2], paths[40][0], "--", lw=1.0, label="latdyn arc length, 40 elements")
    ax[1].set(xlabel="horizontal displacement of the load point u [in]", ylabel="load P [kip]",
              title="Lee's frame: load against horizontal displacement")
    for a in ax:
        a.axhline(0.0, color="0.7", lw=0.6)
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "verification" / "lee_frame.png", dpi=110)


if __name__ == "__main__":
    main()
