"""Results that do not depend on the CPU: the element kernels compiled for another instruction set
(``LATDYN_MARCH``, :func:`latdyn.native.march`) give the same results as those compiled for this
machine's (``-march=native``), and OpenBLAS's kernels for another CPU (``OPENBLAS_CORETYPE``)
give the same results to round-off.

The lanes of a batched kernel are elements, each computed by the same operations in the same
order whatever the vector width, and every unit is compiled with ``-ffp-contract=off`` (no
fused multiply-add the source did not ask for), so the instruction set changes how many
elements one instruction handles, not the rounding: ``x86-64-v2`` (SSE4.2, 2 lanes) and
``native`` (8 lanes with AVX-512) give bit-for-bit the same probes with GCC (measured: 0). The
tolerance, 1e-9 of each probe's largest magnitude, admits a compiler or libm that rounds some
operation otherwise: a different rounding leaves at most 2.9e-10 in these scenes (measured with
OpenBLAS's kernels of another CPU, below), while a kernel that computes something else (a lane
mixed up, a batch tail mishandled) differs by far more.

Each instruction set runs in a process of its own (a process loads one set of kernels), through
the command line, on scenes as a user types them: planar and 3D beams, a hinge with a spring,
damper and stop, rigid links in 3D, a prescribed spin, a static path and modes. A first run
compiles the kernels for x86-64-v2 into the cache (once; the suite's later runs find them).
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import latdyn
from latdyn import native

ROOT = Path(__file__).resolve().parents[1]

SCENES = {
    "planar_beam": """
title: planar cantilever under gravity and a tip force
sections:
  s: {EA: 1.0e6, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 2.0}
gravity: [0, -9.81, 0]
bodies:
  root: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: root, to: [1.5, 0, 0], section: s, elements: 4}
loads:
  - {at: arm.end, force: [0, "20*sin(30*t)", 0]}
solve: {t_end: 0.2, dt: 0.004}
output:
  probes:
    tip_y: {point: arm.end, quantity: displacement, component: y}
    moment: {element: arm.element[0], quantity: moment_z}
    energy: {energy: total}
""",
    "spatial_beam": """
title: 3D cantilever bent and twisted at its tip
sections:
  s: {EA: 1.0e6, EIy: 30.0, EIz: 60.0, GJ: 20.0, rhoA: 1.5, rhoIy: 0.001, rhoIz: 0.002}
bodies:
  root: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: root, to: [1.0, 0.5, 0.2], section: s, elements: 4}
loads:
  - {at: arm.end, force: [0, "30*t", "-40*t"], moment: ["10*t", 0, 0]}
solve: {t_end: 0.2, dt: 0.004, method: newmark}
output:
  probes:
    tip_x: {point: arm.end, quantity: displacement, component: x}
    tip_z: {point: arm.end, quantity: displacement, component: z}
    torque: {element: arm.element[0], quantity: torque}
    kinetic: {energy: kinetic}
""",
    "hinged_panels": """
title: two panels hinged by a spring, a damper and a stop, in gravity
sections:
  panel: {EA: 1.0e7, EIy: 50.0, EIz: 50.0, GJ: 40.0, rhoA: 1.0}
gravity: [0, 0, -9.81]
bodies:
  root: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0], mass: 0.2}
  tip: {at: [1, 1, 0], mass: 0.5}
beams:
  inner: {from: root, to: knee, section: panel, elements: 3}
  outer:
    from: knee
    to: tip
    section: panel
    elements: 3
    start:
      hinge: {axis: [1, 0, 0], stiffness: 20.0, damping: 0.5, limits: [-0.05, 0.5], restitution: 0.5}
solve: {t_end: 0.25, dt: 0.005}
output:
  probes:
    hinge: {hinge: outer.start, quantity: angle}
    tip_z: {point: tip, quantity: position, component: z}
    energy: {energy: total}
""",
    "rigid_links": """
title: a double pendulum of rigid links on skew hinges, started spinning
sections:
  rod: {EA: 1.0e7, EIy: 100.0, EIz: 100.0, GJ: 80.0, rhoA: 3.0}
gravity: [0, -9.81, 0]
initial_velocity: {angular: [0, 0, 2.0]}
bodies:
  pivot: {at: [0, 0, 0], fixed: true}
  elbow: {at: [0.8, 0, 0], mass: 0.3}
beams:
  upper: {from: pivot, to: elbow, section: rod, rigid: true, start: {hinge: {axis: [0, 0, 1]}}}
  lower: {from: elbow, to: [1.4, 0, 0.3], section: rod, rigid: true, start: {hinge: {axis: [0, 1, 1]}}}
