"""A HumanML3D-layout folder end to end: train on it, train the evaluator on it, score on its test
split, serve the trained run with the folder's own words; and every broken-folder case fails with one
line naming the file. The folder is a small `moattn corpus` export (the stand-in for the real dataset)
plus hand-written samples with words the corpus lexicon lacks."""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from engine.cli import main
from engine.io.humanml3d import Caption, write_sample, write_split

RARE = "pirouettes"  # the word only conftest's hml_folder captions have (its hml_rare fixture)


@pytest.fixture(scope="module")
def folder(hml_folder, hml_rare) -> Path:
    assert hml_rare == RARE
    return hml_folder


@pytest.fixture(scope="module")
def run_dir(hml_run) -> Path:
    return hml_run


def _corpus_features(folder: Path, name: str) -> np.ndarray:
    return np.load(folder / "new_joint_vecs" / f"{name}.npy")


def _run(argv, capsys) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _one_line_error(argv, capsys, *needles: str) -> str:
    code, _, err = _run(argv, capsys)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, err
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def evaluator_dir(folder, tmp_path_factory) -> Path:
    """A tiny evaluator trained on the folder's train split (the CLI route is checked separately)."""
    from engine.data import FolderSource
    from engine.evaluation.evaluator import EvaluatorConfig, train_evaluator

    out = tmp_path_factory.mktemp("evaluator")
    train_evaluator(FolderSource(folder), out=out, steps=15, batch_size=16, pool_size=None, progress=False,
                    config=EvaluatorConfig(width=32, layers=1, heads=2, embed_dim=16))
    return out


def test_evaluator_cli_trains_on_the_folder_with_its_own_words(folder, tmp_path, capsys):
    from engine.evaluation.evaluator import load_evaluator
    from engine.synth import vocabulary

    code, out, err = _run(["evaluator", "--data", folder, "--out", tmp_path, "--steps", 1, "--batch-size", 4,
                           "--device", "cpu"], capsys)
    assert code == 0, err
    assert json.loads(out.splitlines()[-1])["data"] == str(folder)
    meta = json.loads((tmp_path / "evaluator.json").read_text())
    assert RARE in meta["vocabulary"] and RARE not in vocabulary()
    assert meta["training"]["pool_size"] == 40 + 2 + 1  # every train item: 42 clips + 1 sub-range caption
    ev = load_evaluator(tmp_path)
    emb = ev.text_embeddings([f"a dancer {RARE} gracefully"])
    assert emb.shape[0] == 1 and np.isfinite(emb).all()
    # saved weights are device-free CPU tensors
    import torch

    state = torch.load(tmp_path / "evaluator.pt", map_location="cpu", weights_only=True)
    assert all(v.device.type == "cpu" for v in state.values())


def test_eval_scores_the_model_on_the_folder_test_split(folder, run_dir, evaluator_dir, capsys):
    code, out, err = _run(["eval", "--model", run_dir, "--evaluator", evaluator_dir, "--data", folder, "--quick",
                           "--samples", 32, "--steps", 2, "--json", "--device", "cpu"], capsys)
    assert code == 0, err
    warned = [line for line in err.splitlines() if line.startswith("moattn eval: warning:")]
    assert len(warned) == 1 and "left out because the evaluator or model does not know" in warned[0]
    assert "texts/test_" in warned[0]  # names the caption file and the words
    payload = json.loads(out)
    assert payload["split"] == "test" and list(payload["splits"]) == ["test"]
    assert payload["settings"]["data"] == str(folder)
    result = payload["splits"]["test"]
    assert result["samples"] == 32 and result["data"] == str(folder)
    assert result["skipped"] >= 1  # test captions with words the train split lacks: left out, counted
    assert 0 < result["noise_floor_shared"] < 32  # fewer than 64 readable items: the second GT draw overlaps
    for name in ("model", "ground_truth"):
        row = result[name]
        assert len(row["r_precision"]) == 3
        values = [*row["r_precision"], row["fid"], row["mm_dist"], row["diversity"], row["foot_skate"]]
        assert all(math.isfinite(v) for v in values), row
    assert math.isfinite(result["gt_noise_floor_fid"])


