"""Linearisation about a state (issue 20; SCENE.md "Linearisation"): scenes as a user writes them,
through the command line and the API, against published tables and closed forms."""
from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import latdyn
from latdyn import cli

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = json.loads((ROOT / "benchmarks" / "references" / "rotating_cantilever.json").read_text())

# a rotating cantilever (benchmarks/rotating_cantilever.py), gamma = Ω·sqrt(ρA L⁴/EI) = 5
L, EI, RHOA = 10.0, 1.4e4, 1.2
SCALE = np.sqrt(RHOA * L**4 / EI)
GAMMA = 5
OMEGA = float(GAMMA / SCALE)
SPIN = """\
sections:
  arm: {{EA: 2.8e8, EIy: 1.4e4, EIz: 1.4e4, GJ: 1.0e4, rhoA: 1.2}}
initial_velocity: {{angular: {w}}}
bodies:
  hub:
    at: [0, 0, 0]
    motion:
      rotation: {{axis: {axis}, angle: "{omega!r}*t"}}
beams:
  arm: {{from: hub, to: {tip}, section: arm, elements: 6}}
solve:
  analysis: modes
  about: {about}
  count: 6
  dt: 0.01
"""


def spin_scene(about="steady", axis=(0, 0, 1), tip=(L, 0, 0)) -> str:
    axis = np.asarray(axis, float)
    return SPIN.format(w=[float(x) for x in OMEGA * axis], axis=[float(x) for x in axis], omega=float(OMEGA),
                       tip=[float(x) for x in tip], about=about)


def read_modes(folder) -> list[dict]:
    with open(Path(folder) / "modes.csv", newline="") as f:
        return list(csv.DictReader(f))


def run_cli(tmp_path, text: str, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(text)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "latdyn", "run", str(path), "-o", str(tmp_path / "out")],
                          env=env, capture_output=True, text=True, cwd=tmp_path, check=False)


def nondimensional(rows, directions, direction):
    return [float(r["frequency_hz"]) * 2 * np.pi * SCALE for r, d in zip(rows, directions) if d == direction]


def test_rotating_cantilever_against_the_published_table_through_the_cli(tmp_path):
    """Flapwise modes rise with the spin (Wright et al. 1982 table), chordwise ones feel −Ω²."""
    completed = run_cli(tmp_path, spin_scene().replace("  count: 6\n", "  count: 6\n  mode_shapes: true\n"))
    assert completed.returncode == 0, completed.stderr
    rows = read_modes(tmp_path / "out")
    assert list(rows[0])[:3] == ["mode", "frequency_hz", "damping_ratio"]
    directions = json.loads((tmp_path / "out" / "summary.json").read_text())["mode_directions"]
    flap, chord = nondimensional(rows, directions, "z"), nondimensional(rows, directions, "y")
    reference = [REFERENCE["omega_bar"][f"flap_{i}"][GAMMA] for i in (1, 2)]
    # 6 elements: the mesh error at rest is 2e-5 (mode 1) and 4e-4 (mode 2)
    np.testing.assert_allclose(flap[:2], reference, rtol=1e-3)
    np.testing.assert_allclose(chord[:2], np.sqrt(np.square(reference) - GAMMA**2), rtol=1e-3)
    assert flap[0] > REFERENCE["omega_bar"]["flap_1"][0] * 1.8  # stiffened well beyond the beam at rest
    assert all(abs(float(r["damping_ratio"])) < 1e-9 for r in rows)  # gyroscopic, conservative
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["about"] == "steady" and summary["linearisation_s"] > 0
    # the shapes, animated over a period for ParaView: the first flapwise mode moves along z, its
    # largest translation 5 % of the scene's size ℓ = 10
    h5py = pytest.importorskip("h5py")
    assert len(summary["mode_shapes"]) == 2 * len(rows)
    flap_mode = directions.index("z") + 1
    with h5py.File(tmp_path / "out" / "paraview" / "modes" / f"mode_{flap_mode:02d}" / "beams.vtkhdf") as f:
        motion = f["VTKHDF/PointData/displacement"][()].reshape(len(f["VTKHDF/Steps/Values"]), -1, 3)
    largest = np.abs(motion).max(axis=(0, 1))
    assert largest[2] == pytest.approx(0.05 * 10.0, rel=1e-6) and largest[1] < 1e-6 * largest[2]


