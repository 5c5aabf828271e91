"""The documentation names only what exists (issue 35, "Nothing false").

README.md and docs/*.md are read as a user reads them, and every name they give is checked
against the code it names:

- a **CLI option** of ``latdyn`` (in a command line ``latdyn COMMAND ...`` or ``python -m latdyn
  COMMAND ...``, in a code block or inline, and any option written alone in backticks) against the
  argparse parser of :mod:`latdyn.cli` (and :mod:`codegen.cli` for ``latdyn-codegen``), with the
  choices an option lists (``--backend auto|c``) against the parser's choices;
- a **scene key** (``solve.method``, ``beams.NAME.rigid``, ``output.paraview_every: 0``) against
  the keys the loader accepts, recorded by running it on every shipped scene;
- a **module or object** (``latdyn.results.plot``, ``latdyn.scene.builder.SceneBuilder``) by
  importing it;
- a **test** (``tests/test_x.py::test_name``) by the file and the function in it;
- a **file path** (``latdyn/solve.py``, ``examples/spinup.yaml``, a Markdown link) by the tree.
"""
from __future__ import annotations

import argparse
import importlib
import re
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

_BACKTICKS = re.compile(r"`([^`\n]+)`")
_FENCE = re.compile(r"^```.*?$(.*?)^```", re.S | re.M)
_LINK = re.compile(r"\]\(([^)\s]+)\)")


def _code_spans(text: str) -> list[str]:
    """Inline code and each line of the fenced blocks."""
    spans = [line for block in _FENCE.findall(text) for line in block.splitlines()]
    return spans + _BACKTICKS.findall(_FENCE.sub("", text))


# ----------------------------------------------------------------------------- CLI options
def _subparsers(parser: argparse.ArgumentParser) -> dict:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


@lru_cache(maxsize=None)
def _parsers() -> dict:
    """``{program: {command or None: parser}}`` for latdyn and latdyn-codegen."""
    from latdyn.cli import build_parser

    latdyn = build_parser()
    commands = {None: latdyn, **_subparsers(latdyn)}
    return {"latdyn": commands, "latdyn-codegen": {None: _codegen_parser()}}


def _codegen_parser() -> argparse.ArgumentParser:
    import codegen.cli as module

    for name in ("build_parser", "parser", "_parser"):
        if callable(getattr(module, name, None)):
            return getattr(module, name)()
    raise AssertionError("codegen.cli has no build_parser(); the test cannot read latdyn-codegen's options")


def _options(parser: argparse.ArgumentParser) -> dict:
    return {s: a for a in parser._actions for s in a.option_strings}


_COMMAND = re.compile(r"^\s*(?:\$\s*)?(?:.*&&\s*)?(?:python -m (latdyn|codegen)|(latdyn-codegen|latdyn))\s+(.*)")
_SCRIPT = re.compile(r"python ((?:benchmarks|examples)/[\w/]+\.py)\s*(.*)")


def _command_lines(text: str):
    """(program, command, argument tokens) of each ``latdyn ...`` command line in code (a line or
    an inline span that starts with the command, or continues one after ``&&``)."""
    for span in _code_spans(text):
        for found in _COMMAND.finditer(span):
            program = {"codegen": "latdyn-codegen"}.get(found[1], found[1]) or found[2]
            tokens = found[3].split("#")[0].replace("[", " ").replace("]", " ").split()
            command = None
            if program == "latdyn" and tokens and not tokens[0].startswith("-"):
                command = tokens[0]
            yield program, command, tokens


def _option_problems(text: str) -> list[str]:
    problems = []
    parsers = _parsers()
    for program, command, tokens in _command_lines(text):
        if program == "latdyn" and command is not None and command not in parsers["latdyn"]:
            problems.append(f"`{program} {command}`: no such command (commands: {', '.join(c for c in parsers['latdyn'] if c)})")
            continue
        options = {**_options(parsers[program][None]), **_options(parsers[program][command])}
        for i, token in enumerate(tokens):
            if not re.fullmatch(r"--?[A-Za-z][\w-]*", token):
                continue
            if token not in options:
                problems.append(f"`{program} {command or ''} {token}`: no such option")
                continue
            action = options[token]
            given = tokens[i + 1] if i + 1 < len(tokens) else ""
            if action.choices and "|" in given:
                for choice in given.split("|"):
                    if choice not in action.choices:
                        problems.append(f"`{program} {command} {token} {given}`: {choice!r} is not one of "
                                        f"{sorted(action.choices)}")
    for span in _code_spans(text):  # the scripts of benchmarks/ and examples/: their own options
        for script, rest in _SCRIPT.findall(span):
            source = ROOT / script
            if not source.is_file():
                problems.append(f"`python {script}`: no such script")
                continue
            for option in re.findall(r"(?<![\w-])--[a-z][\w-]*", rest.split("#")[0]):
                if not _script_defines(source, option):
                    problems.append(f"`python {script} {option}`: the script has no option {option}")
    every_option = {o for commands in parsers.values() for p in commands.values() for o in _options(p)}
    for span in _BACKTICKS.findall(text):
        found = re.fullmatch(r"(--[a-z][\w-]*)(?:[ =].*)?", span.strip())
        if found and found[1] not in every_option and not _is_foreign(found[1], text) and not any(
                _script_defines(script, found[1]) for script in _scripts()):
            problems.append(f"`{span}`: not an option of latdyn, latdyn-codegen or a script of benchmarks/ or examples/")
    return problems


