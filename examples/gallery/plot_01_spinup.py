"""
Spin-up of a flexible beam
==========================

The benchmark of Kane, Ryan & Banerjee (1987): a hub turns a 10 m beam (EI = 1.4e4 N·m²,
ρA = 1.2 kg/m) from rest to Ω = 6 rad/s in 15 s along a smooth law, then holds the rate.
``examples/spinup.yaml`` is the scene. The tip lags behind the hub while it speeds up and,
once the rate is constant, oscillates about its steady deflection at the frequency of the first
chordwise mode of the spinning beam, seen in the frame that turns with the hub: 4.5125 rad/s
(benchmarks/references/benchmarks.json, D1, ``reference_derived``), a period of 1.3924 s.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import latdyn
from latdyn.results.structure import plot_structure

scene = Path("examples/spinup.yaml") if Path("examples/spinup.yaml").exists() else Path("../spinup.yaml")
out = Path(tempfile.mkdtemp()) / "spinup"
result = latdyn.run(latdyn.load_scene(scene), out)
t, tip = np.asarray(result.t), np.asarray(result.probes["tip_v"])

# %%
# The check: the period of the tip's oscillation once the rate is constant (t > 15 s), from the
# upward crossings of its mean.
after = t > 15.5
y = tip[after] - tip[after].mean()
i = np.where((y[:-1] < 0) & (y[1:] >= 0))[0]
up = t[after][i] - y[i] * (t[after][i + 1] - t[after][i]) / (y[i + 1] - y[i])
period = float(np.mean(np.diff(up)))
reference = 2 * np.pi / 4.5125464
error = abs(period - reference) / reference
print(f"period at 6 rad/s: latdyn {period:.5f} s, reference {reference:.5f} s, relative error {error:.2e}")
assert error < 1e-2

# %%
# The tip's deflection in the hub frame, and the structure at six times (drawn by
# ``latdyn plot``'s :func:`latdyn.results.structure.plot_structure`).
fig, ax = plt.subplots(figsize=(8, 3.5))
ax.plot(t, 1e3 * tip, label="latdyn: tip deflection in the hub frame")
ax.axvline(15.0, color="grey", ls=":", label="end of the spin-up (Ω = 6 rad/s)")
ax.set(xlabel="time t (s)", ylabel="tip deflection (mm)", title="Spin-up: tip lag behind the hub")
ax.legend()
fig.tight_layout()

picture = plot_structure(out, out / "structure.png")
fig, ax = plt.subplots(figsize=(8, 5))
ax.imshow(plt.imread(picture))
ax.set_axis_off()
