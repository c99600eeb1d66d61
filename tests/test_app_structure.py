"""The studio's rooms have one-way doors: no import cycle in app/ (lazy imports included), the session core knows no
tab, no tab imports another, and no module reaches into another object's private names."""
from __future__ import annotations

import ast
from pathlib import Path

APP = Path(__file__).resolve().parents[1] / "app"


def _modules() -> dict[str, ast.Module]:
    out = {}
    for path in APP.rglob("*.py"):
        name = ".".join(path.relative_to(APP.parent).with_suffix("").parts).removesuffix(".__init__")
        out[name] = ast.parse(path.read_text(), filename=str(path))
    return out


def _imports(tree: ast.Module) -> set[str]:
    deps = set()
    for node in ast.walk(tree):  # function-level (lazy) imports count too
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "app":
            deps.add(node.module)
        elif isinstance(node, ast.Import):
            deps |= {a.name for a in node.names if a.name.split(".")[0] == "app"}
    return deps


def test_app_has_no_import_cycle():
    graph = {name: _imports(tree) for name, tree in _modules().items()}
    cycles = []

    def visit(node: str, path: list[str], done: set[str]) -> None:
        for dep in sorted(graph.get(node, ())):
            if dep in path:
                cycles.append(path[path.index(dep):] + [dep])
            elif dep not in done:
                done.add(dep)
                visit(dep, path + [dep], done)

    for name in graph:
        visit(name, [name], {name})
    assert not cycles, [" -> ".join(c) for c in cycles[:5]]


def _tab(module: str) -> str | None:
    """The tab a module belongs to ('edit' for app.tabs.edit.job), or None."""
    parts = module.split(".")
    return parts[2] if len(parts) > 2 and parts[:2] == ["app", "tabs"] else None


def test_the_session_core_knows_no_tab():
    bad = [f"{name} imports {dep}" for name, tree in _modules().items() if name.startswith("app.session")
           for dep in sorted(_imports(tree)) if dep == "app.tabs" or dep.startswith("app.tabs.")]
    assert not bad, bad


def test_no_tab_imports_another_tab():
    bad = []
    for name, tree in _modules().items():
        tab = _tab(name)
        for dep in sorted(_imports(tree)):
            if tab is not None and (dep == "app.tabs" or (_tab(dep) is not None and _tab(dep) != tab)):
                bad.append(f"{name} imports {dep}")
    assert not bad, bad


def test_the_viewer_reads_the_core_and_nothing_reads_the_viewer_but_the_page():
    """The viewer shows what the core says is shown; neither the core nor a tab drives it directly."""
    bad = []
    for name, tree in _modules().items():
        deps = _imports(tree)
        if name.startswith("app.viewer"):
            bad += [f"{name} imports {d}" for d in sorted(deps) if d == "app.tabs" or d.startswith("app.tabs.")]
        elif name.startswith(("app.session", "app.tabs")):
            bad += [f"{name} imports {d}" for d in sorted(deps) if d == "app.viewer" or d.startswith("app.viewer.")]
    assert not bad, bad


def test_every_tab_is_a_package_with_a_view():
    tabs = sorted(p.name for p in (APP / "tabs").iterdir() if p.is_dir() and not p.name.startswith("_"))
    assert tabs == sorted(["generate", "edit", "attention", "transfer", "compose", "control", "duet", "files"])
    assert all((APP / "tabs" / t / "view.py").exists() for t in tabs)


# the one exception: Panel's design classes carry their resources in a class attribute that a design subclass
# overrides (the offline theme drops the web-font link)
ALLOWED = {"app.theme": {"_PanelFast._resources"}}


def test_no_module_reaches_into_private_names():
    bad = []
    for name, tree in _modules().items():
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
                    and isinstance(node.value, ast.Name) and node.value.id not in ("self", "cls")):
                if f"{node.value.id}.{node.attr}" not in ALLOWED.get(name, ()):
                    bad.append(f"{name}:{node.lineno} {node.value.id}.{node.attr}")
    assert not bad, bad


def test_units_and_defaults_have_one_home():
    """FPS, the longest motion and the default guidance are stated in engine/units.py only."""
    root = APP.parent
    bad = []
    for path in [*root.joinpath("engine").rglob("*.py"), *APP.rglob("*.py"), *root.joinpath("viz").rglob("*.py")]:
        if path.name == "units.py":
            continue
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and node.value == 9.8:
                bad.append(f"{path.relative_to(root)}:{node.lineno} 9.8")
            targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(
                node, ast.AnnAssign) else []
            for t in targets:
                value = getattr(node, "value", None)
                if isinstance(t, ast.Name) and t.id in ("FPS", "MAX_FRAMES", "MAX_SECONDS", "MIN_SECONDS") \
                        and isinstance(value, ast.Constant):
                    bad.append(f"{path.relative_to(root)}:{node.lineno} {t.id} = {value.value}")
                if isinstance(t, ast.Name) and t.id == "guidance" and isinstance(value, ast.Constant) \
                        and value.value == 2.5:
                    bad.append(f"{path.relative_to(root)}:{node.lineno} guidance = 2.5")
    assert not bad, bad
