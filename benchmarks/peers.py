"""latdyn against Exudyn and OpenSeesPy on the same machine, in one run: error and solver time per setting.

Run from the repository root::

    pip install -e ".[peers]"          # Exudyn and OpenSeesPy are an optional extra, never a requirement
    python benchmarks/peers.py          # full sweep (about half an hour on 2 cores, most of it the lattice)
    python benchmarks/peers.py --quick  # one or two settings per code, one repeat
    python benchmarks/peers.py --peer-python /tmp/peers/bin/python   # the peers from a venv of their own
    python benchmarks/peers.py --problems lattice --bays 4,16,64   # the lattice alone (other rows kept)
    python benchmarks/peers.py --reference --problems lattice --bays 4,16,64   # its reference histories

``--peer-python PYTHON`` runs Exudyn and OpenSeesPy with another interpreter (a venv of their
own, PEERS.md: ``python -m venv /tmp/peers && /tmp/peers/bin/pip install exudyn openseespy numpy
pyyaml``), so neither enters latdyn's environment: each peer run is that interpreter running this
file once (``--one``), timed inside it as in process; latdyn runs in this interpreter.
Without Exudyn (or OpenSeesPy) the script still runs and writes the other codes' rows, with a
note saying how to install it.  Results: ``benchmarks/results/peers.json`` and ``peers.csv`` (``--out``
changes the stem); ``docs/performance.md`` reads them.

Problems
--------
``spinup``      Kane, Ryan & Banerjee (1987) spin-up beam, ``examples/spinup.yaml`` (10 m,
                EA 2.8e7, EI 1.4e4, rhoA 1.2, prescribed hub angle), t_end = 10 s.  Error:
                max of |v(5) - v5_ref|, |v(10) - v10_ref|, |min v - vmin_ref| in metres, v the
                tip deflection in the hub frame (y), against the converged solution of issue 8
                (v(5 s) = -0.46843, v(10 s) = -0.36280, min -0.57379 m at 6.762 s).  Matched
                accuracy: error <= 1e-3 m.
``lattice``     A clamped 3D truss beam of N bays with rigid joints (``benchmarks/lattice.py``:
                square section 0.5 m, bays of 0.5 m, 4 longerons, 4 battens a station, a
                diagonal a face a bay, aluminium tubes, shear-deformable with rotary inertia),
                a sin² tip pulse along z of length T/2, free vibration to 2 T (T ≈ the first
                bending period), N in ``--bays`` (default 4, 16, 64).  Error: the largest
                deviation of the tip history (mean z of the 4 tip joints) from the converged
                reference history (``benchmarks/references/lattice.json``) over the peak.
                Matched accuracy: <= 1 %.  Codes: latdyn, Exudyn (geometrically exact beams
                welded at the joints; a rigid-body–spring model), OpenSeesPy
                (elasticBeamColumn + Corotational; Euler–Bernoulli members without rotary
                inertia, so also scored against a reference of that physics).  Each code's
                fastest setting within 1 % is searched (elements a member 1, 2, 4, … and
                steps per T 25 … 400, coarsest first; ``lattice_sweep``), then the
                candidates are timed ``repeats`` times.
``cantilever``  Simo & Vu-Quoc right-angle cantilever,
                ``examples/benchmarks/D2_right_angle_cantilever.yaml`` (two legs of 10, EA 1e6,
                EI = GJ = 1e3, rhoA 1, rotary inertia [20, 10, 10], out-of-plane triangular
                pulse at the elbow), t_end = 10 s (the sweep; the tip peak is at 7.4 s).
                Error: max of the relative errors of the tip's peak out-of-plane displacement
                (t <= 10 s) and of the elbow's first peak (t <= 6 s), each peak located by a
                parabola through the three recorded samples around the largest, against the
                converged values ``CANTILEVER_REF`` (see there).  Matched accuracy: <= 0.3 %.
                The published curves (digitized, 8.29 at 7.67 s for the tip) are reported
                beside, not used for the error: a digitized figure does not resolve 0.3 %.

Timing
------
Every setting is run ``repeats`` times (once when its first run takes more than
``LONG_RUN_S`` or fails) after one untimed warm-up run of each code and problem (C kernels
compiled and cached, imports done); the repeats are interleaved (pass 1 runs every
setting, then pass 2, ...), and ``solver_s`` is the median.
latdyn: ``summary.json`` ``solver_s`` of ``latdyn.run`` with no results folder (the wall
time inside the integrator's steps: no scene preparation, no probe recording), or, from a
runtime that does not report it, ``wall_time_s`` less ``compile_s``.  Exudyn:
``MainSolverImplicitSecondOrder.SolveSystem`` (solver initialisation + time loop + sensors),
the model built and assembled before.  ``run_s`` is the median of the whole call in Python
for both (``latdyn.run``: scene loading and preparation, steps, probes; Exudyn: building,
Assemble, solve) — the like-for-like "scene to results in memory" time.  ``process_s``
(full mode, headline settings): one fresh ``python`` process that imports the code, builds
and solves one setting, timed from outside.  The 1-minute load
average is recorded with every row: the machine is shared, read the times with it.

JSON schema (``peers.json``)
----------------------------
::

    {
      "schema": "latdyn-peers/1",
      "created": "2026-11-23T01:40:00+00:00",          # UTC
      "mode": "full" | "quick",
      "repeats": int,                                    # timed runs per setting (median)
      "machine": {"cpu": str, "cores": int, "platform": str, "python": str,
                  "numpy": str, "latdyn": str, "exudyn": str | null,
                  "git": {"head": str, "runtime_dirty": bool},  # latdyn/ generated/ codegen/ edited
                  "warm_up_s": {"problem/code": s},
                  "load_average_start": [1, 5, 15 min], "load_average_end": [...]},
      "notes": [str, ...],                               # e.g. Exudyn missing, engines seen
      "problems": {NAME: {"scene": path, "t_end": s, "reference": {...},
                          "error": str (definition), "error_unit": "m" | "relative",
                          "tolerance": float}},
      "rows": [{
          "problem": "spinup" | "cantilever" | "lattice",
          "code": "latdyn" | "exudyn" | "opensees",
          "engine": str,          # latdyn: "<kernel backend>/<step engine>" (summary.json
                                  # backend, engine); exudyn: element type
          "setting": str,         # label, unique per problem and code
          "elements": int,        # total beam elements
          "dt": float, "t_end": float,
          "method": str,          # integrator and its parameter, e.g. "generalized-alpha rho=0.8"
          "newton": str,          # "full" | "modified" (+ tolerance)
          "status": "ok" | "failed" | "error",
          "error": float | null,  # definition and unit in problems[NAME]
          "error_parts": {name: float},
          "values": {name: float},                # the measured quantities
          "steps": int | null,                    # steps taken (Exudyn: its step index at the end,
                                                  # nominal steps + 1 when no step was reduced)
          "step_cuts": int | null,                # latdyn: Newton failures that cut the step
          "newton_iterations": int | null,
          "jacobian_updates": int | null,         # Exudyn: Jacobian computations (modified Newton)
          "solver_s": float | null,               # median over repeats
          "solver_s_all": [float, ...],
          "run_s": float | null,                  # median, whole call in Python
          "compile_s": float | null,              # latdyn: when summary.json reports it
          "process_s": float | null,              # one fresh process, when measured
          "load_average": float,                  # 1-min, mean over the row's timed runs
          "note": str,
          # lattice rows add: "bays", "elements_per_member", "coordinates" (the code's own count of
          # unknowns), "steps_per_T", "variant" (the code's setting family), "candidate" (timed
          # again: the coarsest step within tolerance of its variant and element count)
          }],
      "matched": [{"problem", "tolerance", "latdyn_setting", "latdyn_error", "latdyn_s",
                   "exudyn_engine", "exudyn_setting", "exudyn_error", "exudyn_s",
                   "ratio": latdyn_s / exudyn_s,     # fastest ok row (by solver_s) of each code within
                   "latdyn_run_s", "exudyn_run_s",   # tolerance (t_end 10 s), one entry per Exudyn
                   "ratio_run": latdyn_run_s / exudyn_run_s}]   # element; ratio_run: same rows, run_s
               # lattice entries: {"problem": "lattice", "bays", "tolerance", "latdyn_setting",
               #   "latdyn_error", "latdyn_s", "latdyn_run_s", "latdyn_process_s", "latdyn_coordinates",
               #   "peers": [{"code", "engine", "setting", "error", "solver_s", "run_s", "process_s",
               #              "coordinates", "ratio": latdyn_s / solver_s, "ratio_run",
               #              "own_physics": {...} (OpenSeesPy against the euler_bernoulli reference),
               #              "note" (no setting within tolerance)}],
               #   "best_peer", "ratio_best_peer"}
    }

``peers.csv`` holds the rows, one line each, with the scalar columns above.
"""
from __future__ import annotations

import argparse
import copy
import csv
import datetime
import importlib.util
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"


def _import_latdyn():
    """latdyn from this checkout (also when the editable install points elsewhere)."""
    try:
        import latdyn  # noqa: F401
        import latdyn_generated  # noqa: F401
    except ModuleNotFoundError:
        sys.path.insert(0, str(ROOT))
        if importlib.util.find_spec("latdyn_generated") is None:
            spec = importlib.util.spec_from_file_location(
                "latdyn_generated", ROOT / "generated" / "__init__.py",
                submodule_search_locations=[str(ROOT / "generated")])
            mod = importlib.util.module_from_spec(spec)
            sys.modules["latdyn_generated"] = mod
            spec.loader.exec_module(mod)
    import latdyn
    return latdyn


