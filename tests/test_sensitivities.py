"""Exact sensitivities of static load-control paths (latdyn/analyses/sensitivities.py).

Reference: central differences of whole runs at p ± h and p ± h/2, Richardson-extrapolated
((4 D(h/2) − D(h))/3, error O(h⁴)), the perturbation varied, not the load steps. Checked on a
genuinely 3D structure (two beams at an angle, a hinge whose axis lies in no coordinate plane, a
load turning with a body) for each kind of parameter supported: a load component (global and
follower), a load moment, a hinge stiffness law, a rest angle that the stiffness law also uses;
on a planar one; objectivity (a rigidly turned scene's sensitivities are the turned ones); and the
refusals of what is not differentiated yet."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.results.result import Result
from tests.cli_runs import ROOT, latdyn_run

ARM_3D = """
title: static 3D arm with a hinged second beam
parameters: {F: 2.0, k: 30.0, th0: 0.1, M: 0.5, EI: 20.0, G: 15.0}
sections:
  s: {EA: 1.0e5, EIy: "EI", EIz: "1.5*EI", GJ: "G", rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0]}
beams:
  a: {from: base, to: knee, section: s, elements: 3, y_axis: [0, 1, 0]}
  b:
    from: knee
    to: [1.6, 0.5, 0.4]
    section: s
    elements: 3
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: "k*(1 + (theta - th0)**2)", rest_angle: "th0"}}
loads:
  - {at: b.end, force: ["0.3*F", "-F", "0.5*F"], moment: [0, "M", 0]}
  - {at: knee, force: [0, 0, "-2*F"], frame: knee}
solve: {analysis: static, steps: 4, sensitivities: [F, k, th0, M, EI, G]}
output:
  probes:
    tip_x: {point: b.end, quantity: position, component: x}
    tip_y: {point: b.end, quantity: position, component: y}
    tip_z: {point: b.end, quantity: position, component: z}
    tip_d: {point: b.end, quantity: displacement, component: norm}
    hinge: {hinge: b.start, quantity: angle}
"""

PLANAR = """
title: planar hinged cantilever under a tip load
parameters: {P: 3.0, k: 8.0}
sections:
  s: {EA: 1.0e5, EIy: 5.0, EIz: 5.0, GJ: 4.0, rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  arm:
    from: base
    to: [1.0, 0.2, 0]
    section: s
    elements: 4
    start: {hinge: {axis: [0, 0, 1], stiffness: "k + 0.5*k*theta**2"}}
loads:
  - {at: arm.end, force: ["0.2*P", "-P", 0]}
solve: {analysis: static, steps: 3, sensitivities: [P, k]}
output:
  probes:
    tip_y: {point: arm.end, quantity: displacement, component: y}
    hinge: {hinge: arm.start, quantity: angle}
"""


PLANAR_TURNED = """
title: planar frame whose sections' local z lies in the plane (the model turns them a quarter)
parameters: {P: 3.0, EI: 5.0, G: 4.0}
sections:
  s: {EA: 1.0e5, EIy: "EI", EIz: "3*EI", GJ: "G", rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1.0, 0.2, 0]}
beams:
  a: {from: base, to: knee, section: s, elements: 3, y_axis: [0, 0, 1]}
  b: {from: knee, to: [1.3, 1.0, 0], section: s, elements: 3, y_axis: [0, 0, 1]}
loads:
  - {at: b.end, force: ["P", "-0.4*P", 0]}
solve: {analysis: static, steps: 3, sensitivities: [P, EI, G]}
output:
  probes:
    tip_x: {point: b.end, quantity: displacement, component: x}
    tip_y: {point: b.end, quantity: position, component: y}
