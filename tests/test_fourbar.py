"""D5 four-bar: rocker − crank reaches −2π because the linkage changes branch (docs/verification.md,
section "D5 four-bar: the 2π after the collinear position"; study: benchmarks/fourbar_branch.py).

The 5° misaligned hinge at C makes the flexible linkage leave the parallelogram branch at the
first collinear (change) point t = π/(2·0.6) s, follow the crossed (antiparallelogram) branch —
crank +π, rocker −π — and return to the parallelogram at the second change point, one rocker
turn behind the crank.  The hinge-angle probes are accumulated angles (no wrap): they equal
the chord angles from the point probes, unwrapped.
"""
from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

fb = pytest.importorskip("benchmarks.fourbar_branch")
import latdyn  # noqa: E402

warnings.filterwarnings("ignore", category=RuntimeWarning, module="latdyn")

T1, T2 = fb.T_DEAD  # 2.618 s, 7.854 s


def test_rigid_fourbar_has_two_branches_meeting_at_the_collinear_positions():
    """Grashof equality case (s + l = p + q): the crank–rocker relation is two-valued."""
    f1 = np.linspace(T1 * fb.OMEGA, T2 * fb.OMEGA, 41)
    anti = fb.antiparallelogram_rocker(f1)
    assert np.max(np.abs(fb.loop_gap(f1, anti))) < 1e-12  # the crossed branch closes the loop
    assert np.max(np.abs(fb.loop_gap(f1, f1))) < 1e-12  # so does the parallelogram
    assert np.max(np.abs(fb.antiparallelogram_residual(f1, anti))) < 1e-12
    # they meet only at the change points, where the rocker is collinear with the ground too
    assert anti[0] == pytest.approx(math.pi / 2, abs=1e-12)
    assert anti[-1] == pytest.approx(-math.pi / 2, abs=1e-12)
    assert np.all(np.abs(anti[1:-1] - f1[1:-1]) > 0.1)
    # net rotations between the change points: crank +π, rocker −π
    assert anti[-1] - anti[0] == pytest.approx(-math.pi, abs=1e-12)
    # the misfit of the 5° hinge grows with its rotation: √2·δ at 90°, 2δ at 180°
    assert math.degrees(fb.misfit_angle(math.pi / 2)) == pytest.approx(7.07, abs=0.01)
    assert math.degrees(fb.misfit_angle(math.pi)) == pytest.approx(10.0, abs=1e-9)
    phi = np.linspace(0, math.pi, 50)
    assert np.all(np.diff(fb.misfit_angle(phi)) > 0)


def test_hinge_angle_probe_is_not_reduced_modulo_2pi():
    """A prescribed hinge turned past 2π: the probe reports the accumulated angle."""
    scene = {
        "sections": {"s": {"EA": 1e6, "EIy": 1e3, "EIz": 1e3, "GJ": 1e3, "rhoA": 1.0,
                           "rhoIy": 1e-3, "rhoIz": 1e-3}},
        "bodies": {"hub": {"at": [0, 0, 0], "fixed": True}},
        "beams": {"arm": {"from": "hub", "to": [1, 0, 0], "section": "s", "elements": 1,
                          "start": {"hinge": {"axis": [0, 0, 1], "angle": "2*t**2"}}}},
        "solve": {"analysis": "transient", "t_end": 2.0, "dt": 0.01},
        "output": {"every": 0.1, "probes": {
            "angle": {"hinge": "arm.start", "quantity": "angle"},
            "x": {"point": "arm.end", "quantity": "position", "frame": "global", "component": "x"},
            "y": {"point": "arm.end", "quantity": "position", "frame": "global", "component": "y"}}},
    }
    r = latdyn.run(scene, out_dir=None)
    t, angle = np.asarray(r.t), np.asarray(r.probes["angle"])
    assert angle[-1] == pytest.approx(8.0, abs=1e-9)
    assert np.allclose(angle, 2 * t**2, atol=1e-9)
    chord = np.unwrap(np.arctan2(r.probes["y"], r.probes["x"]))
    assert np.max(np.abs(chord - angle)) < 1e-2  # elastic lag of the tip only; a wrap would be 2π


@pytest.fixture(scope="module")
def fourbar():
    """The D5 scene as shipped (dt 0.004, 4 elements per bar), past the second change point."""
    case = fb.run_case("test", t_end=8.4, every=0.02)
    print(f"\n  D5 to 8.4 s: wall {case['wall_s']:.1f} s")
    return case


def test_fourbar_follows_the_crossed_branch_between_the_change_points(fourbar):
    t, p = fourbar["t"], fourbar["p"]
    f1, f3, hc = p["crank"], p["rocker"], p["hinge_C"]
    assert t[-1] == pytest.approx(8.4, abs=1e-6)

    before = t <= T1 - 0.2
    assert np.max(np.abs(f3 - f1)[before]) < 0.02  # parallelogram
    crossed = (t >= T1 + 0.3) & (t <= T2 - 0.3)
    assert np.max(np.abs(fb.antiparallelogram_residual(f1, f3)[crossed])) < 0.02
    assert np.min(np.abs(fb.parallelogram_residual(f1, f3)[crossed])) > 0.1
    assert np.max(np.abs(hc - (f1 - math.pi))[crossed]) < 0.02  # hinge C: φ_C = φ1 − π
    after = t >= T2 + 0.3
    assert np.max(np.abs(f3 - f1 + 2 * math.pi)[after]) < 0.01  # parallelogram again, one turn behind

    # the rocker turns back exactly at the change points, on the ground line
    (t_a, top), (t_b, bottom) = fb.turning_points(t, f3)
    assert t_a == pytest.approx(T1, abs=0.1) and top == pytest.approx(math.pi / 2, abs=0.01)
    assert t_b == pytest.approx(T2, abs=0.1) and bottom == pytest.approx(-math.pi / 2, abs=0.01)
    # the misaligned hinge never turns more than a quarter turn (the parallelogram would take it to π)
    assert np.max(np.abs(hc)) < math.pi / 2 + 0.02


def test_fourbar_branch_switch_is_quasi_static_and_unwrapped(fourbar):
    t, p = fourbar["t"], fourbar["p"]
    # no wrap: hinge probes = chord angles from the point probes, unwrapped (elastic end slopes only)
    g1, g3 = fb.geometric_angles(p)
    assert np.max(np.abs(g1 - p["crank"])) < 5e-3
    assert np.max(np.abs(g3 - p["rocker"])) < 5e-3
    # strain energy peaks at the first change point and is released on the crossed branch
    first = t < T1 + 1.0
    assert t[first][np.argmax(p["strain"][first])] == pytest.approx(T1, abs=0.04)
    i = int(np.argmin(np.abs(t - (T1 + 1.0))))
    assert p["strain"][i] < 0.6 * np.max(p["strain"][first])
    # inertia is negligible: the elastic energy, not momentum, chooses the branch
    assert np.max(p["kinetic"]) < 1e-2 * np.max(p["strain"])
    # and the drive's work is accounted for through the switch (no numerical dissipation event)
    assert np.max(np.abs(p["energy"] - p["work"])) < 5e-3
