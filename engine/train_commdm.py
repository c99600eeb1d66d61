"""`moattn train --commdm`: train the ComMDM block on a few dozen two-person samples, the prior frozen.

The block follows the base's last layer unless ``--commdm-after`` says otherwise (the paper's place). The few
duets are cropped and, unless ``--no-mirror``, mirrored left <-> right (both as in the paper).
Only the block and the embedding rows of words the prior never saw are trained (L_simple on
both persons' clean motion and placement, plus a contact term on the hands; the two persons
share the timestep and draw their own noise). A share of the pairs (``prefix_prob``) is trained
for prefix completion: the first second of both people and their placement are given
noise-free, as PriorMDM trains its completion task, and ``duet.complete`` samples them so.
Checkpoints (train_state.pt for --resume, fp16 weights.pt), log.jsonl and the config go to --out.
"""
from __future__ import annotations

import copy
import json
import time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from engine.checkpoint import (export_weights, load_model, load_train_state, read_config, save_train_state,
                               write_config_json)
from engine.diffusion.schedule import CosineSchedule
from engine.methods.commdm import ComConfig, duet_roles
from engine.methods.duet import PREFIX_SECONDS, DuetModel, load_duet, new_duet
from engine.methods.duet_losses import contact_loss, duet_losses, prefix_cells
from engine.methods.duet_contact import learn_plans
from engine.methods.duet_data import PairItem, duet_words, few_shot, mean_placement, stack_pairs, training_items
from engine.model.denoiser import Condition
from engine.attention.context import WordIndex
from engine.generate import FPS
from engine.paths import MODEL_DIR
from engine.train import adamw, lr_at, stop_on_signals
from engine.runtime import CPU, Runtime


@dataclass
class ComTrainConfig:
    out: str = "runs/duet"
    prior: str = str(MODEL_DIR)  # the frozen base model folder
    steps: int = 3000
    batch_size: int = 16  # pairs per step
    lr: float = 5e-4
    weight_decay: float = 0.0
    warmup: int = 100
    ema_decay: float = 0.995
    text_dropout: float = 0.2  # pairs trained without text (prefix completion masks the text)
    velocity_weight: float = 0.5
    place_weight: float = 1.0
    contact_weight: float = 0.5  # duet_losses.contact_loss (metres, L1)
    contact_near: float = 0.5  # true hand distances under this count fully, the rest at 10 %
    prefix_prob: float = 0.5  # pairs trained for completion (prefix and placement given noise-free)
    prefix_text_dropout: float = 0.8  # completion usually runs without text (as in the paper)
    shots: int = 6  # samples per interaction (8 interactions: 48 samples)
    crop_every: int = 10
    mirror: bool = field(default=True, metadata={"help": "add each training duet mirrored left <-> right (both "
                                                         "people together, as the paper augments its few duets)"})
    seed: int = 0
    log_every: int = 20
    ckpt_every: int = 200
    threads: int = 0
    com: ComConfig = field(default_factory=ComConfig)

    def to_json(self) -> dict:
        data = asdict(self)
        data["com"] = self.com.to_json()
        return data

    @classmethod
    def from_json(cls, data: dict) -> "ComTrainConfig":
        data = {**_BEFORE_NEW_TERMS, **data}  # a run saved before these terms existed trained without them
        com = ComConfig.from_json(data.pop("com", {}))
        names = {f.name for f in fields(cls)}
        return cls(com=com, **{k: v for k, v in data.items() if k in names})


_BEFORE_NEW_TERMS = {"contact_weight": 0.0, "prefix_prob": 0.0, "mirror": False}
_RUNTIME = ("steps", "log_every", "ckpt_every", "threads")


LR_FLOOR = 0.05  # the cosine ends at 5 % of lr


def _batch(model: DuetModel, items: list[PairItem], rng: np.random.Generator, config: "ComTrainConfig"):
    """Duet states (2P, T + 1, D), their condition, and which pairs are trained for completion (P,)."""
    x0, frame_mask = stack_pairs(items)
    p = len(items)
    tokens = [model.tokenizer.encode(it.captions[int(rng.integers(len(it.captions)))], strict=True) for it in items]
    tokens = tokens + tokens  # both persons read the pair's caption
    ids, mask = model.tokenizer.batch(tokens)
    prefix = rng.random(p) < config.prefix_prob
    use = rng.random(p) >= np.where(prefix, config.prefix_text_dropout, config.text_dropout)
    use = torch.from_numpy(use)
    cond = Condition(text_ids=ids, text_mask=mask, frame_mask=frame_mask, use_text=torch.cat([use, use]),
                     roles=duet_roles(p), words=WordIndex(words=tuple(t.words for t in tokens)))
    return x0, cond, torch.from_numpy(prefix)


