"""A sampled rate loop on a flexible beam's hinge against its exact zero-order-hold discrete-time model.

    python benchmarks/sampled_rate_loop.py [--elements 2] [--kd 0.5] [--t-end 0.5] [--dts 0.002,0.0005,0.000125]

The beam of tests/test_controllers.py's FLEXIBLE scene (2 m, EI 100, rhoA 1, on a hinge about z at a
fixed hub), at rest, driven by a sampled controller ``-kd*om + d`` at 100 Hz (om the hinge rate, d =
0.001 N m a small held torque that starts the motion). The reference is the scene's own linear model
without the controller (``solve.linear_model``: A, B, C with the hinge torque in and the hinge rate
out) discretised exactly with the hold, x_{k+1} = Φ x_k + Γ u_k, Φ = e^{AT}, Γ = ∫₀ᵀ e^{As} ds B (the
matrix exponential of [[A, B], [0, 0]] T), and the sample u_k = −kd C x_k + d: its eigenvalues z
(Φ − kd Γ C) say whether the digital loop is stable (|z| < 1), and its response is what the run must
converge to as dt → 0. Printed: the continuous closed loop's largest real part, the discrete loop's
spectral radius and the frequency of its root, the open-loop mode it comes from, and for each dt the
largest difference of the run's hinge rate at the sample instants from the discrete model's, over
the largest rate (docs/control.md, "The sampled rate loop that diverges").
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
import yaml
from scipy.linalg import expm

import latdyn

SCENE = """
inputs: {{kd: {kd}, d: 0.001}}
{controllers}
sections:
  s: {{EA: 1.0e6, EIy: 100.0, EIz: 100.0, GJ: 80.0, rhoA: 1.0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
beams:
  arm: {{from: hub, to: [2, 0, 0], section: s, elements: {elements},
        start: {{hinge: {{axis: [0, 0, 1], torque: "{torque}"}}}}}}
solve: {solve}
output:
  probes:
    om: {{hinge: arm.start, quantity: rate}}
"""
RATE = 100.0


def run(text: str):
    folder = Path(tempfile.mkdtemp())
    return latdyn.run(latdyn.load_scene(yaml.safe_load(text)), folder), folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--elements", type=int, default=2)
    parser.add_argument("--kd", type=float, default=0.5)
    parser.add_argument("--t-end", type=float, default=0.5)
    parser.add_argument("--dts", default="0.002,0.0005,0.000125")
    args = parser.parse_args()
    T, kd = 1.0 / RATE, args.kd
    _, folder = run(SCENE.format(kd=kd, controllers="", torque="0", elements=args.elements,
                                 solve="{analysis: modes, count: 1, linear_model: {inputs: [arm.start], outputs: [om]}}"))
    with np.load(folder / "linear_model.npz") as model:
        A, B, C = model["A"], model["B"], model["C"]
    n = A.shape[0]
    hold = expm(np.block([[A, B], [np.zeros((1, n + 1))]]) * T)
    Phi, Gamma = hold[:n, :n], hold[:n, n:]
    continuous = np.linalg.eigvals(A - kd * B @ C)
    z = np.linalg.eigvals(Phi - kd * Gamma @ C)
    k = int(np.argmax(np.abs(z)))
    lam = np.linalg.eigvals(A)
    small = np.linalg.eigvals(Phi - 1e-6 * Gamma @ C)
    source = lam[int(np.argmin(np.abs(np.exp(lam * T) - small[int(np.argmax(np.abs(small)))])))]
    print(f"{args.elements} elements, kd = {kd}, sampled at {RATE:g} Hz: continuous closed loop max Re λ = "
          f"{continuous.real.max():+.2e}; discrete loop spectral radius {abs(z[k]):.5f} at "
          f"{abs(np.angle(z[k])) / (2 * np.pi * T):.2f} Hz (as kd → 0 the root of the open-loop mode at "
          f"{abs(source.imag) / (2 * np.pi):.1f} Hz, aliased)")
    steps = int(round(args.t_end * RATE))
    x, reference = np.zeros(n), [0.0]
    for _ in range(steps):
        x = Phi @ x + Gamma[:, 0] * (-kd * (C @ x)[0] + 0.001)
        reference.append((C @ x)[0])
    reference = np.array(reference)
    for dt in (float(s) for s in args.dts.split(",")):
        result, _ = run(SCENE.format(kd=kd, controllers='controllers:\n  ctl: {output: "-kd*om + d", rate: 100}',
                                     torque="ctl", elements=args.elements, solve=f"{{t_end: {args.t_end}, dt: {dt}}}"))
        om = np.interp(np.arange(steps + 1) * T, result.t, result.probes["om"])
        error = np.max(np.abs(om - reference)) / np.max(np.abs(reference))
        print(f"  dt = {dt:g}: run's hinge rate at the samples against the discrete model: {error:.2e} of "
              f"its largest value {np.max(np.abs(reference)):.3e}")


if __name__ == "__main__":
    main()
