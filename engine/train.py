"""`moattn train`: train the denoiser on the corpus (on the fly) or a HumanML3D folder.

Single process by default; under ``torchrun`` (WORLD_SIZE set) it runs torch DDP: NCCL when the
run is on CUDA (rank r on cuda:LOCAL_RANK), gloo on the CPU. Each rank draws its own interleaved
share of the corpus (or folder) indices; rank 0 writes checkpoints, logs and progress. The item
counter in a checkpoint is global, so ``--resume`` works under another world size.
"""
from __future__ import annotations

import contextlib
import copy
import json
import math
import os
import signal
import sys
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch
import torch.distributed as dist
from tqdm import tqdm

from engine.checkpoint import export_weights, load_train_state, read_config, save_train_state, write_config
from engine.data import ActionFocus, Batch, CorpusSource, FolderSource, MotionSource, batch_loader
from engine.diffusion.losses import foot_term, masked_losses
from engine.diffusion.schedule import CosineSchedule
from engine.model.denoiser import Denoiser, ModelConfig
from engine.representation import Normalizer
from engine.runtime import Runtime
from engine.text import Tokenizer


# --loss-weighting high_noise: the noisiest 30 % of the timesteps (also where the default guidance acts)
HIGH_NOISE_FROM = 700


@dataclass
class TrainConfig:
    out: str = "runs/base"
    data: str = "corpus"  # "corpus" or a HumanML3D-layout folder
    steps: int = 20000
    batch_size: int = 32
    max_frames: int = 196
    lr: float = 2e-4
    weight_decay: float = 1e-2
    warmup: int = 500
    ema_decay: float = 0.999
    text_dropout: float = 0.1
    velocity_weight: float = 0.5
    # per-timestep loss weights: "uniform" (every timestep's x0 error alike) or "min_snr" (Hang et al. 2023,
    # min-SNR-gamma: x0 error weighted by min(SNR_t, snr_gamma), normalised to mean 1 over the timesteps). Beware:
    # with this x0-predicting model and the cosine schedule, min_snr leaves timesteps t >= 500 under 7 % of the
    # weight; a 5.5-minute screen row looked fine, but a long run lost the actions those high-noise steps decide
    # (assets/model/TRAINING.md, issue #32)
    # "high_noise": timesteps t >= HIGH_NOISE_FROM (where a sample's action, count and phase are chosen) weigh
    # --high-noise-weight times the rest, normalised to mean 1 over the timesteps
    loss_weighting: str = "uniform"
    snr_gamma: float = 5.0
    high_noise_weight: float = field(default=3.0, metadata={"help": "--loss-weighting high_noise: weight of the "
                                                                     f"timesteps t >= {HIGH_NOISE_FROM} against the "
                                                                     "rest"})
    # corpus only: extra captions per motion that leave side, count, speed and style out, as people type them
    # ("a person waves"); with the corpus's 4 full captions, 2 make a third of the captions trained on short
    underspecified: int = 0
    plain_verbs: float = field(default=0.0, metadata={"help": "chance that an --underspecified caption says the "
                                                             "action's plain verb (walks, punches), not a synonym"})
    styled_captions: float = field(default=0.0, metadata={"help": "chance that an --underspecified caption of a "
                                                                  "styled motion keeps its style (a person walks like "
                                                                  "a robot; a zombie walks)"})
    keep_intensity: bool = field(default=False, metadata={"help": "an --underspecified caption that is not bare keeps "
                                                                "its intensity word (waves energetically, jumps "
                                                                "high)"})
    # corpus only: oversample these actions (comma-separated corpus action names, e.g. "punch,hop,wave,clap"):
    # a share of the batch items is redrawn until its program has one of them (as a segment or an overlay)
    focus_actions: str = field(default="", metadata={"help": "corpus actions to oversample, comma-separated "
                                                            "(e.g. punch,hop,wave,clap)"})
    focus_share: float = field(default=0.0, metadata={"help": "share of training items redrawn to hold a "
                                                             "--focus-actions action"})
    focus_counted: bool = field(default=False, metadata={"help": "with --focus-actions: the redrawn items hold a "
                                                                "focus action repeated a number of times (claps "
                                                                "three times), not just the action"})
    focus_intense: bool = field(default=False, metadata={"help": "with --focus-actions: the redrawn items hold a "
                                                                "focus action said with an intensity word (jumps "
                                                                "high, waves gently), not a normal one"})
    # MDM's foot contact term (engine.diffusion.losses.foot_contact_loss): predicted feet kept still where the target's
    # are planted, in (m/s)^2 of foot speed, this weight against the x0 error
    foot_weight: float = field(default=0.0, metadata={"help": "weight of MDM's foot contact loss: the predicted feet's "
                                                             "speed where the target's are planted, (m/s)^2 (0: off)"})
    # with the root's motion in the term and at every timestep, it taught the model to slow its root (walks at 0.36
    # m/s instead of 0.94); below t = 400 still 0.63. The root now enters detached (losses.foot_term), and the term can
    # be kept to low noise, where the gait is already chosen
    foot_below: int = field(default=1000, metadata={"help": "the foot contact loss acts on timesteps t below this "
                                                           "(1000: all)"})
    skip_path_only: bool = field(default=False, metadata={"help": "train only the skip path (--skip-path), the rest "
                                                                  "of the model frozen, on the timesteps where the "
                                                                  "skip weighs at least 1 %%"})
    grad_clip: float = 1.0
    seed: int = 0
    log_every: int = 20
    ckpt_every: int = 250
    snapshot_every: int = 2000
    stats_samples: int = 2000
    threads: int = 0  # torch threads per process; 0 = torch's default
    workers: int = 0  # DataLoader worker processes building batches (0 = in the training process)
    # batches of similar length: the items of this many batches are sorted by length and cut into batches
    # (engine.data.batch_loader); 1 = random batches padded to their longest item
    length_groups: int = 8
    # session 40: at equal steps 2 trains the same model as 1 (dev adherence, held-out loss) at 1.1x the steps/s
    reuse: int = field(default=2, metadata={"help": "each corpus item goes into this many batches (groups), each time "
                                                   "with its own crop, caption and noise: building the batch, a fifth "
                                                   "of a step, shrinks to 1/N (1: every item once)"})
    max_minutes: float = 0.0  # stop (and checkpoint) after this many minutes of training; 0 = no limit
    device: str = "auto"  # auto | cpu | cuda | cuda:N (under torchrun on CUDA: cuda:LOCAL_RANK)
    precision: str = "auto"  # auto | fp32 | bf16 | fp16 (engine.runtime: bf16 on CPUs only where native)
    # "" = the base model; a control name ("root", "left_wrist", "right_wrist") fine-tunes a control
    # model by PriorMDM's Algorithm 1: those features reach the model noise-free (only scaled by sqrt(alpha_bar))
    control: str = ""
    model: ModelConfig = field(default_factory=ModelConfig)

    def to_json(self) -> dict:
        data = asdict(self)
        data["model"] = self.model.to_json()
        return data

    @classmethod
    def from_json(cls, data: dict) -> "TrainConfig":
        data = dict(data)
        model = ModelConfig.from_json(data.pop("model"))
        names = {f.name for f in fields(cls)}
        return cls(model=model, **{k: v for k, v in data.items() if k in names})


