"""Combinations fuzzing of int19/int20's merges, the kinds least tried together (session 2026-11-28 twelfth, helper fuzz7).

benchmarks/fuzz_combined2.py's two families of random 3D scenes, with these added at random:

- ``boom``: a sampled controller beside a controller with states, the states probed; a load actuator in a body's own
  axes (a controller's force and moment at the tip in the tip's frame); a compliant stop (``contact``) and Coulomb
  friction on a free hinge; a slewing prescribed base; a cable whose rest length is a parameter, chosen to go slack and
  taut; an initial angular velocity and a body's position (geometry) as parameters; damping laws of θ̇ with a parameter;
  every energy probe at random (refusals are counted, not avoided);
- ``linked``: the gimbals of rigid links, the guided bead, the slider-cranks and the slewing gimbal of
  tests/test_sensitivities_in_loop_linked_controllers.py, with at random the guide's stops made compliant or turned into
  a latch, friction on the guide, a sampled controller beside the states, a load actuator in a body's axes, an initial
  velocity parameter, the states probed;
- ``conservative``: ``boom`` stripped of dampers, stops, latches, friction and restitution, under Newmark (the
  trapezoidal rule): (f) ``summary.json``'s energy_balance_error judged there (≤ progress.DRIFT_WARNING, 1e-2).

Each case: fuzz_combined2's checks, (a) loop on against every switch off, (b) API against ``latdyn run``, (c) the API
interrupted and resumed and ``latdyn run`` sent SIGINT then ``--resume``, (e) the probes without
``solve.sensitivities``; and (f) the run's energy_balance_error and warnings kept in the record. ``--richardson SCENE
OUT`` is (d) (fuzz_combined.richardson). ``--tally DIR…`` counts the kept records, with (f)'s table.

``python benchmarks/fuzz_combined3.py --family boom|linked|conservative --runs 100 --seed 7 --keep DIR``; ``--show N``
prints a scene. Not run by the suite.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import random
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import fuzz_combined as base  # noqa: E402
from benchmarks import fuzz_combined2 as two  # noqa: E402

#: (f): energy_balance_error past which a conservative case is a finding (latdyn.timeloop.progress.DRIFT_WARNING)
DRIFT = 1e-2


def _movable(data: dict) -> list[str]:
    """Bodies with a mass of their own that are neither fixed nor prescribed."""
    return [b for b, spec in data["bodies"].items() if "mass" in spec and not spec.get("fixed") and "motion" not in spec]


def _readable(data: dict) -> list[str]:
    """Probes a controller may read (positions and angles; a state reading a rate is refused by name)."""
    return [p for p, spec in data["output"]["probes"].items()
            if ("point" in spec or "hinge" in spec or "guide" in spec) and spec.get("quantity") in ("position", "angle")]


def _sampled_beside_states(rng: random.Random, data: dict) -> None:
    """A sampled controller (50 Hz: a whole number of every step size drawn) reading a position, driving a load on a
    movable body; each controller with states gets its states probed."""
    controllers = data.setdefault("controllers", {})
    reads = rng.choice(_readable(data))
    if not any("rate" in c for c in controllers.values()):
        data["parameters"]["G2"] = round(rng.uniform(0.5, 3.0), 2)
        controllers["smp"] = {"output": f"G2*(0.1 - {reads})", "rate": 50}
        if rng.random() < 0.3:
            controllers["smp"]["limits"] = [-1.0, 1.0]
        data.setdefault("loads", []).append({"at": rng.choice(_movable(data)), "force": ["0.2*smp", 0, "0.1*smp"]})
    for name, c in controllers.items():
        for state in c.get("states", {}):
            if rng.random() < 0.7:
                data["output"]["probes"][f"st_{name}_{state}"] = {"controller": name, "state": state}


def _actuator_in_body_axes(rng: random.Random, data: dict) -> None:
    """A controller's force and moment on a movable body, in that body's own axes."""
    controllers = data.get("controllers") or {}
    if not controllers:
        return
    drive = rng.choice(sorted(controllers))
    body = rng.choice(_movable(data))
    data.setdefault("loads", []).append({"at": body, "force": [0, f"0.2*{drive}", f"-0.1*{drive}"],
                                         "moment": [f"0.01*{drive}", 0, 0], "frame": body})


def _compliant(rng: random.Random, params: dict, joint: dict, lo: float, hi: float) -> None:
    """Limits made a compliant stop (Hunt–Crossley), its stiffness a parameter."""
    joint.pop("restitution", None)
    joint.setdefault("limits", [lo, hi])
    params["kc"] = round(rng.uniform(50.0, 400.0), 1)
    joint["contact"] = {"stiffness": "kc", "exponent": rng.choice([1, 1.5, 2]), "damping": rng.choice([0, 0.2, 1.0])}


def _friction(rng: random.Random, params: dict, joint: dict) -> None:
    params["mu"] = round(rng.uniform(0.005, 0.05), 4)
    joint["friction"] = {"coulomb": "mu", "viscous": rng.choice([0, 0.05])}


def _unrefused(data: dict) -> None:
    """What fuzz_combined2's scenes combine that the package refuses by name, taken out (seed 8 on: 64 of 88 cases were
    refused, the most often for these): a continuous controller reading one with states (the reader's word for it
    made 0), a reader of a hinge's torque whose law names t beside events (it reads the first element's axial force
    instead)."""
    import re

    controllers = data.get("controllers") or {}
    with_states = [c for c, spec in controllers.items() if "states" in spec]
    for name, spec in controllers.items():
        for c in with_states:
            if c != name and "rate" not in spec:
                spec["output"] = re.sub(rf"\b{c}\b", "0", spec["output"])
    probes = data["output"]["probes"]
    text = json.dumps(data)
    if "tq" in probes and ("lock_at" in text or "limits" in text or data.get("cables")):
        probes["tq"] = {"element": "b0.element[0]", "quantity": "axial_force"}


def _parameters(rng: random.Random, data: dict) -> None:
    """1–10 of the scene's parameters listed, of every kind it has."""
    names = list(data["parameters"])
    rng.shuffle(names)
    data["solve"]["sensitivities"] = names[:rng.randint(1, min(10, len(names)))]


