"""The motion library on disk (engine.library): atomic writes, the SQLite index, concurrent writers (processes and
threads) losing nothing, damaged or foreign entries reported and skipped, the size bound removing the least
recently made unpinned motions first, and the workspace's resolution. Torch-free, no model."""
from __future__ import annotations

import json
import multiprocessing
import os
import sqlite3
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from engine.library import LibraryError, MotionLibrary, library_dir, workspace_dir
from engine.library.store import JOINTS_FILE, RECIPE_FILE, joints_digest


def motion(seed: int, frames: int = 40) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.normal(size=(frames, 22, 3)).astype(np.float32)


def add(lib: MotionLibrary, seed: int, *, frames: int = 40, kind: str = "generate", title: str | None = None,
        **kw):
    return lib.add(motion(seed, frames), kind=kind, title=title or f"a person walks · seed {seed}",
                   recipe={"prompt": f"a person walks {seed}", "seed": seed, "steps": 10, "guidance": 2.5,
                           "model": {"folder": "/m", "name": "m"}}, **kw)


@pytest.fixture
def lib(tmp_path) -> MotionLibrary:
    problems: list[str] = []
    library = MotionLibrary(tmp_path / "library", report=problems.append)
    library.reported = problems
    return library


# ---------------------------------------------------------------------------------------------- round trip
def test_a_motion_is_kept_with_its_joints_features_and_recipe(lib):
    joints = motion(1)
    features = np.random.default_rng(2).normal(size=(39, 263)).astype(np.float32)
    added = lib.add(joints, kind="generate", title="a person jumps twice · seed 3", features=features,
                    recipe={"prompt": "a person jumps twice", "seed": 3, "steps": 50, "guidance": 2.5,
                            "seconds": None, "model": {"folder": "/models/base"}, "words": ["a", "person"],
                            "operation": {"record_steps": 10}})
    e = added.entry
    assert e.kind == "generate" and e.frames == 40 and e.seq >= 1 and not added.evicted and not added.reused
    folder = lib.motions / e.id
    assert sorted(p.name for p in folder.iterdir()) == ["features.npy", "joints.npy", "recipe.json"]
    np.testing.assert_array_equal(lib.joints(e.id), joints)
    np.testing.assert_array_equal(lib.features(e.id), features)
    # plain .npy, never a pickle
    assert np.load(folder / JOINTS_FILE, allow_pickle=False).dtype == np.float32
    recipe = json.loads((folder / RECIPE_FILE).read_text())
    assert recipe == lib.recipe(e.id)
    for key, value in {"prompt": "a person jumps twice", "seed": 3, "steps": 50, "guidance": 2.5, "seconds": None,
                       "model": {"folder": "/models/base"}, "kind": "generate", "id": e.id, "parents": []}.items():
        assert recipe[key] == value, key
    assert recipe["chain"] == [{"id": e.id, "kind": "generate", "title": "a person jumps twice · seed 3",
                                "operation": {"record_steps": 10}}]
    assert recipe["digest"] == joints_digest(joints) == e.digest


def test_an_edit_keeps_its_parents_and_the_chain_from_its_first_ancestor(lib):
    first = add(lib, 1).entry
    edit = lib.add(motion(2), kind="edit", title="emphasise jumps", parents=[first.id],
                   recipe={"prompt": "a person walks", "operation": {"edit": "emphasise 'walks' x1.5"}}).entry
    transfer = lib.add(motion(3), kind="transfer", title="out", parents=[edit.id, first.id],
                       recipe={"operation": {"transfer": "leader -> follower", "role": "out"}}).entry
    assert transfer.parents == (edit.id, first.id)
    chain = lib.recipe(transfer.id)["chain"]
    assert [(s["id"], s["kind"]) for s in chain] == [(first.id, "generate"), (edit.id, "edit"),
                                                     (transfer.id, "transfer")]
    assert chain[1]["operation"] == {"edit": "emphasise 'walks' x1.5"}
    lib.remove([first.id])  # a parent gone: its children keep their chain
    assert lib.recipe(transfer.id)["chain"][0]["id"] == first.id


