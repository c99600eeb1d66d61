"""Adherence detectors on hand-built motions and corpus ground truth, and the adherence bench's shape."""
from __future__ import annotations

import re

import numpy as np
import pytest

from engine.analysis.detectors import MotionSignals, detect
from engine.evaluation.adherence import (check_motion, ground_truth_motion, intent_of_program, program_for_intent,
                                         validate)
from engine.intent import parse_intent
from engine.synth.corpus import make_sample
from engine.synth.program import Program, Segment


def corpus_motion(*segments: Segment, style: str = "none") -> np.ndarray:
    return make_sample(Program(segments=segments, style=style), captions=["x"], with_features=False).joints


def test_one_jump_is_not_two():
    one = corpus_motion(Segment(action="jump", frames=40, count=1))
    two = corpus_motion(Segment(action="jump", frames=60, count=2))
    assert len(detect(one, "jump")) == 1 and len(detect(two, "jump")) == 2
    assert check_motion(two, parse_intent("a person jumps twice"))["count"] is True
    assert check_motion(one, parse_intent("a person jumps twice"))["count"] is False


def test_left_kick_is_not_a_right_kick():
    left = corpus_motion(Segment(action="kick", frames=50, count=1, side="left"))
    right = corpus_motion(Segment(action="kick", frames=50, count=1, side="right"))
    assert [d.side for d in detect(left, "kick")] == ["left"]
    assert [d.side for d in detect(right, "kick")] == ["right"]
    assert check_motion(left, parse_intent("a person kicks with the left leg"))["side"] is True
    assert check_motion(right, parse_intent("a person kicks with the left leg"))["side"] is False


def test_a_still_body_does_nothing_asked():
    still = np.repeat(corpus_motion(Segment(action="stand", frames=40))[:1], 60, axis=0)
    result = check_motion(still, parse_intent("a person waves twice then jumps"))
    assert result["action"] is False
    assert check_motion(still, parse_intent("someone stands still"))["action"] is True


def test_order_follows_the_motion():
    walk_jump = corpus_motion(Segment(action="walk", frames=60, direction="forward"),
                              Segment(action="jump", frames=40, count=1))
    assert check_motion(walk_jump, parse_intent("a person walks then jumps"))["order"] is True
    assert check_motion(walk_jump, parse_intent("a person jumps then walks"))["order"] is False


def test_a_slow_gait_with_short_double_support_is_a_walk():
    """What a person sees: stepping forward at walking speed with a foot always on the floor is a walk, even when
    the feet rarely share the floor (generated walks do that); the corpus's runs stay runs."""
    from engine.analysis.detectors import MIN_RUN_SPEED, gait_kind, gait_runs

    assert gait_kind({"double_support": 0.1, "speed": 0.6}) == "walk"
    assert gait_kind({"double_support": 0.1, "speed": MIN_RUN_SPEED + 0.5}) == "run"
    assert gait_kind({"double_support": 0.3, "speed": 2.0}) == "walk"  # both feet down part of every step
    run = corpus_motion(Segment(action="run", frames=80, direction="forward"))
    assert detect(run, "run") and not detect(run, "walk")
    assert all(r["speed"] >= MIN_RUN_SPEED for r in gait_runs(MotionSignals(run)))
    walk = corpus_motion(Segment(action="walk", frames=80, direction="forward"))
    assert detect(walk, "walk") and not detect(walk, "run")


def test_bad_joints_are_refused():
    with pytest.raises(ValueError, match="22, 3"):
        MotionSignals(np.zeros((10, 21, 3)))
    with pytest.raises(ValueError, match="NaN"):
        MotionSignals(np.full((10, 22, 3), np.nan))


def test_ground_truth_realises_the_stated_attributes():
    intent = parse_intent("a man hops on the right leg three times")
    program = program_for_intent(intent, np.random.default_rng(0))
    assert program.segments[0].action == "hop" and program.segments[0].side == "right"
    assert program.segments[0].count == 3
    assert intent_of_program(program).segments[0].side == "right"
    assert check_motion(ground_truth_motion(intent, 0), intent)["count"] is True


