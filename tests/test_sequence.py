"""Prompts of several actions in order: cut into clauses the way the intent parser reads them
(engine.clauses), planned as DoubleTake intervals (engine.methods.sequence), generated clause by clause by the CLI,
the studio and the adherence bench, with "whole" as the one-take way."""
from __future__ import annotations

import json

import numpy as np
import pytest

from engine.clauses import clause_prompts
from engine.duration import auto_seconds
from engine.methods.doubletake import MIN_OWN_FRAMES, DoubleTakeConfig
from engine.methods.sequence import HANDSHAKE, SHORT_CLAUSE_FRAMES, TURN_SETTLE, plan, timeline_frames
from engine.units import FPS, MAX_FRAMES

H = HANDSHAKE  # the frames two clauses share


def test_clauses_share_half_of_a_long_motions_handshake():
    """A counted clause is short: DoubleTake's default handshake (20 frames, for long motions) averaged one of its
    repetitions away, so clauses share 10 (engine.methods.sequence)."""
    from engine.methods.sequence import JOIN

    assert DoubleTakeConfig().handshakes(2)[0] == 20 and H == 10 and JOIN.handshakes(3) == (10, 10)


@pytest.mark.parametrize("prompt, clauses", [
    ("a man waves, then kicks", ("a man waves", "a man kicks")),
    ("someone jumps twice and then walks backwards", ("someone jumps twice", "someone walks backwards")),
    ("A woman squats. Then jumps three times.", ("A woman squats", "A woman jumps three times")),
    ("a man jumps once, then claps twice, then bows", ("a man jumps once", "a man claps twice", "a man bows")),
    # a piece with no action of its own stays with the one before it
    ("a man walks forward, slowly, then jumps", ("a man walks forward, slowly", "a man jumps")),
    # a pronoun is said as the first clause's subject; a subject of its own is kept
    ("a woman kicks with her left leg and then she waves", ("a woman kicks with her left leg", "a woman waves")),
    ("a man claps and then a woman bows", ("a man claps", "a woman bows")),
    ("an old man walks slowly, then sits down", ("an old man walks slowly", "an old man sits down")),
    # the subject is who moves, not the words up to the action ("throws two" is not said again)
    ("a boxer throws two punches then steps back", ("a boxer throws two punches", "a boxer steps back")),
    ("someone slowly walks forward, then jumps", ("someone slowly walks forward", "someone jumps")),
    ("a zombie waves with the left hand then walks forward slowly",
     ("a zombie waves with the left hand", "a zombie walks forward slowly")),
    ("a zombie throws two punches, then bows", ("a zombie throws two punches", "a zombie bows")),
    ("a very old man waves, then bows", ("a very old man waves", "a very old man bows")),
    # after a turn on the spot, walking "back" is the way the body came: ahead of it (the corpus's "walks back" is a
    # walk backwards, so the clause says forward); "backwards" and a "back" with no turn before it keep their meaning
    ("a person walks forward, turns around, then walks back",
     ("a person walks forward", "a person turns around", "a person walks forward")),
    ("a man turns around and runs back to the door", ("a man turns around", "a man runs forward to the door")),
    ("a man turns around, then walks backwards", ("a man turns around", "a man walks backwards")),
    ("a man walks back, then turns around", ("a man walks back", "a man turns around")),
])
def test_a_sequence_is_cut_into_one_prompt_per_action(prompt, clauses):
    assert clause_prompts(prompt) == clauses


@pytest.mark.parametrize("prompt", [
    "a person jumps twice",  # one action
    "a man claps after jumping",  # the order is not the words' order
    "someone walks while waving",  # at the same time, not in order
    "a person walks forward and turns left",  # a walk's direction, not a second action
    "",
])
def test_what_is_not_a_sequence_in_order_stays_whole(prompt):
    assert clause_prompts(prompt) == (" ".join(prompt.split()),)


