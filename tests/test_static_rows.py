"""No lost rows (issue 22, item 3): every requested row λ = k/steps is written after cut steps, a
run that cannot reach a row says so in load factor (exit 1) and writes its last converged state,
static and transient alike; the scene keys of path following are checked before the run (exit 2).

Every scene is YAML text as a user types it, run through ``latdyn run`` and ``latdyn.run``.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import latdyn
from latdyn import cli
from latdyn.errors import SceneError
from latdyn.results.writer import Result

#: The elastica past buckling: a cantilever column under a dead end load 4× its Euler load
#: (P L²/EI = 10; π²/4 = 2.47) with a small lateral load.  Newton cuts two steps near the
#: buckling load; before issue 22 the load factor then left the grid and 14 of 51 rows were
#: written ("solved").
COLUMN = """\
title: elastica past buckling
sections:
  s: {EA: 1.0e7, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1000.0, rhoIy: 100.0, rhoIz: 100.0}
bodies:
  root: {at: [0, 0, 0], fixed: true}
beams:
  col: {from: root, to: [1, 0, 0], section: s, elements: 16}
loads:
  - {at: col.end, force: [-10, 0.01, 0.01], frame: global}
solve: {analysis: static, steps: 50}
output:
  paraview_every: 0
  probes:
    tip_x: {point: col.end, quantity: position, frame: global, component: x}
    tip_y: {point: col.end, quantity: position, frame: global, component: y}
"""

#: Lee's frame (see tests/test_path_following.py) under load control to 20 kip, beyond its limit
#: load (18.56 kip with this mesh): no row beyond the limit can be reached.
LEE_LOAD_CONTROL = """\
title: Lee's frame under load control past its limit load
sections:
  s: {EA: 43200.0, EIy: 14400.0, EIz: 14400.0, GJ: 14400.0, rhoA: 1.0, rhoIy: 1.0, rhoIz: 1.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  corner: {at: [0, 120, 0]}
  load: {at: [24, 120, 0]}
  far: {at: [120, 120, 0], fixed: true}
beams:
  column: {from: base, to: corner, section: s, elements: 5, start: {hinge: {axis: [0, 0, 1]}}}
  left: {from: corner, to: load, section: s, elements: 1}
  right: {from: load, to: far, section: s, elements: 4, end: {hinge: {axis: [0, 0, 1]}}}
loads:
  - {at: load, force: [0, -20.0, 0]}
solve: {analysis: static, steps: 40}
output:
  paraview_every: 0
  probes:
    v: {point: load, quantity: displacement, component: y}
"""

#: A cantilever whose tip load jumps at t = 0.52 beyond what Newton follows with dt_min = dt.
TRANSIENT_JUMP = """\
title: cantilever whose tip load jumps beyond what Newton can follow
sections:
  s: {EA: 1.0e4, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.01}
bodies:
  root: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: root, to: [1, 0, 0], section: s, elements: 4}
loads:
  - {at: arm.end, force: [0, "Piecewise((0, t < 0.52), (1.0e6, True))", 0]}
solve: {analysis: transient, t_end: 1.0, dt: 0.01, dt_min: 0.01, max_iterations: 4}
output:
  paraview_every: 0
  every: 0.1
  probes:
    tip_y: {point: arm.end, quantity: position, component: y}
