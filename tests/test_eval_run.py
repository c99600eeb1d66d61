"""`moattn eval` end to end on tiny models: the rows, the keys, the noise floor."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch

from engine.checkpoint import LoadedModel
from engine.evaluation.evaluator import CONFIG, WEIGHTS, Evaluator, EvaluatorConfig, load_evaluator
from engine.evaluation.run import EvalConfig, evaluate_split, format_table
from engine.model import Denoiser, ModelConfig
from engine.synth import Corpus, vocabulary
from engine.text import Tokenizer


@pytest.fixture(scope="module")
def tiny_evaluator(tmp_path_factory):
    folder = tmp_path_factory.mktemp("evaluator")
    torch.manual_seed(0)
    words = vocabulary()
    config = EvaluatorConfig(width=32, layers=1, heads=2, embed_dim=16, vocab_size=len(words) + 1)
    torch.save(Evaluator(config).state_dict(), folder / WEIGHTS)
    Corpus(split="train").stats(n=64).save(folder)
    from dataclasses import asdict

    (folder / CONFIG).write_text(json.dumps({"config": asdict(config), "vocabulary": list(words)}))
    return load_evaluator(folder)


@pytest.fixture(scope="module")
def tiny_model():
    torch.manual_seed(0)
    words = vocabulary()
    model = Denoiser(ModelConfig(width=32, layers=2, heads=2, text_layers=1, vocab_size=len(words) + 1)).eval()
    return LoadedModel(model=model, tokenizer=Tokenizer(words), normalizer=Corpus(split="train").stats(n=64),
                       config={}, folder=Path("."))


def test_eval_rows_and_noise_floor(tiny_model, tiny_evaluator):
    config = EvalConfig(samples=32, steps=2, guidance=2.0, batch=16, mm_texts=2, mm_repeats=2)
    result = evaluate_split(tiny_model, tiny_evaluator, "test", config)
    for name in ("model", "ground_truth"):
        row = result[name]
        assert set(row) >= {"r_precision", "fid", "mm_dist", "diversity", "foot_skate", "penetration_cm"}
        assert len(row["r_precision"]) == 3 and row["r_precision"] == sorted(row["r_precision"])
        assert all(math.isfinite(v) for v in (row["fid"], row["mm_dist"], row["diversity"]))
    assert result["model"]["multimodality"] >= 0
    assert result["gt_noise_floor_fid"] >= 0
    # an untrained model is farther from the data than a second ground-truth sample
    assert result["model"]["fid"] > result["gt_noise_floor_fid"]
    # the ground-truth corpus motions are physically clean
    assert result["ground_truth"]["foot_skate"] < 0.2 and result["ground_truth"]["penetration_cm"] < 1.0
    table = format_table({"test": result})
    assert "ground_truth" in table and "GT noise FID" in table
