"""Outside check of the refusals issue 34's fifteenth session lifted (session 2026-11-28 sixteenth, helper fuzznew).

Lifted last session, each checked by its author on a handful of scenes: a friction stick on models with rigid links
(forward), a hinge resting on its stop on rigid links (forward), a turning shift (a ring offset, a link's point on a
turning ring) beside events and controllers, a stick beside energy probes and PI or sampled controllers, the adjoint
beside geometry, links, controllers, rests, sticks and events. This driver writes random genuinely 3D scenes of those
families (:data:`FAMILIES`):

- ``gimbal``: two rigid rings on random skew hinges carrying a flexible boom to a tip mass, on a fixed or a slewing
  (prescribed rotation) base; at random a ring offset or the inner ring's hinge point on the outer ring moved by X
  (a part that turns), the inner hinge latching, bouncing off a rigid stop or coming to rest on it (restitution 0),
  or held by Coulomb friction under a sinusoidal torque (or a friction hinge at the boom's end), a PD (of the outer
  hinge's angle and rate, or of a point), a PI or a sampled PD on the outer hinge, a compliant stop;
- ``cart``: a cart on a skew guide on a slewing base carrying a rigid pendulum on a skew hinge and a flexible arm, X
  the guide's origin (the cart and what it carries moved), the pendulum latching or on a stop, a PD on the guide;
- ``braked``: a panel on a skew friction hinge at the tip of a flexible 3D arm under gravity and a torque in t,
  sticking and slipping, its energies probed, a PI or a sampled PD on the hinge, sometimes a latch or stop upstream.

The event angles are placed from a pilot run without sensitivities (the angle the hinge reaches at 55–75 % of the
run), so that most cases meet their event. 1–3 parameters (sections, masses, springs, dampers, friction, gains, the
torque's amplitude, X), the integrator at random (generalized-α with ρ∞ in [0.5, 1], HHT-α, Newmark).

Checks per case (a process of its own, ``--worker``, with ``--timeout``):
(c) the forward method against Richardson-extrapolated central differences of whole runs (h = STEP |p| and h/2, the
    time step fixed, ``solve.tol: 1e-12``; the perturbed runs with ``solve.sensitivities: [p]``: a run without them
    may take other steps — 49 against 41 on seed 1 case 6, 47 against 43 on case 10): every row, each probe's end, max and min and each event time
    (benchmarks/fuzz_sensitivities.compare, relative to that output's largest); a parameter whose perturbed runs take
    other steps or events (fuzz_sensitivities._signature) or whose stuck rows change is skipped and counted;
(a) the adjoint (``solve.sensitivity_method: adjoint``) against the forward method where it takes the scene
    (benchmarks/fuzz_combined4._compare, ≤ 1e-9), or its refusal by message;
(o) objectivity: the scene rotated by a random R and translated by d (fuzz_combined5.moved, and here the guides'
    axes, the offsets in body axes, the prescribed rotations' axes), the invariant probes' sensitivities equal and
    the points' rotated (fuzz_combined5.objectivity, ≤ 1e-9); skipped where a controller reads a point's component;
(e) no traceback: anything other than a SceneError-style refusal is a crash; the worker's timeout.

Tally: agree / refused (by message) / disagree / crash / skipped (and ``unresolved``: off by more than TOL but
within NOISE × the spread of the two central differences, or below what whole runs resolve).

Campaign of 2026-11-28 (seeds 1 and 2, 35 cases each, on 7fbef8b; the cases from about s1-15 and s2-29 on ran with
the two refusals below already in): 49 agree, 6 disagree, 4 unresolved, 10 refused, 1 skipped (5 parameters skipped);
adjoint = forward on the 25 cases it takes within 5.5e-10; objectivity on 60 cases within 4.0e-9. Found:
- s1-6, s2-1: a turning shift (the inner hinge point on the outer ring) carrying the flexible boom through a latch
  under gravity, 5.1e-6 … 1.3e-5 off after the latch (the impulse weight's (∂K/∂X) w 1.9e-6 off; 5.3e-10 without
  gravity or with the boom massless): refused from fuzznew, mended in turngrav (the static ∂r/∂X an event's
  (∂K/∂X) w differences held the elements' weight in the shift's K d + d × F_S; geometry_sensitivities
  ``ReferenceGeometry.add``): both agree since, every row within the spread of the two differences (s1-6 ≤ 3.2e-8,
  s2-1 ≤ 1.1e-8, the tips ≤ 5.3e-10), the adjoint 3.4e-10 and 8.0e-12 off the forward method;
- s1-5: a hinge resting on its stop on rigid links, 3.0e-3 (m) off from the rest's second step, 4.6e-2 after its
  release: the rest on rigid links refused (transient_sensitivities ``_refuse_a_linked_rest``); the cause found by
  linkrest (2026-11-29): the run released the ring and settled it again at one instant, which the forward method
  did not follow; mended, s1-5 agrees within 2.4e-9, and so do the other rests s1-2, s4-1 (1.7e-7, 2.1e-7: an event
  time; the spread 4.3e-4) and the stops without rest s4-3, s4-5;
- s1-0, s1-22 (X through stops: r2/X 4.0e-9, 1.5e-9) and s1-19 (a stick on links: the inner ring's velocity by tau
  1.8e-9): objectivity above 1e-9, not a missing term by their size (both paths hold differences along w or along
  the held angle whose truncation moves with the axes), not shown either.
The unresolved (braked panels by m and Ki, a rest by k1) are off by less than the spread of the two differences.
Rerun of 2026-11-29 (turngrav, load 7-26): ``--runs 30 --seed 5 --family gimbal``, 17 gimbals: 8 agree (s5-8, the ring
offset carrying the boom through a latch under gravity, X ≤ 3.0e-8 within its spread 4.8e-7; m, k1 4.0e-8 and 3.0e-8 on
a2's row 9 µs after the latch), 7 refused (a rest on rigid links; a prescribed rotation; a kinetic-energy probe beside
the shift), 2 unresolved (s5-26 by Fc 4.0e-6, spread 3.1e-6; s5-29 by Kp 1.2e-6, spread 8.2e-7, X skipped: another
branch), 0 crashes.

``python benchmarks/fuzz_lifted.py --runs 60 --seed 1 --keep DIR``; ``--show N --seed S`` prints a case's scene;
``--tally DIR``. Run niced, one thread per process. Not run by the suite.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(1, str(ROOT / "tests"))

from benchmarks import fuzz_combined as combined  # noqa: E402
from benchmarks import fuzz_combined4 as four  # noqa: E402
from benchmarks import fuzz_combined5 as five  # noqa: E402
from benchmarks import fuzz_sensitivities as fs  # noqa: E402

FAMILIES = ("gimbal", "cart", "braked")
#: the relative perturbation of (c) (and half of it)
STEP = 1e-4
#: (c): a derivative agrees within this of its reference, relative to the output's largest
TOL = 1e-6
#: (a) and (o): fuzz_combined4's and fuzz_combined5's bound
BOUND = 1e-9


_r, _unit = five._r, five._unit   # coordinates rounded as fuzz_combined5 rounds them; a random unit vector


def _skew(rng: random.Random, main: int) -> list[float]:
    """An axis near a coordinate axis, tilted by up to ~40° (a skew hinge, never planar)."""
    v = [_r(rng.uniform(-0.5, 0.5)) for _ in range(3)]
    v[main] = 1.0
    return v


def _diag(rng: random.Random, size: float) -> list[float]:
    return [_r(size * rng.uniform(0.7, 1.5)) for _ in range(3)]


def _method(rng: random.Random, solve: dict) -> None:
    kind = rng.choice(["ga", "ga", "hht", "newmark"])
    if kind == "ga":
        solve["rho_inf"] = _r(rng.uniform(0.5, 1.0))
    elif kind == "hht":
        solve["method"] = "hht-alpha"
    else:
        solve["method"] = "newmark"


def _slewing(rng: random.Random) -> dict:
    return {"at": [0.0, 0.0, 0.0], "motion": {"rotation": {"axis": _skew(rng, 2),
                                                          "angle": f"{_r(rng.uniform(0.5, 2.0))}*t**2"}}}


# ---------------------------------------------------------------------------------------------------------- scenes
#
# A scene is (data, event): ``event`` None or (joint key path, kind, probe) that :func:`placed` sets from a pilot run.

def gimbal(rng: random.Random) -> tuple[dict, tuple | None, list[str]]:
    params = {"k1": _r(rng.uniform(4, 8)), "k2": _r(rng.uniform(2, 6)), "c2": _r(rng.uniform(0.02, 0.08)),
              "m": _r(rng.uniform(0.2, 0.4)), "EI": _r(rng.uniform(15, 30)), "P": _r(rng.uniform(0.2, 0.6))}
    kinds: list[str] = []
    outer = [_r(0.3 + rng.uniform(-0.05, 0.05)), _r(0.1 + rng.uniform(-0.05, 0.05)), _r(0.2 + rng.uniform(-0.05, 0.05))]
    inner = [_r(outer[0] + 0.15 + rng.uniform(-0.03, 0.03)), _r(outer[1] - 0.15 + rng.uniform(-0.03, 0.03)),
             _r(outer[2] + 0.15 + rng.uniform(-0.03, 0.03))]
    tip = [_r(inner[0] + 0.55 + rng.uniform(-0.1, 0.1)), _r(inner[1] + 0.3 + rng.uniform(-0.1, 0.1)),
           _r(inner[2] + 0.2 + rng.uniform(-0.1, 0.1))]
    bodies = {"base": {"at": [0.0, 0.0, 0.0], "fixed": True} if rng.random() < 0.6 else _slewing(rng),
              "outer": {"at": outer, "mass": "m", "inertia": _diag(rng, 0.0025)},
              "inner": {"at": inner, "mass": _r(rng.uniform(0.15, 0.25)), "inertia": _diag(rng, 0.0012)},
              "tip": {"at": tip, "mass": 0.1, "inertia": _diag(rng, 0.0002)}}
    if "motion" in bodies["base"]:
        kinds.append("slewing base")
    h1 = {"axis": _skew(rng, 2), "stiffness": "k1", "rest_angle": _r(rng.uniform(-0.6, 0.6))}
    h2 = {"axis": _skew(rng, 0), "stiffness": "k2", "damping": "c2"}
    beams = {"gim1": {"from": "base", "to": "outer", "section": "ring", "rigid": True, "y_axis": _unit(rng),
                      "start": {"hinge": h1}},
             "gim2": {"from": "outer", "to": "inner", "section": "ring", "rigid": True, "y_axis": _unit(rng),
                      "start": {"hinge": h2}},
             "boom": {"from": "inner", "to": "tip", "section": "boom", "elements": rng.randint(1, 2),
                      "y_axis": _unit(rng)}}
    probes = {f"tip_{c}": {"point": "tip", "quantity": "position", "component": c} for c in "xyz"}
    probes.update({f"inner_{c}": {"point": "inner", "quantity": "velocity", "component": c} for c in "xyz"})
    probes.update({"a1": {"hinge": "gim1.start", "quantity": "angle"}, "a2": {"hinge": "gim2.start", "quantity": "angle"},
                   "r2": {"hinge": "gim2.start", "quantity": "rate"}})
    loads = [{"at": "tip", "force": [0.0, "P", "-0.5*P"]}]
    data = {"title": "fuzz_lifted gimbal", "parameters": params,
            "sections": {"ring": {"EA": 1.0e6, "EIy": 1.0e3, "EIz": 1.0e3, "GJ": 1.0e3, "rhoA": 0.8, "rhoIy": 0.0008,
                                  "rhoIz": 0.001},
                         "boom": {"EA": 1.0e5, "EIy": "EI", "EIz": "1.2*EI", "GJ": "0.7*EI", "rhoA": 0.4,
                                  "rhoIy": 0.0004, "rhoIz": 0.0005}},
            "bodies": bodies, "beams": beams, "loads": loads}
    if rng.random() < 0.4:
        data["gravity"] = [0.0, 0.0, -9.81]
    if "motion" not in bodies["base"] and rng.random() < 0.7:
        data["initial_velocity"] = {"linear": [0.0, 0.0, 0.0], "angular": [_r(rng.uniform(-0.5, 0.5)),
                                                                            _r(rng.uniform(-0.5, 0.5)),
                                                                            _r(rng.uniform(1.0, 2.5))],
                                    "about": [0.0, 0.0, 0.0]}
    # the lifted path this case aims at
    aim = rng.choice(["stick", "stick", "stick-end", "rest", "rest", "shift", "shift", "shift"])
    kinds.append(aim)
    event = None
    listed = rng.sample(["k1", "k2", "c2", "m", "EI", "P"], rng.randint(1, 2))
    if aim in ("stick", "stick-end"):
        params["Fc"], params["tau"] = _r(rng.uniform(0.03, 0.07)), _r(rng.uniform(0.08, 0.16))
        w = _r(rng.uniform(10, 18))
        friction = {"coulomb": "Fc", "stick_rate": 0.02}
        if rng.random() < 0.3:
            friction["viscous"] = 0.01
        if aim == "stick":
            h2["torque"] = f"tau*sin({w}*t)"
            h2["friction"] = friction
            h2.pop("damping")
        else:
            beams["boom"]["end"] = {"hinge": {"axis": _skew(rng, 1), "stiffness": 0.5,
                                              "torque": f"0.6*tau*sin({w}*t)",
                                              "friction": {**friction, "coulomb": "0.2*Fc"}}}
            probes["a3"] = {"hinge": "boom.end", "quantity": "angle"}
            probes["r3"] = {"hinge": "boom.end", "quantity": "rate"}
        data.pop("initial_velocity", None)
        listed = ["Fc"] + rng.sample(["k2", "m", "EI", "tau"], rng.randint(0, 2))
    elif aim == "rest":
        event = ("beams.gim2.start.hinge", "rest", "a2")
        listed = rng.sample(["k1", "m", "EI", "P", "c2"], rng.randint(1, 3))
    else:   # a turning shift beside events and controllers
        params["X"] = 0.1
        d = _unit(rng)
        which = rng.choice(["ring", "point"])
        kinds.append(f"shift {which}")
        if which == "ring":
            bodies["outer"]["at"] = [f"{_r(outer[i] - 0.1 * d[i])} + {d[i]}*X" for i in range(3)]
        else:
            beams["gim2"]["from"] = {"body": "outer", "offset": [f"{d[i]}*(X - 0.1)" for i in range(3)]}
        bodies["inner"]["at"] = [f"{_r(inner[i] - 0.1 * d[i])} + {d[i]}*X" for i in range(3)]
        bodies["tip"]["at"] = [f"{_r(tip[i] - 0.1 * d[i])} + {d[i]}*X" for i in range(3)] if rng.random() < 0.5 else tip
        beside = rng.choice(["latch", "stop", "pd", "pd-point", "pi", "sampled", "friction-contact"])
        kinds.append(beside)
        if beside in ("latch", "stop") or rng.random() < 0.5:
            event = ("beams.gim2.start.hinge", "latch" if beside != "stop" else "stop", "a2")
        if beside in ("pd", "pd-point", "pi", "sampled"):
            params.update({"Kp": _r(rng.uniform(0.4, 1.2)), "Kd": _r(rng.uniform(0.2, 0.6)), "Ki": 2.0})
            probes["r1"] = {"hinge": "gim1.start", "quantity": "rate"}
            if beside == "pd-point":
                probes["ox"] = {"point": "outer", "quantity": "position", "component": "x"}
                output = {"output": f"Kp*({_r(outer[0])} - ox) - Kd*r1"}
            elif beside == "pi":
                output = {"output": "Kp*(0.1 - a1) + Ki*E", "states": {"E": "0.1 - a1 - 0.5*E"}}
            else:
                output = {"output": "Kp*(0.1 - a1) - Kd*r1"}
                if beside == "sampled":
                    output["rate"] = rng.choice([50, 100])
            data["controllers"] = {"ctl": output}
            h1["torque"] = "ctl"
            listed = ["X"] + rng.sample(["Kp", "Kd" if beside != "pi" else "Ki", "k1", "m"], rng.randint(0, 2))
        elif beside == "friction-contact":
            h1["friction"] = {"coulomb": 0.02, "static": 0.03, "viscous": 0.01}
            event = ("beams.gim2.start.hinge", "contact", "a2")
            listed = ["X"] + rng.sample(["k1", "m", "EI"], rng.randint(0, 1))
        else:
            listed = ["X"] + rng.sample(["k1", "k2", "m", "EI"], rng.randint(0, 2))
    data["solve"] = {"analysis": "transient", "dt": rng.choice([0.005, 0.01]), "t_end": rng.choice([0.3, 0.4]),
                     "sensitivities": list(dict.fromkeys(listed))}
    _method(rng, data["solve"])
    if rng.random() < 0.3:
        probes.update({"kinetic": {"energy": "kinetic"}, "strain": {"energy": "strain"}})
    data["output"] = {"every": 0.01, "probes": probes}
    return data, event, kinds


def cart(rng: random.Random) -> tuple[dict, tuple | None, list[str]]:
    params = {"X": 0.2, "k": _r(rng.uniform(20, 40)), "c": _r(rng.uniform(0.1, 0.3)), "kh": _r(rng.uniform(2, 4)),
              "EI": _r(rng.uniform(6, 10)), "m": _r(rng.uniform(0.2, 0.4))}
    d = _unit(rng)
    bob = [_r(0.1 + rng.uniform(-0.05, 0.05)), _r(-0.05 + rng.uniform(-0.05, 0.05)), _r(-0.4 + rng.uniform(-0.05, 0.05))]
    tip = [_r(0.6 + rng.uniform(-0.1, 0.1)), _r(0.1 + rng.uniform(-0.1, 0.1)), _r(-0.5 + rng.uniform(-0.1, 0.1))]
    slewing = rng.random() < 0.6   # a shift is refused beside a prescribed rotation: X on a fixed base alone
    bodies = {"base": _slewing(rng) if slewing else {"at": [0.0, 0.0, 0.0], "fixed": True},
              "cart": {"at": [f"{d[i]}*X" for i in range(3)], "mass": 0.5, "inertia": _diag(rng, 0.003),
                       "guide": {"on": "base", "axis": _skew(rng, 0), "stiffness": "k", "damping": "c", "rest": 0.05}},
              "bob": {"at": [f"{bob[i]} + {d[i]}*X" for i in range(3)], "mass": "m", "inertia": _diag(rng, 0.001)},
              "tip": {"at": tip, "mass": 0.1, "inertia": _diag(rng, 0.0002)}}
    beams = {"pend": {"from": "cart", "to": "bob", "section": "rod", "rigid": True, "y_axis": _unit(rng),
                      "start": {"hinge": {"axis": _skew(rng, 1), "stiffness": "kh"}}},
             "arm": {"from": "bob", "to": "tip", "section": "arm", "elements": rng.randint(1, 3), "y_axis": _unit(rng)}}
    probes = {"s": {"guide": "cart", "quantity": "position"}, "s_rate": {"guide": "cart", "quantity": "rate"},
              "th": {"hinge": "pend.start", "quantity": "angle"}}
    probes.update({f"bob_{c}": {"point": "bob", "quantity": "position", "component": c} for c in "xyz"})
    probes.update({f"tip_{c}": {"point": "tip", "quantity": "displacement", "component": c} for c in "xyz"})
    data = {"title": "fuzz_lifted cart on a slewing base", "parameters": params, "gravity": [0.0, 0.0, -9.81],
            "sections": {"rod": {"EA": 1.0e6, "EIy": 1.0e3, "EIz": 1.0e3, "GJ": 1.0e3, "rhoA": 0.6, "rhoIy": 0.0006,
                                 "rhoIz": 0.0006},
                         "arm": {"EA": 1.0e5, "EIy": "EI", "EIz": "1.3*EI", "GJ": "0.8*EI", "rhoA": 0.3,
                                 "rhoIy": 0.0003, "rhoIz": 0.0004}},
            "bodies": bodies, "beams": beams, "loads": [{"at": "tip", "force": [0.5, 0.0, 0.3]}]}
    kinds = []
    event = None
    beside = rng.choice(["latch", "stop", "pd", "none"])
    kinds.append(beside)
    if beside in ("latch", "stop"):
        event = ("beams.pend.start.hinge", beside, "th")
    elif beside == "pd":
        params.update({"Kp": _r(rng.uniform(5, 15)), "Kd": _r(rng.uniform(0.2, 1.0))})
        data["controllers"] = {"ctl": {"output": "-Kp*s - Kd*s_rate"}}
        bodies["cart"]["guide"]["force"] = "ctl"
    listed = ["X"] + rng.sample([k for k in params if k != "X"], rng.randint(0, 2))
    if slewing:
        kinds.append("slewing base")
        listed = listed[1:] or ["k"]
        bodies["cart"]["at"] = [_r(0.2 * d[i]) for i in range(3)]
        bodies["bob"]["at"] = [_r(bob[i] + 0.2 * d[i]) for i in range(3)]
    data["solve"] = {"analysis": "transient", "dt": 0.005, "t_end": rng.choice([0.2, 0.3]), "sensitivities": listed}
    _method(rng, data["solve"])
    data["output"] = {"every": 0.01, "probes": probes}
    return data, event, kinds


def braked(rng: random.Random) -> tuple[dict, tuple | None, list[str]]:
    params = {"Fc": _r(rng.uniform(0.15, 0.25)), "A": _r(rng.uniform(0.6, 1.4)), "EI": _r(rng.uniform(30, 60)),
              "m": _r(rng.uniform(0.8, 1.2))}
    panel = [_r(0.6667 + rng.uniform(-0.1, 0.1)), _r(0.3333 + rng.uniform(-0.1, 0.1)), _r(0.6667 + rng.uniform(-0.1, 0.1))]
    axis = _skew(rng, rng.randrange(3))
    hinge = {"axis": axis, "torque": "A*t", "friction": {"coulomb": "Fc", "static": _r(1.5 * params["Fc"])}}
    data = {"title": "fuzz_lifted braked panel", "parameters": params, "gravity": [0.0, 0.0, -9.81],
            "sections": {"s": {"EA": 1.0e5, "EIy": "EI", "EIz": "1.3*EI", "GJ": "0.8*EI", "rhoA": 0.5, "rhoIy": 0.01,
                               "rhoIz": 0.013}},
            "bodies": {"base": {"at": [0.0, 0.0, 0.0], "fixed": True},
                       "panel": {"at": panel, "mass": "m", "com": [0.1, 0.05, 0.0], "inertia": _diag(rng, 0.35)}},
            "beams": {"arm": {"from": "base", "to": "panel", "section": "s", "elements": 2, "y_axis": _unit(rng),
                              "end": {"hinge": hinge}}}}
    probes = {"angle": {"hinge": "arm.end", "quantity": "angle"}, "rate": {"hinge": "arm.end", "quantity": "rate"}}
    probes.update({f"p_{c}": {"point": "panel", "quantity": "position", "component": c} for c in "xyz"})
    kinds = []
    beside = rng.choice(["energies", "pi", "sampled", "work", "energies-pi"])
    kinds.append(beside)
    listed = ["Fc"] + rng.sample(["EI", "A", "m"], rng.randint(0, 2))
    if "energies" in beside:
        probes.update({"kinetic": {"energy": "kinetic"}, "strain": {"energy": "strain"},
                       "potential": {"energy": "potential"}, "total": {"energy": "total"}})
    if beside == "work":
        hinge["torque"] = f"{_r(rng.uniform(0.15, 0.3))}*A"
        probes.update({"work": {"energy": "external_work"}, "kinetic": {"energy": "kinetic"}})
    if beside in ("pi", "energies-pi"):
        params.update({"Kp": _r(rng.uniform(1, 3)), "Ki": _r(rng.uniform(0.3, 0.8))})
        data["controllers"] = {"ctl": {"output": "-Kp*angle - Ki*S", "states": {"S": "angle"}}}
        hinge["torque"] = "A*t + ctl"
        listed += rng.sample(["Kp", "Ki"], 1)
    if beside == "sampled":
        params.update({"Kp": _r(rng.uniform(1, 3)), "Kd": _r(rng.uniform(0.05, 0.2))})
        data["controllers"] = {"ctl": {"output": "-Kp*angle - Kd*rate", "rate": 100}}
        hinge["torque"] = "A*t + ctl"
        listed += rng.sample(["Kp", "Kd"], 1)
    data["solve"] = {"analysis": "transient", "dt": 0.01, "t_end": 0.4, "sensitivities": listed}
    _method(rng, data["solve"])
    data["output"] = {"probes": probes}
    return data, None, kinds


GENERATORS = {"gimbal": gimbal, "cart": cart, "braked": braked}


def scene_for(seed: int, index: int) -> tuple[dict, tuple | None, list[str], random.Random]:
    rng = random.Random(f"lifted-{seed}-{index}")
    family = rng.choice(["gimbal", "gimbal", "gimbal", "cart", "braked"])
    data, event, kinds = GENERATORS[family](rng)
    return data, event, [family] + kinds, rng


def placed(data: dict, event: tuple | None, rng: random.Random) -> dict:
    """The event's angle set where a pilot run without sensitivities takes the hinge at 55–75 % of the run (a latch
    there, a stop or a rest just short of the angle reached, a compliant stop a little before)."""
    if event is None:
        return data
    import latdyn

    path, kind, probe = event
    pilot = json.loads(json.dumps(data))
    pilot["solve"].pop("sensitivities")
    result = latdyn.run(latdyn.load_scene(pilot))
    angle = np.asarray(result.probes[probe])
    i = int(len(angle) * rng.uniform(0.55, 0.75))
    target = float(angle[i])
    up = target > float(angle[0])
    hinge = data
    for key in path.split("."):
        hinge = hinge[key]
    if kind == "latch":
        hinge["lock_at"] = _r(target)
    elif kind in ("stop", "rest", "contact"):
        lo, hi = (-3.0, _r(target)) if up else (_r(target), 3.0)
        hinge["limits"] = [lo, hi]
        if kind == "stop":
            hinge["restitution"] = _r(rng.uniform(0.3, 0.9))
        elif kind == "rest":
            hinge["restitution"] = 0.0
        elif kind == "contact":
            hinge["contact"] = {"stiffness": 30.0, "exponent": 1.5, "damping": 0.1}
    return data


# ---------------------------------------------------------------------------------------------------------- moving

def moved(scene: dict, R: np.ndarray, d: np.ndarray) -> dict:
    """fuzz_combined5.moved and what it leaves: guides' axes, offsets (body axes: the global ones at t = 0), the
    prescribed rotations' axes, diagonal inertias, the beams' ``from`` given as a body with an offset."""
    s = json.loads(json.dumps(scene))
    for body in s["bodies"].values():
        if isinstance(body.get("inertia"), list) and not isinstance(body["inertia"][0], list):
            body["inertia"] = [[body["inertia"][i] if i == j else 0.0 for j in range(3)] for i in range(3)]
    s = five.moved(s, R, d)
    for body in s["bodies"].values():
        if "guide" in body:
            body["guide"]["axis"] = five._vector(R, body["guide"]["axis"])
        if "com" in body:
            body["com"] = five._vector(R, body["com"])
        rotation = body.get("motion", {}).get("rotation")
        if rotation:
            rotation["axis"] = five._vector(R, rotation["axis"])
    for beam in s["beams"].values():
        for end in ("from", "to"):
            if isinstance(beam[end], dict):
                beam[end]["offset"] = five._vector(R, beam[end]["offset"])
    return s


def objective(data: dict) -> bool:
    """(o) applies: no controller reads a point's component (its rotated scene reads another quantity)."""
    probes = data["output"]["probes"]
    read = " ".join(json.dumps(c) for c in data.get("controllers", {}).values())
    return not any("point" in p and name in read for name, p in probes.items())