def test_modes_at_a_time_of_a_steady_spin_transient_equal_steady():
    """A smooth spin-up to Ω over 6 s (Kane, Ryan & Banerjee's law), then Ω: about {t: 8} the beam
    turns steadily, up to what the spin-up left ringing."""
    ramp = 6.0
    law = (f"Piecewise(({OMEGA!r}/{ramp}*(t**2/2 + ({ramp}/(2*pi))**2*(cos(2*pi*t/{ramp}) - 1)), t < {ramp}), "
           f"({OMEGA!r}*(t - {ramp / 2}), True))")
    spun_up = _yaml(spin_scene(about="{t: 8}"))
    spun_up["bodies"]["hub"]["motion"]["rotation"]["angle"] = law
    del spun_up["initial_velocity"]
    later = latdyn.run(latdyn.load_scene(spun_up))
    steady = latdyn.run(latdyn.load_scene(_yaml(spin_scene())))
    # the spin-up leaves the undamped beam ringing in its chordwise mode: measured over t = 7 ... 9 s
    # (dt 0.01 and 0.005 alike) the frequencies about t swing about the steady ones by ±0.5 % (mode 1,
    # the softened chordwise one) to ±0.03 % (modes 5, 6), with the period of that mode
    np.testing.assert_allclose(later.modes[:2], steady.modes[:2], rtol=6e-3)
    np.testing.assert_allclose(later.modes[2:], steady.modes[2:], rtol=1e-3)


def test_objectivity_a_rotated_spinning_scene_has_the_same_frequencies():
    rotation = _rotation([0.3, -0.5, 0.8], 1.1)
    axis, tip = rotation @ [0, 0, 1], rotation @ [L, 0, 0]
    upright = latdyn.run(latdyn.load_scene(_yaml(spin_scene())))
    turned = latdyn.run(latdyn.load_scene(_yaml(spin_scene(axis=axis, tip=tip))))
    np.testing.assert_allclose(turned.modes, upright.modes, rtol=1e-7)


FREE = """\
sections:
  s: {EA: 1.0e5, EIy: 10, EIz: 20, GJ: 8, rhoA: 0.5, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  a: {at: [0, 0, 0], mass: 0.3, inertia: [1.0e-3, 1.0e-3, 1.0e-3]}
beams:
  s: {from: a, to: [1, 1, 0.5], section: s, elements: 4}
solve: {analysis: modes, count: 8}
"""


def test_rigid_body_modes_of_a_free_structure_stay_at_zero():
    result = latdyn.run(latdyn.load_scene(_yaml(FREE)))
    # the round-off of the eigensolver, ~√ε of the elastic scale (as the undamped analysis has always given)
    assert np.all(result.modes[:6] < 1e-5 * result.modes[6])
    assert result.modes[6] > 0.1


COLUMN = """\
sections:
  col: {{EA: 1.0e6, EIy: 100, EIz: 200, GJ: 80, rhoA: 1.0}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
beams:
  col: {{from: base, to: [0, 0, 2], section: col, elements: 8}}
loads:
  - {{at: col.end, force: [0, 0, -{load}]}}
solve: {{analysis: buckling, steps: 4}}
"""


