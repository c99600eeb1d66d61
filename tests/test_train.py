"""Training on tiny models: loss goes down, checkpoints resume, a HumanML3D folder trains, DDP with 2 processes."""
from __future__ import annotations

import json
import os
import subprocess
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from engine.checkpoint import load_model
from engine.data import MotionText
from engine.io.humanml3d import write_normalizer, write_sample, write_split
from engine.model.denoiser import ModelConfig
from engine.representation import Normalizer
from engine.train import TrainConfig, train

TINY = ModelConfig(width=32, layers=2, heads=2, text_layers=1, dropout=0.0)


class ToySource:
    """Two kinds of motion: features ramp up for 'rise', down for 'fall' (deterministic by index)."""

    def get(self, index: int) -> MotionText:
        rng = np.random.default_rng(index)
        frames = int(rng.integers(20, 40))
        up = index % 2 == 0
        ramp = np.linspace(0, 1, frames)[:, None] * (1 if up else -1)
        features = (ramp + 0.05 * rng.normal(size=(frames, 263))).astype(np.float32)
        return MotionText(features=features, captions=("a person rises",) if up else ("a person falls",))

    def words(self):
        return ["a", "person", "rises", "falls"]


def config(tmp_path: Path, **kw) -> TrainConfig:
    base = dict(out=str(tmp_path / "run"), steps=60, batch_size=8, max_frames=40, lr=2e-3, warmup=5, log_every=10,
                ckpt_every=30, snapshot_every=0, stats_samples=20, threads=1, precision="fp32", model=TINY)
    base.update(kw)
    return TrainConfig(**base)


def test_training_reduces_loss_and_writes_a_loadable_model(tmp_path):
    result = train(config(tmp_path), source=ToySource(), progress=False)
    assert result["step"] == 60
    log = [json.loads(line) for line in (tmp_path / "run" / "log.jsonl").read_text().splitlines()]
    assert log[-1]["mse"] < 0.7 * log[0]["mse"]
    loaded = load_model(tmp_path / "run")
    assert loaded.tokenizer.encode("a person rises").words == ("a", "person", "rises")
    weights = torch.load(tmp_path / "run" / "weights.pt", weights_only=True)
    assert all(v.dtype == torch.float16 for v in weights.values() if v.is_floating_point())


def test_resume_continues_from_the_checkpoint(tmp_path):
    train(config(tmp_path, steps=30), source=ToySource(), progress=False)
    state = torch.load(tmp_path / "run" / "train_state.pt", weights_only=True)
    assert state["step"] == 30
    result = train(config(tmp_path, steps=50), source=ToySource(), progress=False, resume=True)
    assert result["step"] == 50
    steps = [json.loads(line)["step"] for line in (tmp_path / "run" / "log.jsonl").read_text().splitlines()]
    assert steps == [10, 20, 30, 40, 50]


def test_resume_with_a_grown_vocabulary_keeps_word_ids(tmp_path):
    train(config(tmp_path, steps=10), source=ToySource(), progress=False)
    before = load_model(tmp_path / "run").tokenizer

    class Grown(ToySource):
        def words(self):
            return [*super().words(), "jumps"]

    train(config(tmp_path, steps=20), source=Grown(), progress=False, resume=True)
    after = load_model(tmp_path / "run").tokenizer
    assert after.words[: len(before)] == before.words and "jumps" in after


def test_new_words_start_as_the_word_the_old_vocabulary_read_them_as():
    from engine.model.denoiser import Denoiser
    from engine.text import Tokenizer
    from engine.train import seed_new_words

    old = Tokenizer(["a", "person", "jumps", "runs"])
    grown = old.extended(["bounces", "sprints", "zzqx"])  # by meaning, by meaning, nothing
    model = Denoiser(ModelConfig.from_json({**TINY.to_json(), "vocab_size": len(old)}))
    model.text_encoder.resize_vocabulary(len(grown))
    table = model.text_encoder.embed.weight
    before = table.detach().clone()
    assert seed_new_words(model, old=old, grown=grown) == 2
    ids = {w: i for i, w in enumerate(grown.words)}
    assert old.reading("bounces")[0] == "jumps" and old.reading("sprints")[0] == "runs"
    assert torch.equal(table[ids["bounces"]], table[ids["jumps"]])
    assert torch.equal(table[ids["sprints"]], table[ids["runs"]])
    assert torch.equal(table[ids["zzqx"]], before[ids["zzqx"]])  # left out by the old vocabulary: untouched
    assert torch.equal(table[: len(old)], before[: len(old)])


