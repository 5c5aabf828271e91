"""The work of hinge torques and the dissipation of hinge dampers (docs/energy.md): integrated as
½(τ_n + τ_{n+1}) Δθ over each step (csrc/newton_step.c hinge_work, which latdyn.timeloop.progress.hinge_work
calls for the steps from Python), the work the discrete step received, not the trapezoid of the power τ θ̇ in time; and
the unbounded test, which an error of the work's estimate at small energies no longer trips.

Scenes are YAML text as a user writes it, run through the CLI (``python -m latdyn run``) or
``latdyn.run(latdyn.load_scene(...))``.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.timeloop.progress import UNBOUNDED, TransientProgress
from cli_runs import latdyn_run, probe_columns, summary_of

#: A flexible arm on a hinge driven by a PD law (the θ̇ term damps): the stiff arm makes the hinge
#: rate oscillate fast, so that with generalized-α Δθ is far from h (θ̇_n + θ̇_{n+1})/2. The
#: trapezoid of τ θ̇ in time made the work negative from the first step (−1.25e-3 at t = 0.002
#: while θ rose under τ ≈ 1.5) and the run ended "unbounded" at t = 0.02.
PD_ARM = """\
sections:
  arm: {EA: 1.0e6, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 0.5}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
beams:
  arm:
    from: hub
    to: [1, 0, 0]
    section: arm
    elements: 4
    start: {hinge: {axis: AXIS, torque: "3*(0.5-theta) - 1.4*theta_dot"}}
LOADS
solve: {t_end: 0.4, dt: 0.002}
output:
  probes:
    th: {hinge: arm.start, quantity: angle}
    rate: {hinge: arm.start, quantity: rate}
    w: {energy: external_work}
"""

#: A rigid link with a tip body on a hinge with a linear spring, a linear damper and a torque
#: linear in θ and θ̇ (plus a function of t): a linear system, θ̈ I + c θ̇ + k θ = τ(θ, θ̇, t).
LINEAR_HINGE = """\
sections:
  link: {EA: 1.0e6, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 3.0}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
TIP_BODY
beams:
  arm:
    from: hub
    to: TO
    section: link
    rigid: true
    start:
      hinge: {axis: AXIS, stiffness: 40.0, damping: 0.3, torque: "3*(0.5-theta) - 1.4*theta_dot + sin(5*t)"}
solve: {t_end: 1.0, dt: 0.01, method: newmark, tol: 1.0e-12}
output:
  probes:
    w: {energy: external_work}
    dissipated: {energy: dissipated}
