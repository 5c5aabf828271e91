"""Combinations fuzzing of int19's merges in the sensitivities' loop of steps (session 2026-11-28 eleventh, helper fuzz6).

int19 brought into the compiled loop: continuous controllers with states (PI, filters), controllers reading inputs,
cable tensions and lengths, element forces and hinge torques, controllers on models with rigid links and guides, the
work accounts with laws of θ and θ̇, prescribed drives and reels beside controllers and loads of t, and the exact
impulse-weight derivatives. This driver writes random 3D scenes (YAML text) that combine them, from two families:

- ``boom``: benchmarks/fuzz_combined.py's random boom (fixed or prescribed base, latch or stop with restitution,
  cable or reel, PD / chained / sampled controllers, loads of t), then, at random: the PD given a PI state or a
  filter state (clipped or not, a probe of the state), a reader controller on an input, the cable's tension, the
  first element's axial force or a hinge's torque (sometimes with a state), damping laws of θ̇ and torque laws of θ,
  energy probes (dissipated, external work, total) now allowed beside controllers;
- ``linked``: the 3D gimbal, slewing gimbal, guided bead, prescribed slider-crank, closed slider-crank and chain of
  tests/test_sensitivities_in_loop_linked_controllers.py, with at random a PI or filter state on the controller, an
  input, limits, damping laws of θ̇, energy probes, the method and the parameters' subset.

For each case (a process of its own) benchmarks/fuzz_combined.py's checks: (a) loop on against every switch off, (b)
API against ``latdyn run``, (c) API Ctrl-C and resume, command SIGINT and ``--resume``; and here (e): the probes of the
same run without ``solve.sensitivities`` (sha-256 of probes.csv, and the largest difference relative to each column's
largest value). ``--richardson SCENE OUT`` is (d) (fuzz_combined.richardson).

``python benchmarks/fuzz_combined2.py --family boom --runs 100 --seed 1 --keep DIR``; ``--show N`` prints a scene.
Not run by the suite.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import json
import os
import random
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import fuzz_combined as base  # noqa: E402


def _dump(data: dict) -> str:
    import yaml

    return yaml.safe_dump(data, sort_keys=False, width=1000, default_flow_style=None)


def _probe_names(data: dict) -> dict:
    return data["output"]["probes"]


def _add_state(rng: random.Random, data: dict, name: str, reads: str, listed: list[str]) -> None:
    """Give controller ``name`` a PI state (∫(set − reads)) or a first-order filter of ``reads``, at random clipped,
    with a probe of the state."""
    c = data["controllers"][name]
    params = data["parameters"]
    if rng.random() < 0.5:
        params["Ki"] = round(rng.uniform(0.5, 4.0), 2)
        c["states"] = {"Si": f"0.2 - {reads}"}
        c["output"] = f"{c['output']} + Ki*Si"
        listed.append("Ki")
        state = "Si"
    else:
        params["wf"] = round(rng.uniform(5.0, 30.0), 1)
        c["states"] = {"Sf": f"wf*({reads} - Sf)"}
        c["output"] = f"{c['output']} - 0.4*Sf"
        listed.append("wf")
        state = "Sf"
    if rng.random() < 0.3:
        c["initial"] = {state: 0.05}
    if rng.random() < 0.35 and "limits" not in c:
        c["limits"] = [-1.5, 1.5]
    if rng.random() < 0.3:   # (the loop of steps declines a probe of a state: those runs take the Python path)
        _probe_names(data)[f"st_{name}"] = {"controller": name, "state": state}


def random_boom(rng: random.Random) -> str:
    """fuzz_combined's boom with int19's kinds added."""
    import yaml

    data = yaml.safe_load(base.random_scene(rng))
    data["title"] = "fuzz6 combined boom"
    probes = _probe_names(data)
    listed = list(data["solve"]["sensitivities"])
    controllers = data.get("controllers") or {}
    beams = data["beams"]
    hinges = [b for b in beams if "start" in beams[b]]
    last = max(b for b in data["bodies"] if b.startswith("n"))
    reads = next(p for p in probes if p.startswith("a"))
    # the PD with a state (its rate terms dropped: a controller with states reading a rate is refused by name)
    if "pd" in controllers and rng.random() < 0.6:
        if rng.random() < 0.85:
            controllers["pd"]["output"] = controllers["pd"]["output"].split(")")[0] + ") - 0.3*tip_z"
        _add_state(rng, data, "pd", reads, listed)
    elif rng.random() < 0.5:   # a PI of its own on the angle, driving a load on the tip
        data["parameters"]["Kq"] = round(rng.uniform(0.5, 3.0), 2)
        listed.append("Kq")
        controllers["ctl_i"] = {"output": f"Kq*(0.2 - {reads})"}
        data["controllers"] = controllers
        _add_state(rng, data, "ctl_i", reads, listed)
        data.setdefault("loads", []).append({"at": last, "force": ["0.5*ctl_i", 0, "ctl_i"]})
    # a reader of an input or a force
    if rng.random() < 0.6:
        what = rng.choice(["input", "tension", "axial", "torque", "length"])
        if what in ("tension", "length") and not data.get("cables"):
            what = "input"
        if what == "input":
            data["inputs"] = {"u": round(rng.uniform(-0.3, 0.3), 3)}
            sensed = "u"
        elif what in ("tension", "length"):
            sensed = "pull" if what == "tension" else "span"
            probes[sensed] = {"cable": "tie", "quantity": what}
        elif what == "axial":
            sensed = "ax"
            probes[sensed] = {"element": "b0.element[0]", "quantity": "axial_force"}
        else:
            sensed = "tq"
            probes[sensed] = {"hinge": f"{rng.choice(hinges)}.start", "quantity": "torque"}
        data["parameters"]["Kr"] = round(rng.uniform(0.01, 0.2), 3)
        listed.append("Kr")
        controllers["rd"] = {"output": f"Kr*{sensed} + 0.1*sin(3*t)" if rng.random() < 0.5 else f"Kr*{sensed}"}
        if rng.random() < 0.3:
            controllers["rd"]["limits"] = [-0.5, 0.5]
        data["controllers"] = controllers
        if rng.random() < (0.5 if sensed in ("u", "span") else 0.1):   # with states (refused when it reads a force)
            _add_state(rng, data, "rd", sensed, listed)
        free = [b for b in hinges if not any(c in str(beams[b]["start"]["hinge"].get("torque", ""))
                                             for c in controllers if c != "rd")]
        if not free or rng.random() < 0.5:
            data.setdefault("loads", []).append({"at": last, "force": [0, "rd", "0.5*rd"]})
        else:
            h = beams[rng.choice(free)]["start"]["hinge"]
            h["torque"] = f"{h['torque']} + rd" if "torque" in h else "rd"
    # damping laws of θ̇ and torque laws of θ
    for b in hinges:
        h = beams[b]["start"]["hinge"]
        r = rng.random()
        if r < 0.3:
            h["damping"] = f"({h.get('damping', 0.1)})*(1 + theta_dot**2)"
        elif r < 0.5:
            h["torque"] = f"{h['torque']} - 0.2*sin(theta)" if "torque" in h else "-0.2*sin(theta) + 0.1*theta**2"
    _energies(rng, data)
    rng.shuffle(listed)
    data["solve"]["sensitivities"] = list(dict.fromkeys(listed))[:rng.randint(1, min(10, len(set(listed))))]
    return _dump(data)


def _linked_scenes() -> dict:
    from tests import test_sensitivities_in_loop_linked_controllers as t

    return {name: getattr(t, name) for name in ("POINT_PD", "LATCHING_PD", "OFFSET_PD", "LOAD_PUSH", "CHAIN",
                                                "SAMPLED", "POINT_PD_T", "BEAD", "BOB_PD", "SLEWING_PD",
                                                "CLOSED_PD")}


def random_linked(rng: random.Random) -> str:
    """A linked scene of the tests with int19's kinds added."""
    import yaml

    scenes = _linked_scenes()
    name = rng.choice(sorted(scenes))
    text = scenes[name]
    if rng.random() < 0.4:
        text = text.replace('damping: "c2"', 'damping: "c2*(1 + theta_dot**2)"')
    data = yaml.safe_load(text)
    data["title"] = f"fuzz6 linked {name}"
    probes = _probe_names(data)
    listed = list(data["solve"]["sensitivities"])
    controllers = data.get("controllers", {})
    continuous = [c for c in controllers if "rate" not in controllers[c]]
    rates = [p for p, spec in probes.items() if spec.get("quantity") in ("velocity", "rate")]
    stateless = [c for c in continuous if not any(r in controllers[c]["output"] for r in rates)
                 and not any(c in controllers[o]["output"] for o in controllers if o != c)]
    if stateless and rng.random() < 0.8:
        c = rng.choice(stateless)
        readable = [p for p, spec in probes.items() if ("point" in spec or "hinge" in spec or "guide" in spec)
                    and spec.get("quantity") in ("position", "angle")]
        if readable:
            _add_state(rng, data, c, rng.choice(readable), listed)
    if continuous and rng.random() < 0.3:
        c = rng.choice(continuous)
        data["inputs"] = {"u": round(rng.uniform(-0.1, 0.1), 3)}
        controllers[c]["output"] += " + 0.5*u"
    if continuous and rng.random() < 0.3:
        c = rng.choice(continuous)
        controllers[c].setdefault("limits", [-1.0, 1.0])
    _energies(rng, data)
    solve = data["solve"]
    solve.update(rng.choice([{}, {}, {"method": "hht-alpha"}, {"method": "newmark"}, {"rho_inf": 0.6}]))
    if rng.random() < 0.1:
        solve["sensitivity_method"] = "adjoint"
    rng.shuffle(listed)
    solve["sensitivities"] = list(dict.fromkeys(listed))[:rng.randint(1, len(set(listed)))]
    return _dump(data)


