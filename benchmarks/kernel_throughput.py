"""Kernel throughput (elements/s) of the NumPy and C backends at 10⁴ elements.

    python benchmarks/kernel_throughput.py [n_elements]

Medians of 7 calls per kernel, both backends measured in one run.
"""
from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_backends import realistic_inputs  # noqa: E402

from latdyn.model.kernels import load_kernels  # noqa: E402


def median_time(function, arrays, repeats=7):
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        function(*arrays)
        samples.append(time.perf_counter() - start)
    return float(np.median(samples))


def main(n: int = 10_000) -> None:
    inputs = realistic_inputs(n, seed=1)
    sets = {"numpy": load_kernels("numpy"), "c": load_kernels("c")}
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if "model name" in line), "?")
    print(f"{n} elements; {platform.python_implementation()} {platform.python_version()}; CPU {cpu}")
    print(f"{'kernel':34s} {'ops':>7s} {'numpy el/s':>12s} {'C el/s':>12s} {'C/numpy':>8s}")
    for name, meta in sets["numpy"].info.items():
        if not all(arg in inputs for arg, _ in meta["inputs"]):  # the joints unit: per body, load, end, hinge
            continue
        arrays = [inputs[arg] for arg, _ in meta["inputs"]]
        rates = {b: n / median_time(getattr(k, name), arrays) for b, k in sets.items()}
        print(f"{name:34s} {meta.get('op_count', 0):7d} {rates['numpy']:12.3g} {rates['c']:12.3g} "
              f"{rates['c'] / rates['numpy']:8.1f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10_000)
