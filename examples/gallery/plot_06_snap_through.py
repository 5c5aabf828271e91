"""
Snap-through of a shallow arch, traced with arc length
======================================================

The von Mises truss: two pin-jointed bars (half-span a = 10 m, rise h = 1 m, EA = 1e4 N) loaded
at the apex by P = λ · 20 N downwards. Under load control the path ends at the first limit
point; the arc length (``solve.method: arc-length``) follows it through the snap — the load
factor falls, turns negative, rises again — to λ = 1 on the far, inverted branch. The closed
form: with bars of length L(w) = √(a² + (h − w)²) and axial force N = EA (L − L₀)/L₀, the apex in
equilibrium under P(w) = 2 N (w − h)/L; its limit loads are ±max P(w) = ±3.8109 N.
"""
import json
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import latdyn

SCENE = """\
title: shallow von Mises truss, snap-through
sections:
  bar: {EA: 1.0e4, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}
bodies:
  left: {at: [-10, 0, 0], fixed: true}
  apex: {at: [0, 1, 0]}
  right: {at: [10, 0, 0], fixed: true}
beams:
  a: {from: left, to: apex, section: bar, elements: 1, start: {hinge: {axis: [0, 0, 1]}}}
  b: {from: apex, to: right, section: bar, elements: 1, start: {hinge: {axis: [0, 0, 1]}},
      end: {hinge: {axis: [0, 0, 1]}}}
loads:
  - {at: apex, force: [0, -20.0, 0]}
solve: {analysis: static, method: arc-length, steps: 10, max_steps: 300}
output:
  probes:
    w: {point: apex, quantity: displacement, component: y}
"""
folder = Path(tempfile.mkdtemp())
(folder / "von_mises.yaml").write_text(SCENE)
out = folder / "von_mises_results"
result = latdyn.run(latdyn.load_scene(str(folder / "von_mises.yaml")), out)
summary = json.loads((out / "summary.json").read_text())
w, P = -np.asarray(result.probes["w"]), 20.0 * np.asarray(result.t)   # apex deflection down; load

# %%
# The checks: every point of the path on the closed form, and the two limit points that
# ``summary.json`` reports at ±max P.
a, h, EA = 10.0, 1.0, 1.0e4
L0 = np.hypot(a, h)


def load_of(w):
    L = np.hypot(a, h - w)
    return 2.0 * EA * (L - L0) / L0 * (w - h) / L


P_max = float(np.max(load_of(np.linspace(0.0, h, 200_001))))
path_error = float(np.max(np.abs(P - load_of(w)))) / P_max
maximum, minimum = summary["limit_points"]
print(f"{len(w)} path points, largest distance from the closed form: {path_error:.1e} P_max")
print(f"limit loads: latdyn {20 * maximum['load_factor']:.5f} N and {20 * minimum['load_factor']:.5f} N, "
      f"closed form ±{P_max:.5f} N")
assert path_error < 1e-9 and w[-1] > 2 * h and result.t[-1] == 1.0
assert abs(20 * maximum["load_factor"] / P_max - 1) < 2e-3 and abs(20 * minimum["load_factor"] / P_max + 1) < 2e-3

# %%
# The path: latdyn's points on the closed-form curve, with the limit points.
fig, ax = plt.subplots(figsize=(7, 4.5))
dense = np.linspace(0.0, w[-1], 400)
ax.plot(dense, load_of(dense), "k-", lw=1, label="closed form P(w)")
ax.plot(w, P, "o", ms=4, mfc="none", label="latdyn, arc length")
ax.plot([w[np.argmax(P)]], [P.max()], "rv", label="limit point (maximum)")
ax.plot([w[np.argmin(P)]], [P.min()], "r^", label="limit point (minimum)")
ax.axhline(0.0, color="grey", lw=0.5)
ax.set(xlabel="apex deflection w (m, downwards)", ylabel="apex load P (N)", title="von Mises truss: snap-through")
ax.legend()
fig.tight_layout()
