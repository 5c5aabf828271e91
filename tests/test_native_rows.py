"""Rows where the step runs (csrc/rows.c, latdyn.step.compiled.RowBuffers, latdyn.timeloop.loop
TimeLoop._record_rows): the loop of steps in C records the rows on its way (state, energies, momenta,
section forces) and Python takes them a block at a time.

References: a free beam in rigid translation under gravity, whose probes are closed-form (every node
moves with v0 + g t, which generalized-α integrates exactly from consistent accelerations: positions,
velocities, momenta, energies to round-off; section forces zero); and the same run with a row at a
time (``latdyn.timeloop.loop.NATIVE_ROWS = False``, rows recorded from Python after each call into C),
which the rows recorded in C must equal byte for byte (probes.csv, state.h5, summary.json but its
timings), on a 3D and a planar beam driven by a hub, a hinge hitting a stop, a joint's torque
through a latch and resting on a stop (latdyn_joint_forces, the one evaluation of the joint probes and
joint_peaks, in the row and in Python alike), a mass dropped on a slack cable (its tension and length
in the row), blocks cut by a small buffer and by the wall-time budget, and a run whose energy
balance breaks. Before their events the joint probes give their laws exactly (a free joint applies its
law: the constant torque, the spring's k (θ_r − θ)) and the cable its closed-form drop
(tests/test_cables.py check_drop).
"""
from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

import latdyn
import latdyn.step.compiled as compiled_module
import latdyn.timeloop.loop as loop_module
import latdyn.timeloop.transient as transient_module
from latdyn.errors import UnboundedError
from latdyn.model.kernels import load_kernels
from latdyn.scene.loader import _yaml_loader
from latdyn.timeloop.loop import TimeLoop

from cli_runs import latdyn_run, probe_columns, summary_of
from test_cables import check_drop, drop_scene
from test_hinges import stop_scene
from test_runtime import hinged_flap
from test_planar import chain_scene, rotated

try:
    load_kernels("c", "default")
    HAVE_C = True
except RuntimeError:
    HAVE_C = False

pytestmark = pytest.mark.skipif(not HAVE_C, reason="no C compiler: the compiled step needs one")

TIMINGS = ("wall_time_s", "solver_s", "compile_s")

#: a free beam (no support) of mass RHO_A·LENGTH, in rigid translation with V0 under gravity G
RHO_A, LENGTH = 1.5, 2.0
FREE_BEAM = """\
title: free beam in rigid translation
sections:
  bar: {EA: 1.0e7, EIy: 2.0e3, EIz: 1.0e3, GJ: 1.5e3, rhoA: 1.5, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
beams:
  bar: {from: [0, 0, 0], to: [2, 0, 0], section: bar, elements: 4}
gravity: GRAVITY
initial_velocity: {linear: VELOCITY}
solve: {analysis: transient, t_end: 0.2, dt: 0.01}
output:
  probes:
    tip_x: {point: bar.end, quantity: position, component: x}
    tip_y: {point: bar.end, quantity: position, component: y}
    tip_z: {point: bar.end, quantity: position, component: z}
    tip_vz: {point: bar.end, quantity: velocity, component: z}
    tip_speed: {point: bar.end, quantity: velocity, component: norm}
    tip_dx: {point: bar.end, quantity: displacement, component: x}
    kinetic: {energy: kinetic}
    strain: {energy: strain}
    potential: {energy: potential}
    work: {energy: external_work}
    total: {energy: total}
    Px: {momentum: linear, component: x}
    Py: {momentum: linear, component: y}
    Pz: {momentum: linear, component: z}
    Hx: {momentum: angular, component: x}
    Hy: {momentum: angular, component: y}
    Hz: {momentum: angular, component: z}
    N1: {element: "bar.element[1]", quantity: axial_force}
    My1: {element: "bar.element[1]", quantity: moment_y}
"""

