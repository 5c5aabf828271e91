"""Sensitivity fuzzing: random scenes with ``parameters`` and ``solve.sensitivities``, their derivatives
checked against central differences of whole runs (issue 34).

A wrong derivative reported as solved is the worst defect a sensitivity can have. Each case takes a random
scene of ``benchmarks/fuzz_runs.py``'s generator (with the keys of 2026-11-26: guides, cables, contact,
friction, inputs, controllers), turns it into an analysis that differentiates — transient with an implicit
method (generalized-α, HHT-α, Newmark; fixed or adaptive steps) or static by load control or arc length —
with the Newton tolerance ``solve.tol: 1e-12``, and names a random handful of its numbers as parameters
(:func:`parameterise`: section values, body mass, inertia, centre of mass and position, hinge and guide
laws, rest angles, compliant stops and friction, cable values, load components, initial velocities,
controller outputs; a number becomes the parameter, a law ``f`` becomes ``NAME*(f)`` with NAME = 1), all of
them listed in ``solve.sensitivities``.

The scene runs through ``python -m latdyn run`` in its own process with a timeout; then, for each parameter
p, four more runs at p ± h and p ± h/2 (h = 1e-3 |p|, the same scene otherwise: sensitivities asked too, so
the perturbed runs land on events the way the differentiated run does). The reference is the Richardson
extrapolation (4 D(h/2) − D(h))/3 of the central differences D. A parameter whose perturbed runs do not take
the same steps (rows, accepted and rejected step counts, events and cable events: kind, joint and order) is
skipped, and the case says so: the computed solution is not differentiable there. Compared, per probe and
parameter: every row of ``sensitivities.csv`` (by its index: an event's row moves with p, and its sensitivity
is the row's), ``summary.json``
``probe_sensitivities`` (end, max, min: the differences of the probe's last, largest and smallest value) and
``event_sensitivities`` (the differences of the event times, all of a parameter's events as one probe); the
error is the largest difference divided by the largest magnitude of the probe's sensitivity (computed or
referenced; below 1e-9 of the probe's own
scale times 1/|p| it counts as zero). Not compared, and named among the case's skipped: a probe that stays
below ``ROUNDOFF`` (1e-12 in its SI unit) in the run and the perturbed runs (its values and differences are
round-off), and a probe's max or min whose row is another in a perturbed run (two rows nearly tie: the max
is not differentiable there).

Outcomes of a case:

==============  ===========================================================================================
``agrees``      every compared derivative within ``--tol`` (1e-5) of its reference
``unresolved``  a row farther than ``--tol`` but within 3× the spread of the two central differences
                (D(h) and D(h/2) disagree: the perturbed runs' own noise, or a nonsmooth law), or whose
                disagreement moves the perturbed runs by less than ``RESOLUTION`` (1e-10) of the probe's
                largest value (of the run's duration, for an event time): beyond what whole runs resolve
``DISAGREES``   some derivative farther than that (the detail names the worst: probe, parameter, where)
``skipped``     solved, but every parameter's perturbation changed the steps or the events
``refused``     exit 2 naming the file and a key (what is not differentiated says so)
``failed``      exit 1 with the solver's message (or ``unbounded``)
``traceback``   a Python traceback or ``internal error`` on stderr
``hang``        no exit within the timeout (a second try at 4× before it counts)
``defect``      anything else ``fuzz_runs.judge`` finds wrong (a refusal without a key, an unreadable folder)
==============  ===========================================================================================

``--adjoint-share F`` sets ``solve.sensitivity_method: adjoint`` on that fraction of the transient cases
with parameters: its end row, ``probe_sensitivities`` and ``event_sensitivities`` are compared with the
differences the same way, and its summary with the forward method's on the same scene
(:func:`_against_forward`); a case the adjoint refuses goes on by the forward method (the record's ``method``).

``python benchmarks/fuzz_sensitivities.py --runs 30 --seed 1 --keep DIR --json F`` runs a campaign;
``--show N --seed S`` prints case N's scene. Run it from a scratch folder (``cd /tmp``), niced.
"""
from __future__ import annotations

import argparse
import collections
import csv
import json
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.fuzz_runs import RETRY, _r, _run, _scene_text, _unit, judge, random_scene  # noqa: E402

OUTCOMES = ("agrees", "unresolved", "DISAGREES", "skipped", "refused", "failed", "traceback", "hang", "defect")
#: a derivative agrees when within this of its reference, relative to the probe's largest sensitivity
TOL = 1e-5
#: the relative perturbation h/|p| (and h/2)
STEP = 1e-3
#: a row error within this many times the spread of the two central differences is the references' noise
#: (``unresolved``), not the derivative's
NOISE = 3.0
TIMEOUT_S = 60.0
#: a probe's value (in its SI unit) below which, in every run of a parameter, it is round-off and not compared: the generator's lengths, forces and
#: momenta are 1e-3 or more, and a probe that stays below this — a structure at rest, a momentum a free body
#: never gets, an out-of-plane moment of a planar motion — has derivatives and differences of round-off alone
#: (seed 7 case 1: a free body at rest, its momentum 1e-20, derivatives 1e-37 against differences 4e-21)
ROUNDOFF = 1e-12
#: a disagreement whose effect on the perturbed runs, |computed − reference| h, is below this fraction of the probe's
#: largest value (of the run's duration, for an event time) is beyond what whole runs resolve (their Newton tolerance
#: 1e-12 and round-off over the steps): ``unresolved``, not ``DISAGREES`` (seed 21 case 9: a free arm's GJ, which
#: moves a hinge rate by 1e-11 per unit, its differences 0.15 % off at h = 1e-2 and 1e-3 |p| and 4.5 % at 1e-4, and
#: as much with fixed steps: 1e-14 of the rate in the runs)
RESOLUTION = 1e-10

SECTION_KEYS = ("EA", "EIy", "EIz", "GJ", "rhoA", "rhoIy", "rhoIz", "GAy", "GAz")
LAW_KEYS = ("stiffness", "damping", "torque", "force", "rest_angle", "rest")


