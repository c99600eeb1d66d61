"""HumanML3D-layout folders: writer and reader agree, captions parse, bad input is refused."""
from __future__ import annotations

import math

import numpy as np
import pytest

from engine.io import MotionIOError
from engine.io.humanml3d import (
    Caption,
    HumanML3DFolder,
    parse_caption_line,
    write_normalizer,
    write_sample,
    write_split,
)
from engine.representation import Normalizer, joints_to_features


def test_folder_round_trip(tmp_path, real_joints):
    features = joints_to_features(real_joints)
    shorter = features[:40]
    captions = [
        Caption("a person walks forward", ("a/DET", "person/NOUN", "walk/VERB", "forward/ADV"), 0.0, 0.0),
        Caption("then turns around", (), 1.5, 3.25),
    ]
    write_sample(tmp_path, "000001", features, real_joints, captions)
    write_sample(tmp_path, "M000002", shorter, None, ["someone strolls ahead"])
    write_split(tmp_path, "train", ["000001", "M000002"])
    write_split(tmp_path, "test", ["M000002"])
    write_normalizer(tmp_path, Normalizer.fit(features))

    folder = HumanML3DFolder(tmp_path)
    assert folder.names() == ["000001", "M000002"]
    assert folder.split_names("test") == ["M000002"]
    samples = list(folder.iter_samples("train"))
    name, feats, caps = samples[0]
    assert name == "000001" and np.array_equal(feats, features)
    assert caps[0] == captions[0]
    assert caps[1].text == "then turns around" and caps[1].start == 1.5 and caps[1].end == 3.25
    assert caps[1].tokens == ("then/OTHER", "turns/OTHER", "around/OTHER")
    assert caps[1].frames(fps=20) == (30, 65) and caps[0].frames() is None
    assert samples[1].captions == (Caption("someone strolls ahead", ("someone/OTHER", "strolls/OTHER", "ahead/OTHER")),)
    assert np.array_equal(folder.read_joints("000001"), real_joints)
    assert folder.read_joints("M000002") is None
    assert np.allclose(folder.normalizer().mean, features.mean(0), atol=1e-5)
    text = (tmp_path / "texts" / "000001.txt").read_text().splitlines()
    assert text[0] == "a person walks forward#a/DET person/NOUN walk/VERB forward/ADV#0.0#0.0"


def test_reads_the_real_humanml3d_files(tmp_path, real_vecs):
    from tests.conftest import real_file

    (tmp_path / "new_joint_vecs").mkdir()
    np.save(tmp_path / "new_joint_vecs" / "012314.npy", real_vecs)
    (tmp_path / "texts").mkdir()
    (tmp_path / "texts" / "012314.txt").write_text(
        "a man walks in a circle#a/DET man/NOUN walk/VERB in/ADP a/DET circle/NOUN#0.0#0.0\n"
        "he waves#he/PRON wave/VERB#nan#nan\n"
    )
    for name in ("Mean.npy", "Std.npy"):
        (tmp_path / name).write_bytes(real_file(f"humanml3d_{name}").read_bytes())
    write_split(tmp_path, "val", ["012314"])
    folder = HumanML3DFolder(tmp_path)
    sample = folder.read_sample("012314")
    assert sample.features.shape == (170, 263)
    assert [c.whole_clip for c in sample.captions] == [True, True]
    assert folder.normalizer().std.shape == (263,)
    assert [s.name for s in folder.iter_samples("val")] == ["012314"]


@pytest.mark.parametrize(
    "line,message",
    [
        ("a man walks#a/DET#0.0", "4 fields"),
        ("#a/DET#0#0", "empty caption"),
        ("walks#walk/VERB#soon#1", "start time 'soon' is not a number"),
        ("walks#walk/VERB#-1#2", "non-negative"),
        ("walks#walk/VERB#2#1", "end time 1.0 is not after start time 2.0"),
    ],
)
def test_bad_caption_lines(line, message):
    with pytest.raises(MotionIOError, match=message):
        parse_caption_line(line, source="x.txt", line_no=3)


def test_nan_times_mean_whole_clip():
    caption = parse_caption_line("he waves#he/PRON wave/VERB#nan#nan")
    assert caption.whole_clip and not math.isnan(caption.start)


def test_writer_refuses_bad_input(tmp_path, real_joints):
    features = joints_to_features(real_joints)
    with pytest.raises(MotionIOError, match="invalid sample name"):
        write_sample(tmp_path, "../escape", features, None, ["x"])
    with pytest.raises(MotionIOError, match="must not contain '#'"):
        write_sample(tmp_path, "a", features, None, ["walks # fast"])
    with pytest.raises(MotionIOError, match="T poses and T-1 feature frames"):
        write_sample(tmp_path, "a", features, real_joints[:-1], ["x"])
    with pytest.raises(MotionIOError, match=r"must have shape \(T, 263\)"):
        write_sample(tmp_path, "a", real_joints, None, ["x"])
    with pytest.raises(MotionIOError, match="invalid sample name"):
        write_split(tmp_path, "train", ["ok", "not ok"])
    with pytest.raises(MotionIOError, match="not a HumanML3D folder"):
        HumanML3DFolder(tmp_path / "nothing")


def test_missing_listed_sample(tmp_path, real_joints):
    write_sample(tmp_path, "a", joints_to_features(real_joints[:10]), None, ["x"])
    write_split(tmp_path, "train", ["a", "b"])
    folder = HumanML3DFolder(tmp_path)
    assert [s.name for s in folder.iter_samples("train", skip_missing=True)] == ["a"]
    with pytest.raises(MotionIOError, match="not found"):
        list(folder.iter_samples("train"))