"""


#: ARM_3D under gravity, its beams massless, the knee's mass, centre of mass and inertia (which a
#: static residual does not see) named
GRAVITY_3D = (ARM_3D
              .replace("parameters: {", "parameters: {m: 0.8, cx: 0.05, J: 0.01, ")
              .replace("rhoA: 0.5}", "rhoA: 0.0}")
              .replace("knee: {at: [1, 0, 0]}", "knee: {at: [1, 0, 0], mass: \"m\", com: [\"cx\", 0, \"-cx\"], "
                                                "inertia: [\"J\", \"J\", \"2*J\"]}")
              .replace("sensitivities: [F, k, th0, M, EI, G]", "sensitivities: [m, cx, J]")
              .replace("title: static 3D arm", "gravity: [0, 0, -9.81]\ntitle: static 3D arm"))


#: ARM_3D under gravity with beams with mass: the beams' gravity load, whose exact tangent
#: (beam_gravity_D_q) the static Newton matrix holds, comparable to the tip loads; rhoA and the
#: section stiffness named
GRAVITY_BEAMS_3D = (ARM_3D
                    .replace("parameters: {", "parameters: {rho: 0.6, ")
                    .replace("rhoA: 0.5}", "rhoA: \"rho\", rhoIy: \"0.01*rho\", rhoIz: \"0.02*rho\"}")
                    .replace("sensitivities: [F, k, th0, M, EI, G]", "sensitivities: [rho, EI, k]")
                    .replace("title: static 3D arm", "gravity: [1.5, -2.0, -9.81]\ntitle: static 3D arm"))


def _arch() -> str:
    """A shallow circular arch (radius 1, half-angle 0.35 rad, six members of two elements, clamped at
    both supports) in a plane tilted 0.5 rad about x (a 3D model), its crown pushed down by
    displacement control through a near-limit plateau into membrane stiffening (λ from 27 to 470)."""
    angles = np.linspace(-0.35, 0.35, 7)
    tilt = np.array([[1, 0, 0], [0, np.cos(0.5), -np.sin(0.5)], [0, np.sin(0.5), np.cos(0.5)]])
    points = [tilt @ [np.sin(a), np.cos(a) - np.cos(0.35), 0.0] for a in angles]
    down = tilt @ [0.0, -1.0, 0.0]
    scene = {
        "title": "shallow arch, displacement control, tilted",
        "parameters": {"EI": 1.0, "EA0": 5.0e5, "P": 1.0},
        "sections": {"s": {"EA": "EA0", "EIy": "EI", "EIz": "1.2*EI", "GJ": 1.0, "rhoA": 0.1}},
        "bodies": {f"n{i}": {"at": [float(c) for c in p], **({"fixed": True} if i in (0, 6) else {})}
                   for i, p in enumerate(points)},
        "beams": {f"s{i}": {"from": f"n{i}", "to": f"n{i + 1}", "section": "s", "elements": 2} for i in range(6)},
        "loads": [{"at": "n3", "force": [f"({float(c)!r})*P" for c in down]}],
        "solve": {"analysis": "static", "method": "displacement-control", "steps": 12,
                  "control": {"point": "n3", "direction": [float(c) for c in down], "to": 0.12},
                  "sensitivities": ["EI", "EA0", "P"]},
        "output": {"probes": {"crown_z": {"point": "n3", "quantity": "position", "component": "z"},
                              "n1_y": {"point": "n1", "quantity": "displacement", "component": "y"},
                              "n2_x": {"point": "n2", "quantity": "displacement", "component": "x"}}}}
    return yaml.safe_dump(scene, sort_keys=False)


ARCH = _arch()


def _run(text: str, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    return latdyn.run(latdyn.load_scene(data))


def _richardson(text: str, name: str, load_factor: bool = False) -> dict:
    """d(probe)/d(name) over the rows by Richardson-extrapolated central differences of whole runs
    (without solve.sensitivities); with ``load_factor``, also d(load factor)/d(name)."""
    data = yaml.safe_load(text)
    del data["solve"]["sensitivities"]
    plain = yaml.safe_dump(data)
    p0 = data["parameters"][name]
    h = 1e-3 * abs(p0)
    central = []
    for step in (h, h / 2):
        up, down = _run(plain, **{name: p0 + step}), _run(plain, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        if load_factor:
            central[-1]["load_factor"] = (up.t - down.t) / (2 * step)
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


@pytest.fixture(scope="module")
def arm_3d():
    return _run(ARM_3D)


@pytest.mark.parametrize("name", ["F", "k", "th0", "M", "EI", "G"])
def test_3d_static_sensitivities_agree_with_richardson_central_differences(arm_3d, name):
    """Each probe's sensitivity over the rows, against the extrapolated differences: within 1e-8 of the
    probe's largest sensitivity (measured 2e-13 … 1.5e-9)."""
    reference = _richardson(ARM_3D, name)
    assert len(arm_3d.t) == 5
    for probe, expected in reference.items():
        computed = arm_3d.sensitivities[(probe, name)]
        scale = np.abs(expected).max()
        assert scale > 1e-7, (probe, name)
        assert np.abs(computed - expected).max() <= 1e-8 * scale, (probe, name)
        assert computed[0] == 0.0   # the initial configuration, which no load or hinge parameter moves