# =========================================================================== the scene
def differentiable_solve(rng, scene: dict) -> None:
    """Make ``scene``'s analysis one that differentiates: transient with an implicit method (fixed or
    adaptive steps) or static by load control or arc length, with ``tol: 1e-12``; drop what only modes
    and buckling read."""
    old = scene["solve"]
    solve: dict = {}
    for key in ("formulation", "planar"):
        if key in old:
            solve[key] = old[key]
    if rng.random() < 0.7:
        method = str(rng.choice(["generalized-alpha", "hht-alpha", "newmark"]))
        t_end = float(rng.choice([0.1, 0.2, 0.3]))
        solve.update({"analysis": "transient", "method": method, "t_end": t_end,
                      "dt": t_end / int(rng.choice([10, 20, 30]))})
        if method != "newmark" and rng.random() < 0.4:
            solve["rho_inf"] = float(rng.choice([0.0, 0.5, 0.9]))
        if rng.random() < 0.3 and not _prescribed(scene):   # refused with a prescribed motion
            solve["adaptive"] = True
            solve["error_tol"] = float(rng.choice([1e-2, 1e-3]))
        if rng.random() < 0.2:
            solve["newton"] = str(rng.choice(["full", "modified", "exact"]))
    else:
        solve.update({"analysis": "static", "method": str(rng.choice(["load-control", "arc-length"])),
                      "steps": int(rng.integers(3, 9))})
    solve["tol"] = 1e-12
    scene["solve"] = solve
    if solve["analysis"] == "transient" and rng.random() < 0.7:
        # rotary inertia on every section: sensitivities of a run that does not start at rest refuse a
        # model with directions without inertia (docs/parameters.md), which most of these would be
        for section in scene["sections"].values():
            section.setdefault("rhoIy", _r(rng, 1e-4, 1e-2, 5))
            section["rhoIz"] = section["rhoIy"]
    for cable in scene.get("cables", {}).values():
        if isinstance(cable["to"], list) and not cable.get("rhoA"):
            cable["rhoA"] = _r(rng, 0.01, 0.5, 3)   # a free end without mass is refused (nothing holds it)
    output = scene["output"]
    output.pop("paraview_every", None)
    read = " ".join(str(c.get("output", "")) + " " + " ".join(map(str, c.get("states", {}).values()))
                    for c in scene.get("controllers", {}).values())
    for name, probe in list(output["probes"].items()):
        transient_only = ("controller" in probe or "guide" in probe
                          or probe.get("quantity") in ("velocity", "rate", "torque"))
        if solve["analysis"] == "static" and transient_only and not re.search(rf"\b{name}\b", read):
            output["probes"].pop(name)      # differentiated in transient runs only
    if not output["probes"]:
        output["probes"]["tip"] = {"point": _first_point(scene), "quantity": "displacement", "component": "norm"}
    if scene.get("cables") or any("guide" in b for b in scene["bodies"].values()):
        # energy and momentum sensitivities beside cables and guides are refused (docs/parameters.md):
        # a probe of a point instead, so that the case differentiates something
        for name, probe in output["probes"].items():
            if "energy" in probe or "momentum" in probe:
                output["probes"][name] = {"point": _first_point(scene), "quantity": "position",
                                          "component": str(rng.choice(["x", "y", "z"]))}
    if "every" in output and solve["analysis"] == "transient":
        output["every"] = solve["dt"] * int(rng.choice([1, 2]))
    elif "every" in output:
        output.pop("every")


def _first_point(scene: dict) -> str:
    """The end of the first beam: a point every scene has."""
    return f"{next(iter(scene['beams']))}.end"


def _slots(scene: dict) -> list[tuple[str, dict | list, str | int]]:
    """Every number or law of ``scene`` a parameter may stand for: (kind, container, key)."""
    slots: list = []

    def numbers(kind, container, keys):
        for key in keys:
            value = container.get(key) if isinstance(container, dict) else None
            if isinstance(value, (int, float)) and not isinstance(value, bool) and value != 0:
                slots.append((kind, container, key))
            elif isinstance(value, str):
                slots.append((kind, container, key))

    def vector(kind, values):
        if isinstance(values, list):
            for i, v in enumerate(values):
                if (isinstance(v, (int, float)) and not isinstance(v, bool) and v != 0) or isinstance(v, str):
                    slots.append((kind, values, i))

    def joint(kind, law):
        numbers(kind, law, LAW_KEYS)
        if isinstance(law.get("contact"), dict):
            numbers(kind + ".contact", law["contact"], ("stiffness", "exponent", "damping"))
        if isinstance(law.get("friction"), dict):
            numbers(kind + ".friction", law["friction"], ("coulomb", "static", "stribeck_rate", "viscous"))

    for section in scene.get("sections", {}).values():
        numbers("section", section, SECTION_KEYS)
    for body in scene.get("bodies", {}).values():
        if body.get("fixed") or "motion" in body:
            continue
        numbers("body.mass", body, ("mass",))
        vector("body.inertia", body.get("inertia"))
        vector("body.com", body.get("com"))
        if "guide" in body:
            joint("guide", body["guide"])
    for beam in scene.get("beams", {}).values():
        for end in ("start", "end"):
            hinge = beam.get(end, {}).get("hinge")
            if hinge is not None and "angle" not in hinge:
                joint("hinge", hinge)
    for cable in scene.get("cables", {}).values():
        numbers("cable", cable, ("EA", "damping", "rest_length", "rhoA"))
    for load in scene.get("loads", []):
        vector("load", load.get("force"))
        vector("load", load.get("moment"))
    velocity = scene.get("initial_velocity")
    if isinstance(velocity, dict) and scene["solve"]["analysis"] == "transient":
        vector("initial_velocity", velocity.get("linear"))
        vector("initial_velocity", velocity.get("angular"))
    for controller in scene.get("controllers", {}).values():
        numbers("controller", controller, ("output",))
    return slots


#: numbers inside expressions (a law's, a load's, a motion's, a controller's output): a literal not part of a name
LITERAL = re.compile(r"(?<![\w.])(\d+\.?\d*(?:[eE][-+]?\d+)?)(?![\w.(\[])")
#: the keys whose strings are expressions of t, a joint's state or a controller (every one a constant may sit in)
EXPRESSION_KEYS = LAW_KEYS + ("angle", "position", "translation", "rest_length", "output", "force", "moment")
#: the perturbation's floor |p| for a kind whose value may be 0 (a coordinate, a gravity component): h = STEP * max(|p|, floor)
FLOORS = {"point": 0.1, "gravity": 1.0, "velocity_about": 0.1}


