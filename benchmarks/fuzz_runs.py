"""Whole-run fuzzing: random valid scenes run through ``latdyn run`` (issue 30, item 7).

Each case is a random scene of the contract (``shared/SCENE.md``): a tree of flexible beams and
rigid links from a fixed, prescribed or free body, joint bodies with mass and inertia, clamped or
hinged ends with every hinge law (stiffness, damping and torque as numbers or expressions in ``t``,
``theta``, ``theta_dot``; ``rest_angle``; a prescribed ``angle``; ``limits`` with ``restitution``;
``lock_at``), loads in the global frame and in body frames, gravity, an initial rigid motion; every
analysis (transient with every method, fixed or adaptive steps; static by load control, arc length
and displacement control; modes about ``initial``, ``static``, ``steady`` and ``{t: T}``, with mode
shapes and a linear model; buckling), every probe kind and ParaView output. Some transient runs are
interrupted (SIGTERM once a checkpoint is on disk) and resumed with ``--resume``.

The scene is written as YAML text and run in its own process, with a timeout. The outcome of a run:

==================  ===========================================================================
``solved``          exit 0; the results folder reads back (below)
``failed``          exit 1 with ``latdyn: error: the solver failed: ...``; what was recorded reads back
``unbounded``       exit 1 with ``latdyn: error: unbounded: ...`` (the energy balance broke, docs/energy.md;
                    summary.json status ``unbounded``); what was recorded reads back
``refused``         exit 2 with ``latdyn: error: FILE: KEY: ...`` (the message names the file and a key)
==================  ===========================================================================

and the defects, each a reason to look:

==========================  =====================================================================
``traceback``               a Python traceback or ``internal error`` on stderr
``hang``                    no exit within the timeout
``exit_status``             an exit status other than 0, 1, 2 (130 only after our SIGTERM)
``nan_solved``              exit 0 with a NaN or infinity in probes.csv, modes.csv or the linear model
``unreadable``              a results folder that does not read back: probes.csv/summary.json/state.h5/
                            ParaView files/modes.csv/linear_model.npz missing, malformed, or with the
                            wrong rows or columns; a solved run whose status is not ``solved``, whose
                            last time is not ``t_end``, or that left its checkpoint behind
``refusal_without_key``     exit 2 whose message does not name the file and a key path
``failure_without_message`` exit 1 without ``the solver failed:`` or ``unbounded:``
``resume_mismatch``         an interrupted and resumed run whose exit status, probes, state history or
                            summary.json events, cable events, joint peaks and rows differ from the
                            uninterrupted run's (``--resume-every K``: every K-th transient case; 8)
``step_dependent``          (``--step-check``) a solved transient run whose answer changes with the
                            step more than it admits and does not converge (below)
==========================  =====================================================================

The step check (``--step-check``): a solved transient run is run again at dt/2 (same ``t_end``; an
adaptive run with ``error_tol``/4 too, the error of a second-order step falling as dt²). Its probes
are compared on the rows both runs recorded (the coarse run's rows at k·dt or k·``every`` are rows of
the finer run too; an adaptive run without ``every`` shares its first and last rows), each probe
relative to its largest magnitude over both runs (probes below :data:`STEP_CHECK_NOISE` in both are
round-off and not compared). The run admits an error of
``max(energy_balance_error, error_tol if adaptive, STEP_CHECK_FLOOR)``; a difference within
:data:`STEP_CHECK_MULTIPLE` times that is ``agrees``. A larger one is run again at dt/4, dt/8, … down
to dt/:data:`STEP_CHECK_FINEST`: once two successive differences fall with an observed order
``p = log2(|dt/2^(k-1) − dt/2^k| / |dt/2^k − dt/2^(k+1)|)`` of at least :data:`STEP_CHECK_ORDER`,
the first run was ``coarse`` (converging: its step was too long for its motion — a stiff member's
axial ringing, an impact's response — and the step, not the package, sets its error; it stays
``solved``); if they never do, or a finer run does not solve, the case is ``step_dependent`` — an
answer the package reported as solved that it cannot stand behind, to look at.
The record's ``step_check`` holds the verdict and the figures.

``--extended`` adds what the scenes above rarely or never make (:func:`_extensions`: beam ends at
offsets, steady spins, oblique gravity and spin, adaptive steps for every implicit method, a prescribed
angle at a body's end); ``benchmarks/fuzz_invariants.py`` judges the same scenes by invariants.

``python benchmarks/fuzz_runs.py --runs 300 --seed 1`` runs a campaign and prints the counts by
outcome; ``--keep DIR`` saves the scene, stderr and a note of every defect found under DIR;
``--show N --seed S`` prints the scene of case N. ``tests/test_run_fuzz.py`` runs tens of cases
with the same generator.
"""
from __future__ import annotations

import argparse
import collections
import csv
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]

OUTCOMES = ("solved", "failed", "unbounded", "refused")
DEFECTS = ("traceback", "hang", "exit_status", "nan_solved", "unreadable", "refusal_without_key",
           "failure_without_message", "resume_mismatch", "step_dependent")
#: default wall-clock limit of one ``latdyn run`` (a case is sized to take a few seconds)
TIMEOUT_S = 60.0
#: a run past its timeout runs again with this many times the time before it counts as a hang
RETRY = 4
#: the results folders are read back one at a time: h5py's and VTK's HDF5 libraries, called from two of
#: the campaign's threads at once, crashed the judging process (a segmentation fault in 2 of 3 campaigns
#: of six cases, two at a time); the runs themselves are separate processes and stay parallel
READING = threading.Lock()
#: the step check flags a probe difference (relative to the probe's largest magnitude) past this many
#: times the error the run admits (its energy balance error, or error_tol when adaptive)
STEP_CHECK_MULTIPLE = 10.0
#: the least error a run admits: relative round-off of a Newton tolerance of 1e-8 and the rows' digits
STEP_CHECK_FLOOR = 1e-6
#: a probe whose magnitude stays below this in both runs is round-off about zero, not compared
STEP_CHECK_NOISE = 1e-9
#: the observed order of convergence (of two successive differences of dt/2^k runs) at and above which a
#: flagged run is coarse, not wrong
STEP_CHECK_ORDER = 1.0
#: the finest step a flagged run is run again at, as a fraction of its dt (dt/2, dt/4, … this)
STEP_CHECK_FINEST = 16

# =========================================================================== the scene generator
AXES = ([0, 0, 1], [0, 1, 0], [1, 0, 0])
#: directions of a member from its start body
DIRECTIONS = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, -1, 0], [-1, 0, 0.5]]


def _r(rng, lo, hi, digits=4) -> float:
    """A number drawn uniformly in [lo, hi], rounded (the scene stays readable)."""
    return float(round(rng.uniform(lo, hi), digits))


def _choice(rng, options, p=None):
    return options[int(rng.choice(len(options), p=p))]


def _unit(rng) -> list[float]:
    """An axis: mostly a coordinate axis, sometimes oblique."""
    if rng.random() < 0.75:
        axis = list(_choice(rng, AXES))
        return [float(a) * (1 if rng.random() < 0.8 else -1) for a in axis]
    v = rng.normal(size=3)
    return [round(float(x), 3) for x in v / np.linalg.norm(v)]


