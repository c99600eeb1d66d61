"""`moattn eval`: the model's row beside the ground-truth row and a ground-truth noise floor.

Ground truth comes from the procedural corpus (default) or from a HumanML3D-layout folder's split
(``data=``); :func:`split_items` is the one place either is read.
"""
from __future__ import annotations

import time
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from engine.checkpoint import LoadedModel
from engine.evaluation.evaluator import LoadedEvaluator
from engine.evaluation.metrics import diversity, fid, foot_skate, mm_dist, multimodality, penetration_cm, r_precision
from engine.generate import Request, SampleConfig, generate
from engine.representation import features_to_joints
from engine.text import PromptError, Tokenizer
from engine.units import DEFAULT_ETA, DEFAULT_GUIDANCE, DEFAULT_GUIDANCE_FROM

R_PRECISION_POOL = 32  # metrics.r_precision's default pool: a split needs at least this many items
MAX_SKIPS = 1000  # an endless source that skips this many items in a row has a vocabulary problem


@dataclass(frozen=True)
class EvalConfig:
    samples: int = 512
    steps: int = 50
    guidance: float = DEFAULT_GUIDANCE
    guidance_from: int = DEFAULT_GUIDANCE_FROM
    eta: float = DEFAULT_ETA
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
    skipped: list[str] = field(default_factory=list)  # why each unreadable item was left out (file: words)


def is_corpus(data: str | Path | None) -> bool:
    return data is None or str(data) == "corpus"


def _unreadable(caption: str, tokenizers: Mapping[str, Tokenizer], *, strict: bool = True) -> str | None:
    """None when every tokenizer reads ``caption``, else why not (which one lacks which words)."""
    reasons = []
    for owner, tokenizer in tokenizers.items():
        try:
            # a folder's captions must be read exactly; corpus captions as a prompt is read (the shipped evaluator
            # predates the 624-word grammar: its unknown words are read by meaning or left out)
            tokenizer.encode(caption, strict=strict)
        except PromptError as exc:
            unknown = exc.unknown or tokenizer.unknown_words(caption)
            reasons.append(f"the {owner} does not know {', '.join(repr(w) for w in unknown)}" if unknown
                           else f"the {owner} cannot read it ({exc})")
    return "; ".join(reasons) or None


def _choose(captions, first: int, tokenizers: Mapping[str, Tokenizer], *,
            strict: bool = True) -> tuple[str | None, str | None]:
    """(caption, None) trying ``captions[first]`` then the others in order, or (None, why the first failed)."""
    why_first = None
    for k in [first, *(j for j in range(len(captions)) if j != first)]:
        why = _unreadable(captions[k], tokenizers, strict=strict)
        if why is None:
            return captions[k], None
        why_first = why_first or f"{captions[k]!r}: {why}"
    return None, why_first


def split_items(split: str, *, data: str | Path | None = None, seed: int = 0, start: int = 0,
                tokenizers: Mapping[str, Tokenizer] | None = None,
                skipped: list[str] | None = None) -> Iterator[tuple[np.ndarray, str]]:
    """(features (T, 263), caption) ground-truth items of ``split``.

    * corpus (``data`` None or "corpus"): samples ``start``, ``start + 1``, ... (endless), one of
      each sample's captions drawn at random (seeded by ``seed + start``, as before);
    * a HumanML3D-layout folder: its split's items (whole clips, and ``#start#end`` sub-ranges cut at
      20 fps, as training sees them) in an order shuffled by ``seed``, from position ``start`` around
      once (finite); one caption drawn per item, clips longer than the model's 196 frames cropped at a
      seeded random offset.

    With ``tokenizers`` (owner -> tokenizer, e.g. the evaluator's and the model's) only captions all of
    them can read are used; an item with none is left out and its reason (file and unknown words)
    appended to ``skipped``.
    """
    tokenizers = dict(tokenizers or {})
    skipped = skipped if skipped is not None else []
    if is_corpus(data):
        from engine.synth import Corpus

        corpus = Corpus(split=split)
        rng = np.random.default_rng(seed + start)
        index = start
        while True:
            s = corpus.sample(index)
            caption, why = _choose(s.captions, int(rng.integers(len(s.captions))), tokenizers, strict=False)
            if caption is None:
                skipped.append(f"corpus {split} sample {index}: {why}")
            else:
                yield s.features, caption
            index += 1
    from engine.data import FolderSource
    from engine.model.denoiser import MAX_FRAMES

    source = FolderSource(data, split=split)
    order = np.random.default_rng(seed).permutation(len(source))
    for position in range(start, start + len(source)):
        index = int(order[position % len(source)])
        item = source.get(index)
        rng = np.random.default_rng([seed, index])  # the same item gets the same caption and crop in any draw
        caption, why = _choose(item.captions, int(rng.integers(len(item.captions))), tokenizers)
        if caption is None:
            skipped.append(f"{source.caption_file(index)}: {why}")
            continue
        features = item.features
        if len(features) > MAX_FRAMES:
            offset = int(rng.integers(0, len(features) - MAX_FRAMES + 1))
            features = features[offset : offset + MAX_FRAMES]
        yield features, caption


