"""Runs that end, and messages that say what is true (issue 30, item 5).

Every scene here is YAML text as a user types it, run through ``python -m latdyn run`` in a
subprocess with a timeout: a run that crawls fails the test by its timeout, not by hanging the suite.
"""
from __future__ import annotations

import json
import subprocess
import textwrap
from pathlib import Path

import numpy as np
import pytest

from latdyn import cli
from cli_runs import latdyn_run

ROOT = Path(__file__).resolve().parents[1]


def run_cli(tmp_path: Path, text: str, timeout: float = 60.0) -> tuple[subprocess.CompletedProcess, Path]:
    """``latdyn run`` of the scene ``text``; the completed process and the results folder."""
    return latdyn_run(tmp_path, textwrap.dedent(text), timeout=timeout)


def main_cli(tmp_path: Path, text: str, capsys) -> tuple[int, str, Path]:
    """``latdyn run`` of the scene ``text`` in this process (for runs that cannot hang: statics);
    the exit status, stderr and the results folder."""
    scene, out = tmp_path / "scene.yaml", tmp_path / "out"
    scene.write_text(textwrap.dedent(text))
    status = cli.main(["run", str(scene), "-o", str(out), "-q"])
    return status, capsys.readouterr().err, out


def summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


# A deploying arm: a flexible upper arm on a hinge with stops (restitution 0.3) driven into its upper
# stop by a preloaded spring, with a damper whose coefficient grows with θ̇²; a rigid lower link on a
# hinge that latches at 0.8.
DEPLOYING_ARM = """\
    title: deploying arm with stops, a latch and a rate-dependent damper
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
          hinge: {axis: [0, 0, 1], stiffness: 20, rest_angle: 1.0, damping: "0.05*theta_dot**2",
                  limits: [-0.3, 0.4], restitution: 0.3}
      lower:
        from: elbow
        to: tip
        section: arm
        elements: 2
        start:
          hinge: {axis: [0, 0, 1], stiffness: 5, rest_angle: 1.5, lock_at: 0.8}
    solve: {analysis: transient, t_end: 1, dt: 0.01, adaptive: true, dt_min: 2.0e-4}
    output:
      probes:
        upper: {hinge: upper.start, quantity: angle}
        lower: {hinge: lower.start, quantity: angle}
    """


def test_adaptive_steps_never_go_below_dt_min(tmp_path):
    """The floor holds for every step of the adaptive path — steps resized by the error estimate,
    steps shortened onto a stop or a latch — save the last one onto a grid point (a row every
    step, so probes.csv lists the end of every accepted step). It once had none: steps of 7e-7 s
    with dt_min = 2e-4 here, and of 1e-12 s where stops chattered."""
    completed, out = run_cli(tmp_path, DEPLOYING_ARM)
    assert completed.returncode == 0, completed.stderr
    t = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)[:, 0]
    steps, ends = np.diff(t), t[1:]
    on_grid = np.abs(ends / 0.01 - np.round(ends / 0.01)) < 1e-6
    assert summary(out)["steps"] > 100  # the stops and the latch shortened and cut steps
    assert steps[~on_grid].min() >= 2.0e-4 * (1 - 1e-9)


def test_a_motion_that_blows_up_in_finite_time_ends_with_a_clean_failure(tmp_path):
    """θ̈ ∝ 1 + θ̇² blows up at a finite time (θ̇ = tan): adaptive steps follow it down to dt_min
    and the run ends there, exit 1, with the message of the fixed-step path, what was recorded kept."""
    text = DEPLOYING_ARM.replace('stiffness: 20, rest_angle: 1.0, damping: "0.05*theta_dot**2"',
                                 'torque: "20*(1 + theta_dot**2)", damping: "0.1/(1 + theta_dot**2)"')
    text = text.replace("limits: [-0.3, 0.4]", "limits: [-0.5, 100]").replace("dt_min: 2.0e-4", "dt_min: 1.0e-5")
    completed, out = run_cli(tmp_path, text)
    assert completed.returncode == 1, completed.stderr
    assert "below the minimum step" in completed.stderr or "at the minimum step" in completed.stderr
    assert "Traceback" not in completed.stderr
    assert summary(out)["status"] == "failed"
    rows = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)
    assert rows[-1, 0] > 0 and np.isfinite(rows).all()  # t = 0 and the last converged state, at least


