"""The session core's side of the motion library (engine.library): a session motion <-> a library entry.

What a motion's recipe holds is read from the ``MotionItem`` the job made (its settings, its ``info``), so every
tab's results are kept without the tab knowing about the library; the links between the motions of one job (an
edit's reference -> its edited motions, a transfer's leader and follower -> its output) are made once the job's
``Delivery`` has been added (:func:`job_parents`). Nothing here imports Panel or a tab.
"""
from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

from app.generation import GenerationSettings
from app.session.items import MotionItem
from engine.library import Entry, MotionLibrary, jsonable
from engine.library.cli_support import model_info

#: ``info`` keys that say which tab made a motion, in the order they are looked for
_INFO_KINDS = ("edit", "transfer", "compose", "control", "duet")
KIND_LABELS = {"": "all kinds", "generate": "generated", "edit": "edits", "transfer": "transfers",
               "compose": "compositions", "control": "controlled", "duet": "duets", "import": "imports"}


def item_kind(item: MotionItem) -> str:
    """What made the motion: generate | edit | transfer | compose | control | duet | import."""
    if item.kind:
        return item.kind
    for key in _INFO_KINDS:
        if key in item.info:
            return key
    if item.settings is not None:
        return "generate"
    return "import" if item.source == "imported" else (item.source or "motion")


def recipe_of(item: MotionItem, *, model_dir: str | Path | None) -> dict:
    """How ``item`` was made, as its library recipe keeps it (JSON-safe; never its attention)."""
    kind = item_kind(item)
    info = dict(item.info)
    recipe: dict = {"prompt": item.prompt or "", "words": list(item.words)}
    if kind != "import":
        recipe["model"] = model_info(model_dir)
    s = item.settings
    if s is not None:
        recipe.update(prompt=s.prompt, seed=s.seed, steps=s.steps, guidance=s.guidance, guidance_from=s.guidance_from,
                      eta=s.eta, seconds=s.seconds)
        info["record_steps"] = s.record_steps
        info["sequence"] = s.sequence
        info["held_path"] = s.held_path
    elif "seed" in info:
        recipe["seed"] = info.pop("seed")
    if kind == "import":
        recipe["source"] = {"name": re.sub(r"^imported:\s*", "", item.name)}
    info.pop("guides", None)  # drawn target paths (arrays): shown with the motion while the session lasts
    info.pop("followed", None)  # a report object of the generation: recomputed when it is generated again
    operation = {k: v for k, v in info.items() if v is not None}
    if "duet" in operation:  # the pair's names (its joints are the two motions themselves)
        pair = operation["duet"]
        operation["duet"] = {"first": getattr(pair, "first", None), "second": getattr(pair, "second", None)}
    if operation:
        recipe["operation"] = jsonable(operation)
    return recipe


def job_parents(added: list[MotionItem], items: Mapping[str, MotionItem], *, compare: str) -> dict[str, list[str]]:
    """Name -> the names of the motions it was made from, for the motions one job added (``added``, in order).

    An edit's motions come from the motion it is compared with (its reference); a transfer's outputs from the
    leader and the follower of the same run."""
    out: dict[str, list[str]] = {}
    roles = {it.info.get("role"): it.name for it in added if "transfer" in it.info}
    for it in added:
        if "edit" in it.info and compare and compare != it.name and compare in items:
            out[it.name] = [compare]
        elif "transfer" in it.info and str(it.info.get("role", "")).startswith("out"):
            n = str(it.info["role"])[3:]  # "out", "out 2", ...
            out[it.name] = [roles[r] for r in ("leader", f"follower{n}") if r in roles]
    return out


def settings_from_recipe(recipe: Mapping) -> GenerationSettings | None:
    """The Generate-box settings that made a generated motion (for Re-record), or None if it was not generated."""
    try:
        operation = recipe.get("operation") or {}
        seconds = recipe.get("seconds")
        return GenerationSettings(prompt=str(recipe["prompt"]), seconds=None if seconds is None else float(seconds),
                                  seed=int(recipe["seed"]), steps=int(recipe["steps"]),
                                  guidance=float(recipe["guidance"]),
                                  # a recipe from before guidance_from was kept: classic guidance, at every step
                                  guidance_from=int(recipe.get("guidance_from", 0)),
                                  eta=float(recipe.get("eta", 0.0)),  # before eta was kept: deterministic DDIM
                                  record_steps=int(operation.get("record_steps", 10) or 10),
                                  # before sequences were generated clause by clause: one take of the whole prompt
                                  sequence=str(operation.get("sequence", "whole")),
                                  # a take that walked its gait along the corpus's path (a later try) does again
                                  held_path=operation.get("held_path") is True)
    except (KeyError, TypeError, ValueError, AttributeError):
        return None


def item_from_entry(library: MotionLibrary, entry: Entry, name: str) -> MotionItem:
    """A session motion for a library entry: its joints are read when first used (and may be let go again)."""
    settings = words = None
    if entry.kind == "generate":
        try:
            recipe = library.recipe(entry.id)
        except ValueError:
            recipe = {}
        settings = settings_from_recipe(recipe)
        words = tuple(str(w) for w in recipe.get("words") or ()) if isinstance(recipe.get("words"), list) else ()
    entry_id = entry.id
    return MotionItem(name=name, joints=None, source="imported" if entry.kind == "import" else "generated",
                      prompt=entry.prompt, words=words or (), settings=settings, kind=entry.kind,
                      library_id=entry.id, from_library=True, pinned=entry.pinned, frames=entry.frames,
                      loader=lambda: library.joints(entry_id))
