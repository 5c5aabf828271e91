"""
A hinged truss deploys and latches
==================================

``examples/deploying_truss.yaml``: three bays of a truss stowed as a zig-zag open on preloaded
hinge springs; each hinge latches (``lock_at``) when its bay is in line with the one before. The
exact end state is known: every knee locked at its latch angle (π/3, 2π/3, 2π/3 from the stowed
zig-zag) and the truss straight along x, its tip station at x = 3 m, z = 0 (three bays of 1 m),
about which it then vibrates.
"""
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import latdyn
from latdyn.results.structure import plot_structure

path = Path("examples/deploying_truss.yaml")
scene = latdyn.load_scene(path if path.exists() else Path("../deploying_truss.yaml"))
out = Path(tempfile.mkdtemp()) / "truss"
result = latdyn.run(scene, out)
t = np.asarray(result.t)

# %%
# The checks: each knee reaches its latch angle (the step is shortened to land on it, to within
# the event location's tolerance) and then holds it rigidly (constant to round-off), and the
# tip station's mean position over the last second, once every knee is latched, is the straight
# truss's to 1 % of its length (it still vibrates: the peak-to-peak is printed).
latch = {"knee1": np.pi / 3, "knee2": 2 * np.pi / 3, "knee3": 2 * np.pi / 3}
for knee, angle in latch.items():
    history = np.abs(np.asarray(result.probes[knee]))
    first = int(np.flatnonzero(history >= angle - 1e-4)[0])
    held = float(np.max(np.abs(history[first:] - history[first])))
    got = history[-1]
    print(f"{knee}: latched at t = {t[first]:.4f} s at {got:.9f} rad (latch angle {angle:.9f} rad, "
          f"error {abs(got - angle):.1e}); it moves by {held:.1e} rad after")
    assert abs(got - angle) < 1e-5 and held < 1e-10
last = t > t[-1] - 1.0
tip_x, tip_z = np.asarray(result.probes["tip_x"])[last], np.asarray(result.probes["tip_z"])[last]
x, z = tip_x.mean(), tip_z.mean()
print(f"tip station, mean over the last 1 s: x = {x:.4f} m (straight: 3), z = {z:.4f} m (straight: 0); "
      f"z peak-to-peak {np.ptp(tip_z):.4f} m")
assert abs(x - 3.0) < 0.03 and abs(z) < 0.03

# %%
# The knee angles and the structure as it unfolds.
fig, ax = plt.subplots(figsize=(8, 3.5))
for knee, angle in latch.items():
    line, = ax.plot(t, np.abs(result.probes[knee]), label=f"latdyn: {knee} angle")
    ax.axhline(angle, color=line.get_color(), ls=":", lw=1)
ax.set(xlabel="time t (s)", ylabel="|hinge angle| (rad)", title="Knee angles; dotted: latch angles (lock_at)")
ax.legend()
fig.tight_layout()

picture = plot_structure(out, out / "structure.png")
fig, ax = plt.subplots(figsize=(8, 5))
ax.imshow(plt.imread(picture))
ax.set_axis_off()