def test_a_step_the_error_estimate_rejects_at_dt_min_ends_the_run(tmp_path):
    """error_tol far below what a step of dt_min meets: the step at dt_min was once rejected and
    retried at dt_min for ever (21 731 rejections of the first step in 30 s, no step taken); now
    the run ends at once, exit 1, saying so."""
    text = """\
        title: a pendulum with an error tolerance no step of dt_min meets
        gravity: [0, -9.81, 0]
        sections:
          link: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
        bodies:
          base: {at: [0, 0, 0], fixed: true}
          bob: {at: [1, 0, 0], mass: 1.0}
        beams:
          arm: {from: base, to: bob, section: link, start: {hinge: {axis: [0, 0, 1]}}}
        solve: {analysis: transient, t_end: 2, dt: 0.1, adaptive: true, error_tol: 1.0e-9, dt_min: 0.05}
        output:
          probes:
            a: {hinge: arm.start, quantity: angle}
        """
    completed, out = run_cli(tmp_path, text, timeout=30.0)
    assert completed.returncode == 1, completed.stderr
    assert "the error estimate rejects the step at the minimum step" in completed.stderr
    assert "error_tol asks for steps below dt_min" in completed.stderr
    assert summary(out)["status"] == "failed"


def test_a_minimum_step_lost_in_the_round_off_of_t_is_refused(tmp_path):
    text = DEPLOYING_ARM.replace("dt_min: 2.0e-4", "dt_min: 1.0e-15")
    completed, _ = run_cli(tmp_path, text)
    assert completed.returncode == 2
    assert "solve.dt_min" in completed.stderr and "1e-12 * t_end" in completed.stderr


# ----------------------------------------------------------------------------- mechanisms in statics
HINGED_ARM = """\
    title: a hinged arm that nothing holds against its load
    sections:
      arm: {EA: 1.0e7, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 1.0}
    bodies:
      base: {at: [0, 0, 0], fixed: true}
    beams:
      arm:
        from: base
        to: [1, 0, 0]
        section: arm
        elements: 2
        start: {hinge: {axis: [0, 0, 1]}}
    loads:
      - {at: arm.end, force: [0, -10, 0]}
    solve: {analysis: static, steps: 4}
    output:
      probes:
        tip: {point: arm.end, quantity: displacement, component: y}
    """


@pytest.mark.parametrize("solve", [
    "{analysis: static, steps: 4}",
    "{analysis: static, steps: 4, method: arc-length}",
    "{analysis: static, steps: 4, method: displacement-control, control: {point: arm.end, direction: y, to: -0.5}}",
    "{analysis: buckling}",
])
def test_a_static_analysis_of_a_mechanism_names_the_coordinate_that_nothing_holds(tmp_path, capsys, solve):
    """A hinge with no stiffness under a load across it: no equilibrium near the start for any
    load factor. The message names the hinge, and no limit point (once: "past a limit point load
    control cannot go on"; arc length: "the tangent at load factor 0 is singular")."""
    status, err, _ = main_cli(tmp_path, HINGED_ARM.replace("{analysis: static, steps: 4}", solve), capsys)
    assert status == 1, err
    assert "hinge arm.start" in err and "nothing holds" in err
    assert "limit point load control" not in err and "tangent at load factor 0 is singular" not in err


def test_a_hinge_with_a_stop_is_not_held_by_it_in_statics_and_the_message_says_so(tmp_path, capsys):
    text = HINGED_ARM.replace("{hinge: {axis: [0, 0, 1]}}", "{hinge: {axis: [0, 0, 1], limits: [-0.3, 0.3]}}")
    status, err, _ = main_cli(tmp_path, text, capsys)
    assert status == 1
    assert "hinge arm.start" in err and "transient runs only" in err


def test_a_free_floating_structure_names_its_free_nodes(tmp_path, capsys):
    text = HINGED_ARM.replace("base: {at: [0, 0, 0], fixed: true}", "base: {at: [0, 0, 0], mass: 1.0}")
    text = text.replace("        start: {hinge: {axis: [0, 0, 1]}}\n", "")
    status, err, _ = main_cli(tmp_path, text, capsys)
    assert status == 1, err
    assert "base" in err and "arm.end" in err and "dy" in err and "nothing holds" in err