# ---------------------------------------------------------------------------------------------------------- worker

def _rows_before_events(run: dict) -> tuple:
    """How many recorded rows come before each event: an event that crosses a row under the perturbation puts that
    row on the other side of the jump (a row 2.4e-6 s after a stop, seed 1 case 0)."""
    return tuple(int(np.count_nonzero(run["x"] < e["t"])) for e in run["summary"].get("events", []) or [])


def _stuck_rows(result) -> tuple:
    """The rows where a friction joint's rate is exactly 0 (held): a perturbation that moves a stick or a release
    across a row changes the computed solution's branch."""
    return tuple(tuple(np.flatnonzero(np.asarray(v) == 0.0)) for k, v in sorted(result.probes.items())
                 if k in ("r2", "r3", "rate"))


def worker(scene_path: Path, case: Path, seed: str) -> dict:
    import yaml

    data = yaml.safe_load(scene_path.read_text())
    data["solve"]["tol"] = 1e-12
    record: dict = {"checks": {}}
    result, error = five._result(data, case / "forward")
    if error:
        record["forward_error"] = error
        adjoint = json.loads(json.dumps(data))
        adjoint["solve"]["sensitivity_method"] = "adjoint"
        _, aerror = five._result(adjoint, case / "adjoint")
        record["adjoint_error"] = aerror
        return record
    record["events"] = [(e["kind"], e.get("joint"), e["t"]) for e in result.summary.get("events", [])]
    record["stuck"] = [len(r) for r in _stuck_rows(result)]
    base = fs._read(case / "forward")
    # (c) Richardson of whole runs, per parameter
    comparisons, skipped = {}, {}
    signature, stuck = fs._signature(base), _stuck_rows(result)
    for name in data["solve"]["sensitivities"]:
        p = float(data["parameters"][name])
        h = STEP * abs(p)
        runs = []
        for dp in (h, -h, h / 2, -h / 2):
            moved_data = json.loads(json.dumps(data))
            moved_data["parameters"][name] = p + dp
            moved_data["solve"]["sensitivities"] = [name]   # landing on events and sticks as the run with them does
            folder = case / f"r_{name}{dp:+.3g}"
            r, e = five._result(moved_data, folder)
            if e:
                skipped[name] = f"perturbed run failed: {e['error'][:120]}"
                break
            run = fs._read(folder)
            if (fs._signature(run)[:5] != signature[:5] or _stuck_rows(r) != stuck
                    or _rows_before_events(run) != _rows_before_events(base)):
                skipped[name] = "another branch (steps, events, an event across a row, or stuck rows)"
                break
            runs.append(run)
        else:
            comparisons[name] = [{k: v for k, v in c.items()} for c in fs.compare(base, runs, name, h, p)]
    record["checks"]["c"] = {"compared": comparisons, "skipped": skipped}
    # (a) the adjoint against the forward method
    adjoint = json.loads(json.dumps(data))
    adjoint["solve"]["sensitivity_method"] = "adjoint"
    aresult, aerror = five._result(adjoint, case / "adjoint")
    if aerror:
        record["adjoint_error"] = aerror
    else:
        def raw(summary):
            return {"raw_probe_sensitivities": summary.get("probe_sensitivities"),
                    "raw_event_sensitivities": summary.get("event_sensitivities")}
        record["checks"]["a"] = four._compare(raw(result.summary), raw(aresult.summary))
    # (o) objectivity
    if objective(data):
        rng = random.Random(f"{seed}-turn")
        R, d = five.rotation(rng)
        kinds = {name: p.get("energy") or p.get("quantity") for name, p in data["output"]["probes"].items()}
        turned, terror = five._result(moved(data, R, d), case / "turned")
        if terror:
            record["turned_error"] = terror
        else:
            record["checks"]["o"] = five.objectivity(result, turned, R, d, kinds)
    return record