#: Set (to 1) in a process that runs Exudyn alone (peers_as_user.py times such processes as a user's
#: script): neither latdyn nor OpenSeesPy is imported, so the process costs what Exudyn's does.
EXUDYN_ONLY = os.environ.get("LATDYN_PEERS_EXUDYN_ONLY") == "1"

latdyn = None if EXUDYN_ONLY else _import_latdyn()

try:
    import exudyn as exu
    from exudyn import itemInterface as eii
    EXUDYN_VERSION = exu.__version__
except ImportError:  # optional
    exu = eii = None
    EXUDYN_VERSION = None

sys.path.insert(0, str(Path(__file__).resolve().parent))
import lattice as lattice_problem  # noqa: E402  (benchmarks/lattice.py: the lattice problem's models)

ops = None if EXUDYN_ONLY else lattice_problem.import_opensees()  # optional; its libraries preloaded
OPENSEES_VERSION = lattice_problem.opensees_version(ops) if ops is not None else None

#: The interpreter that runs the peers (``--peer-python``: a venv of their own, as PEERS.md asks),
#: None: in this process. Set by :func:`use_peer_python`.
PEER_PYTHON = None


class _InPeerPython:
    """Stands for a peer's module (``exu``, ``ops``) that lives in the ``--peer-python`` interpreter:
    truthy where the sweep asks whether the peer is there; its runs go through :func:`peer_run`."""

    def __init__(self, name):
        self.name = name

    def __repr__(self):
        return f"<{self.name} in {PEER_PYTHON}>"


def use_peer_python(python: str) -> dict:
    """Run the peers in ``python`` (a venv with exudyn, openseespy, numpy and pyyaml): their versions
    are asked from it, and every peer run, in-process or fresh, is that interpreter running this
    file with ``--one``. Returns the versions found ({"exudyn": str | None, "opensees": ...})."""
    global PEER_PYTHON, exu, eii, ops, EXUDYN_VERSION, OPENSEES_VERSION
    done = subprocess.run([python, str(Path(__file__).resolve()), "--peer-versions"], cwd=ROOT,
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"peers.py: --peer-python {python} could not run this script:\n{done.stderr[-2000:]}")
    versions = json.loads(done.stdout.strip().splitlines()[-1])
    PEER_PYTHON = python
    EXUDYN_VERSION, OPENSEES_VERSION = versions["exudyn"], versions["opensees"]
    exu = eii = _InPeerPython("exudyn") if EXUDYN_VERSION else None
    ops = _InPeerPython("openseespy") if OPENSEES_VERSION else None
    return versions


def _json_safe(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    raise TypeError(type(x))


def peer_run(problem, code, cfg):
    """One in-process run of a peer in the ``--peer-python`` interpreter (timed inside it, as
    :func:`exudyn_once` and :func:`lattice_once` time it); the result row's fields."""
    job = json.dumps({"problem": problem, "code": code, "cfg": {k: v for k, v in cfg.items() if k != "headline"}},
                     default=_json_safe)
    done = subprocess.run([PEER_PYTHON, str(Path(__file__).resolve()), "--one", job, "--full"], cwd=ROOT,
                          capture_output=True, text=True)
    try:
        return json.loads(done.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        return {"status": "error", "note": (done.stderr or done.stdout).strip()[-300:]}


EXUDYN_MISSING = ("Exudyn is not installed: latdyn rows only.  Install the optional extra with "
                  "`pip install -e \".[peers]\"` (or `pip install exudyn`) and rerun.")

# ----------------------------------------------------------------------------- references
SPINUP_REF = {"v5": -0.46843, "v10": -0.36280, "vmin": -0.57379, "t_vmin": 6.762,
              "source": "issue 8: converged solution"}
SPINUP_TOL = 1e-3  # m
# Converged peaks of the right-angle cantilever (t_end 10 s), from
# `python benchmarks/peers.py --reference` (2026-11-23): the two codes' finest settings
#   latdyn 160 el, dt 0.00625: tip 8.251930 at 7.4364 s, elbow 5.512707 at 3.0985 s
#   Exudyn 160 el, dt 0.0025:  tip 8.251916 at 7.4360 s, elbow 5.512660 at 3.0984 s
# agree to 1e-5 (relative); the reference is their mean (table in docs/performance.md).
CANTILEVER_REF = {"tip_max": 8.25192, "t_tip_max": 7.436, "elbow_max": 5.51268, "t_elbow_max": 3.0985,
                  "source": "converged: mean of latdyn 160 el dt 0.00625 and Exudyn 160 el dt 0.0025 "
                            "(agree to 1e-5 relative); peers.py --reference"}
CANTILEVER_PUBLISHED = {"tip_max": 8.29, "t_tip_max": 7.67, "elbow_max": 5.5, "t_elbow_max": 3.05,
                        "source": "Simo & Vu-Quoc (1988), digitized (benchmarks.json D2)"}
CANTILEVER_TOL = 3e-3  # relative
LONG_RUN_S = 20.0  # a setting whose first timed run takes longer is not repeated


def _hub_angle(t):
    if t < 15:
        return 6 / 15 * (t ** 2 / 2 + (15 / (2 * math.pi)) ** 2 * (math.cos(2 * math.pi * t / 15) - 1))
    return 6 * (t - 7.5)


def _elbow_force(t):
    if t <= 1:
        return 50 * t
    if t <= 2:
        return 50 * (2 - t)
    return 0.0


peak = lattice_problem.peak  # largest value in a window, refined by a parabola


def spinup_error(t, v):
    t, v = np.asarray(t), np.asarray(v)
    v5 = float(np.interp(5.0, t, v))
    v10 = float(np.interp(10.0, t, v))
    vmin, tmin = peak(t, -v, (0.0, 10.0))
    vmin = -vmin
    parts = {"v5": abs(v5 - SPINUP_REF["v5"]), "v10": abs(v10 - SPINUP_REF["v10"]),
             "vmin": abs(vmin - SPINUP_REF["vmin"])}
    return max(parts.values()), parts, {"v5": v5, "v10": v10, "vmin": vmin, "t_vmin": tmin}


def cantilever_values(t, tip, elbow):
    tip_max, t_tip = peak(t, tip, (0.0, 10.0))
    elbow_max, t_elbow = peak(t, elbow, (0.0, 6.0))
    return {"tip_max": tip_max, "t_tip_max": t_tip, "elbow_max": elbow_max, "t_elbow_max": t_elbow}


def cantilever_error(values):
    if CANTILEVER_REF["tip_max"] is None:
        return None, {}
    parts = {k: abs(values[k] - CANTILEVER_REF[k]) / abs(CANTILEVER_REF[k]) for k in ("tip_max", "elbow_max")}
    pub = CANTILEVER_PUBLISHED["tip_max"]
    parts["tip_max_vs_published"] = abs(values["tip_max"] - pub) / pub
    return max(parts["tip_max"], parts["elbow_max"]), parts


# ----------------------------------------------------------------------------- latdyn
def latdyn_engines():
    """Values of ``solve.engine`` the scene loader accepts ([None] while it has none)."""
    found = [None]
    base = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
    for name in ("compiled", "python", "numpy", "c", "native"):
        s = copy.deepcopy(base)
        s["solve"]["engine"] = name
        try:
            latdyn.load_scene(s)
        except Exception:  # SceneError: unknown key or value
            continue
        found.append(name)
    return found


def latdyn_scene(problem, elements, dt, t_end, method=None, rho_inf=None, engine=None, newton=None, planar=None):
    if problem == "spinup":
        s = yaml.safe_load((ROOT / "examples" / "spinup.yaml").read_text())
        s["beams"]["arm"]["elements"] = elements
        s["output"] = {"every": 0.01 if dt <= 0.01 else dt,
                       "probes": {"tip_v": {"point": "arm.end", "quantity": "position", "frame": "hub",
                                            "component": "y"}}}
    else:
        s = yaml.safe_load((ROOT / "examples" / "benchmarks" / "D2_right_angle_cantilever.yaml").read_text())
        s["beams"]["leg1"]["elements"] = s["beams"]["leg2"]["elements"] = elements // 2
        s["output"] = {"every": dt, "probes": {
            "tip": {"point": "leg2.end", "quantity": "displacement", "frame": "global", "component": "z"},
            "elbow": {"point": "elbow", "quantity": "displacement", "frame": "global", "component": "z"}}}
    s["solve"].update(t_end=t_end, dt=dt)
    if method:
        s["solve"]["method"] = method
    if rho_inf is not None:
        s["solve"]["rho_inf"] = rho_inf
    if engine:
        s["solve"]["engine"] = engine
    if newton:
        s["solve"]["newton"] = newton
    if planar:
        s["solve"]["planar"] = planar
    return s


def latdyn_once(problem, cfg):
    s = latdyn_scene(problem, cfg["elements"], cfg["dt"], cfg["t_end"], cfg.get("method"), cfg.get("rho_inf"),
                     cfg.get("engine"), cfg.get("newton"), cfg.get("planar"))
    t0 = time.perf_counter()
    try:
        r = latdyn.run(s)
    except latdyn.SolverError as exc:
        return {"status": "failed", "note": str(exc).splitlines()[0][:200], "run_s": time.perf_counter() - t0}
    except latdyn.SceneError as exc:  # e.g. solve.engine: compiled refused for this scene
        return {"status": "error", "note": str(exc).splitlines()[-1][:200]}
    run_s = time.perf_counter() - t0
    sm = r.summary
    compile_s = sm.get("compile_s")
    solver_s = sm.get("solver_s", sm.get("solve_s"))
    if solver_s is None:
        solver_s = sm["wall_time_s"] - (compile_s or 0.0)
    out = {"status": "ok", "run_s": run_s, "solver_s": solver_s, "compile_s": compile_s,
           "steps": sm.get("steps"), "newton_iterations": sm.get("newton_iterations"),
           "jacobian_updates": sm.get("jacobian_updates", sm.get("factorizations")),
           "step_cuts": sm.get("newton_cuts"),
           "backend": sm.get("backend"), "engine": sm.get("engine"), "newton_mode": sm.get("newton"),
           "method": sm.get("method"), "tol": sm.get("newton_tolerance")}
    t = np.asarray(r.t)
    if problem == "spinup":
        out["error"], out["error_parts"], out["values"] = spinup_error(t, r.probes["tip_v"])
    else:
        out["values"] = cantilever_values(t, r.probes["tip"], r.probes["elbow"])
        out["error"], out["error_parts"] = cantilever_error(out["values"])
    return out


# ----------------------------------------------------------------------------- Exudyn
def _settings(cfg, write_period):
    ss = exu.SimulationSettings()
    ti = ss.timeIntegration
    ti.numberOfSteps = int(round(cfg["t_end"] / cfg["dt"]))
    ti.endTime = cfg["t_end"]
    ti.verboseMode = 0
    ti.generalizedAlpha.spectralRadius = cfg.get("rho_inf", 0.8)
    ti.newton.useModifiedNewton = cfg.get("modified", True)
    if cfg.get("atol") is not None:  # None: Exudyn's default (1e-10)
        ti.newton.absoluteTolerance = cfg["atol"]
    ss.solution.file.write = False
    ss.solution.sensors.writePeriod = write_period
    ss.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    return ss


def exudyn_spinup_model(n):
    """16-element-style planar model: NodeRigidBody2D + ObjectBeamGeometricallyExact2D.

    The root node is held by three CoordinateConstraints to ground; the one on its
    rotation coordinate has offsetUserFunction = the hub angle law (a Python callback).
    Shear stiffness GA = 1e7 (benchmarks.json D1), cross-section inertia 0 as in the
    latdyn scene (no rotary inertia).
    """
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    h = 10.0 / n
    nodes = [mbs.AddNode(eii.NodeRigidBody2D(referenceCoordinates=[h * i, 0, 0])) for i in range(n + 1)]
    for i in range(n):
        mbs.AddObject(eii.ObjectBeamGeometricallyExact2D(
            nodeNumbers=[nodes[i], nodes[i + 1]], length=h, massPerLength=1.2, crossSectionInertia=0.0,
            bendingStiffness=1.4e4, axialStiffness=2.8e7, shearStiffness=1.0e7))
    ground = mbs.AddNode(eii.NodePointGround())
    mg = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))
    for c in range(3):
        m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=c))
        kw = {"offsetUserFunction": lambda mbs, t, item, offset: _hub_angle(t)} if c == 2 else {}
        mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[mg, m], **kw))
    sensor = mbs.AddSensor(eii.SensorNode(nodeNumber=nodes[-1], outputVariableType=exu.OutputVariableType.Position,
                                          storeInternal=True, writeToFile=False))
    mbs.Assemble()
    return SC, mbs, {"tip": sensor}


