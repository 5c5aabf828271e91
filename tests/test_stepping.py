"""Stepping a transient run from Python (``latdyn.Simulation``) and its FMU (``latdyn fmu``): SCENE.md,
"Stepping from Python" and "``latdyn fmu SCENE -o FILE.fmu``"; docs/stepping.md.

References: one ``latdyn run`` of the same scene (a run paused on the steps it takes is that run, to
round-off: bit for bit here), the exact discrete-time solution of a sampled PD loop on a rigid hub
(tests/test_stepping.py::test_a_python_pd_at_100_hz_follows_the_exact_discrete_time_solution), and
FMPy simulating the FMU against both. Scenes are YAML text as a user types it."""
from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import latdyn
from cli_runs import ROOT, latdyn_run, probe_columns, summary_of
from latdyn.stepping.simulation import SimulationClosed

#: A flexible arm on a tilted hinge under gravity, driven by a torque in t: genuinely 3D (out of
#: plane bending and twist), compiled loop of steps between rows.
ARM_3D = """\
    title: a flexible arm on a tilted hinge
    gravity: [0, 0, -9.81]
    sections:
      rod: {EA: 1.0e7, EIy: 50.0, EIz: 80.0, GJ: 40.0, rhoA: 2.0}
    bodies:
      base: {at: [0, 0, 0], fixed: true}
      tip: {at: [0.8, 0.3, 0.2], mass: 0.3, inertia: [0.001, 0.002, 0.001]}
    beams:
      arm:
        from: base
        to: tip
        section: rod
        elements: 3
        start: {hinge: {axis: [0, 0.6, 0.8], torque: "2*sin(3*t)", damping: 0.1}}
    solve: {t_end: 0.3, dt: 0.005}
    output:
      every: 0.01
      probes:
        angle: {hinge: arm.start, quantity: angle}
        tip_z: {point: tip, quantity: position, component: z}
        tip_v: {point: tip, quantity: velocity, component: y}
        bending: {element: arm.element[0], quantity: moment_y}
        total: {energy: total}
    """

#: Planar: a flexible upper arm driven into a stop (restitution 0.3) by a preloaded spring, a rigid
#: lower link that latches (tests/test_runs_end.py's deploying arm), adaptive steps: every kind of
#: step the loop takes from Python.
DEPLOYING_ARM = """\
    title: deploying arm with stops and a latch
    gravity: [0, -9.81, 0]
    sections:
      arm: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
    bodies:
      base: {at: [0, 0, 0], fixed: true}
      elbow: {at: [1, 0, 0], mass: 0.5}
      tip: {at: [2, 0, 0], mass: 0.2}
    beams:
      upper:
        from: base
        to: elbow
        section: arm
        elements: 2
        start:
          hinge: {axis: [0, 0, 1], stiffness: 20, rest_angle: 1.0, damping: 0.05,
                  limits: [-0.3, 0.4], restitution: 0.3}
      lower:
        from: elbow
        to: tip
        section: arm
        rigid: true
        start:
          hinge: {axis: [0, 0, 1], stiffness: 5, rest_angle: 1.5, lock_at: 0.8}
    solve: {analysis: transient, t_end: 0.6, dt: 0.01, adaptive: true, dt_min: 2.0e-4}
    output:
      every: 0.02
      probes:
        upper: {hinge: upper.start, quantity: angle}
        lower: {hinge: lower.start, quantity: angle}
        kinetic: {energy: kinetic}
    """


def scene_file(tmp_path: Path, text: str, name: str = "scene.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def cli(*args, cwd: Path) -> subprocess.CompletedProcess:
    """``python -m latdyn ARGS`` in a fresh process, this checkout first on the path."""
    import os

    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "latdyn", *map(str, args)], env=env, cwd=cwd,
                          capture_output=True, text=True, timeout=180, check=False)


def rows_of(result) -> np.ndarray:
    return np.column_stack([result.t] + [np.asarray(result.probes[name]) for name in result.probes])


# ----------------------------------------------------------------------------- pieces equal one run
@pytest.mark.parametrize("text, pauses", [
    (ARM_3D, [0.01 * k for k in range(1, 31)]),  # at every row
    (ARM_3D, [0.035, 0.1, 0.105, 0.29, 0.3]),  # on grid points between rows
    (DEPLOYING_ARM, [0.02 * k for k in range(1, 31)]),  # through the stop, the latch, adaptive steps
], ids=["3d-every-row", "3d-uneven", "planar-events-adaptive"])
def test_a_run_paused_on_its_own_steps_equals_one_latdyn_run(tmp_path, text, pauses):
    """Paused on grid points, the steps, the rows, probes.csv and the probes read at each pause are
    those of one ``latdyn run`` (CLI, in its own process): measured equal bit for bit."""
    path = scene_file(tmp_path, text)
    completed = cli("run", path, "-o", tmp_path / "ref", "-q", cwd=tmp_path)
    assert completed.returncode == 0, completed.stderr
    columns = probe_columns(tmp_path / "ref")
    sim = latdyn.Simulation(latdyn.load_scene(str(path)), out_dir=tmp_path / "sim")
    assert sim.t == 0.0
    assert sim.probes() == pytest.approx({k: v[0] for k, v in columns.items() if k != "t"}, rel=0, abs=0)
    for pause in pauses:
        sim.advance_to(pause)
        assert sim.t == pytest.approx(pause, rel=1e-12)
        row = np.flatnonzero(np.isclose(columns["t"], sim.t, rtol=0, atol=1e-12))
        if row.size:  # a pause on a recorded row reads that row
            assert sim.probes() == {k: v[row[0]] for k, v in columns.items() if k != "t"}
    result = sim.close()
    assert result.summary["status"] == "solved"
    assert (tmp_path / "sim" / "probes.csv").read_bytes() == (tmp_path / "ref" / "probes.csv").read_bytes()
    ours, theirs = summary_of(tmp_path / "sim"), summary_of(tmp_path / "ref")
    for key in ("steps", "newton_iterations", "rejected_steps", "energy_balance_error", "rows", "events"):
        assert ours.get(key) == theirs.get(key), key
    assert np.array_equal(rows_of(result), np.column_stack([columns[k] for k in columns]))


