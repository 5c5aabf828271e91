"""The scene reference, written from the loader's own tables at every docs build (issue 35 item 2).

Which keys exist, and where, is never written here by hand: it is recorded from
``latdyn.scene.loader`` itself —

1. **by running it**: every ``_Reader.mapping(value, key, allowed, required)`` call (the one place
   the loader checks a mapping's keys) is recorded while it reads every shipped scene
   (``examples/**/*.yaml``, ``latdyn/examples``) and the few short scenes of :data:`REACH` that get
   it to places no shipped scene goes (displacement control, each kind of probe);
2. **by reading its source**: every table of keys (a module-level ``_*_KEYS`` tuple or a dict of
   them, e.g. ``_PROBE_KEYS``) of the modules of ``latdyn/scene/``, so that a table a new feature
   adds (cables, guides, controllers …) is listed even before a shipped scene uses it.

What a key means, its unit and default are the hand-written part (:data:`DESCRIPTIONS`, keyed by
the key's place, ``NAME`` for user-given names); a default the loader's dataclass gives
(``Solve.rho_inf = 0.8``) is read from the dataclass. A key without a description makes the build
fail (a Sphinx warning under ``-W``), and ``tests/test_docs_true.py`` checks that the reference names
every key the loader accepts and describes each.

latdyn has no unit system of its own: any consistent set (SI: m, kg, s, N) is used throughout, so
units are given as dimensions (length L, mass M, time T, force F).
"""
from __future__ import annotations

import ast
import dataclasses
import re
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = Path(__file__).resolve().parents[1] / "_generated" / "scene_keys.md"

#: Short scenes that take the loader where no shipped scene goes (they must load).
REACH = [
    """
sections: {s: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies: {a: {at: [0, 0, 0], fixed: true}, b: {at: [1, 0, 0]}}
beams:
  m: {from: {body: a, offset: [0, 0, 0]}, to: {body: b, offset: [0, 0, 0]}, section: s,
      start: {hinge: {axis: [0, 0, 1]}}}
solve: {analysis: static, method: displacement-control, steps: 2, control: {point: b, direction: y, to: 0.1}}
output:
  probes:
    p: {point: b, quantity: position, frame: global, component: x}
    h: {hinge: m.start, quantity: angle}
    e: {energy: kinetic}
    l: {momentum: linear, component: x}
    f: {element: m.element[0], quantity: axial_force}
""",
    """
sections: {s: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies: {a: {at: [0, 0, 0], fixed: true}}
beams: {m: {from: a, to: [1, 0, 0], section: s}}
solve: {analysis: modes, about: {t: 0.1}, t_end: 0.2, dt: 0.1}
""",
    """
parameters: {k: 2.0}
inputs: {target: 0.5}
sections: {s: {EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  arm: {at: [1, 0, 0], mass: 1.0, inertia: [0.1, 0.1, 0.1]}
beams: {link: {from: hub, to: arm, section: s, rigid: true, start: {hinge: {axis: [0, 0, 1], torque: pd + pi_}}}}
controllers:
  pd: {output: "k*(target - angle) - rate", limits: [-5, 5]}
  pi_: {output: "0.1*z", states: {z: "target - angle"}, initial: {z: 0}, rate: 100}
solve: {t_end: 0.02, dt: 0.01}
output:
  probes:
    angle: {hinge: link.start, quantity: angle}
    rate: {hinge: link.start, quantity: rate}
    u: {controller: pd}
    zs: {controller: pi_, state: z}
""",
    """
bodies: {a: {at: [0, 0, 0], fixed: true}, b: {at: [0, -1, 0], mass: 1.0}}
cables:
  c: {from: {body: a, offset: [0, 0, 0]}, to: {body: b, offset: [0, 0, 0]}, EA: 100.0, rhoA: 0.1, damping: 0.1,
      elements: 2, rest_length: "1 - 0.01*t"}
solve: {t_end: 0.02, dt: 0.01}
output:
  probes:
    n: {cable: c, quantity: tension}
    l: {cable: c, quantity: length}
""",
]