#: a beam driven by a hub that turns about a tilted axis, gravity across it: every probe kind the
#: rows in C hold (points in global and hub axes, energies, momenta, section forces)
DRIVEN_BEAM = """\
title: driven beam
sections:
  arm: {EA: 2.8e7, EIy: 1.4e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.2}
bodies:
  hub:
    at: [0, 0, 0]
    motion: {rotation: {axis: AXIS, angle: "0.5*t**2"}}
beams:
  arm: {from: hub, to: [10, 0, 0], section: arm, elements: 8}
gravity: GRAVITY
solve: {analysis: transient, t_end: 0.3, dt: 0.005}
output:
EVERY  probes:
    tip_x: {point: arm.end, quantity: position, component: x}
    tip_dz: {point: arm.end, quantity: displacement, frame: hub, component: y}
    tip_v: {point: arm.end, quantity: velocity, frame: hub, component: norm}
    tip_vy: {point: arm.end, quantity: velocity, component: y}
    kinetic: {energy: kinetic}
    strain: {energy: strain}
    work: {energy: external_work}
    total: {energy: total}
    N0: {element: "arm.element[0]", quantity: axial_force}
    M0: {element: "arm.element[0]", quantity: moment_z}
    T0: {element: "arm.element[0]", quantity: torque}
    Px: {momentum: linear, component: x}
    Hz: {momentum: angular, component: z}
"""


def driven_beam(planar: bool, every: float | None = None) -> str:
    axis, gravity = ("[0, 0, 1]", "[0, -9.81, 0]") if planar else ("[0, 1, 1]", "[0, 0, -9.81]")
    return (DRIVEN_BEAM.replace("AXIS", axis).replace("GRAVITY", gravity)
            .replace("EVERY", f"  every: {every}\n" if every else ""))


def free_beam(planar: bool) -> str:
    velocity, gravity = ("[1.0, 2.0, 0.0]", "[0, -9.81, 0]") if planar else ("[1.0, -0.5, 2.0]", "[0, 0, -9.81]")
    return FREE_BEAM.replace("VELOCITY", velocity).replace("GRAVITY", gravity)


@pytest.fixture
def blocks(monkeypatch):
    """The rows each block recorded in C held, run after run (the rows one by one record none)."""
    seen = []
    original = TimeLoop._record_rows

    def counted(self, block):
        seen.append(len(block))
        return original(self, block)

    monkeypatch.setattr(TimeLoop, "_record_rows", counted)
    return seen


def _rows_one_by_one(monkeypatch, native: bool) -> None:
    monkeypatch.setattr(loop_module, "NATIVE_ROWS", native)


def _same_datasets(a: Path, b: Path) -> None:
    """Every dataset of two HDF5 files equal, NaN where NaN."""
    with h5py.File(a) as fa, h5py.File(b) as fb:
        names, other = [], []
        fa.visit(lambda name: names.append(name) if isinstance(fa[name], h5py.Dataset) else None)
        fb.visit(lambda name: other.append(name) if isinstance(fb[name], h5py.Dataset) else None)
        assert names and names == other
        for name in names:
            x, y = fa[name][()], fb[name][()]
            assert x.shape == y.shape and (np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f"
                                           else np.array_equal(x, y)), name


def _same_files(a: Path, b: Path) -> None:
    """probes.csv byte for byte, state.h5 and the ParaView files dataset for dataset, summary.json but
    its timings."""
    assert (a / "probes.csv").read_bytes() == (b / "probes.csv").read_bytes()
    _same_datasets(a / "state.h5", b / "state.h5")
    frames = sorted(p.name for p in (a / "paraview").glob("*.vtkhdf"))
    assert frames and frames == sorted(p.name for p in (b / "paraview").glob("*.vtkhdf"))
    for name in frames:
        _same_datasets(a / "paraview" / name, b / "paraview" / name)
    sa, sb = (json.loads((x / "summary.json").read_text()) for x in (a, b))
    assert {k: v for k, v in sa.items() if k not in TIMINGS} == {k: v for k, v in sb.items() if k not in TIMINGS}


