"""
A slewing antenna
=================

A hub turns a 3 m boom carrying an antenna dish (a rigid body of 5 kg, 2 kg·m² about the slew
axis) through 90° in T = 8 s and stops. The slew law is rest to rest with zero jerk at both ends,
θ(t) = A T/(2π) [¾ t − (T/2π) sin(2πt/T) + (T/16π) sin(4πt/T)], whose angular acceleration
α(t) = A [sin(2πt/T) − ½ sin(4πt/T)] is slow against the boom's first mode (about 20 rad/s).

The reference: while the slew is slow, the boom bends quasi-statically under its own and the
dish's inertia. In the frame that turns with the hub a cantilever (EI, length L, mass per length
ρA) carries the distributed load −ρA α x, the tip force −m α L and the tip moment −J α, so the dish
lags by v(t) = −α(t) [11 ρA L⁵/(120 EI) + m L⁴/(3 EI) + J L²/(2 EI)]. The dynamic part is of order
(2π/T)²/ω₁² ≈ 0.2 % of it.
"""
import math
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import latdyn
from latdyn.results.structure import plot_structure

L, EI, rhoA, m, J = 3.0, 2.0e4, 1.0, 5.0, 2.0
T, Theta = 8.0, math.pi / 2
A = Theta * 2 * math.pi * 4 / (3 * T ** 2)      # so that θ(T) = Θ
angle = (f"Piecewise(({A * T / (2 * math.pi)!r}*(3/4*t - {T / (2 * math.pi)!r}*sin(2*pi*t/{T}) "
         f"+ {T / (16 * math.pi)!r}*sin(4*pi*t/{T})), t < {T}), ({Theta!r}, True))")
SCENE = f"""\
title: slewing antenna
sections:
  boom: {{EA: 1.0e8, EIy: {EI}, EIz: {EI}, GJ: 1.0e4, rhoA: {rhoA}}}
bodies:
  hub:
    at: [0, 0, 0]
    motion: {{rotation: {{axis: [0, 0, 1], angle: "{angle}"}}}}
  dish: {{at: [{L}, 0, 0], mass: {m}, inertia: [1.0, 1.0, {J}]}}
beams:
  boom: {{from: hub, to: dish, section: boom, elements: 6}}
solve: {{t_end: 10.0, dt: 0.01}}
output:
  every: 0.02
  paraview_every: 1.0
  probes:
    lag: {{point: dish, quantity: position, frame: hub, component: y}}
    slew: {{point: dish, quantity: position, component: y}}
"""
folder = Path(tempfile.mkdtemp())
(folder / "slewing_antenna.yaml").write_text(SCENE)
out = folder / "slewing_antenna_results"
result = latdyn.run(latdyn.load_scene(str(folder / "slewing_antenna.yaml")), out)
t, lag = np.asarray(result.t), np.asarray(result.probes["lag"])

# %%
# The check: the dish's lag in the hub frame against the quasi-static cantilever over the slew.
alpha = np.where(t < T, A * (np.sin(2 * np.pi * t / T) - 0.5 * np.sin(4 * np.pi * t / T)), 0.0)
compliance = 11 * rhoA * L ** 5 / (120 * EI) + m * L ** 4 / (3 * EI) + J * L ** 2 / (2 * EI)
quasi_static = -alpha * compliance
during = t < T
error = float(np.max(np.abs(lag - quasi_static)[during]) / np.max(np.abs(quasi_static)))
peak = float(lag[np.argmax(np.abs(lag))])
print(f"peak lag: latdyn {1e3 * peak:.4f} mm, quasi-static {1e3 * quasi_static[np.argmax(np.abs(quasi_static))]:.4f} mm; "
      f"largest difference over the slew {error:.2e} of the peak")
assert error < 0.01
print(f"after the stop the dish vibrates with amplitude {1e6 * np.max(np.abs(lag[t > T])):.3f} µm")

# %%
# The lag, and the boom as it slews.
fig, ax = plt.subplots(figsize=(8, 3.5))
ax.plot(t, 1e3 * lag, label="latdyn: dish position in the hub frame, y")
ax.plot(t[during], 1e3 * quasi_static[during], "k--", label="quasi-static cantilever (closed form)")
ax.axvline(T, color="grey", ls=":", label="end of the slew")
ax.set(xlabel="time t (s)", ylabel="lag of the dish (mm)", title="Slewing antenna: lag of the dish")
ax.legend()
fig.tight_layout()

picture = plot_structure(out, out / "structure.png")
fig, ax = plt.subplots(figsize=(8, 5))
ax.imshow(plt.imread(picture))
ax.set_axis_off()
