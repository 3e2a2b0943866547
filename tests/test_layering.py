"""Imports flow one way: surrogates ← railgym physics (track, vehicles, FMU runner) ←
railgym.report, railgym.envs ← wrappers ← agents; each env in its own folder."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(
                node.module.split(".")[0]
                if node.module.split(".")[0] != "railgym"
                else ".".join(node.module.split(".")[:2])
            )
    return names


PHYSICS = [
    ROOT / "railgym" / "track.py",
    ROOT / "railgym" / "comfort.py",
    ROOT / "railgym" / "_checks.py",
    *(ROOT / "railgym" / "vehicles").rglob("*.py"),
]


@pytest.mark.parametrize("path", sorted((ROOT / "surrogates").rglob("*.py")), ids=str)
def test_surrogates_need_neither_railgym_nor_gymnasium_nor_torch(path):
    bad = _imports(path) & {"railgym", "railgym.envs", "gymnasium", "torch", "stable_baselines3"}
    assert not bad, f"{path} imports {bad}"


@pytest.mark.parametrize("path", PHYSICS, ids=str)
def test_physics_does_not_use_gymnasium_or_envs(path):
    bad = _imports(path) & {
        "gymnasium",
        "torch",
        "stable_baselines3",
        "railgym.envs",
        "railgym.wrappers",
        "agents",
    }
    assert not bad, f"{path} imports {bad}"


@pytest.mark.parametrize("path", sorted((ROOT / "railgym" / "report").glob("*.py")), ids=str)
def test_report_uses_physics_only(path):
    outer = {"gymnasium", "torch", "stable_baselines3", "railgym.envs", "railgym.wrappers"}
    bad = _imports(path) & (outer | {"agents"})
    assert not bad, f"{path} imports {bad}"


@pytest.mark.parametrize("path", sorted((ROOT / "railgym" / "fmu").rglob("*.py")), ids=str)
def test_fmu_does_not_import_envs(path):
    """The FMU runner, mapping, description, collection and exports sit below the envs: the
    FMU batches of the envs live in the envs' folders."""
    bad = _imports(path) & {"gymnasium", "railgym.envs", "railgym.wrappers", "agents"}
    assert not bad, f"{path} imports {bad}"


def test_vehicles_import_no_fmu():
    """The physics sits below the FMU layer: the FMU's part of collection and refinement
    (``railgym collect --fmu-map``, ``refine`` on an FMU) lives in ``railgym.fmu.collect``,
    which hands it to the physics' functions."""
    for path in sorted((ROOT / "railgym" / "vehicles").rglob("*.py")):
        bad = {n for n in _full_imports(path) if n == "railgym.fmu" or n.startswith("railgym.fmu.")}
        assert not bad, f"{path} imports {bad}"


#: the physics of each model, in a package of its own
PHYSICS_PACKAGES = {
    "vertical": ("params", "elements", "kernels", "lanes", "simulate"),
    "vehicle": ("params", "model", "lanes", "damper", "collect", "refine"),
    "crash": ("model", "elements", "scenario", "reference", "surrogate"),
}


@pytest.mark.parametrize("model", sorted(PHYSICS_PACKAGES))
def test_each_model_has_its_physics_package(model):
    _assert_package(ROOT / "railgym" / "vehicles" / model, PHYSICS_PACKAGES[model])


def _assert_package(folder, modules):
    assert (folder / "__init__.py").is_file()
    for module in modules:
        path = folder / f"{module}.py"
        assert path.is_file(), path.relative_to(ROOT).as_posix()


#: one folder per env: its module, batch, frame (and FMU batch, declared arguments, ...)
ENV_FOLDERS = {
    "vertical": ("env", "batch", "fmu_batch", "render"),
    "vehicle": ("env", "batch", "fmu_batch", "render"),
    "crash": ("env", "params", "batch", "step", "layout", "render"),
}


@pytest.mark.parametrize("env", sorted(ENV_FOLDERS))
def test_each_env_has_its_folder(env):
    _assert_package(ROOT / "railgym" / "envs" / env, ENV_FOLDERS[env])


def test_envs_outside_their_folders_import_no_env_folder():
    """The shared modules of railgym/envs (base, params, compiled, track_shell, raster, ...)
    need no env's folder."""
    folders = {f"railgym.envs.{env}" for env in ENV_FOLDERS}
    for path in sorted((ROOT / "railgym" / "envs").glob("*.py")):
        names = {n for n in _full_imports(path) if n.startswith("railgym.envs.")}
        bad = {n for n in names if any(n == f or n.startswith(f + ".") for f in folders)}
        assert not bad, f"{path} imports {bad}"


def _full_imports(path: Path) -> set[str]:
    """The modules ``path`` imports (absolute, full dotted names; in functions too), and
    ``X.name`` for each ``from X import name`` (which may be a module)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
    return names


def test_core_imports_without_torch():
    code = (
        "import sys, surrogates, railgym, railgym.envs.vertical, railgym.envs.crash, "
        "railgym.wrappers, railgym.report, agents.controllers, agents.commands.cli; "
        "print('torch' in sys.modules or 'stable_baselines3' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _module_graph() -> dict[str, set[str]]:
    """Every import of the project's modules (module level, in functions and under
    ``TYPE_CHECKING`` alike) as edges to the most specific project module it names."""
    files = [p for pkg in ("surrogates", "railgym", "agents") for p in (ROOT / pkg).rglob("*.py")]
    modules = {_module_name(p): p for p in files}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*up, base] if base else up)
                targets |= {f"{base}.{a.name}" for a in node.names} | {base}
        edges = set()
        for target in targets:
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                edges.add(target)
        graph[name] = edges
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_cycle_finder_finds_a_circle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_circle_among_the_project_modules():
    """A module never imports (even lazily, in a function) a module that imports it back; a
    package's ``__init__`` re-exports its modules, which never import the package itself."""
    graph = _module_graph()
    assert len(graph) > 100
    assert _cycles(graph) == []


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _private_reaches() -> list[str]:
    """``from X import _name`` and ``X._name`` where ``X`` is another project module: each as
    ``path:line name``. A module named with an underscore (``railgym._checks``)
    is project-internal, and importing it or its public names is fine; its
    underscore names, like any module's, are its own."""
    files = [p for pkg in ("surrogates", "railgym", "agents") for p in (ROOT / pkg).rglob("*.py")]
    modules = {_module_name(p): p for p in files}
    found = []
    for name, path in sorted(modules.items()):
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        tree = ast.parse(path.read_text())
        bound: dict[str, str] = {}  # local name → the project module it is
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name in modules:
                        bound[a.asname or a.name.split(".")[0]] = (
                            a.name if a.asname else a.name.split(".")[0]
                        )
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*up, base] if base else up)
                if base not in modules:
                    continue
                for a in node.names:
                    if f"{base}.{a.name}" in modules:
                        bound[a.asname or a.name] = f"{base}.{a.name}"
                    elif _private(a.name) and base != name:
                        found.append(f"{path.relative_to(ROOT)}:{node.lineno} {base}.{a.name}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                chain, value = [], node.value
                while isinstance(value, ast.Attribute):
                    chain.append(value.attr)
                    value = value.value
                if isinstance(value, ast.Name) and value.id in bound:
                    target = ".".join([bound[value.id], *reversed(chain)])
                    if target in modules and target != name:
                        found.append(f"{path.relative_to(ROOT)}:{node.lineno} {target}.{node.attr}")
    return found


def test_no_module_reaches_into_another_modules_private_names():
    """A name another module needs is public where it is defined (or moved to where both
    take it publicly): an underscore name is its module's own."""
    assert _private_reaches() == []
