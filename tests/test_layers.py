"""Layers point one way (#34): the engine's library code (model, diffusion, attention, methods, io, analysis,
evaluation, synth, ...) imports neither app/ nor viz/, only the command-line layer composes them; the generate
path reaches no benchmark module; the served studio reaches no benchmark or browser harness. Lazy
(function-level) imports count."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _modules(package: str) -> dict[str, ast.Module]:
    out = {}
    for path in (ROOT / package).rglob("*.py"):
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        out[name] = ast.parse(path.read_text(), filename=str(path))
    return out


def _imports(name: str, tree: ast.Module) -> set[str]:
    deps = set()
    package = name if (ROOT / Path(*name.split("."))).is_dir() else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative import
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1] + ([base] if base else []))
            deps.add(base)
            deps |= {f"{base}.{a.name}" for a in node.names}  # "from engine import train" names a module
        elif isinstance(node, ast.Import):
            deps |= {a.name for a in node.names}
    return deps


def _cli_layer(module: str) -> bool:
    return module == "engine.cli" or module.startswith("engine.cli.")


def _graph() -> dict[str, set[str]]:
    mods = {**_modules("engine"), **_modules("app"), **_modules("viz")}
    return {name: {d for d in _imports(name, tree) if d in mods} for name, tree in mods.items()}


def _reach(graph: dict[str, set[str]], roots: list[str]) -> dict[str, str]:
    """module -> the module that first imports it, over everything reachable from ``roots``."""
    seen = {r: "" for r in roots}
    todo = list(roots)
    while todo:
        node = todo.pop()
        for dep in graph.get(node, ()):
            parts = dep.split(".")
            for k in range(1, len(parts) + 1):  # importing a.b.c runs a and a.b too
                mod = ".".join(parts[:k])
                if mod in graph and mod not in seen:
                    seen[mod] = node
                    todo.append(mod)
    return seen


def _chain(seen: dict[str, str], module: str) -> str:
    path = [module]
    while seen.get(path[-1]):
        path.append(seen[path[-1]])
    return " <- ".join(path)


def test_the_engine_library_imports_neither_app_nor_viz():
    bad = [f"{name} imports {dep}" for name, deps in _graph().items()
           if name.startswith("engine") and not _cli_layer(name)
           for dep in sorted(deps) if dep.split(".")[0] in ("app", "viz")]
    assert not bad, bad


def test_the_generate_path_reaches_no_benchmark_module():
    graph = _graph()
    seen = _reach(graph, ["engine.generate", "engine.duration", "engine.analysis.followed", "app.generation"])
    bad = [_chain(seen, m) for m in seen if m.rpartition(".")[2].startswith("bench") or ".bench" in m
           or m.startswith("engine.evaluation.bench")]
    assert not bad, bad


def test_the_served_studio_reaches_no_bench_or_browser_harness():
    graph = _graph()
    seen = _reach(graph, ["app.main", "engine.cli.serve"])
    harness = [m for m in seen if m.startswith(("app.bench", "tests."))
               or m.rpartition(".")[2].startswith("bench")]
    assert not harness, [_chain(seen, m) for m in harness]
