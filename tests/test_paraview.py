"""ParaView output (SCENE.md ``output.paraview_every``; latdyn/results/paraview.py): one transient VTKHDF
file per part, read back with VTK's own reader (tests/vtkhdf_frames.py)."""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import latdyn
from latdyn.results.paraview import default_every
from latdyn.results.writer import Result, ResultWriter
from vtkhdf_frames import read_frames, times

pytest.importorskip("vtk")
ROOT = Path(__file__).resolve().parents[1]
VERTEX, LINE = 1, 3


def cli_run(scene_text: str, folder: Path, name="scene.yaml") -> subprocess.CompletedProcess:
    """``python -m latdyn run`` on a scene typed as YAML text."""
    scene = folder / name
    scene.write_text(textwrap.dedent(scene_text))
    return subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(folder / "out"), "-q"],
                          capture_output=True, text=True, cwd=folder, timeout=300,
                          env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})


# ----------------------------------------------------------------------------- the writer
def test_frames_are_read_back_by_vtk(tmp_path):
    lines = np.array([[0, 1], [1, 2], [2, 3]])
    x0 = np.column_stack([np.arange(4.0), np.zeros(4), np.zeros(4)])
    mesh = {"beams": {"n_points": 4, "cells": [("line", lines)], "cell_data": {"beam": np.array([0, 0, 1])}}}
    with ResultWriter(tmp_path, ["x"], mesh=mesh) as writer:
        for i in range(3):
            u = np.zeros((4, 3))
            u[:, 1] = 0.1 * i * np.arange(4.0)
            writer.record(0.1 * i, [i], frame={"beams": {"points": x0 + u, "point_data": {"displacement": u},
                                                          "cell_data": {"axial_force": np.full(3, float(i))}}})
    frames = read_frames(tmp_path / "paraview" / "beams.vtkhdf")
    assert [f.t for f in frames] == [0.0, 0.1, 0.2]  # the exact recorded times
    last = frames[-1]
    np.testing.assert_array_equal(last.points[:, 1], 0.2 * np.arange(4.0))
    assert last.cells == [(LINE, [0, 1]), (LINE, [1, 2]), (LINE, [2, 3])]
    np.testing.assert_array_equal(last.point_data["displacement"][:, 1], 0.2 * np.arange(4.0))
    np.testing.assert_array_equal(last.cell_data["axial_force"], 2.0)
    np.testing.assert_array_equal(frames[0].cell_data["beam"], [0, 0, 1])  # stored once, every step
    np.testing.assert_array_equal(last.cell_data["beam"], [0, 0, 1])
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["paraview_files"] == ["paraview/beams.vtkhdf"] and summary["paraview_frames"] == 3


def test_frames_at_paraview_every_and_the_last_one_on_failure(tmp_path):
    """Frames at the first record at or after each multiple of `every`; callables are called only
    for frames that are written; the last record's frame at close, also for a failed run."""
    mesh = {"beams": {"n_points": 2, "cells": [("line", [[0, 1]])]}}
    calls = []

    def frame(i):
        def build():
            calls.append(i)
            return {"beams": {"points": [[0.0, 0, 0], [1.0, float(i), 0]], "cell_data": {"axial_force": [float(i)]}}}
        return build

    with pytest.raises(RuntimeError):
        with ResultWriter(tmp_path, ["x"], mesh=mesh, paraview_every=0.3) as writer:
            for i in range(9):
                writer.record(0.1 * i, [i], frame=frame(i))
            raise RuntimeError("solver failed")
    assert calls == [0, 3, 6, 8]  # 0.1·3 = 0.30000000000000004 ≥ 0.3; 0.8 the last, at close
    frames = read_frames(tmp_path / "paraview" / "beams.vtkhdf")
    assert [f.t for f in frames] == [0.0, 0.1 * 3, 0.1 * 6, 0.1 * 8]
    np.testing.assert_array_equal(frames[-1].cell_data["axial_force"], [8.0])
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "failed"


