"""What holds a coordinate (Model.check_held): inertia, or stiffness of either sign.

Defect (found by the senslinkedctl helper, 2026-11-28): a negative stiffness (a destabilising controller, a guide's
spring of negative rate) was refused before the run as "a coordinate that nothing holds", because the check took
xᵀ(M̂ + K̂)x = 0 for "unheld", which only follows from Mx = 0 and Kx = 0 when K is positive semi-definite: a slide of
mass m on a spring −k normalises to M̂ = 1, K̂ = −1, and their sum is 0. The runs below were all refused (exit 2)
before the change; the true refusals (neither mass nor stiffness) still are, with their key and message."""
from __future__ import annotations

import numpy as np
import pytest

import latdyn
from cli_runs import latdyn_run
from latdyn.errors import SceneError
from tests.test_sensitivities_rigid_links import CLOSED_SLIDER_CRANK


def run_text(tmp_path, text: str, name: str = "scene.yaml"):
    """A scene typed as YAML, through the API (``latdyn.load_scene`` of the file, ``latdyn.run``)."""
    path = tmp_path / name
    path.write_text(text)
    return latdyn.run(latdyn.load_scene(str(path)))


#: the slider-crank closed by a rigid rod (one coordinate, the crank's angle), its torque a controller on the slider's
#: place with the destabilising sign (a negative stiffness on the only coordinate, which the mass holds)
DESTABILISED_SLIDER_CRANK = (CLOSED_SLIDER_CRANK.replace('torque: "tau"}}}', 'torque: "ctl"}}}')
                             .replace("solve: {", 'controllers:\n  ctl: {output: "tau - 0.01*(sx - 0.35)"}\nsolve: {')
                             .replace(", sensitivities: [tau, m]", ""))
assert '"ctl"}}}' in DESTABILISED_SLIDER_CRANK and "sensitivities" not in DESTABILISED_SLIDER_CRANK

#: a slide of 2 kg on a spring of rate −8 (a guide's force law 8 s; the scene's stiffness is a number ≥ 0), s'' = 4 s, thrown at 0.1 m/s: s = 0.05 sinh(2t)
UNSTABLE_SLIDE = """
title: a slide on a spring of negative rate, thrown along its guide
bodies:
  m: {at: [0, 0, 0], mass: 2, guide: {axis: [0, 3, 4], force: "8*s"}}
initial_velocity: {linear: [0, 0.06, 0.08]}
solve: {t_end: 1.0, dt: 0.001}
output:
  every: 0.1
  probes:
    s: {guide: m, quantity: position}
"""

#: a massless slide driven by a controller on its place with the destabilising sign under F = sin t (a negative
#: stiffness, which alone holds it; a guide's own force law is a load, which holds nothing, and is refused as before):
#: the guide's force 8 s + sin t is 0, s = −sin(t)/8
MASSLESS_UNSTABLE_SLIDE = """
bodies:
  m: {at: [1, 0, 0], guide: {axis: [1, 0, 0], force: "ctl"}}
controllers:
  ctl: {output: "8*s + sin(t)"}
solve: {t_end: 0.5, dt: 0.05}
output:
  probes:
    s: {guide: m, quantity: position}
"""


def test_a_destabilising_controller_on_the_closed_slider_crank_runs(tmp_path):
    """The CLI and the API run it (exit 0) and agree with the same run with the stable sign to the controller's
    size: 0.01 N m/m on a slide that moves by ~0.05 m over 0.22 s."""
    completed, out = latdyn_run(tmp_path, DESTABILISED_SLIDER_CRANK)
    assert completed.returncode == 0, completed.stderr
    assert "nothing holds" not in completed.stderr
    result = run_text(tmp_path, DESTABILISED_SLIDER_CRANK, "api.yaml")
    stable = run_text(tmp_path, DESTABILISED_SLIDER_CRANK.replace("tau - 0.01", "tau + 0.01"), "stable.yaml")
    assert np.all(np.isfinite(result.probes["sx"])) and len(result.t) == len(stable.t)
    difference = np.abs(result.probes["crank"] - stable.probes["crank"]).max()
    assert 0.0 < difference < 1e-3 * np.abs(stable.probes["crank"]).max()