solve: {t_end: 0.3, dt: 0.005}
output:
  probes:
    shoulder: {hinge: upper.start, quantity: angle}
    elbow: {hinge: lower.start, quantity: rate}
    end_z: {point: lower.end, quantity: position, component: z}
    momentum: {momentum: angular, component: y}
""",
    "spin_up": """
title: a beam on a hub spun up (Kane, Ryan and Banerjee), with an out-of-plane tip load
sections:
  s: {EA: 2.8e7, EIy: 1400.0, EIz: 1400.0, GJ: 1000.0, rhoA: 1.2}
bodies:
  hub:
    at: [0, 0, 0]
    motion: {rotation: {axis: [0, 0, 1], angle: "6*(t**2/2 + (cos(2*pi*t/1.5) - 1)*(1.5/(2*pi))**2/1)"}}
beams:
  arm: {from: hub, to: [8, 0, 0], section: s, elements: 4}
loads:
  - {at: arm.end, force: [0, 0, "2*t"], frame: hub}
solve: {t_end: 0.3, dt: 0.01}
output:
  probes:
    tip_v: {point: arm.end, quantity: position, frame: hub, component: y}
    tip_w: {point: arm.end, quantity: position, frame: hub, component: z}
    axial: {element: arm.element[0], quantity: axial_force}
""",
    "static_frame": """
title: an L frame loaded out of its plane, static
sections:
  s: {EA: 1.0e6, EIy: 20.0, EIz: 30.0, GJ: 15.0, rhoA: 1.0}
bodies:
  root: {at: [0, 0, 0], fixed: true}
  corner: {at: [1, 0, 0]}
beams:
  a: {from: root, to: corner, section: s, elements: 3}
  b: {from: corner, to: [1, 1, 0], section: s, elements: 3}
loads:
  - {at: b.end, force: [0, 0, -15.0]}
solve: {analysis: static, steps: 4}
output:
  probes:
    tip_z: {point: b.end, quantity: displacement, component: z}
    torque: {element: a.element[0], quantity: torque}
""",
    "modes_frame": """
title: modes of a clamped L frame
sections:
  s: {EA: 1.0e6, EIy: 20.0, EIz: 30.0, GJ: 15.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}
bodies:
  root: {at: [0, 0, 0], fixed: true}
  corner: {at: [1, 0, 0], mass: 0.5}
beams:
  a: {from: root, to: corner, section: s, elements: 3}
  b: {from: corner, to: [1, 1, 0], section: s, elements: 3}
solve: {analysis: modes, count: 6}
""",
}

#: The instruction set compared with this machine's: SSE4.2, the x86-64 of any CPU of the last 15 years.
OTHER = "x86-64-v2"

_RUNNER = """
import sys
from latdyn.cli import main
folder = sys.argv[1]
for name in sys.argv[2:]:
    status = main(["run", f"{folder}/{name}.yaml", "-o", f"{folder}/{name}_{sys.argv[0]}", "-q"])
    if status != 0:
        sys.exit(f"{name}: exit status {status}")
"""


def _x86_64() -> bool:
    try:
        return bool(native.isa_macros()) and "__x86_64__" in native.isa_macros()
    except RuntimeError:
        return False


def _run_all(folder: Path, tag: str, **environment: str) -> None:
    """Every scene of SCENES through the command line, in a process of its own with ``environment``
    (and without ``LATDYN_MARCH`` unless it names it); results in ``<scene>_<tag>``."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    for name in ("LATDYN_MARCH", "OPENBLAS_CORETYPE"):
        env.pop(name, None)
    env.update(environment)
    code = _RUNNER.replace("sys.argv[0]", repr(tag))
    result = subprocess.run([sys.executable, "-c", code, str(folder), *SCENES], env=env, cwd=folder,
                            capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]


def _table(path: Path) -> dict[str, np.ndarray]:
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    values = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    return dict(zip(header, values.T))


def _largest_difference(folder: Path, tag: str, other: str) -> float:
    """The largest difference of a probe (or a mode's frequency) between the runs ``tag`` and
    ``other`` of every scene, relative to that column's largest magnitude."""
    worst, compared = 0.0, 0
    for name in SCENES:
        one, two = folder / f"{name}_{tag}", folder / f"{name}_{other}"
        file = "modes.csv" if (one / "modes.csv").exists() else "probes.csv"
        a, b = _table(one / file), _table(two / file)
        assert a.keys() == b.keys()
        for column in a:
            assert a[column].shape == b[column].shape, (name, column)
            scale = max(float(np.max(np.abs(a[column]))), 1e-300)
            worst = max(worst, float(np.max(np.abs(a[column] - b[column]))) / scale)
            compared += 1
    assert compared >= 20
    return worst