def _energies(rng: random.Random, data: dict) -> None:
    """0–2 energy probes, mostly where they are not refused by name (cables; the external work with controllers;
    the dissipated energy through events)."""
    text = json.dumps(data)
    kinds = ["total", "kinetic", "dissipated", "external_work"]
    if rng.random() < 0.85:
        if data.get("cables"):
            kinds = []
        if "guide" in text:
            kinds = [k for k in kinds if k == "dissipated"]
        if data.get("controllers"):
            kinds = [k for k in kinds if k != "external_work"]
        if "lock_at" in text or "limits" in text.replace('"limits": [-1.5, 1.5]', "").replace('"limits": [-0.5, 0.5]', ""):
            kinds = [k for k in kinds if k != "dissipated"]
    for kind in dict.fromkeys(rng.sample(kinds, rng.randint(0, min(2, len(kinds))))):
        data["output"]["probes"][f"e_{kind}"] = {"energy": kind}


def tally_records(folders: list[Path]) -> dict:
    """Counts over the cases' record.json files under ``folders``: cases, solved (and the same on every path),
    refused or failed (by message head), steps in the loop, events, the loop's refusals, and (e)."""
    counts = {"cases": 0, "solved": 0, "same": 0, "problems": [], "refused": {}, "steps": 0, "in_loop": 0,
              "with_events": 0, "events": 0, "loop_refusals": {}, "plain_bit_equal": 0, "plain_with_events": [],
              "cli_resumed": 0, "resumed": 0, "worker_errors": []}
    for folder in folders:
        for path in sorted(folder.glob("*/record.json")):
            r = json.loads(path.read_text())
            counts["cases"] += 1
            if "worker_error" in r:
                counts["worker_errors"].append(path.parent.name)
                continue
            if "on" not in r:
                head = r.get("on_error", "")[:150]
                counts["refused"][head] = counts["refused"].get(head, 0) + 1
                continue
            counts["solved"] += 1
            problems = judge(r)
            if problems:
                counts["problems"].append([path.parent.name, problems])
            else:
                counts["same"] += 1
            on = r["on"]
            counts["steps"] += on["steps"] or 0
            counts["in_loop"] += on["in_loop"] or 0
            counts["events"] += len(on["events"])
            counts["with_events"] += bool(on["events"])
            counts["resumed"] += "resumed" in r
            counts["cli_resumed"] += "cli_resumed" in r
            reason = (r.get("loop_refusal") or "")[:80]
            if reason:
                counts["loop_refusals"][reason] = counts["loop_refusals"].get(reason, 0) + 1
            if r.get("plain_same"):
                counts["plain_bit_equal"] += 1
            elif on["events"]:
                counts["plain_with_events"].append([path.parent.name, r.get("plain_worst"),
                                                    r.get("plain_worst_column")])
    return counts


