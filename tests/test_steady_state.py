"""``about: steady`` finds the relative equilibrium that the scene's start leads to, and says whether
it is stable (issue 30, item 2; latdyn/analyses/steady.py, docs/linearisation.md).

A uniform rod (length L, mass m) hinged at the axis of a shaft that spins at Ω about the vertical,
hinge axis horizontal and normal to the rod's plane, gravity g; φ from the downward vertical.  In
the frame turning with the shaft its amended potential is
V(φ) = −m g (L/2) cos φ − ½ Ω² (m L²/3) sin² φ, so V′ = 0 at sin φ = 0 (hanging, upright) or at
cos φ* = 3g / (2 L Ω²) (the cone, when Ω² > 3g/2L).  With I = mL²/3 the small oscillation about a
relative equilibrium has ω² = V″/I = (3g/2L) cos φ − Ω² cos 2φ:
- on the cone: ω = Ω sin φ* (stable);
- hanging: ω² = 3g/2L − Ω² (stable below Ω_c² = 3g/2L, divergent above at rate √(Ω² − 3g/2L));
- upright: divergent at rate √(3g/2L + Ω²).
The hinge has no spring, so nothing else holds the rod: which equilibrium a search finds is all
the search's doing."""
from __future__ import annotations


import numpy as np
import pytest

import latdyn
from cli_runs import latdyn_run, summary_of

G, L = 9.81, 1.0
CRITICAL = np.sqrt(3 * G / (2 * L))  # 3.836 rad/s

ROD = """\
title: rod on a spinning shaft, started {start} deg off the axis
gravity: [0, 0, -{g}]
sections:
  rod: {{EA: 1.0e8, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 2.0}}
bodies:
  shaft:
    at: [0, 0, 0]
    motion:
      rotation: {{axis: [0, 0, 1], angle: "{omega}*t"}}
beams:
  rod:
    from: shaft
    to: [{x!r}, 0, {z!r}]
    section: rod
    {kind}
    start: {{hinge: {{axis: [0, 1, 0]}}}}
solve:
  analysis: modes
  about: steady
  count: 2
"""


def rod(start_deg: float, omega: float, rigid: bool = True) -> str:
    phi = np.radians(start_deg)
    return ROD.format(start=start_deg, g=G, omega=omega, x=float(L * np.sin(phi)), z=float(-L * np.cos(phi)),
                      kind="rigid: true" if rigid else "elements: 4")


def cone(omega: float) -> float:
    """φ* of the stable relative equilibrium (rad): the cone above Ω_c, hanging below."""
    c = 3 * G / (2 * L * omega**2)
    return float(np.arccos(c)) if c < 1 else 0.0


def run_api(tmp_path, text: str):
    path = tmp_path / "rod.yaml"
    path.write_text(text)
    return latdyn.run(latdyn.load_scene(path))


def run_cli(tmp_path, text: str):
    completed, out = latdyn_run(tmp_path, text, name="rod.yaml", timeout=120)
    return completed, summary_of(out) if completed.returncode == 0 else None


@pytest.mark.parametrize("omega", [6.0, 20.0])
@pytest.mark.parametrize("start", [10, 45, 55, 60, 80])
def test_rod_above_the_critical_speed_settles_on_its_cone_from_every_start(tmp_path, start, omega):
    """Every start on one side of the axis leads to the same stable cone: the angle and the frequency
    of the closed form.  (Newton from 10° or 45° at Ω = 20 ended hanging, divergent, "solved".)"""
    result = run_api(tmp_path, rod(start, omega))
    phi = cone(omega)
    assert result.summary["damping_ratios"][0] == 0.0
    assert 2 * np.pi * result.modes[0] == pytest.approx(omega * np.sin(phi), rel=1e-8)
    found = result.summary["steady_state"]
    assert found["stable"] and found["growth_rate"] <= 0.0 and found["found_by"] == "descent"
    assert found["largest_rotation"] == pytest.approx(abs(phi - np.radians(start)), abs=1e-8)
    assert "warnings" not in result.summary


@pytest.mark.parametrize("start", [10, 45, 80])
def test_flexible_rod_settles_on_the_same_cone(tmp_path, start):
    """A stiff flexible rod (4 elements) on a hinge: the cone of the rigid rod, to its bending
    (measured: 1e-5 rad, frequency −7e-5 at Ω = 10)."""
    omega = 10.0
    result = run_api(tmp_path, rod(start, omega, rigid=False))
    phi = cone(omega)
    assert 2 * np.pi * result.modes[0] == pytest.approx(omega * np.sin(phi), rel=5e-4)
    found = result.summary["steady_state"]
    assert found["stable"] and found["found_by"] == "descent"
    assert found["largest_rotation"] == pytest.approx(abs(phi - np.radians(start)), abs=2e-4)


@pytest.mark.parametrize("start", [10, 80])
def test_rod_below_the_critical_speed_hangs(tmp_path, start):
    omega = 3.0
    result = run_api(tmp_path, rod(start, omega))
    found = result.summary["steady_state"]
    assert found["stable"] and found["largest_rotation"] == pytest.approx(np.radians(start), abs=1e-8)
    assert 2 * np.pi * result.modes[0] == pytest.approx(np.sqrt(CRITICAL**2 - omega**2), rel=1e-8)


def test_the_reported_start_through_the_cli(tmp_path):
    """The report: 45° off the axis above the critical speed, through the command line."""
    omega = 20.0
    completed, summary = run_cli(tmp_path, rod(45, omega))
    assert completed.returncode == 0, completed.stderr
    assert 2 * np.pi * summary["modes_hz"][0] == pytest.approx(omega * np.sin(cone(omega)), rel=1e-8)
    assert summary["status"] == "solved" and summary["steady_state"]["stable"] is True
    assert "warning" not in completed.stderr and "warnings" not in summary


@pytest.mark.parametrize("start, growth", [(0, lambda w: np.sqrt(w**2 - CRITICAL**2)),
                                           (180, lambda w: np.sqrt(w**2 + CRITICAL**2))])
def test_a_start_on_an_unstable_equilibrium_is_reported_unstable_through_the_cli(tmp_path, start, growth):
    """A rod started exactly hanging (above Ω_c) or upright is in equilibrium, an unstable one:
    summary.json and stderr say so, with the divergence rate of the closed form."""
    omega = 6.0
    completed, summary = run_cli(tmp_path, rod(start, omega))
    assert completed.returncode == 0, completed.stderr
    found = summary["steady_state"]
    assert found["stable"] is False and found["largest_rotation"] < 1e-12
    assert found["growth_rate"] == pytest.approx(growth(omega), rel=1e-7)
    assert summary["damping_ratios"][0] == -1.0
    assert "unstable" in completed.stderr and any("unstable" in w for w in summary["warnings"])


def test_a_state_found_by_the_fallback_ramp_says_so(tmp_path, monkeypatch):
    """When the descent from the start fails (here: made to fail once), the ramp of the spin rate
    finds a state, and the run says that it may not be the one the start leads to."""
    from latdyn.analyses import steady

    real, calls = steady._definite_shift, []

    def failing_once(K, M):
        calls.append(1)
        return None if len(calls) == 1 else real(K, M)

    monkeypatch.setattr(steady, "_definite_shift", failing_once)
    result = run_api(tmp_path, rod(45, 6.0))
    assert result.summary["steady_state"]["found_by"] == "spin-rate ramp"
    assert any("ramping the spin rate" in w for w in result.summary["warnings"])
