"""
A space-crane manoeuvre
=======================

A two-link crane arm carries a 20 kg payload: the shoulder (a hub) slews through 90° while the
elbow, a hinge whose angle is prescribed (``angle:``), unfolds the folded arm straight, both in
T = 6 s along the same rest-to-rest law with zero jerk at both ends. The links are flexible (each
2 m, EI = 20 000 N·m², ρA = 2 kg/m); the elbow joint has no mass.

The reference: once the manoeuvre ends, the arm is a straight 4 m cantilever with a tip mass M
(the prescribed hinge holds its angle: it is rigid), and the payload vibrates at the first
frequency of that system, the root β of 1 + cos β cosh β + (M/m) β (cos β sinh β − sin β cosh β) = 0
(m = ρA ℓ the arm's mass), ω = β² √(EI/(ρA ℓ⁴)). The payload's mean position over the last
periods is the rigid arm's end: (4, 0) m in the shoulder's frame.
"""
import math
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from scipy.optimize import brentq

import latdyn
from latdyn.results.structure import plot_structure

L, EI, rhoA, M, T = 2.0, 2.0e4, 2.0, 20.0, 6.0


def rest_to_rest(Theta):
    """θ(t) from 0 to Θ in T with zero rate, acceleration and jerk at both ends (an expression in t)."""
    A = Theta * 2 * math.pi * 4 / (3 * T ** 2)
    return (f"Piecewise(({A * T / (2 * math.pi)!r}*(3/4*t - {T / (2 * math.pi)!r}*sin(2*pi*t/{T}) "
            f"+ {T / (16 * math.pi)!r}*sin(4*pi*t/{T})), t < {T}), ({Theta!r}, True))")


SCENE = f"""\
title: space crane, slew and unfold
sections:
  link: {{EA: 1.0e8, EIy: {EI}, EIz: {EI}, GJ: 1.0e4, rhoA: {rhoA}}}
bodies:
  shoulder:
    at: [0, 0, 0]
    motion: {{rotation: {{axis: [0, 0, 1], angle: "{rest_to_rest(math.pi / 2)}"}}}}
  elbow: {{at: [{L}, 0, 0]}}
  payload: {{at: [{L}, {L}, 0], mass: {M}}}
beams:
  upper: {{from: shoulder, to: elbow, section: link, elements: 4}}
  fore:
    from: elbow
    to: payload
    section: link
    elements: 4
    start: {{hinge: {{axis: [0, 0, 1], angle: "{rest_to_rest(-math.pi / 2)}"}}}}
solve: {{t_end: 10.0, dt: 0.01}}
output:
  every: 0.01
  paraview_every: 0.5
  probes:
    x: {{point: payload, quantity: position, frame: shoulder, component: x}}
    y: {{point: payload, quantity: position, frame: shoulder, component: y}}
"""
folder = Path(tempfile.mkdtemp())
(folder / "space_crane.yaml").write_text(SCENE)
out = folder / "space_crane_results"
result = latdyn.run(latdyn.load_scene(str(folder / "space_crane.yaml")), out)
t, x, y = (np.asarray(v) for v in (result.t, result.probes["x"], result.probes["y"]))

# %%
# The checks: the period of the payload's vibration after the manoeuvre, and its mean position.
length, ratio = 2 * L, M / (rhoA * 2 * L)
beta = brentq(lambda b: 1 + math.cos(b) * math.cosh(b) + ratio * b * (math.cos(b) * math.sinh(b)
                                                                      - math.sin(b) * math.cosh(b)), 0.1, 1.8)
reference = 2 * math.pi / (beta ** 2 * math.sqrt(EI / (rhoA * length ** 4)))
after = t > T + 0.5
ya = y[after] - y[after].mean()
i = np.where((ya[:-1] < 0) & (ya[1:] >= 0))[0]
up = t[after][i] - ya[i] * (t[after][i + 1] - t[after][i]) / (ya[i + 1] - ya[i])
period = float(np.mean(np.diff(up)))
error = abs(period - reference) / reference
print(f"period after the manoeuvre: latdyn {period:.5f} s, cantilever with tip mass {reference:.5f} s "
      f"(β = {beta:.6f}), relative error {error:.2e}")
assert error < 5e-3
print(f"payload mean position: ({x[after].mean():.5f}, {y[after].mean():.5f}) m, rigid arm (4, 0) m; "
      f"vibration amplitude {1e3 * np.max(np.abs(ya)):.2f} mm")
assert abs(x[after].mean() - 4.0) < 1e-3 and abs(y[after].mean()) < 1e-3

# %%
# The payload's path in the shoulder frame, and the crane at several times.
fig, ax = plt.subplots(figsize=(8, 3.5))
ax.plot(t, x, label="latdyn: payload x (shoulder frame)")
ax.plot(t, y, label="latdyn: payload y (shoulder frame)")
ax.axvline(T, color="grey", ls=":", label="end of the manoeuvre")
ax.set(xlabel="time t (s)", ylabel="payload position (m)", title="Space crane: the payload in the shoulder frame")
ax.legend()
fig.tight_layout()

picture = plot_structure(out, out / "structure.png")
fig, ax = plt.subplots(figsize=(8, 5))
ax.imshow(plt.imread(picture))
ax.set_axis_off()
