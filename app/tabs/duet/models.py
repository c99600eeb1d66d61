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


def base_step(model) -> str:
    """The training step of a loaded base model: its config.json's ``step``, else the step its TRAINING.md says it
    was exported at; "?" when neither says."""
    import re

    step = (getattr(model, "config", None) or {}).get("step")
    if step is not None:
        return str(step)
    try:
        text = (Path(model.folder) / "TRAINING.md").read_text(errors="replace")[:4000]
    except (OSError, TypeError, AttributeError):
        return "?"
    found = re.search(r"training step (\d+)", text)
    return found.group(1) if found else "?"


def model_line(model, base) -> str:
    """What the Duet tab says about the duet model it uses, read from the models actually loaded: the block's folder,
    its layer and training, and the base model it runs on (its folder and step; the studio's own or the copy
    shipped with the block)."""
    from engine.paths import shown_folder

    c = model.config
    folder = shown_folder(model.folder) if model.folder is not None else "?"
    line = (f"ComMDM block after layer {model.denoiser.after} of {model.prior.model.num_layers} ({folder}), "
            f"trained {c.get('step', '?')} steps on {c.get('samples', '?')} two-person samples.")
    if model.prior is base:
        return line + f" It runs on the studio's base model (step {base_step(base)})."
    return (line + f" It runs on the base model it was trained on (step {base_step(model.prior)}, "
                   f"{shown_folder(model.prior.folder)}), not on the studio's (step {base_step(base)}).")
