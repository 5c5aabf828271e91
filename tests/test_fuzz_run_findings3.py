"""The outside check of int16's merges (rigid links and guides, geometry parameters and rows in the sensitivities'
loop of steps; fuzz4, 2026-11-28): the combinations its stress runs tried that no other test holds. A chain of
rigid bays whose first hinge latches and whose second bounces off a stop with restitution, rows every 7th step,
takes its smooth steps' sensitivities in the loop, and the four settings of the private switches
(``SENSITIVITIES_IN_LOOP``, ``SENSITIVITY_ROWS_IN_LOOP``) give the same bits; interrupted inside the loop after
the latch it resumes to the same files. Found and mended: a modal run through the API gave other bits than
``latdyn run`` where SciPy's OpenBLAS was first loaded inside the run (its eigensolver), on the machine's cores."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from tests.resumed_runs import resumed_inside_the_loop_is_whole
from tests.test_sensitivities_in_loop_links import CHAIN

#: tests/test_sensitivities_in_loop_links.py's chain of two rigid bays carrying a flexible boom, its first bay
#: latching in line (t = 0.2512 s), its second bouncing off its stop at 2π/3 (t = 0.3404 s, restitution 0.5) instead
#: of latching; rows every 7th step, the boom's axial force among the probes
CHAIN_LATCH_AND_STOP = (CHAIN.replace("rest_angle: 2*pi/3 + 0.3, lock_at: 2*pi/3",
                                      "rest_angle: 2*pi/3 + 0.3, limits: [-1.0, 2*pi/3], restitution: 0.5")
                        .replace("  every: 0.05\n", "  every: 0.035\n")
                        .replace("    knee2: {hinge: bay2.start, quantity: angle}\n",
                                 "    knee2: {hinge: bay2.start, quantity: angle}\n"
                                 '    boom_n: {element: "boom.element[0]", quantity: axial_force}\n'))


def _run(monkeypatch, in_loop: bool, rows_in_loop: bool):
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        patch.setattr("latdyn.timeloop.loop.SENSITIVITY_ROWS_IN_LOOP", rows_in_loop, raising=False)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(CHAIN_LATCH_AND_STOP)))


def test_a_linked_chain_latching_and_bouncing_gives_the_same_bits_with_every_switch(monkeypatch):
    """The latch's and the stop's steps from Python, every other step in the loop; rows every 7th step recorded in
    the loop or from Python, the loop on or off: the sensitivities, probes and events' time derivatives to the bit."""
    reference = _run(monkeypatch, True, True)
    summary = reference.summary
    assert [event["kind"] for event in summary["events"]] == ["latch", "stop"]
    assert summary["steps"] - 4 <= summary["sensitivity_steps_in_loop"] < summary["steps"]
    assert len(reference.probes["knee1"]) == 16   # t = 0, 0.035, …, 0.49, 0.5
    for in_loop, rows_in_loop in ((True, False), (False, True), (False, False)):
        other = _run(monkeypatch, in_loop, rows_in_loop)
        assert other.summary["sensitivity_steps_in_loop"] == (summary["sensitivity_steps_in_loop"] if in_loop else 0)
        assert other.sensitivities.keys() == reference.sensitivities.keys()
        for key, values in reference.sensitivities.items():
            np.testing.assert_array_equal(other.sensitivities[key], values, err_msg=f"{key} {in_loop} {rows_in_loop}")
        for key, values in reference.probes.items():
            np.testing.assert_array_equal(other.probes[key], values, err_msg=key)
        assert other.summary["probe_sensitivities"] == summary["probe_sensitivities"]
        assert other.summary["event_sensitivities"] == summary["event_sensitivities"]


def test_the_chain_interrupted_in_the_loop_between_its_latch_and_its_stop_resumes_to_the_same_files(
        tmp_path, monkeypatch):
    """Ctrl-C as a loop of steps starts after the latch and before the stop; resumed, sensitivities.csv and the
    summary's sensitivities are the uninterrupted run's, byte for byte."""
    scene = yaml.safe_load(CHAIN_LATCH_AND_STOP)
    resumed_inside_the_loop_is_whole(scene, tmp_path, monkeypatch, 0.3)


#: a free hub with six spokes of eight elements (294 coordinates) out of the plane: its modes by SciPy's eigensolver,
#: which loads SciPy's OpenBLAS inside the run when nothing imported SciPy before
FREE_HUB_MODES = """
title: a free hub with six spokes
sections:
  s: {EA: 1.0e5, EIy: 20.0, EIz: 25.0, GJ: 15.0, rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.001}
bodies:
  hub: {at: [0, 0, 0], mass: 2.0, inertia: [0.1, 0.12, 0.15]}
  t0: {at: [1.0, 0.0, 0.0], mass: 0.1}
  t1: {at: [0.5, 0.866, 0.1], mass: 0.1}
  t2: {at: [-0.5, 0.866, 0.2], mass: 0.1}
  t3: {at: [-1.0, 0.0, 0.3], mass: 0.1}
  t4: {at: [-0.5, -0.866, 0.4], mass: 0.1}
  t5: {at: [0.5, -0.866, 0.5], mass: 0.1}
beams:
  b0: {from: hub, to: t0, section: s, elements: 8}
  b1: {from: hub, to: t1, section: s, elements: 8}
  b2: {from: hub, to: t2, section: s, elements: 8}
  b3: {from: hub, to: t3, section: s, elements: 8}
  b4: {from: hub, to: t4, section: s, elements: 8}
  b5: {from: hub, to: t5, section: s, elements: 8}
solve: {analysis: modes, count: 12}
"""

#: the API run in a fresh process that has not imported SciPy, NumPy's OpenBLAS (and any OpenBLAS loaded later)
#: on two threads by the user's variable; the counts of both libraries read back after the run
API = """\
import json, sys
import latdyn
latdyn.run(latdyn.load_scene(sys.argv[1]), out_dir=sys.argv[2])
from threadpoolctl import threadpool_info
print(json.dumps({name: [lib["num_threads"] for lib in threadpool_info() if f"/{name}.libs/" in lib["filepath"]]
                  for name in ("numpy", "scipy")}))
"""


def test_modes_through_the_api_give_the_commands_bits_where_scipy_loads_inside_the_run(tmp_path):
    """``latdyn run`` (OpenBLAS on one thread from its start) and ``latdyn.run`` in a process where SciPy's OpenBLAS
    is first loaded by the run's eigensolver: the same modes.csv, byte for byte; after the run both libraries are
    on the user's two threads. Before: SciPy's OpenBLAS ran on two threads inside the run, frequencies off in
    their last bits (2.264289746623491 Hz against 2.2642897465945193)."""
    scene = tmp_path / "hub.yaml"
    scene.write_text(FREE_HUB_MODES)
    root = Path(__file__).resolve().parents[1]
    environment = {key: value for key, value in os.environ.items()
                   if key not in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    environment["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), os.environ.get("PYTHONPATH", "")) if p)
    command = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "command"),
                              "-q"], env=environment, capture_output=True, text=True, timeout=600)
    assert command.returncode == 0, command.stderr
    api = subprocess.run([sys.executable, "-c", API, str(scene), str(tmp_path / "api")],
                         env={**environment, "OPENBLAS_NUM_THREADS": "2"}, capture_output=True, text=True, timeout=600)
    assert api.returncode == 0, api.stderr
    assert json.loads(api.stdout.strip().splitlines()[-1]) == {"numpy": [2], "scipy": [2]}
    assert (tmp_path / "api" / "modes.csv").read_bytes() == (tmp_path / "command" / "modes.csv").read_bytes()