def test_several_parts_an_empty_one_is_skipped_and_no_frames_with_every_0(tmp_path):
    mesh = {"beams": {"n_points": 0, "cells": [("line", np.zeros((0, 2)))]},
            "bodies": {"n_points": 3, "cells": [("vertex", [[0], [1]]), ("line", [[0, 2]]), ("line", np.zeros((0, 2)))],
                       "cell_data": {"mass": [3.0, 4.0, 0.0]}}}
    frame = {"beams": {"points": np.zeros((0, 3))},
             "bodies": {"points": np.eye(3), "point_data": {"angular_velocity": np.ones((3, 3))}}}
    with ResultWriter(tmp_path / "a", [], mesh=mesh) as writer:
        writer.record(0.0, [], frame=frame)
        with pytest.raises(ValueError, match="parts"):
            writer.record(1.0, [], frame={"bodies": frame["bodies"]})
        with pytest.raises(ValueError, match="constant"):
            writer.record(1.0, [], frame=dict(frame, bodies=dict(frame["bodies"], cell_data={"mass": [1.0, 2, 3]})))
    assert sorted(p.name for p in (tmp_path / "a" / "paraview").iterdir()) == ["bodies.vtkhdf"]
    (bodies,) = read_frames(tmp_path / "a" / "paraview" / "bodies.vtkhdf")
    assert bodies.cells == [(VERTEX, [0]), (VERTEX, [1]), (LINE, [0, 2])]  # the empty block is left out
    np.testing.assert_array_equal(bodies.cell_data["mass"], [3.0, 4.0, 0.0])
    np.testing.assert_array_equal(bodies.points, np.eye(3))
    assert json.loads((tmp_path / "a" / "summary.json").read_text())["paraview_files"] == ["paraview/bodies.vtkhdf"]
    with ResultWriter(tmp_path / "b", [], mesh=mesh, paraview_every=0) as writer:
        writer.record(0.0, [], frame=frame)
    assert not (tmp_path / "b" / "paraview").exists()
    assert "paraview_files" not in json.loads((tmp_path / "b" / "summary.json").read_text())


def test_default_every_keeps_a_few_hundred_frames_on_the_rows():
    assert default_every(20.0, 0.01) == pytest.approx(0.1)  # 10 rows a frame: 201 frames
    assert default_every(20.0, 0.01) / 0.01 == pytest.approx(10.0)
    assert default_every(1.0, 0.01) == 0.01  # fewer rows than 200: every row
    assert default_every(0.0301, 1e-4) == 2e-4


# ----------------------------------------------------------------------------- runs from YAML text
SCENE_3D = """\
    title: a 3D arm with joint bodies, an offset, a hinge and a rigid link
    gravity: [0, -2.0, -9.81]
    sections:
      s: {EA: 1.0e6, EIy: 300, EIz: 500, GJ: 400, rhoA: 1.0, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
    bodies:
      base: {at: [0, 0, 0], fixed: true}
      elbow: {at: [1, 0, 0], mass: 0.5, inertia: [1.0e-3, 2.0e-3, 3.0e-3]}
      tip: {at: [1.5, 0.5, 0], mass: 0.2}
    beams:
      a:
        from: base
        to: {body: elbow, offset: [-0.1, 0, 0]}
        section: s
        elements: 2
        start: {hinge: {axis: [0, 0, 1], torque: "1.0"}}
      link:
        from: {body: elbow, offset: [0.1, 0.1, 0]}
        to: tip
        section: s
        rigid: true
        start: {hinge: {axis: [0, 1, 0]}}
    solve: {analysis: transient, t_end: 0.05, dt: 0.005}
    output:
      paraview_every: 0.02
      probes:
        tip_z: {point: tip, quantity: position, component: z}
        tip_vz: {point: tip, quantity: velocity, component: z}
        elbow_x: {point: elbow, quantity: position, component: x}
        n0: {element: a.element[0], quantity: axial_force}
        my1: {element: a.element[1], quantity: moment_y}
    """


