"""A law that jumps in t: the steps land on the jump and the run restarts after it (latdyn.timeloop.jumps).

Found by the whole-run fuzzer's step check (``benchmarks/fuzz_runs.py --step-check``, seed 101 case 8):
a hub driven by ``18.18*Heaviside(t - 0.01)`` beside a cable that went taut at t = 1e-5 ended "solved"
with its momentum 1.2 % apart at dt, dt/2 and dt/4 (error_tol 1e-4): the steps no longer met the jump
on their grid, and where it fell inside a step changed with every step size. Each check here is
against the exact motion of a rigid arm under a constant torque switched on at t₀,
θ(t) = τ (t − t₀)² / (2 J) after t₀ (nothing before), J the arm's moment of inertia about the hinge
axis: before the mend the arm was 1.2e-4 rad off at dt = 0.01 with the jump between grid points.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns, summary_of

#: a rigid arm of length 1 (rhoA 1: J = 1/3) with a 1-kg body at its end (inertia 0.01 about
#: each axis), on a hinge about z at the fixed ground; the torque switched on at T0 (off the grid)
PLANAR = """\
sections:
  s: {EA: 1.0e6, EIy: 100, EIz: 100, GJ: 80, rhoA: 1}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  tip: {at: [1, 0, 0], mass: 1, inertia: [0.01, 0.01, 0.01]}
beams:
  arm:
    from: g
    to: tip
    section: s
    rigid: true
    start: {hinge: {axis: [0, 0, 1], torque: "2*Heaviside(t - 0.013)"}}
solve: {analysis: transient, t_end: 0.1, dt: DT, method: METHOD}
output:
  probes:
    angle: {hinge: arm.start, quantity: angle}
    rate: {hinge: arm.start, quantity: rate}
"""
J_PLANAR = 1.0 / 3.0 + 1.0 + 0.01
T0, TORQUE = 0.013, 2.0

#: genuinely 3D: the hinge axis skew, n = (1, -2, 2)/3, the arm along (2, 1, 0)/√5 (not normal to n),
#: the body's inertia a full tensor; the torque a Piecewise that jumps from 0 to 3 at 0.0137
SKEW = """\
sections:
  s: {EA: 1.0e6, EIy: 100, EIz: 100, GJ: 80, rhoA: 0.6}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.8944271909999159, 0.4472135954999579, 0], mass: 0.7, inertia: [[0.02, 0.003, 0], [0.003, 0.01, 0.002], [0, 0.002, 0.015]]}
beams:
  arm:
    from: g
    to: tip
    section: s
    rigid: true
    start: {hinge: {axis: [1, -2, 2], torque: "Piecewise((0, t < 0.0137), (3, True))"}}
solve: {analysis: transient, t_end: 0.08, dt: 0.01, method: generalized-alpha ADAPTIVE}
output:
  probes:
    angle: {hinge: arm.start, quantity: angle}
    rate: {hinge: arm.start, quantity: rate}
"""


def _skew_inertia() -> float:
    """J about the skew axis through the hinge: the rod (rhoA 0.6, length 1) and the body (mass at
    its end and its inertia tensor), each with the part of its position normal to the axis."""
    n = np.array([1.0, -2.0, 2.0]) / 3.0
    r = np.array([2.0, 1.0, 0.0]) / np.sqrt(5.0)
    normal = 1.0 - float(r @ n) ** 2            # |r̂ × n|²
    inertia = np.array([[0.02, 0.003, 0], [0.003, 0.01, 0.002], [0, 0.002, 0.015]])
    return 0.6 / 3.0 * normal + 0.7 * normal + float(n @ inertia @ n)


def _exact(t, torque, t0, inertia):
    after = np.clip(np.asarray(t) - t0, 0.0, None)
    return torque * after ** 2 / (2 * inertia), torque * after / inertia


def test_a_torque_switched_on_between_grid_points_gives_the_exact_motion_through_the_cli(tmp_path):
    """Through the CLI: every row of the angle and rate of the arm equal the exact motion (to the
    2e-9 dt the restart skips)."""
    process, out = latdyn_run(tmp_path, PLANAR.replace("DT", "0.01").replace("METHOD", "generalized-alpha"))
    assert process.returncode == 0, process.stderr
    rows = probe_columns(out)
    angle, rate = _exact(rows["t"], TORQUE, T0, J_PLANAR)
    assert np.max(np.abs(rows["angle"] - angle)) < 1e-9
    assert np.max(np.abs(rows["rate"] - rate)) < 1e-9
    assert summary_of(out)["energy_balance_error"] < 1e-8


@pytest.mark.parametrize("method", ["generalized-alpha", "newmark", "hht-alpha"])
@pytest.mark.parametrize("dt", [0.01, 0.004])
def test_a_torque_switched_on_between_grid_points_gives_the_exact_motion_whatever_the_step(method, dt):
    """Through the API, each method, two steps: the same exact motion at every row."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(PLANAR.replace("DT", str(dt)).replace("METHOD", method))))
    angle, rate = _exact(result.t, TORQUE, T0, J_PLANAR)
    assert np.max(np.abs(result.probes["angle"] - angle)) < 1e-9
    assert np.max(np.abs(result.probes["rate"] - rate)) < 1e-9


