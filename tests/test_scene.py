"""Scene reading and validation (latdyn.scene.loader, SCENE.md)."""
from __future__ import annotations

import copy
import json
import math
import pickle
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.scene.expressions import TimeFunction
from latdyn.scene.loader import Scene, describe, load_scene

REPO = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------- the shipped example
def test_shipped_example_loads():
    scene = load_scene(REPO / "examples" / "spinup.yaml")
    assert scene.title == "spin-up beam"
    assert list(scene.sections) == ["arm"] and scene.sections["arm"].EA == 2.8e7  # YAML 1.2 float "2.8e7"
    assert scene.sections["arm"].rhoIy == 0.0
    hub = scene.bodies["hub"]
    assert hub.prescribed and not hub.fixed and hub.mass == 0.0
    assert np.array_equal(hub.rotation_axis, [0, 0, 1])
    assert hub.rotation_angle.value(7.5) == pytest.approx(6.6905467, abs=1e-7)
    arm = scene.beams["arm"]
    assert arm.elements == 8 and arm.section is scene.sections["arm"]
    assert arm.start.body == "hub" and arm.start.joint == "clamped"
    assert arm.end.body is None and arm.end.joint == "free"
    assert np.array_equal(arm.end.point, [10, 0, 0]) and arm.length == 10.0
    assert np.allclose(arm.y_axis, [0, 1, 0])
    assert (scene.solve.analysis, scene.solve.t_end, scene.solve.dt) == ("transient", 20.0, 0.005)
    assert scene.solve.method == "generalized-alpha" and scene.solve.rho_inf == 0.8
    assert scene.output.every == 0.01
    tip, energy = scene.output.probes
    assert (tip.name, tip.kind, tip.quantity, tip.frame, tip.component) == ("tip_v", "point", "position", "hub", "y")
    assert (tip.point.beam, tip.point.node) == ("arm", 8)
    assert (energy.name, energy.kind, energy.quantity) == ("energy", "energy", "total")
    assert len(scene.source_hash) == 64
    assert "elements: 8" in describe(scene)


def test_package_example_is_the_same_file():
    packaged = resources.files("latdyn") / "examples" / "spinup.yaml"
    assert packaged.read_text() == (REPO / "examples" / "spinup.yaml").read_text()


def test_load_scene_accepts_dict_scene_and_path_and_pickles(tmp_path):
    scene = load_scene(str(REPO / "examples" / "spinup.yaml"))
    assert load_scene(scene) is scene
    assert latdyn.load_scene(scene) is scene
    from_dict = load_scene(scene.raw)
    assert from_dict.file == "<dict>" and from_dict.source_hash == scene.source_hash
    path = tmp_path / "spin.json"
    path.write_text(json.dumps(scene.raw, indent="\t"))
    assert load_scene(path).source_hash == scene.source_hash
    again = pickle.loads(pickle.dumps(scene))
    assert isinstance(again, Scene)
    assert again.bodies["hub"].rotation_angle.rate(7.5) == pytest.approx(3.0)
    assert np.array_equal(again.beams["arm"].y_axis, scene.beams["arm"].y_axis)


def test_input_dict_is_not_modified_or_shared():
    raw = copy.deepcopy(BASE)
    scene = load_scene(raw)
    assert raw == BASE
    raw["title"] = "changed"
    assert scene.raw["title"] == "base"


# --------------------------------------------------------------------------- a valid base scene
BASE = {
    "title": "base",
    "sections": {"s": {"EA": 1e7, "EIy": 1e4, "EIz": 1e4, "GJ": 1e4, "rhoA": 1.0}},
    "bodies": {
        "ground": {"at": [0, 0, 0], "fixed": True},
        "tip": {"at": [2, 0, 0], "mass": 1.0, "inertia": [0.1, 0.1, 0.1]},
        "hub": {"at": [0, 3, 0], "motion": {"rotation": {"axis": [0, 0, 1], "angle": "t"}}},
    },
    "beams": {
        "a": {"from": "ground", "to": "tip", "section": "s", "elements": 4,
              "start": {"hinge": {"axis": [0, 0, 1]}}},
        "b": {"from": "tip", "to": [2, 1, 0], "section": "s", "elements": 2},
        "c": {"from": "hub", "to": [1, 3, 0], "section": "s"},
    },
    "loads": [{"at": "tip", "force": [0, "sin(t)", 0]}],
    "solve": {"t_end": 1.0, "dt": 0.01},
    "output": {"every": 0.02, "probes": {
        "p": {"point": "b.end", "quantity": "position", "component": "x"},
        "h": {"hinge": "a.start", "quantity": "angle"},
        "e": {"energy": "total"},
        "m": {"momentum": "linear", "component": "y"},
        "el": {"element": "a.element[0]", "quantity": "axial_force"},
    }},
}