def test_a_hinge_the_loads_do_not_move_is_named_free_not_pushed(tmp_path, capsys):
    """A tensile load along the arm does not turn the free hinge, but its tangent is singular at
    the start: the message says it is free and that the loads do not move it."""
    status, err, _ = main_cli(tmp_path, HINGED_ARM.replace("force: [0, -10, 0]", "force: [10, 0, 0]"), capsys)
    assert status == 1, err
    assert "hinge arm.start is free" in err and "do not move it" in err


def test_a_held_structure_past_its_limit_point_still_says_limit_point(tmp_path, capsys):
    """The mechanism check looks at the structure's own tangent: a shallow arch of hinged bars
    (Lee's frame) under load control past its limit load keeps the limit-point message."""
    text = (ROOT / "tests" / "test_path_following.py").read_text()
    lee = text.split('LEE = """\\\n', 1)[1].split('"""', 1)[0]
    lee = lee.replace("method: arc-length, steps: 20, max_steps: 400", "steps: 4")
    status, err, _ = main_cli(tmp_path, lee, capsys)
    assert status == 1
    assert "past a limit point" in err and "nothing holds" not in err


# ----------------------------------------------------------------------------- displacement control
def lee_frame() -> str:
    """Lee's frame as tests/test_path_following.py has it (arc length; its deflection v at the load
    turns back at 60.9 in, between the limit points of λ)."""
    text = (ROOT / "tests" / "test_path_following.py").read_text()
    return text.split('LEE = """\\\n', 1)[1].split('"""', 1)[0]


def test_displacement_control_that_meets_a_snap_back_of_its_displacement_says_arc_length_is_needed(
        tmp_path, capsys):
    """Controlled to 100 in in steps of 5 in, Lee's frame's deflection turns back at 60.9 in: the run
    once went on from 60 in to 65 in on the far stretch of the path (the horizontal displacement
    jumped from 52 to 93 in, λ from 0.37 to −0.21), skipped the snap-back loop between, and ended
    "solved". Now it ends at the turn, exit 1, naming it and arc length, its last row at the turn."""
    solve = ("solve: {analysis: static, method: displacement-control, steps: 20, "
             "control: {point: load, direction: [0, -1, 0], to: 100.0}}")
    lee = lee_frame().replace("solve: {analysis: static, method: arc-length, steps: 20, max_steps: 400}", solve)
    status, err, out = main_cli(tmp_path, lee, capsys)
    assert status == 1, err
    assert "turns back" in err and "arc-length" in err
    rows = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)
    lam, u, v = rows[:, 0], rows[:, 1], -rows[:, 2]
    assert np.all(lam >= 0) and np.all(np.diff(u) > 0)  # along the path up to the turn, no jump
    # the turn of v on the arc length's path of the same frame (test_path_following's LEE, measured:
    # v = 60.978 and 60.982 in at λ = 0.3079 and 0.2905, u = 60.70 and 62.66 in)
    assert v[-1] == pytest.approx(60.98, abs=0.02)
    assert lam[-1] == pytest.approx(0.3045, abs=2e-3) and 60.7 < u[-1] < 62.66


# ----------------------------------------------------------------------------- solver_s
COLUMN = """\
    title: a cantilever column under a dead axial load
    sections:
      s: {EA: 1.0e4, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 1.0}
    bodies:
      root: {at: [0, 0, 0], fixed: true}
    beams:
      col: {from: root, to: [1, 0, 0], section: s, elements: 4}
    loads:
      - {at: col.end, force: [-1.0, 0.01, 0]}
    solve: SOLVE
    output:
      paraview_every: 0
      probes:
        tip: {point: col.end, quantity: displacement, component: y}
    """


@pytest.mark.parametrize("solve", ["{analysis: static, steps: 4}", "{analysis: buckling}",
                                   "{analysis: modes, count: 3}", "{analysis: modes, count: 3, about: static}",
                                   "{analysis: transient, t_end: 0.01, dt: 0.005}"])
def test_every_analysis_reports_solver_s(tmp_path, capsys, solve):
    """summary.json solver_s: the time of the solution itself, for every analysis (once transient only)."""
    status, err, out = main_cli(tmp_path, COLUMN.replace("SOLVE", solve), capsys)
    assert status == 0, err
    report = summary(out)
    assert 0.0 < report["solver_s"] <= report["wall_time_s"]


