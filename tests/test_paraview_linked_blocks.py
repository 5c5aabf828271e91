"""ParaView frames of a model with rigid links, computed a block of rows at a time (latdyn/results/paraview.py
``frames``): the rows the compiled loop records are completed by its step (csrc/links.c), so their frames need no
pass of Python each; the files are those of the frame-by-frame path (``frame``, which completes the links again)."""
from __future__ import annotations

import h5py
import numpy as np

import latdyn
from latdyn.results import paraview

#: a gimbal of rigid links (a post and an arm on two hinges, a spinning rotor), rows off the step grid
GIMBAL = """
gravity: [0, 0, -9.81]
sections:
  stiff: {EA: 1.0e8, EIy: 1.0e6, EIz: 1.0e6, GJ: 1.0e6, rhoA: 0.01}
bodies:
  base: {at: [0, 0, -0.2], fixed: true}
  gimbal: {at: [0, 0, 0], mass: 0.01, inertia: [1.0e-4, 1.0e-4, 1.0e-4]}
  rotor: {at: [0.5, 0, 0], mass: 1.0, inertia: [1.0, 0.5, 0.5]}
beams:
  post: {from: base, to: gimbal, section: stiff, rigid: true, start: {hinge: {axis: [0, 0, 1]}}}
  arm: {from: gimbal, to: rotor, section: stiff, rigid: true, start: {hinge: {axis: [0, 1, 0]}},
        end: {hinge: {axis: [1, 0, 0], angle: "20*t"}}}
solve: {t_end: 0.3, dt: 0.005}
output:
  every: 0.0137
  paraview_every: 0.0137
  probes:
    tilt: {hinge: arm.start, quantity: angle}
"""


def _run(tmp_path, name):
    scene = tmp_path / "gimbal.yaml"
    scene.write_text(GIMBAL)
    return latdyn.run(latdyn.load_scene(scene), tmp_path / name)


def test_a_linked_models_frames_are_made_a_block_at_a_time(tmp_path, monkeypatch):
    calls = []
    one_by_one = paraview.frame
    monkeypatch.setattr(paraview, "frame", lambda *a, **k: calls.append(1) or one_by_one(*a, **k))
    result = _run(tmp_path, "out")
    assert result.summary["time_loop"] == "compiled"
    assert len(calls) <= 2, f"{len(calls)} frames made one by one"   # (the first row's, before the loop)


def test_the_blocks_frames_are_the_frame_by_frame_ones(tmp_path, monkeypatch):
    _run(tmp_path, "blocks")
    monkeypatch.setattr(paraview, "frames", lambda *a, **k: None)   # every frame by frame(), links completed
    _run(tmp_path, "one_by_one")
    files = sorted(p.name for p in (tmp_path / "blocks" / "paraview").iterdir())
    assert files == sorted(p.name for p in (tmp_path / "one_by_one" / "paraview").iterdir()) and files
    compared = 0
    for name in files:
        with h5py.File(tmp_path / "blocks" / "paraview" / name) as a, \
                h5py.File(tmp_path / "one_by_one" / "paraview" / name) as b:
            datasets = []
            a.visititems(lambda key, obj: datasets.append(key) if isinstance(obj, h5py.Dataset) else None)
            for key in datasets:
                np.testing.assert_array_equal(a[key][()], b[key][()], err_msg=f"{name}: {key}")
                compared += 1
    assert compared > 10
