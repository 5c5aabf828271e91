"""A fresh run that latches, as a user meets it (issues 31 and 34; docs/performance.md, "The latch without SciPy's
sparse package (issue 31/34)").

    python benchmarks/latch_start.py [--rounds 5] [--trees ROOT_A,ROOT_B] [--fifo] [--scenes NAME,...] [--modules]

The scenes: examples/deploying_boom.yaml (``boom``), the boom's design run of examples/deploying_boom_sensitivities.py
without and with its sensitivities to the hinge's k and c (``boom0``, ``boom_kc``: benchmarks/sensitivity_start.py's),
examples/deploying_truss.yaml, examples/cable_deploying_truss.yaml and examples/slider_crank.yaml, each
``python -m latdyn run SCENE -o OUT -q`` in a fresh process; and ``design``, the whole design example
``python examples/deploying_boom_sensitivities.py`` (its SLSQP iterations and the check by central differences, in
one process). Measured as benchmarks/sensitivity_start.py measures (its ``as_a_user`` and ``modules``: the trees
alternating process by process, a warm-up round left out, medians of wall and the child's CPU, ``--fifo`` under
``chrt -f 10``).
"""
from __future__ import annotations

import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import sensitivity_start  # noqa: E402 - the measurement, beside this file

EXAMPLE = ROOT / "examples" / "deploying_boom_sensitivities.py"


def scenes() -> list[tuple[str, str, dict]]:
    """(name, family, scene) of every scene (module docstring); ``design`` runs its script, its scene the run's
    with sensitivities (``boom_kc``)."""
    made = [("boom", "example", yaml.safe_load((ROOT / "examples" / "deploying_boom.yaml").read_text()))]
    made += [s for s in sensitivity_start.scenes() if s[1] == "boom"]
    for name in ("deploying_truss", "cable_deploying_truss", "slider_crank"):
        made.append((name, name, yaml.safe_load((ROOT / "examples" / f"{name}.yaml").read_text())))
    return made + [("design", "design", made[2][2])]


def command(scene: Path, out: Path, fifo: bool) -> list[str]:
    """sensitivity_start's command, or the design example's where the scene is its script."""
    if scene.name == "design.yaml":
        line = [sys.executable, str(EXAMPLE)]
        return ["chrt", "-f", "10", *line] if fifo else line
    return sensitivity_start.command(scene, out, fifo)


def main() -> None:
    args = sensitivity_start.arguments(__doc__.splitlines()[0], adjoint=False).parse_args()
    sensitivity_start.measure(scenes(), args, prefix="latch-start-", command=command)


if __name__ == "__main__":
    main()
