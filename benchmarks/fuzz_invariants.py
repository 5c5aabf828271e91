"""Whole-run fuzzing judged by invariants: what a random run must satisfy beyond ending well.

``benchmarks/fuzz_runs.py`` judges how a run ends (exit status, message, a results folder that reads
back); a run can end well and still be wrong. Each case here is a scene of the same generator
(:func:`fuzz_runs.random_scene`, with ``--joints`` the cables, guides, contact, friction, inputs and
controllers too), run through ``latdyn run`` and checked against what the scene makes exact:

=====================  ===========================================================================
``objectivity``        the scene turned rigidly by the rotation P that takes x to y, y to z and z to x
                       (every point, axis, vector, body inertia and probe component moved with it;
                       a beam's default ``y_axis`` written out turned) gives the turned results: the
                       same outcome, and probes, frequencies, buckling factor equal to
                       :data:`OBJECTIVITY_TOL` of each probe's magnitude. P permutes coordinates, so
                       the turned scene's numbers are exactly the scene's.
``api``                ``latdyn.run(latdyn.load_scene(SCENE))`` gives what ``latdyn run SCENE`` wrote,
                       to :data:`API_TOL` (the same code; bit for bit expected).
``momentum``           a free structure (a root body with mass, no ground, no guide on the ground)
                       without gravity or loads keeps its linear momentum (every force inside it is
                       internal: hinge laws, controllers, cables, stops, friction), to
                       :data:`MOMENTUM_TOL` of the momentum scale ``sqrt(2 M max(kinetic energy))``;
                       its angular momentum about the origin is reported (the Lie-group step keeps it
                       to its own error, not exactly).
``energy``             the energy balance the run reports (summary ``energy_balance_error``) agrees
                       with its probes: ``created = E − E0 − W + D`` from the total, external work and
                       dissipated energy probes, relative to the same scale, is not larger than the
                       summary says (to :data:`ENERGY_SLACK`).
``kinematics``         a point's recorded position changes as its recorded velocity integrates
                       (the trapezoid over the rows; :data:`KINEMATICS_TOL` of the path's length,
                       rows every step).
=====================  ===========================================================================

The check's probes (``inv_*``: linear and angular momentum, the energies, a point's position and
velocity) are added to every transient scene before it runs. A case whose first run is refused or
fails has nothing to check but how it ended (``fuzz_runs.judge``).

``python benchmarks/fuzz_invariants.py --runs 40 --seed 401 --joints`` runs a campaign; ``--keep DIR``
saves each finding's scene (and its turned scene).
"""
from __future__ import annotations

import argparse
import collections
import copy
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from benchmarks import fuzz_runs  # noqa: E402

#: relative difference (to each probe's largest magnitude over both runs) the turned run may show
OBJECTIVITY_TOL = 1e-6
#: probes below this magnitude in both runs are round-off about zero, not compared
NOISE = 1e-9
#: the turned run's first rows (:data:`EARLY_ROWS` after t = 0) agree to this where a difference
#: grows from round-off; a wrong frame or axis shows at once
EARLY_TOL = 1e-9
EARLY_ROWS = 3
#: CLI against API
API_TOL = 1e-12
#: linear momentum drift, relative to the momentum scale
MOMENTUM_TOL = 1e-6
#: the energy balance error past which a run warns that it drifts (latdyn's warning, 0.01)
DRIFT_WARNED = 1e-2
#: the order at and above which a drifting momentum falls with the step (dt/2 to dt/4)
STEP_ORDER = 1.0
#: the probes' energy balance may exceed the summary's energy_balance_error by this (relative)
ENERGY_SLACK = 1e-6
#: a point's position change against its integrated velocity, relative to its path's length
KINEMATICS_TOL = 0.05

#: the coordinate permutation P: (P v)[i] = v[_FROM[i]] (x -> y, y -> z, z -> x)
_FROM = (2, 0, 1)
_COMPONENT = {"x": "y", "y": "z", "z": "x"}


# =========================================================================== the turned scene
def _turn(v):
    """P v for a 3-list (numbers or expressions: the entries move)."""
    if isinstance(v, list) and len(v) == 3:
        return [v[j] for j in _FROM]
    return v


def _turn_point(p):
    if isinstance(p, list):
        return _turn(p)
    if isinstance(p, dict) and "offset" in p:
        return {**p, "offset": _turn(p["offset"])}
    return p


