"""The Compose tab (DoubleTake) without a server, on the tiny model: editing the timeline (add, remove, move, edit,
unknown words), checks with clear messages, a long motion generated through the tab (length = sum of the
intervals minus the handshakes, transitions recorded and coloured), the timeline strip moving the viewer, cancel."""
from __future__ import annotations

import numpy as np
import pytest
from bokeh.events import Tap

from app.tabs.compose.job import INTERVAL_COLORS, TRANSITION_COLOR, frame_colors, prepare, transition_at
from app.tabs.compose.settings import IntervalRow
from app.main import Studio
from viz.colors import default_joint_colors

pytestmark = pytest.mark.timeout(600)


@pytest.fixture()
def studio(tiny_model_dir):
    st = Studio(model_dir=tiny_model_dir, initial=None)
    st.state.param.update(steps=6, seed=2)
    yield st
    st.close()


def _rows(tab):
    return [(r.prompt.value, r.seconds.value) for r in tab.rows]


def test_timeline_add_remove_move_and_edit(studio):
    tab = studio.compose
    c = tab.settings
    assert _rows(tab) == [("a person walks forward", 4.0), ("a person jumps", 3.0)]
    tab.add.clicks += 1
    assert len(tab.rows) == 3 and len(c.intervals) == 3
    tab.rows[2].prompt.value = "a person waves"
    tab.rows[2].seconds.value = 2.5
    assert c.intervals[2] == IntervalRow("a person waves", 2.5)
    tab.rows[2].up.clicks += 1  # waves moves up to second place
    assert [r.prompt for r in c.intervals] == ["a person walks forward", "a person waves", "a person jumps"]
    assert _rows(tab)[1] == ("a person waves", 2.5)  # the widgets follow the settings
    assert tab.rows[0].up.disabled and tab.rows[2].down.disabled and not tab.rows[1].up.disabled
    tab.rows[0].down.clicks += 1
    assert [r.prompt for r in c.intervals][:2] == ["a person waves", "a person walks forward"]
    tab.rows[0].remove.clicks += 1
    assert [r.prompt for r in c.intervals] == ["a person walks forward", "a person jumps"]
    assert len(tab.rows) == 2
    # the expected length: 80 + 60 frames minus one 20-frame handshake
    assert c.expected_frames() == 120 and "120 frames (6.0 s)" in tab.length.object
    assert len(tab.transitions) == 1 and tab.transitions[0].frames.value == 20
    tab.transitions[0].frames.value = 10
    assert c.handshake_frames() == (10,) and c.expected_frames() == 130
    tab.rows[1].remove.clicks += 1
    tab.rows[0].remove.clicks += 1  # the last interval cannot go
    assert len(c.intervals) == 1 and studio.state.notices[-1] == ("error", "the timeline needs at least one interval")
    assert tab.rows[0].remove.disabled


def test_a_sentence_of_actions_in_order_becomes_the_timeline(studio):
    """What the Generate box joins clause by clause, laid out to edit: one interval per clause, as long as it is
    planned there (engine.methods.sequence), with its handshakes; anything else says why in one line."""
    from engine.methods.sequence import HANDSHAKE, plan, timeline_frames

    tab = studio.compose
    c = tab.settings
    tab.transitions[0].frames.value = 30
    sentence = "a man waves, then jogs forward, then squats"
    tab.sentence.value = sentence
    tab.fill.clicks += 1
    planned = plan(sentence)
    assert _rows(tab) == [(iv.prompt, iv.seconds) for iv in planned]
    assert [r.prompt for r in c.intervals] == ["a man waves", "a man jogs forward", "a man squats"]
    assert HANDSHAKE == 10 and c.handshake_frames() == (10, 10)  # the Generate box's, not a long motion's 20
    assert c.expected_frames() == timeline_frames(planned)
    tab.from_sentence("a person jumps twice")
    assert studio.state.notices[-1][0] == "error" and "is not actions in order" in studio.state.notices[-1][1]
    assert len(c.intervals) == 3  # the timeline is kept