@pytest.fixture(scope="module")
def default_runs(tmp_path_factory):
    """The scenes run as a user runs them (native kernels, OpenBLAS's choice): ``<scene>_default``."""
    folder = tmp_path_factory.mktemp("instruction_sets")
    for name, text in SCENES.items():
        (folder / f"{name}.yaml").write_text(text)
    _run_all(folder, "default")
    return folder


@pytest.mark.skipif(not _x86_64(), reason="x86-64 instruction sets: another CPU has its own")
def test_kernels_for_x86_64_v2_and_for_this_cpu_give_the_same_results(default_runs):
    _run_all(default_runs, OTHER, LATDYN_MARCH=OTHER)
    assert _largest_difference(default_runs, "default", OTHER) <= 1e-9  # measured: 0, bit for bit


def test_kernels_as_a_user_gets_them_and_as_the_suite_compiles_them_give_the_same_results(default_runs):
    """The suite compiles the element kernels at -O0 (tests/conftest.py, ``$LATDYN_KERNEL_OPT``: 5-40x cheaper to
    compile); a user's run loads each unit at its own level (-O1 up to OPT_LIMIT_OPS operations,
    latdyn.model.kernels.optimisation). Every unit is compiled with ``-ffp-contract=off`` and without fast-math, so
    the optimiser keeps each operation and its rounding: the scenes' probes agree (measured: 0, bit for bit). With
    the variable empty (the suite run at the user's levels) this compares a build with itself."""
    _run_all(default_runs, "user_levels", **{native.OPTIMISATION_VARIABLE: ""})
    assert _largest_difference(default_runs, "default", "user_levels") <= 1e-9  # measured: 0, bit for bit


@pytest.mark.skipif(not _x86_64(), reason="OpenBLAS's x86-64 kernels")
def test_openblas_kernels_of_another_cpu_give_the_same_results_to_round_off(default_runs):
    """The LU of Newton's matrix is LAPACK's from SciPy's OpenBLAS, whose kernels are chosen by the
    CPU (``OPENBLAS_CORETYPE`` forces one; an OpenBLAS built for one CPU ignores it, and the test
    then compares a run with itself). Those round differently, so here the results agree to
    round-off and not bit for bit. Measured between the SkylakeX and Haswell kernels: at most 7e-13
    of a probe's largest magnitude, except the total energy of the hinged panels, 2.9e-10 of its
    largest (3.9e-11 J of the 0.137 J the damper and the stop take out: a sum of parts far larger
    than itself). The tolerance is Newton's default (1e-8, timeloop.transient.DEFAULT_TOL): a
    difference below it is decided by where Newton stops anyway. The panels' stop has restitution 0.5:
    with 0 the outer panel comes to rest on its stop while its bending vibration rings, and the joint,
    locked there, is released and hits again whenever the locked reaction changes sign (grazing
    contacts, each landed on by a secant whose time is ill-conditioned at zero approach rate): the
    kernels' round-off then moves those event times, and rows compared at moved times differ by
    5e-6 though each run is right to its tolerance."""
    _run_all(default_runs, "haswell", OPENBLAS_CORETYPE="Haswell")
    assert _largest_difference(default_runs, "default", "haswell") <= 1e-8