"""


def pd_arm(axis: str = "[0, 0, 1]", loads: str = "") -> str:
    return PD_ARM.replace("AXIS", axis).replace("LOADS\n", loads)


def test_a_pd_torque_on_a_flexible_arm_is_solved_and_its_first_step_gets_the_work_of_the_mean_torque(tmp_path):
    """Planar, through the CLI: solved (exit 0, no warning), energy_balance_error 2.9e-3 (measured;
    the refusal was 1.05 at t = 0.02), and the work of the first step is ½(τ_0 + τ_1) Δθ with τ
    the PD law at the recorded angle and rate, to round-off."""
    process, out = latdyn_run(tmp_path, pd_arm(), quiet=True)
    assert process.returncode == 0, process.stderr
    summary = summary_of(out)
    assert summary["status"] == "solved" and "warnings" not in summary
    assert summary["energy_balance_error"] < 1e-2
    rows = probe_columns(out)
    theta, rate, work = rows["th"], rows["rate"], rows["w"]
    torque = 3 * (0.5 - theta) - 1.4 * rate
    assert theta[1] > 0 and work[1] > 0
    # the loop takes τ_{n+1} from the step's last Newton evaluation, within the Newton tolerance
    # (1e-8 on the increment) of the recorded state: 5e-6 of a step's work at most (measured)
    assert work[1] == pytest.approx(0.5 * (torque[0] + torque[1]) * (theta[1] - theta[0]), rel=1e-4)
    # every step: the hinge is the only thing that works
    steps = 0.5 * (torque[:-1] + torque[1:]) * np.diff(theta)
    np.testing.assert_allclose(np.diff(work), steps, rtol=1e-4, atol=1e-10)
    # the trapezoid of the power in time, which this replaced, is far off (its sign flips)
    in_time = 0.5 * 0.002 * (torque[:-1] * rate[:-1] + torque[1:] * rate[1:])
    assert np.max(np.abs(in_time - steps)) > 100 * np.max(np.abs(np.diff(work) - steps))


def test_a_pd_torque_on_a_flexible_arm_in_3d_is_solved_from_the_api_and_from_the_python_loop(monkeypatch):
    """Genuinely 3D (a hinge axis off the coordinate axes, a tip load along z): solved with
    energy_balance_error 3.5e-3 (measured; the trapezoid of the power in time ended it "unbounded" at
    t = 0.02, 1.06 times the energy received); the compiled loop of steps and the time loop's own
    steps integrate the same work."""
    from latdyn.timeloop import transient

    loads = 'loads:\n  - {at: arm.end, force: [0, 0, "0.5*sin(3*t)"]}\n'
    text = pd_arm("[0, 0.6, 0.8]", loads)
    compiled = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert compiled.summary["status"] == "solved" and "warnings" not in compiled.summary
    assert compiled.summary["energy_balance_error"] < 1e-2
    assert compiled.summary["time_loop"] == "compiled"
    monkeypatch.setattr(transient, "COMPILED_LOOP", False)
    python = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert python.summary["time_loop"] == "python"
    assert compiled.probes["w"][-1] > 0.01
    np.testing.assert_allclose(python.probes["w"], compiled.probes["w"], rtol=1e-10, atol=1e-15)


def test_a_continuous_controllers_torque_works_as_the_same_torque_law_does():
    """A continuous controller's output on a hinge is an applied torque: its work is ½(y_n + y_{n+1}) Δθ
    a step like the torque law's (evaluate.c adds it to the kernel's applied_torque). The PD arm in
    3D (axis (0, 0.6, 0.8)), its torque once as the law and once as a controller reading the hinge's
    angle and rate probes: the same motion and work, and each step's work is the mean output times
    Δθ (measured: the two runs' angles and work are identical, bit for bit; each step's work is
    ½(y_n + y_{n+1}) Δθ of the recorded outputs to 3.3e-6 of the largest step's work, the loop taking
    y_{n+1} from the step's last Newton evaluation, within the Newton tolerance of the recorded state;
    counted as the trapezoid of y θ̇ in time it would differ as the PD law's test above shows)."""
    law = pd_arm("[0, 0.6, 0.8]").replace("solve: {t_end: 0.4, dt: 0.002}", "solve: {t_end: 0.1, dt: 0.002}")
    controlled = law.replace('torque: "3*(0.5-theta) - 1.4*theta_dot"', "torque: pd").replace(
        "output:\n  probes:\n", "output:\n  probes:\n    u: {controller: pd}\n")
    controlled = 'controllers:\n  pd: {output: "3*(0.5 - th) - 1.4*rate"}\n' + controlled
    by_law = latdyn.run(latdyn.load_scene(yaml.safe_load(law)))
    by_controller = latdyn.run(latdyn.load_scene(yaml.safe_load(controlled)))
    assert by_controller.summary["status"] == "solved" and "warnings" not in by_controller.summary
    p, q = by_controller.probes, by_law.probes
    assert p["w"][-1] > 1e-3
    np.testing.assert_allclose(p["w"], q["w"], rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(p["th"], q["th"], rtol=1e-9, atol=1e-14)
    steps = 0.5 * (p["u"][:-1] + p["u"][1:]) * np.diff(p["th"])
    np.testing.assert_allclose(np.diff(p["w"]), steps, rtol=1e-4, atol=1e-10)


@pytest.mark.parametrize("axis, tip, bound", [("[0, 0, 1]", None, 1e-13), ("[0, 0, 1]", "[1, 0, 0]", 1e-9),
                                              ("[1, 1, 1]", "[0.5, -0.5, 0]", 1e-9)])
def test_newmark_closes_the_balance_of_a_linear_spring_damper_torque_hinge_to_round_off(axis, tip, bound):
    """Newmark's average acceleration keeps the energy of a linear system exactly when the work of
    each force is ½(f_n + f_{n+1}) Δθ. energy_balance_error (measured): 4.9e-16 for the link alone
    (Newton converges in 2 iterations); with the tip body, whose dependent node Newton follows to its
    tolerance 1e-12, 1.1e-10 planar and 3.7e-11 with the axis (1, 1, 1). The trapezoid of the power in
    time left 1.7e-4, 2.2e-4 and 1.2e-4 on the same three scenes."""
    if tip is None:  # the link alone, its end free
        text = LINEAR_HINGE.replace("TIP_BODY\n", "").replace("TO", "[1, 0, 0]")
    else:
        body = f"  tip: {{at: {tip}, mass: 0.7, inertia: [0.01, 0.02, 0.03]}}\n"
        text = LINEAR_HINGE.replace("TIP_BODY\n", body).replace("TO", "tip")
    text = text.replace("AXIS", axis)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert result.summary["status"] == "solved"
    assert result.probes["dissipated"][-1] > 1e-2 and np.max(np.abs(result.probes["w"])) > 1e-2
    assert result.summary["energy_balance_error"] < bound


def rows_of(progress: TransientProgress, totals) -> list[bool]:
    """Feed rows of total energy (all kinetic, no work) to the balance; whether it is unbounded after each."""
    judged = []
    for k, total in enumerate(totals):
        progress.balance(0.1 * k, {"kinetic": total, "strain": 0.0, "potential": 0.0}, 0.0)
        judged.append(progress.unbounded)
    return judged


def test_a_gain_at_one_row_is_not_unbounded_but_a_growing_gain_at_two_rows_is():
    """The structure received 1 J (kinetic at t = 0): a gain past UNBOUNDED at one row that the next
    row does not keep (an error of the work's estimate) leaves the run going; a gain that grows at
    two rows in a row ends it; an energy that is not finite ends it at once."""
    assert UNBOUNDED == 1.0
    progress = TransientProgress(state=None, algorithmic_acceleration=None, locked=None, h=0.1, total0=1.0,
                                 received0=1.0)
    assert rows_of(progress, [1.0, 2.5, 1.2, 2.6, 1.0]) == [False] * 5
    assert rows_of(progress, [2.5, 2.4]) == [False, False]  # past the threshold, but not growing
    assert rows_of(progress, [2.5, 3.5]) == [False, True]
    fresh = TransientProgress(state=None, algorithmic_acceleration=None, locked=None, h=0.1, total0=1.0,
                              received0=1.0)
    assert rows_of(fresh, [1.0, math.inf]) == [False, True]
