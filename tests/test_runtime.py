"""The runtime end to end: kinematics, invariants, latches, analyses, result files."""
from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import latdyn
from latdyn.numerics.so3 import expm_so3

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "spinup.yaml"


def test_shipped_example_runs_through_the_command_line(tmp_path):
    scene = tmp_path / "spin.yaml"
    text = EXAMPLE.read_text().replace("t_end: 20", "t_end: 0.5")
    scene.write_text(text)
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    header = (out / "probes.csv").read_text().splitlines()[0]
    assert header == "t,tip_v,energy"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "solved" and summary["steps"] == 100
    assert (out / "state.h5").exists() or (out / "state.npz").exists()
    assert (out / "paraview" / "beams.vtkhdf").exists()
    check = subprocess.run([sys.executable, "-m", "latdyn", "check", str(scene)], capture_output=True, text=True)
    assert check.returncode == 0 and "coordinates" in check.stdout


def spinning_arm(**solve):
    """A massless, very stiff arm on a prescribed hub: rigid kinematics must be exact."""
    return {
        "sections": {"s": {"EA": 1e9, "EIy": 1e7, "EIz": 1e7, "GJ": 1e7, "rhoA": 0.0}},
        "bodies": {"hub": {"at": [1, 2, 3], "motion": {"rotation": {"axis": [0, 0, 1], "angle": "0.5*t**2"},
                                                        "translation": ["0.1*t", 0, "sin(t)"]}}},
        "beams": {"arm": {"from": "hub", "to": [3, 2, 3], "section": "s", "elements": 2}},
        "solve": {"analysis": "transient", "t_end": 1.0, "dt": 0.01, **solve},
        "output": {"probes": {
            "x": {"point": "arm.end", "quantity": "position", "component": "x"},
            "y": {"point": "arm.end", "quantity": "position", "component": "y"},
            "z": {"point": "arm.end", "quantity": "position", "component": "z"},
            "local": {"point": "arm.end", "quantity": "position", "frame": "hub", "component": "x"},
        }},
    }


def test_prescribed_rotation_gives_exact_rigid_kinematics():
    result = latdyn.run(spinning_arm())
    t = result.t
    angle = 0.5 * t**2
    np.testing.assert_allclose(result.probes["x"], 1 + 0.1 * t + 2 * np.cos(angle), atol=2e-6)
    np.testing.assert_allclose(result.probes["y"], 2 + 2 * np.sin(angle), atol=2e-6)
    np.testing.assert_allclose(result.probes["z"], 3 + np.sin(t), atol=2e-6)
    np.testing.assert_allclose(result.probes["local"], 2.0, atol=2e-6)


def tumbling(rotation=np.eye(3), shift=np.zeros(3), t_end=1.0, dt=0.005, rho_inf=1.0):
    """A free L-shaped frame (two beams on a massive corner body) tumbling in space."""
    R = np.asarray(rotation)
    P = lambda p: (R @ np.asarray(p, float) + shift).tolist()  # noqa: E731
    V = lambda v: (R @ np.asarray(v, float)).tolist()  # noqa: E731
    return {
        "sections": {"s": {"EA": 1e5, "EIy": 40.0, "EIz": 60.0, "GJ": 30.0, "rhoA": 0.5,
                           "rhoIy": 1e-3, "rhoIz": 2e-3}},
        "initial_velocity": {"linear": V([0.2, 0.0, 0.1]), "angular": V([0.3, 1.1, 2.0]), "about": P([0, 0, 0])},
        "bodies": {"corner": {"at": P([0, 0, 0]), "mass": 2.0,
                              "inertia": (R @ np.diag([0.1, 0.2, 0.3]) @ R.T).tolist()},
                   "tip": {"at": P([0, 1.5, 0]), "mass": 0.3}},
        "beams": {
            "a": {"from": "corner", "to": P([2, 0, 0]), "section": "s", "elements": 4, "y_axis": V([0, 1, 0])},
            "b": {"from": "corner", "to": "tip", "section": "s", "elements": 3, "y_axis": V([0, 0, 1])},
        },
        "solve": {"analysis": "transient", "t_end": t_end, "dt": dt, "rho_inf": rho_inf, "tol": 1e-11},
        "output": {"probes": {
            "Hx": {"momentum": "angular", "component": "x"},
            "Hy": {"momentum": "angular", "component": "y"},
            "Hz": {"momentum": "angular", "component": "z"},
            "Px": {"momentum": "linear", "component": "x"},
            "E": {"energy": "total"},
            "U": {"energy": "strain"},
            "tip_x": {"point": "a.end", "quantity": "displacement", "frame": "corner", "component": "x"},
            "tip_y": {"point": "a.end", "quantity": "displacement", "frame": "corner", "component": "y"},
            "tip_z": {"point": "a.end", "quantity": "displacement", "frame": "corner", "component": "z"},
            "tip_speed": {"point": "a.end", "quantity": "velocity", "frame": "corner", "component": "norm"},
        }},
    }


