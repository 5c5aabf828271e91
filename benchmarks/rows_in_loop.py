"""What a recorded row costs with the rows recorded where the step runs, against another tree (main).

    python benchmarks/rows_in_loop.py drive --trees branch=.,main=../main [--repeats 5] [--out FILE]

For each tree (its checkout first on ``PYTHONPATH``, one fresh process a measurement, the trees
interleaved repeat by repeat):

- **rows**: the shipped spin-up (``examples/spinup.yaml``, 8 elements, 4000 steps) and a 3D beam driven
  by a hub about a tilted axis under gravity, with point probes in global and hub axes, every
  energy, momenta and section forces (:func:`beam`), at 8, 48 and 200 elements (200 steps), each run in
  process twice after a warm-up: a row every step, and rows at t = 0 and t_end only, the user's other
  defaults (ParaView frames at the default ``paraview_every``). The rows' cost is the difference of
  ``summary.json`` ``wall_time_s`` (scene preparation, steps, output; no imports, no compilation), per
  row and against ``solver_s`` (the goal of issue 31: rows ≤ 5 % of the solver time + 0.1 s);
- **fresh**: ``python -m latdyn run examples/spinup.yaml -o OUT`` as a user runs it (its ``every``),
  wall time of the whole process, kernels cached.

Medians of the repeats; the 1-minute load average before and after. JSON to ``--out`` and a table on
stdout.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BEAM_ELEMENTS = (8, 48, 200)


def beam(elements: int, steps: int = 200, dt: float = 0.005) -> dict:
    """The 3D beam of the table: 10 m, driven by a hub turning 0.5 t² about [0, 1, 1], gravity along −z."""
    probes = {
        "tip_x": {"point": "arm.end", "quantity": "position", "component": "x"},
        "tip_dz": {"point": "arm.end", "quantity": "displacement", "component": "z"},
        "tip_vy": {"point": "arm.end", "quantity": "velocity", "component": "y"},
        "tip_vh": {"point": "arm.end", "quantity": "velocity", "frame": "hub", "component": "norm"},
        **{name: {"energy": name} for name in ("kinetic", "strain", "potential", "external_work", "total")},
        "N0": {"element": "arm.element[0]", "quantity": "axial_force"},
        "M0": {"element": "arm.element[0]", "quantity": "moment_y"},
        "T0": {"element": "arm.element[0]", "quantity": "torque"},
        "Px": {"momentum": "linear", "component": "x"},
        "Hz": {"momentum": "angular", "component": "z"},
    }
    return {"title": "3D beam rows", "gravity": [0, 0, -9.81],
            "sections": {"arm": {"EA": 2.8e7, "EIy": 1.4e4, "EIz": 1.0e4, "GJ": 1.0e4, "rhoA": 1.2}},
            "bodies": {"hub": {"at": [0, 0, 0], "motion": {"rotation": {"axis": [0, 1, 1], "angle": "0.5*t**2"}}}},
            "beams": {"arm": {"from": "hub", "to": [10, 0, 0], "section": "arm", "elements": elements}},
            "solve": {"analysis": "transient", "t_end": steps * dt, "dt": dt}, "output": {"probes": probes}}


def measure(case: str) -> dict:
    """In this process (this tree's latdyn): the case's run with a row every step and with rows at the
    ends only, after a warm-up."""
    import latdyn  # noqa: PLC0415 - the tree on PYTHONPATH

    if case == "spinup":
        import yaml  # noqa: PLC0415

        raw = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
    else:
        raw = beam(int(case.split("-")[1]))
    every = json.loads(json.dumps(raw))
    every["output"].pop("every", None)
    ends = json.loads(json.dumps(raw))
    ends["output"]["every"] = raw["solve"]["t_end"]
    out = {}
    with tempfile.TemporaryDirectory() as folder:
        latdyn.run(latdyn.load_scene(json.loads(json.dumps(every))), Path(folder) / "warm")
        for name, scene in (("rows", every), ("ends", ends)):
            s = latdyn.run(latdyn.load_scene(scene), Path(folder) / name).summary
            out[name] = {"wall_s": s["wall_time_s"] - (s.get("compile_s") or 0.0), "solver_s": s["solver_s"],
                         "rows": s["rows"], "steps": s["steps"], "time_loop": s.get("time_loop")}
    return out


def fresh(tree: Path, cache: str) -> float:
    with tempfile.TemporaryDirectory() as folder:
        started = time.perf_counter()
        subprocess.run([sys.executable, "-m", "latdyn", "run", str(ROOT / "examples" / "spinup.yaml"), "-o",
                        str(Path(folder) / "out"), "-q"], env=_env(tree, cache), check=True, capture_output=True,
                       cwd=folder)  # not the caller's folder, which `-m` would put first on sys.path
        return time.perf_counter() - started


#: paths after each tree's on PYTHONPATH (``--also``: where a tree without them finds codegen and
#: latdyn_generated)
ALSO: list[str] = []
#: ``--fresh-only``: the fresh processes alone
FRESH_ONLY = False


def _env(tree: Path, cache: str) -> dict:
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(tree), *ALSO]), LATDYN_CACHE_DIR=cache,
                OMP_NUM_THREADS="1")


def drive(trees: dict[str, Path], repeats: int, out: Path | None) -> dict:
    cache = os.environ.get("LATDYN_CACHE_DIR") or tempfile.mkdtemp(prefix="latdyn-cache-")
    cases = ["spinup", *(f"beam-{n}" for n in BEAM_ELEMENTS)] if not FRESH_ONLY else []
    runs = {(tree, case): [] for tree in trees for case in cases}
    fresh_s = {tree: [] for tree in trees}
    for tree, path in trees.items():  # warm-up: every kernel compiled into the cache
        fresh(path, cache)
    load = [os.getloadavg()[0]]
    for _ in range(repeats):
        for case in cases:
            for tree, path in trees.items():
                done = subprocess.run([sys.executable, str(Path(__file__).resolve()), "measure", case],
                                      env=_env(path, cache), check=True, capture_output=True, text=True)
                runs[(tree, case)].append(json.loads(done.stdout.strip().splitlines()[-1]))
        for tree, path in trees.items():
            fresh_s[tree].append(fresh(path, cache))
        load.append(os.getloadavg()[0])
        doc = summarize(trees, cases, runs, fresh_s, load)
        if out is not None:  # after every repeat: a run cut short keeps what it measured
            out.parent.mkdir(parents=True, exist_ok=True)
            out.write_text(json.dumps(doc, indent=1) + "\n")
    print(markdown(doc))
    return doc


def summarize(trees, cases, runs, fresh_s, load) -> dict:
    table = []
    for case in cases:
        for tree in trees:
            r = runs[(tree, case)]
            med = {way: {k: statistics.median(x[way][k] for x in r) for k in ("wall_s", "solver_s")}
                   for way in ("rows", "ends")}
            rows = r[0]["rows"]["rows"]
            cost = med["rows"]["wall_s"] - med["ends"]["wall_s"]
            table.append({"case": case, "tree": tree, "steps": r[0]["rows"]["steps"], "rows": rows,
                          "time_loop": r[0]["rows"]["time_loop"], "wall_rows_s": med["rows"]["wall_s"],
                          "wall_ends_s": med["ends"]["wall_s"], "solver_s": med["rows"]["solver_s"],
                          "rows_s": cost, "row_us": 1e6 * cost / max(rows - 2, 1),
                          "goal_s": 0.05 * med["rows"]["solver_s"] + 0.1})
    return {"created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "repeats": len(load) - 1, "cpus": os.cpu_count(),
            "load_average_1min": load, "rows": table,
            "fresh_spinup_s": {tree: statistics.median(v) for tree, v in fresh_s.items()},
            "fresh_spinup_all_s": fresh_s}


def markdown(doc: dict) -> str:
    lines = ["| case | tree | steps | rows | solver s | wall, a row every step s | wall, rows at the ends s | "
             "rows s | µs a row | goal s |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        lines.append(f"| {r['case']} | {r['tree']} | {r['steps']} | {r['rows']} | {r['solver_s']:.3f} | "
                     f"{r['wall_rows_s']:.3f} | {r['wall_ends_s']:.3f} | {r['rows_s']:.3f} | {r['row_us']:.0f} | "
                     f"{r['goal_s']:.3f} |")
    lines.append("")
    lines.append("fresh `latdyn run examples/spinup.yaml`: " + ", ".join(
        f"{tree} {s:.3f} s" for tree, s in doc["fresh_spinup_s"].items()))
    lines.append(f"medians of {doc['repeats']} interleaved repeats; {doc['cpus']} CPUs; 1-min load "
                 + ", ".join(f"{x:.1f}" for x in doc["load_average_1min"]))
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    m = sub.add_parser("measure")
    m.add_argument("case")
    d = sub.add_parser("drive")
    d.add_argument("--trees", default=f"branch={ROOT}")
    d.add_argument("--repeats", type=int, default=5)
    d.add_argument("--out", type=Path)
    d.add_argument("--fresh-only", action="store_true")
    d.add_argument("--also", default="", help="paths after each tree's on PYTHONPATH, separated by ','")
    args = parser.parse_args(argv)
    if args.command == "measure":
        print(json.dumps(measure(args.case)))
        return 0
    global FRESH_ONLY
    FRESH_ONLY = args.fresh_only
    ALSO.extend(str(Path(p).resolve()) for p in args.also.split(",") if p)
    trees = {name: Path(path).resolve() for name, path in (item.split("=") for item in args.trees.split(","))}
    drive(trees, args.repeats, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