def _section(rng) -> dict:
    ei = _r(rng, 20, 2000, 1)
    section = {"EA": _r(rng, 1e5, 5e6, 0), "EIy": ei, "EIz": _choice(rng, [ei, _r(rng, 20, 2000, 1)]),
               "GJ": _r(rng, 20, 2000, 1), "rhoA": _r(rng, 0.2, 3, 3)}
    if rng.random() < 0.3:
        section["rhoIy"] = section["rhoIz"] = _r(rng, 1e-4, 1e-2, 5)
    if rng.random() < 0.15:
        section["GAy"] = section["GAz"] = _r(rng, 1e5, 5e6, 0)
    return section


def _hinge(rng, *, prescribed_ok: bool) -> dict:
    """A hinge with a random law: every key of SCENE.md's HINGE and its additions."""
    hinge: dict = {"axis": _unit(rng)}
    if prescribed_ok and rng.random() < 0.15:
        hinge["angle"] = _choice(rng, [f"{_r(rng, 0.2, 2, 2)}*t", f"{_r(rng, 0.1, 0.5, 2)}*sin({_r(rng, 1, 10, 1)}*t)",
                                       f"{_r(rng, 0.5, 3, 2)}*t**2", {"table": [[0, 0], [0.1, 0.05], [1, 0.3]]}])
        return hinge
    k = _r(rng, 1, 300, 2)
    law = rng.random()
    if law < 0.3:
        hinge["stiffness"] = k
    elif law < 0.4:
        hinge["stiffness"] = f"{k}*(1 + theta**2)"
    elif law < 0.45:
        hinge["stiffness"] = f"{k}*(1 + 0.5*sin(t))"
    if rng.random() < 0.4:
        c = _r(rng, 0.01, 5, 3)
        hinge["damping"] = _choice(rng, [c, f"{c}*(1 + abs(theta_dot))", f"{c}*(1 + theta**2)"])
    if rng.random() < 0.4:
        T = _r(rng, -20, 20, 2)
        hinge["torque"] = _choice(rng, [T, f"{T}*sin({_r(rng, 1, 10, 1)}*t)", f"{T}*Heaviside(t - 0.01)",
                                        f"{T} - {k}*theta", f"{T}*exp(-t) - {_r(rng, 0.1, 2, 2)}*theta_dot",
                                        {"table": [[0, 0], [0.05, T], [10, T]]}])
    if "stiffness" in hinge and rng.random() < 0.3:
        hinge["rest_angle"] = _r(rng, -0.5, 0.5, 3)
    if rng.random() < 0.3:
        lo, hi = -_r(rng, 0.02, 0.8, 3), _r(rng, 0.02, 0.8, 3)
        hinge["limits"] = [lo, hi]
        if rng.random() < 0.7:
            hinge["restitution"] = _choice(rng, [0, 0.5, 1, _r(rng, 0, 1, 2)])
        if rng.random() < 0.3:
            hinge["lock_at"] = _choice(rng, [lo, hi, round(0.5 * hi, 4)])
    elif rng.random() < 0.2:
        hinge["lock_at"] = _r(rng, -0.5, 0.5, 3)
    return hinge


def random_scene(rng: np.random.Generator, joints: bool = False, extended: bool = False) -> dict:
    """A random scene of the contract, small enough to run in a few seconds; ``joints``: with the keys
    added with the issues of 2026-11-26 as well (:func:`_joint_additions`: cables, guides, contact and
    friction, inputs, controllers, named parameters and sensitivities), drawn after the rest so that
    the scene without them is the one ``joints=False`` draws."""
    scene: dict = {"title": "fuzz"}
    sections = {f"s{i}": _section(rng) for i in range(int(rng.integers(1, 3)))}
    scene["sections"] = sections
    bodies: dict = {}
    ground = rng.random()
    if ground < 0.6:
        bodies["g"] = {"at": [0, 0, 0], "fixed": True}
    elif ground < 0.8:
        w = _r(rng, 0.5, 6, 2)
        bodies["g"] = {"at": [0, 0, 0], "motion": {"rotation": {"axis": _unit(rng), "angle": _choice(
            rng, [f"{w}*t", f"{w}*t**2/2", f"{w}*(t - sin(t))"])}}}
        if rng.random() < 0.2:
            bodies["g"]["motion"]["translation"] = [f"{_r(rng, 0.01, 0.1, 3)}*sin(5*t)", 0, 0]
    else:  # a free structure: its root body has mass
        bodies["g"] = {"at": [0, 0, 0], "mass": _r(rng, 0.5, 5, 2), "inertia": [_r(rng, 0.01, 1, 3)] * 3}
    names = ["g"]           # bodies that members may start from
    points: list[str] = ["g"]
    beams: dict = {}
    n_members = int(rng.integers(1, 5))
    elements_left = 8
    for i in range(n_members):
        name = f"m{i}"
        start = _choice(rng, names)
        at = np.array(bodies[start]["at"], float)
        direction = np.array(_choice(rng, DIRECTIONS), float)
        length = _r(rng, 0.3, 2, 2)
        to_point = [round(float(x), 4) for x in at + length * direction / np.linalg.norm(direction)]
        rigid = rng.random() < 0.3
        member: dict = {"from": start, "section": _choice(rng, list(sections))}
        end_kind = rng.random()
        if end_kind < 0.55:     # a new joint body at the end
            body = f"b{i}"
            spec: dict = {"at": to_point}
            if rng.random() < 0.7:
                spec["mass"] = _r(rng, 0.05, 3, 3)
            if rng.random() < 0.5:
                spec["inertia"] = [_r(rng, 0.001, 0.1, 4) for _ in range(3)]
            if rng.random() < 0.15:
                spec["com"] = [_r(rng, -0.1, 0.1, 3), 0, 0]
            bodies[body] = spec
            member["to"] = body
            names.append(body)
            points.append(body)
        elif end_kind < 0.65 and len(names) > 1:   # back to a body of the tree (a closed loop)
            others = [b for b in names if b != start and bodies[b]["at"] != bodies[start]["at"]]
            member["to"] = _choice(rng, others) if others else to_point
        else:                   # a free end
            member["to"] = to_point
        if isinstance(member["to"], str) and rng.random() < 0.2:
            member["to"] = {"body": member["to"], "offset": [0, 0, 0]}
        if rigid:
            member["rigid"] = True
        else:
            member["elements"] = int(rng.integers(1, min(3, elements_left) + 1))
            elements_left = max(1, elements_left - member["elements"])
            if rng.random() < 0.2:
                member["y_axis"] = [0, 0, 1] if abs(direction[2]) < 1e-9 else [1, 0, 0]
        if rng.random() < 0.55:
            member["start"] = {"hinge": _hinge(rng, prescribed_ok=True)}
        if not isinstance(member["to"], list) and rng.random() < 0.25:
            member["end"] = {"hinge": _hinge(rng, prescribed_ok=False)}
        beams[name] = member
        points += [f"{name}.end", f"{name}.start"] + ([f"{name}.node[1]"] if not rigid else [])
    scene["bodies"] = bodies
    scene["beams"] = beams

    if rng.random() < 0.5:
        scene["gravity"] = _choice(rng, [[0, -9.81, 0], [0, 0, -9.81], [0, -1, 0]])
    if rng.random() < 0.25:
        scene["initial_velocity"] = {"linear": [_r(rng, -1, 1, 2), _r(rng, -1, 1, 2), 0],
                                     "angular": [0, 0, _r(rng, -3, 3, 2)]}
        if rng.random() < 0.4:
            scene["initial_velocity"]["about"] = [_r(rng, -1, 1, 2), 0, 0]
    loads = []
    for _ in range(int(rng.integers(0, 3))):
        load: dict = {"at": _choice(rng, points)}
        magnitude = _r(rng, -20, 20, 2)
        component = _choice(rng, [magnitude, f"{magnitude}*sin(3*t)", f"{magnitude}*t", 0])
        vector = [0, 0, 0]
        vector[int(rng.integers(0, 3))] = component
        load["moment" if rng.random() < 0.3 else "force"] = vector
        if rng.random() < 0.3:
            load["frame"] = _choice(rng, list(bodies))
        loads.append(load)
    if loads:
        scene["loads"] = loads

    scene["solve"] = _solve(rng, scene, points)
    scene["output"] = _output(rng, scene, points)
    if joints:
        _joint_additions(rng, scene, points)
    if extended:
        _extensions(rng, scene)
    return scene