@pytest.mark.parametrize("planar", [False, True])
def test_a_free_beam_in_rigid_translation_gives_its_closed_form_rows(planar, tmp_path, blocks):
    """x(t) = x0 + v0 t + ½ g t², v = v0 + g t on every node; P = m v, H = m x_c × v, kinetic ½ m |v|²,
    potential −m g·x_c, no strain and no section force, external work 0 (gravity is a potential):
    every row but the last recorded in C (one block), each to round-off of its scale."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(free_beam(planar))), tmp_path / "out")
    p, t = result.probes, np.asarray(result.t)
    assert len(t) == 21 and sum(blocks) == 19  # t = 0 and t_end are recorded from Python
    scene = yaml.safe_load(free_beam(planar))
    v0, g = np.array(scene["initial_velocity"]["linear"]), np.array(scene["gravity"])
    mass = RHO_A * LENGTH
    x_tip = np.array([LENGTH, 0, 0]) + np.outer(t, v0) + 0.5 * np.outer(t**2, g)
    x_c = np.array([LENGTH / 2, 0, 0]) + np.outer(t, v0) + 0.5 * np.outer(t**2, g)
    v = v0 + np.outer(t, g)
    for i, c in enumerate("xyz"):
        assert np.max(np.abs(p[f"tip_{c}"] - x_tip[:, i])) <= 1e-12 * LENGTH
        assert np.max(np.abs(p[f"P{c}"] - mass * v[:, i])) <= 1e-12 * mass * np.abs(v).max()
    assert np.max(np.abs(p["tip_vz"] - v[:, 2])) <= 1e-12
    assert np.max(np.abs(p["tip_speed"] - np.linalg.norm(v, axis=1))) <= 1e-12
    assert np.max(np.abs(p["tip_dx"] - v0[0] * t)) <= 1e-12
    H = mass * np.cross(x_c, v)
    for i, c in enumerate("xyz"):
        assert np.max(np.abs(p[f"H{c}"] - H[:, i])) <= 1e-12 * mass * LENGTH * np.abs(v).max()
    kinetic = 0.5 * mass * np.sum(v * v, axis=1)
    assert np.max(np.abs(p["kinetic"] - kinetic)) <= 1e-12 * kinetic.max()
    potential = -mass * x_c @ g
    assert np.max(np.abs(p["potential"] - potential)) <= 1e-12 * mass * 9.81 * LENGTH
    assert np.max(np.abs(p["strain"])) <= 1e-20 and np.all(p["work"] == 0.0)
    assert np.max(np.abs(p["N1"])) <= 1e-6 and np.max(np.abs(p["My1"])) <= 1e-6  # round-off of EA, EI
    assert result.summary["energy_balance_error"] <= 1e-12


@pytest.mark.parametrize("planar, every, rows", [(False, None, 59), (False, 0.01, 29), (False, 0.0123, 23),
                                                (True, None, 59)])
def test_rows_recorded_in_c_equal_rows_one_by_one(planar, every, rows, tmp_path, monkeypatch, blocks):
    """A hub-driven beam, 3D and planar, a row every step, every other step, and at output times off
    the grid of steps (each the first step at or after it): the same files."""
    scene = yaml.safe_load(driven_beam(planar, every))
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
    assert sum(blocks) == rows  # all rows but t = 0 and t_end (0.0123 · 24 falls in the last step)
    _same_files(tmp_path / "True", tmp_path / "False")


def test_a_planar_chain_with_a_turned_section_gives_the_rows_one_by_one(tmp_path, monkeypatch, blocks):
    """tests/test_planar.py's chain in the y-z plane (hinges with spring, damper and torque law, a joint
    body, a follower load, the tip's section turned a quarter in the planar model): the section forces
    the rows recorded in C hold are turned back once, in the probes and the ParaView frames alike."""
    scene = rotated(chain_scene(t_end=0.1), 0)
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
    assert sum(blocks) > 10
    _same_files(tmp_path / "True", tmp_path / "False")


def test_the_shipped_slider_crank_gives_the_rows_one_by_one(tmp_path, monkeypatch, blocks):
    """examples/slider_crank.yaml (a rigid link and a guide, their dependent nodes completed in C), a row
    every step for 0.3 s: the same files."""
    text = (Path(__file__).resolve().parents[1] / "examples" / "slider_crank.yaml").read_text()
    scene = yaml.load(text, Loader=_yaml_loader())  # the loader's YAML: `rod.node[2]` unquoted
    scene["solve"]["t_end"] = 0.3
    scene["output"].pop("every", None)
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
    assert sum(blocks) == 149  # 150 steps: all rows but t = 0 and t_end
    _same_files(tmp_path / "True", tmp_path / "False")


def test_rows_recorded_in_c_as_a_user_runs_it_equal_rows_one_by_one(tmp_path, monkeypatch):
    """``python -m latdyn run`` (rows in C) against the API with a row at a time: the same files."""
    completed, out = latdyn_run(tmp_path, driven_beam(False), quiet=True)
    assert completed.returncode == 0, completed.stderr
    _rows_one_by_one(monkeypatch, False)
    latdyn.run(latdyn.load_scene(tmp_path / "scene.yaml"), tmp_path / "python")
    _same_files(out, tmp_path / "python")
    assert summary_of(out)["rows"] == len(probe_columns(out)["t"]) == 61


def test_a_hinge_hitting_its_stop_hands_the_step_back_between_rows_recorded_in_c(tmp_path, monkeypatch, blocks):
    """The pendulum of tests/test_hinges.py driven into its stop (e = 0.5): the loop returns the
    step that reaches the stop in the middle of a block; the rows before it, the joint peaks and
    the impact's dissipation are those of the rows one by one."""
    scene = stop_scene(0.5)
    scene["solve"]["t_end"] = 0.6  # the stop is reached at t ≈ 0.5 s
    scene["output"]["probes"]["torque"] = {"hinge": "arm.start", "quantity": "torque"}
    scene["output"]["probes"]["dissipated"] = {"energy": "dissipated"}
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
    assert len(blocks) > 2 and sum(blocks) > 500
    _same_files(tmp_path / "True", tmp_path / "False")
    summary = json.loads((tmp_path / "True" / "summary.json").read_text())
    assert summary["events"] and summary["joint_peaks"] and summary["dissipated_energy"] > 0