# ----------------------------------------------------------------------------- descriptions
#: {place of the key: (what it is, unit, default)}; a default of None is read from the loader's
#: dataclass (or is "required" when the loader requires the key).
DESCRIPTIONS: dict[str, tuple[str, str, str | None]] = {
    # top level
    "title": ("free text, shown in results and pictures", "—", "empty"),
    "gravity": ("gravitational acceleration [gx, gy, gz]", "L/T²", "[0, 0, 0]"),
    "initial_velocity": ("rigid motion of the whole structure at t = 0 (prescribed bodies follow their own law)",
                         "—", "at rest"),
    "parameters": ("named numbers {NAME: number}; any number of the scene may be an expression of them "
                   "(docs/parameters.md)", "—", "none"),
    "sections": ("beam cross-sections, by name", "—", "none"),
    "bodies": ("rigid joint bodies, by name", "—", "none"),
    "beams": ("flexible beams (or rigid links), by name", "—", "none"),
    "loads": ("a list of point loads", "—", "none"),
    "solve": ("the analysis and its settings", "—", "a transient run"),
    "output": ("what is recorded", "—", "every step, no probes"),
    # initial velocity
    "initial_velocity.linear": ("velocity of the point `about` [vx, vy, vz]", "L/T", "[0, 0, 0]"),
    "initial_velocity.angular": ("angular velocity [wx, wy, wz]", "rad/T", "[0, 0, 0]"),
    "initial_velocity.about": ("the point whose velocity is `linear`", "L", "the origin"),
    # sections
    "sections.NAME.EA": ("axial stiffness", "F", "required"),
    "sections.NAME.EIy": ("bending stiffness against deflection along local z", "F·L²", "required"),
    "sections.NAME.EIz": ("bending stiffness against deflection along local y", "F·L²", "required"),
    "sections.NAME.GJ": ("torsional stiffness", "F·L²", "required"),
    "sections.NAME.rhoA": ("mass per length", "M/L", "required"),
    "sections.NAME.rhoIy": ("rotary inertia per length about local y", "M·L", None),
    "sections.NAME.rhoIz": ("rotary inertia per length about local z", "M·L", None),
    "sections.NAME.GAy": ("shear stiffness along local y (with EIz); absent: shear-rigid (Euler–Bernoulli)",
                          "F", "absent"),
    "sections.NAME.GAz": ("shear stiffness along local z (with EIy); absent: shear-rigid (Euler–Bernoulli)",
                          "F", "absent"),
    # bodies
    "bodies.NAME.at": ("reference point [x, y, z] at t = 0 (origin of the body frame, parallel to the global axes)",
                       "L", "required"),
    "bodies.NAME.mass": ("mass", "M", "0"),
    "bodies.NAME.com": ("centre of mass, offset from `at`", "L", "[0, 0, 0]"),
    "bodies.NAME.inertia": ("inertia about the centre of mass, t = 0 axes: [Ixx, Iyy, Izz] or 3×3", "M·L²", "0"),
    "bodies.NAME.fixed": ("grounded (no coordinates)", "—", None),
    "bodies.NAME.motion": ("prescribed motion (no coordinates): `translation` and/or `rotation`", "—", "free"),
    "bodies.NAME.motion.translation": ("displacement of `at`, three expressions in t", "L", "none"),
    "bodies.NAME.motion.rotation": ("rotation about a fixed axis through `at`", "—", "none"),
    "bodies.NAME.motion.rotation.axis": ("the axis [ax, ay, az]", "—", "required"),
    "bodies.NAME.motion.rotation.angle": ("the angle, an expression in t", "rad", "required"),
    # beams
    "beams.NAME.from": ("start: a body, `{body, offset}` (a grid point in body axes)", "—", "required"),
    "beams.NAME.to": ("end: a body, `{body, offset}`, or [x, y, z] (a free end: a new massless node)",
                      "L", "required"),
    "beams.NAME.from.body": ("the body the grid point belongs to", "—", "required"),
    "beams.NAME.from.offset": ("the grid point's offset from the body's `at`, in body axes", "L", "[0, 0, 0]"),
    "beams.NAME.to.body": ("the body the grid point belongs to", "—", "required"),
    "beams.NAME.to.offset": ("the grid point's offset from the body's `at`, in body axes", "L", "[0, 0, 0]"),
    "beams.NAME.section": ("name of its section", "—", "required"),
    "beams.NAME.elements": ("number of equal elements", "—", "1"),
    "beams.NAME.y_axis": ("local y (made normal to x = start → end)", "—", "global Z × x, else global Y"),
    "beams.NAME.start": ("joint at the start: `clamped` or `{hinge: HINGE}`", "—", "clamped"),
    "beams.NAME.end": ("joint at the end: `clamped` or `{hinge: HINGE}` (a free end takes none)", "—", "clamped"),
    "beams.NAME.rigid": ("one rigid link with the beam's mass and inertia; `elements` is ignored", "—", None),
    # hinges (the same table at either end)
    "HINGE.axis": ("hinge axis [ax, ay, az], global at t = 0 (the angle is 0 at t = 0)", "—", "required"),
    "HINGE.stiffness": ("spring: a number or an expression in theta, theta_dot, t", "F·L/rad", None),
    "HINGE.damping": ("damper: a number or an expression in theta, theta_dot, t", "F·L·T/rad", None),
    "HINGE.torque": ("applied torque about the axis: an expression in t (or theta, theta_dot)", "F·L", "none"),
    "HINGE.angle": ("prescribed angle, an expression in t (the hinge then has no coordinate)", "rad", "free"),
    "HINGE.lock_at": ("latches rigidly when the angle reaches this value (not 0, where it starts)", "rad", "never"),
    "HINGE.rest_angle": ("neutral angle of the spring", "rad", None),
    "HINGE.limits": ("hard stops [lo, hi] on the angle (lo ≤ 0 ≤ hi)", "rad", "none"),
    "HINGE.restitution": ("coefficient of restitution of an impact on a stop, in [0, 1]", "—", None),
    # sliding joints (guides)
    "bodies.NAME.guide": ("a sliding (prismatic) joint: the body slides along an axis fixed in `on`, keeping "
                          "its orientation; its one coordinate is the slide s", "—", "none"),
    "bodies.NAME.guide.on": ("the body the axis is fixed in", "—", "the ground"),
    "bodies.NAME.guide.axis": ("slide axis [ax, ay, az], global at t = 0 (s = 0 at t = 0)", "—", "required"),
    "bodies.NAME.guide.stiffness": ("spring: a number or an expression in s, s_dot, t", "F/L", "none"),
    "bodies.NAME.guide.damping": ("damper: a number or an expression in s, s_dot, t", "F·T/L", "none"),
    "bodies.NAME.guide.force": ("applied force along the axis: an expression in t (or s, s_dot)", "F", "none"),
    "bodies.NAME.guide.rest": ("neutral slide of the spring", "L", "0"),
    "bodies.NAME.guide.limits": ("hard stops [lo, hi] on the slide (lo ≤ 0 ≤ hi)", "L", "none"),
    "bodies.NAME.guide.restitution": ("coefficient of restitution of an impact on a stop, in [0, 1]", "—", "0"),
    "bodies.NAME.guide.lock_at": ("latches rigidly when the slide reaches this value (not 0, where it starts; "
                                  "not with position)", "L", "never"),
    "bodies.NAME.guide.position": ("prescribed slide, an expression in t (then no coordinate)", "L", "free"),
    # cables (docs/cables.md)
    "cables": ("tension-only members between two points, by name (docs/cables.md)", "—", "none"),
    "cables.NAME.from": ("one end: a body, `{body, offset}`, a point BEAM.start|end|node[i], or [x, y, z] "
                         "(a free end: a new massless node)", "—", "required"),
    "cables.NAME.to": ("the other end, as `from`", "—", "required"),
    "cables.NAME.from.body": ("the body the end belongs to", "—", "required"),
    "cables.NAME.from.offset": ("the end's offset from the body's `at`, in body axes", "L", "[0, 0, 0]"),
    "cables.NAME.to.body": ("the body the end belongs to", "—", "required"),
    "cables.NAME.to.offset": ("the end's offset from the body's `at`, in body axes", "L", "[0, 0, 0]"),
    "cables.NAME.EA": ("axial stiffness (> 0): tension N = EA (ℓ − L₀)/L₀ in each element while taut, 0 while "
                       "slack", "F", "required"),
    "cables.NAME.rhoA": ("mass per unstretched length (≥ 0), lumped at the cable's own nodes", "M/L", "0"),
    "cables.NAME.damping": ("c (≥ 0): adds c·dℓ/dt while taut; the total never pushes (N ≥ 0)", "F·T/L", "0"),
    "cables.NAME.elements": ("number of equal elements (several only with rhoA > 0); inner nodes "
                             "CABLE.node[i] have translations only", "—", "1"),
    "cables.NAME.rest_length": ("unstretched length: a number or an expression in t (a reel; its work is "
                                "external work); shorter than the ends' distance = pretensioned", "L",
                                "the initial distance of its ends"),
    "inputs": ("named external signals {NAME: number}, usable by name in any expression; held in `latdyn run`, "
               "set from Python (latdyn.Simulation) or an FMU", "—", "none"),
    "controllers": ("control laws in the loop, by name, in file order (docs/control.md)", "—", "none"),
    "controllers.NAME.output": ("the output: an expression of t, probes, inputs, parameters, its states and "
                                "controllers defined before it", "—", "required"),
    "controllers.NAME.states": ("{S: EXPR}: dS/dt = EXPR (sampled: S ← S + EXPR/rate once a sample)", "—", "none"),
    "controllers.NAME.initial": ("{S: number}: the states at t = 0", "—", "0"),
    "controllers.NAME.rate": ("sampling rate: output computed at t = k/rate and held (zero-order hold)", "1/T",
                              "continuous"),
    "controllers.NAME.limits": ("saturation [lo, hi] of the output (lo < hi)", "—", "none"),
    # contact and friction at joints (hinges and guides: θ is the slide s of a guide, N·m read N)
    "HINGE.contact": ("the stops compliant (Hunt–Crossley) instead of rigid events: k δⁿ + c δⁿ δ̇, never "
                      "pulling (docs/contact.md); needs limits, excludes restitution", "—", "rigid stops"),
    "HINGE.contact.stiffness": ("k (> 0)", "F·L/radⁿ (guide: F/Lⁿ)", "required"),
    "HINGE.contact.exponent": ("n (≥ 1; 1.5: Hertz)", "—", "1"),
    "HINGE.contact.damping": ("c (≥ 0) of the Hunt–Crossley law", "F·L·T/radⁿ⁺¹ (guide: F·T/Lⁿ⁺¹)", "0"),
    "HINGE.friction": ("friction opposing the joint's rate: Coulomb, static (stiction), Stribeck, viscous "
                       "(docs/contact.md)", "—", "none"),
    "HINGE.friction.coulomb": ("Coulomb level Fc (≥ 0)", "F·L (guide: F)", "required"),
    "HINGE.friction.static": ("breakaway (static) level Fs ≥ Fc", "F·L (guide: F)", "coulomb"),
    "HINGE.friction.stribeck_rate": ("vs: Fs decays to Fc as exp(−(rate/vs)²); 0: no decay", "rad/T (guide: L/T)",
                                     "0"),
    "HINGE.friction.viscous": ("cv: adds cv·rate", "F·L·T/rad (guide: F·T/L)", "0"),
    "HINGE.friction.stick_rate": ("v₀: the rate below which a joint sticks", "rad/T (guide: L/T)", "1e-3"),
    # loads
    "loads.at": ("the point: BODY, BEAM.start, BEAM.end or BEAM.node[i]", "—", "required"),
    "loads.force": ("force [fx, fy, fz], expressions in t", "F", "none"),
    "loads.moment": ("moment [mx, my, mz], expressions in t", "F·L", "none"),
    "loads.frame": ("axes of the components: global, or a body (turning with it: a follower load)", "—", None),
    # solve
    "solve.analysis": ("transient, static, modes or buckling", "—", None),
    "solve.t_end": ("end time (transient; modes about {t: T})", "T", "required"),
    "solve.dt": ("time step (the last step lands on t_end)", "T", "required"),
    "solve.method": ("transient: generalized-alpha, hht-alpha, newmark, explicit; static: load-control, "
                     "arc-length, displacement-control", "—", None),
    "solve.rho_inf": ("spectral radius at infinite frequency (numerical damping), in [0, 1]", "—", None),
    "solve.tol": ("Newton tolerance (relative)", "—", "1e-8 (transient), 1e-10 (static paths)"),
    "solve.steps": ("static: load steps (load factor 0 → 1)", "—", None),
    "solve.count": ("modes: how many frequencies", "—", None),
    "solve.adaptive": ("adaptive time step from the local error estimate", "—", None),
    "solve.error_tol": ("adaptive: local error tolerance", "—", None),
    "solve.dt_min": ("smallest step (steps are cut on Newton failures or by the error estimate)", "T", "dt·1e-6"),
    "solve.max_iterations": ("Newton iterations per step at most", "—", None),
    "solve.formulation": ("beam element: default, cr4402, no_stiffening", "—", None),
    "solve.engine": ("auto or compiled (the same: the compiled Newton step)", "—", None),
    "solve.newton": ("full, modified or exact (full with the inertia tangent from the start)", "—", None),
    "solve.planar": ("auto: a scene that stays in a plane is solved in-plane; off: always 3D", "—", None),
    "solve.control": ("static displacement control: `point`, `direction`, `to`", "—", "none"),
    "solve.control.point": ("the controlled point", "—", "required"),
    "solve.control.direction": ("x, y, z or a vector [dx, dy, dz]", "—", "required"),
    "solve.control.to": ("final displacement of the point along the direction", "L", "required"),
    "solve.max_steps": ("arc length: most path steps", "—", "20 × steps"),
    "solve.about": ("modes: initial, static, steady or {t: T}", "—", None),
    "solve.about.t": ("the time of the transient state to linearise about", "T", "required"),
    "solve.linear_model": ("write OUT/linear_model.npz: `inputs` and `outputs`", "—", "none"),
    "solve.linear_model.inputs": ("hinge torques (BEAM.start|end) and load components by name", "—", "required"),
    "solve.linear_model.outputs": ("probes by name", "—", "required"),
    "solve.mode_shapes": ("modes: also write the mode shapes as ParaView animations", "—", None),
    "solve.sensitivities": ("parameters whose exact derivatives of the recorded probes are written to "
                            "sensitivities.csv (static load and displacement control; others are refused)", "—", "none"),
    "solve.sensitivity_method": ("forward (every row) or adjoint (transient runs without events: each probe's "
                                 "end, max and min derivatives only; docs/parameters.md)", "—", "forward"),
    "solve.flutter": ("buckling: search the flutter load along the path", "—", "where loads are follower loads"),
    # output
    "output.every": ("time between recorded rows", "T", "every step"),
    "output.paraview_every": ("time between ParaView frames; 0: none", "T", "the package's choice"),
    "output.probes": ("recorded columns of probes.csv, by name", "—", "none"),
    "output.probes.NAME.point": ("point probe: the point", "—", "required"),
    "output.probes.NAME.quantity": ("what is measured (point: position|displacement|velocity; hinge: angle|rate|torque; "
                                    "guide: position|rate|force; element: axial_force|torque|moment_y|moment_z; "
                                    "cable: tension|length)",
                                    "L, L/T, rad, rad/T, F, F·L", "required"),
    "output.probes.NAME.frame": ("point probe: global, or a body (relative to its `at`, in its axes)", "—", "global"),
    "output.probes.NAME.component": ("x, y, z or norm (point); x, y, z (momentum)", "—", "norm (point)"),
    "output.probes.NAME.hinge": ("hinge probe: BEAM.start or BEAM.end", "—", "required"),
    "output.probes.NAME.guide": ("guide probe: the guided body (quantity position, rate or force)", "—", "required"),
    "output.probes.NAME.controller": ("controller probe: its output (after saturation)", "—", "required"),
    "output.probes.NAME.state": ("controller probe: one of its states instead of its output", "—", "the output"),
    "output.probes.NAME.energy": ("kinetic, strain, potential, external_work, dissipated or total", "F·L",
                                  "required"),
    "output.probes.NAME.momentum": ("linear or angular (about the global origin)", "M·L/T, M·L²/T", "required"),
    "output.probes.NAME.element": ("element probe: BEAM.element[i] (0-based)", "—", "required"),
    "output.probes.NAME.cable": ("cable probe: the cable (quantity tension: its first element's axial force; "
                                 "length: along the cable)", "—", "required"),
}

