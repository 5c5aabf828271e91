"""The law jumps in t, mended after review (latdyn.timeloop.jumps, docs/stepping.md): each scene here
ended "solved" with a wrong answer before.

Every check is against the exact motion of the rigid arm of tests/test_law_jumps.py (J about the hinge
axis) under a torque that is constant between its jumps: θ̈ = τ(t)/J, which every integrator here
integrates exactly between jumps where the steps land on them.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns
from test_law_jumps import J_PLANAR, PLANAR, SKEW, _skew_inertia

HELD = "    rate: {hinge: arm.start, quantity: rate}\n"


def _planar(torque: str, dt: float = 0.01, method: str = "generalized-alpha", t_end: float = 0.1) -> str:
    return PLANAR.replace("DT", str(dt)).replace("METHOD", method).replace(
        '"2*Heaviside(t - 0.013)"', f'"{torque}"').replace("t_end: 0.1", f"t_end: {t_end}")


def _piecewise_constant(t, pieces, inertia):
    """θ, θ̇ under a torque τ_k from t_k on (``pieces``: (t_k, τ_k), the torque 0 before the first)."""
    t = np.asarray(t, float)
    angle, rate = np.zeros_like(t), np.zeros_like(t)
    previous = 0.0
    for t_k, torque in pieces:   # each change of torque adds a ramp of acceleration from t_k
        after = np.clip(t - t_k, 0.0, None)
        angle += (torque - previous) * after ** 2 / (2 * inertia)
        rate += (torque - previous) * after / inertia
        previous = torque
    return angle, rate


@pytest.mark.parametrize("jump", [0.05, 0.0537])
def test_a_sample_due_at_a_jump_of_a_law_is_taken_through_the_api(jump):
    """A 100 Hz controller holding t, a torque switched on at a jump: the held output is the last
    sample instant at every row (before the mend it stayed one period too long after a jump on a
    sample instant), and the arm moves exactly."""
    text = _planar(f"2*Heaviside(t - {jump})", dt=0.005) + 'controllers:\n  c: {output: "t", rate: 100}\n'
    text = text.replace(HELD, HELD + "    held: {controller: c}\n")
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    t = np.asarray(result.t)
    assert result.summary["status"] == "solved"
    np.testing.assert_allclose(result.probes["held"], np.floor(t * 100 + 1e-6) / 100, rtol=0, atol=1e-9)
    angle, rate = _piecewise_constant(t, [(jump, 2.0)], J_PLANAR)
    assert np.max(np.abs(result.probes["angle"] - angle)) < 1e-9
    assert np.max(np.abs(result.probes["rate"] - rate)) < 1e-9


def test_a_sample_due_at_a_jump_of_a_law_is_taken_through_the_cli(tmp_path):
    """The same through the CLI, dt 0.01, the jump on the sample instant 0.05."""
    text = _planar("2*Heaviside(t - 0.05)") + 'controllers:\n  c: {output: "t", rate: 100}\n'
    process, out = latdyn_run(tmp_path, text.replace(HELD, HELD + "    held: {controller: c}\n"))
    assert process.returncode == 0, process.stderr
    rows = probe_columns(out)
    np.testing.assert_allclose(rows["held"], np.floor(rows["t"] * 100 + 1e-6) / 100, rtol=0, atol=1e-9)


def test_jumps_close_together_or_on_an_oscillation_are_found():
    """Two jumps 1e-3 apart over t_end 10, a jump on an oscillation 10 times its size, a pulse inside
    one interval of the sampling: each jump found (before the mend: none of them)."""
    from latdyn.timeloop.jumps import jump_times

    def found(torque, t_end):
        return jump_times(latdyn.load_scene(yaml.safe_load(_planar(torque, t_end=t_end))), t_end)

    assert found("2*Heaviside(t - 1) + 2*Heaviside(t - 1.001)", 10) == pytest.approx([1.0, 1.001], abs=1e-12)
    assert found("100*sin(50*t) + 10*Heaviside(t - 1)", 20) == pytest.approx([1.0], abs=1e-12)
    assert found("2*Heaviside(t - 0.013) - 2*Heaviside(t - 0.01301)", 0.1) == \
        pytest.approx([0.013, 0.01301], abs=1e-15)
    assert len(found("100*sin(50*t) + Piecewise((t, t < 1), (2 - t, True))", 20)) == 0


def test_a_pulse_inside_one_sampling_interval_gives_the_exact_motion(tmp_path):
    """A torque pulse 1e-5 s long (inside one interval of the search's sampling: its net change 0,
    missed before the mend, the run stepped across it and the arm never moved), through the CLI:
    θ̇ = τ·1e-5/J after it, at every row, to the 2·JUMP_SIDE·dt = 2e-11 s of the pulse each side of
    its jumps skips (relative 2e-6 of the pulse; measured 2.0e-6)."""
    torque = "2*Heaviside(t - 0.013) - 2*Heaviside(t - 0.01301)"
    process, out = latdyn_run(tmp_path, _planar(torque))
    assert process.returncode == 0, process.stderr
    rows = probe_columns(out)
    angle, rate = _piecewise_constant(rows["t"], [(0.013, 2.0), (0.01301, 0.0)], J_PLANAR)
    assert rate[-1] == pytest.approx(2e-5 / J_PLANAR)
    assert np.max(np.abs(rows["angle"] - angle)) < 3e-6 * np.max(angle)
    assert np.max(np.abs(rows["rate"] - rate)) < 3e-6 * np.max(rate)


@pytest.mark.parametrize("torque", ["2*Heaviside(t)", "Piecewise((0, t <= 0), (2, True))"])
@pytest.mark.parametrize("method", ["newmark", "generalized-alpha"])
def test_a_law_that_jumps_at_t0_starts_from_its_value_after_the_jump(torque, method):
    """θ = t²/J exactly (τ = 2 from t = 0 on): before the mend the start took the value at 0
    (1 or 0), 3.5e-4 off at dt 0.01."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(_planar(torque, method=method))))
    angle, rate = _piecewise_constant(result.t, [(0.0, 2.0)], J_PLANAR)
    assert np.max(np.abs(result.probes["angle"] - angle)) < 1e-9
    assert np.max(np.abs(result.probes["rate"] - rate)) < 1e-9