def test_base_scene_is_valid():
    scene = load_scene(BASE)
    assert [p.name for p in scene.output.probes] == ["p", "h", "e", "m", "el"]
    assert scene.beams["c"].elements == 1
    assert scene.hinges[0][:2] == ("a", "start")


def _walk(d, path):
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    for k in keys[:-1]:
        d = d[k]
    return d, keys[-1]


def put(path, value):
    def mutate(d):
        parent, k = _walk(d, path)
        parent[k] = value
    return mutate


def drop(path):
    def mutate(d):
        parent, k = _walk(d, path)
        del parent[k]
    return mutate


def both(*mutations):
    def mutate(d):
        for m in mutations:
            m(d)
    return mutate


NAN, INF = float("nan"), float("inf")

# (id, mutation of BASE, key path named in the error, words the message must contain)
MALFORMED = [
    # unknown keys, at every level
    ("unknown top key", put("colour", "red"), "colour", "allowed keys here: title"),
    ("unknown section key", put("sections.s.E", 1.0), "sections.s.E", "allowed keys here: EA"),
    ("unknown body key", put("bodies.tip.mas", 1.0), "bodies.tip.mas", "did you mean 'mass'"),
    ("unknown beam key", put("beams.a.elemnts", 3), "beams.a.elemnts", "allowed keys"),
    ("unknown hinge key", put("beams.a.start.hinge.stifness", 3), "beams.a.start.hinge.stifness", "stiffness"),
    ("unknown motion key", put("bodies.hub.motion.spin", 1), "bodies.hub.motion.spin", "translation, rotation"),
    ("unknown load key", put("loads.0.torque", [0, 0, 1]), "loads[0].torque", "allowed keys"),
    ("unknown probe key", put("output.probes.p.frme", "global"), "output.probes.p.frme", "frame"),
    ("key of another probe kind", put("output.probes.e.component", "x"), "output.probes.e.component", "energy"),
    ("unknown solve key", put("solve.steps_", 3), "solve.steps_", "allowed keys"),
    ("unknown output key", put("output.format", "csv"), "output.format", "every, probes"),
    ("unknown initial_velocity key", put("initial_velocity", {"spin": [0, 0, 1]}), "initial_velocity.spin",
     "linear, angular, about"),
    # missing required keys
    ("missing section key", drop("sections.s.GJ"), "sections.s.GJ", "missing"),
    ("missing beam section", drop("beams.a.section"), "beams.a.section", "missing"),
    ("missing beam to", drop("beams.b.to"), "beams.b.to", "missing"),
    ("missing body at", drop("bodies.tip.at"), "bodies.tip.at", "missing"),
    ("missing t_end", drop("solve.t_end"), "solve.t_end", "missing"),
    ("missing dt", drop("solve.dt"), "solve.dt", "missing"),
    ("missing hinge axis", put("beams.a.start.hinge", {"stiffness": 1}), "beams.a.start.hinge.axis", "missing"),
    ("missing rotation angle", drop("bodies.hub.motion.rotation.angle"), "bodies.hub.motion.rotation.angle",
     "missing"),
    ("missing probe quantity", drop("output.probes.p.quantity"), "output.probes.p.quantity", "missing"),
    ("missing load at", drop("loads.0.at"), "loads[0].at", "missing"),
    # wrong types
    ("bool is not a number", put("sections.s.EA", True), "sections.s.EA", "number"),
    ("text is not a number", put("bodies.tip.mass", "heavy"), "bodies.tip.mass", "expected"),
    ("number depends on t", put("bodies.tip.mass", "1 + t"), "bodies.tip.mass", "constant"),
    ("infinite number", put("sections.s.EA", INF), "sections.s.EA", "finite"),
    ("nan number", put("bodies.tip.mass", NAN), "bodies.tip.mass", "finite"),
    ("vector of wrong length", put("gravity", [0, -9.81]), "gravity", "3 numbers"),
    ("vector with nan", put("bodies.tip.at", [2, 0, NAN]), "bodies.tip.at[2]", "finite"),
    ("fixed is not bool", put("bodies.ground.fixed", "maybe"), "bodies.ground.fixed", "true or false"),
    ("elements not whole", put("beams.a.elements", 2.5), "beams.a.elements", "whole number"),
    ("elements bool", put("beams.a.elements", True), "beams.a.elements", "whole number"),
    ("sections not a mapping", put("sections", ["s"]), "sections", "mapping"),
    ("loads not a list", put("loads", {"at": "tip"}), "loads", "list"),
    ("title not text", put("title", ["a"]), "title", "text"),
    ("force not 3 components", put("loads.0.force", [1, 2]), "loads[0].force", "3 components"),
    ("probes not a mapping", put("output.probes", "p"), "output.probes", "mapping"),
    # dangling names
    ("dangling section", put("beams.a.section", "ss"), "beams.a.section",
     "expected the name of a section (known: s), got 'ss'"),
    ("dangling body in from", put("beams.a.from", "grond"), "beams.a.from", "known: ground, tip, hub"),
    ("dangling body in offset end", put("beams.b.from", {"body": "nope", "offset": [0, 0, 1]}), "beams.b.from.body",
     "body"),
    ("dangling load point", put("loads.0.at", "nobody"), "loads[0].at", "expected a point"),
    ("dangling load frame", put("loads.0.frame", "nobody"), "loads[0].frame", "global or the name of a body"),
    ("dangling probe beam", put("output.probes.p.point", "zz.end"), "output.probes.p.point", "expected a point"),
    ("bad point syntax", put("output.probes.p.point", "b.middle"), "output.probes.p.point", "BEAM.node[i]"),
    ("dangling probe frame", put("output.probes.p.frame", "arm"), "output.probes.p.frame", "name of a body"),
    ("dangling hinge probe beam", put("output.probes.h.hinge", "q.start"), "output.probes.h.hinge", "BEAM.start"),
    ("dangling element probe beam", put("output.probes.el.element", "q.element[0]"), "output.probes.el.element",
     "BEAM.element[i]"),
    # geometry
    ("zero-length beam", put("beams.b.to", [2, 0, 0]), "beams.b", "zero-length"),
    ("zero-length beam by offset", put("beams.b.from", {"body": "ground", "offset": [2, 1, 0]}), "beams.b",
     "zero-length"),
    ("beam shorter than 1e-12 of its largest coordinate", put("beams.b.to", [2, -1.5e-12, 0]), "beams.b",
     "zero-length"),
    ("zero elements", put("beams.a.elements", 0), "beams.a.elements", ">= 1"),
    ("negative elements", put("beams.a.elements", -3), "beams.a.elements", ">= 1"),
    ("zero hinge axis", put("beams.a.start.hinge.axis", [0, 0, 0]), "beams.a.start.hinge.axis", "non-zero"),
    ("zero rotation axis", put("bodies.hub.motion.rotation.axis", [0, 0, 0]), "bodies.hub.motion.rotation.axis",
     "non-zero"),
    ("zero y_axis", put("beams.a.y_axis", [0, 0, 0]), "beams.a.y_axis", "non-zero"),
    ("y_axis parallel to beam", put("beams.a.y_axis", [-3, 0, 0]), "beams.a.y_axis", "not parallel"),
    # sections
    ("zero EA", put("sections.s.EA", 0), "sections.s.EA", "positive"),
    ("negative EIy", put("sections.s.EIy", -1.0), "sections.s.EIy", "positive"),
    ("zero EIz", put("sections.s.EIz", 0.0), "sections.s.EIz", "positive"),
    ("negative GJ", put("sections.s.GJ", -5), "sections.s.GJ", "positive"),
    ("negative rhoA", put("sections.s.rhoA", -1.0), "sections.s.rhoA", ">= 0"),
    ("negative rhoIy", put("sections.s.rhoIy", -1.0), "sections.s.rhoIy", ">= 0"),
    ("negative rhoIz", put("sections.s.rhoIz", -1e-3), "sections.s.rhoIz", ">= 0"),
    # bodies
    ("negative mass", put("bodies.tip.mass", -1.0), "bodies.tip.mass", ">= 0"),
    ("negative principal inertia", put("bodies.tip.inertia", [1, -1, 1]), "bodies.tip.inertia[1]", ">= 0"),
    ("inertia not symmetric", put("bodies.tip.inertia", [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]), "bodies.tip.inertia",
     "symmetric"),
    ("inertia not positive semi-definite", put("bodies.tip.inertia", [[1, 2, 0], [2, 1, 0], [0, 0, 1]]),
     "bodies.tip.inertia", "positive semi-definite"),
    ("inertia of wrong shape", put("bodies.tip.inertia", [1, 2]), "bodies.tip.inertia", "[Ixx, Iyy, Izz]"),
    ("fixed together with motion", put("bodies.hub.fixed", True), "bodies.hub.motion", "fixed"),
    ("empty motion", put("bodies.hub.motion", {}), "bodies.hub.motion", "translation and/or rotation"),
    ("body named global", put("bodies.global", {"at": [0, 0, 0], "fixed": True}), "bodies.global", "reserved"),
    ("body name with a dot", lambda d: d["bodies"].update({"t.1": {"at": [0, 0, 0], "fixed": True}}), "bodies.t.1", "name"),
    ("massless body with nothing attached", put("bodies.lonely", {"at": [5, 5, 5]}), "bodies.lonely",
     "a coordinate that nothing holds"),
    # joints
    ("free end given a joint", put("beams.b.end", "clamped"), "beams.b.end", "free end"),
    ("free end given a hinge", put("beams.b.end", {"hinge": {"axis": [0, 0, 1]}}), "beams.b.end", "free end"),
    ("unknown joint", put("beams.a.end", "welded"), "beams.a.end", "clamped or {hinge"),
    ("negative hinge stiffness", put("beams.a.start.hinge.stiffness", -1), "beams.a.start.hinge.stiffness", ">= 0"),
    ("lock_at depends on t", put("beams.a.start.hinge.lock_at", "t"), "beams.a.start.hinge.lock_at", "constant"),
    # expressions
    ("python in an expression", put("loads.0.force.1", "__import__('os').system('x')"), "loads[0].force[1]",
     "not allowed"),
    ("attribute in an expression", put("bodies.hub.motion.rotation.angle", "t.real"),
     "bodies.hub.motion.rotation.angle", "not allowed"),
    ("table not increasing", put("loads.0.force.0", {"table": [[0, 0], [0, 1]]}), "loads[0].force[0].table[1]",
     "increasing"),
    ("expression infinite at 0", put("loads.0.force.2", "1/t"), "loads[0].force[2]", "finite"),
    ("load with neither force nor moment", put("loads.0", {"at": "tip"}), "loads[0]", "force and/or moment"),
    # probes
    ("duplicated probe name", put("output.probes", [{"name": "x", "energy": "total"},
                                                    {"name": "x", "energy": "kinetic"}]),
     "output.probes[1]", "duplicated"),
    ("probe named t", put("output.probes.t", {"energy": "total"}), "output.probes.t", "other than"),
    ("probe of two kinds", put("output.probes.e.momentum", "linear"), "output.probes.e", "exactly one"),
    ("probe of no kind", put("output.probes.e", {"quantity": "angle"}), "output.probes.e", "exactly one"),
    ("unknown point quantity", put("output.probes.p.quantity", "speed"), "output.probes.p.quantity",
     "position, displacement, velocity"),
    ("unknown component", put("output.probes.p.component", "w"), "output.probes.p.component", "x, y, z, norm"),
    ("momentum component norm", put("output.probes.m.component", "norm"), "output.probes.m.component", "x, y, z"),
    ("unknown energy", put("output.probes.e.energy", "heat"), "output.probes.e.energy", "kinetic"),
    ("unknown hinge quantity", put("output.probes.h.quantity", "speed"), "output.probes.h.quantity",
     "angle, rate, torque"),
    ("unknown element quantity", put("output.probes.el.quantity", "shear"), "output.probes.el.quantity",
     "axial_force"),
    ("hinge probe on a clamped end", put("output.probes.h.hinge", "a.end"), "output.probes.h.hinge", "clamped"),
    ("hinge probe on a free end", put("output.probes.h.hinge", "b.end"), "output.probes.h.hinge", "free"),
    ("element index out of range", put("output.probes.el.element", "a.element[4]"), "output.probes.el.element",
     "out of range"),
    ("negative element index", put("output.probes.el.element", "a.element[-1]"), "output.probes.el.element",
     "out of range"),
    ("node index out of range", put("output.probes.p.point", "a.node[5]"), "output.probes.p.point", "out of range"),
    ("load node out of range", put("loads.0.at", "b.node[3]"), "loads[0].at", "out of range"),
    # solve and output
    ("every zero", put("output.every", 0), "output.every", "positive"),
    ("every negative", put("output.every", -0.1), "output.every", "positive"),
    ("dt zero", put("solve.dt", 0.0), "solve.dt", "positive"),
    ("dt negative", put("solve.dt", -0.01), "solve.dt", "positive"),
    ("t_end zero", put("solve.t_end", 0), "solve.t_end", "positive"),
    ("rho_inf above 1", put("solve.rho_inf", 1.5), "solve.rho_inf", "[0, 1]"),
    ("rho_inf below 0", put("solve.rho_inf", -0.1), "solve.rho_inf", "[0, 1]"),
    ("unknown method", put("solve.method", "rk4"), "solve.method", "generalized-alpha"),
    ("unknown analysis", put("solve.analysis", "dynamic"), "solve.analysis", "transient, static, modes"),
    ("unknown formulation", put("solve.formulation", "magic"), "solve.formulation", "default"),
    ("static steps zero", both(put("solve", {"analysis": "static", "steps": 0})), "solve.steps", ">= 1"),
    ("modes count zero", put("solve", {"analysis": "modes", "count": 0}), "solve.count", ">= 1"),
    ("dt_min above dt", put("solve.dt_min", 0.1), "solve.dt_min", "dt_min <= dt"),
    ("adaptive not bool", put("solve.adaptive", 1), "solve.adaptive", "true or false"),
    ("no solve for a transient", drop("solve"), "solve.t_end", "missing"),
    # whole scene
    ("empty structure", both(put("bodies", {}), put("beams", {}), put("loads", []), put("output", {})), "beams",
     "at least one body or beam"),
]