#: places whose keys are one table under several names: (place pattern, name in DESCRIPTIONS)
_ALIASES = [(re.compile(r"^beams\.NAME\.(start|end)\.hinge\."), "HINGE."),
            (re.compile(r"^bodies\.NAME\.guide\.(?=contact|friction)"), "HINGE.")]

#: the dataclass whose field defaults are those of the keys at a place
_DATACLASSES = {"sections.NAME": "Section", "bodies.NAME": "Body", "beams.NAME": "Beam", "HINGE": "Hinge",
                "loads": "Load", "solve": "Solve", "output": "Output"}


def describe(place: str) -> tuple[str, str, str | None] | None:
    for pattern, name in _ALIASES:
        place = pattern.sub(name, place)
    return DESCRIPTIONS.get(place)


def _pattern(key: str) -> str:
    """``beams.bay1.start.hinge`` → ``beams.NAME.start.hinge`` (user-given names become NAME)."""
    parts = [p for p in re.sub(r"\[\d+\]", "", key).split(".") if p]
    out: list[str] = []
    for part in parts:
        parent = ".".join(out)
        named = parent in ("sections", "bodies", "beams", "output.probes") or (
            parent.count(".") == 0 and parent and parent not in ("initial_velocity", "loads", "solve", "output",
                                                                 "gravity", "title"))
        out.append("NAME" if named else part)
    return ".".join(out)


