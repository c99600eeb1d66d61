"""`moattn bench --intensity` on the tiny model: its prompts are the corpus grammar's words, its shares are counted
from the draws it made, and bad arguments fail at once."""
from __future__ import annotations

import json

import pytest

from engine.evaluation.bench_intensity import CASES, IntensityBenchConfig, bench_intensity, format_table, variants


def test_the_variants_are_the_corpus_grammars_intensity_words():
    from engine.synth.grammar import INTENSITY_WORDS

    high, little = variants("wave", 2)
    assert high == list(INTENSITY_WORDS["wave"]["high"][:2]) and little == list(INTENSITY_WORDS["wave"]["a little"][:2])
    with pytest.raises(ValueError, match="no intensity case for squat"):
        IntensityBenchConfig(actions=("squat",))
    with pytest.raises(ValueError, match="at least 1"):
        IntensityBenchConfig(seeds=0)


def test_the_bench_counts_grown_and_shrunk_draws(tiny_model_dir, monkeypatch):
    """The shares are the draws' own: with the sizes the amplitude measure returns replaced by known values, "grows",
    "shrinks" and "in order" are exactly the counted shares."""
    import engine.evaluation.bench_intensity as bench
    from engine.checkpoint import load_model

    loaded = load_model(tiny_model_dir)
    # per seed, 1 plain + 1 high + 1 little draw: sizes cycle through these (seed 0: high grows, little shrinks;
    # seed 1: neither)
    sizes = iter([1.0, 2.0, 0.5, 1.0, 0.5, 2.0])
    monkeypatch.setattr(bench, "amplitude", lambda joints, verb: next(sizes))
    result = bench_intensity(loaded, IntensityBenchConfig(actions=("jump",), words=1, seeds=2, steps=2))
    (row,) = result["rows"]
    assert (row["grows"], row["shrinks"], row["in_order"]) == (0.5, 0.5, 0.5)
    assert row["plain_m"] == 1.0 and row["high"] == {"high": 1.25} and row["a_little"] == {"a little": 1.25}
    assert row["prompt"] == CASES["jump"][0] and row["seconds"] > 0
    assert "in order (a high word bigger and a little word smaller than the plain draw): 0.50" in format_table(result)


def test_the_cli_runs_it_and_refuses_bad_seeds(tiny_model_dir, capsys):
    from engine.cli import main

    assert main(["bench", "--intensity", "--model", str(tiny_model_dir), "--quick", "--steps", "2", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert [r["action"] for r in result["rows"]] == list(CASES) and result["seeds"] == 2
    assert all(0.0 <= r["in_order"] <= 1.0 and r["plain_m"] >= 0.0 for r in result["rows"])
    assert main(["bench", "--intensity", "--model", str(tiny_model_dir), "--seeds", "0"]) == 2
    assert "--seeds must be at least 1" in capsys.readouterr().err
