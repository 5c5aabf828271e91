"""Stepping a transient run from Python (``latdyn.Simulation``) and its FMU (``latdyn fmu``): SCENE.md,
"Stepping from Python" and "``latdyn fmu SCENE -o FILE.fmu``"; docs/stepping.md.

References: one ``latdyn run`` of the same scene (a run paused on the steps it takes is that run, to
round-off: bit for bit here), the exact discrete-time solution of a sampled PD loop on a rigid hub
(tests/test_stepping.py::test_a_python_pd_at_100_hz_follows_the_exact_discrete_time_solution), and
FMPy simulating the FMU against both. Scenes are YAML text as a user types it."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import latdyn
from cli_runs import ROOT, probe_columns, summary_of
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
#: lower link that latches (after tests/test_runs_end.py's deploying arm): steps shortened onto the
#: latch (t ≈ 0.29) and the stop (t ≈ 0.34), taken from Python.
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
                  limits: [-0.28, 0.4], restitution: 0.3}
      lower:
        from: elbow
        to: tip
        section: arm
        rigid: true
        start:
          hinge: {axis: [0, 0, 1], stiffness: 5, rest_angle: 1.5, lock_at: 0.6}
    solve: {analysis: transient, t_end: 0.4, dt: 0.005}
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
    (ARM_3D.replace("dt: 0.005}", "dt: 0.01, adaptive: true}"), [0.02 * k for k in range(1, 16)]),
    (DEPLOYING_ARM, [0.02 * k for k in range(1, 21)]),  # through the latch and the stop
], ids=["3d-every-row", "3d-uneven", "3d-adaptive", "planar-events"])
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


# ----------------------------------------------------------------------------- a controller in Python
def hub_scene(planar: bool, dt: float) -> str:
    """A rigid rod (rhoA 3, length 1) on a hinge driven by the input ``u``: about a tilted axis
    [1, 2, 2]/3 (3D; inertia about the axis rhoA L³/3 · |d × n|² = 8/9) or about z (planar; 1)."""
    axis = "[0, 0, 1]" if planar else "[1, 2, 2]"
    return f"""\
    title: rigid hub slewed by a PD loop written in Python
    inputs: {{u: 0.0}}
    sections:
      rod: {{EA: 1.0e9, EIy: 1.0e6, EIz: 1.0e6, GJ: 1.0e6, rhoA: 3.0}}
    bodies:
      base: {{at: [0.3, -0.2, 0.5], fixed: true}}
    beams:
      hub:
        from: base
        to: [1.3, -0.2, 0.5]
        section: rod
        rigid: true
        start: {{hinge: {{axis: {axis}, torque: u}}}}
    solve: {{t_end: 1.0, dt: {dt}, tol: 1.0e-12}}
    output:
      every: 0.01
      probes:
        angle: {{hinge: hub.start, quantity: angle}}
        rate: {{hinge: hub.start, quantity: rate}}
    """


@pytest.mark.parametrize("planar, dt", [(False, 0.01), (True, 0.0025)], ids=["3d-one-step", "planar-four-steps"])
def test_a_python_pd_at_100_hz_follows_the_exact_discrete_time_solution(tmp_path, planar, dt):
    """u_k = −Kp (θ_k − 1) − Kd θ̇_k from the probes every T = 0.01 s, held between samples
    (set_input, advance_to): the hub I θ̈ = u is a double integrator, whose exact zero-order-hold
    discretization is x_{k+1} = Φ x_k + Γ u_k, Φ = [[1, T], [0, 1]], Γ = [T²/2I, T/I]. The input's
    jump restarts the integrator from consistent accelerations, and generalized-α integrates a
    constant acceleration exactly: measured 1.3e-15 rad (3D, one step a sample) and 1.8e-15 (planar,
    four steps a sample, the compiled loop between samples) over 100 samples; energy_balance_error
    8.7e-16 and 2.7e-15. (Without the restart the error was 0.079 rad.)"""
    inertia = 1.0 if planar else 8.0 / 9.0
    T, omega, zeta = 0.01, 4.0, 0.7
    kp, kd = inertia * omega ** 2, 2 * zeta * omega * inertia
    phi, gamma = np.array([[1.0, T], [0.0, 1.0]]), np.array([T * T / (2 * inertia), T / inertia])
    sim = latdyn.Simulation(str(scene_file(tmp_path, hub_scene(planar, dt))), out_dir=tmp_path / "out")
    exact, errors = np.zeros(2), []
    for k in range(100):
        measured = sim.probes()
        errors.append(max(abs(measured["angle"] - exact[0]), abs(measured["rate"] - exact[1])))
        sim.set_input("u", -kp * (measured["angle"] - 1.0) - kd * measured["rate"])
        exact = phi @ exact + gamma * (-kp * (exact[0] - 1.0) - kd * exact[1])
        sim.advance_to((k + 1) * T)
    errors.append(max(abs(sim.probes()["angle"] - exact[0]), abs(sim.probes()["rate"] - exact[1])))
    result = sim.close()
    assert max(errors) < 1e-12
    assert exact[0] > 0.8  # the slew happened
    assert result.summary["status"] == "solved" and len(result.t) == 101
    assert summary_of(tmp_path / "out")["energy_balance_error"] < 1e-12  # the work of the jumping torque counted


def test_an_input_is_held_until_set_and_a_bad_name_or_value_is_refused(tmp_path):
    """Never set, the input keeps the scene's value: the run equals ``latdyn run`` bit for bit. The
    loaded scene given to a Simulation keeps its own inputs."""
    text = hub_scene(False, 0.01).replace("inputs: {u: 0.0}", "inputs: {u: 0.25}")
    path = scene_file(tmp_path, text)
    scene = latdyn.load_scene(str(path))
    reference = latdyn.run(scene)
    sim = latdyn.Simulation(scene)
    assert sim.input_names == ["u"] and sim.inputs() == {"u": 0.25}
    with pytest.raises(ValueError, match=r"no input named 'v'; its inputs: u"):
        sim.set_input("v", 1.0)
    for bad in (float("inf"), "fast", None, True):
        with pytest.raises(ValueError, match=r"input 'u' takes a finite number"):
            sim.set_input("u", bad)
    for k in range(1, 11):
        sim.advance_to(0.1 * k)
    assert np.array_equal(rows_of(sim.close()), rows_of(reference))
    sim = latdyn.Simulation(scene)
    sim.set_input("u", -1.0)
    assert sim.inputs() == {"u": -1.0} and scene.inputs.current() == {"u": 0.25}


# ----------------------------------------------------------------------------- the FMU
ARM_3D_WITH_INPUT = ARM_3D.replace('torque: "2*sin(3*t)"', 'torque: "2*sin(3*t) + u"').replace(
    "    gravity:", "    inputs: {u: 0.0}\n    gravity:")


def relative_difference(ours, reference) -> float:
    """max |ours − reference| over the rows, relative to the largest |reference|, worst probe."""
    return max(float(np.max(np.abs(np.asarray(ours[name]) - np.asarray(reference[name]))))
               / max(float(np.max(np.abs(reference[name]))), 1e-300) for name in reference)


def test_the_fmu_under_fmpy_gives_latdyn_runs_probes_and_follows_its_input_as_the_simulation_does(tmp_path):
    """``latdyn fmu`` through the front door; FMPy simulates it (default experiment: 0 … t_end,
    communication every ``output.every``). Inputs at their start values: the probes of ``latdyn run``
    (its probes.csv) — measured equal bit for bit (contract: 1e-8 relative). A step of the input at t = 0.1234
    (off the step grid: FMPy makes it a communication point): the probes of a Simulation set and
    advanced at the same communication points — measured equal bit for bit."""
    fmpy = pytest.importorskip("fmpy")
    path = scene_file(tmp_path, ARM_3D_WITH_INPUT)
    built = cli("fmu", path, "-o", tmp_path / "arm.fmu", cwd=tmp_path)
    assert built.returncode == 0, built.stderr
    assert "FMI 2.0 co-simulation" in built.stdout and "Python with latdyn" in built.stdout
    description = fmpy.read_model_description(str(tmp_path / "arm.fmu"))
    variables = {v.name: v for v in description.modelVariables}
    assert variables["u"].causality == "input" and float(variables["u"].start) == 0.0
    assert [v.name for v in description.outputs and [o.variable for o in description.outputs]] == \
        ["angle", "tip_z", "tip_v", "bending", "total"]
    assert description.defaultExperiment.stopTime == "0.3" and description.defaultExperiment.stepSize == "0.01"

    assert latdyn.run(str(path), out_dir=tmp_path / "ref").summary["status"] == "solved"
    reference = probe_columns(tmp_path / "ref")
    fmu = fmpy.simulate_fmu(str(tmp_path / "arm.fmu"))
    assert np.allclose(fmu["time"], reference["t"], rtol=0, atol=1e-12)
    assert relative_difference(fmu, {k: v for k, v in reference.items() if k != "t"}) <= 1e-8

    signal = np.array([(0.0, 0.0), (0.1234, 0.0), (0.1234, 1.5), (0.3, 1.5)], dtype=[("time", float), ("u", float)])
    driven = fmpy.simulate_fmu(str(tmp_path / "arm.fmu"), input=signal)
    assert 0.1234 in driven["time"] and len(driven) == len(fmu) + 1
    sim = latdyn.Simulation(str(path))
    replay = {name: [value] for name, value in sim.probes().items()}
    for before, t in zip(driven["time"][:-1], driven["time"][1:]):
        sim.set_input("u", 1.5 if before >= 0.1234 else 0.0)
        sim.advance_to(t)
        for name, value in sim.probes().items():
            replay[name].append(value)
    sim.close()
    assert relative_difference(driven, replay) <= 1e-8
    on_rows = np.isin(driven["time"], fmu["time"])
    assert np.max(np.abs(driven["angle"][on_rows] - fmu["angle"])) > 1e-2  # the input acted


def test_an_fmu_of_a_bad_or_not_transient_scene_is_refused_with_exit_2(tmp_path):
    bad = scene_file(tmp_path, ARM_3D.replace("section: rod", "section: tube"), "bad.yaml")
    completed = cli("fmu", bad, "-o", tmp_path / "bad.fmu", cwd=tmp_path)
    assert completed.returncode == 2 and "bad.yaml: beams.arm.section" in completed.stderr
    assert "Traceback" not in completed.stderr and not (tmp_path / "bad.fmu").exists()
    modal = scene_file(tmp_path, ARM_3D.replace("solve: {t_end: 0.3, dt: 0.005}", "solve: {analysis: modes}"),
                       "modal.yaml")
    completed = cli("fmu", modal, cwd=tmp_path)
    assert completed.returncode == 2 and "modal.yaml: solve.analysis: expected transient" in completed.stderr
    completed = cli("fmu", scene_file(tmp_path, ARM_3D), "-o", tmp_path / "arm.zip", cwd=tmp_path)
    assert completed.returncode == 2 and "arm.zip: an FMU file name ends in .fmu" in completed.stderr


def test_an_fmu_asked_to_go_past_t_end_fails_loudly(tmp_path):
    """A communication step the run cannot take (past ``solve.t_end`` here; a solver failure alike)
    is logged with status error, naming what was wrong, and ends the FMU with fmi2Fatal (an
    exception is the only failure PythonFMU's slave can report besides fmi2Discard, which FMPy
    takes as a quiet early stop): FMPy raises. Another FMU in the same process runs after it."""
    fmpy = pytest.importorskip("fmpy")
    from latdyn.stepping.fmu import build_fmu

    fmu = build_fmu(scene_file(tmp_path, ARM_3D), tmp_path / "arm.fmu")
    logged = []
    with pytest.raises(Exception, match="fmi2DoStep failed"):
        fmpy.simulate_fmu(str(fmu), stop_time=0.35, debug_logging=True,
                          logger=lambda env, instance, status, category, message: logged.append(message.decode()))
    assert any("advance_to(0.31): past solve.t_end = 0.3" in message for message in logged)
    assert len(fmpy.simulate_fmu(str(fmu))) == 31


def test_a_step_that_fails_raises_finishes_the_folder_as_failed_and_ends_the_simulation(tmp_path):
    """θ̈ ∝ 1 + θ̇² blows up in finite time (tests/test_runs_end.py): ``advance_to`` raises the
    SolverError ``latdyn.run`` raises; the folder says failed with the last converged state as a row;
    ``close()`` returns that Result and the simulation refuses to go on, saying why."""
    from test_runs_end import DEPLOYING_ARM as FLEXIBLE_ARMS

    text = FLEXIBLE_ARMS.replace('stiffness: 20, rest_angle: 1.0, damping: "0.05*theta_dot**2"',
                                 'torque: "20*(1 + theta_dot**2)", damping: "0.1/(1 + theta_dot**2)"')
    text = text.replace("limits: [-0.3, 0.4]", "limits: [-0.5, 100]").replace("dt_min: 2.0e-4", "dt_min: 1.0e-5")
    sim = latdyn.Simulation(str(scene_file(tmp_path, text)), out_dir=tmp_path / "out")
    with pytest.raises(latdyn.SolverError, match="minimum step"):
        sim.advance_to(1.0)
    failed_at = sim.t
    written = summary_of(tmp_path / "out")
    assert written["status"] == "failed" and "minimum step" in written["error"]
    result = sim.close()
    assert result.summary["status"] == "failed" and result.t[-1] == failed_at > 0
    assert probe_columns(tmp_path / "out")["t"][-1] == failed_at
    with pytest.raises(SimulationClosed, match="its run failed: SolverError"):
        sim.advance_to(1.0)


@pytest.mark.parametrize("planar", [False, True], ids=["3d", "planar"])
def test_a_python_pd_at_100_hz_equals_the_scenes_sampled_controller_at_rate_100(tmp_path, planar):
    """The same PD written as a sampled controller of the scene (``rate: 100``, read by the hinge
    torque) and run by ``latdyn run`` (CLI), against the Python loop through ``set_input``: every
    row (every 0.01 s, at the sample instants) equal to round-off, measured (the sample compiled,
    csrc/sampling.c): angle 2.2e-16 rad (3D) and 6.9e-18 (planar), rate 4.4e-16 and 2.2e-16 rad/s."""
    inertia = 1.0 if planar else 8.0 / 9.0
    kp, kd = inertia * 16.0, 2 * 0.7 * 4.0 * inertia
    text = hub_scene(planar, 0.01)
    controlled = text.replace("    inputs: {u: 0.0}\n", "").replace("torque: u", "torque: pd").replace(
        "    output:\n", f'    controllers:\n      pd: {{output: "-{kp!r}*(angle - 1) - {kd!r}*rate", rate: 100}}\n'
                         "    output:\n")
    completed = cli("run", scene_file(tmp_path, controlled, "controlled.yaml"), "-o", tmp_path / "ref", "-q",
                    cwd=tmp_path)
    assert completed.returncode == 0, completed.stderr
    reference = probe_columns(tmp_path / "ref")
    sim = latdyn.Simulation(str(scene_file(tmp_path, text)))
    for k in range(100):
        measured = sim.probes()
        sim.set_input("u", -kp * (measured["angle"] - 1.0) - kd * measured["rate"])
        sim.advance_to((k + 1) * 0.01)
    result = sim.close()
    assert np.allclose(result.t, reference["t"], rtol=0, atol=1e-12)
    for name in ("angle", "rate"):
        assert np.max(np.abs(result.probes[name] - reference[name])) < 1e-12, name
    assert reference["angle"][-1] > 0.8  # the slew happened
