"""The transient sensitivities' smooth steps in the loop of steps in C (latdyn/analyses/sensitivities_in_loop.py,
csrc/sensitivity_loop.c; issue 34 item 2): taken where every term of the step's derivative is native (section values
and load components; summary.json ``sensitivity_steps_in_loop`` counts them), equal to the per-step Python path
(the private switch ``SENSITIVITIES_IN_LOOP`` off) through the API and the CLI, with a latch between them taken from
Python; hinge laws' and joint bodies' parameters taken too (the deploying boom's design run through the CLI), a hinge
law in the angle whose derivative does not compile keeps the whole run on the Python path; a run interrupted inside the loop resumes to the same
files."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import ROOT, latdyn_run, latdyn_run_switched, summary_of
from tests.resumed_runs import resumed_inside_the_loop_is_whole
from tests.sensitivity_equality import assert_same_sensitivities
from tests.test_sensitivities_contact import WHEEL
from tests.test_sensitivities_events import LATCH_PLANAR
from tests.test_sensitivities_friction import SKEW
from tests.test_sensitivities_joint_forces import BOOM
from tests.test_sensitivities_native_parts import ARM

#: the planar arm of tests/test_sensitivities_events.py swung open by its root hinge's spring and latching at 0.8 rad
#: (t ≈ 0.46 s), with a tip load: section values and a load's amplitude as parameters (native kinds); the latch's
#: step and the one after it from Python
LATCH = (LATCH_PLANAR.replace("parameters: {k: 2.0, c: 0.05, EI: 20.0, rho: 0.5, m: 0.3}",
                              "parameters: {EI: 20.0, rho: 0.5, F: 0.4}")
         .replace('damping: "c"', "damping: 0.05").replace('mass: "m"', "mass: 0.3")
         .replace("solve: {", 'loads:\n  - {at: tip, force: ["0.2*F", "-F", 0]}\nsolve: {')
         .replace("sensitivities: [k, c, EI, rho, m]", "sensitivities: [EI, rho, F]"))

#: the 3D arm of tests/test_sensitivities_native_parts.py (a hinged second beam, a joint body, gravity, loads in a
#: body's frame and in t), spinning faster and longer: its fastest node turns 0.018–0.028 rad in each step (past dexp's series, measured)
ARM_3D = ARM.replace("angular: [0, 0, 2.0]", "angular: [0, 0, 3.0]").replace("t_end: 0.04", "t_end: 0.06")
assert ARM_3D != ARM and "F: 0.4" in LATCH and "0.05" in LATCH

#: the 3D arm with its hinge's spring, damper, rest angle and a torque in t and its joint body's mass, inertia and
#: centre of mass as parameters (the hinge laws' and joint bodies' kinds): the hinge's stiffness a law in t, so that
#: the derivative laws' values are tabulated per grid point
ARM_3D_JOINTS = (ARM_3D.replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}",
                                "parameters: {E: 1.0, rho: 0.5, F: 2.0, k: 30.0, c: 0.2, r: 0.1, A: 0.5, M: 0.8, "
                                "J: 0.01, cx: 0.05}")
                 .replace("stiffness: 30.0, damping: 0.2}",
                          'stiffness: "k*(1 + 2*t)", damping: "c", rest_angle: "r", torque: "A*sin(20*t) + 0.1*A**2"}')
                 .replace("mass: 0.8, com: [0.05, 0, -0.05], inertia: [0.01, 0.01, 0.02]",
                          'mass: "M", com: ["cx", 0, -0.05], inertia: ["J", 0.01, 0.02]')
                 .replace("sensitivities: [E, rho, F]", "sensitivities: [E, k, c, r, A, M, J, cx]"))
assert all(part in ARM_3D_JOINTS for part in ("cx: 0.05}", 'torque: "A*', 'mass: "M"', "[E, k, c, r, A, M, J, cx]"))


#: the design run of examples/deploying_boom_sensitivities.py (its hinge's spring k and damper c, latching at π), as a
#: user types it: tests/test_sensitivities_joint_forces.py's boom over the example's 2.5 s, its probes the example's
#: (test_the_design_examples_scene_is_the_examples)
BOOM_DESIGN = (BOOM.replace(", the latch load probed", "").replace("t_end: 1.4", "t_end: 2.5")
               .replace("    latch: {hinge: outer.start, quantity: torque}\n", "")
               + "    hinge: {hinge: outer.start, quantity: angle}\n")


def test_the_design_examples_scene_is_the_examples():
    """BOOM_DESIGN is the scene examples/deploying_boom_sensitivities.py optimises."""
    spec = importlib.util.spec_from_file_location("boom_design", ROOT / "examples" / "deploying_boom_sensitivities.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    assert yaml.safe_load(BOOM_DESIGN) == example.SCENE


def _latch(k: str = "2.0") -> str:
    return LATCH.replace('stiffness: "k"', f"stiffness: {k}")


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


@pytest.mark.parametrize("text", [ARM_3D, _latch(), ARM_3D_JOINTS, LATCH_PLANAR, WHEEL, SKEW],
                         ids=["3D arm", "planar latch", "3D arm, hinge and body", "planar latch, hinge and body",
                              "3D compliant stop", "3D friction"])
def test_the_smooth_steps_in_the_loop_are_the_python_paths(text, monkeypatch):
    """The loop of steps carries the sensitivities through every smooth step (all of the arm's; the latch's steps
    but the event's and the landing after it) and they are the per-step Python path's to the bit: rows, extremes
    and the event's time derivative; with section and load parameters, and with a hinge's laws' and a joint body's
    (the planar latch's spring, damper and tip mass), a compliant stop's stiffness, exponent and damping (the wheel
    in and out of its stop: the onset's steps from Python) and a friction law's values (the skew hinge slipping)."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps = native.summary["steps"]
    assert native.summary["time_loop"] == "compiled" and python.summary["time_loop"] == "python"
    assert python.summary["sensitivity_steps_in_loop"] == 0
    in_loop = native.summary["sensitivity_steps_in_loop"]
    if native.summary["event_sensitivities"]:
        assert 0 < in_loop < steps and native.summary["event_sensitivities"][0]["kind"] == "latch"
    elif "contact:" in text or "friction:" in text:   # the stop's onset and exit, the slipping's turns from Python
        assert 0.8 * steps < in_loop < steps
    else:
        assert in_loop == steps > 0
    assert_same_sensitivities(native, python, python_steps_in_loop=False, nonzero="each")  # (asserted above)


@pytest.mark.parametrize("text", [_latch(), BOOM_DESIGN], ids=["planar latch", "deploying boom's design run"])
def test_the_cli_writes_the_python_paths_files(text, tmp_path):
    """``latdyn run`` on the latching arm (section and load parameters) and on the deploying boom's design run (its
    hinge's spring and damper) takes the loop; the same command with the switch off (in a process of its own) writes
    the same sensitivities.csv and probes.csv, byte for byte, and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] > 40
    reference = tmp_path / "python"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", reference, "import latdyn.analyses.sensitivities_in_loop as loop; loop.SENSITIVITIES_IN_LOOP = False")
    assert run.returncode == 0, run.stderr
    assert summary_of(reference)["sensitivity_steps_in_loop"] == 0
    for name in ("sensitivities.csv", "probes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    assert summary["probe_sensitivities"] == summary_of(reference)["probe_sensitivities"]
    assert summary["event_sensitivities"] == summary_of(reference)["event_sensitivities"]


def test_a_hinge_law_in_the_angle_keeps_the_run_on_the_python_path_where_it_does_not_compile(monkeypatch):
    """A hinge parameter whose derivative law names theta takes the loop with the law compiled
    (latdyn/analyses/derivative_laws.py; tests/test_sensitivities_in_loop_state_laws.py); where the law does not
    compile, every step of the run from Python, decided at its start; the same parameter in a constant law takes the
    loop."""
    from latdyn.assembly import compiled_laws

    text = _latch('"k"').replace("parameters: {EI: 20.0,", "parameters: {k: 2.0, EI: 20.0,").replace(
        "sensitivities: [EI, rho, F]", "sensitivities: [EI, k]")
    assert _run(text, monkeypatch, True).summary["sensitivity_steps_in_loop"] > 40
    in_angle = text.replace('stiffness: "k"', 'stiffness: "k*(1 + 0.1*theta**2)"')
    assert _run(in_angle, monkeypatch, True).summary["sensitivity_steps_in_loop"] > 40

    def unavailable(*args, **kwargs):
        raise compiled_laws.LawsUnavailable("no compiler for the laws (test)")

    monkeypatch.setattr(compiled_laws, "compile_laws", unavailable)
    result = _run(in_angle, monkeypatch, True)
    assert result.summary["time_loop"] == "python" and result.summary["sensitivity_steps_in_loop"] == 0
    assert np.abs(result.sensitivities[("tip_y", "k")]).max() > 0.0


@pytest.mark.parametrize("text", [_latch(), LATCH_PLANAR], ids=["sections and load", "hinge and body"])
def test_a_run_interrupted_inside_the_loop_resumes_to_the_same_files(text, tmp_path, monkeypatch):
    """Interrupted (Ctrl-C) as a loop of steps starts at t ≥ 0.2, before the latch, and resumed from its checkpoint:
    sensitivities.csv and summary.json's sensitivities and its count of steps in the loop are the uninterrupted
    run's, byte for byte (section and load parameters; the hinge's k, c and the tip's mass among them)."""
    resumed_inside_the_loop_is_whole(yaml.safe_load(text), tmp_path, monkeypatch, 0.2)
