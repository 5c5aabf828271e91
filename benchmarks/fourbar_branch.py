"""D5 four-bar: why rocker − crank reaches 2π after the first collinear position.

    python benchmarks/fourbar_branch.py           # full study (a few minutes), figure
    python benchmarks/fourbar_branch.py --quick   # the 12 s run and the forced-parallelogram run only

Writes docs/verification/d5_fourbar_branch.png; docs/verification.md, section "D5 four-bar:
the 2π after the collinear position", quotes the numbers printed here.

The linkage of examples/benchmarks/D5_fourbar.yaml: ground AD = coupler BC = 0.24, crank AB =
rocker DC = 0.12, so s + l = p + q (Grashof's equality case: a change-point linkage).  With
φ1 the crank angle and φ3 the rocker angle (both hinge angles about z, zero at t = 0, when
both links point along +y), loop closure |C − B| = |AD| is

    sin((φ1 − φ3)/2) · [a sin((φ1 − φ3)/2) + d cos((φ1 + φ3)/2)] = 0,

two branches: the parallelogram φ3 = φ1, and the antiparallelogram (crossed) one
a sin((φ1 − φ3)/2) + d cos((φ1 + φ3)/2) = 0.  They meet where both links lie on the ground
line, φ1 = φ3 = π/2 + kπ (t = 2.618 s, 7.854 s at 0.6 rad/s): there the relation φ3(φ1) is
not single-valued.  The relative rotation of the misaligned hinge at C is φ_C = −φ1 on the
parallelogram branch and φ1 − π on the crossed one.
"""
from __future__ import annotations

import copy
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
warnings.filterwarnings("ignore", category=RuntimeWarning)
import latdyn  # noqa: E402

SCENE = ROOT / "examples" / "benchmarks" / "D5_fourbar.yaml"
FIGURE = ROOT / "docs" / "verification" / "d5_fourbar_branch.png"
A_LEN, D_LEN = 0.12, 0.24  # crank = rocker; coupler = ground
OMEGA = 0.6  # crank rate of the scene
T_DEAD = (math.pi / 2 / OMEGA, 3 * math.pi / 2 / OMEGA)  # the two collinear (change) points


# ----------------------------------------------------------------------------- rigid kinematics
def parallelogram_residual(f1, f3):
    """Zero on the parallelogram branch φ3 = φ1 (mod 2π)."""
    return np.sin((np.asarray(f1) - f3) / 2)


def antiparallelogram_residual(f1, f3):
    """Zero on the crossed branch; scaled like the parallelogram residual (divided by a)."""
    f1, f3 = np.asarray(f1), np.asarray(f3)
    return (A_LEN * np.sin((f1 - f3) / 2) + D_LEN * np.cos((f1 + f3) / 2)) / A_LEN


def antiparallelogram_rocker(f1):
    """φ3 on the crossed branch, continuous for φ1 in [π/2, 3π/2] and equal to φ1 at both ends.

    With v = φ1/2 and d = 2a the branch condition gives tan(φ3/2) = (sin v + 2 cos v)/(cos v + 2 sin v).
    """
    v = np.asarray(f1) / 2
    r = D_LEN / A_LEN
    x = np.arctan2(np.sin(v) + r * np.cos(v), np.cos(v) + r * np.sin(v))
    return 2 * x


def loop_gap(f1, f3):
    """|C − B| − |AD| for rigid links at angles φ1, φ3.

    B = a(−sin φ1, cos φ1), C = D + a(−sin φ3, cos φ3).
    """
    f1, f3 = np.asarray(f1), np.asarray(f3)
    bx, by = -A_LEN * np.sin(f1), A_LEN * np.cos(f1)
    cx, cy = D_LEN - A_LEN * np.sin(f3), A_LEN * np.cos(f3)
    return np.hypot(cx - bx, cy - by) - D_LEN