def _extended_slots(scene: dict) -> list[tuple[str, dict | list, str | int]]:
    """The slots of ``--extended`` campaigns besides :func:`_slots`': point coordinates (a body's position, a
    beam's or a cable's free end, an offset; zeros too: a planar scene's point moved out of its plane),
    gravity components (zeros too), a constant inside an expression (a law, a load, a prescribed motion, a
    reel, a controller's output), a stop's limits, a latch's angle, a restitution, a controller's limits and
    initial state, the point ``initial_velocity`` is ``about``."""
    slots: list = []

    def coordinates(kind, values):
        if isinstance(values, list) and len(values) == 3:
            for i, v in enumerate(values):
                if isinstance(v, (int, float)) and not isinstance(v, bool):
                    slots.append((kind, values, i))

    def constants(node):
        items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
        for key, value in items:
            if isinstance(value, str) and (key in EXPRESSION_KEYS or isinstance(key, int)):
                for k, match in enumerate(LITERAL.finditer(value)):
                    if float(match.group(1)) != 0:
                        slots.append(("constant", node, (key, k)))
            elif isinstance(value, (dict, list)) and key not in ("table",):
                constants(value)

    def stops(kind, law):
        for key in ("limits",):
            if isinstance(law.get(key), list):
                slots.extend((kind, law[key], i) for i, v in enumerate(law[key]) if isinstance(v, (int, float)) and v)
        for key in ("lock_at", "restitution"):
            if isinstance(law.get(key), (int, float)) and not isinstance(law.get(key), bool) and law[key] != 0:
                slots.append((kind, law, key))

    for name, body in scene.get("bodies", {}).items():
        if not body.get("fixed") and "motion" not in body:
            coordinates("point", body.get("at"))
        if "guide" in body:
            stops("guide.stop", body["guide"])
        constants(body)
    for beam in scene.get("beams", {}).values():
        coordinates("point", beam.get("to"))
        if isinstance(beam.get("to"), dict):
            coordinates("point", beam["to"].get("offset"))
        for end in ("start", "end"):
            hinge = beam.get(end, {}).get("hinge")
            if hinge is not None and "angle" not in hinge:
                stops("hinge.stop", hinge)
        constants(beam)
    for cable in scene.get("cables", {}).values():
        for end in ("from", "to"):
            coordinates("point", cable.get(end))
            if isinstance(cable.get(end), dict):
                coordinates("point", cable[end].get("offset"))
        constants(cable)
    coordinates("gravity", scene.get("gravity"))
    for load in scene.get("loads", []):
        constants(load)
    for controller in scene.get("controllers", {}).values():
        constants(controller)
        if isinstance(controller.get("limits"), list):
            slots.extend(("controller", controller["limits"], i) for i in range(len(controller["limits"])))
        for state in (controller.get("initial") or {}):
            if controller["initial"][state]:
                slots.append(("controller", controller["initial"], state))
    velocity = scene.get("initial_velocity")
    if isinstance(velocity, dict) and scene["solve"]["analysis"] == "transient":
        coordinates("velocity_about", velocity.get("about"))
    return slots


def _unname(node, values: dict):
    """Put back the numbers the generator named (its own ``parameters``), in place."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in list(items):
        if isinstance(value, str) and value in values:
            node[key] = values[value]
        else:
            _unname(value, values)


def _prescribed(scene: dict) -> bool:
    """Whether a body's motion, a hinge's angle or a guide's position is prescribed."""
    bodies = scene.get("bodies", {}).values()
    hinges = [spec.get(end, {}).get("hinge") or {} for spec in scene.get("beams", {}).values()
              for end in ("start", "end")]
    return (any("motion" in b or "position" in b.get("guide", {}) for b in bodies)
            or any("angle" in h for h in hinges))


def parameterise(rng, scene: dict, extended: bool = False, kinds: tuple[str, ...] | None = None) -> list[str]:
    """Name 1–3 numbers or laws of ``scene`` as parameters (kinds drawn evenly, then a slot of the kind)
    and ask for their sensitivities; the names, in order. ``extended``: the slots of :func:`_extended_slots`
    too (a constant inside an expression becomes the parameter, its value the constant's); ``kinds``: only
    slots of these kinds."""
    _unname(scene, scene.pop("parameters", {}))
    scene["solve"].pop("sensitivities", None)
    by_kind = collections.defaultdict(list)
    for slot in _slots(scene) + (_extended_slots(scene) if extended else []):
        if kinds is None or slot[0] in kinds:
            by_kind[slot[0]].append(slot)
    kinds = sorted(by_kind)
    chosen = []
    for kind in rng.permutation(kinds)[:int(rng.integers(1, 4))]:
        options = by_kind[str(kind)]
        chosen.append(options[int(rng.integers(len(options)))])
    parameters, names = {}, []
    for i, (kind, container, key) in enumerate(chosen):
        name = f"p{i}_{kind.replace('.', '_')}"
        if kind == "constant":          # the k-th literal of the expression at container[key]
            key, k = key
            match = list(LITERAL.finditer(container[key]))[k]
            parameters[name] = float(match.group(1))
            container[key] = container[key][:match.start()] + name + container[key][match.end():]
            names.append(name)
            continue
        value = container[key]
        if isinstance(value, str):       # a law: scaled by the parameter, 1 at the run
            parameters[name] = 1.0
            container[key] = f"{name}*({value})"
        else:
            parameters[name] = float(value)
            container[key] = name
        names.append(name)
    if parameters:
        scene["parameters"] = parameters
        scene["solve"]["sensitivities"] = names
    return names


def sensitivity_scene(seed: int, index: int, adjoint_share: float = 0.0, extended: bool = False) -> dict:
    """Case ``index`` of ``seed``: a scene of ``fuzz_runs.random_scene`` made differentiable and given
    parameters (None-free: a scene with nothing to name gets a section value); a transient one with
    parameters takes ``solve.sensitivity_method: adjoint`` with probability ``adjoint_share`` (drawn from a
    generator of its own, so that a seed's scenes are the same whatever the share)."""
    rng = np.random.default_rng([seed, index, 34])
    scene = random_scene(rng, joints=True)
    differentiable_solve(rng, scene)
    parameterise(rng, scene, extended)
    solve = scene["solve"]
    if (solve["analysis"] == "transient" and solve.get("sensitivities")
            and np.random.default_rng([seed, index, 35]).random() < adjoint_share):
        solve["sensitivity_method"] = "adjoint"
    return scene


# =========================================================================== aimed scenes (2026-11-27)
#: ``--aim`` families: scenes of what came in on 2026-11-27, which :func:`random_scene` rarely or never draws
AIMS = ("loop", "links", "rates")


def _arm_chain(rng, *, rigid: bool, planar: bool, arms: int) -> tuple[dict, dict, dict, list[str], list[str]]:
    """A chain of ``arms`` hinged arms from a fixed ground body g, each ending at a joint body b<i> with mass
    and inertia (rigid members: rigid links; else flexible, 1–2 elements, rotary inertia on the section); the
    scene's sections, bodies and beams, the hinges' names and the bodies'."""
    section = {"EA": _r(rng, 1e5, 5e6, 0), "EIy": _r(rng, 50, 2000, 0), "EIz": _r(rng, 50, 2000, 0),
               "GJ": _r(rng, 50, 1000, 0), "rhoA": _r(rng, 0.2, 3, 3), "rhoIy": _r(rng, 1e-4, 1e-3, 5)}
    section["rhoIz"] = section["rhoIy"]
    bodies: dict = {"g": {"at": [0, 0, 0], "fixed": True}}
    beams: dict = {}
    hinges, names, at = [], [], np.zeros(3)
    for i in range(arms):
        direction = np.array([1.0, _r(rng, -0.5, 0.5, 2), 0.0 if planar else _r(rng, -0.4, 0.4, 2)])
        at = at + _r(rng, 0.4, 1.0, 2) * direction / np.linalg.norm(direction)
        body = f"b{i}"
        bodies[body] = {"at": [round(float(x), 4) for x in at], "mass": _r(rng, 0.2, 2, 3),
                        "inertia": [_r(rng, 0.002, 0.05, 4) for _ in range(3)]}
        axis = [0, 0, 1] if planar else [round(x, 3) for x in _unit(rng)]
        if not planar and abs(axis[2]) < 0.3:
            axis[2] = 1.0
        hinge = {"axis": axis, "stiffness": _r(rng, 1, 30, 2), "damping": _r(rng, 0.01, 0.5, 3),
                 "torque": round(float(rng.choice([-1, 1])) * _r(rng, 1, 6, 2), 3)}
        member: dict = {"from": names[-1] if names else "g", "to": body, "section": "s",
                        "start": {"hinge": hinge}}
        if rigid:
            member["rigid"] = True
        else:
            member["elements"] = int(rng.integers(1, 3))
        beams[f"arm{i}"] = member
        hinges.append(f"arm{i}.start")
        names.append(body)
    return {"s": section}, bodies, beams, hinges, names