def _extensions(rng, scene: dict) -> None:
    """What the scenes above rarely or never make (``extended``; drawn last, so that the scene without
    them is the one ``extended=False`` draws): beam ends at an offset from their joint body (both ends),
    a spin at constant rate for ``about: steady`` (which the ground's laws otherwise seldom give),
    gravity and the initial rotation off the coordinate axes, adaptive steps for every implicit method
    and the ``newton`` variants, a prescribed hinge angle at a body's end."""
    bodies, solve = scene["bodies"], scene["solve"]
    for beam in scene["beams"].values():
        for end in ("from", "to"):
            target = beam[end]
            name = target["body"] if isinstance(target, dict) else target
            if isinstance(name, str) and rng.random() < 0.35:
                offset = [_r(rng, -0.15, 0.15, 3) for _ in range(3)]
                beam[end] = {"body": name, "offset": offset}
        # an end that became its start's point is a beam of zero length: back to the body's point
        ends = [beam[e] for e in ("from", "to")]
        points = [np.add(bodies[e["body"] if isinstance(e, dict) else e]["at"] if not isinstance(e, list) else e,
                         e.get("offset", [0, 0, 0]) if isinstance(e, dict) else [0, 0, 0]) for e in ends]
        if np.linalg.norm(points[1] - points[0]) < 0.05:
            beam["to"] = beam["to"]["body"] if isinstance(beam["to"], dict) else beam["to"]
    if solve.get("about") == "steady" and rng.random() < 0.8:
        ground = bodies["g"]
        for key in ("fixed", "mass", "inertia"):
            ground.pop(key, None)
        ground["motion"] = {"rotation": {"axis": _unit(rng), "angle": f"{_r(rng, 0.5, 8, 2)}*t"}}
    if scene.get("gravity") and rng.random() < 0.4:
        scene["gravity"] = [_r(rng, -6, 6, 2), _r(rng, -9.81, 0, 2), _r(rng, -6, 6, 2)]
    if "initial_velocity" in scene and rng.random() < 0.5:
        scene["initial_velocity"]["angular"] = [_r(rng, -3, 3, 2) for _ in range(3)]
    if solve["analysis"] == "transient" and solve.get("method") != "explicit" and rng.random() < 0.3:
        solve["adaptive"] = True
        solve["error_tol"] = _choice(rng, [1e-3, 1e-4, 1e-5])
        if rng.random() < 0.3:
            solve["newton"] = _choice(rng, ["full", "modified", "exact"])
    hinged = [spec["end"]["hinge"] for spec in scene["beams"].values()
              if isinstance(spec.get("end"), dict) and "hinge" in spec["end"]]
    if hinged and rng.random() < 0.2 and not scene.get("controllers"):
        hinge = _choice(rng, hinged)
        for key in ("stiffness", "damping", "torque", "rest_angle", "limits", "restitution", "lock_at",
                    "contact", "friction"):
            hinge.pop(key, None)
        hinge["angle"] = f"{_r(rng, 0.1, 0.5, 2)}*sin({_r(rng, 1, 8, 1)}*t)"


def _contact_friction(rng, joint: dict) -> None:
    """Maybe a compliant stop (``contact`` on ``limits``) and ``friction`` on a hinge or guide law
    ``joint`` (the same values for a hinge, in rad, and a guide, in m)."""
    if "limits" in joint and rng.random() < 0.5:
        joint["contact"] = {"stiffness": _r(rng, 1e2, 1e5, 0)}
        if rng.random() < 0.5:
            joint["contact"]["exponent"] = _choice(rng, [1, 1.5, 2])
        if rng.random() < 0.5:
            joint["contact"]["damping"] = _r(rng, 0.1, 50, 2)
        joint.pop("restitution", None)
    if "angle" not in joint and "position" not in joint and rng.random() < 0.25:
        friction = {"coulomb": _r(rng, 0.01, 2, 3)}
        if rng.random() < 0.3:
            friction["static"] = round(friction["coulomb"] * _r(rng, 1, 1.5, 2), 4)
        if rng.random() < 0.3:
            friction["stribeck_rate"] = _r(rng, 0.01, 0.5, 3)
        if rng.random() < 0.3:
            friction["viscous"] = _r(rng, 0.01, 1, 3)
        joint["friction"] = friction