@pytest.mark.parametrize("cut", ["buffer", "budget"])
def test_blocks_cut_by_the_buffer_or_the_budget_give_the_same_rows(cut, tmp_path, monkeypatch, blocks):
    """Buffers of 3 rows (the loop stops at the row after them), or a wall-time budget that ends every
    call after one step (on a row it recorded): the same files as the rows one by one."""
    if cut == "buffer":
        monkeypatch.setattr(compiled_module, "MAX_ROWS", 3)
    else:
        monkeypatch.setattr(transient_module, "LOOP_BUDGET_S", 1e-12)
    scene = yaml.safe_load(driven_beam(False))
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
    if cut == "buffer":
        assert max(blocks) == 3 and sum(blocks) == 45  # of 60 steps, each fourth row (after a full buffer) Python's
    else:
        # one step a call: its row recorded in C is the state the call ends at, not recorded again
        assert set(blocks) == {1} and sum(blocks) == 59
    _same_files(tmp_path / "True", tmp_path / "False")


def test_a_balance_that_breaks_inside_a_block_ends_the_run_at_that_row(tmp_path, monkeypatch, blocks):
    """The balance judged broken from t = 0.12 on (TransientProgress.unbounded made so; the break of a
    real run, the right-angle cantilever at dt = 0.2 of tests/test_energy_balance.py, ends the same way,
    docs/performance.md): the row at t = 0.12 lies inside a block recorded in C; the run ends there,
    with the same message and counters as the rows one by one, and the block's later rows are not written."""
    from latdyn.timeloop.progress import TransientProgress

    balance = TransientProgress.balance

    def judged(self, t, energies, external_work):
        self.row_t = t
        return balance(self, t, energies, external_work)

    monkeypatch.setattr(TransientProgress, "balance", judged)
    monkeypatch.setattr(TransientProgress, "unbounded", property(lambda self: getattr(self, "row_t", 0.0) >= 0.12))
    scene = yaml.safe_load(driven_beam(False))
    messages = {}
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        with pytest.raises(UnboundedError) as raised:
            latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
        messages[native] = str(raised.value)
    assert messages[True] == messages[False] and "energy balance broke at t = 0.12" in messages[True]
    assert blocks == [59]  # the block held the rows up to t_end; those after the break were dropped
    _same_files(tmp_path / "True", tmp_path / "False")
    assert probe_columns(tmp_path / "True")["t"][-1] == pytest.approx(0.12)


