"""latdyn.scene.builder: scenes in code are the same validated scenes as YAML files."""
from __future__ import annotations

import importlib.util
import time
from pathlib import Path

import numpy as np
import pytest

import latdyn
from latdyn.scene.builder import SceneBuilder, hinge
from latdyn.errors import SceneError

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def boom() -> SceneBuilder:
    b = SceneBuilder("boom")
    b.section("panel", EA=1e7, EIy=1e3, EIz=1e3, GJ=1e3, rhoA=0.5, rhoIy=1e-4)
    b.body("root", at=[0, 0, 0], fixed=True)
    b.body("knee", at=np.array([1.0, 0, 0]), mass=0.2, inertia=[1e-3, 1e-3, 1e-3])
    b.beam("p1", "root", "knee", "panel", elements=2)
    b.beam("p2", ("knee", [0, 0.05, 0]), [0, 0.05, 0], "panel", elements=2,
           start=hinge([0, 0, -1], stiffness="2*(1 + 0.1*theta)", rest_angle=3.6, lock_at="pi",
                       limits=[-0.1, 3.3], restitution=0.2))
    b.load("p2.end", force=[0, "0.1*sin(t)", 0])
    b.probe("angle", hinge="p2.start", quantity="angle")
    b.solve(t_end=0.1, dt=0.01)
    return b


def test_builder_yields_the_scene_its_yaml_file_yields(tmp_path):
    b = boom()
    built = b.build()
    path = tmp_path / "boom.yaml"
    b.to_yaml(path)
    read = latdyn.load_scene(str(path))
    assert read.source_hash == built.source_hash
    assert latdyn.load_scene(b.to_dict()).source_hash == built.source_hash
    h = read.beams["p2"].start.hinge
    assert (h.rest_angle, h.limits, h.restitution) == (3.6, (-0.1, 3.3), 0.2)
    np.testing.assert_allclose(read.beams["p2"].start.point, [1.0, 0.05, 0.0])
    assert read.beams["p2"].end.joint == "free" and read.n_elements == 4


def test_builder_errors_name_the_generated_key():
    b = boom()
    b.beam("p3", "knee", "nowhere", "panel")
    with pytest.raises(SceneError) as info:
        b.build()
    assert "beams.p3.to" in str(info.value) and "knee" in str(info.value)


def test_bays_repeat_a_bay_and_the_truss_example_builds_ten_thousand_elements_in_a_second():
    spec = importlib.util.spec_from_file_location("deployable_truss", EXAMPLES / "deployable_truss.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    small = example.truss(3).build()
    assert len(small.beams) == 30 and len(small.hinges) == 12 and len(small.bodies) == 16
    best = float("inf")
    for _ in range(3):  # the best of three: the machine is shared
        # the process's CPU time, not the wall: the suite runs on every core (pytest-xdist), and what
        # another worker or another job takes of the core is not the builder's time
        t0 = time.process_time()
        scene = example.truss().build()
        best = min(best, time.process_time() - t0)
    assert scene.n_elements == 10_000
    assert best < 2.0  # 0.52 s of CPU (0.8 s wall) measured at load 4 on the 2-core machine; room for slower CI


def test_rigid_link_built_and_run():
    """p1 as a rigid link (tests/test_rigid.py has the physics): the knee follows it, p2's hinge
    with its law, stops and latch sits on a dependent node."""
    from latdyn.model.model import DEPENDENT, Model

    b = boom()
    b.data["beams"]["p1"]["rigid"] = True
    scene = b.build()
    assert scene.n_elements == 2
    model = Model.from_scene(scene)
    assert model.nodes[model.body_node["knee"]].kind == DEPENDENT
    assert model.n_dofs == 6 * 2 + 1  # p2's two nodes and its hinge
    result = latdyn.run(scene)
    assert np.all(np.isfinite(result.probes["angle"]))
    b.data["beams"]["p1"]["rigid"] = False
    assert b.build().n_elements == 4