def _joint_additions(rng, scene: dict, points: list) -> None:
    """Add to ``scene`` what issues 32–34 brought: guides (a guided body on the ground or on a body,
    with a law, stops, a latch or a prescribed slide, maybe joined to the tree by a flexible member),
    cables (between points or to a free end, taut, slack or pretensioned, a reel in t, with mass
    and elements), contact and friction at hinges and guides, inputs, controllers (continuous,
    with states, sampled, saturated) driving a hinge torque, a guide force or a load, and named
    parameters in section values, masses and hinge laws with ``solve.sensitivities``; and their
    probes."""
    bodies, beams, probes = scene["bodies"], scene["beams"], scene["output"]["probes"]
    solve = scene["solve"]
    sensors: list[str] = []          # probes a controller may read (hinge, guide, point, cable)
    actuated: list[tuple[dict, str]] = []   # (a law's mapping, its key) a controller may drive
    for beam, spec in beams.items():
        for end in ("start", "end"):
            hinge = spec.get(end, {}).get("hinge")
            if hinge is None:
                continue
            _contact_friction(rng, hinge)
            if "angle" not in hinge:
                actuated.append((hinge, "torque"))
                if rng.random() < 0.5:
                    name = f"h_{beam}_{end}"
                    probes[name] = {"hinge": f"{beam}.{end}", "quantity": _choice(rng, ["angle", "rate", "torque"])}
                    if probes[name]["quantity"] != "torque":
                        sensors.append(name)
    if rng.random() < 0.45:      # a guided body
        anchors = [b for b, spec in bodies.items() if "guide" not in spec]
        on = _choice(rng, [None] + anchors)
        at = [_r(rng, -1, 1, 2), _r(rng, -1, 1, 2), _r(rng, -0.5, 0.5, 2)]
        guide: dict = {"axis": _unit(rng)}
        if on is not None:
            guide["on"] = on
        kind = rng.random()
        if kind < 0.15:
            guide["position"] = _choice(rng, [f"{_r(rng, 0.05, 0.5, 2)}*t", f"{_r(rng, 0.05, 0.2, 2)}*sin(4*t)"])
        else:
            if rng.random() < 0.6:
                guide["stiffness"] = _r(rng, 1, 500, 2)
                if rng.random() < 0.3:
                    guide["rest"] = _r(rng, -0.1, 0.1, 3)
            if rng.random() < 0.4:
                guide["damping"] = _r(rng, 0.01, 5, 3)
            if rng.random() < 0.5:
                guide["force"] = _choice(rng, [_r(rng, -20, 20, 2), f"{_r(rng, -20, 20, 2)}*sin(5*t)",
                                               f"{_r(rng, 1, 20, 2)}*t - {_r(rng, 1, 50, 2)}*s_dot"])
            if rng.random() < 0.35:
                lo, hi = -_r(rng, 0.005, 0.2, 3), _r(rng, 0.005, 0.2, 3)
                guide["limits"] = [lo, hi]
                if rng.random() < 0.6:
                    guide["restitution"] = _choice(rng, [0, 0.5, 1])
            elif rng.random() < 0.15:
                guide["lock_at"] = _choice(rng, [-1, 1]) * _r(rng, 0.005, 0.1, 3)
            _contact_friction(rng, guide)
            actuated.append((guide, "force"))
        bodies["gd"] = {"at": at, "mass": _r(rng, 0.1, 3, 3), "guide": guide}
        if rng.random() < 0.5:
            bodies["gd"]["inertia"] = [_r(rng, 0.001, 0.1, 4)] * 3
        if rng.random() < 0.3:   # joined to the tree by a flexible member
            beams["gm"] = {"from": _choice(rng, anchors), "to": "gd", "section": _choice(rng, list(scene["sections"])),
                           "elements": 1}
            if rng.random() < 0.5:
                beams["gm"]["end"] = {"hinge": {"axis": _unit(rng)}}
        points.append("gd")
        name = "g_slide"
        probes[name] = {"guide": "gd", "quantity": _choice(rng, ["position", "rate", "force"])}
        if probes[name]["quantity"] != "force":
            sensors.append(name)
    cables = {}
    for i in range(int(rng.integers(0, 3)) if rng.random() < 0.4 else 0):
        ends = list(bodies)    # a cable's ends: bodies, a body with an offset, or a free end [x, y, z]
        a = _choice(rng, ends)
        b = _choice(rng, [e for e in ends if bodies[e]["at"] != bodies[a]["at"]] or [None])
        if b is None or rng.random() < 0.3:
            b = [_r(rng, -1, 1, 2), _r(rng, 0.2, 1.5, 2), _r(rng, -0.3, 0.3, 2)]
        elif rng.random() < 0.2:
            b = {"body": b, "offset": [_r(rng, -0.1, 0.1, 3), 0, 0]}
        cable: dict = {"from": a, "to": b, "EA": _r(rng, 1e2, 1e5, 0)}
        if rng.random() < 0.4:
            cable["rhoA"] = _r(rng, 0.01, 0.5, 3)
            if rng.random() < 0.5:
                cable["elements"] = int(rng.integers(2, 5))
        if rng.random() < 0.3:
            cable["damping"] = _r(rng, 0.1, 20, 2)
        rest = rng.random()
        if rest < 0.2:
            cable["rest_length"] = _r(rng, 0.1, 2, 3)
        elif rest < 0.35:
            cable["rest_length"] = _choice(rng, [f"{_r(rng, 0.3, 2, 2)} - {_r(rng, 0.05, 0.5, 2)}*t",
                                                 f"{_r(rng, 0.3, 2, 2)}*(1 + 0.1*sin(6*t))"])
        cables[f"c{i}"] = cable
        probes[f"c{i}_n"] = {"cable": f"c{i}", "quantity": _choice(rng, ["tension", "length"])}
        sensors.append(f"c{i}_n")
    if cables:
        scene["cables"] = cables
    if rng.random() < 0.25:
        scene["inputs"] = {"u": _r(rng, -1, 1, 2)}
        if actuated and rng.random() < 0.6:
            law, key = _choice(rng, actuated)
            law[key] = f"{_r(rng, 0.5, 10, 2)}*u"
    if sensors and actuated and rng.random() < 0.4:
        sensor = _choice(rng, sensors)
        controller: dict = {"output": f"-{_r(rng, 1, 50, 2)}*({sensor} - {_r(rng, -0.2, 0.2, 3)})"}
        if rng.random() < 0.3:
            controller["states"] = {"I": sensor}
            controller["output"] += f" - {_r(rng, 0.1, 10, 2)}*I"
            if rng.random() < 0.4:
                controller["initial"] = {"I": _r(rng, -0.1, 0.1, 3)}
        if rng.random() < 0.3:
            controller["rate"] = _choice(rng, [20, 50, 100, 1000])
        if rng.random() < 0.3:
            limit = _r(rng, 0.5, 20, 2)
            controller["limits"] = [-limit, limit]
        scene["controllers"] = {"ctl": controller}
        law, key = _choice(rng, actuated)
        law[key] = _choice(rng, ["ctl", f"2*ctl + {_r(rng, -1, 1, 2)}"])
        probes["ctl_out"] = {"controller": "ctl"}
    if rng.random() < 0.3 and solve["analysis"] in ("transient", "static"):
        parameters, names = {}, []
        section = scene["sections"][_choice(rng, list(scene["sections"]))]
        if rng.random() < 0.7:
            parameters["EI"] = section["EIy"]
            section["EIy"] = "EI"
            names.append("EI")
        if rng.random() < 0.5:
            parameters["rho"] = section["rhoA"]
            section["rhoA"] = "rho"
            names.append("rho")
        massive = [b for b, spec in bodies.items() if "mass" in spec and not spec.get("fixed")]
        if massive and rng.random() < 0.5:
            body = _choice(rng, massive)
            parameters["m"] = bodies[body]["mass"]
            bodies[body]["mass"] = "m"
            names.append("m")
        stiff = [(h, k) for h, k in actuated if isinstance(h.get("stiffness"), float)]
        if stiff and rng.random() < 0.5:
            law, _ = _choice(rng, stiff)
            parameters["k"] = law["stiffness"]
            law["stiffness"] = "k"
            names.append("k")
        if parameters:
            scene["parameters"] = parameters
            solve["sensitivities"] = names


def _solve(rng, scene, points) -> dict:
    analysis = _choice(rng, ["transient", "static", "modes", "buckling"], p=[0.5, 0.2, 0.2, 0.1])
    solve: dict = {"analysis": analysis}
    if rng.random() < 0.15:
        solve["formulation"] = _choice(rng, ["default", "cr4402", "no_stiffening"])
    if rng.random() < 0.15:
        solve["planar"] = _choice(rng, ["auto", "off"])
    if analysis == "transient" or (analysis == "modes" and rng.random() < 0.3):
        method = _choice(rng, ["generalized-alpha", "hht-alpha", "newmark", "explicit"], p=[0.4, 0.2, 0.25, 0.15])
        if method == "explicit":    # conditionally stable: small steps, a short run (it may well blow up)
            t_end, dt = _choice(rng, [0.01, 0.02]), _choice(rng, [1e-4, 2e-4])
        else:
            t_end = _choice(rng, [0.05, 0.1, 0.2, 0.5])
            dt = t_end / _choice(rng, [5, 10, 20, 50])
        solve.update({"t_end": t_end, "dt": dt, "method": method})
        if method in ("generalized-alpha", "hht-alpha") and rng.random() < 0.4:
            solve["rho_inf"] = _choice(rng, [0, 0.5, 1, 0.9])
        if method != "explicit" and rng.random() < 0.25:
            solve["adaptive"] = True
            if rng.random() < 0.5:
                solve["error_tol"] = _choice(rng, [1e-3, 1e-5])
        if method != "explicit" and rng.random() < 0.2:
            solve["newton"] = _choice(rng, ["full", "modified", "exact"])
        if rng.random() < 0.1:
            solve["tol"] = 1e-6
    if analysis in ("static", "buckling"):
        solve["steps"] = int(rng.integers(2, 11))
    if analysis == "static":
        method = _choice(rng, ["load-control", "arc-length", "displacement-control"], p=[0.5, 0.25, 0.25])
        solve["method"] = method
        if method == "arc-length" and rng.random() < 0.5:
            solve["max_steps"] = int(rng.integers(10, 60))
        if method == "displacement-control":
            solve["control"] = {"point": _choice(rng, points[1:] or points), "direction": _choice(rng, ["x", "y", "z"]),
                                "to": _r(rng, -0.2, 0.2, 3) or 0.05}
    if analysis == "modes":
        solve["count"] = int(rng.integers(1, 9))
        about = rng.random()
        if about < 0.35:
            solve["about"] = "initial"
        elif about < 0.6:
            solve["about"] = "static"
            solve["steps"] = int(rng.integers(2, 8))
        elif about < 0.8:
            solve["about"] = "steady"
        elif "t_end" in solve:
            solve["about"] = {"t": solve["t_end"]}
        if rng.random() < 0.2:
            solve["mode_shapes"] = True
    return solve