def exudyn_cantilever_model(n):
    """3D model: NodeRigidBodyRotVecLG + ObjectBeamGeometricallyExact (n elements in all).

    Each leg has its own nodes with the reference rotation of its local axes (leg 1 along
    y: rotation vector [0, 0, pi/2]; leg 2 along -x: [0, 0, pi]); the two elbow nodes are
    welded by a GenericJoint with all six axes constrained, the root node to ground the
    same way.  Section: stiffness diag(EA, GA, GA, GJ, EI, EI) = (1e6, 1e6, 1e6, 1e3,
    1e3, 1e3) (GA from Simo & Vu-Quoc; latdyn's scene is shear-rigid), inertia
    diag(20, 10, 10), rhoA = 1.  The elbow force is a Force load with a Python
    loadVectorUserFunction.
    """
    from exudyn.rigidBodyUtilities import RotationVector2RotationMatrix
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    sec = exu.BeamSection()
    sec.stiffnessMatrix = np.diag([1e6, 1e6, 1e6, 1e3, 1e3, 1e3])
    sec.inertia = np.diag([20.0, 10.0, 10.0])
    sec.massPerLength = 1.0
    per_leg = n // 2
    h = 10.0 / per_leg

    def leg(p0, d, rv):
        nodes = [mbs.AddNode(eii.NodeRigidBodyRotVecLG(
            referenceCoordinates=list(np.asarray(p0, float) + i * h * np.asarray(d, float)) + rv))
            for i in range(per_leg + 1)]
        for i in range(per_leg):
            mbs.AddObject(eii.ObjectBeamGeometricallyExact(nodeNumbers=[nodes[i], nodes[i + 1]], length=h,
                                                           sectionData=sec))
        return nodes

    rv1, rv2 = [0, 0, math.pi / 2], [0, 0, math.pi]
    leg1 = leg([0, 0, 0], [0, 1, 0], rv1)
    leg2 = leg([0, 10, 0], [-1, 0, 0], rv2)
    R1, R2 = RotationVector2RotationMatrix(rv1), RotationVector2RotationMatrix(rv2)
    ground = mbs.AddObject(eii.ObjectGround())
    mg = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=[0, 0, 0]))
    m0 = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=leg1[0]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        mbs.AddObject(eii.GenericJoint(markerNumbers=[mg, m0], constrainedAxes=[1] * 6,
                                       rotationMarker0=np.eye(3), rotationMarker1=R1.T))
        ma = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=leg1[-1]))
        mb = mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=leg2[0]))
        mbs.AddObject(eii.GenericJoint(markerNumbers=[ma, mb], constrainedAxes=[1] * 6,
                                       rotationMarker0=R1.T, rotationMarker1=R2.T))
    mbs.AddLoad(eii.Force(markerNumber=ma, loadVector=[0, 0, 0],
                          loadVectorUserFunction=lambda mbs, t, load: [0, 0, _elbow_force(t)]))
    disp = exu.OutputVariableType.Displacement
    sensors = {"tip": mbs.AddSensor(eii.SensorNode(nodeNumber=leg2[-1], outputVariableType=disp,
                                                   storeInternal=True, writeToFile=False)),
               "elbow": mbs.AddSensor(eii.SensorNode(nodeNumber=leg1[-1], outputVariableType=disp,
                                                     storeInternal=True, writeToFile=False))}
    mbs.Assemble()
    return SC, mbs, sensors


def exudyn_cantilever_rbs_model(n):
    """Rigid-body-spring model of the cantilever: n rigid segments (n/2 per leg).

    Each segment of length h is a rigid body (Lie-group rotation-vector node) with mass
    rhoA*h and inertia diag(20 h, 10 h + h^3/12, 10 h + h^3/12) in its axes, placed at its
    middle; neighbours are joined at their common end by an ObjectConnectorRigidBodySpringDamper
    of stiffness diag(EA, GA, GA, GJ, EI, EI)/h (all three translational and all three
    rotational entries are equal in this problem, so the frame of the spring does not matter;
    at the elbow the marker rotations align the two legs' frames), the root segment to
    ground by twice that (half a segment).  Same load, sensors at the segment ends.
    """
    from exudyn.rigidBodyUtilities import RotationVector2RotationMatrix
    from exudyn.utilities import RigidBodyInertia
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    per_leg = n // 2
    h = 10.0 / per_leg
    K = np.diag([1e6, 1e6, 1e6, 1e3, 1e3, 1e3]) / h
    J = np.diag([20 * h, 10 * h + h ** 3 / 12, 10 * h + h ** 3 / 12])
    R1 = RotationVector2RotationMatrix([0, 0, math.pi / 2])
    R2 = RotationVector2RotationMatrix([0, 0, math.pi])

    def leg(p0, d, R):
        p0, d = np.asarray(p0, float), np.asarray(d, float)
        return [mbs.CreateRigidBody(referencePosition=list(p0 + (i + 0.5) * h * d), referenceRotationMatrix=R,
                                    inertia=RigidBodyInertia(mass=h, inertiaTensor=J),
                                    nodeType=exu.NodeType.RotationRotationVector)
                for i in range(per_leg)]

    def end(body, x):
        return mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=body, localPosition=[x, 0, 0]))

    leg1 = leg([0, 0, 0], [0, 1, 0], R1)
    leg2 = leg([0, 10, 0], [-1, 0, 0], R2)
    ground = mbs.AddObject(eii.ObjectGround())
    mg = mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=ground, localPosition=[0, 0, 0]))
    spring = eii.RigidBodySpringDamper
    mbs.AddObject(spring(markerNumbers=[mg, end(leg1[0], -h / 2)], stiffness=2 * K, rotationMarker0=R1,
                         rotationMarker1=np.eye(3)))
    for bodies in (leg1, leg2):
        for a, b in zip(bodies[:-1], bodies[1:]):
            mbs.AddObject(spring(markerNumbers=[end(a, h / 2), end(b, -h / 2)], stiffness=K))
    elbow = end(leg1[-1], h / 2)
    mbs.AddObject(spring(markerNumbers=[elbow, end(leg2[0], -h / 2)], stiffness=K, rotationMarker0=np.eye(3),
                         rotationMarker1=R2.T @ R1))
    mbs.AddLoad(eii.Force(markerNumber=elbow, loadVector=[0, 0, 0],
                          loadVectorUserFunction=lambda mbs, t, load: [0, 0, _elbow_force(t)]))
    pos = exu.OutputVariableType.Position
    sensors = {"tip": mbs.AddSensor(eii.SensorBody(bodyNumber=leg2[-1], localPosition=[h / 2, 0, 0],
                                                   outputVariableType=pos, storeInternal=True, writeToFile=False)),
               "elbow": mbs.AddSensor(eii.SensorBody(bodyNumber=leg1[-1], localPosition=[h / 2, 0, 0],
                                                     outputVariableType=pos, storeInternal=True, writeToFile=False))}
    mbs.Assemble()
    return SC, mbs, sensors