# ----------------------------------------------------------------------------- recording the loader
def recorded_tables() -> dict[str, list[tuple[tuple[str, ...], tuple[str, ...]]]]:
    """``{place: [(allowed keys, required keys), …]}`` from the loader's mapping() calls while it reads
    the shipped scenes and :data:`REACH` (several tables at one place: the kinds of probe)."""
    from latdyn.scene import loader

    tables: dict[str, list] = {}
    original = loader._Reader.mapping

    def recording(self, value, key, allowed, required=(), *args, **kwargs):
        if not (isinstance(value, dict) and set(value) - set(allowed)):  # not a refusal's listing
            entry = (tuple(allowed), tuple(required))
            if entry not in tables.setdefault(_pattern(key), []):
                tables[_pattern(key)].append(entry)
        return original(self, value, key, allowed, required, *args, **kwargs)

    loader._Reader.mapping = recording
    try:
        scenes = sorted((ROOT / "examples").rglob("*.yaml")) + sorted((ROOT / "latdyn" / "examples").glob("*.yaml"))
        for path in scenes:
            try:
                loader.load_scene(str(path))
            except loader.SceneError:
                pass  # a study file, not a scene
        with tempfile.TemporaryDirectory() as folder:
            for i, text in enumerate(REACH):
                scene = Path(folder) / f"reach_{i}.yaml"
                scene.write_text(text, encoding="utf-8")
                loader.load_scene(str(scene))
    finally:
        loader._Reader.mapping = original
    import importlib
    for place, (module, table, required) in READ_ELSEWHERE.items():
        keys = tuple(getattr(importlib.import_module(f"latdyn.scene.{module}"), table))
        if (keys, required) not in tables.setdefault(place, []):
            tables[place].append((keys, required))
    return tables


