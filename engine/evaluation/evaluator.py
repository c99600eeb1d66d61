"""The evaluator: a small contrastive text-motion model trained on a train split (the corpus's or a
HumanML3D-layout folder's).

Its embeddings (unit norm) give FID, R-precision, MM-Dist, Diversity and MultiModality the
HumanML3D way. It sees normalised 263-dim features (with its own Mean/Std) and the words of its
training captions (its vocabulary is saved beside it). It runs on any device; its files are
device-free (CPU tensors, loaded with map_location="cpu").
"""
from __future__ import annotations

import contextlib
import json
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn
from tqdm import tqdm

from engine.data import MotionSource, collate
from engine.representation import FEATURE_DIM, Normalizer
from engine.runtime import CPU, Runtime
from engine.text import PromptError, TokenizedPrompt, Tokenizer, sinusoidal, split_words

WEIGHTS = "evaluator.pt"
CONFIG = "evaluator.json"


@dataclass(frozen=True)
class EvaluatorConfig:
    width: int = 128
    layers: int = 2
    heads: int = 4
    embed_dim: int = 128
    vocab_size: int = 512
    max_frames: int = 196
    pool: int = 2  # average-pool frames by this factor before the transformer (speed)


class _SeqEncoder(nn.Module):
    def __init__(self, width: int, layers: int, heads: int, embed_dim: int):
        super().__init__()
        layer = nn.TransformerEncoderLayer(d_model=width, nhead=heads, dim_feedforward=2 * width, dropout=0.1,
                                           batch_first=True, norm_first=True)
        self.encoder = nn.TransformerEncoder(layer, num_layers=layers, enable_nested_tensor=False)
        self.head = nn.Sequential(nn.LayerNorm(width), nn.Linear(width, embed_dim))
        self.width = width

    def forward(self, h: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        h = h + sinusoidal(torch.arange(h.shape[1], device=h.device), self.width)[None]
        h = self.encoder(h, src_key_padding_mask=~mask)
        m = mask[..., None].float()
        pooled = (h * m).sum(1) / m.sum(1).clamp_min(1)
        return F.normalize(self.head(pooled), dim=-1)


class Evaluator(nn.Module):
    def __init__(self, config: EvaluatorConfig):
        super().__init__()
        self.config = config
        self.motion_in = nn.Sequential(nn.Linear(FEATURE_DIM, config.width), nn.GELU(), nn.Linear(config.width, config.width))
        self.motion = _SeqEncoder(config.width, config.layers, config.heads, config.embed_dim)
        self.words = nn.Embedding(config.vocab_size, config.width, padding_idx=0)
        self.text = _SeqEncoder(config.width, config.layers, config.heads, config.embed_dim)
        self.log_temp = nn.Parameter(torch.tensor(np.log(1 / 0.07), dtype=torch.float32))

    def embed_motion(self, x: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        # x (B, T, 263) normalised with the evaluator's stats -> (B, D)
        p = self.config.pool
        if p > 1:
            pad = (-x.shape[1]) % p
            x = torch.nn.functional.pad(x * mask[..., None], (0, 0, 0, pad))
            m = torch.nn.functional.pad(mask.float(), (0, pad))
            counts = m.reshape(m.shape[0], -1, p).sum(-1)
            x = x.reshape(x.shape[0], -1, p, x.shape[-1]).sum(2) / counts.clamp_min(1)[..., None]
            mask = counts > 0
        return self.motion(self.motion_in(x), mask)

    def embed_text(self, ids: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        return self.text(self.words(ids), mask)


@dataclass
class LoadedEvaluator:
    model: Evaluator
    tokenizer: Tokenizer
    normalizer: Normalizer

    @property
    def device(self) -> torch.device:
        return next(self.model.parameters()).device

    def readable(self, caption: str) -> bool:
        """Whether the evaluator can read ``caption`` (not empty, not too long, something in it says a motion)."""
        try:
            self.tokenizer.encode(caption)  # read as a prompt is: words the evaluator never saw by meaning or left out
        except PromptError:
            return False
        return True

    def text_for(self, caption: str) -> str:
        """``caption`` as the evaluator embeds it (:meth:`tokens_for`)."""
        return self.tokens_for(caption).prompt

    def tokens_for(self, caption: str) -> TokenizedPrompt:
        """``caption`` read as the evaluator can embed it: as a prompt is when :meth:`readable`, else the words it
        knows (a corpus caption whose only verbs the evaluator never saw, "the character first heads ahead", would be
        refused as a prompt; a bench then scores it by the rest instead of failing at its end), or "a person"."""
        try:
            return self.tokenizer.encode(caption)
        except PromptError:
            known = " ".join(w for w in split_words(caption) if self.tokenizer.read_as(w) is not None)
        try:
            return self.tokenizer.encode(known)
        except PromptError:  # nothing known, or nothing known says a motion
            return self.tokenizer.encode("a person")

    @torch.no_grad()
    def motion_embeddings(self, features: list[np.ndarray], *, batch: int = 64) -> np.ndarray:
        """Raw (de-normalised) features, one (T, 263) array per motion -> (N, D) on the CPU."""
        device = self.device
        out = []
        for i in range(0, len(features), batch):
            chunk = [self.normalizer.normalize(f[: self.model.config.max_frames]) for f in features[i : i + batch]]
            length = max(len(c) for c in chunk)
            x = torch.zeros(len(chunk), length, FEATURE_DIM)  # built on the CPU, moved once
            mask = torch.zeros(len(chunk), length, dtype=torch.bool)
            for j, c in enumerate(chunk):
                x[j, : len(c)] = torch.from_numpy(np.asarray(c, dtype=np.float32))
                mask[j, : len(c)] = True
            out.append(self.model.embed_motion(x.to(device), mask.to(device)).float().cpu().numpy())
        return np.concatenate(out)

    @torch.no_grad()
    def text_embeddings(self, captions: list[str], *, batch: int = 256) -> np.ndarray:
        """Captions -> (N, D) on the CPU; words the evaluator does not know are read by meaning or left out, as a
        prompt is (it predates the 624-word grammar: retrain it with `moattn evaluator` for exact captions)."""
        device = self.device
        read = [self.tokens_for(c) for c in captions]
        out = []
        for i in range(0, len(read), batch):
            ids, mask = self.tokenizer.batch(read[i : i + batch], strict=False)
            out.append(self.model.embed_text(ids.to(device), mask.to(device)).float().cpu().numpy())
        return np.concatenate(out)


def load_evaluator(folder: str | Path, *, runtime: Runtime = CPU) -> LoadedEvaluator:
    """An evaluator folder (weights, config + vocabulary, Mean/Std), its network on ``runtime.device`` in fp32."""
    folder = Path(folder)
    if not (folder / CONFIG).exists():
        raise FileNotFoundError(f"no evaluator in {folder} (expected {CONFIG}); train one with `moattn evaluator --out {folder}`")
    try:
        meta = json.loads((folder / CONFIG).read_text())
        config, vocabulary = EvaluatorConfig(**meta["config"]), meta["vocabulary"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise ValueError(f"{folder / CONFIG} is not an evaluator config: {exc}") from None
    model = Evaluator(config)
    state = torch.load(folder / WEIGHTS, map_location="cpu", weights_only=True)
    model.load_state_dict({k: v.float() if v.is_floating_point() else v for k, v in state.items()})
    model.eval().to(runtime.device)
    return LoadedEvaluator(model=model, tokenizer=Tokenizer(vocabulary), normalizer=Normalizer.load(folder))


def train_evaluator(
    source: MotionSource,
    *,
    out: str | Path,
    steps: int = 1500,
    batch_size: int = 48,
    pool_size: int | None = 3000,
    lr: float = 3e-4,
    seed: int = 0,
    config: EvaluatorConfig | None = None,
    progress: bool = True,
    stats_samples: int = 1000,
    runtime: Runtime = CPU,
) -> dict:
    """InfoNCE between motion and caption embeddings; saves fp16 weights, config and stats in ``out``.

    Trains on a fixed pool of ``pool_size`` samples of ``source`` (drawn once; every caption of each
    is used), which keeps the data cost out of the step time. A finite source (one with ``len``, e.g.
    a HumanML3D folder's train split) is used whole when ``pool_size`` is None or larger. The
    vocabulary is the source's words (a folder's own captions, not the corpus lexicon). The network
    trains on ``runtime.device`` (bf16 autocast when the runtime asks for it); the saved weights are
    CPU tensors.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    words = sorted(source.words())
    tokenizer = Tokenizer(words)
    config = config or EvaluatorConfig(vocab_size=len(tokenizer) + 16)
    if config.vocab_size < len(tokenizer):  # a given config must still have a row per word
        config = replace(config, vocab_size=len(tokenizer))
    finite = getattr(source, "__len__", None)
    if finite is not None:
        pool_size = len(source) if pool_size is None else min(pool_size, len(source))
    elif pool_size is None:
        pool_size = 3000
    if pool_size < 2:
        raise ValueError(f"the evaluator needs at least 2 training motions, the source has {pool_size}")
    batch_size = min(batch_size, pool_size)
    pool = [source.get(i) for i in tqdm(range(pool_size), disable=not progress, desc="evaluator data", unit="motion")]
    normalizer = Normalizer.fit(np.concatenate([item.features for item in pool[:stats_samples]]))
    device = runtime.device
    autocast = runtime.autocast() if runtime.dtype == torch.bfloat16 else contextlib.nullcontext()
    model = Evaluator(config).to(device)
    optimizer = torch.optim.AdamW(model.parameters(), lr=lr, weight_decay=1e-2)
    history = []
    t0 = time.perf_counter()
    for step in tqdm(range(steps), disable=not progress, desc="evaluator", unit="step"):
        items = [pool[i] for i in rng.choice(len(pool), batch_size, replace=False)]
        batch = collate(items, tokenizer=tokenizer, normalize=normalizer.normalize, rng=rng, text_dropout=0.0,
                        max_frames=config.max_frames)
        with autocast:
            m = model.embed_motion(batch.x0.to(device), batch.cond.frame_mask.to(device))
            t = model.embed_text(batch.cond.text_ids.to(device), batch.cond.text_mask.to(device))
        logits = model.log_temp.exp().clamp(max=100) * t.float() @ m.float().T
        # captions of the same program can repeat in a batch: treat identical captions as positives
        same = torch.tensor([[a == b for b in batch.captions] for a in batch.captions], dtype=torch.float32,
                            device=device)
        target = same / same.sum(1, keepdim=True)
        loss = 0.5 * (torch.sum(-target * logits.log_softmax(1), 1).mean() + torch.sum(-target.T * logits.log_softmax(0).T, 1).mean())
        for g in optimizer.param_groups:
            g["lr"] = lr * min(1.0, (step + 1) / max(1, min(200, steps // 10))) * (0.1 + 0.9 * 0.5 * (1 + np.cos(np.pi * step / steps)))
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        optimizer.step()
        history.append(loss.item())
    state = {k: (v.half() if v.is_floating_point() else v).cpu() for k, v in model.state_dict().items()}
    torch.save(state, out / WEIGHTS)
    normalizer.save(out)
    summary = {"steps": steps, "batch_size": batch_size, "pool_size": pool_size, "final_loss": float(np.mean(history[-50:])),
               "seconds": time.perf_counter() - t0, "vocabulary": len(tokenizer) - 1, "device": str(device)}
    (out / CONFIG).write_text(json.dumps({"config": asdict(config), "vocabulary": list(tokenizer.words[1:]),
                                          "training": summary}, indent=2))
    return summary
