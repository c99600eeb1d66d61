"""What a motion followed of its prompt (engine.analysis.followed): corpus motions with known programs read ✓
where they do what is asked and ✗ where not; unvalidated checks read "not checked"; the CLI prints the line and
the studio's Generate box shows it for the shown motion only."""
from __future__ import annotations

import json

import numpy as np
import pytest

from engine.analysis.followed import (FOLLOWED, MISSED, NOT_CHECKED, detector_reliability, follow_generated,
                                      followed, prompt_notes)
from engine.evaluation.adherence import ATTRIBUTES
from engine.synth.corpus import make_sample
from engine.synth.program import ACTIONS, Program, Segment

# every check validated: the tests below read the detectors themselves (one test uses the real validation)
ALL = {(attr, action): True for attr in ATTRIBUTES for action in ACTIONS} | {("order", "*"): True}


def corpus_motion(*segments: Segment) -> np.ndarray:
    return make_sample(Program(segments=segments), captions=["x"], with_features=False).joints


@pytest.fixture(scope="module")
def jumps3():
    return corpus_motion(Segment(action="jump", frames=80, count=3))


@pytest.fixture(scope="module")
def hops3_left():
    return corpus_motion(Segment(action="hop", frames=80, count=3, side="left"))


def _rows(report) -> dict[str, str]:
    return {row.attribute: row.verdict for _, row in report.rows}


def test_three_jumps_follow_a_prompt_for_three_jumps(jumps3):
    report = followed("a person jumps three times", jumps3, reliable=ALL)
    assert _rows(report) == {"action": FOLLOWED, "count": FOLLOWED}
    assert report.verdict == FOLLOWED
    assert report.describe() == "asked: jump \u00d73 \u00b7 seen: jump \u00d73 \u2713"


def test_three_jumps_do_not_follow_two_left_hops(jumps3):
    report = followed("someone hops twice on the left leg", jumps3, reliable=ALL)
    assert _rows(report) == {"action": MISSED, "count": MISSED, "side": MISSED}
    # what the motion does instead is said, as the detectors count it
    assert report.describe() == "asked: hop \u00d72 (left) \u00b7 seen: jump \u00d73 \u2717"
    assert followed("a person jumps twice", jumps3, reliable=ALL).describe() == \
        "asked: jump \u00d72 \u00b7 seen: jump \u00d73 \u2717"


def test_the_hopping_side_is_checked(hops3_left):
    left = followed("a man hops three times on the left leg", hops3_left, reliable=ALL)
    assert _rows(left) == {"action": FOLLOWED, "count": FOLLOWED, "side": FOLLOWED}
    assert left.describe() == "asked: hop \u00d73 (left) \u00b7 seen: hop \u00d73 (left) \u2713"
    right = followed("a man hops three times on the right leg", hops3_left, reliable=ALL)
    assert _rows(right)["side"] == MISSED and "seen: hop \u00d73 (left) \u2717" in right.describe()


def test_an_unvalidated_check_says_not_checked_never_a_guess(hops3_left):
    reliable = dict(ALL)
    reliable[("side", "hop")] = False
    report = followed("a man hops three times on the right leg", hops3_left, reliable=reliable)
    row = next(r for _, r in report.rows if r.attribute == "side")
    assert row.verdict == NOT_CHECKED and row.seen == ""  # what the detector read is not shown
    assert report.describe() == \
        "asked: hop \u00d73 (right) \u00b7 seen: hop \u00d73 \u2713 (side not checked)"
    reliable[("action", "hop")] = reliable[("count", "hop")] = False
    assert followed("a man hops three times on the right leg", hops3_left, reliable=reliable).describe() == \
        "asked: hop \u00d73 (right) \u00b7 seen: not checked"


def test_speed_and_style_have_no_detector(jumps3):
    report = followed("a zombie jumps three times slowly", jumps3, reliable=ALL)
    rows = _rows(report)
    assert rows["speed"] == NOT_CHECKED and rows["style"] == NOT_CHECKED and rows["count"] == FOLLOWED
    assert report.describe() == ("asked: jump \u00d73 (slowly) \u00b7 seen: jump \u00d73 \u2713 (speed not checked)"
                                 " | style zombie: not checked")


