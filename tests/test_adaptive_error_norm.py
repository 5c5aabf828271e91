"""Adaptive steps measure every coordinate with inertia (issue 30, follow-up of item 5).

The error estimate of an adaptive step is a mass-weighted joint norm
(:func:`latdyn.numerics.inertia.joint_norms`).  It used to give weight 0 to every joint without
translational mass — the hinge of a rigid link on a fixed body, a body with rotary inertia only —
so such a model took its nominal steps ``dt`` with no rejection and reported a wrong answer as
"solved" (a rigid pendulum: θ(2) = −0.335 against −0.297).  Each scene here is YAML text through
``python -m latdyn run`` and is checked against a closed form or a converged reference.
"""
from __future__ import annotations

import csv
import json
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from cli_runs import latdyn_run, summary_of



def run_cli(tmp_path: Path, text: str) -> Path:
    """``latdyn run`` of the scene ``text``; the results folder (the run must be solved)."""
    done, out = latdyn_run(tmp_path, textwrap.dedent(text), quiet=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert summary_of(out)["status"] == "solved"
    return out


def final_angle(out: Path) -> float:
    with open(out / "probes.csv") as f:
        rows = list(csv.DictReader(f))
    return float(rows[-1]["a"])


RIGID_PENDULUM = """\
    title: a rigid pendulum released horizontally
    gravity: [0, -9.81, 0]
    sections:
      link: {EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
    bodies:
      base: {at: [0, 0, 0], fixed: true}
      bob: {at: [1, 0, 0], mass: 1.0}
    beams:
      arm: {from: base, to: bob, section: link, rigid: true, start: {hinge: {axis: [0, 0, 1]}}}
    solve: {analysis: transient, t_end: 2, dt: 0.1, adaptive: true, error_tol: 1.0e-5}
    output:
      probes:
        a: {hinge: arm.start, quantity: angle}
    """


def test_a_rigid_pendulum_adaptive_run_meets_its_tolerance(tmp_path):
    """The hinge of a rigid link on a fixed body is a joint without translational mass.  Reference:
    the pendulum's equation J θ̈ = −g (m_b L + m_r L/2) cos θ, J = m_b L² + m_r L²/3 (bob 1 kg, rod
    1 kg, L = 1 m), integrated to 1e-12 (it equals a fixed-step run at dt = 5e-4 to 2e-7: −0.297212).
    Before the fix: 20 steps of dt, none rejected, θ(2) = −0.335 (error 0.038); after it, 139 steps
    and an error of 8.3e-4 rad (error_tol 1e-5; at 1e-6: 278 steps, 2e-4 rad), 106 (252) trials rejected;
    since the accepted steps' own estimate sizes the next step (docs/stepping.md): 140 steps, 14
    rejected, 8.0e-4 rad (at 1e-6: 289 steps, 16 rejected, 1.9e-4 rad)."""
    out = run_cli(tmp_path, RIGID_PENDULUM)
    k = 9.81 * 1.5 / (4.0 / 3.0)
    exact = solve_ivp(lambda t, y: [y[1], -k * np.cos(y[0])], (0.0, 2.0), [0.0, 0.0],
                      rtol=1e-12, atol=1e-12).y[0, -1]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"] > 100  # the error estimate sees the hinge: far more than t_end/dt = 20
    assert abs(final_angle(out) - exact) < 2e-3  # 8.3e-4 measured; 0.038 before


@pytest.mark.parametrize("rigid", ["true", "false"])
def test_a_body_with_rotary_inertia_only_on_a_hinge_meets_its_tolerance(tmp_path, rigid):
    """The class: a joint with inertia but no mass.  A wheel of inertia J = 2 and no mass on a
    massless spoke (a rigid link, or a flexible beam whose end node then has rotary inertia only),
    on a hinge spring k = 8 preloaded to rest_angle 0.5: θ = 0.5 (1 − cos ω t), ω = (k/J)^½ = 2.
    Before the fix both ran 6 steps of dt = 0.5 with no rejection (θ(3) off by 0.11 and 0.32);
    after it (error_tol 1e-5) the rigid one 110 steps, off by 2.8e-4 (at 1e-6: 231 steps, 7e-5; the
    flexible one at 1e-6: 278 steps, 2.6e-4, it also starts a dt/2 late, issue 30 item 3). Since the
    accepted steps' own estimate sizes the next step (docs/stepping.md; measured with the flexible one's
    start as it is now): rigid 110 steps, 7 rejected (100 before), 2.7e-4 (at 1e-6: 235, 6 rejected (219),
    6.1e-5); flexible 132, 6 rejected (121), 2.0e-4 (at 1e-6: 282, 8 rejected (267), 5.0e-5 (5.1e-5))."""
    out = run_cli(tmp_path, f"""\
        title: a wheel with rotary inertia only on a hinge spring
        sections:
          spoke: {{EA: 1.0e8, EIy: 1.0e6, EIz: 1.0e6, GJ: 1.0e6, rhoA: 0.0}}
        bodies:
          base: {{at: [0, 0, 0], fixed: true}}
          wheel: {{at: [1, 0, 0], inertia: [2.0, 2.0, 2.0]}}
        beams:
          spoke:
            from: base
            to: wheel
            section: spoke
            rigid: {rigid}
            start: {{hinge: {{axis: [0, 0, 1], stiffness: 8.0, rest_angle: 0.5}}}}
        solve: {{analysis: transient, t_end: 3, dt: 0.5, adaptive: true, error_tol: 1.0e-5}}
        output:
          probes:
            a: {{hinge: spoke.start, quantity: angle}}
        """)
    exact = 0.5 * (1.0 - np.cos(2.0 * 3.0))
    assert abs(final_angle(out) - exact) < 2e-3


def test_joint_norms_measure_joints_without_translational_mass():
    """Unit check of the norm: a joint with mass m counts a rotation by its lever arm (J/m)^½; a
    lone hinge of inertia J counts by (J/m̄)^½, m̄ the mean mass of the joints that have one, or,
    in a model where none has, by ℓ·|θ|; a joint without any inertia counts 0."""
    from latdyn.numerics.inertia import JointBlocks, joint_norms
    groups = np.array([[0, -1], [1, 2], [3, -1]])
    blocks = np.zeros((3, 2, 2))
    blocks[0, 0, 0] = 5.0           # a hinge, inertia 5, nothing else
    blocks[1] = np.diag([2.0, 8.0])  # a translation of mass 2 and a rotation of inertia 8
    joint = JointBlocks(groups, blocks, np.ones((3, 2)), np.array([0.0, 2.0, 0.0]))
    size = joint_norms(joint, np.array([0.1, 0.0, 0.1, 0.7]), 3.0)
    assert size == pytest.approx([np.sqrt(5 * 0.01 / 2), 0.2, 0.0])
    massless = JointBlocks(groups[:1], blocks[:1], np.ones((1, 2)), np.zeros(1))
    assert joint_norms(massless, np.array([0.1]), 3.0) == pytest.approx([0.3])
