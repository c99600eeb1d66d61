"""Program transforms give the ground truth they promise."""
from __future__ import annotations

import numpy as np

from engine.synth import Program, Segment, make_sample
from engine.synth.transforms import (combine, interval_sequence, replace_action, shift, with_count, with_intensity,
                                     with_path)

FEET = [7, 10, 8, 11]


def _flights(joints):
    from engine.synth.labels import intervals

    return intervals(joints[:, FEET, 1].min(1) > 0.01)


def test_replace_action_keeps_timing():
    p = Program(segments=(Segment("walk", 60, direction="forward"), Segment("jump", 50, count=2)))
    q = replace_action(p, 1, "squat")
    a, b = make_sample(p), make_sample(q)
    assert [(s.start, s.end) for s in a.labels.segments] == [(s.start, s.end) for s in b.labels.segments]
    assert b.labels.segments[1].action == "squat" and b.labels.segments[1].count == 2
    np.testing.assert_allclose(a.joints[:55], b.joints[:55], atol=1e-6)  # untouched before the seam


def test_combine_keeps_leader_outline_and_follower_style():
    leader = Program(segments=(Segment("walk", 110, direction="left"),))
    follower = Program(segments=(Segment("walk", 80, direction="forward"),), style="zombie")
    out = combine(outline_of=leader, motifs_of=follower)
    a, c = make_sample(leader), make_sample(out)
    assert c.labels.style == "zombie" and c.labels.frames == a.labels.frames
    assert np.linalg.norm(a.labels.root_path - c.labels.root_path, axis=1).max() < 0.1
    assert a.labels.outline["step_frames"] == c.labels.outline["step_frames"]
    # the zombie's arms are forward: wrists ahead of the shoulders
    fwd = c.joints[40:, [20, 21], :] - c.joints[40:, [16, 17], :]
    heading = c.labels.heading[40:]
    ahead = fwd[..., 0] * np.sin(heading)[:, None] + fwd[..., 2] * np.cos(heading)[:, None]
    assert ahead.mean() > 0.35


def test_combine_transfers_gait_kind_with_leader_rhythm():
    leader = Program(segments=(Segment("walk", 100, direction="forward"),))
    follower = Program(segments=(Segment("run", 80, direction="forward"),))
    out = combine(outline_of=leader, motifs_of=follower)
    assert out.segments[0].action == "run"
    a, c = make_sample(leader).labels.outline, make_sample(out).labels.outline
    assert a["segments"][0]["cadence"] == c["segments"][0]["cadence"]
    for side in ("left", "right"):  # same number of steps, same rhythm (landings shift by the duty factor)
        assert len(a["step_frames"][side]) == len(c["step_frames"][side])
        assert np.abs(np.diff(a["step_frames"][side]) - np.diff(c["step_frames"][side])).max() <= 3


def test_combine_can_take_the_followers_stride():
    """stride_of="follower": a walk -> run keeps the leader's step times and path shape with the run's stride, so
    it covers more ground; a segment that keeps its gait kind is the same either way."""
    import pytest

    def speed(program):
        root = make_sample(program).joints[:, 0, [0, 2]]
        return float(np.linalg.norm(np.diff(root, axis=0), axis=1).mean() * 20)

    walk = Program(segments=(Segment("walk", 100, direction="left"),))
    run = Program(segments=(Segment("run", 80, direction="forward"),))
    same = combine(outline_of=walk, motifs_of=run)
    longer = combine(outline_of=walk, motifs_of=run, stride_of="follower")
    ratio = (2.9 / 2.8) / (1.3 / 1.85)  # GAITS: the run's step length over the walk's
    assert abs(speed(same) / speed(walk) - 1) < 0.03
    assert abs(speed(longer) / speed(walk) - ratio) < 0.08
    a, c = make_sample(same).labels.outline, make_sample(longer).labels.outline
    assert a["step_frames"] == c["step_frames"]  # same steps, same times: only the stride changed
    back = combine(outline_of=run, motifs_of=walk, stride_of="follower")
    assert abs(speed(back) / speed(run) - 1 / ratio) < 0.08
    styled = Program(segments=(Segment("walk", 80, direction="forward"),), style="zombie")
    assert combine(outline_of=walk, motifs_of=styled, stride_of="follower") == combine(outline_of=walk,
                                                                                         motifs_of=styled)
    with pytest.raises(ValueError, match="stride_of"):
        combine(outline_of=walk, motifs_of=run, stride_of="both")


def test_with_intensity_raises_jumps_monotonically():
    p = Program(segments=(Segment("jump", 45, count=1),))
    heights = []
    for value in (0.4, 0.7, 1.0, 1.3, 1.6, 2.0):
        s = make_sample(with_intensity(p, value))
        apex = s.labels.jumps[0]["apex"]
        heights.append(float(s.joints[apex, FEET, 1].min()))
    assert all(b > a + 0.02 for a, b in zip(heights, heights[1:]))


def test_with_count_changes_jumps():
    p = Program(segments=(Segment("jump", 40, count=1),))
    for n in (2, 4):
        s = make_sample(with_count(p, n))
        assert len(_flights(s.joints)) == n == len(s.labels.jumps)


def test_shift_rotates_segments_and_timing():
    p = Program(segments=(Segment("walk", 60, direction="forward"), Segment("jump", 40, count=1),
                          Segment("wave", 50, count=2, side="right")))
    q = shift(p, rotate=1)
    assert [s.action for s in q.segments] == ["jump", "wave", "walk"]
    lab = make_sample(q).labels
    assert [(s.start, s.end) for s in lab.segments] == [(0, 40), (40, 90), (90, 150)]
    r = shift(p, order=[2, 0, 1])
    assert [s.action for s in r.segments] == ["wave", "walk", "jump"]


def test_with_path_follows_waypoints():
    p = Program(segments=(Segment("walk", 140, direction="forward"),))
    path = [(0.0, 0.0), (0.0, 2.0), (1.5, 3.5)]
    s = make_sample(with_path(p, path))
    end = s.labels.root_path[-1]
    assert np.linalg.norm(end - np.array([1.5, 3.5])) < 0.15


def test_interval_sequence_transitions():
    progs = [(Program(segments=(Segment("walk", 10, direction="forward"),)), 60),
             (Program(segments=(Segment("jump", 10, count=1),)), 40),
             (Program(segments=(Segment("wave", 10, count=2, side="left"),)), 50)]
    prog, trans = interval_sequence(progs, blend=10)
    assert prog.frames == 150
    assert [t["boundary"] for t in trans] == [60, 100]
    lab = make_sample(prog).labels
    assert [(t["start"], t["end"]) for t in lab.transitions] == [(t["start"], t["end"]) for t in trans]