def _write_folder(root: Path) -> None:
    source = ToySource()
    names = []
    for i in range(12):
        item = source.get(i)
        write_sample(root, f"m{i:03d}", item.features, None, list(item.captions))
        names.append(f"m{i:03d}")
    write_split(root, "train", names)
    write_normalizer(root, Normalizer.fit(np.concatenate([source.get(i).features for i in range(12)])))


def test_trains_on_a_humanml3d_folder(tmp_path):
    folder = tmp_path / "hml"
    _write_folder(folder)
    result = train(config(tmp_path, data=str(folder), steps=20), progress=False)
    assert result["step"] == 20 and (tmp_path / "run" / "weights.pt").exists()


def _moattn_train(folder: Path, out: Path, steps: int, *, processes: int, resume: bool = False):
    """`moattn train` on a tiny model, under torchrun (gloo on the CPU) when ``processes`` > 1."""
    launcher = (["-m", "torch.distributed.run", "--standalone", f"--nproc_per_node={processes}"] if processes > 1
                else [])
    cmd = [sys.executable, *launcher, "-m", "engine.cli",
           "train", "--data", str(folder), "--out", str(out), "--steps", str(steps), "--batch-size", "4",
           "--max-frames", "40", "--width", "32", "--layers", "2", "--heads", "2", "--text-layers", "1",
           "--log-every", "4", "--ckpt-every", "6", "--snapshot-every", "0", "--stats-samples", "8", "--threads", "1",
           "--precision", "fp32", "--device", "cpu", "--no-progress", *(["--resume"] if resume else [])]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env,
                          cwd=Path(__file__).resolve().parents[1])
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc, torch.load(out / "train_state.pt", weights_only=True)