def test_a_bow_before_jumps_is_seen():
    """The jumps' flights do not raise the height a bow's pelvis is measured against (every seed of the corpus's own
    motion: before, none)."""
    intent = parse_intent("a man bows, then jumps three times, then waves")
    for seed in range(4):
        joints = ground_truth_motion(intent, seed)
        signals = MotionSignals(joints)
        assert signals.flights and signals.grounded_pelvis < signals.standing_pelvis - 0.1  # the flights are high
        assert check_motion(joints, intent) == {"action": True, "count": True, "side": None, "direction": None,
                                                "intensity": None, "order": True}, seed


def test_validation_on_a_corpus_slice():
    result = validate(motions=40)
    agreement = result["agreement"]
    assert set(agreement) >= {"action", "count", "side", "direction", "order", "action_absent"}
    assert agreement["action"] > 0.8 and agreement["count"] > 0.8 and agreement["action_absent"] > 0.9
    # a check seen fewer times than the minimum is never called reliable
    rare = [k for k, v in result["per_action"].items() if v["n"] < 5]
    assert all(not result["reliable"][k] for k in rare)


def test_bench_ground_truth_only_shape():
    from engine.evaluation.bench_adherence import AdherenceBenchConfig, bench_adherence, format_table, read_prompts

    assert len(read_prompts()) >= 60
    result = bench_adherence(None, AdherenceBenchConfig(seeds=1, validation_motions=30),
                             prompts=["a person jumps twice", "a person flurbs", "someone kicks with the left leg"])
    assert result["model"] is None and result["ground_truth"]["action_n"] >= 1
    assert [u["prompt"] for u in result["unparsed"]] == ["a person flurbs"]  # no word of it says a motion
    assert len(result["per_prompt"]) == 2
    assert "detector validation" in format_table(result)


def test_the_bench_scores_a_stated_intensity_in_its_own_column():
    from engine.evaluation.bench_adherence import AdherenceBenchConfig, bench_adherence, format_table

    result = bench_adherence(None, AdherenceBenchConfig(seeds=1, validation_motions=60),
                             prompts=["a person jumps high", "a person kicks a little with the left leg"])
    truth = result["ground_truth"]
    assert truth["intensity_n"] >= 1 and truth["intensity"] == 1.0  # the truth jumps at its stated level
    lines = format_table(result).splitlines()
    head = lines[lines.index("adherence (share of motions whose stated attribute matches; n in brackets):") + 1]
    assert head.split() == ["action", "count", "side", "direction", "intensity", "order"]
    truth_row = next(line for line in lines if line.startswith("ground_truth"))
    cells = re.findall(r"(\S+) \(\s*(\d+)\)", truth_row)  # "share (n)" per column
    assert cells[4] == ("1.00", str(truth["intensity_n"]))


def test_root_speed_shows_a_walk_in_place(monkeypatch):
    """The bench's root speed: the model's over the truth's where every action travels. A model that walks in place
    (no foot slides, so skate cannot show it) reads a ratio near 0; jumps are not counted."""
    import engine.evaluation.bench_adherence as ba

    def in_place(loaded, prompt, lengths, config, **_held):
        truths = [ba.ground_truth_motion(ba.parse_intent(prompt), 7 + k) for k in range(len(lengths))]
        for j in truths:
            j[:, :, [0, 2]] -= j[:, :1, [0, 2]]  # the same body, its root held where it is
        return truths

    monkeypatch.setattr(ba, "_model_motions", in_place)

    class Loaded:
        tempo = ()  # the corpus's lengths (no count tempo measured)

        class tokenizer:
            @staticmethod
            def encode(prompt):
                return prompt

    result = ba.bench_adherence(Loaded(), ba.AdherenceBenchConfig(seeds=2, validation_motions=30),
                                prompts=["a person walks forward", "a person jumps twice"])
    speed = result["root_speed"]
    assert speed["ground_truth"] > 0.5 and speed["model"] < 0.05 and speed["ratio"] < 0.1
    assert "root speed where every action travels" in ba.format_table(result)
    from engine.evaluation.metrics import root_speed

    assert root_speed(np.zeros((5, 22, 3))) == 0.0 and root_speed(np.zeros((1, 22, 3))) == 0.0