def _output(rng, scene, points) -> dict:
    beams = scene["beams"]
    probes: dict = {}
    for i in range(int(rng.integers(1, 6))):
        kind = _choice(rng, ["point", "hinge", "energy", "momentum", "element"])
        hinged = [f"{b}.{end}" for b, spec in beams.items() for end in ("start", "end") if end in spec]
        flexible = [b for b, spec in beams.items() if not spec.get("rigid")]
        if kind == "point":
            probe = {"point": _choice(rng, points), "quantity": _choice(rng, ["position", "displacement", "velocity"]),
                     "component": _choice(rng, ["x", "y", "z", "norm"])}
            if rng.random() < 0.3:
                probe["frame"] = _choice(rng, list(scene["bodies"]))
        elif kind == "hinge" and hinged:
            probe = {"hinge": _choice(rng, hinged), "quantity": _choice(rng, ["angle", "rate"])}
        elif kind == "element" and flexible:
            beam = _choice(rng, flexible)
            probe = {"element": f"{beam}.element[{int(rng.integers(0, beams[beam]['elements']))}]",
                     "quantity": _choice(rng, ["axial_force", "torque", "moment_y", "moment_z"])}
        elif kind == "momentum":
            probe = {"momentum": _choice(rng, ["linear", "angular"]), "component": _choice(rng, ["x", "y", "z"])}
        else:
            probe = {"energy": _choice(rng, ["kinetic", "strain", "potential", "external_work", "total"])}
        probes[f"p{i}"] = probe
    output: dict = {"probes": probes}
    solve = scene["solve"]
    if "t_end" in solve and rng.random() < 0.4:
        output["every"] = _choice(rng, [solve["dt"], 2 * solve["dt"], solve["t_end"] / 7])
    if rng.random() < 0.3:
        output["paraview_every"] = _choice(rng, [0, solve.get("t_end", 1) / 3])
    if solve["analysis"] == "modes" and rng.random() < 0.3:
        inputs = [f"{b}.{end}" for b, spec in beams.items() for end in ("start", "end")
                  if end in spec and "angle" not in spec[end]["hinge"]]
        inputs += [f"{_choice(rng, points)}.force.{_choice(rng, ['x', 'y', 'z'])}"]
        if scene.get("loads"):
            inputs.append("loads[0]")
        solve["linear_model"] = {"inputs": inputs[:3], "outputs": list(probes)[:2]}
    return output


# =========================================================================== running and judging a case
def _scene_text(scene: dict) -> str:
    return yaml.safe_dump(scene, sort_keys=False, default_flow_style=None, width=120)


def _run(args, *, timeout, cwd, interrupt_when=None):
    """(exit status or None on timeout, stdout, stderr, wall seconds); ``interrupt_when``: a path
    whose appearance triggers a SIGTERM (the run is then expected to exit 130)."""
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    started = time.perf_counter()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        process = subprocess.Popen([sys.executable, "-m", "latdyn", *args], cwd=cwd, stdout=out, stderr=err,
                                   env=env, text=True)
        status = None
        try:
            if interrupt_when is not None:
                while process.poll() is None and time.perf_counter() - started < timeout:
                    if Path(interrupt_when).exists():
                        process.send_signal(signal.SIGTERM)
                        break
                    time.sleep(0.01)
            status = process.wait(timeout=max(0.1, timeout - (time.perf_counter() - started)))
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        out.seek(0)
        err.seek(0)
        return status, out.read(), err.read(), time.perf_counter() - started


def _finite(values) -> bool:
    return bool(np.all(np.isfinite(np.asarray(values, dtype=float))))


def check_folder(out: Path, scene: dict, status: int) -> list[tuple[str, str]]:
    """What is wrong with the results folder of a run that exited with ``status`` (0 or 1):
    a list of ``(defect, detail)`` notes, empty when it reads back."""
    from latdyn.errors import ResultsError
    from latdyn.results.result import Result, load_state_history

    solve, probes = scene["solve"], list(scene["output"]["probes"])
    analysis = solve["analysis"]
    problems: list[tuple[str, str]] = []

    def bad(detail, kind="unreadable"):
        problems.append((kind, detail))

    if not out.is_dir():
        if status == 0:
            bad("no results folder")
        return problems
    try:
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        bad(f"summary.json: {exc}")
        return problems
    if status == 0 and summary.get("status") != "solved":
        bad(f"exit 0 with summary status {summary.get('status')!r}")
    if status == 1 and summary.get("status") == "solved":
        bad("exit 1 with summary status 'solved'")
    try:
        result = Result.load(out)
    except ResultsError as exc:
        if status == 0 or (out / "probes.csv").exists():
            bad(f"Result.load: {exc}")
        return problems
    has_rows = (out / "probes.csv").is_file()
    if has_rows:
        with open(out / "probes.csv", newline="", encoding="utf-8") as f:
            header = next(csv.reader(f), [])
        # buckling records no rows along its path: its header's first column is not checked
        first = {"static": ["load_factor"], "buckling": ["t", "load_factor"]}.get(analysis, ["t"])
        if analysis != "modes" and (header[:1] not in [[f] for f in first] or header[1:] != probes):
            bad(f"probes.csv header {header}, expected {[first[0], *probes]}")
        if summary.get("rows") is not None and summary["rows"] != len(result.t):
            bad(f"probes.csv has {len(result.t)} rows, summary.json says {summary['rows']}")
        if status == 0 and not all(_finite(v) for v in [result.t, *result.probes.values()]):
            bad("NaN or infinity in probes.csv", "nan_solved")
        if analysis == "transient" and len(result.t):
            if result.t[0] != 0.0 or np.any(np.diff(result.t) <= 0):
                bad(f"times not increasing from 0: {result.t[:5]}...")
            if status == 0 and abs(result.t[-1] - solve["t_end"]) > 1e-9 * max(1.0, solve["t_end"]):
                bad(f"solved but the last row is at t = {result.t[-1]!r}, t_end = {solve['t_end']}")
        if status == 0 and analysis == "transient" and not len(result.t):
            bad("solved with no rows")
    elif status == 0 and analysis != "modes":
        bad("no probes.csv")
    if analysis == "modes" and status == 0:
        if result.modes is None:
            bad("no modes.csv")
        else:
            if not _finite(result.modes):
                bad("NaN in modes.csv", "nan_solved")
            # no modes only where there is nothing to move (every part fixed or prescribed)
            if len(result.modes) > solve.get("count", 6) or (len(result.modes) == 0 and summary.get("coordinates")):
                bad(f"modes.csv has {len(result.modes)} modes, count is {solve.get('count', 6)}")
    if status == 0 and not all(f is not None for f in summary.get("modes_hz", [])):
        bad("a frequency in summary.json modes_hz is NaN (null)", "nan_solved")
    if analysis == "buckling" and status == 0 and "buckling_factor" not in summary:
        bad("buckling run without buckling_factor in summary.json")
    state_file = summary.get("state_file")
    if state_file:
        try:
            history = load_state_history(out)
            rows = len(history["t"]) if "t" in history else None
            if summary.get("state_rows") is not None and rows != summary["state_rows"]:
                bad(f"{state_file} has {rows} rows, summary.json says {summary['state_rows']}")
        except (ResultsError, OSError, KeyError, ValueError) as exc:
            bad(f"{state_file}: {exc}")
    elif status == 0 and analysis == "transient":
        bad("no state history")
    for name in summary.get("paraview_files", []) or []:
        problems.extend(_check_vtkhdf(out / name))
    if status == 0 and solve.get("linear_model"):
        try:
            with np.load(out / "linear_model.npz") as f:
                for key in ("A", "B", "C", "D"):
                    if not _finite(f[key]):
                        bad(f"linear_model.npz {key} not finite", "nan_solved")
        except (OSError, KeyError, ValueError) as exc:
            bad(f"linear_model.npz: {exc}")
    if status == 0 and solve.get("sensitivities") and analysis in ("transient", "static"):
        try:
            with open(out / "sensitivities.csv", newline="", encoding="utf-8") as f:
                table = list(csv.reader(f))
            # the adjoint writes the last recorded row alone (docs/parameters.md "The discrete adjoint")
            rows = 1 if solve.get("sensitivity_method") == "adjoint" else len(result.t)
            if len(table) - 1 != rows:
                bad(f"sensitivities.csv has {len(table) - 1} rows, probes.csv {len(result.t)}")
            elif not _finite([[float(x) for x in row] for row in table[1:]]):
                bad("NaN or infinity in sensitivities.csv", "nan_solved")
        except (OSError, ValueError) as exc:
            bad(f"sensitivities.csv: {exc}")
    if status == 0 and (out / "checkpoint.npz").exists():
        bad("a solved run left checkpoint.npz")
    return problems