def test_a_failed_static_run_reports_solver_s(tmp_path, capsys):
    status, _, out = main_cli(tmp_path, HINGED_ARM, capsys)
    assert status == 1
    report = summary(out)
    assert report["status"] == "failed" and report["solver_s"] > 0.0


# ----------------------------------------------------------------------------- the crawl guard
def test_the_step_control_ends_a_run_whose_steps_stay_near_the_minimum():
    """Events that re-trigger at the same instant (a stop chattering) keep every step near dt_min
    however the step control grows it back: 1000 accepted steps averaging under 100 dt_min end the
    run (SolverError, exit 1) rather than let it crawl; steps of 200 dt_min go on, and so do steps
    of dt where dt_min = dt (the crawling step is never above dt/1000)."""
    from types import SimpleNamespace

    from latdyn.errors import SolverError
    from latdyn.timeloop.control import CRAWL_STEPS, StepControl

    solve = SimpleNamespace(t_end=1.0, dt=1e-2, dt_min=None, adaptive=False, error_tol=1e-4)

    def accepted_steps(size: float, count: int, dt_min: float | None = None) -> float:
        control = StepControl(SimpleNamespace(**{**vars(solve), "dt_min": dt_min}), None, 1.0)
        run = SimpleNamespace(state=SimpleNamespace(t=0.1), h=control.dt)
        for _ in range(count):
            run.state.t += size
            control.after_accepted(run, None, size, latched=True, stopped=True)
        return run.state.t

    assert accepted_steps(200 * 1e-8, 3 * CRAWL_STEPS) > 0.1
    assert accepted_steps(1e-2, 3 * CRAWL_STEPS, dt_min=1e-2) > 0.1  # dt_min = dt: steps of dt never crawl
    with pytest.raises(SolverError, match="stays near the minimum step") as failure:
        accepted_steps(3 * 1e-8, 3 * CRAWL_STEPS)
    assert "ended on a latch or a stop" in str(failure.value) and "a stop chattering" in str(failure.value)


# ----------------------------------------------------------------------------- a stop to rest on
RESTING = """\
    title: a pendulum that falls onto its stop, bounces and comes to rest on it
    gravity: [0, -9.81, 0]
    sections:
      arm: {EA: 1.0e10, EIy: 1.0e9, EIz: 1.0e9, GJ: 1.0e9, rhoA: 0.01}
    bodies:
      pivot: {at: [0, 0, 0], fixed: true}
      bob: {at: [1, 0, 0], mass: 1.0}
    beams:
      arm:
        from: pivot
        to: bob
        section: arm
        start:
          hinge: {axis: [0, 0, 1], damping: "0.01*theta_dot**2", limits: [-0.3, 0.3], restitution: 0.5}
    solve: {analysis: transient, t_end: 2, dt: 0.01, adaptive: true}
    output:
      probes:
        angle: {hinge: arm.start, quantity: angle}
        rate: {hinge: arm.start, quantity: rate}
    """


def test_a_hinge_that_comes_to_rest_on_its_stop_rests_there(tmp_path):
    """Bounces of e = 0.5 ever shorter, at ever closer instants (the Zeno sequence of a stop with
    restitution under a load that holds the hinge on it): once a bounce is shorter than a step the
    hinge rests, rate 0. It once kept a bounce of e × (the rate gravity gives in one step) at
    every step for ever: a rate of 0.031 rad/s recorded at rest, the stop hit again each step."""
    completed, out = run_cli(tmp_path, RESTING, timeout=60.0)
    assert completed.returncode == 0, completed.stderr
    rows = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)
    t, angle, rate = rows.T
    first = int(np.argmax(angle <= -0.3 + 1e-9))
    assert rate[first] > 0.3 * abs(rate[first - 1])  # the first impact bounces with its restitution
    resting = t > 1.0
    np.testing.assert_allclose(angle[resting], -0.3, atol=1e-9)
    np.testing.assert_allclose(rate[resting], 0.0, atol=1e-12)


GUIDED_SLIDER = """\
    title: a slider on a guide that nothing holds, loaded along and across it
    sections:
      s: {EA: 1.0e6, EIy: 100, EIz: 100, GJ: 80, rhoA: 1}
    bodies:
      base: {at: [0, 0, 0], fixed: true}
      slider:
        at: [1, 0, 0]
        mass: 2.0
        guide: {axis: [1, 0, 0]}
    beams:
      arm: {from: base, to: [0, 1, 0], section: s, elements: 2}
    loads:
      - {at: slider, force: [10, -10, 0]}
    solve: {analysis: static, steps: 2}
    """