def test_listing_searches_prompts_and_titles_and_filters_by_kind(lib):
    add(lib, 1, title="a person jumps twice · seed 1")
    add(lib, 2, title="a person waves · seed 2")
    lib.add(motion(3), kind="import", title="imported: walk.bvh", recipe={"source": {"name": "walk.bvh"}})
    assert [e.title for e in lib.entries()] == ["a person jumps twice · seed 1", "a person waves · seed 2",
                                                "imported: walk.bvh"]
    assert [e.title for e in lib.entries(search="WAVES")] == ["a person waves · seed 2"]
    assert [e.title for e in lib.entries(search="walk bvh")] == ["imported: walk.bvh"]
    assert [e.title for e in lib.entries(search="100%_")] == []  # LIKE's wildcards are plain characters
    assert [e.kind for e in lib.entries(kind="import")] == ["import"]
    assert [e.title for e in lib.entries(newest_first=True, limit=1)] == ["imported: walk.bvh"]
    some = lib.entries()[1]
    assert lib.resolve(some.id[:20]) in {e.id for e in lib.entries()}
    with pytest.raises(LibraryError, match="no motion"):
        lib.get("19990101")


def test_the_same_import_again_is_the_same_entry(lib):
    joints = motion(5)
    a = lib.add(joints, kind="import", title="imported: walk.npy", reuse=True)
    b = lib.add(joints, kind="import", title="imported: walk.npy", reuse=True)
    c = lib.add(joints, kind="import", title="imported: other.npy", reuse=True)
    assert b.reused and b.entry.id == a.entry.id and b.entry.touched >= a.entry.touched
    assert not c.reused and lib.count() == 2


def test_bad_motions_are_refused_before_anything_is_written(lib):
    for bad in (np.zeros((0, 22, 3)), np.zeros((10, 21, 3)), np.full((5, 22, 3), np.nan)):
        with pytest.raises(LibraryError):
            lib.add(bad, kind="import", title="bad")
    assert lib.count() == 0 and list(lib.motions.iterdir()) == []


def test_an_interrupted_write_leaves_nothing_behind(lib, monkeypatch):
    import engine.library.store as store

    calls = []

    def failing_save(path, array):
        calls.append(path)
        if len(calls) == 2:  # the joints were written, the features fail (a full disk)
            raise OSError(28, "No space left on device")
        return real_save(path, array)

    real_save = store._save_npy
    monkeypatch.setattr(store, "_save_npy", failing_save)
    with pytest.raises(OSError):
        lib.add(motion(1), kind="generate", title="x", features=np.zeros((39, 263), np.float32))
    assert lib.count() == 0 and list(lib.motions.iterdir()) == []  # no half motion, no row
    monkeypatch.setattr(store, "_save_npy", real_save)
    assert add(lib, 2).entry.id in {e.id for e in lib.entries()}


# ---------------------------------------------------------------------------------------------- concurrency
def _writer(root: str, worker: int, count: int, limit_mb, queue) -> None:
    """One process of the concurrent-writers test: add ``count`` motions, pin every third."""
    try:
        lib = MotionLibrary(root, limit_mb=limit_mb)
        made = []
        for k in range(count):
            added = lib.add(motion(1000 * worker + k, frames=30 + k), kind="generate",
                            title=f"worker {worker} motion {k}", recipe={"prompt": f"worker {worker}", "seed": k})
            if limit_mb is None and k % 3 == 0:
                lib.pin(added.entry.id)
            made.append((added.entry.id, added.entry.digest, [e.id for e in added.evicted]))
        queue.put((worker, made, None))
    except BaseException as exc:  # noqa: BLE001 - reported to the test
        queue.put((worker, [], repr(exc)))


def _run_writers(root: Path, *, workers: int, count: int, limit_mb=None):
    ctx = multiprocessing.get_context("spawn")  # separate interpreters, as two servers or a server and the CLI
    queue = ctx.Queue()
    procs = [ctx.Process(target=_writer, args=(str(root), w, count, limit_mb, queue)) for w in range(workers)]
    for p in procs:
        p.start()
    results = [queue.get(timeout=240) for _ in procs]
    for p in procs:
        p.join(60)
    assert all(p.exitcode == 0 for p in procs)
    errors = [err for _, _, err in results if err]
    assert not errors, errors
    return {w: made for w, made, _ in results}


