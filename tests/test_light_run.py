"""A run pays only for what it uses (issue 31): the scene's YAML read by libyaml where that reads it as
the Python scanner does, the reverse Cuthill–McKee order of mid-size models without SciPy's csgraph
(the same order), the held check on the package's own LU, and a band model's run that never loads
scipy.sparse.linalg, csgraph or scipy.linalg (docs/performance.md, "Where a run's time goes")."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import latdyn
from latdyn.errors import SceneError
from latdyn.numerics import csr
from latdyn.numerics.csr import CSR, transposed, transposed_product
from latdyn.numerics.linalg import reverse_cuthill_mckee
from latdyn.scene import loader

ROOT = Path(__file__).resolve().parents[1]


# ----------------------------------------------------------------------------- reverse Cuthill–McKee
def _patterns():
    rng = np.random.default_rng(7)
    for trial in range(120):
        n = int(rng.integers(1, 160))
        m = int(rng.integers(0, 4 * n))
        rows, cols = rng.integers(0, n, m), rng.integers(0, n, m)
        if trial % 3 == 0:  # a band with its diagonal, duplicates and one-sided entries
            rows = np.concatenate([rows, np.arange(n)])
            cols = np.concatenate([(rows[:m] + rng.integers(-4, 5, m)) % n, np.arange(n)])
        yield rows, cols, n


def test_reverse_cuthill_mckee_is_scipys_order_where_scipys_seeds_have_no_ties():
    """SciPy's order to the last index wherever NumPy's default argsort of the degrees (SciPy's seeds) is the stable
    one, and a permutation everywhere; elsewhere it breaks ties by the lowest index (the next test)."""
    sps = pytest.importorskip("scipy.sparse")
    csgraph = pytest.importorskip("scipy.sparse.csgraph")
    compared = 0
    for rows, cols, n in _patterns():  # several components, isolated nodes, unsymmetric patterns
        pattern = sps.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
        order = reverse_cuthill_mckee(rows, cols, n)
        assert np.array_equal(np.sort(order), np.arange(n))
        symmetric = ((pattern + pattern.T) != 0).astype(np.int32)
        degree = np.diff(symmetric.indptr) + symmetric.diagonal()
        if np.array_equal(np.argsort(degree), np.argsort(degree, kind="stable")):
            compared += 1
            expected = csgraph.reverse_cuthill_mckee(pattern, symmetric_mode=False)
            assert np.array_equal(order, expected)
    assert compared >= 5


#: The orders reverse_cuthill_mckee gives the 16-bay lattice's patterns (benchmarks/lattice.py, 2 elements a member:
#: 408 coordinates, the band LU) in a run of two steps.
_MID_ORDERS = """
import hashlib, sys
sys.path.insert(0, sys.argv[1])
import latdyn
import lattice
from latdyn.numerics import linalg
found, original = [], linalg.reverse_cuthill_mckee
def ordered(rows, cols, n):
    order = original(rows, cols, n)
    found.append(hashlib.sha256(order.tobytes()).hexdigest())
    return order
linalg.reverse_cuthill_mckee = ordered
latdyn.run(latdyn.load_scene(lattice.latdyn_scene(16, 2, 1e-4, t_end=2e-4)))
print(found)
"""


def test_a_mid_size_models_band_order_is_the_same_whatever_simd_numpy_dispatches():
    """``reverse_cuthill_mckee`` (the band and sparse storages' order, every model above DENSE_LIMIT coordinates)
    seeds its search by a stable sort of the degrees: NumPy's default argsort, which SciPy's csgraph calls, broke the
    ties of a lattice's equal degrees differently under AVX-512, AVX2 and none (the 16-bay lattice's probes differed
    by 9.2e-14 between AVX-512 and AVX2), so the order, and a mid-size model's results, followed the CPU."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    orders = []
    for disabled in _DISPATCH:
        done = subprocess.run([sys.executable, "-c", _MID_ORDERS, str(ROOT / "benchmarks")], capture_output=True, text=True,
                              env={**env, "NPY_DISABLE_CPU_FEATURES": disabled}, timeout=300)
        if done.returncode != 0 and "NPY_DISABLE_CPU_FEATURES" in done.stderr:
            continue   # a NumPy built without this dispatch
        assert done.returncode == 0, done.stderr[-2000:]
        orders.append(done.stdout.strip().splitlines()[-1])
    assert orders and orders[0] != "[]" and all(order == orders[0] for order in orders)


#: NumPy's CPU dispatch a test process can leave out (NPY_DISABLE_CPU_FEATURES): none, AVX-512, AVX-512 and AVX2.
_DISPATCH = ("", "X86_V4 AVX512_ICL AVX512_SPR", "X86_V3 X86_V4 AVX512_ICL AVX512_SPR")

#: The orders small_rcm_band gives the right-angle cantilever's patterns (120 coordinates) in a run of two steps.
_SMALL_ORDERS = """
import hashlib, sys
import yaml
import latdyn
from latdyn.assembly import factorization
found, original = [], factorization.small_rcm_band
def ordered(rows, cols, n):
    order = original(rows, cols, n)
    found.append(hashlib.sha256(order[0].tobytes()).hexdigest())
    return order
factorization.small_rcm_band = ordered
scene = yaml.safe_load(open(sys.argv[1]).read())
scene["solve"]["t_end"] = 2 * scene["solve"]["dt"]
latdyn.run(latdyn.load_scene(scene))
print(found)
"""


def test_a_small_models_band_order_is_the_same_whatever_simd_numpy_dispatches():
    """``small_rcm_band`` (the order of models of at most DENSE_LIMIT coordinates) sorts degrees stably: its order,
    and so a small model's band LU, does not depend on which of NumPy's sorts the CPU dispatches. NumPy's default
    ``argsort`` breaks ties differently under AVX-512, AVX2 and none (x86-simd-sort): ``reverse_cuthill_mckee``, which
    keeps SciPy's order, gives the cantilever's 120-coordinate pattern another order without AVX2 (and the 16-bay
    lattice's another under each), so small models keep their own search (the session of 2026-11-28, eleventh)."""
    scene = ROOT / "examples" / "benchmarks" / "D2_right_angle_cantilever.yaml"
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    orders = []
    for disabled in _DISPATCH:
        done = subprocess.run([sys.executable, "-c", _SMALL_ORDERS, str(scene)], capture_output=True, text=True,
                              env={**env, "NPY_DISABLE_CPU_FEATURES": disabled}, timeout=300)
        if done.returncode != 0 and "NPY_DISABLE_CPU_FEATURES" in done.stderr:
            continue   # a NumPy built without this dispatch
        assert done.returncode == 0, done.stderr[-2000:]
        orders.append(done.stdout.strip().splitlines()[-1])
    assert orders[0] != "[]" and all(order == orders[0] for order in orders)


# ----------------------------------------------------------------------------- YAML in C
SCENE = """\
title: a skew arm on a hub, as typed
sections:
  arm: {EA: 2.8e7, EIy: 1.4e4, EIz: 1.4e4, GJ: 1.0e4, rhoA: 1.2}
bodies:
  hub:
    at: [0, 0, 0]
    motion:
      rotation: {axis: [0, 0, 1], angle: "0.5*t**2"}
  off:                       # a body named with a YAML 1.1 word
    at: [1, 2, 0.5]
beams:
  arm: {from: hub, to: [2, 1, 0.5], section: arm, elements: 3}
solve: {analysis: transient, t_end: 0.02, dt: 0.01}
output:
  every: 0.01
  probes:
    tip: {point: arm.end, quantity: position, frame: hub, component: y}
"""


def _read_in_python(text: str):
    parse = loader._yaml_loader()(text)
    try:
        node = parse.get_single_node()
        return None if node is None else parse.construct_document(node)
    finally:
        parse.dispose()


def test_yaml_read_in_c_gives_the_python_parsers_values():
    pytest.importorskip("yaml.cyaml")
    data = loader._read_yaml_in_c(SCENE, "scene.yaml")
    assert data is not loader._MISSING
    assert data == _read_in_python(SCENE)
    assert data["bodies"]["off"]["at"] == [1, 2, 0.5] and data["sections"]["arm"]["EA"] == 2.8e7
    assert "off" in data["bodies"]  # YAML 1.2 words: not the boolean False


def test_a_text_read_again_keeps_the_tag_its_quotes_give():
    """The resolver matches each plain text once a file (``_yaml_loader``'s ``resolve``): the same text
    quoted stays a string and plain is read again as a number, a boolean, null or a word, in either
    order and in both parsers."""
    text = ("a: [1, '1', 1, \"1\", 2.8e7, '2.8e7', 2.8e7, true, 'true', true, off, 'off', null, 'null', ~, '']\n"
            "b: ['7', 7, 'false', false, '0.5', 0.5, '~', ~]\n")
    expected = {"a": [1, "1", 1, "1", 2.8e7, "2.8e7", 2.8e7, True, "true", True, "off", "off", None, "null",
                      None, ""],
                "b": ["7", 7, "false", False, "0.5", 0.5, "~", None]}
    for data in (loader._read_yaml_in_c(text, "scene.yaml"), _read_in_python(text)):
        assert data == expected
        assert {k: [type(v) for v in data[k]] for k in data} == {k: [type(v) for v in expected[k]] for k in expected}


def _typed(value):
    """A value with the type of every part, floats by their bits (``-0.0``, NaN), the order of keys kept."""
    if isinstance(value, dict):
        return ("dict", [(_typed(k), _typed(v)) for k, v in value.items()])
    if isinstance(value, list):
        return ("list", [_typed(v) for v in value])
    if isinstance(value, float):
        return ("float", np.float64(value).tobytes())
    return (type(value).__name__, value)


def _read_by_the_constructor(text: str):
    """libyaml's nodes read as before ``loader._plain_document``: the duplicate-key walk, then the loader's
    ``construct_document``."""
    import yaml

    parse = loader._c_yaml_loader()(text)
    try:
        node = parse.get_single_node()
        loader._check_duplicate_keys(node, "", "scene.yaml", set())
        return parse.construct_document(node), node, parse
    except (yaml.YAMLError, SceneError) as exc:
        return type(exc), node, parse


_PLAIN_TEXTS = [
    "a: [1, -0.0, .inf, -.Inf, .nan, 0x1F, 0o17, 017, 0b101, 1_000, 1:30, 2.8e7, 2.8e+7, 1e400, +5, ~, null, "
    "true, FALSE, off, 'x', \"y\", '', 3.]\n",
    "{1: a, 1.0: b, true: c, ~: d, 2.5: f, -0.0: g}\n",
    "x:\n  - {p: [1, 2, [3, [4, {q: r}]]]}\n  -\n  - !!str 5\n  - !!float 1\n  - !!int '7'\n",
    "title: |\n  two\n  lines\nnext: >\n  folded\n  text\n",
    "just a word\n", "- 1\n- [2]\n", "a: &x 1\nb: *x\nc: [*x, *x]\n",
    "a: " + "[" * 199 + "]" * 199 + "\n",  # as deep as the walk goes (loader._PLAIN_DEPTH)
]
_OTHER_TEXTS = [
    "a: &x [1, 2]\nb: *x\n", "base: &b {k: 1}\nd:\n  <<: *b\n  j: 2\n",
    "when: 2001-12-14\n", "s: !!set {a, b}\n", "b: !!binary aGk=\n", "o: !!omap [{a: 1}]\n",
    "a: 1\na: 2\n", "a: 1\n'a': 2\n", "? [k]\n: v\n", "a: !!int abc\n", "a: !!bool maybe\n",
    "a: !!str {k: v}\n", "a: !!map [1]\n", "{1: a, '1': b}\n", "= : 1\n", "a: !!python/name:os.system ''\n",
    "a: 0b_\n", "a: !!float x\n", "a: " + "9" * 5000 + "\n",  # an int, a float its constructor cannot read
    "a: " + "[" * 200 + "]" * 200 + "\n",  # deeper than the walk goes: the constructor's data
]


@pytest.mark.parametrize("text", _PLAIN_TEXTS + _OTHER_TEXTS)
def test_a_plain_document_is_read_in_one_walk_as_the_constructor_reads_it(text):
    """``loader._plain_document`` (the duplicate-key check and the construction in one walk; docs/performance.md,
    "Thirteenth pass") gives the constructor's data, types, float bits and key order, or leaves the document to
    the duplicate-key walk and the constructor (aliases, merge keys, other tags, duplicated or non-scalar keys,
    a scalar its tag cannot read); ``_read_yaml_in_c`` gives the same either way."""
    pytest.importorskip("yaml.cyaml")
    expected, _, parse = _read_by_the_constructor(text)  # its nodes flattened by the constructor (merge keys)
    parse.dispose()
    parse = type(parse)(text)
    try:
        walked = loader._plain_document(parse, parse.get_single_node())
    finally:
        parse.dispose()
    if text in _PLAIN_TEXTS:
        assert walked is not loader._MISSING and _typed(walked) == _typed(expected)
    else:
        assert walked is loader._MISSING
    try:
        read = loader._read_yaml_in_c(text, "scene.yaml")
    except SceneError as exc:
        read = type(exc)
    if isinstance(expected, type):
        assert read is loader._MISSING or read is SceneError
    else:
        assert read is not loader._MISSING and _typed(read) == _typed(expected)


class _FaultyTags:
    """A stand-in for the walk's table of tags whose every look-up fails as a bug would."""

    def __contains__(self, tag):
        raise AttributeError("a fault inside the walk")


def test_a_fault_inside_the_one_walk_reader_is_raised_not_hidden_behind_the_constructor(tmp_path, monkeypatch):
    """``loader._plain_document`` leaves a document to the constructor only for what it decides is outside its
    subset (other tags, aliases of collections, duplicated or non-scalar keys, a scalar its constructor cannot
    read, nesting deeper than ``_PLAIN_DEPTH``): an error of any other kind inside it reaches the caller, through
    ``latdyn.load_scene`` too, rather than the scene being read again the slow way as if nothing happened."""
    pytest.importorskip("yaml.cyaml")
    scene = tmp_path / "spin.yaml"
    scene.write_text(SPIN, encoding="utf-8")
    assert latdyn.load_scene(scene).beams
    monkeypatch.setattr(loader, "_PLAIN_SCALAR_TAGS", _FaultyTags())
    with pytest.raises(AttributeError, match="a fault inside the walk"):
        latdyn.load_scene(scene)


def test_the_shipped_scenes_are_read_in_one_walk_as_the_constructor_reads_them():
    pytest.importorskip("yaml.cyaml")
    scenes = sorted((ROOT / "examples").rglob("*.yaml")) + sorted((ROOT / "tests").rglob("*.yaml"))
    scenes += sorted((ROOT / "benchmarks").rglob("*.yaml"))
    walked = 0
    for path in scenes:
        text = path.read_text(encoding="utf-8")
        expected, _, parse = _read_by_the_constructor(text)
        parse.dispose()
        parse = type(parse)(text)
        try:
            node = parse.get_single_node()
            data = loader._plain_document(parse, node) if node is not None else loader._MISSING
        finally:
            parse.dispose()
        if data is not loader._MISSING:
            walked += 1
            assert _typed(data) == _typed(expected), path
    assert walked >= 20


def test_the_cross_product_of_two_3_vectors_is_numpys_to_the_bit():
    """``latdyn.numerics.so3.cross`` (the model's element frames, the initial velocities) gives
    ``np.cross``'s bits: magnitudes from 1e-12 to 1e12, zeros of both signs, Python floats and
    tuples as the scene gives them."""
    from latdyn.numerics.so3 import cross

    rng = np.random.default_rng(31)
    pairs = [rng.standard_normal((2, 3)) * 10.0 ** rng.uniform(-12, 12, (2, 3)) for _ in range(20_000)]
    pairs += [np.array([[0.0, -0.0, 1.0], [-0.0, 0.0, 2.0]]), np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]])]
    for a, b in pairs:
        assert cross(a, b).tobytes() == np.cross(a, b).tobytes()
    a, b = (0.1, 0.2, 0.7), [0.3, -0.9, 0.5]
    assert cross(np.array(a), b).tobytes() == np.cross(np.array(a), b).tobytes()
    assert cross(a, b).dtype == np.float64