@pytest.mark.parametrize("name", ["m", "cx"])
def test_3d_static_sensitivities_by_masses_under_gravity_agree_with_richardson_central_differences(name):
    result = _run(GRAVITY_3D)
    reference = _richardson(GRAVITY_3D, name)
    for probe, expected in reference.items():
        scale = np.abs(expected).max()
        assert scale > 1e-7, (probe, name)
        assert np.abs(result.sensitivities[(probe, name)] - expected).max() <= 1e-8 * scale, (probe, name)
    assert all(np.all(result.sensitivities[(probe, "J")] == 0.0) for probe in reference)   # no inertia in statics


@pytest.mark.parametrize("name", ["rho", "EI", "k"])
def test_3d_static_sensitivities_under_gravity_on_beams_with_mass_agree_with_richardson_central_differences(name):
    """The static Newton matrix holds the beams' gravity tangent, so δq = −K⁻¹ ∂r/∂p is exact under
    gravity too: a section's mass per length (∂Q/∂ρA through beam_gravity, linear), its stiffness and a
    hinge law, within 1e-8 of the probe's largest sensitivity."""
    result = _run(GRAVITY_BEAMS_3D)
    reference = _richardson(GRAVITY_BEAMS_3D, name)
    for probe, expected in reference.items():
        scale = np.abs(expected).max()
        assert scale > 1e-7, (probe, name)
        assert np.abs(result.sensitivities[(probe, name)] - expected).max() <= 1e-8 * scale, (probe, name)


@pytest.fixture(scope="module")
def arch():
    return _run(ARCH)


@pytest.mark.parametrize("name", ["EI", "EA0"])
def test_displacement_control_sensitivities_agree_with_richardson_central_differences(arch, name):
    """The load factor moves with the parameters (the crown's displacement is what is held): the
    bordered solve's sensitivities against the extrapolated differences of whole runs (measured
    ≤ 1.8e-9 of each probe's largest)."""
    reference = _richardson(ARCH, name, load_factor=True)
    assert np.ptp(arch.t) > 400   # through the plateau near λ = 27 into membrane stiffening
    for probe, expected in reference.items():
        scale = np.abs(expected).max()
        assert scale > 0, (probe, name)
        assert np.abs(arch.sensitivities[(probe, name)] - expected).max() <= 1e-7 * scale, (probe, name)


def test_under_displacement_control_the_load_amplitude_moves_nothing_but_the_load_factor(arch):
    """r = f(q) − λ P e: at a held displacement q does not depend on P, and λ P does not either:
    δλ/δP = −λ/P (exact), the probes' zero but round-off."""
    for probe in ("crown_z", "n1_y", "n2_x"):
        assert np.abs(arch.sensitivities[(probe, "P")]).max() <= 1e-10 * np.abs(arch.probes[probe]).max()
    assert np.abs(arch.sensitivities[("load_factor", "P")] + arch.t / 1.0).max() <= 1e-10 * arch.t.max()


def test_the_load_factors_sensitivities_are_in_the_summary(tmp_path, arch):
    run, out = latdyn_run(tmp_path, ARCH)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    peak = int(np.argmax(arch.t))
    assert summary["load_factor_sensitivities"]["max"] == {
        name: arch.sensitivities[("load_factor", name)][peak] for name in ("EI", "EA0", "P")}
    assert set(summary["probe_sensitivities"]) == {"crown_z", "n1_y", "n2_x"}


