"""``inputs: {NAME: number}`` (SCENE.md, "Added with the issues of 2026-11-26"): named signals that
any expression may use, held in ``latdyn run``, set from outside with ``scene.inputs.set``.

References are exact: a rigid link driven by a constant hinge torque u (θ = u t² / 2I), a free
body under load components u and w·t (y = u t²/2m, z = w t³/6m: genuinely 3D), a hinge spring of
stiffness k_in (the period 2π√(I/k) of its modes, and the response u/k (1 − cos ωt))."""
from __future__ import annotations

import math

import numpy as np
import pytest

import latdyn
from cli_runs import latdyn_run, probe_columns

#: a rigid link of mass m at its far end (I = m L² about the hinge), driven by torque u about z
LINK = """
inputs: {{u: 2.0, k_in: 8.0}}
sections:
  s: {{EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [0.5, 0, 0], mass: 4.0}}
beams:
  arm:
    from: hub
    to: tip
    section: s
    rigid: true
    start: {{hinge: {{axis: [0, 0, 1], {law}}}}}
solve: {solve}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
"""
INERTIA = 4.0 * 0.5 ** 2  # m L² = 1


def link(law: str = 'torque: "u"', solve: str = "{t_end: 1.0, dt: 0.01}") -> str:
    return LINK.format(law=law, solve=solve)


def test_hinge_torque_names_an_input_cli(tmp_path):
    """θ(t) = u t² / 2I under the constant torque u = 2 (generalized-α is exact for it)."""
    completed, out = latdyn_run(tmp_path, link())
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    exact = 2.0 * p["t"] ** 2 / (2 * INERTIA)
    assert np.max(np.abs(p["th"] - exact)) < 1e-9


def test_load_components_name_inputs_3d_api():
    """A free body (mass 2) pushed by [1, u, w·t]: x = t²/2m, y = u t²/2m, z = w t³/6m (3D: every
    axis moves). Generalized-α is exact for the constant forces; under the ramp its error is
    O(h²) (measured 1.7e-6 of 0.125 at h = 0.005)."""
    scene = latdyn.load_scene({
        "inputs": {"u": 3.0, "w": -1.5},
        "bodies": {"b": {"at": [0.0, 0.0, 0.0], "mass": 2.0, "inertia": [1.0, 1.0, 1.0]}},
        "loads": [{"at": "b", "force": [1, "u", "w*t"]}],
        "solve": {"t_end": 1.0, "dt": 0.005},
        "output": {"probes": {name: {"point": "b", "quantity": "displacement", "component": name}
                              for name in "xyz"}},
    })
    result = latdyn.run(scene)
    t = np.asarray(result.t)
    assert np.max(np.abs(result.probes["x"] - t ** 2 / 4.0)) < 1e-9
    assert np.max(np.abs(result.probes["y"] - 3.0 * t ** 2 / 4.0)) < 1e-9
    assert np.max(np.abs(result.probes["z"] - (-1.5) * t ** 3 / 12.0)) < 2.5e-6


def test_inputs_set_from_outside_reach_the_compiled_laws():
    """The laws read the scene's input array itself: the same scene run again after
    ``scene.inputs.set`` (its laws already compiled in this process) follows the new value."""
    scene = latdyn.load_scene(__import__("yaml").safe_load(link()))
    first = latdyn.run(scene)
    scene.inputs.set("u", -6.0)
    assert scene.inputs["u"] == -6.0 and scene.inputs.current() == {"u": -6.0, "k_in": 8.0}
    second = latdyn.run(scene)
    t = np.asarray(second.t)
    assert np.max(np.abs(np.asarray(first.probes["th"]) - 2.0 * t ** 2 / 2)) < 1e-9
    assert np.max(np.abs(np.asarray(second.probes["th"]) + 6.0 * t ** 2 / 2)) < 1e-9
    scene.inputs.reset()
    assert scene.inputs["u"] == 2.0
    with pytest.raises(KeyError, match="unknown input 'v'.*u, k_in"):
        scene.inputs.set("v", 1.0)
    with pytest.raises(ValueError, match="input 'u': expected a finite number"):
        scene.inputs.set("u", float("nan"))


def test_hinge_law_names_an_input(tmp_path):
    """A spring of stiffness k_in and torque u: θ = u/k (1 − cos ωt), ω = √(k/I); its modes the
    frequency ω/2π, through the hinge law's exact derivative."""
    law = 'stiffness: "k_in", torque: "u"'
    completed, out = latdyn_run(tmp_path, link(law, "{t_end: 1.0, dt: 0.004, rho_inf: 1.0}"))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    omega = math.sqrt(8.0 / INERTIA)
    exact = 2.0 / 8.0 * (1 - np.cos(omega * p["t"]))
    assert np.max(np.abs(p["th"] - exact)) < 1e-5  # measured 4.9e-6 of 0.5 at dt = 0.004
    modes = latdyn.run(latdyn.load_scene(__import__("yaml").safe_load(
        link(law, "{analysis: modes, count: 1}"))))
    assert abs(modes.modes[0] - omega / (2 * math.pi)) < 1e-9 * omega


@pytest.mark.parametrize("inputs, key, says", [
    ("{t: 1}", "inputs.t", "word of the expression language"),
    ("{theta: 1}", "inputs.theta", "word of the expression language"),
    ("{sin: 1}", "inputs.sin", "word of the expression language"),
    ("{u: fast}", "inputs.u", "expected a number"),
    ("{u: \"2*t\"}", "inputs.u", "expected a number"),
    ("[u]", "inputs", "expected a mapping of input names"),
])
def test_refused_inputs(tmp_path, inputs, key, says):
    from latdyn.errors import SceneError

    text = link().replace("inputs: {u: 2.0, k_in: 8.0}", f"inputs: {inputs}")
    if key == "inputs.t":  # through the CLI once: exit 2, the key, no traceback
        completed, _ = latdyn_run(tmp_path, text)
        assert completed.returncode == 2
        assert key in completed.stderr and says in completed.stderr, completed.stderr
        assert "Traceback" not in completed.stderr
    with pytest.raises(SceneError) as refused:
        latdyn.load_scene(__import__("yaml").safe_load(text))
    assert key in str(refused.value) and says in str(refused.value)


def test_probe_named_like_an_input_is_refused(tmp_path):
    completed, _ = latdyn_run(tmp_path, link().replace("th: {hinge", "u: {hinge"))
    assert completed.returncode == 2
    assert "output.probes.u" in completed.stderr and "share one namespace" in completed.stderr


def test_unknown_name_is_still_refused_with_inputs(tmp_path):
    completed, _ = latdyn_run(tmp_path, link('torque: "v"'))
    assert completed.returncode == 2
    assert "beams.arm.start.hinge.torque" in completed.stderr and "'v'" in completed.stderr
