"""Property-based fuzzing of the scene loader (hypothesis; SCENE.md, issue 7).

Valid scenes (``examples/spinup.yaml`` and ``examples/benchmarks/*.yaml``) are
mutated: a value replaced at a random key path (wrong types, NaN/inf, huge
numbers, odd names, dangling references, bad expressions and tables, lists
where mappings are expected, deep nesting), a key deleted, inserted or renamed,
a line of the file replaced by odd YAML. Whatever comes out, the loader must

- return a :class:`~latdyn.scene.loader.Scene` whose model builds, or
- raise :class:`~latdyn.errors.SceneError` naming the file and a key path,

and ``latdyn check`` must exit 0 or 2 (2 with the file named on stderr) — never
another exception, a traceback, exit status 1, or a hang. The examples are
derandomized so that every run (and CI) tests the same ones.

The regression tests below the properties are the crashes the fuzzing found,
each with the mutation that caused it. Whole runs of random valid scenes (every analysis,
method and output, through ``latdyn run``) are fuzzed in ``tests/test_run_fuzz.py``.
"""
from __future__ import annotations

import contextlib
import copy
import functools
import io
import json
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from latdyn import cli
from latdyn.errors import SceneError
from latdyn.scene.expressions import MAX_TEXT, parse_time_function
from latdyn.model.model import Model
from latdyn.scene.loader import MAX_COUNT, MAX_ELEMENTS, describe, load_scene

REPO = Path(__file__).resolve().parents[1]
SCENE_FILES = [REPO / "examples" / "spinup.yaml", *sorted((REPO / "examples" / "benchmarks").glob("*.yaml"))]
#: One example may take a second (a large expression); longer than this is a hang.
SLOW_S = 30.0


