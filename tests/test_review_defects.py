"""Defects found in review (issue 34's session), each reproduced from a scene as a user types it (YAML
through the CLI, or a mapping through the API) and checked against what the package must do.

1. A study judged a structure at rest unbounded on round-off: its energy rule had no floor, where the
   run's rule has one (``progress.energy_round_off``). The study uses the same floor now.
2. A law's signals were found as words of its text: "1e2*k" read a controller (or input) named ``e2``,
   so a plain run was refused and sensitivities too. The names are the parser's tokens now, and
   ``ControllerTerms.refusal`` takes each law's parsed names by the key it was read at.
3. A massless cable pretensioned to a free end snapped in the first step (its pretension's energy
   lost): refused now unless the loads at the end balance the pull. Found on the way: a cable's end
   off a coordinate plane left the model planar (the end moved in the plane only).
4. Geometry parameters a planar model cannot take, and a kernel variant without the reference
   derivatives, were refused only after compiling (``latdyn check`` passed them): refused up front now."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.model.model import Model
from latdyn.studies.case import _energy_status
from latdyn.timeloop.progress import energy_round_off
from latdyn.errors import SceneError
from tests.cli_runs import ROOT, latdyn_run, probe_columns, summary_of
from tests.test_energy_balance import AT_REST


# ----------------------------------------------------------------------------- 1. the studies' floor
AT_REST_STUDY = """\
title: a structure at rest
scene: rest.yaml
vary:
  solve.dt: [0.01, 0.005]
reference:
  overrides: {solve.dt: 0.0025}
