"""The real generated kernels: NumPy, C and a direct SymPy evaluation agree."""
from __future__ import annotations

import importlib
import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("latdyn_generated.beam_default") is None,
    reason="generated/beam_default.py does not exist yet (run latdyn-codegen)",
)

N = 5


def realistic_inputs(n: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Argument blocks of ``n`` plausible elements (see codegen/conventions.py).

    Random chords 1–3 long, orthonormal nodal frames near the chord direction, unit hinge
    axes, positive section properties with L0 near the chord length.
    """
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    base = Rotation.random(n, random_state=seed).as_matrix()
    length = rng.uniform(1.0, 3.0, n)
    x1 = rng.normal(size=(n, 3))
    x2 = x1 + length[:, None] * base[:, :, 0]
    bend1 = Rotation.from_rotvec(0.2 * rng.normal(size=(n, 3))).as_matrix()
    bend2 = Rotation.from_rotvec(0.2 * rng.normal(size=(n, 3))).as_matrix()
    frame1, frame2 = base @ bend1, base @ bend2
    offset1 = 0.1 * rng.normal(size=(n, 3))
    offset2 = 0.1 * rng.normal(size=(n, 3))
    axis1 = rng.normal(size=(n, 3))
    axis2 = rng.normal(size=(n, 3))
    axis1 /= np.linalg.norm(axis1, axis=1, keepdims=True)
    axis2 /= np.linalg.norm(axis2, axis=1, keepdims=True)
    geometry = np.concatenate(
        [x1, x2, offset1, offset2, frame1.reshape(n, 9), frame2.reshape(n, 9), axis1, axis2], axis=1
    )
    section = np.column_stack([
        length * rng.uniform(0.95, 1.05, n),   # L0
        rng.uniform(1e3, 1e4, n),              # EA
        rng.uniform(10, 100, n),               # EIy
        rng.uniform(10, 100, n),               # EIz
        rng.uniform(10, 100, n),               # GJ
        rng.uniform(0.5, 2.0, n),              # rhoA
        rng.uniform(0.01, 0.1, n),             # rhoIy
        rng.uniform(0.01, 0.1, n),             # rhoIz
        rng.uniform(0.0, 1e-2, n),             # 1/GAy (Φ up to ≈ 1)
        rng.uniform(0.0, 1e-2, n),             # 1/GAz
    ])
    velocity = rng.normal(size=(n, 14))
    acceleration = rng.normal(size=(n, 14))
    gravity = np.tile([0.0, 0.0, -9.81], (n, 1)) + 0.1 * rng.normal(size=(n, 3))
    reference = rng.normal(size=(n, 25))   # a variation of the reference data (geometry parameters)
    return {"geometry": geometry, "section": section, "velocity": velocity, "acceleration": acceleration,
            "gravity": gravity, "reference": reference}


def _variants():
    try:
        from latdyn.model.kernels import known_variants

        return list(known_variants())
    except Exception:  # noqa: BLE001 - collected before the skip applies
        return ["default"]


#: The variant whose C kernels are compared as a user gets them, each unit at its own -O level
#: (latdyn.model.kernels.optimisation); the others at the level the suite compiles at (tests/conftest.py: -O0,
#: 5-40x cheaper to compile, the same operations rounded alike), so that every kernel's C is compared here and
#: the optimised build of one variant's every kernel too.
USER_LEVEL_VARIANT = "default"


@pytest.fixture(scope="module", params=_variants())
def backends(request):
    from latdyn import native
    from latdyn.model import kernels

    variant = request.param
    numpy_set = kernels.load_kernels("numpy", variant)
    with pytest.MonkeyPatch.context() as patch:
        if variant == USER_LEVEL_VARIANT:
            patch.setenv(native.OPTIMISATION_VARIABLE, "")
            patch.setattr(kernels, "_LOADED", {})   # this process's other tests keep the suite's build
        try:
            c_set = kernels.load_kernels("c", variant)
            for name in c_set.info:   # those compiled on first use (ON_DEMAND) too, at this level
                getattr(c_set, name)
        except RuntimeError as error:
            pytest.skip(f"C kernels unavailable: {error}")
    return variant, numpy_set, c_set


def _assert_the_build_a_user_gets(c_set):
    """The C kernels of USER_LEVEL_VARIANT are the libraries a user's run loads (each unit at its own -O level), not
    the suite's: each kernel compiled as a unit of its own has the library the kernel cache names for its source at
    the user's flags (found there: the fixture built them), another than the suite's (the level is in the digest)."""
    from latdyn import native
    from latdyn.model import kernels

    ops = {name: int(meta.get("op_count", 0)) for name, meta in c_set.info.items()}
    alone = [name for name in c_set.info if name.startswith("beam_") and ops[name] > kernels.BUNDLE_OPS]
    assert {"beam_inertia_matrices", "beam_stiffness_D_q"} <= set(alone)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(native.OPTIMISATION_VARIABLE, "")
        users = kernels._compile(f"beam_{c_set.variant}", alone, ops)
    for name in alone:
        assert Path(c_set.library(name)._name) == Path(users[name]), name


_FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "asin": np.arcsin, "acos": np.arccos,
              "atan": np.arctan, "atan2": np.arctan2, "exp": np.exp, "log": np.log,
              "Abs": np.abs, "sign": np.sign, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh}


def _direct(spec, inputs):
    """Evaluate the spec's SymPy expressions node by node (no CSE, no printer), all
    elements at once; shared subexpressions and the spec's intermediates are evaluated once."""
    import sympy as sp

    n = len(next(iter(inputs.values())))
    values: dict = {}
    for argument in spec.inputs:
        for k, symbol in enumerate(argument.symbols()):
            values[symbol] = inputs[argument.name][:, k]

    def evaluate(root):
        stack = [root]
        while stack:
            node = stack[-1]
            if node in values:
                stack.pop()
                continue
            if node.is_Number or node.is_NumberSymbol:
                values[node] = np.full(n, float(node))
                stack.pop()
                continue
            if node.is_Symbol:
                raise KeyError(f"{spec.name}: unbound symbol {node}")
            pending = [arg for arg in node.args if arg not in values]
            if pending:
                stack.extend(pending)
                continue
            args = [values[arg] for arg in node.args]
            with np.errstate(all="ignore"):
                if node.is_Add:
                    result = np.sum(args, axis=0)
                elif node.is_Mul:
                    result = np.prod(args, axis=0)
                elif node.is_Pow:
                    result = np.power(args[0], args[1])
                else:
                    result = _FUNCTIONS[type(node).__name__](*args)
            values[node] = result
            stack.pop()
        return values[root]

    for symbol, expr in getattr(spec, "intermediates", None) or []:
        values[symbol] = evaluate(sp.sympify(expr))
    results = []
    for out in spec.outputs:
        block = [evaluate(sp.sympify(e)) for e in out.expressions]
        results.append(np.stack(block, axis=1).reshape(n, *out.shape))
    return results


def _assert_close(actual, expected, what):
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    assert np.all(np.isfinite(actual)), f"{what}: not finite"
    scale = np.linalg.norm(expected)
    error = np.linalg.norm(actual - expected)
    assert error <= 1e-10 * max(scale, 1e-300) or (scale == 0 and error == 0), \
        f"{what}: relative error {error / max(scale, 1e-300):.3e}"


#: The planar variants whose kernels are compared with the direct SymPy evaluation as well: the xy plane of
#: each family. A variant's yz and zx planes are the same formulation with another normal
#: (codegen/formulation.py ``_planar_variants``), derived, CSE'd and printed by the same code; their
#: kernels are compared here NumPy against C (every output), and their models with the 3D model in
#: tests/test_planar.py (``test_planar_model_equals_3d_model``, every plane). Deriving a variant again for
#: the direct evaluation is most of this file's time (1-6 min a variant on 2 busy cores when the six yz and
#: zx derivations were 15 % of the suite's; since the log map's jet rules are derived once a process,
#: codegen/derivation.py ``_log_jet_rules``, the file took 38 s against 104 s in one process, on a core to
#: itself at load 10-13: 11-15 s for a process's first variants, 1-3 s for the later ones).
SYMPY_PLANES = (None, "xy")


def test_numpy_c_and_sympy_agree(backends):
    from codegen.derivation import build_kernels
    from latdyn.model.kernels import PLANE_SUFFIXES

    variant, numpy_set, c_set = backends
    if variant == USER_LEVEL_VARIANT:
        _assert_the_build_a_user_gets(c_set)
    plane = next((p for p in PLANE_SUFFIXES.values() if variant.endswith(f"_{p}")), None)
    if plane not in SYMPY_PLANES:
        _numpy_and_c_agree(numpy_set, c_set, variant)
        return
    inputs = realistic_inputs(N, seed=11)
    specs = {spec.name: spec for spec in build_kernels(variant)}
    beam = {name: meta for name, meta in numpy_set.info.items() if name.startswith("beam_")}  # joints: test_joints
    names, c_names = sorted(specs), sorted(n for n in c_set.info if n.startswith("beam_"))
    assert names == sorted(beam) == c_names, "generated/ is stale: run latdyn-codegen"
    for name, meta in beam.items():
        arrays = [inputs[arg] for arg, _ in meta["inputs"]]
        from_numpy = getattr(numpy_set, name)(*arrays)
        from_c = getattr(c_set, name)(*arrays)
        direct = _direct(specs[name], inputs)
        for (out, shape), a, b, d in zip(meta["outputs"], from_numpy, from_c, direct):
            assert a.shape == b.shape == (N, *shape)
            _assert_close(a, d, f"{variant} {name}.{out} numpy vs sympy")
            _assert_close(b, d, f"{variant} {name}.{out} C vs sympy")
        # an output the spec does not hold: its forward-mode tangent (codegen/forward.py, added after CSE),
        # compared between the backends here and with central differences in tests/test_element.py
        assert len(meta["outputs"]) == len(direct) + (specs[name].tangent is not None)
        for (out, shape), a, b in list(zip(meta["outputs"], from_numpy, from_c))[len(direct):]:
            assert a.shape == b.shape == (N, *shape)
            _assert_close(b, a, f"{variant} {name}.{out} C vs numpy")


def _numpy_and_c_agree(numpy_set, c_set, variant):
    """Every beam kernel's every output, C against NumPy (the two printers of one CSE'd program)."""
    inputs = realistic_inputs(N, seed=11)
    beam = {name: meta for name, meta in numpy_set.info.items() if name.startswith("beam_")}
    assert sorted(beam) == sorted(n for n in c_set.info if n.startswith("beam_")), "generated/ is stale"
    for name, meta in beam.items():
        arrays = [inputs[arg] for arg, _ in meta["inputs"]]
        for (out, shape), a, b in zip(meta["outputs"], getattr(numpy_set, name)(*arrays),
                                      getattr(c_set, name)(*arrays)):
            assert a.shape == b.shape == (N, *shape)
            _assert_close(b, a, f"{variant} {name}.{out} C vs numpy")


def test_call_convention(backends):
    variant, numpy_set, c_set = backends
    inputs = realistic_inputs(3, seed=2)
    for kernels in (numpy_set, c_set):
        name, meta = next(iter(kernels.info.items()))
        function = getattr(kernels, name)
        arrays = [inputs[arg] for arg, _ in meta["inputs"]]
        empty = function(*[a[:0] for a in arrays])
        assert [e.shape for e in empty] == [(0, *shape) for _, shape in meta["outputs"]]
        as_lists = function(*[a.tolist() for a in arrays])          # any float array-like
        strided = function(*[np.asfortranarray(a) for a in arrays])
        for x, y in zip(as_lists, strided):
            np.testing.assert_array_equal(x, y)
        bad = [a[:, :-1] for a in arrays]
        with pytest.raises(ValueError, match=f"{name}.*{meta['inputs'][0][0]}"):
            function(*bad)


def test_unknown_backend_and_variant():
    from latdyn.model.kernels import load_kernels

    with pytest.raises(ValueError, match="numpy"):
        load_kernels("fortran")
    with pytest.raises(ValueError, match="default"):
        load_kernels("numpy", "nope")


def test_auto_without_a_compiler_names_the_fix(monkeypatch, tmp_path):
    import latdyn.model.kernels as kernels
    from latdyn.errors import MissingExtra

    monkeypatch.setattr(kernels, "_LOADED", {})
    monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    monkeypatch.setenv("LATDYN_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(MissingExtra, match=r'C kernels unavailable .*pip install "latdyn\[compiler\]"'):
        kernels.load_kernels("auto", "default")
    with pytest.raises(RuntimeError):
        kernels.load_kernels("c", "default")


def test_each_compiled_unit_holds_its_kernel_alone():
    """The C units compiled with a variant (latdyn.model.kernels._kernel_sources) and with the joints unit hold one
    kernel each, also when an ON_DEMAND kernel (compiled on first use) lies between them in the generated file."""
    from latdyn.model.kernels import ON_DEMAND, PACKAGE, _kernel_sources

    every = set()
    for stem in ("beam_default", "beam_default_xy", "joints"):
        names = list(importlib.import_module(f"{PACKAGE}.{stem}").KERNELS)
        every |= set(names)
        for asked in ([n for n in names if n not in ON_DEMAND], [n for n in ON_DEMAND if n in names]):
            for name, unit in _kernel_sources(stem, asked).items():
                defined = re.findall(rb"\nvoid (\w+)\(int64_t n", unit)
                assert defined == [name.encode()], (stem, name, defined)
    assert set(ON_DEMAND) <= every