def test_an_intensity_word_is_checked_against_the_corpus_levels(jumps3):
    from engine.analysis.action_size import intensity_seen
    from engine.analysis.detectors import MotionSignals, detect

    high = corpus_motion(Segment(action="jump", frames=80, count=3, intensity=1.6, intensity_word="high"))

    def read(joints):  # the reading at the detected jumps' apexes
        m = MotionSignals(joints)
        return intensity_seen(m.joints, "jump", events=[e.frame for e in detect(m, "jump")])

    (level, size), (level_high, size_high) = read(jumps3), read(high)
    assert (level, level_high) == ("normal", "high")
    report = followed("a person jumps really high three times", high, reliable=ALL)
    assert _rows(report) == {"action": FOLLOWED, "count": FOLLOWED, "intensity": FOLLOWED}
    assert report.describe() == f"asked: jump \u00d73 (high) \u00b7 seen: jump \u00d73 (high {size_high:.2f} m) \u2713"
    plain = followed("a person jumps really high three times", jumps3, reliable=ALL)  # a normal jump asked high
    assert _rows(plain)["intensity"] == MISSED
    assert plain.describe() == f"asked: jump \u00d73 (high) \u00b7 seen: jump \u00d73 (normal {size:.2f} m) \u2717"
    # where the reading was not validated for the action it is not checked, and what it read is not shown
    unvalidated = {k: v for k, v in ALL.items() if k != ("intensity", "jump")}
    row = next(r for _, r in followed("a person jumps high three times", jumps3, reliable=unvalidated).rows
               if r.attribute == "intensity")
    assert row.verdict == NOT_CHECKED and row.seen == ""
    # a zombie jumps at 0.6x the height: its high jump reads high, not as a normal one
    zombie = make_sample(Program(segments=(Segment(action="jump", frames=80, count=3, intensity=1.6,
                                                   intensity_word="high"),), style="zombie"),
                         captions=["x"], with_features=False).joints
    assert _rows(followed("a zombie jumps high three times", zombie, reliable=ALL))["intensity"] == FOLLOWED
    # a punch has no size the corpus scales: "hard" is not read as an intensity at all
    assert "intensity" not in _rows(followed("a person punches hard", jumps3, reliable=ALL))


def test_a_sequence_reads_one_part_per_segment_and_its_order():
    walk_jump = corpus_motion(Segment(action="walk", frames=60, direction="forward"),
                              Segment(action="jump", frames=40, count=1))
    report = followed("a person walks forward then jumps once", walk_jump, reliable=ALL)
    assert report.describe() == ("asked: walk (forward) \u00b7 seen: walk (forward) \u2713 | "
                                 "asked: jump \u00d71 \u00b7 seen: jump \u00d71 \u2713 | "
                                 "order: walk \u2192 jump \u2713")
    backwards = followed("a person jumps once then walks forward", walk_jump, reliable=ALL)
    assert backwards.verdict == MISSED and backwards.describe().endswith("order: walk \u2192 jump \u2717")
    gesture = followed("a person walks while waving", walk_jump, reliable=ALL)
    assert [p.asked_line for p in gesture.parts] == ["walk", "wave while walking"]
    assert gesture.parts[1].verdict == MISSED


def test_a_prompt_with_no_action_checks_nothing(jumps3):
    report = followed("xyzzy", jumps3, reliable=ALL)
    assert report.parts == () and report.verdict == NOT_CHECKED
    assert report.describe() == "asked: no action recognised \u00b7 nothing checked"
    json.dumps(followed("a person jumps twice", jumps3, reliable=ALL).to_json())  # serialisable


def test_the_default_checks_are_the_validated_ones(jumps3):
    """Without ``reliable``, a check is made only where the adherence validation found its detector reliable."""
    reliable = detector_reliability()
    for prompt in ("a person jumps three times", "a person dances", "a person waves with the left hand twice",
                   "a person jogs in a circle"):
        report = followed(prompt, jumps3)
        for k, row in report.rows:
            if k is not None and row.verdict != NOT_CHECKED:
                assert reliable[(row.attribute, report.parts[k].rows[0].asked.replace(" ", "_"))], (prompt, row)
    assert followed("a person jumps three times", jumps3).verdict == FOLLOWED


