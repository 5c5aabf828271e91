"""Combinations fuzzing of the sensitivities' loop of steps (session 2026-11-28 tenth, helper fuzz5).

Seven helpers brought into the compiled sensitivity loop, each tested alone: work accounts, prescribed motions,
reels, laws of the state and t beside events, points' sensors, chains, load actuators, sampled controllers, cables
beside controllers and t, sparse step matrices. This driver writes random 3D scenes (YAML text as a user types it)
that combine them: a boom of two to four hinged beams on a fixed or prescribed base, hinge laws of t and of the state
and t, a latch or a stop with restitution, a cable from the base to the tip (sometimes reeled), PD and sampled
controllers reading hinges and points and driving hinge torques and loads, loads of t, energy probes (dissipated,
external work, total), 1–10 parameters of mixed kinds, sometimes a boom long enough for the sparse LU. For each:

- (a) the loop on and off (the private switches ``SENSITIVITIES_IN_LOOP``, ``ADJOINT_IN_LOOP`` for the fifth of the
  cases by the discrete adjoint, ``SENSITIVITY_ROWS_IN_LOOP``): sha-256 of sensitivities.csv, probes.csv
  and summary.json's probe and event sensitivities;
- (b) ``latdyn.run`` against ``python -m latdyn run SCENE -o OUT -q``: the same files, byte for byte;
- (c) the run interrupted (Ctrl-C at the first loop of steps from t ≥ t_end/2) and resumed: the same files.

- (c) through the command as well: ``latdyn run`` sent SIGINT at a random share of its rows, then ``--resume``;
- a refusal or failure with the loop on: the same message with every switch off;
- (d) ``--richardson SCENE OUT``: the end row against Richardson differences of whole runs (:func:`richardson`).

``--frames``: the scenes are :func:`random_frame`'s, benchmarks/sparse_sensitivities_loop.py's 9 × 9 space frame
(846 coordinates, the sparse LU) with controllers, a prescribed corner, a cable and energy probes.

``python benchmarks/fuzz_combined.py --runs 20 --seed 1 --keep DIR`` runs a campaign (from a scratch folder, niced);
``--show N --seed S`` prints case N's scene. Each case runs in a process of its own (``--worker``) with a timeout.
Not run by the suite.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import random
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SUMMARY_KEYS = ("probe_sensitivities", "event_sensitivities", "sensitivity_steps_in_loop", "steps", "events")


def _f(x: float) -> str:
    return repr(round(x, 4))


def random_scene(rng: random.Random) -> str:
    """A random 3D boom scene as YAML text."""
    params: dict[str, float] = {}
    laws: list[str] = []   # parameter names that became part of a law

    def param(name: str, value: float) -> str:
        params[name] = value
        return name

    big = rng.random() < 0.15
    beams_n = rng.randint(2, 4)
    elements = [rng.randint(1, 3) for _ in range(beams_n)]
    if big:
        elements[0] = rng.randint(22, 30)
    # a 3D zig-zag boom
    points = [(0.0, 0.0, 0.0)]
    for i in range(beams_n):
        x, y, z = points[-1]
        points.append((x + rng.uniform(0.4, 0.8), y + rng.uniform(-0.4, 0.4), z + rng.uniform(-0.3, 0.5)))
    E = param("E", 1.0) if rng.random() < 0.6 else "1.0"
    rho = param("rho", 0.5) if rng.random() < 0.4 else "0.5"
    lines = ["title: fuzz5 combined boom", "gravity: [0, 0, -9.81]" if rng.random() < 0.6 else "gravity: [0, 0, 0]"]
    section = (f'  s: {{EA: "1.0e4*{E}", EIy: "20*{E}", EIz: "30*{E}", GJ: "15*{E}", rhoA: "{rho}", '
               f'rhoIy: "0.01*{rho}", rhoIz: "0.02*{rho}"}}')
    bodies = []
    prescribed = rng.random() < 0.35
    if prescribed:
        kind = rng.choice(["rotation", "translation", "both"])
        motion = []
        if kind in ("translation", "both"):
            motion.append('translation: ["0.05*sin(3*t)", 0, "0.02*t**2"]')
        if kind in ("rotation", "both"):
            motion.append('rotation: {axis: [0.2, 0.1, 1.0], angle: "0.5*t**2 - 0.1*t**3"}')
        bodies.append(f"  base: {{at: [0, 0, 0], motion: {{{', '.join(motion)}}}}}")
    else:
        bodies.append("  base: {at: [0, 0, 0], fixed: true}")
    for i in range(1, beams_n + 1):
        p = points[i]
        mass = f'"{param(f"m{i}", round(rng.uniform(0.2, 1.0), 3))}"' if rng.random() < 0.25 else _f(rng.uniform(0.2, 1.0))
        bodies.append(f"  n{i}: {{at: [{_f(p[0])}, {_f(p[1])}, {_f(p[2])}], mass: {mass}, com: [0.02, 0, -0.01], "
                      f"inertia: [0.01, 0.01, 0.02]}}")
    probes = [f"    tip_z: {{point: n{beams_n}, quantity: position, component: z}}",
              f"    tip_vy: {{point: n{beams_n}, quantity: velocity, component: y}}"]
    controllers = []
    loads = []
    hinge_index = list(range(1, beams_n))   # beams b1.. have a hinge at their start
    rng.shuffle(hinge_index)
    event_hinge = hinge_index[0] if rng.random() < 0.7 else None
    sampled = rng.random() < 0.3
    continuous = rng.random() < 0.6 or not sampled
    pd_hinge = hinge_index[-1]
    probes.append(f"    a{pd_hinge}: {{hinge: b{pd_hinge}.start, quantity: angle}}")
    probes.append(f"    w{pd_hinge}: {{hinge: b{pd_hinge}.start, quantity: rate}}")
    probes.append(f"    p_y: {{point: n{beams_n}, quantity: position, frame: n{pd_hinge}, component: y}}")
    if continuous:
        Kp = param("Kp", round(rng.uniform(2, 20), 2)) if rng.random() < 0.7 else _f(rng.uniform(2, 20))
        Kd = param("Kd", round(rng.uniform(0.2, 1.5), 2)) if rng.random() < 0.5 else _f(rng.uniform(0.2, 1.5))
        reads = rng.choice([f"w{pd_hinge}", "tip_vy", f"w{pd_hinge} + 0.3*tip_vy"])
        limits = ", limits: [-3, 3]" if rng.random() < 0.3 else ""
        controllers.append(f'  pd: {{output: "{Kp}*(0.3 - a{pd_hinge}) - {Kd}*({reads})"{limits}}}')
        if rng.random() < 0.3:
            controllers.append('  push: {output: "0.5*pd + 0.2*p_y"}')
    if sampled:
        G = param("G", round(rng.uniform(1, 6), 2)) if rng.random() < 0.6 else "3.0"
        rate = None   # chosen with dt: its instants on the grid
        controllers.append(f'  dig: {{output: "{G}*(0.2 - p_y) - 0.5*a{pd_hinge}", rate: {rate}'
                           + (", limits: [-2, 2]" if rng.random() < 0.3 else "") + "}")
    names = [c.split(":")[0].strip() for c in controllers]
    beams = []
    for i in range(beams_n):
        b = f"  b{i}: {{from: {'base' if i == 0 else f'n{i}'}, to: n{i + 1}, section: s, elements: {elements[i]}"
        b += ", y_axis: [0, 0, 1]" if abs(points[i + 1][2] - points[i][2]) < 0.2 else ", y_axis: [0, 1, 0]"
        if i >= 1:
            axis = [round(rng.uniform(-1, 1), 2) for _ in range(3)]
            axis[rng.randrange(3)] = 1.0
            k = rng.choice([lambda: "2.0", lambda: f'"{param(f"k{i}", 2.0)}"',
                            lambda: f'"{param(f"k{i}", 2.0)}*(1 + 2*t)"', lambda: '"1.5*(1 + t)"'])()
            c = rng.choice([lambda: "0.2", lambda: f'"{param(f"c{i}", 0.2)}"', lambda: "0.05"])()
            torque_terms = []
            if i == pd_hinge and names:
                torque_terms.append(rng.choice(names))
            form = rng.random()
            if form < 0.25:
                torque_terms.append(f"{param(f'A{i}', 0.5) if rng.random() < 0.5 and not torque_terms else '0.5'}*sin(9*t)")
            elif form < 0.45:
                torque_terms.append("0.5*t*(1 + 0.2*sin(theta))")
            elif form < 0.6:
                torque_terms.append("0.3*sin(4*t)*cos(theta) + 0.1*t*theta_dot")
            hinge = f"axis: [{', '.join(map(str, axis))}], stiffness: {k}, damping: {c}"
            if torque_terms:
                hinge += f', torque: "{" + ".join(torque_terms)}"'
            if i == event_hinge:
                if rng.random() < 0.5:
                    hinge += ", rest_angle: 1.2, lock_at: 0.4"
                else:
                    hinge += ", rest_angle: 1.2, limits: [-1.0, 0.4], restitution: 0.5"
            elif rng.random() < 0.4:
                hinge += f', rest_angle: "{param(f"r{i}", 0.3)}"'
            b += f", start: {{hinge: {{{hinge}}}}}"
        beams.append(b + "}")
    # loads: of t, and driven by a controller
    if rng.random() < 0.7:
        F = param("F", 1.0) if rng.random() < 0.5 else "1.0"
        loads.append(f'  - {{at: n{beams_n}, force: ["0.3*{F}", "-{F}*t", "0.5*{F}*sin(5*t)"]}}')
    if names and rng.random() < 0.6:
        drive = rng.choice(names)
        loads.append(f'  - {{at: n{beams_n}, force: [0, "0.3*{drive}", 0], moment: ["0.05*{drive}", 0, 0], '
                     f'frame: n{pd_hinge}}}')
    cables = []
    if rng.random() < 0.45:
        d = math.dist(points[0], points[-1])
        EA = param("EA", 2000.0) if rng.random() < 0.5 else "2000.0"
        if rng.random() < 0.5:   # a reel hauling in, smooth (a kink off the grid sends the run to Python): taut on the way
            rest = f'"{_f(1.01 * d)} - 0.3*t"'
        else:
            rest = _f(1.002 * d)
        cables.append(f'  tie: {{from: base, to: n{beams_n}, EA: "{EA}", rest_length: {rest}}}')
        probes.append("    pull: {cable: tie, quantity: tension}")
    # energies: refused beside cables; the external work with controllers, or through events with loads of t
    kinds = ["total", "kinetic"] + ([] if event_hinge else ["dissipated", "dissipated"])
    kinds += [] if controllers or (event_hinge and loads) else ["external_work", "external_work"]
    for kind in [] if cables else dict.fromkeys(rng.sample(kinds, rng.randint(0, 2))):
        probes.append(f"    e_{kind}: {{energy: {kind}}}")
    # parameters: 1..10 of them, listed
    listed = list(params)
    rng.shuffle(listed)
    listed = listed[:rng.randint(1, min(10, len(listed)))] if listed else []
    if not listed:
        params["F0"] = 0.5
        loads.append('  - {at: n1, force: [0, 0, "-F0"]}')
        listed = ["F0"]
    t_end = rng.choice([0.2, 0.3, 0.4])
    dt = rng.choice([0.005, 0.004])
    controllers = [c.replace("rate: None", f"rate: {rng.choice([40, 50, 100] if dt == 0.005 else [50, 125])}")
                   for c in controllers]
    adjoint = ", sensitivity_method: adjoint" if rng.random() < 0.2 else ""
    adjoint += rng.choice(["", "", ", method: hht-alpha", ", method: newmark", ", rho_inf: 0.6"])
    text = "\n".join(lines)
    text += "\nparameters: {" + ", ".join(f"{k}: {v}" for k, v in params.items()) + "}\n"
    text += "sections:\n" + section + "\n"
    text += "bodies:\n" + "\n".join(bodies) + "\n"
    text += "beams:\n" + "\n".join(beams) + "\n"
    if loads:
        text += "loads:\n" + "\n".join(loads) + "\n"
    if cables:
        text += "cables:\n" + "\n".join(cables) + "\n"
    if controllers:
        text += "controllers:\n" + "\n".join(controllers) + "\n"
    text += (f"initial_velocity: {{angular: [0, 0, {_f(rng.uniform(0.5, 3.0))}]}}\n"
             if not prescribed and rng.random() < 0.5 else "")
    text += (f"solve: {{analysis: transient, dt: {dt}, t_end: {t_end}, sensitivities: [{', '.join(listed)}]"
             f"{adjoint}}}\n")
    text += f"output:\n  every: {rng.choice([0.01, 0.02, dt])}\n  probes:\n" + "\n".join(probes) + "\n"
    return text


def random_frame(rng: random.Random) -> str:
    """A random scene on the sparse LU: benchmarks/sparse_sensitivities_loop.py's 9 × 9 double-layer space frame
    (512 members, 846 coordinates, bandwidth above BAND_LIMIT) with, at random, a PD controller on the centre's
    sag and rate driving a load there, a sampled one driving a load at another joint, a load of t, a prescribed
    corner (a translation in t), a cable across the bottom layer, energy probes; 1–10 parameters of mixed kinds."""
    import yaml

    from benchmarks.sparse_sensitivities_loop import space_frame

    data = space_frame([], 9, dt=0.001, t_end=rng.choice([0.01, 0.012]))
    params = data["parameters"]
    chosen = [f"F{i}" for i in rng.sample(range(512), rng.randint(0, 3))]
    params.update({"P": 1.0, "m": 0.2})
    data["parameters"] = {k: v for k, v in params.items() if k in chosen or not k.startswith("F")}
    for name, section in data["sections"].items():
        if section["EA"] not in chosen:
            section["EA"] = float(params[section["EA"]])
    data["loads"][0]["force"] = [0, "3000*P*t", "-20000*P*t"]
    data["bodies"]["b4_4"]["mass"] = "m"
    chosen += ["P", "m"]
    probes = data["output"]["probes"]
    probes["rate"] = {"point": "t4_4", "quantity": "velocity", "component": "z"}
    controllers = {}
    if rng.random() < 0.7:
        data["parameters"].update({"Kp": 2000.0, "Kd": 5.0})
        controllers["pd"] = {"output": "-Kp*sag - Kd*rate"}
        data["loads"].append({"at": "t4_4", "force": [0, 0, "pd"]})
        chosen += ["Kp", "Kd"]
    if rng.random() < 0.5:
        data["parameters"]["G"] = 500.0
        controllers["dig"] = {"output": "-G*drift", "rate": rng.choice([500, 1000])}
        data["loads"].append({"at": "t2_6", "force": ["dig", 0, "0.5*dig"]})
        chosen.append("G")
    if controllers:
        data["controllers"] = controllers
    if rng.random() < 0.4:
        data["bodies"]["t0_0"] = {"at": [0.0, 0.0, 0.0], "motion": {"translation": ["0.01*sin(40*t)", 0, "5*t**2"]}}
    if rng.random() < 0.4:
        data["parameters"]["EA"] = 5.0e5
        data["cables"] = {"tie": {"from": "b0_0", "to": "b7_7", "EA": "EA", "rest_length": 0.999 * math.dist(
            [0.5, 0.5, -0.7], [7.5, 7.5, -0.7])}}
        probes["pull"] = {"cable": "tie", "quantity": "tension"}
        chosen.append("EA")
    elif rng.random() < 0.5:
        probes["e_total"] = {"energy": "total"}
    rng.shuffle(chosen)
    data["solve"]["sensitivities"] = chosen[:rng.randint(1, min(10, len(chosen)))]
    if rng.random() < 0.2:
        data["solve"]["sensitivity_method"] = "adjoint"
    return yaml.safe_dump(data, sort_keys=False, width=1000)


# ---------------------------------------------------------------------------------------------------------- worker

def _digest(out: Path) -> dict:
    d = {}
    for name in ("sensitivities.csv", "probes.csv"):
        path = out / name
        d[name] = hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else None
    s = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    for key in ("probe_sensitivities", "event_sensitivities"):
        d[key] = hashlib.sha256(json.dumps(s.get(key), sort_keys=True).encode()).hexdigest()
    d["in_loop"] = s.get("sensitivity_steps_in_loop")
    d["steps"] = s.get("steps")
    d["time_loop"] = s.get("time_loop")
    d["events"] = [e.get("kind") for e in s.get("events", [])]
    return d


def worker(scene_path: Path, out: Path) -> dict:
    import yaml

    import latdyn
    import latdyn.analyses.sensitivities_in_loop as loop
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    import latdyn.timeloop.transient as transient

    record: dict = {}
    text = scene_path.read_text()
    try:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)), out / "on")
    except Exception as e:   # noqa: BLE001
        record["on_error"] = f"{type(e).__name__}: {e}"[:300]
        # the same refusal or failure with every loop switch off
        import latdyn.analyses.adjoint_in_loop as adjoint_loop
        import latdyn.timeloop.loop as time_loop
        loop.SENSITIVITIES_IN_LOOP = adjoint_loop.ADJOINT_IN_LOOP = time_loop.SENSITIVITY_ROWS_IN_LOOP = False
        try:
            latdyn.run(latdyn.load_scene(yaml.safe_load(text)), out / "off")
            record["off_error"] = "solved"
        except Exception as e2:   # noqa: BLE001
            record["off_error"] = f"{type(e2).__name__}: {e2}"[:300]
        return record
    record["on"] = _digest(out / "on")
    import latdyn.analyses.adjoint_in_loop as adjoint_loop
    import latdyn.timeloop.loop as time_loop
    loop.SENSITIVITIES_IN_LOOP = adjoint_loop.ADJOINT_IN_LOOP = time_loop.SENSITIVITY_ROWS_IN_LOOP = False
    try:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)), out / "off")
        record["off"] = _digest(out / "off")
    except Exception as e:   # noqa: BLE001
        record["off_error"] = f"{type(e).__name__}: {e}"[:300]
    loop.SENSITIVITIES_IN_LOOP = adjoint_loop.ADJOINT_IN_LOOP = time_loop.SENSITIVITY_ROWS_IN_LOOP = True
    # (c) interrupted at t >= t_end/2 and resumed
    t_stop = yaml.safe_load(text)["solve"]["t_end"] / 2
    originals = {name: getattr(CompiledGeneralizedAlpha, name) for name in ("step", "advance")}

    def stopping(name):
        def call(self, state, *args, **kwargs):
            if state.t >= t_stop:
                raise KeyboardInterrupt
            return originals[name](self, state, *args, **kwargs)
        return call

    budget = transient.LOOP_BUDGET_S
    for name in originals:
        setattr(CompiledGeneralizedAlpha, name, stopping(name))
    transient.LOOP_BUDGET_S = 1e-12
    try:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)), out / "resumed")
        record["resume_note"] = "not interrupted"
    except KeyboardInterrupt:
        pass
    finally:
        for name, f in originals.items():
            setattr(CompiledGeneralizedAlpha, name, f)
        transient.LOOP_BUDGET_S = budget
    try:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)), out / "resumed", resume=True)
        record["resumed"] = _digest(out / "resumed")
    except Exception as e:   # noqa: BLE001
        record["resume_error"] = f"{type(e).__name__}: {e}"[:300]
    return record


def richardson(scene_path: Path, out: Path, step: float = 1e-3) -> dict:
    """(d) The end row of sensitivities.csv against the Richardson extrapolation (4 D(h/2) − D(h))/3 of central
    differences D of whole runs (h = ``step``·|p|; ``solve.tol: 1e-12`` in every run), per probe and parameter, the
    error relative to the probe's largest |sensitivity| over the run. A parameter whose perturbed runs take other
    steps or events is skipped."""
    import csv

    import yaml

    import latdyn

    def run(scene: dict, folder: Path) -> tuple[dict, dict, dict]:
        latdyn.run(latdyn.load_scene(scene), folder)
        with open(folder / "probes.csv") as f:
            probes = list(csv.DictReader(f))
        sens = {}
        if (folder / "sensitivities.csv").exists():
            with open(folder / "sensitivities.csv") as f:
                rows = list(csv.DictReader(f))
            sens = {k: [float(r[k]) for r in rows] for k in rows[0] if k != "t"}
        summary = json.loads((folder / "summary.json").read_text())
        return probes[-1], sens, summary

    base = yaml.safe_load(scene_path.read_text())
    base["solve"]["tol"] = 1e-12
    end, sens, summary = run(base, out / "r0")
    shape = (summary["steps"], [(e["kind"], round(e["t"], 6)) for e in summary["events"]])
    record = {"worst": 0.0, "skipped": [], "errors": {}}
    for name in base["solve"]["sensitivities"]:
        v = float(base["parameters"][name])
        h = step * abs(v) if v else step
        ends = {}
        for k, dv in (("+h", h), ("-h", -h), ("+h2", h / 2), ("-h2", -h / 2)):
            scene = yaml.safe_load(scene_path.read_text())
            scene["solve"]["tol"] = 1e-12
            scene["solve"]["sensitivities"] = [name]
            scene["parameters"][name] = v + dv
            e, _, sm = run(scene, out / f"r_{name}{k}")
            if (sm["steps"], [e2["kind"] for e2 in sm["events"]]) != (shape[0], [x[0] for x in shape[1]]):
                record["skipped"].append(name)
                break
            ends[k] = e
        else:
            for probe in end:
                if probe == "t" or f"{probe}/{name}" not in sens:
                    continue
                d1 = (float(ends["+h"][probe]) - float(ends["-h"][probe])) / (2 * h)
                d2 = (float(ends["+h2"][probe]) - float(ends["-h2"][probe])) / h
                ref = (4 * d2 - d1) / 3
                column = sens[f"{probe}/{name}"]
                scale = max(max(abs(x) for x in column), abs(ref), 1e-300)
                err = abs(column[-1] - ref) / scale
                spread = abs(d2 - d1) / scale
                record["errors"][f"{probe}/{name}"] = [err, spread, column[-1], ref]
                if err > record["worst"]:
                    record["worst"] = err
    return record


COMPARED = ("sensitivities.csv", "probes.csv", "probe_sensitivities", "event_sensitivities")


def judge(record: dict) -> list[str]:
    problems = []
    on = record.get("on")
    if on is None:
        return [] if record.get("off_error", record.get("on_error")) == record.get("on_error") else [
            f"off: {record.get('off_error')}"]
    for other in ("off", "cli", "resumed", "cli_resumed"):
        if other not in record:
            if f"{other}_error" in record:
                problems.append(f"{other}: {record[f'{other}_error']}")
            continue
        for key in COMPARED:
            if record[other][key] != on[key]:
                problems.append(f"{other} != on: {key}")
    if "cli" in record and record["cli"]["in_loop"] != on["in_loop"]:
        problems.append("cli in_loop count differs")
    for other in ("resumed", "cli_resumed"):
        if other in record and record[other]["in_loop"] != on["in_loop"]:
            problems.append(f"{other} in_loop {record[other]['in_loop']} != {on['in_loop']}")
    return problems


def _cli_interrupted(case: Path, env: dict, fraction: float) -> dict:
    """(c) through the command: ``latdyn run`` sent SIGINT (Ctrl-C) at ``fraction`` of its run's time (the process
    start excluded: at the first probes' row past that share of the rows it takes), then ``latdyn run --resume``."""
    import signal

    out = case / "cli_resumed"
    command = [sys.executable, "-m", "latdyn", "run", str(case / "scene.yaml"), "-o", str(out), "-q"]
    rows = (case / "cli" / "probes.csv").read_text().count("\n")
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    interrupted = False
    while process.poll() is None:
        probes = out / "probes.csv"
        if probes.exists() and probes.stat().st_size and probes.read_text().count("\n") >= fraction * rows:
            process.send_signal(signal.SIGINT)
            interrupted = True
            break
        time.sleep(0.002)
    process.wait(timeout=600)
    if not interrupted or process.returncode == 0:
        return {"cli_resume_note": "finished before the interruption"}
    summary = out / "summary.json"
    if summary.exists() and json.loads(summary.read_text()).get("status") == "solved":   # Ctrl-C after the end
        return {"cli_resume_note": "solved before the interruption", "cli_resumed": _digest(out)}
    resumed = subprocess.run(command + ["--resume"], env=env, capture_output=True, text=True, timeout=600)
    if resumed.returncode != 0:
        return {"cli_resumed_error": resumed.stderr[-300:]}
    return {"cli_resumed": _digest(out)}