def test_euler_buckling_of_a_cantilever_column_through_cli_and_api(tmp_path):
    """P_cr = π²EI/(4L²); EIy < EIz buckles first, the second factor is the stiffer plane."""
    completed = run_cli(tmp_path, COLUMN.format(load=100))
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    critical = np.pi**2 * 100 / (4 * 2.0**2)
    # +6e-5: the column shortens by P/EA before it buckles
    assert summary["buckling_factor"] * 100 == pytest.approx(critical, rel=2e-4)
    assert summary["buckling_kind"].startswith("bifurcation")
    linearised = summary["linearised_buckling_factors"]
    assert [x * 100 for x in linearised[:2]] == pytest.approx([critical, 2 * critical], rel=3e-4)
    api = latdyn.run(latdyn.load_scene(_yaml(COLUMN.format(load=10))))
    assert api.summary["buckling_factor"] * 10 == pytest.approx(critical, rel=2e-4)


LATERAL = """\
sections:
  s: {EA: 1.0e7, EIy: 1000, EIz: 1, GJ: 1, rhoA: 1.0}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  s: {from: base, to: [2, 0, 0], section: s, elements: 8}
loads:
  - {at: s.end, force: [0, 0, -1]}
solve: {analysis: buckling}
"""


def test_lateral_buckling_of_a_cantilever_under_a_tip_load():
    """P_cr = 4.0126 √(EI_weak GJ)/L² (Timoshenko & Gere, load at the centroid, EI_strong ≫ EI_weak).
    The element converges to it at about first order (measured: +17.5 %, +7.4 %, +3.5 % with 4, 8,
    16 elements); the linearised estimate about the unloaded beam would be spurious here."""
    result = latdyn.run(latdyn.load_scene(_yaml(LATERAL)))
    closed_form = 4.0126 * np.sqrt(1.0 * 1.0) / 2.0**2
    assert 1.0 < result.summary["buckling_factor"] / closed_form < 1.09


STRING = """\
sections:
  s: {EA: 1.0e7, EIy: 1.0, EIz: 1.0, GJ: 1, rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [2, 0, 0], mass: 1.0e5}
beams:
  s: {from: base, to: tip, section: s, elements: 8, start: {hinge: {axis: [0, 0, 1]}}}
loads:
  - {at: tip, force: [200, 0, 0]}
solve: {analysis: modes, about: static, count: 8, steps: 2}
"""


def test_loaded_frequencies_of_a_pretensioned_beam_about_static():
    """In-plane: pinned (hinge) – pinned (a heavy tip body without rotary inertia), tension P:
    ω_n² = (nπ/L)⁴ EI/ρA + (nπ/L)² P/ρA."""
    result = latdyn.run(latdyn.load_scene(_yaml(STRING)))
    assert result.summary["about"] == "static"
    k = np.arange(1, 3) * np.pi / 2.0
    expected = np.sqrt(k**4 * 1.0 / 0.5 + k**2 * 200 / 0.5) / (2 * np.pi)
    in_plane = [f for f, d in zip(result.modes, result.summary["mode_directions"]) if d == "y" and f > 1.0]
    np.testing.assert_allclose(in_plane[:2], expected, rtol=1e-4)
    unloaded = latdyn.run(latdyn.load_scene(_yaml(STRING.replace("about: static", "about: initial"))))
    assert unloaded.modes[3] < 0.5 * result.modes[3]  # about t = 0 the tension is not there


PENDULUM = """\
gravity: [0, -9.81, 0]
sections:
  rod: {EA: 1.0e7, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
bodies:
  top: {at: [0, 0, 0], fixed: true}
beams:
  rod: {from: top, to: [0, -1, 0], section: rod, elements: 4, start: {hinge: {axis: [0, 0, 1]}}}
solve: {analysis: modes, about: static, count: 2}
"""