def test_notes_are_read_when_the_tokenizer_gives_them(jumps3):
    class Tokenized:
        def notes(self):
            return ["left out: stiffly", "read 'skips' as 'hops'"]

    assert prompt_notes(object()) == ()
    assert prompt_notes(None) == ()
    assert prompt_notes(Tokenized()) == ("left out: stiffly", "read 'skips' as 'hops'")
    report, notes = follow_generated("a person jumps three times", jumps3, Tokenized())
    assert report.verdict in (FOLLOWED, MISSED) and notes == ("left out: stiffly", "read 'skips' as 'hops'")
    reason, _ = follow_generated("a person jumps", jumps3[:2])
    assert isinstance(reason, str) and reason.startswith("could not be read")


def test_moattn_generate_prints_what_was_followed(tiny_model_dir, tmp_path, capsys, monkeypatch):
    from engine.cli import main
    from engine.text import TokenizedPrompt

    out = tmp_path / "m.npy"
    assert main(["generate", "a person hops three times on the left leg", "--out", str(out), "--steps", "2",
                 "--model", str(tiny_model_dir)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[0] == f"wrote {out}"
    assert any(line.startswith("kept in the library as ") for line in lines)  # the test workspace's library
    followed = next(line for line in lines if line.startswith("followed: "))
    assert followed.startswith("followed: asked: hop \u00d73 (left) \u00b7 seen: "), lines
    report = json.loads(lines[-1])
    assert report["followed"]["line"] == followed[len("followed: "):] and report["notes"] == []
    # the tokenized prompt's notes, where it has them, on a line of their own
    monkeypatch.setattr(TokenizedPrompt, "notes", lambda self: ("left out: stiffly",), raising=False)
    assert main(["generate", "a person jumps twice", "--out", str(out), "--steps", "2",
                 "--model", str(tiny_model_dir)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert "notes: left out: stiffly" in lines and json.loads(lines[-1])["notes"] == ["left out: stiffly"]
    assert lines.index("notes: left out: stiffly") == lines.index(next(l for l in lines if l.startswith("followed: "))) + 1


def test_printable_spells_the_marks_out_where_the_terminal_cannot():
    from engine.cli.generate import printable

    class Latin1:
        encoding = "latin-1"

    assert printable("seen: jump \u00d72 \u2717", Latin1()) == "seen: jump x2 [no]"

    class Ascii:
        encoding = "ascii"

    assert printable("a \u00b7 b \u2713 \u2192", Ascii()) == "a - b [yes] ->"


def test_the_generate_box_shows_the_shown_motions_report_only(tiny_model_dir, real_joints):
    from app.main import Studio

    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s, box = st.state, st.controls.followed
        assert box.object == "" and not box.visible
        s.param.update(prompt="a person jumps twice", seconds=2.0, steps=3, record_steps=0, seed=1)
        assert s.generate() and s.wait(120), s.notices[-1:]
        first = s.current
        assert "asked: jump \u00d72 \u00b7 seen: " in box.object and box.visible
        assert 'class="followed-no"' in box.object or 'class="followed-yes"' in box.object
        s.show_motion(real_joints, title="imported")  # another motion shown: no report of the last one
        assert box.object == "" and not box.visible
        s.show(first)
        assert "asked: jump \u00d72" in box.object
        s.param.update(prompt="a person waves", seed=2)
        assert s.generate() and s.wait(120)
        assert "asked: wave \u00b7 seen: " in box.object and "jump" not in box.object.split("seen:")[0]
    finally:
        st.close()


def test_the_box_html_colours_the_marks_and_shows_the_notes(jumps3):
    from app.tabs.generate.followed import followed_html

    report = followed("a zombie jumps twice slowly", jumps3, reliable=ALL)
    text = followed_html(report, ("read 'jumsp' as 'jumps'", "left out: head <b>"))
    assert '<span class="followed-no">\u2717</span>' in text and "followed-unchecked" in text
    assert "read &#x27;jumsp&#x27; as &#x27;jumps&#x27;; left out: head &lt;b&gt;" in text  # escaped
    assert followed_html(None) == "" and "could not be read" in followed_html("could not be read (too short)")
    assert "followed-yes" in followed_html(followed("a person jumps three times", jumps3, reliable=ALL))


# ----------------------------------------------------------------------------- tries: keep the motion that followed
def test_best_try_keeps_the_first_that_followed_else_the_fewest_misses(jumps3, hops3_left):
    from engine.analysis.followed import UNREADABLE, best_try, misses

    ok = followed("a person jumps three times", jumps3, reliable=ALL)
    wrong = followed("a person jumps three times", hops3_left, reliable=ALL)
    assert misses(ok) == 0 and misses(wrong) >= 1 and misses("could not be read (too short)") == UNREADABLE
    assert best_try([wrong, ok, ok]) == 1
    assert best_try([ok, wrong]) == 0
    assert best_try(["could not be read", wrong]) == 1
    assert best_try([wrong, wrong]) == 0  # equals: the earliest
    with pytest.raises(ValueError, match="no tries"):
        best_try([])



def test_take_tries_stops_at_the_first_take_that_followed(jumps3, hops3_left):
    from engine.analysis.followed import take_tries

    ok = followed("a person jumps three times", jumps3, reliable=ALL)
    wrong = followed("a person jumps three times", hops3_left, reliable=ALL)
    made = []

    def make(seed):
        made.append(seed)
        return ok if seed == 6 else wrong

    assert take_tries(make, seed=5, tries=4, report=lambda r: r) == (1, [wrong, ok]) and made == [5, 6]
    made.clear()
    kept, takes = take_tries(lambda seed: made.append(seed) or wrong, seed=0, tries=3, report=lambda r: r)
    assert made == [0, 1, 2] and kept == 0 and len(takes) == 3  # none followed: all made, the earliest of equals


def test_moattn_generate_tries_seeds_until_one_follows(tiny_model_dir, tmp_path, capsys, workspace):
    """A tiny random model follows nothing: every try is made, the one that missed fewest is kept, and the report,
    the library's recipe and the title say its seed."""
    from engine.cli import main
    from engine.library import MotionLibrary
    from engine.methods.generate_options import DEFAULT_TRIES

    out = tmp_path / "m.npy"
    assert main(["generate", "a person jumps twice", "--out", str(out), "--steps", "2", "--seed", "5", "--tries", "3",
                 "--model", str(tiny_model_dir)]) == 0
    captured = capsys.readouterr()
    report = json.loads(captured.out.strip().splitlines()[-1])
    assert report["tries"] == 3 and report["seed"] in (5, 6, 7)
    assert f"tried seeds 5, 6, 7: kept seed {report['seed']}" in captured.err
    lib = MotionLibrary(workspace=workspace)
    [entry] = lib.entries()
    assert entry.title.endswith(f"seed {report['seed']}") and lib.recipe(entry.id)["seed"] == report["seed"]
    # --tries 1: the seed asked for; the default: DEFAULT_TRIES tries
    assert main(["generate", "a person jumps twice", "--out", str(out), "--steps", "2", "--seed", "5", "--tries", "1",
                 "--model", str(tiny_model_dir)]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["tries"] == 1 and report["seed"] == 5
    assert main(["generate", "a person jumps twice", "--out", str(out), "--steps", "2", "--seed", "5",
                 "--model", str(tiny_model_dir)]) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["tries"] == DEFAULT_TRIES
    assert main(["generate", "a person jumps twice", "--out", str(out), "--tries", "0",
                 "--model", str(tiny_model_dir)]) == 2


def test_the_generate_box_tries_and_keeps_the_seed_it_shows(tiny_model_dir):
    from app.main import Studio
    from engine.methods.generate_options import DEFAULT_TRIES

    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        s = st.state
        assert s.tries == DEFAULT_TRIES and st.controls.tries.value == DEFAULT_TRIES
        s.param.update(prompt="a person jumps twice", seconds=2.0, steps=2, record_steps=0, seed=3, tries=2)
        titles = []
        s._preview = lambda done, total, joints, title: titles.append(title)  # the live preview's title per step
        assert s.generate() and s.wait(120), s.notices[-1:]
        assert titles[0] == "a person jumps twice · seed 3 (try 1 of up to 2)"
        assert titles[-1] == "a person jumps twice · seed 4 (try 2 of up to 2)"
        item = s.item
        info = item.info
        assert info["tried"] == (3, 4) and item.settings.seed in (3, 4) and item.settings.tries == 1
        assert item.name.endswith(f"seed {item.settings.seed}")
        assert "tried seeds 3-4, kept seed" in s.status
        # re-recording it makes that seed's motion again, in one try
        assert s.rerecord() and s.wait(120), s.notices[-1:]
        assert s.seed == item.settings.seed
    finally:
        st.close()
