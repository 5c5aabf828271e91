"""Compile time against run time of each generated C kernel at -O0, -O1 and -O2.

    python benchmarks/compile_levels.py [variant] [n_elements]

Each kernel is compiled as its own translation unit (as latdyn.model.kernels does) at each
level, one compile at a time (wall and CPU time of the compiler), then timed on
``n_elements`` realistic elements (median of 7 calls, µs per element). The table says
which level pays: a level pays when the run time it saves over a run outweighs the extra
compile time. Results go to benchmarks/results/compile_levels.json with the machine.
"""
from __future__ import annotations

import ctypes
import importlib
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_backends import realistic_inputs  # noqa: E402

from latdyn.model.kernels import PACKAGE, _c_function, _kernel_sources  # noqa: E402
from latdyn.native import compiler  # noqa: E402

LEVELS = ("-O0", "-O1", "-O2")


def compile_unit(source: bytes, level: str, folder: Path, name: str) -> tuple[Path, float, float]:
    c_file = folder / f"{name}{level}.c"
    c_file.write_bytes(source)
    target = folder / f"{name}{level}.so"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run([*compiler().command, level, "-std=c99", "-fPIC", "-shared", str(c_file), "-o", str(target), "-lm"],
                   check=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return target, wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(variant: str = "default", n: int = 2000) -> None:
    module = importlib.import_module(f"{PACKAGE}.beam_{variant}")
    names = list(module.KERNELS)
    units = _kernel_sources(f"beam_{variant}", names)
    inputs = realistic_inputs(n, seed=1)
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if "model name" in line), "?")
    machine = {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
               "load_average": os.getloadavg()}
    print(f"variant {variant}; {n} elements; CPU {cpu}, {os.cpu_count()} cores; load {os.getloadavg()}")
    print(f"{'kernel':32s} {'ops':>7s} " + " ".join(f"{lv + ' s':>8s} {lv + ' µs':>8s}" for lv in LEVELS))
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for name in names:
            meta = module.KERNELS[name]
            arrays = [np.ascontiguousarray(inputs[arg]) for arg, _ in meta["inputs"]]
            row = {"kernel": name, "ops": meta.get("op_count", 0)}
            for level in LEVELS:
                target, wall, cpu_s = compile_unit(units[name], level, Path(scratch), name)
                call = _c_function(ctypes.CDLL(str(target)), name, meta)
                samples = []
                for _ in range(7):
                    start = time.perf_counter()
                    call(*arrays)
                    samples.append(time.perf_counter() - start)
                row[level] = {"compile_wall_s": wall, "compile_cpu_s": cpu_s,
                              "us_per_element": 1e6 * float(np.median(samples)) / n}
            rows.append(row)
            print(f"{name:32s} {row['ops']:7d} " + " ".join(
                f"{row[lv]['compile_cpu_s']:8.2f} {row[lv]['us_per_element']:8.2f}" for lv in LEVELS), flush=True)
    out = Path(__file__).resolve().parent / "results" / f"compile_levels_{variant}.json"
    out.write_text(json.dumps({"machine": machine, "variant": variant, "elements": n, "rows": rows}, indent=1))
    print(f"wrote {out}")


if __name__ == "__main__":
    main(*(sys.argv[1:2] or ["default"]), *([int(sys.argv[2])] if len(sys.argv) > 2 else []))
