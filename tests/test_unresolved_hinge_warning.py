"""A fixed step that does not resolve a hinge's motion is said (latdyn.timeloop.progress.UNRESOLVED_TURN,
docs/energy.md, "Steps that do not resolve a hinge").

A top (m = 1, its centre of mass l = 0.3 above the pivot, A = 0.14 about it) in a Cardan suspension of
massless rings, not spinning, falls from upright with ω₀ = (−0.02, 2, 0): its axis swings in a vertical
plane 0.57° from the outer hinge's axis x, a planar pendulum A ψ̈ = m g l sin ψ. As it passes the
horizontal the outer ring's angle flips through π at up to ψ̇ / sin 0.57° ≈ 680 rad/s (gimbal lock: a
singularity of the coordinates, not of the motion). At dt = 0.002 that flip is not resolved and the top
is 0.033 off (11 % of its arm) at t = 1.5 with energy_balance_error 0.0097, under the drift warning; at
dt = 0.001 it is 0.0014 off.
"""
from __future__ import annotations

import math

import numpy as np
import yaml
from scipy.integrate import solve_ivp

import latdyn
from cli_runs import latdyn_run, latdyn_run_switched, probe_columns, summary_of
from test_literature_cases_heldout3 import sleeping_top

OMEGA0 = (-0.02, 2.0, 0.0)


def falling_top(dt: float) -> str:
    """The sleeping top of the held-out set (not spinning), falling with ω₀ = (−0.02, 2, 0) until t = 1.5."""
    return sleeping_top(f"{{t_end: 1.5, dt: {dt}}}", OMEGA0[2], OMEGA0[0], tip_y=OMEGA0[1])


def position_error(t, x, y, z) -> float:
    """Largest distance of the top from the planar pendulum's (A = 0.05 + m l², by scipy)."""
    A, mgl, l = 0.05 + 0.09, 9.81 * 0.3, 0.3
    psi = solve_ivp(lambda _, s: [s[1], mgl / A * math.sin(s[0])], (0, t[-1]), [0.0, math.hypot(*OMEGA0)],
                    t_eval=t, rtol=1e-12, atol=1e-13).y[0]
    w = np.array(OMEGA0) / np.linalg.norm(OMEGA0)
    d = np.cross(w, [0.0, 0.0, 1.0])  # the direction the top falls in
    return float(np.max(np.sqrt((x - l * np.sin(psi) * d[0]) ** 2 + (y - l * np.sin(psi) * d[1]) ** 2
                                + (z - l * np.cos(psi)) ** 2)))


def unresolved(warnings) -> list[str]:
    return [w for w in warnings or [] if "is not resolved by the step" in w]


def test_a_step_that_does_not_resolve_the_outer_rings_flip_is_said(tmp_path):
    """dt = 0.002 (command line): the outer hinge r1 (and the spin hinge, which flips with it) turns by
    h |Δθ̇| = 0.438 rad over its step at t = 0.44 (> 0.25); the warning names the hinge, the time, the
    step and the remedy, on stderr and in summary.json, and the run still ends (exit 0)."""
    completed, out = latdyn_run(tmp_path, falling_top(0.002))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    assert position_error(p["t"], p["x"], p["y"], p["z"]) > 0.02  # measured 0.0334: the warning is due
    summary = summary_of(out)
    assert summary["energy_balance_error"] < 0.01  # measured 0.0097: the drift warning does not see it
    said = unresolved(summary.get("warnings"))
    assert said and said[0].startswith("hinge r1.start is not resolved by the step"), summary.get("warnings")
    assert "at t = 0.44" in said[0] and "step of 0.002 s" in said[0] and "smaller dt" in said[0]
    assert "turns it by 0.438 rad" in said[0]
    assert "latdyn: warning: hinge r1.start is not resolved by the step" in completed.stderr