#: PLANAR_TURNED under an in-plane gravity, its beams' mass per length named
PLANAR_GRAVITY = (PLANAR_TURNED.replace("parameters: {", "parameters: {rho: 0.8, ")
                  .replace("rhoA: 0.5}", "rhoA: \"rho\"}")
                  .replace("sensitivities: [P, EI, G]", "sensitivities: [rho, EI]")
                  .replace("title: planar frame", "gravity: [0.5, -9.81, 0]\ntitle: planar frame"))


@pytest.mark.parametrize("text, names", [(PLANAR, ("P", "k")), (PLANAR_TURNED, ("P", "EI")),
                                         (PLANAR_GRAVITY, ("rho", "EI"))],
                         ids=["hinged", "sections_turned", "gravity"])
def test_planar_static_sensitivities_agree_with_richardson_central_differences(text, names):
    result = _run(text)
    assert result.summary.get("planar") is not False
    for name in names:
        reference = _richardson(text, name)
        for probe, expected in reference.items():
            scale = np.abs(expected).max()
            assert scale > 1e-7
            assert np.abs(result.sensitivities[(probe, name)] - expected).max() <= 1e-8 * scale, (probe, name)
    assert all(np.all(values == 0.0) for (probe, name), values in result.sensitivities.items() if name == "G")


def _turned(text: str, rotation: np.ndarray) -> str:
    """The scene moved rigidly by ``rotation`` about the origin: points, the hinge axis, the beams'
    section axes and the loads' components (all global), each turned component written as an
    expression of the parameters."""
    data = yaml.safe_load(text)
    turn = lambda v: [float(c) for c in rotation @ np.asarray(v, float)]  # noqa: E731
    data["bodies"]["knee"]["at"] = turn(data["bodies"]["knee"]["at"])
    data["beams"]["b"]["to"] = turn(data["beams"]["b"]["to"])
    data["beams"]["b"]["start"]["hinge"]["axis"] = turn(data["beams"]["b"]["start"]["hinge"]["axis"])
    for beam in data["beams"].values():
        beam["y_axis"] = turn(beam["y_axis"])     # the sections' axes (EIy != EIz) turn too
    for load in data["loads"]:
        for key in ("force", "moment"):
            if key in load:
                components = [f"({c})" for c in load[key]]
                load[key] = ["+".join(f"({float(rotation[i, j])!r})*{components[j]}" for j in range(3)) for i in range(3)]
    data["output"]["probes"] = {k: v for k, v in data["output"]["probes"].items() if k != "tip_d"}
    return yaml.safe_dump(data)


def test_sensitivities_of_a_rigidly_turned_scene_are_the_turned_sensitivities(arm_3d):
    """Point sensitivities turn with the scene, hinge-angle sensitivities stay. (The knee's load is
    made global first: a body's axes are the global ones at t = 0, so a load in body axes does not
    turn with the scene.)"""
    angle, axis = 0.7, np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    skew = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * skew + (1 - np.cos(angle)) * skew @ skew
    data = yaml.safe_load(ARM_3D)
    data["loads"][1].pop("frame")     # the same scene with the knee's load global, then turned
    original = latdyn.run(latdyn.load_scene(data))
    turned = latdyn.run(latdyn.load_scene(yaml.safe_load(_turned(yaml.safe_dump(data), rotation))))
    for name in ("F", "k", "th0", "M", "EI", "G"):
        before = np.array([original.sensitivities[(f"tip_{c}", name)] for c in "xyz"])
        after = np.array([turned.sensitivities[(f"tip_{c}", name)] for c in "xyz"])
        scale = np.abs(before).max()
        assert np.abs(after - rotation @ before).max() <= 1e-8 * scale, name
        hinge = original.sensitivities[("hinge", name)]
        assert np.abs(turned.sensitivities[("hinge", name)] - hinge).max() <= 1e-8 * np.abs(hinge).max(), name