@pytest.mark.parametrize("mutate, key, words", [c[1:] for c in MALFORMED], ids=[c[0] for c in MALFORMED])
def test_malformed_scene_is_rejected(mutate, key, words):
    raw = copy.deepcopy(BASE)
    mutate(raw)
    with pytest.raises(SceneError) as err:
        load_scene(raw)
    e = err.value
    assert isinstance(e, ValueError)
    assert e.file == "<dict>"
    assert e.key == key, str(e)
    assert words in e.expected, str(e)
    assert str(e) == f"<dict>: {key}: {e.expected}"


def test_malformed_ids_are_unique_and_many():
    ids = [c[0] for c in MALFORMED]
    assert len(ids) == len(set(ids)) and len(ids) >= 30


def test_top_level_must_be_a_mapping(tmp_path):
    with pytest.raises(SceneError) as err:
        load_scene({1: 2})
    assert err.value.key == "(top level)"
    path = tmp_path / "list.yaml"
    path.write_text("- a\n- b\n")
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert err.value.file == str(path) and "mapping" in err.value.expected
    empty = tmp_path / "empty.yaml"
    empty.write_text("# nothing\n")
    with pytest.raises(SceneError) as err:
        load_scene(empty)
    assert "empty" in err.value.expected


# --------------------------------------------------------------------------- files
def test_yaml_syntax_error_names_file_and_line(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("title: x\nsections:\n  s: {EA: 1, EIy: 2\nbodies: {}\n")
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert err.value.file == str(path)
    assert err.value.key.startswith("line ")
    assert "invalid YAML" in err.value.expected


def test_json_syntax_error_names_file_and_line(tmp_path):
    path = tmp_path / "bad.json"
    path.write_text('{"title": "x",\n "bodies": {,}}')
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert err.value.key == "line 2, column 13" and "invalid JSON" in err.value.expected


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(SceneError) as err:
        load_scene(tmp_path / "nope.yaml")
    assert err.value.file == str(tmp_path / "nope.yaml") and "no such file" in err.value.expected
    with pytest.raises(SceneError) as err:
        load_scene(tmp_path)
    assert "directory" in err.value.expected


def test_error_from_a_file_names_the_file(tmp_path):
    raw = copy.deepcopy(BASE)
    raw["beams"]["a"]["section"] = "arms"
    path = tmp_path / "spin.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert str(err.value) == f"{path}: beams.a.section: expected the name of a section (known: s), got 'arms'"


@pytest.mark.parametrize("suffix, text, key", [
    (".yaml", "title: a\nsolve: {t_end: 1, dt: 1}\nbodies:\n  x: {at: [0,0,0], mass: 1}\n"
              "  x: {at: [0,0,0], mass: 2}\n", "bodies.x"),
    (".yaml", "output:\n  probes:\n    p: {energy: total}\n    p: {energy: kinetic}\n", "output.probes.p"),
    (".json", '{"bodies": {"x": {"at": [0,0,0], "mass": 1, "mass": 2}}}', "bodies.x.mass"),
])
def test_duplicated_keys_in_files(tmp_path, suffix, text, key):
    path = tmp_path / f"dup{suffix}"
    path.write_text(text)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert err.value.key == key and "duplicated" in err.value.expected


def test_yaml_reads_exponent_floats_and_refuses_inf(tmp_path):
    raw = copy.deepcopy(BASE)
    text = yaml.safe_dump(raw, sort_keys=False).replace("EA: 10000000.0", "EA: 1e7")
    assert "EA: 1e7" in text
    path = tmp_path / "e.yaml"
    path.write_text(text)
    assert load_scene(path).sections["s"].EA == 1e7
    path.write_text(text.replace("EA: 1e7", "EA: .inf"))
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert err.value.key == "sections.s.EA"


# --------------------------------------------------------------------------- every key, accepted
EVERYTHING = """
title: every key of SCENE.md
gravity: [0, 0, -9.81]
initial_velocity: {linear: [0.1, 0, 0], angular: [0, 0, 0.2], about: [1, 0, 0]}
sections:
  s: {EA: 1e7, EIy: 1.0e4, EIz: 2e4, GJ: 5e3, rhoA: 1.5, rhoIy: 0.01, rhoIz: 0.02}
  unused: {EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}
bodies:
  ground: {at: [0, 0, 0], fixed: true}
  hub:
    at: [0, 0, 1]
    motion:
      translation: [0, 0, "0.1*sin(t)"]
      rotation: {axis: [0, 0, 2], angle: {table: [[0, 0], [1, 1]]}}
  slider: {at: [5, 0, 0], motion: {translation: ["t**2", 0, {table: [[0, 0]]}]}}
  tip: {at: [2, 0, 0], mass: 2, com: [0.1, 0, 0], inertia: [[1, 0.1, 0], [0.1, 2, 0], [0, 0, 3]]}
  joint: {at: [2, 2, 0], mass: 0.5, inertia: [0.1, 0.1, 0.1], fixed: false}
  ball: {at: [9, 9, 9], mass: 1}
  truss: {at: [3, 3, 0]}
beams:
  a:
    from: ground
    to: tip
    section: s
    elements: 4
    y_axis: [0, 1, 1]
    start:
      hinge: {axis: [0, 0, 1], stiffness: 10, damping: 0.1, torque: "Heaviside(t - 0.5)*2", lock_at: "pi/2"}
    end: clamped
  b:
    from: {body: tip, offset: [0, 0.1, 0]}
    to: {body: joint}
    section: s
    start: clamped
    end: {hinge: {axis: [1, 0, 0], angle: "0.1*t**2"}}
  c: {from: hub, to: [1, 0, 1], section: s, elements: 2}
  d: {from: joint, to: truss, section: s, elements: 3}
  e: {from: slider, to: [5, 0, -1], section: s}
loads:
  - {at: tip, force: [1, 0, "Piecewise((1, t < 1), (0, True))"], moment: [0, 0, 1], frame: tip}
  - {at: a.node[2], force: [0, {table: [[0, 0], [1, 1]]}, 0], frame: global}
  - {at: b.start, moment: ["exp(-t)", "log(1 + t)", "sqrt(1 + t)*abs(t - 1)*sign(t)"]}
  - {at: c.end, force: ["tan(t)*cos(t)", "Min(t, 1)", "Max(t, 1) + e + pi"]}
solve: {analysis: transient, t_end: 1, dt: 0.01, method: hht-alpha, rho_inf: 0.9, tol: 1e-8}
output:
  every: 0.05
  probes:
    p1: {point: tip, quantity: position, frame: global, component: x}
    p2: {point: c.end, quantity: displacement, frame: hub, component: y}
    p3: {point: a.node[1], quantity: velocity, component: z}   # flow style with [i] unquoted
    p4: {point: b.start, quantity: velocity, component: norm}
    p5: {point: a.start, quantity: position}
    h1: {hinge: a.start, quantity: angle}
    h2: {hinge: b.end, quantity: rate}
    e1: {energy: kinetic}
    e2: {energy: strain}
    e3: {energy: potential}
    e4: {energy: external_work}
    e5: {energy: total}
    m1: {momentum: linear, component: x}
    m2: {momentum: angular, component: z}
    m3: {momentum: angular, component: y}
    el1: {element: a.element[0], quantity: axial_force}
    el2: {element: a.element[3], quantity: torque}
    el3: {element: d.element[2], quantity: moment_y}
    el4: {element: c.element[1], quantity: moment_z}
"""


@pytest.fixture
def everything(tmp_path):
    path = tmp_path / "everything.yaml"
    path.write_text(EVERYTHING)
    return load_scene(path)


def test_every_key_is_accepted(everything):
    s = everything
    assert s.title == "every key of SCENE.md"
    assert np.array_equal(s.gravity, [0, 0, -9.81])
    iv = s.initial_velocity
    assert np.array_equal(iv.about, [1, 0, 0]) and np.allclose(iv.velocity_at([1, 1, 0]), [-0.1, 0, 0])
    sec = s.sections["s"]
    assert (sec.EA, sec.EIy, sec.EIz, sec.GJ, sec.rhoA, sec.rhoIy, sec.rhoIz) == (1e7, 1e4, 2e4, 5e3, 1.5, 0.01, 0.02)
    assert list(s.bodies) == ["ground", "hub", "slider", "tip", "joint", "ball", "truss"]
    assert s.bodies["ground"].fixed and not s.bodies["ground"].prescribed
    hub = s.bodies["hub"]
    assert hub.prescribed and np.array_equal(hub.rotation_axis, [0, 0, 1])
    assert hub.translation[2].value(math.pi / 2) == pytest.approx(0.1)
    assert hub.rotation_angle.rate(0.5) == pytest.approx(1.0)
    assert s.bodies["slider"].rotation_angle is None and s.bodies["slider"].prescribed
    tip = s.bodies["tip"]
    assert tip.mass == 2 and np.array_equal(tip.com, [0.1, 0, 0]) and tip.inertia[0, 1] == 0.1
    assert np.array_equal(s.bodies["joint"].inertia, np.diag([0.1, 0.1, 0.1])) and not s.bodies["joint"].fixed
    a, b = s.beams["a"], s.beams["b"]
    assert np.allclose(a.y_axis, [0, 2 ** -0.5, 2 ** -0.5])  # [0, 1, 1] is normal to x = X: only made unit
    h = a.start.hinge
    assert a.start.joint == "hinge" and a.end.joint == "clamped"
    assert (h.stiffness, h.damping, h.lock_at) == (10.0, 0.1, pytest.approx(math.pi / 2))
    assert h.torque.value(1.0) == 2.0 and h.angle is None
    assert b.start.body == "tip" and np.array_equal(b.start.offset, [0, 0.1, 0])
    assert np.array_equal(b.start.point, [2, 0.1, 0]) and b.end.body == "joint"
    assert b.end.hinge.angle.rate(1.0) == pytest.approx(0.2) and b.end.hinge.torque is None
    assert [ld.frame for ld in s.loads] == ["tip", "global", "global", "global"]
    assert s.loads[0].force[2].value(0.5) == 1.0 and s.loads[0].moment[2].value(0) == 1.0
    assert s.loads[1].at.node == 2 and s.loads[1].moment is None
    assert s.loads[2].at.node == 0 and s.loads[2].force is None
    assert s.loads[3].at.node == 2
    sol = s.solve
    assert (sol.analysis, sol.t_end, sol.dt, sol.method, sol.rho_inf, sol.tol) == \
        ("transient", 1.0, 0.01, "hht-alpha", 0.9, 1e-8)
    assert s.output.every == 0.05
    probes = {p.name: p for p in s.output.probes}
    assert probes["p2"].frame == "hub" and probes["p5"].component == "norm"
    assert (probes["h2"].beam, probes["h2"].end, probes["h2"].quantity) == ("b", "end", "rate")
    assert [probes[f"e{i}"].quantity for i in range(1, 6)] == \
        ["kinetic", "strain", "potential", "external_work", "total"]
    assert (probes["m2"].quantity, probes["m2"].component) == ("angular", "z")
    assert (probes["el3"].beam, probes["el3"].element, probes["el3"].quantity) == ("d", 2, "moment_y")
    text = describe(s)
    for word in ("bodies:   7", "beams:    5", "elements: 11", "hinges:   2", "loads:    4", "probes:   19",
                 "hht-alpha"):
        assert word in text


def test_scene_pickles_with_time_functions(everything):
    again = pickle.loads(pickle.dumps(everything))
    assert again.loads[2].moment[0].value(1.0) == pytest.approx(math.exp(-1))
    assert again.source_hash == everything.source_hash


@pytest.mark.parametrize("method", ["generalized-alpha", "hht-alpha", "newmark", "explicit"])
def test_every_method(method):
    raw = copy.deepcopy(BASE)
    raw["solve"]["method"] = method
    assert load_scene(raw).solve.method == method


def test_static_and_modes_analyses():
    raw = copy.deepcopy(BASE)
    raw["solve"] = {"analysis": "static", "steps": 4}
    s = load_scene(raw).solve
    assert (s.analysis, s.steps, s.t_end) == ("static", 4, None)
    raw["solve"] = {"analysis": "modes", "count": 3}
    s = load_scene(raw).solve
    assert (s.analysis, s.count) == ("modes", 3)
    raw["solve"] = {"analysis": "modes"}
    assert load_scene(raw).solve.count == 6
    raw["solve"] = {"analysis": "static"}
    assert load_scene(raw).solve.steps == 10


def test_extensions():
    raw = copy.deepcopy(BASE)
    raw["beams"]["free"] = {"from": [0, 0, 5], "to": [1, 0, 5], "section": "s"}
    raw["solve"].update(adaptive=True, error_tol=1e-5, dt_min=1e-4, max_iterations=12, formulation="no_stiffening")
    raw["output"]["probes"] = [{"name": "a_end", "point": "a.end", "quantity": "velocity"},
                               {"name": "w", "energy": "kinetic"}]
    raw["beams"]["a"]["start"]["hinge"]["lock_at"] = "pi/4"
    s = load_scene(raw)
    free = s.beams["free"]
    assert free.start.joint == "free" and free.start.body is None
    sol = s.solve
    assert (sol.adaptive, sol.error_tol, sol.dt_min, sol.max_iterations, sol.formulation) == \
        (True, 1e-5, 1e-4, 12, "no_stiffening")
    assert [p.name for p in s.output.probes] == ["a_end", "w"]
    assert s.output.probes[0].component == "norm"
    assert s.beams["a"].start.hinge.lock_at == pytest.approx(math.pi / 4)


# --------------------------------------------------------------------------- normalisation rules
def test_default_y_axis_and_gram_schmidt():
    def y_of(to, y_axis=None):
        raw = copy.deepcopy(BASE)
        raw["beams"]["b"]["to"] = to
        if y_axis is not None:
            raw["beams"]["b"]["y_axis"] = y_axis
        return load_scene(raw).beams["b"]

    assert np.allclose(y_of([2, 1, 0]).y_axis, [-1, 0, 0])        # Z x Y = -X
    assert np.allclose(y_of([2, 0, 3]).y_axis, [0, 1, 0])         # vertical beam: global Y
    assert np.allclose(y_of([2, 0, -3]).y_axis, [0, 1, 0])
    beam = y_of([3, 1, 1], y_axis=[0, 0, 5])
    x = beam.x_axis
    assert abs(np.dot(beam.y_axis, x)) < 1e-14 and np.linalg.norm(beam.y_axis) == pytest.approx(1.0)
    assert np.cross(x, beam.y_axis)[2] < 1.0                       # z = x × y is not the given axis
    assert np.dot(beam.y_axis, [0, 0, 1]) > 0                      # but y keeps its sense


def test_massless_bodies_that_are_held_are_accepted():
    raw = copy.deepcopy(BASE)
    raw["bodies"]["pin"] = {"at": [0, 0, 7]}
    raw["beams"]["to_pin"] = {"from": "tip", "to": "pin", "section": "s"}   # attached: a truss joint
    raw["bodies"]["still"] = {"at": [8, 8, 8], "fixed": True}              # fixed
    raw["bodies"]["moved"] = {"at": [9, 8, 8], "motion": {"translation": ["t", 0, 0]}}  # prescribed
    raw["bodies"]["flywheel"] = {"at": [7, 8, 8], "inertia": [0, 0, 1]}    # inertia only
    s = load_scene(raw)
    assert s.bodies["pin"].mass == 0 and s.bodies["moved"].prescribed


def test_constant_scalars_accept_constant_expressions():
    raw = copy.deepcopy(BASE)
    raw["bodies"]["tip"]["mass"] = "2*pi"
    raw["sections"]["s"]["EA"] = "2.8e7"
    raw["gravity"] = [0, 0, "-9.81"]
    s = load_scene(raw)
    assert s.bodies["tip"].mass == pytest.approx(2 * math.pi)
    assert s.sections["s"].EA == 2.8e7 and s.gravity[2] == -9.81


def test_source_hash_is_canonical():
    raw = copy.deepcopy(BASE)
    reordered = dict(reversed(list(raw.items())))
    assert load_scene(raw).source_hash == load_scene(reordered).source_hash
    raw["title"] = "other"
    assert load_scene(raw).source_hash != load_scene(BASE).source_hash


def test_key_order_of_the_file_is_kept():
    raw = copy.deepcopy(BASE)
    raw["bodies"] = dict(reversed(list(raw["bodies"].items())))
    assert list(load_scene(raw).bodies) == ["hub", "tip", "ground"]


def test_time_function_types():
    s = load_scene(BASE)
    f = s.loads[0].force
    assert all(isinstance(c, TimeFunction) for c in f)
    assert f[0].is_constant and not f[1].is_constant
    assert f[1].value(np.array([0.0, math.pi / 2])) == pytest.approx([0.0, 1.0])


def test_numpy_values_in_a_dict_are_plain_data():
    raw = copy.deepcopy(BASE)
    raw["gravity"] = np.array([0.0, 0.0, -9.81])
    raw["bodies"]["tip"]["inertia"] = np.eye(3) * 0.1
    raw["beams"]["a"]["elements"] = np.int64(3)
    s = load_scene(raw)
    assert s.gravity[2] == -9.81 and s.beams["a"].elements == 3
    assert s.raw["gravity"] == [0.0, 0.0, -9.81]
    assert s.source_hash == load_scene(s.raw).source_hash