def exudyn_once(problem, cfg):
    if PEER_PYTHON is not None:
        return peer_run(problem, "exudyn", cfg)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        if problem == "spinup":
            SC, mbs, sensors = exudyn_spinup_model(cfg["elements"])
            ss = _settings(cfg, 0.01 if cfg["dt"] <= 0.01 else cfg["dt"])
        elif cfg.get("model") == "rbs":
            SC, mbs, sensors = exudyn_cantilever_rbs_model(cfg["elements"])
            ss = _settings(cfg, cfg["dt"])
        else:
            SC, mbs, sensors = exudyn_cantilever_model(cfg["elements"])
            ss = _settings(cfg, cfg["dt"])
    solver = exu.MainSolverImplicitSecondOrder()
    t1 = time.perf_counter()
    try:
        ok = solver.SolveSystem(mbs, ss)
    except Exception as exc:  # Exudyn raises on some failures
        ok, msg = False, str(exc)[:200]
    else:
        msg = ""
    t2 = time.perf_counter()
    it = solver.it
    out = {"solver_s": t2 - t1, "run_s": t2 - t0, "compile_s": None, "steps": int(it.currentStepIndex),
           "newton_iterations": int(it.newtonStepsCount), "jacobian_updates": int(it.newtonJacobiCount)}
    if not ok:
        d = mbs.GetSensorStoredData(sensors["tip"])
        out.update(status="failed", note=(msg or f"SolveSystem returned False at t = {d[-1, 0]:.3f} s "
                                          f"(Newton did not converge)"))
        return out
    out["status"] = "ok"
    d = mbs.GetSensorStoredData(sensors["tip"])
    t = d[:, 0]
    if problem == "spinup":
        th = np.array([_hub_angle(x) for x in t])
        v = -np.sin(th) * d[:, 1] + np.cos(th) * d[:, 2]  # tip y in the hub frame
        out["error"], out["error_parts"], out["values"] = spinup_error(t, v)
    else:
        e = mbs.GetSensorStoredData(sensors["elbow"])
        out["values"] = cantilever_values(t, d[:, 3], e[:, 3])  # z: reference z is 0 (position = displacement)
        out["error"], out["error_parts"] = cantilever_error(out["values"])
    return out


# ----------------------------------------------------------------------------- lattice
LATTICE_TOL = 1e-2          # relative: history deviation over the peak (benchmarks/lattice.py error)
LATTICE_BAYS = (4, 16, 64)
STEP_LADDER = (25, 35, 50, 70, 100, 140, 200, 280, 400)   # steps per period T tried, coarsest first
LATTICE_RUN_BUDGET_S = 150.0  # a search run predicted to take longer is not started


def lattice_variants(quick):
    """(code, variant label, base cfg, elements a member to try) of the lattice search.

    Tolerances: each code's Newton tolerance is part of its setting, held honest by the error
    against the reference: latdyn's increment test (1e-8 of the scene's length, its default,
    and 1e-6); Exudyn's residual test (absolute 1e-4 F0 with its default relative 1e-8, and a
    loose absolute 1e-2 F0 / relative 1e-5); OpenSeesPy's NormDispIncr 1e-8 L (1e-6 and 1e-5
    L took as many iterations in a trial at 16 bays).  OpenSeesPy's ``ModifiedNewton -initial``
    is not searched: it failed within the first steps at 42 of the 45 settings tried (4, 16,
    64 bays) in a first pass."""
    out = [("latdyn", "cr4402, modified Newton, tol 1e-6",
            {"formulation": "cr4402", "newton": "modified", "tol": 1e-6}, (1, 2, 4)),
           ("latdyn", "cr4402, modified Newton", {"formulation": "cr4402", "newton": "modified"}, (1, 2, 4)),
           ("latdyn", "default element, full Newton", {}, (1, 2, 4))]
    if quick:
        out = out[:1]
    if exu is not None:
        loose = {"atol_F0": 1e-2, "rtol": 1e-5}
        out.append(("exudyn", "beam, modified Newton, loose tol", dict(model="beam", modified=True, **loose),
                    (2, 4, 8, 16, 32)))
        out.append(("exudyn", "rigid-body-spring, modified Newton, loose tol",
                    dict(model="rbs", modified=True, **loose), (2, 4, 8, 16, 32)))
        if not quick:
            out.append(("exudyn", "rigid-body-spring, modified Newton",
                        {"model": "rbs", "modified": True, "atol_F0": 1e-4}, (2, 4, 8, 16, 32)))
    if ops is not None:
        out.append(("opensees", "ModifiedNewton", {"algorithm": "ModifiedNewton"}, (1, 2, 4)))
    return out


def lattice_once(code, cfg):
    """One lattice run of one code; the fields of a row (error against the timoshenko reference;
    OpenSeesPy's also against the euler_bernoulli one, in error_parts)."""
    bays = cfg["bays"]
    if code != "latdyn" and PEER_PYTHON is not None:  # its history scored here: the reference's spline needs SciPy
        res = peer_run("lattice", code, dict(cfg, raw=True))
        t, u = (None if res.get(k) is None else np.asarray(res.pop(k), float) for k in ("t", "u"))
    else:
        eq = lattice_problem.equivalent_beam(bays)
        run_cfg = dict(cfg, dt=eq["T"] / cfg["steps_per_T"])
        run_cfg.pop("raw", None)
        if "atol_F0" in run_cfg:
            run_cfg["atol"] = run_cfg.pop("atol_F0") * eq["F0"]
        if code == "latdyn":
            res = lattice_problem.latdyn_run(latdyn, bays, run_cfg)
            res.pop("summary", None)
        elif code == "exudyn":
            res = lattice_problem.exudyn_run(exu, eii, bays, run_cfg)
        else:
            res = lattice_problem.opensees_run(ops, bays, run_cfg)
        if cfg.get("raw"):  # a --peer-python run: the caller scores the history
            return res
        t, u = res.pop("t", None), res.pop("u", None)
    if res.get("status") == "ok":
        res["values"] = lattice_problem.values(bays, t, u)
        res["error"], res["error_parts"] = lattice_problem.error(bays, t, u)
        if code == "opensees":
            eb, _ = lattice_problem.error(bays, t, u, physics="euler_bernoulli")
            res["error_parts"]["history_vs_euler_bernoulli"] = eb
    return res


def _lattice_row(code, variant, bays, e, k, cfg, results):
    eq = lattice_problem.equivalent_beam(bays)
    last = results[-1]
    ok = [r for r in results if r.get("status") == "ok"]
    solver_all = [r["solver_s"] for r in results if r.get("solver_s") is not None]
    run_all = [r["run_s"] for r in results if r.get("run_s") is not None]
    if code == "latdyn":
        engine = (last.get("backend") or "?") + "/" + (last.get("engine") or "python") + \
                 f", {cfg.get('formulation', 'default')} element"
        method = last.get("method") or "generalized-alpha"
        method += " rho=0.8"
        newton = (last.get("newton_mode") or cfg.get("newton") or "full") + \
            (f" (tol {last.get('tol'):g})" if last.get("tol") else "")
    elif code == "exudyn":
        engine = "RigidBody+RigidBodySpringDamper" if cfg.get("model") == "rbs" else "ObjectBeamGeometricallyExact"
        method = "generalized-alpha rho=0.8"
        newton = ("modified" if cfg.get("modified", True) else "full") + f" (abs tol {cfg['atol_F0']:g} F0" + \
            (f", rel tol {cfg['rtol']:g})" if cfg.get("rtol") else ")")
    else:
        engine = "elasticBeamColumn+Corotational"
        method = "HHT alpha=0.889 (rho=0.8)"
        newton = cfg.get("algorithm", "ModifiedNewton") + " (NormDispIncr 1e-8 L)"
    label = f"{bays} bays, {e} el/member, dt T/{k:g}, {variant}"
    return {"problem": "lattice", "code": code, "engine": engine, "setting": label, "bays": bays,
            "elements_per_member": e, "elements": 12 * bays * e, "coordinates": last.get("coordinates"),
            "steps_per_T": k, "dt": eq["T"] / k, "t_end": eq["t_end"], "method": method, "newton": newton,
            "status": "ok" if results and len(ok) == len(results) else last.get("status", "error"),
            "error": last.get("error"), "error_parts": last.get("error_parts", {}), "values": last.get("values", {}),
            "steps": last.get("steps"), "step_cuts": last.get("step_cuts"),
            "newton_iterations": last.get("newton_iterations"), "jacobian_updates": last.get("jacobian_updates"),
            "solver_s": statistics.median(solver_all) if solver_all else None, "solver_s_all": solver_all,
            "run_s": statistics.median(run_all) if run_all else None, "compile_s": last.get("compile_s"),
            "process_s": None, "load_average": float(np.mean([r["load"] for r in results])),
            "note": last.get("note", ""), "variant": variant, "candidate": False}