@pytest.mark.parametrize("argv,message", [
    (["--transfer", "--prompts", "p.txt"], "--prompts goes with --adherence, --sampling or --levers"),
    (["--transfer", "--drawn", "2"], "--drawn goes with --control"),
    (["--control", "--drawn", "-1"], "--drawn must be 0 or more"),
    (["--edits", "--seeds", "2"], "--seeds goes with --duet, --adherence, --sampling, --levers, --intensity or --tempo"),
    (["--adherence", "--seeds", "0"], "--seeds must be at least 1"),
    (["--tempo", "--seeds", "0"], "--seeds must be at least 1, got 0"),
    (["--sampling", "--steps", "20"], "--sampling measures its own step counts"),
])
def test_bench_flags_are_checked_before_any_model_loads(capsys, argv, message):
    from engine.cli import main

    assert main(["bench", *argv, "--model", "/nonexistent"]) == 2
    assert message in capsys.readouterr().err


def test_bench_refuses_an_empty_prompts_file(tmp_path, capsys):
    from engine.cli import main

    empty = tmp_path / "none.txt"
    empty.write_text("# only a comment\n\n")
    assert main(["bench", "--adherence", "--prompts", str(empty), "--model", "/nonexistent"]) == 2
    assert "holds no prompts" in capsys.readouterr().err


def test_the_model_row_uses_the_lengths_a_user_gets(monkeypatch, tiny_model_dir):
    from engine.evaluation.bench_adherence import AdherenceBenchConfig
    """By default the model is sampled at the length predicted from the prompt (the studio's and the CLI's
    default), not at the ground truth's length; `--lengths truth` gives the old row."""
    import engine.evaluation.bench_adherence as bench
    from engine.checkpoint import load_model
    from engine.duration import auto_seconds

    seen = []
    real = bench._model_motions

    def spy(loaded, prompt, lengths, config, **held):
        seen.append(list(lengths))
        return real(loaded, prompt, lengths, config, **held)

    monkeypatch.setattr(bench, "_model_motions", spy)
    loaded = load_model(tiny_model_dir)
    prompt = "a person jumps twice"
    bench.bench_adherence(loaded, AdherenceBenchConfig(seeds=2, steps=2, validation_motions=10), prompts=[prompt])
    assert seen[-1] == [round(auto_seconds(prompt) * 20) + 1] * 2
    result = bench.bench_adherence(loaded, AdherenceBenchConfig(seeds=2, steps=2, validation_motions=10,
                                                                 lengths="truth"), prompts=[prompt])
    assert result["settings"]["lengths"] == "truth" and seen[-1] != seen[-2]
    with pytest.raises(ValueError, match="lengths must be"):
        AdherenceBenchConfig(lengths="long")


def test_tries_keep_each_seeds_best_motion(monkeypatch):
    """`--tries 2`: each seed's two tries are made, and the one that follows its prompt is kept, whichever came
    first; the table says so."""
    import engine.evaluation.bench_adherence as ba

    made = []

    def one_right(loaded, prompt, lengths, config, **_held):
        # seed 0's first try and seed 1's second try are two jumps; the others stand still
        jumps = ba.ground_truth_motion(ba.parse_intent("a person jumps twice"), 3)
        still = ba.ground_truth_motion(ba.parse_intent("someone stands still"), 3)
        made.append(len(lengths))
        return [jumps, still, still, jumps]  # entries: seed 0 try 1, seed 1 try 1, seed 0 try 2, seed 1 try 2

    monkeypatch.setattr(ba, "_model_motions", one_right)

    class Loaded:
        tempo = ()

        class tokenizer:
            @staticmethod
            def encode(prompt):
                return prompt

    result = ba.bench_adherence(Loaded(), ba.AdherenceBenchConfig(seeds=2, tries=2, validation_motions=30),
                                prompts=["a person jumps twice"])
    row = result["per_prompt"][0]
    assert made == [4] and row["tries_kept"] == [0, 1] and row["model"]["action"] == 1.0
    assert "(each the best of 2 tries)" in ba.format_table(result)
    with pytest.raises(ValueError, match="--tries must be at least 1"):
        ba.AdherenceBenchConfig(tries=0)


