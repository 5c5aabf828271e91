"""The time loop: exact times, the energy balance as SCENE.md defines it, cut steps reported."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import yaml

import latdyn


def pendulum(t_end=1.0, dt=0.005, **solve):
    """A rigid-ish pendulum released from rest under gravity (total energy starts at zero)."""
    return {
        "gravity": [0, -9.81, 0],
        "sections": {"s": {"EA": 1e6, "EIy": 1e4, "EIz": 1e4, "GJ": 1e4, "rhoA": 0.0}},
        "bodies": {"pivot": {"at": [0, 0, 0], "fixed": True}, "bob": {"at": [1, 0, 0], "mass": 1.0}},
        "beams": {"rod": {"from": "pivot", "to": "bob", "section": "s", "elements": 1,
                          "start": {"hinge": {"axis": [0, 0, 1]}}}},
        "solve": {"analysis": "transient", "t_end": t_end, "dt": dt, "method": "newmark", **solve},
        "output": {"every": 0.05, "paraview_every": 0,
                   "probes": {"angle": {"hinge": "rod.start", "quantity": "angle"}, "total": {"energy": "total"}}},
    }


def test_energy_balance_error_is_relative_to_the_energies_exchanged():
    result = latdyn.run(pendulum())
    error = result.summary["energy_balance_error"]
    # total energy starts at zero: dividing by it reported 1.0; the swing exchanges ~9.8 J
    drift = np.max(np.abs(result.probes["total"] - result.probes["total"][0]))
    assert 0 < error < 1e-3
    assert abs(error - drift / (9.81 * np.max(-np.sin(result.probes["angle"])) * 1.0)) < 0.5 * error + 1e-12


def test_last_step_lands_on_t_end_and_times_are_computed():
    result = latdyn.run(pendulum(t_end=0.1237, dt=0.005, **{}), )
    assert result.t[-1] == 0.1237
    every = np.arange(0, 0.1237, 0.05)
    np.testing.assert_array_equal(result.t[:-1], [k * 0.05 for k in range(len(every))])
    assert result.summary["steps"] == 25  # 24 steps of 0.005 and one of 0.0037


def test_dt_larger_than_t_end_is_refused_with_exit_2(tmp_path):
    scene = tmp_path / "long_step.yaml"
    scene.write_text(yaml.safe_dump(pendulum(t_end=0.01, dt=0.02)))
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "out")],
                          capture_output=True, text=True)
    assert done.returncode == 2
    assert "solve.dt" in done.stderr and "long_step.yaml" in done.stderr
    assert not (tmp_path / "out" / "probes.csv").exists()


def test_cut_steps_are_reported_on_stderr_and_in_the_summary(tmp_path):
    scene = tmp_path / "cut.yaml"
    # two Newton iterations are not enough for the first swing at this step: steps get cut
    scene.write_text(yaml.safe_dump(pendulum(t_end=0.3, dt=0.05, max_iterations=2, tol=1e-12)))
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_cuts"] > 0 and summary["rejected_steps"] >= summary["newton_cuts"]
    assert "step cut to" in done.stderr
    assert len(summary["cut_times"]) == min(summary["newton_cuts"], 100)
