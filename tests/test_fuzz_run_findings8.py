"""Findings of benchmarks/fuzz_combined5.py (session 2026-11-28 thirteenth, helper fuzz9), each a YAML scene and a
study through the front door.

A study (shared/STUDY.md) adds four energy probes to every transient case (``_study_K``, ``_study_S``, ``_study_P``,
``_study_W``: latdyn/studies/case.py, ENERGY_PROBES) for its ``unbounded`` rule. A scene with
``solve.sensitivities`` then has its sensitivities taken of those probes too, and where the external work is not
differentiated (an adaptive run with a load in t; any scene with a controller: latdyn/analyses/energy_sensitivities.py)
every case of the study was refused on 86d57d9, by a probe the user never wrote, while the scene alone runs (exit 0).
Fuzz seed 1 case 1 (an adaptive chain, benchmarks/fuzz_combined5.py --seed 1) found it; the scenes here are the
smallest that show it. Now a case whose sensitivities would refuse the study's energy probes runs without them
(latdyn/studies/runner.py ``_with_energy_probes``: judged on non-finite values alone).

Under arc length and displacement control the load factor is a result, and its sensitivity along the path
``result.sensitivities[("load_factor", NAME)]`` (docs/parameters.md: "in memory and from Result.load"). 86d57d9 kept
it in memory only: sensitivities.csv had no ``load_factor/NAME`` columns, so ``latdyn run`` wrote no row of the path
parameter's derivative (only summary.json's end, max and min) and ``Result.load`` of the folder had none (found
comparing the objectivity check's loaded results, seed 2 case 0, a tilted arch through its limit point)."""
from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

import latdyn
from latdyn.results.result import Result
from tests.cli_runs import latdyn_run, summary_of

ROOT = Path(__file__).resolve().parents[1]

#: a flexible arm on a hinge spring, its tip pushed by a load in t, adaptive steps, sensitivities by k and F
ADAPTIVE_ARM = """
title: a flexible arm on a hinge spring, its tip pushed by a load in t, adaptive steps
parameters: {k: 2.0, EI: 20.0, F: 0.4}
sections:
  s: {EA: 1.0e4, EIy: EI, EIz: EI, GJ: 10.0, rhoA: 0.5, rhoIy: 0.0005, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0, 0], mass: 0.3, inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: base, to: tip, section: s, elements: 2, start: {hinge: {axis: [0, 0, 1], stiffness: k}}}
loads:
  - {at: tip, force: [0, "F*sin(6*t)", 0]}
solve: {analysis: transient, dt: 0.02, t_end: 0.2, adaptive: true, error_tol: 3.0e-3, sensitivities: [k, F]}
output:
  every: 0.02
  probes:
    tip_y: {point: tip, quantity: position, component: y}
"""

#: the same arm on fixed steps, a PD controller on its tip's sag driving the load
CONTROLLED_ARM = """
title: a flexible arm on a hinge, a PD controller on its tip's sag, fixed steps
parameters: {k: 2.0, EI: 20.0, Kp: 1.0}
sections:
  s: {EA: 1.0e4, EIy: EI, EIz: EI, GJ: 10.0, rhoA: 0.5, rhoIy: 0.0005, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0, 0], mass: 0.3, inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: base, to: tip, section: s, elements: 2, start: {hinge: {axis: [0, 0, 1], stiffness: k}}}
controllers:
  pd: {output: "-Kp*tip_y"}
loads:
  - {at: tip, force: [0, "0.4 + pd", 0]}
solve: {analysis: transient, dt: 0.02, t_end: 0.2, sensitivities: [k, Kp]}
output:
  every: 0.02
  probes:
    tip_y: {point: tip, quantity: position, component: y}
"""


def _study(tmp_path: Path, scene: str, name: str, values: list) -> Path:
    (tmp_path / "scene.yaml").write_text(scene)
    study = {"title": f"the arm's {name}", "scene": "scene.yaml", "vary": {f"parameters.{name}": values},
             "reference": {"overrides": {f"parameters.{name}": values[0]}},
             "error": {"probe": "tip_y", "norm": "final"}}
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(study, sort_keys=False))
    return path