def test_concurrent_writers_in_separate_processes_lose_nothing(tmp_path):
    root = tmp_path / "library"
    MotionLibrary(root)  # made first, as a server would; the writers also race on an existing index
    made = _run_writers(root, workers=4, count=12)
    lib = MotionLibrary(root)
    entries = {e.id: e for e in lib.entries()}
    expected = {i: d for rows in made.values() for i, d, _ in rows}
    assert len(expected) == 48 and set(entries) == set(expected)
    for entry_id, digest in expected.items():
        assert entries[entry_id].digest == digest
        assert joints_digest(lib.joints(entry_id)) == digest  # every file whole and its own
    assert {e.title for e in entries.values()} == {f"worker {w} motion {k}" for w in range(4) for k in range(12)}
    assert sum(e.pinned for e in entries.values()) == 4 * 4
    assert lib.check() == [] and lib.problems == []
    assert not [p for p in lib.motions.iterdir() if p.name.startswith(".")]  # no temporary leftovers


def test_concurrent_writers_with_a_small_bound_keep_index_and_files_in_step(tmp_path):
    root = tmp_path / "library"
    per_motion = MotionLibrary(root).add(motion(0), kind="generate", title="probe").entry.bytes
    limit_mb = 10 * per_motion / 2**20  # about ten motions
    made = _run_writers(root, workers=3, count=10, limit_mb=limit_mb)
    lib = MotionLibrary(root, limit_mb=limit_mb)
    entries = lib.entries()
    evicted = {i for rows in made.values() for _, _, gone in rows for i in gone}
    kept = {e.id for e in entries}
    assert lib.total_bytes() <= lib.limit_bytes + max(e.bytes for e in entries)  # the newest may overshoot once
    assert 5 <= len(kept) <= 12 and not kept & evicted
    assert len(kept) + len(evicted) == 31  # every motion is either kept or was reported as removed
    for e in entries:
        lib.joints(e.id)
    assert lib.check() == [] and lib.problems == []
    assert {p.name for p in lib.motions.iterdir()} == kept  # no folder without a row, no row without a folder


def test_concurrent_threads_of_one_server_lose_nothing(lib):
    errors = []

    def work(worker):
        try:
            for k in range(10):
                add(lib, 100 * worker + k, title=f"thread {worker} #{k}")
        except BaseException as exc:  # noqa: BLE001
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(w,)) for w in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert not errors and lib.count() == 40 and len(lib.entries()) == 40


# ---------------------------------------------------------------------------------------------- damage
def test_a_damaged_or_vanished_entry_is_reported_once_and_skipped(lib):
    a, b, c = (add(lib, k).entry for k in range(3))
    (lib.motions / a.id / JOINTS_FILE).write_bytes(b"\x93NUMPY garbage")  # truncated / overwritten
    import shutil

    shutil.rmtree(lib.motions / b.id)  # deleted behind the library's back
    listed = [e.id for e in lib.entries()]
    assert listed == [a.id, c.id]  # b skipped
    assert len(lib.reported) == 1 and b.id in lib.reported[0] and "missing" in lib.reported[0]
    lib.entries()
    assert len(lib.reported) == 1  # reported once, not on every listing
    with pytest.raises(LibraryError, match="damaged"):
        lib.joints(a.id)
    assert any(a.id in line and "cannot be read" in line for line in lib.reported)
    np.testing.assert_array_equal(lib.joints(c.id), motion(2))  # the others are fine
    assert all("\n" not in line for line in lib.reported)
    assert {e.id for e in lib.remove([a.id, b.id])} == {a.id, b.id}  # a damaged entry can be deleted
    assert [e.id for e in lib.entries()] == [c.id]


def test_changed_joints_and_pickles_are_refused(lib):
    a, b = add(lib, 1).entry, add(lib, 2).entry
    np.save(lib.motions / a.id / JOINTS_FILE, motion(9), allow_pickle=False)  # another motion, same shape
    with pytest.raises(LibraryError, match="digest"):
        lib.joints(a.id)
    objects = np.empty(2, dtype=object)
    objects[:] = [{"x": 1}, None]
    np.save(lib.motions / b.id / JOINTS_FILE, objects, allow_pickle=True)  # a pickle in disguise: never loaded
    with pytest.raises(LibraryError, match="cannot be read"):
        lib.joints(b.id)