def _scripts() -> list[Path]:
    return sorted((ROOT / "benchmarks").glob("*.py")) + sorted((ROOT / "examples").glob("*.py"))


def _script_defines(script: Path, option: str) -> bool:
    """The script's argparse takes ``option``: its source passes the string to add_argument, or it builds its parser
    with ``MODULE.arguments(...)`` or runs ``MODULE.main(...)`` of a script beside it whose source does
    (benchmarks/latch_start.py takes benchmarks/sensitivity_start.py's, benchmarks/energy_sensitivities_loop.py runs
    benchmarks/hinge_sensitivities_loop.py's)."""
    source = script.read_text(encoding="utf-8")
    if re.search(rf"add_argument\([^)]*[\"']{re.escape(option)}[\"']", source) is not None:
        return True
    return any(_script_defines(script.with_name(f"{module}.py"), option)
               for module in re.findall(r"\b(\w+)\.(?:arguments|main)\(", source) if script.with_name(f"{module}.py").is_file())


def _is_foreign(option: str, text: str) -> bool:
    """An option that a command of another program in the same text takes (pip, pytest, python)."""
    return any(re.search(rf"\b(pip|pytest|python)\b[^`\n]*\s{re.escape(option)}\b", line)
               for line in _code_spans(text))


# ----------------------------------------------------------------------------- scene keys
@lru_cache(maxsize=None)
def _accepted_keys() -> dict:
    """``{key path pattern: keys accepted there}``, recorded from the loader's own checks while it
    reads every shipped scene (names of sections, bodies, beams and probes become ``NAME``)."""
    from latdyn.scene import loader

    recorded: dict[str, set] = {}
    reader = loader._Reader  # the loader's reader: every mapping it reads goes through mapping()
    original = reader.mapping

    def recording(self, value, key, allowed, *args, **kwargs):
        recorded.setdefault(_pattern(key), set()).update(allowed)
        return original(self, value, key, allowed, *args, **kwargs)

    reader.mapping = recording
    try:
        scenes = sorted((ROOT / "examples").rglob("*.yaml")) + sorted((ROOT / "latdyn" / "examples").glob("*.yaml"))
        for path in scenes:
            try:
                loader.load_scene(str(path))
            except loader.SceneError:
                pass  # a study file, not a scene
    finally:
        reader.mapping = original
    return recorded


def _pattern(key: str) -> str:
    parts = [p for p in re.sub(r"\[\d+\]", "", key).split(".") if p]
    out = []
    for i, part in enumerate(parts):
        parent = ".".join(out)
        out.append("NAME" if parent in ("sections", "bodies", "beams", "output.probes", "cables") else part)
    return ".".join(out)


_KEY = re.compile(r"([a-z_]+(?:\.[A-Za-z_]+)+)(?::\s*(\S.*))?")
#: keys whose value is a word from a list of the loader's: the list's name in latdyn.scene.loader
_WORDS = {"solve.analysis": ("ANALYSES",), "solve.method": ("METHODS", "STATIC_METHODS"),
          "solve.formulation": ("FORMULATIONS",), "solve.engine": ("ENGINES",), "solve.planar": ("PLANAR",),
          "solve.newton": ("NEWTON",), "solve.about": ("ABOUT",)}


def _value_problems(span: str, key: str, value: str | None) -> list[str]:
    """``solve.newton: exact``: the word is one the loader takes there (placeholders in capitals,
    mappings and numbers are not checked)."""
    from latdyn.scene import loader

    if key not in _WORDS or not value:
        return []
    words = {w for name in _WORDS[key] for w in getattr(loader, name)}
    problems = []
    for word in re.split(r"\s*\|\s*", value.strip()):
        if re.fullmatch(r"[a-z][\w-]*", word) and word not in words:
            problems.append(f"`{span}`: the loader takes no {word!r} for {key} (it takes {', '.join(sorted(words))})")
    return problems