def load_split(name: str, *, count: int, offset: int = 0, seed: int = 0, data: str | Path | None = None,
               tokenizers: Mapping[str, Tokenizer] | None = None) -> Split:
    """The first ``count`` items of :func:`split_items` from ``offset`` (fewer when a folder's split is smaller)."""
    split = Split(features=[], captions=[])
    for features, caption in split_items(name, data=data, seed=seed, start=offset, tokenizers=tokenizers,
                                         skipped=split.skipped):
        split.features.append(features)
        split.captions.append(caption)
        if len(split.features) >= count:
            break
        if is_corpus(data) and len(split.skipped) > max(MAX_SKIPS, 10 * count):
            break  # the corpus is endless: stop looking
    if not split.features or (is_corpus(data) and len(split.skipped) > max(MAX_SKIPS, 10 * count)):
        where = "the corpus" if is_corpus(data) else str(data)
        if not split.skipped:
            raise ValueError(f"no usable items in split {name!r} of {where}: it has none")
        raise ValueError(f"no usable items in split {name!r} of {where}: {len(split.skipped)} left out because the "
                         f"evaluator or model does not know their words (first: {split.skipped[0]})")
    return split


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
                                                     guidance_from=config.guidance_from, eta=config.eta,
                                                     seed=config.seed + start))
        for k, i in enumerate(idx):
            out[i] = gen.features[k, : lengths[i]]
        if progress is not None:
            progress(min(start + config.batch, len(order)), len(order))
    return out  # type: ignore[return-value]


def evaluate_split(loaded: LoadedModel | None, evaluator: LoadedEvaluator, split: str, config: EvalConfig,
                   *, progress=None, data: str | Path | None = None) -> dict:
    """Rows for ``split`` of the corpus, or of the HumanML3D-layout folder ``data``.

    Only captions both the evaluator and the model can read are scored; the others are left out with
    a warning (counted in ``skipped``), and a split with nothing left raises ``ValueError``.
    For a folder the noise floor's second ground-truth sample is the next ``samples`` items of the
    shuffled split (disjoint when the split has twice as many; ``noise_floor_shared`` counts overlap).
    """
    tokenizers = {"evaluator": evaluator.tokenizer}
    if loaded is not None:
        tokenizers["model"] = loaded.tokenizer
    gt = load_split(split, count=config.samples, seed=config.seed, data=data, tokenizers=tokenizers)
    other_offset = 1_000_000 if is_corpus(data) else len(gt.features) + len(gt.skipped)
    other = load_split(split, count=len(gt.features), offset=other_offset, seed=config.seed, data=data,
                       tokenizers=tokenizers)
    if len(gt.features) < R_PRECISION_POOL:
        where = "the corpus" if is_corpus(data) else str(data)
        raise ValueError(f"split {split!r} of {where} has {len(gt.features)} usable item(s); R-precision needs at "
                         f"least {R_PRECISION_POOL}" + (f" ({len(gt.skipped)} left out for unknown words, first: "
                                                        f"{gt.skipped[0]})" if gt.skipped else ""))
    reference = evaluator.motion_embeddings(gt.features)
    other_emb = evaluator.motion_embeddings(other.features)
    result = {
        "ground_truth": row(evaluator, gt.features, gt.captions, reference_motion=other_emb),
        "gt_noise_floor_fid": fid(reference, other_emb),
        "samples": len(gt.features),
    }
    if not is_corpus(data):
        def key(features, caption):
            return hash((caption, np.ascontiguousarray(features).tobytes()))

        seen = {key(f, c) for f, c in zip(gt.features, gt.captions)}
        result["data"] = str(data)
        result["noise_floor_shared"] = sum(key(f, c) in seen for f, c in zip(other.features, other.captions))
    if gt.skipped:
        result["skipped"] = len(gt.skipped)
        warnings.warn(f"split {split!r}: {len(gt.skipped)} item(s) left out because the evaluator or model does not "
                      f"know their words (first: {gt.skipped[0]})", UserWarning, stacklevel=2)
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
        left_out = f", {res['skipped']} left out for unknown words" if res.get("skipped") else ""
        lines.append(f"{split:6} {'GT noise FID':13} {res['gt_noise_floor_fid']:8.3f}  ({res['samples']} samples{left_out})")
    return "\n".join(lines)