@pytest.fixture(scope="module")
def run_3d(tmp_path_factory):
    folder = tmp_path_factory.mktemp("run3d")
    done = cli_run(SCENE_3D, folder)
    assert done.returncode == 0, done.stderr
    return folder / "out"


def test_3d_run_beams_with_a_rigid_link(run_3d):
    loaded = Result.load(run_3d)
    beams = read_frames(run_3d / "paraview" / "beams.vtkhdf")
    # frames at 0, 0.02, 0.04 and t_end, at exactly the recorded times
    assert [f.t for f in beams] == [loaded.t[0], loaded.t[4], loaded.t[8], loaded.t[-1]] == times(
        run_3d / "paraview" / "bodies.vtkhdf")
    assert beams[-1].t == 0.05
    last = beams[-1]
    # points: base, the interior node, the offset end at the elbow, the link's start (offset) and end (the tip)
    assert last.points.shape == (5, 3)
    assert last.cells == [(LINE, [0, 1]), (LINE, [1, 2]), (LINE, [3, 4])]
    np.testing.assert_array_equal(last.cell_data["rigid"], [0, 0, 1])
    np.testing.assert_array_equal(last.cell_data["beam"], [0, 0, 1])
    np.testing.assert_allclose(last.cell_data["axial_force"][0], loaded.probes["n0"][-1], rtol=1e-12)
    np.testing.assert_allclose(last.cell_data["moment_y"][1], loaded.probes["my1"][-1], rtol=1e-12)
    assert np.isnan(last.cell_data["torque"][2])  # a rigid link has no section forces
    np.testing.assert_allclose(last.points[4, 2], loaded.probes["tip_z"][-1], rtol=1e-12)
    np.testing.assert_allclose(last.point_data["velocity"][4, 2], loaded.probes["tip_vz"][-1], rtol=1e-12)
    assert abs(loaded.probes["tip_z"][-1]) > 1e-3  # it fell: a real comparison
    first = beams[0]
    np.testing.assert_allclose(first.points, [[0, 0, 0], [0.45, 0, 0], [0.9, 0, 0], [1.1, 0.1, 0], [1.5, 0.5, 0]],
                               atol=1e-15)
    np.testing.assert_array_equal(first.point_data["displacement"], 0.0)
    np.testing.assert_allclose(last.point_data["displacement"], last.points - first.points, atol=1e-15)


def test_3d_run_bodies_with_offsets(run_3d):
    loaded = Result.load(run_3d)
    bodies = read_frames(run_3d / "paraview" / "bodies.vtkhdf")
    beams = read_frames(run_3d / "paraview" / "beams.vtkhdf")
    last = bodies[-1]
    # base, elbow, tip as vertices; lines from the elbow to the beam's end and to the link's start
    assert last.cells == [(VERTEX, [0]), (VERTEX, [1]), (VERTEX, [2]), (LINE, [1, 3]), (LINE, [1, 4])]
    np.testing.assert_array_equal(last.cell_data["body"], [0, 1, 2, 1, 1])
    np.testing.assert_array_equal(last.cell_data["mass"], [0.0, 0.5, 0.2, 0.0, 0.0])
    np.testing.assert_array_equal(last.cell_data["kind"], [2, 0, 3, 0, 0])  # fixed, free, placed by the link
    np.testing.assert_allclose(last.points[1, 0], loaded.probes["elbow_x"][-1], rtol=1e-12)
    np.testing.assert_allclose(last.points[3:], beams[-1].points[[2, 3]], rtol=1e-14)
    np.testing.assert_allclose(last.points[2], beams[-1].points[4], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(last.points[3] - last.points[1]), 0.1, rtol=1e-9)
    assert set(last.point_data) == {"displacement", "velocity", "angular_velocity", "axis_x", "axis_y", "axis_z"}
    np.testing.assert_allclose(np.linalg.norm(last.point_data["axis_z"], axis=1), 1.0, rtol=1e-12)
    np.testing.assert_array_equal(last.point_data["angular_velocity"][0], 0.0)  # the base is fixed