def _rows(folder: Path) -> list[dict]:
    with open(folder / "study.csv", newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize("scene, name", [(ADAPTIVE_ARM, "F"), (CONTROLLED_ARM, "Kp")], ids=["adaptive", "controller"])
def test_the_scene_alone_solves_with_its_sensitivities(tmp_path, scene, name):
    """The premise: ``latdyn run`` of each scene exits 0, sensitivities.csv beside probes.csv."""
    run, out = latdyn_run(tmp_path, scene, quiet=True)
    assert run.returncode == 0, run.stderr
    assert summary_of(out)["status"] == "solved" and (out / "sensitivities.csv").exists()


@pytest.mark.parametrize("scene, name", [(ADAPTIVE_ARM, "F"), (CONTROLLED_ARM, "Kp")], ids=["adaptive", "controller"])
def test_a_study_of_a_scene_with_sensitivities_solves_its_cases(tmp_path, scene, name):
    """``latdyn study`` varying one parameter of a scene that solves alone with its sensitivities: every case
    solved, its sensitivities.csv beside its probes. On 86d57d9 every case is ``failed``: "refused: …:
    solve.sensitivities: probe '_study_W' (energy external_work): the external work of an adaptive run with
    loads[0] … / with controllers is not differentiated yet"."""
    values = [float(yaml.safe_load(scene)["parameters"][name]), 2.0 * float(yaml.safe_load(scene)["parameters"][name])]
    path = _study(tmp_path, scene, name, values)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    run = subprocess.run([sys.executable, "-m", "latdyn", "study", str(path), "-o", str(tmp_path / "cli")],
                         env=env, capture_output=True, text=True, cwd=tmp_path, timeout=300, check=False)
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr
    rows = _rows(tmp_path / "cli")
    assert [r["status"] for r in rows] == ["solved", "solved"], [r["message"][:200] for r in rows]
    table = latdyn.study(str(path), out=str(tmp_path / "api"))
    assert list(table["status"]) == ["solved", "solved"]


#: a shallow toggle of two beams in 3D (rise 0.08 over half-spans 1, the top pushed down and a little sideways),
#: beyond its limit load: arc length follows the snap-through to λ = 1 on the far branch
TOGGLE = """
title: a shallow 3D toggle through its limit point, arc length
parameters: {EI: 1.0, EA0: 50000.0, P: 1.0}
sections:
  s: {EA: EA0, EIy: EI, EIz: EI, GJ: 0.8*EI, rhoA: 0.1}
bodies:
  a: {at: [-1.0, 0.0, 0.0], fixed: true}
  b: {at: [1.0, 0.0, 0.0], fixed: true}
  top: {at: [0.0, 0.0, 0.08]}
beams:
  left: {from: a, to: top, section: s, elements: 3, y_axis: [0.0, 0.0, 1.0]}
  right: {from: b, to: top, section: s, elements: 3, y_axis: [0.0, 0.0, 1.0]}
loads:
  - {at: top, force: [0, 0.01, "-25.0*P"]}
solve: {analysis: static, method: arc-length, steps: 8, max_steps: 300, sensitivities: [EA0, P]}
output:
  probes:
    top_z: {point: top, quantity: displacement, component: z}
"""


@pytest.mark.parametrize("method", ["arc-length", "displacement-control"])
def test_the_load_factors_sensitivity_along_the_path_is_written_and_loaded(tmp_path, method):
    """``latdyn run`` writes ``load_factor/NAME`` beside the probes' columns of sensitivities.csv, and
    ``Result.load`` of the folder gives the API's ``result.sensitivities[("load_factor", NAME)]``, bit for bit, every
    row (the path passes its limit point: λ falls between rows). On 86d57d9 the columns were missing."""
    text = TOGGLE if method == "arc-length" else TOGGLE.replace(
        "method: arc-length, steps: 8, max_steps: 300",
        "method: displacement-control, steps: 8, control: {point: top, direction: z, to: -0.12}")
    run, out = latdyn_run(tmp_path, text, quiet=True)
    assert run.returncode == 0, run.stderr
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert (result.t[1:] < result.t[:-1]).any()   # past the limit point
    with open(out / "sensitivities.csv", newline="") as f:
        header = next(csv.reader(f))
    assert [c for c in header if c.startswith("load_factor/")] == ["load_factor/EA0", "load_factor/P"]
    loaded = Result.load(out)
    for name in ("EA0", "P"):
        assert abs(result.sensitivities[("load_factor", name)]).max() > 0.0
        assert (loaded.sensitivities[("load_factor", name)] == result.sensitivities[("load_factor", name)]).all()
        assert (loaded.sensitivities[("top_z", name)] == result.sensitivities[("top_z", name)]).all()