def test_unknown_words_are_noted_and_only_a_refused_prompt_blocks(studio):
    s, tab = studio.state, studio.compose
    # a word the model does not know is left out with the engine's note; Generate stays enabled (issue #32 item 5)
    tab.rows[1].prompt.value_input = "a person jumps flibbers"
    assert "left out: flibbers" in tab.rows[1].flag.object and tab.rows[1].flag.visible
    assert not tab.rows[0].flag.visible and not tab.bar.run.disabled
    # a prompt the engine refuses (nothing else says a motion): its message, Generate disabled and refused
    tab.rows[1].prompt.value_input = "a person flibbers"
    assert "flibbers" in tab.rows[1].flag.object and "prompt-refused" in tab.rows[1].flag.object
    assert tab.bar.run.disabled
    assert not tab.generate()
    assert s.notices[-1][0] == "error" and "flibbers" in s.notices[-1][1] and not s.running
    tab.rows[1].prompt.value_input = "a person jumps"
    assert not tab.rows[1].flag.visible and not tab.bar.run.disabled


@pytest.mark.parametrize("rows, message", [
    ([("a person walks", 0.6), ("a person jumps", 3.0)], "needs at least"),
    ([("a person walks", 12.0)], "(0, 9.8]"),
    ([("", 3.0)], "type what the person does"),
])
def test_bad_intervals_give_clear_messages(studio, rows, message):
    s, c = studio.state, studio.compose.settings
    c.intervals = [IntervalRow(p, t) for p, t in rows]
    assert not studio.compose.generate()
    level, text = s.notices[-1]
    assert level == "error" and text.startswith("cannot compose:") and message in text, text


def test_generate_a_long_motion(studio):
    s, tab = studio.state, studio.compose
    c = tab.settings
    c.intervals = [IntervalRow("a person walks forward", 3.0), IntervalRow("a person jumps", 2.5),
                   IntervalRow("a person waves", 3.0)]
    progress = []
    s.param.watch(lambda e: progress.append(e.new), "progress")
    assert tab.generate() and s.wait(300), s.notices[-1:]
    assert not [n for n in s.notices if n[0] == "error"], s.notices
    r = c.result
    h = c.handshake_frames()
    assert h == (20, 20)
    assert r.n_frames == 60 + 50 + 60 - sum(h) == len(s.item.joints)  # sum of intervals minus the handshakes
    assert r.starts == [0, 40, 70] and r.transitions == [(40, 60), (70, 90)]
    assert s.current == r.name and s.item.info["compose"] is r
    assert np.isfinite(s.item.joints).all()
    # one progress bar over both takes (first take: 6 steps; second take: the steps below T' = 0.7)
    assert max(progress) == s.progress_total > 6 and tab.bar.progress.value == 0  # idle
    assert "composition" == s.job and r.seconds_taken > 0
    assert f"{r.n_frames} frames" in tab.result.object and "wall time" in tab.result.object
    # skeleton colours: intervals alternate, transition frames highlighted
    colors = s.frame_colors[r.name]
    assert colors.shape == (r.n_frames, 22, 3)
    np.testing.assert_array_equal(colors[10], default_joint_colors(INTERVAL_COLORS[0]))
    np.testing.assert_array_equal(colors[50], default_joint_colors(TRANSITION_COLOR))
    np.testing.assert_array_equal(colors[65], default_joint_colors(INTERVAL_COLORS[1]))
    np.testing.assert_array_equal(colors, frame_colors(r))
    spec = studio.viewer.spec()
    assert len(spec.role_colors) == 1 and spec.role_colors[0][1] is colors
    # the strip: intervals and transitions; a click moves the viewer, the playhead follows
    assert list(tab.strip_src.data["left"]) == [0, 40, 70] and list(tab.hand_src.data["left"]) == [40, 70]
    tab.strip._trigger_event(Tap(tab.strip, x=47.3, y=0.5))
    assert s.frame == 47 and tab.playhead.location == 47 and "transition 1" in tab.strip.title.text
    assert transition_at(r, 47) == 0 and transition_at(r, 65) is None
    assert len(tab.jumps.objects) == 2
    tab.jumps.objects[1].clicks += 1
    assert s.frame == 70
    # from another motion, a click brings the long motion back
    s.show_motion(s.item.joints[:10], title="other")
    tab.jump(75)
    assert s.current == r.name and s.frame == 75


