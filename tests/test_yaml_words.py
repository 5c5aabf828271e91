"""YAML words (SCENE.md, "YAML words"): a key that takes a word accepts what a user writes in
plain YAML, though YAML 1.1 reads ``off``, ``on``, ``yes``, ``no`` as booleans. Scenes here are
YAML text, run through the command line and through the API."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest
import yaml

import latdyn
from latdyn.errors import SceneError

SCENE = """\
title: words a user types
sections:
  s: {{EA: 1.0e6, EIy: 100, EIz: 100, GJ: 80, rhoA: 1}}
bodies:
  {body}: {{at: [0, 0, 0], fixed: {fixed}}}
beams:
  arm: {{from: {body}, to: [1, 0, 0], section: s, elements: 2}}
loads:
  - {{at: arm.end, force: [0, 0, -1]}}
solve:
  analysis: transient
  t_end: 0.02
  dt: 0.01
  planar: {planar}
output:
  paraview_every: 0
  probes:
    w: {{point: arm.end, quantity: displacement, component: z}}
"""


def _write(tmp_path, **words):
    values = {"body": "base", "fixed": "true", "planar": "auto", **words}
    path = tmp_path / "scene.yaml"
    path.write_text(SCENE.format(**values))
    return path


@pytest.mark.parametrize("planar", ["off", "Off", "OFF", "'off'", '"off"'])
def test_planar_off_as_typed_forces_the_3d_model(tmp_path, planar):
    path = _write(tmp_path, planar=planar)
    assert latdyn.load_scene(path).solve.planar == "off"
    out = subprocess.run([sys.executable, "-m", "latdyn", "check", str(path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "planar: off" in out.stdout and "3D model" in out.stdout


def test_yes_no_on_words_as_names_and_booleans(tmp_path):
    """A body named ``no`` stays a name, and ``fixed: yes`` means fixed (YAML 1.1's reading)."""
    path = _write(tmp_path, body="no", fixed="yes", planar="off")
    scene = latdyn.load_scene(path)
    assert list(scene.bodies) == ["no"] and scene.bodies["no"].fixed is True
    out_dir = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(path), "-o", str(out_dir), "-q"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    summary = json.loads((out_dir / "summary.json").read_text())
    assert summary["status"] == "solved" and summary["coordinates"] == 12  # 3D: 2 free nodes × 6


def test_a_word_that_is_no_option_names_the_options_not_false(tmp_path):
    path = _write(tmp_path, planar="on")
    done = subprocess.run([sys.executable, "-m", "latdyn", "check", str(path)], capture_output=True, text=True)
    assert done.returncode == 2
    assert "solve.planar" in done.stderr and "'on'" in done.stderr and "False" not in done.stderr
    assert "True" not in done.stderr and "Traceback" not in done.stderr


def test_booleans_from_a_yaml_1_1_reader(tmp_path):
    """A scene built in Python with yaml.safe_load (YAML 1.1) carries ``planar: False``: it is the
    one option that can have been written (``off``); a boolean no option can mean asks for quotes."""
    raw = yaml.safe_load(_write(tmp_path, planar="off").read_text())
    assert raw["solve"]["planar"] is False
    assert latdyn.load_scene(raw).solve.planar == "off"
    raw["solve"]["method"] = True
    with pytest.raises(SceneError) as err:
        latdyn.load_scene(raw)
    assert "solve.method" in str(err.value) and "quoted" in str(err.value)
