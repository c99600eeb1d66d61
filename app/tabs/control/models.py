"""The fine-tuned control models a server offers for DiffusionBlending: found in a folder, loaded once per server."""
from __future__ import annotations

import threading
from pathlib import Path

from app.tabs.control.paths import LABELS
from engine.methods.control import same_base

_models_lock = threading.Lock()
_models: dict[Path, tuple[float, dict, str]] = {}  # folder -> (mtime, name -> LoadedModel, problem)


def control_models(folder: str | Path, *, base=None) -> tuple[dict, str]:
    """The fine-tuned control models in ``folder`` (loaded once per server) that can be blended with ``base`` (the
    loaded base model: same vocabulary and feature statistics), and, if none, why."""
    models, problem = _load(folder)
    if base is None or not models:
        return models, problem
    fits = {n: m for n, m in models.items() if same_base(base, m)}
    if len(fits) < len(models):
        odd = ", ".join(LABELS[n] for n in models if n not in fits)
        problem = (f"the control models for {odd} in {Path(folder)} were fine-tuned from another base model "
                   "(other vocabulary or feature statistics) and cannot be blended with this one")
    return fits, problem


def _load(folder: str | Path) -> tuple[dict, str]:
    from app.model_cache import runtime
    from engine.methods.control import load_controls

    key = Path(folder).expanduser().resolve()
    mtime = key.stat().st_mtime if key.exists() else -1.0
    with _models_lock:
        cached = _models.get(key)
        if cached is not None and cached[0] == mtime:
            return cached[1], cached[2]
        problem = ""
        try:
            models = load_controls(key, runtime=runtime()) if key.exists() else {}
        except Exception as exc:  # a broken folder: say so, offer inpainting
            models, problem = {}, f"the control models in {key} could not be loaded ({exc})"
        if not models and not problem:
            problem = (f"no fine-tuned control models in {key} (train one with `moattn train --control root "
                       "--init-from assets/model --out assets/control/root`)")
        _models[key] = (mtime, models, problem)
        return models, problem
