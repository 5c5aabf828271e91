"""The energy balance (docs/energy.md): declared dissipation is dissipated energy, not an error;
a run whose balance breaks ends as ``unbounded``; a visible drift is a warning.

Scenes are YAML text as a user writes it, run through the CLI (``python -m latdyn run``) or
``latdyn.run(latdyn.load_scene(...))``.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.results.result import Result

ROOT = Path(__file__).resolve().parents[1]

#: A rigid link of length 1 (a bob of mass 1 at its end, the link's own mass 0.03) on a hinge
#: about z at a fixed pivot; no gravity. The spring (k = 10, rest angle 1) drives it from rest at
#: θ = 0 into the stop at 0.5: the kinetic energy before the impact is the spring's energy
#: released, ½ k (1² − 0.5²) = 3.75 J, exactly (the trapezoidal rule keeps the energy of this
#: linear system; the step lands on the stop).
STOP = """\
sections:
  rod: {EA: 1.0e9, EIy: 1.0e6, EIz: 1.0e6, GJ: 1.0e6, rhoA: 0.03}
bodies:
  pivot: {at: [0, 0, 0], fixed: true}
  bob: {at: [1, 0, 0], mass: 1.0}
beams:
  link:
    from: pivot
    to: bob
    section: rod
    rigid: true
    start:
      hinge: {axis: [0, 0, 1], stiffness: 10.0, rest_angle: 1.0, limits: [-0.6, 0.5], restitution: RESTITUTION}
solve: {analysis: transient, t_end: 1.5, dt: 0.002, method: newmark}
output:
  probes:
    angle: {hinge: link.start, quantity: angle}
    kinetic: {energy: kinetic}
    total: {energy: total}
    work: {energy: external_work}
    dissipated: {energy: dissipated}