def misfit_angle(phi_c, delta=math.radians(5.0)):
    """Angle of R_z(φ)ᵀ R_n(φ): how far a hinge tilted by δ from z, turned by φ, is from turning about z.

    cos(ψ/2) = 1 − 2 sin²(φ/2) sin²(δ/2): ψ grows with |φ| from 0 to 2δ at |φ| = π; √2 δ at π/2.
    """
    c = 1 - 2 * np.sin(np.asarray(phi_c) / 2) ** 2 * math.sin(delta / 2) ** 2
    return 2 * np.arccos(np.clip(c, -1, 1))


def branch(f1, f3, ratio=10.0):
    """'P' (parallelogram), 'A' (antiparallelogram) or '?' (near a change point, both residuals small)."""
    rp, ra = np.abs(parallelogram_residual(f1, f3)), np.abs(antiparallelogram_residual(f1, f3))
    return np.where(ratio * rp < ra, "P", np.where(ratio * ra < rp, "A", "?"))


def geometric_angles(p):
    """Crank and rocker angles from the point probes (chords AB and DC), unwrapped."""
    crank = np.unwrap(np.arctan2(-p["Bx"], p["By"]))
    rocker = np.unwrap(np.arctan2(-(p["Cx"] - D_LEN), p["Cy"]))
    return crank, rocker


def turning_points(t, y):
    """Times and values of the local extrema of y (parabola through three samples)."""
    t, y = np.asarray(t), np.asarray(y)
    dy = np.diff(y)
    out = []
    for i in np.where(dy[:-1] * dy[1:] < 0)[0] + 1:
        y0, y1, y2 = y[i - 1], y[i], y[i + 1]
        h = t[i + 1] - t[i]
        den = y0 - 2 * y1 + y2
        s = 0.5 * (y0 - y2) / den if den != 0 else 0.0
        out.append((t[i] + s * h, y1 - 0.25 * (y0 - y2) * s))
    return out


# ----------------------------------------------------------------------------- runs
def scene(dt=0.004, elements=4, t_end=12.0, every=0.02, method=None, rho_inf=None, tilt_axis=None,
          rocker_angle=None) -> dict:
    """The D5 scene with overrides; energies split into kinetic and strain."""
    s = yaml.safe_load(SCENE.read_text())
    for b in ("bar1", "bar2", "bar3"):
        s["beams"][b]["elements"] = elements
    s["solve"].update(dt=dt, t_end=t_end)
    if method:
        s["solve"]["method"] = method
    if rho_inf is not None:
        s["solve"]["rho_inf"] = rho_inf
    if tilt_axis is not None:
        s["beams"]["bar2"]["end"]["hinge"]["axis"] = [float(c) for c in tilt_axis]
    if rocker_angle is not None:  # prescribe the rocker: forces a branch
        s["beams"]["bar3"]["end"]["hinge"]["angle"] = rocker_angle
    s["output"]["every"] = every
    s["output"]["probes"]["kinetic"] = {"energy": "kinetic"}
    s["output"]["probes"]["strain"] = {"energy": "strain"}
    return s


def run_case(label="baseline", **overrides) -> dict:
    s = scene(**overrides)
    t0 = time.perf_counter()
    r = latdyn.run(copy.deepcopy(s), out_dir=None)
    wall = time.perf_counter() - t0
    t = np.asarray(r.t)
    p = {k: np.asarray(v) for k, v in r.probes.items()}
    return {"label": label, "t": t, "p": p, "summary": dict(r.summary), "wall_s": wall, "scene": s}