GENERATORS = {"boom": random_boom, "linked": random_linked}


def _columns(path: Path) -> dict:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}


def without_sensitivities(scene_path: Path, out: Path) -> dict:
    """(e) The same scene without ``solve.sensitivities``: probes.csv's sha-256 and the largest difference of each
    column relative to its largest |value|, against the run with them (``out/on``)."""
    import yaml

    import latdyn

    data = yaml.safe_load(scene_path.read_text())
    for key in ("sensitivities", "sensitivity_method"):
        data["solve"].pop(key, None)
    try:
        latdyn.run(latdyn.load_scene(data), out / "plain")
    except Exception as e:   # noqa: BLE001
        return {"plain_error": f"{type(e).__name__}: {e}"[:300]}
    a, b = _columns(out / "on" / "probes.csv"), _columns(out / "plain" / "probes.csv")
    record = {"plain_same": (out / "on" / "probes.csv").read_bytes() == (out / "plain" / "probes.csv").read_bytes()}
    if set(a) != set(b) or len(a["t"]) != len(b["t"]):
        record["plain_shape"] = [len(a.get("t", [])), len(b.get("t", []))]
        return record
    worst = {}
    for k in a:
        scale = max(max(abs(x) for x in a[k]), 1e-300)
        worst[k] = max(abs(x - y) for x, y in zip(a[k], b[k])) / scale
    record["plain_worst"] = max(worst.values())
    record["plain_worst_column"] = max(worst, key=worst.get)
    s = json.loads((out / "plain" / "summary.json").read_text())
    record["plain_steps"] = s.get("steps")
    record["plain_events"] = [e.get("kind") for e in s.get("events", [])]
    return record


