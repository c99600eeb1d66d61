"""The library's index: one SQLite table of motions (Python's ``sqlite3``), safe for several processes at once.

Every write is one transaction (``BEGIN IMMEDIATE``: writers queue, each waits up to :data:`BUSY_SECONDS`), the
journal is write-ahead (readers never block writers). A connection is opened per operation, so the index can be
used from any thread and any process. The index holds what listing and the size bound need; each motion's full
recipe is the ``recipe.json`` in its folder (:mod:`engine.library.store`), from which a lost or damaged index is
rebuilt.
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import sqlite3
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from engine.units import FPS

SCHEMA_VERSION = 1
APPLICATION_ID = 0x6D6F6174  # "moat": marks the file as this library's index (a foreign SQLite file is not)
BUSY_SECONDS = 30.0

COLUMNS = ("seq", "id", "created", "touched", "kind", "title", "prompt", "frames", "bytes", "pinned", "digest",
           "parents")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS motions (
    seq      INTEGER PRIMARY KEY AUTOINCREMENT,
    id       TEXT    NOT NULL UNIQUE,
    created  REAL    NOT NULL,
    touched  REAL    NOT NULL,
    kind     TEXT    NOT NULL,
    title    TEXT    NOT NULL,
    prompt   TEXT    NOT NULL DEFAULT '',
    frames   INTEGER NOT NULL,
    bytes    INTEGER NOT NULL,
    pinned   INTEGER NOT NULL DEFAULT 0,
    digest   TEXT    NOT NULL,
    parents  TEXT    NOT NULL DEFAULT '[]'
);
CREATE INDEX IF NOT EXISTS motions_touched ON motions (pinned, touched, seq);
CREATE INDEX IF NOT EXISTS motions_digest ON motions (digest);
CREATE TABLE IF NOT EXISTS settings (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""


class IndexUnusable(Exception):
    """The index file cannot be used (not SQLite, not this library's, damaged)."""


@dataclass(frozen=True)
class Entry:
    """One motion of the library as the index lists it."""

    id: str
    seq: int  # order of arrival (never reused)
    created: float  # Unix time it was made
    touched: float  # Unix time it was last made or re-made (the size bound removes the least recent first)
    kind: str  # generate | edit | transfer | compose | control | duet | import | ...
    title: str
    prompt: str
    frames: int
    bytes: int  # its files' size on disk
    pinned: bool
    digest: str  # sha256 of its joints (float32, C order), hex
    parents: tuple[str, ...]  # ids of the motions it was made from (an edit's source, a transfer's leader/follower)

    @property
    def seconds(self) -> float:
        return self.frames / FPS

    def to_json(self) -> dict:
        return {"id": self.id, "kind": self.kind, "title": self.title, "prompt": self.prompt, "frames": self.frames,
                "seconds": round(self.seconds, 2), "bytes": self.bytes, "pinned": self.pinned,
                "created": self.created, "touched": self.touched, "parents": list(self.parents),
                "digest": self.digest}


def entry_from_row(row: sqlite3.Row | tuple) -> Entry:
    """An Entry from a row of ``COLUMNS``; ValueError (what is wrong) for a row this library did not write."""
    values = dict(zip(COLUMNS, row))
    try:
        parents = json.loads(values["parents"] or "[]")
        if not isinstance(parents, list) or not all(isinstance(p, str) for p in parents):
            raise ValueError("its parents are not a list of ids")
        entry = Entry(id=str(values["id"]), seq=int(values["seq"]), created=float(values["created"]),
                      touched=float(values["touched"]), kind=str(values["kind"]), title=str(values["title"]),
                      prompt=str(values["prompt"] or ""), frames=int(values["frames"]), bytes=int(values["bytes"]),
                      pinned=bool(values["pinned"]), digest=str(values["digest"]), parents=tuple(parents))
    except (TypeError, ValueError, json.JSONDecodeError) as exc:
        raise ValueError(f"its index row is malformed ({exc})") from None
    if not valid_id(entry.id):
        raise ValueError("its id is not one this library makes")
    if entry.frames < 1 or entry.bytes < 0:
        raise ValueError(f"its index row says {entry.frames} frames, {entry.bytes} bytes")
    return entry


def valid_id(text: str) -> bool:
    """Ids are made by :func:`engine.library.store.new_id`: ``YYYYMMDD-HHMMSS-`` and 8 hex digits."""
    if len(text) != 24 or text[8] != "-" or text[15] != "-":
        return False
    return text[:8].isdigit() and text[9:15].isdigit() and all(c in "0123456789abcdef" for c in text[16:])


class Index:
    """The SQLite file ``path``: connect per operation, one transaction per write."""

    def __init__(self, path: Path):
        self.path = Path(path)

    @contextlib.contextmanager
    def connect(self, *, write: bool = False) -> Iterator[sqlite3.Connection]:
        """A connection; with ``write`` inside ``BEGIN IMMEDIATE`` ... ``COMMIT`` (rolled back on an error)."""
        con = sqlite3.connect(self.path, timeout=BUSY_SECONDS, isolation_level=None)
        try:
            con.execute(f"PRAGMA busy_timeout = {int(BUSY_SECONDS * 1000)}")
            if write:
                con.execute("BEGIN IMMEDIATE")
                try:
                    yield con
                except BaseException:
                    con.execute("ROLLBACK")
                    raise
                con.execute("COMMIT")
            else:
                yield con
        finally:
            con.close()

    def create(self) -> None:
        """Make the schema (idempotent; several processes may race here). Raises IndexUnusable for a file that is
        not this library's index (not SQLite, damaged, another application's, a newer schema)."""
        try:
            with self.connect() as con:
                app_id = con.execute("PRAGMA application_id").fetchone()[0]
                version = con.execute("PRAGMA user_version").fetchone()[0]
                tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
                if app_id not in (0, APPLICATION_ID) or (app_id == 0 and tables - {"sqlite_sequence"}):
                    raise IndexUnusable(f"{self.path} is another program's SQLite file")
                if version > SCHEMA_VERSION:
                    raise IndexUnusable(f"{self.path} was written by a newer version (schema {version})")
                if app_id == APPLICATION_ID and version == SCHEMA_VERSION and "motions" in tables:
                    self._check_columns(con)
                    return
                try:
                    con.execute("PRAGMA journal_mode = WAL")
                except sqlite3.DatabaseError:
                    pass  # e.g. a filesystem without shared memory: the rollback journal still works
                con.execute("BEGIN IMMEDIATE")
                try:
                    for statement in _SCHEMA.split(";"):
                        if statement.strip():
                            con.execute(statement)
                    con.execute(f"PRAGMA application_id = {APPLICATION_ID}")
                    con.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
                    con.execute("COMMIT")
                except BaseException:
                    with contextlib.suppress(sqlite3.Error):
                        con.execute("ROLLBACK")
                    raise
                self._check_columns(con)
        except sqlite3.DatabaseError as exc:
            raise IndexUnusable(f"{self.path} cannot be read as the library's index ({exc})") from None

    def _check_columns(self, con: sqlite3.Connection) -> None:
        have = [r[1] for r in con.execute("PRAGMA table_info(motions)")]
        if tuple(have) != COLUMNS:
            raise IndexUnusable(f"{self.path} has a motions table of another layout ({', '.join(have)[:80]})")
        problem = con.execute("PRAGMA quick_check").fetchone()[0]
        if problem != "ok":
            raise IndexUnusable(f"{self.path} is damaged ({problem})")

    # ------------------------------------------------------------------ reads
    def rows(self, *, search: str | None = None, kind: str | None = None, pinned: bool | None = None,
             after_seq: int | None = None, ids: Iterable[str] | None = None, limit: int | None = None,
             newest_first: bool = False) -> list[tuple]:
        where, args = [], []
        if search:
            words = [w for w in search.lower().split() if w]
            for w in words:  # every word, anywhere in the prompt or the title
                pattern = "%" + w.replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_") + "%"
                where.append("(lower(prompt) LIKE ? ESCAPE '\\' OR lower(title) LIKE ? ESCAPE '\\')")
                args += [pattern, pattern]
        if kind:
            where.append("kind = ?")
            args.append(kind)
        if pinned is not None:
            where.append("pinned = ?")
            args.append(int(pinned))
        if after_seq is not None:
            where.append("seq > ?")
            args.append(int(after_seq))
        if ids is not None:
            ids = list(ids)
            if not ids:
                return []
            where.append(f"id IN ({','.join('?' * len(ids))})")
            args += ids
        sql = f"SELECT {', '.join(COLUMNS)} FROM motions"
        if where:
            sql += " WHERE " + " AND ".join(where)
        sql += " ORDER BY seq" + (" DESC" if newest_first else "")
        if limit is not None:
            sql += f" LIMIT {int(limit)}"
        with self.connect() as con:
            return con.execute(sql, args).fetchall()

    def ids_with_prefix(self, prefix: str) -> list[str]:
        pattern = prefix.replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_") + "%"
        with self.connect() as con:
            return [r[0] for r in con.execute("SELECT id FROM motions WHERE id LIKE ? ESCAPE '\\' ORDER BY seq",
                                              (pattern,))]

    def find_digest(self, digest: str, *, kind: str | None = None) -> list[tuple]:
        sql = f"SELECT {', '.join(COLUMNS)} FROM motions WHERE digest = ?"
        args: list = [digest]
        if kind:
            sql += " AND kind = ?"
            args.append(kind)
        with self.connect() as con:
            return con.execute(sql + " ORDER BY seq", args).fetchall()

    def total_bytes(self) -> int:
        with self.connect() as con:
            return int(con.execute("SELECT COALESCE(SUM(bytes), 0) FROM motions").fetchone()[0])

    def count(self) -> int:
        with self.connect() as con:
            return int(con.execute("SELECT COUNT(*) FROM motions").fetchone()[0])

    def last_seq(self) -> int:
        with self.connect() as con:
            return int(con.execute("SELECT COALESCE(MAX(seq), 0) FROM motions").fetchone()[0])

    def setting(self, key: str) -> str | None:
        with self.connect() as con:
            row = con.execute("SELECT value FROM settings WHERE key = ?", (key,)).fetchone()
        return None if row is None else str(row[0])

    # ------------------------------------------------------------------ writes
    def insert(self, entry: Entry) -> Entry:
        """Add ``entry`` (its ``seq`` is assigned here); returns it with its seq."""
        with self.connect(write=True) as con:
            cur = con.execute(
                "INSERT INTO motions (id, created, touched, kind, title, prompt, frames, bytes, pinned, digest, "
                "parents) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                (entry.id, entry.created, entry.touched, entry.kind, entry.title, entry.prompt, entry.frames,
                 entry.bytes, int(entry.pinned), entry.digest, json.dumps(list(entry.parents))))
            seq = int(cur.lastrowid)
        return dataclasses.replace(entry, seq=seq)

    def touch(self, entry_id: str, when: float | None = None) -> None:
        with self.connect(write=True) as con:
            con.execute("UPDATE motions SET touched = ? WHERE id = ?", (time.time() if when is None else when,
                                                                        entry_id))

    def set_pinned(self, entry_id: str, pinned: bool) -> bool:
        with self.connect(write=True) as con:
            return con.execute("UPDATE motions SET pinned = ? WHERE id = ?", (int(pinned), entry_id)).rowcount > 0

    def delete(self, ids: Iterable[str]) -> list[tuple]:
        """Remove these ids' rows in one transaction; returns the rows removed."""
        ids = list(ids)
        if not ids:
            return []
        marks = ",".join("?" * len(ids))
        with self.connect(write=True) as con:
            rows = con.execute(f"SELECT {', '.join(COLUMNS)} FROM motions WHERE id IN ({marks})", ids).fetchall()
            con.execute(f"DELETE FROM motions WHERE id IN ({marks})", ids)
        return rows

    def evict(self, limit_bytes: int, *, keep: Iterable[str] = ()) -> tuple[list[tuple], int]:
        """In one transaction: remove the least recently made unpinned motions (never those in ``keep``) until the
        total is within ``limit_bytes``. Returns (the rows removed, the total after)."""
        keep = set(keep)
        with self.connect(write=True) as con:
            total = int(con.execute("SELECT COALESCE(SUM(bytes), 0) FROM motions").fetchone()[0])
            if total <= limit_bytes:
                return [], total
            removed = []
            cur = con.execute(f"SELECT {', '.join(COLUMNS)} FROM motions WHERE pinned = 0 ORDER BY touched, seq")
            for row in cur.fetchall():
                if total <= limit_bytes:
                    break
                if row[1] in keep:
                    continue
                removed.append(row)
                total -= int(row[8])
            if removed:
                ids = [r[1] for r in removed]
                con.execute(f"DELETE FROM motions WHERE id IN ({','.join('?' * len(ids))})", ids)
        return removed, total

    def set_setting(self, key: str, value: str | None) -> None:
        with self.connect(write=True) as con:
            if value is None:
                con.execute("DELETE FROM settings WHERE key = ?", (key,))
            else:
                con.execute("INSERT INTO settings (key, value) VALUES (?, ?) "
                            "ON CONFLICT(key) DO UPDATE SET value = excluded.value", (key, value))
