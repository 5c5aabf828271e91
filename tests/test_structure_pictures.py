"""Pictures of the structure (SCENE.md, "Pictures of the structure"): ``latdyn plot OUT`` writes
``plots/structure.png`` and ``latdyn animate OUT [-o FILE]`` an animation, from the results folder
alone; what they draw is what the run computed; a folder they cannot draw from is refused (exit 2)."""
from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from latdyn import cli
from latdyn.results.structure import load_structure, structure_view

PNG = b"\x89PNG\r\n\x1a\n"

# a flexible pendulum in the x-y plane: a hinge at a fixed pivot, a tip mass, gravity along -y
PLANAR_SCENE = """\
title: planar pendulum
gravity: [0, -9.81, 0]
sections:
  rod: {EA: 1.0e6, EIy: 50, EIz: 50, GJ: 40, rhoA: 0.5}
bodies:
  pivot: {at: [0, 0, 0], fixed: true}
  tip: {at: [1, 0, 0], mass: 0.2}
beams:
  arm:
    from: pivot
    to: tip
    section: rod
    elements: 3
    start: {hinge: {axis: [0, 0, 1]}}
solve: {t_end: 0.2, dt: 0.01}
output:
  every: 0.01
  probes:
    tip_y: {point: tip, quantity: position, component: y}
    swing: {hinge: arm.start, quantity: angle}
    energy: {energy: total}
"""

# out of every coordinate plane: a rigid link on a skew hinge, then a flexible beam; gravity
SPATIAL_SCENE = """\
title: skew rigid link and beam
gravity: [0, 0, -9.81]
sections:
  rod: {EA: 1.0e6, EIy: 50, EIz: 50, GJ: 40, rhoA: 0.5}
bodies:
  pivot: {at: [0, 0, 0], fixed: true}
  elbow: {at: [0.6, 0, 0], mass: 0.3}
beams:
  link: {from: pivot, to: elbow, section: rod, rigid: true, start: {hinge: {axis: [0, 1, 1]}}}
  arm: {from: elbow, to: [0.6, 0.5, 0.2], section: rod, elements: 2}
solve: {t_end: 0.15, dt: 0.01}
output:
  every: 0.01
  paraview_every: 0.03
  probes:
    elbow_z: {point: elbow, quantity: displacement, component: z}
"""


def _run(tmp_path: Path, text: str, name: str) -> Path:
    scene = tmp_path / f"{name}.yaml"
    scene.write_text(text)
    out = tmp_path / f"{name}_results"
    assert cli.main(["run", str(scene), "-o", str(out), "-q"]) == 0
    return out


@pytest.fixture(scope="module")
def planar_results(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("planar"), PLANAR_SCENE, "pendulum")


@pytest.fixture(scope="module")
def spatial_results(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("spatial"), SPATIAL_SCENE, "skew")


def test_plot_writes_the_structure_picture(planar_results, capsys):
    assert cli.main(["plot", str(planar_results)]) == 0
    picture = planar_results / "plots" / "structure.png"
    assert picture.read_bytes()[:8] == PNG
    from PIL import Image

    with Image.open(picture) as image:
        assert image.size[0] > 500 and image.size[1] > 400
    assert (planar_results / "plots" / "tip_y.png").is_file()  # the probe plots are still there


def test_the_structure_drawn_is_the_structure_computed(planar_results):
    """Each frame's joint bodies are where the state history puts them at that time, the beam is
    one polyline of its grid points, and the planar scene is drawn in its plane."""
    history = load_structure(planar_results)
    with h5py.File(planar_results / "state.h5", "r") as f:
        t, x = f["t"][:], f["x"][:]
        nodes = [n.decode() if isinstance(n, bytes) else str(n) for n in f.attrs["nodes"]]
    assert history.frames == len(t) == 21
    np.testing.assert_array_equal(history.times, t)
    tip = nodes.index("tip")
    drawn_tip = history.body_points[:, history.bodies, :]
    computed = x.reshape(len(t), -1, 3)[:, tip]
    assert any(np.allclose(drawn_tip[:, i], computed, atol=1e-12) for i in range(drawn_tip.shape[1]))
    assert np.linalg.norm(computed[-1] - computed[0]) > 1e-3  # it swung: the frames differ
    assert len(history.beam_segments) == 3 and len(history.link_segments) == 0
    # one polyline: each element's end is the next one's start
    assert all(history.beam_segments[k, 1] == history.beam_segments[k + 1, 0] for k in range(2))
    assert structure_view(history).plane == (0, 1)
    assert history.body_fixed.sum() == 1


def test_rigid_links_are_drawn_and_a_spatial_scene_is_3d(spatial_results):
    history = load_structure(spatial_results)
    assert len(history.link_segments) == 1 and len(history.beam_segments) == 2
    view = structure_view(history)
    assert view.plane is None
    # equal axes: every axis spans the same length per unit (the box is the extents, one scale)
    assert np.all(view.upper - view.lower > 0)
    link = history.beam_points[:, history.link_segments[0]]
    length = np.linalg.norm(link[:, 1] - link[:, 0], axis=1)
    np.testing.assert_allclose(length, 0.6, rtol=1e-9)  # a rigid link keeps its length in every frame
    assert cli.main(["plot", str(spatial_results)]) == 0
    assert (spatial_results / "plots" / "structure.png").read_bytes()[:8] == PNG


def test_animate_writes_a_gif_of_every_frame_by_default(spatial_results, capsys):
    from PIL import Image

    assert cli.main(["animate", str(spatial_results)]) == 0
    gif = spatial_results / "animation.gif"
    assert str(gif) in capsys.readouterr().out
    frames = json.loads((spatial_results / "summary.json").read_text())["paraview_frames"]
    assert frames == 6  # t = 0, 0.03, ..., 0.15
    with Image.open(gif) as image:
        assert image.format == "GIF" and image.n_frames == frames