def _turn_inertia(inertia):
    if isinstance(inertia, list) and len(inertia) == 3 and all(isinstance(r, list) for r in inertia):
        # P I Pᵀ: (P I Pᵀ)[i][j] = I[_FROM[i]][_FROM[j]]
        return [[inertia[a][b] for b in _FROM] for a in _FROM]
    return _turn(inertia)


def _turn_hinge_like(law: dict) -> dict:
    law = dict(law)
    if "axis" in law:
        law["axis"] = _turn(law["axis"])
    return law


def turned_scene(scene: dict, y_axes: dict) -> dict:
    """``scene`` turned by P; ``y_axes``: each beam's y axis as the loader made it (a list of 3 floats),
    written out turned so that its default (from the global Z) does not change with the turn."""
    s = copy.deepcopy(scene)
    for body in s.get("bodies", {}).values():
        body["at"] = _turn(body["at"])
        if "com" in body:
            body["com"] = _turn(body["com"])
        if "inertia" in body:
            body["inertia"] = _turn_inertia(body["inertia"])
        motion = body.get("motion")
        if motion:
            if "translation" in motion:
                motion["translation"] = _turn(motion["translation"])
            if "rotation" in motion:
                motion["rotation"] = _turn_hinge_like(motion["rotation"])
        if "guide" in body:
            body["guide"] = _turn_hinge_like(body["guide"])
    for name, beam in s.get("beams", {}).items():
        beam["from"], beam["to"] = _turn_point(beam["from"]), _turn_point(beam["to"])
        if name in y_axes:
            beam["y_axis"] = _turn([float(x) for x in y_axes[name]])
        for end in ("start", "end"):
            if isinstance(beam.get(end), dict) and "hinge" in beam[end]:
                beam[end] = {**beam[end], "hinge": _turn_hinge_like(beam[end]["hinge"])}
    for cable in s.get("cables", {}).values():
        cable["from"], cable["to"] = _turn_point(cable["from"]), _turn_point(cable["to"])
    if "gravity" in s:
        s["gravity"] = _turn(s["gravity"])
    velocity = s.get("initial_velocity")
    if velocity:
        for key in ("linear", "angular", "about"):
            if key in velocity:
                velocity[key] = _turn(velocity[key])
    for load in s.get("loads", []):
        for key in ("force", "moment"):
            if key in load:
                load[key] = _turn(load[key])
    solve = s["solve"]
    if "control" in solve and solve["control"].get("direction") in _COMPONENT:
        solve["control"]["direction"] = _COMPONENT[solve["control"]["direction"]]
    model = solve.get("linear_model")
    if model:
        model["inputs"] = [_turn_input(i) for i in model["inputs"]]
    for probe in s["output"]["probes"].values():
        if probe.get("component") in _COMPONENT and ("point" in probe or "momentum" in probe):
            probe["component"] = _COMPONENT[probe["component"]]
    return s


def _turn_input(name: str) -> str:
    head, _, last = name.rpartition(".")
    if head.endswith((".force", ".moment")) and last in _COMPONENT:
        return f"{head}.{_COMPONENT[last]}"
    return name


# =========================================================================== the check's probes
def with_invariant_probes(scene: dict) -> dict:
    """A transient ``scene`` with the probes the checks read (``inv_*``), after its own."""
    s = copy.deepcopy(scene)
    if s["solve"]["analysis"] != "transient":
        return s
    probes = s["output"]["probes"]
    for c in "xyz":
        probes[f"inv_p{c}"] = {"momentum": "linear", "component": c}
        probes[f"inv_L{c}"] = {"momentum": "angular", "component": c}
    for kind in ("kinetic", "strain", "potential", "total", "external_work", "dissipated"):
        probes[f"inv_{kind}"] = {"energy": kind}
    point = _moving_point(s)
    if point:
        for c in "xyz":
            probes[f"inv_x{c}"] = {"point": point, "quantity": "position", "component": c}
            probes[f"inv_v{c}"] = {"point": point, "quantity": "velocity", "component": c}
    return s


def _moving_point(scene: dict) -> str | None:
    """The end of the last beam (a point that moves in most scenes)."""
    beams = list(scene.get("beams", {}))
    return f"{beams[-1]}.end" if beams else None