def test_a_law_that_jumps_at_t0_on_a_skew_hinge_in_3d_through_the_cli(tmp_path):
    """Genuinely 3D (tests/test_law_jumps.py's skew arm), the Piecewise jumping at t = 0, through the CLI."""
    text = SKEW.replace("ADAPTIVE", "").replace("t < 0.0137", "t <= 0")
    process, out = latdyn_run(tmp_path, text)
    assert process.returncode == 0, process.stderr
    rows = probe_columns(out)
    angle, rate = _piecewise_constant(rows["t"], [(0.0, 3.0)], _skew_inertia())
    assert np.max(np.abs(rows["angle"] - angle)) < 1e-9
    assert np.max(np.abs(rows["rate"] - rate)) < 1e-9


@pytest.mark.parametrize("torque", ["2*Heaviside(t - 0.1)", "Piecewise((0, t < 0.1), (2, True))",
                                    "2*Heaviside(t - 0.1 + 1e-14)"])
@pytest.mark.parametrize("method", ["newmark", "generalized-alpha"])
def test_a_law_that_jumps_at_t_end_moves_nothing(torque, method):
    """A torque switched on at t_end (or 1e-14 before it) moves nothing in the run: before the mend
    the last step integrated the law after the jump (final rate 3.7e-3 with Newmark)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(_planar(torque, method=method))))
    assert result.summary["status"] == "solved"
    assert np.max(np.abs(result.probes["angle"])) == 0.0
    assert np.max(np.abs(result.probes["rate"])) == 0.0
    assert result.t[-1] == pytest.approx(0.1, abs=1e-10)


def test_a_jump_of_a_law_scaled_by_an_input_set_later_is_landed_on():
    """inputs {F: 0}, torque 2*F*Heaviside(t - 0.013), F set to 1 at t = 0.005 from Python: the steps land
    on the jump (searched with generic input values) and the arm moves exactly (before the mend the jump
    was searched at F = 0 only, not found, and the run stepped across it: 2.4e-4 rad off)."""
    text = _planar("2*F*Heaviside(t - 0.013)") + "inputs: {F: 0}\n"
    sim = latdyn.Simulation(latdyn.load_scene(yaml.safe_load(text)))
    sim.advance_to(0.005)
    sim.set_input("F", 1.0)
    sim.advance_to(0.1)
    angle, rate = _piecewise_constant([sim.t], [(0.013, 2.0)], J_PLANAR)
    probes = sim.probes()
    sim.close()
    assert abs(probes["angle"] - angle[0]) < 1e-9
    assert abs(probes["rate"] - rate[0]) < 1e-9


def test_a_jump_timed_by_an_input_is_refused_in_a_simulation():
    """Heaviside(t - T0), T0 an input: set_input could move the jump off the steps found at the start, so
    a Simulation refuses it naming the law; latdyn.run (inputs as given) lands on it exactly."""
    text = _planar("2*Heaviside(t - T0)") + "inputs: {T0: 0.013}\n"
    with pytest.raises(latdyn.SceneError, match=r"beams\.arm\.start\.hinge\.torque.*an input"):
        latdyn.Simulation(latdyn.load_scene(yaml.safe_load(text)))
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    angle, _ = _piecewise_constant(result.t, [(0.013, 2.0)], J_PLANAR)
    assert np.max(np.abs(result.probes["angle"] - angle)) < 1e-9


@pytest.mark.parametrize("scene", ["planar", "skew"])
def test_the_restart_after_a_jump_on_a_spinning_rigid_arm_is_exact(scene):
    """The arm spinning at 20 rad/s when the torque switches on: θ = ω₀t + τ(t − t₀)²/2J. Before the
    mend the restart took Newton's K, whose ω² term of the rigid link put 1.3e-5 rad into the angle at
    dt 0.01; now (rigid links only: the integrator's start, M⁻¹f) what is left is the motion the held
    state misses across the 2e-9·dt skipped at the jump, ω₀·2e-11 = 4e-10 rad (measured 4.0e-10)."""
    w0 = 20.0
    if scene == "planar":
        text, torque, t0, inertia = _planar("2*Heaviside(t - 0.013)"), 2.0, 0.013, J_PLANAR
        spin = [0.0, 0.0, w0]
    else:
        text, torque, t0, inertia = SKEW.replace("ADAPTIVE", ""), 3.0, 0.0137, _skew_inertia()
        spin = [float(w) for w in w0 * np.array([1.0, -2.0, 2.0]) / 3.0]
    text += f"initial_velocity: {{angular: {spin}}}\n"
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    angle, rate = _piecewise_constant(result.t, [(t0, torque)], inertia)
    assert result.summary["status"] == "solved"
    assert np.max(np.abs(result.probes["angle"] - (w0 * np.asarray(result.t) + angle))) < 1e-9
    assert np.max(np.abs(result.probes["rate"] - (w0 + rate))) < 1e-9
