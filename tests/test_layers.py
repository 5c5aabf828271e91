"""The package's layers (docs/architecture.md): every import, including those inside functions,
goes to a lower layer or within its own subpackage, and no module imports itself back through
a circle. Read from the source (ast), so that it holds for imports that a run never executes."""
from __future__ import annotations

import ast
from pathlib import Path

import latdyn

PACKAGE = Path(latdyn.__file__).parent

#: Layer of each top-level module or subpackage of latdyn; an import may only go down, or sideways
#: within one subpackage. Subpackages of one layer do not import each other.
LAYERS = {
    "version": 0, "errors": 0, "records": 0, "digest": 0,  # records: dataclasses made without exec; digest: SHA-256
    "native": 1, "numerics": 1,  # native refuses a LATDYN_MARCH it cannot build for (a SceneError)
    "scene": 2,
    "model": 3,
    "assembly": 4,
    "step": 5, "results": 5,
    "timeloop": 6,
    "analyses": 7,  # a linearisation about a state a transient run reaches uses the time loop
    "solve": 8,
    "studies": 9, "stepping": 9,  # stepping: a transient run driven from Python, and its FMU
    "cli": 10, "__main__": 11, "__init__": 11,
}


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path) -> set[str]:
    """The latdyn modules ``path`` imports (absolute, relative, at any depth in the file)."""
    name = _module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "latdyn"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if module.split(".")[0] != "latdyn":
                continue
            for alias in node.names:  # `from latdyn.results import paraview`: a module
                if (PACKAGE.parent / (module.replace(".", "/") + f"/{alias.name}.py")).exists():
                    found.add(f"{module}.{alias.name}")
                else:  # a name defined in `module` (its __init__ for a package)
                    found.add(module)
    return found


def _graph() -> dict[str, set[str]]:
    modules = {_module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        targets = set()
        for imported in _imports(path):
            while imported not in modules and "." in imported:
                imported = imported.rpartition(".")[0]
            if imported in modules and imported != name:
                targets.add(imported)
        graph[name] = targets
    return graph


def _unit(module: str) -> str:
    parts = module.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


def test_every_module_has_a_layer():
    units = {_unit(m) for m in _graph()}
    assert units <= set(LAYERS), f"modules without a layer: {sorted(units - set(LAYERS))}"


def test_imports_only_go_down():
    wrong = []
    for module, targets in _graph().items():
        for target in targets:
            a, b = _unit(module), _unit(target)
            if a == b and a != "__init__":
                continue
            if target == "latdyn":  # the package's own __init__ (public API) is the top layer
                wrong.append(f"{module} -> {target}")
            elif LAYERS[b] >= LAYERS[a]:
                wrong.append(f"{module} (layer {LAYERS[a]}) -> {target} (layer {LAYERS[b]})")
    assert not wrong, "imports that run up or sideways:\n" + "\n".join(sorted(wrong))


def test_no_import_cycle():
    graph = _graph()
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for target in sorted(graph[node]):
            if state.get(target) == 1:
                cycles.append(" -> ".join(stack[stack.index(target):] + [target]))
            elif target not in state:
                visit(target)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def test_the_graph_is_read():
    """The reader finds imports of every kind (so that the tests above can fail)."""
    graph = _graph()
    assert "latdyn.assembly.assembler" in graph["latdyn.assembly.prepare"]  # from-import at the top
    assert "latdyn.step.compiled" in graph["latdyn.timeloop.transient"]  # `from latdyn.step import compiled` in a function
    assert "latdyn.results.paraview" in graph["latdyn.solve"]
