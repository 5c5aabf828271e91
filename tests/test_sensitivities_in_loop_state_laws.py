"""Hinge laws of the state in the sensitivities' loop of steps (issue 34 item 2; latdyn/analyses/derivative_laws.py,
csrc/sensitivity_loop.c): a parameter whose derivative law names θ, θ̇ or an input (the deploying boom's torque
k (θ₀ − θ) − c θ̇ by k and c; a 3D arm's stiffness in θ, damping in θ̇, torque in θ, t and an input, its rest angle
beside a stiffness in θ) takes the loop, its law's value the compiled law's at the hinge's θ, θ̇ in C, and the
results are the per-step Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the
API and the CLI; the inputs those laws read are each run's own. Explicit time dependence beside an event (a torque
and a load of t beside the boom's latch) takes the loop too."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, latdyn_run_switched, summary_of, the_loop_off_writes_the_same
from tests.resumed_runs import resumed_inside_the_loop_is_whole
from tests.sensitivity_equality import assert_same_sensitivities
from tests.test_sensitivities_events import LATCH_3D
from tests.test_sensitivities_in_loop import ARM_3D
from tests.test_sensitivities_joint_forces import BOOM

#: the deploying boom of tests/test_sensitivities_joint_forces.py opened by a torque law of its angle and rate,
#: k (θ₀ − θ) − c θ̇, latching at π: its parameters k, c (derivatives θ₀ − θ and −θ̇) and θ₀ (the constant k)
BOOM_TORQUE = (BOOM.replace("parameters: {k: 2.0, c: 0.1}", "parameters: {k: 2.0, c: 0.1, theta0: 3.6}")
               .replace('stiffness: "k", damping: "c", rest_angle: 3.6,', 'torque: "k*(theta0 - theta) - c*theta_dot",')
               .replace("sensitivities: [k, c]", "sensitivities: [k, c, theta0]"))

#: the 3D arm of tests/test_sensitivities_in_loop.py with laws of its hinge's state and an input u: a stiffness in θ
#: (its rest angle r a parameter beside it), a damping in θ̇, a torque in θ, t and u
ARM_3D_STATE = (ARM_3D.replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}",
                               "parameters: {E: 1.0, rho: 0.5, F: 2.0, k: 30.0, c: 0.2, r: 0.1, A: 0.5}\n"
                               "inputs: {u: 0.3}")
                .replace("stiffness: 30.0, damping: 0.2}",
                         'stiffness: "k*(1 + 0.5*theta**2)", damping: "c*(1 + exp(-theta_dot**2))", rest_angle: "r", '
                         'torque: "A*u*sin(3*theta + 20*t) + 0.1*A**2*u"}')
                .replace("sensitivities: [E, rho, F]", "sensitivities: [E, k, c, r, A]"))
#: the deploying boom's design parameters k, c latching at π with a torque of t and a tip load F of t: explicit time
#: dependence beside an event (∂r/∂t δt, latdyn/analyses/transient_sensitivities.py ExplicitTime)
BOOM_IN_TIME = (BOOM.replace("parameters: {k: 2.0, c: 0.1}", "parameters: {k: 2.0, c: 0.1, F: 0.2}")
                .replace('rest_angle: 3.6,', 'rest_angle: 3.6, torque: "0.3*sin(4*t)",')
                .replace("solve: {", 'loads:\n  - {at: tip, force: ["F*cos(3*t)", "0.5*F*t", 0]}\nsolve: {')
                .replace("sensitivities: [k, c]", "sensitivities: [k, c, F]"))
#: tests/test_sensitivities_events.py's 3D wheel on a skew hinge latching at 0.5 rad with a torque and a load of t
LATCH_3D_IN_TIME = (LATCH_3D.replace("rest_angle: 1.0, lock_at", 'rest_angle: 1.0, torque: "0.05*sin(5*t)", lock_at')
                    .replace("solve: {", 'loads:\n  - {at: wheel, force: ["0.2*t", 0, "-0.1*cos(2*t)"]}\nsolve: {'))
assert "sin(4*t)" in BOOM_IN_TIME and "F*cos(3*t)" in BOOM_IN_TIME
assert "sin(5*t)" in LATCH_3D_IN_TIME and '"0.2*t"' in LATCH_3D_IN_TIME
assert "theta0: 3.6" in BOOM_TORQUE and "torque: \"k*(theta0" in BOOM_TORQUE
assert "inputs: {u: 0.3}" in ARM_3D_STATE and "exp(-theta_dot" in ARM_3D_STATE and "[E, k, c, r, A]" in ARM_3D_STATE


#: the 3D arm's hinged second beam slewed by a PD controller on its hinge's angle and rate towards a set point: the
#: gains Kp, Kd, the set point ref and a section value E as parameters; NONLINEAR: its output a sine of the error and
#: a rate's cube (its partials' C differs from NumPy's lambdas in the last bits)
ARM_PD = (ARM_3D.replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}",
                         "parameters: {E: 1.0, rho: 0.5, F: 2.0, Kp: 20.0, Kd: 1.5, ref: 0.4}")
          .replace("stiffness: 30.0, damping: 0.2}", 'stiffness: 2.0, damping: 0.2, torque: "pd"}')
          .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - angle) - Kd*omega"}\nsolve: {')
          .replace("    hinge: {hinge: b.start, quantity: angle}\n",
                   "    angle: {hinge: b.start, quantity: angle}\n    omega: {hinge: b.start, quantity: rate}\n")
          .replace("sensitivities: [E, rho, F]", "sensitivities: [E, Kp, Kd, ref]"))
ARM_PD_NONLINEAR = ARM_PD.replace('"Kp*(ref - angle) - Kd*omega"', '"Kp*sin(ref - angle) - Kd*omega*(1 + 0.1*omega**2)"')
assert "omega: {hinge" in ARM_PD and 'torque: "pd"' in ARM_PD and "[E, Kp, Kd, ref]" in ARM_PD
#: the PD output clipped to ±3 (saturated from the start, released on the way: no derivative while clipped)
ARM_PD_CLIPPED = ARM_PD.replace('"Kp*(ref - angle) - Kd*omega"}', '"Kp*(ref - angle) - Kd*omega", limits: [-3, 3]}')
assert "sin(ref - angle)" in ARM_PD_NONLINEAR and "limits: [-3, 3]" in ARM_PD_CLIPPED


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def _same(native, python) -> None:
    """The two runs' sensitivities and the summary's, to the bit; every column nonzero."""
    assert_same_sensitivities(native, python, python_path=True, nonzero="each")


@pytest.mark.parametrize("text", [BOOM_TORQUE, BOOM_IN_TIME, LATCH_3D_IN_TIME],
                         ids=["torque of the state", "laws of t, a latch", "laws of t, a latch in 3D"])
def test_the_booms_laws_of_its_state_and_of_time_beside_the_latch_take_the_loop(text, monkeypatch):
    """The boom's k, c and θ₀ through a torque k (θ₀ − θ) − c θ̇, and its k, c, F beside a torque and a load of t
    (explicit time dependence beside the latch), and the 3D wheel's beside its latch likewise: every smooth step in the loop of steps (all but the latch's and the
    landing after it), the Python path's sensitivities and event time derivative to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps = native.summary["steps"]
    assert native.summary["time_loop"] == "compiled" and steps - 3 <= native.summary["sensitivity_steps_in_loop"] < steps
    assert native.summary["event_sensitivities"][0]["kind"] == "latch"
    _same(native, python)


