"""The discrete adjoint's native passes on models a designer meets (latdyn/analyses/adjoint_in_loop.py; issue 34, item
6): beside continuous controllers without states the forward pass's smooth steps stored by the loop of steps and the
reverse pass's smooth steps in one native call each (``adjoint_in_loop.refusal``: controllers with states and
sampled ones keep the per-step path), and on models with rigid links or guides the contraction (∂r/∂p)ᵀw with the
reduced ∂r/∂p the forward method's loop forms, left by the native reverse step (csrc/sensitivity_loop.c
``parameter_columns``, ``ReverseSteps.residual_transposed_product``) — the derivatives the per-step Python and NumPy
path's (the private switches ``ADJOINT_IN_LOOP`` and ``REVERSE_NATIVE`` off) to the bit, and the forward method's to
1e-10 of each output's largest. The scenes are benchmarks/adjoint_designer_cost.py's."""
from __future__ import annotations

import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, latdyn_run_switched, summary_of
from tests.test_adjoint_in_loop import _run
from tests.test_adjoint_in_loop_links import _adjoint, _largest_gap

#: a gimbal: the outer ring on a skew hinge driven by a PD of its angle and rate, the inner ring a rigid link
#: latching at −0.1 rad (t = 0.268 s), a flexible boom with a tip body beyond
GIMBAL_PD = """
title: a gimbal, the outer hinge under a PD, the inner ring latching, a flexible boom
parameters: {k1: 6.0, k2: 4.0, c2: 0.05, m: 0.3, P: 0.4, EI: 20.0, rest: 0.6, rho: 0.8, Kp: 1.5, Kd: 0.2}
sections:
  ring: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: "rho", rhoIy: "0.001*rho", rhoIz: 0.001}
  boom: {EA: 1.0e5, EIy: "EI", EIz: "1.2*EI", GJ: "0.7*EI", rhoA: 0.4, rhoIy: 0.0004, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  outer: {at: [0.3, 0.1, 0.2], mass: "m", inertia: [0.002, 0.003, 0.0025]}
  inner: {at: [0.45, -0.05, 0.35], mass: 0.2, inertia: [0.001, 0.0012, 0.0015]}
  tip: {at: [1.0, 0.25, 0.55], mass: 0.1, inertia: [0.0002, 0.0002, 0.0002]}
beams:
  gim1: {from: base, to: outer, section: ring, rigid: true,
         start: {hinge: {axis: [0.2, 0.3, 1.0], stiffness: "k1", rest_angle: "rest", torque: "pd"}}}
  gim2: {from: outer, to: inner, section: ring, rigid: true,
         start: {hinge: {axis: [1.0, -0.4, 0.3], stiffness: "k2", damping: "c2", lock_at: -0.1}}}
  boom: {from: inner, to: tip, section: boom, elements: 3}
loads:
  - {at: tip, force: [0, "P", "-0.5*P"]}
controllers:
  pd: {output: "-Kp*(a1 - 0.2) - Kd*r1"}
initial_velocity: {angular: [0.5, -0.3, 2.0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.4, sensitivities: [k1, k2, c2, m, P, EI, rest, rho, Kp, Kd]}
output:
  probes:
    tip_z: {point: tip, quantity: displacement, component: z}
    a2: {hinge: gim2.start, quantity: angle}
    a1: {hinge: gim1.start, quantity: angle}
    r1: {hinge: gim1.start, quantity: rate}
"""

#: a deploying truss bay: two rigid bays swung open by their hinges' preloaded springs, the first latching in line
#: (t = 0.274 s), a flexible boom beyond them and a flexible strut off the first bay's end (out of the bays' plane)
TRUSS_BAY = """
title: a deploying truss bay of rigid links latching in line, a flexible boom and a strut beyond
parameters: {k: 1.5, c: 0.02, m: 0.1, EI: 30.0, EIs: 20.0, F: 0.2, Fy: 0.1, ms: 0.05, GJ: 20.0, rhoA: 0.3}
sections:
  bay: {EA: 1.0e7, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 0.5, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
  boom: {EA: 1.0e6, EIy: "EI", EIz: "1.1*EI", GJ: "GJ", rhoA: "rhoA", rhoIy: 1.0e-4, rhoIz: 1.0e-4}
  strut: {EA: 1.0e6, EIy: "EIs", EIz: "EIs", GJ: 15.0, rhoA: 0.2, rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  root: {at: [0, 0, 0], fixed: true}
  s1: {at: [0.25, 0, 0.433013], mass: "m", inertia: [0.001, 0.001, 0.001]}
  s2: {at: [0.5, 0, 0], mass: 0.1, inertia: [0.001, 0.001, 0.001]}
  tip: {at: [1.0, 0.1, 0], mass: 0.05, inertia: [0.0005, 0.0005, 0.0005]}
  end: {at: [0.25, 0.4, 0.433013], mass: "ms", inertia: [0.0005, 0.0005, 0.0005]}
beams:
  bay1: {from: root, to: s1, section: bay, rigid: true,
         start: {hinge: {axis: [0, 1, 0], stiffness: "k", damping: "c", rest_angle: pi/3 + 0.3, lock_at: pi/3}}}
  bay2: {from: s1, to: s2, section: bay, rigid: true,
         start: {hinge: {axis: [0, -1, 0], stiffness: "k", rest_angle: 2*pi/3 + 0.3}}}
  boom: {from: s2, to: tip, section: boom, elements: 3}
  strut: {from: s1, to: end, section: strut, elements: 2}
loads:
  - {at: tip, force: [0, "Fy", "-F"]}
solve: {analysis: transient, t_end: 0.4, dt: 0.005, sensitivities: [k, c, m, EI, EIs, F, Fy, ms, GJ, rhoA]}
output:
  probes:
    tip_z: {point: tip, quantity: position, component: z}
    knee1: {hinge: bay1.start, quantity: angle}
"""

