"""`moattn eval`: the model's row beside the ground-truth row and a ground-truth noise floor."""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from engine.checkpoint import LoadedModel
from engine.evaluation.evaluator import LoadedEvaluator
from engine.evaluation.metrics import diversity, fid, foot_skate, mm_dist, multimodality, penetration_cm, r_precision
from engine.generate import Request, SampleConfig, generate
from engine.representation import features_to_joints


@dataclass(frozen=True)
class EvalConfig:
    samples: int = 512
    steps: int = 50
    guidance: float = 2.5
    batch: int = 32
    mm_texts: int = 32
    mm_repeats: int = 10
    seed: int = 0

    @classmethod
    def quick(cls) -> "EvalConfig":
        return cls(samples=128, steps=20, mm_texts=8, mm_repeats=4)


@dataclass
class Split:
    features: list[np.ndarray]
    captions: list[str]


def load_split(name: str, *, count: int, offset: int = 0, seed: int = 0) -> Split:
    from engine.synth import Corpus

    corpus = Corpus(split=name)
    rng = np.random.default_rng(seed + offset)
    feats, caps = [], []
    for i in range(offset, offset + count):
        s = corpus.sample(i)
        feats.append(s.features)
        caps.append(s.captions[int(rng.integers(len(s.captions)))])
    return Split(features=feats, captions=caps)


def row(evaluator: LoadedEvaluator, features: list[np.ndarray], captions: list[str], *,
        reference_motion: np.ndarray, mm_groups: list[np.ndarray] | None = None) -> dict:
    motion = evaluator.motion_embeddings(features)
    text = evaluator.text_embeddings(captions)
    joints = [features_to_joints(f) for f in features]
    return {
        "r_precision": r_precision(text, motion),
        "fid": fid(motion, reference_motion),
        "mm_dist": mm_dist(text, motion),
        "diversity": diversity(motion),
        "multimodality": multimodality(mm_groups) if mm_groups else None,
        "foot_skate": float(np.mean([foot_skate(j) for j in joints])),
        "penetration_cm": float(np.mean([penetration_cm(j) for j in joints])),
    }


def sample_model(loaded: LoadedModel, captions: list[str], lengths: list[int], config: EvalConfig, *,
                 progress=None) -> list[np.ndarray]:
    """Generate one motion per caption with the given feature lengths, in batches of similar length."""
    order = np.argsort(lengths)
    out: list[np.ndarray | None] = [None] * len(captions)
    for start in range(0, len(order), config.batch):
        idx = order[start : start + config.batch]
        request = Request(prompts=[captions[i] for i in idx], frames=[int(lengths[i]) for i in idx])
        gen = generate(loaded, request, SampleConfig(steps=config.steps, guidance=config.guidance,
                                                     seed=config.seed + start))
        for k, i in enumerate(idx):
            out[i] = gen.features[k, : lengths[i]]
        if progress is not None:
            progress(min(start + config.batch, len(order)), len(order))
    return out  # type: ignore[return-value]


def evaluate_split(loaded: LoadedModel | None, evaluator: LoadedEvaluator, split: str, config: EvalConfig,
                   *, progress=None) -> dict:
    gt = load_split(split, count=config.samples, seed=config.seed)
    other = load_split(split, count=config.samples, offset=1_000_000, seed=config.seed)
    reference = evaluator.motion_embeddings(gt.features)
    other_emb = evaluator.motion_embeddings(other.features)
    result = {
        "ground_truth": row(evaluator, gt.features, gt.captions, reference_motion=other_emb),
        "gt_noise_floor_fid": fid(reference, other_emb),
        "samples": config.samples,
    }
    if loaded is not None:
        t0 = time.perf_counter()
        lengths = [len(f) for f in gt.features]
        generated = sample_model(loaded, gt.captions, lengths, config, progress=progress)
        mm_caps = gt.captions[: config.mm_texts]
        mm_lengths = lengths[: config.mm_texts]
        groups = []
        for r in range(config.mm_repeats):
            reps = sample_model(loaded, mm_caps, mm_lengths, EvalConfig(**{**config.__dict__, "seed": config.seed + 1000 * (r + 1)}))
            groups.append(evaluator.motion_embeddings(reps))
        mm_groups = [np.stack([g[i] for g in groups]) for i in range(len(mm_caps))]
        result["model"] = row(evaluator, generated, gt.captions, reference_motion=reference, mm_groups=mm_groups)
        result["model"]["seconds"] = time.perf_counter() - t0
    return result


def format_table(results: dict) -> str:
    lines = []
    header = f"{'split':6} {'row':13} {'top1':>6} {'top2':>6} {'top3':>6} {'FID':>8} {'MMDist':>7} {'Div':>6} {'MModal':>7} {'skate':>6} {'pen cm':>7}"
    lines.append(header)
    lines.append("-" * len(header))
    for split, res in results.items():
        for name in ("model", "ground_truth"):
            r = res.get(name)
            if r is None:
                continue
            mm = "-" if r.get("multimodality") is None else f"{r['multimodality']:.3f}"
            p = r["r_precision"]
            lines.append(f"{split:6} {name:13} {p[0]:6.3f} {p[1]:6.3f} {p[2]:6.3f} {r['fid']:8.3f} {r['mm_dist']:7.3f} "
                         f"{r['diversity']:6.3f} {mm:>7} {r['foot_skate']:6.3f} {r['penetration_cm']:7.2f}")
        lines.append(f"{split:6} {'GT noise FID':13} {res['gt_noise_floor_fid']:8.3f}  ({res['samples']} samples)")
    return "\n".join(lines)