def test_foreign_folders_and_rows_are_reported_and_skipped(lib, tmp_path):
    good = add(lib, 1).entry
    stray = lib.motions / "holiday-photos"
    stray.mkdir()
    (stray / "img.jpg").write_bytes(b"\xff\xd8")
    os.utime(stray, (0, 0))  # old enough not to be another process's write in progress
    with sqlite3.connect(lib.index.path) as con:  # a row no version of this library writes
        con.execute("INSERT INTO motions (id, created, touched, kind, title, prompt, frames, bytes, pinned, digest, "
                    "parents) VALUES ('../../etc', 0, 0, 'generate', 'x', '', 10, 10, 0, 'd', 'not json')")
    assert [e.id for e in lib.entries()] == [good.id]
    problems = lib.check()
    text = "\n".join(str(p) for p in problems)
    assert "holiday-photos" in text and "not in the index" in text and "../../etc" in text
    assert all(str(p).startswith("library: skipped ") for p in problems)


def test_a_bad_recipe_is_reported_and_the_motion_still_listed(lib):
    a = add(lib, 1).entry
    (lib.motions / a.id / RECIPE_FILE).write_text("{not json")
    assert [e.id for e in lib.entries()] == [a.id]  # the index still lists it; its recipe is what is damaged
    with pytest.raises(LibraryError, match="not JSON"):
        lib.recipe(a.id)
    (lib.motions / a.id / RECIPE_FILE).write_text(json.dumps({"format": "someone-else", "id": a.id}))
    with pytest.raises(LibraryError, match="foreign"):
        lib.recipe(a.id)
    assert len(lib.reported) == 2


@pytest.mark.parametrize("damage", ["garbage", "foreign-sqlite", "truncated"])
def test_an_unusable_index_is_set_aside_and_rebuilt_from_the_recipes(tmp_path, damage):
    root = tmp_path / "library"
    lib = MotionLibrary(root)
    ids = [add(lib, k, title=f"m{k}").entry.id for k in range(3)]
    lib.pin(ids[1])
    index = root / "index.sqlite"
    for suffix in ("-wal", "-shm"):
        Path(str(index) + suffix).unlink(missing_ok=True)
    if damage == "garbage":
        index.write_bytes(b"this is not a database" * 100)
    elif damage == "truncated":
        index.write_bytes(index.read_bytes()[:1500])
    else:
        index.unlink()
        with sqlite3.connect(index) as con:
            con.execute("CREATE TABLE notes (body TEXT)")
    reported = []
    again = MotionLibrary(root, report=reported.append)  # never fatal
    assert len(reported) == 1 and "index.sqlite" in reported[0] and "rebuilt" in reported[0]
    assert [e.id for e in again.entries()] == ids and [e.pinned for e in again.entries()] == [False, True, False]
    assert any(p.name.startswith("index.sqlite.unusable-") for p in root.iterdir())
    np.testing.assert_array_equal(again.joints(ids[2]), motion(2))


# ---------------------------------------------------------------------------------------------- the bound
def test_the_bound_removes_the_least_recently_made_unpinned_motions_first(tmp_path):
    lib = MotionLibrary(tmp_path / "library", limit_mb=1000)
    entries = [add(lib, k, frames=200).entry for k in range(6)]
    size = entries[0].bytes
    lib.pin(entries[0].id)
    lib = MotionLibrary(tmp_path / "library", limit_mb=4.5 * size / 2**20)  # room for four and a half
    added = add(lib, 6, frames=200)
    # 7 motions, 4 fit: the oldest unpinned (1, 2, 3) go; the pinned first one stays
    assert [e.id for e in added.evicted] == [e.id for e in entries[1:4]]
    assert [e.id for e in lib.entries()] == [entries[0].id, entries[4].id, entries[5].id, added.entry.id]
    assert lib.total_bytes() <= lib.limit_bytes and not added.over_limit
    for e in added.evicted:
        assert not (lib.motions / e.id).exists()
    lib.touch(entries[4].id)  # re-made (the same import again): now the newest
    gone = add(lib, 7, frames=200).evicted
    assert [e.id for e in gone] == [entries[5].id]