"""


def _write(tmp_path: Path, text: str, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def test_every_row_of_the_grid_is_written_after_cut_steps(tmp_path):
    scene = _write(tmp_path, COLUMN)
    completed = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "cli"), "-q"],
                               capture_output=True, text=True)
    assert completed.returncode == 0, completed.stderr
    api = latdyn.run(latdyn.load_scene(str(scene)), tmp_path / "api")
    for out in (tmp_path / "cli", tmp_path / "api"):
        summary = _summary(out)
        assert summary["status"] == "solved"
        assert summary["rejected_steps"] >= 1  # the case cuts steps: the path that lost rows is taken
        result = Result.load(out)
        assert result.t.tolist() == [k / 50 for k in range(51)]  # 51 of 51, exactly on the grid
        lines = (out / "probes.csv").read_text().splitlines()
        assert lines[0].startswith("load_factor,") and len(lines) == 52
    np.testing.assert_allclose(api.probes["tip_y"], Result.load(tmp_path / "cli").probes["tip_y"], rtol=1e-12)
    # past buckling the column has bent over (in the diagonal plane of the lateral load): the tip
    # well off the axis and drawn back past mid-length
    assert api.probes["tip_y"][-1] > 0.4 and api.probes["tip_x"][-1] < 0.5


def test_a_row_that_cannot_be_reached_is_named_in_load_factor_and_the_last_state_written(tmp_path, capsys):
    scene = _write(tmp_path, LEE_LOAD_CONTROL)
    out = tmp_path / "out"
    assert cli.main(["run", str(scene), "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert "could not reach load factor" in err and "load factor" in err
    assert "t =" not in err
    summary = _summary(out)
    assert summary["status"] == "failed"
    result = Result.load(out)
    # the grid up to the limit (k/40 ≤ 0.925), then the last converged state beyond the last grid row
    grid = [k / 40 for k in range(38)]
    assert result.t[:38].tolist() == grid
    assert len(result.t) == 39 and 0.925 < result.t[-1] < 0.93
    assert result.t[-1] == pytest.approx(summary["load_factor_reached"], rel=1e-12)
    # the limit load of this mesh is 18.557 kip (arc length, tests/test_path_following.py)
    assert 20 * result.t[-1] == pytest.approx(18.557, abs=0.01)
    with pytest.raises(latdyn.SolverError, match="load factor"):
        latdyn.run(latdyn.load_scene(str(scene)), tmp_path / "api")


def test_a_failed_transient_run_writes_its_last_converged_state(tmp_path, capsys):
    scene = _write(tmp_path, TRANSIENT_JUMP)
    out = tmp_path / "out"
    assert cli.main(["run", str(scene), "-o", str(out), "-q"]) == 1
    assert "Newton failed" in capsys.readouterr().err
    result = Result.load(out)
    # rows every 0.1 up to 0.5, then the last converged state, not on the output grid: the steps land on
    # the load's jump at 0.52 and the run restarts just after it (latdyn/timeloop/jumps.py), where Newton
    # then fails to follow the jumped load
    np.testing.assert_allclose(result.t[:-1], [0.0, 0.1, 0.2, 0.3, 0.4, 0.5], atol=1e-12)
    assert 0.52 < result.t[-1] <= 0.52 + 1e-9
    assert _summary(out)["status"] == "failed"


@pytest.mark.parametrize("solve, key, words", [
    ("{analysis: static, method: newmark}", "solve.method", "for a static analysis one of"),
    ("{analysis: static, method: displacement-control}", "solve.control", "missing required key 'control'"),
    ("{analysis: static, control: {point: arm.end, direction: y, to: 0.1}}", "solve.control",
     "only with method: displacement-control"),
    ("{analysis: static, method: displacement-control, control: {point: arm.end, direction: w, to: 0.1}}",
     "solve.control.direction", "x, y, z or a vector"),
    ("{analysis: static, method: displacement-control, control: {point: arm.tip, direction: y, to: 0.1}}",
     "solve.control.point", "expected a point"),
    ("{analysis: static, method: displacement-control, control: {point: arm.end, direction: y, to: 0}}",
     "solve.control.to", "non-zero"),
    ("{analysis: static, method: displacement-control, control: {point: arm.end, direction: y}}",
     "solve.control", "to"),
    ("{analysis: static, max_steps: 10}", "solve.max_steps", "only with method: arc-length"),
    ("{analysis: transient, t_end: 1, dt: 0.1, max_steps: 10}", "solve.max_steps", "only in a static analysis"),
    ("{analysis: static, method: arc-length, max_steps: 0}", "solve.max_steps", ""),
])
def test_path_following_keys_are_checked_before_the_run(tmp_path, capsys, solve, key, words):
    text = f"""\
sections:
  s: {{EA: 1.0e4, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies:
  root: {{at: [0, 0, 0], fixed: true}}
beams:
  arm: {{from: root, to: [1, 0, 0], section: s, elements: 2}}
solve: {solve}
"""
    scene = _write(tmp_path, text)
    with pytest.raises(SceneError) as caught:
        latdyn.load_scene(str(scene))
    message = str(caught.value)
    assert str(scene) in message and key in message and words in message
    assert cli.main(["run", str(scene), "-o", str(tmp_path / "out"), "-q"]) == 2
    err = capsys.readouterr().err
    assert key in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()