def test_a_flow_index_and_a_yaml_error_go_to_the_python_parser():
    flow = SCENE + "  loads_at: {element: arm.element[0], quantity: torque}\n"
    assert loader._read_yaml_in_c(flow, "scene.yaml") is loader._MISSING  # `[` inside a plain scalar
    assert _read_in_python(flow)["output"]["loads_at"]["element"] == "arm.element[0]"
    broken = SCENE.replace("  every: 0.01", "  every: [0.01")
    assert loader._read_yaml_in_c(broken, "scene.yaml") is loader._MISSING
    with pytest.raises(SceneError, match=r"line \d+, column \d+.*invalid YAML"):
        latdyn.load_scene(_written(broken))
    duplicate = SCENE.replace("title: a skew", "title: one\ntitle: a skew")
    with pytest.raises(SceneError, match="duplicated key .first on line 1, again on line 2"):
        latdyn.load_scene(_written(duplicate))


def test_tabs_and_byte_order_marks_go_to_the_python_parser():
    """libyaml reads a tab after a key's colon, and drops a byte-order mark inside a value, where the
    Python scanner refuses the first and keeps the second: such text is read by the Python parser, so a
    scene loads (or is refused) the same with and without libyaml."""
    tabbed = SCENE.replace("title: a skew", "title:\ta skew")
    assert loader._read_yaml_in_c(tabbed, "scene.yaml") is loader._MISSING
    with pytest.raises(SceneError, match="invalid YAML"):
        latdyn.load_scene(_written(tabbed))
    marked = SCENE.replace("title: a skew", "title: \ufeffa skew")
    assert loader._read_yaml_in_c(marked, "scene.yaml") is loader._MISSING
    assert loader._read_yaml_in_c(SCENE.replace("\n", "\r\n"), "scene.yaml") is loader._MISSING


