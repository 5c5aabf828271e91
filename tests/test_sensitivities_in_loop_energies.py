"""Energy and momentum probes in the sensitivities' loop of steps in C (latdyn/analyses/sensitivities_in_loop.py;
issue 34 item 2): the kinetic, strain, potential and total energies and the linear and angular momenta are functions
of a row's state and the parameters (latdyn/analyses/energy_sensitivities.py), recorded from the carried δq, δv at
each row as the other probes are; a run with them takes its smooth steps in the loop, and the sensitivities are the
per-step Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit — a 3D arm spinning, a planar
frame spinning, the planar arm through its latch. The external work and the dissipated energy, sums over the steps
whose sensitivities each step carries in Python, keep the run on the Python path, and so does the discrete adjoint
with any energy or momentum probe (adjoint_in_loop.refusal)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.test_sensitivities_energies import FROM_REST_3D, PLANAR_SPIN, SPIN_3D
from tests.test_sensitivities_events import LATCH_PLANAR
from tests.test_sensitivities_in_loop_cables import _run


def _state_energies(text: str) -> str:
    """``text`` without its external work and dissipated energy probes."""
    return "\n".join(line for line in text.splitlines() if "external_work" not in line and "dissipated" not in line) + "\n"


#: the planar arm swung open by its spring until its hinge latches, with the energies and the momentum about z
LATCH_ENERGIES = LATCH_PLANAR + """    kinetic: {energy: kinetic}
    strain: {energy: strain}
    total: {energy: total}
    hz: {momentum: angular, component: z}
    px: {momentum: linear, component: x}
"""


def _same(native, python) -> None:
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    assert max(np.abs(values).max() for key, values in python.sensitivities.items() if key[0] == "kinetic") > 0.0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary.get("event_sensitivities") == python.summary.get("event_sensitivities")


@pytest.mark.parametrize("text", [_state_energies(SPIN_3D), _state_energies(PLANAR_SPIN), _state_energies(FROM_REST_3D)],
                         ids=["3D arm spinning", "planar frame spinning", "3D arm from rest"])
def test_energy_and_momentum_probes_take_every_step_in_the_loop(text, monkeypatch):
    """Every step in the loop of steps, the energies' and momenta's sensitivities the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] > 0
    assert python.summary["sensitivity_steps_in_loop"] == 0
    _same(native, python)


def test_energy_and_momentum_probes_through_a_latch_are_the_python_paths(monkeypatch):
    """Through the latch (its steps from Python) the smooth steps in the loop; the bits and the latch time's
    derivatives the Python path's."""
    native, python = _run(LATCH_ENERGIES, monkeypatch, True), _run(LATCH_ENERGIES, monkeypatch, False)
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert 0.8 * steps < in_loop < steps and [e["kind"] for e in native.summary["events"]] == ["latch"]
    _same(native, python)


def test_the_external_work_keeps_the_python_path(monkeypatch):
    """The external work and the dissipated energy (sums whose sensitivities each step carries) keep every step on
    the Python path."""
    result = _run(SPIN_3D, monkeypatch, True)
    assert result.summary["sensitivity_steps_in_loop"] == 0 and result.summary["time_loop"] == "python"


def test_the_adjoint_with_energy_probes_keeps_the_python_path(monkeypatch):
    """The discrete adjoint's forward pass with an energy or momentum probe takes every step from Python."""
    data = yaml.safe_load(_state_energies(SPIN_3D))
    data["solve"]["sensitivity_method"] = "adjoint"
    with monkeypatch.context():
        result = latdyn.run(latdyn.load_scene(data))
    assert result.summary["sensitivity_steps_in_loop"] == 0 and result.summary["time_loop"] == "python"
