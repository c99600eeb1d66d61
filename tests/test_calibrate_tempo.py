"""`moattn bench --tempo`: the scale of a counted action's predicted length at which the model makes the count most
often, chosen only beyond the noise, and written where every `--seconds auto` reads it."""
from __future__ import annotations

import shutil
from dataclasses import replace

import pytest

from engine.evaluation.calibrate_tempo import (VERB_PHRASES, TempoConfig, calibrate_tempo, calibration_prompt, choose,
                                               format_table, write_tempo)
from engine.intent import COUNTED_ACTIONS, parse_intent


def test_choose_takes_the_best_scale_only_beyond_the_gain():
    assert choose({1.0: 0.3, 1.15: 0.5, 1.3: 0.45}, 0.12) == 1.15
    assert choose({1.0: 0.3, 1.15: 0.4, 1.3: 0.35}, 0.12) == 1.0  # within the noise: the corpus's length
    assert choose({0.9: 0.6, 1.0: 0.6, 1.15: 0.6}, 0.0) == 1.0  # a tie: nearest 1
    assert choose({0.9: 0.9, 1.0: 0.5, 1.3: 0.9}, 0.12) == 0.9  # a tie between two beyond it: the nearer 1 first
    # base v9's claps: 1.45 counts best by 0.06, inside the noise of 1.15, which is the smaller change
    assert choose({0.9: 0.0, 1.0: 0.28, 1.15: 0.5, 1.3: 0.44, 1.45: 0.56}, 0.12) == 1.15
    assert choose({0.9: 0.11, 1.0: 0.22, 1.15: 0.28, 1.3: 0.44, 1.45: 0.22}, 0.12) == 1.3  # its waves


def test_every_calibration_prompt_is_one_counted_action_and_in_no_bench_set():
    from engine.evaluation.bench_adherence import PROMPTS_FILE
    from engine.evaluation.bench_levers import DEV_PROMPTS

    bench = set()
    for path in (PROMPTS_FILE, DEV_PROMPTS):
        bench |= {ln.strip() for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")}
    for action in COUNTED_ACTIONS:
        for count in TempoConfig().counts:
            for phrasing in range(len(VERB_PHRASES[action])):
                prompt = calibration_prompt(action, count, phrasing)
                segs = parse_intent(prompt).segments
                assert len(segs) == 1 and segs[0].action == action and segs[0].count == count, prompt
                assert prompt not in bench
    # the draws take an action's phrasings in turn
    assert calibration_prompt("hop", 2, 1) == "the person hops on the left leg twice" == calibration_prompt("hop", 2, 4)


def test_the_config_refuses_scales_without_one_and_unknown_actions():
    with pytest.raises(ValueError, match="include 1"):
        TempoConfig(scales=(1.1, 1.2))
    with pytest.raises(ValueError, match="no calibration phrase"):
        TempoConfig(actions=("moonwalk",))


def test_a_calibration_on_the_tiny_model_is_written_where_auto_lengths_read_it(tiny_model_dir, tmp_path):
    from engine.checkpoint import load_model, read_config

    folder = tmp_path / "model"
    shutil.copytree(tiny_model_dir, folder)
    config = replace(TempoConfig.quick(), actions=("clap", "jump"), seeds=2, steps=2, min_gain=0.0)
    result = calibrate_tempo(load_model(folder), config)
    assert set(result["per_action"]) == {"clap", "jump"} and set(result["per_action"]["clap"]) == {"1", "1.15", "1.3"}
    assert all(0.0 <= v <= 1.0 for shares in result["per_action"].values() for v in shares.values())
    assert result["exact_chosen"] >= result["exact_at_scale_1"]  # the chosen scale is never worse on its own draws
    write_tempo(folder, result)
    written = read_config(folder)["durations"]
    assert written["count_scale"] == {a: s for a, s in result["count_scale"].items() if s != 1.0}
    assert load_model(folder).tempo == tuple(sorted(written["count_scale"].items()))
    table = format_table(result)
    assert "clap" in table and "chosen" in table


def test_tempo_flags():
    from engine.cli.bench import add_parser, run
    from engine.cli.common import Parser

    parser = Parser(prog="moattn")
    add_parser(parser.add_subparsers())
    with pytest.raises(ValueError, match="--tempo goes alone"):
        run(parser.parse_args(["bench", "--tempo", "--control"]))
    with pytest.raises(ValueError, match="--write goes with"):
        run(parser.parse_args(["bench", "--adherence", "--write"]))