def analyse(case: dict) -> dict:
    """The numbers of the explanation, for one run."""
    t, p = case["t"], case["p"]
    f1, f3 = p["crank"], p["rocker"]
    g1, g3 = geometric_angles(p)
    br = branch(f1, f3)
    tp = turning_points(t, f3)
    out = {
        "label": case["label"],
        "wall_s": case["wall_s"],
        "t_end": float(t[-1]),
        "rocker_minus_crank_end": float(f3[-1] - f1[-1]),
        "rocker_turning_points": [(round(float(a), 4), round(float(b), 4)) for a, b in tp],
        "max_hinge_minus_chord_crank": float(np.max(np.abs(g1 - f1))),
        "max_hinge_minus_chord_rocker": float(np.max(np.abs(g3 - f3))),
        "max_abs_hinge_C": float(np.max(np.abs(p["hinge_C"]))),
        "max_strain": float(np.max(p["strain"])),
        "t_max_strain_first_half": float(t[np.argmax(np.where(t < 5.2, p["strain"], -1))]),
        "max_kinetic": float(np.max(p["kinetic"])),
        "energy_balance_error": case["summary"].get("energy_balance_error"),
        "rejected_steps": case["summary"].get("rejected_steps"),
        "newton_per_step": case["summary"].get("newton_iterations_per_step"),
        "branches": _segments(t, br),
    }
    crossed = (t > T_DEAD[0] + 0.3) & (t < min(T_DEAD[1] - 0.3, t[-1]))
    if np.any(crossed):
        out["max_anti_residual_crossed"] = float(np.max(np.abs(antiparallelogram_residual(f1, f3)[crossed])))
        out["max_hinge_C_minus_(crank-pi)_crossed"] = float(np.max(np.abs(p["hinge_C"] - (f1 - math.pi))[crossed]))
    return out


def _segments(t, br):
    """[(branch, t_from, t_to)] with the '?' samples near change points dropped."""
    segs = []
    for ti, b in zip(t, br):
        if b == "?":
            continue
        if segs and segs[-1][0] == b:
            segs[-1][2] = float(ti)
        else:
            segs.append([str(b), float(ti), float(ti)])
    return [(b, round(a, 3), round(c, 3)) for b, a, c in segs]


# ----------------------------------------------------------------------------- report
def _print(a: dict) -> None:
    print(f"{a['label']}: t_end {a['t_end']:.2f} s, wall {a['wall_s']:.1f} s")
    for k, v in a.items():
        if k not in ("label", "t_end", "wall_s"):
            print(f"    {k}: {v}")


def figure(base: dict, forced: dict | None, path: Path = FIGURE) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, p = base["t"], base["p"]
    f1, f3 = p["crank"], p["rocker"]
    fig, ax = plt.subplots(2, 2, figsize=(12, 8))
    a = ax[0, 0]
    a.plot(t, f1, label="crank φ1 (prescribed 0.6 t)")
    a.plot(t, f3, label="rocker φ3 (hinge probe)")
    a.plot(t, f3 - f1, label="rocker − crank")
    a.plot(t, p["hinge_C"], ":", label="hinge C (misaligned) φ_C")
    anti = (t >= T_DEAD[0]) & (t <= T_DEAD[1])
    a.plot(t[anti], antiparallelogram_rocker(f1[anti]), "k--", lw=1, label="rigid crossed branch φ3(φ1)")
    a.axhline(-2 * math.pi, color="gray", lw=0.5)
    for td in T_DEAD:
        a.axvline(td, color="gray", ls=":", lw=1)
    a.set(xlabel="t [s]", ylabel="rad", title="angles; dotted verticals: collinear (change) points")
    a.legend(fontsize=8)

    a = ax[0, 1]
    a.semilogy(t, np.abs(parallelogram_residual(f1, f3)) + 1e-8, label="|parallelogram residual|")
    a.semilogy(t, np.abs(antiparallelogram_residual(f1, f3)) + 1e-8, label="|crossed-branch residual|")
    for td in T_DEAD:
        a.axvline(td, color="gray", ls=":", lw=1)
    a.set(xlabel="t [s]", title="which rigid branch the flexible linkage follows", ylim=(1e-5, 5))
    a.legend(fontsize=8)

    a = ax[1, 0]
    for tt, c in ((1.0, "C0"), (2.62, "C5"), (4.0, "C1"), (5.24, "C2"), (6.5, "C3"), (9.0, "C4")):
        i = int(np.argmin(np.abs(t - tt)))
        xs = [0.0, p["Bx"][i], p["Cx"][i], D_LEN]
        ys = [0.0, p["By"][i], p["Cy"][i], 0.0]
        a.plot(xs, ys, "-o", color=c, ms=3, label=f"t = {t[i]:.2f} s ({branch(f1[i], f3[i])})")
    a.plot([0, D_LEN], [0, 0], color="gray", lw=4, alpha=0.5, zorder=0)
    a.set(aspect="equal", xlabel="x [m]", ylabel="y [m]", title="A-B-C-D from the point probes")
    a.legend(fontsize=8)

    a = ax[1, 1]
    a.plot(t, p["strain"], label="strain energy (free rocker)")
    if forced is not None:
        a.plot(forced["t"], forced["p"]["strain"], "--", label="strain energy, rocker forced to φ3 = φ1")
    a.plot(t, 100 * p["kinetic"], label="100 × kinetic energy")
    a.plot(t, p["energy"] - p["work"], label="total − external work")
    b = a.twinx()
    b.plot(t, np.degrees(misfit_angle(p["hinge_C"])), color="gray", lw=1)
    b.set_ylabel("misfit ψ(φ_C) of the 5° hinge [deg] (gray)")
    for td in T_DEAD:
        a.axvline(td, color="gray", ls=":", lw=1)
    a.set(xlabel="t [s]", ylabel="J", title="energies")
    a.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)


