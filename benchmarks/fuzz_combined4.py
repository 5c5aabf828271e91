"""Outside check of int20's merges (session 2026-11-28 twelfth, helper fuzz8): random 3D scenes with rigid links or
guides AND events AND new kinds, forward and adjoint.

int20 made exact the impulse weight's derivative on linked models (along the rates, the controllers' couplings of
points, cables, forces, inputs, states and chains, the cables' rest length and ρA, the stops and friction), the adjoint
with guides and events beside rigid links, the external work of prescribed motions with links, geometry parameters
beside controllers, and controllers with states on linked models in the loop. This driver starts from the linked
scenes with events of the tests (the gimbal latching or bouncing, its loads in the rings' frames, the slider-crank
between its stops, with cables, the prescribed crank's swing on its stop, the guided mass bouncing at a flexible
arm's tip, the placed and latching PDs, the point PD in t) and adds at random: hinge or guide laws of the rate
(damping of θ̇ or ṡ, torques of θ and θ̇), a controller reading a point (position, sometimes velocity) or a cable
(tension or length) that drives a load (global or in a body's frame) or a free hinge's torque, a cable from a new
anchor with its rest length and ρA as parameters (damped, sometimes several elements), a compliant stop with its
damping a parameter, friction; the method (generalized-α, HHT-α, Newmark, ρ∞ 0.6), and 1–8 of the scene's
parameters.

Checks per case (a process of its own, ``--worker``):
(a) the forward method against the adjoint (``solve.sensitivity_method: adjoint``): each probe's end, max and min
    derivatives and each event time's, the largest difference relative to that output's largest |derivative| over
    the parameters, or to FLOOR = 1e-4 of the probe's largest over end, max and min where that is larger (an output
    of round-off, 1e-17, beside derivatives of 1e-2) (≤ 1e-9 judged); a refusal of the adjoint recorded;
(b) the loop of steps on against every switch off (sha-256 of sensitivities.csv, probes.csv and the summary's
    derivatives), for the forward method and for the adjoint;
(d) ``latdyn run`` (every ``--cli-every``-th case) against the API, sha-256 (forward, and the adjoint where taken);
(f) the same scene without ``solve.sensitivities``: its events and the first one's time, recorded, not judged (the
    run without lands on a hinge's event as the run with them, latdyn/timeloop/landing.py, but on a cable's change by
    its own passes and not on the cables' inner elements' changes: on scenes whose
    two-element cables' inner node is not resolved by dt the times differ by milliseconds, seed 6 case 50, where
    the derivatives agree with differences of the runs with sensitivities);
(e) no traceback: a failure that is not a SceneError/SolverError-style refusal is recorded (``crash``), and the
    worker's timeout.
(c) is ``--richardson SCENE OUT`` (benchmarks/fuzz_combined.richardson: end rows, tol 1e-12, Richardson of central
differences of whole runs).

``python benchmarks/fuzz_combined4.py --runs 100 --seed 1 --keep DIR``; ``--show N`` prints a scene; ``--tally DIR``.
Not run by the suite.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(1, str(ROOT / "tests"))   # (tests/test_linked_cables.py imports cli_runs as the suite does)

from benchmarks import fuzz_combined as base  # noqa: E402

#: a refusal or a solver's failure, reported with a message (not a traceback)
CLEAN = ("SceneError", "SolverError", "UnboundedError", "ResultsError")


def _scenes() -> dict:
    from tests.test_sensitivities_in_loop_linked2 import CRANK_STOP
    from tests.test_sensitivities_in_loop_linked_controllers import BOB_PD, LATCHING_PD, OFFSET_PD, POINT_PD_T
    from tests.test_sensitivities_rigid_links import LATCH, SLIDER_CRANK, STOP
    from tests.test_weight_derivative_linked_rest import (BEAD_FOLLOWER, CRANK_CABLES, GIMBAL_DAMPED, GIMBAL_LOADS,
                                                          GIMBAL_MIXED)

    return {"LATCH": LATCH, "STOP": STOP, "SLIDER_CRANK": SLIDER_CRANK, "CRANK_STOP": CRANK_STOP,
            "GIMBAL_LOADS": GIMBAL_LOADS, "CRANK_CABLES": CRANK_CABLES, "BEAD_FOLLOWER": BEAD_FOLLOWER,
            "GIMBAL_MIXED": GIMBAL_MIXED, "GIMBAL_DAMPED": GIMBAL_DAMPED, "LATCHING_PD": LATCHING_PD,
            "OFFSET_PD": OFFSET_PD, "BOB_PD": BOB_PD, "POINT_PD_T": POINT_PD_T}


def _dump(data: dict) -> str:
    import yaml

    return yaml.safe_dump(data, sort_keys=False, width=1000, default_flow_style=None)


def _hinges(data: dict) -> list[dict]:
    out = []
    for beam in data.get("beams", {}).values():
        for end in ("start", "end"):
            h = (beam.get(end) or {}).get("hinge")
            if isinstance(h, dict):
                out.append(h)
    return out


def _moving(data: dict) -> list[str]:
    return [b for b, spec in data["bodies"].items() if not spec.get("fixed") and "motion" not in spec]


def _free_hinges(data: dict) -> list[dict]:
    """Hinges neither prescribed nor driven by a torque already."""
    return [h for h in _hinges(data) if "angle" not in h and "torque" not in h]


#: ``--focus adjoint``: the scenes the adjoint takes with events (no laws of t), guided ones twice
ADJOINT_FOCUS = ("LATCH", "STOP", "SLIDER_CRANK", "SLIDER_CRANK", "GIMBAL_LOADS", "CRANK_CABLES", "CRANK_CABLES",
                 "BEAD_FOLLOWER", "BEAD_FOLLOWER", "GIMBAL_MIXED", "GIMBAL_DAMPED", "LATCHING_PD")


def random_scene(rng: random.Random, focus: str = "") -> tuple[str, str]:
    """(name of the base scene, the scene's YAML text); ``focus`` "adjoint": the base scenes of
    :data:`ADJOINT_FOCUS`, no compliant stop or friction (the adjoint refuses them by name), no point velocity
    beside a guide (refused by name)."""
    import yaml

    scenes = _scenes()
    name = rng.choice(ADJOINT_FOCUS if focus == "adjoint" else sorted(scenes))
    data = yaml.safe_load(scenes[name])
    data["title"] = f"fuzz8 {name}"
    params = data["parameters"]
    probes = data["output"]["probes"]
    controllers = data.setdefault("controllers", {}) or {}
    data["controllers"] = controllers
    kinds = []
    # rate-dependent laws on hinges (not prescribed) and guides
    for h in _hinges(data):
        if "angle" in h or rng.random() > 0.35:
            continue
        r = rng.random()
        if r < 0.5:
            params["cr"] = round(rng.uniform(0.01, 0.08), 3)
            h["damping"] = f"({h.get('damping', 'cr')})*(1 + 2*theta_dot**2)" if "damping" in h else \
                "cr*(1 + theta**2)*(1 + theta_dot**2)"
        else:
            params["cr"] = round(rng.uniform(0.01, 0.08), 3)
            law = "-cr*(1 + 10*theta**2)*theta_dot"
            h["torque"] = f"{h['torque']} {law}" if "torque" in h else law
        kinds.append("rate law")
    for b, spec in data["bodies"].items():
        g = spec.get("guide")
        if g and rng.random() < 0.3:
            params["cg"] = round(rng.uniform(0.05, 0.5), 3)
            g["damping"] = "cg*(1 + 5*s_dot**2)"
            kinds.append("guide rate law")
    moving = _moving(data)
    # a cable from a new anchor, its rest length and ρA parameters
    if rng.random() < 0.4:
        body = rng.choice(moving)
        at = data["bodies"][body]["at"]
        anchor = [round(at[0] + rng.uniform(-0.3, 0.3), 3), round(at[1] + rng.uniform(0.15, 0.35), 3),
                  round(at[2] + rng.uniform(-0.2, 0.2), 3)]
        data["bodies"]["anchor8"] = {"at": anchor, "fixed": True}
        dist = sum((a - b) ** 2 for a, b in zip(anchor, at)) ** 0.5
        params["Lc"] = round(dist * rng.uniform(0.97, 1.01), 4)
        cable = {"from": "anchor8", "to": body if rng.random() < 0.6 else {"body": body, "offset": [0.01, 0, 0.02]},
                 "EA": round(rng.uniform(10.0, 60.0), 1), "rest_length": "Lc",
                 "damping": round(rng.uniform(0.0, 0.5), 2)}
        if rng.random() < 0.5:
            params["rc"] = round(rng.uniform(0.01, 0.1), 3)
            cable["rhoA"] = "rc"
            if rng.random() < 0.4:
                cable["elements"] = 2
        data.setdefault("cables", {})["c8"] = cable
        probes["ten8"] = {"cable": "c8", "quantity": "tension"}
        kinds.append("cable")
    # a controller reading a point or a cable, driving a load or a free hinge
    if rng.random() < 0.6:
        reads = "point"
        if "c8" in data.get("cables", {}) and rng.random() < 0.5:
            reads = "cable"
        if reads == "point":
            body = rng.choice(moving)
            comp = rng.choice("xyz")
            probes["pp8"] = {"point": body, "quantity": "position", "component": comp}
            ref = round(rng.uniform(-0.1, 0.1), 3)
            output = f"Kc*({ref} - pp8)"
            guided = any("guide" in spec for spec in data["bodies"].values())
            if rng.random() < 0.4 and not (focus == "adjoint" and guided):
                probes["pv8"] = {"point": body, "quantity": "velocity", "component": comp}
                output += " - 0.1*Kc*pv8"
        else:
            q = rng.choice(["tension", "length"])
            probes["cq8"] = {"cable": "c8", "quantity": q}
            output = "-Kc*cq8" if q == "tension" else f"Kc*({params['Lc']} - cq8)"
        params["Kc"] = round(rng.uniform(0.2, 2.0), 2)
        controllers["ctl8"] = {"output": output}
        if rng.random() < 0.3:
            controllers["ctl8"]["limits"] = [-0.5, 0.5]
        free = _free_hinges(data)
        if free and rng.random() < 0.4:
            rng.choice(free)["torque"] = "0.1*ctl8"
            kinds.append(f"controller of a {reads} on a hinge")
        else:
            at = rng.choice(moving)
            load = {"at": at, "force": [0, "0.5*ctl8", "0.2*ctl8"]}
            if rng.random() < 0.5:
                load["frame"] = at
            data.setdefault("loads", []).append(load)
            kinds.append(f"controller of a {reads} on a load")
    # a compliant stop with a damping parameter, or friction, on a free hinge
    free = [h for h in _free_hinges(data) if "limits" not in h and "lock_at" not in h]
    if focus == "adjoint":
        pass
    elif free and rng.random() < (0.1 if focus == "extras" else 0.3):
        h = rng.choice(free)
        params["cd"] = round(rng.uniform(0.5, 5.0), 2)
        h["limits"] = [-0.02, 0.02]
        h["contact"] = {"stiffness": 2000.0, "exponent": 1.5, "damping": "cd"}
        kinds.append("compliant stop")
    elif free and rng.random() < 0.15:
        h = rng.choice(free)
        h["friction"] = {"coulomb": 0.01, "stribeck_rate": 0.1, "viscous": 0.02}
        kinds.append("friction")
    forced = []
    if focus == "extras":
        forced = _extras(rng, data, kinds)
    if not controllers:
        del data["controllers"]
    solve = data["solve"]
    solve.update(rng.choice([{}, {}, {"method": "hht-alpha"}, {"method": "newmark"}, {"rho_inf": 0.6}]))
    names = [p for p, v in params.items() if isinstance(v, (int, float))]
    rng.shuffle(names)
    solve["sensitivities"] = list(dict.fromkeys(forced + names))[:max(len(forced), rng.randint(1, min(8, len(names))))]
    data["title"] += " + " + ", ".join(kinds) if kinds else ""
    return name, _dump(data)


def _extras(rng: random.Random, data: dict, kinds: list) -> list[str]:
    """``--focus extras``: int20's other paths — a PI or filter state on the controller reading a point or cable
    (or on a scene's own controller reading a point), energy probes (the external work of prescribed motions with
    links among them), a geometry parameter (a moving body's ``at`` component) beside the controllers. The
    parameters the sensitivities must name."""
    params, probes, controllers = data["parameters"], data["output"]["probes"], data["controllers"]
    forced = []
    readers = [c for c in controllers if "rate" not in controllers[c] and "states" not in controllers[c]]
    if readers and rng.random() < 0.6:
        c = rng.choice(readers)
        sensed = next((p for p in ("pp8", "cq8") if p in probes and p in controllers[c]["output"]), None)
        if sensed is None:
            sensed = next((p for p, spec in probes.items() if "point" in spec and spec.get("quantity") == "position"
                           and p in controllers[c]["output"]), None)
        if sensed is not None:
            if rng.random() < 0.5:
                params["Ki"] = round(rng.uniform(0.5, 3.0), 2)
                controllers[c]["states"] = {"Si": f"0.05 - {sensed}"}
                controllers[c]["output"] = f"{controllers[c]['output']} + Ki*Si"
                forced.append("Ki")
            else:
                params["wf"] = round(rng.uniform(5.0, 30.0), 1)
                controllers[c]["states"] = {"Sf": f"wf*({sensed} - Sf)"}
                controllers[c]["output"] = f"{controllers[c]['output']} - 0.3*Sf"
                forced.append("wf")
            kinds.append("controller state")
    if rng.random() < 0.6:
        for kind in rng.sample(["external_work", "total", "kinetic", "dissipated"], rng.randint(1, 2)):
            probes[f"e_{kind}"] = {"energy": kind}
            kinds.append(f"energy {kind}")
    if rng.random() < 0.5:
        movable = [b for b, spec in data["bodies"].items() if not spec.get("fixed") and b != "anchor8"]
        body = rng.choice(movable)
        axis = rng.randrange(3)
        params["gx"] = float(data["bodies"][body]["at"][axis])
        data["bodies"][body]["at"][axis] = "gx"
        forced.append("gx")
        kinds.append("geometry parameter")
    return forced


# ---------------------------------------------------------------------------------------------------------- worker

def _switches(on: bool) -> None:
    import latdyn.analyses.adjoint_in_loop as adjoint_loop
    import latdyn.analyses.sensitivities_in_loop as loop
    import latdyn.timeloop.loop as time_loop

    loop.SENSITIVITIES_IN_LOOP = adjoint_loop.ADJOINT_IN_LOOP = time_loop.SENSITIVITY_ROWS_IN_LOOP = on


def _run(data: dict, out: Path) -> dict:
    """The run through the API: its digest and summary's derivatives, or the error's kind and message."""
    import latdyn

    try:
        result = latdyn.run(latdyn.load_scene(data), out)
    except Exception as e:   # noqa: BLE001
        import traceback

        return {"error": f"{type(e).__name__}: {e}"[:400], "error_kind": type(e).__name__,
                "where": traceback.format_exc()[-600:]}
    d = base._digest(out)
    s = result.summary
    d["status"] = s.get("status")
    d["raw_probe_sensitivities"] = s.get("probe_sensitivities")
    d["raw_event_sensitivities"] = s.get("event_sensitivities")
    d["event_times"] = [e.get("t") for e in s.get("events", [])]
    return {"digest": d}


def _compare(forward: dict, adjoint: dict) -> dict:
    """(a) The adjoint's probe derivatives (end, max, min) and event times' against the forward method's: per output
    the largest difference relative to that output's largest |derivative|."""
    worst, where = 0.0, None
    fp, ap = forward["raw_probe_sensitivities"] or {}, adjoint["raw_probe_sensitivities"] or {}
    missing = []
    for probe, by in fp.items():
        stats = {stat: values for stat, values in by.items() if isinstance(values, dict)}
        # an output whose derivatives are round-off (a latched point's in its link's frame: 1e-17) is held to
        # FLOOR of its probe's largest derivative over end, max and min instead of its own largest
        largest = max((abs(v) for values in stats.values() for v in values.values()), default=0.0)
        for stat, values in stats.items():
            other = (ap.get(probe) or {}).get(stat)
            if other is None:
                missing.append(f"{probe}.{stat}")
                continue
            scale = max(max((abs(v) for v in values.values()), default=0.0), FLOOR * largest, 1e-300)
            for name, v in values.items():
                err = abs(other.get(name, float("nan")) - v) / scale
                if not err <= worst:
                    worst, where = err, f"{probe}.{stat}/{name}"
    fe, ae = forward["raw_event_sensitivities"] or [], adjoint["raw_event_sensitivities"] or []
    if len(fe) != len(ae):
        missing.append(f"events {len(fe)} != {len(ae)}")
    for i, (a, b) in enumerate(zip(fe, ae)):
        scale = max(max((abs(v) for v in a.get("dt", {}).values()), default=0.0), 1e-300)
        for name, v in a.get("dt", {}).items():
            err = abs(b.get("dt", {}).get(name, float("nan")) - v) / scale
            if not err <= worst:
                worst, where = err, f"event[{i}].dt/{name}"
    return {"worst": worst, "where": where, "missing": missing}


def worker(scene_path: Path, out: Path) -> dict:
    import yaml

    text = scene_path.read_text()
    record: dict = {}
    forward = yaml.safe_load(text)
    adjoint = yaml.safe_load(text)
    adjoint["solve"]["sensitivity_method"] = "adjoint"
    for label, data in (("forward", forward), ("adjoint", adjoint)):
        _switches(True)
        record[label] = _run(data, out / label)
        _switches(False)
        record[f"{label}_off"] = _run(yaml.safe_load(json.dumps(data)), out / f"{label}_off")
        _switches(True)
    if "digest" in record["forward"] and "digest" in record["adjoint"]:
        record["a"] = _compare(record["forward"]["digest"], record["adjoint"]["digest"])
    if "digest" in record["forward"]:   # (f) the same scene without solve.sensitivities: its events
        plain = yaml.safe_load(text)
        for key in ("sensitivities", "sensitivity_method"):
            plain["solve"].pop(key, None)
        record["plain"] = _run(plain, out / "plain")
    (out / "adjoint.yaml").write_text(_dump(adjoint))
    return record


COMPARED = ("sensitivities.csv", "probes.csv", "probe_sensitivities", "event_sensitivities")
#: (a)'s scale's floor, relative to the probe's largest derivative over its end, max and min
FLOOR = 1e-4
#: (a)'s bound: the adjoint's derivatives against the forward method's, relative to each output's largest
BOUND = 1e-9


def judge(record: dict) -> list[str]:
    problems = []
    if "digest" in record.get("forward", {}) and "digest" in record.get("adjoint", {}):
        record["a"] = _compare(record["forward"]["digest"], record["adjoint"]["digest"])
        f, a = record["forward"]["digest"], record["adjoint"]["digest"]
        if (f["events"], f["event_times"], f["probes.csv"]) != (a["events"], a["event_times"], a["probes.csv"]):
            problems.append("adjoint's run differs from the forward method's (events or probes.csv)")
    for label in ("forward", "adjoint"):
        on, off = record.get(label, {}), record.get(f"{label}_off", {})
        for r, which in ((on, label), (off, f"{label}_off")):
            if "error" in r and r["error_kind"] not in CLEAN:
                problems.append(f"{which} crash: {r['error']}")
        if ("error" in on) != ("error" in off):
            problems.append(f"{label}: loop on {on.get('error', 'solved')[:100]} / off {off.get('error', 'solved')[:100]}")
        elif "digest" in on:
            for key in COMPARED:
                if on["digest"][key] != off["digest"][key]:
                    problems.append(f"{label} loop off != on: {key}")
        cli = record.get(f"{label}_cli")
        if cli is not None:
            if "error" in cli:
                if "error" not in on:
                    problems.append(f"{label} cli: {cli['error'][-200:]}")
            elif "digest" in on:
                for key in COMPARED:
                    if cli["digest"][key] != on["digest"][key]:
                        problems.append(f"{label} cli != api: {key}")
    plain, forward = record.get("plain", {}), record.get("forward", {})
    if "error" in plain:
        problems.append(f"plain: {plain['error'][:150]}")
    elif "digest" in plain and "digest" in forward:   # (f) measured, not judged (the module docstring)
        f, q = forward["digest"], plain["digest"]
        record["plain_first_event"] = (abs(f["event_times"][0] - q["event_times"][0])
                                       if f["event_times"] and q["event_times"] else None)
        record["plain_events_same"] = f["events"] == q["events"]
    a = record.get("a")
    if a:
        if a["missing"]:
            problems.append(f"adjoint lacks {a['missing'][:5]}")
        if not a["worst"] <= BOUND:
            problems.append(f"adjoint vs forward {a['worst']:.2e} at {a['where']}")
    if "error" in record.get("forward", {}) and "error" not in record.get("adjoint", {"error": 1}):
        problems.append("forward refused, adjoint solved")
    return problems


def _cli(case: Path, label: str, env: dict, timeout: float) -> dict:
    scene = case / ("scene.yaml" if label == "forward" else "adjoint.yaml")
    out = case / f"{label}_cli"
    try:
        c = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"], env=env,
                           capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": "timeout"}
    if c.returncode != 0:
        return {"error": f"exit {c.returncode}: {c.stderr[-300:]}", "traceback": "Traceback" in c.stderr}
    d = base._digest(out)
    return {"digest": d}


def tally_records(folders: list[Path]) -> dict:
    counts = {"cases": 0, "by_scene": {}, "forward_solved": 0, "adjoint_solved": 0, "adjoint_compared": 0,
              "same": 0, "problems": [], "forward_refused": {}, "adjoint_refused": {}, "worker_errors": [],
              "with_events": 0, "events": 0, "steps": 0, "in_loop": 0, "adjoint_worst": 0.0, "cli_checked": 0,
              "kinds": {}, "methods": {}}
    import yaml
    for folder in folders:
        for path in sorted(folder.glob("*/record.json")):
            r = json.loads(path.read_text())
            counts["cases"] += 1
            scene = yaml.safe_load((path.parent / "scene.yaml").read_text())
            name = scene["title"].split()[1]
            counts["by_scene"][name] = counts["by_scene"].get(name, 0) + 1
            method = scene["solve"].get("method", "generalized-alpha") + (
                " rho_inf" if "rho_inf" in scene["solve"] else "")
            counts["methods"][method] = counts["methods"].get(method, 0) + 1
            for k in (scene["title"].split(" + ")[1].split(", ") if " + " in scene["title"] else []):
                counts["kinds"][k] = counts["kinds"].get(k, 0) + 1
            if "worker_error" in r:
                counts["worker_errors"].append([path.parent.name, r["worker_error"][-200:]])
                continue
            for label in ("forward", "adjoint"):
                if "error" in r[label]:
                    head = r[label]["error"][:130]
                    counts[f"{label}_refused"][head] = counts[f"{label}_refused"].get(head, 0) + 1
                else:
                    counts[f"{label}_solved"] += 1
            counts["cli_checked"] += "forward_cli" in r
            if "digest" in r["forward"]:
                d = r["forward"]["digest"]
                counts["steps"] += d["steps"] or 0
                counts["in_loop"] += d["in_loop"] or 0
                counts["events"] += len(d["events"])
                counts["with_events"] += bool(d["events"])
            r["problems"] = judge(r)
            if r.get("plain_first_event") is not None:
                counts.setdefault("plain_first_event", []).append(r["plain_first_event"])
                counts["plain_events_differ"] = counts.get("plain_events_differ", 0) + (not r["plain_events_same"])
            if "a" in r:
                counts["adjoint_compared"] += 1
                counts["adjoint_worst"] = max(counts["adjoint_worst"], r["a"]["worst"])
            if r["problems"]:
                counts["problems"].append([path.parent.name, r["problems"]])
            else:
                counts["same"] += 1
    return counts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=Path("/tmp/fuzz8"))
    parser.add_argument("--show", type=int)
    parser.add_argument("--timeout", type=float, default=300)
    parser.add_argument("--cli-every", type=int, default=3, help="(d) on every N-th case")
    parser.add_argument("--worker", nargs=2)
    parser.add_argument("--richardson", nargs=2, help="SCENE OUT: (c) for one scene")
    parser.add_argument("--step", type=float, default=1e-3, help="(c)'s relative step h (Richardson of h, h/2)")
    parser.add_argument("--tally", nargs="+", type=Path)
    parser.add_argument("--focus", choices=["", "adjoint", "extras"], default="", help="adjoint: random_scene's focus")
    args = parser.parse_args(argv)
    if args.tally:
        print(json.dumps(tally_records(args.tally), indent=1))
        return 0
    if args.worker:
        print("RECORD " + json.dumps(worker(Path(args.worker[0]), Path(args.worker[1]))))
        return 0
    if args.richardson:
        print(json.dumps(base.richardson(Path(args.richardson[0]), Path(args.richardson[1]), args.step), indent=1))
        return 0
    if args.show is not None:
        print(random_scene(random.Random(f"fuzz8-{args.seed}-{args.show}"), args.focus)[1])
        return 0
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    tally: dict[str, int] = {}
    for n in range(args.first, args.first + args.runs):
        name, text = random_scene(random.Random(f"fuzz8-{args.seed}-{n}"), args.focus)
        case = args.keep / f"s{args.seed}-{n}"
        case.mkdir(parents=True, exist_ok=True)
        (case / "scene.yaml").write_text(text)
        start = time.time()
        record = base.run_worker(__file__, case, env, args.timeout)
        if "worker_error" not in record and n % args.cli_every == 0:
            for label in ("forward", "adjoint"):
                if "digest" in record[label]:
                    record[f"{label}_cli"] = _cli(case, label, env, args.timeout)
        problems = judge(record) if "worker_error" not in record else ["worker: " + record["worker_error"][-200:]]
        record["problems"] = problems
        (case / "record.json").write_text(json.dumps(record, indent=1))
        outcome = "PROBLEM" if problems else "ok"
        tally[outcome] = tally.get(outcome, 0) + 1
        f, a = record.get("forward", {}), record.get("adjoint", {})
        fd = f.get("digest", {})
        print(f"{n}: {outcome} {time.time() - start:.0f}s {name} in_loop {fd.get('in_loop')}/{fd.get('steps')} "
              f"events {fd.get('events')} fwd {f.get('error', 'ok')[:90]} adj {a.get('error', 'ok')[:90]} "
              f"a {record.get('a', {}).get('worst')} {problems}", flush=True)
    print(json.dumps(tally))
    return 0


if __name__ == "__main__":
    sys.exit(main())