def test_plan_gives_each_clause_its_own_predicted_length():
    prompt = "a man waves, then kicks twice"
    intervals = plan(prompt)
    assert [iv.prompt for iv in intervals] == ["a man waves", "a man kicks twice"]
    own = [auto_seconds(iv.prompt) for iv in intervals]
    # each interval holds its clause's time and half of the handshake it shares
    assert [round(iv.seconds * FPS) for iv in intervals] == [round(s * FPS) + H // 2 for s in own]
    assert abs(timeline_frames(intervals) - round(sum(own) * FPS)) <= 1


def test_a_short_clause_keeps_all_its_time_outside_the_handshakes():
    [jump, clap, bow] = plan("a man jumps once, then claps twice, then bows")
    own = round(auto_seconds("a man jumps once") * FPS)
    assert own < SHORT_CLAUSE_FRAMES  # a jump said once is short: half a handshake on top would leave it squeezed
    assert round(jump.seconds * FPS) == own + H  # its own frames, and the whole handshake it shares
    # two handshakes in the middle: at least the short part of its own time outside both
    own_clap = round(auto_seconds("a man claps twice") * FPS)
    assert round(clap.seconds * FPS) == max(own_clap + H, 2 * H + min(own_clap, SHORT_CLAUSE_FRAMES))
    own_bow = round(auto_seconds("a man bows") * FPS)
    assert own_bow > SHORT_CLAUSE_FRAMES and round(bow.seconds * FPS) == own_bow + H // 2  # long: half a handshake


def test_a_turn_clause_gets_time_to_settle_its_turn_beside_each_neighbour():
    walk, turn, again = plan("a person walks forward, turns around, then walks forward")
    assert walk.prompt == again.prompt == "a person walks forward" and turn.prompt == "a person turns around"
    own_turn = round(auto_seconds("a person turns around") * FPS)
    # its own time, half of each handshake, and TURN_SETTLE frames beside each of its two neighbours
    assert round(turn.seconds * FPS) == own_turn + H + 2 * TURN_SETTLE
    assert round(walk.seconds * FPS) == round(auto_seconds("a person walks forward") * FPS) + H // 2  # not a turn
    first, runs = plan("a man turns around and then runs")  # one neighbour: one settle
    assert round(first.seconds * FPS) == round(auto_seconds("a man turns around") * FPS) + H // 2 + TURN_SETTLE
    # a length the user gives is shared as the settled lengths are
    given = plan("a person walks forward, turns around, then walks forward", seconds=12.0)
    assert abs(timeline_frames(given) - 12.0 * FPS) <= 2
    assert given[1].seconds > given[0].seconds  # the turn's share holds its settle time


def test_plan_shares_a_given_length_and_refuses_one_too_short():
    intervals = plan("a person waves, then jogs forward, then squats", seconds=9.0)
    assert len(intervals) == 3
    assert abs(timeline_frames(intervals) - 9.0 * FPS) <= 2
    for i, iv in enumerate(intervals):  # every interval keeps frames of its own beside its handshakes
        shared = H * ((i > 0) + (i < 2))
        assert shared + MIN_OWN_FRAMES <= round(iv.seconds * FPS) <= MAX_FRAMES
    with pytest.raises(ValueError, match="longer than the model's 9.8 s: give a shorter duration"):
        plan("a man waves, then kicks", seconds=30.0)  # never cut short in silence
    with pytest.raises(ValueError, match="asks for 3 actions in order.*needs at least .* s"):
        plan("a person waves, then jogs forward, then squats", seconds=2.0)


def test_whole_and_single_actions_are_one_take():
    assert plan("a man waves, then kicks", sequence="whole") is None
    assert plan("a man waves twice") is None
    with pytest.raises(ValueError, match="sequence must be one of clauses, whole"):
        plan("a man waves, then kicks", sequence="both")


def test_cli_generates_a_sequence_clause_by_clause(capsys, tiny_model_dir, tmp_path):
    from engine.cli import main

    out = tmp_path / "seq.npy"
    code = main(["generate", "a person walks forward, then jumps", "--model", str(tiny_model_dir), "--steps", "3",
                 "--out", str(out), "--no-library"])
    stdout, stderr = capsys.readouterr()
    assert code == 0, stderr
    assert "clause by clause: 'a person walks forward'" in stderr and "'a person jumps'" in stderr
    report = json.loads(stdout.strip().splitlines()[-1])
    intervals = plan("a person walks forward, then jumps")
    assert report["clauses"] == ["a person walks forward", "a person jumps"]
    joints = np.load(out)
    assert joints.shape == (timeline_frames(intervals), 22, 3) == (report["frames"], 22, 3)
    assert np.isfinite(joints).all()

    code = main(["generate", "a person walks forward, then jumps", "--model", str(tiny_model_dir), "--steps", "2",
                 "--out", str(out), "--no-library", "--seconds", "12"])  # longer than one take: each clause is not
    stdout, stderr = capsys.readouterr()
    assert code == 0, stderr
    assert abs(len(np.load(out)) - 12 * FPS) <= 2 and json.loads(stdout.strip().splitlines()[-1])["seconds"] > 11.8

    code = main(["generate", "a person walks forward, then jumps", "--model", str(tiny_model_dir), "--steps", "3",
                 "--out", str(out), "--no-library", "--sequence", "whole", "--seconds", "2"])
    stdout, stderr = capsys.readouterr()
    assert code == 0, stderr
    assert "clause by clause" not in stderr and json.loads(stdout.strip().splitlines()[-1])["clauses"] is None
    assert np.load(out).shape == (40, 22, 3)


def test_the_studio_generates_a_sequence_clause_by_clause_with_its_attention(tiny_model_dir):
    from app.main import Studio
    from app.session.library import recipe_of, settings_from_recipe

    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s, view = st.state, st.attention
        prompt = "a person walks forward, then jumps"
        s.param.update(prompt=prompt, seconds=None, steps=3, record_steps=2, seed=1)
        # the Generate box says how the prompt will be made before it runs, and what its maps will take
        assert st.controls.sequence.visible and "2 actions in order" in st.controls.clauses.object
        assert "attention kept: none" not in st.controls.memory.object
        # the length box's placeholder is the joined motion's length
        intervals = plan(prompt)
        assert st.controls.seconds.placeholder == f"auto {timeline_frames(intervals) / FPS:.1f}"
        assert s.generate() and s.wait(120), s.notices[-1:]
        item = s.item
        assert item.settings.sequence == "clauses"
        n = timeline_frames(intervals)
        assert len(item.joints) == n
        assert any("generated clause by clause: 'a person walks forward' → 'a person jumps'" in n
                   for n in item.info["notes"])
        # its attention: each clause's words over the joined timeline, recorded in the first take
        record = item.attention
        assert record is not None and record.n_frames == n
        assert record.words == ("a", "person", "walks", "forward", "a", "person", "jumps")
        cross = record.cross_map()
        np.testing.assert_allclose(cross.sum(1), 1.0, atol=2e-3)  # every frame's row is still a distribution
        first = int(round(intervals[0].seconds * FPS))
        second_start = n - int(round(intervals[1].seconds * FPS))
        assert np.allclose(cross[:second_start, 4:], 0) and np.allclose(cross[first:, :4], 0)
        assert (cross[second_start:first, :4].sum(1) > 0.2).all()  # the handshake hears both clauses
        sm = record.self_map()
        np.testing.assert_allclose(sm.sum(1), 1.0, atol=2e-3)
        assert np.allclose(sm[:second_start, first:], 0)  # the walk's frames never attend to the jump's own
        assert "generated clause by clause" in view.info.object and "first take" in view.info.object
        assert view.words.options and len(view.words.options) == len(record.words)
        # re-recording repeats it: the same seed gives the same motion and the same maps
        assert s.rerecord() and s.wait(120), s.notices[-1:]
        np.testing.assert_allclose(s.item.joints, item.joints, atol=1e-5)
        assert s.item.attention is not None and s.item.attention.words == record.words
        # the library keeps how it was made; a recipe from before keeps meaning one take
        assert settings_from_recipe(recipe_of(item, model_dir=tiny_model_dir)).sequence == "clauses"
        old = recipe_of(item, model_dir=tiny_model_dir)
        del old["operation"]["sequence"]
        assert settings_from_recipe(old).sequence == "whole"

        s.sequence = "whole"  # one take of the whole prompt
        assert "one take" in st.controls.clauses.object
        assert st.controls.seconds.placeholder == f"auto {auto_seconds(prompt):.1f}"
        assert s.generate() and s.wait(120), s.notices[-1:]
        assert s.item.attention is not None and s.item.settings.sequence == "whole"
        assert s.item.attention.words == ("a", "person", "walks", "forward", "then", "jumps")
        s.prompt = "a person jumps twice"  # one action: nothing to choose
        assert not st.controls.sequence.visible
    finally:
        st.close()


def test_the_adherence_bench_scores_sequences_as_a_user_gets_them(tiny_model_dir):
    from engine.checkpoint import load_model
    from engine.evaluation.bench_adherence import AdherenceBenchConfig, _model_motions

    loaded = load_model(tiny_model_dir)
    prompt = "a person walks forward, then jumps"
    config = AdherenceBenchConfig(seeds=2, steps=2, validation_motions=1)
    clauses = _model_motions(loaded, prompt, [41, 41], config)
    assert [len(m) for m in clauses] == [timeline_frames(plan(prompt))] * 2
    assert not np.allclose(clauses[0], clauses[1])  # one seed each
    whole = _model_motions(loaded, prompt, [41, 41], AdherenceBenchConfig(seeds=2, steps=2, sequence="whole"))
    assert [len(m) for m in whole] == [40, 40]
    with pytest.raises(ValueError, match="sequence must be one of"):
        AdherenceBenchConfig(sequence="both")


def test_the_studio_checks_a_sequence_by_its_clauses(tiny_model_dir):
    """A joined motion may outlast the model's longest one: each clause is checked against it instead."""
    from app.generation import GenerationSettings, check
    from engine.checkpoint import load_model

    loaded = load_model(tiny_model_dir)
    prompt = "a person walks forward, then jumps"
    longest = loaded.model.config.max_frames / FPS
    checked = check(loaded, GenerationSettings(prompt=prompt, seconds=longest + 2))
    assert abs(checked.frames - (longest + 2) * FPS) <= 2 and checked.total_steps > checked.config.steps
    with pytest.raises(ValueError, match="must be between"):
        check(loaded, GenerationSettings(prompt=prompt, seconds=longest + 2, sequence="whole"))
    with pytest.raises(ValueError, match="needs at least"):
        check(loaded, GenerationSettings(prompt=prompt, seconds=1.5))