def judge(record: dict) -> tuple[str, list[str]]:
    """The case's outcome and its problems."""
    problems = []
    for key in ("forward_error", "adjoint_error", "turned_error"):
        e = record.get(key)
        if e and e["error_kind"] not in four.CLEAN:
            problems.append(f"crash ({key}): {e['error'][:200]} | {e['where'][-300:]}")
    if "worker_error" in record:
        return ("timeout" if record["worker_error"] == "timeout" else "crash"), [record["worker_error"][-400:]]
    if "forward_error" in record:
        return ("crash" if problems else "refused"), problems
    c = record["checks"].get("c", {})
    unresolved = []
    for name, comparisons in c.get("compared", {}).items():
        for comp in comparisons:
            if comp.get("not_compared") or comp["error"] <= TOL:
                continue
            label = f"(c) {comp['probe']} {comp['where']} by {name}: {comp['error']:.2e}"
            if comp.get("unresolvable") or comp["error"] <= fs.NOISE * comp.get("spread", 0.0):
                unresolved.append(label + f" (spread {comp.get('spread', 0.0):.1e})")
            else:
                problems.append(label)
    a = record["checks"].get("a")
    if a and (a["missing"] or not a["worst"] <= BOUND):
        problems.append(f"(a) adjoint vs forward {a['worst']:.2e} at {a['where']} {a['missing'][:3]}")
    o = record["checks"].get("o")
    if o and not o["worst"] <= BOUND:
        problems.append(f"(o) objectivity {o['worst']:.2e} at {o['where']}")
    record["unresolved"] = unresolved
    if any(p.startswith("crash") for p in problems):
        return "crash", problems
    if problems:
        return "DISAGREE", problems
    if not c.get("compared"):
        return "skipped", []
    return ("unresolved" if unresolved else "agree"), unresolved


