"""Labels agree with the synthesised joints."""
from __future__ import annotations

import numpy as np

from engine.synth import Corpus, Program, Segment, make_sample
from engine.synth.labels import intervals

FEET = [7, 10, 8, 11]


def airborne_intervals(joints: np.ndarray, clearance: float = 0.01) -> list[list[int]]:
    low = joints[:, FEET, 1].min(1)
    return intervals(low > clearance)


def test_jump_count_and_apex_heights_match_joints():
    for count in (1, 2, 3):
        for action in ("jump", "jump_forward"):
            s = make_sample(Program(segments=(Segment(action, 25 * count + 10, count=count),)))
            flights = airborne_intervals(s.joints)
            assert len(flights) == len(s.labels.jumps) == count == s.labels.counts[action]
            for jp in s.labels.jumps:
                low = s.joints[jp["apex"], FEET, 1].min()
                assert abs(low - jp["height"]) < 0.02
                # the apex is the highest frame of its flight
                a, b = int(np.ceil(jp["takeoff"])), int(np.floor(jp["landing"]))
                heights = s.joints[a:b + 1, FEET, 1].min(1)
                assert jp["apex"] == a + int(np.argmax(heights))


def test_ballistic_flight_time_matches_height():
    s = make_sample(Program(segments=(Segment("jump", 40, count=1, intensity=1.4),)))
    jp = s.labels.jumps[0]
    flight_s = (jp["landing"] - jp["takeoff"]) / 20.0
    assert abs(flight_s - 2 * np.sqrt(2 * jp["height"] / 9.81)) < 1e-3  # labels are rounded
    # the pelvis follows a parabola with g = 9.81 in the air
    a, b = int(np.ceil(jp["takeoff"])), int(np.floor(jp["landing"]))
    y = s.joints[a:b + 1, 0, 1].astype(np.float64)
    acc = np.diff(y, 2) * 400.0
    assert np.allclose(acc, -9.81, atol=0.5)


def test_hops_and_jacks_counted_in_joints():
    s = make_sample(Program(segments=(Segment("hop", 60, count=3, side="left"),)))
    assert len(airborne_intervals(s.joints)) == 3 == s.labels.counts["hop"]
    s = make_sample(Program(segments=(Segment("jumping_jacks", 60, count=2),)))
    assert len(airborne_intervals(s.joints)) == 4  # out and in per jack
    assert s.labels.counts["jumping_jacks"] == 2


def test_contact_frames_have_near_zero_foot_speed():
    for i in range(12):
        s = Corpus("train").sample(i)
        c = s.labels.contact_frames
        both = c[1:] & c[:-1]
        step = np.linalg.norm(np.diff(s.joints[:, FEET], axis=0), axis=-1)
        if both.any():
            assert step[both].max() < 0.01  # 1 cm per frame
            assert step[both].mean() < 0.001


def test_contact_feet_touch_the_floor():
    s = make_sample(Program(segments=(Segment("walk", 100, direction="forward"),)))
    c = s.labels.contact_frames
    toe_h = s.joints[:, [10, 11], 1][c[:, [1, 3]]]
    assert np.abs(toe_h).max() < 0.01


def test_segment_boundaries_match_motion_changes():
    s = make_sample(Program(segments=(Segment("walk", 80, direction="forward"), Segment("stand", 40))))
    seg0, seg1 = s.labels.segments
    assert (seg0.start, seg0.end, seg1.start, seg1.end) == (0, 80, 80, 120)
    win = s.labels.transitions[0]
    feet_speed = np.linalg.norm(np.diff(s.joints[:, FEET], axis=0), axis=-1).max(1)
    assert feet_speed[win["end"]:].max() < 1e-6  # standing after the blend
    assert feet_speed[20:60].max() > 0.02  # stepping inside the walk
    s = make_sample(Program(segments=(Segment("stand", 40), Segment("jump", 50, count=2))))
    for start, end in airborne_intervals(s.joints):
        assert start >= 40


def test_step_events_match_landings():
    s = make_sample(Program(segments=(Segment("walk", 100, direction="forward"),)))
    c = s.labels.contact_frames
    for side, col in (("left", 0), ("right", 2)):
        landings = [a for a, b in intervals(c[:, col]) if a > 0]
        labelled = s.labels.outline["step_frames"][side]
        assert len(landings) == len(labelled)
        assert np.abs(np.array(landings) - np.array(labelled)).max() <= 1


def test_counts_of_gestures_follow_program():
    for action in ("wave", "clap", "punch", "kick", "squat", "bow"):
        s = make_sample(Program(segments=(Segment(action, 110, count=3, side="right"),)))
        assert s.labels.counts[action] == 3
        assert s.labels.segments[0].counted == 3


def test_labels_json_roundtrip_is_plain():
    import json

    s = Corpus("ood").sample(2)
    data = json.loads(json.dumps(s.labels.to_json()))
    assert data["frames"] == s.joints.shape[0]
    assert len(data["root_path"]) == s.joints.shape[0]
    assert {"outline", "motifs", "contacts", "jumps", "segments"} <= set(data)


def test_labels_are_built_on_first_use_and_match_the_canonical_frame():
    """Training reads only features and captions, so a sample's labels wait until asked for; when asked they are the
    canonical frame's: the root path starts at the origin like the canonical joints."""
    s = Corpus("train").sample(3)
    assert "labels" not in vars(s)
    labels = s.labels
    assert labels is s.labels and labels.index == 3 and labels.split == "train"
    root = np.asarray(labels.root_path)
    assert np.allclose(root, s.joints[:, 0, [0, 2]], atol=1e-4)