def _drifts(result):
    p = result.probes
    H = np.array([p["Hx"], p["Hy"], p["Hz"]])
    return (np.max(np.abs(p["Px"] - p["Px"][0])) / abs(p["Px"][0]),
            np.max(np.abs(H - H[:, :1])) / np.linalg.norm(H[:, 0]),
            np.max(np.abs(p["E"] - p["E"][0])) / p["E"][0])


def test_free_structure_conserves_momentum_and_energy():
    """ρ∞ = 1: momentum and energy drift are small and vanish at second order in the step."""
    coarse = latdyn.run(tumbling(dt=0.005))
    fine = latdyn.run(tumbling(dt=0.0025))
    assert np.max(coarse.probes["U"]) > 1e-3 * coarse.probes["E"][0]  # it does deform
    drift_coarse, drift_fine = _drifts(coarse), _drifts(fine)
    # measured: P 3.8e-6, H 3.9e-5, E 8.5e-5 at dt = 0.005
    assert drift_coarse[0] < 1e-5 and drift_coarse[1] < 1e-4 and drift_coarse[2] < 2e-4
    for c, f in zip(drift_coarse, drift_fine):
        assert c / f > 3.0  # second order: halving the step divides the drift by about 4


def test_rotated_and_translated_scene_gives_the_same_body_frame_results():
    """Body frames are parallel to the global axes at t = 0 (SCENE.md), so body-frame
    vectors of the rotated scene are the rotated vectors of the original."""
    rotation = expm_so3(np.array([0.4, -1.3, 0.8]))
    a = latdyn.run(tumbling(t_end=0.3))
    b = latdyn.run(tumbling(rotation, np.array([3.0, -2.0, 5.0]), t_end=0.3))
    tip_a = np.array([a.probes[k] for k in ("tip_x", "tip_y", "tip_z")])
    tip_b = np.array([b.probes[k] for k in ("tip_x", "tip_y", "tip_z")])
    assert np.max(np.abs(tip_a)) > 1e-3  # the tip moves relative to the corner body
    np.testing.assert_allclose(tip_b, rotation @ tip_a, atol=1e-7 * np.max(np.abs(tip_a)))
    for name in ("tip_speed", "E", "U"):
        scale = np.max(np.abs(a.probes[name]))
        np.testing.assert_allclose(b.probes[name], a.probes[name], atol=1e-7 * scale + 1e-12)


def hinged_flap(lock_at=0.6):
    return {
        "sections": {"s": {"EA": 1e6, "EIy": 500.0, "EIz": 500.0, "GJ": 400.0, "rhoA": 1.0,
                           "rhoIy": 1e-3, "rhoIz": 1e-3}},
        "bodies": {"base": {"at": [0, 0, 0], "fixed": True}},
        "beams": {"flap": {"from": "base", "to": [1, 0, 0], "section": "s", "elements": 3,
                           "start": {"hinge": {"axis": [0, 0, 1], "torque": "2.0", "lock_at": lock_at}}}},
        "solve": {"analysis": "transient", "t_end": 1.5, "dt": 0.005},
        "output": {"probes": {"angle": {"hinge": "flap.start", "quantity": "angle"},
                              "rate": {"hinge": "flap.start", "quantity": "rate"}}},
    }