#: a cart on a skew ground guide (spring, damper), a flexible mast clamped on it with a tip body, pushed sideways
CART_MAST = """
title: a cart on a skew guide carrying a flexible mast with a tip body
parameters: {k: 30.0, c: 0.4, m: 1.0, mt: 0.2, EI: 8.0, GJ: 6.0, rhoA: 0.4, P: 1.5, Q: 0.3, rest: 0.01}
gravity: [0, 0, -9.81]
sections:
  mast: {EA: 1.0e6, EIy: "EI", EIz: "1.2*EI", GJ: "GJ", rhoA: "rhoA", rhoIy: 1.0e-4, rhoIz: 1.0e-4}
bodies:
  cart: {at: [0, 0, 0], mass: "m", inertia: [0.01, 0.01, 0.01],
         guide: {axis: [1, 0.3, 0], stiffness: "k", damping: "c", rest: "rest"}}
  top: {at: [0.1, -0.05, 0.8], mass: "mt", inertia: [0.001, 0.001, 0.001]}
beams:
  mast: {from: cart, to: top, section: mast, elements: 4}
loads:
  - {at: cart, force: ["P", 0, 0]}
  - {at: top, force: [0, "Q", 0]}
solve: {analysis: transient, t_end: 0.4, dt: 0.005, sensitivities: [k, c, m, mt, EI, GJ, rhoA, P, Q, rest]}
output:
  probes:
    slide: {guide: cart, quantity: position}
    top_y: {point: top, quantity: displacement, component: y}
"""


#: the cart bouncing off its guide's stop (e = 0.8, t = 0.29 s) under loads of t: after the stop the reverse steps at
#: stored states off the time grid read the laws' values at their own times
CART_STOP_LOADS_IN_T = CART_MAST.replace(
    'rest: "rest"}', 'rest: "rest", limits: [-0.02, 0.012], restitution: 0.8}').replace(
    'force: ["P", 0, 0]', 'force: ["P*(1 + sin(20*t))", 0, "0.3*Q*t"]').replace("t_end: 0.4", "t_end: 0.3")
assert CART_STOP_LOADS_IN_T.count("sin(20*t)") == 1 and "limits" in CART_STOP_LOADS_IN_T


def test_the_cli_takes_the_gimbal_under_a_pd_natively_and_writes_the_python_paths_files(tmp_path):
    """The gimbal whose outer hinge a PD drives, to just after its latch: ``latdyn run`` stores its smooth steps in the
    loop of steps (on the base every step came from Python: controllers) and writes the per-step path's
    sensitivities.csv and probes.csv byte for byte and its summary.json derivatives (probes' end, max, min; the latch's
    time) to the bit."""
    completed, out = latdyn_run(tmp_path, _adjoint(GIMBAL_PD.replace("t_end: 0.4", "t_end: 0.3")), quiet=True)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] >= 29
    assert [event["kind"] for event in summary["events"]] == ["latch"]
    reference = tmp_path / "python"
    run = latdyn_run_switched(tmp_path, tmp_path / "scene.yaml", reference, "import latdyn.analyses.adjoint_in_loop "
                              "as loop; loop.ADJOINT_IN_LOOP = False; loop.REVERSE_NATIVE = False")
    assert run.returncode == 0, run.stderr
    assert summary_of(reference)["sensitivity_steps_in_loop"] == 0
    for name in ("sensitivities.csv", "probes.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name
    for key in ("probe_sensitivities", "event_sensitivities"):
        assert summary[key] == summary_of(reference)[key], key


@pytest.mark.parametrize("text", [GIMBAL_PD, TRUSS_BAY, CART_MAST, CART_STOP_LOADS_IN_T],
                         ids=["gimbal, PD", "truss bay", "cart, mast", "cart, stop, loads of t"])
def test_the_reverse_steps_contract_the_loops_parameter_columns(text, monkeypatch):
    """Each native reverse step contracts w with the reduced ∂r/∂p it left (the Python contraction,
    ``AdjointSensitivities.residual_transposed_product``, only at the steps from Python: those of the events and after
    them; on the base it was called at every step), the derivatives are the per-step path's to the bit and the
    forward method's to 1e-10 of each output's largest (measured ≤ 3.0e-11: the truss bay by k)."""
    from latdyn.analyses.adjoint_sensitivities import AdjointSensitivities

    contracted = []
    original = AdjointSensitivities.residual_transposed_product

    def counted(self, *args, **kwargs):
        contracted.append(args[0].t)
        return original(self, *args, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(AdjointSensitivities, "residual_transposed_product", counted)
        native = _run(_adjoint(text), monkeypatch, True)
    from_python = len(contracted)
    python = _run(_adjoint(text), monkeypatch, False)
    steps = native.summary["steps"]
    # the steps from Python, the start's (AdjointSensitivities._through_the_start) and each event's pieces
    assert native.native_reverse >= steps - 2 and from_python <= 1 + steps - native.native_reverse + len(
        native.summary["events"]) * 6, (native.native_reverse, from_python)
    for key in ("probe_sensitivities", "event_sensitivities"):
        assert native.summary.get(key) == python.summary.get(key), key
    forward = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert _largest_gap(native.summary["probe_sensitivities"], forward.summary["probe_sensitivities"]) <= 1e-10
