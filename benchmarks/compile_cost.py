"""Where the first compile's time goes: the compiler's CPU time of each kernel unit, by commit.

    python benchmarks/compile_cost.py STEM [STEM ...] --rev REV [--rev REV ...] [--repeat K]
                                      [--preamble-of REV] [--only NAME,NAME] [--json FILE]

For each ``REV`` (a commit, ``.`` for this working tree's ``generated/``, or a folder of generated files) the generated
``STEM.c`` of that commit is split into its units as :func:`latdyn.model.kernels._kernel_sources`
splits it (the includes and helpers, then one kernel), the units a first run compiles (not the
ON_DEMAND ones) are compiled one at a time with the flags :func:`latdyn.model.kernels._compile`
gives them (the -O level by the unit's operation count, ``native.C_FLAGS``, the instruction set's
flags), and the compiler's CPU time (user + system of the child, far less disturbed by other load
than its wall time) is printed per unit and summed per file: the median of ``--repeat`` compiles.

``--bundled WORKERS`` compiles the small kernels together as :func:`latdyn.model.kernels._bundles` groups
them (this checkout's rule; 0: each kernel alone, as before the ninth pass). ``--helpers FILE`` takes the helpers from a file (an experiment's). ``--preamble-of REV2`` replaces each unit's helpers (everything before the first kernel) by those
of ``REV2``'s file: the same kernel bodies with another template's helpers, to separate the
template's share of a change from the kernels'. Nothing is written to the kernel cache.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from latdyn import native  # noqa: E402
from latdyn.model import kernels  # noqa: E402


def _read(rev: str, path: str) -> str:
    if rev == ".":
        return (ROOT / path).read_text()
    if Path(rev).is_dir():  # a folder of generated files (an experiment's)
        return (Path(rev) / Path(path).name).read_text()
    return subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:{path}"], check=True, capture_output=True,
                          text=True).stdout


def generated_units(rev: str, stem: str) -> tuple[str, dict[str, str], dict[str, int]]:
    """The helpers (includes and inline functions) of ``rev``'s ``generated/STEM.c``, each kernel's own
    text (its comment line to the next kernel) and its operation count, in the order of its KERNELS."""
    source = _read(rev, f"generated/{stem}.c")
    namespace: dict = {}
    exec(compile(_read(rev, f"generated/{stem}.py"), f"{rev}:{stem}.py", "exec"), namespace)
    unit = namespace["KERNELS"]
    marks = {name: source.find(f"\n/* {name}: ") for name in unit}
    starts = sorted(at for at in marks.values() if at >= 0)
    helpers = source[: starts[0]].split("*/", 1)[-1]
    bodies = {}
    for name, at in marks.items():
        if at >= 0:
            later = [s for s in starts if s > at]
            bodies[name] = source[at: later[0] if later else len(source)]
    return helpers, bodies, {name: int(meta.get("op_count", 0)) for name, meta in unit.items()}


def compile_cpu(source: bytes, flags, folder: Path, name: str) -> tuple[float, float]:
    """The compiler's CPU seconds (user + system) and wall seconds for one unit."""
    c_file = folder / f"{name}.c"
    c_file.write_bytes(source)
    using = native.compiler()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run([*using.command, *flags, str(c_file), "-o", str(folder / f"{name}.so"), "-lm"], check=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def measure(stem: str, rev: str, repeat: int, preamble_of: str | None, only=None, extra_flags=(),
            helpers_file: str | None = None, bundled: int = 0) -> dict:
    helpers, bodies, ops = generated_units(rev, stem)
    if preamble_of:
        helpers = generated_units(preamble_of, stem)[0]
    if helpers_file:
        helpers = Path(helpers_file).read_text()
    simd = native.vector_flags(native.compiler())
    names = [n for n in bodies if n not in kernels.ON_DEMAND and (not only or n in only)]
    groups = kernels._bundles(names, ops, bundled) if bundled else [[name] for name in names]
    rows = {}
    with tempfile.TemporaryDirectory() as scratch:
        for group in groups:
            name = group[0] if len(group) == 1 else f"{group[0]} and {len(group) - 1} more"
            flags = (kernels.optimisation(max(ops[n] for n in group)), *native.C_FLAGS[1:], *simd, *extra_flags)
            source = (helpers + "".join(bodies[n] for n in group)).encode()
            samples = [compile_cpu(source, flags, Path(scratch), f"unit{len(rows)}") for _ in range(repeat)]
            rows[name] = {"ops": sum(ops[n] for n in group), "level": flags[0],
                          "cpu_s": statistics.median(s[0] for s in samples),
                          "wall_s": statistics.median(s[1] for s in samples)}
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("stems", nargs="+")
    parser.add_argument("--rev", action="append", default=None)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--preamble-of", default=None)
    parser.add_argument("--helpers", default=None, help="a file of helpers to use instead (an experiment's)")
    parser.add_argument("--only", default=None, help="kernel names, comma-separated")
    parser.add_argument("--flag", action="append", default=[], help="an extra compiler flag")
    parser.add_argument("--bundled", type=int, default=0, metavar="WORKERS",
                        help="the small kernels in units as latdyn.model.kernels._bundles makes them for WORKERS")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    only = set(args.only.split(",")) if args.only else None
    results = {}
    print(f"load {os.getloadavg()[0]:.1f}; {native.compiler().name}; {' '.join(native.vector_flags(native.compiler()))}")
    for rev in args.rev or ["."]:
        for stem in args.stems:
            rows = measure(stem, rev, args.repeat, args.preamble_of, only, tuple(args.flag), args.helpers, args.bundled)
            results[f"{rev}:{stem}"] = rows
            print(f"\n{rev} {stem}{' with the helpers of ' + (args.helpers or args.preamble_of) if args.helpers or args.preamble_of else ''}"
                  f" (load {os.getloadavg()[0]:.1f})")
            for name, row in sorted(rows.items(), key=lambda item: -item[1]["cpu_s"]):
                print(f"  {name:40s} {row['ops']:7d} {row['level']}  {row['cpu_s']:6.2f} s CPU  {row['wall_s']:6.2f} s wall")
            print(f"  {'total':40s} {sum(r['ops'] for r in rows.values()):7d}      "
                  f"{sum(r['cpu_s'] for r in rows.values()):6.2f} s CPU  "
                  f"{sum(r['wall_s'] for r in rows.values()):6.2f} s wall  ({len(rows)} units)")
    if args.json:
        Path(args.json).write_text(json.dumps({"load": os.getloadavg(), "results": results}, indent=1))


if __name__ == "__main__":
    main()