def test_hinge_latches_at_lock_angle_and_stays_locked():
    result = latdyn.run(hinged_flap())
    angle, rate = result.probes["angle"], result.probes["rate"]
    reached = np.flatnonzero(angle >= 0.6 - 1e-6)
    assert len(reached), "the hinge never reached its lock angle"
    first = reached[0]
    assert angle[first] == pytest.approx(0.6, abs=1e-6)  # the step was shortened to land on it
    after = slice(first + 1, None)
    np.testing.assert_allclose(angle[after], angle[first], atol=1e-12)
    np.testing.assert_allclose(rate[after], 0.0, atol=1e-12)
    # before latching the flap accelerates under the torque: it moves
    assert angle[first // 2] > 0.0


def test_modal_analysis_of_clamped_beam():
    scene = {
        "sections": {"s": {"EA": 1e7, "EIy": 2.0, "EIz": 3.0, "GJ": 1.0, "rhoA": 0.5}},
        "bodies": {"wall": {"at": [0, 0, 0], "fixed": True}},
        "beams": {"b": {"from": "wall", "to": [1, 0, 0], "section": "s", "elements": 8}},
        "solve": {"analysis": "modes", "count": 4},
    }
    result = latdyn.run(scene)
    f = np.sort(result.modes)
    beta = 1.8751040687119611
    expected = sorted([beta**2 * np.sqrt(EI / 0.5) / (2 * np.pi) for EI in (2.0, 3.0)])
    np.testing.assert_allclose(f[:2], expected, rtol=1e-5)


def test_static_tip_force_small_deflection():
    P, L, EI = 1e-3, 2.0, 5.0
    scene = {
        "sections": {"s": {"EA": 1e8, "EIy": EI, "EIz": EI, "GJ": 4.0, "rhoA": 1.0}},
        "bodies": {"wall": {"at": [0, 0, 0], "fixed": True}},
        "beams": {"b": {"from": "wall", "to": [L, 0, 0], "section": "s", "elements": 4}},
        "loads": [{"at": "b.end", "force": [0, P, 0]}],
        "solve": {"analysis": "static", "steps": 2},
        "output": {"probes": {"v": {"point": "b.end", "quantity": "displacement", "component": "y"}}},
    }
    result = latdyn.run(scene)
    assert list(result.t) == [0.0, 0.5, 1.0]
    assert result.probes["v"][-1] == pytest.approx(P * L**3 / (3 * EI), rel=1e-5)


@pytest.mark.parametrize("method", ["generalized-alpha", "hht-alpha", "newmark", "explicit"])
def test_every_method_follows_a_pendulum(method):
    """A stiff massive-tip pendulum under gravity: all integrators agree with the rigid solution early on."""
    dt = 2e-4 if method == "explicit" else 2e-3
    scene = {
        "gravity": [0, -9.81, 0],
        "sections": {"s": {"EA": 1e5, "EIy": 1e3, "EIz": 1e3, "GJ": 1e3, "rhoA": 0.0}},
        "bodies": {"pivot": {"at": [0, 0, 0], "fixed": True}, "bob": {"at": [1, 0, 0], "mass": 1.0}},
        "beams": {"rod": {"from": "pivot", "to": "bob", "section": "s", "elements": 1,
                          "start": {"hinge": {"axis": [0, 0, 1]}}}},
        "solve": {"analysis": "transient", "t_end": 0.3, "dt": dt, "method": method},
        "output": {"every": 0.1, "probes": {"angle": {"hinge": "rod.start", "quantity": "angle"}}},
    }
    result = latdyn.run(scene)
    # small-time rigid pendulum from horizontal: θ ≈ −(g/L) t²/2 (1 − (g/L)... ) to leading order
    from scipy.integrate import solve_ivp

    sol = solve_ivp(lambda t, y: [y[1], -9.81 * np.cos(y[0])], (0, 0.3), [0, 0], rtol=1e-10, atol=1e-12,
                    dense_output=True)
    np.testing.assert_allclose(result.probes["angle"], sol.sol(result.t)[0], atol=3e-3)


def test_result_pickles_and_scene_errors_exit_2(tmp_path):
    import pickle

    result = latdyn.run(spinning_arm(t_end=0.05))
    again = pickle.loads(pickle.dumps(result))
    np.testing.assert_array_equal(again.probes["x"], result.probes["x"])
    bad = copy.deepcopy(spinning_arm())
    bad["beams"]["arm"]["section"] = "nope"
    with pytest.raises(latdyn.SceneError, match="beams.arm.section"):
        latdyn.run(bad)


def test_unheld_coordinate_is_refused():
    scene = {
        "sections": {"s": {"EA": 1e6, "EIy": 1.0, "EIz": 1.0, "GJ": 1.0, "rhoA": 1.0}},
        "bodies": {"wall": {"at": [0, 0, 0], "fixed": True}, "joint": {"at": [1, 0, 0]}},
        "beams": {"b": {"from": "wall", "to": "joint", "section": "s",
                        "end": {"hinge": {"axis": [0, 0, 1]}}}},
        "solve": {"analysis": "transient", "t_end": 0.1, "dt": 0.01},
    }
    with pytest.raises(latdyn.SceneError, match="nothing holds"):
        latdyn.run(scene)


def test_scene_with_every_runtime_feature():
    """Offsets, COM, inertia, hinge spring + damper + torque, a prescribed hinge angle,
    body-frame loads from a table, gravity and an initial velocity, in one run."""
    scene = {
        "title": "all features",
        "gravity": [0, 0, -9.81],
        "initial_velocity": {"linear": [0, 0, 0.1], "angular": [0, 0, 0.2], "about": [0, 0, 0]},
        "sections": {"s": {"EA": 1e6, "EIy": 300.0, "EIz": 400.0, "GJ": 200.0, "rhoA": 1.0,
                           "rhoIy": 1e-3, "rhoIz": 2e-3}},
        "bodies": {
            "base": {"at": [0, 0, 0], "fixed": True},
            "joint": {"at": [1, 0, 0], "mass": 2.0, "com": [0.05, 0, 0], "inertia": [0.01, 0.02, 0.03]},
            "drive": {"at": [0, 2, 0], "motion": {"translation": ["0.01*t", 0, 0]}},
        },
        "beams": {
            "a": {"from": "base", "to": {"body": "joint", "offset": [-0.1, 0, 0]}, "section": "s", "elements": 2,
                  "start": {"hinge": {"axis": [0, 0, 1], "stiffness": 50.0, "damping": 2.0, "torque": "sin(3*t)"}}},
            "b": {"from": "joint", "to": [1, 1, 0], "section": "s", "elements": 2,
                  "start": {"hinge": {"axis": [1, 0, 0], "angle": "0.2*sin(2*t)"}}},
            "c": {"from": "drive", "to": [0, 3, 0], "section": "s", "elements": 1, "y_axis": [1, 0, 0]},
        },
        "loads": [{"at": "joint", "force": [{"table": [[0, 0], [0.2, 1.0], [1, 1.0]]}, 0, 0],
                   "moment": [0, 0, "0.1"], "frame": "joint"}],
        "solve": {"analysis": "transient", "t_end": 0.4, "dt": 0.005, "rho_inf": 0.9},
        "output": {"every": 0.05, "probes": {
            "hinge_a": {"hinge": "a.start", "quantity": "angle"},
            "hinge_b": {"hinge": "b.start", "quantity": "angle"},
            "joint_v": {"point": "joint", "quantity": "velocity", "component": "norm"},
            "work": {"energy": "external_work"},
            "total": {"energy": "total"},
            "N": {"element": "a.element[0]", "quantity": "axial_force"},
        }},
    }
    result = latdyn.run(scene)
    t = result.t
    assert len(t) == 9 and t[-1] == pytest.approx(0.4)
    np.testing.assert_allclose(result.probes["hinge_b"], 0.2 * np.sin(2 * t), atol=1e-12)
    assert np.all(np.isfinite([v for v in result.probes.values()]))
    assert np.max(np.abs(result.probes["hinge_a"])) > 1e-4
    assert np.max(np.abs(result.probes["work"])) > 0.0
    # the damper and the integrator only remove energy: total − work never grows
    balance = result.probes["total"] - result.probes["work"]
    assert balance[-1] <= balance[0] + 1e-6 * np.max(np.abs(result.probes["total"]))
