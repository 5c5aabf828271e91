"""The work of prescribed motions and the impulse of a prescribed rate that jumps: scenes typed as YAML,
through the command line and the API (docs/energy.md, "The work of a prescribed motion"; docs/verification.md,
"a fifth set").

A prescribed motion's work is ½(r_n + r_{n+1}) Δq over each prescribed coordinate (csrc/newton_step.c drive_work,
which latdyn.timeloop.progress drive_work calls for the steps from Python), the steps land where a prescribed
acceleration jumps (a ramp's ends) and on a kink, where the free rates take the impulse the jump of the prescribed rate implies
(latdyn.timeloop.impulse.prescribed_velocity_jump). References: Goldstein's impulse on a free rod (the
crank's elbow brought to 2 m/s at once gives the rod's hinge −5 rad/s and 7/6 J), and the energy balance."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
import latdyn.timeloop.transient as transient_module
from cli_runs import latdyn_run, latdyn_run_switched, probe_columns, summary_of

#: the crank brought from rest to 2 rad/s at t = 0.5: over 10 ms, over 1 ms (constant accelerations), at once
RAMP_10_MS = "Piecewise((0, t < 0.5), (100*(t - 0.5)**2, t < 0.51), (0.01 + 2*(t - 0.51), True))"
RAMP_1_MS = "Piecewise((0, t < 0.5), (1000*(t - 0.5)**2, t < 0.501), (0.001 + 2*(t - 0.501), True))"
KINK = "Piecewise((0, t < 0.5), (2*(t - 0.5), True))"


def crank(angle: str, dt: float, t_end: float, every: float, tol: str = "") -> str:
    """A rigid crank (1 kg, 1 m) at a prescribed angle about z carrying a free rigid rod (1 kg, 1 m) on a
    hinge at its end, in line with it at rest; no gravity (tests/test_literature_cases_heldout4.py's)."""
    return f"""\
title: a crank carrying a free rod
inputs: {{u: 0.0}}
sections:
  rod: {{EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}}
bodies:
  ground: {{at: [0, 0, 0], fixed: true}}
  elbow: {{at: [1, 0, 0]}}
beams:
  crank: {{from: ground, to: elbow, section: rod, rigid: true, start: {{hinge: {{axis: [0, 0, 1], angle: "{angle}"}}}}}}
  arm: {{from: elbow, to: [2, 0, 0], section: rod, rigid: true, start: {{hinge: {{axis: [0, 0, 1]}}}}}}
solve: {{t_end: {t_end}, dt: {dt}{tol}}}
output:
  every: {every}
  probes:
    rate: {{hinge: arm.start, quantity: rate}}
    ke: {{energy: kinetic}}
    W: {{energy: external_work}}
"""


def run_api(text: str):
    return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def test_a_crank_brought_to_speed_in_one_step_is_solved_with_the_work_its_drive_did(tmp_path):
    """The 1 ms ramp at dt = 0.001 (rows every step): the rod takes −5 rad/s. It ended `unbounded` at
    t = 0.505, 'the integrator created 1.51e+03 times the energy the structure received (0.0007747)': the
    time trapezoid of the drive's power missed the work of the step whose end took the ramp's acceleration.
    Now the work is counted over the crank's Δθ and the steps land on the ramp's ends: `solved`, no warning."""
    completed, out = latdyn_run(tmp_path, crank(RAMP_1_MS, 0.001, 0.52, 0.001))
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["status"] == "solved" and not summary.get("warnings"), summary.get("warnings")
    assert summary["energy_balance_error"] < 1e-2   # measured 4.3e-4 (Newton's default tolerance)
    p = probe_columns(out)
    assert abs(p["rate"][-1] + 5.0) < 0.02                 # measured −4.9986 at t = 0.52
    assert abs(p["W"][-1] - p["ke"][-1]) < 1e-3 * p["ke"][-1]


def test_the_drives_work_closes_the_balance_to_the_steps_order_on_ramps_and_a_kink():
    """The 10 ms and 1 ms ramps and the kink, to t = 0.6 (the rod swinging on the crank after), at dt = 0.002
    and 0.001 with Newton's tolerance 1e-10 (below the step's error: with the default tolerance the
    reaction taken from the last Newton evaluation, not the converged state, leaves 2.8e-3 and 1.5e-3 on the
    10 ms ramp at dt = 0.001 and 0.0005, the same before this change). Measured energy_balance_error (rows every
    0.05): 10 ms 1.87e-5, 4.67e-6; 1 ms 3.44e-6, 2.66e-6; kink 6.59e-6, 1.65e-6. Before: 10 ms 'drifts: 0.0997' (dt 0.001),
    1 ms `unbounded` or 0.77, kink 1 (the rod carried along)."""
    for law in (RAMP_10_MS, RAMP_1_MS, KINK):
        errors = [run_api(crank(law, dt, 0.6, 0.05, ", tol: 1.0e-10")).summary["energy_balance_error"]
                  for dt in (0.002, 0.001)]
        assert errors[0] < 3e-5 and errors[1] < 1e-5, (law, errors)
        if law != RAMP_1_MS:   # the 1 ms ramp is landed on at both steps (its ends 1 ms apart): no order to see
            assert errors[0] / errors[1] > 3.0, (law, errors)


def test_a_rate_jumped_from_outside_gives_the_free_rod_the_impulse():
    """`angle: "u*(t - 0.5)"` with u = 0, set to 2 at t = 0.5 by `Simulation.set_input` (a kink from outside:
    the angle stays, its rate jumps). The restart applies the impulse: the rod's hinge −5 rad/s and 7/6 J
    just after it (round-off). Before, the rod was carried along (rate 0)."""
    sim = latdyn.Simulation(latdyn.load_scene(yaml.safe_load(crank("u*(t - 0.5)", 0.01, 0.6, 0.01))))
    sim.advance_to(0.5)
    sim.set_input("u", 2.0)
    sim.advance_to(0.51)
    result = sim.close()
    rate, ke = np.asarray(result.probes["rate"]), np.asarray(result.probes["ke"])
    assert abs(rate[-1] + 5.0) < 5e-3            # measured −4.99847 one step (10 ms) after the kick
    assert abs(ke[-1] - 7 / 6) < 5e-3            # measured 1.17041
    assert result.summary["energy_balance_error"] < 1e-5   # measured 2.1e-6


def test_sensitivities_across_a_kink_are_refused_naming_the_law():
    """The restart at a kink (and at a jump of a prescribed acceleration) is not differentiated: refused before
    the run, naming solve.sensitivities and the law's key. Before, they were computed (through a restart that
    carried the rod along)."""
    text = crank(KINK, 0.01, 1.0, 0.1).replace("title:", "parameters: {k: 0.5}\ntitle:").replace(
        "hinge: {axis: [0, 0, 1]}", 'hinge: {axis: [0, 0, 1], stiffness: "k"}').replace(
        "solve: {", "solve: {sensitivities: [k], ").split("    ke:")[0]   # the hinge's rate alone
    try:
        run_api(text)
    except latdyn.SceneError as refusal:
        assert "solve.sensitivities" in str(refusal) and "beams.crank.start.hinge.angle" in str(refusal)
        assert "at t = 0.5" in str(refusal)
    else:
        raise AssertionError("sensitivities across a kink were computed")


def test_the_loop_of_steps_in_c_goes_through_a_prescribed_laws_jumps(tmp_path, monkeypatch):
    """The loop of steps in C stops on the grid point before each jump of a prescribed law at a point k·dt
    (the 10 ms ramp's two acceleration jumps, a kink); the step landing before the jump, the restart and the
    step to the next grid point are Python's, then the loop in C again. summary.json says ``time_loop:
    compiled`` and probes.csv equals the run with every step from Python byte for byte (CLI); a prescribed
    hub body ramped in 3D (API) equals it bit for bit, the drive's work too: the steps from Python take it from
    the loop of steps' own drive_forces and drive_work in C and the generated so3_log_increment (before, a Python
    sum and rotation vector of their own gave a work that differed from the loop's by up to 1.8e-15). Before
    that, a run whose laws jump took every step from Python (``time_loop: python``)."""
    switched_off = "import latdyn.timeloop.transient as m; m.COMPILED_LOOP = False"
    for i, law in enumerate((RAMP_10_MS, KINK)):
        folder = tmp_path / f"law{i}"
        folder.mkdir()
        completed, out = latdyn_run(folder, crank(law, 0.002, 0.6, 0.01))
        assert completed.returncode == 0, completed.stderr
        stepped = latdyn_run_switched(folder, folder / "scene.yaml", folder / "stepped", switched_off)
        assert stepped.returncode == 0, stepped.stderr
        looped, reference = summary_of(out), summary_of(folder / "stepped")
        assert looped["time_loop"] == "compiled" and reference["time_loop"] == "python"
        for key in ("steps", "newton_iterations", "factorizations", "energy_balance_error"):
            assert looped[key] == reference[key], key
        assert (out / "probes.csv").read_bytes() == (folder / "stepped" / "probes.csv").read_bytes()
    text = spun_beam("body", 0.01, law="Piecewise((2*t**2, t < 1), (4*t - 2, True))", axis="[0, 0.6, 0.8]",
                     slide="Piecewise((0.5*t**2, t < 0.6), (0.6*t - 0.18, True))")   # jumps at 0.6 and 1
    looped = run_api(text)
    monkeypatch.setattr(transient_module, "COMPILED_LOOP", False)
    stepped = run_api(text)
    assert looped.summary["time_loop"] == "compiled" and stepped.summary["time_loop"] == "python"
    assert looped.summary["steps"] == stepped.summary["steps"] == 150
    for name in ("tip", "W"):
        assert np.array_equal(np.asarray(looped.probes[name]), np.asarray(stepped.probes[name])), name


#: Kane's spin-up θ = (Ω/T)(t²/2 + (T/2π)²(cos(2πt/T) − 1)), Ω = 4, T = 1, then at Ω: its rate and acceleration
#: are continuous (no landing)
KANE = "Piecewise((4*(t**2/2 + (1/(2*pi))**2*(cos(2*pi*t) - 1)), t < 1), (4*(t - 0.5), True))"


def spun_beam(motion: str, dt: float, law: str = KANE, axis: str = "[0, 0, 1]", slide: str | None = None) -> str:
    """A flexible beam (4 elements) spun up by ``law`` about ``axis``: through a prescribed hub body's rotation
    (``slide``: with the translation along x too) or a prescribed hinge angle about z (``motion``)."""
    translation = f', translation: ["{slide}", 0, 0]' if slide is not None else ""
    drive = {"body": f'hub: {{at: [0, 0, 0], motion: {{rotation: {{axis: {axis}, angle: "{law}"}}{translation}}}}}',
             "hinge": "hub: {at: [0, 0, 0], fixed: true}"}[motion]
    hinge = f', start: {{hinge: {{axis: [0, 0, 1], angle: "{law}"}}}}' if motion == "hinge" else ""
    return f"""\
title: a flexible beam spun up
sections:
  s: {{EA: 1.0e4, EIy: 20.0, EIz: 20.0, GJ: 20.0, rhoA: 1.0, rhoIy: 1.0e-4, rhoIz: 1.0e-4}}
bodies:
  {drive}
beams:
  arm: {{from: hub, to: [1, 0, 0], section: s, elements: 4{hinge}}}
solve: {{t_end: 1.5, dt: {dt}}}
output:
  every: 0.05
  probes:
    tip: {{point: arm.end, quantity: position, component: y}}
    W: {{energy: external_work}}
"""


def test_a_spin_up_counts_the_same_work_through_a_body_or_a_hinge_in_c_and_in_python(monkeypatch):
    """The spin-up of a flexible beam, its hub a prescribed body (the work over the rotation vector of
    T_{n+1} T_nᵀ) or its root a prescribed hinge (over Δθ): the same work (1e-12), the balance closed at second
    order (measured 6.0e-4, 1.5e-4 at dt = 0.01, 0.005 to t = 2), and the loop of steps in C equal to the steps
    from Python bit for bit (both count the work with csrc/newton_step.c drive_work). These held before too (a
    smooth drive: the time trapezoid of the power is second order there as well)."""
    works = {}
    for motion in ("body", "hinge"):
        errors = []
        for dt in (0.01, 0.005):
            result = run_api(spun_beam(motion, dt))
            errors.append(result.summary["energy_balance_error"])
            works[motion, dt] = np.asarray(result.probes["W"])
        assert errors[1] < 3e-4 and errors[0] / errors[1] > 3.0, errors
    for dt in (0.01, 0.005):
        assert np.abs(works["body", dt] - works["hinge", dt]).max() < 1e-12
    monkeypatch.setattr(transient_module, "COMPILED_LOOP", False)
    stepped = run_api(spun_beam("body", 0.01))
    assert stepped.summary["time_loop"] == "python"
    assert np.array_equal(np.asarray(stepped.probes["W"]), works["body", 0.01])


def test_a_cable_hung_at_its_rest_length_reports_no_change_at_the_start(tmp_path):
    """A cable (EA = 400, 2 kg/m) from a fixed point to a free end at its rest length (the default), under
    gravity: it is on its boundary at t = 0 and taut from the first step. It reported a `taut` event at
    t = 4e-6 (dt/1000, the landing's floor); SCENE.md lists the changes after t = 0, and this is its state at
    the start: no event now, the motion unchanged (the probes equal bit for bit, measured)."""
    completed, out = latdyn_run(tmp_path, """\
title: a cable hung at its rest length
gravity: [0, 0, -9.81]
bodies:
  top: {at: [0, 0, 0], fixed: true}
cables:
  c: {from: top, to: [0.5, 0, -0.8], EA: 400.0, rhoA: 2.0}
solve: {t_end: 0.1, dt: 0.004}
output:
  every: 0.02
  probes:
    N: {cable: c, quantity: tension}
""")
    assert completed.returncode == 0, completed.stderr
    assert summary_of(out)["cable_events"] == []
    assert probe_columns(out)["N"][-1] > 0.0   # taut: pulling


def test_a_kink_at_t_end_is_landed_on_as_a_jump_at_t_end_is():
    """The crank's kink at t_end = 0.5 (dt 0.01): the last step ends 1e-9·dt before it, on the law as it was, and
    the run ends there (docs/stepping.md: a jump at t_end), the rod at rest with the crank. Before, the kink at
    t_end was not searched for (kinks only inside (0, t_end)): the last step took the crank's new rate and
    carried the rod along (5.333 J), `solved` with 'the energy balance drifts: energy_balance_error 1'."""
    result = run_api(crank(KINK, 0.01, 0.5, 0.01))
    assert result.summary["status"] == "solved" and not result.summary.get("warnings")
    assert result.t[-1] == pytest.approx(0.5 - 1e-9 * 0.01, abs=1e-15)
    assert result.probes["rate"][-1] == 0.0 and result.probes["ke"][-1] == 0.0
    assert result.summary["energy_balance_error"] < 1e-12
