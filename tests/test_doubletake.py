"""DoubleTake (PriorMDM) as the paper has it, on a tiny seeded model: the second take's transition sandwich (the
neighbouring intervals around each handshake, soft masks over them, unfolded back without a seam), a handshake
length per transition (engine, `moattn compose --handshake`, the studio's settings), and the options declared once
with their bounds (clear one-line errors)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from engine.checkpoint import LoadedModel
from engine.cli import build_parser, main
from engine.diffusion import StepState
from engine.generate import SampleConfig
from engine.methods import doubletake as dt
from engine.methods.doubletake import (
    DoubleTakeConfig, Handshake, Interval, Sandwich, SecondTake, allowance, check_intervals, compose, offsets,
    sandwiches, second_take_timesteps, unfold, unfold_sandwiches, unfold_weights,
)
from engine.methods.doubletake_config import option_info, options, parse_handshakes
from tests.conftest import random_corpus_model


@pytest.fixture(scope="module")
def loaded() -> LoadedModel:
    return random_corpus_model(layers=2)


def _state(x):
    return StepState(step=0, num_steps=1, t=10, t_next=5, x_t=x, x0_hat=x, x_prev=x)


# ----------------------------------------------------------------------------- options, declared once
def test_options_are_declared_once_with_bounds_and_the_cli_reads_them():
    assert option_info(DoubleTakeConfig, "handshake").default == DoubleTakeConfig().handshake == 20
    take = SecondTake()
    for info in options(SecondTake):
        assert getattr(take, info.name) == info.default and info.help
    names = [info.name for info in options(SecondTake)]
    assert {"renoise", "hard", "soft", "ramp", "steps", "context"} <= set(names)
    compose_parser = build_parser()._subparsers._group_actions[0].choices["compose"]
    flags = {a.dest: a for a in compose_parser._actions}
    for info in options(SecondTake):  # every option has its flag, whose help states the declared bounds and default
        lo, hi = info.bounds
        action = flags[info.flag.replace("-", "_")]
        assert action.option_strings == [f"--{info.flag}"]
        assert f"{lo:g} to {hi:g}" in action.help and f"(default {info.default_text()})" in action.help, action.help
    assert flags["steps"].option_strings == ["--steps"] and flags["steps"].default == 50  # the sampling steps
    assert flags["second_take_steps"].option_strings == ["--second-take-steps"]  # the second take's own
    assert flags["renoise"].option_strings == ["--renoise"] and "(default 1)" in flags["renoise"].help
    assert "20,30,15" in flags["handshake"].help and "0 to 60 frames" in flags["handshake"].help


@pytest.mark.parametrize("kwargs, message", [
    (dict(renoise=1.5), "renoise must be between 0.01 and 1, got 1.5"),
    (dict(hard=-0.1), "hard must be between 0 and 1"),
    (dict(soft=0.9, hard=0.5), "soft (0.9) must not exceed hard (0.5)"),
    (dict(ramp=61), "ramp must be between 0 and 60 frames"),
    (dict(steps=0), "steps must be between 1 and 1000"),
    (dict(context=2.5), "context is a whole number"),
])
def test_second_take_options_are_checked_against_their_bounds(kwargs, message):
    with pytest.raises(ValueError) as err:
        SecondTake(**kwargs)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_handshakes_one_for_all_or_one_per_transition():
    assert DoubleTakeConfig().handshakes(4) == (20, 20, 20)
    assert DoubleTakeConfig(handshake=(10,)).handshakes(3) == (10, 10)
    assert DoubleTakeConfig(handshake=(10, 30, 0)).handshakes(4) == (10, 30, 0)
    assert DoubleTakeConfig().handshakes(1) == ()
    with pytest.raises(ValueError, match=r"2 handshake lengths for 4 intervals: give one for all transitions or one "
                                         r"per transition \(3\)"):
        DoubleTakeConfig(handshake=(10, 20)).handshakes(4)
    with pytest.raises(ValueError, match="handshake 2 must be between 0 and 60 frames, got 61"):
        DoubleTakeConfig(handshake=(10, 61))
    with pytest.raises(ValueError, match="whole number of frames"):
        DoubleTakeConfig(handshake=(10, 2.5))


def test_parse_handshakes():
    assert parse_handshakes("20") == (20,)
    assert parse_handshakes("20,30,15") == (20, 30, 15)
    assert parse_handshakes(" 1s, 0.5s ,0") == (20, 10, 0)
    for text, message in [("abc", "'abc' is not a number of frames"), ("20,,30", "expected frames like 20"),
                          ("1.5", "1.5 is not a whole number of frames (for seconds add an s: 1.5s)"),
                          ("100", "100 (100 frames) is out of range: a handshake lasts 0 to 60 frames (0 to 3 s)"),
                          ("-5", "out of range"), ("4s", "4s (80 frames) is out of range"), ("nan", "not a number")]:
        with pytest.raises(ValueError) as err:
            parse_handshakes(text)
        assert message in str(err.value) and str(err.value).startswith("--handshake:"), str(err.value)


# ----------------------------------------------------------------------------- first take, per transition
def test_handshake_hook_blends_each_transition_over_its_own_length():
    x = torch.zeros(3, 12, 1)
    x[0], x[1], x[2] = 1.0, 0.0, -1.0
    lengths = [12, 10, 9]
    out = Handshake(lengths=lengths, h=[4, 2])(_state(x)).x_prev
    torch.testing.assert_close(out[0, 8:12, 0], torch.tensor([1.0, 0.75, 0.5, 0.25]))  # 4 frames, 1 -> 0
    torch.testing.assert_close(out[1, :4, 0], out[0, 8:12, 0])
    torch.testing.assert_close(out[1, 8:10, 0], torch.tensor([0.0, -0.5]))  # 2 frames, 0 -> -1
    torch.testing.assert_close(out[2, :2, 0], out[1, 8:10, 0])
    assert (out[1, 4:8] == 0).all() and (out[2, 2:] == -1).all()
    cut = Handshake(lengths=lengths, h=[0, 2])(_state(x)).x_prev  # a 0-frame handshake is a plain cut
    assert (cut[0] == 1).all() and (cut[1, :8] == 0).all()


def test_offsets_unfold_and_checks_per_transition():
    x = torch.arange(3 * 12, dtype=torch.float32).view(3, 12, 1)
    lengths, hs = [12, 10, 9], [4, 2]
    assert offsets(lengths, hs) == [0, 8, 16]
    u = unfold(x, lengths, hs)
    assert u.shape[0] == sum(lengths) - 6 and u[8, 0] == x[0, 8, 0] and u[12, 0] == x[1, 4, 0]
    assert u[16, 0] == x[1, 8, 0] and u[18, 0] == x[2, 2, 0]
    # interval 2 sits between a 30- and a 20-frame handshake: it needs 30 + 20 + 10 own frames = 3 s
    ivs = [Interval("a", 3.0), Interval("b", 2.9), Interval("c", 3.0)]
    with pytest.raises(ValueError, match=r"interval 2 \('b'\) lasts 58 frames: with handshakes of 30 and 20 frames it "
                                         r"needs at least 3.0 s"):
        check_intervals(ivs, (30, 20))
    assert check_intervals(ivs, (20, 20)) == [60, 58, 60]
    assert check_intervals(ivs, [20]) == [60, 58, 60]  # a list of one: one for all
    assert check_intervals(ivs[:1], ()) == check_intervals(ivs[:1], 20) == [60]  # one interval: no transition
    with pytest.raises(ValueError, match="3 handshake lengths for 3 intervals"):
        check_intervals(ivs, [20, 20, 20])


# ----------------------------------------------------------------------------- the sandwich
def test_sandwich_is_the_neighbouring_intervals_around_the_handshake():
    take = SecondTake()
    # three intervals, handshakes at [40, 60) and [90, 110) on a 150-frame timeline
    s = sandwiches([(40, 60), (90, 110)], 150, take, limit=196)
    # (S_1, τ_1, S_2): from the start to the next handshake; (S_2, τ_2, S_3): from the previous handshake to the end
    assert s == [Sandwich(lo=0, hi=90, a=40, b=60), Sandwich(lo=60, hi=150, a=90, b=110)]
    assert s[0].handshake == slice(40, 60) and s[1].handshake == slice(30, 50)
    # a fixed context caps each side; the old +-30 frames are still available as an option
    assert sandwiches([(40, 60), (90, 110)], 150, SecondTake(context=30), limit=196) == [
        Sandwich(10, 90, 40, 60), Sandwich(60, 140, 90, 110)]
    # too long for the model: cropped around the handshake, as evenly as the sides allow
    long = sandwiches([(170, 190), (340, 360)], 530, take, limit=196)
    assert long == [Sandwich(82, 278, 170, 190), Sandwich(252, 448, 340, 360)]
    assert all(w.frames == 196 for w in long)
    lop = sandwiches([(20, 40)], 400, take, limit=100)  # only 20 frames before: the rest goes after
    assert lop == [Sandwich(0, 100, 20, 40)]
    # a 0-frame handshake (a cut) has no sandwich; its neighbour's sandwich runs up to the cut
    assert sandwiches([(50, 50), (90, 110)], 150, take, limit=196) == [Sandwich(50, 150, 90, 110)]


def test_soft_mask_over_the_sandwich():
    take = SecondTake(hard=0.85, soft=0.1, ramp=10)
    m = allowance(90, slice(40, 60), take)
    assert torch.allclose(m[40:60], torch.tensor(0.85))
    assert torch.allclose(m[:29], torch.tensor(0.1)) and torch.allclose(m[71:], torch.tensor(0.1))  # the intervals
    assert (torch.diff(m[29:41]) > 0).all() and (torch.diff(m[59:71]) < 0).all()  # b = 10 frames of ramp each side


def test_unfolding_has_no_seam_and_takes_the_refined_handshakes_whole():
    windows = [Sandwich(0, 90, 40, 60), Sandwich(60, 150, 90, 110)]
    w = unfold_weights(windows, ramp=10, total=150)
    assert (w[0, 30:70] == 1).all() and (w[1, 80:120] == 1).all()  # 1 on each τ and its ramps, for that take alone
    assert (w[1, :70] == 0).all() and (w[0, 80:] == 0).all()
    assert 0 < w[0, 0] < 0.05 and 0 < w[1, -1] < 0.05  # to ~0 at the ends no other sandwich covers
    torch.testing.assert_close(w[:, 70:80].sum(0), torch.ones(10))  # the shared interval: a cross-fade summing to 1
    assert (torch.diff(w[0, 69:81]) < 0).all()
    first = torch.zeros(150, 2)
    same = torch.zeros(2, 90, 2)
    assert torch.equal(unfold_sandwiches(first, windows, same, ramp=10), first)  # nothing refined, nothing changes
    refined = torch.ones(2, 90, 2)  # every sandwich frame refined by +1
    out = unfold_sandwiches(first, windows, refined, ramp=10)[:, 0]
    assert (out[30:120] == 1).all()  # the handshakes, their ramps and the interval between: refined takes whole
    assert (out <= 1 + 1e-6).all()  # where two sandwiches share an interval they cross-fade, never add up
    assert torch.diff(out).abs().max() < 0.06  # no frame jumps from refined to first take (old: a step of 1)
    # a shared interval cross-fades from one sandwich's take to the other's
    two = torch.stack([torch.full((90, 2), 1.0), torch.full((90, 2), 3.0)])
    mixed = unfold_sandwiches(first, windows, two, ramp=10)[:, 0]
    assert (mixed[30:70] == 1).all() and (mixed[80:120] == 3).all() and 1 < mixed[75] < 3
    assert torch.diff(mixed[60:90]).min() >= 0 and torch.diff(mixed).abs().max() < 0.2
    # handshakes close together (their ramps overlap): the cross-fade runs over the overlap, still without a jump
    close = [Sandwich(0, 70, 20, 40), Sandwich(40, 120, 55, 75)]
    wc = unfold_weights(close, ramp=10, total=120)
    assert (wc[0, 10:45] == 1).all() and (wc[1, 50:85] == 1).all() and (wc.sum(0)[10:85] > 1 - 1e-6).all()
    assert torch.diff(wc, dim=1).abs().max() < 0.2


def test_second_take_timesteps():
    assert second_take_timesteps(SecondTake(renoise=0.7), 20) == [699, 649, 599, 549, 499, 449, 399, 349, 299, 249,
                                                                 199, 149, 99, 49]
    assert len(second_take_timesteps(SecondTake(renoise=0.7, steps=50), 20)) == 35
    assert second_take_timesteps(SecondTake(renoise=1.0), 20)[0] == 999


# ----------------------------------------------------------------------------- end to end on the tiny model
def _spy_soft_inpaint(monkeypatch):
    seen = []
    real = dt.SoftInpaint

    def spy(denoiser, known, keep):
        seen.append((known.clone(), keep.clone()))
        return real(denoiser, known=known, keep=keep)

    monkeypatch.setattr(dt, "SoftInpaint", spy)
    return seen


def test_the_second_take_renoises_the_neighbouring_intervals_with_soft_masks(loaded, monkeypatch):
    seen = _spy_soft_inpaint(monkeypatch)
    ivs = [Interval("a person walks forward", 3.0), Interval("a person jumps", 6.0), Interval("a person runs", 3.0)]
    take = SecondTake()
    r = compose(loaded, ivs, DoubleTakeConfig(second_take=take), sample=SampleConfig(steps=4, guidance=2.0))
    assert r.transitions == [(40, 60), (140, 160)] and len(r.features) == 200
    ((known, keep),) = seen
    first = torch.as_tensor(loaded.normalizer.normalize(r.first_take), dtype=known.dtype)
    # one sandwich per transition, each interval whole up to the other handshake: [0, 140) and [60, 200)
    assert known.shape[:2] == (2, 140)
    torch.testing.assert_close(known[0], first[:140], atol=1e-4, rtol=1e-4)
    torch.testing.assert_close(known[1], first[60:200], atol=1e-4, rtol=1e-4)
    # soft masks: the handshake keeps 1 - M_hard of the first take, the intervals 1 - M_soft, a b-frame ramp between
    b = take.ramp
    hard, soft = torch.tensor(1 - take.hard), torch.tensor(1 - take.soft)
    assert torch.allclose(keep[0, 40:60], hard) and torch.allclose(keep[1, 80:100], hard)
    assert torch.allclose(keep[0, : 40 - b - 1], soft) and torch.allclose(keep[0, 60 + b + 1 :], soft)
    assert torch.allclose(keep[1, : 80 - b - 1], soft) and torch.allclose(keep[1, 100 + b + 1 :], soft)
    assert (torch.diff(keep[0, 40 - b - 1 : 41]) < 0).all()
    changed = np.abs(r.features - r.first_take).max(axis=1) > 1e-5
    assert changed[40:60].all() and changed[140:160].all()
    assert changed[90:110].all()  # the middle interval's own frames, far from either handshake, are refined too


def test_a_sandwich_longer_than_the_model_is_cropped_and_the_rest_stays(loaded, monkeypatch):
    seen = _spy_soft_inpaint(monkeypatch)
    ivs = [Interval("a person walks forward", 9.5), Interval("a person jumps", 9.5), Interval("a person runs", 9.5)]
    r = compose(loaded, ivs, DoubleTakeConfig(), sample=SampleConfig(steps=3, guidance=2.0))
    assert r.transitions == [(170, 190), (340, 360)] and len(r.features) == 530
    ((known, keep),) = seen
    assert known.shape[:2] == (2, loaded.model.config.max_frames)
    same = np.abs(r.features - r.first_take).max(axis=1) < 1e-5
    assert same[:82].all() and same[448:].all() and not same[82:448].any()


def test_per_transition_handshakes_end_to_end(loaded):
    ivs = [Interval("a person walks forward", 3.0), Interval("a person jumps", 3.0), Interval("a person runs", 3.0)]
    sample = SampleConfig(steps=3, guidance=2.0)
    r = compose(loaded, ivs, DoubleTakeConfig(handshake=(10, 30)), sample=sample)
    assert r.starts == [0, 50, 80] and r.transitions == [(50, 60), (80, 110)] and len(r.features) == 180 - 40
    assert np.isfinite(r.joints).all()
    cut = compose(loaded, ivs, DoubleTakeConfig(handshake=(0, 20)), sample=sample)  # a cut, then a handshake
    assert cut.transitions == [(60, 60), (100, 120)] and len(cut.features) == 160
    same = np.abs(cut.features - cut.first_take).max(axis=1) < 1e-5
    assert same[:60].all() and not same[100:120].any()  # no sandwich over the cut: the first interval stays
    with pytest.raises(ValueError, match="3 handshake lengths for 3 intervals"):
        compose(loaded, ivs, DoubleTakeConfig(handshake=(10, 20, 30)), sample=sample)


# ----------------------------------------------------------------------------- the command line
def test_cli_handshake_per_transition(tiny_model_dir, tmp_path, capsys):
    out = tmp_path / "long.npy"
    base = ["compose", "a person walks forward:3", "a person jumps:3", "a person runs:3", "--steps", "3",
            "--model", str(tiny_model_dir), "--out", str(out)]
    assert main([*base, "--handshake", "10,30"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["handshakes"] == [10, 30] and report["transitions"] == [[50, 60], [80, 110]]
    assert np.load(out).shape[0] == report["frames"] == 140
    assert main([*base, "--handshake", "0.5s"]) == 0  # seconds, one for all
    assert json.loads(capsys.readouterr().out)["handshakes"] == [10, 10]
    for flags, message in [(["--handshake", "10,20,30"], "--handshake: 3 handshake lengths for 3 intervals: give one "
                                                         "for all transitions or one per transition (2)"),
                           (["--handshake", "90"], "--handshake: 90 (90 frames) is out of range"),
                           (["--handshake", "1.5"], "not a whole number of frames"),
                           (["--renoise", "2"], "--renoise must be between 0.01 and 1, got 2"),
                           (["--ramp", "-1"], "--ramp must be between 0 and 60 frames, got -1"),
                           (["--second-take-steps", "0"], "--second-take-steps must be between 1 and 1000, got 0"),
                           (["--soft", "0.9"], "second take: soft (0.9) must not exceed hard (0.85)"),
                           (["--first-take-only", "--renoise", "0.5"], "--renoise set the second take"),
                           (["--handshake", "40"], "interval 2 ('a person jumps') lasts 60 frames: with handshakes "
                                                   "of 40 and 40 frames it needs at least 4.5 s")]:
        assert main([*base, *flags]) == 2, flags
        err = capsys.readouterr().err.strip()
        assert err.startswith("moattn compose: error:") and message in err and "\n" not in err, (flags, err)
    assert not out.with_name("x.npy").exists()
