"""The discrete adjoint's cost on three models a designer meets, beside the run without sensitivities and the forward
method (issue 34, item 6; docs/performance.md, "The adjoint on designers' linked models (issue 34)").

    python benchmarks/adjoint_designer_cost.py [--repeats 5] [--only TEXT] [--fresh] [--write DIR]

Scenes (tests/test_adjoint_in_loop_designer.py; YAML text as a user types it, genuinely 3D): a gimbal (the outer
ring's hinge under a PD, the inner ring a rigid link latching, a flexible boom beyond), a deploying truss bay (two rigid
bays swung open by preloaded hinge springs, latching in line, two flexible members beyond), a cart on a skew ground
guide carrying a flexible mast with a tip body; each by 1, 10 and 100 parameters (beyond the scene's own, load amplitudes ``F1`` …), two probes. Each case
warm once, then ``--repeats`` rounds alternating the run without sensitivities, the forward method and the adjoint;
medians of ``time.process_time`` and wall, in process; ``--fresh``: each run a fresh ``python -m latdyn run SCENE -o
OUT -q`` (CPU: the child's user + system). ``--write DIR`` writes each case's three YAML files there. Run under
``chrt -f 10``; another checkout's build through ``PYTHONPATH`` for a before.
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scenes() -> dict:
    """{name: (YAML text, the point the extra loads act at, the parameter of the 1-parameter case)}: the scenes of
    tests/test_adjoint_in_loop_designer.py."""
    from tests.test_adjoint_in_loop_designer import CART_MAST, GIMBAL_PD, TRUSS_BAY

    return {"gimbal": (GIMBAL_PD, "tip", "k1"), "truss": (TRUSS_BAY, "tip", "k"), "cart": (CART_MAST, "top", "k")}


def with_parameters(text: str, point: str, first: str, count: int) -> str:
    """``text`` differentiated by ``count`` parameters: the first alone (1), the scene's ten (10), or its ten and
    ``count`` − 10 load amplitudes ``F1`` … at ``point`` (each 0.001 N in a direction of its own)."""
    start = text.index("sensitivities: [")
    end = text.index("]", start)
    names = text[start + len("sensitivities: ["):end].split(", ")
    assert len(names) == 10, names
    if count == 1:
        names = [first]
    elif count > 10:
        extra = [f"F{i + 1}" for i in range(count - 10)]
        loads = "".join(f'  - {{at: {point}, force: ["{name}", "{(-1) ** i * 0.5}*{name}", "{0.1 * (i % 7)}*{name}"]}}\n'
                        for i, name in enumerate(extra))
        text = text.replace("parameters: {", "parameters: {" + "".join(f"{name}: 0.001, " for name in extra), 1)
        text = text.replace("loads:\n", "loads:\n" + loads, 1)
        names = names + extra
        start = text.index("sensitivities: [")
        end = text.index("]", start)
    return text[:start] + "sensitivities: [" + ", ".join(names) + text[end:]


def cases(only: str = "") -> dict:
    """{name: YAML text} for each scene by 1, 10 and 100 parameters."""
    out = {}
    for scene, (text, point, first) in scenes().items():
        for count in (1, 10, 100):
            name = f"{scene}, {count} p"
            if only in name:
                out[name] = with_parameters(text, point, first, count)
    return out


def variants(text: str) -> dict:
    """{without, forward, adjoint: the scene's data}."""
    import yaml

    plain, forward, adjoint = (yaml.safe_load(text) for _ in range(3))
    plain["solve"].pop("sensitivities")
    adjoint["solve"]["sensitivity_method"] = "adjoint"
    return {"without": plain, "forward": forward, "adjoint": adjoint}


def in_process(data: dict) -> tuple:
    """(CPU s, wall s, result) of one run of ``data`` in this process."""
    import latdyn

    cpu, wall = time.process_time(), time.perf_counter()
    result = latdyn.run(latdyn.load_scene(data))
    return time.process_time() - cpu, time.perf_counter() - wall, result


def fresh(path: Path, out: Path) -> tuple:
    """(CPU s, wall s, None) of one fresh ``python -m latdyn run path -o out -q``: the child's user + system."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    subprocess.run([sys.executable, "-m", "latdyn", "run", str(path), "-o", str(out), "-q"], check=True,
                   env=dict(os.environ))
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, wall, None


def compare(scenes: dict, repeats: int, as_user: bool) -> None:
    """Each of ``scenes`` warm once per variant, then ``repeats`` rounds alternating them; medians printed."""
    import yaml

    for name, text in scenes.items():
        runs = variants(text)
        with tempfile.TemporaryDirectory() as folder:
            paths = {}
            for key, data in runs.items():
                paths[key] = Path(folder) / f"{key}.yaml"
                paths[key].write_text(yaml.safe_dump(data))

            def once(key):
                return fresh(paths[key], Path(folder) / key) if as_user else in_process(runs[key])

            for key in runs:   # warm: laws compiled, kernels cached
                once(key)
            times = {key: [] for key in runs}
            for _ in range(repeats):
                for key in runs:
                    times[key].append(once(key)[:2])
        cpu = {key: statistics.median(t for t, _ in values) for key, values in times.items()}
        wall = {key: statistics.median(w for _, w in values) for key, values in times.items()}
        print(f"{name}: " + "; ".join(f"{key} {cpu[key] * 1e3:.0f} ms CPU ({wall[key] * 1e3:.0f} wall)" for key in runs)
              + f"; forward {cpu['forward'] / cpu['without']:.2f} x without; adjoint "
              f"{cpu['adjoint'] / cpu['without']:.2f} x without, {cpu['adjoint'] / cpu['forward']:.2f} x forward",
              flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--only", default="", help="the cases whose name holds this text")
    parser.add_argument("--fresh", action="store_true", help="each run a fresh latdyn run, as a user runs it")
    parser.add_argument("--write", default="", help="a folder to write each case's YAML files into")
    args = parser.parse_args()
    selected = cases(args.only)
    if args.write:
        import yaml

        folder = Path(args.write)
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in selected.items():
            for key, data in variants(text).items():
                (folder / f"{name.replace(', ', '-').replace(' ', '')}-{key}.yaml").write_text(yaml.safe_dump(data))
        return
    compare(selected, args.repeats, args.fresh)


if __name__ == "__main__":
    sys.path.append(str(ROOT))   # after PYTHONPATH: the build compared is the one it names
    main()
