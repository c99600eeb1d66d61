"""Shared fixtures: paths to the real reference data (read in place, never copied); a temporary workspace."""
from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest

from engine.paths import PROJECT_ROOT, REAL_DATA_DIR
from engine.skeleton import JOINT_NAMES

# The motion library (engine.library) keeps every motion the CLI and the studio make in the workspace, by default the
# user's data folder: the test run never writes there. Set before any test (and any subprocess it starts) runs;
# each test then gets its own empty workspace (``workspace`` below).
_SESSION_WORKSPACE = tempfile.mkdtemp(prefix="moattn-test-workspace-")
os.environ["MOATTN_WORKSPACE"] = _SESSION_WORKSPACE
os.environ.pop("MOATTN_LIBRARY_MB", None)
atexit.register(shutil.rmtree, _SESSION_WORKSPACE, True)


@pytest.fixture(autouse=True)
def workspace(tmp_path_factory, monkeypatch) -> Path:
    """This test's own motion-library workspace ($MOATTN_WORKSPACE), empty at its start."""
    folder = tmp_path_factory.mktemp("workspace")
    monkeypatch.setenv("MOATTN_WORKSPACE", str(folder))
    return folder

REAL_DATA = REAL_DATA_DIR  # the one definition lives in engine.paths (the inversion benchmark reads it too)


def real_file(name: str) -> Path:
    path = REAL_DATA / name
    assert path.exists(), f"real data missing: {path} (the project's measuring data, ../shared/data/real/)"
    return path


@pytest.fixture(scope="session")
def real_joints() -> np.ndarray:
    return np.load(real_file("humanml3d_012314_joints.npy"), allow_pickle=False)


@pytest.fixture(scope="session")
def real_vecs() -> np.ndarray:
    return np.load(real_file("humanml3d_012314_vecs.npy"), allow_pickle=False)


@pytest.fixture(scope="session")
def tiny_model_dir(tmp_path_factory):
    """A tiny model trained once per test session on the corpus (for app tests)."""
    from app.bench.testing import tiny_model

    return tiny_model(tmp_path_factory.getbasetemp() / "tiny-model")


@pytest.fixture(scope="session")
def tiny_duet_dir(tiny_model_dir, tmp_path_factory):
    """A ComMDM block trained a few steps on the tiny model (for app and CLI tests)."""
    from app.bench.testing import tiny_duet

    return tiny_duet(tmp_path_factory.getbasetemp() / "tiny-duet", tiny_model_dir)


def random_corpus_model(*, layers: int, width: int = 32, heads: int = 2):
    """An untrained seeded model with the corpus vocabulary and statistics (for method tests)."""
    import torch

    from engine.checkpoint import LoadedModel
    from engine.model import Denoiser, ModelConfig
    from engine.synth import Corpus, vocabulary
    from engine.text import Tokenizer

    torch.manual_seed(0)
    words = vocabulary()
    model = Denoiser(ModelConfig(width=width, layers=layers, heads=heads, text_layers=1, vocab_size=len(words) + 8)).eval()
    return LoadedModel(model=model, tokenizer=Tokenizer(words), normalizer=Corpus(split="train").stats(n=32),
                       config={}, folder=Path("."))


def cyclic_attention_map(reps: int, *, rest: int, period: int = 16) -> np.ndarray:
    """A self-attention map like the model's for a repeated action between two still parts: frames attend
    to their neighbours, action frames to the same phase of every repetition, still frames to each other."""
    t = np.arange(2 * rest + reps * period)
    active = (t >= rest) & (t < rest + reps * period)
    phase = 2 * np.pi * (t - rest) / period
    local = np.exp(-0.5 * ((t[:, None] - t[None]) / 2.0) ** 2)
    cyclic = np.exp(2 * (np.cos(phase[:, None] - phase[None]) - 1)) * np.outer(active, active)
    attn = 0.02 + local + 0.5 * cyclic + 0.3 * np.outer(~active, ~active)
    return attn / attn.sum(1, keepdims=True)


HML_RARE = "pirouettes"  # a word only hml_folder's captions have, never the corpus lexicon
HML_TINY_MODEL = dict(width=32, layers=2, heads=2, text_layers=1, dropout=0.0)


