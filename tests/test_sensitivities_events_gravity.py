"""Sensitivities through events under gravity (latdyn/analyses/transient_sensitivities.py ``_stiffness_derivative``;
docs/parameters.md, "The impulse weight's derivative"): the impulse weighs with the evaluation's K, which leaves the
elements' gravity tangent out (csrc/evaluate.c holds it in the inertia tangent), so the parameters whose (∂K/∂p) w is
differenced along w take the static ∂r/∂p without the elements' gravity load −λ ∂Q/∂p (before, a spurious
−dt² ∂²Q/∂q∂p w entered every such parameter's impulse).

References: Richardson-extrapolated central differences of whole runs at p ± h, p ± h/2 (h = 1e-4 p), each probe over
its rows relative to its largest (the adjoint: its end, max and min), and the event time's, relative. ρ is put on the
difference path by a null load ``force: [0, "0*rho", 0]`` (the same run, ρ no longer by section values alone); the
geometry parameter L (the arm's length) is differenced as any geometry parameter."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_events import LATCH_3D, LATCH_PLANAR, STOP_3D

#: the latching arm with gravity in its plane and its length L a geometry parameter
LATCH_PLANAR_GRAVITY = (LATCH_PLANAR.replace("sections:", "gravity: [0, 9.81, 0]\nsections:", 1)
                        .replace("tip: {at: [1.0, 0, 0]", 'tip: {at: ["L", 0, 0]')
                        .replace("parameters: {", "parameters: {L: 1.0, "))
#: the 3D wheel latching under a skew gravity
LATCH_3D_GRAVITY = LATCH_3D.replace("sections:", "gravity: [1.0, -2.0, -9.81]\nsections:", 1)
#: the 3D wheel thrown back by its stop (restitution 0.5) under a skew gravity, at 1.030 s; it comes back onto the
#: stop at 1.045 s, after the run's end
STOP_3D_GRAVITY = (STOP_3D.replace("sections:", "gravity: [-2.0, 1.0, -1.0]\nsections:", 1)
                   .replace("t_end: 1.07", "t_end: 1.04"))


def _on_the_difference_path(text: str, body: str) -> str:
    """``text`` with a null load naming ρ on ``body``: ρ is then no longer used by section values alone."""
    loaded = text.replace("solve:", f'loads:\n  - {{at: {body}, force: [0, "0*rho", 0]}}\nsolve:', 1)
    assert loaded != text
    return loaded


def _adjoint(text: str) -> str:
    switched = text.replace("analysis: transient,", "analysis: transient, sensitivity_method: adjoint,")
    assert switched != text
    return switched


def _run(text: str, name: str, value: float | None = None):
    data = yaml.safe_load(text)
    data["solve"]["sensitivities"] = [name]
    if value is not None:
        data["parameters"][name] = value
    return latdyn.run(latdyn.load_scene(data))


def _error(text: str, name: str, kinds: list) -> tuple:
    """(the largest probe error, the largest event-time error) of ``name``'s sensitivities against the references
    (module docstring)."""
    result = _run(text, name)
    assert [e["kind"] for e in result.summary["events"]] == kinds
    p0 = float(yaml.safe_load(text)["parameters"][name])
    central, times = [], []
    for step in (1e-4 * p0, 5e-5 * p0):
        up, down = _run(text, name, p0 + step), _run(text, name, p0 - step)
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]] == kinds
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"],
                                                                              down.summary["events"])]))
    adjoint = "sensitivity_method: adjoint" in text
    worst = 0.0
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        scale = np.abs(expected).max()
        if adjoint:
            values, by = result.probes[probe], result.summary["probe_sensitivities"][probe]
            for which, row in (("end", len(values) - 1), ("max", int(np.argmax(values))),
                               ("min", int(np.argmin(values)))):
                worst = max(worst, abs(by[which][name] - expected[row]) / scale)
        else:
            worst = max(worst, float(np.abs(result.sensitivities[(probe, name)] - expected).max() / scale))
    expected_times = (4 * times[1] - times[0]) / 3
    computed_times = np.array([e["dt"][name] for e in result.summary["event_sensitivities"]])
    return worst, float(np.abs(computed_times - expected_times).max() / np.abs(expected_times).max())


@pytest.mark.parametrize("text, name", [
    (LATCH_PLANAR_GRAVITY, "rho"),
    (_on_the_difference_path(LATCH_PLANAR_GRAVITY, "tip"), "rho"),
    (LATCH_PLANAR_GRAVITY, "L"),
], ids=["rho_generated", "rho_differenced", "geometry_L"])
def test_a_planar_latch_under_gravity_agrees_with_richardson_central_differences(text, name):
    """The latching arm under gravity in its plane: ρ by section values alone (generated) 3.7e-9, ρ on the
    difference path 3.7e-9 (4.3e-6 with the elements' gravity load differenced), the geometry parameter L 1.1e-9
    (8.8e-7 before); the latch time's 7.5e-9, 7.5e-9, 2.1e-9 (measured)."""
    probes, event = _error(text, name, ["latch"])
    assert probes <= 1e-7 and event <= 1e-7, (probes, event)


@pytest.mark.parametrize("adjoint", [False, True], ids=["forward", "adjoint"])
def test_a_3d_latch_under_gravity_agrees_with_richardson_central_differences(adjoint):
    """The 3D wheel's latch under a skew gravity, ρ on the difference path: forward 6.5e-9, adjoint 5.2e-9 (both
    8.0e-6 with the elements' gravity load differenced); the latch time's 8.1e-9 (measured)."""
    text = _on_the_difference_path(LATCH_3D_GRAVITY, "wheel")
    probes, event = _error(_adjoint(text) if adjoint else text, "rho", ["latch"])
    assert probes <= 1e-7 and event <= 1e-7, (probes, event)


@pytest.mark.parametrize("adjoint", [False, True], ids=["forward", "adjoint"])
def test_a_3d_stop_under_gravity_agrees_with_richardson_central_differences(adjoint):
    """The 3D wheel thrown back by its stop under a skew gravity, ρ on the difference path: forward 6.5e-7, adjoint
    2.7e-7 (both 7.7e-6 with the elements' gravity load differenced); the stop time's 4.8e-7 (measured). ρ moves
    this run little: the references' own error is near 1e-6 here (6.6e-7 and 7.0e-7 forward at h four times larger
    and smaller; 1.5e-6 at h/30, round-off)."""
    text = _on_the_difference_path(STOP_3D_GRAVITY, "wheel")
    probes, event = _error(_adjoint(text) if adjoint else text, "rho", ["stop"])
    assert probes <= 1e-6 and event <= 1e-6, (probes, event)


def test_the_cli_writes_the_event_sensitivities_under_gravity_as_the_api(tmp_path):
    """``python -m latdyn run`` of the planar latch under gravity, ρ on the difference path: summary.json's
    ``event_sensitivities`` and ``probe_sensitivities`` as the API's."""
    text = _on_the_difference_path(LATCH_PLANAR_GRAVITY, "tip")
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert summary["event_sensitivities"] == api.summary["event_sensitivities"]
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]