def _event(rng, hinge: dict) -> None:
    """A latch or a rigid stop ahead of ``hinge``'s torque (reached within the run's 0.1–0.3 s)."""
    sign = 1.0 if hinge["torque"] > 0 else -1.0
    reach = _r(rng, 0.005, 0.04, 3)
    if rng.random() < 0.5:
        hinge["lock_at"] = round(sign * reach, 4)
    else:
        hinge["limits"] = sorted([round(sign * reach, 4), round(-sign * 0.6, 4)])
        # restitution 0 mostly ends at rest on the stop, which the sensitivities refuse (one case in six)
        hinge["restitution"] = float(rng.choice([0, 0.5, 0.9, 0.5, 0.9, 0.7]))


def aimed_scene(seed: int, index: int, aim: str, adjoint_share: float = 0.0) -> dict:
    """Case ``index`` of ``seed`` in the ``aim`` family (:data:`AIMS`), all transient with fixed steps unless said:

    ``loop``   the kinds the loop of steps differentiates natively (sensitivities_in_loop): section values
               and load components (numbers, laws in t, in a body's frame) as the only parameters, a chain of
               flexible hinged arms (3D or planar) with a latch or a rigid stop between smooth stretches,
               rows at every step, every 2nd–5th or the default; a third of the cases interrupted and resumed
               (:func:`_resume_check`);
    ``links``  adaptive steps (error_tol 1e-3 … 1e-5) on a chain of rigid arms (rigid links with free hinges:
               the adaptive error estimate's link-hinge term and its derivative), maybe a flexible arm on
               them, a latch or stop; parameters of any kind;
    ``rates``  a latch or stop beside a stiffness that moves with the rates: a damped compliant stop in
               contact, a controller nonlinear in a hinge's rate driving a torque, a follower load in a
               body's axes driven by a controller of a rate, a hinge damping law in the angle; parameters of
               any kind, constants inside expressions too."""
    rng = np.random.default_rng([seed, index, 36, AIMS.index(aim)])
    planar = aim == "loop" and rng.random() < 0.3
    arms = int(rng.integers(1, 4)) if aim != "rates" else 2
    sections, bodies, beams, hinges, names = _arm_chain(rng, rigid=aim == "links", planar=planar, arms=arms)
    scene: dict = {"title": f"fuzz {aim}", "sections": sections, "bodies": bodies, "beams": beams}
    first = beams["arm0"]["start"]["hinge"]
    evented = rng.random() < {"loop": 0.7, "links": 0.5, "rates": 1.0}[aim]
    if evented:
        _event(rng, first)
    # loads in t beside events keep the loop's run on the Python path (sensitivities_in_loop.refusal): most
    # loop cases with events have constant loads
    timed = not evented or aim != "loop" or rng.random() < 0.3
    if aim == "links" and rng.random() < 0.5:     # a flexible arm on the rigid chain
        tip = np.array(bodies[names[-1]]["at"], float) + [_r(rng, 0.3, 0.8, 2), 0.1, 0.0]
        beams["flex"] = {"from": names[-1], "to": [round(float(x), 4) for x in tip], "section": "s", "elements": 2}
    t_end = float(rng.choice([0.1, 0.2, 0.3]))
    solve: dict = {"analysis": "transient", "method": str(rng.choice(["generalized-alpha", "hht-alpha", "newmark"])),
                   "t_end": t_end, "dt": t_end / int(rng.choice([10, 20, 30])), "tol": 1e-12}
    if planar:
        solve["planar"] = "auto"
    if aim == "links":
        solve.update(adaptive=True, error_tol=float(rng.choice([1e-3, 1e-4, 1e-5])))
    loads: list = []
    tip = names[-1]
    force: list = [0.0, 0.0, 0.0]
    for i in range(2 if planar else 3):
        kind = rng.random()
        if kind < 0.4 or (kind < 0.7 and not timed):
            force[i] = _r(rng, -5, 5, 2)
        elif kind < 0.7 and timed:
            force[i] = str(rng.choice([f"{_r(rng, 0.5, 5, 2)}*sin({_r(rng, 2, 20, 1)}*t)",
                                       f"{_r(rng, 1, 10, 2)}*t", f"{_r(rng, 0.5, 3, 2)}*cos(6*t) - 1"]))
    load: dict = {"at": tip, "force": force}
    if not planar and rng.random() < 0.4:
        load["frame"] = tip
    if not planar and rng.random() < 0.3:
        load["moment"] = [0, 0, _r(rng, -1, 1, 2)]
    loads.append(load)
    if rng.random() < 0.3:
        scene["gravity"] = [0, -9.81, 0] if planar or rng.random() < 0.5 else [0, 0, -9.81]
    probes: dict = {"tip_y": {"point": tip, "quantity": "position", "component": "y"},
                    "a0": {"hinge": hinges[0], "quantity": str(rng.choice(["angle", "rate", "torque"]))}}
    if len(hinges) > 1:
        probes["a1"] = {"hinge": hinges[1], "quantity": str(rng.choice(["angle", "rate", "torque"]))}
    if not planar:
        probes["tip_z"] = {"point": tip, "quantity": str(rng.choice(["position", "velocity"])), "component": "z"}
        if rng.random() < 0.4:
            probes["tip_z"]["frame"] = names[0]
    if aim != "links" and rng.random() < 0.5:
        probes["m0"] = {"element": "arm0.element[0]", "quantity": str(rng.choice(["axial_force", "moment_y",
                                                                                   "moment_z", "torque"]))}
    if aim == "rates":
        second = beams["arm1"]["start"]["hinge"]
        variant = int(rng.integers(0, 4))
        if variant == 0:      # a damped compliant stop in contact from the start
            second["torque"] = -abs(second["torque"])
            second["limits"] = [-_r(rng, 0.001, 0.01, 4), 0.5]
            second["contact"] = {"stiffness": _r(rng, 500, 5000, 0), "exponent": float(rng.choice([1, 1.5, 2])),
                                 "damping": _r(rng, 1, 20, 2)}
        elif variant == 1:    # a controller nonlinear in the second hinge's rate
            probes["a1"] = {"hinge": hinges[1], "quantity": "angle"}
            probes["r1"] = {"hinge": hinges[1], "quantity": "rate"}
            scene["controllers"] = {"ctl": {"output": str(rng.choice([
                f"-{_r(rng, 2, 10, 2)}*a1 - {_r(rng, 0.2, 1, 2)}*(1 + {_r(rng, 10, 40, 1)}*a1**2)*r1 - 2.0",
                f"-{_r(rng, 0.1, 1, 2)}*r1*abs(r1) - {_r(rng, 2, 10, 2)}*a1 + 1.5",
                f"-{_r(rng, 0.5, 3, 2)}*r1**3 - {_r(rng, 2, 10, 2)}*a1 - 1.0"]))}}
            second["torque"] = "ctl"
        elif variant == 2:    # a follower load in the last body's axes driven by a controller of a rate
            probes["r1"] = {"hinge": hinges[1], "quantity": "rate"}
            scene["controllers"] = {"push": {"output": str(rng.choice([
                f"-{_r(rng, 5, 40, 1)}*r1 - 3.0", f"-{_r(rng, 1, 10, 1)}*r1*(1 + r1**2) + 2.0"]))}}
            loads.append({"at": tip, "force": [0, "push", 0], "frame": tip})
        else:                 # a hinge damping law in the angle
            second["damping"] = f"{_r(rng, 0.1, 1, 2)}*(1 + {_r(rng, 10, 50, 1)}*theta**2)"
    scene["loads"] = loads
    scene["solve"] = solve
    output: dict = {"probes": probes}
    rows = rng.random()
    if aim == "loop" and rows < 0.4:
        output["every"] = solve["dt"]
    elif rows < 0.7:
        output["every"] = solve["dt"] * int(rng.integers(2, 6))
    scene["output"] = output
    # a start spun about the ground hinge's axis (initial_velocity: a native kind), from a generator of its own
    # (added after seeds 17 and 18 ran, at d9b97e4, without it and with restitution 0 one stop in three)
    extra = np.random.default_rng([seed, index, 37])
    if aim == "links":
        # the link-hinge term of the error estimate is the larger where a hinge moves little inertia: a light
        # body on the chain, a tight error_tol (added after seed 18 ran, at d9b97e4, with error_tol 1e-3 … 1e-5
        # and every body 0.2–2 kg: of its cases 0, 1, 3, 5 one sized steps by the term, 5 of 14 times)
        solve["error_tol"] = float(extra.choice([1e-4, 1e-5, 1e-6]))
        for body in names[:-1]:
            if extra.random() < 0.5:
                bodies[body]["mass"], bodies[body]["inertia"] = 0.01, [1e-5, 1e-5, 1e-5]
    elif extra.random() < 0.3:
        axis = beams["arm0"]["start"]["hinge"]["axis"]
        scene["initial_velocity"] = {"angular": [round(_r(extra, 0.5, 3, 2) * float(a), 4) for a in axis]}
    # rates: the constants inside the controllers' outputs and laws besides the plain kinds, not the geometry's
    # (refused beside controllers) nor the stops' (refused)
    kinds = {"loop": ("section", "load", "initial_velocity"), "links": None,
             "rates": ("section", "body.mass", "body.inertia", "hinge", "hinge.contact", "load", "initial_velocity",
                       "controller", "constant")}[aim]
    parameterise(rng, scene, extended=aim == "rates", kinds=kinds)
    if aim == "loop" and rng.random() < 1 / 3:
        scene["solve"]["resume_check"] = True    # taken off before the run (run_case)
    if scene["solve"].get("sensitivities") and np.random.default_rng([seed, index, 35]).random() < adjoint_share:
        scene["solve"]["sensitivity_method"] = "adjoint"
    return scene