def fuzz_settings(max_examples: int):
    """Reproducible (derandomized, no example database), no per-example deadline."""
    return settings(derandomize=True, database=None, deadline=None, max_examples=max_examples,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@functools.cache
def base_scenes() -> dict[str, dict]:
    """The plain data of every valid example scene, by file name."""
    return {path.name: load_scene(path).raw for path in SCENE_FILES}


def check_loads_or_refuses(source, file: str):
    """Load ``source``; a SceneError must name ``file`` and a key, an accepted scene must build its model.

    Returns the scene, or None when it was refused. Any other exception propagates (the test fails).
    """
    started = time.perf_counter()
    try:
        scene = load_scene(source)
        describe(scene)
        Model.from_scene(scene).size_report()
    except SceneError as exc:
        assert exc.file == file and exc.key and exc.expected, str(exc)
        assert str(exc).startswith(f"{file}: {exc.key}: ")
        scene = None
    assert time.perf_counter() - started < SLOW_S
    return scene


# =========================================================================== mutations of plain data
ODD_NAMES = ["", " ", " hub", "arm ", ".", "a.b", "arm.end", "x[0]", "[", "]", ",", "'", '"', "a\nb", "\t",
             "\x00", "\u200b", "ü", "Ω", "名前", "🙂", "global", "t", "load_factor", "start", "null", "~", "-",
             "1"]
EXPRESSIONS = ["__import__('os')", "t**t**t**999", "9**9**9", "t.real", "lambda: 1", "[1]", "'a'", "1_000", "1j",
               "0x10", "sqrt(-1)", "1/0", "0**-1", "log(0)", "sin(", ")", "t <", "t < 1", "True",
               "Piecewise((1, t < 0))", "exp(exp(exp(exp(10))))", "1e999", "1e-999", "Min()", "atan2(t)", "open('x')",
               "os.system('ls')", "t; t", "t\nt", "(" * 300 + "t" + ")" * 300, "1+" * 999 + "1", "-" * 1500 + "t",
               "t" * (MAX_TEXT + 1), "*".join(f"(t+{i})" for i in range(100)), "e**e**e**e**e", "0.0**0", "sin(t)",
               "6*t", "pi/2", "-t"]
KEYWORDS = ["clamped", "hinge", "transient", "static", "modes", "newmark", "explicit", "default", "no_stiffening",
            "global", "total", "kinetic", "position", "velocity", "angle", "rate", "axial_force", "linear", "x",
            "norm", "auto", "off"]
KEYS = ["title", "gravity", "sections", "bodies", "beams", "loads", "solve", "output", "EA", "rhoA", "at", "mass",
        "inertia", "fixed", "motion", "rotation", "axis", "angle", "from", "to", "section", "elements", "y_axis",
        "start", "end", "hinge", "lock_at", "force", "frame", "t_end", "dt", "every", "probes", "point", "name",
        "table", "body", "offset", "energy", "EAA", "elemnts", "__class__", 1, None, True, 2.5]
BIG_NUMBERS = [0, -0.0, 1e-320, 1e-300, 1e300, 1e308, -1e308, 2**31, 2**63, 10**12, 10**30, 10**400]
BAD_TABLES = [{"table": []}, {"table": [[0]]}, {"table": [[1, 2], [0, 3]]}, {"table": [[0, float("nan")]]},
              {"table": [[0, 10**400]]}, {"table": [["a", 1]]}, {"table": [[True, 1]]}, {"table": "t"},
              {"table": [[0, 1]], "x": 1}, {"tabel": [[0, 1]]}, {"table": [[0, 1], [0, 2]]}]


def key_paths(tree, prefix=()):
    """Every path (a tuple of keys and indices) to a value inside ``tree``, parents first."""
    items = tree.items() if isinstance(tree, dict) else enumerate(tree) if isinstance(tree, list) else ()
    paths = []
    for key, value in items:
        paths.append(prefix + (key,))
        paths.extend(key_paths(value, prefix + (key,)))
    return paths


def at_path(tree, path):
    """The value at ``path`` (keys and indices) inside ``tree``."""
    for key in path:
        tree = tree[key]
    return tree


def names_in(tree) -> list[str]:
    """Part names of a scene and points/elements on its beams, valid and out of range."""
    parts = {}
    for group in ("sections", "bodies", "beams"):
        if isinstance(tree.get(group), dict):
            parts.update(dict.fromkeys(map(str, tree[group])))
    points = []
    for beam in (tree.get("beams") if isinstance(tree.get("beams"), dict) else {}):
        points += [f"{beam}.start", f"{beam}.end", f"{beam}.node[1]", f"{beam}.node[-1]", f"{beam}.node[99999]",
                   f"{beam}.element[0]", f"{beam}.element[7]", f"{beam}.node[{'9' * 30}]", f"{beam}.middle"]
    return [*parts, *points, "nobody", "nobody.end"]


def scalars(tree, *, for_files: bool):
    """Leaf values: wrong types, non-finite and huge numbers, odd text, names, expressions, keywords."""
    strategies = [st.none(), st.booleans(), st.integers(min_value=-10**20, max_value=10**20), st.floats(),
                  st.sampled_from(BIG_NUMBERS), st.sampled_from(ODD_NAMES), st.sampled_from(EXPRESSIONS),
                  st.sampled_from(KEYWORDS), st.sampled_from(names_in(tree)), st.text(max_size=8)]
    if not for_files:  # values a YAML/JSON writer cannot write (the text-level fuzzing covers their files)
        strategies += [st.sampled_from([10**5000, "\ud800", (1, 2, 3), b"bytes"])]
    return st.one_of(strategies)


def values(tree, current, *, for_files: bool):
    """A value to put where ``current`` is: a leaf, a near miss of ``current``, or a container."""
    leaf = scalars(tree, for_files=for_files)
    numbers = st.one_of(st.integers(min_value=-5, max_value=5), st.floats(), st.sampled_from(BIG_NUMBERS))
    options = [
        leaf,
        st.lists(numbers, min_size=3, max_size=3),                  # a vector, maybe with nan or 1e308
        st.lists(leaf, max_size=4),                                  # a list where a mapping was
        st.dictionaries(st.sampled_from(KEYS + ODD_NAMES), leaf, max_size=3),
        st.sampled_from(BAD_TABLES),
        st.builds(lambda rows: {"table": rows}, st.lists(st.lists(numbers, min_size=2, max_size=2), max_size=4)),
        st.builds(lambda axis, extra: {"hinge": {"axis": axis, **extra}}, st.lists(numbers, min_size=3, max_size=3),
                  st.dictionaries(st.sampled_from(["stiffness", "angle", "torque", "lock_at", "damping"]), leaf,
                                  max_size=2)),
        st.builds(lambda depth, inner: functools.reduce(lambda v, k: {k: v} if k % 2 else [v], range(depth), inner),
                  st.integers(min_value=1, max_value=60), leaf),    # deep nesting
    ]
    if isinstance(current, (int, float)) and not isinstance(current, bool) and abs(current) < 1e300:
        options.append(st.sampled_from([-current, 0 * current, current * 1e300, str(current), [current],
                                        {"table": [[0, current]]}, current + 0.5]))
    if isinstance(current, list) and current:
        options.append(st.builds(lambda i, v: current[:i] + [v] + current[i + 1:],
                                 st.integers(min_value=0, max_value=len(current) - 1), leaf))
        options.append(st.just(current[:-1]))
    if isinstance(current, dict) and current:
        options.append(st.builds(lambda extra: {**current, **extra},
                                 st.dictionaries(st.sampled_from(KEYS), leaf, min_size=1, max_size=2)))
    return st.one_of(options)


@st.composite
def mutated_scenes(draw, *, for_files: bool = False):
    """(name of the example, its data after one to three mutations)."""
    def fresh(strategy):  # a copy: later mutations change containers in place, constants must stay
        return copy.deepcopy(draw(strategy))

    name = draw(st.sampled_from(sorted(base_scenes())))
    tree = copy.deepcopy(base_scenes()[name])
    for _ in range(draw(st.integers(min_value=1, max_value=3))):
        paths = key_paths(tree)
        if not paths:
            break
        operation = draw(st.sampled_from(["replace", "replace", "replace", "delete", "insert", "rename"]))
        path = draw(st.sampled_from(paths))
        parent, key = at_path(tree, path[:-1]), path[-1]
        if operation == "replace":
            parent[key] = fresh(values(tree, parent[key], for_files=for_files))
        elif operation == "delete":
            del parent[key]
        elif operation == "insert":
            container = at_path(tree, path) if isinstance(at_path(tree, path), (dict, list)) else parent
            value = fresh(scalars(tree, for_files=for_files))
            if isinstance(container, dict):
                container[draw(st.sampled_from(KEYS + ODD_NAMES))] = value
            else:
                container.insert(draw(st.integers(min_value=0, max_value=len(container))), value)
        elif isinstance(parent, dict):  # rename a key (a part name, a probe name, a known key)
            new = draw(st.sampled_from(KEYS + ODD_NAMES + names_in(tree)))
            renamed = {(new if k == key else k): v for k, v in parent.items()}
            parent.clear()
            parent.update(renamed)
    return name, tree


# =========================================================================== properties
@fuzz_settings(max_examples=600)
@given(mutated_scenes())
def test_mutated_scene_dicts_load_or_raise_scene_error(case):
    _, tree = case
    check_loads_or_refuses(tree, "<dict>")


@fuzz_settings(max_examples=120)
@given(case=mutated_scenes(for_files=True), as_json=st.booleans())
def test_mutated_scene_files_and_latdyn_check(tmp_path_factory, case, as_json):
    """Through a YAML or JSON file: the loader names the file, ``latdyn check`` exits 0 or 2."""
    name, tree = case
    path = tmp_path_factory.mktemp("fuzz") / (Path(name).stem + (".json" if as_json else ".yaml"))
    text = json.dumps(tree) if as_json else yaml.safe_dump(tree, allow_unicode=True, sort_keys=False)
    path.write_text(text, encoding="utf-8")
    scene = check_loads_or_refuses(str(path), str(path))
    status, out, err = run_check(path)
    assert status == (0 if scene is not None else 2), err
    assert "Traceback" not in err and "internal error" not in err
    if status == 2:
        assert err.startswith(f"latdyn: error: {path}: ")
    else:
        assert "model:" in out


def run_check(path) -> tuple[int, str, str]:
    """``latdyn check PATH`` in this process: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main(["check", str(path)])
    return status, out.getvalue(), err.getvalue()


#: One flow sequence whose last item is 9**9 items long, by aliases (a "billion laughs").
LAUGHS = "[&a [x, x, x, x, x, x, x, x, x]" + "".join(
    f", &{b} [{', '.join([f'*{a}'] * 9)}]" for a, b in zip("abcdefgh", "bcdefghi")) + "]"
ODD_YAML = ["!!int abc", "!!float x", "!!bool maybe", "!!timestamp 2020-13-45", "!!binary '***'", "!!str",
            "!!python/object/apply:os.system [ls]", "!!set {a, b}", "!!omap [a: 1, b: 2]", "&a [*a]", "*nowhere",
            "9" * 5000, "-" + "9" * 400, "1e400", ".nan", "-.inf", "0x1F", "0o17", "1_000", "0b101", "~", "''",
            '"\\ud800"', '"\\x00"', "\t1", "[" * 1500 + "]" * 1500, "{a: 1, a: 2}", "[a, b", "}", "@x", "`x", "%x",
            "{? [a, b]: 1}", "{<<: {a: 1}}", "{<<: [1]}", LAUGHS, "|\n  text", ">-", "- a\n- b", "a: b: c", "- "]


@st.composite
def mutated_yaml_texts(draw):
    """The text of an example with one line replaced, deleted, repeated, truncated or given an odd value."""
    lines = draw(st.sampled_from(SCENE_FILES)).read_text(encoding="utf-8").splitlines()
    i = draw(st.integers(min_value=0, max_value=len(lines) - 1))
    operation = draw(st.sampled_from(["value", "value", "value", "delete", "repeat", "truncate", "indent"]))
    if operation == "value":
        match = re.match(r"^(\s*(?:- )?[^:#]+:\s*)(.*)$", lines[i])
        head = match.group(1) if match else lines[i] + " "
        lines[i] = head + draw(st.sampled_from(ODD_YAML))
    elif operation == "delete":
        del lines[i]
    elif operation == "repeat":
        lines.insert(i, lines[i])
    elif operation == "truncate":
        lines[i] = lines[i][:draw(st.integers(min_value=0, max_value=len(lines[i])))]
        del lines[i + 1:]
    else:
        lines[i] = draw(st.sampled_from(["\t", " ", "   "])) + lines[i]
    return "\n".join(lines) + "\n"


@fuzz_settings(max_examples=250)
@given(text=mutated_yaml_texts())
def test_mutated_yaml_text_loads_or_raises_scene_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("fuzz") / "scene.yaml"
    path.write_text(text, encoding="utf-8")
    check_loads_or_refuses(str(path), str(path))


# =========================================================================== limits
def spinup(**beam) -> dict:
    raw = copy.deepcopy(base_scenes()["spinup.yaml"])
    raw["beams"]["arm"].update(beam)
    return raw


@pytest.mark.parametrize("elements", [10**12, 10**400, 1e300, MAX_ELEMENTS + 1],
                         ids=["1e12", "1e400", "float 1e300", "limit + 1"])
def test_huge_element_counts_are_refused_before_building(elements):
    started = time.perf_counter()
    with pytest.raises(SceneError) as err:
        load_scene(spinup(elements=elements))
    assert time.perf_counter() - started < 5.0
    assert err.value.key == "beams.arm.elements" and f"at most {MAX_ELEMENTS} elements" in err.value.expected


def test_element_limit_counts_the_whole_scene():
    raw = spinup(elements=MAX_ELEMENTS)
    assert len(Model.from_scene(load_scene(raw)).element_nodes) == MAX_ELEMENTS
    raw["beams"]["arm"]["elements"] = MAX_ELEMENTS // 2
    raw["beams"]["second"] = {**raw["beams"]["arm"], "to": [0, 10, 0], "elements": MAX_ELEMENTS // 2 + 1}
    with pytest.raises(SceneError, match=f"{MAX_ELEMENTS // 2} in the beams before") as err:
        load_scene(raw)
    assert err.value.key == "beams.second.elements"


def test_whole_numbers_are_bounded():
    raw = copy.deepcopy(base_scenes()["S1_end_moment_circle.yaml"])
    raw["solve"]["steps"] = MAX_COUNT + 1
    with pytest.raises(SceneError, match=f"<= {MAX_COUNT}") as err:
        load_scene(raw)
    assert err.value.key == "solve.steps"


# =========================================================================== the crashes found
def put(raw, path: str, value) -> dict:
    """``raw`` with the value at a dotted path (list indices as numbers) replaced."""
    keys = [int(k) if k.isdigit() else k for k in path.split(".")]
    at_path(raw, keys[:-1])[keys[-1]] = value
    return raw


def spinup_with(path: str, value) -> dict:
    return put(copy.deepcopy(base_scenes()["spinup.yaml"]), path, value)


def deep_list(depth: int) -> list:
    value: list = []
    for _ in range(depth):
        value = [value]
    return value


# (id, scene data, key path named, words of the message); each crashed before it was fixed
FOUND = [
    ("integer beyond float (OverflowError)", lambda: spinup_with("sections.arm.EA", 10**400), "sections.arm.EA",
     "finite"),
    ("integer beyond float in an expression slot", lambda: spinup_with("bodies.hub.motion.rotation.angle", 10**400),
     "bodies.hub.motion.rotation.angle", "finite"),
    ("integer beyond float in a table", lambda: spinup_with("bodies.hub.motion.rotation.angle",
                                                            {"table": [[0, 0], [1, 10**400]]}),
     "bodies.hub.motion.rotation.angle.table[1]", "finite"),
    ("integer of 5000 digits in a message (ValueError)", lambda: spinup_with("title", {"x": 10**5000}), "title",
     "5001 digits"),
    ("title of 5000 digits (ValueError)", lambda: spinup_with("title", 10**5000), "title", "free text"),
    ("lone surrogate in the title (UnicodeEncodeError in the hash)", lambda: spinup_with("title", "\ud800"),
     "title", "valid Unicode"),
    ("unprintable body name (UnicodeEncodeError in latdyn check)",
     lambda: put(spinup_with("bodies", {"h\ud800": {"at": [0, 0, 0], "fixed": True}}), "beams.arm.from", "h\ud800"),
     "bodies.'h\\ud800'", "printable"),
    ("expression nested too deeply (RecursionError)", lambda: spinup_with("bodies.hub.motion.rotation.angle",
                                                                          "1+" * 999 + "1"),
     "bodies.hub.motion.rotation.angle", "nested too deeply"),
    ("0**-1 (ValueError: math domain error)", lambda: spinup_with("bodies.hub.motion.rotation.angle", "0**-1"),
     "bodies.hub.motion.rotation.angle", "divides by zero"),
    ("self-referencing dict (RecursionError)",
     lambda: (lambda raw: raw.__setitem__("title", raw) or raw)(copy.deepcopy(base_scenes()["spinup.yaml"])),
     "title", "free text"),
    ("dict nested 5000 deep (RecursionError)", lambda: spinup_with("title", deep_list(5000)), "(top level)",
     "nested too deeply"),
    ("beam longer than float64 (zero-length message, NaN axes)", lambda: spinup_with("beams.arm.to", [1e200, 1e200, 0]),
     "beams.arm", "too long to compute"),
    ("node index of 5000 digits (ValueError)",
     lambda: spinup_with("output.probes.tip_v.point", f"arm.node[{'9' * 5000}]"), "output.probes.tip_v.point",
     "expected a point"),
    ("dt > t_end (SCENE.md: refused)", lambda: spinup_with("solve.dt", 30), "solve.dt", "dt <= t_end"),
]


@pytest.mark.parametrize("make, key, words", [case[1:] for case in FOUND], ids=[case[0] for case in FOUND])
def test_crashes_found_by_fuzzing_are_scene_errors(make, key, words):
    with pytest.raises(SceneError) as err:
        load_scene(make())
    assert err.value.key == key and words in err.value.expected, str(err.value)


def test_huge_inertia_is_checked_without_overflow():
    """The symmetry and eigenvalue checks overflowed (LinAlgError: eigenvalues did not converge)."""
    inertia = [[1e308, 1e308, 0], [1e308, 1e308, 0], [0, 0, 1]]   # positive semi-definite, valid
    raw = spinup_with("bodies.tip", {"at": [10, 0, 0], "inertia": inertia})
    raw["beams"]["arm"]["to"] = "tip"
    assert load_scene(raw).bodies["tip"].inertia[0, 1] == 1e308
    with pytest.raises(SceneError, match="positive semi-definite"):
        load_scene(put(raw, "bodies.tip.inertia", [[1e308, -1e308, 0], [-1e308, 1e307, 0], [0, 0, 1]]))


@pytest.mark.parametrize("text", [
    "*".join(f"(t+{i})" for i in range(40)),       # 7 s in SymPy before
    "sin(" * 90 + "t" + ")" * 90,                  # 14 s
    "**".join(["t"] * 40),                         # 6 s
    "*".join(f"(t+{i})" for i in range(100)),      # 240 s
], ids=["product of 40", "sin nested 90 deep", "power tower of 40", "product of 100"])
def test_expressions_too_complex_to_differentiate_are_refused_quickly(text):
    started = time.perf_counter()
    with pytest.raises(SceneError, match="too complex|nested too deeply"):
        parse_time_function(text, "f.yaml", "loads[0].force[1]")
    assert time.perf_counter() - started < 15.0


@pytest.mark.parametrize("value, where", [
    ("!!int abc", "line 1, column 8"), ("!!float x", "line 1, column 8"), ("!!bool maybe", "line 1, column 8"),
    ("!!timestamp 2020-13-45", "line 1, column 8"), ("9" * 5000, "line 1, column 8"),
    ("[" * 5000 + "]" * 5000, "(top level)"), (LAUGHS, "title"),
], ids=["!!int", "!!float", "!!bool", "!!timestamp", "5000 digits", "nested 5000 deep", "billion laughs"])
def test_yaml_values_that_crashed_the_reader(tmp_path, value, where):
    """ValueError/KeyError/AttributeError from PyYAML's constructors, RecursionError, a 92 s repr of 9**9 items."""
    path = tmp_path / "odd.yaml"
    path.write_text(f"title: {value}\n")
    started = time.perf_counter()
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert time.perf_counter() - started < 15.0
    assert err.value.file == str(path) and err.value.key == where and len(str(err.value)) < 2000


@pytest.mark.parametrize("text", ['{"title": ' + "9" * 5000 + "}", '{"title": ' + "[" * 5000 + "]" * 5000 + "}"],
                         ids=["5000 digits", "nested 5000 deep"])
def test_json_values_that_crashed_the_reader(tmp_path, text):
    path = tmp_path / "odd.json"
    path.write_text(text)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    assert err.value.file == str(path)


# =========================================================================== the command line
def test_latdyn_check_exits_2_naming_file_and_key(tmp_path):
    """A separate process: exit status 2, the file and key on stderr, no traceback, no model of 10**12 elements."""
    path = tmp_path / "huge.yaml"
    path.write_text(yaml.safe_dump(spinup(elements=10**12)))
    done = subprocess.run([sys.executable, "-m", "latdyn", "check", str(path)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith(f"latdyn: error: {path}: beams.arm.elements: expected a whole number <= "), \
        done.stderr
    assert "Traceback" not in done.stderr and not done.stdout


@pytest.mark.parametrize("name, text, key", [
    ("expression.yaml", "bodies: {hub: {at: [0, 0, 0], mass: 1}}\n"
                        "loads: [{at: hub, force: [\"__import__('os')\", 0, 0]}]\n", "loads[0].force[0]"),
    ("tag.yaml", "title: !!int abc\n", "line 1, column 8"),
    ("deep.json", "[" * 5000 + "]" * 5000, "(top level)"),
    ("surrogate.yaml", 'title: "\\ud800"\n', "title"),
], ids=["expression", "tag", "deep", "surrogate"])
def test_latdyn_check_exits_2_on_files_that_crashed_it(tmp_path, name, text, key):
    path = tmp_path / name
    path.write_text(text)
    status, out, err = run_check(path)
    assert status == 2 and err.startswith(f"latdyn: error: {path}: {key}: "), err
