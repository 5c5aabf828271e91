"""A compliant stop's law (its stiffness, exponent and Hunt–Crossley damping) as parameters of 3D transient runs,
against Richardson-extrapolated central differences of whole runs (issue 34): what limits the reference.

Two helpers saw the stops' damping 1.8e-5 off (tests/test_sensitivities_in_loop_states_more.py's TORQUE_STOPS) and
the boom's stop 2e-6 off by its stiffness and exponent, 7.3e-5 by its damping
(tests/test_weight_derivative_parameters2.py's STOP_BOOM), on 10be92c too. Neither is the derivative's error:

- STOP_BOOM (the spar pressed on its stop from its onset to the end, through the wheel's latch) is off by Newton's
  tolerance. The sensitivities are the derivative at the state Newton stopped at (``solve.tol``, 1e-8; the probes
  2.5e-10 off the converged run's), and they move with it: by 1.9e-6 of their largest between tol 1e-8 and 1e-13
  (1.5e-4 at tol 1e-6, 1.1e-8 at 1e-10, 5e-10 at 1e-12), by kc 2.1e-6, and by kc with the exponent 1.2, 2 or 3
  0.9e-6, 2.6e-6, 3.7e-6 (so not the law's δⁿ⁻² at the onset); the boom without the stop by its spring k 2.8e-7.
  The stop's law moves the run little (the sensitivities are 1e-3 of the probes), so the same state error is a
  larger part of them. The differences of whole runs hardly move with the tolerance (1.1e-7). With
  ``tol: 1.0e-12`` in the scene the agreement is 1.9e-8 (exponent), 2.8e-8 (stiffness), 1.5e-7 (damping, at 1e-2 of
  its value), the latch time's derivative 3e-10.
- TORQUE_STOPS' damping moves the run by 1e-6 of its probes: a perturbation of 1e-4 of the value moves the probes
  by 1e-11 of themselves, where the runs' round-off is, so the differences' error falls as 1/h (1.8e-5, 2.3e-6,
  1.8e-7 at 1e-4, 1e-3, 1e-2 of the value) to 4.4e-8 at 1e-1, the same with ``tol: 1.0e-12``.

No term of the derivative was found wrong: the rows against Richardson from the onset on show no jump,
the error grows with the steps in contact and falls with the tolerance (docs/parameters.md, "Compliant stops").

Beside them, the discrete adjoint against the forward method on the latching boom whose PD reads points, a point's
velocity or a cable's length: 1e-10 to 4e-10 apart at 10be92c, within 4.2e-11 now (the last test's docstring says
why)."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of
from tests.test_adjoint_events import _adjoint, _disagreement
from tests.test_sensitivities_in_loop_states_more import TORQUE_STOPS
from tests.test_weight_derivative_couplings import LENGTH, POINTS, VELOCITY
from tests.test_weight_derivative_parameters2 import STOP_BOOM

#: STOP_BOOM with Newton converged to 1e-12 (the run and the differences' runs)
TIGHT_BOOM = STOP_BOOM.replace("dt: 0.01,", "dt: 0.01, tol: 1.0e-12,")
#: TORQUE_STOPS by its stops' damping alone
ARM_DAMPING = TORQUE_STOPS.replace("sensitivities: [kc, cc, Kt, F]", "sensitivities: [cc]")
assert "tol: 1.0e-12" in TIGHT_BOOM and "sensitivities: [kc, nc, cc]" in TIGHT_BOOM and "[cc]" in ARM_DAMPING


def _run(text: str, name: str, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    data["solve"]["sensitivities"] = [name]
    return latdyn.run(latdyn.load_scene(data))


def _richardson(text: str, name: str, relative: float) -> tuple[dict, np.ndarray]:
    """({probe: Richardson-extrapolated central difference of whole runs by ``name``}, the events' times' likewise),
    steps h and h/2, h = ``relative`` of the value."""
    value = yaml.safe_load(text)["parameters"][name]
    h = relative * abs(value)
    central, times = [], []
    for step in (h, h / 2):
        up, down = _run(text, name, **{name: value + step}), _run(text, name, **{name: value - step})
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]]
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"],
                                                                              down.summary["events"])]))
    return ({k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}, (4 * times[1] - times[0]) / 3)


def _worst(sensitivities: dict, expected: dict) -> float:
    """The largest difference over the rows and probes, relative to each probe's largest."""
    return max(float(np.abs(sensitivities[k] - e).max() / np.abs(e).max()) for k, e in expected.items())


@pytest.fixture(scope="module")
def tight_boom():
    return latdyn.run(latdyn.load_scene(yaml.safe_load(TIGHT_BOOM)))