# =========================================================================== the comparison
def _read(out: Path) -> dict:
    """What a finished run's folder holds: times, probes, sensitivities, summary."""
    def table(path):
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        header, values = rows[0], np.array([[float(x) for x in row] for row in rows[1:]], float)
        return {h: values[:, j] if len(values) else np.zeros(0) for j, h in enumerate(header)}

    probes = table(out / "probes.csv")
    first = "t" if "t" in probes else "load_factor"
    sens = table(out / "sensitivities.csv") if (out / "sensitivities.csv").exists() else {}
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    return {"x": probes.pop(first), "first": first, "probes": probes, "sens": sens, "summary": summary}


def _signature(run: dict) -> tuple:
    """What must not change between the perturbed runs: rows, steps, events."""
    s = run["summary"]
    events = tuple((e.get("joint"), e.get("kind")) for e in s.get("events", []) or [])
    cables = tuple((e.get("cable"), e.get("state")) for e in s.get("cable_events", []) or [])
    return (len(run["x"]), s.get("steps"), s.get("rejected_steps"), events, cables,
            s.get("newton_cuts"))


def _richardson(values: list) -> np.ndarray:
    """(4 D(h/2) − D(h))/3 from the values at p + h, p − h, p + h/2, p − h/2 (h folded in by the caller)."""
    up, down, up2, down2 = (np.asarray(v, float) for v in values)
    return (4.0 * (up2 - down2) - 0.5 * (up - down)) / 3.0