def _gimbal_under_gravity(text: str) -> str:
    """tests/test_sensitivities_rigid_links.py's gimbal under gravity, ρ also the boom's mass per length."""
    heavy = (text.replace("initial_velocity:", "gravity: [0, 0, -9.81]\ninitial_velocity:", 1)
             .replace("rhoA: 0.4,", 'rhoA: "0.5*rho",'))
    assert heavy.count("rho") > text.count("rho") and "gravity" in heavy
    return heavy


@pytest.mark.parametrize("which, kinds", [("LATCH", ["latch"]), ("STOP", ["stop"] * 3)], ids=["latch", "stop"])
def test_a_gimbal_of_rigid_links_latching_or_bouncing_under_gravity_agrees_with_richardson(which, kinds):
    """Rigid links (the reduction's weight differenced along δq and its geometric term): the gimbal's inner ring
    latching, and bouncing three times off its stop, under gravity, ρ the rings' and the boom's mass: latch 7.3e-9,
    stop 1.1e-8 (8.9e-7 and 5.9e-6 with the elements' gravity load differenced); the event times' 1.1e-9, 5.2e-9
    (3.7e-6 before, the stop's) (measured)."""
    from tests import test_sensitivities_rigid_links as links

    probes, event = _error(_gimbal_under_gravity(getattr(links, which)), "rho", kinds)
    assert probes <= 1e-7 and event <= 1e-7, (probes, event)
