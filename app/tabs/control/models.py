"""The fine-tuned control models a server offers for DiffusionBlending: found in a folder, loaded once per server,
and the base model control runs on (the loaded one, or the control models' own prior shipped beside them)."""
from __future__ import annotations

import threading
from pathlib import Path

from app.tabs.control.paths import LABELS

_models_lock = threading.Lock()
_models: dict[Path, tuple[float, dict, str]] = {}  # folder -> (mtime, name -> LoadedModel, problem)
_priors: dict[Path, tuple[float, object]] = {}  # prior folder -> (mtime, LoadedModel or None)


def control_setup(folder: str | Path, *, base=None):
    """(ControlBase or None, problem): the base model control runs on with ``base`` loaded (``base`` itself, or the
    prior shipped in ``folder/prior`` when the control models were fine-tuned on its vocabulary and statistics, not
    on ``base``'s), the control models that blend with it, and why some or all cannot be blended ("" if none)."""
    from engine.methods.control import control_base

    models, problem = _load(folder)
    if base is None:
        return None, problem
    run = control_base(base, models, folder=Path(folder).expanduser().resolve(), prior=lambda: _prior(folder))
    if run.odd:
        odd = ", ".join(LABELS[n] for n in run.odd)
        problem = (f"the control models for {odd} in {Path(folder)} were fine-tuned from another base model "
                   "(other vocabulary or feature statistics) and cannot be blended with this one")
    return run, problem


def control_models(folder: str | Path, *, base=None) -> tuple[dict, str]:
    """The fine-tuned control models in ``folder`` (loaded once per server) that can be blended on the base control
    runs on with ``base`` loaded (see :func:`control_setup`), and, if none, why."""
    run, problem = control_setup(folder, base=base)
    return (_load(folder)[0] if run is None else run.models), problem


def _prior(folder: str | Path):
    """The base model shipped beside the control models (``folder/prior``), loaded once per server; None if none."""
    from app.model_cache import runtime
    from engine.methods.control import load_prior, prior_folder

    key = prior_folder(Path(folder).expanduser().resolve())
    config = key / "config.json"
    mtime = config.stat().st_mtime if config.exists() else -1.0
    with _models_lock:
        cached = _priors.get(key)
        if cached is not None and cached[0] == mtime:
            return cached[1]
        try:
            prior = load_prior(key.parent, runtime=runtime()) if mtime >= 0 else None
        except Exception:  # a broken copy: as if none were shipped (the tab then says the models do not fit)
            prior = None
        _priors[key] = (mtime, prior)
        return prior


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