def compare(base: dict, perturbed: list[dict], name: str, h: float, p: float) -> list[dict]:
    """The comparisons of one parameter: a record per (probe, where) with the computed value(s), the
    reference, the error relative to the probe's largest sensitivity."""
    records = []
    x = base["x"]
    # every row, by its index: a row's time may move with p (an event's, one after it until a step lands on
    # the grid, an arc length's load factor), and its sensitivity is the row's (docs/parameters.md)
    same = np.ones(len(x), bool)
    for probe, values in base["probes"].items():
        column = base["sens"].get(f"{probe}/{name}")
        if column is None:
            continue
        if max(float(np.max(np.abs(run["probes"][probe]), initial=0.0)) for run in [base, *perturbed]) < ROUNDOFF:
            records.append({"probe": probe, "where": "rows and summary", "not_compared": True,
                            "detail": f"the probe stays below {ROUNDOFF:g} in every run (round-off): not compared"})
            continue
        reference = _richardson([run["probes"][probe] for run in perturbed]) / h
        if len(column) != len(x):       # the adjoint's sensitivities.csv: the last recorded row alone
            same = np.zeros(len(x), bool)
            same[-1] = True
            column = np.full(len(x), column[-1])
        scale_value = float(np.max(np.abs(values))) if len(values) else 0.0
        # |p| or, for a parameter of value 0 (a coordinate), the size its perturbation was made for (h / STEP)
        floor = 1e-9 * max(scale_value, 1e-12) / max(abs(p), h / STEP, 1e-12)
        largest = max(float(np.max(np.abs(column[same]))) if same.any() else 0.0,
                      float(np.max(np.abs(reference[same]))) if same.any() else 0.0)
        scale = max(float(np.max(np.abs(column))), float(np.max(np.abs(reference[same]))) if same.any() else 0.0,
                    floor)
        rows = np.abs(column - reference)[same]
        if largest < floor:
            # computed and reference both below the floor: zero, the differences round-off (the adjoint's end
            # row of a latched angle: computed 0, the differences 1e-11 of a 0.15 rad angle)
            rows = np.zeros_like(rows)
        worst = int(np.argmax(rows)) if len(rows) else 0
        where = float(x[same][worst]) if len(rows) else float("nan")
        # the two central differences' disagreement: truncation (h²) and the runs' own noise (1/h)
        columns = [run["probes"][probe] for run in perturbed]
        spread = np.abs((columns[0] - columns[1]) / 2 - (columns[2] - columns[3])) / h
        resolved = RESOLUTION * max(scale_value, ROUNDOFF) / h   # a derivative's error the differences can see
        records.append({"probe": probe, "where": f"rows (worst at {base['first']} = {where:.6g})",
                        "error": float(rows.max() / scale) if len(rows) else 0.0, "scale": scale,
                        "unresolvable": bool(len(rows)) and float(rows.max()) <= resolved,
                        "spread": float(spread[same].max() / scale) if len(rows) else 0.0,
                        "zero": not (np.any(column) or np.any(reference)) or largest < floor})
        rows_spread = records[-1]["spread"]
        summary = base["summary"].get("probe_sensitivities", {}).get(probe)
        if summary:
            ends = {"end": [run["probes"][probe][-1] for run in perturbed],
                    "max": [np.max(run["probes"][probe]) for run in perturbed],
                    "min": [np.min(run["probes"][probe]) for run in perturbed]}
            rows_of = {"end": lambda v: len(v) - 1, "max": np.argmax, "min": np.argmin}
            for key, values4 in ends.items():
                computed = summary.get(key, {}).get(name)
                if computed is None:
                    continue
                moved = {int(rows_of[key](run["probes"][probe])) for run in perturbed} - {int(rows_of[key](values))}
                if moved:
                    # the largest (smallest) value is another row's in a perturbed run: the max is not
                    # differentiable there (two rows nearly tie), and its differences are no reference
                    records.append({"probe": probe, "where": f"summary {key}", "not_compared": True,
                                    "detail": f"its row moves with the parameter ({int(rows_of[key](values))} -> "
                                              f"{sorted(moved)}): not compared"})
                    continue
                ref = float(_richardson(values4)) / h
                below = max(abs(computed), abs(ref)) < floor     # both zero to the floor: agree
                records.append({"probe": probe, "where": f"summary {key}", "spread": rows_spread,
                                "unresolvable": abs(computed - ref) <= resolved,
                                "error": 0.0 if below else abs(computed - ref) / max(scale, abs(ref), abs(computed),
                                                                                     floor),
                                "computed": computed, "reference": ref})
    # the event times as one more probe: each error relative to the largest event-time derivative
    events = []
    for i, event in enumerate(base["summary"].get("event_sensitivities", []) or []):
        computed = event.get("dt", {}).get(name)
        if computed is None:
            continue
        ref = float(_richardson([run["summary"]["events"][i]["t"] for run in perturbed])) / h
        events.append((f"event {i} ({event.get('joint')} {event.get('kind')})", computed, ref))
    floor = 1e-8 * float(base["x"][-1] if base["first"] == "t" else 1.0) / max(abs(p), h / STEP, 1e-12)
    scale = max([floor] + [max(abs(c), abs(r)) for _, c, r in events])
    duration = float(base["x"][-1] if base["first"] == "t" else 1.0)
    for label, computed, ref in events:
        records.append({"probe": label, "where": "dt", "error": abs(computed - ref) / scale,
                        "unresolvable": abs(computed - ref) * h <= RESOLUTION * duration,
                        "computed": computed, "reference": ref})
    return records


def _against_forward(scene: dict, out: Path, launch) -> list[dict]:
    """The adjoint's summary.json ``probe_sensitivities`` and ``event_sensitivities`` against the forward
    method's on the same scene (the same computed trajectory: they agree to round-off), each relative to the
    largest of its probe's (or of all event times') derivatives of either method."""
    forward = json.loads(json.dumps(scene))
    forward["solve"].pop("sensitivity_method")
    status, stderr, _, fout = launch(forward, "forward")
    if status != 0:
        return [{"parameter": "-", "probe": "the forward method", "where": f"exited {status}",
                 "error": float("inf")}]
    adjoint = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    reference = json.loads((fout / "summary.json").read_text(encoding="utf-8"))
    records = []
    probes = reference.get("probe_sensitivities", {}) or {}
    for probe, by_key in probes.items():
        pairs = [(key, name, value, ((adjoint.get("probe_sensitivities", {}) or {}).get(probe, {}) or {})
                  .get(key, {}).get(name)) for key, values in by_key.items() for name, value in values.items()]
        scale = max([abs(v) for _, _, value, computed in pairs for v in (value, computed)
                     if v is not None and np.isfinite(v)] + [1e-300])
        for key, name, value, computed in pairs:
            same_nan = value is None and computed is None
            error = 0.0 if same_nan else (float("inf") if value is None or computed is None
                                          else abs(computed - value) / scale)
            records.append({"parameter": name, "probe": probe, "where": f"summary {key}, adjoint vs forward",
                            "error": error, "computed": computed, "reference": value})
    events = list(zip(adjoint.get("event_sensitivities", []) or [], reference.get("event_sensitivities", []) or []))
    if len(adjoint.get("event_sensitivities", []) or []) != len(reference.get("event_sensitivities", []) or []):
        records.append({"parameter": "-", "probe": "events", "where": "adjoint vs forward: counts differ",
                        "error": float("inf")})
    scale = max([abs(v) for _, e in events for v in e.get("dt", {}).values() if v is not None] + [1e-300])
    for i, (a, f) in enumerate(events):
        for name, value in f.get("dt", {}).items():
            computed = a.get("dt", {}).get(name)
            records.append({"parameter": name, "probe": f"event {i} ({f.get('joint')} {f.get('kind')})",
                            "where": "dt, adjoint vs forward", "computed": computed, "reference": value,
                            "error": float("inf") if computed is None or value is None
                            else abs(computed - value) / scale})
    return records


def _floor(name: str) -> float:
    """The floor of |p| in the perturbation h = STEP max(|p|, floor): a coordinate or a gravity component may
    be 0 (FLOORS by the kind in the parameter's name), anything else 1e-3."""
    kind = name.split("_", 1)[1] if "_" in name else ""
    return FLOORS.get(kind, 1e-3)


