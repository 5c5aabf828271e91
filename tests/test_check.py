"""`latdyn check`: what the model carries and why, and warnings on dt and element rotations."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

from latdyn.cli import main

SECTION = {"EA": 1e6, "EIy": 100.0, "EIz": 100.0, "GJ": 80.0, "rhoA": 1.0}


def run_check(tmp_path, capsys, scene: dict) -> str:
    import yaml

    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene, sort_keys=False))
    assert main(["check", str(path)]) == 0
    return capsys.readouterr().out


def cantilever(dt: float, **extra) -> dict:
    """A 2 m cantilever of 8 elements: f1 = 1.8751²/(2π) √(EI/(ρA L⁴)) = 1.3994 Hz (Euler–Bernoulli)."""
    return {
        "sections": {"s": SECTION},
        "bodies": {"wall": {"at": [0, 0, 0], "fixed": True}},
        "beams": {"arm": {"from": "wall", "to": [2, 0, 0], "section": "s", "elements": 8}},
        "solve": {"t_end": 1.0, "dt": dt, **extra},
    }


F1 = 1.875104**2 / (2 * math.pi) * math.sqrt(100.0 / (1.0 * 2.0**4))


def test_report_counts_coordinates_per_kind_and_what_was_removed(tmp_path, capsys):
    scene = {
        "sections": {"s": SECTION},
        "bodies": {"ground": {"at": [0, 0, 0], "fixed": True},
                   "hub": {"at": [0, 0, 1], "motion": {"rotation": {"axis": [0, 0, 1], "angle": "t"}}},
                   "elbow": {"at": [1, 0, 0], "mass": 1.0}},
        "beams": {"a": {"from": "ground", "to": "elbow", "section": "s", "elements": 3,
                        "start": {"hinge": {"axis": [0, 0, 1], "stiffness": 5, "lock_at": 1.0}}},
                  "b": {"from": "hub", "to": [1, 0, 1], "section": "s", "elements": 2,
                        "start": {"hinge": {"axis": [0, 1, 0], "angle": "0.1*t"}}},
                  "c": {"from": "elbow", "to": [2, 0, 0], "section": "s", "elements": 1,
                        "start": {"hinge": {"axis": [0, 0, 1], "limits": [-1, 1]}}}},
        "solve": {"t_end": 1.0, "dt": 0.001},
    }
    out = run_check(tmp_path, capsys, scene)
    # free nodes: elbow, a.node[1..2], b.node[1], b.end, c.end = 6; free hinges: a.start, c.start
    assert "model: 8 nodes (6 free), 6 elements, 3 hinges (2 with a coordinate), 38 coordinates" in out
    assert "coordinates: 18 node translations + 18 node rotations + 2 hinge angles = 38" in out
    assert "nodes: 3 joint bodies, 3 interior beam nodes, 2 free beam ends" in out
    assert ("removed: 6 for 1 fixed bodies (ground); 6 for 1 prescribed bodies (hub); "
            "1 for 1 prescribed hinge angles (b.start)") in out
    assert "events: 1 joints with lock_at (a.start)" in out and "1 joints with rigid stops (c.start (e = 0))" in out


def test_dt_too_large_for_the_lowest_mode_is_warned_with_its_frequency(tmp_path, capsys):
    coarse = run_check(tmp_path, capsys, cantilever(dt=0.1))
    found = float(re.search(r"lowest non-rigid mode: ([\d.]+) Hz", coarse).group(1))
    assert found == pytest.approx(F1, rel=1e-3)
    assert "warning: dt = 0.1 cannot resolve the lowest non-rigid mode" in coarse
    fine = run_check(tmp_path, capsys, cantilever(dt=0.01))
    assert "steps per period at dt = 0.01" in fine and "warning" not in fine


def test_element_rotation_beyond_the_sine_measure_is_warned(tmp_path, capsys):
    """A tip moment M bends the cantilever to curvature M/EI: each of the 8 elements turns its
    ends by ±κ L_e / 2 against its chord, sin(0.25 M L_e / EI ...) > 0.5 for M = 600."""
    scene = cantilever(dt=0.001, formulation="no_stiffening")
    scene["loads"] = [{"at": "arm.end", "moment": [0, 0, 600.0]}]
    out = run_check(tmp_path, capsys, scene)
    assert re.search(r"warning: element arm\.element\[\d\] turns sin φ = [\d.]+ against its chord in a linear "
                     r"static estimate", out)
    scene["loads"] = [{"at": "arm.end", "moment": [0, 0, 10.0]}]
    assert "turns sin" not in run_check(tmp_path, capsys, scene)


def test_prescribed_hinge_angle_at_t0_is_checked_at_the_initial_configuration(tmp_path, capsys):
    scene = cantilever(dt=0.001, formulation="no_stiffening")
    scene["beams"]["arm"]["start"] = {"hinge": {"axis": [0, 0, 1], "angle": 0.7}}
    scene["beams"]["arm"]["elements"] = 1
    out = run_check(tmp_path, capsys, scene)
    assert "warning: element arm.element[0] turns sin φ = 0.644 against its chord at the initial configuration" in out



#: A rod on a hinge whose torque grows with the angle (a negative spring, 2000 N m/rad), stiff out
#: of its plane (EIy) so that the modes (3D) list its in-plane bending second, as check (planar) sees it.
PUSHED = """\
sections:
  rod: {EA: 1.0e6, EIy: 1.0e6, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  rod: {from: base, to: [0, 1, 0], section: rod, elements: 4, start: {hinge: {axis: [0, 0, 1], torque: "2000*theta"}}}
solve: {t_end: 1.0, dt: 0.001}
"""


def test_a_divergent_mode_is_not_the_lowest_mode_dt_must_resolve(tmp_path, capsys):
    """The hinge mode diverges at about the rate s = √(2000/(ρA L³/3)) = 77/s of a rigid rod (natural
    frequency s/2π = 12.3 Hz, the flexible rod's 12.6, damping ratio −1 in the modes about the initial
    configuration); it does not oscillate, so the lowest mode check holds dt against is the next one,
    the rod's first bending mode about its hinge (pinned–free without the negative spring:
    3.9266² √(EI/ρA L⁴)/2π = 245 Hz)."""
    path = tmp_path / "pushed.yaml"
    path.write_text(PUSHED)
    assert main(["check", str(path)]) == 0
    found = float(re.search(r"lowest non-rigid mode: ([\d.]+) Hz", capsys.readouterr().out).group(1))
    path.write_text(PUSHED.replace("solve: {t_end: 1.0, dt: 0.001}", "solve: {analysis: modes, count: 2}"))
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "--quiet"]) == 0
    rows = [line.split(",") for line in (tmp_path / "out" / "modes.csv").read_text().splitlines()[1:]]
    divergent, bending = ([float(x) for x in row] for row in rows)
    assert divergent[2] == -1.0 and divergent[3] == pytest.approx(np.sqrt(6000) / (2 * math.pi), rel=0.03)
    assert 200 < bending[1] < 250 and found == pytest.approx(bending[1], rel=5e-4)