def test_a_handshake_per_transition_on_the_timeline(studio):
    s, tab = studio.state, studio.compose
    c = tab.settings
    c.intervals = [IntervalRow("a person walks forward", 3.0), IntervalRow("a person jumps", 3.0),
                   IntervalRow("a person waves", 3.0)]
    # one widget per transition, between the rows it joins, with the engine's default and bounds
    assert len(tab.transitions) == 2 and c.handshakes == [20, 20]
    assert tab.rows_box.objects == [tab.rows[0].view, tab.transitions[0].view, tab.rows[1].view,
                                    tab.transitions[1].view, tab.rows[2].view]
    assert (tab.transitions[0].frames.start, tab.transitions[0].frames.end) == (0, 60)
    tab.transitions[0].frames.value = 10
    tab.transitions[1].frames.value = 30
    assert c.handshakes == [10, 30] and c.expected_frames() == 180 - 40
    assert "handshakes of 10 + 30 frames" in tab.length.object and "(1.50 s)" in tab.transitions[1].label.object
    plan = prepare(s, c)
    assert plan.config.handshakes(3) == (10, 30)
    # out of range from the widget: a one-line error, the widget put back, the settings unchanged
    tab.transitions[1].frames.value = 75
    assert s.notices[-1] == ("error", "transition 2's handshake must be between 0 and 60 frames, got 75")
    assert tab.transitions[1].frames.value == 30 and c.handshakes == [10, 30]
    with pytest.raises(ValueError, match="there is no transition 3"):
        c.set_handshake(2, 20)
    # too long for the intervals it joins: the engine's message, before any work
    tab.transitions[1].frames.value = 45
    assert not tab.generate()
    assert "with handshakes of 10 and 45 frames it needs at least" in s.notices[-1][1]
    tab.transitions[1].frames.value = 30
    # moving rows keeps the handshakes in their places; adding a row adds a default one; removing one removes its
    tab.rows[2].up.clicks += 1
    assert c.handshakes == [10, 30]
    tab.add.clicks += 1
    assert c.handshakes == [10, 30, 20] and len(tab.transitions) == 3
    tab.rows[1].remove.clicks += 1  # the second row goes with the transition before it
    assert c.handshakes == [30, 20] and len(tab.transitions) == 2
    assert [t.frames.value for t in tab.transitions] == [30, 20]
    # the composition runs them
    c.intervals = c.intervals[:2]
    assert c.handshakes == [30]
    tab.second_take.value = False
    assert tab.generate() and s.wait(300), s.notices[-1:]
    r = c.result
    assert r.handshakes == [30] and r.transitions == [(30, 60)] and r.n_frames == 90
    assert "transitions (handshake 30 frames): 30–59" in tab.result.object


def test_one_interval_and_first_take_only(studio):
    s, tab = studio.state, studio.compose
    c = tab.settings
    c.intervals = [IntervalRow("a person walks forward", 2.0)]
    tab.second_take.value = False
    assert tab.generate() and s.wait(300), s.notices[-1:]
    assert c.result.n_frames == 40 and c.result.transitions == [] and not c.result.second_take
    assert s.progress_total == 6


def test_second_take_with_text(studio):
    from app.tabs.compose.job import prepare

    s, tab = studio.state, studio.compose
    c = tab.settings
    c.intervals = [IntervalRow("a person walks forward", 2.0), IntervalRow("a person jumps", 2.0)]
    assert not tab.second_take_text.disabled and prepare(s, c).config.second_take.text is False
    tab.second_take_text.value = True
    assert c.second_take_text and prepare(s, c).config.second_take.text is True
    assert tab.generate() and s.wait(300), s.notices[-1:]
    assert c.result.second_take and c.result.second_take_text and c.result.planted_feet
    assert "second take (with text, planted feet)" in tab.result.object
    tab.second_take.value = False  # no second take: its text switch greys out, and no text is claimed
    assert tab.second_take_text.disabled and prepare(s, c).config.second_take is None
    assert tab.generate() and s.wait(300), s.notices[-1:]
    assert not c.result.second_take_text and "first take only" in tab.result.object
    tab.second_take.value = True
    assert not tab.second_take_text.disabled
    # planted feet in the second take: on by default, the box reaches the engine and the summary
    assert not tab.planted_feet.disabled and prepare(s, c).config.second_take.planted_feet is True
    tab.planted_feet.value = False
    assert prepare(s, c).config.second_take.planted_feet is False
    assert tab.generate() and s.wait(300), s.notices[-1:]
    assert not c.result.planted_feet and "planted feet" not in tab.result.object
    tab.second_take.value = False
    assert tab.planted_feet.disabled and prepare(s, c).config.second_take is None


def test_cancel(studio):
    s, tab = studio.state, studio.compose
    s.steps = 400
    assert tab.generate()
    assert tab.bar.run.disabled and not tab.bar.cancel.disabled
    tab.bar.cancel.clicks += 1
    assert s.wait(300)
    assert s.notices[-1] == ("info", "composition cancelled") and not s.running and tab.settings.result is None