def test_a_march_the_compiler_does_not_take_is_refused_naming_the_variable(tmp_path):
    """Through the command line: exit status 2 and a message naming LATDYN_MARCH, no traceback."""
    (tmp_path / "beam.yaml").write_text(SCENES["planar_beam"])
    env = dict(os.environ, LATDYN_MARCH="no-such-cpu",
               PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    result = subprocess.run([sys.executable, "-m", "latdyn", "run", "beam.yaml", "-o", "out", "-q"],
                            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 2, result.stderr
    assert "LATDYN_MARCH" in result.stderr and "-march=no-such-cpu" in result.stderr
    assert "Traceback" not in result.stderr


@pytest.mark.parametrize("value", ["x86-64-v2; rm -rf /", "-O3", "native sse"])
def test_a_march_that_is_not_one_word_is_refused(value, monkeypatch):
    monkeypatch.setenv("LATDYN_MARCH", value)
    with pytest.raises(latdyn.SceneError, match="LATDYN_MARCH.*an instruction set"):
        native.vector_flags()


@pytest.mark.parametrize("value", ["O0", "-O9", "-O0 -ffast-math"])
def test_a_kernel_optimisation_level_not_known_is_refused(value, monkeypatch):
    monkeypatch.setenv(native.OPTIMISATION_VARIABLE, value)
    with pytest.raises(latdyn.SceneError, match="LATDYN_KERNEL_OPT.*an optimisation level"):
        native.kernel_optimisation()


def test_a_march_this_cpu_cannot_run_is_refused(monkeypatch):
    """x86-64-v4 on a CPU without AVX-512: its kernels would stop on an illegal instruction."""
    here = frozenset({"__x86_64__", "__SSE2__", "__AVX2__", "__znver2", "__tune_znver2__"})
    wanted = frozenset({"__x86_64__", "__SSE2__", "__AVX2__", "__AVX512F__", "__AVX512VL__", "__k8"})
    monkeypatch.setattr(native, "isa_macros", lambda using=None, chosen="native": here if chosen == "native" else wanted)
    monkeypatch.setattr(native, "compiler", lambda: native.Compiler(["cc"], b"cc 1"))
    monkeypatch.setenv("LATDYN_MARCH", "x86-64-v4")
    with pytest.raises(latdyn.SceneError, match=r"LATDYN_MARCH: -march=x86-64-v4 needs instructions this "
                                                r"CPU lacks \(AVX512F, AVX512VL\)"):
        native.vector_flags()
    monkeypatch.setenv("LATDYN_MARCH", "x86-64-v3")
    monkeypatch.setattr(native, "isa_macros", lambda using=None, chosen="native": here if chosen == "native" else here - {"__znver2"} | {"__k8"})
    flags = native.vector_flags()
    assert flags[0] == "-march=x86-64-v3" and flags[1].startswith("-DLATDYN_ISA=")


#: a generated unit's preamble (the template's lanes and functions) with one kernel of ours: each lane's
#: latdyn_sqrt of the inputs, a batch of LATDYN_LANES at a time
_SQRT_DRIVER = """
void lanes_sqrt(int64_t n, const double *x, double *out)
{
    for (int64_t i = 0; i < n; i += LATDYN_LANES) {
        latdyn_vec v;
        for (int l = 0; l < LATDYN_LANES; ++l) v[l] = x[i + l];
        v = latdyn_sqrt(v);
        for (int l = 0; l < LATDYN_LANES; ++l) out[i + l] = v[l];
    }
}
"""


@pytest.mark.parametrize("lanes", [None, 2, 4])
def test_the_kernels_square_root_gives_libms_bits_in_every_lane(lanes):
    """The generated units' latdyn_sqrt (codegen/templates/c_source.c.j2: one SIMD instruction where the
    instruction set has one, else lane by lane through libm), compiled as the kernels are (this machine's
    instruction set; its own lane count, and 2 and 4 lanes), gives each lane the bits of C's sqrt
    (NumPy's, the same correctly rounded IEEE square root) on random magnitudes from 1e-300 to 1e300,
    subnormals, ±0, infinities, NaN and negative numbers (the default NaN): the kernels' results do not
    depend on whether the square root is one instruction."""
    import ctypes

    source = (Path(__file__).resolve().parents[1] / "generated" / "beam_default.c").read_text()
    preamble = source[: source.index("\n/* beam_")].split("*/", 1)[-1]
    defines = () if lanes is None else (f"-DLATDYN_LANES={lanes}",)
    flags = ("-O1", *native.C_FLAGS[1:], *native.vector_flags(), *defines)
    library = native.load(native.build("test_lanes_sqrt", (preamble + _SQRT_DRIVER).encode(), flags))
    rng = np.random.default_rng(7)
    special = [0.0, -0.0, np.inf, -np.inf, np.nan, -1.0, -1e-300, 5e-324, 2.2e-308, 1.0, 2.0, 4.0]
    x = np.concatenate([special, 10.0 ** rng.uniform(-300, 300, 4000), rng.uniform(0.0, 1.0, 4000)])
    x = np.concatenate([x, np.zeros(-len(x) % 8)])
    out = np.empty_like(x)
    library.lanes_sqrt(ctypes.c_int64(len(x)), ctypes.c_void_p(x.ctypes.data), ctypes.c_void_p(out.ctypes.data))
    with np.errstate(invalid="ignore"):
        expected = np.sqrt(x)
    assert np.array_equal(out.view(np.uint64), expected.view(np.uint64))