@pytest.fixture(scope="session")
def hml_rare() -> str:
    """The word only ``hml_folder``'s captions have."""
    return HML_RARE


@pytest.fixture(scope="session")
def hml_folder(tmp_path_factory) -> Path:
    """A HumanML3D-layout folder, the stand-in for the real dataset: 60 test + 40 train corpus samples (train
    written last: Mean/Std are the train split's), and two train samples with words outside the corpus lexicon,
    one with a #start#end sub-range caption. As in the real dataset, some test captions use words the train split
    never has."""
    from engine.io.humanml3d import Caption, HumanML3DFolder, write_sample, write_split
    from engine.synth.export import export_corpus

    def features(name: str) -> np.ndarray:
        return np.load(root / "new_joint_vecs" / f"{name}.npy")

    root = tmp_path_factory.mktemp("hml") / "HumanML3D"
    export_corpus(root, n=60, split="test")
    export_corpus(root, n=40, split="train")
    write_sample(root, "dance_000", features("train_000001"), None,
                 [f"a dancer {HML_RARE} gracefully on the spot", Caption("then she bows", start=0.5, end=2.0)])
    write_sample(root, "dance_001", features("train_000002"), None, [f"someone {HML_RARE} twice"])
    names = HumanML3DFolder(root).split_names("train")
    write_split(root, "train", [*names, "dance_000", "dance_001"])
    return root


@pytest.fixture(scope="session")
def hml_run(hml_folder, tmp_path_factory) -> Path:
    """A tiny model trained on ``hml_folder`` (its vocabulary, its Mean/Std)."""
    from engine.model import ModelConfig
    from engine.train import TrainConfig, train

    out = tmp_path_factory.mktemp("run") / "model"
    train(TrainConfig(out=str(out), data=str(hml_folder), steps=30, batch_size=8, max_frames=196, lr=2e-3, warmup=5,
                      log_every=10, ckpt_every=30, snapshot_every=0, stats_samples=20, threads=1, workers=0,
                      precision="fp32", device="cpu", model=ModelConfig(**HML_TINY_MODEL)), progress=False)
    return out


@pytest.fixture(scope="session")
def run_coroutine():
    """Run a coroutine on a fresh event loop in its own thread (another test may have left a loop running)."""
    import asyncio
    import threading

    def run(coro):
        out = {}
        thread = threading.Thread(target=lambda: out.setdefault("value", asyncio.run(coro)))
        thread.start()
        thread.join(120)
        return out["value"]

    return run


# a standing figure (22 joints, metres) and one that walks: shared by the drawing tests (test_viz, test_viz_flat)
_STAND = np.array([
    [0.00, 0.95, 0.00], [0.09, 0.88, 0.00], [-0.09, 0.88, 0.00], [0.00, 1.07, -0.01], [0.10, 0.50, 0.01],
    [-0.10, 0.50, 0.01], [0.00, 1.20, 0.00], [0.10, 0.08, -0.02], [-0.10, 0.08, -0.02], [0.00, 1.26, 0.01],
    [0.11, 0.02, 0.12], [-0.11, 0.02, 0.12], [0.00, 1.48, 0.02], [0.07, 1.40, 0.01], [-0.07, 1.40, 0.01],
    [0.00, 1.60, 0.05], [0.18, 1.42, 0.00], [-0.18, 1.42, 0.00], [0.22, 1.16, 0.00], [-0.22, 1.16, 0.00],
    [0.24, 0.90, 0.03], [-0.24, 0.90, 0.03],
])


def walker(n_frames: int = 12, *, speed: float = 0.05) -> np.ndarray:
    """A figure walking forward (+Z) and swinging its arms, (T, 22, 3): every frame differs from the last."""
    t = np.arange(n_frames)
    motion = np.repeat(_STAND[None], n_frames, axis=0)
    motion[:, :, 2] += speed * t[:, None]
    swing = 0.15 * np.sin(t / 2.0)
    for joint, sign in (("left_wrist", 1), ("left_elbow", 0.5), ("right_wrist", -1), ("right_elbow", -0.5)):
        motion[:, JOINT_NAMES.index(joint), 2] += sign * swing
    return motion
