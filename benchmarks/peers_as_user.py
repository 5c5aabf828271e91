"""latdyn against Exudyn as a user runs each: a fresh process, a results folder, a row every step.

    python benchmarks/peers_as_user.py [--repeats 3] [--peer-python /tmp/peers/bin/python]
                                       [--problems spinup,cantilever,lattice]

``benchmarks/peers.py`` times the solvers in process at each code's best setting with no
results folder. A user does not run them that way; here every run is one fresh process, timed
from outside (imports, building, solving, writing results), the codes alternating in rounds,
medians of ``--repeats``:

Every timed process caches byte code as an installation does (``PYTHONDONTWRITEBYTECODE`` is
dropped from its environment). The Exudyn processes import neither latdyn nor OpenSeesPy
(``LATDYN_PEERS_EXUDYN_ONLY``); this script's own modules (the models of peers.py) and PyYAML
are the rest of what they import besides Exudyn and NumPy.

- latdyn: ``python -m latdyn run SCENE -o OUT -q`` with the package's defaults (ParaView frames,
  state.h5, probes.csv), ``output.every = dt`` (a row every step): ``process_s``. The same scene
  is also run in process, ``latdyn.run(latdyn.load_scene(SCENE), out_dir=OUT)`` in a fresh
  interpreter after ``import latdyn``: ``inprocess_first_s`` (its first call: kernels loaded from
  the cache) and ``inprocess_s`` (a second call in the same process);
- Exudyn 1.13.6: the model of ``peers.py`` (``benchmarks/lattice.py`` for the lattice) built and
  solved by a script, with Exudyn's own output defaults (the text solution file of coordinates,
  velocities and accelerations, and the sensor files) written every step (``writePeriod = dt``):
  ``process_s`` from outside, ``inprocess_s`` = building + solving inside the process (Exudyn
  imported before). ``--peer-python`` runs it with another interpreter (a venv of the peers'
  own, PEERS.md: ``python -m venv /tmp/peers && /tmp/peers/bin/pip install exudyn openseespy
  numpy pyyaml``); by default the one running this script, if it has Exudyn.
- ``--latdyn-python`` runs latdyn's processes with another interpreter likewise: a venv of latdyn's own
  dependencies (``python -m venv /tmp/latdyn-user && /tmp/latdyn-user/bin/pip install numpy h5py pyyaml
  scipy``; this checkout on its ``PYTHONPATH``), whose start is a user's installation's as the peer's venv
  is Exudyn's: a development interpreter's ``site`` may process ``.pth`` files a user's has not (an editable
  install's import hook, a sandbox's), 20-60 ms of a process here (docs/performance.md, "Ninth pass");
  by default the one running this script.

Problems and settings (matched accuracy as ``peers.py`` measures it, each code's own mesh):

- ``spinup``: Kane's spin-up, 20 s; latdyn 2 elements (planar model, the default), dt 0.01;
  Exudyn 16 two-dimensional geometrically exact beams, dt 0.01, modified Newton.
  Goal (issue 31): latdyn ≤ 0.5 × Exudyn.
- ``cantilever``: the right-angle cantilever, 30 s, dt 0.01; latdyn 8 elements a leg
  (``examples/benchmarks/D2_right_angle_cantilever.yaml``, its method); Exudyn 16 geometrically
  exact beams a leg, and its rigid-body–spring model (``peers.exudyn_cantilever_rbs_model``) of
  20 segments a leg, modified Newton. Goal: ≤ 1 × Exudyn's best model.
- ``lattice``: the 3D truss beam of ``benchmarks/lattice.py``, 16 bays (the nearest size with a
  reference history: ``benchmarks/references/lattice.json``), to 2 T; latdyn 1 element a
  member, dt T/70, ``formulation: cr4402``, modified Newton, tol 1e-6 (the matched setting of
  peers.py); Exudyn's rigid-body–spring model and its geometrically exact beam, 2 elements a
  member, dt T/70, modified Newton, absolute tolerance 1e-2 F0, relative 1e-5. Goal: in process
  ≤ 0.3 ×, ``latdyn run`` ≤ 0.4 × the best peer.

Every process is also timed in CPU (user + system of the child and what it started, ``getrusage``):
``process_cpu_s``, and latdyn ÷ the peer of least CPU (``ratio_process_cpu``, no goal of its own:
on a machine shared with other jobs CPU time is the steadier measure).

The error of each run is computed from what it wrote (probes.csv; Exudyn's sensor data) as
``peers.py`` does. Results: ``benchmarks/results/peers_as_user.json`` and a table on stdout.
The 1-minute load average is recorded with every round.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
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

#: Lattice size and the T-relative step of its settings.
LATTICE_BAYS = 16
LATTICE_STEPS_PER_T = 70
_LATTICE_PEER = {"bays": LATTICE_BAYS, "elements": 2, "steps_per_T": LATTICE_STEPS_PER_T, "rho_inf": 0.8,
                 "modified": True, "atol_F0": 1e-2, "rtol": 1e-5}

SETTINGS = {
    "spinup": {"latdyn": {"elements": 2, "dt": 0.01, "t_end": 20.0},
               "exudyn": {"elements": 16, "dt": 0.01, "t_end": 20.0, "rho_inf": 0.8, "modified": True,
                          "atol": 1e-6}},
    "cantilever": {"latdyn": {"elements": 16, "dt": 0.01, "t_end": 30.0},
                   "exudyn": {"elements": 32, "dt": 0.01, "t_end": 30.0, "rho_inf": 0.8, "modified": True,
                              "atol": 1e-6},
                   "exudyn_rbs": {"elements": 40, "dt": 0.01, "t_end": 30.0, "rho_inf": 0.8, "modified": True,
                                  "atol": 1e-6, "model": "rbs"}},
    "lattice": {"latdyn": {"bays": LATTICE_BAYS, "elements": 1, "steps_per_T": LATTICE_STEPS_PER_T,
                           "formulation": "cr4402", "newton": "modified", "tol": 1e-6},
                "exudyn_rbs": dict(_LATTICE_PEER, model="rbs"),
                "exudyn": dict(_LATTICE_PEER, model="beam")},
}
#: Issue 31's goals: latdyn ÷ the best peer, by process_s ("process") and inprocess_s ("inprocess").
GOALS = {"spinup": {"process": 0.5, "inprocess": 0.5}, "cantilever": {"process": 1.0, "inprocess": 1.0},
         "lattice": {"process": 0.4, "inprocess": 0.3}}
ENGINES = {"latdyn": "latdyn", "exudyn": "ObjectBeamGeometricallyExact", "exudyn_rbs": "RigidBody+RigidBodySpringDamper"}


def _lattice():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import lattice

    return lattice


def child_environment(**extra) -> dict:
    """The environment of a timed process: this one's, this checkout first on the path, and Python caches byte code as a user's
    installation has it (``PYTHONDONTWRITEBYTECODE`` would compile every module of the checkout,
    and this script, in every process: 0.1-0.2 s of CPU)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    path = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    return {**env, "PYTHONPATH": path, **extra}  # this checkout's latdyn, whatever is installed