# fields a resumed run takes from the new call rather than from its checkpoint
_RUNTIME_FIELDS = ("steps", "log_every", "ckpt_every", "snapshot_every", "threads", "workers", "device", "precision",
                   "length_groups", "reuse", "max_minutes")


def kept_from_checkpoint(given: dict, saved: dict) -> dict[str, tuple]:
    """Hyper-parameters a continued base run (``--resume``, or ``--init-from`` without ``--control``) keeps from
    its saved config although the call gave another value: name -> (given, kept)."""
    return {k: (v, saved[k]) for k, v in given.items()
            if k not in (*_RUNTIME_FIELDS, "out", "model") and k in saved and saved[k] != v}


def make_source(config: TrainConfig, *, split: str = "train") -> MotionSource:
    if config.data == "corpus":
        train = split == "train"
        return CorpusSource(split=split, seed=config.seed, underspecified=config.underspecified if train else 0,
                            plain_verbs=config.plain_verbs, styled=config.styled_captions,
                            keep_intensity=config.keep_intensity,
                            focus=focus_from(config) if train else None)
    return FolderSource(config.data, split=split)


def focus_from(config: TrainConfig) -> "ActionFocus | None":
    """The --focus-actions/--focus-share lever of a config, or None when it is off."""
    names = tuple(a.strip() for a in config.focus_actions.split(",") if a.strip())
    if not names or config.focus_share <= 0:
        return None
    return ActionFocus(actions=names, share=config.focus_share, counted=config.focus_counted,
                       intense=config.focus_intense)


def lr_at(step: int, config, *, floor: float = 0.1) -> float:
    """Linear warm-up over ``config.warmup`` steps, then cosine from ``config.lr`` down to ``floor`` × lr."""
    if step < config.warmup:
        return config.lr * (step + 1) / config.warmup
    progress = min(1.0, (step - config.warmup) / max(1, config.steps - config.warmup))
    return config.lr * (floor + (1 - floor) * 0.5 * (1 + math.cos(math.pi * progress)))


