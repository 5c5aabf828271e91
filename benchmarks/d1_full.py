"""D1 spin-up, full 20 s, with and without geometric stiffening.

    python benchmarks/d1_full.py      # prints a summary, writes docs/verification/d1_spinup.png
"""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
warnings.filterwarnings("ignore", category=RuntimeWarning)
from benchmarks import problems as P  # noqa: E402


def main():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    full = P.check_D1_full()
    r = full["result"]
    ns, err, wall_ns = P.run_D1_no_stiffening(t_end=20.0)
    lines = [f"with stiffening: {full['wall_s']:.1f} s wall"]
    for q, ref, got, e, tol in full["rows"]:
        lines.append(f"  {q}: reference {ref:.6g}, latdyn {got:.6g}, error {e:.3g}")
    fig, ax = plt.subplots(1, 2, figsize=(12, 4))
    ax[0].plot(r.t, r.probes["tip_v"], label="default (stiffening)")
    if ns is not None:
        t, v = np.asarray(ns.t), np.asarray(ns.probes["tip_v"])
        beyond = np.where(np.abs(v) > 10)[0]
        when = t[beyond[0]] if len(beyond) else None
        lines.append(f"no_stiffening: run completed to {t[-1]:.2f} s; max |tip v| = {np.max(np.abs(v)):.3g} m; "
                     f"|tip v| > L first at t = {when}")
        ax[0].plot(t, np.clip(v, -12, 12), label="no_stiffening (clipped at +-12)")
    else:
        lines.append(f"no_stiffening: SolverError: {err.splitlines()[0]}")
    ax[0].axvline(8.5122, color="k", ls=":", label="Omega = omega_1 (8.51 s)")
    ax[0].set(xlabel="t [s]", ylabel="tip v in hub frame [m]", title="D1 spin-up")
    ax[0].legend()
    ax[1].plot(r.t, 1e3 * np.asarray(r.probes["stretch"]), label="tip stretch (hub frame)")
    ax[1].axhline(1e3 * P.reference("L5")["reference_kane_beam_Omega6"]["u_tip_stretched_m"], color="r",
                  ls="--", label="L5 steady 0.5143 mm")
    ax[1].set(xlabel="t [s]", ylabel="mm", title="D1 axial stretch vs L5")
    ax[1].legend()
    fig.tight_layout()
    P.ROOT.joinpath("docs", "verification").mkdir(parents=True, exist_ok=True)
    fig.savefig(P.ROOT / "docs" / "verification" / "d1_spinup.png", dpi=110)
    print("\n".join(lines))
    return full, lines


if __name__ == "__main__":
    main()
