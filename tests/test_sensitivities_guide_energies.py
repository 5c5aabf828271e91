"""Energies and momenta with guides (bodies.NAME.guide; issue 34, "probes of every kind"; docs/parameters.md
"Energies and momenta"): the kinetic and total energies and the linear and angular momenta of a model with guided
bodies, and its external work through a load on a guided body and the guide's own force, differentiated on the
per-step path and in the loop of steps (latdyn/analyses/sensitivities_in_loop.py ``_energy_refusal``,
``_account_refusal``). A guided body is a dependent node of the links' reduction: its δq is J δq and its rates'
δv_dep = J δv + ∂(J v)/∂q δq (latdyn/analyses/link_sensitivities.py ``dependent_rates``, the generated
``prismatic_link_edge_rates_D_q``; for a load on it csrc/work_accounts.c ``dependent_node_motion``), which the
energies' forms (energy_sensitivities._StateForms) and the external work's power take as they are. Against
Richardson-extrapolated central differences of whole runs (1e-4 and 5e-5 relative), the loop against the per-step
path to the bit (API and CLI). Scenes (3D): a bead guided along a skew rod that a prescribed motion turns about a skew
axis, under gravity and a load; a mass on a skew guide at the tip of a flexible arm, pushed by a load and the guide's
force. The external work of a prescribed motion with guides (the drive's reaction through the guides' reduction), refused
here before, is differentiated now: tests/test_sensitivities_refusals_lifted.py."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run, summary_of
from tests.reference_runs import reference_runs
from tests.sensitivity_equality import assert_same_sensitivities
from tests.test_sensitivities_events import _run as _api_run
from tests.test_sensitivities_guides import GUIDE_3D, STATIC_GUIDE
from tests.test_sensitivities_in_loop_energies import STATE_PROBES

#: a bead on a rod that a prescribed motion turns at 2 rad/s about the skew axis (1, 2, 2)/3, along the skew axis
#: (2, −2, 1)/3 of the rod, on a damped spring and a force of t along it, under gravity and a load of t: the
#: centrifugal and Coriolis terms of a guide on a turning body in all three directions; the slide and
#: tests/test_sensitivities_in_loop_energies.py's STATE_PROBES (kinetic, strain, potential, total, the six momenta)
BEAD_3D = """
title: a bead on a rod turning about a skew axis, on a spring along the rod, pushed by a load
parameters: {k: 3.0, c: 0.1, m: 0.5, rest: 0.05, F: 0.4, fg: 0.2}
gravity: [0, 0, -9.81]
bodies:
  rod: {at: [0, 0, 0], motion: {rotation: {axis: [1, 2, 2], angle: "2.0*t"}}}
  bead: {at: [0.2, -0.1, 0.0], mass: "m", inertia: [0.001, 0.002, 0.0015],
         guide: {'on': rod, axis: [2, -2, 1], stiffness: "k", damping: "c", rest: "rest", force: "fg*sin(3*t)"}}
loads:
  - {at: bead, force: ["F", "0.5*F", "-0.3*F*t"]}
solve: {analysis: transient, dt: 0.01, t_end: 0.6, sensitivities: [k, c, m, rest, F, fg]}
output:
  every: 0.05
  probes:
    s: {guide: bead, quantity: position}
""" + STATE_PROBES

#: tests/test_sensitivities_guides.py's GUIDE_3D (a mass on a skew guide (1, −2, 2)/3 at the tip body of a flexible 3D
#: arm, under gravity) pushed by a load of t on the guided mass and the guide's force of t, to 0.3 s at a tight Newton
#: tolerance; the external work beside the energies and momenta (no prescribed motion: its drive's reaction through
#: the guide's reduction is refused)
ARM_3D = (GUIDE_3D[:GUIDE_3D.index("  probes:\n")]
          .replace("parameters: {k: 40.0, c: 0.3, m: 0.4, rest: 0.02, EI: 30.0}",
                   "parameters: {k: 40.0, c: 0.3, m: 0.4, rest: 0.02, EI: 30.0, F: 0.5, fg: 0.3}")
          .replace('rest: "rest"}}', 'rest: "rest", force: "fg*sin(5*t)"}}')
          .replace("solve: {analysis: transient, dt: 0.005, t_end: 0.4, sensitivities: [k, m, EI, rest]}",
                   'loads:\n  - {at: slider, force: ["F", "-0.5*F", "0.3*F*t"]}\n'
                   "solve: {analysis: transient, dt: 0.005, t_end: 0.3, tol: 1.0e-11, sensitivities: [k, m, EI, F, fg]}")
          ) + """  probes:
    kinetic: {energy: kinetic}
    total: {energy: total}
    py: {momentum: linear, component: y}
    hz: {momentum: angular, component: z}
    work: {energy: external_work}
