"""latdyn against Exudyn as a user runs each: a fresh process, a results folder, a row every step.

    python benchmarks/peers_as_user.py [--repeats 3]

``benchmarks/peers.py`` times the solvers in process at each code's best setting with no
results folder. A user does not run them that way; here each run is one fresh process, timed
from outside (imports, building, solving, writing results), the codes alternating in rounds,
medians of ``--repeats``:

- latdyn: ``latdyn run SCENE -o OUT`` with the package's defaults (ParaView frames, state.h5,
  probes.csv), ``output.every = dt`` (a row every step);
- Exudyn 1.13.6: the model of ``peers.py`` built and solved by a script, with Exudyn's own
  output defaults (the text solution file of coordinates, velocities and accelerations, and
  the sensor files) written every step (``writePeriod = dt``).

Problems and settings (the issue's table, matched accuracy as ``peers.py`` measures it):

- ``spinup``: Kane's spin-up, 20 s; latdyn 2 elements (planar model, the default), dt 0.01;
  Exudyn 16 two-dimensional geometrically exact beams, dt 0.01, modified Newton.
- ``cantilever``: the right-angle cantilever, 30 s, dt 0.01; latdyn 8 elements a leg
  (``examples/benchmarks/D2_right_angle_cantilever.yaml``, its method); Exudyn 16
  geometrically exact beams a leg, modified Newton.

The error of each run is computed from what it wrote (probes.csv; Exudyn's sensor data) as
``peers.py`` does. Results: ``benchmarks/results/peers_as_user.json`` and a table on stdout.
The 1-minute load average is recorded with every round.
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

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
OUT = ROOT / "benchmarks" / "results" / "peers_as_user.json"

SETTINGS = {
    "spinup": {"latdyn": {"elements": 2, "dt": 0.01, "t_end": 20.0},
               "exudyn": {"elements": 16, "dt": 0.01, "t_end": 20.0, "rho_inf": 0.8, "modified": True,
                          "atol": 1e-6}},
    "cantilever": {"latdyn": {"elements": 16, "dt": 0.01, "t_end": 30.0},
                   "exudyn": {"elements": 32, "dt": 0.01, "t_end": 30.0, "rho_inf": 0.8, "modified": True,
                              "atol": 1e-6}},
}


def latdyn_scene(problem: str, cfg: dict) -> dict:
    """The scene a user writes: the shipped file, the mesh and step changed, a row every step."""
    if problem == "spinup":
        s = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
        s["beams"]["arm"]["elements"] = cfg["elements"]
        probes = {"tip_v": {"point": "arm.end", "quantity": "position", "frame": "hub", "component": "y"}}
    else:
        s = yaml.safe_load((ROOT / "examples" / "benchmarks" / "D2_right_angle_cantilever.yaml").read_text())
        s["beams"]["leg1"]["elements"] = s["beams"]["leg2"]["elements"] = cfg["elements"] // 2
        probes = {"tip": {"point": "leg2.end", "quantity": "displacement", "frame": "global", "component": "z"},
                  "elbow": {"point": "elbow", "quantity": "displacement", "frame": "global", "component": "z"}}
    s["solve"].update(t_end=cfg["t_end"], dt=cfg["dt"])
    s["output"] = {"every": cfg["dt"], "probes": probes}
    return s


def latdyn_process(problem: str, folder: Path) -> dict:
    cfg = SETTINGS[problem]["latdyn"]
    scene = folder / f"{problem}.yaml"
    scene.write_text(yaml.safe_dump(latdyn_scene(problem, cfg), sort_keys=False))
    out = folder / f"{problem}_results"
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          capture_output=True, text=True, cwd=folder)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        return {"status": "failed", "note": done.stderr.strip().splitlines()[-1:], "process_s": wall}
    summary = json.loads((out / "summary.json").read_text())
    table = np.genfromtxt(out / "probes.csv", delimiter=",", names=True)
    row = {"status": "ok", "process_s": wall, "wall_time_s": summary["wall_time_s"], "solver_s": summary["solver_s"],
           "compile_s": summary.get("compile_s"), "rows": summary["rows"],
           "paraview_frames": summary.get("paraview_frames"), "newton": summary.get("newton"),
           "steps": summary["steps"], "newton_iterations": summary["newton_iterations"],
           "compiled_anything": "compiling" in done.stderr}
    row["error"] = error(problem, table["t"], table)
    return row


def error(problem: str, t, table) -> float:
    from benchmarks import peers

    window = t <= 10.0 + 1e-9  # the references of peers.py are over the first 10 s
    if problem == "spinup":
        return peers.spinup_error(t[window], table["tip_v"][window])[0]
    values = peers.cantilever_values(t[window], table["tip"][window], table["elbow"][window])
    return peers.cantilever_error(values)[0]


def exudyn_one(problem: str, folder: str) -> int:
    """In a fresh process: build and solve the Exudyn model with its output defaults."""
    os.chdir(folder)
    from benchmarks import peers

    cfg = dict(SETTINGS[problem]["exudyn"])
    if problem == "spinup":
        SC, mbs, sensors = peers.exudyn_spinup_model(cfg["elements"])
    else:
        SC, mbs, sensors = peers.exudyn_cantilever_model(cfg["elements"])
    for number in sensors.values():  # as a user leaves them: written to files too
        mbs.SetSensorParameter(number, "writeToFile", True)
        mbs.SetSensorParameter(number, "fileName", f"solution/sensor{number}.txt")
    ss = peers._settings(cfg, cfg["dt"])
    ss.solution.file.write = True  # Exudyn's default, which peers.py turns off
    ss.solution.file.writePeriod = cfg["dt"]
    solver = peers.exu.MainSolverImplicitSecondOrder()
    ok = solver.SolveSystem(mbs, ss)
    data = mbs.GetSensorStoredData(sensors["tip"])
    t = data[:, 0]
    if problem == "spinup":
        th = np.array([peers._hub_angle(x) for x in t])
        table = {"tip_v": -np.sin(th) * data[:, 1] + np.cos(th) * data[:, 2]}
    else:
        table = {"tip": data[:, 3], "elbow": mbs.GetSensorStoredData(sensors["elbow"])[:, 3]}
    print(json.dumps({"ok": bool(ok), "error": error(problem, t, table),
                      "steps": int(solver.it.currentStepIndex), "newton_iterations": int(solver.it.newtonStepsCount),
                      "files_bytes": sum(p.stat().st_size for p in Path("solution").glob("*"))}))
    return 0 if ok else 1


def exudyn_process(problem: str, folder: Path) -> dict:
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--exudyn-one", problem, str(folder)],
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        return {"status": "failed", "note": (done.stderr or done.stdout).strip().splitlines()[-1:], "process_s": wall}
    info = json.loads(done.stdout.strip().splitlines()[-1])
    return {"status": "ok", "process_s": wall, **{k: info[k] for k in ("error", "steps", "newton_iterations",
                                                                       "files_bytes")}}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--exudyn-one", nargs=2, metavar=("PROBLEM", "FOLDER"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.exudyn_one:
        return exudyn_one(*args.exudyn_one)
    from benchmarks import peers
    try:
        import exudyn  # noqa: F401
        codes = ("latdyn", "exudyn")
    except ImportError:
        print("NOTE: Exudyn is not installed (pip install exudyn): latdyn rows only", file=sys.stderr)
        codes = ("latdyn",)
    runs = {(p, c): [] for p in SETTINGS for c in codes}
    load = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory() as tmp:
        for problem in SETTINGS:  # warm-up: kernels compiled and cached (not timed)
            latdyn_process(problem, Path(tmp))
        for _ in range(args.repeats):
            for problem in SETTINGS:
                for code in codes:
                    folder = Path(tempfile.mkdtemp(dir=tmp))
                    run = latdyn_process if code == "latdyn" else exudyn_process
                    runs[(problem, code)].append(run(problem, folder))
            load.append(os.getloadavg()[0])
    rows = []
    for problem in SETTINGS:
        row = {"problem": problem}
        for code in codes:
            done = [r for r in runs[(problem, code)] if r["status"] == "ok"]
            if not done:
                row[code] = runs[(problem, code)][-1]
                continue
            row[code] = dict(done[-1], settings=SETTINGS[problem][code],
                             process_s=statistics.median(r["process_s"] for r in done),
                             process_s_all=[r["process_s"] for r in done])
            if code == "latdyn":
                for key in ("wall_time_s", "solver_s"):
                    row[code][key] = statistics.median(r[key] for r in done)
        if all(row.get(c, {}).get("status") == "ok" for c in ("latdyn", "exudyn")):
            row["ratio"] = row["latdyn"]["process_s"] / row["exudyn"]["process_s"]
        rows.append(row)
    doc = {"schema": "latdyn-peers-as-user/1", "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
           "repeats": args.repeats,
           "machine": dict(peers.machine(), load_average_1min=load),
           "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1, default=float) + "\n")
    print(markdown(doc))
    return 0


def markdown(doc: dict) -> str:
    lines = ["| problem | latdyn process s (wall_time_s / solver_s) | latdyn error | Exudyn process s | "
             "Exudyn error | ratio |", "|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        L, E = r.get("latdyn", {}), r.get("exudyn", {})
        lat = (f"{L['process_s']:.2f} ({L['wall_time_s']:.2f} / {L['solver_s']:.2f})" if L.get("status") == "ok"
               else L.get("status", "-"))
        exu = f"{E['process_s']:.2f}" if E.get("status") == "ok" else E.get("status", "-")
        ratio = f"{r['ratio']:.2f}" if "ratio" in r else "-"
        lines.append(f"| {r['problem']} | {lat} | {L.get('error', float('nan')):.2g} | {exu} | "
                     f"{E.get('error', float('nan')):.2g} | {ratio} |")
    lines.append("")
    lines.append(f"fresh processes, medians of {doc['repeats']}; 1-min load average "
                 f"{', '.join(f'{x:.1f}' for x in doc['machine']['load_average_1min'])}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