def test_a_hanging_pendulum_swings_about_its_static_state():
    """Its restoring stiffness is the tension that gravity puts in the rod: about static the stiff
    rod swings at √(3g/2L); about the unstretched initial configuration it has none (0 Hz)."""
    hanging = latdyn.run(latdyn.load_scene(_yaml(PENDULUM)))
    assert hanging.modes[0] == pytest.approx(np.sqrt(1.5 * 9.81) / (2 * np.pi), rel=1e-5)
    unstretched = latdyn.run(latdyn.load_scene(_yaml(PENDULUM.replace("about: static", "about: initial"))))
    assert unstretched.modes[0] < 1e-3 * hanging.modes[0]


LINEAR = """\
sections:
  s: {{EA: 1.0e5, EIy: 10, EIz: 10, GJ: 8, rhoA: 0.5}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
beams:
  s: {{from: base, to: [2, 0, 0], section: s, elements: 4, start: {{hinge: {{axis: [0, 0, 1], stiffness: 50, damping: 0.5}}}}}}
loads:
  - {{at: s.end, force: [0, "0.01*sin(3*t)", 0]}}
output:
  paraview_every: 0
  probes:
    tip_y: {{point: s.end, quantity: position, component: y}}
    hinge: {{hinge: s.start, quantity: angle}}
solve: {solve}
"""


def test_linear_model_against_the_nonlinear_transient(tmp_path):
    """A, B, C, D about rest, through scipy.signal, and the transient of the same small input."""
    signal = pytest.importorskip("scipy.signal")
    modal = "{analysis: modes, linear_model: {inputs: [s.end.force.y, s.start, loads[0]], outputs: [tip_y, hinge]}}"
    completed = run_cli(tmp_path, LINEAR.format(solve=modal))
    assert completed.returncode == 0, completed.stderr
    rows = read_modes(tmp_path / "out")
    assert 0 < float(rows[0]["damping_ratio"]) < 0.1  # the hinge damper
    model = np.load(tmp_path / "out" / "linear_model.npz")
    assert list(model["inputs"]) == ["s.end.force.y", "s.start", "loads[0]"]
    assert list(model["outputs"]) == ["tip_y", "hinge"] and len(model["states"]) == model["A"].shape[0]
    system = signal.StateSpace(model["A"], model["B"], model["C"], model["D"])
    transient = latdyn.run(latdyn.load_scene(_yaml(LINEAR.format(
        solve="{analysis: transient, t_end: 2, dt: 0.002, rho_inf: 1.0}"))))
    t = np.asarray(transient.t)
    u = np.stack([0.01 * np.sin(3 * t), 0 * t, 0 * t], axis=1)
    _, y, _ = signal.lsim(system, u, t)
    for j, name in enumerate(["tip_y", "hinge"]):
        nonlinear = np.asarray(transient.probes[name]) - model["y0"][j]
        # second order in the 1 % amplitude, plus the integrator's error
        assert np.abs(y[:, j] - nonlinear).max() < 2e-3 * np.abs(nonlinear).max()
    # the load as an input is the unit force along y at the tip: the same column of B
    np.testing.assert_allclose(model["B"][:, 2], 0.0, atol=1e-12)  # its value at t = 0 is zero
    transient_model = latdyn.run(latdyn.load_scene(_yaml(LINEAR.format(
        solve="{analysis: transient, t_end: 0.01, dt: 0.01, linear_model: {inputs: [s.start], outputs: [hinge]}}"))),
        tmp_path / "transient")
    assert transient_model.summary["linear_model"]
    # that scene is planar (xy): its linear model has the in-plane coordinates only, and their
    # frequencies are the 3D model's in-plane (y) ones
    planar = np.load(tmp_path / "transient" / "linear_model.npz")
    eigenvalues = np.linalg.eigvals(planar["A"])
    in_plane = np.sort(np.abs(eigenvalues[eigenvalues.imag > 1e-9]))[:3] / (2 * np.pi)
    assert planar["A"].shape[0] < model["A"].shape[0]
    directions = json.loads((tmp_path / "out" / "summary.json").read_text())["mode_directions"]
    in_plane_3d = [float(r["natural_frequency_hz"]) for r, d in zip(rows, directions) if d == "y"]
    np.testing.assert_allclose(in_plane, in_plane_3d[:3], rtol=1e-8)