def test_a_step_that_resolves_it_is_not_flagged():
    """dt = 0.001 (API): 0.195 rad, the top 0.0014 off: no warning."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(falling_top(0.001))))
    p = {k: np.asarray(v) for k, v in result.probes.items()}
    assert position_error(np.asarray(result.t), p["x"], p["y"], p["z"]) < 0.002  # measured 0.00137
    assert unresolved(result.summary.get("warnings")) == []


def adaptive_top(error_tol: float) -> str:
    """The falling top with adaptive steps from dt = 0.002 (error_tol as given)."""
    return sleeping_top(f"{{t_end: 1.5, dt: 0.002, adaptive: true, error_tol: {error_tol}}}", OMEGA0[2], OMEGA0[0],
                        tip_y=OMEGA0[1])


def test_an_adaptive_run_follows_the_flip_as_its_error_tol_tightens(tmp_path):
    """The error estimate weighs a change of acceleration by the inertia it moves; at the flip the outer ring and
    the spin hinge turn against each other (θ̈ = ∓2.7e5 rad/s²), which moves almost nothing with inertia at that
    moment and sets the plane the top falls on in. It now also counts each rigid link's hinge as a rotation,
    ℓ h² |β − 1/6| |Δθ̈| (latdyn.numerics.inertia.largest_link_turn). Measured against the pendulum (t ≤ 1.5):
    error_tol 1e-3, 1e-4, 1e-5, 1e-6: 0.074, 0.025, 0.0071, 0.0018 (806, 904, 1131, 1661 steps); before 0.13,
    0.077, 0.033, 0.0090 (755, 788, 862, 1064), no better at 1e-5 than the fixed dt = 0.002. No warning either way."""
    completed, out = latdyn_run(tmp_path, adaptive_top(1e-5))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    assert position_error(p["t"], p["x"], p["y"], p["z"]) < 0.01  # measured 0.0071 (0.0328 before)
    assert summary_of(out).get("warnings") in (None, [])
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(adaptive_top(1e-6))))
    p = {k: np.asarray(v) for k, v in result.probes.items()}
    assert position_error(np.asarray(result.t), p["x"], p["y"], p["z"]) < 0.0025  # measured 0.00175 (0.0090 before)


def test_the_sensitivities_of_an_adaptive_run_through_the_flip_take_the_link_hinges_term():
    """The step sizes' derivative follows the estimate's new term where it sized the steps (δe/e = 2 δh/h + δx_i/x_i,
    latdyn.analyses.adaptive_sensitivities.error_derivative): the top's mass as a parameter, error_tol 1e-3 into
    the flip (t ≤ 0.46, 261 steps, 7 rejected): every row of x, y, z by m within 1e-6 of its largest against
    Richardson differences (h = 1e-5 |m|), measured 1.6e-9; differentiated as the inertia-weighted norm there,
    2.2e-4 (at error_tol 1e-4 up to t = 0.5, benchmarks/fuzz_sensitivities.py --scene: 2e-8 against 1.09)."""
    from test_sensitivities_fuzz_findings import _richardson

    text = "parameters: {m: 1.0}\n" + sleeping_top(
        "{t_end: 0.46, dt: 0.002, adaptive: true, error_tol: 1.0e-3, tol: 1.0e-12, sensitivities: [m]}",
        OMEGA0[2], OMEGA0[0], tip_y=OMEGA0[1]).replace("mass: 1.0, inertia", "mass: m, inertia")
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    expected = _richardson(text, "m", 1e-5)
    for probe in ("x", "y", "z"):
        computed = np.asarray(result.sensitivities[(probe, "m")])
        assert np.abs(computed - expected[probe]).max() <= 1e-6 * np.abs(expected[probe]).max(), probe


def hinged_arm(dt: float, output: str = "") -> str:
    """A uniform flexible arm (L = 1, EI = ρA = 1, EA = 10⁶, 4 elements) on a hinge about z at the
    ground with a rotary spring k = 1, driven by a constant torque 2 from rest. The torque, applied at
    once, swings the arm's root through 0.13 rad within 0.005 s (its local bending, much faster than
    the arm's swing: θ(0.005) = 0.1290 at dt = 0.001, 0.0005, 0.00025)."""
    return f"""\
title: a hinged flexible arm under a constant torque
sections:
  arm: {{EA: 1.0e6, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies:
  ground: {{at: [0, 0, 0], fixed: true}}
beams:
  arm: {{from: ground, to: [1, 0, 0], section: arm, elements: 4,
         start: {{hinge: {{axis: [0, 0, 1], stiffness: 1.0, torque: "2"}}}}}}
solve: {{t_end: 2.0, dt: {dt}}}
output:
  {output}
  probes:
    th: {{hinge: arm.start, quantity: angle}}
"""