def is_free_and_unloaded(scene: dict) -> bool:
    """No ground, no prescribed motion, no gravity, no loads, no guide on the ground: every force internal."""
    bodies = scene["bodies"]
    if any(b.get("fixed") or "motion" in b for b in bodies.values()):
        return False
    if any("guide" in b and "on" not in b["guide"] for b in bodies.values()):
        return False
    gravity = scene.get("gravity")
    if gravity and any(g != 0 for g in gravity):
        return False
    return not scene.get("loads")


def _number(value, parameters) -> float:
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str) and value in parameters:
        return float(parameters[value])
    return 0.0


def total_mass(scene: dict) -> float:
    """The scene's mass (bodies, beams, cables): the momentum scale's M."""
    parameters = scene.get("parameters", {})
    bodies = scene["bodies"]
    mass = sum(_number(b.get("mass", 0), parameters) for b in bodies.values())

    def where(p):
        if isinstance(p, list):
            return np.array([_number(x, parameters) for x in p])
        name = p["body"] if isinstance(p, dict) else p
        return np.array([_number(x, parameters) for x in bodies[name]["at"]])

    for beam in scene.get("beams", {}).values():
        length = float(np.linalg.norm(where(beam["to"]) - where(beam["from"])))
        mass += _number(scene["sections"][beam["section"]]["rhoA"], parameters) * length
    for cable in scene.get("cables", {}).values():
        length = float(np.linalg.norm(where(cable["to"]) - where(cable["from"])))
        mass += _number(cable.get("rhoA", 0), parameters) * length
    return mass


# =========================================================================== the checks
def _relative_difference(a: dict, b: dict, names) -> tuple[float, str]:
    worst, where = 0.0, ""
    for name in names:
        x, y = np.asarray(a[name], float), np.asarray(b[name], float)
        if x.shape != y.shape:
            return float("inf"), f"{name}: {x.shape} rows against {y.shape}"
        scale = max(float(np.nanmax(np.abs(x), initial=0.0)), float(np.nanmax(np.abs(y), initial=0.0)))
        if scale < NOISE or not len(x):
            continue
        k = int(np.nanargmax(np.abs(x - y)))
        if abs(x[k] - y[k]) <= NOISE:      # round-off about a small probe
            continue
        d = float(abs(x[k] - y[k])) / scale
        if not np.isfinite(d) or d > worst:
            worst, where = d, f"{name}[{k}]: {x[k]:.10g} against {y[k]:.10g}"
    return worst, where


def _api_probes(scene_path: Path, npz: Path, timeout: float) -> tuple[int | None, str]:
    code = ("import sys, numpy as np, latdyn\n"
            "r = latdyn.run(latdyn.load_scene(sys.argv[1]))\n"
            "np.savez(sys.argv[2], t=r.t, modes=np.zeros(0) if r.modes is None else r.modes,"
            " **{'p_' + k: v for k, v in r.probes.items()})\n")
    env = dict(__import__("os").environ, PYTHONPATH=str(REPO))
    try:
        done = subprocess.run([sys.executable, "-c", code, str(scene_path), str(npz)], capture_output=True,
                              text=True, timeout=timeout, env=env, cwd=scene_path.parent)
    except subprocess.TimeoutExpired:
        return None, "no exit within the timeout"
    return done.returncode, done.stderr[-600:]


def freed(scene: dict, rng) -> dict:
    """``scene`` made a free, unloaded transient run (for the momentum check): its root body takes mass
    and inertia in place of ``fixed``/``motion``, gravity and loads go, a guide on the ground goes on
    the root, and a static or modal analysis becomes a transient run of generalized-α or Newmark."""
    s = copy.deepcopy(scene)
    root = s["bodies"]["g"]
    root.pop("fixed", None)
    root.pop("motion", None)
    root.setdefault("mass", fuzz_runs._r(rng, 0.5, 5, 2))
    root.setdefault("inertia", [fuzz_runs._r(rng, 0.01, 1, 3)] * 3)
    s.pop("gravity", None)
    s.pop("loads", None)
    for body in s["bodies"].values():
        if "guide" in body and "on" not in body["guide"]:
            body["guide"]["on"] = "g"
    solve = s["solve"]
    if solve["analysis"] != "transient":
        t_end = fuzz_runs._choice(rng, [0.1, 0.2, 0.5])
        s["solve"] = solve = {"analysis": "transient", "t_end": t_end, "dt": t_end / fuzz_runs._choice(rng, [10, 20, 50]),
                              "method": fuzz_runs._choice(rng, ["generalized-alpha", "newmark", "hht-alpha"])}
        s["output"].pop("every", None)
    if "initial_velocity" not in s:
        s["initial_velocity"] = {"linear": [fuzz_runs._r(rng, -1, 1, 2), fuzz_runs._r(rng, -1, 1, 2), fuzz_runs._r(rng, -1, 1, 2)],
                                 "angular": [fuzz_runs._r(rng, -3, 3, 2) for _ in range(3)]}
    # the loads' probes and inputs name what is gone
    s["output"]["probes"] = {k: v for k, v in s["output"]["probes"].items()}
    if "sensitivities" in solve and solve["analysis"] != "transient":
        solve.pop("sensitivities")
    return s