def run_worker(script: str, case: Path, env: dict, timeout: float) -> dict:
    """``script --worker`` on ``case/scene.yaml`` in a process of its own: the record it prints."""
    try:
        w = subprocess.run([sys.executable, script, "--worker", str(case / "scene.yaml"), str(case)],
                           env=env, capture_output=True, text=True, timeout=timeout)
        line = [x for x in w.stdout.splitlines() if x.startswith("RECORD ")]
        return json.loads(line[-1][7:]) if line else {"worker_error": w.stderr[-800:]}
    except subprocess.TimeoutExpired:
        return {"worker_error": "timeout"}


def command_checks(case: Path, env: dict, timeout: float, rng: random.Random) -> dict:
    """(b) ``latdyn run`` on ``case/scene.yaml`` into ``case/cli`` and (c) through the command (:func:`_cli_interrupted`
    at a share of the rows drawn from ``rng``): the record's entries."""
    c = subprocess.run([sys.executable, "-m", "latdyn", "run", str(case / "scene.yaml"), "-o", str(case / "cli"), "-q"],
                       env=env, capture_output=True, text=True, timeout=timeout)
    if c.returncode != 0:
        return {"cli_error": c.stderr[-300:]}
    return {"cli": _digest(case / "cli"), **_cli_interrupted(case, env, rng.uniform(0.3, 0.9))}


