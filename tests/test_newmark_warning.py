"""Newmark on a 3D model with directions without inertia says what it cannot stand behind
(issue 30, follow-up of item 6).

The trapezoidal rule leaves the rates of directions without inertia (and of those whose inertia
is tiny against their stiffness) undamped: on an algebraic direction its rate and acceleration go
on by a double eigenvalue −1 (latdyn.step.integrators.newmark_warning).  In 3D they feed the
velocity-dependent forces, and D4 with ρI = 0 goes out of its plane from round-off (1e-20 m at
0.25 s to 1e-2 m at 1 s, 65 step cuts, not converging with dt; docs/verification.md, "D4 in 3D:
out-of-plane motion").  Until the method condenses those directions, such a run warns on stderr
and in summary.json ``warnings``; the runs the package stands behind do not.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
D4 = ROOT / "examples" / "benchmarks" / "D4_flexible_pendulum.yaml"


def run_d4(tmp_path: Path, rho_i: float | None = None, **solve) -> tuple[str, dict]:
    """D4 as the scene file has it, for 5 ms, with ``solve`` and the section's rotary inertia
    changed; stderr and summary.json."""
    text = D4.read_text().replace("t_end: 1.0", "t_end: 0.005")
    if "method" in solve:
        text = text.replace("method: newmark", f"method: {solve.pop('method')}")
    for key, value in solve.items():
        text = text.replace("solve: {", f"solve: {{{key}: {value}, ")
    if rho_i is not None:
        text = text.replace("rhoA: 9.972}", f"rhoA: 9.972, rhoIy: {rho_i}, rhoIz: {rho_i}}}")
    yaml.safe_load(text)  # still a valid scene text
    scene, out = tmp_path / "scene.yaml", tmp_path / "out"
    scene.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                          env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stderr, json.loads((out / "summary.json").read_text())


def test_newmark_on_d4_in_3d_without_rotary_inertia_warns(tmp_path):
    stderr, summary = run_d4(tmp_path, planar="off")
    assert summary["status"] == "solved"
    assert "latdyn: warning: method newmark on a 3D model" in stderr
    assert "without inertia" in stderr
    assert any("method newmark on a 3D model" in w for w in summary["warnings"])


@pytest.mark.parametrize("method", ["generalized-alpha", "hht-alpha"])
def test_the_alpha_methods_without_numerical_damping_warn_as_newmark_does(tmp_path, method):
    """ρ∞ = 1 leaves the same double root −1 on the directions without inertia (HHT-α is then the
    trapezoidal rule): found by the whole-run fuzzer's step check, seed 106 case 20, a 3D arm's hinge
    rate alternating +11.9, −8.4, +12.9 rad/s step to step, solved without a word."""
    stderr, summary = run_d4(tmp_path, planar="off", method=method, rho_inf=1)
    assert summary["status"] == "solved"
    assert f"latdyn: warning: method {method} with rho_inf 1 on a 3D model" in stderr
    assert any(f"method {method} with rho_inf 1 on a 3D model" in w for w in summary["warnings"])


@pytest.mark.parametrize("case", [
    {"planar": "off", "method": "generalized-alpha"},  # damps those rates (double root −ρ∞)
    {"planar": "off", "method": "generalized-alpha", "rho_inf": 0.99},  # a little damping is damping
    {"planar": "off", "rho_i": 6.73e-5},  # the section's own rotary inertia: nothing without inertia
    {},  # the shipped scene: the planar model has no twist
])
def test_runs_the_package_stands_behind_do_not_warn(tmp_path, case):
    case = dict(case)
    stderr, summary = run_d4(tmp_path, case.pop("rho_i", None), **case)
    assert "warning" not in stderr
    assert not summary.get("warnings")