def lattice_sweep(bays_list, quick, repeats, log):
    """Search, per code, variant and size, the fastest setting within LATTICE_TOL, then time
    the candidates (one per variant and element count: the coarsest step that met the
    tolerance) ``repeats`` times in interleaved passes.  Returns the rows."""
    variants = lattice_variants(quick)
    ladder = (50, 100) if quick else STEP_LADDER
    entries = []   # [code, variant, bays, e, k, cfg, results]
    reference = lattice_problem.load_reference()
    for bays in bays_list:
        if str(bays) not in reference.get("bays", {}):
            log(f"  lattice {bays} bays: no reference history in {lattice_problem.REFERENCE_FILE.name}: skipped "
                f"(python benchmarks/peers.py --reference --problems lattice --bays {bays})")
            continue
        # warm-up (not timed): kernels, the scene's laws, imports
        for code, variant, base, _ in variants:
            lattice_once(code, dict(base, bays=bays, elements=1 if code != "exudyn" else 2, steps_per_T=10,
                                    t_end=lattice_problem.equivalent_beam(bays)["T"] / 5))
        for code, variant, base, element_list in variants:
            if code == "exudyn" and base.get("atol_F0") == 1e-4 and bays >= 128:
                # F0 falls as 1/L²: an absolute residual tolerance of 1e-4 F0 (0.4 mN at 256 bays)
                # stalled Exudyn's Newton (a 256-bay run still going after 9 minutes): loose tolerance only
                log(f"  lattice {bays} bays {code} {variant}: not searched from 128 bays on (Newton stalls)")
                continue
            found = None   # (e, k) of the first candidate
            cost = None    # solver seconds per (element-member x step) seen, to predict run times
            for e in element_list:
                if found is not None and e > 2 * found[0]:
                    break
                for k in ladder:
                    if found is not None and k >= found[1]:
                        break   # more elements and as many steps: slower than the candidate
                    if cost is not None and cost * e * k * 2 > LATTICE_RUN_BUDGET_S:
                        log(f"  lattice {bays} bays {code} {variant}: {e} el/member, T/{k}: skipped "
                            f"(predicted > {LATTICE_RUN_BUDGET_S:.0f} s)")
                        break
                    cfg = dict(base, bays=bays, elements=e, steps_per_T=k)
                    res = lattice_once(code, cfg)
                    res["load"] = load1()
                    entries.append([code, variant, bays, e, k, cfg, [res]])
                    err = res.get("error")
                    log(f"  lattice {bays} bays {code} {variant}: {e} el/member, T/{k}: {res.get('status')} "
                        f"error {'-' if err is None else f'{err:.2e}'} solver {res.get('solver_s') or 0:.3f} s "
                        f"load {res['load']:.2f}")
                    if res.get("solver_s"):
                        cost = max(cost or 0.0, res["solver_s"] / (e * k * 2))
                    if res.get("status") == "ok" and err is not None and err <= LATTICE_TOL:
                        entries[-1].append(True)   # a candidate: timed again below
                        found = found or (e, k)
                        break
    candidates = [x for x in entries if len(x) == 8]
    for rep in range(1, repeats):
        for x in candidates:
            if x[6][0].get("solver_s", 0) >= LONG_RUN_S:
                continue
            res = lattice_once(x[0], x[5])
            res["load"] = load1()
            x[6].append(res)
    rows = []
    for x in entries:
        row = _lattice_row(*x[:7])
        row["candidate"] = len(x) == 8
        rows.append(row)
    return rows


def lattice_matched(rows, bays_list):
    """Per size: the fastest ok row of each code within LATTICE_TOL (by solver_s) and the
    ratios latdyn / peer; OpenSeesPy also at its own physics (error against the
    euler_bernoulli reference), marked so."""
    matched = []
    for bays in bays_list:
        ok = [r for r in rows if r["problem"] == "lattice" and r["bays"] == bays and r["status"] == "ok"
              and r["solver_s"]]
        if not ok:
            continue
        within = [r for r in ok if r["error"] is not None and r["error"] <= LATTICE_TOL]
        lat = [r for r in within if r["code"] == "latdyn"]
        entry = {"problem": "lattice", "bays": bays, "tolerance": LATTICE_TOL}
        if lat:
            L = min(lat, key=lambda r: r["solver_s"])
            entry.update(latdyn_setting=L["setting"], latdyn_error=L["error"], latdyn_s=L["solver_s"],
                         latdyn_run_s=L["run_s"], latdyn_process_s=L.get("process_s"),
                         latdyn_coordinates=L.get("coordinates"))
        peers_found = []
        for code, engine in dict.fromkeys((r["code"], r["engine"]) for r in ok if r["code"] != "latdyn"):
            mine = [r for r in within if r["code"] == code and r["engine"] == engine]
            own = None
            if code == "opensees":
                own = [r for r in ok if r["code"] == code and
                       (r["error_parts"].get("history_vs_euler_bernoulli") or 1) <= LATTICE_TOL]
            peer = {"code": code, "engine": engine}
            if mine:
                P = min(mine, key=lambda r: r["solver_s"])
                peer.update(setting=P["setting"], error=P["error"], solver_s=P["solver_s"], run_s=P["run_s"],
                            process_s=P.get("process_s"), coordinates=P.get("coordinates"))
                if lat:
                    peer["ratio"] = entry["latdyn_s"] / P["solver_s"]
                    peer["ratio_run"] = entry["latdyn_run_s"] / P["run_s"] if P["run_s"] else None
            else:
                best = min((r for r in ok if r["code"] == code and r["engine"] == engine),
                           key=lambda r: r["error"] if r["error"] is not None else math.inf, default=None)
                peer["note"] = ("no setting within the tolerance" +
                                (f"; smallest error {best['error']:.2e} ({best['setting']})"
                                 if best and best["error"] is not None else ""))
            if own and (not mine or min(own, key=lambda r: r["solver_s"])["setting"] != peer.get("setting")):
                O = min(own, key=lambda r: r["solver_s"])
                peer["own_physics"] = {"reference": "euler_bernoulli", "setting": O["setting"],
                                       "error": O["error_parts"]["history_vs_euler_bernoulli"],
                                       "solver_s": O["solver_s"],
                                       "ratio": entry["latdyn_s"] / O["solver_s"] if lat else None}
            peers_found.append(peer)
        entry["peers"] = peers_found
        timed = [p for p in peers_found if "ratio" in p]
        if timed:
            best = min(timed, key=lambda p: p["solver_s"])
            entry["best_peer"] = f"{best['code']} {best['engine']}"
            entry["ratio_best_peer"] = best["ratio"]
        matched.append(entry)
    return matched


def lattice_process_times(rows, matched):
    """Fresh-process times of the matched settings: latdyn as a user runs it (``latdyn run SCENE
    -o OUT -q``, the scene written as YAML, results written), the peers by ``peers.py --one``."""
    import tempfile

    by_setting = {(r["code"], r["setting"]): r for r in rows if r["problem"] == "lattice"}
    for entry in matched:
        picks = []
        if entry.get("latdyn_setting"):
            picks.append(("latdyn", entry["latdyn_setting"]))
        picks += [(p["code"], p["setting"]) for p in entry["peers"] if p.get("setting")]
        for code, setting in picks:
            row = by_setting[(code, setting)]
            if code == "latdyn":
                with tempfile.TemporaryDirectory() as tmp:
                    eq = lattice_problem.equivalent_beam(row["bays"])
                    kw = next(b for c, v, b, _ in lattice_variants(False) if c == code and v == row["variant"])
                    scene = Path(tmp) / "lattice.yaml"
                    scene.write_text(lattice_problem.scene_yaml(row["bays"], row["elements_per_member"],
                                                                eq["T"] / row["steps_per_T"], **kw))
                    for _ in range(2):
                        t0 = time.perf_counter()
                        p = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o",
                                            str(Path(tmp) / "out"), "-q"], capture_output=True, text=True, cwd=tmp,
                                           env=timed_environment())
                        wall = time.perf_counter() - t0
                        if "compiling" not in p.stderr:
                            break
                    row["process_s"] = wall if p.returncode == 0 else None
            else:
                cfg = {"bays": row["bays"], "elements": row["elements_per_member"], "steps_per_T": row["steps_per_T"]}
                cfg.update(next(b for c, v, b, _ in lattice_variants(False) if c == code and v == row["variant"]))
                row["process_s"] = process_time("lattice", code, cfg)
            row["process_load"] = load1()
            if code == "latdyn":
                entry["latdyn_process_s"] = row["process_s"]
            else:
                for p in entry["peers"]:
                    if p.get("setting") == setting:
                        p["process_s"] = row["process_s"]