def _key_problems(text: str) -> list[str]:
    accepted = _accepted_keys()
    top = accepted.get("", set())
    problems = []
    for span in _BACKTICKS.findall(text):
        found = _KEY.fullmatch(span.strip())
        if not found or found[1].split(".")[0] not in top:
            continue
        problems += _value_problems(span, found[1], found[2])
        parts = found[1].split(".")
        path = ""
        for part in parts:
            here = accepted.get(path)
            named = f"{path}.NAME" if path else "NAME"
            if here is None and any(k == named or k.startswith(named + ".") for k in accepted):
                path = named  # a level of user-given names (sections, bodies, beams, probes)
                continue
            if here is None:
                break  # below what the shipped scenes exercise (a probe's keys, say): not checked
            if part.isupper() or part == "NAME":
                path = named
                continue
            if part not in here:
                problems.append(f"`{span}`: the loader accepts no key {part!r} at {path or 'the top level'} "
                                f"(accepted: {', '.join(sorted(here))})")
                break
            path = f"{path}.{part}" if path else part
    return problems


# ----------------------------------------------------------------------------- modules, tests, files
_DOTTED = re.compile(r"((?:latdyn|codegen|latdyn_generated)(?:\.[A-Za-z_]\w*)+)(?:\(.*)?")


def _resolves(dotted: str) -> bool:
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


def _module_problems(text: str) -> list[str]:
    problems = []
    for span in _code_spans(text):
        for token in re.findall(r"(?<![\w/.])(?:latdyn|codegen|latdyn_generated)(?:\.[A-Za-z_]\w*)+", span):
            if token.endswith((".py", ".yaml", ".md")):
                continue
            if not _resolves(token):
                problems.append(f"`{token}`: no such module or object")
    return problems


_TREE = ("latdyn", "codegen", "generated", "tests", "docs", "examples", "benchmarks", ".ci")
_PATH = re.compile(r"(?:\.\./)?(?:%s)/[\w./{},*-]*" % "|".join(re.escape(t) for t in _TREE))


def _expand(path: str) -> list[str]:
    found = re.search(r"\{([^{}]*)\}", path)
    if not found:
        return [path]
    return [p for alt in found[1].split(",") for p in _expand(path[:found.start()] + alt + path[found.end():])]


def _path_problems(doc: Path, text: str) -> list[str]:
    problems = []
    candidates = []
    for span in _code_spans(text):
        candidates += [m.group(0) for m in _PATH.finditer(span) if m.start() == 0 or not
                       (span[m.start() - 1].isalnum() or span[m.start() - 1] in "_./~$-")]
    candidates += [link.split("#")[0] for link in _LINK.findall(text) if "://" not in link]
    for raw in candidates:
        test = None
        if "::" in raw:
            raw, test = raw.split("::", 1)
        raw = raw.rstrip(".,;:)")
        if not raw or "*" in raw or "<" in raw:
            continue
        if not (raw.endswith("/") or re.search(r"\.[A-Za-z0-9{},]+$", raw.rsplit("/", 1)[-1])):
            continue  # neither a file (an extension) nor a folder (a slash): another project's path
        for path in _expand(raw):
            here = [ROOT / path, doc.parent / path]
            if not any(p.exists() for p in here):
                problems.append(f"`{path}`: no such file or folder")
    for span in _code_spans(text) + [text]:
        for file, name in re.findall(r"(tests/[\w/]+\.py)::(\w+)", span):
            source = ROOT / file
            if not source.is_file():
                problems.append(f"`{file}::{name}`: no such test file")
            elif not re.search(rf"^\s*(?:async\s+)?def {re.escape(name)}\(|^class {re.escape(name)}\b",
                               source.read_text(encoding="utf-8"), re.M):
                problems.append(f"`{file}::{name}`: no such test in {file}")
    return sorted(set(problems))


# ----------------------------------------------------------------------------- the tests
def _read(doc: Path) -> str:
    return doc.read_text(encoding="utf-8")


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_documented_cli_options_exist(doc):
    problems = _option_problems(_read(doc))
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_documented_scene_keys_are_accepted_by_the_loader(doc):
    problems = _key_problems(_read(doc))
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_documented_modules_and_objects_import(doc):
    problems = _module_problems(_read(doc))
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_documented_files_and_tests_exist(doc):
    problems = _path_problems(doc, _read(doc))
    assert not problems, "\n".join(problems)