def main(quick: bool = False) -> None:
    base = run_case("baseline: dt 0.004, 4 elements per bar, generalized-alpha rho 0.8")
    _print(analyse(base))
    forced = run_case("rocker forced to stay on the parallelogram (angle 0.6 t)", t_end=5.3,
                      rocker_angle="0.6*t")
    fp, bp = forced["p"], base["p"]
    for tt in (2.0, 2.618, 3.5, 4.5, 5.236):
        i, j = int(np.argmin(np.abs(forced["t"] - tt))), int(np.argmin(np.abs(base["t"] - tt)))
        print(f"    t = {tt:5.3f}: strain energy free {bp['strain'][j]:.3f} J, forced parallelogram "
              f"{fp['strain'][i]:.3f} J; misfit ψ free {math.degrees(misfit_angle(bp['hinge_C'][j])):.2f}°, "
              f"forced {math.degrees(misfit_angle(fp['hinge_C'][i])):.2f}°")
    figure(base, forced)
    print(f"figure: {FIGURE.relative_to(ROOT)}")
    if quick:
        return
    s5, c5 = math.sin(math.radians(5)), math.cos(math.radians(5))
    studies = [
        ("dt 0.002", dict(dt=0.002)),
        ("dt 0.001", dict(dt=0.001)),
        ("8 elements per bar", dict(elements=8)),
        ("newmark (no numerical damping)", dict(method="newmark")),
        ("generalized-alpha rho 0.5", dict(rho_inf=0.5)),
        ("no tilt (perfect parallelogram)", dict(tilt_axis=[0, 0, 1])),
        ("tilt 1 deg about bar 2", dict(tilt_axis=[0, -math.sin(math.radians(1)), math.cos(math.radians(1))])),
        ("tilt 5 deg about the in-plane normal of bar 2 (MBDyn, mb_sef_py inputs)", dict(tilt_axis=[s5, 0, c5])),
        ("24 s (two crank turns)", dict(t_end=24.0, every=0.04)),
    ]
    for label, kw in studies:
        try:
            _print(analyse(run_case(label, **kw)))
        except Exception as exc:  # a failed variant is a finding, not a crash of the study
            print(f"{label}: {type(exc).__name__}: {str(exc).splitlines()[0]}")


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