def train_commdm(config: ComTrainConfig, *, resume: bool = False, progress: bool = True) -> dict:
    """Train the ComMDM block to ``config.steps`` (or until SIGINT/SIGTERM), see :class:`ComTrainingRun`."""
    run = ComTrainingRun(config, progress=progress)
    run.start(resume=resume)
    run.build()
    return run.loop()


class ComTrainingRun:
    """One ComMDM training job as named steps, as :class:`engine.train.TrainingRun` splits the base trainer:
    :meth:`start` (resume from --out's checkpoint, or a fresh run), :meth:`build` (the frozen prior, the few
    duets and their crops, the block, EMA, optimizer, random streams), :meth:`loop` (:meth:`train_step`, with
    :meth:`log` and :meth:`checkpoint` on their schedules)."""

    def __init__(self, config: ComTrainConfig, *, progress: bool = True):
        if config.threads:
            torch.set_num_threads(config.threads)
        self.config = config
        self.progress = progress
        self.out = Path(config.out).resolve()
        self.out.mkdir(parents=True, exist_ok=True)
        self.state: dict | None = None  # a saved train state to continue from
        self.step = 0

    # -- start: a saved run's hyper-parameters and state, or none --------------------------------------------------
    def start(self, *, resume: bool) -> None:
        out = self.out
        if resume and (out / "train_state.pt").exists():
            saved = read_config(out)
            runtime = {k: getattr(self.config, k) for k in _RUNTIME}
            self.config = ComTrainConfig.from_json({**saved["train"], **runtime, "out": str(out)})
            self.state = load_train_state(out)
        elif resume:
            print(f"no checkpoint in {out}; starting from scratch")

    # -- build: prior, data, block, EMA, optimizer, random streams -------------------------------------------------
    def build(self) -> None:
        config = self.config
        prior = load_model(config.prior)
        samples = few_shot("train", per_interaction=config.shots, seed=config.seed)
        items = training_items(samples, prior.normalizer, crop_every=config.crop_every, mirror=config.mirror)
        words = [w for w in duet_words() if w not in prior.tokenizer]
        model = new_duet(prior, words, config=config.com, mean_place=mean_placement(items), seed=config.seed)
        net = model.denoiser
        params = [p for n, p in net.named_parameters() if p.requires_grad]
        ema = copy.deepcopy(net).eval()
        optimizer = adamw(params, lr=config.lr, weight_decay=config.weight_decay)
        if self.state is not None:
            net.load_state_dict(self.state["model"], strict=False)
            ema.load_state_dict(self.state["ema"], strict=False)
            optimizer.load_state_dict(self.state["optimizer"])
            self.step = int(self.state["step"])
            self.state = None  # loaded: let the saved tensors go
        self.prior, self.items, self.model, self.net, self.params = prior, items, model, net, params
        self.ema, self.optimizer = ema, optimizer
        self.rng = np.random.default_rng([config.seed, self.step])
        self.gen = torch.Generator().manual_seed(config.seed * 7919 + self.step)
        self.schedule = CosineSchedule()
        self.given = int(round(PREFIX_SECONDS * FPS))
        self.info = {**model.config, "kind": "commdm", "prefix_noise_free": config.prefix_prob > 0,
                     "train": config.to_json(), "prior_step": prior.config.get("step"), "samples": len(samples),
                     "items": len(items), "mirrored": config.mirror,
                     "interactions": sorted({s.interaction for s in samples}), "contacts": learn_plans(samples)}
        print(f"ComMDM: {len(samples)} two-person samples ({config.shots} per interaction), {len(items)} crops"
              f"{' (half of them mirrored)' if config.mirror else ''}, {sum(p.numel() for p in params)} trained "
              f"parameters, {len(words)} new words, the block after base layer {net.after} of {net.prior.num_layers}",
              flush=True)

    # -- what the loop writes ----------------------------------------------------------------------------------------
    def checkpoint(self) -> None:
        """config.json, train_state.pt (the trained tensors, EMA, optimizer, step) and the EMA's fp16 weights.pt."""
        net, out = self.net, self.out
        trainable = set(net.trainable())
        if not all(torch.isfinite(v).all() for k, v in net.state_dict().items() if k in trainable):
            print(f"step {self.step}: weights are not finite; checkpoint NOT written", flush=True)
            return
        write_config_json(out, {**self.info, "step": self.step})
        keep = lambda sd: {k: v for k, v in sd.items() if k in trainable}  # noqa: E731
        save_train_state(out, {"model": keep(net.state_dict()), "ema": keep(self.ema.state_dict()),
                               "optimizer": self.optimizer.state_dict(), "step": self.step})
        export_weights(out, keep(self.ema.state_dict()))

    def log(self, window: list[tuple[float, float, float, float]], seconds: float) -> dict:
        """One log.jsonl line for the steps since the last one."""
        w = np.asarray(window)
        entry = {"step": self.step, "mse": float(w[:, 0].mean()), "vel": float(w[:, 1].mean()),
                 "place": float(w[:, 2].mean()), "contact": float(w[:, 3].mean()),
                 "lr": lr_at(self.step, self.config, floor=LR_FLOOR), "s_per_step": seconds / len(window),
                 "time": time.time()}
        with (self.out / "log.jsonl").open("a") as fh:
            fh.write(json.dumps(entry) + "\n")
        return entry

    # -- one step and the loop -------------------------------------------------------------------------------------
    def train_step(self) -> tuple[float, float, float, float] | None:
        """One update on a batch of pairs: (mse, velocity, placement, contact), or None when the loss was not
        finite (no update)."""
        config, schedule, net = self.config, self.schedule, self.net
        picks = self.rng.choice(len(self.items), size=min(config.batch_size, len(self.items)), replace=False)
        x0, cond, prefix = _batch(self.model, [self.items[i] for i in picks], self.rng, config)
        p = len(picks)
        t = torch.randint(0, schedule.steps, (p,), generator=self.gen).repeat(2)  # one t per pair
        x_t = schedule.q_sample(x0, t, torch.randn(x0.shape, generator=self.gen))
        if prefix.any():  # the completion's known cells, noise-free: sqrt(alpha_bar) x0
            ab = schedule.alpha_bar(t).reshape(-1, 1, 1)
            x_t = torch.where(prefix_cells(x0, prefix, self.given), ab.sqrt() * x0, x_t)
        for group in self.optimizer.param_groups:
            group["lr"] = lr_at(self.step, config, floor=LR_FLOOR)
        x0_hat = net(x_t, t, cond)
        mse, vel, place = duet_losses(x0_hat, x0, cond.frame_mask)
        touch = (contact_loss(x0_hat, x0, cond.frame_mask, normalizer=self.prior.normalizer, near=config.contact_near)
                 if config.contact_weight else torch.zeros(()))
        loss = mse + config.velocity_weight * vel + config.place_weight * place + config.contact_weight * touch
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(self.params, 1.0)
        if not torch.isfinite(loss):
            print(f"step {self.step}: non-finite loss; update skipped", flush=True)
            return None
        self.optimizer.step()
        with torch.no_grad():
            decay = min(config.ema_decay, (1 + self.step) / (10 + self.step))
            for (name, pe), pm in zip(self.ema.named_parameters(), net.parameters()):
                if pm.requires_grad:
                    pe.lerp_(pm, 1 - decay)
        self.step += 1
        return mse.item(), vel.item(), place.item(), touch.item()

    def loop(self) -> dict:
        config = self.config
        bar = tqdm(total=config.steps, initial=self.step, disable=not self.progress, desc="train commdm", unit="step")
        window, t0, last = [], time.perf_counter(), {}
        with stop_on_signals() as stop:
            try:
                self.net.train()
                while self.step < config.steps and not stop.requested:
                    losses = self.train_step()
                    if losses is None:
                        continue
                    window.append(losses)
                    bar.update(1)
                    if self.step % config.log_every == 0 or self.step == config.steps:
                        last = self.log(window, time.perf_counter() - t0)
                        bar.set_postfix(mse=f"{last['mse']:.4f}", place=f"{last['place']:.4f}",
                                        contact=f"{last['contact']:.3f}")
                        window, t0 = [], time.perf_counter()
                    if self.step % config.ckpt_every == 0:
                        self.checkpoint()
            finally:
                bar.close()
                self.checkpoint()
        return {"step": self.step, "stopped": stop.requested, **last}


def load_trained(folder: str | Path, prior_folder: str | Path | None = None, *, runtime: Runtime = CPU) -> DuetModel:
    """A duet model folder with its prior (the one named in its training config unless given), on ``runtime``."""
    from engine.paths import PROJECT_ROOT

    config = read_config(Path(folder))
    named = Path(config["train"]["prior"])  # a shipped config names its prior relative to the project
    prior = load_model(prior_folder or (named if named.is_absolute() else PROJECT_ROOT / named), runtime=runtime)
    return load_duet(folder, prior)