# the checks catch what they are for: each finds a planted falsehood of its kind
@pytest.mark.parametrize("text, check", [
    ("```bash\nlatdyn run scene.yaml [--backend auto|c|numpy]\n```", "options"),
    ("`latdyn run scene.yaml --no-such-flag`", "options"),
    ("`latdyn draw OUT`", "options"),
    ("`--resume-from`", "options"),
    ("`solve.no_such_key`", "keys"),
    ("`beams.NAME.rigidity: true`", "keys"),
    ("`solve.engine: python`", "keys"),
    ("`solve.formulation: default | no_such_element`", "keys"),
    ("`latdyn.results.no_such_module`", "modules"),
    ("`latdyn.solve.no_such_function`", "modules"),
    ("`tests/test_cli.py::test_that_was_never_written`", "paths"),
    ("[a picture](docs/pictures/no_such_picture.png)", "paths"),
    ("`examples/no_such_scene.yaml`", "paths"),
])
def test_each_check_finds_a_planted_falsehood(text, check):
    found = {"options": _option_problems, "keys": _key_problems, "modules": _module_problems,
             "paths": lambda t: _path_problems(ROOT / "README.md", t)}[check](text)
    assert found, f"the {check} check missed {text!r}"


@pytest.mark.parametrize("text", [
    "```bash\nlatdyn run scene.yaml [-o OUT] [--resume] [-q]\npip install --no-compile -e .\n```",
    "`solve.method`, `beams.NAME.rigid`, `output.paraview_every: 0`",
    "`latdyn.scene.builder.SceneBuilder`, `tests/test_cli.py::test_plot_writes_pngs`, `examples/spinup.yaml`",
])
def test_true_statements_pass(text):
    assert not (_option_problems(text) + _key_problems(text) + _module_problems(text)
                + _path_problems(ROOT / "README.md", text))


# ----------------------------------------------------------------------------- the scene reference
def _scene_reference():
    """docs/_ext/scene_reference.py, the page it writes at every docs build, and what it could not describe."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("scene_reference", ROOT / "docs" / "_ext" / "scene_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    text, undescribed = module.reference()
    return module, text, undescribed


def _reference_sections(text: str) -> dict:
    """``{place: keys listed in its table(s)}`` of the scene reference's Markdown."""
    sections: dict[str, set] = {}
    place = None
    for line in text.splitlines():
        heading = re.match(r"## (?:`([^`]*)`|Top level)", line)
        if heading:
            place = heading[1] or ""
            sections.setdefault(place, set())
        elif place is not None and (row := re.match(r"\| `([^`]+)` \|", line)):
            sections[place].add(row[1])
    return sections


def test_scene_reference_names_every_key_the_loader_accepts_and_describes_each():
    """Every key at every place the loader checks (recorded on the shipped scenes, as the other
    checks here do) has its row under that place, and every key of every table of keys in
    latdyn/scene/ is on the page; none is left without a description (unit, default)."""
    module, text, undescribed = _scene_reference()
    sections = _reference_sections(text)
    # the places as the reference names them (a level of names it writes NAME, as this file's _pattern
    # does for the levels it knows)
    missing = [f"{place or '(top level)'}.{key}" for place, keys in _accepted_keys().items()
               for key in keys if key not in sections.get(module._pattern(place), set())]
    assert not missing, f"the scene reference lacks: {missing}"
    on_page = set().union(*sections.values())
    for table, keys in module.source_tables().items():
        assert set(keys) <= on_page, f"{table}: {sorted(set(keys) - on_page)} not in the scene reference"
    assert not undescribed, (f"add what each is, its unit and default to DESCRIPTIONS in "
                             f"docs/_ext/scene_reference.py: {undescribed}")


def test_scene_reference_catches_a_key_it_was_not_told_about(monkeypatch):
    """A key added to a loader table (as a new feature adds one) appears on the page at once, and is
    reported as undescribed until DESCRIPTIONS says what it is."""
    from latdyn.scene import loader

    monkeypatch.setattr(loader, "_SOLVE_KEYS", loader._SOLVE_KEYS + ("no_such_setting",))
    module, text, undescribed = _scene_reference()
    assert "| `no_such_setting` |" in text and "solve.no_such_setting" in undescribed


def test_every_shipped_scene_is_standard_yaml():
    """The shipped scenes and studies read with any YAML tool (PyYAML's safe loader), not only latdyn's loader,
    which also takes a bracket inside a flow mapping (``{point: rod.node[2]}``): a user's script that reads an
    example to change it (the adaptive slider–crank of docs/verification.md was reported hanging by such a
    script that had failed to parse it) must not meet a dialect."""
    import yaml

    scenes = sorted((ROOT / "examples").rglob("*.yaml")) + sorted((ROOT / "latdyn" / "examples").glob("*.yaml"))
    unreadable = []
    for path in scenes:
        try:
            yaml.safe_load(path.read_text())
        except yaml.YAMLError as error:
            unreadable.append(f"{path.relative_to(ROOT)}: {str(error).splitlines()[0]}")
    assert not unreadable, unreadable
