"""Rotating cantilever: modes about the steady spin against the published table, and a Campbell diagram.

Run from the repository root::

    python benchmarks/rotating_cantilever.py                # 20 elements, gamma = 0 ... 12
    python benchmarks/rotating_cantilever.py --elements 10

A uniform Euler–Bernoulli cantilever (L = 10, EI = 1.4e4, rhoA = 1.2, EA = 2.8e8: nearly
inextensible) clamped to a hub at its axis spins about global z at Ω; ``solve.analysis: modes``,
``about: steady`` (latdyn/analyses/linearise.py) gives the frequencies in the spinning frame.  The
flapwise (z) frequencies are compared, nondimensional, with the table of
``benchmarks/references/rotating_cantilever.json`` (Wright et al. 1982), the chordwise (y)
ones with ω_c² = ω_f² − Ω² of the inextensible beam evaluated with the table's flap values.
Writes ``benchmarks/results/rotating_cantilever.json`` and the Campbell diagram
``docs/campbell_rotating_cantilever.png`` (frequency in Hz against the spin rate in rad/s,
every computed mode, labelled by its dominant direction).  Also times one linearisation
against one step of the transient of the same scene (compiled step), and checks the first
flapwise and chordwise frequencies against the spectrum of a transient response at gamma = 5.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import latdyn  # noqa: E402

L, EI, RHOA, EA = 10.0, 1.4e4, 1.2, 2.8e8
SCALE = np.sqrt(RHOA * L**4 / EI)  # omega_bar = omega * SCALE


def scene(omega: float, elements: int, **solve) -> dict:
    spec = {"analysis": "modes", "about": "steady", "count": 9, "dt": 0.01}
    spec.update(solve)
    return {
        "sections": {"arm": {"EA": EA, "EIy": EI, "EIz": EI, "GJ": 1.0e4, "rhoA": RHOA}},
        "initial_velocity": {"angular": [0, 0, float(omega)]},
        "bodies": {"hub": {"at": [0, 0, 0], "motion": {"rotation": {"axis": [0, 0, 1], "angle": f"{float(omega)!r}*t"}}}},
        "beams": {"arm": {"from": "hub", "to": [L, 0, 0], "section": "arm", "elements": elements}},
        "solve": spec,
    }


def modes_of(omega: float, elements: int):
    with tempfile.TemporaryDirectory() as out:
        started = time.perf_counter()
        latdyn.run(latdyn.load_scene(scene(omega, elements)), out)
        seconds = time.perf_counter() - started
        rows = (Path(out) / "modes.csv").read_text().splitlines()
        summary = json.loads((Path(out) / "summary.json").read_text())
    header = rows[0].split(",")
    table = [dict(zip(header, r.split(",")), direction=d) for r, d in zip(rows[1:], summary["mode_directions"])]
    return table, seconds, summary["linearisation_s"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, default=20)
    args = parser.parse_args()
    reference = json.loads((ROOT / "benchmarks" / "references" / "rotating_cantilever.json").read_text())
    rows, campbell = [], []
    for k, gamma in enumerate(reference["gamma"]):
        omega = gamma / SCALE
        table, seconds, lin_s = modes_of(omega, args.elements)
        flap = [float(m["frequency_hz"]) * 2 * np.pi * SCALE for m in table if m["direction"] == "z"][:3]
        chord = [float(m["frequency_hz"]) * 2 * np.pi * SCALE for m in table if m["direction"] == "y"][:2]
        ref = [reference["omega_bar"][f"flap_{i}"][k] for i in (1, 2, 3)]
        chord_ref = [float(np.sqrt(r * r - gamma * gamma)) for r in ref[:2]]
        rows.append({"gamma": gamma, "omega_rad_s": omega, "flap": flap, "flap_reference": ref,
                     "flap_relative_error": [f / r - 1 for f, r in zip(flap, ref)],
                     "chord": chord, "chord_inextensible": chord_ref,
                     "chord_relative_error": [c / r - 1 for c, r in zip(chord, chord_ref)],
                     "run_s": seconds, "linearisation_s": lin_s})
        campbell.append((omega, table))
        print(f"gamma {gamma:4.1f}: flap " + " ".join(f"{f:8.4f} ({r:8.4f})" for f, r in zip(flap, ref))
              + " | chord " + " ".join(f"{c:8.4f} ({r:8.4f})" for c, r in zip(chord, chord_ref))
              + f" | {seconds:.2f} s", flush=True)
    # the cost of a linearisation against a transient step of the same scene
    with tempfile.TemporaryDirectory() as out:
        transient = scene(6.0, args.elements, analysis="transient", t_end=1.0, dt=0.01)
        transient["solve"].pop("about")
        transient["solve"].pop("count")
        transient["solve"]["planar"] = "off"
        latdyn.run(latdyn.load_scene(transient), out)
        summary = json.loads((Path(out) / "summary.json").read_text())
    step_s = summary["solver_s"] / max(summary["steps"], 1)
    lin_s = float(np.median([r["linearisation_s"] for r in rows]))
    response = response_check(args.elements)
    result = {"elements": args.elements, "rows": rows, "response_check": response,
              "linearisation_s_median": lin_s, "transient_step_s": step_s,
              "linearisation_over_step": lin_s / step_s,
              "reference": "benchmarks/references/rotating_cantilever.json"}
    path = ROOT / "benchmarks" / "results" / "rotating_cantilever.json"
    path.write_text(json.dumps(result, indent=1) + "\n")
    print(f"linearisation {lin_s * 1e3:.1f} ms (median, incl. the modes) vs a transient step {step_s * 1e3:.2f} ms "
          f"({lin_s / step_s:.0f}x); wrote {path.relative_to(ROOT)}")
    draw(campbell, ROOT / "docs" / "campbell_rotating_cantilever.png")


def response_check(elements: int, gamma: float = 5.0, duration: float = 40.0) -> dict:
    """The same beam in a transient run: rigid spin at t = 0, a short tip pulse along z and y in
    the hub's axes, then free; the tip's z and y in the hub frame, Hann-windowed FFT, the peak
    located by parabolic interpolation of the log spectrum, against about: steady."""
    omega = gamma / SCALE
    spec = scene(omega, elements, analysis="transient", t_end=duration, dt=0.01, planar="off")
    spec["solve"].pop("about")
    spec["solve"].pop("count")
    pulse = "Piecewise((1.0, t < 0.05), (0, True))"
    spec["loads"] = [{"at": "arm.end", "force": [0, pulse, pulse], "frame": "hub"}]
    spec["output"] = {"every": 0.01, "probes": {
        axis: {"point": "arm.end", "quantity": "position", "frame": "hub", "component": axis} for axis in "yz"}}
    started = time.perf_counter()
    result = latdyn.run(latdyn.load_scene(spec))
    seconds = time.perf_counter() - started
    steady, _, _ = modes_of(omega, elements)
    out = {"gamma": gamma, "duration_s": duration, "transient_s": seconds}
    for axis in "yz":
        t, x = np.asarray(result.t), np.asarray(result.probes[axis])
        keep = t >= 0.1
        x = (x[keep] - x[keep].mean()) * np.hanning(keep.sum())
        spectrum = np.abs(np.fft.rfft(x, 8 * len(x)))
        freqs = np.fft.rfftfreq(8 * len(x), t[1] - t[0])
        k = int(np.argmax(spectrum[1:])) + 1
        a, b, c = np.log(spectrum[k - 1:k + 2])
        peak = freqs[k] + 0.5 * (a - c) / (a - 2 * b + c) * (freqs[1] - freqs[0])
        predicted = next(float(m["frequency_hz"]) for m in steady if m["direction"] == axis)
        out[axis] = {"response_hz": float(peak), "steady_modes_hz": predicted, "relative": float(peak / predicted - 1)}
        print(f"response check, tip {axis}: {peak:.5f} Hz from the transient, {predicted:.5f} Hz about steady "
              f"({peak / predicted - 1:+.1e})", flush=True)
    return out


def draw(campbell, path: Path) -> None:
    """Frequency (Hz) against the spin rate (rad/s), one line per mode label and order."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    rates = np.array([omega for omega, _ in campbell])
    styles = {"z": ("C0", "flapwise (z)"), "y": ("C1", "chordwise (y)"), "x": ("C2", "axial (x)"),
              "rx": ("C3", "torsion (rx)")}
    for label, (colour, name) in styles.items():
        series = [[float(m["frequency_hz"]) for m in table if m["direction"] == label] for _, table in campbell]
        depth = min(len(s) for s in series)
        for order in range(min(depth, 3)):
            ax.plot(rates, [s[order] for s in series], "o-", color=colour, ms=3,
                    label=name if order == 0 else None)
    ax.plot(rates, rates / (2 * np.pi), "k--", lw=0.8, label="1P (spin rate)")
    ax.set_xlabel("spin rate Ω (rad/s)")
    ax.set_ylabel("frequency in the spinning frame (Hz)")
    ax.set_title("Campbell diagram: rotating cantilever\n(L = 10 m, EI = 1.4e4 N m², ρA = 1.2 kg/m, hub radius 0)", fontsize=10)
    ax.set_ylim(0, None)
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
