"""`moattn library list|show|export|rm|pin|unpin|limit|import`, and the commands that keep what they make in the
library (`moattn generate`, `moattn convert`) with `--no-library` / `--workspace` / `--library-mb`."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from engine.cli import main
from engine.library import MotionLibrary
from tests.conftest import real_file

KEPT = re.compile(r"kept in the library as (\S+) \(")


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_generate_keeps_its_motion_and_the_library_gives_it_back(capsys, tiny_model_dir, tmp_path, workspace):
    code, out, err = run(capsys, "generate", "a person walks forward", "--model", tiny_model_dir, "--steps", 3,
                         "--seconds", 1.5, "--seed", 4)
    assert code == 0, err
    entry_id = KEPT.search(out).group(1)  # no --out: kept in the library only
    lib = MotionLibrary(workspace=workspace)
    [entry] = lib.entries()
    assert entry.id == entry_id and entry.kind == "generate" and entry.title == "a person walks forward · seed 4"
    assert entry.frames == 30

    code, out, err = run(capsys, "library", "show", entry_id[:20])  # a unique prefix is enough
    assert code == 0, err
    for line in ("prompt    a person walks forward", "seed      4", "steps     3", "seconds   1.5",
                 f"model     {tiny_model_dir.resolve()}"):
        assert line in out, out
    code, out, _ = run(capsys, "library", "show", entry_id, "--json")
    recipe = json.loads(out)
    assert (recipe["prompt"], recipe["seed"], recipe["steps"], recipe["seconds"]) == ("a person walks forward", 4,
                                                                                      3, 1.5)
    assert recipe["guidance"] > 0 and recipe["operation"]["sampler"] == "ddim"

    joints = lib.joints(entry_id)
    code, out, err = run(capsys, "library", "export", entry_id, "--out", tmp_path / "walk.npy")
    assert code == 0 and f"wrote {tmp_path / 'walk.npy'}" in out, err
    np.testing.assert_array_equal(np.load(tmp_path / "walk.npy"), joints)
    assert run(capsys, "library", "export", entry_id, "--out", tmp_path / "walk.bvh")[0] == 0
    assert (tmp_path / "walk.bvh").read_text().startswith("HIERARCHY")
    assert run(capsys, "library", "export", entry_id, "--out", f"{tmp_path / 'folder'}/")[0] == 0
    assert sorted(p.name for p in (tmp_path / "folder").iterdir()) == ["features.npy", "joints.npy", "recipe.json"]
    assert json.loads((tmp_path / "folder" / "recipe.json").read_text())["id"] == entry_id

    # the same prompt again with --no-library: written, not kept
    code, out, err = run(capsys, "generate", "a person walks forward", "--model", tiny_model_dir, "--steps", 2,
                         "--seconds", 1, "--out", tmp_path / "b.npy", "--no-library")
    assert code == 0 and "library" not in out and lib.count() == 1, err
    code, _, err = run(capsys, "generate", "a person walks", "--model", tiny_model_dir, "--no-library")
    assert code == 2 and "nothing would be kept" in err and err.count("\n") == 1


def test_library_list_search_kind_pin_rm_and_limit(capsys, tmp_path, workspace):
    src = real_file("humanml3d_012314_joints.npy")
    code, out, err = run(capsys, "convert", src, tmp_path / "walk.bvh", "--seconds", 2)  # an import: kept
    assert code == 0, err
    walk = KEPT.search(out).group(1)
    code, out, _ = run(capsys, "convert", src, tmp_path / "walk2.bvh", "--seconds", 2)
    assert f"already in the library as {walk}" in out  # the same file and window: the same entry
    assert run(capsys, "convert", src, tmp_path / "w3.npy", "--no-library")[0] == 0
    code, out, err = run(capsys, "library", "import", real_file("cmu_131_01_walk.bvh"), "--seconds", 3,
                         "--title", "cmu walk")
    assert code == 0, err
    cmu = KEPT.search(out).group(1)
    lib = MotionLibrary(workspace=workspace)
    lib.add(np.zeros((400, 22, 3), np.float32), kind="generate", title="a person jumps twice · seed 0",
            recipe={"prompt": "a person jumps twice", "seed": 0, "steps": 50, "guidance": 2.5})
    assert lib.count() == 3

    code, out, err = run(capsys, "library", "list")
    assert code == 0 and err == ""
    lines = out.strip().splitlines()
    assert len(lines) == 4 and lines[0].startswith(walk) and "import" in lines[0] and "imported: " in lines[0]
    assert "cmu walk" in lines[1] and "a person jumps twice" in lines[2]
    assert lines[-1].startswith("3 motions,") and f"in {lib.root}" in lines[-1]
    code, out, _ = run(capsys, "library", "list", "--search", "JUMPS")
    assert out.count("\n") == 2 and "a person jumps twice" in out and out.strip().endswith(str(lib.root))
    code, out, _ = run(capsys, "library", "list", "--kind", "import", "--json")
    assert [json.loads(line)["id"] for line in out.splitlines()] == [walk, cmu]

    assert run(capsys, "library", "pin", walk)[1].startswith(f"pinned {walk}")
    code, out, _ = run(capsys, "library", "list", "--pinned")
    assert out.splitlines()[0].startswith(walk) and "; * pinned" in out
    code, out, _ = run(capsys, "library", "limit", "0.05")
    assert "library bound 0.05 MB (stored)" in out and "over the bound" in out  # the unpinned went
    assert [e.id for e in lib.entries()] == [walk]
    code, out, _ = run(capsys, "library", "limit", "default")
    assert "500 MB (the default)" in out
    assert run(capsys, "library", "unpin", walk)[0] == 0
    code, out, _ = run(capsys, "library", "rm", walk)
    assert code == 0 and out.startswith(f"removed {walk}") and lib.count() == 0
    code, _, err = run(capsys, "library", "rm", walk)
    assert code == 2 and "was not in the library" in err and err.count("\n") == 1


def test_a_corrupt_entry_is_one_line_and_the_listing_goes_on(capsys, workspace):
    lib = MotionLibrary(workspace=workspace)
    ids = [lib.add(np.full((10, 22, 3), k, np.float32), kind="import", title=f"clip {k}").entry.id for k in range(3)]
    import shutil

    shutil.rmtree(lib.motions / ids[1])
    (lib.motions / ids[2] / "recipe.json").write_text("garbage")
    code, out, err = run(capsys, "library", "list")
    assert code == 0 and "clip 0" in out and "clip 1" not in out and "clip 2" in out
    assert err.count("\n") == 1 and err.startswith(f"library: skipped {ids[1]}")
    code, out, err = run(capsys, "library", "show", ids[2])
    assert code == 2 and err.count("\n") == 2  # the problem reported, then the command's one-line error
    assert "recipe is not JSON" in err
    code, out, err = run(capsys, "library", "export", ids[1], "--out", f"{workspace}/x.npy")
    assert code == 2 and "its joints file is missing" in err


def test_the_workspace_flag_wins_over_the_environment(capsys, tmp_path, workspace):
    other = tmp_path / "elsewhere"
    lib = MotionLibrary(workspace=other)
    lib.add(np.zeros((10, 22, 3), np.float32), kind="import", title="over there")
    code, out, _ = run(capsys, "library", "list", "--workspace", other)
    assert "over there" in out and str(other) in out
    code, out, _ = run(capsys, "library", "list")
    assert "over there" not in out and out.startswith("0 motions") and str(workspace) in out
    assert not (workspace / "library").exists()  # listing an empty workspace creates nothing in it


@pytest.mark.parametrize("value", ["0", "-3", "lots"])
def test_a_bad_library_bound_is_refused_before_any_work(capsys, value):
    with pytest.raises(SystemExit) as exit_:
        main(["generate", "a person walks", "--library-mb", value])
    err = capsys.readouterr().err
    assert exit_.value.code == 2 and "--library-mb" in err and err.count("\n") == 1


def test_edit_and_compose_keep_what_they_make_with_their_recipe(capsys, tiny_model_dir, tmp_path, workspace):
    code, out, err = run(capsys, "edit", "emphasize", "a person jumps", "--word", "jumps", "--weight", 0.5,
                         "--model", tiny_model_dir, "--steps", 2, "--seconds", 1, "--seed", 3,
                         "--out", tmp_path / "edited.npy")
    assert code == 0, err
    json.loads(out)  # stdout stays one JSON report: the library's line goes to stderr
    err1 = err
    code, out2, err = run(capsys, "compose", "a person walks:2", "a person jumps:2", "--model", tiny_model_dir,
                          "--steps", 2, "--out", tmp_path / "long.npy")
    assert code == 0, err
    json.loads(out2)
    lib = MotionLibrary(workspace=workspace)
    kept = {e.kind: e for e in lib.entries()}
    assert set(kept) == {"edit", "compose"} and lib.count() == 2
    assert KEPT.search(err1).group(1) == kept["edit"].id and KEPT.search(err).group(1) == kept["compose"].id
    np.testing.assert_array_equal(lib.joints(kept["edit"].id), np.load(tmp_path / "edited.npy"))
    np.testing.assert_array_equal(lib.joints(kept["compose"].id), np.load(tmp_path / "long.npy"))
    code, shown, _ = run(capsys, "library", "show", kept["edit"].id, "--json")
    recipe = json.loads(shown)
    assert (recipe["prompt"], recipe["seed"], recipe["steps"]) == ("a person jumps", 3, 2)
    assert recipe["operation"]["edit"] == "emphasize" and recipe["operation"]["made_by"] == "moattn edit"
    code, shown, _ = run(capsys, "library", "show", kept["compose"].id, "--json")
    recipe = json.loads(shown)
    assert recipe["operation"]["compose"] == ["a person walks:2", "a person jumps:2"]
    assert "a person walks" in kept["compose"].title and "a person jumps" in kept["compose"].title