def random_boom(rng: random.Random) -> str:
    """fuzz_combined2's boom with the least tried kinds added."""
    import yaml

    data = yaml.safe_load(two.random_boom(rng))
    data["title"] = "fuzz7 combined boom"
    params = data["parameters"]
    beams, bodies = data["beams"], data["bodies"]
    last = max(b for b in bodies if b.startswith("n"))
    if rng.random() < 0.6:
        _sampled_beside_states(rng, data)
    if rng.random() < 0.5:
        _actuator_in_body_axes(rng, data)
    free = [b for b in beams if "start" in beams[b] and not {"lock_at", "limits"} & set(beams[b]["start"]["hinge"])]
    if free and rng.random() < 0.35:
        _compliant(rng, params, beams[rng.choice(free)]["start"]["hinge"], -0.3, 0.25)
    if free and rng.random() < 0.15:
        _friction(rng, params, beams[rng.choice(free)]["start"]["hinge"])
    if bodies["base"].get("fixed") and rng.random() < 0.3:   # a slewing base
        del bodies["base"]["fixed"]
        # (a parameter in a prescribed motion is refused by name)
        bodies["base"]["motion"] = {"rotation": {"axis": [0.1, 0.2, 1.0], "angle": f"{round(rng.uniform(0.5, 2.0), 2)}*t**2"}}
        data.pop("initial_velocity", None)
    for cable in (data.get("cables") or {}).values():
        if rng.random() < 0.6:   # slack at the start or taut: a rest length about the span, a parameter
            d = math.dist(bodies["base"]["at"], bodies[last]["at"])
            params["L0"] = round(d * rng.uniform(0.995, 1.01), 4)
            cable["rest_length"] = "L0 - 0.2*t" if rng.random() < 0.3 else "L0"
    if "motion" not in bodies["base"] and rng.random() < 0.4:
        params["w0"] = round(rng.uniform(0.5, 3.0), 2)
        data["initial_velocity"] = {"angular": [0, 0, "w0"]}
    if "motion" not in bodies["base"] and rng.random() < 0.3:   # geometry: the first body's height (refused by name
        # beside a prescribed rotation)
        params["z1"] = float(bodies["n1"]["at"][2])
        bodies["n1"]["at"][2] = "z1"
    hinges = [b for b in beams if "start" in beams[b]]
    if rng.random() < 0.4:
        h = beams[rng.choice(hinges)]["start"]["hinge"]
        params["cd"] = 0.1
        h["damping"] = "cd*(1 + 0.5*theta_dot**2)"
    if not data.get("cables") and rng.random() < 0.1:   # beyond fuzz_combined2's, which avoids the kinds refused
        for kind in rng.sample(["total", "kinetic", "dissipated", "external_work"], rng.randint(1, 2)):
            data["output"]["probes"][f"e_{kind}"] = {"energy": kind}
    data["solve"].pop("sensitivity_method", None)
    data["solve"].pop("method", None)
    data["solve"].pop("rho_inf", None)
    data["solve"].update(rng.choice([{}, {}, {"method": "hht-alpha"}, {"method": "newmark"}, {"rho_inf": 0.6}]))
    if rng.random() < 0.2:
        data["solve"]["sensitivity_method"] = "adjoint"
    _unrefused(data)
    _parameters(rng, data)
    return two._dump(data)