@pytest.mark.parametrize("event", ["latch", "stop"])
def test_a_joints_torque_through_a_latch_and_resting_on_a_stop_is_recorded_in_c(event, tmp_path, monkeypatch,
                                                                                  blocks):
    """tests/test_runtime.py's flap under a constant torque 2 that latches at 0.6 rad, and
    tests/test_hinges.py's pendulum driven by a spring (k = 10, θ_r = 1) into a stop at 0.5 that it
    stays on (restitution 0): the torque probe and joint_peaks in rows recorded in C equal the rows
    one by one, byte for byte, after the event too (the latch's reaction; the stop's when the joint
    rests on it); before the event a free joint applies its law: 2 exactly, k (θ_r − θ) to round-off."""
    if event == "latch":
        scene, hinge, angle_at = hinged_flap(), "flap.start", 0.6
    else:
        scene, hinge, angle_at = stop_scene(0.0), "arm.start", 0.5
        scene["solve"]["t_end"] = 0.7  # on the stop from t ≈ 0.33 s
    scene["output"]["probes"]["torque"] = {"hinge": hinge, "quantity": "torque"}
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
    assert len(blocks) >= 2 and sum(blocks) > 100
    _same_files(tmp_path / "True", tmp_path / "False")
    probes, summary = probe_columns(tmp_path / "True"), summary_of(tmp_path / "True")
    angle, torque = probes["angle"], probes["torque"]
    hit = int(np.argmax(angle >= angle_at - 1e-6))
    assert 10 < hit < len(angle) - 10 and summary["events"]
    law = np.full(hit, 2.0) if event == "latch" else 10.0 * (1.0 - angle[:hit])
    if event == "latch":
        assert np.array_equal(torque[:hit], law)
    else:
        np.testing.assert_allclose(torque[:hit], law, rtol=1e-12, atol=0.0)
    assert not np.allclose(torque[hit + 1:], torque[hit - 1])  # past the event: the latch's or stop's reaction
    (peak,) = summary["joint_peaks"].values()
    assert abs(peak["peak"]) == pytest.approx(np.abs(torque).max(), rel=1e-12)


def test_a_mass_dropped_on_a_slack_cable_gives_its_tension_and_length_in_rows_recorded_in_c(tmp_path, monkeypatch,
                                                                                           blocks):
    """tests/test_cables.py's drop along a direction out of every coordinate plane (taut, then slack
    again): the cable's tension and length recorded in the row equal the rows one by one, byte for
    byte, and give the closed-form drop (check_drop: taut and slack times, the peak tension and
    stretch)."""
    scene = yaml.safe_load(drop_scene([1, -2, 2], 0.1, 0.8))
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
    assert len(blocks) >= 2 and sum(blocks) > 300
    _same_files(tmp_path / "True", tmp_path / "False")
    check_drop(summary_of(tmp_path / "True"), probe_columns(tmp_path / "True"), 0.8, 0.1)


def test_a_loop_call_ending_on_a_row_with_joint_forces_hands_back_its_last_newton_evaluation():
    """The row's joint forces are one more evaluation in Work; a loop call that ends on that row (its
    wall-time budget spent after one step) still hands back the last Newton evaluation (the reaction of
    the slider-crank's driven crank, the hinges' torques, the cables' work rows: what the time loop reads
    of it), as the same call without rows does."""
    from latdyn.assembly.prepare import prepare
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.step.integrators import AlphaParameters

    text = (Path(__file__).resolve().parents[1] / "examples" / "slider_crank.yaml").read_text()
    scene = yaml.load(text, Loader=_yaml_loader())
    handed_back = []
    for rows in ([1], None):
        prepared = prepare(latdyn.load_scene(scene))
        step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                        1e-8, 25, 1.0)
        state = prepared.state
        step.start(state)
        hinges = len(prepared.model.hinges)
        done = step.advance(state, grid_index=0, stop_index=10, dt=0.002, t_end=1.5, n_grid=750, power=0.0,
                            external_work=0.0, hinge_work_torque=np.zeros(hinges), hinge_damper_torque=np.zeros(hinges),
                            budget_s=1e-12, rows=rows, joints=True)
        assert done.steps == 1 and done.status == 3
        if rows:
            assert len(done.rows) == 1 and np.any(done.rows.joint_forces[0] != 0.0)
        last = step.last_evaluation
        handed_back.append((last.reaction, last.hinge_work_torque, last.hinge_damper_torque, last.cable_work))
    recorded, plain = handed_back
    assert np.any(recorded[0] != 0.0)
    for a, b in zip(recorded, plain):
        assert np.array_equal(a, b)


def _law_spring_potential(theta):
    """∫_1^θ k(s)(s − 1) ds of the spring k(s) = 10 (1 + s²) with rest angle 1, in closed form."""
    def primitive(s):
        return 10.0 * (s**4 / 4 - s**3 / 3 + s**2 / 2 - s)

    return primitive(theta) - primitive(1.0)


