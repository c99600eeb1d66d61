"""The motion library: every motion made, edited or imported, kept on disk in the workspace (torch-free).

Layout of ``<workspace>/library``::

    index.sqlite            the index (engine.library.index): what listing, search and the size bound need
    motions/<id>/joints.npy     (T, 22, 3) float32, metres, 20 fps (plain .npy, never a pickle)
    motions/<id>/features.npy   (T', 263) float32 HumanML3D features, when the motion has them
    motions/<id>/recipe.json    how it was made: prompt, seed, steps, guidance, model, the edit/transfer chain
                                and its parents' ids (see :meth:`MotionLibrary.add`)

Writes are atomic: a motion's folder is written under a temporary name and renamed into place, then its index
row is inserted in one transaction; a recipe is rewritten to a temporary file and ``os.replace``-d. Several
processes and threads may write at once (each motion has its own folder, the index queues writers). A removed
motion's row goes first, then its folder. A row or folder that is damaged or not this library's is reported (one
line, through ``report``) and skipped, never fatal; an unusable index file is moved aside and rebuilt from the
recipes.

The library is bounded (``limit_mb``): past it, the least recently made unpinned motions are removed first, and
:meth:`MotionLibrary.add` says which (``Added.evicted``) so the front end can tell the user.
"""
from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import secrets
import shutil
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engine.library.index import Entry, Index, IndexUnusable, entry_from_row, valid_id
from engine.library.workspace import DEFAULT_LIMIT_MB, check_limit_mb, library_dir, limit_from_env
from engine.units import FPS

FORMAT = "moattn-motion"
FORMAT_VERSION = 1
JOINTS_FILE = "joints.npy"
FEATURES_FILE = "features.npy"
RECIPE_FILE = "recipe.json"
INDEX_FILE = "index.sqlite"
MOTIONS_DIR = "motions"
MAX_RECIPE_BYTES = 1 << 20  # a recipe larger than this is not one this library wrote
LEFTOVER_SECONDS = 3600.0  # temporary folders older than this (a crashed write) are cleared
ORPHAN_GRACE_SECONDS = 60.0  # a folder without an index row younger than this may be another process's add
#: what the recipe of every motion holds (None where it does not apply, e.g. an import has no seed)
RECIPE_KEYS = ("prompt", "seed", "steps", "guidance", "seconds", "model")
_CORE_KEYS = {"format", "version", "id", "kind", "title", "created", "created_utc", "frames", "fps", "digest", "pinned",
              "parents", "files", *RECIPE_KEYS}

Report = Callable[[str], None]


class LibraryError(ValueError):
    """A user-facing library problem (no such motion, a damaged entry, a bad limit): one line."""


@dataclass(frozen=True)
class Problem:
    """A damaged or foreign entry, skipped."""

    what: str  # an id or a folder name
    reason: str

    def __str__(self) -> str:
        return f"library: skipped {self.what}: {self.reason}"


@dataclass(frozen=True)
class Added:
    """What :meth:`MotionLibrary.add` did."""

    entry: Entry
    evicted: tuple[Entry, ...] = ()  # removed to stay within the bound (least recently made, unpinned)
    total_bytes: int = 0  # the library's size afterwards
    limit_bytes: int = 0
    reused: bool = False  # the same motion was there already (``reuse=True``): nothing new was written

    @property
    def over_limit(self) -> bool:
        """Still over the bound (pinned motions, or the new one, alone exceed it)."""
        return self.total_bytes > self.limit_bytes


def new_id() -> str:
    """``YYYYMMDD-HHMMSS-`` (UTC) and 8 random hex digits: sortable by time, unique across processes."""
    return time.strftime("%Y%m%d-%H%M%S", time.gmtime()) + "-" + secrets.token_hex(4)


def joints_digest(joints: np.ndarray) -> str:
    """sha256 (hex) of a motion's joints as stored: float32, C order, with its shape."""
    array = np.ascontiguousarray(joints, dtype=np.float32)
    h = hashlib.sha256(repr(array.shape).encode())
    h.update(array.tobytes())
    return h.hexdigest()


