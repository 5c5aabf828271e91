"""Energy and momentum probes in the sensitivities' loop of steps (issue 34 item 2; latdyn/analyses/sensitivities_in_loop.py
``_energy_refusal``): the energies of a row's state alone (kinetic, strain, potential, total) and the linear and
angular momenta need only the δq, δv the loop carries to each row (csrc/sensitivity_loop.c ``sensitivity_loop_row``,
then TransientSensitivities.record at the row, latdyn/analyses/energy_sensitivities.py): their runs take the loop, and
the results are the per-step Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the
API and the CLI; the work accounts (external work, dissipated energy: sums over the steps) beside them too
(tests/test_sensitivities_in_loop_work.py). Scenes: the spin-up of examples/spinup.yaml (a prescribed rotation) with a section value as
parameter, cut short; a 3D hinged arm with a damper and its hinge spring's k; a free 3D beam's momenta."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of
from tests.sensitivity_equality import assert_same_sensitivities
from tests.test_sensitivities_energies import ENERGY_PROBES
from tests.test_sensitivities_events import LATCH_3D, LATCH_PLANAR
from tests.test_sensitivities_in_loop import ARM_3D

ROOT = Path(__file__).resolve().parents[1]

#: tests/test_sensitivities_energies.py's energy and momentum probes but the work accounts: the kinetic, strain,
#: potential and total energies and the six momenta (probed on the latching arms too, where the kinetic energy and the
#: momenta jump at the latch, which the Python path takes)
STATE_PROBES = "".join(line + "\n" for line in ENERGY_PROBES.strip("\n").split("\n")
                       if "external_work" not in line and "dissipated" not in line)
assert STATE_PROBES.count("{energy:") == 4 and STATE_PROBES.count("{momentum:") == 6

#: the spin-up of examples/spinup.yaml (its hub's prescribed rotation, its `energy: total` probe) with the arm's
#: bending stiffness as a parameter, over its first 0.3 s
SPINUP = ((ROOT / "examples" / "spinup.yaml").read_text()
          .replace("sections:", "parameters: {EI: 1.4e4}\nsections:")
          .replace("EIy: 1.4e4, EIz: 1.4e4", 'EIy: "EI", EIz: "EI"')
          .replace("t_end: 20", "t_end: 0.3\n  sensitivities: [EI]")
          .replace("    energy: {energy: total}\n",
                   "    energy: {energy: total}\n    kinetic: {energy: kinetic}\n    strain: {energy: strain}\n"))
assert 'EIy: "EI"' in SPINUP and "sensitivities: [EI]" in SPINUP and "kinetic: {energy" in SPINUP

#: the 3D arm of tests/test_sensitivities_in_loop.py (a hinged second beam with a spring and a damper, a joint body,
#: gravity, loads) with its hinge spring's k beside E, rho, F, and every energy of the state and the momenta probed
ARM_ENERGIES = (ARM_3D.replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}", "parameters: {E: 1.0, rho: 0.5, F: 2.0, k: 30.0}")
                .replace("stiffness: 30.0, damping: 0.2}", 'stiffness: "k", damping: 0.2}')
                .replace("sensitivities: [E, rho, F]", "sensitivities: [E, rho, F, k]")
                + STATE_PROBES)
assert 'stiffness: "k"' in ARM_ENERGIES and "[E, rho, F, k]" in ARM_ENERGIES and "hy: {momentum" in ARM_ENERGIES

#: a free 3D beam (no support) thrown spinning about a skew axis, a tip load of its amplitude F in t: its energies
#: and momenta by the section values and F
FREE_BEAM = """
title: a free 3D beam thrown spinning, its momenta
parameters: {E: 1.0, rho: 0.5, F: 1.0}
sections:
  s: {EA: "1.0e4*E", EIy: "20*E", EIz: "30*E", GJ: "15*E", rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.02*rho"}
bodies:
  a: {at: [0, 0, 0]}
beams:
  b: {from: a, to: [1.0, 0.3, 0.2], section: s, elements: 4, y_axis: [0, 0, 1]}
loads:
  - {at: b.end, force: [0, "F*sin(10*t)", "0.5*F"]}
initial_velocity: {linear: [0.1, 0, 0.2], angular: [0.5, 1.0, 2.0]}
solve: {analysis: transient, dt: 0.005, t_end: 0.1, sensitivities: [E, rho, F]}
output:
  every: 0.01
  probes:
""" + STATE_PROBES


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def _same(native, python, beside_the_loop: int = 0) -> None:
    """The two runs' sensitivities and the summary's, to the bit; the loop took every step but ``beside_the_loop``."""
    assert_same_sensitivities(native, python, in_loop_but=beside_the_loop)


@pytest.mark.parametrize("text", [SPINUP, ARM_ENERGIES, FREE_BEAM], ids=["spin-up", "3D hinged arm", "free 3D beam"])
def test_energies_of_the_state_and_momenta_take_the_loop(text, monkeypatch):
    """Kinetic, strain, potential and total energies and the momenta: every step in the loop of steps, the Python
    path's sensitivities to the bit; an energy's and a momentum's columns nonzero."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    _same(native, python)
    probe = "kinetic" if "kinetic" in text else "total"
    assert any(np.abs(v).max() > 0.0 for (name, _), v in native.sensitivities.items() if name == probe)


@pytest.mark.parametrize("text", [LATCH_PLANAR + STATE_PROBES, LATCH_3D + STATE_PROBES], ids=["planar latch", "3D latch"])
def test_energies_of_the_state_and_momenta_beside_a_latch(text, monkeypatch):
    """The planar arm and the 3D wheel latching: every smooth step in the loop but the latch's and the landing after
    it (from Python), the energies' and momenta's sensitivities and the event's the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == ["latch"]
    _same(native, python, beside_the_loop=2)


@pytest.mark.parametrize("quantity", ["dissipated", "external_work"])
def test_the_work_accounts_take_the_loop_beside_them(quantity, monkeypatch):
    """The dissipated energy and the external work (sums over the steps, carried by csrc/work_accounts.c in the loop
    and from Python alike: tests/test_sensitivities_in_loop_work.py) take the loop beside the energies of the state
    and the momenta; the run is the one with the switch off to the bit."""
    text = ARM_ENERGIES + f"    account: {{energy: {quantity}}}\n"
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    _same(native, python)
    assert np.abs(native.sensitivities[("account", "k")]).max() > 0.0


def test_the_cli_writes_the_python_paths_files_for_the_spin_up(tmp_path):
    """``latdyn run`` on the cut spin-up takes the loop; the same command with the switch off (a process of its own)
    writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, SPINUP)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] == summary["steps"] == 60
    from tests.cli_runs import the_loop_off_writes_the_same   # here: benchmarks/energy_sensitivities_loop.py reads
    # this file's scenes beside older trees' tests/cli_runs.py

    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("text", [ARM_ENERGIES, FREE_BEAM], ids=["3D hinged arm", "free 3D beam"])
def test_the_adjoints_passes_take_the_loop_with_energies_of_the_state_and_momenta(text, monkeypatch):
    """Under ``sensitivity_method: adjoint`` (seeded at each row by the probes' forms, energy_sensitivities.probe_forms,
    at the stored states; it refuses the work accounts itself) the forward pass's every step is stored by the loop of
    steps and the reverse pass takes every step natively (latdyn/analyses/adjoint_in_loop.py), the derivatives those of
    the Python and NumPy passes (both private switches off) to the bit."""
    text = text.replace("sensitivities: [", "sensitivity_method: adjoint, sensitivities: [")
    runs = []
    for native in (True, False):
        with monkeypatch.context() as patch:
            patch.setattr("latdyn.analyses.adjoint_in_loop.ADJOINT_IN_LOOP", native)
            patch.setattr("latdyn.analyses.adjoint_in_loop.REVERSE_NATIVE", native)
            runs.append(latdyn.run(latdyn.load_scene(yaml.safe_load(text))))
    native, python = runs
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] > 0
    assert python.summary["sensitivity_steps_in_loop"] == 0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert any(value != 0.0 for value in native.summary["probe_sensitivities"]["kinetic"]["end"].values())
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