def run_case(seed: int, index: int, workdir: Path, *, timeout: float = TIMEOUT_S, tol: float = TOL,
             step: float = STEP, scene: dict | None = None, adjoint_share: float = 0.0,
             extended: bool = False, prune: bool = False, aim: str | None = None) -> dict:
    """Generate, run and check case ``index`` of ``seed`` (or check ``scene``, its ``parameters`` and
    ``solve.sensitivities`` as given); a record of its outcome. ``prune``: a refusal that names one of several
    parameters (``parameter 'NAME' is used at …``) drops it from ``solve.sensitivities`` and runs the case
    again (the record's ``pruned`` lists the refusals)."""
    if scene is None:
        scene = (aimed_scene(seed, index, aim, adjoint_share) if aim else
                 sensitivity_scene(seed, index, adjoint_share, extended))
    resume = bool(scene["solve"].pop("resume_check", False))
    case_dir = workdir / f"case{index:04d}"
    case_dir.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()

    def launch(spec: dict, tag: str):
        path = case_dir / f"{tag}.yaml"
        path.write_text(_scene_text(spec), encoding="utf-8")
        out = case_dir / f"out_{tag}"
        command = ["run", str(path), "-o", str(out), "-q"]
        status, _, stderr, _ = _run(command, timeout=timeout, cwd=case_dir)
        if status is None:
            status, _, stderr, _ = _run(command, timeout=RETRY * timeout, cwd=case_dir)
        return status, stderr, path, out

    names = scene["solve"].get("sensitivities", [])
    record = {"index": index, "analysis": scene["solve"]["analysis"], "parameters": names, "scene": scene,
              "checks": [], "skipped": [], "pruned": []}
    if scene["solve"].get("sensitivity_method") == "adjoint":
        record["method"] = "adjoint"
    while True:
        status, stderr, path, out = launch(scene, "base")
        refused = re.search(r"parameter '(\w+)' is used at", stderr) if status == 2 and prune else None
        if refused and refused.group(1) in names and len(names) > 1:
            # one parameter refused (named in the message): the case goes on with the others, and says so
            record["pruned"].append(stderr.strip().splitlines()[-1][-240:])
            names = [n for n in names if n != refused.group(1)]
            scene = json.loads(json.dumps(scene))
            scene["solve"]["sensitivities"] = names
            record.update(scene=scene, parameters=names)
            continue
        if record.get("method") == "adjoint" and status == 2 and "sensitivity_method" in stderr:
            # what the adjoint does not take it refuses naming the key: the case goes on by the forward method
            record["method"] = "forward (adjoint refused: " + stderr.strip().splitlines()[-1][-160:] + ")"
            scene = json.loads(json.dumps(scene))
            scene["solve"].pop("sensitivity_method")
            record["scene"] = scene
            continue
        break
    if record.get("method") == "adjoint" and status == 0:
        record["checks"] += _against_forward(scene, out, launch)
    outcome, detail = judge(status, stderr, path, out, scene)
    record["stderr"] = stderr[-3000:]
    if outcome != "solved":
        mapping = {"solved": "agrees", "unbounded": "failed", "refused": "refused", "failed": "failed",
                   "traceback": "traceback", "hang": "hang"}
        record.update(outcome=mapping.get(outcome, "defect"), detail=f"{outcome}: {detail}")
        record["wall_s"] = round(time.perf_counter() - started, 1)
        return record
    base = _read(out)
    record["time_loop"] = base["summary"].get("time_loop")
    record["steps_in_loop"] = base["summary"].get("sensitivity_steps_in_loop")
    record["steps"] = base["summary"].get("steps")
    if resume:
        record["resume"] = _resume_check(path, out, case_dir, RETRY * timeout)
    for name in names:
        p = scene["parameters"][name]
        h = step * max(abs(p), _floor(name))
        perturbed = []
        for tag, dp in (("up", h), ("down", -h), ("up2", h / 2), ("down2", -h / 2)):
            spec = json.loads(json.dumps(scene))
            spec["parameters"][name] = p + dp
            status, stderr, path, pout = launch(spec, f"{name}_{tag}")
            if status != 0:
                perturbed = f"the run at {name} {'+' if dp > 0 else '-'} {abs(dp):.3g} exited {status}: " \
                            f"{stderr.strip().splitlines()[-1] if stderr.strip() else ''}"
                break
            perturbed.append(_read(pout))
        if isinstance(perturbed, str):
            record["skipped"].append(f"{name}: {perturbed}")
            continue
        signatures = {_signature(run) for run in [base, *perturbed]}
        if len(signatures) > 1:
            record["skipped"].append(f"{name}: the perturbation changes the steps or events "
                                     f"({sorted(map(str, signatures))[:2]})")
            continue
        for check in compare(base, perturbed, name, h, p):
            if check.get("not_compared"):
                record["skipped"].append(f"{name}: {check['probe']} {check['where']} {check['detail']}")
            else:
                record["checks"].append({"parameter": name, **check})
    if resume and record["resume"] not in ("equal", "not interrupted"):
        record["checks"].append({"parameter": "-", "probe": "resume", "where": record["resume"],
                                 "error": float("inf")})
    bad = [c for c in record["checks"] if not c["error"] <= tol]
    noisy = [c for c in bad if c["error"] <= NOISE * c.get("spread", 0.0) or c.get("unresolvable")]
    if bad and len(noisy) == len(bad):
        worst = max(bad, key=lambda c: c["error"])
        why = (f"the differences themselves {worst.get('spread', 0.0):.3g} apart"
               if worst["error"] <= NOISE * worst.get("spread", 0.0) else
               f"a difference below {RESOLUTION:g} of the probe over h: beyond what whole runs resolve")
        record.update(outcome="unresolved", detail=f"{worst['probe']}/{worst['parameter']} {worst['where']}: "
                                                   f"{worst['error']:.3g} off, {why}")
    elif bad:
        worst = max(bad, key=lambda c: c["error"] if np.isfinite(c["error"]) else np.inf)
        record.update(outcome="DISAGREES", detail=f"{worst['probe']}/{worst['parameter']} {worst['where']}: "
                                                  f"{worst['error']:.3g} off ({len(bad)} of {len(record['checks'])})")
    elif record["checks"]:
        worst = max(c["error"] for c in record["checks"])
        zeros = sum(1 for c in record["checks"] if c.get("zero"))
        rows = sum(1 for c in record["checks"] if "zero" in c)
        record.update(outcome="agrees", detail=f"{len(record['checks'])} checks, worst {worst:.2g}"
                                               + (f" ({zeros} of {rows} probe columns 0 in both)" if zeros else ""))
    else:
        record.update(outcome="skipped", detail="; ".join(record["skipped"])[:300] or "no probe to compare")
    if record["skipped"] and record["outcome"] != "skipped":
        record["detail"] += f"; skipped {len(record['skipped'])}: " + "; ".join(record["skipped"])[:200]
    record["wall_s"] = round(time.perf_counter() - started, 1)
    return record


def _resume_check(path: Path, uninterrupted: Path, case_dir: Path, timeout: float) -> str:
    """Run the scene at ``path`` again, interrupted (SIGTERM) once its first checkpoint is written and resumed;
    "equal" where its sensitivities.csv and probes.csv are the uninterrupted run's byte for byte and
    summary.json's sensitivities the same, "not interrupted" where it ended first, else what differs."""
    out = case_dir / "out_resumed"
    first, _, err1, _ = _run(["run", str(path), "-o", str(out), "-q", "--checkpoint-every", "0"], timeout=timeout,
                             cwd=case_dir, interrupt_when=out / "checkpoint.npz")
    if first == 0:
        return "not interrupted"
    if first != 130:
        return f"the interrupted run exited {first}: {err1.strip()[-200:]}"
    second, _, err2, _ = _run(["run", str(path), "-o", str(out), "-q", "--resume"], timeout=timeout, cwd=case_dir)
    if second != 0:
        return f"the resumed run exited {second}: {err2.strip()[-200:]}"
    for name in ("sensitivities.csv", "probes.csv"):
        if (out / name).read_bytes() != (uninterrupted / name).read_bytes():
            return f"resumed: {name} differs from the uninterrupted run's"
    a, b = (json.loads((folder / "summary.json").read_text(encoding="utf-8")) for folder in (uninterrupted, out))
    for key in ("probe_sensitivities", "event_sensitivities", "sensitivity_steps_in_loop"):
        if a.get(key) != b.get(key):
            return f"resumed: summary.json {key} differs from the uninterrupted run's"
    return "equal"