@pytest.mark.parametrize("force, said", [("[10, -10, 0]", "the loads move guide slider, which nothing holds"),
                                         ("[0, -10, 0]", "guide slider is free at load factor 0"),
                                         ("[10, -10, 0]", "nothing holds guide slider: no stiffness")])
def test_a_guide_that_nothing_holds_is_named_whole(tmp_path, capsys, force, said):
    """A guide's slide is one coordinate, named as a joint ("guide slider"), not as a node's
    component ("guide slider: " with nothing after the colon, found by benchmarks/fuzz_runs.py)."""
    text = GUIDED_SLIDER.replace("[10, -10, 0]", force)
    if "no stiffness" in said:
        text = text.replace("{analysis: static, steps: 2}", "{analysis: buckling}")
    status, err, _ = main_cli(tmp_path, text, capsys)
    assert status == 1, err
    assert said in err and "slider: :" not in err and "slider:  " not in err


DIVERGING_LAW_SPRING = """\
    title: an explicit run past its stability limit, with a law spring whose angle runs away
    sections:
      s0: {EA: 2422299.0, EIy: 1757.9, EIz: 1757.9, GJ: 834.7, rhoA: 0.659}
      s1: {EA: 4654948.0, EIy: 825.8, EIz: 825.8, GJ: 360.1, rhoA: 1.486, rhoIy: 0.00043, rhoIz: 0.00043, GAy: 4628845.0, GAz: 4628845.0}
    bodies:
      g:
        at: [0, 0, 0]
        fixed: true
      b1:
        at: [0.0, -1.4, 0.0]
        mass: 2.419
    beams:
      m0:
        from: g
        section: s0
        to: [0.0, -0.46, 0.0]
        elements: 3
        start:
          hinge:
            axis: [0.0, 0.0, 1.0]
            stiffness: 237.04
            damping: 4.097*(1 + abs(theta_dot))
            friction: {coulomb: 1.137}
      m1:
        from: g
        section: s1
        to: b1
        elements: 2
        y_axis: [0, 0, 1]
        start:
          hinge:
            axis: [1.0, 0.0, -0.0]
            stiffness: 100.45*(1 + theta**2)
            limits: [-0.365, 0.73]
            contact: {stiffness: 4583.0, exponent: 1.5}
      m2:
        from: b1
        section: s0
        to: [0.0, -2.56, 0.0]
        elements: 2
    gravity: [0, 0, -9.81]
    initial_velocity:
      linear: [0.91, 0.46, 0]
      angular: [0, 0, -0.61]
    loads:
    - at: m1.node[1]
      force: [0, 0, 0]
    - at: m2.node[1]
      force: [0, 0, -7.45*sin(3*t)]
      frame: g
    solve: {analysis: transient, t_end: 0.02, dt: 0.0002, method: explicit}
    output:
      probes:
        p0: {point: 'm1.node[1]', quantity: velocity, component: y}
        p1: {energy: potential}
        h_m0_start: {hinge: m0.start, quantity: angle}
        h_m1_start: {hinge: m1.start, quantity: torque}
      every: 0.0004
    inputs: {u: 0.19}
    """


def test_a_run_whose_law_springs_angle_diverges_ends(tmp_path):
    """An explicit run far past its stability limit drove a law spring's angle to ~1e15 rad, and the
    spring's potential (csrc/evaluate.c law_spring_potential: 16 Gauss points a 0.25 rad piece) then
    looped over ~4e15 pieces: the run never ended, and as the loop is in C, not even SIGTERM stopped it
    (found by benchmarks/fuzz_runs.py --joints, seed 7, case 21). The pieces are now at most 4096: the
    run ends, refused as unstable or unbounded, in seconds."""
    completed, out = latdyn_run(tmp_path, textwrap.dedent(DIVERGING_LAW_SPRING), quiet=True, timeout=120)
    assert completed.returncode == 1, completed.stderr
    assert "unstable" in completed.stderr or "unbounded" in completed.stderr, completed.stderr
    assert json.loads((out / "summary.json").read_text())["status"] in ("failed", "unbounded")