@pytest.mark.parametrize("solve, key", [
    ("{analysis: modes, about: stedy}", "solve.about"),
    ("{analysis: modes, about: {time: 1}}", "solve.about.time"),
    ("{analysis: modes, about: steady}", "solve.about"),  # nothing spins
    ("{analysis: modes, linear_model: {inputs: [s.middle], outputs: [tip_y]}}", "solve.linear_model.inputs[0]"),
    ("{analysis: modes, linear_model: {inputs: [s.start], outputs: [nope]}}", "solve.linear_model.outputs[0]"),
    ("{analysis: modes, linear_model: {inputs: [base.force.y], outputs: []}}", "solve.linear_model.inputs"),
    ("{analysis: modes, about: {t: 1}}", "solve.dt"),
])
def test_bad_linearisation_keys_exit_2_naming_the_key(tmp_path, capsys, solve, key):
    path = tmp_path / "bad.yaml"
    path.write_text(LINEAR.format(solve=solve))
    assert cli.main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"{key}:" in err and "Traceback" not in err


# ----------------------------------------------------------------------------- helpers
def _yaml(text: str) -> dict:
    import yaml

    return yaml.safe_load(text)


def _rotation(axis, angle) -> np.ndarray:
    from latdyn.numerics.so3 import expm_so3

    axis = np.asarray(axis, float)
    return expm_so3(axis / np.linalg.norm(axis) * angle)



SKEW_ARM = """\
title: a 3D arm on a skew hinge under skew gravity, a joint body with an offset centre of mass, a follower load
gravity: [0.8, -9.81, 1.3]
sections:
  arm: {EA: 2.0e6, EIy: 900.0, EIz: 1300.0, GJ: 700.0, rhoA: 2.5, rhoIy: 0.01, rhoIz: 0.02}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.9, 0.4, -0.3], mass: 0.7, com: [0.05, -0.02, 0.03], inertia: [0.02, 0.03, 0.025]}
beams:
  arm:
    from: base
    to: tip
    section: arm
    elements: 3
    start: {hinge: {axis: [0.3, 0.5, 0.81], stiffness: "40*(theta - 0.1) + 5*theta**3", damping: 0.4}}
loads:
  - {at: tip, force: [0, 2.0, -1.5], moment: [0.3, 0, 0.2], frame: tip}
solve: {analysis: modes, count: 2}
"""


@pytest.mark.parametrize("inertia", [True, False])
def test_the_exact_tangent_equals_differences_of_the_residual_at_a_moving_state(inertia):
    """r_q = ∂r/∂q at fixed velocities and accelerations from the generated kernels (the elements'
    and the joint bodies' inertia tangents, gravity, follower load and hinge-law tangents) equals
    central differences of the residual at a random moved, moving and accelerating 3D state, at load
    factor 0.7 (measured: ≤ 3e-11 of max|K|, the differences' own error)."""
    from latdyn.analyses.linearisation import tangent_q, tangent_q_by_differences
    from latdyn.assembly.prepare import prepare

    assembler = prepare(latdyn.load_scene(_yaml(SKEW_ARM))).assembler
    rng = np.random.default_rng(7)
    state = assembler.advance(assembler.initial_state(), 0.1 * rng.standard_normal(assembler.model.n_dofs))
    for name in ("v", "w", "a", "alpha", "theta_dot", "theta_ddot"):
        getattr(state, name)[:] = rng.standard_normal(getattr(state, name).shape)
    exact = tangent_q(assembler, state, 0.7, inertia=inertia)
    differences = tangent_q_by_differences(assembler, state, 0.7, inertia=inertia)
    assert np.abs(exact - differences).max() <= 1e-9 * np.abs(exact).max()
    assert np.abs(exact - differences).max() > 0.0  # two computations, not one