RIGID_ONLY = """\
    title: a pendulum that is one rigid link
    gravity: [0, -9.81, 0]
    sections:
      rod: {EA: 1.0e6, EIy: 10, EIz: 10, GJ: 10, rhoA: 2.0}
    bodies:
      pivot: {at: [0, 0, 0], fixed: true}
    beams:
      arm:
        from: pivot
        to: [1, 0, 0]
        section: rod
        rigid: true
        start: {hinge: {axis: [0, 0, 1]}}
    solve: {analysis: transient, t_end: 0.05, dt: 0.01}
    output:
      probes:
        angle: {hinge: arm.start, quantity: angle}
    """


def test_a_scene_whose_only_beam_is_a_rigid_link(tmp_path):
    """It used to exit 1 (meshio: "Incompatible cell data 'beam'. 0 cell blocks")."""
    done = cli_run(RIGID_ONLY, tmp_path)
    assert done.returncode == 0, done.stderr
    out = tmp_path / "out"
    beams = read_frames(out / "paraview" / "beams.vtkhdf")
    angle = Result.load(out).probes["angle"]
    assert [f.t for f in beams] == Result.load(out).t.tolist()
    for f, theta in zip(beams, angle):
        assert f.cells == [(LINE, [0, 1])]
        np.testing.assert_array_equal(f.cell_data["rigid"], [1])
        np.testing.assert_allclose(f.points[1], [np.cos(theta), np.sin(theta), 0.0], atol=1e-12)
    assert angle[-1] < -1e-3
    (bodies_last,) = read_frames(out / "paraview" / "bodies.vtkhdf")[-1:]
    assert bodies_last.cells == [(VERTEX, [0])]
    # and from Python
    result = latdyn.run(latdyn.load_scene(tmp_path / "scene.yaml"), tmp_path / "py")
    np.testing.assert_array_equal(result.probes["angle"], angle)
    assert result.summary["paraview_files"] == ["paraview/beams.vtkhdf", "paraview/bodies.vtkhdf"]


def test_paraview_every_0_writes_no_frames_and_a_negative_one_is_refused(tmp_path):
    done = cli_run(RIGID_ONLY.replace("    output:\n", "    output:\n      paraview_every: 0\n"), tmp_path)
    assert done.returncode == 0, done.stderr
    assert not (tmp_path / "out" / "paraview").exists()
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert "paraview_files" not in summary and summary["rows"] == 6
    bad = cli_run(RIGID_ONLY.replace("    output:\n", "    output:\n      paraview_every: -1\n"), tmp_path, "bad.yaml")
    assert bad.returncode == 2
    assert "output.paraview_every" in bad.stderr and ">= 0" in bad.stderr and "bad.yaml" in bad.stderr


def test_static_run_has_a_frame_per_load_step_and_modes_none(tmp_path):
    scene = latdyn.load_scene({
        "sections": {"s": {"EA": 1e6, "EIy": 10.0, "EIz": 10.0, "GJ": 10.0, "rhoA": 1.0}},
        "bodies": {"wall": {"at": [0, 0, 0], "fixed": True}},
        "beams": {"c": {"from": "wall", "to": [1, 0, 0], "section": "s", "elements": 2}},
        "loads": [{"at": "c.end", "force": [0, -1.0, 0]}],
        "solve": {"analysis": "static", "steps": 4},
        "output": {"probes": {"v": {"point": "c.end", "quantity": "displacement", "component": "y"}}}})
    latdyn.run(scene, tmp_path / "static")
    frames = read_frames(tmp_path / "static" / "paraview" / "beams.vtkhdf")
    assert [f.t for f in frames] == [0.0, 0.25, 0.5, 0.75, 1.0]
    np.testing.assert_allclose(frames[-1].point_data["displacement"][-1, 1],
                               Result.load(tmp_path / "static").probes["v"][-1], rtol=1e-12)
    modal = dict(scene.raw, solve={"analysis": "modes", "count": 2})
    latdyn.run(modal, tmp_path / "modes")
    assert not (tmp_path / "modes" / "paraview").exists()