def test_lever_screen_rows_score_each_model_on_the_dev_prompts(tiny_model_dir, tmp_path, capsys):
    """`moattn bench --levers`: one row per model folder with dev adherence, the seeds' spread, foot skate against
    the truth and one real file's inversion; flags that belong elsewhere are refused."""
    import json

    from engine.cli import main
    from engine.evaluation.bench_levers import format_table
    from tests.conftest import real_file

    prompts = tmp_path / "dev.txt"
    prompts.write_text("a person jumps twice\nsomeone waves with the left hand\n")
    argv = ["bench", "--levers", str(tiny_model_dir), "--prompts", str(prompts), "--seeds", "2", "--steps", "5",
            "--guidance", "1.5", "--guidance-from", "600", "--real", str(real_file("cmu_131_01_walk.bvh")), "--quick", "--json"]
    assert main(argv) == 0
    result = json.loads(capsys.readouterr().out)
    (row,) = result["rows"]
    assert result["prompts"] == 2 and result["seeds"] == 2 and row["guidance"] == 1.5
    assert row["guidance_from"] == 600 and "guidance 1.5 at t >= 600" in format_table(result)
    assert "actions in order in one take (the model alone)" in format_table(result)
    assert 0.0 <= row["action"] <= 1.0 and row["action_seed_std"] is not None
    assert row["foot_skate"] is not None and row["inversion_cm"] > 0 and row["refused"] == 0
    assert main(["bench", "--levers", "--model", "/nonexistent"]) == 2
    assert "needs the model folders" in capsys.readouterr().err
    # a real file that cannot be read is refused before any row is scored
    assert main(["bench", "--levers", str(tiny_model_dir), "--prompts", str(prompts), "--real",
                 "cmu_131_01_walk.bvh"]) == 2
    err = capsys.readouterr().err
    assert "cmu_131_01_walk.bvh" in err and "[1/2]" not in err  # no prompt was sampled
    assert main(["bench", "--inversion", "--guidance", "2", "--model", "/nonexistent"]) == 2
    assert "--guidance and --guidance-from go with --adherence or --levers" in capsys.readouterr().err
    assert main(["bench", "--inversion", "--guidance-from", "0", "--model", "/nonexistent"]) == 2
    assert "go with --adherence or --levers" in capsys.readouterr().err
    assert main(["bench", "--inversion", "--eta", "0", "--model", "/nonexistent"]) == 2
    assert "--eta goes with --adherence, --levers or --edits" in capsys.readouterr().err


def test_lever_rows_say_which_prompts_a_lever_moved():
    from engine.evaluation.bench_levers import format_table, prompt_changes

    def row(name, shares):
        return {"model": name, "step": 10, "action": 0.5, "action_seed_std": 0.02, "count": 0.1, "side": 0.5,
                "foot_skate": 0.1, "foot_skate_vs_truth": 2.0, "inversion_cm": None, "inversion_noise_std": None,
                "samples_per_s": 30.0, "refused": 0, "guidance": 2.5, "per_prompt_action": shares}

    result = {"prompts": 3, "seeds": 4, "real_file": None, "rows": [
        row("control", {"someone walks": 0.0, "a man jumps": 1.0, "a woman squats twice": None}),
        row("lever", {"someone walks": 0.75, "a man jumps": 0.25, "a woman squats twice": None})]}
    text = prompt_changes(result)
    assert "lever against control: 2 prompts moved" in text
    assert "+ someone walks 0.00 -> 0.75" in text and "- a man jumps 1.00 -> 0.25" in text
    assert "squats" not in text and text in format_table(result)
    result["rows"][1]["per_prompt_action"]["someone walks"] = 0.25  # a move of one seed in four is not listed
    assert "1 prompts moved" in prompt_changes(result)


def test_a_turn_before_bows_is_seen_first():
    """A turn's event is where the body has turned half of the way, not the middle of the still stretch, which goes
    on through the bows that follow (the corpus's own motion: before, the order read backwards in 3 of 6 seeds)."""
    intent = parse_intent("a person turns around, then bows")
    for seed in range(6):
        joints = ground_truth_motion(intent, seed)
        turns = detect(MotionSignals(joints), "turn")
        assert [t.side for t in turns] == ["around"], seed
        assert check_motion(joints, intent)["order"] is True, seed