# =========================================================================== the campaign
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=30, help="cases to run (default 30)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the generator (default 1)")
    parser.add_argument("--start", type=int, default=0, help="first case index (default 0)")
    parser.add_argument("--timeout", type=float, default=TIMEOUT_S, help=f"seconds per run (default {TIMEOUT_S:g})")
    parser.add_argument("--tol", type=float, default=TOL, help=f"agreement bound (default {TOL:g})")
    parser.add_argument("--step", type=float, default=STEP, help=f"relative perturbation h/|p| (default {STEP:g})")
    parser.add_argument("--adjoint-share", type=float, default=0.0, metavar="F",
                        help="set solve.sensitivity_method: adjoint on this fraction of the transient cases "
                             "(default 0); a case the adjoint refuses goes on by the forward method")
    parser.add_argument("--extended", action="store_true",
                        help="name the numbers of _extended_slots too: point coordinates, gravity, constants inside "
                             "expressions, stops' limits, latches, restitutions, controller limits and initial "
                             "states (a seed's scenes differ from its campaign without it)")
    parser.add_argument("--prune", action="store_true",
                        help="a refusal naming one of a case's parameters drops that one and runs the case again "
                             "(named in the record's 'pruned')")
    parser.add_argument("--aim", choices=AIMS, default=None,
                        help="draw the scenes of aimed_scene's family instead: 'loop' (section values and load "
                             "components, the loop of steps, latches or stops, rows, resume), 'links' (adaptive "
                             "steps on rigid links), 'rates' (a stiffness that moves with the rates at events)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="save the scene, stderr and the checks of every case not 'agrees' here")
    parser.add_argument("--json", type=Path, default=None, help="write the counts and every record here")
    parser.add_argument("--scene", type=Path, default=None,
                        help="check this scene file instead (a reduced case): print each comparison")
    parser.add_argument("--show", type=int, default=None, metavar="N", help="print the scene of case N and exit")
    args = parser.parse_args(argv)
    if args.show is not None:
        print(_scene_text(aimed_scene(args.seed, args.show, args.aim, args.adjoint_share) if args.aim else
                          sensitivity_scene(args.seed, args.show, args.adjoint_share, args.extended)), end="")
        return 0
    if args.scene is not None:
        import yaml

        with tempfile.TemporaryDirectory(prefix="latdyn_sensfuzz_") as base:
            record = run_case(0, 0, Path(base), timeout=args.timeout, tol=args.tol, step=args.step,
                              scene=yaml.safe_load(args.scene.read_text(encoding="utf-8")))
        for c in record["checks"]:
            print(f"{c['parameter']:>12s} {c['probe']:>24s} {c['where']:32s} error {c['error']:.3g}"
                  + (f" (computed {c['computed']:.9g}, reference {c['reference']:.9g})" if "computed" in c else "")
                  + (f" spread {c['spread']:.2g}" if "spread" in c else ""))
        print(record["outcome"], record["detail"])
        return 0 if record["outcome"] in ("agrees", "skipped", "refused", "failed") else 1
    records = []
    with tempfile.TemporaryDirectory(prefix="latdyn_sensfuzz_") as base:
        for index in range(args.start, args.start + args.runs):
            record = run_case(args.seed, index, Path(base), timeout=args.timeout, tol=args.tol, step=args.step,
                              adjoint_share=args.adjoint_share, extended=args.extended, prune=args.prune,
                              aim=args.aim)
            records.append(record)
            mark = "  <--" if record["outcome"] in ("DISAGREES", "traceback", "hang", "defect") else ""
            method = " adjoint" if record.get("method") == "adjoint" else ""
            loop = f" loop {record['steps_in_loop']}/{record['steps']}" if record.get("steps_in_loop") else ""
            print(f"case {index:4d} {record['analysis'] + method + loop:17s} {record['outcome']:9s} {record['wall_s']:6.1f} s "
                  f"{','.join(record['parameters'])[:60]:60s} {record['detail'][:160]}{mark}", flush=True)
            if args.keep is not None and record["outcome"] != "agrees":
                args.keep.mkdir(parents=True, exist_ok=True)
                stem = args.keep / f"seed{args.seed}_case{index:04d}_{record['outcome']}"
                stem.with_suffix(".yaml").write_text(
                    f"# {record['outcome']}: {record['detail']}\n# python benchmarks/fuzz_sensitivities.py --show "
                    f"{index} --seed {args.seed}" + (f" --aim {args.aim}" if args.aim else "") + "\n"
                    + _scene_text(record["scene"]), encoding="utf-8")
                stem.with_suffix(".txt").write_text(record["stderr"] + "\n" + json.dumps(record["checks"], indent=1),
                                                    encoding="utf-8")
            if args.json:   # after every case: a campaign stopped midway keeps the cases it ran
                _write_json(args, records)
    summary = _write_json(args, records) if args.json else _campaign_summary(args, records)
    print(json.dumps(summary, indent=1))
    return 0 if not any(r["outcome"] in ("DISAGREES", "traceback", "hang", "defect") for r in records) else 1


def _campaign_summary(args, records: list[dict]) -> dict:
    """The counts of a campaign's ``records``."""
    by = collections.Counter(r["outcome"] for r in records)
    return {"seed": args.seed, "start": args.start, "runs": len(records), "tol": args.tol, "aim": args.aim,
            "in_loop_cases": sum(1 for r in records if (r.get("steps_in_loop") or 0) > 0),
            "resumed_equal": sum(1 for r in records if r.get("resume") == "equal"),
            "adjoint_share": args.adjoint_share, "extended": args.extended, "prune": args.prune,
            "pruned_parameters": sum(len(r["pruned"]) for r in records),
            "adjoint_cases": sum(1 for r in records if r.get("method") == "adjoint"),
            "outcomes": dict(by), "checks": sum(len(r["checks"]) for r in records),
            "skipped_parameters": sum(len(r["skipped"]) for r in records),
            "wall_s": round(sum(r["wall_s"] for r in records), 1)}


def _write_json(args, records: list[dict]) -> dict:
    """Write the campaign's counts and every record to ``args.json``; the counts."""
    summary = _campaign_summary(args, records)
    args.json.write_text(json.dumps({**summary, "records": [
        {k: r.get(k) for k in ("index", "analysis", "method", "parameters", "outcome", "detail", "skipped",
                               "pruned", "wall_s", "time_loop", "steps", "steps_in_loop", "resume")}
        | {"worst": max((c["error"] for c in r["checks"]), default=None)} for r in records]}, indent=1))
    return summary


if __name__ == "__main__":
    sys.exit(main())
