"""A controller designed on latdyn's linear model and checked in the nonlinear run (issue 33;
docs/stepping.md, "A worked example"). Needs python-control (``pip install control``).

For an arm on a hub hinge (rigid, then flexible: 4 elements), ``solve.linear_model`` gives A, B,
C, D from the hub torque to the hub angle and rate; python-control places a PD u = kp (ref − θ) −
kd θ̇ for a rigid-body pole pair at ω = 3 rad/s, ζ = 0.7 (J read off the model), gives the closed
loop's eigenvalues, continuous and sampled at 100 Hz with a zero-order hold (``control.c2d``), and
the sampled loop's response to a 0.5 rad slew; latdyn.Simulation then runs the same PD from Python
at 100 Hz on the nonlinear model. Run: ``python examples/pd_slew_design.py [OUT]``."""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import control
import numpy as np

import latdyn

ARM = """\
title: arm on a hub hinge
inputs: {u: 0.0}
sections:
  arm: {EA: 1.0e7, EIy: 40.0, EIz: 40.0, GJ: 30.0, rhoA: 1.0}
bodies:
  hub: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: hub, to: [1.0, 0, 0], section: arm, KIND, start: {hinge: {axis: [0, 0, 1], torque: u}}}
solve: SOLVE
output:
  every: 0.01
  probes:
    angle: {hinge: arm.start, quantity: angle}
    rate: {hinge: arm.start, quantity: rate}
"""
SLEW, T = 0.5, 0.01  # rad, s
OMEGA, ZETA = 3.0, 0.7


def design(out: Path, kind: str) -> dict:
    """The PD designed on the linear model of the arm (``kind``: ``rigid: true`` or ``elements: 4``),
    and the nonlinear slew stepped from Python against the sampled loop's linear prediction."""
    name = kind.split(":")[0]
    linear = out / f"{name}.yaml"
    linear.write_text(ARM.replace("KIND", kind).replace(
        "SOLVE", "{t_end: 0.01, dt: 0.01, linear_model: {inputs: [arm.start], outputs: [angle, rate]}}"))
    latdyn.run(str(linear), out_dir=out / f"{name}_linear")
    model = np.load(out / f"{name}_linear" / "linear_model.npz")
    plant = control.ss(model["A"], model["B"], model["C"], model["D"])
    s = 1e-4j  # the rate's response to the torque is 1/(J s) at low frequency
    inertia = float(np.real(1.0 / (s * np.asarray(plant(s))[1, 0])))
    kp, kd = inertia * OMEGA ** 2, 2 * ZETA * OMEGA * inertia
    gain = np.array([[kp, kd]])
    continuous = control.feedback(plant, gain)  # u = r − K y
    sampled = control.feedback(control.c2d(plant, T, "zoh"), gain)
    t = np.arange(0, 4.0 + 1e-9, T)
    slew = control.ss(sampled.A, sampled.B[:, :1] * kp * SLEW, sampled.C[:1], 0, T)  # r = kp·ref
    _, predicted = control.forced_response(slew, t, np.ones_like(t))
    stepped = out / f"{name}_stepped.yaml"
    stepped.write_text(ARM.replace("KIND", kind).replace("SOLVE", "{t_end: 4.0, dt: 0.002}"))
    sim = latdyn.Simulation(str(stepped), out_dir=out / f"{name}_stepped")
    report = {"J": inertia, "kp": kp, "kd": kd,
              "continuous loop: largest real part": float(np.max(continuous.poles().real)),
              "sampled loop: largest |eigenvalue|": float(np.max(np.abs(sampled.poles())))}
    try:
        while sim.t < sim.t_end - 1e-9:
            y = sim.probes()
            sim.set_input("u", kp * (SLEW - y["angle"]) - kd * y["rate"])
            sim.advance_to(min(sim.t + T, sim.t_end))
    except latdyn.SolverError as failure:
        report["nonlinear run"] = f"ended at t = {sim.t:.3g}: {str(failure).splitlines()[0][:90]}"
    result = sim.close()
    angle = np.asarray(result.probes["angle"])
    if len(angle) == len(predicted):
        report["nonlinear vs linear sampled loop, max |angle diff| (rad)"] = float(np.max(np.abs(angle - predicted)))
        report["overshoot (rad)"] = float(angle.max() - SLEW)
    return report


if __name__ == "__main__":
    folder = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="pd_slew_"))
    folder.mkdir(parents=True, exist_ok=True)
    for kind in ("rigid: true", "elements: 4"):
        print(kind)
        for key, value in design(folder, kind).items():
            print(f"  {key}: {value}")