def refusal(record: dict, key: str) -> str:
    e = record.get(key)
    if not e:
        return ""
    message = e["error"]
    return message.split(": ", 1)[-1][:160]


def tally_records(folders: list[Path]) -> dict:
    counts: dict = {"outcomes": {}, "refused": {}, "adjoint_refused": {}, "skipped_parameters": 0, "kinds": {},
                    "problems": {}, "unresolved": {}, "adjoint_compared": 0, "adjoint_worst": 0.0,
                    "objectivity_compared": 0, "objectivity_worst": 0.0, "richardson_worst": 0.0}
    for folder in folders:
        path = folder / "record.json"
        if not path.exists():
            continue
        record = json.loads(path.read_text())
        outcome = record["outcome"]
        counts["outcomes"][outcome] = counts["outcomes"].get(outcome, 0) + 1
        for kind in record.get("kinds", []):
            counts["kinds"][kind] = counts["kinds"].get(kind, 0) + 1
        if outcome == "refused":
            m = refusal(record, "forward_error")
            counts["refused"][m] = counts["refused"].get(m, 0) + 1
        m = refusal(record, "adjoint_error")
        if m and outcome != "refused":
            counts["adjoint_refused"][m] = counts["adjoint_refused"].get(m, 0) + 1
        c = record.get("checks", {}).get("c", {})
        counts["skipped_parameters"] += len(c.get("skipped", {}))
        for comparisons in c.get("compared", {}).values():
            for comp in comparisons:
                if not comp.get("not_compared"):
                    counts["richardson_worst"] = max(counts["richardson_worst"], comp["error"])
        if record.get("checks", {}).get("a"):
            counts["adjoint_compared"] += 1
            counts["adjoint_worst"] = max(counts["adjoint_worst"], record["checks"]["a"]["worst"])
        if record.get("checks", {}).get("o"):
            counts["objectivity_compared"] += 1
            counts["objectivity_worst"] = max(counts["objectivity_worst"], record["checks"]["o"]["worst"])
        if record.get("problems"):
            counts["problems"][folder.name] = record["problems"][:4]
        if record.get("unresolved"):
            counts["unresolved"][folder.name] = record["unresolved"][:2]
    return counts