def test_a_hinge_spring_with_a_stiffness_law_gives_its_potential_in_rows_recorded_in_c(tmp_path, monkeypatch,
                                                                                     blocks):
    """tests/test_hinges.py's pendulum swung by a spring k(θ) = 10 (1 + θ²) with rest angle 1 from θ = 0
    (through 2 and back): its potential integrated in C (latdyn_energies, the compiled law by Gauss–
    Legendre quadrature on pieces of 0.25 rad) equals the closed form 10 (θ⁴/4 − θ³/3 + θ²/2 − θ) from 1
    to θ (to the near-rigid arm's own strain energy, 1.5e-8 of the peak), and the rows recorded in C equal
    the rows one by one, byte for byte."""
    from test_hinges import pendulum

    scene = pendulum({"stiffness": "10*(1 + theta**2)", "rest_angle": 1.0},
                     solve={"analysis": "transient", "t_end": 1.5, "dt": 5e-3})
    scene["output"]["probes"]["strain"] = {"energy": "strain"}
    for native in (True, False):
        _rows_one_by_one(monkeypatch, native)
        latdyn.run(latdyn.load_scene(scene), tmp_path / str(native))
    assert len(blocks) >= 2 and sum(blocks) > 200
    _same_files(tmp_path / "True", tmp_path / "False")
    probes = probe_columns(tmp_path / "True")
    angle = probes["angle"]
    assert angle.max() > 1.5  # past 0.25 rad from the rest angle on both sides: several pieces
    reference = _law_spring_potential(angle)
    error = np.abs(probes["strain"] - reference).max() / reference.max()
    assert error < 5e-8, error  # 1.45e-8 measured: the arm's own strain (the same with the quadrature in Python)


def test_controller_probes_are_recorded_in_c(tmp_path, monkeypatch, blocks):
    """tests/test_controllers.py's hub under a sampled PI (10 Hz, dt = 0.01: its output and state probes
    held between the samples, where the loop of steps stops), in 3D under a continuous PD (its output
    evaluated in the row, latdyn_controller_outputs_at) and tests/test_controller_states.py's low-pass
    filter state F and output of θ = c t² (continuous: the state recorded in the row as accepted): the
    rows recorded in C equal the rows one by one, byte for byte; the PI's state at each instant is the
    exact discrete-time solution's to 1e-12, the PD's output its law −40 (θ − 1) − 8 θ̇ at the row's
    angle and rate to 1e-12 of its scale, θ the exact slew to generalized-α's 3.4e-5 at h = 0.004, F its
    closed form c (t² − 2τt + 2τ²(1 − e^{−t/τ})) to the trapezoidal rule's 2.5e-6 and the filter's
    output F itself exactly."""
    from test_controller_states import D, FILTER, disturbed
    from test_controllers import CONTINUOUS_PD, GAINS, J, SAMPLED_PI, SPATIAL, discrete_pi, hub, pd_exact

    pi = hub(SAMPLED_PI, solve="{t_end: 1.0, dt: 0.01}", inputs="inputs: {kp: 6.0, kd: 2.0, ki: 1.0, ref: 1.0}",
             probes="    u: {controller: ctl}\n    Sp: {controller: ctl, state: S}")
    low_pass = disturbed(hub(FILTER, torque="0", inputs="inputs: {tau: 0.25}", axis=SPATIAL,
                             solve="{t_end: 1.0, dt: 0.01}", probes="    Fp: {controller: lp, state: F}\n"
                                                                    "    y: {controller: lp}"), SPATIAL)
    pd = hub(CONTINUOUS_PD, inputs=GAINS, axis=SPATIAL, solve="{t_end: 1.0, dt: 0.004}",
             probes="    u: {controller: ctl}")
    for name, text in (("pi", pi), ("low_pass", low_pass), ("pd", pd)):
        for native in (True, False):
            _rows_one_by_one(monkeypatch, native)
            latdyn.run(latdyn.load_scene(yaml.safe_load(text)), tmp_path / f"{name}{native}")
        _same_files(tmp_path / f"{name}True", tmp_path / f"{name}False")
    assert sum(blocks) > 400  # the runs' rows but those at the sample instants, t = 0 and t_end
    p = probe_columns(tmp_path / "piTrue")
    exact = discrete_pi(6.0, 2.0, 1.0, 1.0, 10, 10)
    for k in range(10):
        row = int(np.argmin(np.abs(p["t"] - k / 10)))
        assert abs(p["Sp"][row] - exact[k + 1, 2]) < 1e-12  # recorded at the instant, after its sample
        assert np.all(p["u"][row:row + 10] == p["u"][row])  # held to the next instant
    p = probe_columns(tmp_path / "low_passTrue")
    t, tau, c = p["t"], 0.25, D / (2 * J)
    exact = c * (t ** 2 - 2 * tau * t + 2 * tau ** 2 * (1 - np.exp(-t / tau)))
    assert np.max(np.abs(p["Fp"] - exact)) < 3e-6
    assert np.array_equal(p["y"], p["Fp"])
    p = probe_columns(tmp_path / "pdTrue")
    assert np.max(np.abs(p["u"] - (-40.0 * (p["th"] - 1.0) - 8.0 * p["om"]))) < 1e-12 * 40.0
    assert np.max(np.abs(p["th"] - pd_exact(p["t"]))) < 4e-5