def test_animate_to_a_file_with_fewer_frames(planar_results, tmp_path):
    from PIL import Image

    target = tmp_path / "swing.gif"
    assert cli.main(["animate", str(planar_results), "-o", str(target), "--frames", "5", "--fps", "10"]) == 0
    with Image.open(target) as image:
        assert image.n_frames == 5
        assert image.info["duration"] == 100  # ms a frame at 10 frames per second


def test_animate_mp4_without_ffmpeg_names_the_tool(planar_results, tmp_path, capsys, monkeypatch):
    from matplotlib import animation

    monkeypatch.setattr(animation.FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    target = tmp_path / "swing.mp4"
    assert cli.main(["animate", str(planar_results), "-o", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("latdyn: error: ") and "ffmpeg" in err and "Traceback" not in err
    assert not target.exists()


@pytest.mark.parametrize("argv_tail, words", [
    (["-o", "movie.avi"], [".avi", ".gif or .mp4"]),
    (["--frames", "0"], ["--frames", ">= 1"]),
])
def test_animate_bad_arguments_exit_2(planar_results, tmp_path, capsys, argv_tail, words):
    tail = [str(tmp_path / a) if a.endswith(".avi") else a for a in argv_tail]
    assert cli.main(["animate", str(planar_results), *tail]) == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err


def test_animate_a_missing_folder_exits_2(tmp_path, capsys):
    missing = tmp_path / "no_results"
    assert cli.main(["animate", str(missing)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("latdyn: error: ") and str(missing) in err and "Traceback" not in err
    assert not missing.exists()


def test_a_run_without_paraview_files_is_plotted_without_the_picture_and_not_animated(tmp_path, capsys):
    out = _run(tmp_path, PLANAR_SCENE.replace("  every: 0.01\n", "  every: 0.01\n  paraview_every: 0\n"), "bare")
    assert cli.main(["plot", str(out)]) == 0
    assert (out / "plots" / "tip_y.png").is_file() and not (out / "plots" / "structure.png").exists()
    capsys.readouterr()
    assert cli.main(["animate", str(out)]) == 2
    err = capsys.readouterr().err
    assert "paraview_every" in err and str(out) in err
    assert not (out / "animation.gif").exists()


def test_probe_plots_say_what_each_probe_measures_and_its_unit(planar_results):
    labels = json.loads((planar_results / "summary.json").read_text())["probe_labels"]
    assert labels == {"tip_y": "tip_y: position y of tip (m)",
                      "swing": "swing: hinge angle of arm.start (rad)",
                      "energy": "energy: total energy (J)"}


def test_the_deploying_truss_example_latches_straight():
    """examples/deploying_truss.yaml (the README's picture): every member of a bay is hinged at its
    start about the station's batten line, and the latch angles, turned through bay after bay,
    bring every bay in line with x: the truss it latches is straight (the run itself takes a
    minute, too long for the suite; its picture is docs/pictures/deploying_truss_structure.png)."""
    from scipy.spatial.transform import Rotation

    import latdyn

    scene = latdyn.load_scene(str(Path(__file__).resolve().parents[1] / "examples" / "deploying_truss.yaml"))
    turned = np.eye(3)  # the rotation of the bays before this one, deployed
    for bay in (1, 2, 3):
        members = [scene.beams[f"bay{bay}_{m}"] for m in "abd"]
        hinges = [m.start.hinge for m in members]
        assert all(h is not None and h.lock_at is not None and h.rest_angle > h.lock_at for h in hinges)
        axis, lock = hinges[0].axis, hinges[0].lock_at
        assert all(np.allclose(h.axis, axis) and h.lock_at == lock for h in hinges)  # one hinge line a bay
        chord = members[0].end.point - members[0].start.point
        turned = Rotation.from_rotvec(lock * (turned @ axis)).as_matrix() @ turned
        np.testing.assert_allclose(turned @ chord, [np.linalg.norm(chord), 0.0, 0.0], atol=1e-6)


def test_a_modal_run_with_mode_shapes_is_plotted_without_a_structure_picture(tmp_path, capsys):
    """paraview/ of a modal run holds only the mode shapes (paraview/modes/): `latdyn plot` draws its
    modes and no structure, and `latdyn animate` says there is no motion to draw."""
    text = PLANAR_SCENE.replace("solve: {t_end: 0.2, dt: 0.01}", "solve: {analysis: modes, count: 3, mode_shapes: true}")
    out = _run(tmp_path, text, "modal")
    assert (out / "paraview" / "modes").is_dir()
    assert cli.main(["plot", str(out)]) == 0
    assert (out / "plots" / "modes.png").is_file() and not (out / "plots" / "structure.png").exists()
    capsys.readouterr()
    assert cli.main(["animate", str(out)]) == 2
    assert "ParaView" in capsys.readouterr().err


def test_a_static_path_is_drawn_by_load_factor(tmp_path):
    from latdyn.results.structure import time_text

    text = PLANAR_SCENE.replace("start: {hinge: {axis: [0, 0, 1]}}", "start: clamped").replace(
        "solve: {t_end: 0.2, dt: 0.01}", "solve: {analysis: static, steps: 4}").replace(
        "    swing: {hinge: arm.start, quantity: angle}\n", "")
    out = _run(tmp_path, text, "static")
    history = load_structure(out)
    assert history.time_label == "load factor" and history.frames == 5
    np.testing.assert_allclose(history.times, np.linspace(0.0, 1.0, 5))
    assert time_text(history, 4) == "load factor 1"
    assert cli.main(["plot", str(out)]) == 0 and (out / "plots" / "structure.png").is_file()