def random_linked(rng: random.Random) -> str:
    """fuzz_combined2's linked scene with the least tried kinds added."""
    import yaml

    data = yaml.safe_load(two.random_linked(rng))
    data["title"] = data["title"].replace("fuzz6", "fuzz7")
    params, bodies = data["parameters"], data["bodies"]
    for name, spec in bodies.items():
        guide = spec.get("guide")
        if guide is None:
            continue
        r = rng.random()
        if r < 0.35:
            _compliant(rng, params, guide, *guide.get("limits", [-0.05, 0.03]))
        elif r < 0.6 and "limits" in guide:   # a latch on the bead
            guide.pop("limits")
            guide.pop("restitution", None)
            guide["lock_at"] = rng.choice([0.02, -0.02])
        if rng.random() < 0.2:
            _friction(rng, params, guide)
    for beam in data["beams"].values():
        hinge = beam.get("start", {}).get("hinge", {})
        if "limits" in hinge and rng.random() < 0.4:
            _compliant(rng, params, hinge, *hinge["limits"])
    if rng.random() < 0.5:
        _sampled_beside_states(rng, data)
    if rng.random() < 0.5:
        _actuator_in_body_axes(rng, data)
    iv = data.get("initial_velocity", {}).get("angular")
    if iv and rng.random() < 0.5:
        params["w0"] = float(iv[2])
        iv[2] = "w0"
    if rng.random() < 0.1:
        for kind in rng.sample(["total", "kinetic", "dissipated", "external_work"], rng.randint(1, 2)):
            data["output"]["probes"][f"e_{kind}"] = {"energy": kind}
    _unrefused(data)
    _parameters(rng, data)
    return two._dump(data)


def random_conservative(rng: random.Random) -> str:
    """:func:`random_boom` with every declared loss taken out (dampers, stops, latches, restitution, friction), the
    events with them, under Newmark: what remains keeps energy but for the work it declares and the step's error."""
    import yaml

    data = yaml.safe_load(random_boom(rng))
    data["title"] = "fuzz7 conservative boom"
    for beam in data["beams"].values():
        hinge = beam.get("start", {}).get("hinge")
        if hinge:
            for key in ("lock_at", "limits", "restitution", "contact", "friction"):
                hinge.pop(key, None)
            hinge["damping"] = 0
    for key in ("rho_inf", "sensitivity_method"):
        data["solve"].pop(key, None)
    data["solve"]["method"] = "newmark"
    _parameters(rng, data)
    return two._dump(data)


GENERATORS = {"boom": random_boom, "linked": random_linked, "conservative": random_conservative}


def worker(scene_path: Path, out: Path) -> dict:
    """fuzz_combined2's worker, with (f): the run's energy_balance_error and warnings."""
    record = two.worker(scene_path, out)
    summary = out / "on" / "summary.json"
    if "on" in record and summary.exists():
        s = json.loads(summary.read_text())
        record["energy_balance_error"] = s.get("energy_balance_error")
        record["warnings"] = [w[:160] for w in s.get("warnings", [])]
    return record


def judge(record: dict, conservative: bool = False) -> list[str]:
    problems = two.judge(record)
    error = record.get("energy_balance_error")
    if conservative and "on" in record and (error is None or error > DRIFT):
        problems.append(f"(f) energy_balance_error {error}")
    return problems


