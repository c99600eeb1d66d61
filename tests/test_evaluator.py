"""The evaluator learns to tell captions apart on a toy source, saves, loads and embeds."""
from __future__ import annotations

import numpy as np

from engine.evaluation.evaluator import EvaluatorConfig, load_evaluator, train_evaluator
from engine.evaluation.metrics import r_precision
from tests.test_train import ToySource


def test_evaluator_trains_saves_and_separates_captions(tmp_path):
    config = EvaluatorConfig(width=32, layers=1, heads=2, embed_dim=16, vocab_size=8)
    summary = train_evaluator(ToySource(), out=tmp_path, steps=40, batch_size=16, pool_size=64, stats_samples=32,
                              config=config, progress=False)
    # two captions: with duplicates as positives the loss floor is log(8); chance is log(16)
    assert summary["final_loss"] < np.log(16) - 0.3
    ev = load_evaluator(tmp_path)
    src = ToySource()
    items = [src.get(1000 + i) for i in range(64)]
    motion = ev.motion_embeddings([i.features for i in items])
    text = ev.text_embeddings([i.captions[0] for i in items])
    assert motion.shape == (64, 16) and np.allclose(np.linalg.norm(motion, axis=1), 1, atol=1e-3)
    # rising motions sit closer to "rises" than to "falls"
    rises, falls = ev.text_embeddings(["a person rises", "a person falls"])
    up = np.array([i.captions[0] == "a person rises" for i in items])
    closer = (motion @ rises > motion @ falls) == up
    assert closer.mean() > 0.9
    assert r_precision(text, motion, pool=32)[2] > 0.05
    # a caption whose only verb the evaluator never saw is scored by the words it knows, not refused (the transfer
    # bench failed at its end over "the character first heads ahead like the undead")
    assert ev.text_for("a person flurbs") == "a person" and ev.text_for("a person rises") == "a person rises"
    odd, plain = ev.text_embeddings(["a person flurbs", "a person"])
    assert np.allclose(odd, plain)
