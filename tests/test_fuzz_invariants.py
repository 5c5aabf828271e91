"""The invariants of random whole runs (``benchmarks/fuzz_invariants.py``): the turned scene, and the
checks on a 3D scene through the front door, with a wrong turn and a made-up drift that they catch."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import fuzz_invariants as fi  # noqa: E402
from benchmarks import fuzz_runs  # noqa: E402

#: a genuinely 3D scene as a user types it: an oblique hinge, beam ends at offsets, a body with a
#: centre of mass off its point and a full inertia, gravity, a load in a body's frame, a spin
SCENE = """
title: a 3D arm for the turned run
sections:
  s: {EA: 2.0e5, EIy: 40, EIz: 60, GJ: 30, rhoA: 0.8, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
  tip:
    at: [0.6, 0.3, 0.2]
    mass: 0.7
    com: [0.02, -0.01, 0.03]
    inertia: [[0.010, 0.001, 0.0], [0.001, 0.020, 0.002], [0.0, 0.002, 0.015]]
beams:
  arm:
    from: {body: hub, offset: [0.0, 0.05, 0.0]}
    to: {body: tip, offset: [-0.04, 0.0, 0.02]}
    section: s
    elements: 2
    start: {hinge: {axis: [0.3, 0.4, 0.866], stiffness: 20, damping: 0.1}}
gravity: [0, -9.81, -2.0]
loads:
  - {at: tip, force: [0, 0, "3*sin(7*t)"], frame: tip}
initial_velocity: {angular: [0.5, -1.0, 2.0]}
solve: {analysis: transient, t_end: 0.05, dt: 0.005}
output:
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    tip_vz: {point: arm.end, quantity: velocity, component: z}
    tip_in_hub: {point: arm.end, quantity: displacement, frame: tip, component: y}
    angle: {hinge: arm.start, quantity: angle}
    my: {element: "arm.element[1]", quantity: moment_y}
    Lz: {momentum: angular, component: z}
    energy: {energy: total}
"""


def test_the_turn_moves_every_vector_and_component():
    scene = yaml.safe_load(SCENE)
    turned = fi.turned_scene(scene, {"arm": [0.0, 1.0, 0.0]})
    # P takes x to y, y to z, z to x: (P v) = [v_z, v_x, v_y]
    assert turned["bodies"]["tip"]["at"] == [0.2, 0.6, 0.3]
    assert turned["bodies"]["tip"]["com"] == [0.03, 0.02, -0.01]
    assert turned["bodies"]["tip"]["inertia"] == [[0.015, 0.0, 0.002], [0.0, 0.010, 0.001], [0.002, 0.001, 0.020]]
    assert turned["beams"]["arm"]["from"] == {"body": "hub", "offset": [0.0, 0.0, 0.05]}
    assert turned["beams"]["arm"]["y_axis"] == [0.0, 0.0, 1.0]
    assert turned["beams"]["arm"]["start"]["hinge"]["axis"] == [0.866, 0.3, 0.4]
    assert turned["gravity"] == [-2.0, 0, -9.81]
    assert turned["loads"][0]["force"] == ["3*sin(7*t)", 0, 0]
    assert turned["initial_velocity"]["angular"] == [2.0, 0.5, -1.0]
    assert turned["output"]["probes"]["tip_x"]["component"] == "y"
    assert turned["output"]["probes"]["Lz"]["component"] == "x"
    assert scene == yaml.safe_load(SCENE)     # the scene itself is left as it was


def test_a_3d_scene_and_its_turn_agree_through_the_cli_and_a_wrong_turn_is_caught(tmp_path):
    from latdyn.results.result import Result
    from latdyn.scene.loader import load_scene

    scene = yaml.safe_load(SCENE)
    y_axes = {name: list(map(float, beam.y_axis)) for name, beam in load_scene(scene).beams.items()}
    turned = fi.turned_scene(scene, y_axes)
    wrong = fi.turned_scene(scene, y_axes)
    wrong["gravity"] = scene["gravity"]         # gravity left unturned
    results = {}
    for name, s in (("scene", scene), ("turned", turned), ("wrong", wrong)):
        path = tmp_path / f"{name}.yaml"
        path.write_text(fuzz_runs._scene_text(s), encoding="utf-8")
        status, _, err, _ = fuzz_runs._run(["run", str(path), "-o", str(tmp_path / name), "-q"], timeout=120,
                                           cwd=tmp_path)
        assert status == 0, err
        results[name] = Result.load(tmp_path / name)
    d, where = fi._compare_results(results["scene"], results["turned"], scene)
    assert d < 1e-9, where
    d, where = fi._compare_results(results["scene"], results["wrong"], scene)
    assert d > 1e-3, where


class _Made:
    def __init__(self, t, probes, summary):
        self.t, self.probes, self.summary = np.asarray(t, float), probes, summary


def test_the_momentum_drift_and_the_energy_balance_are_measured():
    scene = {"bodies": {"g": {"at": [0, 0, 0], "mass": 2.0}}, "beams": {}, "sections": {}}
    t = [0.0, 0.1, 0.2]
    probes = {"inv_kinetic": np.array([1.0, 1.0, 1.0]),
              **{f"inv_p{c}": np.array([2.0, 2.0, 2.0 + 0.02]) if c == "x" else np.zeros(3) for c in "xyz"},
              **{f"inv_L{c}": np.zeros(3) for c in "xyz"}}
    linear, angular = fi.momentum_drift(scene, _Made(t, probes, {}))
    # the scale sqrt(2 M KE) = 2: a change of 0.02 is 1e-2
    assert abs(linear - 0.01) < 1e-12 and angular == 0.0
    assert fi.is_free_and_unloaded(scene)
    assert not fi.is_free_and_unloaded({**scene, "gravity": [0, -9.81, 0]})
    assert not fi.is_free_and_unloaded({"bodies": {"g": {"at": [0, 0, 0], "fixed": True}}})


def test_a_resumed_run_must_give_the_same_files(tmp_path):
    """fuzz_runs._resumed_files_equal: the state history and the summary's events compared, and a
    difference in either is a ``resume_mismatch``."""
    import json

    def folder(name, q, events):
        out = tmp_path / name
        out.mkdir()
        np.savez(out / "state.npz", t=np.array([0.0, 0.1]), q=np.asarray(q, float))
        (out / "summary.json").write_text(json.dumps({"status": "solved", "events": events, "rows": 2}))
        return out

    event = [{"joint": "arm.start", "kind": "latch", "t": 0.05}]
    a = folder("a", [[0.0, 1.0], [0.5, 1.5]], event)
    assert fuzz_runs._resumed_files_equal(a, folder("same", [[0.0, 1.0], [0.5, 1.5 + 1e-12]], event)) is None
    moved = fuzz_runs._resumed_files_equal(a, folder("moved", [[0.0, 1.0], [0.5, 1.51]], event))
    assert moved["outcome"] == "resume_mismatch" and "state history q" in moved["detail"]
    later = fuzz_runs._resumed_files_equal(a, folder("later", [[0.0, 1.0], [0.5, 1.5]],
                                                     [{**event[0], "t": 0.06}]))
    assert later["outcome"] == "resume_mismatch" and "events" in later["detail"]