def test_an_unbounded_run_names_the_hinge_its_step_did_not_resolve(tmp_path):
    """dt = 0.008 does not resolve the root's swing: the first step turns the hinge's rate by 38.1 rad/s,
    h |Δθ̇| = 0.305 rad, and the balance breaks at t = 0.078 (the integrator's, not the arm's: at dt = 0.0025
    the run is solved, θ(2) = 3.4452 against 3.4394 at dt = 0.00025). The refusal (exit 1) names the hinge
    and the step; at dt = 0.0025 nothing is said. (Until 2026-11-27 this was dt = 0.005, whose step ending at
    t = 0.015 converged to −5.3 rad in the compiled loop and was accepted there: a root a whole turn away,
    which the loop now hands back and the time loop cuts, as from Python: the next test.)"""
    completed, _ = latdyn_run(tmp_path, hinged_arm(0.008))
    assert completed.returncode == 1
    message = completed.stderr
    assert "unbounded: the energy balance broke at t = 0.078" in message, message
    assert "before it, hinge arm.start is not resolved by the step" in message, message
    assert "ending at t = 0.008" in message and "rerun with a smaller dt" in message
    # rows every 0.05: the balance is not judged before Newton's cuts fail below the minimum step at
    # t = 0.0892, which ends the run; that message names the same first step
    (tmp_path / "every").mkdir()
    completed, _ = latdyn_run(tmp_path / "every", hinged_arm(0.008, "every: 0.05"))
    assert completed.returncode == 1
    assert "Newton failed below the minimum step" in completed.stderr, completed.stderr
    assert "before it, hinge arm.start is not resolved by the step" in completed.stderr, completed.stderr
    assert "ending at t = 0.008, which turns it by 0.305 rad" in completed.stderr
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(hinged_arm(0.0025))))
    assert result.summary.get("warnings") in (None, [])
    assert abs(result.probes["th"][-1] / 3.4394 - 1) < 5e-3  # measured 1.7e-3


def test_a_root_a_whole_turn_away_in_the_compiled_loop_is_cut_as_from_python(tmp_path):
    """dt = 0.005: the step ending at t = 0.015 converges to θ = −5.3 rad, more than π from θ_n + h θ̇_n. The
    loop of steps in C accepted it (the far-root check ran on steps from Python alone) and the run broke at
    t = 0.0175 (exit 1), while the same scene with a hinge parameter's sensitivities, every step from Python, cut it
    and was solved: the scene's answer hung on whether sensitivities were asked (fuzz_sensitivities seed 20 case
    18). The loop now hands such a step back, and the run is the Python path's, byte for byte."""
    completed, out = latdyn_run(tmp_path, hinged_arm(0.005))
    assert completed.returncode == 0, completed.stderr
    assert "a whole turn away" in completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["far_roots"] == 1
    python = tmp_path / "python"
    python.mkdir()
    text = hinged_arm(0.005).replace("stiffness: 1.0,", "stiffness: k,").replace(
        "solve: {t_end: 2.0,", "parameters: {k: 1.0}\nsolve: {sensitivities: [k], t_end: 2.0,")
    (python / "scene.yaml").write_text(text)
    python_out = python / "out"   # every step from Python: the sensitivities' loop held off (a hinge's k takes it)
    completed = latdyn_run_switched(python, python / "scene.yaml", python_out,
                                    "import latdyn.analyses.sensitivities_in_loop as loop; loop.SENSITIVITIES_IN_LOOP = False")
    assert completed.returncode == 0, completed.stderr
    assert summary_of(python_out)["time_loop"] == "python"
    assert (out / "probes.csv").read_bytes() == (python_out / "probes.csv").read_bytes()
