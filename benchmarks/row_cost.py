"""What a recorded row costs, as a function of model size.

    python benchmarks/row_cost.py [--repeats 3] [--steps 400]

The spin-up beam (``examples/spinup.yaml``: its probes, a tip deflection and the total
energy) meshed into n elements, as its planar model and in 3D (``planar: off``), is run with a
results folder in three ways, in process, the steps the same:

- ``rows``: a row every step (probes.csv, state.h5), no ParaView;
- ``rows+paraview``: a row every step and the ParaView frames at the default
  ``output.paraview_every``;
- ``end``: one row at the end (the steps alone, and the run's fixed costs).

The cost of a row is (wall − wall of ``end``) / (rows − 1), in µs; of a ParaView frame, the
difference of the first two divided by the frames written. ``wall`` is ``summary.json``
``wall_time_s`` (scene preparation, steps, output; no imports, no kernel compilation), the
median of interleaved repeats. Results: ``benchmarks/results/row_cost.json`` and a table on
stdout. The 1-minute load average is recorded: read the times with it.
"""
from __future__ import annotations

import argparse
import copy
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import yaml

import latdyn
from latdyn.scene.loader import _yaml_loader

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks import peers  # noqa: E402  (machine(): the description every benchmark records)

OUT = ROOT / "benchmarks" / "results" / "row_cost.json"
ELEMENTS = (2, 8, 32, 128)
WAYS = ("end", "rows", "rows+paraview")


def scene(elements: int, planar: str, way: str, steps: int) -> dict:
    raw = yaml.load((ROOT / "examples" / "spinup.yaml").read_text(), Loader=_yaml_loader())
    dt = 0.005
    raw["beams"]["arm"]["elements"] = elements
    raw["solve"].update(t_end=steps * dt, dt=dt, planar=planar)
    output = raw.setdefault("output", {})
    output["every"] = steps * dt if way == "end" else dt
    if way != "rows+paraview":
        output["paraview_every"] = 0
    else:
        output.pop("paraview_every", None)
    return raw


def run_once(raw: dict) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        result = latdyn.run(copy.deepcopy(raw), Path(folder) / "out")
    s = result.summary
    return {"wall_s": s["wall_time_s"] - (s.get("compile_s") or 0.0), "solver_s": s["solver_s"],
            "rows": s["rows"], "frames": s.get("paraview_frames", 0) or 0}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args(argv)

    cases = [(n, planar) for planar in ("auto", "off") for n in ELEMENTS]
    for n, planar in cases:  # warm-up: kernels compiled and cached
        run_once(scene(n, planar, "rows+paraview", 4))
    runs = {(n, planar, way): [] for n, planar in cases for way in WAYS}
    load = [os.getloadavg()[0]]
    for _ in range(args.repeats):
        for n, planar in cases:
            for way in WAYS:
                runs[(n, planar, way)].append(run_once(scene(n, planar, way, args.steps)))
        load.append(os.getloadavg()[0])

    rows = []
    for n, planar in cases:
        med = {way: {k: statistics.median(r[k] for r in runs[(n, planar, way)]) for k in ("wall_s", "solver_s")}
               for way in WAYS}
        recorded = runs[(n, planar, "rows")][0]["rows"]
        frames = runs[(n, planar, "rows+paraview")][0]["frames"]
        row_us = 1e6 * (med["rows"]["wall_s"] - med["end"]["wall_s"]) / max(recorded - 1, 1)
        frame_us = (1e6 * (med["rows+paraview"]["wall_s"] - med["rows"]["wall_s"]) / frames) if frames else None
        rows.append({"elements": n, "model": "planar" if planar == "auto" else "3D", "steps": args.steps,
                     "rows": recorded, "frames": frames, "row_us": row_us, "frame_us": frame_us,
                     "solver_us_per_step": 1e6 * med["rows"]["solver_s"] / args.steps,
                     "wall_s": {way: med[way]["wall_s"] for way in WAYS},
                     "wall_over_solver": med["rows+paraview"]["wall_s"] / med["rows+paraview"]["solver_s"]})
    doc = {"schema": "latdyn-row-cost/1", "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "repeats": args.repeats,
           "machine": dict(peers.machine(), load_average_1min=load),
           "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(markdown(doc))
    return 0


def markdown(doc: dict) -> str:
    lines = ["| model | elements | µs a step (solver) | µs a row | µs a ParaView frame | frames | "
             "wall ÷ solver (rows + ParaView) |", "|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        frame = "" if r["frame_us"] is None else f"{r['frame_us']:.0f}"
        lines.append(f"| {r['model']} | {r['elements']} | {r['solver_us_per_step']:.0f} | {r['row_us']:.0f} | "
                     f"{frame} | {r['frames']} | {r['wall_over_solver']:.2f} |")
    lines.append("")
    lines.append(f"{doc['rows'][0]['steps']} steps, a row every step; medians of {doc['repeats']} interleaved "
                 f"repeats; 1-min load average {', '.join(f'{x:.1f}' for x in doc['machine']['load_average_1min'])}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