def main(argv=None) -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=Path("/tmp/fuzz_lifted"))
    parser.add_argument("--timeout", type=float, default=600)
    parser.add_argument("--show", type=int)
    parser.add_argument("--worker", nargs=2)
    parser.add_argument("--tally", type=Path)
    parser.add_argument("--family", choices=sorted(GENERATORS), help="run only the cases of this family")
    args = parser.parse_args(argv)
    if args.worker:
        scene, case = Path(args.worker[0]), Path(args.worker[1])
        try:
            record = worker(scene, case, case.name)
        except Exception:   # noqa: BLE001 -- the worker's own failure, recorded as a crash
            import traceback

            record = {"worker_error": traceback.format_exc()[-1500:]}
        print("RECORD " + json.dumps(record))
        return 0
    if args.tally:
        print(json.dumps(tally_records(sorted(p for p in args.tally.iterdir() if p.is_dir())), indent=1))
        return 0
    if args.show is not None:
        data, event, kinds, rng = scene_for(args.seed, args.show)
        print(f"# {kinds}\n" + four._dump(placed(data, event, rng)))
        return 0
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    for n in range(args.first, args.first + args.runs):
        case = args.keep / f"s{args.seed}-{n}"
        start = time.time()
        data, event, kinds, rng = scene_for(args.seed, n)
        if args.family is not None and kinds[0] != args.family:
            continue
        case.mkdir(parents=True, exist_ok=True)
        try:
            data = placed(data, event, rng)
        except Exception as e:   # noqa: BLE001 -- the pilot run's own failure: a case of its own
            record = {"forward_error": {"error": f"pilot: {type(e).__name__}: {e}"[:400], "error_kind": type(e).__name__,
                                        "where": ""}}
        else:
            (case / "scene.yaml").write_text(four._dump(data))
            record = combined.run_worker(__file__, case, env, args.timeout)
        if isinstance(record.get("worker_error"), str) and "Traceback" not in record["worker_error"] \
                and record["worker_error"] != "timeout":
            record["worker_error"] = "no record: " + record["worker_error"]
        record["kinds"] = kinds
        outcome, problems = judge(record)
        record["outcome"], record["problems"] = outcome, problems
        (case / "record.json").write_text(json.dumps(record, indent=1, default=str))
        c = record.get("checks", {})
        print(f"{n}: {outcome:10s} {time.time() - start:5.0f}s {kinds} events {[e[0] for e in record.get('events', [])]} "
              f"stuck {record.get('stuck')} c-skip {list(c.get('c', {}).get('skipped', {}))} "
              f"a {c.get('a', {}).get('worst', refusal(record, 'adjoint_error')[:60])} o {c.get('o', {}).get('worst')} "
              f"{problems[:2] or refusal(record, 'forward_error')}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
