"""Contact and friction on sliding joints (SCENE.md "Contact and friction at joints": hinges *and*
guides), through the front door: a guide's law is evaluated by the hinge's code (docs/guides.md), so
the same closed forms hold with the slide s for θ and the mass for the inertia.

- A mass m = 0.01 on a spring k = 1 along an oblique guide, released 0.45 from the spring's rest with
  Coulomb friction F = 0.1: the amplitude falls by 2F/k a half cycle, the half period stays π√(m/k), it
  sticks inside |s − s_r| ≤ F/k and stays (rate 0), the dissipated energy is the loss.
- A mass sliding at v into a Hertz stop (n = 3/2) on a guide: the peak penetration
  ((n+1) m v²/2k)^{1/(n+1)}, the peak force k δⁿ as the joint's force probe and `joint_peaks`, rebound at −v.
"""
from __future__ import annotations

import numpy as np
import pytest

from cli_runs import latdyn_run, probe_columns, summary_of
from test_contact import check_coulomb_oscillator

GUIDED = """
bodies:
  m: {{at: [0.3, -0.2, 0.1], mass: {mass}, guide: {{axis: {axis}, {guide}}}}}
initial_velocity: {{linear: {velocity}, about: [0.3, -0.2, 0.1]}}
solve: {{t_end: {t_end}, dt: {dt}}}
output:
  probes:
    angle: {{guide: m, quantity: position}}
    rate: {{guide: m, quantity: rate}}
    force: {{guide: m, quantity: force}}
    total: {{energy: total}}
    dissipated: {{energy: dissipated}}
"""


def guided(guide: str, *, axis=(2, -1, 2), speed=0.0, mass=0.01, t_end=0.8, dt=0.004) -> str:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return GUIDED.format(mass=mass, axis=list(axis), guide=guide, velocity=[float(speed * x) for x in a],
                         t_end=t_end, dt=dt)


def test_coulomb_friction_on_an_oblique_guide_through_the_cli(tmp_path):
    """The torsional oscillator's numbers (tests/test_contact.py) with s for θ and m for I."""
    scene = guided("stiffness: 1.0, rest: 0.45, friction: {coulomb: 0.1}")
    done, out = latdyn_run(tmp_path, scene)
    assert done.returncode == 0, done.stderr
    p = probe_columns(out)
    check_coulomb_oscillator(p["t"], p, summary_of(out))


def test_a_hertz_stop_on_a_guide_gives_the_peak_load_in_closed_form(tmp_path):
    m, v, k, n, stop = 2.0, 1.0, 1.0e5, 1.5, 0.05
    scene = guided(f"limits: [-1, {stop}], contact: {{stiffness: {k}, exponent: {n}}}", speed=v, mass=m,
                   t_end=0.15, dt=0.0002)
    done, out = latdyn_run(tmp_path, scene)
    assert done.returncode == 0, done.stderr
    p, summary = probe_columns(out), summary_of(out)
    depth = ((n + 1) * m * v**2 / (2 * k)) ** (1 / (n + 1))
    assert p["angle"].max() - stop == pytest.approx(depth, rel=2e-3)
    # the joint's force: the stop pushes s down (negative), its peak k δⁿ
    assert -p["force"].min() == pytest.approx(k * depth**n, rel=5e-3)
    peak = summary["joint_peaks"]["m"]
    assert peak["peak"] == pytest.approx(p["force"].min(), rel=1e-12)
    assert p["rate"][-1] == pytest.approx(-v, rel=2e-3)  # elastic: rebounds at −v
    assert p["dissipated"][-1] == pytest.approx(0.0, abs=1e-9)