def test_a_close_syncs_the_state_file_a_periodic_rewrite_left_unsynced(tmp_path, monkeypatch):
    """A periodic rewrite that already holds every row leaves nothing new for the close: the close still
    syncs the file on the disk (docs/usage.md: a finished run's state.h5 is synced)."""
    import numpy as np

    from latdyn.results import state_history
    from latdyn.results.writer import ResultWriter

    synced = []
    original = state_history.fsync_path
    monkeypatch.setattr(state_history, "fsync_path", lambda path: (synced.append(Path(path).name), original(path)))
    writer = ResultWriter(tmp_path, ["x"], checkpoint_rows=3, checkpoint_min_seconds=0.0)
    for i in range(3):
        writer.record(0.1 * i, [float(i)], state={"q": np.full(2, float(i))})
    assert synced == []          # the periodic rewrite: not synced
    writer.close()
    assert any(name.startswith("state.") for name in synced)


def _written(text: str) -> str:
    import tempfile

    folder = tempfile.mkdtemp()
    path = Path(folder) / "scene.yaml"
    path.write_text(text)
    return str(path)


# ----------------------------------------------------------------------------- a band model, light
BEAM = """\
title: clamped 3D cantilever, 22 elements (132 coordinates, band LU)
sections:
  s: {EA: 1.0e7, EIy: 2.0e4, EIz: 1.0e4, GJ: 8.0e3, rhoA: 2.0, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
bodies:
  wall: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: wall, to: [2.0, 0.5, 0.3], section: s, elements: 22}
loads:
  - {at: arm.end, force: [0, 0, -10.0]}
solve: {analysis: transient, t_end: 0.01, dt: 0.002}
output:
  every: 0.002
  probes:
    w: {point: arm.end, quantity: displacement, frame: global, component: z}
"""