def test_the_cli_writes_sensitivities_csv_and_the_summary(tmp_path, arm_3d):
    run, out = latdyn_run(tmp_path, ARM_3D)
    assert run.returncode == 0, run.stderr
    header = (out / "sensitivities.csv").read_text().splitlines()[0].split(",")
    assert header[0] == "load_factor" and header[1:7] == [f"tip_x/{n}" for n in ("F", "k", "th0", "M", "EI", "G")]
    assert len(header) == 1 + 5 * 6
    loaded = Result.load(out)
    for key, values in arm_3d.sensitivities.items():
        assert np.array_equal(loaded.sensitivities[key], values)
    summary = json.loads((out / "summary.json").read_text())
    end = summary["probe_sensitivities"]["hinge"]["end"]
    assert end == {name: arm_3d.sensitivities[("hinge", name)][-1] for name in ("F", "k", "th0", "M", "EI", "G")}
    rows = arm_3d.probes["tip_z"]
    lowest = summary["probe_sensitivities"]["tip_z"]["min"]["F"]
    assert lowest == arm_3d.sensitivities[("tip_z", "F")][int(np.argmin(rows))]
    assert summary["event_sensitivities"] == []


@pytest.mark.parametrize("change, expected", [
    (lambda d: d["solve"].update(analysis="transient", method="explicit", t_end=0.1, dt=0.05, steps=None),
     "not for method explicit"),
    (lambda d: d["solve"].update(analysis="modes", steps=None), "not yet for a modes analysis"),
    (lambda d: d["solve"].update(analysis="buckling", steps=None), "not yet for a buckling analysis"),
    (lambda d: d.update(gravity=[0, 0, "-k"]), "used at gravity[2]"),
    (lambda d: d["output"]["probes"].update(v={"point": "b.end", "quantity": "velocity", "frame": "knee"}),
     "probe 'v'"),
])
def test_what_is_not_differentiated_yet_is_refused(change, expected):
    data = yaml.safe_load(ARM_3D)
    change(data)
    data["solve"] = {k: v for k, v in data["solve"].items() if v is not None}
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities" and expected in info.value.expected


def test_a_refused_sensitivity_exits_2_in_run_and_check_and_writes_nothing(tmp_path):
    text = ARM_3D.replace("analysis: static, steps: 4", "analysis: transient, method: explicit, t_end: 0.1, dt: 0.05")
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 2 and "solve.sensitivities" in run.stderr and "Traceback" not in run.stderr
    assert not out.exists() or not (out / "probes.csv").exists()
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    check = subprocess.run([sys.executable, "-m", "latdyn", "check", str(tmp_path / "scene.yaml")], env=env,
                           capture_output=True, text=True, timeout=120, check=False)
    assert check.returncode == 2 and "not for method explicit" in check.stderr
    (tmp_path / "supported.yaml").write_text(ARM_3D)
    check = subprocess.run([sys.executable, "-m", "latdyn", "check", str(tmp_path / "supported.yaml")], env=env,
                           capture_output=True, text=True, timeout=120, check=False)
    assert check.returncode == 0 and "sensitivities by: F, k, th0, M, EI, G" in check.stdout


def test_a_kernel_variant_without_the_gravity_tangent_refuses_beams_with_mass_under_gravity():
    """A variant generated before beam_gravity_D_q has no exact static matrix under gravity: refused,
    naming the variant to regenerate; massless beams or no gravity pass."""
    from types import SimpleNamespace

    from latdyn.analyses.sensitivities import _refuse_without_gravity_tangent
    from latdyn.assembly.prepare import prepare

    prepared = prepare(yaml.safe_load(GRAVITY_BEAMS_3D))
    stale = SimpleNamespace(libraries={"beam_gravity": None}, variant="default")
    with pytest.raises(SceneError) as info:
        _refuse_without_gravity_tangent(prepared.scene, prepared.model, stale)
    assert info.value.key == "solve.sensitivities" and "python -m codegen --variant default" in info.value.expected
    _refuse_without_gravity_tangent(prepared.scene, prepared.model, prepared.assembler.kernels)   # regenerated
    massless = prepare(yaml.safe_load(GRAVITY_3D))
    _refuse_without_gravity_tangent(massless.scene, massless.model, stale)