def check_case(seed: int, index: int, workdir: Path, *, joints: bool, timeout: float, free: bool = False,
               extended: bool = False) -> dict:
    """Run case ``index`` of ``seed`` with the check's probes, its turned scene and its API twin; judge
    (``free``: the scene made free and unloaded first, :func:`freed`)."""
    from latdyn.results.result import Result
    from latdyn.scene.loader import load_scene

    rng = np.random.default_rng([seed, index])
    scene = fuzz_runs.random_scene(rng, joints=joints, extended=extended)
    if free:
        scene = freed(scene, rng)
    scene = with_invariant_probes(scene)
    case = workdir / f"case{index:04d}"
    case.mkdir(parents=True, exist_ok=True)
    path = case / "scene.yaml"
    path.write_text(fuzz_runs._scene_text(scene), encoding="utf-8")
    status, _, stderr, wall = fuzz_runs._run(["run", str(path), "-o", str(case / "out"), "-q"], timeout=timeout, cwd=case)
    outcome, detail = fuzz_runs.judge(status, stderr, path, case / "out", scene)
    record = {"index": index, "analysis": scene["solve"]["analysis"], "outcome": outcome, "detail": detail,
              "wall_s": round(wall, 2), "findings": [], "scene": scene, "stderr": stderr[-3000:]}
    if outcome not in ("solved", "failed", "unbounded"):
        return record
    findings = record["findings"]
    with fuzz_runs.READING:
        result = Result.load(case / "out")

    # objectivity: the turned scene
    try:
        loaded = load_scene(str(path))
        y_axes = {name: list(map(float, beam.y_axis)) for name, beam in loaded.beams.items()}
    except Exception as exc:  # noqa: BLE001 - a scene that ran loads
        findings.append(("objectivity", f"the scene that ran does not load in-process: {exc}"))
        y_axes = None
    if y_axes is not None:
        turned = turned_scene(scene, y_axes)
        tpath = case / "turned.yaml"
        tpath.write_text(fuzz_runs._scene_text(turned), encoding="utf-8")
        tstatus, _, terr, _ = fuzz_runs._run(["run", str(tpath), "-o", str(case / "turned_out"), "-q"],
                                             timeout=timeout, cwd=case)
        if tstatus != status:
            findings.append(("objectivity", f"exit {status}, turned exit {tstatus}: "
                             f"{(terr.strip().splitlines() or [''])[-1][:300]}"))
        elif status == 0:
            with fuzz_runs.READING:
                t_result = Result.load(case / "turned_out")
            d, where = _compare_results(result, t_result, scene)
            record["objectivity"] = d
            if result.summary.get("coordinates") != t_result.summary.get("coordinates"):
                # a plane other than x–y, or a direction, must be found as the x–y plane is
                findings.append(("objectivity", f"{result.summary.get('coordinates')} coordinates, turned "
                                 f"{t_result.summary.get('coordinates')}"))
            allowed = OBJECTIVITY_TOL
            admitted = max(fuzz_runs.admitted_error(scene, result.summary),
                           fuzz_runs.admitted_error(turned, t_result.summary))
            early = _early_difference(result, t_result)
            record["objectivity_early"] = early
            if not same_steps(result.summary, t_result.summary) or admitted > DRIFT_WARNED or early <= EARLY_TOL:
                # round-off that moved a step cut or an event's step takes another path, as good as the
                # first to the error the run admits (fuzz_runs.admitted_error); and a run whose balance
                # drifts past the warning's level amplifies round-off as it creates or loses energy; and
                # a difference that grows from round-off (the first rows equal to EARLY_TOL: slack cable
                # elements of inner nodes with mass, friction sticking, impacts, all non-smooth) is the
                # run's sensitivity to round-off, where a frame wrong in the turned scene shows at once
                allowed = max(allowed, fuzz_runs.STEP_CHECK_MULTIPLE * max(
                    fuzz_runs.admitted_error(scene, result.summary), fuzz_runs.admitted_error(turned, t_result.summary)))
            if d > allowed:
                findings.append(("objectivity", f"turned run differs by {d:.3g} (allowed {allowed:.3g}): {where}"))

    # the API gives the CLI's numbers
    if status == 0:
        code, err = _api_probes(path, case / "api.npz", timeout)
        if code != 0:
            findings.append(("api", f"API exit {code}: {err.strip().splitlines()[-1] if err.strip() else ''}"))
        else:
            with np.load(case / "api.npz") as f:
                api = {k[2:]: f[k] for k in f.files if k.startswith("p_")}
                api_modes = f["modes"]
            d, where = _relative_difference(result.probes, api, list(result.probes))
            if result.modes is not None and len(result.modes):
                dm, wm = _relative_difference({"modes": result.modes}, {"modes": api_modes}, ["modes"])
                d, where = max((d, where), (dm, wm))
            record["api"] = d
            if d > API_TOL:
                findings.append(("api", f"API differs by {d:.3g}: {where}"))

    if scene["solve"]["analysis"] == "transient" and len(result.t) > 1:
        findings.extend(_transient_invariants(scene, result, record, case, timeout))
    return record