"""
assert "fg*sin(5*t)" in ARM_3D and "F: 0.5" in ARM_3D and "tol: 1.0e-11" in ARM_3D and "every: 0.01" in ARM_3D


def _agree(result, text: str, name: str) -> float:
    """The largest error of ``result``'s sensitivities by ``name`` (each probe over the rows, relative to its largest)
    against Richardson-extrapolated central differences of whole runs (1e-4 and 5e-5 relative; without sensitivities
    where they write ``result``'s probes: tests/reference_runs.py)."""
    p0 = yaml.safe_load(text)["parameters"][name]
    run = reference_runs(text, result, lambda **moved: _api_run(text, name, **moved))
    central = []
    for step in (1e-4 * abs(p0), 5e-5 * abs(p0)):
        up, down = run(**{name: p0 + step}), run(**{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    worst = 0.0
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        worst = max(worst, np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max())
    return worst


def _run(text: str, monkeypatch, in_loop: bool, only: str | None = None):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return _api_run(text, only)


@pytest.mark.parametrize("text, name", [(BEAD_3D, "m"), (BEAD_3D, "k"), (ARM_3D, "fg"), (ARM_3D, "EI")],
                         ids=["bead-m", "bead-k", "arm-fg", "arm-EI"])
def test_energies_momenta_and_work_with_guides_agree_with_richardson(text, name):
    """Measured (every probe's worst, relative to its largest): bead k 3.2e-9, c 1.1e-9, m 3.3e-9, rest 6.0e-10,
    F 2.4e-10, fg 5.2e-10; arm k 6.1e-9, m 2.0e-9, EI 1.3e-8, F 1.7e-8, fg 2.5e-8 (its linear momentum's y the
    largest; the external work ≤ 2.9e-10)."""
    result = _api_run(text, name)
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"]
    assert _agree(result, text, name) <= 1e-6


@pytest.mark.parametrize("text", [BEAD_3D, ARM_3D], ids=["bead on a turning rod", "guide on a flexible arm"])
def test_the_loop_gives_the_per_step_paths_bits(text, monkeypatch):
    """Every step in the loop of steps; the sensitivities and the summary's the per-step Python path's to the bit;
    the energies' and momenta's columns nonzero."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert_same_sensitivities(native, python, in_loop_but=0)
    for probe in ("kinetic", "total", "hz") + (("work",) if "work:" in text else ()):
        assert any(np.abs(v).max() > 0.0 for (name, _), v in native.sensitivities.items() if name == probe), probe


def test_the_cli_writes_the_python_paths_files(tmp_path):
    """``latdyn run`` on the guide at the arm's tip takes the loop at every step; the same command with the switch off
    (a process of its own) writes the same sensitivities.csv and probes.csv, byte for byte, and the summary's
    sensitivities."""
    completed, out = latdyn_run(tmp_path, ARM_3D)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] == summary["steps"] == 60
    from tests.cli_runs import the_loop_off_writes_the_same

    the_loop_off_writes_the_same(tmp_path, out)


def test_a_static_guide_total_energy_agrees_and_the_rest_are_zero():
    """Static load control of the slider on its skew guide at the arm's tip, under gravity
    (tests/test_sensitivities_guides.py STATIC_GUIDE): the total energy (strain + potential at rest) by F, EI and m
    against Richardson, measured 4.3e-10, 6.6e-11, 3.4e-10 (CI runs m); the kinetic energy, the momenta and the
    external work, which a static path records as 0, have zero sensitivities."""
    text = (STATIC_GUIDE.replace("solve:", "gravity: [0, 0, -9.81]\nsolve:").replace("[F, EI]", "[m]")
            .replace("rest: 0.0", "rest: 0.01").replace("    sz: {point", "    total: {energy: total}\n    sz: {point"))
    zeros = "    kinetic: {energy: kinetic}\n    px: {momentum: linear, component: x}\n    work: {energy: external_work}\n"
    result = _api_run(text + zeros)
    assert _agree(result, text, "m") <= 1e-6
    for probe in ("kinetic", "px", "work"):
        assert not np.any(result.sensitivities[(probe, "m")]), probe


#: ARM_3D's slider latching at s = −0.01 (t = 0.199 s), its load and the guide's force constant (through an event the
#: external work is refused where they depend on t: the event's time moves the power there), to 0.4 s
ARM_LATCH = (ARM_3D.replace('force: "fg*sin(5*t)"}}', 'force: "fg", lock_at: -0.01}}').replace('"0.3*F*t"', '"0.3*F"')
             .replace("t_end: 0.3", "t_end: 0.4"))
assert "lock_at: -0.01" in ARM_LATCH and "*t" not in ARM_LATCH


def test_through_a_guides_latch_the_energies_momenta_and_work_agree_and_the_loop_gives_the_same_bits(monkeypatch):
    """The slider latching on its guide: the energies', momenta's and the external work's sensitivities through the
    latch (measured by m, k, fg: ≤ 2.6e-9, 2.5e-9, 8.3e-9; the external work's 3.0e-10, 1.6e-10, 6.5e-10; CI runs fg);
    every smooth step in the loop but the latch's and the landing after it, the per-step path's bits."""
    native, python = _run(ARM_LATCH, monkeypatch, True), _run(ARM_LATCH, monkeypatch, False)
    assert [(e["joint"], e["kind"]) for e in native.summary["events"]] == [("slider", "latch")]
    assert_same_sensitivities(native, python, in_loop_but=2)
    assert _agree(_api_run(ARM_LATCH, "fg"), ARM_LATCH, "fg") <= 1e-6


def test_the_external_work_through_a_guides_event_with_laws_of_t_stays_refused():
    """A guard: through a guide's latch the external work is refused where a load or the guide's force depends on t,
    named, as a hinge's event is (the event's time moves the power there: 7.3e-4 off by m with the refusal lifted)."""
    for text, timed in ((ARM_LATCH.replace('"0.3*F"', '"0.3*F*t"'), "loads\\[0\\]"),
                        (ARM_LATCH.replace('force: "fg"', 'force: "fg*t"'), "the force or spring of bodies.slider.guide")):
        with pytest.raises(SceneError, match=f"events of bodies.slider.guide .*with {timed}, which depends on t"):
            latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


#: ARM_LATCH's slider on a compliant stop at s = −0.01 (Hunt–Crossley, k_c, exponent 1.5) in place of its latch, the
#: strain energy probed beside (it holds the stop's potential k_c⟨δ⟩^2.5/2.5)
ARM_STOP = (ARM_LATCH.replace("lock_at: -0.01}}", 'limits: [-0.01, 1.0], contact: {stiffness: "kc", exponent: 1.5}}}')
            .replace("parameters: {", "parameters: {kc: 2000.0, ").replace("[k, m, EI, F, fg]", "[kc, m]")
            .replace("  probes:\n", "  probes:\n    strain: {energy: strain}\n"))
assert 'stiffness: "kc"' in ARM_STOP and "[kc, m]" in ARM_STOP


def test_a_guides_compliant_stop_in_the_strain_and_total_energies_by_its_stiffness(monkeypatch):
    """The stop's potential is linear in its stiffness: ∂/∂k_c the kernel's contact energy with k_c's derivative, for a
    guide's stops as for a hinge's (``_StateForms._stops``; before, a guide's key was not matched and the strain energy
    by k_c was 0.79 off, the total 2.1). Measured by kc: strain 2.6e-9, total 7.0e-9, all probes ≤ 7.0e-9; by m ≤
    1.1e-9. The loop (every step but the stop's onset landings) gives the per-step path's bits."""
    native, python = _run(ARM_STOP, monkeypatch, True, "kc"), _run(ARM_STOP, monkeypatch, False, "kc")
    assert_same_sensitivities(native, python, in_loop_but=native.summary["steps"] - native.summary[
        "sensitivity_steps_in_loop"])
    assert native.summary["sensitivity_steps_in_loop"] >= native.summary["steps"] - 2
    assert _agree(native, ARM_STOP, "kc") <= 1e-6


def test_the_strain_energy_by_a_guides_stop_exponent_stays_refused():
    """A guard, as for a hinge's stops: the stops' potential's derivative by the exponent is not computed; a guide's
    exponent is named (before, its key was not matched: the strain energy by it was not refused)."""
    text = ARM_STOP.replace("exponent: 1.5", 'exponent: "nc"').replace("parameters: {", "parameters: {nc: 1.5, ").replace(
        "[kc, m]", "[nc]")
    with pytest.raises(SceneError, match=r"exponent of compliant stops \(bodies\.slider\.guide\.contact\.exponent\)"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