#: places whose keys a module of latdyn/scene/ reads with its own table instead of the loader's
#: mapping(): {place: (module, table, required keys)}
READ_ELSEWHERE = {"controllers.NAME": ("controllers", "CONTROLLER_KEYS", ("output",))}


def source_tables() -> dict[str, tuple[str, ...]]:
    """``{module.TABLE: keys}``: every ``_*_KEYS`` table (a tuple of words, or a dict of them) of the
    modules of latdyn/scene/, read from their source."""
    found: dict[str, tuple[str, ...]] = {}
    for source in sorted((ROOT / "latdyn" / "scene").glob("*.py")):
        tree = ast.parse(source.read_text(encoding="utf-8"))
        for node in tree.body:
            targets = [t.id for t in getattr(node, "targets", [getattr(node, "target", None)])
                       if isinstance(t, ast.Name)]
            value = getattr(node, "value", None)
            for name in targets:
                if not re.fullmatch(r"_?[A-Z_]*KEYS", name) or value is None:
                    continue
                try:
                    table = ast.literal_eval(value)
                except ValueError:
                    continue
                words = table.values() if isinstance(table, dict) else [table]
                keys = tuple(dict.fromkeys(k for group in words for k in group if isinstance(k, str)))
                found[f"{source.stem}.{name}"] = keys
    return found