def test_a_negative_spring_holds_a_slide_with_or_without_mass(tmp_path):
    """Exact references: s = 0.05 sinh(2t) with mass 2 on −8 (started at 0.1 m/s along the guide); s = −sin(t)/8
    for the massless slide, which only the negative spring holds."""
    result = run_text(tmp_path, UNSTABLE_SLIDE)
    exact = 0.05 * np.sinh(2.0 * result.t)
    assert np.abs(result.probes["s"] - exact).max() < 1e-5 * np.abs(exact).max()
    completed, _ = latdyn_run(tmp_path, MASSLESS_UNSTABLE_SLIDE)
    assert completed.returncode == 0, completed.stderr
    result = run_text(tmp_path, MASSLESS_UNSTABLE_SLIDE, "massless.yaml")
    np.testing.assert_allclose(result.probes["s"], -np.sin(result.t) / 8.0, atol=1e-12)


def test_a_coordinate_that_nothing_holds_is_still_refused_beside_a_negative_stiffness(tmp_path):
    """Neither mass nor spring on one slide, a negative spring on another: exit 2, the unheld guide named, no
    traceback; a massless cart that carries a slider of mass only along one direction still refused by its name
    with a negative spring on the slider (a direction that is not a coordinate axis of the check)."""
    completed, _ = latdyn_run(tmp_path, "bodies:\n  a: {at: [0, 0, 0], mass: 2, guide: {axis: [0, 1, 0], force: \"8*s\"}}\n"
                                        "  b: {at: [1, 0, 0], guide: {axis: [1, 0, 0]}}\n"
                                        "solve: {t_end: 0.1, dt: 0.01}\n")
    assert completed.returncode == 2 and "Traceback" not in completed.stderr
    assert "scene.yaml: bodies.b.guide: a coordinate that nothing holds (neither inertia nor stiffness): guide b" \
        in completed.stderr
    with pytest.raises(SceneError, match=r"scene.yaml: bodies.cart: a coordinate that nothing holds"):
        run_text(tmp_path, """
bodies:
  cart: {at: [0, 0, 0]}
  slider: {at: [0, 1, 0], mass: 2, guide: {on: cart, axis: [0, 1, 0], force: "5*s"}}
solve: {t_end: 0.1, dt: 0.01}
""")


def test_the_sign_blind_decision_refuses_an_oblique_unheld_direction_beside_a_negative_stiffness():
    """The matrices alone (Model.check_held's second decision, on M̂ + |K̂|): the first coordinate has mass 1 and
    stiffness −1 (their normalised sum is 0: refused before the change), the other two a spring between them and no
    mass, so x = (0, 1, 1) is in both null spaces, on no coordinate axis: refused, naming both; with a mass on the
    third coordinate (a free-floating pair, held by inertia) it is held."""
    from types import SimpleNamespace

    from latdyn.assembly.factorization import Factorization
    from latdyn.model.model import Model

    names = np.array(["a", "b", "c"])
    model = SimpleNamespace(n_dofs=3, dof_names=lambda: names, _key_of=lambda name: f"bodies.{name}")
    model._refuse_empty = lambda d, n, f: Model._refuse_empty(model, d, n, f)
    K = np.array([[-1.0, 0.0, 0.0], [0.0, 1.0, -1.0], [0.0, -1.0, 1.0]])
    with pytest.raises(SceneError, match=r"f.yaml: bodies.[bc]: a coordinate that nothing holds .*: [bc], [bc]$"):
        Model.check_held(model, np.diag([1.0, 0.0, 0.0]), K, "f.yaml", Factorization)
    Model.check_held(model, np.diag([1.0, 0.0, 0.5]), K, "f.yaml", Factorization)