def _early_difference(a, b) -> float:
    """The largest relative difference of the probes over the first :data:`EARLY_ROWS` rows after t = 0
    (each relative to its magnitude over the whole run), inf where the rows differ."""
    n = min(len(a.t), len(b.t), EARLY_ROWS + 1)
    if n < 2 or not np.allclose(a.t[:n], b.t[:n], rtol=0, atol=1e-12):
        return float("inf")
    worst = 0.0
    for name, x in a.probes.items():
        y = b.probes[name]
        scale = max(float(np.nanmax(np.abs(x), initial=0.0)), float(np.nanmax(np.abs(y), initial=0.0)))
        if scale < NOISE:
            continue
        worst = max(worst, float(np.nanmax(np.abs(x[:n] - y[:n]))) / scale)
    return worst


def same_steps(a: dict, b: dict) -> bool:
    """Whether two runs' summaries show the same steps: counts, rejections and cut times (to 1e-9)."""
    if a.get("analysis") != "transient":
        return True
    if any(a.get(k) != b.get(k) for k in ("steps", "rejected_steps", "newton_cuts")):
        return False
    ca, cb = a.get("cut_times") or [], b.get("cut_times") or []
    return len(ca) == len(cb) and all(abs(x - y) <= 1e-9 for x, y in zip(ca, cb))


def _compare_results(a, b, scene) -> tuple[float, str]:
    if a.t.shape == b.t.shape and np.allclose(a.t, b.t, rtol=0, atol=1e-9 * max(1.0, float(np.max(np.abs(a.t), initial=0)))):
        d, where = _relative_difference(a.probes, b.probes, list(a.probes))
    else:   # adaptive steps that went otherwise: the rows both recorded (the first and the last at least)
        d, where = fuzz_runs.step_difference(a, b)
        where = f"rows {len(a.t)} against {len(b.t)}; {where}"
    if a.modes is not None and len(a.modes) and b.modes is not None:
        fa = np.asarray(a.summary.get("modes_hz", []), float)
        fb = np.asarray(b.summary.get("modes_hz", []), float)
        if fa.shape != fb.shape:
            return float("inf"), f"modes_hz {fa.shape} against {fb.shape}"
        scale = max(float(np.max(np.abs(fa), initial=0.0)), 1e-12)
        # (near) zero frequencies of rigid-body modes are round-off: compared to the largest
        dm = float(np.max(np.abs(fa - fb), initial=0.0)) / scale
        if dm > d:
            d, where = dm, f"modes_hz {fa} against {fb}"
    for key in ("buckling_factor",):
        if key in a.summary or key in b.summary:
            x, y = a.summary.get(key), b.summary.get(key)
            if x is None or y is None:
                if x != y:
                    return float("inf"), f"{key} {x} against {y}"
                continue
            dk = abs(x - y) / max(abs(x), abs(y), 1e-300)
            if dk > d:
                d, where = dk, f"{key} {x!r} against {y!r}"
    return d, where