def test_a_pause_between_grid_points_lands_on_it_and_the_run_goes_back_to_the_grid(tmp_path):
    """A pause off the grid shortens the step that would cross it to land on it exactly; the next
    step goes on to the next grid point and the steps after it are dt again, so the run takes one
    step more per such pause (two pauses within one grid interval included) and the rows stay where
    ``output.every`` puts them. The shorter steps cost no accuracy: against a run at dt/8, the paused
    run's largest error in each probe is that of the unpaused run (measured ratios 0.96 … 1.003;
    the errors themselves 1e-3 … 2e-2 of each probe's range at this dt)."""
    path = scene_file(tmp_path, ARM_3D)
    reference = latdyn.run(str(path))
    fine = latdyn.run(str(scene_file(tmp_path, ARM_3D.replace("dt: 0.005", "dt: 0.000625"), "fine.yaml")))
    sim = latdyn.Simulation(str(path))
    pauses = [0.0123, 0.05, 0.1777, 0.1778, 0.2501]  # four off the grid of dt = 0.005
    for pause in pauses:
        sim.advance_to(pause)
        assert sim.t == pause  # exactly
    sim.advance_to(sim.t_end)
    result = sim.close()
    assert np.array_equal(result.t, reference.t) and np.allclose(fine.t, reference.t, rtol=0, atol=1e-12)
    assert result.summary["steps"] == reference.summary["steps"] + 4
    for name, exact in fine.probes.items():
        paused = np.max(np.abs(result.probes[name] - exact))
        unpaused = np.max(np.abs(reference.probes[name] - exact))
        assert 0 < paused <= 1.05 * unpaused, name


# ----------------------------------------------------------------------------- what close() writes
def test_close_before_t_end_keeps_the_rows_so_far_and_the_state_it_stands_at(tmp_path):
    """Closed at t = 0.123 (off the rows of every 0.01): rows at 0 … 0.12, then the state at 0.123;
    summary.json says interrupted and where; a second close returns the same Result; the closed
    simulation refuses to go on, naming why."""
    path = scene_file(tmp_path, ARM_3D)
    with latdyn.Simulation(str(path), out_dir=tmp_path / "out") as sim:
        sim.advance_to(0.123)
        at_pause = sim.probes()
    result = sim.close()
    assert result is sim.close()
    assert result.t[-1] == 0.123 and len(result.t) == 14
    assert result.probes["angle"][-1] == at_pause["angle"]
    written = summary_of(tmp_path / "out")
    assert written["status"] == "interrupted" and "t = 0.123" in written["error"]
    assert probe_columns(tmp_path / "out")["t"][-1] == 0.123
    with pytest.raises(SimulationClosed, match="closed"):
        sim.advance_to(0.2)
    with pytest.raises(SimulationClosed, match="closed"):
        sim.set_input("u", 1.0)


# ----------------------------------------------------------------------------- refusals
def test_times_outside_sim_t_to_t_end_and_unknown_inputs_are_refused_clearly(tmp_path):
    path = scene_file(tmp_path, ARM_3D)
    sim = latdyn.Simulation(str(path))
    sim.advance_to(0.1)
    with pytest.raises(ValueError, match=r"at t = 0\.1 and steps only forward"):
        sim.advance_to(0.05)
    with pytest.raises(ValueError, match=r"past solve\.t_end = 0\.3"):
        sim.advance_to(0.31)
    with pytest.raises(ValueError, match="steps only forward"):
        sim.advance_to(float("nan"))
    with pytest.raises(ValueError, match="must be a number"):
        sim.advance_to("soon")
    with pytest.raises(ValueError, match=r"no input named 'thrust'.*none \(the scene has no inputs\)"):
        sim.set_input("thrust", 1.0)
    sim.advance_to(0.1 + 1e-13)  # within 1e-9 dt of sim.t: already there
    assert sim.t == pytest.approx(0.1, abs=1e-15)
    sim.advance_to(0.3 + 1e-13)  # within 1e-9 dt of t_end: t_end
    assert sim.t == 0.3
    assert sim.close().summary["status"] == "solved"


def test_a_scene_that_is_not_transient_is_refused_naming_solve_analysis(tmp_path):
    path = scene_file(tmp_path, ARM_3D.replace("solve: {t_end: 0.3, dt: 0.005}", "solve: {analysis: modes}"))
    with pytest.raises(latdyn.SceneError, match=r"scene\.yaml: solve\.analysis: expected transient"):
        latdyn.Simulation(str(path))