def latdyn_scene(problem: str, cfg: dict) -> dict:
    """The scene a user writes: the shipped file (or the lattice's), the mesh and step changed,
    a row every step, the output's defaults otherwise."""
    if problem == "lattice":
        lattice = _lattice()
        dt = lattice.equivalent_beam(cfg["bays"])["T"] / cfg["steps_per_T"]
        s = lattice.latdyn_scene(cfg["bays"], cfg["elements"], dt, formulation=cfg["formulation"],
                                 newton=cfg["newton"], tol=cfg["tol"])
        s["output"].pop("paraview_every", None)  # the default, as for the other problems
        return s
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
    """``latdyn run`` in a fresh process, then the same scene in process in another one."""
    cfg = SETTINGS[problem]["latdyn"]
    scene = folder / f"{problem}.yaml"
    scene.write_text(yaml.safe_dump(latdyn_scene(problem, cfg), sort_keys=False))
    out = folder / f"{problem}_results"
    before, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    done = subprocess.run([LATDYN_PYTHON[0], "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          capture_output=True, text=True, cwd=folder, env=child_environment())
    wall, cpu = time.perf_counter() - t0, _cpu_since(before)
    if done.returncode != 0:
        return {"status": "failed", "note": done.stderr.strip().splitlines()[-1:], "process_s": wall}
    summary = json.loads((out / "summary.json").read_text())
    table = np.genfromtxt(out / "probes.csv", delimiter=",", names=True)
    row = {"status": "ok", "process_s": wall, "process_cpu_s": cpu, "wall_time_s": summary["wall_time_s"],
           "solver_s": summary["solver_s"],
           "compile_s": summary.get("compile_s"), "rows": summary["rows"],
           "paraview_frames": summary.get("paraview_frames"), "newton": summary.get("newton"),
           "steps": summary["steps"], "newton_iterations": summary["newton_iterations"],
           "factorizations": summary.get("factorizations"), "coordinates": summary.get("coordinates"),
           "compiled_anything": "compiling" in done.stderr}
    row["error"] = error(problem, table["t"], table)
    inner = subprocess.run([LATDYN_PYTHON[0], str(Path(__file__).resolve()), "--latdyn-inprocess", str(scene),
                            str(folder / "inprocess")], capture_output=True, text=True, cwd=folder,
                           env=child_environment())
    if inner.returncode == 0:
        row.update(json.loads(inner.stdout.strip().splitlines()[-1]))
    else:
        row["inprocess_note"] = inner.stderr.strip().splitlines()[-1:]
    return row


#: The interpreter of latdyn's processes (``--latdyn-python``; this one by default).
LATDYN_PYTHON = [sys.executable]


def _cpu_since(before) -> float:
    """CPU seconds (user + system) of the child processes that ended since ``before`` (getrusage)."""
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def latdyn_inprocess(scene: str, out: str) -> int:
    """In a fresh process: ``import latdyn``, then two whole calls of the scene with a results folder."""
    import latdyn

    times = []
    for k in range(2):
        t0 = time.perf_counter()
        latdyn.run(latdyn.load_scene(scene), out_dir=f"{out}{k}")
        times.append(time.perf_counter() - t0)
    print(json.dumps({"inprocess_first_s": times[0], "inprocess_s": times[1]}))
    return 0


def error(problem: str, t, table) -> float:
    from benchmarks import peers

    if problem == "lattice":
        lattice = _lattice()
        u = np.mean([np.asarray(table[f"u{k}"], float) for k in range(4)], axis=0)
        return lattice.error(LATTICE_BAYS, np.asarray(t, float), u)[0]
    window = t <= 10.0 + 1e-9  # the references of peers.py are over the first 10 s
    if problem == "spinup":
        return peers.spinup_error(t[window], table["tip_v"][window])[0]
    values = peers.cantilever_values(t[window], table["tip"][window], table["elbow"][window])
    return peers.cantilever_error(values)[0]


def exudyn_one(problem: str, code: str, folder: str) -> int:
    """In a fresh process: build and solve the Exudyn model with its output defaults."""
    os.chdir(folder)
    from benchmarks import peers

    peers._quiet_exudyn()
    cfg = dict(SETTINGS[problem][code])
    t0 = time.perf_counter()
    if problem == "lattice":
        lattice = _lattice()
        eq = lattice.equivalent_beam(cfg["bays"])
        cfg.update(dt=eq["T"] / cfg["steps_per_T"], atol=cfg.pop("atol_F0") * eq["F0"])
        SC, mbs, tips = lattice.exudyn_model(peers.exu, peers.eii, cfg["bays"], cfg["elements"], cfg["model"])
        sensors = dict(enumerate(tips))
        ss = lattice.exudyn_settings(peers.exu, cfg["bays"], cfg)
    else:
        if problem == "spinup":
            SC, mbs, sensors = peers.exudyn_spinup_model(cfg["elements"])
        elif cfg.get("model") == "rbs":
            SC, mbs, sensors = peers.exudyn_cantilever_rbs_model(cfg["elements"])
        else:
            SC, mbs, sensors = peers.exudyn_cantilever_model(cfg["elements"])
        ss = peers._settings(cfg, cfg["dt"])
    for number in sensors.values():  # as a user leaves them: written to files too
        mbs.SetSensorParameter(number, "writeToFile", True)
        mbs.SetSensorParameter(number, "fileName", f"solution/sensor{number}.txt")
    ss.solution.file.write = True  # Exudyn's default, which peers.py turns off
    ss.solution.file.writePeriod = cfg["dt"]
    ss.solution.sensors.writePeriod = cfg["dt"]
    solver = peers.exu.MainSolverImplicitSecondOrder()
    ok = solver.SolveSystem(mbs, ss)
    inprocess = time.perf_counter() - t0
    if problem == "lattice":
        data = [mbs.GetSensorStoredData(s) for s in sensors.values()]
        t = data[0][:, 0]
        table = {f"u{k}": d[:, 3] for k, d in enumerate(data)}
    else:
        data = mbs.GetSensorStoredData(sensors["tip"])
        t = data[:, 0]
        if problem == "spinup":
            th = np.array([peers._hub_angle(x) for x in t])
            table = {"tip_v": -np.sin(th) * data[:, 1] + np.cos(th) * data[:, 2]}
        else:
            table = {"tip": data[:, 3], "elbow": mbs.GetSensorStoredData(sensors["elbow"])[:, 3]}
    # the error is computed by the caller (the reference's spline needs SciPy, which a peers' venv may lack)
    Path("peer_table.json").write_text(json.dumps({"t": np.asarray(t).tolist(),
                                                   **{k: np.asarray(v).tolist() for k, v in table.items()}}))
    print(json.dumps({"ok": bool(ok), "inprocess_s": inprocess,
                      "steps": int(solver.it.currentStepIndex), "newton_iterations": int(solver.it.newtonStepsCount),
                      "jacobian_updates": int(solver.it.newtonJacobiCount),
                      "coordinates": int(mbs.systemData.ODE2Size()),
                      "files_bytes": sum(p.stat().st_size for p in Path("solution").glob("*"))}))
    return 0 if ok else 1


def exudyn_process(problem: str, code: str, folder: Path, python: str) -> dict:
    before, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    done = subprocess.run([python, str(Path(__file__).resolve()), "--exudyn-one", problem, code, str(folder)],
                          capture_output=True, text=True, env=child_environment(LATDYN_PEERS_EXUDYN_ONLY="1"))
    wall, cpu = time.perf_counter() - t0, _cpu_since(before)
    if done.returncode != 0:
        return {"status": "failed", "note": (done.stderr or done.stdout).strip().splitlines()[-1:], "process_s": wall}
    info = json.loads(done.stdout.strip().splitlines()[-1])
    table = {k: np.asarray(v) for k, v in json.loads((folder / "peer_table.json").read_text()).items()}
    info["error"] = error(problem, table["t"], table)
    return {"status": "ok", "process_s": wall, "process_cpu_s": cpu, **{k: info[k] for k in ("error", "inprocess_s", "steps", "newton_iterations",
                                                                       "jacobian_updates", "coordinates", "files_bytes")}}


def peer_python(requested: str | None) -> str | None:
    """The interpreter that has Exudyn: ``--peer-python``, else this one if it has it; None."""
    for python in ([requested] if requested else [sys.executable]):
        done = subprocess.run([python, "-c", "import exudyn; print(exudyn.__version__)"], capture_output=True, text=True)
        if done.returncode == 0:
            return python
        if requested:
            raise SystemExit(f"peers_as_user.py: {python} cannot import exudyn: {done.stderr.strip()[-300:]}")
    return None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--problems", default=",".join(SETTINGS), help="comma-separated subset of %(default)s")
    parser.add_argument("--peer-python", metavar="PYTHON", help="the interpreter with Exudyn (a venv of its own)")
    parser.add_argument("--latdyn-python", metavar="PYTHON",
                        help="the interpreter of latdyn's processes (a venv of its own dependencies; default: this one)")
    parser.add_argument("--exudyn-one", nargs=3, metavar=("PROBLEM", "CODE", "FOLDER"), help=argparse.SUPPRESS)
    parser.add_argument("--latdyn-inprocess", nargs=2, metavar=("SCENE", "OUT"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.exudyn_one:
        return exudyn_one(*args.exudyn_one)
    if args.latdyn_inprocess:
        return latdyn_inprocess(*args.latdyn_inprocess)
    from benchmarks import peers

    if args.latdyn_python:
        LATDYN_PYTHON[0] = args.latdyn_python
    problems = [p.strip() for p in args.problems.split(",") if p.strip()]
    python = peer_python(args.peer_python)
    if python is None:
        print("NOTE: Exudyn is not installed (pip install exudyn, or --peer-python): latdyn rows only", file=sys.stderr)
    exudyn_version = None if python is None else subprocess.run(
        [python, "-c", "import exudyn; print(exudyn.__version__)"], capture_output=True, text=True).stdout.strip()
    plan = [(p, c) for p in problems for c in SETTINGS[p] if c == "latdyn" or python is not None]
    runs = {key: [] for key in plan}
    load = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory() as tmp:
        for problem in problems:  # warm-up: kernels compiled and cached (not timed)
            latdyn_process(problem, Path(tmp))
        for _ in range(args.repeats):
            for problem, code in plan:
                folder = Path(tempfile.mkdtemp(dir=tmp))
                run = latdyn_process(problem, folder) if code == "latdyn" else \
                    exudyn_process(problem, code, folder, python)
                runs[(problem, code)].append(run)
                print(f"  {problem} {code}: {run.get('status')} {run.get('process_s', float('nan')):.3f} s",
                      file=sys.stderr, flush=True)
            load.append(os.getloadavg()[0])
    rows = [summarize(problem, runs) for problem in problems]
    doc = {"schema": "latdyn-peers-as-user/2", "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
           "repeats": args.repeats, "peer_python": python, "latdyn_python": LATDYN_PYTHON[0], "exudyn": exudyn_version,
           "machine": dict(peers.machine(), load_average_1min=load), "goals": GOALS, "rows": rows}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1, default=float) + "\n")
    print(markdown(doc))
    return 0


def summarize(problem: str, runs: dict) -> dict:
    """One problem's row: each code's medians, and latdyn ÷ the fastest peer that succeeded."""
    row = {"problem": problem}
    for (p, code), results in runs.items():
        if p != problem:
            continue
        done = [r for r in results if r["status"] == "ok"]
        if not done:
            row[code] = results[-1]
            continue
        row[code] = dict(done[-1], settings=SETTINGS[problem][code], engine=ENGINES[code])
        for key in ("process_s", "process_cpu_s", "inprocess_s", "inprocess_first_s", "wall_time_s", "solver_s"):
            values = [r[key] for r in done if r.get(key) is not None]
            if values:
                row[code][key] = statistics.median(values)
                row[code][key + "_all"] = values
    latdyn = row.get("latdyn", {})
    peers_ok = [c for c in SETTINGS[problem] if c != "latdyn" and row.get(c, {}).get("status") == "ok"]
    if latdyn.get("status") == "ok" and peers_ok:
        for measure, key in (("process", "process_s"), ("inprocess", "inprocess_s"), ("process_cpu", "process_cpu_s")):
            if measure not in GOALS[problem]:  # CPU: the ratio against the peer fastest in CPU, no goal of its own
                best = min(peers_ok, key=lambda c: row[c][key])
                row[f"ratio_{measure}"] = latdyn[key] / row[best][key]
                row[f"best_peer_{measure}"] = best
                continue
            best = min(peers_ok, key=lambda c: row[c][key])
            row[f"ratio_{measure}"] = latdyn[key] / row[best][key]
            row[f"best_peer_{measure}"] = best
            row[f"goal_{measure}"] = GOALS[problem][measure]
            row[f"met_{measure}"] = row[f"ratio_{measure}"] <= GOALS[problem][measure]
    return row


def markdown(doc: dict) -> str:
    lines = ["| problem | code | model | process s | process CPU s | in process s | error | latdyn ÷ best peer, "
             "process (goal) | in process (goal) | process CPU |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        for code in SETTINGS[r["problem"]]:
            x = r.get(code)
            if x is None:
                continue
            ok = x.get("status") == "ok"
            proc = f"{x['process_s']:.2f}" if ok else x.get("status", "-")
            cpu = f"{x['process_cpu_s']:.2f}" if ok and x.get("process_cpu_s") is not None else "-"
            inner = f"{x['inprocess_s']:.2f}" if ok and x.get("inprocess_s") is not None else "-"
            extra = ["", "", ""]
            if code == "latdyn":
                if "ratio_process_cpu" in r:
                    extra[2] = f"{r['ratio_process_cpu']:.2f} vs {r['best_peer_process_cpu']}"
                for k, measure in enumerate(("process", "inprocess")):
                    if f"ratio_{measure}" in r:
                        extra[k] = (f"**{r[f'ratio_{measure}']:.2f}** vs {r[f'best_peer_{measure}']} "
                                    f"(≤ {r[f'goal_{measure}']}: {'met' if r[f'met_{measure}'] else 'not met'})")
            lines.append(f"| {r['problem']} | {code} | {ENGINES[code]} | {proc} | {cpu} | {inner} | "
                         f"{x.get('error', float('nan')):.2g} | {extra[0]} | {extra[1]} | {extra[2]} |")
    lines.append("")
    lines.append(f"fresh processes, medians of {doc['repeats']}; latdyn with {doc.get('latdyn_python')}, "
                 f"peers with {doc.get('peer_python')} "
                 f"(Exudyn {doc.get('exudyn')}); 1-min load average "
                 f"{', '.join(f'{x:.1f}' for x in doc['machine']['load_average_1min'])}")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
