"""`--seconds auto`: the length is predicted from the prompt's parsed intent with the corpus's own duration rule;
an explicit length wins."""
from __future__ import annotations

import json

import pytest

from engine.checkpoint import read_config
from engine.duration import AUTO, DEFAULT_SECONDS, auto_seconds, model_tempo, resolve_seconds
from engine.paths import MODEL_DIR
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
    tempo = model_tempo(read_config(MODEL_DIR))  # the shipped model's count tempo, as the command reads it
    assert report["seconds_from"] == "prompt" and report["seconds"] == auto_seconds("someone kick twice", tempo)
    assert report["frames"] == round(report["seconds"] * 20)
    assert main(["generate", "someone kicks", "--seconds", "2", "--out", str(out), "--steps", "2"]) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["frames"] == 40


def test_a_models_count_tempo_scales_its_counted_actions_only():
    tempo = (("clap", 1.3),)
    plain, slow = auto_seconds("a person claps three times"), auto_seconds("a person claps three times", tempo)
    assert abs(slow - 1.3 * plain) <= 0.1  # rounded to 0.1 s
    assert auto_seconds("a person jumps twice", tempo) == auto_seconds("a person jumps twice")  # another action
    assert auto_seconds("a person claps", tempo) == auto_seconds("a person claps")  # no count asked
    walk = auto_seconds("a person walks forward")
    both = auto_seconds("a person walks forward, then claps three times", tempo)
    assert abs(both - (walk + slow)) <= 0.15  # the walk keeps its length
    assert resolve_seconds(None, "a person claps three times", tempo=tempo) == slow
    assert resolve_seconds(2.0, "a person claps three times", tempo=tempo) == 2.0  # an explicit length wins


def test_model_tempo_reads_the_config_and_the_sequence_plan_uses_it():
    from engine.methods.sequence import plan

    config = {"durations": {"count_scale": {"wave": 1.2, "clap": 1.3}}}
    assert model_tempo(config) == (("clap", 1.3), ("wave", 1.2))
    assert model_tempo({}) == () and model_tempo(None) == () and model_tempo({"durations": {}}) == ()
    prompt = "a person walks forward, then claps three times"
    plain, slow = plan(prompt), plan(prompt, tempo=model_tempo(config))
    assert plain[0].seconds == slow[0].seconds and slow[1].seconds > plain[1].seconds


def test_generate_reads_the_models_count_tempo(tiny_model_dir, tmp_path, capsys):
    import shutil

    from engine.checkpoint import load_model, write_config_json
    from engine.cli import main

    folder = tmp_path / "model"
    shutil.copytree(tiny_model_dir, folder)
    data = read_config(folder)
    data["durations"] = {"count_scale": {"clap": 1.4}}
    write_config_json(folder, data)
    assert load_model(folder).tempo == (("clap", 1.4),)
    out = tmp_path / "m.npy"
    assert main(["generate", "a person claps three times", "--model", str(folder), "--out", str(out), "--steps", "2",
                 "--no-library"]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["seconds"] == auto_seconds("a person claps three times", (("clap", 1.4),))
    assert report["seconds"] > auto_seconds("a person claps three times")


def test_a_counted_action_gets_its_length_whatever_the_speed_word():
    """The model repeats at its own pace: "jumps quickly three times" gets the room of three jumps (the corpus's
    shorter length gave two, session 33), and so does "slowly"."""
    from engine.duration import auto_seconds

    plain = auto_seconds("a person jumps three times")
    assert auto_seconds("a person jumps quickly three times") == plain == auto_seconds("a person jumps slowly three times")
    assert auto_seconds("someone claps quickly twice") == auto_seconds("someone claps twice")