def test_pinned_motions_are_never_removed_and_the_overshoot_is_said(tmp_path):
    lib = MotionLibrary(tmp_path / "library")
    first = add(lib, 0, frames=200).entry
    lib.pin(first.id)
    lib = MotionLibrary(tmp_path / "library", limit_mb=1.0)
    big = lib.add(motion(1, frames=6000), kind="import", title="a long recording")  # 1.5 MB on its own
    assert big.over_limit and not big.evicted and lib.count() == 2


def test_the_stored_bound_and_its_order_of_precedence(tmp_path, monkeypatch):
    root = tmp_path / "library"
    monkeypatch.delenv("MOATTN_LIBRARY_MB", raising=False)
    lib = MotionLibrary(root)
    assert lib.limit_mb == 500 and lib.limit_source() == "default"
    entries = [add(lib, k, frames=200).entry for k in range(3)]
    removed = lib.set_limit_mb(2.5 * entries[0].bytes / 2**20)  # applied at once
    assert [e.id for e in removed] == [entries[0].id]
    assert MotionLibrary(root).limit_source() == "stored"  # kept for later runs
    monkeypatch.setenv("MOATTN_LIBRARY_MB", "123")
    assert MotionLibrary(root).limit_mb == 123
    assert MotionLibrary(root, limit_mb=7).limit_mb == 7
    with pytest.raises(ValueError):
        MotionLibrary(root, limit_mb=0)
    monkeypatch.setenv("MOATTN_LIBRARY_MB", "lots")
    with pytest.raises(ValueError, match="MOATTN_LIBRARY_MB"):
        MotionLibrary(root).limit_mb


def test_unpinning_applies_the_bound(tmp_path):
    lib = MotionLibrary(tmp_path / "library")
    a = add(lib, 0, frames=200).entry
    lib.pin(a.id)
    lib = MotionLibrary(tmp_path / "library", limit_mb=1.5 * a.bytes / 2**20)
    b = add(lib, 1, frames=200)
    assert not b.evicted and b.over_limit
    lib.pin(a.id, False)
    assert [e.id for e in lib.entries()] == [b.entry.id]


# ---------------------------------------------------------------------------------------------- workspace
def test_the_workspace_comes_from_the_flag_then_the_environment_then_the_user_data_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("MOATTN_WORKSPACE", str(tmp_path / "env"))
    assert workspace_dir(tmp_path / "flag") == tmp_path / "flag"
    assert workspace_dir() == tmp_path / "env" and library_dir() == tmp_path / "env" / "library"
    monkeypatch.delenv("MOATTN_WORKSPACE")
    import platformdirs

    assert workspace_dir() == Path(platformdirs.user_data_dir("moattn", appauthor=False))
    assert MotionLibrary  # (never opened here: that would write into the user's folder)


def test_the_test_suite_never_uses_the_users_data_folder(workspace):
    import platformdirs

    assert os.environ["MOATTN_WORKSPACE"] == str(workspace)
    assert not str(workspace_dir()).startswith(platformdirs.user_data_dir("moattn", appauthor=False))


def test_the_library_is_torch_free():
    import subprocess

    code = ("import sys, engine.library, engine.library.cli_support, engine.cli.library; "
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.returncode == 0 and out.stdout.strip() == "False", out.stderr


def test_a_huge_recipe_is_kept_short_never_unreadable(lib):
    details = {"per_frame": [[float(i)] * 200 for i in range(250)]}  # ~250 x 200 numbers: not a recipe
    e = lib.add(motion(1), kind="control", title="big", recipe={"prompt": "p", "seed": 1, "operation": details}).entry
    recipe = lib.recipe(e.id)  # readable (under the reader's size limit)
    assert recipe["prompt"] == "p" and recipe["seed"] == 1 and "too large" in recipe["operation"]
    assert recipe["chain"] == [{"id": e.id, "kind": "control", "title": "big"}]
