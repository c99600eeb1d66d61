"""Layers point one way (#34): the engine's library code (model, diffusion, attention, methods, io, analysis,
evaluation, synth, ...) imports neither app/ nor viz/, only the command-line package engine/cli/ composes them; the
generate path reaches no benchmark and no evaluation module; the served studio reaches no benchmark or browser
harness, and nothing in app/ outside app/bench/ imports it; every parser refuses abbreviated flags; no function is
over 100 lines. Lazy (function-level) imports count."""
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


def _named_imports(tree: ast.Module) -> set[str]:
    """Every module a file names in an import, however it is imported: ``import``, ``from ... import`` (absolute),
    ``importlib.import_module("...")`` and ``__import__("...")`` with a literal name; anywhere in the file."""
    deps = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and not node.level and node.module:
            deps.add(node.module)
            deps |= {f"{node.module}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            deps |= {a.name for a in node.names}
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str):
            func = node.func
            name = func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else ""
            if name in ("import_module", "__import__"):
                deps.add(node.args[0].value)
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


def test_only_engine_cli_names_app_or_viz_in_the_engine():
    """The same rule read from every import statement and import_module/__import__ call in engine/, whether or not
    the module it names exists: only engine/cli/ (the one place where engine, viz and app meet) names app or viz."""
    bad = [f"{name} imports {dep}" for name, tree in _modules("engine").items() if not _cli_layer(name)
           for dep in sorted(_named_imports(tree)) if dep.split(".")[0] in ("app", "viz")]
    assert not bad, bad
    assert (ROOT / "engine" / "cli" / "__init__.py").exists() and not list((ROOT / "engine").glob("cli_*.py"))


def test_the_generate_path_reaches_no_evaluation_module():
    """engine/generate.py and engine/duration.py, and every engine module they import (transitively, lazy imports
    included), import no engine.evaluation module: what they share with the benchmarks lives in a neutral module."""
    graph = _graph()
    seen = _reach(graph, ["engine.generate", "engine.duration"])
    bad = [_chain(seen, m) for m in sorted(seen) if m == "engine.evaluation" or m.startswith("engine.evaluation.")]
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


def test_nothing_in_the_app_outside_app_bench_imports_it():
    """app/bench/ (benchmarks, the browser harness, test helpers) sits beside the studio; the studio never imports
    it, not even lazily."""
    bad = [f"{name} imports {dep}" for name, tree in _modules("app").items()
           if name != "app.bench" and not name.startswith("app.bench.")
           for dep in sorted(_imports(name, tree)) if dep == "app.bench" or dep.startswith("app.bench.")]
    assert not bad, bad
    assert not [p.name for p in (ROOT / "app").glob("*.py") if p.name.startswith(("bench", "browser", "testing"))]


def test_every_argument_parser_refuses_abbreviations():
    """An argparse parser built in engine/ or app/ says allow_abbrev=False (engine/cli's Parser sets it for the
    whole `moattn` tree), so ``--to kicks`` is refused rather than read as ``--to-frame kicks``."""
    bad = []
    for package in ("engine", "app", "viz"):
        for name, tree in _modules(package).items():
            for node in ast.walk(tree):
                if isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) \
                        == "ArgumentParser":
                    given = {k.arg: k.value for k in node.keywords}
                    if not (isinstance(given.get("allow_abbrev"), ast.Constant) and given["allow_abbrev"].value is False):
                        bad.append(f"{name}:{node.lineno}")
    assert not bad, bad


MAX_FUNCTION_LINES = 100


def test_no_function_is_over_100_lines():
    """No function or method in engine/, app/ or viz/ is longer than 100 lines (from its def to its last line,
    nested functions included in their outer one)."""
    long = []
    for package in ("engine", "app", "viz"):
        for path in sorted((ROOT / package).rglob("*.py")):
            tree = ast.parse(path.read_text(), filename=str(path))
            for node in ast.walk(tree):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    lines = node.end_lineno - node.lineno + 1
                    if lines > MAX_FUNCTION_LINES:
                        long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines} lines)")
    # EXPECTED TO FAIL until another branch lands (#34, being split there now): make_duet (engine/synth/duet.py),
    # ballistic_reps (engine/synth/primitives/jumps.py), gait (engine/synth/primitives/locomotion.py) and
    # train_commdm (engine/train_commdm.py) are over 100 lines. Left failing on purpose, not skipped: it passes once
    # that split is merged; any other name in this list is a new long function.
    assert not long, long