class _Stop:
    """Set by SIGINT/SIGTERM so the loop checkpoints and exits cleanly."""

    def __init__(self):
        self.requested = False

    def __call__(self, signum, frame):
        self.requested = True


@contextlib.contextmanager
def stop_on_signals() -> Iterator[_Stop]:
    """SIGINT/SIGTERM set the yielded flag's ``requested`` instead of killing the process (a training loop then
    checkpoints and exits); the previous handlers come back on exit."""
    stop = _Stop()
    previous = {s: signal.signal(s, stop) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _state_from_model_folder(folder: Path, batch_size: int) -> tuple[dict, dict]:
    """(saved config, a train state) from a shipped model folder: its weights start both the model
    and the EMA; the optimizer starts fresh. Lets a later session continue from assets/model."""
    import torch as _torch

    saved = read_config(folder)
    weights = _torch.load(folder / "weights.pt", map_location="cpu", weights_only=True)
    weights = {k: (v.float() if v.is_floating_point() else v) for k, v in weights.items()}
    step = int(saved.get("step", 0))
    return saved, {"model": weights, "ema": weights, "optimizer": None, "step": step,
                   "next_index": step * batch_size}


def train(config: TrainConfig, *, resume: bool = False, progress: bool = True, source: MotionSource | None = None,
          init_from: str | Path | None = None, given: tuple[str, ...] | None = None,
          fresh_schedule: bool = False) -> dict:
    """Run one training job to ``config.steps`` (or until SIGTERM / ``max_minutes``), see :class:`TrainingRun`.

    ``given``: the config fields the caller set explicitly (the CLI's flags; None: a library call, which means every
    field of ``config``); a continued base run says which of them it does not apply, and keeps its own schedule
    length unless ``steps`` is among them. ``fresh_schedule`` (with ``init_from``): a fine-tune of the base model with this call's
    hyper-parameters (learning rate, warm-up, levers), steps counted from 0; the architecture is the base's."""
    run = TrainingRun(config, progress=progress, source=source)
    try:
        run.start(resume=resume, init_from=init_from, given=given, fresh_schedule=fresh_schedule)
        run.build()
        return run.loop()
    finally:
        run.close()


class _StartPoint(NamedTuple):
    """Where a run starts: the (possibly continued) config, the saved weights/optimizer (None: from scratch), the
    tokenizer the weights were trained with, and the feature statistics."""

    config: TrainConfig
    state: dict | None
    tokenizer: Tokenizer
    normalizer: Normalizer


class TrainingRun:
    """One training job as named steps: :meth:`start` (resume, continue or fine-tune a model folder, or scratch),
    :meth:`build` (model, EMA, optimizer, batch stream), :meth:`loop` (steps, with :meth:`log`, :meth:`checkpoint`
    and :meth:`snapshot` on their schedules), :meth:`close` (process group)."""

    def __init__(self, config: TrainConfig, *, progress: bool = True, source: MotionSource | None = None):
        if config.loss_weighting not in LOSS_WEIGHTINGS:
            raise ValueError(f"--loss-weighting {config.loss_weighting!r}: expected one of {', '.join(LOSS_WEIGHTINGS)}")
        if config.length_groups < 1 or config.max_minutes < 0:
            raise ValueError("--length-groups must be at least 1 and --max-minutes 0 or more")
        if config.reuse < 1 or config.batch_size % config.reuse:
            raise ValueError(f"--reuse must be at least 1 and divide --batch-size ({config.batch_size}), "
                             f"got {config.reuse}")
        self.config = config
        self.progress = progress
        self.distributed = int(os.environ.get("WORLD_SIZE", "1")) > 1
        self.runtime = _runtime(config, distributed=self.distributed)
        if self.distributed:
            dist.init_process_group("nccl" if self.runtime.device.type == "cuda" else "gloo")
        self.rank = dist.get_rank() if self.distributed else 0
        self.world = dist.get_world_size() if self.distributed else 1
        self.main = self.rank == 0
        if self.main:
            print(f"training on {self.runtime.describe()}" + (f", {self.world} processes" if self.distributed else ""),
                  flush=True)
        if config.threads:
            torch.set_num_threads(config.threads)
        self.out = Path(config.out).resolve()
        if self.main:
            self.out.mkdir(parents=True, exist_ok=True)
        self._barrier()
        self.source = source or make_source(config)
        self.step = self.index = 0

    def _barrier(self) -> None:
        if self.distributed:
            dist.barrier()

    # -- start: where the weights, hyper-parameters and vocabulary come from ---------------------------------------
    def start(self, *, resume: bool, init_from: str | Path | None, given: tuple[str, ...] | None,
              fresh_schedule: bool) -> None:
        config, out = self.config, self.out
        words = tuple(self.source.words())
        resumable = resume and (out / "train_state.pt").exists()
        if resumable or init_from is not None:
            point = self._continued(resumable=resumable, init_from=init_from, given=given,
                                    fresh_schedule=fresh_schedule)
        else:
            if resume and self.main:
                print(f"no checkpoint in {out}; starting from scratch")
            point = self._scratch(words)
        config = point.config
        self.grown = point.tokenizer.extended(words)
        if len(self.grown) > config.model.vocab_size:
            config.model = ModelConfig.from_json({**config.model.to_json(), "vocab_size": len(self.grown) + 64})
        self.config, self.point = config, point

    def _continued(self, *, resumable: bool, init_from, given, fresh_schedule: bool) -> _StartPoint:
        config, out = self.config, self.out
        if resumable:
            saved, state = read_config(out), load_train_state(out)
            stats_folder = out
        else:
            saved, state = _state_from_model_folder(Path(init_from), config.batch_size)
            stats_folder = Path(init_from)
            if self.main:
                print(f"starting from the model in {init_from} (step {state['step']}); optimizer state is new")
        if not resumable and (config.control or fresh_schedule):
            # a control fine-tune (PriorMDM Algorithm 1) or a fresh-schedule fine-tune: the base's architecture,
            # this call's hyper-parameters, steps counted from 0
            if config.control and saved["train"].get("control"):
                raise ValueError(f"{init_from} is already a control model ({saved['train']['control']}): "
                                 "fine-tune from the base model")
            model = dict(saved["train"]["model"])
            if config.model.skip_sigma > 0:  # the prediction's skip has no weights: a fine-tune may switch it on
                model["skip_sigma"] = config.model.skip_sigma
            if config.model.skip_path > 0:  # ... and add the skip's own path (new weights, its output starting at 0)
                model["skip_path"] = config.model.skip_path
            config = TrainConfig.from_json({**config.to_json(), "model": model, "out": str(out)})
            state.update(step=0, next_index=0)
        else:
            # the run's hyper-parameters come from the checkpoint; how to run it now comes from the call
            kept = kept_from_checkpoint({k: getattr(config, k) for k in given or ()}, saved["train"])
            for name, (want, value) in kept.items() if self.main else ():
                print(f"--{name.replace('_', '-')} {want} is not applied: a continued run keeps its saved {name} "
                      f"({value})", file=sys.stderr)
            # ... except the schedule's length, which a call changes only by naming --steps (a resume without it once
            # jumped a run's cosine from 11000 to the default 20000 steps and left its lr high)
            how = {k: getattr(config, k) for k in _RUNTIME_FIELDS if k != "steps" or given is None or "steps" in given}
            # fields the checkpoint predates (new levers) take the call's value
            config = TrainConfig.from_json({**config.to_json(), **saved["train"], **how, "out": str(out)})
        normalizer = Normalizer.load(stats_folder)
        if self.main and stats_folder != out:
            normalizer.save(out)
        return _StartPoint(config, state, Tokenizer(saved["vocabulary"]), normalizer)

    def _scratch(self, words: tuple[str, ...]) -> _StartPoint:
        normalizer = _fit_stats(self.source, self.config) if self.main else None
        if self.main:
            normalizer.save(self.out)
        if self.distributed:
            dist.barrier()
            normalizer = Normalizer.load(self.out)
        return _StartPoint(self.config, None, Tokenizer(sorted(words)), normalizer)

    # -- build: model, EMA, optimizer, batches ---------------------------------------------------------------------
    def build(self) -> None:
        config, state, runtime = self.config, self.point.state, self.runtime
        model_config = config.model
        torch.manual_seed(config.seed)
        opt_state = None
        if state is not None:
            params = state["model"]
            vocab_rows = params["text_encoder.embed.weight"].shape[0]
            # build at the saved size, load, then grow the word table if the vocabulary grew
            model = Denoiser(ModelConfig.from_json({**model_config.to_json(), "vocab_size": vocab_rows}))
            _load_allowing_new_skip_path(model, params)
            if vocab_rows < model_config.vocab_size:
                model.text_encoder.resize_vocabulary(model_config.vocab_size)
                seeded = seed_new_words(model, old=self.point.tokenizer, grown=self.grown)
                print(f"vocabulary grew to {len(self.grown)} words: embeddings extended ({seeded} new words start as "
                      f"the word the old vocabulary read them as), optimizer state reset")
            else:
                opt_state = state["optimizer"]
            self.step, self.index = int(state["step"]), int(state["next_index"])
        else:
            model = Denoiser(model_config)
        self.tokenizer, self.normalizer = self.grown, self.point.normalizer
        ema = copy.deepcopy(model).eval()
        if state is not None and state["ema"]["text_encoder.embed.weight"].shape == ema.text_encoder.embed.weight.shape:
            ema_state = {k: (v.float() if v.is_floating_point() else v) for k, v in state["ema"].items()}
            _load_allowing_new_skip_path(ema, ema_state)
        for p in ema.parameters():
            p.requires_grad_(False)
        model.to(runtime.device)
        ema.to(runtime.device)
        model.autocast_dtype = runtime.dtype
        if self.distributed:
            ids = [runtime.device.index] if runtime.device.type == "cuda" else None
            net = torch.nn.parallel.DistributedDataParallel(model, device_ids=ids)
        else:
            net = model
        timesteps_below = None
        if config.skip_path_only:
            if model.skip_path is None:
                raise ValueError("--skip-path-only needs a skip path (--skip-path N with --skip-sigma S)")
            for name, p in model.named_parameters():
                p.requires_grad_(name.startswith("skip_path."))
            timesteps_below = skip_timesteps(model)
        trained = [p for p in model.parameters() if p.requires_grad]
        optimizer = adamw(trained, lr=config.lr, weight_decay=config.weight_decay)
        if opt_state is not None:
            optimizer.load_state_dict(opt_state)
        self.model, self.ema, self.optimizer = model, ema, optimizer
        self.point = self.point._replace(state=None)  # the saved tensors are loaded: let them go
        self.stream = batch_loader(
            self.source, tokenizer=self.tokenizer, normalize=self.normalizer.normalize,
            batch_size=config.batch_size, seed=config.seed * 1000 + self.rank + self.step,
            start_index=self.index + self.rank, stride=self.world, workers=config.workers,
            pin_memory=runtime.device.type == "cuda", max_frames=config.max_frames, text_dropout=config.text_dropout,
            length_groups=config.length_groups, reuse=config.reuse,
        )
        if self.main:
            print(f"batches of {config.batch_size}"
                  + (f", of similar length (groups of {config.length_groups})" if config.length_groups > 1 else "")
                  + (f", each item in {config.reuse} batches" if config.reuse > 1 else "")
                  + (f", built by {config.workers} worker processes" if config.workers else ", built in-process"),
                  flush=True)
        gen = torch.Generator().manual_seed(config.seed * 7919 + self.rank * 104729 + self.step)
        control_dims = None
        if config.control:
            from engine.methods.control import control_dims as _dims

            control_dims = torch.as_tensor(_dims(config.control))
        self.train_step = TrainStep(model=model, net=net, ema=ema, optimizer=optimizer, runtime=runtime,
                                    generator=gen, velocity_weight=config.velocity_weight,
                                    grad_clip=config.grad_clip, ema_decay=config.ema_decay,
                                    control_dims=control_dims,
                                    timestep_weights=timestep_weights(config), foot_weight=config.foot_weight,
                                    foot_below=config.foot_below, timesteps_below=timesteps_below,
                                    keep_input=config.skip_path_only,
                                    stats=(torch.as_tensor(self.normalizer.mean), torch.as_tensor(self.normalizer.std)))

    # -- what the loop writes ----------------------------------------------------------------------------------------
    def checkpoint(self) -> None:
        """train_state.pt (weights, EMA, optimizer, step, item counter), config.json and the EMA's weights.pt."""
        if not self.main:
            return
        if not all(torch.isfinite(p).all() for p in self.model.parameters()):
            print(f"step {self.step}: weights are not finite; checkpoint NOT written", flush=True)
            return
        write_config(self.out, model_config=self.config.model, vocabulary=self.tokenizer.words[1:],
                     extra={"train": self.config.to_json(), "step": self.step})
        save_train_state(self.out, {"model": on_cpu(self.model.state_dict()), "ema": on_cpu(self.ema.state_dict()),
                                    "optimizer": on_cpu(self.optimizer.state_dict()), "step": self.step,
                                    "next_index": self.index})
        export_weights(self.out, on_cpu(self.ema.state_dict()))

    def snapshot(self) -> None:
        """A loadable model folder of the EMA at this step: snapshots/step_NNNNNNN."""
        snap = self.out / "snapshots" / f"step_{self.step:07d}"
        snap.mkdir(parents=True, exist_ok=True)
        write_config(snap, model_config=self.config.model, vocabulary=self.tokenizer.words[1:],
                     extra={"train": self.config.to_json(), "step": self.step})
        self.normalizer.save(snap)
        export_weights(snap, on_cpu(self.ema.state_dict()))

    def log(self, losses: list[tuple[float, float, float]], seconds: float) -> dict:
        """One log.jsonl line for the steps since the last one (``foot`` only where that term is on)."""
        entry = {"step": self.step, "mse": float(np.mean([l[0] for l in losses])),
                 "vel": float(np.mean([l[1] for l in losses])), "lr": lr_at(self.step, self.config),
                 "s_per_step": seconds / len(losses), "time": time.time()}
        if self.config.foot_weight:
            entry["foot"] = float(np.mean([l[2] for l in losses]))
        if self.main:
            with (self.out / "log.jsonl").open("a") as fh:
                fh.write(json.dumps(entry) + "\n")
        return entry

    # -- the loop ------------------------------------------------------------------------------------------------------
    def loop(self) -> dict:
        config = self.config
        deadline = time.monotonic() + 60 * config.max_minutes if config.max_minutes else None
        bar = tqdm(total=config.steps, initial=self.step, disable=not self.progress or not self.main, desc="train",
                   unit="step")
        skipped = 0
        window, window_t0, last = [], time.perf_counter(), {}
        with stop_on_signals() as stop:
            try:
                self.model.train()
                while self.step < config.steps and not stop.requested:
                    if deadline is not None and time.monotonic() > deadline:
                        if self.main:
                            print(f"--max-minutes {config.max_minutes:g} reached at step {self.step}", flush=True)
                        break
                    batch = next(self.stream)
                    self.index += config.batch_size * self.world // config.reuse  # the new items it read
                    outcome = self.train_step(batch, step=self.step, lr=lr_at(self.step, config))
                    if not outcome.applied:
                        if outcome.overflow:
                            continue  # an fp16 gradient overflowed: the scaler lowered its scale
                        skipped += 1  # never let one bad batch poison the weights
                        if self.main:
                            print(f"step {self.step}: non-finite loss or gradient; update skipped ({skipped} so far)",
                                  flush=True)
                        if skipped > 50:
                            raise RuntimeError("more than 50 non-finite updates: stopping (check the data and learning "
                                               "rate)")
                        continue
                    self.step += 1
                    window.append((outcome.mse, outcome.vel, outcome.foot))
                    bar.update(1)
                    if self.step % config.log_every == 0 or self.step == config.steps:
                        last = self.log(window, time.perf_counter() - window_t0)
                        bar.set_postfix(mse=f"{last['mse']:.4f}", s_step=f"{last['s_per_step']:.2f}")
                        window, window_t0 = [], time.perf_counter()
                    if self.step % config.ckpt_every == 0:
                        self.checkpoint()
                    if self.main and config.snapshot_every and self.step % config.snapshot_every == 0:
                        self.snapshot()
            finally:
                bar.close()
                self.checkpoint()
        return {"step": self.step, "stopped": stop.requested, **last}

    def close(self) -> None:
        if self.distributed and dist.is_initialized():
            dist.barrier()
            dist.destroy_process_group()


LOSS_WEIGHTINGS = ("uniform", "min_snr", "high_noise")


def timestep_weights(config: TrainConfig) -> torch.Tensor | None:
    """(steps,) per-timestep x0-loss weights of ``config.loss_weighting`` on the training schedule; None for uniform."""
    schedule = CosineSchedule()
    if config.loss_weighting == "min_snr":
        return min_snr_weights(schedule, config.snr_gamma)
    if config.loss_weighting == "high_noise":
        return high_noise_weights(schedule, config.high_noise_weight)
    return None


def high_noise_weights(schedule: CosineSchedule, weight: float) -> torch.Tensor:
    """(steps,) x0-loss weights: ``weight`` for t >= HIGH_NOISE_FROM, 1 below, scaled to mean 1 over the timesteps.

    ``masked_losses`` divides by the batch's total weight, so in effect a batch's noisy items weigh ``weight`` times
    its others (a batch without any is trained as with uniform weights); the logged mse is this weighted one."""
    if weight <= 0:
        raise ValueError(f"--high-noise-weight must be positive, got {weight}")
    w = torch.ones(schedule.steps)
    w[HIGH_NOISE_FROM:] = weight
    return w / w.mean()


def skip_timesteps(model: Denoiser, *, least: float = 0.01) -> int:
    """The timesteps t below this one are those where the prediction's skip weighs at least ``least``."""
    c = model.skip_weight(torch.arange(len(model.skip_alpha_bar) - 1))
    return max(1, int((c >= least).sum()))


def _load_allowing_new_skip_path(model: torch.nn.Module, params: dict) -> None:
    """Load a state into ``model``; the skip path's weights may be missing (a fine-tune switching it on keeps their
    initial values: the path's output starts at zero). Any other mismatch raises as ``load_state_dict`` does."""
    missing, unexpected = model.load_state_dict(params, strict=False)
    wrong = [k for k in missing if not k.startswith("skip_path.")] + list(unexpected)
    if wrong:
        model.load_state_dict(params)  # raises, naming them


def seed_new_words(model, *, old, grown) -> int:
    """Start each word new to ``grown`` at the embedding of the word ``old`` reads it as (its form, meaning or
    spelling: "skips" -> "hops"), so a fine-tune begins by reading new words exactly as the old model did rather
    than from near-zero rows; words ``old`` leaves out keep their small random start. Returns how many were seeded."""
    table = model.text_encoder.embed.weight  # (vocab_rows, width)
    seeded = 0
    with torch.no_grad():
        for word in grown.words[len(old.words):]:
            known, _how = old.reading(word)
            if known is not None:
                table[grown.words.index(word)] = table[old.words.index(known)]
                seeded += 1
    return seeded


def min_snr_weights(schedule: CosineSchedule, gamma: float) -> torch.Tensor:
    """(steps,) x0-loss weights of min-SNR-gamma: min(SNR_t, gamma), SNR_t = ab / (1 - ab), scaled to mean 1 over
    the timesteps so the learning rate keeps its meaning."""
    if gamma <= 0:
        raise ValueError(f"--snr-gamma must be positive, got {gamma}")
    ab = schedule.alphas_cumprod
    snr = ab / (1 - ab).clamp_min(1e-12)
    w = snr.clamp(max=gamma)
    return (w / w.mean()).float()


class StepOutcome(NamedTuple):
    mse: float
    vel: float
    applied: bool  # False: the update was skipped (non-finite loss or gradient)
    overflow: bool = False  # skipped because an fp16 gradient overflowed (the scaler lowered its scale)
    foot: float = 0.0  # the foot contact term (0 when it is off)


@dataclass
class TrainStep:
    """One optimisation step of the denoiser: what ``moattn train`` runs and ``moattn bench --train`` times.

    Timesteps and noise are drawn on the CPU from ``generator`` (the same run on any device); the batch crosses
    to the runtime's device here. The model's own ``autocast_dtype`` sets the forward precision; fp16 scales the
    loss. ``control_dims``: features that reach the model noise-free (a control fine-tune, PriorMDM Algorithm 1).
    """

    model: Denoiser
    net: torch.nn.Module  # the model, or its DistributedDataParallel wrapper
    ema: Denoiser
    optimizer: torch.optim.Optimizer
    runtime: Runtime
    generator: torch.Generator
    velocity_weight: float = 0.5
    grad_clip: float = 1.0
    ema_decay: float = 0.999
    control_dims: torch.Tensor | None = None
    timestep_weights: torch.Tensor | None = None  # (steps,) per-timestep loss weights; None = uniform
    schedule: CosineSchedule = field(default_factory=CosineSchedule)
    foot_weight: float = 0.0  # MDM's foot contact term (needs ``stats``)
    foot_below: int = 1000  # ... on timesteps t below this
    stats: tuple[torch.Tensor, torch.Tensor] | None = None  # (mean, std) of the features: x0 back to metres
    timesteps_below: int | None = None  # draw t below this (None: every timestep of the schedule)
    #: the prediction's skip acts on every item (``--skip-path-only``); otherwise the network trains as the x0
    #: prediction that generation uses (the skip never acts there: engine.model.denoiser.KEEP_INPUT)
    keep_input: bool = False

    def __post_init__(self) -> None:
        self.scaler = torch.amp.GradScaler(self.runtime.device.type, enabled=self.runtime.dtype == torch.float16)
        if self.foot_weight and self.stats is None:
            raise ValueError("the foot contact loss needs the feature statistics (stats)")

    def losses(self, batch: Batch) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(mse, velocity, foot contact) of the denoiser on ``batch`` at random timesteps (foot 0 when its weight
        is 0)."""
        device = self.runtime.device
        b = batch.x0.shape[0]
        t = torch.randint(0, self.timesteps_below or self.schedule.steps, (b,), generator=self.generator)
        noise = torch.randn(batch.x0.shape, generator=self.generator)
        if self.control_dims is not None:
            noise[..., self.control_dims] = 0.0
        x_t = self.schedule.q_sample(batch.x0, t, noise)
        x0 = batch.x0.to(device, non_blocking=True)
        cond = batch.cond.to_device(device)
        if self.keep_input:  # training the skip path alone: the prediction's skip acts on every item
            cond = cond.keeping_input()
        x0_hat = self.net(x_t.to(device, non_blocking=True), t.to(device), cond)
        weights = None if self.timestep_weights is None else self.timestep_weights[t]
        mse, vel = masked_losses(x0_hat.float(), x0, cond.frame_mask, weights)
        foot = torch.zeros((), device=mse.device)
        counted = (t < self.foot_below).to(device)  # (B,) the samples the foot term counts
        if self.foot_weight and bool(counted.any()):
            mean, std = (s.to(device) for s in self.stats)
            # the term on its samples alone: the same mean over their planted frames, without rebuilding the rest
            foot = foot_term(x0_hat[counted].float() * std + mean, x0[counted].float() * std + mean,
                             cond.frame_mask[counted])
        return mse, vel, foot

    def loss(self, batch: Batch) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """(the loss trained on, its mse, its velocity term, its foot contact term)."""
        mse, vel, foot = self.losses(batch)
        return mse + self.velocity_weight * vel + self.foot_weight * foot, mse, vel, foot

    def __call__(self, batch: Batch, *, step: int, lr: float) -> StepOutcome:
        for group in self.optimizer.param_groups:
            group["lr"] = lr
        loss, mse, vel, foot = self.loss(batch)
        self.optimizer.zero_grad(set_to_none=True)
        self.scaler.scale(loss).backward()
        self.scaler.unscale_(self.optimizer)
        grad_norm = torch.nn.utils.clip_grad_norm_(self.model.parameters(), self.grad_clip)
        if not (torch.isfinite(loss) and torch.isfinite(grad_norm)):
            self.optimizer.zero_grad(set_to_none=True)
            overflow = self.scaler.is_enabled() and bool(torch.isfinite(loss))
            if overflow:
                self.scaler.update()
            return StepOutcome(mse=float(mse), vel=float(vel), applied=False, overflow=overflow, foot=float(foot))
        self.scaler.step(self.optimizer)
        self.scaler.update()
        with torch.no_grad():
            decay = min(self.ema_decay, (1 + step) / (10 + step))
            torch._foreach_lerp_(list(self.ema.parameters()), list(self.model.parameters()), 1 - decay)
        return StepOutcome(mse=mse.item(), vel=vel.item(), applied=True, foot=foot.item())


def adamw(params, *, lr: float, weight_decay: float) -> torch.optim.AdamW:
    """The trainers' optimizer: AdamW, with its fused kernel (one update for every tensor; the same algorithm and the
    same state dict as the default one, about 1.05x faster per training step on the CPU, `moattn bench --train`)."""
    params = list(params)
    fused = bool(params) and all(p.device.type in ("cpu", "cuda") and p.is_floating_point() for p in params)
    return torch.optim.AdamW(params, lr=lr, weight_decay=weight_decay, fused=fused or None)


def _runtime(config: TrainConfig, *, distributed: bool) -> Runtime:
    """The device rule for a training process; under torchrun on CUDA each rank takes cuda:LOCAL_RANK."""
    runtime = Runtime.create(config.device, config.precision, training=True)
    if distributed and runtime.device.type == "cuda" and runtime.device.index in (None, 0):
        local = int(os.environ.get("LOCAL_RANK", "0"))
        runtime = Runtime.create(f"cuda:{local}", config.precision, training=True)
    if runtime.device.type == "cuda":
        torch.cuda.set_device(runtime.device)
    return runtime


def on_cpu(state):
    """A state dict (nested dicts/lists of tensors) with every tensor on the CPU: checkpoints stay device-free."""
    if isinstance(state, torch.Tensor):
        return state.detach().cpu()
    if isinstance(state, dict):
        return {k: on_cpu(v) for k, v in state.items()}
    if isinstance(state, (list, tuple)):
        return type(state)(on_cpu(v) for v in state)
    return state


def _fit_stats(source: MotionSource, config: TrainConfig) -> Normalizer:
    """The folder's own Mean/Std when training on a HumanML3D folder that has them, else fitted."""
    if config.data != "corpus" and (Path(config.data) / "Mean.npy").exists():
        return Normalizer.load(config.data)
    feats = [source.get(10_000_000 + i).features for i in range(config.stats_samples)]
    return Normalizer.fit(np.concatenate(feats, axis=0))