def test_a_3d_hinges_laws_of_its_state_and_an_input_take_the_loop(monkeypatch):
    """The 3D arm's hinge stiffness in θ (and its rest angle), damping in θ̇ and torque in θ, t and an input: every
    step in the loop, the Python path's to the bit; again with the input at another value in the same process (the
    compiled laws' library is shared: each run reads its own input), whose sensitivities differ."""
    native, python = _run(ARM_3D_STATE, monkeypatch, True), _run(ARM_3D_STATE, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] > 0
    _same(native, python)
    other = ARM_3D_STATE.replace("inputs: {u: 0.3}", "inputs: {u: 0.7}")
    moved, moved_python = _run(other, monkeypatch, True), _run(other, monkeypatch, False)
    assert moved.summary["sensitivity_steps_in_loop"] == moved.summary["steps"]
    _same(moved, moved_python)
    assert not np.array_equal(moved.sensitivities[("tip_z", "A")], native.sensitivities[("tip_z", "A")])


def test_the_cli_writes_the_python_paths_files_for_the_booms_torque(tmp_path):
    """``latdyn run`` on the boom with its torque of θ and θ̇ takes the loop; the same command with the switch off
    (a process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's
    sensitivities."""
    completed, out = latdyn_run(tmp_path, BOOM_TORQUE)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] > 270
    the_loop_off_writes_the_same(tmp_path, out)