"""

RELEASED = 0.5 * 10.0 * (1.0 - 0.25)  # the spring's energy from θ = 0 to the stop


def run_text(text: str, tmp_path: Path, name: str = "scene") -> tuple[subprocess.CompletedProcess, Path]:
    """Run a scene written as YAML text through the CLI; (the process, its results folder)."""
    scene, out = tmp_path / f"{name}.yaml", tmp_path / f"{name}_results"
    scene.write_text(text)
    process = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "--quiet"],
                             capture_output=True, text=True, timeout=120, cwd=tmp_path)
    return process, out


@pytest.mark.parametrize("restitution", [0.0, 0.5])
def test_a_stop_with_restitution_dissipates_one_minus_e_squared_of_the_kinetic_energy(restitution):
    """Newton's impact law on a rigid hinge stop: θ̇⁺ = −e θ̇⁻ removes (1 − e²) ½ I θ̇⁻², recorded by
    ``{energy: dissipated}`` and subtracted in the balance, which stays at round-off through the
    impact (energy_balance_error was 0.75 (e = 0) and 0.56 (e = 0.5) while the impact's loss
    counted as an error; 3.6e-4 and 1.5e-3 now, the integrator's after the impact)."""
    scene = yaml.safe_load(STOP.replace("RESTITUTION", str(restitution)))
    scene["solve"].update(t_end=0.45, dt=0.005)
    result = latdyn.run(latdyn.load_scene(scene))
    p = result.probes
    hit = int(np.argmax(p["dissipated"] > 0))
    assert hit > 0 and p["angle"][hit] == pytest.approx(0.5, abs=1e-9)
    assert p["dissipated"][hit - 1] == 0.0
    assert p["kinetic"][hit - 1] < RELEASED < p["kinetic"][hit - 1] * 1.1  # the step before lands on the stop
    assert p["dissipated"][hit] == pytest.approx((1 - restitution**2) * RELEASED, rel=1e-6)
    assert p["kinetic"][hit] == pytest.approx(restitution**2 * RELEASED, rel=1e-6)
    balance = p["total"] - p["total"][0] - p["work"] + p["dissipated"]
    assert np.max(np.abs(balance[:hit + 1])) <= 1e-6 * RELEASED
    # After the impact the step restarts from a zero hinge acceleration (events.hinge_stops), not
    # the spring's M⁻¹f: the trapezoidal rule's first step then gains 0.15 % of the energy (e = 0.5),
    # and a hinge resting on its stop gains ⅛ τ²h²/I a step (e = 0): the integrator's error, which
    # the balance shows; no impact's loss is in it.
    assert np.max(np.abs(balance)) <= 3e-3 * p["total"][0]
    assert result.summary["energy_balance_error"] < 3e-3
    assert np.all(np.diff(p["dissipated"]) >= 0.0)
    assert result.summary["dissipated_energy"] == pytest.approx(p["dissipated"][-1])
    assert result.summary["status"] == "solved" and "warnings" not in result.summary


def test_d2_with_newmark_at_dt_0_2_ends_unbounded_with_the_time_and_its_rows_kept(tmp_path):
    """The right-angle cantilever (examples/benchmarks) at dt = 0.2: the trapezoidal rule's energy
    grows from t ≈ 23 s (Newton then cuts steps). Exit 1, status unbounded, the time on stderr,
    probes.csv read back up to that time."""
    raw = yaml.safe_load((ROOT / "examples/benchmarks/D2_right_angle_cantilever.yaml").read_text())
    raw["solve"]["dt"] = 0.2
    process, out = run_text(yaml.safe_dump(raw), tmp_path, "d2")
    assert process.returncode == 1, process.stderr
    assert "Traceback" not in process.stderr
    message = [line for line in process.stderr.splitlines() if "energy balance broke" in line]
    assert len(message) == 1 and "unbounded" in message[0]
    t_break = float(message[0].split("at t = ")[1].split(":")[0])
    assert 20.0 < t_break < 30.0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "unbounded"
    assert not (out / "checkpoint.npz").exists() and "--resume" not in process.stderr  # the run is over
    result = Result.load(out)
    assert result.t[-1] == pytest.approx(t_break, rel=1e-5)
    assert np.all(np.isfinite(result.probes["energy"]))
    # before the break the energy stayed near the work done; at the break it is far above it
    assert result.probes["energy"][-1] > 2 * result.probes["work"][-1]


def test_the_shipped_d2_stays_solved_without_a_warning(tmp_path, capsys):
    """The benchmark at its shipped step (0.05): accurate, so solved, and nothing to warn of."""
    raw = yaml.safe_load((ROOT / "examples/benchmarks/D2_right_angle_cantilever.yaml").read_text())
    raw["solve"]["t_end"] = 6.0  # the load pulse and free vibration; the whole run is no different
    result = latdyn.run(latdyn.load_scene(raw), tmp_path / "d2")
    assert "warning" not in capsys.readouterr().err
    summary = json.loads((tmp_path / "d2" / "summary.json").read_text())
    assert summary["status"] == "solved" and "warnings" not in summary
    assert result.summary["energy_balance_error"] < 2e-3


def test_a_visible_drift_is_a_warning_on_stderr_and_in_the_summary(tmp_path, capsys):
    """The flying spaghetti with ρ∞ = 1 (no numerical dissipation) at dt = 0.5: its energy in free
    flight (t > 5 s, nothing acts) grows by 7 % while it stays below what the loads put in: not
    unbounded, but a balance error of 0.127 of the energy (measured), which the run says."""
    raw = yaml.safe_load((ROOT / "examples/benchmarks/D3_flying_spaghetti.yaml").read_text())
    raw["solve"].update(dt=0.5, method="generalized-alpha", rho_inf=1.0)
    latdyn.run(latdyn.load_scene(raw), tmp_path / "d3")
    warnings = [line for line in capsys.readouterr().err.splitlines() if line.startswith("latdyn: warning:")]
    assert len(warnings) == 1 and "energy balance" in warnings[0]
    summary = json.loads((tmp_path / "d3" / "summary.json").read_text())
    assert summary["status"] == "solved"
    assert summary["energy_balance_error"] > 0.05
    assert summary["warnings"] == [warnings[0].removeprefix("latdyn: warning: ")]


#: The rigid link of STOP released from θ = 0 by a spring whose rest angle is 0.5 (1.5 periods
#: of free decay through a damper): E(0) = ½ k 0.5² = 1.25 J, all of it strain.
DAMPER = """\
sections:
  rod: {EA: 1.0e9, EIy: 1.0e6, EIz: 1.0e6, GJ: 1.0e6, rhoA: 0.03}
bodies:
  pivot: {at: [0, 0, 0], fixed: true}
  bob: {at: [1, 0, 0], mass: 1.0}
beams:
  link:
    from: pivot
    to: bob
    section: rod
    rigid: true
    start:
      hinge: {axis: [0, 0, 1], stiffness: 10.0, rest_angle: 0.5, damping: DAMPING}
solve: {analysis: transient, t_end: 3.0, dt: DT, method: newmark}
output:
  every: 0.02
  probes:
    total: {energy: total}
    work: {energy: external_work}
    dissipated: {energy: dissipated}
"""


def free_decay(damping: str, dt: float, tol: float | None = None):
    text = DAMPER.replace("DAMPING", f'"{damping}"').replace("DT", str(dt))
    if tol is not None:
        text = text.replace("method: newmark", f"method: newmark, tol: {tol}")
    return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


@pytest.mark.parametrize("damping", ["0.4", "0.2*(1 + theta_dot**2)"])
def test_a_hinge_damper_dissipates_the_energy_the_free_decay_loses(damping):
    """Free decay through a hinge damper, a constant and a law in θ̇: the dissipated energy equals
    the kinetic + strain energy lost. The dampers' work is ½(c θ̇_n + c θ̇_{n+1}) Δθ a step
    (progress.hinge_work), which Newmark's average acceleration makes exact for any damper law and a
    linear spring: the mismatch is the Newton tolerance's, not the step's (measured at dt = 0.04:
    2.1e-8 and 1.8e-8 of the energy at the default tol 1e-8; 2.3e-12 and 3.5e-12 at tol 1e-12; the
    trapezoidal rule in time that this replaced left 2.7e-3)."""
    for tol, bound in ((None, 1e-6), (1e-12, 1e-10)):
        result = free_decay(damping, 0.04, tol)
        p = result.probes
        lost = p["total"][0] - p["total"]
        assert p["work"][-1] == 0.0
        assert lost[-1] > 0.6 * p["total"][0]  # most of the energy is gone
        assert np.all(np.diff(p["dissipated"]) >= 0.0)
        mismatch = np.max(np.abs(p["dissipated"] - lost)) / p["total"][0]
        assert mismatch < bound
        assert result.summary["energy_balance_error"] == pytest.approx(mismatch, rel=1e-6)
        assert result.summary["status"] == "solved" and "warnings" not in result.summary


def test_the_dampers_dissipation_is_the_same_from_the_loop_in_c_and_from_python(monkeypatch):
    """The compiled loop of steps (newton_step.c latdyn_advance) and the time loop's own steps
    (timeloop/loop.py) integrate the same ∫ c θ̇ dθ (progress.hinge_work)."""
    from latdyn.timeloop import transient

    compiled = free_decay("0.2*(1 + theta_dot**2)", 0.04).probes["dissipated"]
    monkeypatch.setattr(transient, "COMPILED_LOOP", False)
    python = free_decay("0.2*(1 + theta_dot**2)", 0.04).probes["dissipated"]
    assert compiled[-1] > 0.5
    np.testing.assert_allclose(python, compiled, rtol=1e-12, atol=1e-14)


#: A 3D structure that never moves: a shear-flexible cantilever, no loads, no gravity, beside a guided
#: body at rest (its guide makes the model 3D). Its strain energy at t = 0 is 3.4e-29 J of round-off,
#: later rows 4e-26 J: round-off over round-off, which the unbounded test once took for 1.2e3 times the
#: energy received and ended the run as unbounded (found by benchmarks/fuzz_runs.py --joints).
AT_REST = """\
sections:
  s0: {EA: 2716941.0, EIy: 1446.7, EIz: 1383.1, GJ: 431.4, rhoA: 2.35, GAy: 2201305.0, GAz: 2201305.0}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  gd:
    at: [-0.19, -0.8, 0.22]
    mass: 1.524
    guide: {axis: [-0.177, -0.786, -0.592], damping: 2.374}
beams:
  m0: {from: g, to: [-1.5742, 0.0, 0.7871], section: s0, elements: 1, y_axis: [1, 0, 0]}
solve: {analysis: transient, t_end: 0.1, dt: 0.01}
output:
  every: 0.014285714285714287
  probes:
    strain: {energy: strain}
"""


def test_a_structure_at_rest_is_solved_with_its_round_off_energies(tmp_path):
    """Energies within the round-off of a structure at rest (½ Σ EA L (8 ε)², progress.energy_round_off:
    7.5e-24 J here) are no energy received: the run is solved, balance error 0, no warning (CLI), and the
    API's run too. The floor stays far below any energy a load gives: 1e-3 N along the beam stores
    F² L / (2 EA) = 3.2e-13 J, 4e10 times the floor."""
    scene = tmp_path / "rest.yaml"
    scene.write_text(AT_REST)
    completed = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "out")],
                               capture_output=True, text=True)
    assert completed.returncode == 0, completed.stderr
    assert "warning" not in completed.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["status"] == "solved" and summary["energy_balance_error"] == 0.0
    strain = Result.load(tmp_path / "out").probes["strain"]
    assert 0.0 < np.max(strain) < 1e-24     # round-off, not zero, and below the floor
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(AT_REST)))
    assert result.t[-1] == pytest.approx(0.1)