def _check_vtkhdf(path: Path) -> list[tuple[str, str]]:
    """A ParaView file opens as HDF5 with the VTKHDF root and, with VTK installed, its reader reads it."""
    try:
        import h5py

        with h5py.File(path, "r") as f:
            root = f["VTKHDF"]
            if root.attrs.get("Type") is None:
                return [("unreadable", f"{path.name}: no VTKHDF Type attribute")]
    except (OSError, KeyError) as exc:
        return [("unreadable", f"{path.name}: {exc}")]
    try:
        import vtk
    except ImportError:
        return []
    reader = vtk.vtkHDFReader()
    if not reader.CanReadFile(str(path)):
        return [("unreadable", f"{path.name}: vtkHDFReader cannot read it")]
    reader.SetFileName(str(path))
    reader.Update()
    if reader.GetOutput() is None:
        return [("unreadable", f"{path.name}: vtkHDFReader read nothing")]
    return []


_REFUSAL = re.compile(r"^latdyn: error: (?P<file>.+?): (?P<key>[^:\n]+): (?P<what>.+)", re.M)


def judge(status, stderr: str, scene_path: Path, out: Path, scene: dict) -> tuple[str, str]:
    """(outcome, detail) of a finished ``latdyn run``."""
    if status is None:
        return "hang", "no exit within the timeout"
    if "Traceback" in stderr or "internal error" in stderr:
        return "traceback", stderr.strip().splitlines()[-1] if stderr.strip() else ""
    if status not in (0, 1, 2):
        return "exit_status", f"exit status {status}"
    if status == 2:
        m = _REFUSAL.search(stderr)
        key = m["key"] if m else ""
        if not m or m["file"] != str(scene_path) or not key.strip() or key in ("<file>", "<source>", "(top level)"):
            return "refusal_without_key", stderr.strip()[:300]
        if out.exists():
            return "unreadable", f"refused ({key}) but a results folder was left behind"
        return "refused", f"{key}: {m['what'].strip().splitlines()[0][:200]}"
    unbounded = status == 1 and "latdyn: error: unbounded:" in stderr
    if status == 1 and not unbounded and "latdyn: error: the solver failed:" not in stderr:
        return "failure_without_message", stderr.strip()[:300]
    problems = check_folder(out, scene, status)
    if problems:
        kinds = [k for k, _ in problems]
        kind = "nan_solved" if "nan_solved" in kinds else "unreadable"
        return kind, "; ".join(d for _, d in problems)[:500]
    if unbounded:
        status_in_summary = json.loads((out / "summary.json").read_text()).get("status")
        if status_in_summary != "unbounded":
            return "unreadable", f"unbounded on stderr, summary.json status {status_in_summary!r}"
        return "unbounded", re.search(r"unbounded: (.*)", stderr).group(1)[:200]
    if status == 1:
        m = re.search(r"the solver failed: (.*)", stderr)
        return "failed", m.group(1)[:200] if m else ""
    return "solved", ""


def run_case(seed: int, index: int, workdir: Path, *, timeout: float = TIMEOUT_S, resume_every: int = 8,
             joints: bool = False, step_check: bool = False, extended: bool = False) -> dict:
    """Generate case ``index`` of ``seed`` (``joints``: with :func:`_joint_additions`), run it (and, for
    every ``resume_every``-th transient case, interrupt and resume it; ``step_check``: a solved transient
    run again at dt/2, :func:`_step_check`) and judge it. Returns a record: index, outcome, detail, wall
    seconds, scene."""
    rng = np.random.default_rng([seed, index])
    scene = random_scene(rng, joints=joints, extended=extended)
    case_dir = workdir / f"case{index:04d}"
    case_dir.mkdir(parents=True, exist_ok=True)
    scene_path = case_dir / "scene.yaml"
    scene_path.write_text(_scene_text(scene), encoding="utf-8")
    out = case_dir / "out"
    command = ["run", str(scene_path), "-o", str(out), "-q"]
    status, stdout, stderr, wall = _run(command, timeout=timeout, cwd=case_dir)
    retried = ""
    if status is None:
        # A first run may wait for kernels to compile (a formulation or law not in the cache yet, or
        # another process compiling the same one under a file lock): once more, with the cache warm
        # and RETRY times the time. A run that ends then was slow, not hung; one that does not hangs.
        status, stdout, stderr, wall = _run(command, timeout=RETRY * timeout, cwd=case_dir)
        retried = f" (the first run passed the {timeout:g} s timeout; the second took {wall:.1f} s)"
    with READING:
        outcome, detail = judge(status, stderr, scene_path, out, scene)
    detail += retried
    record = {"index": index, "outcome": outcome, "detail": detail, "wall_s": round(wall, 2), "status": status,
              "analysis": scene["solve"]["analysis"], "stderr": stderr[-4000:], "scene": scene}
    if (outcome in ("solved", "failed") and scene["solve"]["analysis"] == "transient" and resume_every
            and index % resume_every == resume_every - 1):
        # the interrupted and resumed runs may take as long as the uninterrupted one did
        record.update(_resume_check(scene_path, scene, out, status, case_dir, RETRY * timeout))
    if step_check and record["outcome"] == "solved" and scene["solve"]["analysis"] == "transient":
        check = _step_check(scene, out, case_dir, RETRY * timeout)
        record["step_check"] = check
        if check["verdict"] == "step_dependent":
            record.update(outcome="step_dependent", detail=check["detail"])
    return record