def tally_records(folders: list[Path]) -> dict:
    """fuzz_combined2's counts, and (f): energy_balance_error by whether the run had events, and the drift warnings."""
    counts = two.tally_records(folders)
    balance = {"no events": [], "events": []}
    for folder in folders:
        for path in sorted(folder.glob("*/record.json")):
            r = json.loads(path.read_text())
            if "on" in r and r.get("energy_balance_error") is not None:
                balance["events" if r["on"]["events"] else "no events"].append((r["energy_balance_error"],
                                                                              path.parent.name))
    for key, values in balance.items():
        values.sort()
        counts[f"(f) {key}"] = {"n": len(values), "median": values[len(values) // 2][0] if values else None,
                                "largest": values[-3:]}
    return counts


def interrupted_by_the_clock(case: Path, env: dict, rng: random.Random, timeout: float) -> dict:
    """(c) through the command: ``latdyn run --checkpoint-every 0`` sent SIGINT once its checkpoint has been written a
    number of times drawn from ``rng`` (1–8; fuzz_combined's poll of probes.csv's rows never saw a row before the end,
    the rows being written in blocks), then ``latdyn run --resume``; the digest against an uninterrupted run's
    (``case/clock_whole``). Interrupted before its first step, a run leaves no checkpoint and ``--resume`` refuses."""
    import signal
    import subprocess

    command = [sys.executable, "-m", "latdyn", "run", str(case / "scene.yaml"), "-q"]
    whole = subprocess.run(command + ["-o", str(case / "clock_whole")], env=env, capture_output=True, text=True,
                           timeout=timeout)
    if whole.returncode != 0:
        return {"clock_error": whole.stderr[-300:]}
    out = case / "clock"
    writes = rng.randint(1, 8)   # the checkpoint's writes to wait for
    # a command started in the background of a shell (``( … &)``) inherits SIGINT ignored, and Python then sets no
    # handler (signal.getsignal: SIG_IGN): this pass, run so, saw every run of seed 8 "finish before the interruption"
    # (and so, maybe, fuzz_combined2's campaigns: cli_resumed 0 of 201); the child takes the default disposition back
    process = subprocess.Popen(command + ["-o", str(out), "--checkpoint-every", "0"], env=env,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    seen, last = 0, None
    checkpoint = out / "checkpoint.npz"
    while process.poll() is None and seen < writes:
        try:
            stat = checkpoint.stat()
            stamp = (stat.st_ino, stat.st_mtime_ns, stat.st_size)   # each write replaces the file
        except FileNotFoundError:
            stamp = None
        if stamp is not None and stamp != last:
            seen, last = seen + 1, stamp
        time.sleep(0.001)
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
    process.wait(timeout=timeout)
    record = {"clock_writes": writes, "clock_rc": process.returncode}
    summary = out / "summary.json"
    status = json.loads(summary.read_text()).get("status") if summary.exists() else None
    record["clock_status"] = status
    if process.returncode == 0:
        record["clock_note"] = "finished before the interruption"
        return record
    if status == "interrupted" and not json.loads(summary.read_text()).get("steps"):
        record["clock_note"] = "interrupted before the first step"   # no checkpoint: --resume refuses (exit 2)
        return record
    if status != "interrupted":
        record["clock_error"] = f"exit {process.returncode}, status {status}: {process.stderr.read()[-300:]}"
        return record
    resumed = subprocess.run(command + ["-o", str(out), "--resume"], env=env, capture_output=True, text=True,
                             timeout=timeout)
    if resumed.returncode != 0:
        record["clock_error"] = f"resume exit {resumed.returncode}: {resumed.stderr[-300:]}"
        return record
    a, b = base._digest(case / "clock_whole"), base._digest(out)
    record["clock_same"] = all(a[k] == b[k] for k in base.COMPARED) and a["in_loop"] == b["in_loop"]
    return record


def interrupt_cases(folders: list[Path], timeout: float) -> dict:
    """:func:`interrupted_by_the_clock` on every solved case kept under ``folders``: the counts."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    counts = {"cases": 0, "interrupted and resumed, same": 0, "differs": [], "errors": []}
    for folder in folders:
        for path in sorted(folder.glob("*/record.json")):
            if "on" not in json.loads(path.read_text()):
                continue
            counts["cases"] += 1
            record = interrupted_by_the_clock(path.parent, env, random.Random(path.parent.name), timeout)
            (path.parent / "clock.json").write_text(json.dumps(record, indent=1))
            if "clock_error" in record:
                counts["errors"].append([path.parent.name, record["clock_error"]])
            elif "clock_note" in record:
                counts[record["clock_note"]] = counts.get(record["clock_note"], 0) + 1
            elif record["clock_same"]:
                counts["interrupted and resumed, same"] += 1
            else:
                counts["differs"].append(path.parent.name)
            print(path.parent.name, record, flush=True)
    return counts


def main(argv=None) -> int:
    parser = two.arguments(GENERATORS, Path("/tmp/fuzz7"), 7)
    parser.add_argument("--interrupt", nargs="+", type=Path,
                        help="DIR…: (c) by the clock (interrupted_by_the_clock) on the solved cases kept there")
    args = parser.parse_args(argv)
    if args.interrupt:
        print(json.dumps(interrupt_cases(args.interrupt, args.timeout), indent=1))
        return 0
    if two.answered(args, GENERATORS, tally_records, worker):
        return 0
    generate = GENERATORS[args.family]
    conservative = args.family == "conservative"
    print(json.dumps(two.campaign(args, __file__, generate, lambda record: judge(record, conservative),
                                  lambda record: f"ebe {record.get('energy_balance_error')} ")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
