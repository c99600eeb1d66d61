"""The duet model a server offers (loaded once per folder and prior), its vocabulary, and the held-out example
duets a completion can start from."""
from __future__ import annotations

import threading
from pathlib import Path

EXAMPLE = "example: "

_lock = threading.Lock()
_cache: dict[tuple[Path, int], tuple[float, object, str]] = {}  # (folder, id(prior)) -> (mtime, DuetModel, problem)
_examples: dict[str, object] = {}


def duet_model(folder: str | Path, prior) -> tuple[object | None, str]:
    """The duet model in ``folder`` on ``prior`` (loaded once per server and prior), or (None, why not)."""
    from engine.methods.duet import load_duet

    key = Path(folder).expanduser().resolve()
    cfg = key / "config.json"
    mtime = cfg.stat().st_mtime if cfg.exists() else -1.0
    with _lock:
        cached = _cache.get((key, id(prior)))
        if cached is not None and cached[0] == mtime:
            return cached[1], cached[2]
        model, problem = None, ""
        if prior is None:
            problem = "no base model is loaded"
        elif not cfg.exists():
            problem = f"no duet model in {key} (train one with `moattn train --commdm --out {key}`)"
        else:
            try:
                model = load_duet(key, prior)
            except Exception as exc:  # another prior, a broken folder: say so
                problem = f"the duet model in {key} cannot be used: {exc}"
        _cache[(key, id(prior))] = (mtime, model, problem)
        return model, problem


def duet_vocabulary(folder: str | Path, prior_tokenizer):
    """The prior's tokenizer extended by the duet model's words (read from its config, no weights loaded)."""
    import json

    if prior_tokenizer is None:
        return None
    try:
        words = json.loads((Path(folder) / "config.json").read_text()).get("words", [])
    except (OSError, ValueError):
        words = []
    return prior_tokenizer.extended(words)


def example_names() -> list[str]:
    from engine.synth.duet import INTERACTIONS

    return [EXAMPLE + k.replace("_", " ") for k in INTERACTIONS]


def example(name: str):
    """A held-out corpus duet of the named interaction (made once)."""
    from engine.methods.duet_data import few_shot

    with _lock:
        if not _examples:
            for s in few_shot("test", per_interaction=1):
                _examples[EXAMPLE + s.interaction.replace("_", " ")] = s
        if name not in _examples:
            raise ValueError(f"no example {name!r}")
        return _examples[name]