def refined_scene(scene: dict, factor: int) -> dict:
    """``scene`` with its step divided by ``factor`` (and an adaptive run's ``error_tol`` by
    ``factor``², a second-order step's error falling as dt²), the same end time and rows, no ParaView
    frames."""
    import copy

    fine = copy.deepcopy(scene)
    solve = fine["solve"]
    solve["dt"] = solve["dt"] / factor
    if solve.get("adaptive"):
        solve["error_tol"] = solve.get("error_tol", 1e-4) / factor ** 2
    fine["output"].pop("paraview_every", None)
    return fine


def admitted_error(scene: dict, summary: dict) -> float:
    """The relative error a solved transient run admits: its energy balance error, its ``error_tol``
    when adaptive, and never less than :data:`STEP_CHECK_FLOOR`."""
    solve = scene["solve"]
    admitted = [STEP_CHECK_FLOOR, float(summary.get("energy_balance_error") or 0.0)]
    if solve.get("adaptive"):
        admitted.append(float(solve.get("error_tol", 1e-4)))
    return max(admitted)


def _rows_at(result, times, span: float) -> tuple[np.ndarray, np.ndarray]:
    """For each of ``times``: whether ``result`` recorded a row there (within 1e-9 ``span``) and its index."""
    j = np.clip(np.searchsorted(result.t, times), 0, len(result.t) - 1)
    left = np.clip(j - 1, 0, len(result.t) - 1)
    j = np.where(np.abs(result.t[left] - times) < np.abs(result.t[j] - times), left, j)
    return np.abs(result.t[j] - times) <= 1e-9 * span, j


def step_difference(coarse, fine, times=None) -> tuple[float, str]:
    """The largest difference of the probes of results ``coarse`` and ``fine`` on the rows both
    recorded (of ``times`` where given: the first run's, so that successive refinements are compared on
    the same rows), each probe relative to its largest magnitude over both (probes below
    :data:`STEP_CHECK_NOISE` in both skipped): (difference, the probe and time where it is)."""
    times = coarse.t if times is None else np.asarray(times, float)
    span = max(1.0, abs(float(times[-1])) if len(times) else 1.0)
    in_coarse, i = _rows_at(coarse, times, span)
    in_fine, j = _rows_at(fine, times, span)
    shared = in_coarse & in_fine
    i, j, at = i[shared], j[shared], times[shared]
    worst, where = 0.0, "no probe compared"
    for name, values in coarse.probes.items():
        a, b = values[i], fine.probes[name][j]
        scale = max(float(np.max(np.abs(values), initial=0.0)), float(np.max(np.abs(fine.probes[name]), initial=0.0)))
        if scale < STEP_CHECK_NOISE or not len(a):
            continue
        k = int(np.argmax(np.abs(a - b)))
        difference = float(abs(a[k] - b[k])) / scale
        if difference >= worst:
            worst, where = difference, f"{name} at t = {at[k]:.6g} ({a[k]:.6g} against {b[k]:.6g})"
    return worst, where


def _step_check(scene: dict, out: Path, case_dir: Path, timeout: float) -> dict:
    """The solved transient run in ``out`` against the same scene at dt/2 and, where they differ by
    more than the run admits, at dt/4, dt/8 … dt/:data:`STEP_CHECK_FINEST` until two successive
    differences fall with the observed order :data:`STEP_CHECK_ORDER`: the verdict ``agrees``,
    ``coarse`` (the differences fall, the first run's step was too long for its motion) or
    ``step_dependent`` (they never fall, or a finer run does not solve)."""
    from latdyn.results.result import Result

    with READING:
        coarse = Result.load(out)
    allowed = STEP_CHECK_MULTIPLE * admitted_error(scene, coarse.summary)
    results, differences, orders, check = [coarse], [], [], {"allowed": allowed}
    factor = 1
    while factor < STEP_CHECK_FINEST:
        factor *= 2
        path = case_dir / f"scene_dt_over_{factor}.yaml"
        path.write_text(_scene_text(refined_scene(scene, factor)), encoding="utf-8")
        fine_out = case_dir / f"out_dt_over_{factor}"
        status, _, stderr, _ = _run(["run", str(path), "-o", str(fine_out), "-q"], timeout=timeout, cwd=case_dir)
        if status != 0:
            why = "no exit within the timeout" if status is None else (stderr.strip().splitlines() or [""])[-1][:200]
            return {"verdict": "step_dependent", **check,
                    "detail": f"solved at dt but not at dt/{factor} (exit {status}): {why}"}
        with READING:
            results.append(Result.load(fine_out))
        difference, where = step_difference(results[-2], results[-1], coarse.t)
        differences.append(difference)
        if factor == 2:
            check.update(difference=difference, at=where)
            if difference <= allowed:
                return {"verdict": "agrees", **check}
            continue
        orders.append(float(np.log2(differences[-2] / difference)) if difference > 0 else float("inf"))
        check.update(differences=differences, orders=orders, order=orders[-1], finest=factor)
        if orders[-1] >= STEP_CHECK_ORDER:
            return {"verdict": "coarse", **check}
    return {"verdict": "step_dependent", **check,
            "detail": f"dt and dt/2 differ by {differences[0]:.3g} (the run admits {allowed / STEP_CHECK_MULTIPLE:.3g}); "
                      f"the differences down to dt/{factor} {', '.join(f'{d:.3g}' for d in differences[1:])} do not "
                      f"fall (orders {', '.join(f'{o:.2f}' for o in orders)}): {check['at']}"}


def _resume_check(scene_path, scene, uninterrupted, status, case_dir, timeout) -> dict:
    """Interrupt a second run once its first checkpoint is written, resume it, and compare."""
    out = case_dir / "resumed"
    first, _, err1, _ = _run(["run", str(scene_path), "-o", str(out), "-q", "--checkpoint-every", "0"],
                             timeout=timeout, cwd=case_dir, interrupt_when=out / "checkpoint.npz")
    if first == status:     # finished before the signal arrived: nothing to resume
        return {"resume": "not interrupted"}
    if first != 130:
        return {"outcome": "resume_mismatch", "detail": f"interrupted run exited {first}: {err1.strip()[-300:]}"}
    second, _, err2, _ = _run(["run", str(scene_path), "-o", str(out), "-q", "--resume"], timeout=timeout, cwd=case_dir)
    if second != status:
        return {"outcome": "resume_mismatch" if second is not None else "hang",
                "detail": f"resumed run exited {second}, uninterrupted {status}: {err2.strip()[-300:]}"}
    from latdyn.results.result import Result

    with READING:
        a, b = Result.load(uninterrupted), Result.load(out)
    if len(a.t) != len(b.t) or not np.allclose(a.t, b.t, rtol=0, atol=1e-12):
        return {"outcome": "resume_mismatch", "detail": f"rows {len(a.t)} uninterrupted, {len(b.t)} resumed"}
    for name, values in a.probes.items():
        scale = max(1e-12, float(np.nanmax(np.abs(values))) if len(values) else 1.0)
        if not np.allclose(values, b.probes[name], rtol=0, atol=1e-6 * scale, equal_nan=True):
            worst = float(np.nanmax(np.abs(values - b.probes[name])))
            return {"outcome": "resume_mismatch", "detail": f"probe {name} differs by {worst:.3g} (scale {scale:.3g})"}
    return _resumed_files_equal(uninterrupted, out) or {"resume": "equal"}