@pytest.mark.parametrize("name, relative, tolerance", [("nc", 1e-3, 1e-7), ("kc", 1e-3, 1e-7), ("cc", 1e-2, 5e-7)],
                         ids=["exponent", "stiffness", "damping"])
def test_converged_tightly_the_booms_stop_agrees_with_richardson_differences(tight_boom, name, relative, tolerance):
    """The boom's spar pressed on its compliant stop through the wheel's latch, Newton to 1e-12: every row of every
    probe by the stop's exponent, stiffness and damping (measured 1.9e-8, 2.8e-8, 1.5e-7) and the latch time's
    derivative (3e-10) agree with Richardson differences of whole runs."""
    assert [e["kind"] for e in tight_boom.summary["events"]] == ["latch"]
    expected, times = _richardson(TIGHT_BOOM, name, relative)
    by_name = {k: tight_boom.sensitivities[(k, name)] for k in expected}
    assert _worst(by_name, expected) <= tolerance
    computed = [event["dt"][name] for event in tight_boom.summary["event_sensitivities"]]
    assert computed == pytest.approx(times, rel=1e-8)


def test_at_the_default_tolerance_newtons_error_moves_the_sensitivities_not_the_differences():
    """The same boom at the default ``solve.tol`` (1e-8) by the exponent. Its sensitivities are off the differences of
    whole runs by 1.7e-6 at perturbations of 1e-4 and 1e-3 of the value alike (not the differences' truncation or
    round-off): they are the derivative at the state Newton stopped at, 2.5e-10 off the converged one, and move by
    1.9e-6 of their largest between Newton to 1e-8 and to 1e-12. The differences of the default runs agree with the
    tightly converged sensitivities (measured 1.3e-7)."""
    loose, tight = _run(STOP_BOOM, "nc"), _run(TIGHT_BOOM, "nc")
    of = lambda result: {k: result.sensitivities[(k, "nc")] for k in result.probes}  # noqa: E731
    differences = [_richardson(STOP_BOOM, "nc", h)[0] for h in (1e-4, 1e-3)]
    errors = [_worst(of(loose), expected) for expected in differences]
    assert all(5e-7 < error < 5e-6 for error in errors), errors
    assert _worst(of(tight), differences[1]) < 5e-7
    assert 5e-7 < _worst(of(loose), of(tight)) < 5e-6
    assert max(float(np.abs(loose.probes[k] - tight.probes[k]).max()) for k in loose.probes) < 1e-9


def test_latdyn_run_of_the_arms_stop_damping_agrees_with_richardson_differences(tmp_path):
    """``latdyn run`` of the 3D arm whose skew hinge a controller of its torque drives onto its compliant stops, by
    the stops' damping: sensitivities.csv against Richardson differences of whole runs (API) at 1e-1 of the value
    (measured 4.4e-8). The damping moves the probes by 1e-6 of themselves, so the differences need the large
    perturbation (at 1e-4 their round-off gives 1.8e-5)."""
    completed, out = latdyn_run(tmp_path, ARM_DAMPING)
    assert completed.returncode == 0, completed.stderr
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.DictReader(f))
    expected, _ = _richardson(ARM_DAMPING, "cc", 1e-1)
    from_file = {k: np.array([float(r[f"{k}/cc"]) for r in rows]) for k in expected}
    assert _worst(from_file, expected) <= 2e-7
    assert summary_of(out)["probe_sensitivities"]["hinge"]["end"]["cc"] == pytest.approx(from_file["hinge"][-1],
                                                                                          rel=1e-12)


@pytest.mark.parametrize("text", [POINTS, VELOCITY, LENGTH], ids=["points", "a point's velocity", "a cable's length"])
def test_the_adjoint_equals_the_forward_method_beside_controllers_reading_points(text):
    """tests/test_weight_derivative_couplings.py's latching 3D boom whose PD reads points, a point's velocity at an
    offset, a three-element cable's length: the discrete adjoint's end, max and min values and latch time derivatives
    are the forward method's within 1e-10 of each output's largest (measured 2.0e-11, 4.2e-11, 5.0e-12). At 10be92c
    they were 3.9e-10, 1.2e-10, 2.4e-10 apart: the impulse weight's derivative along the rates was a central
    difference of the whole K w, the elements' stiff block (which does not move with the rates) among it, taken along
    δv by the forward method and along each unit rate by the adjoint, whose round-off differed (with only the blocks
    that move with the rates differenced, 10be92c's gaps were 8.4e-11, 4.2e-11, 5.0e-12); rateweight's generated
    rates' part and ``rates_rest_product`` (those blocks alone) closed it."""
    forward = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(_adjoint(text))))
    assert [e["kind"] for e in adjoint.summary["events"]] == ["latch"]
    assert _disagreement(forward.summary, adjoint.summary) <= 1e-10