def test_derivative_laws_that_do_not_compile_keep_the_run_on_the_python_path(monkeypatch):
    """Where the derivative laws of the state do not compile (no compiler, a construct the C printer cannot write)
    the whole run takes the Python path, its laws' NumPy values."""
    from latdyn.assembly import compiled_laws

    def unavailable(*args, **kwargs):
        raise compiled_laws.LawsUnavailable("no compiler for the laws (test)")

    monkeypatch.setattr(compiled_laws, "compile_laws", unavailable)
    result = _run(BOOM_TORQUE, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == 0 and result.summary["time_loop"] == "python"
    assert np.abs(result.sensitivities[("knee_y", "k")]).max() > 0.0


def test_a_run_interrupted_inside_the_loop_resumes_to_the_same_files(tmp_path, monkeypatch):
    """The boom with its torque of the state, interrupted (Ctrl-C) as a loop of steps starts at t ≥ 0.2 and resumed
    from its checkpoint: the uninterrupted run's files, byte for byte (the derivative laws compiled again)."""
    resumed_inside_the_loop_is_whole(yaml.safe_load(BOOM_TORQUE), tmp_path, monkeypatch, 0.2)


@pytest.mark.parametrize("text", [ARM_PD, ARM_PD_NONLINEAR, ARM_PD_CLIPPED], ids=["PD", "nonlinear PD", "clipped PD"])
def test_a_pd_controlled_3d_arm_takes_the_loop(text, monkeypatch):
    """The 3D arm slewed by a PD controller (its gains, its set point and a section value as parameters): every step in
    the loop of steps (the controller's ∂f/∂p compiled, at the hinge's angle and rate in C), the Python path's
    sensitivities to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] > 0
    _same(native, python)


def test_the_cli_writes_the_python_paths_files_for_the_pd_controlled_arm(tmp_path):
    """``latdyn run`` on the PD-controlled 3D arm over 0.3 s takes the loop; with the switch off (a process of its own)
    the same sensitivities.csv and probes.csv, byte for byte, and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, ARM_PD.replace("t_end: 0.06", "t_end: 0.3"))
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] == summary["steps"] == 60
    reference = tmp_path / "python"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", reference,
                              "import latdyn.analyses.sensitivities_in_loop as loop; loop.SENSITIVITIES_IN_LOOP = False")
    assert run.returncode == 0, run.stderr
    for name in ("sensitivities.csv", "probes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    assert summary["probe_sensitivities"] == summary_of(reference)["probe_sensitivities"]


def test_a_controller_reading_an_input_takes_the_loop(monkeypatch):
    """The PD arm whose controller reads an input besides its hinge takes every step in the loop (the input's value
    from the scene's inputs' array: tests/test_sensitivities_in_loop_controller_reads.py), the Python path's bits."""
    reading = ARM_PD.replace('"Kp*(ref - angle) - Kd*omega"}', '"Kp*(ref - angle) - Kd*omega - 0.5*u"}').replace(
        "parameters: {", "inputs: {u: 0.2}\nparameters: {")
    assert "0.5*u" in reading and "inputs: {u: 0.2}" in reading
    native, python = _run(reading, monkeypatch, True), _run(reading, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] > 0
    _same(native, python)