def check_joints(joints) -> np.ndarray:
    """Joints (T, 22, 3) float32, finite, T >= 1; ValueError otherwise."""
    array = np.asarray(joints)
    if array.ndim != 3 or array.shape[1:] != (22, 3) or len(array) < 1:
        raise LibraryError(f"a motion is joints of shape (T, 22, 3), got {array.shape}")
    if not np.issubdtype(array.dtype, np.number):
        raise LibraryError(f"a motion's joints are numbers, got {array.dtype}")
    array = np.ascontiguousarray(array, dtype=np.float32)
    if not np.isfinite(array).all():
        raise LibraryError("the motion contains NaN or infinite values")
    return array


def write_json_atomic(path: Path, data: dict) -> None:
    """Write JSON to a temporary file beside ``path``, flush it to disk, then ``os.replace`` it into place."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(3)}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(data, f, indent=1, ensure_ascii=False, allow_nan=False, default=str)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def _save_npy(path: Path, array: np.ndarray) -> None:
    with open(path, "wb") as f:
        np.save(f, array, allow_pickle=False)
        f.flush()
        os.fsync(f.fileno())


def jsonable(value, *, depth: int = 0, max_items: int = 256):
    """``value`` as plain JSON (dataclasses and mappings as objects, small arrays as lists, numpy scalars as
    numbers); what cannot be (a large array, an object) becomes a short description, so a recipe is always
    writable and never large."""
    if depth > 6:
        return "…"
    if value is None or isinstance(value, (bool, str)):
        return value if not isinstance(value, str) or len(value) <= 4000 else value[:4000] + "…"
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        f = float(value)
        return f if np.isfinite(f) else None
    if isinstance(value, np.ndarray):
        if value.size <= max_items and value.dtype.kind in "biuf":
            return jsonable(value.tolist(), depth=depth + 1)
        return f"array {tuple(value.shape)}"
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): jsonable(v, depth=depth + 1) for k, v in list(value.items())[:max_items]}
    if isinstance(value, (list, tuple, set, frozenset)):
        items = list(value)
        out = [jsonable(v, depth=depth + 1) for v in items[:max_items]]
        return out + ([f"… {len(items) - max_items} more"] if len(items) > max_items else [])
    if isinstance(value, Path):
        return str(value)
    return str(value)[:200]


class MotionLibrary:
    """The library in ``root`` (default: ``<workspace>/library``, see engine.library.workspace).

    ``limit_mb``: the size bound (None: $MOATTN_LIBRARY_MB, else the stored setting, else the default).
    ``report``: called with one line per damaged or foreign entry found (each once per library object).
    """

    def __init__(self, root: str | os.PathLike | None = None, *, workspace: str | os.PathLike | None = None,
                 limit_mb: float | None = None, report: Report | None = None):
        self.root = Path(root) if root is not None else library_dir(workspace)
        self.motions = self.root / MOTIONS_DIR
        self._limit_mb = None if limit_mb is None else check_limit_mb(limit_mb, what="--library-mb")
        self.report = report  # called with each problem's line (a front end may set it later)
        self._reported: set[tuple[str, str]] = set()
        self._lock = threading.Lock()
        self.problems: list[Problem] = []  # every problem found (reported or not), newest last
        self.motions.mkdir(parents=True, exist_ok=True)
        self.index = Index(self.root / INDEX_FILE)
        try:
            self.index.create()
        except IndexUnusable as exc:
            self._set_aside(exc)

    def __repr__(self) -> str:
        return f"MotionLibrary({str(self.root)!r})"

    # ------------------------------------------------------------------ problems
    def _problem(self, what: str, reason: str) -> Problem:
        problem = Problem(what, reason)
        with self._lock:
            self.problems.append(problem)
            del self.problems[:-200]
            new = (what, reason) not in self._reported
            self._reported.add((what, reason))
        if new and self.report is not None:
            try:
                self.report(str(problem))
            except Exception:
                pass
        return problem

    def _set_aside(self, exc: Exception) -> None:
        """The index file is unusable: move it (and its journal) aside, report it, rebuild from the recipes."""
        stamp = time.strftime("%Y%m%d-%H%M%S")
        aside = self.root / f"{INDEX_FILE}.unusable-{stamp}-{secrets.token_hex(2)}"
        for suffix in ("", "-wal", "-shm", "-journal"):
            src = self.root / (INDEX_FILE + suffix)
            with contextlib.suppress(FileNotFoundError):
                os.replace(src, Path(str(aside) + suffix))
        self._problem(INDEX_FILE, f"{exc}; moved to {aside.name}, the index is rebuilt from the motions' recipes")
        self.index.create()
        self.rebuild()

    # ------------------------------------------------------------------ limit
    @property
    def limit_mb(self) -> float:
        """The bound in MB: given, else $MOATTN_LIBRARY_MB, else stored (``set_limit_mb``), else the default."""
        if self._limit_mb is not None:
            return self._limit_mb
        env = limit_from_env()
        if env is not None:
            return env
        stored = self.index.setting("limit_mb")
        if stored is not None:
            try:
                return check_limit_mb(stored)
            except ValueError:
                self._problem("limit", f"the stored size bound {stored[:20]!r} is not a size: the default is used")
        return DEFAULT_LIMIT_MB

    @property
    def limit_bytes(self) -> int:
        return int(self.limit_mb * 2**20)

    def limit_source(self) -> str:
        if self._limit_mb is not None:
            return "given"
        if limit_from_env() is not None:
            return "MOATTN_LIBRARY_MB"
        return "stored" if self.index.setting("limit_mb") is not None else "default"

    def set_limit_mb(self, mb: float | None) -> tuple[Entry, ...]:
        """Store the bound (None: back to the default) for every later use of this library; applies it now and
        returns the motions it removed."""
        value = None if mb is None else check_limit_mb(mb)
        self.index.set_setting("limit_mb", None if value is None else repr(value))
        return self.enforce_limit()

    def enforce_limit(self, *, keep: Iterable[str] = ()) -> tuple[Entry, ...]:
        """Remove the least recently made unpinned motions until the library is within its bound."""
        rows, _ = self.index.evict(self.limit_bytes, keep=keep)
        removed = []
        for row in rows:
            self._remove_folder(row[1])
            with contextlib.suppress(ValueError):
                removed.append(entry_from_row(row))
        return tuple(removed)

    def total_bytes(self) -> int:
        return self.index.total_bytes()

    # ------------------------------------------------------------------ write
    def add(self, joints, *, kind: str, title: str, recipe: dict | None = None, features=None,
            parents: Iterable[str] = (), pinned: bool = False, reuse: bool = False) -> Added:
        """Keep a motion: its joints (and features) as .npy, its recipe as JSON, a row in the index; then apply the
        bound (never removing this one).

        ``recipe``: how it was made; the keys of RECIPE_KEYS (prompt, seed, steps, guidance, seconds, model) are
        always written (None where they do not apply), anything else given is kept as given (made JSON-safe), and
        ``parents`` / ``chain`` are added: the ids it was made from, and the steps from its first ancestor to it.
        ``reuse``: if a motion of this kind with the same joints and title is already kept, re-make that one (it
        counts as new for the bound) instead of adding a copy.
        """
        joints = check_joints(joints)
        kind = str(kind).strip() or "motion"
        title = str(title).strip() or kind
        digest = joints_digest(joints)
        if reuse:
            for row in reversed(self.index.find_digest(digest, kind=kind)):
                try:
                    entry = entry_from_row(row)
                except ValueError:
                    continue
                if entry.title == title and (self.motions / entry.id / JOINTS_FILE).exists():
                    now = time.time()
                    self.index.touch(entry.id, now)
                    entry = dataclasses.replace(entry, touched=now)
                    return Added(entry=entry, total_bytes=self.index.total_bytes(), limit_bytes=self.limit_bytes,
                                 reused=True)
        feats = None
        if features is not None:
            feats = np.ascontiguousarray(np.asarray(features), dtype=np.float32)
            if feats.ndim != 2 or not np.isfinite(feats).all():
                feats = None  # not features this library can keep: the joints are the motion
        parents = tuple(dict.fromkeys(str(p) for p in parents if p))
        recipe = jsonable(dict(recipe or {}))
        entry_id = new_id()
        now = time.time()
        data = {"format": FORMAT, "version": FORMAT_VERSION, "id": entry_id, "kind": kind, "title": title,
                "created": now, "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(now)),
                "frames": int(len(joints)), "fps": FPS, "digest": digest, "pinned": bool(pinned),
                **{k: recipe.pop(k, None) for k in RECIPE_KEYS}}
        data["prompt"] = str(data["prompt"] or "")
        recipe.pop("parents", None)
        recipe.pop("chain", None)
        data.update({k: v for k, v in recipe.items() if k not in data})
        data["parents"] = list(parents)
        chain = self._chain(parents) + [{"id": entry_id, "kind": kind, "title": title,
                                         **({"operation": data["operation"]} if "operation" in data else {})}]
        data["chain"] = chain
        data["files"] = {"joints": JOINTS_FILE, "features": FEATURES_FILE if feats is not None else None}
        if len(json.dumps(data, default=str)) > MAX_RECIPE_BYTES // 4:  # a job's details too large: kept short
            for key in [k for k in data if k not in _CORE_KEYS]:
                data[key] = f"(not kept: {key} was too large)"
            data["chain"] = [{k: v for k, v in step.items() if k != "operation"} for step in chain]

        tmp = self.motions / f".tmp-{entry_id}-{os.getpid()}"
        final = self.motions / entry_id
        try:
            tmp.mkdir(parents=True)
            _save_npy(tmp / JOINTS_FILE, joints)
            if feats is not None:
                _save_npy(tmp / FEATURES_FILE, feats)
            write_json_atomic(tmp / RECIPE_FILE, data)
            size = sum(p.stat().st_size for p in tmp.iterdir())
            os.replace(tmp, final)  # the folder appears whole or not at all
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        entry = Entry(id=entry_id, seq=0, created=now, touched=now, kind=kind, title=title, prompt=data["prompt"],
                      frames=int(len(joints)), bytes=int(size), pinned=bool(pinned), digest=digest, parents=parents)
        try:
            entry = self.index.insert(entry)
        except BaseException:
            shutil.rmtree(final, ignore_errors=True)
            raise
        evicted = self.enforce_limit(keep=[entry.id])
        return Added(entry=entry, evicted=evicted, total_bytes=self.index.total_bytes(), limit_bytes=self.limit_bytes)

    def _chain(self, parents: tuple[str, ...]) -> list[dict]:
        """The first parent's chain (from its own recipe), or a stub naming it when it is gone."""
        if not parents:
            return []
        first = parents[0]
        try:
            chain = self.recipe(first).get("chain")
            if isinstance(chain, list) and all(isinstance(step, dict) for step in chain):
                return chain[-50:]
        except LibraryError:
            pass
        return [{"id": first, "kind": "missing", "title": "(no longer in the library)"}]

    def touch(self, entry_id: str) -> None:
        """The motion was made again (the same import, say): the bound counts it as the newest."""
        self.index.touch(self.resolve(entry_id))

    def pin(self, entry_id: str, pinned: bool = True) -> Entry:
        """Pin (kept whatever the bound) or unpin a motion; returns it."""
        entry = self.get(entry_id)
        if not self.index.set_pinned(entry.id, pinned):
            raise LibraryError(f"no motion {entry.id} in the library (removed meanwhile)")
        path = self.motions / entry.id / RECIPE_FILE
        with contextlib.suppress(LibraryError, OSError):
            data = self.recipe(entry.id)
            data["pinned"] = bool(pinned)
            write_json_atomic(path, data)
        if not pinned:
            self.enforce_limit()
        return dataclasses.replace(entry, pinned=bool(pinned))

    def remove(self, ids: Iterable[str]) -> tuple[Entry, ...]:
        """Delete these motions (their rows, then their folders); returns the ones that were there. A damaged
        entry can always be removed."""
        ids = [self.resolve(i) for i in ids]
        rows = self.index.delete(ids)
        removed = []
        for row in rows:
            self._remove_folder(row[1])
            with contextlib.suppress(ValueError):
                removed.append(entry_from_row(row))
        for entry_id in set(ids) - {r[1] for r in rows}:  # a folder the index did not list (a foreign entry)
            self._remove_folder(entry_id)
        return tuple(removed)

    def _remove_folder(self, entry_id: str) -> None:
        folder = self.motions / entry_id
        trash = self.motions / f".trash-{entry_id}-{secrets.token_hex(3)}"
        try:
            os.replace(folder, trash)  # gone from its name at once, however long the delete takes
        except OSError:
            return
        shutil.rmtree(trash, ignore_errors=True)

    # ------------------------------------------------------------------ read
    def entries(self, *, search: str | None = None, kind: str | None = None, pinned: bool | None = None,
                after_seq: int | None = None, limit: int | None = None, newest_first: bool = False,
                ids: Iterable[str] | None = None) -> list[Entry]:
        """The motions kept, oldest first (``newest_first`` reverses), filtered: ``search`` (every word in the
        prompt or the title, any case), ``kind``, ``pinned``. A row that is damaged or foreign, or whose files are
        gone, is reported and skipped."""
        out = []
        for row in self.index.rows(search=search, kind=kind, pinned=pinned, after_seq=after_seq, limit=limit,
                                   newest_first=newest_first, ids=ids):
            try:
                entry = entry_from_row(row)
            except ValueError as exc:
                self._problem(str(row[1])[:40] if len(row) > 1 else "?", str(exc))
                continue
            if not (self.motions / entry.id / JOINTS_FILE).is_file():
                self._problem(entry.id, _missing(entry))
                continue
            out.append(entry)
        return out

    def resolve(self, entry_id: str) -> str:
        """A full id from an id or a unique prefix of one (``moattn library show 20250101-1200``)."""
        text = str(entry_id).strip()
        if not text:
            raise LibraryError("no motion id given")
        if valid_id(text):
            return text
        found = self.index.ids_with_prefix(text)
        if len(found) == 1:
            return found[0]
        if not found:
            raise LibraryError(f"no motion {text[:40]!r} in the library (see `moattn library list`)")
        raise LibraryError(f"{text[:40]!r} names {len(found)} motions: give more of the id")

    def get(self, entry_id: str) -> Entry:
        entry_id = self.resolve(entry_id)
        rows = self.index.rows(ids=[entry_id])
        if not rows:
            raise LibraryError(f"no motion {entry_id} in the library (see `moattn library list`)")
        try:
            return entry_from_row(rows[0])
        except ValueError as exc:
            self._problem(entry_id, str(exc))
            raise LibraryError(f"motion {entry_id} is damaged: {exc}") from None

    def joints(self, entry_id: str) -> np.ndarray:
        """The motion's joints (T, 22, 3) float32, checked against its digest; LibraryError if damaged or gone."""
        entry = self.get(entry_id)
        path = self.motions / entry.id / JOINTS_FILE
        try:
            array = np.load(path, allow_pickle=False)
        except FileNotFoundError:
            raise self._damaged(entry, "its joints file is missing") from None
        except (ValueError, OSError, EOFError) as exc:
            raise self._damaged(entry, f"its joints file cannot be read ({str(exc)[:80]})") from None
        try:
            array = check_joints(array)
        except LibraryError as exc:
            raise self._damaged(entry, str(exc)) from None
        if joints_digest(array) != entry.digest:
            raise self._damaged(entry, "its joints do not match their digest (changed on disk)")
        return array

    def features(self, entry_id: str) -> np.ndarray | None:
        """The motion's features (T', 263), or None if it has none or they cannot be read."""
        path = self.motions / self.resolve(entry_id) / FEATURES_FILE
        if not path.exists():
            return None
        try:
            array = np.load(path, allow_pickle=False)
        except (ValueError, OSError, EOFError):
            return None
        return array if array.ndim == 2 and array.dtype == np.float32 else None

    def recipe(self, entry_id: str) -> dict:
        """The motion's recipe (its recipe.json); LibraryError if it is missing, damaged or not this library's."""
        entry_id = self.resolve(entry_id)
        path = self.motions / entry_id / RECIPE_FILE
        try:
            data = _read_recipe(path)
        except FileNotFoundError:
            raise LibraryError(f"motion {entry_id} has no recipe (no longer in the library?)") from None
        except ValueError as exc:
            self._problem(entry_id, str(exc))
            raise LibraryError(f"motion {entry_id}: {exc}") from None
        if data.get("id") != entry_id:
            self._problem(entry_id, "its recipe names another motion")
            raise LibraryError(f"motion {entry_id}: its recipe names another motion")
        return data

    def _damaged(self, entry: Entry, reason: str) -> LibraryError:
        self._problem(entry.id, f"{entry.title[:60]!r}: {reason}")
        return LibraryError(f"motion {entry.id} ({entry.title[:60]}) is damaged: {reason}")

    def find(self, joints, *, kind: str | None = None) -> list[Entry]:
        """Motions kept with exactly these joints (of ``kind``), oldest first."""
        out = []
        for row in self.index.find_digest(joints_digest(check_joints(joints)), kind=kind):
            with contextlib.suppress(ValueError):
                out.append(entry_from_row(row))
        return out

    def last_seq(self) -> int:
        return self.index.last_seq()

    def count(self) -> int:
        return self.index.count()

    # ------------------------------------------------------------------ upkeep
    def check(self) -> list[Problem]:
        """Every problem now: rows damaged or without files, folders the index does not list (foreign, or left by
        an interrupted write); each reported once. Clears temporary folders left by crashed writes."""
        found: list[Problem] = []
        listed = set()
        for row in self.index.rows():
            try:
                entry = entry_from_row(row)
            except ValueError as exc:
                found.append(self._problem(str(row[1])[:40], str(exc)))
                continue
            listed.add(entry.id)
            if not (self.motions / entry.id / JOINTS_FILE).is_file():
                found.append(self._problem(entry.id, _missing(entry)))
        now = time.time()
        for path in self.motions.iterdir():
            name = path.name
            try:
                age = now - path.stat().st_mtime
            except OSError:
                continue
            if name.startswith((".tmp-", ".trash-")):
                if age > LEFTOVER_SECONDS or name.startswith(".trash-"):
                    shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)
                continue
            if name in listed or age < ORPHAN_GRACE_SECONDS:
                continue
            what = "not a motion folder" if not path.is_dir() else "not in the index (foreign, or an interrupted write)"
            found.append(self._problem(f"{MOTIONS_DIR}/{name[:40]}", what))
        return found

    def rebuild(self) -> int:
        """Insert a row for every motion folder with a valid recipe that the index lacks (after an index was lost);
        returns how many. Damaged or foreign folders are reported and skipped."""
        listed = {r[1] for r in self.index.rows()}
        added = 0
        found: list[Entry] = []
        for path in sorted(self.motions.iterdir()):
            if path.name.startswith(".") or path.name in listed or not path.is_dir():
                continue
            try:
                data = _read_recipe(path / RECIPE_FILE)
                if data.get("id") != path.name or not valid_id(path.name):
                    raise ValueError("its recipe names another motion")
                joints_path = path / JOINTS_FILE
                if not joints_path.is_file():
                    raise ValueError("its joints file is missing")
                entry = Entry(id=path.name, seq=0, created=float(data["created"]), touched=float(data["created"]),
                              kind=str(data["kind"]), title=str(data["title"]), prompt=str(data.get("prompt") or ""),
                              frames=int(data["frames"]), bytes=sum(p.stat().st_size for p in path.iterdir()),
                              pinned=bool(data.get("pinned", False)), digest=str(data["digest"]),
                              parents=tuple(str(p) for p in data.get("parents") or ()))
            except FileNotFoundError:
                self._problem(f"{MOTIONS_DIR}/{path.name[:40]}", "no recipe.json: not a motion of this library")
                continue
            except (ValueError, KeyError, TypeError) as exc:
                self._problem(f"{MOTIONS_DIR}/{path.name[:40]}", f"cannot be rebuilt: {str(exc)[:100]}")
                continue
            found.append(entry)
        for entry in sorted(found, key=lambda e: (e.created, e.id)):  # in the order they were made
            try:
                self.index.insert(entry)
                added += 1
            except Exception as exc:  # e.g. another process rebuilt it meanwhile
                self._problem(entry.id, f"not re-indexed: {str(exc)[:100]}")
        return added


def _missing(entry: Entry) -> str:
    return f"{entry.title[:60]!r}: its files are missing (deleted outside the library?)"


def _read_recipe(path: Path) -> dict:
    """A recipe.json of this library (format, version, the fields listing needs); ValueError saying what is wrong,
    FileNotFoundError if there is none."""
    size = path.stat().st_size
    if size > MAX_RECIPE_BYTES:
        raise ValueError(f"its recipe is {size} bytes: not one this library wrote")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"its recipe is not JSON ({str(exc)[:60]})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ValueError("its recipe is not a moattn motion recipe (foreign entry)")
    if not isinstance(data.get("version"), int) or data["version"] > FORMAT_VERSION:
        raise ValueError(f"its recipe has format version {data.get('version')!r} (newer than this program's)")
    for key, kind in (("kind", str), ("title", str), ("frames", int), ("digest", str)):
        if not isinstance(data.get(key), kind):
            raise ValueError(f"its recipe's {key!r} is missing or malformed")
    return data