# ----------------------------------------------------------------------------- sweep
def sweep(quick, engines):
    """(problem, code, cfg) in run order; cfg holds the setting, 'label', 'repeats', flags.

    latdyn: the whole sweep with the compiled step when ``solve.engine: compiled`` exists
    (plus full Newton at the headline settings), the Python step at the headline settings where the
    loader still accepts ``python`` (before issue 17);
    with no ``solve.engine`` the whole sweep with the one engine there is.
    """
    rows = []
    main_engine = "compiled" if "compiled" in engines else None
    sp_all = [(4, 0.01)] if quick else [(2, 0.01), (2, 0.005), (4, 0.02), (4, 0.01), (8, 0.01), (8, 0.005)]
    ca_all = [(20, 0.05)] if quick else [(6, 0.1), (10, 0.2), (10, 0.1), (10, 0.05), (20, 0.05), (20, 0.025)]
    head = {"spinup": (4, 0.01), "cantilever": (20, 0.05)}
    variants = [(main_engine, None, None, None)]
    if main_engine and not quick:
        # the spin-up is planar: solve.planar: off gives the 3D model of the same scene
        variants += [(main_engine, "full", "headline", None)]
        if "python" in engines:  # the Python step, up to issue 17 (its Newton iteration now exists in C only)
            variants += [("python", None, "headline", None)]
        variants += [(main_engine, None, "headline", "off")]
    for eng, newton, only, planar in variants:
        sfx = ("" if eng is None else f", {eng}") + ("" if newton is None else f", {newton} Newton") + \
              ("" if planar is None else f", planar {planar}")
        for problem, settings in (("spinup", sp_all), ("cantilever", ca_all)):
            if planar == "off" and problem != "spinup":
                continue
            for n, dt in settings:
                if only == "headline" and (n, dt) != head[problem]:
                    continue
                rows.append((problem, "latdyn", dict(elements=n, dt=dt, t_end=10.0, engine=eng, newton=newton,
                                                     planar=planar, label=f"{n} el, dt {dt}{sfx}",
                                                     headline=(n, dt) == head[problem] and only is None)))
    if exu is not None:
        sp = [(16, 0.01, {})] if quick else [(8, 0.01, {}), (8, 0.005, {}), (16, 0.02, {}), (16, 0.01, {}),
                                             (32, 0.005, {}),
                                             (16, 0.01, {"modified": False}),
                                             (16, 0.01, {"atol": None, "repeats": 1})]
        for n, dt, extra in sp:
            cfg = dict(elements=n, dt=dt, t_end=10.0, rho_inf=0.8, modified=True, atol=1e-6)
            cfg.update(extra)
            tag = ("" if cfg["modified"] else ", full Newton") + (", default tol" if cfg["atol"] is None else "")
            cfg.update(label=f"{n} el, dt {dt}{tag}", headline=(n, dt) == (16, 0.01) and not tag)
            rows.append(("spinup", "exudyn", cfg))
        ca = [(20, 0.05, {})] if quick else [(10, 0.1, {}), (10, 0.05, {}), (20, 0.1, {}), (20, 0.05, {}),
                                             (20, 0.025, {}), (20, 0.01, {}), (40, 0.025, {}),
                                             (20, 0.01, {"rho_inf": 1.0, "t_end": 30.0, "repeats": 1}),
                                             (20, 0.01, {"t_end": 30.0, "repeats": 1}),
                                             (20, 0.05, {"model": "rbs"}), (40, 0.1, {"model": "rbs"}),
                                             (40, 0.05, {"model": "rbs"}), (80, 0.05, {"model": "rbs"})]
        for n, dt, extra in ca:
            cfg = dict(elements=n, dt=dt, t_end=10.0, rho_inf=0.8, modified=True, atol=1e-6)
            cfg.update(extra)
            tag = (f", rho_inf {cfg['rho_inf']:g}" if cfg["rho_inf"] != 0.8 else "") + \
                  (f", t_end {cfg['t_end']:g}" if cfg["t_end"] != 10.0 else "") + \
                  (", rigid-body-spring" if cfg.get("model") == "rbs" else "")
            cfg.update(label=f"{n} el, dt {dt}{tag}", headline=(n, dt) == (20, 0.05) and not tag)
            rows.append(("cantilever", "exudyn", cfg))
    return rows


def _quiet_exudyn():
    if isinstance(exu, _InPeerPython):
        return
    if hasattr(exu, "config") and hasattr(exu.config, "printToConsole"):
        exu.config.printToConsole = False
    else:  # older Exudyn
        exu.SetWriteToConsole(False)


def load1():
    try:
        return os.getloadavg()[0]
    except OSError:  # pragma: no cover
        return float("nan")


def machine():
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "platform": platform.platform(),
            "python": platform.python_version(), "numpy": np.__version__,
            "latdyn": latdyn.__version__, "exudyn": EXUDYN_VERSION, "opensees": OPENSEES_VERSION,
            "git": _git(), "load_average_start": list(os.getloadavg())}


def _git():
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "latdyn", "generated", "codegen"], cwd=ROOT,
                               capture_output=True, text=True).stdout.strip()
        return {"head": head, "runtime_dirty": bool(dirty)}
    except OSError:
        return None


def describe(code, cfg, res):
    if code == "latdyn":
        engine = (res.get("backend") or "?") + "/" + (res.get("engine") or cfg.get("engine") or "python")
        method = res.get("method") or cfg.get("method") or "default"
        newton = (res.get("newton_mode") or cfg.get("newton") or "full") + \
            (f" (tol {res.get('tol'):g})" if res.get("tol") else "")
    else:
        engine = ("ObjectBeamGeometricallyExact2D" if cfg.get("problem") == "spinup" else
                  "RigidBody+RigidBodySpringDamper" if cfg.get("model") == "rbs" else "ObjectBeamGeometricallyExact")
        method = f"generalized-alpha rho={cfg.get('rho_inf', 0.8):g}"
        atol = cfg.get("atol")
        newton = ("modified" if cfg.get("modified", True) else "full") + \
                 (f" (abs tol {atol:g})" if atol is not None else " (default tol)")
    return engine, method, newton


def matched_pairs(rows):
    """Per problem and Exudyn element: the fastest ok row of each code within the tolerance
    (t_end 10 s rows) and the ratio of their solver times."""
    matched = []
    for problem, tol in (("spinup", SPINUP_TOL), ("cantilever", CANTILEVER_TOL)):
        ok = [r for r in rows if r["problem"] == problem and r["status"] == "ok" and r["error"] is not None
              and r["error"] <= tol and r["t_end"] == 10.0 and r["solver_s"]]
        lat = [r for r in ok if r["code"] == "latdyn"]
        if not lat:
            continue
        L = min(lat, key=lambda r: r["solver_s"])
        for engine in dict.fromkeys(r["engine"] for r in ok if r["code"] == "exudyn"):
            E = min((r for r in ok if r["code"] == "exudyn" and r["engine"] == engine), key=lambda r: r["solver_s"])
            matched.append({"problem": problem, "tolerance": tol, "latdyn_setting": L["setting"],
                            "latdyn_error": L["error"], "latdyn_s": L["solver_s"], "exudyn_engine": engine,
                            "exudyn_setting": E["setting"], "exudyn_error": E["error"], "exudyn_s": E["solver_s"],
                            "ratio": L["solver_s"] / E["solver_s"],
                            "latdyn_run_s": L["run_s"], "exudyn_run_s": E["run_s"],
                            "ratio_run": L["run_s"] / E["run_s"] if L["run_s"] and E["run_s"] else None})
    return matched


