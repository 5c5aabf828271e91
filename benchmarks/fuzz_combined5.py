"""Outside check of main 86d57d9 (session 2026-11-28 thirteenth, helper fuzz9) where it is least checked: static
paths with sensitivities, adaptive steps with sensitivities, objectivity, resume, studies beside sensitivities.

Each case is a random 3D scene of one of three families:
- ``static``: a shallow arch (tilted, hinged or clamped, the load off the crown), a shallow star dome of beams
  (3–6 supports, crown load) or a toggle of two beams, under load control or arc length (through the limit point
  where it has one), its sensitivities along the path (the load factor's among them);
- ``adaptive``: a chain of 2–3 flexible beams on skew hinges (law springs in θ, dampers in θ̇, rest angles)
  from a fixed base, bodies with full 3×3 inertias, loads (force, moment) in t, gravity, an initial spin about
  the first hinge, sometimes a cable from an anchor, ``adaptive: true``;
- ``fixed``: the same chains on fixed steps (generalized-α, HHT-α, Newmark, ρ∞ 0.6).

Checks per case (a process of its own, ``--worker``):
(o) objectivity: the same scene rigidly rotated by a random R and translated by d (every point, hinge axis, beam
    ``y_axis``, inertia R I Rᵀ, load, gravity, initial velocity and its point moved): the sensitivities of the
    invariant probes (hinge angles, energies, tensions, the load factor) equal, of the points' positions and
    displacements (x, y, z of a point together) R times the original's, each relative to the output's largest
    over the rows, ≤ 1e-9 judged; the positions themselves R p + d;
(a) the adjoint (transient only) against the forward method (fuzz_combined4's comparison, ≤ 1e-9);
(b) the loop of steps on against every switch off (sha-256), the forward method;
(r) resume: the run interrupted (KeyboardInterrupt at the first step from t ≥ t_end/2, tests/resumed_runs.py's
    pattern) and resumed: sensitivities.csv, probes.csv and the summary's derivatives bit-equal (transient);
(d) ``latdyn run`` against the API (every ``--cli-every``-th case), sha-256;
(s) a study (STUDY.md) varying one sensitivity parameter over [p, p + h, p − h], ``solve.sensitivities`` kept:
    each case's sensitivities.csv bit-equal to the run's own at p, and its central difference of the end row
    against the sensitivity there (recorded);
(e) no traceback: an error that is not a SceneError/SolverError-style refusal is a crash; the worker's timeout.
(c) is ``--richardson SCENE OUT``: transient, benchmarks/fuzz_combined.richardson (end rows, runs taking other
    steps or events skipped); static, every row against Richardson of central differences of whole runs without
    sensitivities (h = 1e-3 p), the load factor among them (a path of another length skipped).

``python benchmarks/fuzz_combined5.py --runs 60 --seed 1 --keep DIR``; ``--show N``; ``--tally DIR``.
Not run by the suite.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import json
import math
import os
import random
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(1, str(ROOT / "tests"))

from benchmarks import fuzz_combined as base  # noqa: E402
from benchmarks import fuzz_combined4 as four  # noqa: E402

FAMILIES = ("static", "adaptive", "fixed")
#: (o)'s bound, relative to each output's largest |value| over the rows
BOUND = 1e-9


def _r(x: float) -> float:
    return float(round(x, 4))


def _unit(rng: random.Random) -> list[float]:
    v = [rng.gauss(0, 1) for _ in range(3)]
    n = math.sqrt(sum(c * c for c in v))
    return [_r(c / n) for c in v]


def _inertia(rng: random.Random) -> list[list[float]]:
    a = np.array([[rng.uniform(-1, 1) for _ in range(3)] for _ in range(3)])
    m = 0.004 * (a @ a.T) + 0.01 * np.eye(3)
    return [[float(round(m[i, j], 5)) for j in range(3)] for i in range(3)]


# ---------------------------------------------------------------------------------------------------- scenes

def _chain(rng: random.Random, adaptive: bool) -> dict:
    params = {"k": _r(rng.uniform(1.0, 4.0)), "EI": _r(rng.uniform(20.0, 60.0)), "rho": _r(rng.uniform(0.5, 1.5)),
              "m": _r(rng.uniform(0.2, 0.6)), "F": _r(rng.uniform(0.3, 1.0))}
    section = {"EA": 1.0e5, "EIy": "EI", "EIz": rng.choice(["EI", "1.3*EI"]), "GJ": "0.8*EI", "rhoA": "rho",
               "rhoIy": "0.01*rho", "rhoIz": "0.012*rho"}
    bodies = {"base": {"at": [0.0, 0.0, 0.0], "fixed": True}}
    beams, probes = {}, {}
    n = rng.randint(2, 3)
    at = [0.0, 0.0, 0.0]
    kinds = []
    for i in range(n):
        d = _unit(rng)
        length = rng.uniform(0.4, 0.8)
        at = [_r(a + length * c) for a, c in zip(at, d)]
        name = f"b{i}"
        bodies[name] = {"at": at, "mass": "m" if i == n - 1 else _r(rng.uniform(0.1, 0.4)), "inertia": _inertia(rng)}
        prev = "base" if i == 0 else f"b{i - 1}"
        beam = {"from": prev, "to": name, "section": "s", "elements": rng.randint(1, 2), "y_axis": _unit(rng)}
        if i == 0 or rng.random() < 0.6:
            hinge = {"axis": _unit(rng), "stiffness": rng.choice(["k", "k*(1 + 0.5*theta**2)"])}
            if rng.random() < 0.5:
                params["c"] = _r(rng.uniform(0.02, 0.1))
                hinge["damping"] = rng.choice(["c", "c*(1 + theta_dot**2)"])
                kinds.append("hinge damping")
            if rng.random() < 0.4:
                hinge["rest_angle"] = _r(rng.uniform(-0.5, 0.5))
            beam["start"] = {"hinge": hinge}
            probes[f"a{i}"] = {"hinge": f"l{i}.start", "quantity": "angle"}
        beams[f"l{i}"] = beam
    tip = f"b{n - 1}"
    for c in "xyz":
        probes[f"tip_{c}"] = {"point": tip, "quantity": "position", "component": c}
    mid = f"l{n - 1}.end" if rng.random() < 0.5 else "b0"
    for c in "xyz":
        probes[f"mid_{c}"] = {"point": mid, "quantity": "displacement", "component": c}
    d = _unit(rng)
    w = _r(rng.uniform(3.0, 8.0))
    loads = [{"at": tip, "force": [f"{c}*F*sin({w}*t)" if c else 0 for c in d]}]
    if rng.random() < 0.5:
        e = _unit(rng)
        loads[0]["moment"] = [f"{0.1 * c:.4f}*F*t" for c in e]
        kinds.append("moment in t")
    scene = {"title": "", "parameters": params, "sections": {"s": section}, "bodies": bodies, "beams": beams,
             "loads": loads}
    if rng.random() < 0.5:
        scene["gravity"] = [_r(rng.uniform(-3, 3)), _r(rng.uniform(-3, 3)), -9.81]
        kinds.append("gravity")
    if rng.random() < 0.4:
        axis = beams["l0"]["start"]["hinge"]["axis"]
        w0 = rng.uniform(0.5, 2.0)
        scene["initial_velocity"] = {"linear": [0.0, 0.0, 0.0], "angular": [_r(w0 * c) for c in axis],
                                     "about": [0.0, 0.0, 0.0]}
        kinds.append("initial spin")
    if rng.random() < 0.3:
        anchor = [_r(c + rng.uniform(-0.3, 0.3)) for c in at]
        anchor[2] = _r(anchor[2] + 0.3)
        bodies["anchor"] = {"at": anchor, "fixed": True}
        params["Lc"] = _r(math.dist(anchor, at) * rng.uniform(0.97, 1.0))
        scene["cables"] = {"c": {"from": "anchor", "to": tip, "EA": _r(rng.uniform(10, 60)), "rest_length": "Lc",
                                 "damping": _r(rng.uniform(0.0, 0.3))}}
        probes["ten"] = {"cable": "c", "quantity": "tension"}
        kinds.append("cable")
    if rng.random() < 0.5:
        probes["e_total"] = {"energy": rng.choice(["total", "kinetic", "strain"])}
        kinds.append("energy")
    solve = {"analysis": "transient", "dt": 0.02, "t_end": rng.choice([0.2, 0.3])}
    if adaptive:
        solve.update({"adaptive": True, "error_tol": rng.choice([1e-3, 3e-3])})
    else:
        solve.update(rng.choice([{}, {"method": "hht-alpha"}, {"method": "newmark"}, {"rho_inf": 0.6}]))
    names = list(params)
    rng.shuffle(names)
    solve["sensitivities"] = names[:rng.randint(1, min(6, len(names)))]
    scene["solve"] = solve
    scene["output"] = {"every": 0.02, "probes": probes}
    scene["title"] = ("adaptive" if adaptive else "fixed") + " chain + " + ", ".join(kinds)
    return scene


def _static(rng: random.Random) -> dict:
    kind = rng.choice(["arch", "dome", "toggle"])
    params = {"EI": _r(rng.uniform(0.5, 2.0)), "EA0": float(rng.choice([2e4, 5e4, 1e5])), "P": 1.0}
    section = {"EA": "EA0", "EIy": "EI", "EIz": rng.choice(["EI", "1.2*EI"]), "GJ": "0.8*EI", "rhoA": 0.1}
    bodies, beams, loads, probes = {}, {}, [], {}
    down = [0.0, 0.0, -1.0]
    if kind == "arch":
        half = rng.uniform(0.2, 0.4)
        n = 6
        angles = np.linspace(-half, half, n + 1)
        for i, a in enumerate(angles):
            bodies[f"n{i}"] = {"at": [_r(math.sin(a)), 0.0, _r(math.cos(a) - math.cos(half))]}
        for i in (0, n):
            bodies[f"n{i}"]["fixed"] = True
        hinged = rng.random() < 0.5
        for i in range(n):
            beam = {"from": f"n{i}", "to": f"n{i + 1}", "section": "s", "elements": 2, "y_axis": [0.0, 0.0, 1.0]}
            if hinged and i == 0:
                beam["start"] = {"hinge": {"axis": [0.0, 1.0, 0.0]}}
            if hinged and i == n - 1:
                beam["end"] = {"hinge": {"axis": [0.0, 1.0, 0.0]}}
            beams[f"s{i}"] = beam
        at = rng.choice(["n3", "n3", "n2"])
        loads.append({"at": at, "force": [0, 0, "-P"]})
        probes["crown_z"] = {"point": "n3", "quantity": "displacement", "component": "z"}
        probes["n2_x"] = {"point": "n2", "quantity": "displacement", "component": "x"}
        probes["n2_y"] = {"point": "n2", "quantity": "displacement", "component": "y"}
        probes["n2_z"] = {"point": "n2", "quantity": "displacement", "component": "z"}
        steps = 10
    elif kind == "dome":
        legs = rng.randint(3, 6)
        radius, rise = 1.0, _r(rng.uniform(0.08, 0.16))
        bodies["crown"] = {"at": [0.0, 0.0, rise]}
        for i in range(legs):
            phi = 2 * math.pi * i / legs + rng.uniform(-0.1, 0.1)
            bodies[f"f{i}"] = {"at": [_r(radius * math.cos(phi)), _r(radius * math.sin(phi)), 0.0], "fixed": True}
            beams[f"l{i}"] = {"from": f"f{i}", "to": "crown", "section": "s", "elements": 2,
                              "y_axis": [0.0, 0.0, 1.0]}
        loads.append({"at": "crown", "force": [_r(rng.uniform(-0.05, 0.05)), 0, "-P"]})
        probes["crown_x"] = {"point": "crown", "quantity": "displacement", "component": "x"}
        probes["crown_y"] = {"point": "crown", "quantity": "displacement", "component": "y"}
        probes["crown_z"] = {"point": "crown", "quantity": "displacement", "component": "z"}
        steps = 10
    else:
        rise = _r(rng.uniform(0.05, 0.12))
        bodies.update({"a": {"at": [-1.0, 0.0, 0.0], "fixed": True}, "b": {"at": [1.0, 0.0, 0.0], "fixed": True},
                       "top": {"at": [0.0, 0.0, rise]}})
        for name, end in (("left", "a"), ("right", "b")):
            beams[name] = {"from": end, "to": "top", "section": "s", "elements": 3, "y_axis": [0.0, 0.0, 1.0]}
        loads.append({"at": "top", "force": [0, _r(rng.uniform(-0.02, 0.02)), "-P"]})
        probes["top_x"] = {"point": "top", "quantity": "displacement", "component": "x"}
        probes["top_y"] = {"point": "top", "quantity": "displacement", "component": "y"}
        probes["top_z"] = {"point": "top", "quantity": "displacement", "component": "z"}
        steps = 8
    method = rng.choice(["arc-length", "arc-length", "load-control"])
    scene = {"title": f"static {kind} {method}", "parameters": params, "sections": {"s": section},
             "bodies": bodies, "beams": beams, "loads": loads}
    # the load's scale: the shallow truss's limit load 2/(3√3)·EA·(h/L)³ per member (the arch's: 40 EI, measured),
    # beyond it under arc length (a snap-through on the path), half of it under load control (below it)
    if kind == "arch":
        limit = 40.0 * params["EI"]
    else:
        members = len(beams)
        h = bodies["top" if kind == "toggle" else "crown"]["at"][2]
        limit = members * 2 / (3 * math.sqrt(3)) * params["EA0"] * (h / math.hypot(1.0, h)) ** 3
    scale = _r(limit * (rng.uniform(1.1, 1.6) if method == "arc-length" else rng.uniform(0.3, 0.6)))
    loads[0]["force"] = [f"-{scale}*P" if c == "-P" else c for c in loads[0]["force"]]
    solve = {"analysis": "static", "method": method, "steps": steps}
    if method == "arc-length":
        solve["max_steps"] = 300
    names = ["EI", "EA0", "P"]
    rng.shuffle(names)
    solve["sensitivities"] = names[:rng.randint(1, 3)]
    scene["solve"] = solve
    scene["output"] = {"probes": probes}
    return scene


def random_scene(rng: random.Random, family: str) -> dict:
    if family == "static":
        return _static(rng)
    return _chain(rng, family == "adaptive")


# ---------------------------------------------------------------------------------------------------- moving

def rotation(rng: random.Random) -> tuple[np.ndarray, np.ndarray]:
    q = np.array([rng.gauss(0, 1) for _ in range(4)])
    w, x, y, z = q / np.linalg.norm(q)
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    d = np.array([rng.uniform(-1, 1) for _ in range(3)])
    return R, d


def _vector(R: np.ndarray, v: list, d: np.ndarray | None = None) -> list:
    """R v (+ d): numbers where v is numbers, else expressions."""
    if all(isinstance(c, (int, float)) for c in v):
        out = R @ np.array(v, dtype=float) + (d if d is not None else 0.0)
        return [float(c) for c in out]
    out = []
    for i in range(3):
        terms = [f"({float(R[i, j])!r})*({v[j]})" for j in range(3) if not (isinstance(v[j], (int, float)) and v[j] == 0)]
        if d is not None:
            terms.append(repr(float(d[i])))
        out.append(" + ".join(terms) if terms else 0.0)
    return out


def moved(scene: dict, R: np.ndarray, d: np.ndarray) -> dict:
    """``scene`` rotated by R and translated by d (everything SCENE.md places in the global axes)."""
    s = json.loads(json.dumps(scene))
    for body in s["bodies"].values():
        body["at"] = _vector(R, body["at"], d)
        if "inertia" in body:
            body["inertia"] = [[float(c) for c in row] for row in R @ np.array(body["inertia"]) @ R.T]
    for beam in s["beams"].values():
        if "y_axis" in beam:
            beam["y_axis"] = _vector(R, beam["y_axis"])
        for end in ("start", "end"):
            h = (beam.get(end) or {}).get("hinge") if isinstance(beam.get(end), dict) else None
            if h:
                h["axis"] = _vector(R, h["axis"])
    for load in s.get("loads", []):
        for key in ("force", "moment"):
            if key in load:
                load[key] = _vector(R, load[key])
    if "gravity" in s:
        s["gravity"] = _vector(R, s["gravity"])
    if "initial_velocity" in s:
        v = s["initial_velocity"]
        v["linear"] = _vector(R, v["linear"])
        v["angular"] = _vector(R, v["angular"])
        v["about"] = _vector(R, v["about"], d)
    return s


def objectivity(original, turned, R: np.ndarray, d: np.ndarray, original_kinds: dict) -> dict:
    """(o): per output the largest difference relative to its largest |value| over the rows."""
    worst, where = 0.0, None
    probes = original.probes
    groups = {}
    for name in probes:
        if name[-2:] in ("_x", "_y", "_z"):
            groups.setdefault(name[:-2], []).append(name)
    vector_names = {n for g in groups.values() for n in g}

    def note(err, label):
        nonlocal worst, where
        if not err <= worst:
            worst, where = err, label

    def rel(a, b):
        scale = max(np.abs(a).max(), np.abs(b).max(), 1e-300)
        return float(np.abs(a - b).max() / scale)

    if len(original.t) != len(turned.t):
        return {"worst": float("inf"), "where": f"rows {len(original.t)} != {len(turned.t)}"}
    note(rel(original.t, turned.t), "t/load_factor")
    names = sorted({p for (_, p) in original.sensitivities})
    for name in probes:
        if name not in vector_names:
            # an energy's potential of gravity is measured from the origin, which the translation moves: its
            # change from the start is invariant, not its value
            moved_by = (lambda x: x - x[0]) if original_kinds.get(name) in ("total", "potential") else (lambda x: x)
            note(rel(moved_by(probes[name]), moved_by(turned.probes[name])), name)
            for p in names:
                if (name, p) in original.sensitivities:
                    note(rel(moved_by(original.sensitivities[(name, p)]),
                             moved_by(turned.sensitivities[(name, p)])), f"{name}/{p}")
    for g, members in groups.items():
        if len(members) != 3:
            continue
        xyz = [f"{g}_{c}" for c in "xyz"]
        vals = np.array([probes[n] for n in xyz])
        positions = original_kinds.get(xyz[0]) == "position"   # positions move by d, displacements do not
        expected = R @ vals + (d.reshape(3, 1) if positions else 0.0)
        got = np.array([turned.probes[n] for n in xyz])
        note(rel(expected, got), f"{g} (R p + d)")
        for p in names:
            if (xyz[0], p) in original.sensitivities:
                sv = R @ np.array([original.sensitivities[(n, p)] for n in xyz])
                st = np.array([turned.sensitivities[(n, p)] for n in xyz])
                note(rel(sv, st), f"{g}/{p}")
    if "load_factor" in {k for (k, _) in original.sensitivities}:
        for p in names:
            note(rel(original.sensitivities[("load_factor", p)], turned.sensitivities[("load_factor", p)]),
                 f"load_factor/{p}")
    return {"worst": worst, "where": where}


# ---------------------------------------------------------------------------------------------------- worker

def _result(data: dict, out: Path | None = None):
    import latdyn

    try:
        return latdyn.run(latdyn.load_scene(json.loads(json.dumps(data))), out), None
    except Exception as e:   # noqa: BLE001
        import traceback

        return None, {"error": f"{type(e).__name__}: {e}"[:400], "error_kind": type(e).__name__,
                      "where": traceback.format_exc()[-600:]}


def _resumed(data: dict, out: Path) -> dict:
    """(r): interrupted at the first step from t ≥ t_end/2 and resumed (tests/resumed_runs.py's pattern)."""
    import latdyn
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    import latdyn.timeloop.transient as transient

    t_stop = data["solve"]["t_end"] / 2
    originals = {name: getattr(CompiledGeneralizedAlpha, name) for name in ("step", "advance")}

    def stopping(name):
        def call(self, state, *args, **kwargs):
            if state.t >= t_stop:
                raise KeyboardInterrupt
            return originals[name](self, state, *args, **kwargs)
        return call

    budget = transient.LOOP_BUDGET_S
    note = {}
    for name in originals:
        setattr(CompiledGeneralizedAlpha, name, stopping(name))
    transient.LOOP_BUDGET_S = 1e-12
    try:
        latdyn.run(latdyn.load_scene(json.loads(json.dumps(data))), out)
        note["resume_note"] = "not interrupted"
    except KeyboardInterrupt:
        pass
    except Exception as e:   # noqa: BLE001
        note["resume_error"] = f"interrupted run: {type(e).__name__}: {e}"[:300]
    finally:
        for name, f in originals.items():
            setattr(CompiledGeneralizedAlpha, name, f)
        transient.LOOP_BUDGET_S = budget
    try:
        latdyn.run(latdyn.load_scene(json.loads(json.dumps(data))), out, resume=True)
        note["digest"] = base._digest(out)
    except Exception as e:   # noqa: BLE001
        note["resume_error"] = f"{type(e).__name__}: {e}"[:300]
    return note


def _study(data: dict, case: Path, result) -> dict:
    """(s): a study varying one sensitivity parameter over [p, p + h, p − h], solve.sensitivities kept."""
    import yaml

    import latdyn

    name = data["solve"]["sensitivities"][0]
    v = float(data["parameters"][name])
    h = 1e-4 * abs(v)
    (case / "study_scene.yaml").write_text(four._dump(data))
    probe = next(iter(data["output"]["probes"]))
    study = {"title": "fuzz9", "scene": "study_scene.yaml", "vary": {f"parameters.{name}": [v, v + h, v - h]},
             "reference": {"overrides": {f"parameters.{name}": v}}, "error": {"probe": probe, "norm": "final"}}
    (case / "study.yaml").write_text(yaml.safe_dump(study, sort_keys=False))
    try:
        table = latdyn.study(str(case / "study.yaml"), out=str(case / "study"))
    except Exception as e:   # noqa: BLE001
        return {"error": f"{type(e).__name__}: {e}"[:400], "error_kind": type(e).__name__}
    record = {"name": name}
    with open(case / "study" / "study.csv") as f:
        rows = list(csv.DictReader(f))
    record["status"] = [r["status"] for r in rows]
    record["messages"] = sorted({r["message"][:300] for r in rows if r["message"]})

    def columns(folder: Path, name_: str) -> dict:
        with open(folder / name_) as f:
            table = list(csv.reader(f))
        return {h: [r[i] for r in table[1:]] for i, h in enumerate(table[0]) if not h.startswith("_study_")}

    own_sens, own_probes = columns(case / "api", "sensitivities.csv"), columns(case / "api", "probes.csv")
    ends, slopes = {}, None
    for folder in sorted((case / "study" / "cases").glob("*")):
        value = json.loads((folder / "case.json").read_text())["overrides"][f"parameters.{name}"]
        if not (folder / "probes.csv").exists():
            continue
        ends[value] = {k: float(c[-1]) for k, c in columns(folder, "probes.csv").items() if k != "t"}
        if value == v:
            record["own_probes_same"] = columns(folder, "probes.csv") == own_probes
            if (folder / "sensitivities.csv").exists():
                record["own_sensitivities_same"] = columns(folder, "sensitivities.csv") == own_sens
    if len(ends) == 3:
        slopes = {}
        for k in ends[v]:
            fd = (ends[v + h][k] - ends[v - h][k]) / (2 * h)
            col = own_sens.get(f"{k}/{name}")
            if col is not None:
                ref = float(col[-1])
                scale = max(max(abs(float(x)) for x in col), 1e-300)
                slopes[k] = [fd, ref, abs(fd - ref) / scale]
    record["slopes"] = slopes
    return record


def worker(scene_path: Path, case: Path, family: str, study: bool, seed: str) -> dict:
    import yaml

    data = yaml.safe_load(scene_path.read_text())
    record: dict = {"family": family}
    result, err = _result(data, case / "api")
    if err:
        record["forward"] = err
        return record
    record["forward"] = {"digest": base._digest(case / "api"), "steps": result.summary.get("steps"),
                         "rejected": result.summary.get("rejected_steps"), "status": result.summary.get("status")}
    # (o) objectivity
    R, d = rotation(random.Random(seed + "-R"))
    turned_data = moved(data, R, d)
    (case / "turned.yaml").write_text(four._dump(turned_data))
    turned, err = _result(turned_data, case / "turned")
    record["o"] = err if err else objectivity(result, turned, R, d, {
        k: v.get("quantity", v.get("energy")) for k, v in data["output"]["probes"].items()})
    if family != "static":
        # (b) loop off
        four._switches(False)
        off, err = _result(data, case / "off")
        four._switches(True)
        record["off"] = err if err else {"digest": base._digest(case / "off")}
        # (a) adjoint
        adjoint = json.loads(json.dumps(data))
        adjoint["solve"]["sensitivity_method"] = "adjoint"
        (case / "adjoint.yaml").write_text(four._dump(adjoint))
        res, err = _result(adjoint, case / "adjoint")
        if err:
            record["adjoint"] = err
        else:
            fd = dict(base._digest(case / "api"), raw_probe_sensitivities=result.summary.get("probe_sensitivities"),
                      raw_event_sensitivities=result.summary.get("event_sensitivities"))
            adg = dict(base._digest(case / "adjoint"), raw_probe_sensitivities=res.summary.get("probe_sensitivities"),
                       raw_event_sensitivities=res.summary.get("event_sensitivities"))
            record["adjoint"] = {"digest": base._digest(case / "adjoint")}
            record["a"] = four._compare(fd, adg)
            record["a"]["probes_same"] = fd["probes.csv"] == adg["probes.csv"]
        # (r) resume
        record["resume"] = _resumed(data, case / "resumed")
    else:
        # static: a run without sensitivities takes the same path (arc length: the same rows)
        plain = json.loads(json.dumps(data))
        del plain["solve"]["sensitivities"]
        p, err = _result(plain, case / "plain")
        record["plain_same_rows"] = None if err else bool(
            np.array_equal(p.t, result.t) and all(np.array_equal(p.probes[k], result.probes[k]) for k in p.probes))
    if study:
        record["study"] = _study(data, case, result)
    return record


def judge(record: dict) -> list[str]:
    problems = []
    crash = lambda r: isinstance(r, dict) and "error" in r and r.get("error_kind") not in four.CLEAN  # noqa: E731
    for key in ("forward", "o", "off", "adjoint"):
        if crash(record.get(key)):
            problems.append(f"{key} crash: {record[key]['error'][:200]}")
    if "error" in record.get("forward", {}):
        return problems
    f = record["forward"]["digest"]
    o = record.get("o", {})
    if "error" in o:
        problems.append(f"turned scene: {o['error'][:150]}")
    elif not o.get("worst", 0.0) <= BOUND:
        problems.append(f"objectivity {o['worst']:.2e} at {o['where']}")
    off = record.get("off")
    if off is not None:
        if "error" in off:
            problems.append(f"loop off: {off['error'][:150]}")
        else:
            problems += _differing(off["digest"], f, "loop off != on")
    a = record.get("a")
    if a:
        if a["missing"]:
            problems.append(f"adjoint lacks {a['missing'][:5]}")
        if not a["worst"] <= four.BOUND:
            problems.append(f"adjoint vs forward {a['worst']:.2e} at {a['where']}")
        if not a["probes_same"]:
            problems.append("adjoint's probes.csv differs")
    r = record.get("resume")
    if r is not None:
        if "resume_error" in r:
            problems.append(f"resume: {r['resume_error'][:150]}")
        elif "digest" in r:
            problems += _differing(r["digest"], f, "resumed != whole")
    if record.get("plain_same_rows") is False:
        problems.append("static: the run without sensitivities takes other rows")
    s = record.get("study")
    if s is not None:
        if "error" in s:
            problems.append(f"study: {s['error'][:200]}")
        elif any(st != "solved" for st in s["status"]):
            problems.append(f"study: cases {s['status']}: {s['messages'][:1]}")
        elif not (s.get("own_probes_same") and s.get("own_sensitivities_same")):
            problems.append(f"study: the case at p is not the run's own (probes {s.get('own_probes_same')}, "
                            f"sensitivities {s.get('own_sensitivities_same')})")
    cli = record.get("cli")
    if cli is not None:
        if "error" in cli:
            problems.append(f"cli: {cli['error'][-200:]}")
        else:
            problems += _differing(cli["digest"], f, "cli != api")
    return problems


def _differing(digest: dict, whole: dict, what: str) -> list[str]:
    """The files and summary keys (fuzz_combined4.COMPARED) whose sha-256 differ from the whole run's."""
    return [f"{what}: {key}" for key in four.COMPARED if digest[key] != whole[key]]


def _cli(case: Path, env: dict, timeout: float) -> dict:
    import subprocess

    out = case / "cli"
    try:
        c = subprocess.run([sys.executable, "-m", "latdyn", "run", str(case / "scene.yaml"), "-o", str(out), "-q"],
                           env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": "timeout"}
    if c.returncode != 0:
        return {"error": f"exit {c.returncode}: {c.stderr[-300:]}", "traceback": "Traceback" in c.stderr}
    return {"digest": base._digest(out)}


def _run_worker(case: Path, env: dict, timeout: float, family: str, study: bool, seed: str) -> dict:
    import subprocess

    try:
        w = subprocess.run([sys.executable, __file__, "--worker", str(case / "scene.yaml"), str(case), family,
                            "1" if study else "0", seed], env=env, capture_output=True, text=True, timeout=timeout)
        line = [x for x in w.stdout.splitlines() if x.startswith("RECORD ")]
        return json.loads(line[-1][7:]) if line else {"worker_error": w.stderr[-800:]}
    except subprocess.TimeoutExpired:
        return {"worker_error": "timeout"}


# ---------------------------------------------------------------------------------------------------- (c)

def richardson_static(scene_path: Path, out: Path, step: float = 1e-3) -> dict:
    """(c), static: every row of the sensitivities (the load factor's among them) against Richardson of central
    differences of whole runs without sensitivities; relative to each output's largest."""
    import yaml

    import latdyn

    scene = yaml.safe_load(scene_path.read_text())
    result = latdyn.run(latdyn.load_scene(json.loads(json.dumps(scene))))
    record = {"worst": 0.0, "skipped": [], "errors": {}}
    for name in scene["solve"]["sensitivities"]:
        v = float(scene["parameters"][name])
        central = []
        for h in (step * abs(v), step * abs(v) / 2):
            runs = []
            for dv in (h, -h):
                s = json.loads(json.dumps(scene))
                del s["solve"]["sensitivities"]
                s["parameters"][name] = v + dv
                runs.append(latdyn.run(latdyn.load_scene(s)))
            if len(runs[0].t) != len(result.t) or len(runs[1].t) != len(result.t):
                break
            diff = {k: (runs[0].probes[k] - runs[1].probes[k]) / (2 * h) for k in result.probes}
            diff["load_factor"] = (runs[0].t - runs[1].t) / (2 * h)
            central.append(diff)
        if len(central) < 2:
            record["skipped"].append(name)
            continue
        for k in central[0]:
            ref = (4 * central[1][k] - central[0][k]) / 3
            got = result.sensitivities.get((k, name))
            if got is None:
                continue
            scale = max(np.abs(ref).max(), np.abs(got).max(), 1e-300)
            err = float(np.abs(got - ref).max() / scale)
            spread = float(np.abs(central[1][k] - central[0][k]).max() / scale)
            record["errors"][f"{k}/{name}"] = [err, spread]
            record["worst"] = max(record["worst"], err)
    return record


# ---------------------------------------------------------------------------------------------------- tally

def tally_records(folders: list[Path]) -> dict:
    counts = {"cases": 0, "families": {}, "solved": {}, "refused": {}, "problems": [], "worker_errors": [],
              "objectivity_worst": {}, "adjoint_solved": 0, "adjoint_refused": {}, "adjoint_worst": 0.0,
              "resumed_same": 0, "resume_notes": {}, "cli_checked": 0, "studies": 0, "steps": 0, "rejected": 0,
              "events": 0}
    for folder in folders:
        for path in sorted(folder.glob("*/record.json")):
            r = json.loads(path.read_text())
            counts["cases"] += 1
            fam = r.get("family", "?")
            counts["families"][fam] = counts["families"].get(fam, 0) + 1
            if "worker_error" in r:
                counts["worker_errors"].append([path.parent.name, r["worker_error"][-200:]])
                continue
            if "error" in r["forward"]:
                head = r["forward"]["error"][:140]
                counts["refused"][head] = counts["refused"].get(head, 0) + 1
            else:
                counts["solved"][fam] = counts["solved"].get(fam, 0) + 1
                counts["steps"] += r["forward"].get("steps") or 0
                counts["rejected"] += r["forward"].get("rejected") or 0
                counts["events"] += len(r["forward"]["digest"]["events"])
                o = r.get("o", {})
                if "worst" in o:
                    counts["objectivity_worst"][fam] = max(counts["objectivity_worst"].get(fam, 0.0), o["worst"])
            ad = r.get("adjoint")
            if ad is not None:
                if "error" in ad:
                    head = ad["error"][:120]
                    counts["adjoint_refused"][head] = counts["adjoint_refused"].get(head, 0) + 1
                else:
                    counts["adjoint_solved"] += 1
                    counts["adjoint_worst"] = max(counts["adjoint_worst"], r["a"]["worst"])
            res = r.get("resume")
            if res is not None and "digest" in res:
                counts["resumed_same"] += all(res["digest"][k] == r["forward"]["digest"][k] for k in four.COMPARED)
            if res is not None and "resume_note" in res:
                counts["resume_notes"][res["resume_note"]] = counts["resume_notes"].get(res["resume_note"], 0) + 1
            counts["cli_checked"] += "cli" in r
            counts["studies"] += "study" in r and "error" not in r["study"]
            problems = judge(r)
            if problems:
                counts["problems"].append([path.parent.name, problems])
    return counts


def main(argv=None) -> int:
    import yaml

    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=Path("/tmp/fuzz9"))
    parser.add_argument("--show", type=int)
    parser.add_argument("--timeout", type=float, default=300)
    parser.add_argument("--cli-every", type=int, default=3)
    parser.add_argument("--study-every", type=int, default=4)
    parser.add_argument("--family", choices=FAMILIES, help="only this family (default: in turn)")
    parser.add_argument("--worker", nargs=5)
    parser.add_argument("--richardson", nargs=2, help="SCENE OUT: (c) for one scene")
    parser.add_argument("--step", type=float, default=1e-3)
    parser.add_argument("--tally", nargs="+", type=Path)
    args = parser.parse_args(argv)
    if args.tally:
        print(json.dumps(tally_records(args.tally), indent=1))
        return 0
    if args.worker:
        scene, case, family, study, seed = args.worker
        print("RECORD " + json.dumps(worker(Path(scene), Path(case), family, study == "1", seed)))
        return 0
    if args.richardson:
        scene = yaml.safe_load(Path(args.richardson[0]).read_text())
        f = richardson_static if scene["solve"]["analysis"] == "static" else base.richardson
        print(json.dumps(f(Path(args.richardson[0]), Path(args.richardson[1]), args.step), indent=1))
        return 0

    def case_of(n):
        family = args.family or FAMILIES[n % 3]
        seed = f"fuzz9-{args.seed}-{n}"
        return family, seed, random_scene(random.Random(seed), family)

    if args.show is not None:
        print(four._dump(case_of(args.show)[2]))
        return 0
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    tally: dict[str, int] = {}
    for n in range(args.first, args.first + args.runs):
        family, seed, data = case_of(n)
        case = args.keep / f"s{args.seed}-{n}"
        case.mkdir(parents=True, exist_ok=True)
        (case / "scene.yaml").write_text(four._dump(data))
        start = time.time()
        study = family != "static" and n % args.study_every == 1
        record = _run_worker(case, env, args.timeout, family, study, seed)
        if "worker_error" not in record and "digest" in record.get("forward", {}) and n % args.cli_every == 0:
            record["cli"] = _cli(case, env, args.timeout)
        problems = judge(record) if "worker_error" not in record else ["worker: " + record["worker_error"][-200:]]
        record["problems"] = problems
        (case / "record.json").write_text(json.dumps(record, indent=1))
        outcome = "PROBLEM" if problems else "ok"
        tally[outcome] = tally.get(outcome, 0) + 1
        f = record.get("forward", {})
        print(f"{n}: {outcome} {time.time() - start:.0f}s {family} {data['title'][:60]} steps {f.get('steps')} "
              f"fwd {f.get('error', 'ok')[:90]} o {record.get('o', {}).get('worst')} "
              f"adj {record.get('adjoint', {}).get('error', 'ok')[:60]} a {record.get('a', {}).get('worst')} "
              f"{problems}", flush=True)
    print(json.dumps(tally))
    return 0


if __name__ == "__main__":
    sys.exit(main())