def worker(scene_path: Path, out: Path) -> dict:
    import latdyn.analyses.sensitivities_in_loop as loop

    reasons: list = []
    original = loop.refusal

    def refusal(owner):
        reason = original(owner)
        reasons.append(reason)
        return reason

    loop.refusal = refusal
    try:
        record = base.worker(scene_path, out)
    finally:
        loop.refusal = original
    record["loop_refusal"] = reasons[0] if reasons else None
    if "on" in record:
        record.update(without_sensitivities(scene_path, out))
    return record


def judge(record: dict) -> list[str]:
    problems = base.judge(record)
    if "on" in record:
        if "plain_error" in record:
            problems.append(f"plain: {record['plain_error']}")
        elif "plain_shape" in record:
            problems.append(f"plain rows {record['plain_shape']}")
        elif not record["plain_same"] and not record["on"]["events"]:
            # with events the run with sensitivities lands on them to 1e-12 and restarts at dt after them, the run
            # without at the events' tolerance (docs/parameters.md, "The landing step"): only runs without events
            # are held to the bit here; the others' differences are recorded (plain_worst)
            problems.append(f"plain differs {record.get('plain_worst', 0):.2e} in {record.get('plain_worst_column')}")
        elif not record["plain_same"]:   # by the events' landing and the steps after them: measured, not judged
            if record.get("plain_events") != record["on"]["events"]:
                problems.append(f"plain events {record.get('plain_events')} != {record['on']['events']}")
    return problems


def arguments(generators: dict, keep: Path, seed: int) -> argparse.ArgumentParser:
    """The campaign's command line (this driver's and benchmarks/fuzz_combined3.py's)."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--family", choices=sorted(generators), default="boom")
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=seed)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=keep)
    parser.add_argument("--show", type=int)
    parser.add_argument("--timeout", type=float, default=300)
    parser.add_argument("--no-cli", action="store_true", help="skip (b) and the command's (c)")
    parser.add_argument("--worker", nargs=2)
    parser.add_argument("--richardson", nargs=2, help="SCENE OUT: (d) for one scene")
    parser.add_argument("--tally", nargs="+", type=Path, help="DIR…: counts over the records kept there")
    return parser


def campaign(args, script: str, generate, judge_record, line=lambda record: "") -> dict:
    """``args.runs`` cases of ``generate`` from ``args.first``, each ``script --worker`` in a process of its own and
    the command's checks, judged by ``judge_record`` and kept under ``args.keep``; a line per case (``line``: what it
    adds). Returns the outcomes' counts."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    tally: dict[str, int] = {}
    for n in range(args.first, args.first + args.runs):
        text = generate(random.Random(f"{args.family}-{args.seed}-{n}"))
        case = args.keep / f"{args.family}-s{args.seed}-{n}"
        case.mkdir(parents=True, exist_ok=True)
        (case / "scene.yaml").write_text(text)
        start = time.time()
        record = base.run_worker(script, case, env, args.timeout)
        if "on" in record and not args.no_cli:
            record.update(base.command_checks(case, env, args.timeout, random.Random(f"{args.seed}-{n}-stop")))
        outcome = base.judged(record, judge_record, case, tally)
        on = record.get("on", {})
        print(f"{n}: {outcome} {time.time() - start:.0f}s in_loop {on.get('in_loop')}/{on.get('steps')} "
              f"events {on.get('events')} plain {record.get('plain_same')} {record.get('plain_worst')} {line(record)}"
              f"{record['problems'] or record.get('on_error', '') or record.get('worker_error', '')[-200:]}", flush=True)
    return tally


def answered(args, generators: dict, tally, work) -> bool:
    """Whether ``args`` asked for one of the campaign's other answers, printed here: ``--tally`` (by ``tally``),
    ``--worker`` (by ``work``), ``--richardson`` or ``--show``."""
    if args.tally:
        print(json.dumps(tally(args.tally), indent=1))
    elif args.worker:
        print("RECORD " + json.dumps(work(Path(args.worker[0]), Path(args.worker[1]))))
    elif args.richardson:
        print(json.dumps(base.richardson(Path(args.richardson[0]), Path(args.richardson[1])), indent=1))
    elif args.show is not None:
        print(generators[args.family](random.Random(f"{args.family}-{args.seed}-{args.show}")))
    else:
        return False
    return True


def main(argv=None) -> int:
    args = arguments(GENERATORS, Path("/tmp/fuzz6"), 1).parse_args(argv)
    if not answered(args, GENERATORS, tally_records, worker):
        print(json.dumps(campaign(args, __file__, GENERATORS[args.family], judge)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