#: a 3D frame of two legs joined by a beam that ends in a sprung and damped hinge at either end, spinning
#: about z: every joint free, no controller (the truss of kernel_throughput.py --whole-solver in small)
SPRUNG_FRAME = """\
title: a spinning frame with sprung hinges
sections:
  s: {EA: 2.0e6, EIy: 80.0, EIz: 120.0, GJ: 60.0, rhoA: 0.5, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
bodies:
  a: {at: [0, 0, 0], fixed: true}
  b: {at: [1, 0, 0], fixed: true}
  c: {at: [0, 0, 1], mass: 2.0, inertia: [0.01, 0.02, 0.03]}
  d: {at: [1, 0, 1], mass: 2.0, inertia: [0.01, 0.02, 0.03]}
beams:
  left: {from: a, to: c, section: s, elements: 2}
  right: {from: b, to: d, section: s, elements: 2}
  top:
    from: c
    to: d
    section: s
    elements: 2
    start: {hinge: {axis: [0, 1, 0], stiffness: 50.0, damping: 0.3}}
    end: {hinge: {axis: [0, 1, 0], stiffness: 20.0}}
initial_velocity: {angular: [0.0, 0.0, 0.5]}
solve: {analysis: transient, t_end: 0.05, dt: 0.01}
"""


def test_free_joints_forces_are_their_laws_without_an_evaluation_of_the_elements():
    """Where every joint is free and no controller runs, latdyn_joint_forces (a row's joint forces, the
    joint probes, joint_peaks) evaluates the joints' laws alone: the same values, to the bit, as the
    whole evaluation of the equations of motion sums (−f of each hinge), and k (θ_r − θ) − c θ̇ of each
    sprung and damped hinge to round-off, while the elements' blocks in Work are left untouched (the
    element kernels, most of a truss's row, not called)."""
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(yaml.load(SPRUNG_FRAME, Loader=_yaml_loader())))
    assembler, model = prepared.assembler, prepared.model
    state = prepared.state.copy()
    rng = np.random.default_rng(3)
    state.theta[:] = 0.05 * rng.standard_normal(len(state.theta))
    state.theta_dot[:] = 0.4 * rng.standard_normal(len(state.theta_dot))
    native = assembler.native()
    assembler.evaluate(state, matrices=True)
    whole = -native.buffers["joint_forces"].copy()
    native.buffers["mass"][:] = np.nan
    forces = native.joint_forces(state)
    assert np.array_equal(forces, whole) and np.all(np.isnan(native.buffers["mass"]))
    stiffness = np.array([50.0, 20.0])
    damping = np.array([0.3, 0.0])
    law = -stiffness * state.theta - damping * state.theta_dot  # rest angle 0
    assert len(model.hinges) == 2
    np.testing.assert_allclose(forces, law, rtol=1e-13, atol=1e-15)


def test_the_last_recorded_state_of_a_block_outlives_the_next_loop_call(tmp_path, monkeypatch):
    """A block's rows are written from views of the loop's buffers (not copied first); the state of its last
    row, which a checkpoint keeps (TimeLoop.last_recorded), is a copy: after the later loop calls have
    written their rows into the same buffers, each is still the state its row recorded."""
    monkeypatch.setattr(compiled_module, "MAX_ROWS", 3)
    kept = []
    original = TimeLoop._record_rows

    def recorded(self, block):
        original(self, block)
        last = block.state(len(block) - 1)
        kept.append((self.last_recorded, {name: np.array(getattr(last, name)) for name in ("x", "T", "v", "w", "a")}))

    monkeypatch.setattr(TimeLoop, "_record_rows", recorded)
    latdyn.run(latdyn.load_scene(yaml.safe_load(driven_beam(False))), tmp_path / "out")
    assert len(kept) >= 10
    for state, at_its_row in kept:
        for name, values in at_its_row.items():
            assert np.array_equal(getattr(state, name), values), name