def momentum_drift(scene: dict, result) -> tuple[float, float]:
    """The largest change of the linear and the angular momentum over the run, relative to the momentum
    scale sqrt(2 M max KE) and to (that times the largest distance of a body from the origin, and the
    largest |L|)."""
    p = result.probes
    mass = total_mass(scene)
    scale = max(float(np.sqrt(2.0 * mass * np.max(np.abs(p["inv_kinetic"])))) if mass > 0 else 0.0, NOISE)
    momentum = np.stack([p[f"inv_p{c}"] for c in "xyz"], axis=1)
    angular = np.stack([p[f"inv_L{c}"] for c in "xyz"], axis=1)
    parameters = scene.get("parameters", {})
    reach = max([1.0] + [float(np.linalg.norm([_number(x, parameters) for x in b["at"]])) for b in scene["bodies"].values()])
    a_scale = max(float(np.max(np.linalg.norm(angular, axis=1))), scale * reach, NOISE)
    return (float(np.max(np.linalg.norm(momentum - momentum[0], axis=1))) / scale,
            float(np.max(np.linalg.norm(angular - angular[0], axis=1))) / a_scale)


def _rerun(scene: dict, case: Path, stem: str, timeout: float):
    """``scene`` run through the CLI in ``case``: its Result, or None where it does not solve."""
    from latdyn.results.result import Result

    path = case / f"{stem}.yaml"
    path.write_text(fuzz_runs._scene_text(scene), encoding="utf-8")
    status, _, _, _ = fuzz_runs._run(["run", str(path), "-o", str(case / f"{stem}_out"), "-q"], timeout=timeout, cwd=case)
    if status != 0:
        return None
    with fuzz_runs.READING:
        return Result.load(case / f"{stem}_out")


def _transient_invariants(scene, result, record, case, timeout) -> list:
    findings = []
    p = result.probes
    kinetic = p.get("inv_kinetic")
    if is_free_and_unloaded(scene) and "inv_px" in p and result.summary.get("status") == "solved":
        drifts = momentum_drift(scene, result)
        record["momentum"] = dict(zip(("linear", "angular"), drifts))
        admitted = fuzz_runs.STEP_CHECK_MULTIPLE * fuzz_runs.admitted_error(scene, result.summary)
        if max(drifts) > max(MOMENTUM_TOL, admitted):
            # the step keeps the momenta to its own error (relative coordinates, a Lie-group step), which
            # its energy balance measures: a drift past that must fall as the step does, at an
            # order ≥ 1 from dt to dt/4
            finer = [drifts]
            for factor in (2, 4):
                fine = _rerun(fuzz_runs.refined_scene(scene, factor), case, f"dt_over_{factor}", timeout)
                if fine is None:
                    findings.append(("momentum", f"momentum drifts {drifts[0]:.3g}, {drifts[1]:.3g} and the run at "
                                     f"dt/{factor} does not solve"))
                    return findings
                finer.append(momentum_drift(scene, fine))
            record["momentum_refined"] = finer
            for i, kind in enumerate(("linear", "angular")):
                d = [f[i] for f in finer]
                if d[0] > max(MOMENTUM_TOL, admitted) and not (d[2] <= d[0] / 4 ** STEP_ORDER):
                    findings.append(("momentum", f"{kind} momentum of a free, unloaded structure drifts by "
                                     f"{', '.join(f'{x:.3g}' for x in d)} at dt, dt/2, dt/4: not falling with the step"))
    if all(f"inv_{k}" in p for k in ("total", "external_work", "dissipated")) and result.summary.get("status") == "solved":
        created = p["inv_total"] - p["inv_total"][0] - p["inv_external_work"] + p["inv_dissipated"]
        reported = float(result.summary.get("energy_balance_error") or 0.0)
        # the summary's scale: the largest of kinetic, strain, |potential change| and |external work|
        scale = max(float(np.max(np.abs(p["inv_kinetic"]))), float(np.max(np.abs(p["inv_strain"]))),
                    float(np.max(np.abs(p["inv_potential"] - p["inv_potential"][0]))),
                    float(np.max(np.abs(p["inv_external_work"]))), NOISE)
        seen = float(np.max(np.abs(created))) / scale
        record["energy"] = {"reported": reported, "probes": seen}
        if seen > 2 * reported + ENERGY_SLACK:
            k = int(np.argmax(np.abs(created)))
            findings.append(("energy", f"the probes' balance {seen:.3g} (created {created[k]:.4g} J at t = "
                             f"{result.t[k]:.6g}), the summary's energy_balance_error {reported:.3g}"))
    if "inv_xx" in p and "every" not in scene["output"] and result.summary.get("status") == "solved":
        x = np.stack([p[f"inv_x{c}"] for c in "xyz"], axis=1)
        v = np.stack([p[f"inv_v{c}"] for c in "xyz"], axis=1)
        dt = np.diff(result.t)[:, None]
        integrated = np.cumsum(0.5 * (v[1:] + v[:-1]) * dt, axis=0)
        moved = x[1:] - x[0]
        path = float(np.sum(np.linalg.norm(np.diff(x, axis=0), axis=1)))
        if path > 1e-6:
            off = float(np.max(np.linalg.norm(moved - integrated, axis=1))) / path
            record["kinematics"] = off
            # an integrator's own relation of position and velocity is not the trapezoid (generalized-α
            # with ρ∞ < 1 weighs the accelerations otherwise), and it parts them where the step is too long
            if off > max(KINEMATICS_TOL, fuzz_runs.STEP_CHECK_MULTIPLE * fuzz_runs.admitted_error(scene, result.summary)):
                findings.append(("kinematics", f"position and integrated velocity of {_moving_point(scene)} "
                                 f"part by {off:.3g} of its path {path:.3g}"))
    return findings


