"""What the random whole runs of 2026-11-27 (``benchmarks/fuzz_runs.py``, ``benchmarks/fuzz_invariants.py``;
docs/verification.md, "Random whole runs judged by invariants") found, each through the front door and
failing before its mend."""
from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "tests" / "fuzz_cases"

#: a preloaded hinge spring (rest_angle 0.5) on a 3D arm under a small load: the preload turns the arm
#: by 0.5 rad, the load's first arc length (Δλ = 1/steps) is far shorter
PRELOADED_ARM = """
title: a preloaded hinge spring under a small load, by arc length
sections:
  s: {EA: 1.0e6, EIy: 200, EIz: 150, GJ: 100, rhoA: 1}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.8, 0.3, 0.4], mass: 1}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 2
    start: {hinge: {axis: [0.0, 0.6, 0.8], stiffness: 40, rest_angle: 0.5}}
loads:
  - {at: tip, force: [0, 0, -0.2]}
solve: {analysis: static, steps: 4, method: METHOD}
output:
  probes:
    angle: {hinge: arm.start, quantity: angle}
    tip_z: {point: tip, quantity: position, component: z}
"""


def _cli(scene: Path, out: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          capture_output=True, text=True, cwd=scene.parent, timeout=300)


def _rows(out: Path) -> dict[str, np.ndarray]:
    with open(out / "probes.csv", newline="", encoding="utf-8") as f:
        table = list(csv.reader(f))
    return {name: np.array([float(row[i]) for row in table[1:]]) for i, name in enumerate(table[0])}


def test_arc_length_begins_at_the_equilibrium_of_a_preloaded_start(tmp_path):
    """Arc length from a start that is no equilibrium (a preloaded hinge spring) failed at load factor 0
    ('Newton failed with arc lengths down to …') where load control solved; it now begins at the
    equilibrium at λ = 0 and ends where load control ends, through the CLI and the API."""
    import latdyn

    rows = {}
    for method in ("arc-length", "load-control"):
        scene = tmp_path / f"{method}.yaml"
        scene.write_text(PRELOADED_ARM.replace("METHOD", method), encoding="utf-8")
        done = _cli(scene, tmp_path / method)
        assert done.returncode == 0, done.stderr
        rows[method] = _rows(tmp_path / method)
    arc, load = rows["arc-length"], rows["load-control"]
    assert arc["load_factor"][-1] == 1.0 and len(arc["load_factor"]) >= 4
    for probe in ("angle", "tip_z"):
        assert abs(arc[probe][-1] - load[probe][-1]) < 1e-10, probe
    # every row past the first is on the path: near the preload's equilibrium (0.5 rad), not the start
    assert np.all(np.abs(arc["angle"][1:] - 0.5) < 0.01), arc["angle"]
    result = latdyn.run(latdyn.load_scene(str(tmp_path / "arc-length.yaml")))
    assert np.array_equal(result.probes["angle"], arc["angle"])


def test_the_reduced_fuzz_case_of_a_preloaded_loop_solves_by_arc_length(tmp_path):
    scene = CASES / "arc_length_from_a_preloaded_loop.yaml"
    done = _cli(scene, tmp_path / "arc")
    assert done.returncode == 0, done.stderr
    lc = tmp_path / "load_control.yaml"
    lc.write_text(scene.read_text(encoding="utf-8").replace("method: arc-length", "method: load-control"),
                  encoding="utf-8")
    assert _cli(lc, tmp_path / "lc").returncode == 0
    arc, load = _rows(tmp_path / "arc"), _rows(tmp_path / "lc")
    assert arc["load_factor"][-1] == 1.0
    for probe in ("m2_angle", "m3_angle", "b2_x"):
        assert abs(arc[probe][-1] - load[probe][-1]) < 1e-9 * max(1.0, abs(load[probe][-1])), probe


def test_arc_length_under_loads_that_are_zero_at_t0_says_the_loads_move_nothing(tmp_path):
    """A load in t (10.24*t, in a turning hub's frame, on a 3D arm) is zero at t = 0, where a static
    analysis takes it: its round-off moved the structure by 4.4e-18, and arc length failed with 'Newton
    failed with arc lengths down to 1.08e-21'. It now says the loads move nothing and names load control."""
    import latdyn
    from latdyn.errors import SolverError

    scene = CASES / "arc_length_loads_zero_at_t0.yaml"
    done = _cli(scene, tmp_path / "out")
    assert done.returncode == 1, done.stderr
    assert "arc-length continuation cannot start: the loads move nothing" in done.stderr, done.stderr
    assert "solve.method: load-control solves it" in done.stderr and "Traceback" not in done.stderr
    try:
        latdyn.run(latdyn.load_scene(str(scene)))
    except SolverError as exc:
        assert "the loads move nothing" in str(exc)
    else:
        raise AssertionError("solved")


def test_displacement_control_from_a_preloaded_start_follows_the_path(tmp_path):
    """Displacement control of the preloaded 3D arm's tip (down by 0.05 in 4 rows, measured from the
    initial configuration) failed at its first row: 'the controlled displacement turns back at 0 (a
    snap-back …)', every first step judged off the path because it also took the preload's move. It
    now solves, each row an equilibrium: the first row's load factor, applied by load control, gives
    its state; and the start (no equilibrium) is no limit point."""
    import json

    scene = tmp_path / "dc.yaml"
    scene.write_text(PRELOADED_ARM.replace(
        "method: METHOD", "method: displacement-control, control: {point: tip, direction: z, to: -0.05}"),
        encoding="utf-8")
    done = _cli(scene, tmp_path / "dc")
    assert done.returncode == 0, done.stderr
    rows = _rows(tmp_path / "dc")
    assert np.allclose(rows["tip_z"], [0.4, 0.3875, 0.375, 0.3625, 0.35], rtol=0, atol=1e-12)
    summary = json.loads((tmp_path / "dc" / "summary.json").read_text())
    assert summary["limit_points"] == [] and not summary.get("warnings")
    lam = float(rows["load_factor"][1])
    check = tmp_path / "check.yaml"
    check.write_text(PRELOADED_ARM.replace("METHOD", "load-control").replace("steps: 4", "steps: 20").replace(
        "force: [0, 0, -0.2]", f"force: [0, 0, {-0.2 * lam!r}]"), encoding="utf-8")
    assert _cli(check, tmp_path / "check").returncode == 0
    held = _rows(tmp_path / "check")
    assert abs(held["angle"][-1] - rows["angle"][1]) < 1e-10 and abs(held["tip_z"][-1] - 0.3875) < 1e-10


def test_arc_length_with_sensitivities_from_a_preloaded_start_says_why_it_fails(tmp_path):
    """With solve.sensitivities arc length still starts from the initial configuration (its derivative
    is taken from there), and on the preloaded arm it fails there: the message says why and what
    solves it, where it said only 'Newton failed with arc lengths down to …'."""
    scene = tmp_path / "sens.yaml"
    scene.write_text("parameters: {k: 40}\n" + PRELOADED_ARM.replace("stiffness: 40", "stiffness: k").replace(
        "method: METHOD", "method: arc-length, sensitivities: [k]"), encoding="utf-8")
    done = _cli(scene, tmp_path / "out")
    assert done.returncode == 1, done.stderr
    assert "from the initial configuration, which is no equilibrium" in done.stderr, done.stderr
    assert "load control, displacement control and arc length without sensitivities solve" in done.stderr
