"""`moattn bench --train` on a tiny shape: the result's structure, and FLOPs that match an analytic count."""
from __future__ import annotations

import json
import math

import pytest
import torch

from engine.cli import main
from engine.evaluation.bench_train import Shape, TrainBenchConfig, _Trainer, bench_train, format_table
from engine.paths import MODEL_DIR
from engine.runtime import CPU

TINY = Shape(width=32, layers=2, heads=2, text_layers=1)
CONFIG = TrainBenchConfig(shapes=(TINY,), batch_size=4, frames=24, prompt_words=5, warmup=1, steps=2, peak_size=256,
                          peak_repeats=2, generator_workers=(0, 2), generator_batches=2, generator_batch_size=4)


def analytic_forward_flops(s: Shape, *, batch: int, frames: int, words: int, features: int = 263) -> int:
    """Matmul FLOPs (2 per multiply-add) of one training-mode forward: linear layers and attention products."""
    B, T, L, w = batch, frames, words, s.width
    linear = lambda rows, n_in, n_out: 2 * rows * n_in * n_out  # noqa: E731
    total = linear(B * T, features, w) + 2 * linear(B, w, w)  # in_proj, time MLP
    for _ in range(s.layers):
        total += 2 * linear(B, w, 2 * w)  # the two AdaNorms' scale/shift
        total += 4 * linear(B * T, w, w) + 2 * 2 * B * T * T * w  # self-attention: q, k, v, out; QK^T, PV
        total += 2 * linear(B * T, w, w) + 2 * linear(B * L, w, w) + 2 * 2 * B * T * L * w  # cross-attention
        total += linear(B * T, w, 4 * w) + linear(B * T, 4 * w, w)  # feed-forward
    total += linear(B * T, w, features)  # out_proj
    for _ in range(s.text_layers):  # nn.TransformerEncoderLayer, feed-forward 2 x width
        total += linear(B * L, w, 3 * w) + 2 * 2 * B * L * L * w + linear(B * L, w, w)
        total += linear(B * L, w, 2 * w) + linear(B * L, 2 * w, w)
    return total


def test_flop_count_matches_the_analytic_count():
    forward, total = _Trainer(TINY, CPU, CONFIG).flops()
    expected = analytic_forward_flops(TINY, batch=4, frames=24, words=5)
    assert forward == pytest.approx(expected, rel=0.01)
    # backward: a gradient for each matmul's input and weight (the first layer's input needs none)
    assert 2.5 * forward < total <= 3 * forward


def test_bench_on_a_tiny_shape_gives_finite_positive_numbers():
    result = bench_train(CONFIG, device="cpu", model_dir=MODEL_DIR)
    json.dumps(result)  # JSON-ready
    assert result["device"] == "cpu" and isinstance(result["native_bf16"], bool)
    assert result["cpu_capability"] == torch.backends.cpu.get_cpu_capability()
    assert set(result["peak_gflops"]) == {"fp32", "bf16"}
    assert [(r["shape"], r["precision"]) for r in result["rows"]] == [("32x2", "fp32"), ("32x2", "bf16")]
    for r in result["rows"]:
        for key in ("steps_per_s", "samples_per_s", "gflop_per_step", "gflops", "share_of_peak"):
            assert math.isfinite(r[key]) and r[key] > 0, key
        assert r["samples_per_s"] == pytest.approx(4 * r["steps_per_s"])
        assert r["gflops"] == pytest.approx(r["gflop_per_step"] * r["steps_per_s"])
        assert r["native_bf16"] == result["native_bf16"]
    assert [g["workers"] for g in result["generator"]] == [0, 2]
    assert all(math.isfinite(g["samples_per_s"]) and g["samples_per_s"] > 0 for g in result["generator"])
    assert result["generator_keeps_up"] == any(g["keeps_up"] for g in result["generator"])
    table = format_table(result)
    assert "32x2" in table and "generator keeps up" in table


def test_only_the_named_precision_is_measured():
    config = TrainBenchConfig(shapes=(TINY,), batch_size=2, frames=8, prompt_words=3, warmup=0, steps=1,
                              peak_size=64, peak_repeats=1, generator_workers=(0,), generator_batches=1,
                              generator_batch_size=2)
    result = bench_train(config, device="cpu", precision="fp32")
    assert list(result["peak_gflops"]) == ["fp32"] and [r["precision"] for r in result["rows"]] == ["fp32"]


def test_cuda_on_a_cpu_machine_is_a_one_line_error(capsys, monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)  # the same on a machine with a GPU
    assert main(["bench", "--train", "--device", "cuda"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--device cuda" in err and "no CUDA GPU" in err


def test_fp16_on_the_cpu_is_a_one_line_error(capsys):
    assert main(["bench", "--train", "--device", "cpu", "--precision", "fp16"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