def _resumed_files_equal(uninterrupted: Path, resumed: Path) -> dict | None:
    """None where the resumed run's state history (every array, to 1e-6 of its magnitude) and the
    summary's events and peaks (SCENE.md: "the result files then equal those of an uninterrupted run")
    equal the uninterrupted run's; else the ``resume_mismatch`` record."""
    from latdyn.errors import ResultsError
    from latdyn.results.result import load_state_history

    try:
        with READING:
            a, b = load_state_history(uninterrupted), load_state_history(resumed)
    except (ResultsError, OSError) as exc:
        return {"outcome": "resume_mismatch", "detail": f"state history: {exc}"}
    if sorted(a) != sorted(b):
        return {"outcome": "resume_mismatch", "detail": f"state history keys {sorted(a)} against {sorted(b)}"}
    for key in a:
        x, y = np.asarray(a[key], float), np.asarray(b[key], float)
        if x.shape != y.shape:
            return {"outcome": "resume_mismatch", "detail": f"state history {key}: shape {x.shape} against {y.shape}"}
        scale = max(1e-12, float(np.nanmax(np.abs(x), initial=0.0)))
        if not np.allclose(x, y, rtol=0, atol=1e-6 * scale, equal_nan=True):
            worst = float(np.nanmax(np.abs(x - y)))
            return {"outcome": "resume_mismatch", "detail": f"state history {key} differs by {worst:.3g} (scale {scale:.3g})"}
    sa = json.loads((uninterrupted / "summary.json").read_text(encoding="utf-8"))
    sb = json.loads((resumed / "summary.json").read_text(encoding="utf-8"))
    for key in ("status", "events", "cable_events", "joint_peaks", "rows", "state_rows"):
        if not _close(sa.get(key), sb.get(key)):
            return {"outcome": "resume_mismatch", "detail": f"summary.json {key}: {str(sa.get(key))[:150]} against "
                                                           f"{str(sb.get(key))[:150]}"}
    return None


def _close(a, b, rtol: float = 1e-6) -> bool:
    """Equal JSON values, numbers to ``rtol`` of the larger."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k], rtol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y, rtol) for x, y in zip(a, b))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return abs(a - b) <= rtol * max(abs(a), abs(b), 1e-12)
    return a == b


# =========================================================================== the campaign
def campaign(runs: int, seed: int, *, jobs: int = 1, timeout: float = TIMEOUT_S, keep: Path | None = None,
             workdir: Path | None = None, progress=None, start: int = 0, joints: bool = False,
             step_check: bool = False, extended: bool = False, resume_every: int = 8) -> list[dict]:
    """Run cases ``start`` … ``start + runs - 1`` of ``seed``, ``jobs`` at a time (``joints``: scenes with
    the keys of 2026-11-26 too; ``step_check``: :func:`_step_check` on solved transient runs); the
    records in order."""
    own = workdir is None
    base = Path(tempfile.mkdtemp(prefix="latdyn_fuzz_")) if own else Path(workdir)
    records = []
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(run_case, seed, i, base, timeout=timeout, joints=joints,
                               step_check=step_check, extended=extended, resume_every=resume_every) for i in range(start, start + runs)]
        for future in futures:
            record = future.result()
            records.append(record)
            if keep is not None and record["outcome"] not in OUTCOMES:
                _keep(record, seed, keep)
            if progress:
                progress(record)
    if own:
        import shutil

        shutil.rmtree(base, ignore_errors=True)
    return records


def _keep(record: dict, seed: int, keep: Path) -> None:
    keep.mkdir(parents=True, exist_ok=True)
    stem = keep / f"seed{seed}_case{record['index']:04d}_{record['outcome']}"
    stem.with_suffix(".yaml").write_text(
        f"# {record['outcome']}: {record['detail']}\n# python benchmarks/fuzz_runs.py --show {record['index']} "
        f"--seed {seed}\n" + _scene_text(record["scene"]), encoding="utf-8")
    stem.with_suffix(".stderr").write_text(record["stderr"], encoding="utf-8")


def counts(records: list[dict]) -> dict:
    """Counts by outcome (and, for each analysis, by outcome)."""
    by = collections.Counter(r["outcome"] for r in records)
    per_analysis = collections.defaultdict(collections.Counter)
    for r in records:
        per_analysis[r["analysis"]][r["outcome"]] += 1
    verdicts = collections.Counter(r["step_check"]["verdict"] for r in records if "step_check" in r)
    return {"runs": len(records), "outcomes": dict(by), **({"step_check": dict(verdicts)} if verdicts else {}),
            "by_analysis": {k: dict(v) for k, v in sorted(per_analysis.items())},
            "resumed": sum(r.get("resume") == "equal" for r in records),
            "wall_s": {"total": round(sum(r["wall_s"] for r in records), 1),
                       "max": max((r["wall_s"] for r in records), default=0.0)}}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=300, help="cases to run (default 300)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the generator (default 1)")
    parser.add_argument("--start", type=int, default=0, help="first case index (default 0)")
    parser.add_argument("--jobs", type=int, default=1, help="runs at a time (default 1)")
    parser.add_argument("--timeout", type=float, default=TIMEOUT_S, help=f"seconds per run (default {TIMEOUT_S:g})")
    parser.add_argument("--workdir", type=Path, default=None,
                        help="run the cases in this folder and leave it (default: a temporary folder, removed)")
    parser.add_argument("--keep", type=Path, default=None, help="save each defect's scene and stderr here")
    parser.add_argument("--json", type=Path, default=None, help="write the counts and every record's outcome here")
    parser.add_argument("--joints", action="store_true",
                        help="scenes with cables, guides, contact, friction, inputs, controllers and sensitivities too")
    parser.add_argument("--extended", action="store_true",
                        help="scenes with offsets, steady spins, oblique gravity, adaptive steps for every method too")
    parser.add_argument("--resume-every", type=int, default=8, metavar="K",
                        help="interrupt and resume every K-th transient case (default 8; 1: every one)")
    parser.add_argument("--step-check", action="store_true",
                        help="run each solved transient case again at dt/2 (and dt/4) and judge the difference")
    parser.add_argument("--show", type=int, default=None, metavar="N", help="print the scene of case N and exit")
    args = parser.parse_args(argv)
    if args.show is not None:
        print(_scene_text(random_scene(np.random.default_rng([args.seed, args.show]), joints=args.joints,
                                             extended=args.extended)), end="")
        return 0

    def progress(record):
        mark = "" if record["outcome"] in OUTCOMES else "  <-- DEFECT"
        check = record.get("step_check")
        if check and check["verdict"] != "step_dependent":
            mark += f"  [dt/2: {check['verdict']} {check['difference']:.2g}" + (
                f", order {check['order']:.2f} at dt/{check['finest']}]" if "order" in check else "]")
        print(f"case {record['index']:4d} {record['analysis']:9s} {record['outcome']:24s} {record['wall_s']:6.1f} s "
              f"{record['detail'][:110]}{mark}", flush=True)

    records = campaign(args.runs, args.seed, jobs=args.jobs, timeout=args.timeout, keep=args.keep,
                       progress=progress, start=args.start, workdir=args.workdir, joints=args.joints,
                       step_check=args.step_check, extended=args.extended,
                       resume_every=args.resume_every)
    summary = counts(records)
    print(json.dumps(summary, indent=1))
    if args.json:
        args.json.write_text(json.dumps({"seed": args.seed, "start": args.start, **summary, "records": [
            {k: r[k] for k in ("index", "analysis", "outcome", "detail", "wall_s", "step_check") if k in r}
            for r in records]}, indent=1))
    return 0 if not any(r["outcome"] in DEFECTS for r in records) else 1


if __name__ == "__main__":
    sys.exit(main())
