"""Defects found in review (issue 34's session), each reproduced from a scene as a user types it (YAML
through the CLI, or a mapping through the API) and checked against what the package must do.

1. A study judged a structure at rest unbounded on round-off: its energy rule had no floor, where the
   run's rule has one (``progress.energy_round_off``). The study uses the same floor now."""
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
from tests.cli_runs import ROOT, latdyn_run
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
    (lambda d: d["beams"]["arm"]["start"]["hinge"].update(torque="1e2*k*e2*1e-2"), "beams.arm.start.hinge.torque"),
    (lambda d: d.update(loads=[{"at": "tip", "force": [0, 0, 0], "moment": [0, "0.5*e2*k", 0], "frame": "tip"}]),
     "loads[0].moment[1]"),
])
def test_a_law_that_reads_a_controller_with_a_parameter_is_still_refused(tmp_path, change, key):
    """The other direction: a hinge torque or a load component that reads the controller and a parameter
    (its gain would depend on the parameter) is refused, before anything is compiled, naming the law's key
    (CLI exit 2, and the API)."""
    data = yaml.safe_load(E2_ARM)
    change(data)
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities" and f"used at {key}, a law that names a controller" in str(info.value)
    completed, _ = latdyn_run(tmp_path, yaml.safe_dump(data, sort_keys=False))
    assert completed.returncode == 2 and f"used at {key}" in completed.stderr and "Traceback" not in completed.stderr