# =========================================================================== the campaign
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--seed", type=int, default=401)
    parser.add_argument("--start", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--timeout", type=float, default=120.0)
    parser.add_argument("--joints", action="store_true")
    parser.add_argument("--extended", action="store_true", help="fuzz_runs.random_scene's extensions too")
    parser.add_argument("--free", action="store_true", help="make every scene free, unloaded and transient (freed)")
    parser.add_argument("--workdir", type=Path, default=None)
    parser.add_argument("--keep", type=Path, default=None)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    from concurrent.futures import ThreadPoolExecutor

    base = args.workdir or Path(tempfile.mkdtemp(prefix="latdyn_inv_"))
    records = []
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(check_case, args.seed, i, base, joints=args.joints, timeout=args.timeout,
                               free=args.free, extended=args.extended)
                   for i in range(args.start, args.start + args.runs)]
        for future in futures:
            r = future.result()
            records.append(r)
            marks = "; ".join(f"{k.upper()}: {d[:160]}" for k, d in r["findings"])
            extra = " ".join(f"{k}={r[k] if not isinstance(r[k], float) else format(r[k], '.2g')}"
                             for k in ("objectivity", "api", "momentum", "energy", "kinematics") if k in r)
            print(f"case {r['index']:4d} {r['analysis']:9s} {r['outcome']:10s} {r['wall_s']:6.1f} s {r['detail'][:80]} "
                  f"{extra} {marks}", flush=True)
            if args.keep and (r["findings"] or r["outcome"] in fuzz_runs.DEFECTS):
                args.keep.mkdir(parents=True, exist_ok=True)
                stem = args.keep / f"seed{args.seed}_case{r['index']:04d}"
                notes = "".join(f"# {k}: {d}\n" for k, d in r["findings"]) or f"# {r['outcome']}: {r['detail']}\n"
                stem.with_suffix(".yaml").write_text(notes + fuzz_runs._scene_text(r["scene"]), encoding="utf-8")
    summary = {"seed": args.seed, "runs": len(records), "joints": args.joints, "free": args.free,
               "outcomes": dict(collections.Counter(r["outcome"] for r in records)),
               "findings": dict(collections.Counter(k for r in records for k, _ in r["findings"])),
               "checked": {k: sum(k in r for r in records) for k in ("objectivity", "api", "momentum", "energy", "kinematics")}}
    print(json.dumps(summary, indent=1))
    if args.json:
        args.json.write_text(json.dumps({**summary, "records": [
            {k: r[k] for k in ("index", "analysis", "outcome", "detail", "wall_s", "findings", "objectivity", "api",
                               "momentum", "energy", "kinematics") if k in r} for r in records]}, indent=1))
    return 0 if not any(r["findings"] for r in records) else 1


if __name__ == "__main__":
    sys.exit(main())
