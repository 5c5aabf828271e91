"""The discrete adjoint on models with rigid links or guides through events: its CPU time against the run without
sensitivities and the forward method, in process (docs/performance.md, "Adjoint with guides and events beside links
(issue 34)", "The adjoint on linked models in the loop of steps (issue 34)").

    python benchmarks/adjoint_linked_cost.py [--repeats 5] [--only TEXT]

Scenes (tests/test_sensitivities_refusals_lifted.py and tests/test_sensitivities_guides.py, more parameters): the
gimbal of rigid links whose inner ring latches (8 parameters), a bead on a guide on the gimbal's inner ring hitting its
stops three times (8), a slider on a skew guide at a 3D arm's tip hitting its stop (5, and 12 with the section values
and the tip's mass as parameters); the guided arm, free and hitting its stop, by 1, 10 and 100 load amplitudes. Each
scene warm once per variant, then ``--repeats`` rounds alternating the run without sensitivities, the forward method
and the adjoint; medians of ``time.process_time`` and wall. Run under
``chrt -f 10`` on a loaded machine; another checkout's build through ``PYTHONPATH`` for a before.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scenes() -> dict:
    """{name: YAML text}."""
    from tests.test_sensitivities_guides import GUIDE_3D, STOP_3D
    from tests.test_sensitivities_refusals_lifted import BEAD_ON_GIMBAL, LATCH

    twelve = STOP_3D.replace(
        "parameters: {k: 40.0, c: 0.3, m: 0.4, rest: 0.02, EI: 30.0}",
        "parameters: {k: 40.0, c: 0.3, m: 0.4, rest: 0.02, EI: 30.0, EA: 100000.0, EIz: 39.0, GJ: 24.0, rA: 0.5, "
        "rIy: 0.001, rIz: 0.0013, mt: 0.2}").replace(
        's: {EA: 100000.0, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.0013}',
        's: {EA: "EA", EIy: "EI", EIz: "EIz", GJ: "GJ", rhoA: "rA", rhoIy: "rIy", rhoIz: "rIz"}').replace(
        "mass: 0.2, inertia: [0.002, 0.003, 0.004]", 'mass: "mt", inertia: [0.002, 0.003, 0.004]').replace(
        "sensitivities: [k, m, EI, rest]", "sensitivities: [k, c, m, rest, EI, EA, EIz, GJ, rA, rIy, rIz, mt]")
    out = {"gimbal latch (8 p)": LATCH.replace("sensitivities: [k1, m, P, EI, rho]",
                                               "sensitivities: [k1, k2, c2, m, P, EI, rest, rho]"),
           "bead on the gimbal, 3 stops (8 p)": BEAD_ON_GIMBAL.replace(
               "sensitivities: [k1, m, P, ks, ms]", "sensitivities: [k1, k2, c2, m, P, EI, ks, ms]"),
           "guide stop on a 3D arm (5 p)": STOP_3D.replace("sensitivities: [k, m, EI, rest]",
                                                           "sensitivities: [k, c, m, EI, rest]"),
           "guide stop on a 3D arm (12 p)": twelve}
    assert all(text.count("sensitivities: [") == 1 for text in out.values()) and '"mt"' in twelve
    for count in (1, 10, 100):   # the loads' amplitudes: 1, 10, 100 parameters on the guided arm, free and stopped
        out[f"guided 3D arm, {count} load p"] = loaded(GUIDE_3D, count)
        out[f"guide stop on a 3D arm, {count} load p"] = loaded(STOP_3D, count)
    return out


def loaded(text: str, count: int) -> str:
    """``text`` (the guided 3D arm) with ``count`` loads at the arm's nodes and the tip, each of its own amplitude
    F1 … F<count> (0.01 N each way), the sensitivities by those amplitudes."""
    points = ["arm.node[1]", "arm.node[2]", "tip"]
    names = [f"F{i + 1}" for i in range(count)]
    loads = "".join(f'  - {{at: "{points[i % 3]}", force: ["{name}", "-{name}", "0.5*{name}"]}}\n'
                    for i, name in enumerate(names))
    out = text.replace("parameters: {k: 40.0,", "parameters: {" + "".join(f"{name}: 0.01, " for name in names)
                       + "k: 40.0,").replace("beams:", "loads:\n" + loads + "beams:")
    return out.replace("sensitivities: [k, m, EI, rest]", f"sensitivities: [{', '.join(names)}]")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--only", default="", help="the scenes whose name holds this text")
    args = parser.parse_args()
    compare({name: text for name, text in scenes().items() if args.only in name}, args.repeats)


def compare(scenes: dict, repeats: int) -> None:
    """Each of ``scenes`` ({name: YAML text}) warm once per variant (without sensitivities, the forward method, the
    adjoint), then ``repeats`` rounds alternating them; medians of CPU and wall time printed."""
    import yaml

    import latdyn

    for name, text in scenes.items():
        plain, forward, adjoint = (yaml.safe_load(text) for _ in range(3))
        plain["solve"].pop("sensitivities")
        adjoint["solve"]["sensitivity_method"] = "adjoint"
        variants = {"without": plain, "forward": forward, "adjoint": adjoint}
        for data in variants.values():   # warm: laws compiled, kernels opened
            latdyn.run(latdyn.load_scene(data))
        times = {key: [] for key in variants}
        for _ in range(repeats):
            for key, data in variants.items():
                cpu, wall = time.process_time(), time.perf_counter()
                result = latdyn.run(latdyn.load_scene(data))
                times[key].append((time.process_time() - cpu, time.perf_counter() - wall))
        cpu = {key: statistics.median(t for t, _ in values) for key, values in times.items()}
        wall = {key: statistics.median(w for _, w in values) for key, values in times.items()}
        print(f"{name}: {result.summary.get('steps')} steps; "
              + "; ".join(f"{key} {cpu[key] * 1e3:.0f} ms CPU ({wall[key] * 1e3:.0f} wall)" for key in variants)
              + f"; adjoint {cpu['adjoint'] / cpu['without']:.2f} x without, {cpu['adjoint'] / cpu['forward']:.2f} x "
              "the forward method", flush=True)


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    main()