def _default(place: str, key: str, required: bool) -> str:
    described = describe(f"{place}.{key}" if place else key)
    if required:
        return "required"
    if described and described[2] is not None:
        return described[2]
    from latdyn.scene import loader

    owner = describe_place = place
    for pattern, name in _ALIASES:
        describe_place = pattern.sub(name, place + ".").rstrip(".")
    cls = getattr(loader, _DATACLASSES.get(describe_place, _DATACLASSES.get(owner, "")), None)
    if cls is not None and dataclasses.is_dataclass(cls):
        for f in dataclasses.fields(cls):
            if f.name == key and f.default is not dataclasses.MISSING:
                if isinstance(f.default, bool):
                    return str(f.default).lower()
                return "absent" if f.default is None else f"{f.default!r}".strip("'")
    return "—"


# ----------------------------------------------------------------------------- the page
def reference() -> tuple[str, list[str]]:
    """(the page's Markdown, the keys it could not describe)."""
    tables = recorded_tables()
    undescribed: list[str] = []
    lines = [
        "# Scene reference",
        "",
        "Every key the scene loader (`latdyn.scene.loader`) accepts, where it goes, its unit and its default.",
        "This page is written at every build of the documentation from the loader itself (the places and",
        "keys it checks while reading the shipped scenes, and every table of keys in its source), so it",
        "names every key the loader accepts; `SCENE.md` beside the repository is the contract, and",
        "`docs/usage.md` shows the keys at work. latdyn has no unit system of its own: use any",
        "consistent set (SI: m, kg, s, N). Units are given as dimensions: length L, mass M, time T,",
        "force F, angles in rad; every number may be an expression in `t` where the key says so.",
        "Places in capitals (`NAME`) are names you choose.",
        "",
    ]
    seen_keys: set[str] = set()
    for place in sorted(tables, key=lambda p: (p.count("."), p)):
        entries = tables[place]
        for allowed, required in entries:
            title = f"`{place}`" if place else "Top level"
            if len(entries) > 1 and place.startswith("output.probes"):
                title += f" — probe with `{allowed[0]}`"
            lines += [f"## {title}", "", "| key | what it is | unit | default |", "|---|---|---|---|"]
            for key in allowed:
                seen_keys.add(key)
                full = f"{place}.{key}" if place else key
                described = describe(full)
                if described is None:
                    undescribed.append(full)
                    what, unit = "(not described: see SCENE.md)", "—"
                else:
                    what, unit = described[0], described[1]
                lines.append(f"| `{key}` | {what} | {unit} | {_default(place, key, key in required)} |")
            lines.append("")
    loose = {name: keys for name, keys in source_tables().items() if set(keys) - seen_keys}
    if loose:
        lines += ["## Tables no shipped scene reaches yet", "",
                  "Keys of the loader's tables at places that no shipped scene (and no scene of the reference's",
                  "own) reaches yet; `SCENE.md` says where they go.", ""]
        for name, keys in loose.items():
            lines.append(f"- `{name}`: " + ", ".join(f"`{k}`" for k in keys))
            undescribed += [f"{name}.{k}" for k in keys if k not in seen_keys]
        lines.append("")
    return "\n".join(lines), undescribed


def write(app=None) -> list[str]:
    text, undescribed = reference()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    if not OUT.exists() or OUT.read_text(encoding="utf-8") != text:
        OUT.write_text(text, encoding="utf-8")
    return undescribed


def _on_builder_inited(app):
    from sphinx.util import logging

    for key in write(app):
        logging.getLogger(__name__).warning(
            "scene reference: the loader accepts %s, which docs/_ext/scene_reference.py DESCRIPTIONS does not "
            "describe (what it is, unit, default)", key)


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1", "parallel_read_safe": True}
