"""The session core's motion list: every motion a session can show (``items``, in creation order), the Motion
list's search and kind filter, and the motion library behind it (engine.library): every motion added is kept there
(a job's motions together, linked to the motions they were made from), motions kept by other sessions appear, and
library motions let go of their joints when many are loaded. ``MotionList`` is one part of ``StudioState``; it
knows no tab (tabs hand their motions to the job runner in a ``Delivery``, imports call ``show_motion``).
"""
from __future__ import annotations

import traceback
from pathlib import Path

import numpy as np
import param

from app.session.items import MAX_ITEMS_WITH_ATTENTION, MAX_LOADED_ITEMS, MotionItem
from app.session.library import KIND_LABELS, item_from_entry, item_kind, job_parents, recipe_of


class MotionList(param.Parameterized):
    """The session's motions and their library. Uses the session's notices (``error``, ``warning``, ``info``) and
    its viewer rule (``show``, ``current``, ``compare``, ``also``)."""

    items = param.Dict(default={}, doc="name -> MotionItem, in creation order (with a library: all its motions)")
    motion_search = param.String(default="", label="Search", doc="the Motion list shows motions whose prompt or "
                                 "name has every word typed here")
    motion_kind = param.Selector(default="", objects={v: k for k, v in KIND_LABELS.items()}, label="Kind",
                                 doc="the Motion list shows motions of this kind")
    library_status = param.String(default="", doc="one line on the motion library (motions, size of its bound, "
                                                  "folder); empty without a library")

    def unique_name(self, base: str) -> str:
        name, k = base, 2
        while name in self.items:
            name, k = f"{base} ({k})", k + 1
        return name

    def add_item(self, item: MotionItem, *, show: bool = True, keep: bool = True) -> None:
        """Add a motion to the session's list (and show it); with a library it is kept there too (``keep=False``:
        not yet; the job runner keeps a job's motions together once it has added them all, so that their links are
        known). Nothing is dropped: memory stays bounded because old motions let go of their attention maps (and
        say so) and library motions of their joints (read again when used)."""
        items = dict(self.items)
        items[item.name] = item
        with param.parameterized.batch_call_watchers(self):
            self.items = items
            self._bound_memory(keep=item.name)
            if show:
                self.show(item.name)
        if keep:
            self._keep([item.name])

    def _bound_memory(self, *, keep: str = "") -> None:
        """Old motions lose their recorded maps and denoising steps; library motions not shown let go of their
        joints past MAX_LOADED_ITEMS."""
        items = self.items

        def oldest_past_bound(attr: str) -> list[str]:
            """Names holding ``attr`` beyond the newest MAX_ITEMS_WITH_ATTENTION (``keep`` counted first)."""
            have = [n for n, it in items.items() if getattr(it, attr) is not None]
            kept = ([keep] if keep in have else [])
            kept += [n for n in have if n != keep][::-1][:MAX_ITEMS_WITH_ATTENTION - len(kept)]
            return [n for n in have if n not in kept]

        for name in oldest_past_bound("attention"):
            items[name].attention = None  # keep memory bounded: old motions lose their maps (and say so)
            items[name].evicted = True
        for name in oldest_past_bound("denoising"):
            items[name].denoising = None  # as bounded: the step slider is there for the newest motions
        shown = {keep, self.current, self.compare, *self.also}
        loaded = [it for n, it in items.items() if it.loaded and it.loader is not None and n not in shown]
        for it in loaded[:max(0, len(loaded) - MAX_LOADED_ITEMS)]:
            it.release()

    def show_motion(self, joints: np.ndarray, *, title: str, source: str = "imported") -> MotionItem:
        """Add a plain motion (file import, example) and show it; the same file imported again (the same joints
        and title) shows the motion the library keeps for it instead of a copy."""
        joints = np.asarray(joints, dtype=np.float32)
        if joints.ndim != 3 or joints.shape[1:] != (22, 3) or len(joints) < 1:
            raise ValueError(f"a motion must have shape (T, 22, 3), got {joints.shape}")
        if not np.isfinite(joints).all():
            raise ValueError("the motion contains NaN or infinite values")
        if self.library is not None and source == "imported":
            known = self._library_twin(joints, title)
            if known is not None:
                self.show(known.name)
                return known
        item = MotionItem(name=self.unique_name(title), joints=joints, source=source)
        self.add_item(item)
        return item

    # ------------------------------------------------------------------ the motion library
    def _library_twin(self, joints: np.ndarray, title: str) -> MotionItem | None:
        """The session motion of the import the library keeps with these joints and this title, if any."""
        try:
            ids = {e.id for e in self.library.find(joints, kind="import") if e.title == title}
        except Exception:
            return None
        if not ids:
            return None
        self.sync_library()
        for item in self.items.values():
            if item.library_id in ids:
                try:
                    self.library.touch(item.library_id)  # re-made: the bound counts it as new
                except Exception:
                    pass
                return item
        return None

    def _keep(self, names: list[str]) -> None:
        """Keep these session motions (added together by one job, or one at a time) in the library, linked to
        the motions they were made from; say when the bound removed older ones."""
        if self.library is None or not names:
            return
        added = [self.items[n] for n in names if n in self.items and self.items[n].library_id is None]
        parents = job_parents(added, self.items, compare=self.compare)
        evicted = []
        for item in added:
            ids = [self.items[p].library_id for p in parents.get(item.name, ()) if p in self.items]
            try:
                done = self.library.add(item.joints, kind=item_kind(item), title=item.name, features=item.features,
                                        recipe=recipe_of(item, model_dir=self.model_dir),
                                        parents=[i for i in ids if i])
            except Exception as exc:  # a full disk, a read-only workspace: the session keeps it, says why
                traceback.print_exc()
                self.error(f"{item.name!r} was not kept in the motion library: {exc}")
                continue
            item.library_id = done.entry.id
            item.kind = done.entry.kind
            item.loader = lambda library=self.library, entry_id=done.entry.id: library.joints(entry_id)
            evicted += done.evicted
            if done.over_limit:
                self.warning(f"the motion library is over its {done.limit_bytes / 2**20:g} MB bound "
                             f"({done.total_bytes / 2**20:.1f} MB): pinned motions are never removed")
        if evicted:
            gone = [e.title for e in evicted]
            self.warning(f"the motion library reached its {self.library.limit_mb:g} MB bound: removed the "
                         f"{len(gone)} least recently made unpinned motion{'s' if len(gone) != 1 else ''} "
                         f"({', '.join(repr(t[:40]) for t in gone[:3])}{' ...' if len(gone) > 3 else ''}). "
                         f"Pin a motion to keep it.")
        self.sync_library()

    def sync_library(self) -> None:
        """Bring the session's motions in line with the library: motions kept by other sessions (or the CLI) are
        added, motions removed there (deleted, or past the bound) are dropped unless shown."""
        if self.library is None:
            return
        try:
            entries = self.library.entries()
            total = self.library.total_bytes()
        except Exception as exc:
            traceback.print_exc()
            self.error(f"the motion library cannot be read: {exc}")
            return
        present = {e.id for e in entries}
        items = dict(self.items)
        shown = {self.current, self.compare, *self.also}
        changed = False
        for name, it in list(items.items()):
            if it.library_id and it.library_id not in present:
                changed = True
                if name in shown and it.loaded:
                    it.library_id, it.loader = None, None  # still shown: it stays, no longer kept
                else:
                    del items[name]
        by_id = {it.library_id: it for it in items.values() if it.library_id}
        for entry in entries:
            it = by_id.get(entry.id)
            if it is None:
                name = _unique(entry.title, items)
                items[name] = item_from_entry(self.library, entry, name)
                changed = True
            elif it.pinned != entry.pinned:
                it.pinned = entry.pinned  # pinned or unpinned elsewhere
                changed = True
        with param.parameterized.batch_call_watchers(self):
            if changed:
                self.items = items
            self.library_status = (f"{len(entries)} motion{'s' if len(entries) != 1 else ''} kept, "
                                   f"{total / 2**20:.1f} of {self.library.limit_mb:g} MB, in "
                                   f"{_home_relative(self.library.root)}")

    def listed_names(self) -> list[str]:
        """The motions the Motion list shows: every motion matching the search words and the kind, oldest first
        (the shown one always)."""
        words = self.motion_search.lower().split()
        kind = self.motion_kind
        out = []
        for name, it in self.items.items():
            if kind and item_kind(it) != kind and name != self.current:
                continue
            text = f"{name} {it.prompt}".lower()
            if any(w not in text for w in words) and name != self.current:
                continue
            out.append(name)
        return out

    def delete_motion(self, name: str) -> bool:
        """Delete a motion from the session and the library; another motion is shown if it was. False (and a
        notification) if there is no such motion."""
        item = self.items.get(name)
        if item is None:
            self.error(f"no motion named {name!r} to delete")
            return False
        if self.library is not None and item.library_id:
            try:
                self.library.remove([item.library_id])
            except Exception as exc:
                self.error(f"{name!r} could not be deleted from the motion library: {exc}")
                return False
        items = {n: it for n, it in self.items.items() if n != name}
        with param.parameterized.batch_call_watchers(self):
            self.items = items
            if self.compare == name:
                self.compare = ""
            if name in self.also:
                self.also = [n for n in self.also if n != name]
            self.frame_colors = {k: v for k, v in self.frame_colors.items() if k != name}
            if self.current == name:
                rest = [n for n in self.listed_names() if n != name] or list(items)
                if rest:
                    self.show(rest[-1])
                else:
                    self.current = ""
        self.info(f"deleted {name!r}")
        self.sync_library()
        return True

    def pin_motion(self, name: str, pinned: bool = True) -> bool:
        """Pin a motion (kept whatever the library's bound) or unpin it."""
        item = self.items.get(name)
        if item is None or self.library is None or not item.library_id:
            self.error("only a motion kept in the library can be pinned")
            return False
        try:
            self.library.pin(item.library_id, pinned)
        except Exception as exc:
            self.error(f"{name!r} could not be {'pinned' if pinned else 'unpinned'}: {exc}")
            return False
        item.pinned = bool(pinned)
        self.param.trigger("items")
        return True

    def _readable(self, item: MotionItem) -> bool:
        """Whether the motion's joints can be had (a library motion is read now); if not, it is reported, taken off
        the list, and False."""
        if item.loaded or item.loader is None:
            return True
        try:
            item.joints
            return True
        except Exception as exc:
            self.error(f"{item.name!r} cannot be shown: {exc}")
            self.items = {n: it for n, it in self.items.items() if it is not item}
            return False



def _home_relative(path: Path) -> str:
    """``path`` with the home folder written ~ (the status line stays short)."""
    try:
        return "~/" + str(Path(path).resolve().relative_to(Path.home().resolve()))
    except (ValueError, OSError, RuntimeError):
        return str(path)


def _unique(base: str, taken) -> str:
    name, k = base, 2
    while name in taken:
        name, k = f"{base} ({k})", k + 1
    return name

