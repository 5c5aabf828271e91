"""Issue 34: the discrete adjoint's geometry parameters beside rigid links, guides and controllers, and beside a hinge
resting on its rigid stop (docs/parameters.md, "Geometry parameters by the adjoint").

On 5a68b93 the adjoint refused geometry parameters beside rigid links or guides and beside controllers reading points,
cables or joint forces or driving loads (SceneError naming solve.sensitivity_method, exit 2: ``adjoint_refusal``), and
beside a hinge coming to rest on its rigid stop (SolverError, exit 1, naming the stop's ``limits``). Every test here
fails there (checked by running this file on 5a68b93: each scene refused).

What the forward method takes beside links and guides it takes on the reduction (latdyn/analyses/
geometry_sensitivities.py): the start's move on the minimum coordinates, the reduced K_0 and C_0, ∂r/∂p reduced (the
held dependent nodes' moves, the shifts on parts that turn) and the probes' moves with the shifts; the adjoint's start
(``_start_moved_transposed``) and Eᵀw (``residual_transposed_product``, the reduced ∂r/∂p transposed onto w) are those
maps transposed, and a controller's ∂f/∂s ∂s/∂X comes with ∂r/∂p. Here the adjoint's derivatives (every probe's end,
max and min, every event time's) are the forward method's, relative to each output's largest derivative: measured (load
10 on 2 cores, the runs' numbers do not depend on it) the gimbal whose first hinge point moves 6.4e-12, the cart on a
rail whose guide origin moves 1.7e-11, the inner ring's hinge point on the turning outer ring 3.5e-12, the outer ring
moved (the link's length and direction, its inertia with them) 4.5e-12, the gimbal's
latch beside its moved base 1.3e-11, the knee's PD reading its moved point 2.2e-12, the gimbal's PD reading the outer
ring's height 1.2e-11; the loop of steps on and off to the bit.

A rest beside a geometry parameter: the released boom of tests/test_sensitivities_hinge_on_stop.py (RELEASE: 13 rattles
on its stop, released for good at 1.26 s) by the tip's z differs from the forward method by 4.3e-9 on the end angle,
whose derivative is small (0.009: 4.7e-7 of it, 3.7e-7 of the largest by all six parameters). That is round-off both
methods carry, not a term left out: at t = 0 ∂r/∂X of the stiff boom (EA 1e8, 6.5e7 on the free coordinates) and the
moved start's K δq cancel to 17 (on the hinge's row 1.16e7 to 5.9), and perturbing each entry of the forward method's
∂r/∂X by a relative 1.1e-16 (three draws) moves its own end angle's derivative by 8.3e-10, 2.8e-9 and −2.1e-10 and the
tip's and mid node's by up to 1.1e-9 (the adjoint's gap there: 1.2e-9, 1.1e-9). The smooth boom (no stop) shows the
same: one step's derivatives by z 9e-9 relative apart (by ρ 1e-12). So these scenes are checked against the forward
method within 3e-9 where the cancellation leaves that — BOOM by z and k 1.4e-9, all of it the landing time's derivative
by z (0.354050377, 4.8e-10 apart: its free flight's round-off; the outputs 1e-13), REBOUND 2.7e-10 — and RELEASE
against Richardson-extrapolated central differences of whole runs."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run
from tests.test_adjoint_events import _disagreement
from tests.test_geometry_sensitivities_link_geometry import GIMBAL_HINGE_POINT, INNER_POINT, RAIL
from tests.test_geometry_sensitivities_link_length import RING
from tests.test_geometry_sensitivities_links import GIMBAL_PD, LATCH_PLACED, PD_KNEE
from tests.test_sensitivities_hinge_on_stop import BOOM, REBOUND, RELEASE

#: the 3D scenes beside rigid links, guides and controllers, each by its geometry parameter X and one other
LINKED = {"gimbal-hinge-point": GIMBAL_HINGE_POINT, "cart-rail-origin": RAIL, "inner-ring-point": INNER_POINT,
          "ring-offset-link-length": RING, "gimbal-latch": LATCH_PLACED, "pd-reading-a-moved-point": PD_KNEE, "gimbal-pd-ring-height": GIMBAL_PD}
#: how the adjoint's derivatives may differ from the forward method's beside links, guides and controllers
BOUND = 1e-10
#: ... beside a rest on a stiff boom: the cancellation of ∂r/∂X with K δq (module docstring)
REST_BOUND = 3e-9


def _adjoint(text: str) -> str:
    switched = text.replace("solve: {analysis: transient,", "solve: {analysis: transient, sensitivity_method: adjoint,")
    assert yaml.safe_load(switched)["solve"]["sensitivity_method"] == "adjoint"
    return switched


def _api(text: str, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    return latdyn.run(latdyn.load_scene(data))


def _by_zt(text: str) -> str:
    """``text`` (a boom of tests/test_sensitivities_hinge_on_stop.py) by the tip's z and the spring k alone."""
    return text.replace("sensitivities: [k, c, P, m, rho, zt]", "sensitivities: [k, zt]")