def test_torchrun_two_processes_and_resume_under_another_world_size(tmp_path):
    folder = tmp_path / "hml"
    _write_folder(folder)
    out = tmp_path / "ddp"
    proc, state = _moattn_train(folder, out, 12, processes=2)
    assert "training on cpu, fp32, 2 processes" in proc.stdout
    assert "batches of 4, of similar length (groups of 8), each item in 2 batches, built in-process" in proc.stdout
    assert state["step"] == 12
    # each step read half a batch of new items on each of the 2 ranks (--reuse 2, the default: every item goes into
    # two batches); rank 0 alone logged
    assert state["next_index"] == 12 * 4 * 2 // 2
    log = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert [r["step"] for r in log] == [4, 8, 12]
    # the item counter is global: one process continues where two stopped, and two continue after one
    _, state = _moattn_train(folder, out, 16, processes=1, resume=True)
    assert (state["step"], state["next_index"]) == (16, (12 * 4 * 2 + 4 * 4) // 2)
    _, state = _moattn_train(folder, out, 20, processes=2, resume=True)
    assert (state["step"], state["next_index"]) == (20, (12 * 4 * 2 + 4 * 4 + 4 * 4 * 2) // 2)
    log = [json.loads(line) for line in (out / "log.jsonl").read_text().splitlines()]
    assert [r["step"] for r in log] == [4, 8, 12, 16, 20]
    assert all(np.isfinite(r["mse"]) for r in log)
    # weights stay device-free and load for inference
    assert load_model(out).model.device == torch.device("cpu")


def test_continue_from_a_shipped_model_folder(tmp_path):
    from engine.cli.export import export_model

    train(config(tmp_path, steps=20), source=ToySource(), progress=False)
    shipped = export_model(tmp_path / "run", tmp_path / "shipped", command="test", reports=[])
    assert (shipped / "TRAINING.md").read_text().count("test") >= 1
    # shipped files carry no absolute path of this machine
    assert str(tmp_path) not in (shipped / "TRAINING.md").read_text() + (shipped / "config.json").read_text()
    assert json.loads((shipped / "config.json").read_text())["train"]["out"] == "run"
    result = train(config(tmp_path, out=str(tmp_path / "next"), steps=30), source=ToySource(), progress=False,
                   init_from=shipped)
    assert result["step"] == 30
    steps = [json.loads(line)["step"] for line in (tmp_path / "next" / "log.jsonl").read_text().splitlines()]
    assert steps == [30]  # it started at the shipped model's step 20


def test_a_continued_run_says_which_flags_it_does_not_apply(tmp_path, capsys):
    from engine.cli.export import export_model
    from engine.train import kept_from_checkpoint

    assert kept_from_checkpoint({"lr": 1e-4, "steps": 30, "seed": 0}, {"lr": 2e-4, "steps": 20, "seed": 0}) == {
        "lr": (1e-4, 2e-4)}  # steps is the call's to set; an equal value is no news
    train(config(tmp_path, steps=4), source=ToySource(), progress=False)
    shipped = export_model(tmp_path / "run", tmp_path / "shipped", command="test", reports=[])
    saved_lr = config(tmp_path).lr
    capsys.readouterr()
    result = train(config(tmp_path, out=str(tmp_path / "next"), steps=6, lr=saved_lr / 2), source=ToySource(),
                   progress=False, init_from=shipped, given=("lr", "steps", "out"))
    err = capsys.readouterr().err
    assert f"--lr {saved_lr / 2} is not applied" in err and f"({saved_lr})" in err and "--steps" not in err
    assert json.loads((tmp_path / "next" / "config.json").read_text())["train"]["lr"] == saved_lr
    assert result["step"] == 6
    # a control fine-tune applies the call's hyper-parameters: nothing to say
    train(config(tmp_path, out=str(tmp_path / "ctl"), steps=2, lr=saved_lr / 2, control="root"), source=ToySource(),
          progress=False, init_from=shipped, given=("lr",))
    assert "is not applied" not in capsys.readouterr().err


def test_shipped_files_carry_no_absolute_paths():
    from engine.paths import ASSETS

    bad = []
    for path in ASSETS.rglob("*"):
        if path.suffix in (".json", ".md", ".txt"):
            text = path.read_text(encoding="utf-8")
            bad += [f"{path.relative_to(ASSETS)}: {line.strip()}" for line in text.splitlines()
                    if re.search(r'["`\\s](/(work|root|home|tmp|Users)/)', line)]
    assert not bad, bad[:5]


def test_min_snr_weights_follow_the_clamped_snr():
    from engine.diffusion.schedule import CosineSchedule
    from engine.train import min_snr_weights

    schedule = CosineSchedule()
    w = min_snr_weights(schedule, 5.0)
    assert w.shape == (schedule.steps,) and abs(float(w.mean()) - 1.0) < 1e-4
    assert bool((w[1:] <= w[:-1] + 1e-6).all())  # less weight as the noise grows (SNR falls)
    assert float(w[0]) == float(w[:10].max()) and float(w[-1]) < 0.01 * float(w[0])  # clamped at gamma near t=0


def test_min_snr_training_runs_and_is_recorded(tmp_path):
    result = train(config(tmp_path, steps=20, loss_weighting="min_snr", snr_gamma=5.0), source=ToySource(),
                   progress=False)
    assert result["step"] == 20
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["train"]["loss_weighting"] == "min_snr"
    import pytest

    with pytest.raises(ValueError, match="loss-weighting"):
        train(config(tmp_path, loss_weighting="snr"), source=ToySource(), progress=False)


def test_high_noise_weights_favour_the_noisiest_timesteps():
    from engine.diffusion.schedule import CosineSchedule
    from engine.train import HIGH_NOISE_FROM, high_noise_weights

    schedule = CosineSchedule()
    w = high_noise_weights(schedule, 3.0)
    assert w.shape == (schedule.steps,) and abs(float(w.mean()) - 1.0) < 1e-4
    assert abs(float(w[HIGH_NOISE_FROM]) / float(w[HIGH_NOISE_FROM - 1]) - 3.0) < 1e-4
    assert float(w[:HIGH_NOISE_FROM].std()) == 0.0 and float(w[HIGH_NOISE_FROM:].std()) == 0.0
    import pytest

    with pytest.raises(ValueError, match="high-noise-weight"):
        high_noise_weights(schedule, 0.0)


def test_high_noise_training_runs_and_is_recorded(tmp_path):
    result = train(config(tmp_path, steps=12, loss_weighting="high_noise", high_noise_weight=2.0),
                   source=ToySource(), progress=False)
    assert result["step"] == 12
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["train"]["loss_weighting"] == "high_noise" and saved["train"]["high_noise_weight"] == 2.0


def test_a_sample_weight_counts_once_in_the_velocity_term():
    import torch

    from engine.diffusion.losses import masked_losses

    gen = torch.Generator().manual_seed(0)
    x0 = torch.randn(2, 6, 3, generator=gen)
    x0_hat = torch.randn(2, 6, 3, generator=gen)
    mask = torch.ones(2, 6, dtype=torch.bool)
    _, vel_a = masked_losses(x0_hat[:1], x0[:1], mask[:1])
    _, vel_b = masked_losses(x0_hat[1:], x0[1:], mask[1:])
    _, vel = masked_losses(x0_hat, x0, mask, torch.tensor([3.0, 1.0]))
    assert abs(float(vel) - float((3 * vel_a + vel_b) / 4)) < 1e-6  # weight 3, not 9


def test_fresh_schedule_fine_tune_takes_the_calls_hyper_parameters(tmp_path):
    base = tmp_path / "base"
    train(config(tmp_path, out=str(base), steps=20, lr=2e-3), source=ToySource(), progress=False)
    out = tmp_path / "tuned"
    result = train(config(tmp_path, out=str(out), steps=10, lr=5e-4, warmup=2), source=ToySource(), progress=False,
                   init_from=base, fresh_schedule=True)
    assert result["step"] == 10  # counted from 0, not from the base's 20
    saved = json.loads((out / "config.json").read_text())
    assert saved["train"]["lr"] == 5e-4 and saved["step"] == 10
    assert saved["model"]["width"] == TINY.width


def test_max_minutes_stops_with_a_checkpoint(tmp_path):
    result = train(config(tmp_path, steps=100000, max_minutes=1e-4), source=ToySource(), progress=False)
    assert result["step"] < 100000
    state = torch.load(tmp_path / "run" / "train_state.pt", weights_only=True)
    assert state["step"] == result["step"]


def test_a_resume_keeps_its_schedule_length_unless_steps_is_named(tmp_path):
    """A resumed run called without --steps (given=() as the CLI passes it) keeps its own cosine: it once took the
    default 20000 steps and left the learning rate high (session 24)."""
    from engine.train import lr_at

    train(config(tmp_path, steps=30), source=ToySource(), progress=False)
    defaults = config(tmp_path, steps=TrainConfig().steps)  # what the CLI builds when --steps is not given
    assert train(defaults, source=ToySource(), progress=False, resume=True, given=("threads",))["step"] == 30
    saved = json.loads((tmp_path / "run" / "config.json").read_text())["train"]
    assert saved["steps"] == 30 and lr_at(29, TrainConfig(**{**saved, "model": TINY})) < 0.2 * saved["lr"]
    # naming --steps lengthens it
    assert train(config(tmp_path, steps=40), source=ToySource(), progress=False, resume=True,
                 given=("steps",))["step"] == 40


def test_the_foot_contact_term_counts_only_planted_feet_that_slide():
    from engine.diffusion.losses import foot_contact_loss
    from engine.skeleton import FOOT_JOINTS

    frames = 10
    target = torch.zeros(1, frames, 22, 3)
    target[..., 1] = 1.0  # every joint high ...
    left_ankle, right_ankle = FOOT_JOINTS["left"][0], FOOT_JOINTS["right"][0]
    target[:, :, left_ankle, 1] = 0.0  # ... but the left ankle, planted on the floor the whole time
    target[:, :, right_ankle, 1] = 0.0
    target[:, :, right_ankle, 0] = torch.arange(frames) * 0.1  # the right ankle low but swinging fast: not planted
    mask = torch.ones(1, frames, dtype=torch.bool)
    assert float(foot_contact_loss(target, target, mask)) == 0.0
    pred = target.clone()
    pred[:, :, left_ankle, 0] = torch.arange(frames) * 0.01  # the planted ankle slides 1 cm per frame: 0.2 m/s
    pred[:, :, right_ankle, 0] = 0.0  # the swinging one stands still: not penalised
    assert abs(float(foot_contact_loss(pred, target, mask)) - 0.2**2) < 1e-6
    assert float(foot_contact_loss(pred, target, mask, samples=torch.tensor([False]))) == 0.0  # a sample left out
    mask[:, 5:] = False  # padding frames count for nothing
    pred[:, 5:, left_ankle, 0] = 5.0
    assert abs(float(foot_contact_loss(pred, target, mask)) - 0.2**2) < 1e-6


def test_foot_contact_training_runs_and_is_logged(tmp_path):
    result = train(config(tmp_path, steps=12, foot_weight=1.0, foot_below=400), source=ToySource(), progress=False)
    assert result["step"] == 12
    log = [json.loads(line) for line in (tmp_path / "run" / "log.jsonl").read_text().splitlines()]
    assert all("foot" in e and np.isfinite(e["foot"]) for e in log)
    saved = json.loads((tmp_path / "run" / "config.json").read_text())
    assert saved["train"]["foot_weight"] == 1.0 and saved["train"]["foot_below"] == 400


def test_the_foot_term_moves_the_legs_not_the_root():
    """Where a planted foot slides, the term's gradient reaches the legs' features, never the root's motion (with it, a
    model learnt to walk in place)."""
    from engine.diffusion.losses import ROOT_DIMS, foot_term
    from engine.evaluation.adherence import ground_truth_motion
    from engine.intent import parse_intent
    from engine.representation import joints_to_features

    walk = ground_truth_motion(parse_intent("a person walks forward"), 3)
    target = torch.as_tensor(joints_to_features(walk), dtype=torch.float32)[None]
    pred = target.clone()
    pred[..., 1:3] *= 1.5  # the root runs ahead of the legs: planted feet slide
    pred.requires_grad_(True)
    mask = torch.ones(pred.shape[:2], dtype=torch.bool)
    loss = foot_term(pred, target, mask)
    assert float(loss.detach()) > 0.01
    loss.backward()
    assert float(pred.grad[..., :ROOT_DIMS].abs().max()) == 0.0
    assert float(pred.grad[..., ROOT_DIMS:].abs().max()) > 0.0


def test_a_fine_tune_may_switch_the_prediction_skip_on(tmp_path):
    """``--skip-sigma`` has no weights: a fresh-schedule fine-tune of a model without it switches it on (the model
    folder's architecture otherwise), and a later fine-tune that does not name it keeps it."""
    base = tmp_path / "base"
    train(config(tmp_path, out=str(base), steps=6), source=ToySource(), progress=False)
    skip = ModelConfig(**{**TINY.to_json(), "skip_sigma": 0.1})
    out = tmp_path / "tuned"
    train(config(tmp_path, out=str(out), steps=4, model=skip), source=ToySource(), progress=False,
          init_from=base, fresh_schedule=True)
    assert json.loads((out / "config.json").read_text())["model"]["skip_sigma"] == 0.1
    assert load_model(out).model.config.skip_sigma == 0.1
    assert load_model(base).model.config.skip_sigma == 0.0
    plain = tmp_path / "plain"  # a fine-tune that does not name it keeps the base's
    train(config(tmp_path, out=str(plain), steps=4), source=ToySource(), progress=False, init_from=out,
          fresh_schedule=True)
    assert json.loads((plain / "config.json").read_text())["model"]["skip_sigma"] == 0.1


def _skip_path_fine_tune(tmp_path: Path) -> tuple[Path, Path]:
    """(a base trained a few steps, its fine-tune with a 16-channel skip path trained alone)."""
    base = tmp_path / "base"
    train(config(tmp_path, out=str(base), steps=6), source=ToySource(), progress=False)
    path = ModelConfig(**{**TINY.to_json(), "skip_sigma": 0.1, "skip_path": 16})
    out = tmp_path / "path"
    train(config(tmp_path, out=str(out), steps=5, model=path, skip_path_only=True, lr=1e-3, warmup=1),
          source=ToySource(), progress=False, init_from=base, fresh_schedule=True)
    return base, out


def test_a_skip_path_fine_tune_may_train_the_path_alone(tmp_path):
    """``--skip-path N --skip-path-only``: a fresh-schedule fine-tune adds the skip's own path and trains only it; every
    other weight stays the base's, bit for bit, and the path's output is no longer zero."""
    base, out = _skip_path_fine_tune(tmp_path)
    before, after = load_model(base).model.state_dict(), load_model(out).model.state_dict()
    assert json.loads((out / "config.json").read_text())["model"]["skip_path"] == 16
    assert set(after) - set(before) == {k for k in after if k.startswith("skip_path.")}
    assert all(torch.equal(before[k], after[k]) for k in before)
    assert float(after["skip_path.conv_out.weight"].abs().max()) > 0


def test_training_the_skip_path_alone_needs_one(tmp_path):
    base = tmp_path / "base"
    train(config(tmp_path, out=str(base), steps=3), source=ToySource(), progress=False)
    try:
        train(config(tmp_path, out=str(tmp_path / "x"), steps=2, skip_path_only=True), source=ToySource(),
              progress=False, init_from=base, fresh_schedule=True)
    except ValueError as exc:
        assert "--skip-path" in str(exc)
    else:
        raise AssertionError("--skip-path-only without a skip path was accepted")


def test_a_network_fine_tune_of_a_model_with_a_skip_path_leaves_the_path_alone(tmp_path):
    """Without ``--skip-path-only`` the network trains as the plain x0 prediction that generation uses: the skip never
    acts in its loss, so the skip path gets no gradient and keeps its weights, while the network's move."""
    _, tuned = _skip_path_fine_tune(tmp_path)
    again = tmp_path / "again"
    train(config(tmp_path, out=str(again), steps=4, lr=1e-3, warmup=1), source=ToySource(), progress=False,
          init_from=tuned, fresh_schedule=True)
    before, after = load_model(tuned).model.state_dict(), load_model(again).model.state_dict()
    assert all(torch.equal(before[k], after[k]) for k in before if k.startswith("skip_path."))
    assert not torch.equal(before["out_proj.weight"], after["out_proj.weight"])


def test_the_foot_term_rebuilds_only_the_feet_and_gives_the_whole_skeletons_value():
    """features_to_joints(only=...) is the full rebuild's columns; the foot term on them equals the term on all 22."""
    from engine.diffusion.losses import FEET, ROOT_DIMS, foot_contact_loss, foot_term
    from engine.evaluation.adherence import ground_truth_motion
    from engine.intent import parse_intent
    from engine.representation import features_to_joints, joints_to_features

    walk = ground_truth_motion(parse_intent("a person walks forward"), 3)
    target = torch.as_tensor(joints_to_features(walk), dtype=torch.float32)[None]
    full = features_to_joints(target)
    assert torch.equal(features_to_joints(target, only=FEET), full[..., list(FEET), :])
    with pytest.raises(ValueError, match="root"):
        features_to_joints(target, only=(0, 7))
    pred = target.clone()
    pred[..., 1:3] *= 1.5
    mask = torch.ones(pred.shape[:2], dtype=torch.bool)
    legs = torch.cat([pred[..., :ROOT_DIMS], pred[..., ROOT_DIMS:]], -1)
    whole = foot_contact_loss(features_to_joints(legs), full, mask)
    assert float(whole) > 0.01
    assert torch.allclose(foot_term(pred, target, mask), whole, rtol=1e-6)


def test_the_training_step_counts_the_foot_term_on_its_noise_levels_only():
    """TrainStep rebuilds the feet of the samples below foot_below alone: the same value as the term over the whole
    batch with the others masked out."""
    import copy

    from engine.data import collate
    from engine.diffusion.losses import foot_term
    from engine.evaluation.adherence import ground_truth_motion
    from engine.intent import parse_intent
    from engine.model.denoiser import Denoiser
    from engine.representation import joints_to_features
    from engine.runtime import CPU
    from engine.text import Tokenizer
    from engine.train import TrainStep, adamw

    torch.manual_seed(0)
    model = Denoiser(TINY).train()
    walks = [MotionText(features=joints_to_features(ground_truth_motion(parse_intent("a person walks forward"), seed)),
                        captions=("a person walks",)) for seed in range(6)]
    batch = collate(walks, tokenizer=Tokenizer(["a", "person", "walks"]), normalize=lambda f: f,
                    rng=np.random.default_rng(0), max_frames=40)
    stats = (torch.zeros(263), torch.ones(263))  # the features are the walks' own: x0 in metres
    step = TrainStep(model=model, net=model, ema=copy.deepcopy(model),
                     optimizer=adamw(model.parameters(), lr=1e-3, weight_decay=0.0), runtime=CPU,
                     generator=torch.Generator().manual_seed(3), foot_weight=1.0, foot_below=500, stats=stats)
    _, _, foot = step.losses(batch)
    # the same draws again, by hand: t and noise come first from the step's generator
    gen = torch.Generator().manual_seed(3)
    t = torch.randint(0, step.schedule.steps, (batch.x0.shape[0],), generator=gen)
    noise = torch.randn(batch.x0.shape, generator=gen)
    assert 0 < int((t < 500).sum()) < len(t)  # some samples counted, some not
    with torch.no_grad():
        x0_hat = model(step.schedule.q_sample(batch.x0, t, noise), t, batch.cond)
    expected = foot_term(x0_hat, batch.x0, batch.cond.frame_mask, samples=t < 500)
    assert float(expected) > 0.0
    assert torch.allclose(foot.detach(), expected, rtol=1e-5, atol=1e-7)


def test_reuse_counts_only_the_new_items_a_run_read(tmp_path):
    """--reuse 2: each step reads half a batch of new items, so the item counter a resumed run starts from advances by
    half as much; a batch size the reuse does not divide is refused at once."""
    train(config(tmp_path, steps=6, reuse=2), source=ToySource(), progress=False)
    state = torch.load(tmp_path / "run" / "train_state.pt", weights_only=True)
    assert (state["step"], state["next_index"]) == (6, 6 * 8 // 2)
    assert json.loads((tmp_path / "run" / "config.json").read_text())["train"]["reuse"] == 2
    train(config(tmp_path, steps=8, reuse=2), source=ToySource(), progress=False, resume=True, given=("steps",))
    state = torch.load(tmp_path / "run" / "train_state.pt", weights_only=True)
    assert (state["step"], state["next_index"]) == (8, 8 * 8 // 2)
    with pytest.raises(ValueError, match="--reuse"):
        train(config(tmp_path, out=str(tmp_path / "other"), reuse=3), source=ToySource(), progress=False)
