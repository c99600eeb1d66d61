"""`--seconds auto`: the length is predicted from the prompt's parsed intent with the corpus's own duration rule;
an explicit length wins."""
from __future__ import annotations

import json

import pytest

from engine.duration import AUTO, DEFAULT_SECONDS, auto_seconds, resolve_seconds
from engine.generate import MAX_SECONDS, MIN_SECONDS


def test_more_counts_need_more_time_and_fit_the_corpus_rule():
    two, five = auto_seconds("a person jumps twice"), auto_seconds("a person jumps five times")
    assert two < five
    # the corpus rule: 0.95 s a jump plus a 0.3 s crouch, times 0.95-1.15
    assert 2 * 0.95 + 0.3 <= two <= (2 * 0.95 + 0.3) * 1.15 + 0.05
    assert auto_seconds("someone kicks twice") < 4.0 < auto_seconds("a person walks in a circle")


def test_a_sequence_sums_its_parts_within_the_model_range():
    walk, jump = auto_seconds("a person walks forward"), auto_seconds("a person jumps twice")
    both = auto_seconds("a person walks forward, then jumps twice")
    assert abs(both - (walk + jump)) <= 0.15
    long = auto_seconds("a person walks in a circle, then runs in a circle, then jumps five times")
    assert MIN_SECONDS <= long <= MAX_SECONDS and long == MAX_SECONDS


def test_no_recognised_action_gets_the_default_and_explicit_lengths_win():
    assert auto_seconds("a person flurbs") == DEFAULT_SECONDS
    assert auto_seconds("a person staggers") == auto_seconds("a person walks")  # a gait verb: a walk's length
    assert resolve_seconds(3.0, "a person jumps twice") == 3.0
    assert resolve_seconds(None, "a person jumps twice") == resolve_seconds(AUTO, "a person jumps twice")
    with pytest.raises(ValueError, match="or 'auto'"):
        resolve_seconds("long", "a person jumps")


def test_generate_defaults_to_auto_and_says_so(tmp_path, capsys):
    from engine.cli import main

    out = tmp_path / "m.npy"
    assert main(["generate", "someone kick twice", "--out", str(out), "--steps", "2"]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["seconds_from"] == "prompt" and report["seconds"] == auto_seconds("someone kick twice")
    assert report["frames"] == round(report["seconds"] * 20)
    assert main(["generate", "someone kicks", "--seconds", "2", "--out", str(out), "--steps", "2"]) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["frames"] == 40
