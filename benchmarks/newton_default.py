"""Which Newton iteration should be the default? Full against modified, measured on every
shipped transient scene, planar and 3D.

    python benchmarks/newton_default.py [--repeats 3] [--t-end-cap 10]

For each transient scene in ``examples/`` and ``examples/benchmarks/`` (scenes the compiled
step covers; up to issue 17 the Python step, which had no modified Newton, ran the others),
and for each planar scene once more with
``planar: off`` (its 3D model), the scene is run with ``solve.newton: full`` and ``modified``
in process, with no results folder, after one untimed warm-up of each. The repeats are
interleaved (pass 1 runs every setting, then pass 2, ...); ``solver_s`` (the time inside the
steps) is the median. The two runs converge to the same Newton tolerance, so the probes
differ by about that tolerance: ``probe_difference`` is the largest difference between the
two runs' probes over the run, divided by the probe's range (its max − min).

Results: ``benchmarks/results/newton_default.json`` and a Markdown table on stdout (the one in
``docs/performance.md``, "Newton default"). The 1-minute load average is recorded: the machine
is shared, read the times with it.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import yaml

import latdyn
import latdyn.solve
from latdyn.scene.loader import _yaml_loader

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks import peers  # noqa: E402  (machine(): the description every benchmark records)

OUT = ROOT / "benchmarks" / "results" / "newton_default.json"
MODES = ("full", "modified")


def scenes(t_end_cap: float):
    """(name, raw scene dict) of the shipped transient scenes; planar ones also with planar: off."""
    paths = sorted((ROOT / "examples").glob("*.yaml")) + sorted((ROOT / "examples" / "benchmarks").glob("*.yaml"))
    for path in paths:
        raw = yaml.load(path.read_text(), Loader=_yaml_loader())
        solve = raw.setdefault("solve", {})
        if solve.get("analysis", "transient") != "transient" or solve.get("method") == "explicit" \
                or solve.get("adaptive"):
            continue
        solve["t_end"] = min(float(solve["t_end"]), t_end_cap)
        name = str(path.relative_to(ROOT / "examples"))
        planar = latdyn.assembly.prepare.prepare(latdyn.load_scene(copy.deepcopy(raw))).model.plane is not None
        yield name, raw, "planar" if planar else "3D"
        if planar and solve.get("planar", "auto") == "auto":
            off = copy.deepcopy(raw)
            off["solve"]["planar"] = "off"
            yield name + " (planar: off)", off, "3D"


def run_once(raw: dict, newton: str) -> dict:
    scene = copy.deepcopy(raw)
    scene["solve"]["newton"] = newton
    t0 = time.perf_counter()
    try:
        result = latdyn.run(scene)
    except latdyn.SolverError as exc:
        return {"status": "failed", "note": str(exc).splitlines()[0][:200]}
    s = result.summary
    return {"status": "ok", "run_s": time.perf_counter() - t0, "solver_s": s["solver_s"], "steps": s["steps"],
            "newton_iterations": s["newton_iterations"], "factorizations": s["factorizations"],
            "engine": s.get("engine"), "time_loop": s.get("time_loop"), "newton_cuts": s.get("newton_cuts"),
            "probes": {k: np.asarray(v) for k, v in result.probes.items()}, "t": np.asarray(result.t)}


def probe_difference(a: dict, b: dict) -> float | None:
    if a["status"] != "ok" or b["status"] != "ok" or len(a["t"]) != len(b["t"]):
        return None
    worst = 0.0
    for name, va in a["probes"].items():
        vb = b["probes"][name]
        scale = float(np.ptp(va)) or max(float(np.max(np.abs(va))), 1e-300)
        worst = max(worst, float(np.max(np.abs(va - vb))) / scale)
    return worst


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--t-end-cap", type=float, default=10.0, help="cap t_end of long scenes (s)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)

    cases = list(scenes(args.t_end_cap))
    runs: dict = {(name, mode): [] for name, _, _ in cases for mode in MODES}
    for name, raw, _ in cases:  # warm-up: kernels and laws compiled and cached, imports done
        for mode in MODES:
            run_once(raw, mode)
    load = [os.getloadavg()[0]]
    for _ in range(args.repeats):
        for name, raw, _ in cases:
            for mode in MODES:
                runs[(name, mode)].append(run_once(raw, mode))
        load.append(os.getloadavg()[0])

    rows = []
    for name, raw, kind in cases:
        row = {"scene": name, "model": kind, "t_end": raw["solve"]["t_end"], "dt": raw["solve"]["dt"]}
        for mode in MODES:
            done = runs[(name, mode)]
            first = done[0]
            if first["status"] != "ok":
                row[mode] = {"status": first["status"], "note": first["note"]}
                continue
            row[mode] = {k: first[k] for k in ("steps", "newton_iterations", "factorizations", "engine",
                                               "time_loop", "newton_cuts")}
            row[mode]["status"] = "ok"
            row[mode]["solver_s"] = statistics.median(r["solver_s"] for r in done if r["status"] == "ok")
        row["probe_difference"] = probe_difference(runs[(name, "full")][0], runs[(name, "modified")][0])
        if row["full"].get("status") == "ok" and row["modified"].get("status") == "ok":
            row["modified_over_full"] = row["modified"]["solver_s"] / row["full"]["solver_s"]
        rows.append(row)

    doc = {"schema": "latdyn-newton-default/1", "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
           "repeats": args.repeats, "t_end_cap": args.t_end_cap,
           "machine": dict(peers.machine(), load_average_1min=load),
           "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(markdown(doc))
    return 0


def markdown(doc: dict) -> str:
    lines = ["| scene | model | full: iterations / factorizations / solver s | "
             "modified: iterations / factorizations / solver s | modified ÷ full | probe difference |",
             "|---|---|---|---|---|---|"]

    def cell(r):
        if r.get("status") != "ok":
            return r.get("status", "?")
        return f"{r['newton_iterations']} / {r['factorizations']} / {r['solver_s']:.3f}"

    for row in doc["rows"]:
        ratio = row.get("modified_over_full")
        diff = row.get("probe_difference")
        lines.append(f"| {row['scene']} | {row['model']} | {cell(row['full'])} | {cell(row['modified'])} | "
                     f"{'' if ratio is None else f'{ratio:.2f}'} | {'' if diff is None else f'{diff:.1e}'} |")
    ratios = [r["modified_over_full"] for r in doc["rows"] if "modified_over_full" in r]
    if ratios:
        lines.append("")
        lines.append(f"modified ÷ full solver time: median {statistics.median(ratios):.2f}, "
                     f"range {min(ratios):.2f}–{max(ratios):.2f} over {len(ratios)} scenes; "
                     f"1-min load average {', '.join(f'{x:.1f}' for x in doc['machine']['load_average_1min'])}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
