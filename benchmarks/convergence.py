"""Convergence studies: L1 and S1/S2 against element count, D1 against the time step.

    python benchmarks/convergence.py      # prints tables, writes docs/verification/convergence_*.png
"""
from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
warnings.filterwarnings("ignore", category=RuntimeWarning)
from benchmarks import problems as P  # noqa: E402

OUT = P.ROOT / "docs" / "verification"


def orders(hs, errs):
    return [float("nan")] + [math.log(errs[i - 1] / errs[i]) / math.log(hs[i - 1] / hs[i]) for i in range(1, len(errs))]


def l1_study(ns=(2, 4, 8, 16)):
    exact = [b ** 2 for b in P.reference("L1")["reference"]["betaL_clamped_free"][:3]]
    table = []
    for n in ns:
        om = P.l1_frequencies(n)
        table.append([float((om[np.argmin(abs(om - e))] - e) / e) for e in exact])
    return ns, np.array(table)


def s1_study(ns=(20, 40, 80)):
    return ns, np.array([P.s1_tip_error(n) for n in ns])


def s2_study(ns=(4, 8, 16, 32), alpha="1"):
    ref = P.reference("S2")["reference_by_alpha"][alpha]["transverse_over_L"]
    errs = []
    for n in ns:
        r, _ = P.s2_run(n)
        lf = np.asarray(r.t)
        i = int(np.argmin(abs(4 * lf - float(alpha))))
        errs.append(abs(r.probes["tip_y"][i] - ref) / ref)
    return ns, np.array(errs)


def d1_dt_study(dts=(0.02, 0.01, 0.005, 0.0025)):
    """Period at constant spin against dt, and the self-convergence of the tip history."""
    periods, tips = [], []
    for dt in dts:
        out = P.check_D1_constant(dt=dt, t_end=3.0)
        periods.append(out["rows"][0][2])
        r = out["result"]
        tips.append(float(np.interp(2.0, r.t, r.probes["tip_y"])))
    best = tips[-1]
    diffs = [abs(x - best) for x in tips[:-1]]
    return dts, np.array(periods), np.array(tips), np.array(diffs)


def main():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    OUT.mkdir(parents=True, exist_ok=True)
    lines = []

    ns, tab = l1_study()
    lines.append("L1 clamped-free, relative frequency error (from above > 0) and observed order in h")
    o = [orders([1 / n for n in ns], tab[:, k]) for k in range(3)]
    for i, n in enumerate(ns):
        lines.append(f"  n={n:3d}  " + "  ".join(f"{tab[i, k]:+.3e} (p={o[k][i]:.2f})" for k in range(3)))
    fig, ax = plt.subplots(1, 3, figsize=(13, 3.8))
    for k in range(3):
        ax[0].loglog(ns, tab[:, k], "o-", label=f"mode {k + 1}")
    ax[0].loglog(ns, tab[0, 2] * (ns[0] / np.array(ns)) ** 4, "k--", label="h^4")
    ax[0].set(xlabel="elements", ylabel="relative error", title="L1 clamped-free frequencies")
    ax[0].legend()

    ns1, e1 = s1_study()
    ns2, e2 = s2_study()
    lines.append("S1 end moment: |tip - root| / L at M = 2 pi EI/L, observed order")
    for n, e, p in zip(ns1, e1, orders([1 / n for n in ns1], e1)):
        lines.append(f"  n={n:3d}  {e:.3e}  p={p:.2f}")
    lines.append("S2 elastica alpha = 1: relative error of v/L, observed order")
    for n, e, p in zip(ns2, e2, orders([1 / n for n in ns2], e2)):
        lines.append(f"  n={n:3d}  {e:.3e}  p={p:.2f}")
    ax[1].loglog(ns1, e1, "o-", label="S1 tip gap / L")
    ax[1].loglog(ns2, e2, "s-", label="S2 v/L rel. error (alpha=1)")
    ax[1].loglog(ns1, e1[0] * (ns1[0] / np.array(ns1)) ** 2, "k--", label="h^2")
    ax[1].axhline(1e-3, color="r", lw=0.8, label="tolerance")
    ax[1].set(xlabel="elements", title="S1 / S2 statics")
    ax[1].legend()

    dts, periods, tips, diffs = d1_dt_study()
    Tref = P.reference("D1")["reference_derived"]["post_ramp_oscillation_period_s"]
    lines.append("D1 constant spin 6 rad/s (8 elements): period vs dt; tip v at t=2 vs finest dt")
    od = orders(list(dts[:-1]), list(diffs))
    for i, dt in enumerate(dts):
        extra = f"  |v - v_finest| = {diffs[i]:.3e} (p={od[i]:.2f})" if i < len(diffs) else ""
        lines.append(f"  dt={dt:<6g} period {periods[i]:.5f} s (err {abs(periods[i] - Tref) / Tref:.2e}){extra}")
    ax[2].loglog(dts[:-1], diffs, "o-", label="|tip v(2 s) - finest|")
    ax[2].loglog(dts[:-1], diffs[0] * (np.array(dts[:-1]) / dts[0]) ** 2, "k--", label="dt^2")
    ax[2].set(xlabel="dt [s]", title="D1 time-step convergence")
    ax[2].legend()
    fig.tight_layout()
    fig.savefig(OUT / "convergence.png", dpi=110)
    print("\n".join(lines))
    return lines


if __name__ == "__main__":
    main()