def test_ground_truth_items_come_from_the_folder_split(folder):
    from engine.evaluation.run import load_split, split_items

    split = load_split("test", count=100, data=folder)
    assert len(split.features) == 60  # a finite split: every item once
    captions = {line.split("#")[0] for p in (folder / "texts").glob("test_*.txt")
                for line in p.read_text().splitlines()}
    assert set(split.captions) <= captions
    first = next(split_items("test", data=folder))
    again = next(split_items("test", data=folder))
    assert first[1] == again[1] and np.array_equal(first[0], again[0])  # seeded
    corpus = load_split("test", count=3)  # without data: the corpus, as before
    assert len(corpus.features) == 3


def test_served_run_knows_the_folder_words(run_dir):
    from engine.checkpoint import load_model
    from engine.generate import Request, SampleConfig, generate

    loaded = load_model(run_dir)
    assert RARE in loaded.tokenizer and "gracefully" in loaded.tokenizer
    gen = generate(loaded, Request(prompts=[f"a dancer {RARE} gracefully"], frames=[40]), SampleConfig(steps=2))
    assert gen.features.shape == (1, 40, 263) and np.isfinite(gen.features).all()
    assert gen.tokens[0].words[2] == RARE


def test_long_clips_are_cropped_at_random_and_sub_ranges_honoured(tmp_path, folder):
    from engine.data import FolderSource, collate
    from engine.text import Tokenizer

    base = _corpus_features(folder, "train_000000")
    long = np.concatenate([base] * (250 // len(base) + 1))[:250]
    write_sample(tmp_path, "long", long, None, ["a person walks for a long time"])
    write_sample(tmp_path, "parts", long[:100], None, [Caption("a person walks", ()),
                                                       Caption("then jumps", (), start=1.0, end=2.5)])
    write_split(tmp_path, "train", ["long", "parts"])
    source = FolderSource(tmp_path)
    assert len(source) == 3
    sub = [i for i in range(3) if source.get(i).captions == ("then jumps",)]
    assert len(sub) == 1
    assert np.array_equal(source.get(sub[0]).features, long[20:50])  # 1.0 s .. 2.5 s at 20 fps
    assert len(source.get(0).features) == 250  # kept whole; cropped per batch
    tokenizer = Tokenizer(source.words())
    starts = set()
    for seed in range(6):
        batch = collate([source.get(0)], tokenizer=tokenizer, normalize=lambda f: f,
                        rng=np.random.default_rng(seed), max_frames=196, text_dropout=0.0)
        x = batch.x0[0].numpy()
        assert x.shape == (196, 263) and bool(batch.cond.frame_mask.all())
        start = next(s for s in range(250 - 196 + 1) if np.array_equal(x, long[s : s + 196]))
        starts.add(start)
    assert len(starts) > 1  # a random window, not always the first 196 frames


def test_missing_listed_samples_are_skipped_with_a_warning(tmp_path, folder):
    from engine.data import FolderSource

    write_sample(tmp_path, "a", _corpus_features(folder, "train_000000"), None, ["a person walks"])
    write_sample(tmp_path, "b", _corpus_features(folder, "train_000001"), None, ["a person runs"])
    (tmp_path / "texts" / "b.txt").unlink()
    write_split(tmp_path, "train", ["a", "b", "c"])
    with pytest.warns(UserWarning, match=r"skipped 2 of 3 listed samples .*b\.txt"):
        source = FolderSource(tmp_path)
    assert len(source) == 1
    write_split(tmp_path, "train", ["b", "c"])
    with pytest.raises(ValueError, match=r"none of the 2 samples .*first missing: .*b\.txt"):
        FolderSource(tmp_path)


def test_unknown_eval_words_are_skipped_and_counted(tmp_path, folder):
    from engine.evaluation.run import load_split
    from engine.text import Tokenizer

    feats = _corpus_features(folder, "train_000000")
    write_sample(tmp_path, "a", feats, None, ["a person walks"])
    write_sample(tmp_path, "b", feats, None, ["a person zigzags"])
    write_split(tmp_path, "test", ["a", "b"])
    split = load_split("test", count=10, data=tmp_path, tokenizers={"evaluator": Tokenizer(["a", "person", "walks"])})
    assert split.captions == ["a person walks"]
    assert len(split.skipped) == 1 and "b.txt" in split.skipped[0] and "'zigzags'" in split.skipped[0]


@pytest.fixture()
def small(tmp_path, folder) -> Path:
    """A three-sample folder (with Mean/Std) to break in one way per test."""
    root = tmp_path / "small"
    for i in range(3):
        write_sample(root, f"s{i}", _corpus_features(folder, f"train_00000{i}"), None, ["a person walks forward"])
    write_split(root, "train", ["s0", "s1", "s2"])
    write_split(root, "test", ["s0", "s1", "s2"])
    for name in ("Mean.npy", "Std.npy"):
        shutil.copy(folder / name, root / name)
    return root


def _bad_object_array():
    return np.array([np.zeros((3, 263)), np.zeros((4, 263))], dtype=object)


@pytest.mark.parametrize("array,needle", [
    (np.zeros((40, 250), np.float32), "(40, 250)"),
    (np.zeros(263, np.float32), "(263,)"),
    (_bad_object_array(), "object array"),
    (np.full((40, 263), np.nan, np.float32), "NaN"),
])
def test_broken_feature_files_name_the_file(small, capsys, array, needle):
    path = small / "new_joint_vecs" / "s1.npy"
    np.save(path, array, allow_pickle=array.dtype == object)
    _one_line_error(["evaluator", "--data", small, "--out", small / "ev", "--steps", 1], capsys, str(path), needle)


@pytest.mark.parametrize("file_name,array,needle", [
    ("Mean.npy", np.zeros(250, np.float32), "(250,)"),
    ("Std.npy", np.where(np.arange(263) == 5, 0.0, 1.0).astype(np.float32), "index 5"),
])
def test_broken_statistics_name_the_file(small, capsys, file_name, array, needle):
    np.save(small / file_name, array)
    _one_line_error(["evaluator", "--data", small, "--out", small / "ev", "--steps", 1], capsys,
                    str(small / file_name), needle)


def test_broken_layouts_name_the_path(small, tmp_path, capsys):
    ev = ["evaluator", "--out", tmp_path / "ev", "--steps", 1, "--data"]
    _one_line_error([*ev, tmp_path / "nowhere"], capsys, str(tmp_path / "nowhere"), "does not exist")
    (small / "train.txt").unlink()
    _one_line_error([*ev, small], capsys, str(small / "train.txt"), "does not exist")
    write_split(small, "train", ["s0", "gone"])
    (small / "new_joint_vecs" / "s0.npy").unlink()
    _one_line_error([*ev, small], capsys, "none of the 2 samples", str(small / "new_joint_vecs" / "s0.npy"))
    (small / "texts" / "s1.txt").write_text("a person walks#a/DET#zero#1.0\n")
    write_split(small, "train", ["s1"])
    _one_line_error([*ev, small], capsys, str(small / "texts" / "s1.txt"), "line 1", "'zero'")
    shutil.rmtree(small / "texts")
    _one_line_error([*ev, small], capsys, str(small), "texts/")
    shutil.rmtree(small / "new_joint_vecs")
    _one_line_error([*ev, small], capsys, str(small), "new_joint_vecs/")


def test_eval_names_the_caption_file_with_unknown_words(small, evaluator_dir, capsys):
    for i in range(3):
        (small / "texts" / f"s{i}.txt").write_text("a person zigzags wildly#a/DET#0.0#0.0\n")
    line = _one_line_error(["eval", "--gt-only", "--evaluator", evaluator_dir, "--data", small, "--device", "cpu"],
                           capsys, str(small / "texts"), "'zigzags'", "'wildly'", "evaluator")
    assert "no usable items in split 'test'" in line
    _one_line_error(["eval", "--gt-only", "--evaluator", evaluator_dir, "--data", small, "--splits", "val"],
                    capsys, str(small / "val.txt"), "does not exist")


def test_unavailable_device_is_one_line(small, capsys, monkeypatch):
    import torch

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)  # the same on a machine with a GPU
    _one_line_error(["evaluator", "--data", small, "--out", small / "ev", "--device", "cuda"], capsys, "--device cuda")
    _one_line_error(["eval", "--gt-only", "--data", small, "--device", "cuda"], capsys, "--device cuda")


def test_eval_guidance_flags_are_the_declared_sampling_options(small, capsys):
    """`moattn eval --guidance/--guidance-from`: the sampling options' own bounds, said in one line before any load."""
    _one_line_error(["eval", "--gt-only", "--data", small, "--guidance-from", "1000"], capsys, "--guidance-from", "999")
    _one_line_error(["eval", "--gt-only", "--data", small, "--guidance", "21"], capsys, "--guidance", "20")