@pytest.fixture(scope="module")
def runs():
    return {}


def _both(runs, text: str) -> tuple:
    """(forward, adjoint) of ``text`` through the API, run once per module."""
    if text not in runs:
        runs[text] = (_api(text), _api(_adjoint(text)))
    return runs[text]


@pytest.mark.parametrize("name", list(LINKED))
def test_the_adjoint_equals_the_forward_method_beside_links_guides_and_controllers(runs, name):
    """Each probe's end, max and min and each event's time (the gimbal's latch): within BOUND of the forward method's,
    by X and by the other parameter; X's derivatives not all zero."""
    forward, adjoint = _both(runs, LINKED[name])
    assert adjoint.summary["events"] == forward.summary["events"]
    assert _disagreement(forward.summary, adjoint.summary, events=False) <= BOUND
    assert any(by["X"] != 0.0 for which in adjoint.summary["probe_sensitivities"].values() for by in which.values())


def test_the_cli_equals_the_api_on_the_gimbal_whose_hinge_point_moves(runs, tmp_path):
    """``python -m latdyn run`` of the gimbal with the adjoint: exit 0 (2 on 5a68b93), summary.json's probe sensitivities
    ``latdyn.run``'s to the bit."""
    completed, out = latdyn_run(tmp_path, _adjoint(GIMBAL_HINGE_POINT), quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["probe_sensitivities"] == _both(runs, GIMBAL_HINGE_POINT)[1].summary["probe_sensitivities"]


@pytest.mark.parametrize("name", ["BOOM", "REBOUND"])
def test_the_adjoint_equals_the_forward_method_through_a_rest_by_a_geometry_parameter(runs, name):
    """The boom resting on its stop (three rattles) and put back twice by the projection, by the tip's z and k: within
    REST_BOUND of the forward method's (the landing time's too); both runs end on the stop."""
    forward, adjoint = _both(runs, _by_zt({"BOOM": BOOM, "REBOUND": REBOUND}[name]))
    assert adjoint.probes["angle"][-1] == forward.probes["angle"][-1] == 0.6
    assert _disagreement(forward.summary, adjoint.summary) <= REST_BOUND


def test_the_released_boom_by_a_geometry_parameter_agrees_with_richardson(runs):
    """RELEASE by the tip's z: the adjoint's end derivatives and the stop's time's against Richardson-extrapolated
    central differences of whole runs (zt ± 1e-4, ± 5e-5, the runs keeping their sensitivities so that their steps land
    on the stop as the differentiated run's), within 1e-6 of each probe's largest derivative over the rows (the forward
    method's test's measure, tests/test_sensitivities_events.py ``_agree``). Measured: the end angle 8.6e-9 (3.5e-9 on
    0.0090213613), the tip's height 1.4e-9, the mid node's 4.3e-9, the stop time 1.3e-9 relative; the forward method's
    2.0e-9, 3.1e-10, 1.6e-9 and 4.0e-10 (both within one rounding's spread of ∂r/∂X: module docstring)."""
    text = _by_zt(RELEASE)
    adjoint = _both(runs, text)[1]
    assert [e["kind"] for e in adjoint.summary["events"]] == ["stop"]
    central, times = [], []
    for step in (1e-4, 5e-5):
        up, down = _api(text, zt=1.0 + step), _api(text, zt=1.0 - step)
        central.append({p: (up.probes[p] - down.probes[p]) / (2 * step) for p in up.probes})
        times.append((up.summary["events"][0]["t"] - down.summary["events"][0]["t"]) / (2 * step))
    for probe, end in adjoint.summary["probe_sensitivities"].items():
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        assert abs(end["end"]["zt"] - expected[-1]) <= 1e-6 * np.abs(expected).max(), probe
    expected_time = (4 * times[1] - times[0]) / 3
    assert adjoint.summary["event_sensitivities"][0]["dt"]["zt"] == pytest.approx(expected_time, rel=1e-6, abs=1e-9)



@pytest.mark.parametrize("name", ["gimbal-hinge-point", "cart-rail-origin"])
def test_the_loop_of_steps_on_and_off_gives_the_same_adjoint(monkeypatch, name):
    """Beside the rigid link and the guide, by X: the forward pass's steps stored by the loop of steps (30 and 60 of
    them) and the reverse pass's native steps give the Python path's derivatives to the bit."""
    from tests.test_adjoint_in_loop import _run as _run_switched

    text = _adjoint(LINKED[name])
    native, python = _run_switched(text, monkeypatch, True), _run_switched(text, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == native.native_reverse == native.summary["steps"]
    assert python.summary["sensitivity_steps_in_loop"] == 0 and python.native_reverse == 0
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
