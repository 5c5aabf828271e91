"""Defects found in review (issue 34's session), each reproduced from a scene as a user types it (YAML
through the CLI, or a mapping through the API) and checked against what the package must do.

1. A study judged a structure at rest unbounded on round-off: its energy rule had no floor, where the
   run's rule has one (``progress.energy_round_off``). The study uses the same floor now."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import yaml

import latdyn
from latdyn.model.model import Model
from latdyn.studies.case import _energy_status
from latdyn.timeloop.progress import energy_round_off
from tests.cli_runs import ROOT
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