def judged(record: dict, judge, case: Path, tally: dict) -> str:
    """The case's outcome by ``judge``, counted in ``tally``; the record with its problems written to the case."""
    problems = judge(record)
    outcome = ("DIFFERS" if problems else "same") if "on" in record else (
        "worker_error" if "on_error" not in record else "REFUSED ONLY IN LOOP" if problems else "refused/failed")
    tally[outcome] = tally.get(outcome, 0) + 1
    record["problems"] = problems
    (case / "record.json").write_text(json.dumps(record, indent=1))
    return outcome


def main(argv=None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=Path("/tmp/fuzz5"))
    parser.add_argument("--show", type=int)
    parser.add_argument("--frames", action="store_true", help="the sparse space frame's scenes (random_frame)")
    parser.add_argument("--timeout", type=float, default=600)
    parser.add_argument("--worker", nargs=2)
    parser.add_argument("--richardson", nargs=2, help="SCENE OUT: (d) for one scene")
    args = parser.parse_args(argv)
    if args.worker:
        record = worker(Path(args.worker[0]), Path(args.worker[1]))
        print("RECORD " + json.dumps(record))
        return 0
    if args.richardson:
        record = richardson(Path(args.richardson[0]), Path(args.richardson[1]))
        print(json.dumps(record, indent=1))
        return 0
    if args.show is not None:
        print((random_frame if args.frames else random_scene)(random.Random(f"{args.seed}-{args.show}")))
        return 0
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    tally: dict[str, int] = {}
    for n in range(args.first, args.first + args.runs):
        text = (random_frame if args.frames else random_scene)(random.Random(f"{args.seed}-{n}"))
        case = args.keep / f"s{args.seed}-{n}"
        case.mkdir(parents=True, exist_ok=True)
        (case / "scene.yaml").write_text(text)
        start = time.time()
        record = run_worker(__file__, case, env, args.timeout)
        if "on" in record:
            record.update(command_checks(case, env, args.timeout, random.Random(f"{args.seed}-{n}-stop")))
        outcome = judged(record, judge, case, tally)
        on = record.get("on", {})
        print(f"{n}: {outcome} {time.time() - start:.0f}s in_loop {on.get('in_loop')}/{on.get('steps')} "
              f"events {on.get('events')} {record['problems'] or record.get('on_error', '') or record.get('worker_error', '')[-200:]}",
              flush=True)
    print(json.dumps(tally))
    return 0


if __name__ == "__main__":
    sys.exit(main())
