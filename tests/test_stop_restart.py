"""After an impact on a stop the motion goes on from accelerations that belong to it (issue 30,
follow-up of items 3 and 5).

A stiff flexible pendulum (EI = 1e9, ρA = 0.01, a 1 kg bob, no rotary inertia) falls onto its stop
with restitution e at fixed steps.  The step that lands on the stop is shortened to as little as
1e-7 s; its algorithmic acceleration on the stiff directions with little inertia (the bob node's
rotation, the hinge's own spin, inertia 1e-4, stiffness 4e9) is Newton's tolerance over h² — 1e4
rad/s² — and it used to go on into the next steps (only the hinge's was zeroed): the rates rang,
each bounce made it worse, the pendulum was flung off its stop at ~150 rad/s² and the run ended
with "Newton failed below the minimum step" (e = 0.5).  The accelerations now restart after the
impact from the equations of motion, stiff directions quasi-static at the nominal step
(latdyn.timeloop.events.restart_accelerations).  Scenes as YAML text through the CLI.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

STOP = """\
    title: a pendulum that falls onto its stop and comes to rest there
    gravity: [0, -9.81, 0]
    sections:
      arm: {{EA: 1.0e10, EIy: 1.0e9, EIz: 1.0e9, GJ: 1.0e9, rhoA: 0.01}}
    bodies:
      pivot: {{at: [0, 0, 0], fixed: true}}
      bob: {{at: [1, 0, 0], mass: 1.0}}
    beams:
      arm:
        from: pivot
        to: bob
        section: arm
        start:
          hinge: {{axis: [0, 0, 1], damping: "0.01*theta_dot**2", limits: [-0.3, 0.3], restitution: {e}}}
    solve: {{analysis: transient, t_end: 2, dt: 0.01, adaptive: false}}
    output:
      probes:
        angle: {{hinge: arm.start, quantity: angle}}
        rate: {{hinge: arm.start, quantity: rate}}
    """


@pytest.mark.parametrize("e", [0.05, 0.5])
def test_a_stiff_pendulum_bounces_on_its_stop_by_newtons_law_and_comes_to_rest(tmp_path, e):
    """Every bounce reverses the rate by −e; between bounces the pendulum moves under gravity alone
    (|θ̈| ≤ g (m_b L + m_r L/2)/J cos θ ≈ 9.83 rad/s², here ≤ 12 with the damper; it was flung at
    ~150 rad/s² and the run failed at t = 0.70 s); it comes to rest on the stop; no step is cut.
    Measured: e = 0.5 bounces 2.403 → 1.202, 1.200 → 0.601, 0.600 → 0.300, 208 steps."""
    scene, out = tmp_path / "scene.yaml", tmp_path / "out"
    scene.write_text(textwrap.dedent(STOP.format(e=e)))
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "solved" and summary["newton_cuts"] == 0
    t, angle, rate = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1).T
    on_stop = angle == -0.3
    impacts = np.nonzero(on_stop[1:] & (rate[:-1] < -1e-3) & (rate[1:] > 0))[0] + 1
    assert len(impacts) >= (3 if e == 0.5 else 1)
    for i in impacts:
        # the rate that met the stop: the row before's (the step before the one landed on the stop, up to dt
        # earlier: the landing ends on the stop in one step, latdyn.timeloop.landing) carried to the impact's time
        # by the acceleration of the two rows before (gravity; 2.3305 at t = 0.24 is 2.4027 at 0.24767). Measured:
        # e times 1.00105, 1.01045 (e = 0.05; the second bounce's rows before it are the first's slow rebound),
        # 1.00105, 1.00001, 0.99983, 0.99997, 0.99992 (e = 0.5)
        slope = (rate[i - 1] - rate[i - 2]) / (t[i - 1] - t[i - 2])
        assert rate[i] == pytest.approx(-e * (rate[i - 1] + slope * (t[i] - t[i - 1])), rel=2e-2)
    # after the first impact, between impacts: gravity only (rows a step of at least dt/10 apart
    # that span no impact and are not on the stop; the steps shortened onto the stop show their own
    # error, 1e-3 rad/s). Measured ≤ 9.6. (Before the first impact the rate rings from t = 0, ±2.3
    # rad/s² about 9.4 at first, decaying: the start, not the impacts — issue 30 item 3's branch.)
    free = ~on_stop[1:] & ~on_stop[:-1] & (np.diff(t) >= 1e-3) & (t[:-1] > t[impacts[0]])
    acceleration = np.diff(rate)[free] / np.diff(t)[free]
    assert np.max(np.abs(acceleration)) < 12.0
    first = impacts[0]
    assert np.max(np.abs(rate[first:])) < np.max(np.abs(rate[:first]))  # never faster than the fall
    assert angle[-1] == -0.3 and rate[-1] == 0.0  # at rest on the stop