error: {probe: strain, norm: max}
"""


def test_a_study_of_a_structure_at_rest_is_solved(tmp_path):
    """A 3D cantilever at rest beside a guided body (no load, no gravity) computes strain energies of
    3.4e-29 J at t = 0 and 4e-26 J later: round-off over round-off. Before, every case of its study
    (and the reference) was judged unbounded ("created more energy than the structure received, from
    t = 0.03"); with the run's floor, ½ Σ EA L (8 ε)² = 7.5e-24 J, they are solved (CLI and API)."""
    (tmp_path / "rest.yaml").write_text(AT_REST)
    (tmp_path / "study.yaml").write_text(AT_REST_STUDY)
    completed = subprocess.run([sys.executable, "-m", "latdyn", "study", "study.yaml", "-o", "out"], cwd=tmp_path,
                               capture_output=True, text=True, timeout=300,
                               env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert completed.returncode == 0, completed.stderr
    assert "(2 solved, 0 failed, 0 unbounded)" in completed.stderr
    rows = (tmp_path / "out" / "study.csv").read_text().splitlines()
    assert len(rows) == 3 and all(",solved," in row for row in rows[1:]), rows
    study = yaml.safe_load(AT_REST_STUDY)
    study["scene"] = str(tmp_path / "rest.yaml")
    table = latdyn.study(study, out=tmp_path / "api", progress=False)
    assert table["status"] == ["solved", "solved"]


def test_the_studies_floor_is_the_runs_and_hides_no_instability():
    """The floor is the run's own (one function): energies within it are none received; an energy
    that grows past what the structure received is still unbounded with the floor in place."""
    round_off = energy_round_off(Model.from_scene(latdyn.load_scene(yaml.safe_load(AT_REST))))
    assert 7e-24 < round_off < 8e-24
    t = np.linspace(0.0, 0.1, 5)
    zero = np.zeros(5)
    noise = np.array([3.4e-29, 4e-26, 1e-27, 4e-26, 2e-26])  # the strain energies of the run at rest
    probes = {"_study_K": zero, "_study_S": noise, "_study_P": zero, "_study_W": zero}
    assert _energy_status(t, probes) == "unbounded"           # the rule without a floor: the defect
    assert _energy_status(t, probes, round_off) is None
    grow = np.array([1e-3, 1e-3, 3e-3, 9e-3, 27e-3])            # a free vibration of 1 mJ that grows
    probes = {"_study_K": grow, "_study_S": zero, "_study_P": zero, "_study_W": zero}
    assert _energy_status(t, probes, round_off) == "unbounded"


# ----------------------------------------------------------------------------- 2. the names a law reads
#: an arm on a sprung hinge out of the coordinate planes, damped by a controller named ``e2``; the spring's
#: stiffness is written "1e2*k*1e-2": numbers with exponents, whose ``e2`` the package once took for the
#: controller (found by words in the text, not by the parser's tokens)
E2_ARM = """\
title: an arm on a sprung hinge out of the coordinate planes, damped by a controller named e2
parameters: {k: 3.0, g: 0.8}
sections: {s: {EA: 1.0e6, EIy: 2.0e3, EIz: 2.0e3, GJ: 1.5e3, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.01}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6, 0.3, 0.5], mass: 0.5}
beams:
  arm: {from: base, to: tip, section: s, elements: 2,
        start: {hinge: {axis: [1, -2, 0.5], stiffness: "1e2*k*1e-2", rest_angle: 0.4, torque: "e2"}}}
controllers:
  e2: {output: "-g*rate"}
solve: {analysis: transient, t_end: 0.3, dt: 0.01, sensitivities: [k, g]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.start, quantity: angle}
    rate: {hinge: arm.start, quantity: rate}
    tip_z: {point: tip, quantity: position, component: z}
"""


def _e2_arm(**parameters):
    data = yaml.safe_load(E2_ARM)
    data["parameters"].update(parameters)
    del data["solve"]["sensitivities"]
    return latdyn.run(latdyn.load_scene(data))


def test_a_number_with_an_exponent_does_not_read_a_controller(tmp_path):
    """"1e2*k*1e-2" reads no controller ``e2``: before, the stiffness's law listed e2 among the signals it
    reads, so the run was refused twice over (exit 2: "a continuous controller ('e2') drives ... expected it
    nowhere else", and with sensitivities "parameter 'k' is used at ..., a law that names a controller").
    Now it runs (CLI, exit 0), and ∂/∂k (API) agrees with central differences of whole runs (k ± 1e-4 k,
    ± 5e-5 k, Richardson-extrapolated): measured 2.3e-10 (angle), 4.5e-9 (rate), 2.4e-10 (tip z) of each
    probe's largest sensitivity."""
    from latdyn.scene.loader import load_scene

    data = yaml.safe_load(E2_ARM)
    stiffness = load_scene(data).beams["arm"].start.hinge.stiffness
    assert getattr(stiffness, "input_names", ()) == ()   # now the number 3 itself
    del data["solve"]["sensitivities"]
    completed, _ = latdyn_run(tmp_path, yaml.safe_dump(data, sort_keys=False))
    assert completed.returncode == 0, completed.stderr
    sensitivities = latdyn.run(latdyn.load_scene(yaml.safe_load(E2_ARM))).sensitivities
    k, h = 3.0, 3e-4
    central = []
    for step in (h, h / 2):
        up, down = _e2_arm(k=k + step), _e2_arm(k=k - step)
        central.append({name: (up.probes[name] - down.probes[name]) / (2 * step) for name in up.probes})
    for probe in ("angle", "rate", "tip_z"):
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        scale = np.abs(expected).max()
        assert scale > 1e-3, probe
        error = np.abs(sensitivities[(probe, "k")] - expected).max() / scale
        assert error <= 1e-7, (probe, error)


@pytest.mark.parametrize("change, key", [
    (lambda d: d.update(loads=[{"at": "tip", "force": [0, 0, 0], "moment": [0, "0.5*e2*k", 0], "frame": "tip"}]),
     "loads[0].moment[1]"),
])
def test_a_law_that_reads_a_controller_with_a_parameter_is_still_refused(tmp_path, change, key):
    """The other direction: a load component that reads the controller and a parameter (its gain would depend on
    the parameter) is refused, before anything is compiled, naming the law's key (the API; a hinge torque is
    differentiated since: :func:`test_a_hinge_torque_that_reads_a_controller_with_a_parameter_is_differentiated`)."""
    data = yaml.safe_load(E2_ARM)
    change(data)
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities" and f"used at {key}, a law that names a controller" in str(info.value)
    if key.startswith("beams"):   # and through the CLI
        completed, _ = latdyn_run(tmp_path, yaml.safe_dump(data, sort_keys=False))
        assert completed.returncode == 2 and f"used at {key}" in completed.stderr and "Traceback" not in completed.stderr


# ----------------------------------------------------------------------------- 3. a massless cable's free end
#: a massless cable from a fixed anchor to a free end [0.6, 0.48, 0.64] (length 1), rest length 0.9:
#: pretensioned, N = EA (1 − 0.9)/0.9 = 2.2e5 N, and the end has no mass
PRETENSIONED_FREE_END = """\
title: a massless cable pretensioned to a free end
bodies:
  anchor: {at: [0, 0, 0], fixed: true}
cables:
  rope: {from: anchor, to: [0.6, 0.48, 0.64], EA: 2.0e6, rest_length: 0.9}
solve: {analysis: transient, t_end: 0.05, dt: 0.01}
output:
  probes:
    tension: {cable: rope, quantity: tension}
    z: {point: rope.end, quantity: position, component: z}
"""
PULL = 2.0e6 * (1.0 - 0.9) / 0.9


def _balanced(fraction: float) -> str:
    """The scene with a load at the free end pulling it away from the anchor with ``fraction`` of the pull."""
    force = [f'"{fraction * PULL!r}*{c}"' for c in ("0.6", "0.48", "0.64")]
    return PRETENSIONED_FREE_END.replace("solve:", f"loads:\n  - {{at: rope.end, force: [{', '.join(force)}]}}\nsolve:")


def test_a_pretensioned_massless_cable_whose_free_end_is_not_in_equilibrium_is_refused(tmp_path):
    """The end has no mass: before, the first step snapped it to the rest length (tension 2.2e5 N -> 0,
    the pretension's 1.1e4 J gone: an energy balance error of 1, then "went slack", exit 1). Now ``latdyn
    run`` (no load) and ``latdyn check`` (a load that balances half the pull) refuse it before any step
    (exit 2), naming cables.rope.rest_length, the pull and what to give instead; the API raises the same
    SceneError for both."""
    completed, out = latdyn_run(tmp_path, PRETENSIONED_FREE_END)
    assert completed.returncode == 2, completed.stderr
    assert "cables.rope.rest_length: expected the free end rope.end of the massless cable in equilibrium at t = 0" \
        in completed.stderr and "Traceback" not in completed.stderr
    assert f"pulls it with {PULL:.6g} N" in completed.stderr and f"{PULL:.6g} N of that is not balanced" in completed.stderr
    assert not (out / "probes.csv").exists()
    (tmp_path / "half.yaml").write_text(_balanced(0.5))
    check = subprocess.run([sys.executable, "-m", "latdyn", "check", "half.yaml"], cwd=tmp_path, capture_output=True,
                           text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert check.returncode == 2 and f"{0.5 * PULL:.6g} N of that is not balanced" in check.stderr, check.stderr
    for text in (PRETENSIONED_FREE_END, _balanced(0.5)):
        with pytest.raises(SceneError) as info:
            latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
        assert info.value.key == "cables.rope.rest_length"


def test_a_pretensioned_massless_cable_whose_pull_a_load_balances_holds_still(tmp_path):
    """The same cable with a load at its end equal and opposite to the pull: in equilibrium at t = 0, it
    runs and stays there (the tension and the end's z exactly as at t = 0 at every row; balance error 0)."""
    completed, out = latdyn_run(tmp_path, _balanced(1.0))
    assert completed.returncode == 0, completed.stderr
    probes = probe_columns(out)
    assert np.abs(probes["tension"] / PULL - 1.0).max() < 1e-12
    assert np.abs(probes["z"] - 0.64).max() < 1e-15
    assert summary_of(out)["energy_balance_error"] < 1e-12


#: the same pretension with mass (rhoA 2 kg/m: 0.9 kg lumped at the free end) and EA 2000 N, off the xy plane
MASSIVE_FREE_END = """\
title: a pretensioned cable with mass, from an anchor to a free end off the xy plane
bodies:
  anchor: {at: [0, 0, 0], fixed: true}
cables:
  rope: {from: anchor, to: [0.6, 0.48, 0.64], EA: 2000.0, rhoA: 2.0, rest_length: 0.9}
solve: {analysis: transient, t_end: 0.03, dt: 0.0001}
output:
  every: 0.001
  probes:
    z: {point: rope.end, quantity: position, component: z}
    length: {cable: rope, quantity: length}
"""


def test_a_cable_off_the_plane_keeps_the_model_3d(tmp_path):
    """A cable's end off the xy plane kept the model planar (its ends were not among the points the plane
    is checked against): the end then moved in the xy plane only, its z frozen at 0.64 (an error of 0.059
    against the exact motion, a length off by 0.035). Now the model is 3D and the end (0.9 kg, pulled
    along the cable, ℓ(t) = L0 + 0.1 cos ω t, ω² = EA/(L0 m), taut to t = 0.03) follows
    z = 0.64 ℓ(t): measured 2.1e-7 (z) and 3.2e-7 (length), generalized-α at ω dt = 0.005."""
    completed, out = latdyn_run(tmp_path, MASSIVE_FREE_END)
    assert completed.returncode == 0, completed.stderr
    probes = probe_columns(out)
    omega = np.sqrt(2000.0 / (0.9 * 0.9))
    length = 0.9 + 0.1 * np.cos(omega * probes["t"])
    assert np.abs(probes["length"] - length).max() < 1e-6
    assert np.abs(probes["z"] - 0.64 * length).max() < 1e-6
    model = Model.from_scene(latdyn.load_scene(yaml.safe_load(MASSIVE_FREE_END)))
    assert model.plane is None and "cables.rope.to is off the plane" in model.plane_reason


# ----------------------------------------------------------------------------- 4. geometry refusals up front
#: a planar cantilever in the xy plane whose free end's z is a parameter (0): z0 lifts it off the plane
OFF_PLANE = """\
title: a planar cantilever whose end a parameter lifts off the plane
parameters: {L: 1.2, z0: 0.0, c: 0.0, ax: 0.0}
sections: {s: {EA: 1.0e6, EIy: 100.0, EIz: 100.0, GJ: 80.0, rhoA: 1.0}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: base, to: ["L", 0, "z0"], section: s, elements: 2, y_axis: [0, 1, "c"],
        start: {hinge: {axis: ["ax", 0, 1], stiffness: 50.0}}}
loads:
  - {at: arm.end, force: [0, -1, 0]}
solve: {analysis: transient, t_end: 0.02, dt: 0.01, sensitivities: [NAME]}
output:
  probes:
    tip: {point: arm.end, quantity: position, component: y}
"""


def _nothing_compiled(monkeypatch):
    """Make loading (compiling) the kernels an error: a refusal must come first."""
    import latdyn.assembly.prepare as prepare

    def compiled(*args, **kwargs):
        raise AssertionError("the kernels were loaded before the refusal")
    monkeypatch.setattr(prepare, "load_kernels", compiled)


@pytest.mark.parametrize("name, expected", [
    ("z0", "a geometry parameter moves a point off the plane of the planar model; expected solve.planar: off"),
    ("c", "a parameter of beams.arm.y_axis in a planar model"),
    ("ax", "a parameter of beams.arm.start.hinge.axis in a planar model"),
])
def test_geometry_parameters_a_planar_model_cannot_take_are_refused_before_compiling(tmp_path, monkeypatch, name,
                                                                                    expected):
    """Before, these were refused only when the run built the sensitivities (after compiling the kernels) and
    ``latdyn check`` passed them (exit 0). Now ``latdyn check`` refuses them (exit 2, naming
    solve.sensitivities, the message the run gave) and so does the run, before any kernel is loaded."""
    text = OFF_PLANE.replace("NAME", name)
    (tmp_path / "scene.yaml").write_text(text)
    if name == "z0":   # one through the CLI
        check = subprocess.run([sys.executable, "-m", "latdyn", "check", "scene.yaml"], cwd=tmp_path,
                               capture_output=True, text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
        assert check.returncode == 2 and f"solve.sensitivities: {expected}" in check.stderr, check.stderr
    _nothing_compiled(monkeypatch)
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert info.value.key == "solve.sensitivities" and expected in info.value.expected


def test_an_in_plane_geometry_parameter_is_not_refused():
    """The other side: L moves the end along x, in the plane: nothing refuses it."""
    from latdyn.analyses.sensitivities import refusal

    assert refusal(latdyn.load_scene(yaml.safe_load(OFF_PLANE.replace("NAME", "L")))) is None


def test_a_variant_without_the_reference_derivatives_is_refused_before_compiling(monkeypatch):
    """A kernel variant generated before the reference derivatives (none is committed: its generated metadata
    stands in) is refused from the generated metadata alone, with the message the run gave after compiling."""
    import latdyn.model.kernels as kernels

    monkeypatch.setattr(kernels, "generated_info", lambda variant: {})
    _nothing_compiled(monkeypatch)
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(yaml.safe_load(OFF_PLANE.replace("NAME", "L"))))
    assert info.value.expected.startswith("geometry parameters need the kernels beam_internal_force_D_reference and "
                                          "beam_inertia_force_D_reference (reference block of 25), which the "
                                          "generated variant 'default_xy' does not hold yet")


def test_a_hinge_torque_that_reads_a_controller_with_a_parameter_is_differentiated():
    """The torque ``1e2*k*e2*1e-2`` (refused on 86d57d9, "a law that names a controller"; the number 1e2 reads no
    controller): ∂τ/∂k = e2 at fixed output (tests/test_sensitivities_refusals_lifted2.py). Against
    Richardson-extrapolated central differences of whole runs: measured angle 3.4e-10, rate 1.0e-8, tip_z 2.8e-10."""
    data = yaml.safe_load(E2_ARM)
    data["beams"]["arm"]["start"]["hinge"]["torque"] = "1e2*k*e2*1e-2"
    sensitivities = latdyn.run(latdyn.load_scene(data)).sensitivities
    del data["solve"]["sensitivities"]

    def run(k):
        moved = yaml.safe_load(yaml.safe_dump(data))
        moved["parameters"]["k"] = k
        return latdyn.run(latdyn.load_scene(moved))

    central = []
    for step in (3e-4, 1.5e-4):
        up, down = run(3.0 + step), run(3.0 - step)
        central.append({name: (up.probes[name] - down.probes[name]) / (2 * step) for name in up.probes})
    for probe in ("angle", "rate", "tip_z"):
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        error = np.abs(sensitivities[(probe, "k")] - expected).max() / np.abs(expected).max()
        assert error <= 1e-6, (probe, error)