def timed_environment() -> dict:
    """The environment of a fresh process timed from outside: this checkout first on the path and
    byte code cached as a user's installation has it (``PYTHONDONTWRITEBYTECODE`` dropped: with it
    every module of the checkout is compiled again in every process)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    return env


def process_time(problem, code, cfg):
    """One fresh interpreter: import, build, solve once; wall time from outside.

    When latdyn says on stderr that it compiled kernels (the cache was stale: someone changed
    the kernels meanwhile), the process is run again and that second time is returned.
    """
    arg = json.dumps({"problem": problem, "code": code, "cfg": {k: v for k, v in cfg.items() if k != "headline"}})
    python = PEER_PYTHON if code != "latdyn" and PEER_PYTHON is not None else sys.executable
    for _ in range(2):
        t0 = time.perf_counter()
        p = subprocess.run([python, str(Path(__file__).resolve()), "--one", arg], cwd=ROOT,
                           capture_output=True, text=True, env=timed_environment())
        dt = time.perf_counter() - t0
        if "compiling" not in p.stderr:
            break
    return dt if p.returncode == 0 else None


def run_one(problem, code, cfg):
    cfg = dict(cfg, problem=problem)
    if problem == "lattice":
        return lattice_once(code, cfg)
    return latdyn_once(problem, cfg) if code == "latdyn" else exudyn_once(problem, cfg)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="one or two settings per code, one repeat")
    ap.add_argument("--repeats", type=int, default=None, help="timed runs per setting (default 3; quick 1)")
    ap.add_argument("--out", default=str(RESULTS / "peers"), help="output stem (.json and .csv are added)")
    ap.add_argument("--no-process", action="store_true", help="skip the fresh-process timings")
    ap.add_argument("--reference", action="store_true", help="converge the cantilever peaks with both codes")
    ap.add_argument("--markdown", metavar="JSON", help="print the tables of a peers.json as Markdown and exit")
    ap.add_argument("--problems", default="spinup,cantilever,lattice",
                    help="comma-separated subset of spinup, cantilever, lattice (rows of the others are kept "
                         "from the existing output file)")
    ap.add_argument("--bays", default=",".join(map(str, LATTICE_BAYS)),
                    help="lattice sizes (bays), comma-separated (default %(default)s)")
    ap.add_argument("--peer-python", metavar="PYTHON",
                    help="run Exudyn and OpenSeesPy with this interpreter (a venv of their own: "
                         "python -m venv /tmp/peers && /tmp/peers/bin/pip install exudyn openseespy numpy pyyaml)")
    ap.add_argument("--one", help=argparse.SUPPRESS)
    ap.add_argument("--full", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--peer-versions", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.peer_versions:
        print(json.dumps({"exudyn": EXUDYN_VERSION, "opensees": OPENSEES_VERSION}))
        return 0
    if args.peer_python:
        print(f"peers from {args.peer_python}: {use_peer_python(args.peer_python)}", file=sys.stderr)
    problems = [p.strip() for p in args.problems.split(",") if p.strip()]
    bays_list = [int(b) for b in args.bays.split(",")]
    if args.one:
        job = json.loads(args.one)
        if exu is not None and job["code"] == "exudyn":
            _quiet_exudyn()
        res = run_one(job["problem"], job["code"], job["cfg"])
        print(json.dumps(res if args.full else {k: res.get(k) for k in ("status", "error", "solver_s")},
                         default=_json_safe))
        return 0 if res.get("status") == "ok" else 1
    if args.reference:
        if "lattice" in problems:
            lattice_problem.make_reference(bays_list, latdyn, exu, eii, ops, log=lambda m: print(m, flush=True))
        if "cantilever" in problems:
            return reference_run()
        return 0
    if args.markdown:
        print(markdown(json.loads(Path(args.markdown).read_text())))
        return 0
    repeats = args.repeats or (1 if args.quick else 3)
    notes = []
    if exu is None:
        notes.append(EXUDYN_MISSING)
        print("NOTE: " + EXUDYN_MISSING, file=sys.stderr)
    else:
        _quiet_exudyn()  # Exudyn's own warnings (e.g. singular initial Jacobian)
    engines = latdyn_engines()
    notes.append("latdyn solve.engine values accepted: " + (", ".join(e for e in engines if e) or "none (one engine)"))
    if ops is None:
        notes.append(lattice_problem.OPENSEES_MISSING)
        print("NOTE: " + lattice_problem.OPENSEES_MISSING, file=sys.stderr)
    info = machine()
    plan = [x for x in sweep(args.quick, engines) if x[0] in problems]
    # warm-up: compile/cache kernels, first imports; not timed
    warm = {}
    for problem, code, cfg in plan:
        key = (problem, code, cfg.get("engine"))
        if key not in warm:
            w = dict(cfg, t_end=0.5, elements=min(cfg["elements"], 4 if problem == "spinup" else 4))
            t0 = time.perf_counter()
            run_one(problem, code, w)
            warm[key] = time.perf_counter() - t0
    # repeats interleaved: pass r runs every setting once, so that a change of load on the
    # shared machine falls on every code and setting alike
    runs = [[] for _ in plan]
    for rep in range(repeats):
        for k, (problem, code, cfg) in enumerate(plan):
            if rep >= cfg.get("repeats", repeats):
                continue
            if rep > 0 and (runs[k][0].get("status") != "ok" or (runs[k][0].get("solver_s") or 0) >= LONG_RUN_S):
                continue
            res = run_one(problem, code, cfg)
            res["load"] = load1()
            runs[k].append(res)
            if rep == 0:
                print(f"  pass 1: {problem} {code} {cfg['label']}: {res.get('status')} "
                      f"{res.get('solver_s') or 0:.3f} s", file=sys.stderr, flush=True)
    rows = []
    for (problem, code, cfg), results in zip(plan, runs):
        last = results[-1]
        ok = [r for r in results if r.get("status") == "ok"]
        solver_all = [r["solver_s"] for r in results if r.get("solver_s") is not None]
        run_all = [r["run_s"] for r in results if r.get("run_s") is not None]
        engine, method, newton = describe(code, dict(cfg, problem=problem), last)
        row = {"problem": problem, "code": code, "engine": engine, "setting": cfg["label"],
               "elements": cfg["elements"], "dt": cfg["dt"], "t_end": cfg["t_end"], "method": method,
               "newton": newton, "status": "ok" if len(ok) == len(results) else last.get("status", "error"),
               "error": last.get("error"), "error_parts": last.get("error_parts", {}),
               "values": last.get("values", {}), "steps": last.get("steps"), "step_cuts": last.get("step_cuts"),
               "newton_iterations": last.get("newton_iterations"),
               "jacobian_updates": last.get("jacobian_updates"),
               "solver_s": statistics.median(solver_all) if solver_all else None, "solver_s_all": solver_all,
               "run_s": statistics.median(run_all) if run_all else None,
               "compile_s": last.get("compile_s"), "process_s": None,
               "load_average": float(np.mean([r["load"] for r in results])), "note": last.get("note", "")}
        if cfg.get("headline") and not args.quick and not args.no_process and row["status"] == "ok":
            row["process_s"] = process_time(problem, code, cfg)
        rows.append(row)
        err = "-" if row["error"] is None else f"{row['error']:.3g}"
        st = "-" if row["solver_s"] is None else f"{row['solver_s']:.3f}"
        print(f"{problem:10s} {code:6s} {cfg['label']:32s} {row['status']:6s} error {err:>9s}  solver {st:>8s} s  "
              f"steps {row['steps']}  newton {row['newton_iterations']}  jac {row['jacobian_updates']}  "
              f"load {row['load_average']:.2f}", flush=True)
    if "lattice" in problems:
        lattice_rows = lattice_sweep(bays_list, args.quick, repeats,
                                     log=lambda m: print(m, file=sys.stderr, flush=True))
        lat_matched = lattice_matched(lattice_rows, bays_list)
        if not args.quick and not args.no_process:
            lattice_process_times(lattice_rows, lat_matched)
        for row in lattice_rows:
            err = "-" if row["error"] is None else f"{row['error']:.3g}"
            st = "-" if row["solver_s"] is None else f"{row['solver_s']:.3f}"
            print(f"lattice    {row['code']:8s} {row['setting']:60s} {row['status']:6s} error {err:>9s}  "
                  f"solver {st:>8s} s  load {row['load_average']:.2f}", flush=True)
        rows += lattice_rows
    info["load_average_end"] = list(os.getloadavg())
    info["warm_up_s"] = {f"{p}/{c}" + (f"/{e}" if e else ""): round(v, 3) for (p, c, e), v in warm.items()}
    matched = matched_pairs(rows)
    if "lattice" in problems:
        matched += lat_matched
        for x in lat_matched:
            ratios = ", ".join(f"{p['code']} {p['engine']}: {p['ratio']:.2f}" for p in x["peers"] if "ratio" in p)
            print(f"matched lattice {x['bays']} bays: latdyn {x.get('latdyn_setting')} "
                  f"{x.get('latdyn_s') or float('nan'):.3f} s; latdyn / peer: {ratios or '-'}")
    for x in (m for m in matched if m["problem"] != "lattice"):
        print(f"matched {x['problem']}: latdyn {x['latdyn_setting']} {x['latdyn_s']:.3f} s vs Exudyn "
              f"{x['exudyn_setting']} {x['exudyn_s']:.3f} s: ratio {x['ratio']:.2f}")
    specs = {
               "spinup": {"scene": "examples/spinup.yaml", "t_end": 10.0, "reference": SPINUP_REF,
                          "error": "max(|v(5)-v5_ref|, |v(10)-v10_ref|, |min v - vmin_ref|), tip y in the hub frame",
                          "error_unit": "m", "tolerance": SPINUP_TOL},
               "cantilever": {"scene": "examples/benchmarks/D2_right_angle_cantilever.yaml", "t_end": 10.0,
                              "reference": CANTILEVER_REF, "published": CANTILEVER_PUBLISHED,
                              "error": "max of relative errors of the tip peak u3 (t<=10) and the elbow first "
                                       "peak u3 (t<=6), parabola-refined",
                              "error_unit": "relative", "tolerance": CANTILEVER_TOL},
             "lattice": {"scene": "benchmarks/lattice.py latdyn_scene(bays, elements, dt)", "bays": bays_list,
                         "t_end": "2 T (benchmarks/lattice.py equivalent_beam)",
                         "reference": {"file": "benchmarks/references/lattice.json",
                                       "how": lattice_problem.load_reference().get("how")},
                         "error": "max over the run's rows of |u - u_ref| / max |u_ref|, u the mean z-displacement "
                                  "of the four tip joints, u_ref the timoshenko reference history (cubic spline); "
                                  "OpenSeesPy rows also against the euler_bernoulli reference (error_parts)",
                         "error_unit": "relative", "tolerance": LATTICE_TOL}}
    out = Path(args.out)
    kept = []
    old = json.loads(out.with_suffix(".json").read_text()) if out.with_suffix(".json").exists() else None
    measured = {"created": None, "git": info.get("git"), "load_average_start": info["load_average_start"],
                "load_average_end": info["load_average_end"]}
    for name in problems:
        specs.get(name, {})["measured"] = measured   # which run measured a problem's rows
    if old is not None and set(problems) != {"spinup", "cantilever", "lattice"}:
        for name in old.get("problems", {}):
            if name not in problems:
                kept.append(name)
                specs[name] = old["problems"][name]
                specs[name].setdefault("measured", {"created": old.get("created"), "git": old["machine"].get("git"),
                                                    "load_average_start": old["machine"].get("load_average_start"),
                                                    "load_average_end": old["machine"].get("load_average_end")})
                rows = [r for r in old["rows"] if r["problem"] == name] + rows
                matched = [m for m in old["matched"] if m["problem"] == name] + matched
    if old is not None and "lattice" in problems and "lattice" in old.get("problems", {}):
        done = set(bays_list)
        old_rows = [r for r in old["rows"] if r["problem"] == "lattice" and r["bays"] not in done]
        if old_rows:
            sizes = sorted({r["bays"] for r in old_rows})
            rows = [r for r in rows if r["problem"] != "lattice"] + old_rows + \
                [r for r in rows if r["problem"] == "lattice"]
            matched = matched + [m for m in old["matched"] if m["problem"] == "lattice" and m["bays"] not in done]
            specs["lattice"]["bays"] = sorted(done | set(sizes))
            specs["lattice"]["measured_sizes"] = dict(old["problems"]["lattice"].get("measured_sizes") or {
                str(b): old["problems"]["lattice"].get("measured") for b in sizes})
            specs["lattice"]["measured_sizes"].update({str(b): measured for b in bays_list})
            when = old["problems"]["lattice"].get("measured", {}).get("created")
            notes.append(f"lattice rows of {sizes} bays kept from the run of {when} "
                         "(problems.lattice.measured_sizes)")
    if kept:
        notes.append("rows of " + ", ".join(f"{k} kept from the run of {specs[k]['measured']['created']}"
                                            for k in kept) + " (problems.NAME.measured)")
    matched = [m for m in matched if m["problem"] != "lattice"] + \
        sorted((m for m in matched if m["problem"] == "lattice"), key=lambda m: m["bays"])
    specs = {k: v for k, v in specs.items() if k in problems or k in kept}
    created = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    measured["created"] = created
    doc = {"schema": "latdyn-peers/1",
           "created": created,
           "mode": "quick" if args.quick else "full", "repeats": repeats, "machine": info, "notes": notes,
           "problems": specs, "rows": rows, "matched": matched}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps(doc, indent=1, default=float) + "\n")
    cols = ["problem", "code", "engine", "setting", "bays", "elements", "coordinates", "dt", "t_end", "method",
            "newton", "status", "error", "steps", "newton_iterations", "jacobian_updates", "solver_s", "run_s",
            "compile_s",
            "process_s", "load_average", "note"]
    with open(out.with_suffix(".csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {out.with_suffix('.json')} and .csv")
    return 0


def _fmt(x, spec):
    return "–" if x is None else format(x, spec)


def markdown(doc):
    """The tables of docs/performance.md from a peers.json document."""
    out = []
    m = doc["machine"]
    out.append(f"Machine: {m['cpu']}, {m['cores']} cores, {m['platform']}; Python {m['python']}, NumPy {m['numpy']}, "
               f"latdyn {m['latdyn']} (git {((m.get('git') or {}).get('head'))}"
               f"{', runtime edited in the working tree' if (m.get('git') or {}).get('runtime_dirty') else ''}), "
               f"Exudyn {m['exudyn']}. Load average at start {m['load_average_start'][0]:.2f}, "
               f"at end {m['load_average_end'][0]:.2f}. Run {doc['created']}, mode {doc['mode']}, "
               f"median of {doc['repeats']} timed runs.")
    for problem, spec in doc["problems"].items():
        if problem == "lattice":
            out.extend(lattice_markdown(doc))
            continue
        unit = spec["error_unit"]
        out.append("")
        out.append(f"#### {problem} (error: {spec['error']}; {unit}; tolerance {spec['tolerance']:g})")
        out.append("")
        out.append("| code | engine | setting | status | error | solver s | run s | process s | steps "
                   "| Newton it. | Jacobians | load |")
        out.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for r in doc["rows"]:
            if r["problem"] != problem:
                continue
            err = _fmt(r["error"], ".2e")
            if r["status"] != "ok":
                err = r["note"][:60] or r["status"]
            out.append(f"| {r['code']} | {r['engine']} | {r['setting']} | {r['status']} | {err} | "
                       f"{_fmt(r['solver_s'], '.3f')} | {_fmt(r['run_s'], '.3f')} | {_fmt(r['process_s'], '.2f')} | "
                       f"{_fmt(r['steps'], 'd')} | {_fmt(r['newton_iterations'], 'd')} | "
                       f"{_fmt(r['jacobian_updates'], 'd')} | {r['load_average']:.2f} |")
    if not any(m["problem"] != "lattice" for m in doc["matched"]):
        return "\n".join(out)
    out.append("")
    out.append("| problem | tolerance | latdyn setting | error | solver s | run s | Exudyn element | setting "
               "| error | solver s | run s | latdyn / Exudyn, solver | latdyn / Exudyn, run |")
    out.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for x in doc["matched"]:
        if x["problem"] == "lattice":
            continue
        out.append(f"| {x['problem']} | {x['tolerance']:g} | {x['latdyn_setting']} | {x['latdyn_error']:.2e} | "
                   f"{x['latdyn_s']:.3f} | {_fmt(x.get('latdyn_run_s'), '.3f')} | {x.get('exudyn_engine', '')} | "
                   f"{x['exudyn_setting']} | {x['exudyn_error']:.2e} | {x['exudyn_s']:.3f} | "
                   f"{_fmt(x.get('exudyn_run_s'), '.3f')} | **{x['ratio']:.2f}** | "
                   f"**{_fmt(x.get('ratio_run'), '.2f')}** |")
    return "\n".join(out)


def lattice_markdown(doc):
    """The lattice tables: the candidates of the search (per code, variant and element count the
    coarsest step within tolerance, timed ``repeats`` times; every run of the search is in
    peers.csv), then matched accuracy."""
    spec = doc["problems"]["lattice"]
    n_rows = sum(r["problem"] == "lattice" for r in doc["rows"])
    out = ["", f"#### lattice (error: {spec['error']}; tolerance {spec['tolerance']:g})", "",
           f"Candidates (the coarsest step within tolerance per code, variant and element count; all {n_rows} "
           f"runs of the search are in peers.csv):", "",
           "| bays | code | engine | setting | status | error | solver s | run s | process s | coordinates | steps "
           "| Newton it. | Jacobians | load |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["rows"]:
        if r["problem"] != "lattice" or not r.get("candidate"):
            continue
        err = _fmt(r["error"], ".2e")
        if r["status"] != "ok":
            err = (r["note"] or r["status"])[:60]
        elif r["code"] == "opensees":
            err += f" (EB {_fmt(r['error_parts'].get('history_vs_euler_bernoulli'), '.2e')})"
        setting = r["setting"]
        n_all = len(r.get("solver_s_all") or [])
        solver = _fmt(r["solver_s"], ".3f") + (f" ({n_all})" if n_all > 1 else "")
        out.append(f"| {r['bays']} | {r['code']} | {r['engine']} | {setting} | {r['status']} | {err} | {solver} | "
                   f"{_fmt(r['run_s'], '.3f')} | {_fmt(r['process_s'], '.2f')} | {_fmt(r.get('coordinates'), 'd')} | "
                   f"{_fmt(r['steps'], 'd')} | {_fmt(r['newton_iterations'], 'd')} | "
                   f"{_fmt(r['jacobian_updates'], 'd')} | {r['load_average']:.2f} |")
    out += ["", "| bays | latdyn setting | error | solver s | process s | peer | peer setting | error | solver s "
            "| process s | latdyn / peer, solver |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for x in doc["matched"]:
        if x["problem"] != "lattice":
            continue
        head = (f"| {x['bays']} | {x.get('latdyn_setting', '–')} | {_fmt(x.get('latdyn_error'), '.2e')} | "
                f"{_fmt(x.get('latdyn_s'), '.3f')} | {_fmt(x.get('latdyn_process_s'), '.2f')} | ")
        for p in x["peers"]:
            if p.get("setting"):
                out.append(head + f"{p['code']} {p['engine']} | {p['setting']} | {p['error']:.2e} | "
                           f"{p['solver_s']:.3f} | {_fmt(p.get('process_s'), '.2f')} | "
                           f"**{_fmt(p.get('ratio'), '.2f')}** |")
            else:
                out.append(head + f"{p['code']} {p['engine']} | {p.get('note', '')} | – | – | – | – |")
            own = p.get("own_physics")
            if own:
                out.append(head + f"{p['code']} {p['engine']}, against its own physics (Euler–Bernoulli reference) "
                           f"| {own['setting']} | {own['error']:.2e} | {own['solver_s']:.3f} | – | "
                           f"{_fmt(own.get('ratio'), '.2f')} |")
    return out


def reference_run():
    """Convergence of the cantilever peaks (t_end 10 s) with both codes; prints a table."""
    if exu is not None:
        _quiet_exudyn()
    plan = [("latdyn", dict(elements=n, dt=dt, t_end=10.0)) for n, dt in ((40, 0.0125), (80, 0.00625), (160, 0.00625))]
    if exu is not None:
        plan += [("exudyn", dict(elements=n, dt=dt, t_end=10.0, rho_inf=0.8, modified=True, atol=1e-6))
                 for n, dt in ((40, 0.005), (80, 0.0025), (160, 0.0025))]
    for code, cfg in plan:
        res = run_one("cantilever", code, cfg)
        v = res.get("values", {})
        print(f"{code:6s} {cfg['elements']:3d} el dt {cfg['dt']:<8g} {res['status']}  tip_max {v.get('tip_max'):.6f} "
              f"at {v.get('t_tip_max'):.4f}  elbow_max {v.get('elbow_max'):.6f} at {v.get('t_elbow_max'):.4f}  "
              f"{res.get('solver_s', 0):.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
