"""Modes of a moving scene (issue 22, item 5): ``about: initial`` on a scene with prescribed
motion or an initial velocity says what it computes — a warning naming the motion on stderr and
in ``summary.json`` ``warnings`` — never silently.  YAML text through ``latdyn run`` and the API."""
from __future__ import annotations

import json

import pytest

import latdyn
from latdyn import cli

SCENE = """\
title: a beam on a hub
sections:
  arm: {EA: 2.8e7, EIy: 1.4e4, EIz: 1.4e4, GJ: 1.0e4, rhoA: 1.2}
bodies:
  hub:
    at: [0, 0, 0]
HUB
beams:
  arm: {from: hub, to: [10, 0, 0], section: arm, elements: 4}
INITIAL
solve: {analysis: modes, count: 3}
"""

CASES = {
    "spun": ("    motion: {rotation: {axis: [0, 0, 1], angle: \"6*t\"}}", "",
             "body 'hub' has a prescribed rotation about [0, 0, 1]"),
    "thrown": ("    fixed: true", "initial_velocity: {linear: [0, 1, 0], angular: [0, 0, 0]}",
               "initial_velocity is linear [0, 1, 0], angular [0, 0, 0]"),
    "at rest": ("    fixed: true", "", None),
    "held at an angle": ("    motion: {rotation: {axis: [0, 0, 1], angle: 0.3}}", "", None),
}


@pytest.mark.parametrize("case", list(CASES))
def test_modes_about_the_initial_configuration_of_a_moving_scene_warn(tmp_path, capsys, case):
    hub, initial, words = CASES[case]
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE.replace("HUB", hub).replace("INITIAL", initial))
    assert cli.main(["run", str(scene), "-o", str(tmp_path / "cli"), "-q"]) == 0
    err = capsys.readouterr().err
    summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
    api = latdyn.run(latdyn.load_scene(str(scene)), tmp_path / "api")
    api_summary = json.loads((tmp_path / "api" / "summary.json").read_text())
    assert len(api.modes) == 3
    if words is None:
        assert "warning" not in err and not summary.get("warnings") and not api_summary.get("warnings")
        return
    assert "warning" in err and words in err and "about: initial" in err
    for s in (summary, api_summary):
        (warning,) = s["warnings"]
        assert words in warning and "at rest" in warning