def test_a_band_model_runs_without_scipy_sparse(tmp_path):
    """A model above the dense LU's size whose band the step factorizes: its held check and its
    consistent start are computed in NumPy (latdyn.numerics.csr) on the package's LU, its order here,
    so a run imports neither scipy.sparse nor its linalg, csgraph or scipy.linalg (≈0.2 s of CPU at
    the start of every such run)."""
    scene = tmp_path / "beam.yaml"
    scene.write_text(BEAM)
    code = textwrap.dedent(f"""
        import json, sys
        import latdyn
        result = latdyn.run(latdyn.load_scene({str(scene)!r}), out_dir={str(tmp_path / 'out')!r})
        print(json.dumps({{"coordinates": result.summary["coordinates"], "status": result.summary["status"],
                          "loaded": sorted(m for m in ("scipy.sparse", "scipy.sparse.linalg", "scipy.sparse.csgraph",
                                                       "scipy.linalg") if m in sys.modules)}}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["status"] == "solved" and found["coordinates"] == 132
    assert found["loaded"] == []


SPIN = """
sections:
  arm: {EA: 2.8e7, EIy: 1.4e4, EIz: 1.4e4, GJ: 1.0e4, rhoA: 1.2}
bodies:
  hub:
    at: [0, 0, 0]
    motion:
      rotation:
        axis: [0, 0, 1]
        angle: "Piecewise((6/15*(t**2/2 + (15/(2*pi))**2*(cos(2*pi*t/15) - 1)), t < 15), (6*(t - 7.5), True))"
beams:
  arm: {from: hub, to: [10, 0, 0], section: arm, elements: 2}
loads:
  - {at: arm.end, force: [0, 0, "-0.1*sin(3*t)"]}
solve: {analysis: transient, t_end: 0.02, dt: 0.01}
output:
  every: 0.01
  probes:
    tip_v: {point: arm.end, quantity: position, frame: hub, component: y}
"""


def test_a_run_whose_laws_are_compiled_does_not_import_sympy(tmp_path):
    """The compiled laws are found in the cache by their text: a run of a prescribed hub angle and a load
    in t whose laws were compiled before (the first run) neither imports SymPy (0.3 s of a run's start)
    nor prints C, and its probes are the first run's to the byte."""
    scene = tmp_path / "spin.yaml"
    scene.write_text(SPIN)
    code = textwrap.dedent("""
        import json, sys
        from latdyn.cli import main
        code = main(["run", sys.argv[1], "-o", sys.argv[2], "-q"])
        print(json.dumps({"code": code, "sympy": "sympy" in sys.modules}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    found = []
    for k in range(2):
        done = subprocess.run([sys.executable, "-c", code, str(scene), str(tmp_path / f"out{k}")],
                              capture_output=True, text=True, env=env, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        found.append(json.loads(done.stdout.strip().splitlines()[-1]))
    assert found[1] == {"code": 0, "sympy": False}
    assert (tmp_path / "out0" / "probes.csv").read_bytes() == (tmp_path / "out1" / "probes.csv").read_bytes()


def test_latdyn_run_starts_one_blas_thread_unless_the_user_chose_and_the_files_are_the_same(tmp_path):
    """``latdyn run`` as its process's command starts NumPy's and SciPy's OpenBLAS with one thread (their
    pools' start and spinning: ~80 ms of CPU of a lattice's run), a thread count the user set is kept,
    ``main([...])`` called in a process leaves its threads alone, and the probes are the API's, run in a
    process with the default threads, to the byte."""
    scene = tmp_path / "beam.yaml"
    scene.write_text(BEAM)
    code = textwrap.dedent("""
        import json, os, sys
        from latdyn.cli import main
        out, called = sys.argv[1], sys.argv[2] == "argv"
        sys.argv = ["latdyn", "run", os.environ["SCENE"], "-o", out, "-q"]
        code = main(sys.argv[1:]) if called else main()
        import threadpoolctl
        threads = sorted({lib["num_threads"] for lib in threadpoolctl.threadpool_info() if lib["internal_api"] == "openblas"})
        print(json.dumps({"code": code, "threads": threads, "variable": os.environ.get("OPENBLAS_NUM_THREADS")}))
        """)
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    env.update(PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), SCENE=str(scene))
    found = {}
    for name, how, extra in (("command", "main", {}), ("chosen", "main", {"OPENBLAS_NUM_THREADS": "2"}),
                             ("called", "argv", {})):
        done = subprocess.run([sys.executable, "-c", code, str(tmp_path / name), how], capture_output=True,
                              text=True, env={**env, **extra}, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        found[name] = json.loads(done.stdout.strip().splitlines()[-1])
    assert found["command"] == {"code": 0, "threads": [1], "variable": "1"}
    assert found["chosen"] == {"code": 0, "threads": [2], "variable": "2"}
    assert found["called"]["code"] == 0 and found["called"]["variable"] is None
    assert found["called"]["threads"] != [1] or (os.cpu_count() or 1) == 1  # OpenBLAS's default: a thread a core
    latdyn.run(latdyn.load_scene(str(scene)), out_dir=str(tmp_path / "api"))
    for name in ("command", "chosen", "called"):
        assert (tmp_path / name / "probes.csv").read_bytes() == (tmp_path / "api" / "probes.csv").read_bytes()


def test_latdyn_run_collects_less_often_as_its_process_command_and_the_files_are_the_same(tmp_path):
    """``latdyn run`` as its process's command raises the collector's first threshold (700 ->
    cli.RUN_COLLECTOR_THRESHOLD: its start's passes found nothing to free); ``main([...])`` called in a
    process leaves the collector's thresholds alone; the probes and state are the API's to the byte."""
    import gc

    from latdyn import cli

    scene = tmp_path / "beam.yaml"
    scene.write_text(BEAM)
    code = textwrap.dedent("""
        import gc, json, os, sys
        from latdyn.cli import main
        out, called = sys.argv[1], sys.argv[2] == "argv"
        before = gc.get_threshold()
        sys.argv = ["latdyn", "run", os.environ["SCENE"], "-o", out, "-q"]
        code = main(sys.argv[1:]) if called else main()
        print(json.dumps({"code": code, "before": before, "after": gc.get_threshold()}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), SCENE=str(scene))
    found = {}
    for name in ("command", "argv"):
        done = subprocess.run([sys.executable, "-c", code, str(tmp_path / name), name], capture_output=True,
                              text=True, env=env, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        found[name] = json.loads(done.stdout.strip().splitlines()[-1])
    default = list(gc.get_threshold())
    assert found["command"]["code"] == 0 and found["command"]["before"] == default
    assert found["command"]["after"] == [cli.RUN_COLLECTOR_THRESHOLD] + default[1:]
    assert found["argv"] == {"code": 0, "before": default, "after": default}
    latdyn.run(latdyn.load_scene(str(scene)), out_dir=str(tmp_path / "api"))
    for name in ("command", "argv"):
        for file in ("probes.csv",):
            assert (tmp_path / name / file).read_bytes() == (tmp_path / "api" / file).read_bytes()


# ----------------------------------------------------------------------------- the end of the process
def test_the_command_leaves_complete_files_and_a_call_in_process_keeps_the_collector(tmp_path):
    """``python -m latdyn run`` freezes the garbage collector at its start and end (cli._freeze_collector):
    the results it leaves are complete (summary.json solved, the rows of every step, state.h5 and
    the ParaView files readable); ``cli.main([...])`` called in a process that goes on (a test, a
    notebook) leaves its collector as it was."""
    import gc

    import h5py

    from cli_runs import latdyn_run, probe_columns, summary_of
    from latdyn import cli

    done, out = latdyn_run(tmp_path, BEAM, quiet=True)
    assert done.returncode == 0, done.stderr
    summary = summary_of(out)
    assert summary["status"] == "solved" and summary["rows"] == 6
    assert len(probe_columns(out)["w"]) == 6
    with h5py.File(out / "state.h5") as f:
        assert f["t"].shape == (6,)
    for name in summary["paraview_files"]:
        with h5py.File(out / name) as f:
            assert len(f["VTKHDF"]["Steps"]["Values"]) == summary["paraview_frames"]
    frozen = gc.get_freeze_count()
    assert cli.main(["check", str(tmp_path / "scene.yaml")]) == 0
    assert gc.get_freeze_count() == frozen


#: A ``sitecustomize`` that leaves an object whose finalizer writes TEARDOWN_MARK as the interpreter tears
#: down its modules (not at ``os._exit``), and an atexit function that writes ATEXIT_MARK (run either way).
TEARDOWN_PROBE = """\
import atexit, os, sys

class _Teardown:
    def __del__(self, open=open, mark=os.environ["TEARDOWN_MARK"]):  # bound now: builtins go at teardown
        open(mark, "w").close()

sys._latdyn_teardown_probe = _Teardown()
atexit.register(lambda: open(os.environ["ATEXIT_MARK"], "w").close())
"""


def _run_probed(tmp_path, arguments, *, code=None):
    """``python -m latdyn ARGUMENTS`` (or ``python -c CODE``) with :data:`TEARDOWN_PROBE` loaded: (the
    completed process, whether the teardown ran, whether the atexit function ran)."""
    probe = tmp_path / "probe"
    probe.mkdir(exist_ok=True)
    (probe / "sitecustomize.py").write_text(TEARDOWN_PROBE)
    marks = {"TEARDOWN_MARK": tmp_path / "teardown.mark", "ATEXIT_MARK": tmp_path / "atexit.mark"}
    for mark in marks.values():
        mark.unlink(missing_ok=True)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(probe), str(ROOT), os.environ.get("PYTHONPATH", "")]),
               **{k: str(v) for k, v in marks.items()})
    command = [sys.executable, "-m", "latdyn", *arguments] if code is None else [sys.executable, "-c", code]
    done = subprocess.run(command, env=env, capture_output=True, text=True, cwd=tmp_path, timeout=120)
    return done, marks["TEARDOWN_MARK"].exists(), marks["ATEXIT_MARK"].exists()


def test_the_run_command_ends_without_the_teardown_its_files_complete_its_messages_and_statuses_kept(tmp_path):
    """``python -m latdyn run`` ends its process after the atexit functions and the flush of its output,
    without the interpreter's teardown (cli._end_without_teardown): the results are complete (summary.json
    solved, every row in probes.csv, state.h5 and the ParaView files readable), the line on stdout reaches
    the pipe, and a bad scene still exits 2 with its message; ``latdyn check`` ends as before."""
    import h5py

    from cli_runs import probe_columns, summary_of

    (tmp_path / "scene.yaml").write_text(BEAM)
    done, teardown, atexit_ran = _run_probed(tmp_path, ["run", "scene.yaml", "-o", "out"])
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("latdyn: solved -> ") and done.stdout.endswith("wall time\n")
    assert atexit_ran and not teardown
    out = tmp_path / "out"
    summary = summary_of(out)
    assert summary["status"] == "solved" and summary["rows"] == 6
    assert len(probe_columns(out)["w"]) == 6
    with h5py.File(out / "state.h5") as f:
        assert f["t"].shape == (6,)
    for name in summary["paraview_files"]:
        with h5py.File(out / name) as f:
            assert len(f["VTKHDF"]["Steps"]["Values"]) == summary["paraview_frames"]
    (tmp_path / "bad.yaml").write_text(BEAM.replace("rhoA: 2.0", "rhoA: heavy"))
    done, teardown, atexit_ran = _run_probed(tmp_path, ["run", "bad.yaml", "-o", "bad"])
    assert done.returncode == 2 and "bad.yaml" in done.stderr and "rhoA" in done.stderr
    assert atexit_ran and not teardown and not (tmp_path / "bad").exists()
    done, teardown, atexit_ran = _run_probed(tmp_path, ["check", "scene.yaml"])
    assert done.returncode == 0 and atexit_ran and teardown


def test_a_program_that_goes_on_after_the_command_is_not_ended_by_it(tmp_path):
    """``main()`` called from a user's own program (``python -c``), or under a profiler, returns: what the
    program does after it runs, and the interpreter ends as always (teardown included)."""
    (tmp_path / "scene.yaml").write_text(BEAM)
    code = ("import sys; from latdyn.cli import main; sys.argv = ['latdyn', 'run', 'scene.yaml', '-o', 'out', '-q']; "
            "status = main(); print('after', status)")
    done, teardown, atexit_ran = _run_probed(tmp_path, [], code=code)
    assert done.returncode == 0 and done.stdout.endswith("after 0\n") and teardown and atexit_ran
    done, teardown, _ = _run_probed(tmp_path, ["run", "scene.yaml", "-o", "out2", "-q"], code=(
        "import cProfile, runpy, sys; sys.argv = ['latdyn', 'run', 'scene.yaml', '-o', 'out2', '-q']; "
        "cProfile.run(\"runpy.run_module('latdyn', run_name='__main__')\", 'profile.out')"))
    assert done.returncode == 0 and teardown and (tmp_path / "profile.out").exists()


def test_a_file_left_open_for_writing_keeps_the_teardown(tmp_path):
    """Where the process holds a file open for writing besides stdin, stdout and stderr, the command does
    not end without the teardown (cli._open_for_writing: nothing buffered in it may be lost); a file open
    for reading does not count. In a fresh process (pytest's capture holds files open for writing)."""
    code = textwrap.dedent(f"""
        from latdyn import cli
        print(cli._open_for_writing())
        with open({str(tmp_path / "held.txt")!r}, "w"):
            print(cli._open_for_writing())
        with open({str(tmp_path / "held.txt")!r}):
            print(cli._open_for_writing())
    """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60)
    assert done.stdout.split() == ["False", "True", "False"], done.stderr


def test_a_short_run_writes_its_state_history_once_and_an_asked_checkpoint_at_once(tmp_path):
    """``checkpoint_min_seconds`` (a run's writer: 1 s): rows due by count are not rewritten before it;
    the close writes every row; a checkpoint asked for (a resume checkpoint's) is written at once."""
    from latdyn.results.state_history import FIRST_CHUNK_ROWS, STATE_H5_FILE
    from latdyn.results.writer import RUN_CHECKPOINT_MIN_SECONDS, ResultWriter, load_state_history

    assert RUN_CHECKPOINT_MIN_SECONDS == 1.0
    with ResultWriter(tmp_path, ["x"], checkpoint_rows=2, checkpoint_min_seconds=1e9) as writer:
        for i in range(10):
            writer.record(0.1 * i, [float(i)], state={"q": np.full(3, float(i))})
        assert not (tmp_path / STATE_H5_FILE).exists()  # due by count, held back by the minimum
        writer.checkpoint()
        np.testing.assert_array_equal(load_state_history(tmp_path)["q"][:, 0], np.arange(10.0))
        for i in range(10, 13):
            writer.record(0.1 * i, [float(i)], state={"q": np.full(3, float(i))})
    np.testing.assert_array_equal(load_state_history(tmp_path)["q"][:, 0], np.arange(13.0))


def test_a_short_runs_state_file_holds_its_rows_not_empty_chunks(tmp_path):
    """state.h5's chunks hold no more rows than the file's first write brings (at least
    ``FIRST_CHUNK_ROWS``; at most 1024 rows and 2 MiB, as before): a run written once, at its close,
    makes a file of about the size of its rows (the 16-bay lattice's 141 rows: 7.2 MB in chunks of
    1024 rows, 1.5 MB now); rows appended later fill further chunks and read back equal."""
    import h5py

    from latdyn.results.state_history import FIRST_CHUNK_ROWS, STATE_H5_FILE
    from latdyn.results.writer import ResultWriter, load_state_history

    width = 600  # 2 MiB / 8 bytes / 600 = 436 rows a chunk before
    for first, later in ((141, 0), (10, 0), (141, 300)):
        out = tmp_path / f"rows_{first}_{later}"
        with ResultWriter(out, ["x"], checkpoint_min_seconds=1e9) as writer:
            for i in range(first + later):
                if i == first:
                    writer.checkpoint()
                writer.record(0.1 * i, [float(i)], state={"T": np.full(width, float(i))})
        with h5py.File(out / STATE_H5_FILE) as f:
            assert f["T"].chunks == (max(FIRST_CHUNK_ROWS, first), width)
        np.testing.assert_array_equal(load_state_history(out)["T"][:, -1], np.arange(first + later, dtype=float))
        chunks = -(-(first + later) // max(FIRST_CHUNK_ROWS, first))
        assert (out / STATE_H5_FILE).stat().st_size < 8 * width * max(FIRST_CHUNK_ROWS, first) * chunks + 64_000


# ----------------------------------------------------------------------------- sparse products in NumPy
def _random_csr(rng, n_rows, n_cols, density):
    sps = pytest.importorskip("scipy.sparse")
    m = int(density * n_rows * n_cols)
    rows, cols = rng.integers(0, n_rows, m), rng.integers(0, n_cols, m)
    values = rng.standard_normal(m) * 10.0 ** rng.integers(-8, 8, m)
    values[::7] = 0.0  # structural zeros, kept
    values[3::11] = -0.0
    ours = CSR.from_coo(values, rows, cols, (n_rows, n_cols))
    theirs = sps.csr_matrix((values, (rows, cols)), shape=(n_rows, n_cols))
    return ours, theirs


def _same_bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("direct_keys", [None, 0])
def test_csr_products_are_scipys_to_the_last_bit(direct_keys, monkeypatch):
    """SciPy's A.T @ B (CSR A and B), A @ x and A.T @ x, and A.T.tocsr(): the same entries, the same
    bits (each sum's terms in SciPy's order, exact zeros dropped from the products); the products'
    sums in a dense array (small products) and by sorted keys (``DIRECT_KEYS`` 0) alike."""
    if direct_keys is not None:
        import latdyn.numerics.csr as csr

        monkeypatch.setattr(csr, "DIRECT_KEYS", direct_keys)
    rng = np.random.default_rng(11)
    for trial in range(40):
        n, p, q = (int(rng.integers(1, 60)) for _ in range(3))
        a, a_ref = _random_csr(rng, n, p, 0.15)
        b, b_ref = _random_csr(rng, n, q, 0.15)
        product = (a_ref.T @ b_ref).tocsr()
        product.sort_indices()
        ours = transposed_product(a, b)
        assert _same_bits(ours.indptr, product.indptr.astype(np.int64))
        assert _same_bits(ours.indices, product.indices.astype(np.int64)) and _same_bits(ours.data, product.data)
        x, y = rng.standard_normal(p), rng.standard_normal(n)
        assert _same_bits(a.matvec(x), a_ref @ x) and _same_bits(a.rmatvec(y), a_ref.T @ y)
        t = a_ref.T.tocsr()
        t.sort_indices()
        assert _same_bits(transposed(a).data, t.data) and _same_bits(transposed(a).indices, t.indices.astype(np.int64))


def test_the_impulses_csr_operations_are_scipys_to_the_last_bit():
    """What the latch's impulse does without SciPy (latdyn.timeloop.impulse._response on _OwnMatrices) against what it does with
    SciPy's matrices: M + h²K on one pattern with its zeros dropped, a basis's columns, Q_cᵀ K Q_c and Q_mᵀ K Q_c,
    the block matrix, Q X and Q_cᵀ X for X of several columns: the same entries, the same bits."""
    sps = pytest.importorskip("scipy.sparse")
    rng = np.random.default_rng(31)
    h2 = 0.002 ** 2
    for trial in range(40):
        n = int(rng.integers(2, 60))
        m, m_ref = _random_csr(rng, n, n, 0.2)
        values = rng.standard_normal(len(m.data)) * 10.0 ** rng.integers(-4, 8, len(m.data))
        values[::5] = -m.data[::5] / h2   # sums that cancel
        k = CSR(m.shape, m.indptr, m.indices, values)
        k_ref = sps.csr_matrix((values, m.indices, m.indptr), shape=m.shape)
        assert _same_bits(csr.nonzero(CSR(m.shape, m.indptr, m.indices, m.data + h2 * k.data)).data,
                          (m_ref + h2 * k_ref).tocsr().data)
        quasi_static, quasi_static_ref = csr.nonzero(CSR(m.shape, m.indptr, m.indices, m.data + h2 * k.data)), \
            (m_ref + h2 * k_ref).tocsr()
        assert _same_bits(quasi_static.indices, quasi_static_ref.indices.astype(np.int64))
        basis, basis_ref = _random_csr(rng, n, n, 0.1)
        split = int(rng.integers(1, n))
        qm, qc = csr.columns(basis, 0, split), csr.columns(basis, split, n)
        qm_ref, qc_ref = basis_ref[:, :split], basis_ref[:, split:]
        kc = csr.transposed_product(qc, k)
        made = (csr.product(kc, qc), csr.product(kc, qm), csr.product(csr.transposed_product(qm, quasi_static), qm))
        expected = ((qc_ref.T @ k_ref @ qc_ref).tocsr(), (qc_ref.T @ k_ref @ qm_ref).tocsr(),
                    (qm_ref.T @ quasi_static_ref @ qm_ref).tocsr())
        for ours, theirs in zip(made, expected):
            theirs.sort_indices()
            assert _same_bits(ours.indptr, theirs.indptr.astype(np.int64))
            assert _same_bits(ours.indices, theirs.indices.astype(np.int64)) and _same_bits(ours.data, theirs.data)
        coupling = csr.product(csr.transposed_product(qm, k), qc)
        ours = csr.blocks(made[2], CSR(coupling.shape, coupling.indptr, coupling.indices, coupling.data * h2),
                          made[1], made[0])
        theirs = sps.bmat([[qm_ref.T @ quasi_static_ref @ qm_ref, h2 * (qm_ref.T @ k_ref @ qc_ref)],
                           [expected[1], expected[0]]], format="csr")
        assert _same_bits(ours.indices, theirs.indices.astype(np.int64)) and _same_bits(ours.data, theirs.data)
        x = rng.standard_normal((n, 3))
        assert _same_bits(csr.times(basis, x), basis_ref @ x)
        assert _same_bits(csr.transposed_times(qc, x), qc_ref.T @ x)


def test_the_consistent_start_without_scipy_is_the_splits_to_round_off(monkeypatch):
    """The start's Δv̇ of a 3D frame of 324 coordinates, every direction with inertia, at a random moving
    state: without SciPy it is −M⁻¹ r solved on M's own pattern, Jacobi-scaled (integrators.inverse_mass_times);
    through SciPy's sparse matrices Q_m (Q_mᵀ M Q_m)⁻¹ (−Q_mᵀ r) with the split's square Q_m. The same
    to round-off (measured 2.7e-14 of the largest), and both satisfy M Δv̇ = −r to round-off."""
    from test_linalg import lattice

    import latdyn.step.integrators as integrators
    from latdyn.assembly.prepare import prepare

    prepared = prepare(lattice(4, 4))
    assert integrators.start_without_scipy(prepared.model)
    rng = np.random.default_rng(5)
    state = prepared.state.copy()
    state.x[:] += 1e-3 * rng.standard_normal(state.x.shape)
    state.v[:] += 0.1 * rng.standard_normal(state.v.shape)
    state.w[:] += 0.1 * rng.standard_normal(state.w.shape)
    evaluation = prepared.assembler.evaluate(state, matrices=True)
    ours = integrators.consistent_acceleration(prepared.model, evaluation)
    monkeypatch.setattr(integrators, "start_without_scipy", lambda model: False)  # restored after the test
    theirs = integrators.consistent_acceleration(prepared.model, evaluation)
    largest = np.max(np.abs(theirs))
    assert largest > 1.0 and np.max(np.abs(ours - theirs)) <= 1e-12 * largest
    mass, residual = evaluation.combined_csr(1.0, 0.0, 0.0), evaluation.residual
    for delta in (ours, theirs):
        assert np.max(np.abs(mass.matvec(delta) + residual)) <= 1e-13 * np.max(np.abs(residual))


def test_a_mid_size_model_with_a_coordinate_nothing_holds_is_refused_by_the_numpy_check():
    """The held check in NumPy (numerics.csr, the package's LU) of a 3D frame above the dense LU's
    size: a tail beam free to spin about its own axis on a hinge is refused, naming it."""
    from test_linalg import lattice

    raw = lattice(4, 4)
    latdyn.load_scene(raw)
    raw["bodies"]["loose"] = {"at": [10.0, 0.0, 0.0]}
    raw["beams"]["tail"] = {"from": "j0_0_1", "to": "loose", "section": "s", "elements": 2,
                            "end": {"hinge": {"axis": [1, 0, 0]}}}  # the tail's own axis: spin unheld
    with pytest.raises(SceneError, match="nothing holds") as info:
        from latdyn.assembly.prepare import prepare

        prepare(raw)
    assert "bodies.loose" in str(info.value) or "beams.tail.end.hinge" in str(info.value)


def _spd_band(n: int, rng) -> np.ndarray:
    """A symmetric positive definite matrix with unit diagonal, banded in a shuffled numbering."""
    band = np.zeros((n, n))
    for k in range(1, 9):
        band += np.diag(rng.uniform(-0.3, 0.3, n - k), k)
    A = band + band.T
    A = A @ A.T + 1e-3 * np.eye(n)  # wider band, positive definite
    d = 1.0 / np.sqrt(np.diag(A))
    order = rng.permutation(n)
    return (d[:, None] * A * d[None, :])[np.ix_(order, order)]


def test_the_banded_cholesky_decides_positive_definiteness_where_the_eigenvalues_do():
    """Factorization.positive_definite(A, s): A − s·I positive definite, by LAPACK's banded Cholesky in the
    pattern's reverse Cuthill–McKee order: True for s just below λ_min (by 1e-9 of it), False just above,
    on shuffled band matrices (unsymmetric storage: its symmetric part counts); None where the band is
    wider than BAND_LIMIT."""
    from latdyn.assembly.factorization import Factorization
    from latdyn.numerics.linalg import BAND_LIMIT

    rng = np.random.default_rng(3)
    for n in (130, 200, 400):
        A = _spd_band(n, rng)
        skew = np.triu(rng.uniform(-1e-3, 1e-3, (n, n)) * (A != 0), 1)
        stored = A + skew - skew.T  # the same symmetric part
        lowest = np.linalg.eigvalsh(A)[0]
        rows, cols = np.nonzero(stored)
        matrix = CSR.from_coo(stored[rows, cols], rows, cols, (n, n))
        assert Factorization.positive_definite(matrix, lowest * (1 - 1e-9)) is True
        assert Factorization.positive_definite(matrix, lowest * (1 + 1e-9)) is False
        singular = A - lowest * np.eye(n)  # a null direction, as an unheld coordinate gives
        rows, cols = np.nonzero(singular)
        matrix = CSR.from_coo(singular[rows, cols], rows, cols, (n, n))
        assert Factorization.positive_definite(matrix, 2e-10) is False
    n = 3 * BAND_LIMIT
    dense = np.eye(n) + 1e-3 * (np.eye(n, k=n - 1) + np.eye(n, k=1 - n))  # a ring: its band is wide
    dense[0, n // 2] = dense[n // 2, 0] = 1e-3
    dense[n // 4, 3 * n // 4] = dense[3 * n // 4, n // 4] = 1e-3
    rows, cols = np.nonzero(np.ones((n, n)))
    assert Factorization.positive_definite(CSR.from_coo(np.ravel(dense), rows, cols, (n, n)), 0.0) is None


def test_a_held_mid_size_model_is_decided_by_the_cholesky_and_an_unheld_one_named_as_before(monkeypatch):
    """The held check of a mid-size model (numerics.csr): a held 3D frame is proven held by one banded
    Cholesky of A − 2·HELD_TOLERANCE·I (no inverse iteration runs); the frame with a tail free to spin about
    its own axis is not, and the inverse iteration names it as before."""
    import latdyn.model.model as model_module
    from test_linalg import lattice

    from latdyn.assembly.prepare import prepare

    def no_iteration(*args, **kwargs):
        raise AssertionError("the inverse iteration ran for a held model")

    with monkeypatch.context() as patched:
        patched.setattr(model_module, "psd_null_direction", no_iteration)
        prepare(lattice(4, 4))
    raw = lattice(4, 4)
    raw["bodies"]["loose"] = {"at": [10.0, 0.0, 0.0]}
    raw["beams"]["tail"] = {"from": "j0_0_1", "to": "loose", "section": "s", "elements": 2,
                            "end": {"hinge": {"axis": [1, 0, 0]}}}
    with pytest.raises(SceneError, match="nothing holds") as info:
        prepare(raw)
    assert "bodies.loose" in str(info.value) or "beams.tail.end.hinge" in str(info.value)


def test_the_order_of_a_pattern_ordered_again_is_the_same_and_a_copy():
    """A run orders the same pattern twice (the held check, the step's matrix): the second call gives the
    first's order without searching again, as a copy the caller may change; another pattern its own."""
    from latdyn.numerics import linalg

    (rows, cols, n), (other_rows, other_cols, _) = [p for p in _patterns() if p[2] > 20][:2]
    first = reverse_cuthill_mckee(rows, cols, n)
    first[:] = -1  # the caller's copy
    again = reverse_cuthill_mckee(rows.copy(), cols.copy(), n)
    assert np.array_equal(again, linalg._reverse_cuthill_mckee(rows, cols, n))
    shifted = (other_cols[: len(other_rows)] + 1) % n
    assert np.array_equal(reverse_cuthill_mckee(other_rows, shifted, n),
                          linalg._reverse_cuthill_mckee(other_rows, shifted, n))


# ----------------------------------------------------------------------------- ParaView frames in blocks
def _h5_datasets(path: Path) -> dict:
    import h5py

    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, item: out.__setitem__(name, (item[()], item.maxshape, dict(item.attrs)))
                     if isinstance(item, h5py.Dataset) else out.__setitem__(name, dict(item.attrs)))
    return out


def _same_datasets(a: dict, b: dict) -> bool:
    if a.keys() != b.keys():
        return False
    for name, x in a.items():
        y = b[name]
        if isinstance(x, dict):
            if x.keys() != y.keys() or any(not np.array_equal(x[k], y[k]) for k in x):
                return False
        elif (x[0].dtype, x[0].shape, x[1]) != (y[0].dtype, y[0].shape, y[1]) \
                or x[0].tobytes() != y[0].tobytes():
            return False
    return True


@pytest.mark.parametrize("frame_block", [256, 3])
def test_frames_written_as_a_block_are_the_files_of_frames_written_one_at_a_time(tmp_path, monkeypatch, frame_block):
    """A block of rows' frames (paraview.FrameBlock, as the loop of steps records them) goes to the files
    in one write a dataset; the files equal those of the same frames recorded one by one, with a block
    larger than FRAME_BLOCK split (frame_block 3) and a last frame the schedule skipped."""
    from latdyn.results import paraview

    monkeypatch.setattr(paraview, "FRAME_BLOCK", frame_block)
    rng = np.random.default_rng(3)
    m, n_points, n_cells = 11, 5, 4
    mesh = {"beams": {"n_points": n_points, "cells": [("line", np.array([[0, 1], [1, 2], [2, 3], [3, 4]]))],
                      "cell_data": {"beam": np.arange(n_cells, dtype=float)}},
            "bodies": {"n_points": 2, "cells": [("vertex", np.array([[0], [1]]))], "cell_data": {}}}
    block = paraview.FrameBlock(m, {
        "beams": {"points": rng.normal(size=(m, n_points, 3)),
                  "point_data": {"velocity": rng.normal(size=(m, n_points, 3)), "u": rng.normal(size=(m, n_points))},
                  "cell_data": {"N": rng.normal(size=(m, n_cells)), "M": rng.normal(size=(m, n_cells, 2))}},
        "bodies": {"points": rng.normal(size=(m, 2, 3)), "point_data": {"axis_x": rng.normal(size=(m, 2, 3))},
                   "cell_data": {}}})
    times = [0.1 * k for k in range(m + 1)]

    class Frames:
        def __call__(self, r):
            return block[min(r, m - 1)]

        def many(self, rows):
            return block if rows == list(range(m)) else None

    together = paraview.ParaviewWriter(tmp_path / "a", mesh, every=None)
    together.record_rows(times[:m], Frames())
    assert together._files["beams"].steps == (9 if frame_block == 3 else 0)  # whole blocks of ≤ FRAME_BLOCK written
    together.close()
    one_by_one = paraview.ParaviewWriter(tmp_path / "b", mesh, every=None)
    for r in range(m):
        one_by_one.record(times[r], block[r])
    one_by_one.close()
    assert together.frames == one_by_one.frames == m
    for name in ("beams.vtkhdf", "bodies.vtkhdf"):
        a, b = _h5_datasets(tmp_path / "a" / name), _h5_datasets(tmp_path / "b" / name)
        assert _same_datasets(a, b), name
        assert len(a["VTKHDF/Steps/Values"][0]) == m and a["VTKHDF/Steps"]["NSteps"] == m
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["beams.vtkhdf", "bodies.vtkhdf"]  # no .tmp left
    # a frame of the wrong size in a block is refused as one recorded alone is
    bad = paraview.FrameBlock(2, {"beams": {**block.parts["beams"], "points": np.zeros((2, n_points + 1, 3))},
                                  "bodies": block.parts["bodies"]})
    writer = paraview.ParaviewWriter(tmp_path / "c", mesh, every=None)
    with pytest.raises(ValueError, match="has 6 points, the mesh has 5"):
        writer.record_rows(times[:2], type("F", (), {"__call__": lambda self, r: bad[r], "many": lambda self, rows: bad})())


def test_a_new_paraview_file_is_readable_under_its_name_while_the_run_goes_on(tmp_path):
    """The first frame creates the file under a temporary name, complete on disk before it takes its own
    name, and kept open for appending without a lock: another reader opens it at once."""
    import h5py

    from latdyn.results import paraview

    mesh = {"beams": {"n_points": 2, "cells": [("line", np.array([[0, 1]]))], "cell_data": {}}}
    writer = paraview.ParaviewWriter(tmp_path, mesh, every=None)
    writer.record(0.0, {"beams": {"points": np.eye(3)[:2], "point_data": {"u": np.ones(2)}, "cell_data": {}}})
    writer.write_pending()
    with h5py.File(tmp_path / "beams.vtkhdf", "r", locking=False) as f:
        assert int(f["VTKHDF/Steps"].attrs["NSteps"]) == 1 and f["VTKHDF/Points"].shape == (2, 3)
    assert not (tmp_path / "beams.vtkhdf.tmp").exists()
    writer.close()


def test_where_an_open_file_cannot_be_renamed_the_new_paraview_file_is_closed_renamed_and_reopened(
        tmp_path, monkeypatch):
    """A platform that renames no open file (Windows): the new file is closed, renamed and opened again,
    and the files are those of the ordinary path."""
    from latdyn.results import paraview

    mesh = {"beams": {"n_points": 2, "cells": [("line", np.array([[0, 1]]))], "cell_data": {"beam": np.zeros(1)}}}
    frames = [{"beams": {"points": np.eye(3)[:2] * (k + 1), "point_data": {"u": np.full(2, k)},
                         "cell_data": {"N": np.full(1, -k)}}} for k in range(3)]

    def write(folder):
        writer = paraview.ParaviewWriter(folder, mesh, every=None)
        for k, frame in enumerate(frames):
            writer.record(0.5 * k, frame)
        writer.close()

    write(tmp_path / "a")
    replace, refused = Path.replace, []

    def no_open_rename(self, target):
        if self.name.endswith(".tmp") and not refused:
            refused.append(self.name)
            raise PermissionError("the file is open")
        return replace(self, target)

    monkeypatch.setattr(Path, "replace", no_open_rename)
    write(tmp_path / "b")
    assert refused == ["beams.vtkhdf.tmp"]
    assert _same_datasets(_h5_datasets(tmp_path / "a" / "beams.vtkhdf"), _h5_datasets(tmp_path / "b" / "beams.vtkhdf"))


def test_a_list_of_labels_is_stored_as_h5py_stores_it(tmp_path):
    """state.h5's attributes, written by latdyn's own HDF5 writer: the same attribute (type, character
    set, shape, values) as h5py's own guess for a list of str, an empty list, numbers and a str; a
    list mixing str and numbers is refused."""
    import h5py

    from latdyn.results import hdf5_writer

    values = {"labels": ["x:0", "ü:1", ""], "empty": [], "numbers": [1.0, 2.0], "text": "a"}
    ours = hdf5_writer.File(tmp_path / "a.h5", header_version=2)
    for name, value in values.items():
        ours.root.set_attribute(name, value)
    with pytest.raises(ValueError, match="attribute 'mixed'"):
        ours.root.set_attribute("mixed", ["a", 1])
    ours.close()
    with h5py.File(tmp_path / "b.h5", "w", libver=("v108", "latest")) as theirs:
        for name, value in values.items():
            theirs.attrs[name] = value
    with h5py.File(tmp_path / "a.h5", "r") as ours, h5py.File(tmp_path / "b.h5", "r") as theirs:
        assert sorted(ours.attrs) == sorted(values)
        for name in values:
            a, b = ours.attrs.get_id(name), theirs.attrs.get_id(name)
            assert a.get_type().equal(b.get_type()) and a.shape == b.shape, name
            assert np.array_equal(np.asarray(ours.attrs[name]), np.asarray(theirs.attrs[name])), name


@pytest.mark.parametrize("width, dtype, chunks, fillvalue",
                         [((3,), "f8", (4000, 3), None), ((), "f8", (1024,), None), ((), "i8", (1024,), 1),
                          ((), "i8", (1024,), 0), ((1,), "i8", (1024, 1), None), ((6,), "f8", (12, 6), None)])
def test_a_paraview_files_growing_dataset_is_the_one_h5py_creates(tmp_path, width, dtype, chunks, fillvalue):
    """The ParaView files' growing datasets, written by latdyn's own HDF5 writer, have the creation
    properties (chunks, fill value and its time, allocation, no times tracked, no filters), type and
    space of h5py's ``create_dataset`` with the same options, the fill value where nothing was written,
    and a hard link to one is the same dataset."""
    import h5py

    from latdyn.results import hdf5_writer

    f = hdf5_writer.File(tmp_path / "a.h5")
    ours = f.root.create_growing("d", width, dtype, chunks, fillvalue=fillvalue)
    ours.grow(5)
    f.root.link("offsets/also", ours)
    f.close()
    with h5py.File(tmp_path / "b.h5", "w") as g:
        theirs = g.create_dataset("d", shape=(0, *width), maxshape=(None, *width), dtype=dtype, chunks=chunks,
                                  track_times=False, **({} if fillvalue is None else {"fillvalue": fillvalue}))
        theirs.resize((5, *width))
    with h5py.File(tmp_path / "a.h5", "r") as f, h5py.File(tmp_path / "b.h5", "r") as g:
        ours, theirs = f["d"], g["d"]
        assert ours.id.get_create_plist().equal(theirs.id.get_create_plist())
        assert (ours.dtype, ours.shape, ours.maxshape, ours.chunks, ours.fillvalue) == \
               (theirs.dtype, theirs.shape, theirs.maxshape, theirs.chunks, theirs.fillvalue)
        assert ours.id.get_type().equal(theirs.id.get_type())
        assert np.array_equal(ours[()], theirs[()])  # the fill value where nothing was written
        assert f["offsets/also"] == ours and f["offsets"].get("also", getlink=True).__class__ is h5py.HardLink


BLOCK_FRAMES_SCENE = """\
    title: a 3D arm of two flexible beams with a joint body, a hinge and a tip load
    gravity: [0, -2.0, -9.81]
    sections:
      s: {EA: 1.0e6, EIy: 300, EIz: 500, GJ: 400, rhoA: 1.0, rhoIy: 1.0e-3, rhoIz: 1.0e-3}
    bodies:
      base: {at: [0, 0, 0], fixed: true}
      elbow: {at: [1, 0, 0], mass: 0.5, inertia: [1.0e-3, 2.0e-3, 3.0e-3]}
      tip: {at: [1.5, 0.5, 0.2], mass: 0.2}
    beams:
      a: {from: base, to: {body: elbow, offset: [-0.1, 0, 0]}, section: s, elements: 3,
          start: {hinge: {axis: [0, 0, 1], torque: "1.0"}}}
      b: {from: elbow, to: tip, section: s, elements: 3, y_axis: [0, 0, 1]}
    loads:
      - {at: tip, force: [0, 0, "-2*sin(20*t)"]}
    solve: {analysis: transient, t_end: 0.06, dt: 0.002}
    output:
      paraview_every: 0.004
      probes:
        tip_z: {point: tip, quantity: position, component: z}
        my: {element: b.element[1], quantity: moment_y}
    """


@pytest.mark.parametrize("every, frames", [(0.004, 16), (0.002, 31)], ids=["every-other-row", "every-row"])
def test_a_runs_frames_in_blocks_are_its_frames_row_by_row(tmp_path, monkeypatch, every, frames):
    """A 3D run's ParaView files through the CLI (the rows' frames computed and written a block at a time)
    equal, dataset for dataset and bit for bit, those of the same scene through the API with every
    frame computed and written row by row (paraview.frame), and so do its probes; a frame every row
    takes the block's states as slices (TimeLoop._frames_of), every other row as copies."""
    from latdyn.timeloop.loop import TimeLoop

    scene = tmp_path / "arm.yaml"
    scene.write_text(textwrap.dedent(BLOCK_FRAMES_SCENE).replace("paraview_every: 0.004", f"paraview_every: {every}"))
    done = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "blocks"), "-q"],
                          capture_output=True, text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr
    asked = []
    monkeypatch.setattr(TimeLoop, "_frames_of", lambda self, block, rows: asked.append(len(rows)))  # None: row by row
    latdyn.run(latdyn.load_scene(scene), out_dir=tmp_path / "rows")
    assert asked and max(asked) > 1  # the blocks' frames were asked for, and given row by row
    for name in ("beams.vtkhdf", "bodies.vtkhdf"):
        blocks, rows = (_h5_datasets(tmp_path / k / "paraview" / name) for k in ("blocks", "rows"))
        assert _same_datasets(blocks, rows), name
        assert len(blocks["VTKHDF/Steps/Values"][0]) == frames  # t = 0, every, …, 0.06
    assert (tmp_path / "blocks" / "probes.csv").read_bytes() == (tmp_path / "rows" / "probes.csv").read_bytes()
    assert abs(float((tmp_path / "rows" / "probes.csv").read_text().splitlines()[-1].split(",")[2])) > 0  # it moved


# ----------------------------------------------------------------------------- the progress bar
def test_a_run_shorter_than_the_bars_delay_never_imports_tqdm(tmp_path):
    """``latdyn run`` shows its bar (progress on: no ``-q``) only after its delay, so a short run never
    imports tqdm (and its ``multiprocessing``: 30–60 ms of a fresh process); its files are those of the
    same run with ``-q``."""
    scene = tmp_path / "spin.yaml"
    scene.write_text(SPIN)
    code = textwrap.dedent("""
        import json, sys
        from latdyn.cli import main
        code = main(["run", *sys.argv[1:]])
        print(json.dumps({"code": code, "tqdm": "tqdm" in sys.modules}))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    found = []
    for k, quiet in enumerate(([], ["-q"])):
        done = subprocess.run([sys.executable, "-c", code, str(scene), "-o", str(tmp_path / f"out{k}"), *quiet],
                              capture_output=True, text=True, env=env, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        found.append(json.loads(done.stdout.strip().splitlines()[-1]))
    assert found == [{"code": 0, "tqdm": False}] * 2
    assert (tmp_path / "out0" / "probes.csv").read_bytes() == (tmp_path / "out1" / "probes.csv").read_bytes()


#: Modules a plain ``latdyn run`` has no use for (docs/performance.md, "Thirteenth pass"): the command line is read
#: without argparse (and its gettext and locale), a traceback is printed only with ``--debug``.
NOT_IMPORTED_BY_A_PLAIN_RUN = ("argparse", "gettext", "traceback")


def test_a_plain_run_imports_no_argparse_and_no_traceback(tmp_path):
    """``latdyn run SCENE -o OUT -q`` in a fresh process imports none of :data:`NOT_IMPORTED_BY_A_PLAIN_RUN`;
    its files are those of the same run whose command line argparse read (``--backend=auto``). Its laws compiled
    and cached by a first run: compiling the hub's law of t (SymPy's ``lambdify``) imports numpy.testing, and with
    it unittest, argparse and traceback, so with an empty cache the check failed or passed by the tests' order."""
    scene = tmp_path / "spin.yaml"
    scene.write_text(SPIN)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    first = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(tmp_path / "first"), "-q"],
                           capture_output=True, text=True, env=env, timeout=300)
    assert first.returncode == 0, first.stderr[-2000:]
    code = textwrap.dedent("""
        import json, sys
        from latdyn.cli import main
        code = main(sys.argv[1:])
        print(json.dumps({"code": code, "imported": [m for m in MODULES if m in sys.modules]}))
        """).replace("MODULES", repr(NOT_IMPORTED_BY_A_PLAIN_RUN))
    found = []
    for k, how in enumerate((["-q"], ["-q", "--backend=auto"])):
        done = subprocess.run([sys.executable, "-c", code, "run", str(scene), "-o", str(tmp_path / f"out{k}"), *how],
                              capture_output=True, text=True, env=env, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        found.append(json.loads(done.stdout.strip().splitlines()[-1]))
    assert found[0] == {"code": 0, "imported": []}
    assert found[1]["code"] == 0 and "argparse" in found[1]["imported"]
    assert (tmp_path / "out0" / "probes.csv").read_bytes() == (tmp_path / "out1" / "probes.csv").read_bytes()


def test_the_bar_made_after_its_delay_is_dated_from_the_runs_start(monkeypatch, capsys):
    """Past its delay the bar is tqdm's, dated from the start (its elapsed time the run's), and shows the
    value and the postfix of the update that made it; a bar closed before its delay prints nothing."""
    pytest.importorskip("tqdm")
    from latdyn.results import progress

    clock = [1000.0]
    monkeypatch.setattr(progress.time, "time", lambda: clock[0])
    quiet = progress.progress_bar(2.0)
    quiet.update(1.0)
    quiet.close()
    assert quiet._bar is None and capsys.readouterr().err == ""
    bar = progress.progress_bar(2.0)
    bar.update(0.5, dt=1e-3)
    assert bar._bar is None  # before its delay (5 s in a log): nothing made, nothing shown
    clock[0] += 6.0
    bar._bar = None
    bar.update(1.5, dt=2e-3)
    made = bar._bar
    assert made is not None and made.start_t == 1000.0 and made.n == 1.5
    assert made.postfix is not None and "dt=0.002" in made.postfix
    bar.close()


def test_the_dataclasses_a_run_imports_have_docstrings_of_their_own(tmp_path):
    """A dataclass without a docstring gets one made from ``inspect.signature`` when its module is imported
    (7 of the lattice run's classes: ≈ 0.5 ms of its process; docs/performance.md, "Eleventh pass"); each
    class that the modules of a run (``latdyn run`` of a beam, in a fresh process) define says what it is."""
    scene = tmp_path / "beam.yaml"
    scene.write_text(BEAM)
    code = textwrap.dedent("""
        import dataclasses, inspect, json, os, sys
        from latdyn.cli import main
        assert main(["run", os.environ["SCENE"], "-o", sys.argv[1], "-q"]) == 0
        made = [f"{c.__module__}.{c.__qualname__}" for m in list(sys.modules.values())
                if getattr(m, "__name__", "").startswith("latdyn") for c in vars(m).values()
                if isinstance(c, type) and dataclasses.is_dataclass(c) and c.__module__ == m.__name__
                and c.__doc__ == c.__name__ + str(inspect.signature(c)).replace(" -> None", "")]
        print(json.dumps(made))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), SCENE=str(scene))
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "out")], capture_output=True, text=True,
                          env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(done.stdout.strip().splitlines()[-1]) == []


def test_the_records_a_run_imports_compile_no_repr_eq_or_hash(tmp_path):
    """``dataclass`` compiles each ``__repr__``, ``__eq__`` (and a frozen class's ``__hash__``) from text when its
    module is imported (≈ 5 ms of the lattice's process for its 40 classes; docs/performance.md, "Twelfth pass");
    the classes that a run's modules define (``latdyn run`` of a beam, in a fresh process) are
    :func:`latdyn.records.record` s, whose methods are the same for every class."""
    scene = tmp_path / "beam.yaml"
    scene.write_text(BEAM)
    code = textwrap.dedent("""
        import dataclasses, json, os, sys
        from latdyn.cli import main
        assert main(["run", os.environ["SCENE"], "-o", sys.argv[1], "-q"]) == 0
        classes = [c for m in list(sys.modules.values()) if getattr(m, "__name__", "").startswith("latdyn")
                   for c in vars(m).values()
                   if isinstance(c, type) and dataclasses.is_dataclass(c) and c.__module__ == m.__name__]
        compiled = [f"{c.__module__}.{c.__qualname__}.{name}" for c in classes
                    for name in ("__repr__", "__eq__", "__hash__")
                    if getattr(getattr(c, name, None), "__code__", None) is not None
                    and getattr(c, name).__code__.co_filename == "<string>"]
        print(json.dumps([len(classes), compiled]))
        """)
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), SCENE=str(scene))
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "out")], capture_output=True, text=True,
                          env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    classes, compiled = json.loads(done.stdout.strip().splitlines()[-1])
    assert classes >= 30 and compiled == []