def test_a_continuous_controller_that_switches_on_gives_the_exact_motion():
    """The same torque as a continuous controller's output (its parsed expression searched for the
    jump), read by the hinge law by name."""
    text = PLANAR.replace("DT", "0.01").replace("METHOD", "generalized-alpha").replace(
        '"2*Heaviside(t - 0.013)"', "drive") + 'controllers:\n  drive: {output: "2*Heaviside(t - 0.013)"}\n'
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    angle, rate = _exact(result.t, TORQUE, T0, J_PLANAR)
    assert np.max(np.abs(result.probes["angle"] - angle)) < 1e-9
    assert np.max(np.abs(result.probes["rate"] - rate)) < 1e-9


@pytest.mark.parametrize("adaptive", [False, True], ids=["fixed", "adaptive"])
def test_a_piecewise_jump_on_a_skew_hinge_in_3d_gives_the_exact_motion(adaptive):
    """Through the API, genuinely 3D (a skew axis, an arm not normal to it, a full inertia tensor), with
    fixed and adaptive steps: the angle and rate at every row equal θ = τ(t − t₀)²/2J."""
    scene = latdyn.load_scene(yaml.safe_load(SKEW.replace("ADAPTIVE", ", adaptive: true" if adaptive else "")))
    result = latdyn.run(scene)
    angle, rate = _exact(result.t, 3.0, 0.0137, _skew_inertia())
    assert result.summary["status"] == "solved"
    assert np.max(np.abs(result.probes["angle"] - angle)) < 1e-9
    assert np.max(np.abs(result.probes["rate"] - rate)) < 1e-9


def test_the_jumps_found_and_the_laws_that_do_not_jump():
    """Heaviside, sign and Piecewise in t jump where their argument changes sign and the value
    changes; a Piecewise that joins continuously (the spin-up's ramp, a triangle load) is no jump,
    and a run without jumps keeps the loop of steps in C."""
    from latdyn.timeloop.jumps import jump_times

    def scene(torque):
        text = PLANAR.replace("DT", "0.01").replace("METHOD", "newmark")
        return latdyn.load_scene(yaml.safe_load(text.replace('"2*Heaviside(t - 0.013)"', f'"{torque}"')))

    assert jump_times(scene("2*Heaviside(t - 0.013)"), 0.1) == pytest.approx([0.013], abs=1e-15)
    assert jump_times(scene("sign(t - 0.05) + sin(t)"), 0.1) == pytest.approx([0.05], abs=1e-15)
    assert jump_times(scene("Piecewise((1, t < 0.03), (2, t < 0.06), (0, True))"), 0.1) == pytest.approx([0.03, 0.06])
    for continuous in ("Piecewise((50*t, t <= 0.02), (50*(0.04 - t), t <= 0.04), (0, True))",
                       "Heaviside(t - 0.2)", "Heaviside(theta - 0.1)", "abs(t - 0.05)"):
        assert len(jump_times(scene(continuous), 0.1)) == 0, continuous
    result = latdyn.run(scene("Piecewise((50*t, t <= 0.02), (50*(0.04 - t), t <= 0.04), (0, True))"))
    assert result.summary["time_loop"] == "compiled"


def test_sensitivities_beside_a_jump_in_t_are_refused_naming_the_law(tmp_path):
    """The restart at the jump is not differentiated: refused (exit 2) naming solve.sensitivities and
    the law that jumps, not reported."""
    text = PLANAR.replace("DT", "0.01").replace("METHOD", "generalized-alpha").replace(
        "rhoA: 1}", "rhoA: 1}\nparameters: {m: 1}").replace("mass: 1,", "mass: m,").replace(
        "solve: {", "solve: {sensitivities: [m], ")
    process, out = latdyn_run(tmp_path, text)
    assert process.returncode == 2, process.stderr
    assert "solve.sensitivities" in process.stderr and "beams.arm.start.hinge.torque jumps in t" in process.stderr


def test_a_runs_start_searches_the_laws_for_jumps_once(monkeypatch):
    """The start of a transient run asks twice whether a law jumps (the refusal of a prescribed position that
    jumps, and the instants the steps land on): the laws' values are searched once
    (latdyn.timeloop.jumps.law_jumps; before, twice: 7 of the spin-up's 24 ms at its start). The spin-up's
    Piecewise angle, cut to 1 s: each search of its text (its values, its rate, its acceleration: read from the
    laws' cache or made, latdyn.timeloop.jumps._searched) once, and the run as before."""
    from pathlib import Path

    import latdyn.timeloop.jumps as jumps

    searched = []
    lookup = jumps._searched

    def counted(search, law, *args, **kwargs):
        searched.append(search)
        return lookup(search, law, *args, **kwargs)

    monkeypatch.setattr(jumps, "_searched", counted)
    data = yaml.safe_load((Path(__file__).resolve().parents[1] / "examples" / "spinup.yaml").read_text())
    data["solve"]["t_end"] = 1.0
    result = latdyn.run(latdyn.load_scene(data))
    assert result.summary["status"] == "solved"
    assert sorted(searched) == ["accelerations", "rates", "values"], searched
