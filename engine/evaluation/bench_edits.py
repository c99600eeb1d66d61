"""`moattn bench --edits`: MotionCLR edits scored against corpus ground truth, baselines in the same run.

Figures (JSON keys):
- counting.attention / counting.baseline: exact-match rate of repetition counts on held-out corpus
  motions with known counts (attention: the motion is DDIM-inverted and its self-attention recorded
  while it is rebuilt, counted from its lag profile, see engine.analysis.counting; baseline: peaks of the
  smoothed root height); counting.by_method: the same maps counted by every counting method (the lag
  profile, MotionCLR's recipe as published, its per-row variant);
- emphasis_spearman: rank correlation between the emphasis weight on the verb and the motion's
  amplitude as the corpus's intensity scales it (see :func:`amplitude`), averaged over prompts and seeds;
  emphasis acts in the layers calibrated for the model (``moattn bench --edits --calibrate``, on other prompts);
  ``emphasis.change``: the amplitude's change from the lowest to the highest weight, relative to the unedited
  motion's (a rank correlation of +1 can be a 1 % change nobody sees); ``emphasis.visible``: the share of draws that
  a person sees grow with the weight (rho >= 0.8 and a change of at least :data:`VISIBLE_CHANGE`);
- replacement_iou: timing IoU of the first segment (the walk) between reference and edited motion, with
  in-place replacement, beside the same edited prompt sampled from the same noise without it; a frame
  walks when its root speed exceeds half the reference's peak speed (the same threshold for all three
  motions), and a pair whose reference never reaches 0.3 m/s has no walk to time and is only counted
  (``replacement.pairs_without_walk``); ``replacement.edit_recognized``: share of all edited motions that the
  evaluator places nearer the edited prompt than the reference prompt (did the new verb land at all?), beside
  the same for the edited prompt sampled without replacement (``edit_recognized_without_replacement``);
- shift_order_acc: share of shifted motions whose activity matches the rolled reference better than
  the unshifted one;
- example_based: FID (vs held-out corpus motions) and diversity of example-based outputs beside
  perturbing the example's noise directly;
- grounding: "a person jumps four times" with "jumps" grounded to four chosen 1-s spans (the paper's
  headline grounding case) at an uneven rhythm (1, 2, 4 and 6 s of 8), so that the prompt's own
  evenly spread jumps do not land in them by themselves; ``spans_hit``: the share of the spans in which a jump
  lands (a jump's apex, by the adherence detectors, engine.analysis.detectors), beside the same prompt from the
  same noise without grounding (``spans_hit_without``); ``placed``: the share of the detected jumps that land
  inside a span; also the jumps counted in the whole motion by the detectors, by root-height peaks and from the
  self-attention (lag profile), and the jumps outside every span;
- fid: FID of every edit's outputs vs held-out corpus motions (few samples: compare within the run).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d
from scipy.stats import spearmanr

from engine.analysis.action_size import amplitude
from engine.analysis.counting import COUNTING_METHODS, CountingConfig, count_from_attention
from engine.attention import AttentionStore, StoreConfig, stack
from engine.checkpoint import LoadedModel
from engine.evaluation.evaluator import LoadedEvaluator
from engine.evaluation.metrics import diversity, fid
from engine.generate import Request, SampleConfig, generate
from engine.methods import edits
from engine.methods.edit_options import (
    SWEEP_WEIGHTS, EditOptions, calibrated_layers, calibrated_mode, run_edit, sweep_weights,
)
from engine.methods.motionclr import ExampleConfig, Ground, GroundingConfig, ReplaceConfig, ShiftConfig
from engine.representation import joints_to_features
from engine.units import DEFAULT_ETA, DEFAULT_GUIDANCE

REPEATED_ACTIONS = ("jump", "hop", "squat", "clap", "kick", "punch", "wave", "bow", "jumping_jacks")
VERBS = ("jumps", "kicks", "claps", "waves", "punches", "squats", "bows")


@dataclass(frozen=True)
class EditBenchConfig:
    counting_samples: int = 40
    emphasis_prompts: tuple[str, ...] = ("a person jumps", "a person jumps twice", "a person kicks with the right leg",
                                         "a person waves the right hand")
    emphasis_seeds: int = 3
    emphasis_points: int = 5  # of the calibrated mode's sweep (engine.methods.edit_options.SWEEP_WEIGHTS): 5 or 3
    #: modes measured beside the calibrated one (the headline figure), each in its own default layers; () = none
    emphasis_other_modes: tuple[str, ...] = tuple(SWEEP_WEIGHTS)
    pairs: int = 7
    replacement_seeds: int = 6  # 42 draws: "verb recognised" is a share, and 21 draws left it a +-0.1 guess
    shift_prompts: int = 7
    examples: int = 4
    outputs_per_example: int = 4
    steps: int = 50
    guidance: float = DEFAULT_GUIDANCE
    eta: float = DEFAULT_ETA  # the fresh noise each sampling step adds, as the studio and `moattn edit` sample
    seconds: float = 5.0
    reference_samples: int = 128
    grounding_prompt: str = "a person jumps four times"
    grounding_word: str = "jumps"
    # centres of the 1-s spans, as fractions of the motion: jumps at 1, 2, 4 and 6 s of 8, a slowing rhythm and a
    # still end (an even spread, the rhythm the prompt alone already has, would be hit without grounding)
    grounding_centres: tuple[float, ...] = (0.125, 0.25, 0.5, 0.75)
    grounding_seconds: float = 8.0
    grounding_seeds: int = 3
    grounding_weight: float = 0.3
    grounding_layers: tuple[int, ...] | None = None  # None: the grounding edit's default (as `moattn edit ground`)

    def sample(self, seed: int = 0) -> SampleConfig:
        """The sampling config of every edit this benchmark runs, with ``seed``."""
        return SampleConfig(steps=self.steps, guidance=self.guidance, eta=self.eta, seed=seed)

    @classmethod
    def quick(cls) -> "EditBenchConfig":
        return cls(counting_samples=16, emphasis_prompts=("a person jumps", "a person kicks with the right leg"),
                   emphasis_seeds=2, pairs=4, replacement_seeds=1, shift_prompts=4, examples=2, outputs_per_example=4,
                   steps=20, reference_samples=64, grounding_seeds=2)


# ----------------------------------------------------------------------------- measurements on joints
def root_speed(joints: np.ndarray) -> np.ndarray:
    """Smoothed horizontal root speed per frame (m/s)."""
    v = np.linalg.norm(np.diff(joints[:, 0, [0, 2]], axis=0), axis=-1) * 20
    return gaussian_filter1d(np.concatenate([v[:1], v]), 2.0)


WALK_FRACTION, MIN_WALK_PEAK = 0.5, 0.3  # m/s


def walking_interval(joints: np.ndarray, threshold: float) -> np.ndarray:
    """Frames whose root speed exceeds ``threshold`` (m/s; see :func:`walk_threshold`)."""
    return root_speed(joints) > threshold


def walk_threshold(reference: np.ndarray) -> float | None:
    """Half the reference's peak root speed; None when the reference never walks (peak under 0.3 m/s)."""
    peak = float(root_speed(reference).max())
    return WALK_FRACTION * peak if peak >= MIN_WALK_PEAK else None


def iou(a: np.ndarray, b: np.ndarray) -> float:
    union = (a | b).sum()
    return float((a & b).sum() / union) if union else 1.0


#: the relative amplitude change, lowest to highest emphasis weight, from which the edit is visibly bigger (10 %: 3 cm
#: on a 0.3-m jump, 6 cm on a 0.6-m kick)
VISIBLE_CHANGE = 0.10


def emphasis_response(weights, amplitudes) -> dict:
    """One draw of emphasis (amplitudes at increasing ``weights``, 0 among them): rank correlation, change relative to
    the unedited amplitude, and ``score`` = rho x min(1, |change| / VISIBLE_CHANGE) (1: monotone and visible; a
    monotone change too small to see scores little), ``visible``: rho >= 0.8 and change >= VISIBLE_CHANGE."""
    weights, amplitudes = list(weights), list(amplitudes)
    rho = rank_correlation(weights, amplitudes)
    unedited = amplitudes[weights.index(0.0)] if 0.0 in weights else float(np.mean(amplitudes))
    change = (amplitudes[int(np.argmax(weights))] - amplitudes[int(np.argmin(weights))]) / max(abs(unedited), 1e-6)
    return {"spearman": rho, "change": float(change), "score": rho * min(1.0, abs(change) / VISIBLE_CHANGE),
            "visible": bool(rho >= 0.8 and change >= VISIBLE_CHANGE)}


def rank_correlation(weights, amplitudes) -> float:
    """Spearman's rho; 0 when it is undefined (all amplitudes equal)."""
    rho = spearmanr(weights, amplitudes).statistic
    return 0.0 if np.isnan(rho) else float(rho)


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    d = np.sqrt((a * a).sum() * (b * b).sum())
    return float((a * b).sum() / d) if d > 0 else 0.0


# ----------------------------------------------------------------------------- the parts
def bench_counting(loaded: LoadedModel, config: EditBenchConfig, *, log=print) -> dict:
    from engine.synth import Corpus

    corpus = Corpus(split="test")
    hits_attn, hits_base, rows, i = 0, 0, [], 0
    while len(rows) < config.counting_samples and i < 20 * config.counting_samples:
        s = corpus.sample(10_000 + i, with_features=False)
        i += 1
        segs = s.labels.segments
        if len(segs) != 1 or segs[0].action not in REPEATED_ACTIONS or len(s.joints) > 197:
            continue
        action = segs[0].action
        truth = s.labels.counts[action]
        count = edits.count_motion(loaded, s.joints, prompt=s.captions[0], steps=min(config.steps, 20))
        by_method = {m: count_from_attention(count.self_map, CountingConfig(method=m)).rounded
                     for m in COUNTING_METHODS}  # the same map, every method
        rows.append({"action": action, "truth": int(truth), "attention": count.attention.rounded,
                     "attention_raw": round(count.attention.count, 2), "baseline": count.baseline,
                     "by_method": by_method})
        hits_attn += count.attention.rounded == truth
        hits_base += count.baseline == truth
        log(f"counting {len(rows)}/{config.counting_samples}: {rows[-1]}")
    n = max(1, len(rows))
    by_method = {m: sum(r["by_method"][m] == r["truth"] for r in rows) / n for m in COUNTING_METHODS}
    return {"attention": hits_attn / n, "baseline": hits_base / n, "samples": len(rows), "rows": rows,
            "by_method": by_method}


def bench_emphasis(loaded: LoadedModel, config: EditBenchConfig, *, mode: str | None = None,
                   log=print) -> tuple[dict, list[np.ndarray]]:
    """Emphasis in ``mode`` (None: the calibrated one, as `moattn edit emphasize` and the studio act without
    --mode), in that mode's default layers."""
    frames = int(config.seconds * 20)
    mode = mode or calibrated_mode(loaded.config)
    layers = calibrated_layers(loaded.config, mode)  # what run_edit acts in for this mode (None: every layer)
    weights = sweep_weights(mode, config.emphasis_points)
    draws, outputs, per_prompt, jump_rhos = [], [], {}, []
    for prompt in config.emphasis_prompts:
        verb = next(w for w in loaded.tokenizer.encode(prompt).words if w in VERBS)
        for seed in range(config.emphasis_seeds):
            heights = []
            for w in weights:
                options = EditOptions(kind="emphasize", prompt=prompt, word=verb, weight=w, mode=mode, seed=seed)
                out = run_edit(loaded, options, frames=frames, sample=config.sample(seed))
                heights.append(amplitude(out.after, verb))
                outputs.append(out.after)
            draw = emphasis_response(weights, heights)
            draws.append(draw)
            if verb.startswith("jump"):
                jump_rhos.append(draw["spearman"])
            per_prompt.setdefault(prompt, []).append({"seed": seed, "amplitudes": [round(h, 3) for h in heights],
                                                      **draw})
            log(f"emphasis ({mode}) {prompt!r} seed {seed}: rho {draw['spearman']:.2f}, change {draw['change']:+.0%}, "
                f"amplitudes {np.round(heights, 3).tolist()}")
    return {"spearman": float(np.mean([d["spearman"] for d in draws])),
            "change": float(np.mean([d["change"] for d in draws])),
            "visible": float(np.mean([d["visible"] for d in draws])), "per_prompt": per_prompt,
            "jumps_min": float(min(jump_rhos)) if jump_rhos else None, "mode": mode, "weights": list(weights),
            "layers": list(layers or range(loaded.model.num_layers)), "every_layer": layers is None}, outputs


def _pairs(loaded: LoadedModel, n: int) -> list[tuple[str, str]]:
    pairs = []
    for a, b in zip(VERBS, VERBS[1:] + VERBS[:1]):
        ref, edit = f"a person walks forward then {a} twice", f"a person walks forward then {b} twice"
        if not loaded.tokenizer.unknown_words(ref) and not loaded.tokenizer.unknown_words(edit):
            pairs.append((ref, edit))
    return pairs[:n]


def nearer_first(evaluator: LoadedEvaluator, motions: list[np.ndarray], first: list[str],
                 second: list[str]) -> np.ndarray:
    """Per motion (joints): is its evaluator embedding nearer the ``first`` caption than the ``second``? (bool)"""
    m = evaluator.motion_embeddings([joints_to_features(j) for j in motions])
    a, b = evaluator.text_embeddings(list(first)), evaluator.text_embeddings(list(second))
    return np.linalg.norm(m - a, axis=-1) < np.linalg.norm(m - b, axis=-1)


def bench_replacement(loaded: LoadedModel, evaluator: LoadedEvaluator, config: EditBenchConfig, *,
                      log=print) -> tuple[dict, list[np.ndarray]]:
    """Each prompt pair with ``replacement_seeds`` noises (seed k + 100 j for pair k): one noise per pair
    leaves the figure to a handful of draws."""
    frames = int(config.seconds * 20)
    with_edit, without, outputs, no_walk, per_pair = [], [], [], 0, {}
    plains, refs, edited = [], [], []
    for k, (ref, edit) in enumerate(_pairs(loaded, config.pairs)):
        for j in range(config.replacement_seeds):
            s = config.sample(k + 100 * j)
            out = edits.replace(loaded, ref, edit, ReplaceConfig(), frames=frames, sample=s)
            outputs.append(out.after)
            plain = generate(loaded, Request(prompts=[edit], frames=[frames], noise=out.generation.noise[1:2]),
                             s).joints[0]
            plains.append(plain)
            refs.append(ref)
            edited.append(edit)
            threshold = walk_threshold(out.before)
            if threshold is None:
                no_walk += 1
                log(f"replace {ref!r} -> {edit!r} seed {s.seed}: the reference does not walk (peak root speed "
                    f"{root_speed(out.before).max():.2f} m/s); not timed")
                continue
            ref_walk = walking_interval(out.before, threshold)
            with_edit.append(iou(ref_walk, walking_interval(out.after, threshold)))
            without.append(iou(ref_walk, walking_interval(plain, threshold)))
            per_pair.setdefault(f"{ref} -> {edit}", []).append(round(with_edit[-1], 3))
            log(f"replace {ref!r} -> {edit!r} seed {s.seed}: IoU {with_edit[-1]:.2f} "
                f"(without replacement {without[-1]:.2f})")
    recognized = nearer_first(evaluator, outputs, edited, refs) if outputs else np.zeros(0, bool)
    recognized_plain = nearer_first(evaluator, plains, edited, refs) if plains else np.zeros(0, bool)
    log(f"replacement: {recognized.sum()}/{len(recognized)} edited motions nearer the edited prompt than the "
        f"reference's (without replacement {recognized_plain.sum()}/{len(recognized_plain)})")
    return {"iou": float(np.mean(with_edit)) if with_edit else float("nan"),
            "iou_without_replacement": float(np.mean(without)) if without else float("nan"),
            "pairs": len(with_edit), "pairs_without_walk": no_walk, "per_pair": per_pair,
            "edit_recognized": float(recognized.mean()) if len(recognized) else float("nan"),
            "edit_recognized_without_replacement": float(recognized_plain.mean()) if len(recognized_plain)
            else float("nan")}, outputs


def bench_shift(loaded: LoadedModel, config: EditBenchConfig, *, log=print) -> tuple[dict, list[np.ndarray]]:
    frames = int(config.seconds * 20)
    correct, outputs = [], []
    prompts = [p for p, _ in _pairs(loaded, config.shift_prompts)]
    cfg = ShiftConfig(fraction=0.5)
    for k, prompt in enumerate(prompts):
        out = edits.shift(loaded, prompt, cfg, frames=frames, sample=config.sample(k))
        ref, shifted = root_speed(out.before), root_speed(out.after)
        rolled = np.roll(ref, -int(round(cfg.fraction * len(ref))))
        correct.append(_corr(shifted, rolled) > _corr(shifted, ref))
        outputs.append(out.after)
        log(f"shift {prompt!r}: corr rolled {_corr(shifted, rolled):.2f} vs original {_corr(shifted, ref):.2f}")
    return {"accuracy": float(np.mean(correct)) if correct else float("nan"), "prompts": len(correct)}, outputs


def bench_example(loaded: LoadedModel, evaluator: LoadedEvaluator, reference: np.ndarray, config: EditBenchConfig,
                  *, log=print) -> dict:
    frames = int(config.seconds * 20)
    prompts = [p for p, _ in _pairs(loaded, config.examples)] or ["a person jumps"]
    ours, perturbed, div_ours, div_pert = [], [], [], []
    for k, prompt in enumerate(prompts[: config.examples]):
        s = config.sample(k)
        out = edits.example_based(loaded, prompt, ExampleConfig(seed=k), count=config.outputs_per_example,
                                  frames=frames, sample=s)
        outs = [out.joints("out", i) for i in range(config.outputs_per_example)]
        base = out.generation.noise[0:1]
        g = torch.Generator().manual_seed(100 + k)
        noise = base + 0.5 * torch.randn(config.outputs_per_example, *base.shape[1:], generator=g)
        noise = noise / noise.std(dim=(1, 2), keepdim=True)
        pert = generate(loaded, Request(prompts=[prompt] * len(noise), frames=[frames] * len(noise), noise=noise), s).joints
        e_ours = evaluator.motion_embeddings([joints_to_features(j) for j in outs])
        e_pert = evaluator.motion_embeddings([joints_to_features(j) for j in pert])
        div_ours.append(diversity(e_ours, pairs=len(e_ours)))
        div_pert.append(diversity(e_pert, pairs=len(e_pert)))
        ours.extend(e_ours)
        perturbed.extend(e_pert)
        log(f"example {prompt!r}: diversity {div_ours[-1]:.3f} vs perturbed noise {div_pert[-1]:.3f}")
    return {"fid": fid(np.array(ours), reference), "diversity": float(np.mean(div_ours)),
            "perturbed_noise_fid": fid(np.array(perturbed), reference),
            "perturbed_noise_diversity": float(np.mean(div_pert)), "samples": len(ours)}


def grounding_spans(frames: int, centres: tuple[float, ...], *, width: int = 20) -> tuple[tuple[int, int], ...]:
    """Spans of ``width`` frames (1 s) centred at ``centres`` (fractions of a ``frames``-frame motion), in order;
    they must fit in the motion and not overlap."""
    spans = []
    for c in sorted(centres):
        a = int(round(c * frames)) - width // 2
        spans.append((a, a + width))
    if not spans or spans[0][0] < 0 or spans[-1][1] > frames or any(
            b > a2 for (_, b), (a2, _) in zip(spans, spans[1:])):
        raise ValueError(f"spans of {width} frames at {list(centres)} do not fit in {frames} frames apart")
    return tuple(spans)


JUMP_KINDS = ("jump", "jump_forward")


def jump_frames(joints: np.ndarray) -> list[int]:
    """The apex frames of the jumps in a motion (the adherence detectors: both feet leave and land together)."""
    from engine.analysis.detectors import MotionSignals, detect

    m = MotionSignals(joints)
    return sorted(e.frame for kind in JUMP_KINDS for e in detect(m, kind))


def spans_hit(frames: list[int], spans) -> list[bool]:
    """Per span: does a jump's apex fall inside it?"""
    return [any(a <= f < b for f in frames) for a, b in spans]


def placed_share(row: dict) -> float:
    """The share of a draw's detected jumps that land inside a span (0 when none was detected)."""
    detected = row["jumps_detected"]
    return (detected - row["jumps_outside"]) / detected if detected else 0.0


def bench_grounding(loaded: LoadedModel, config: EditBenchConfig, *, log=print) -> dict:
    """The paper's four-jumps case: the prompt with its verb grounded to chosen spans vs the prompt alone (the
    pair's reference, same noise). Scored per span by the jump detector, and counted three ways."""
    from engine.analysis.counting import count_from_root_height
    from engine.methods.edits import CountingRun, count_actions

    frames = int(config.grounding_seconds * 20)
    spans = grounding_spans(frames, config.grounding_centres)
    cfg = GroundingConfig.from_spans(config.grounding_word, spans, frames=frames, weight=config.grounding_weight,
                                     window=edits_window(loaded, config.grounding_layers))
    loaded.tokenizer.encode(config.grounding_prompt).word_index(config.grounding_word)
    run = CountingRun()
    draws, hit, hit_without = [], [], []
    for seed in range(config.grounding_seeds):
        sample = config.sample(seed)
        lo, hi = int(run.steps[0] * sample.steps), int(run.steps[1] * sample.steps)
        store = AttentionStore(StoreConfig(kinds=("self",), steps=frozenset(range(lo, hi)),
                                           budget_bytes=1024 * 1024 * 1024))
        noise = torch.randn(1, frames, loaded.model.config.feature_dim,
                            generator=torch.Generator().manual_seed(seed)).expand(2, -1, -1).clone()
        request = Request(prompts=[config.grounding_prompt] * 2, frames=[frames] * 2, roles=["ref", "out"],
                          noise=noise)
        gen = generate(loaded, request, sample, controller=stack(Ground(cfg, num_steps=sample.steps), store))
        row = {"seed": seed}
        for role, slot in (("without", 0), ("grounded", 1)):
            joints = gen.joints[slot]
            jumps = jump_frames(joints)
            hits = spans_hit(jumps, spans)
            outside = sum(not any(a <= f < b for a, b in spans) for f in jumps)
            attention = count_actions(store, joints, frames=frames, num_steps=sample.steps, slot=slot, run=run)
            row[role] = {"spans_hit": float(np.mean(hits)), "hits": hits, "jump_apexes": jumps,
                         "jumps_detected": len(jumps),
                         "jumps_outside": outside,
                         "root_height_count": count_from_root_height(joints[:, 0, 1]),
                         "attention_count": round(attention.attention.count, 2)}
        hit.append(row["grounded"]["spans_hit"])
        hit_without.append(row["without"]["spans_hit"])
        draws.append(row)
        g, w = row["grounded"], row["without"]
        log(f"grounding seed {seed}: spans hit {g['spans_hit']:.2f} (without {w['spans_hit']:.2f}); jumps detected "
            f"{g['jumps_detected']} at {g['jump_apexes']} (without {w['jumps_detected']}), outside the spans "
            f"{g['jumps_outside']}; root-height count {g['root_height_count']}, attention count "
            f"{g['attention_count']}")
    return {"spans_hit": float(np.mean(hit)), "spans_hit_without": float(np.mean(hit_without)),
            "placed": float(np.mean([placed_share(d["grounded"]) for d in draws])),
            "placed_without": float(np.mean([placed_share(d["without"]) for d in draws])),
            "prompt": config.grounding_prompt, "word": config.grounding_word, "spans": [list(s) for s in spans],
            "frames": frames, "weight": config.grounding_weight,
            "layers": list(cfg.window.layers) if cfg.window.layers is not None else "all",
            "draws": draws}


def edits_window(loaded: LoadedModel, layers: tuple[int, ...] | None = None):
    """The grounding edit's window for this model: ``layers``, or its default (as ``moattn edit ground``: every
    layer)."""
    from engine.methods.edit_options import default_window
    from engine.methods.windows import Window

    window = default_window("ground", loaded.config)
    return window if layers is None else Window(window.start, window.end, tuple(layers))


def bench_edits(loaded: LoadedModel, evaluator: LoadedEvaluator, config: EditBenchConfig = EditBenchConfig(),
                *, log=print) -> dict:
    from engine.evaluation.run import load_split

    t0 = time.perf_counter()
    reference = evaluator.motion_embeddings(load_split("test", count=config.reference_samples).features)
    counting = bench_counting(loaded, config, log=log)
    emphasis, emph_out = bench_emphasis(loaded, config, log=log)
    emphasis["other_modes"] = {m: bench_emphasis(loaded, config, mode=m, log=log)[0]
                               for m in config.emphasis_other_modes if m != emphasis["mode"]}
    for other in emphasis["other_modes"].values():
        other.pop("per_prompt")  # the headline mode's draws are kept; the others' figures suffice
    replacement, repl_out = bench_replacement(loaded, evaluator, config, log=log)
    shifting, shift_out = bench_shift(loaded, config, log=log)
    example = bench_example(loaded, evaluator, reference, config, log=log)
    grounding = bench_grounding(loaded, config, log=log)

    def edit_fid(joints: list[np.ndarray]) -> float | None:
        if len(joints) < 4:
            return None
        return fid(evaluator.motion_embeddings([joints_to_features(j) for j in joints]), reference)

    return {
        "counting": {"attention": counting["attention"], "baseline": counting["baseline"],
                     "samples": counting["samples"], "rows": counting["rows"], "by_method": counting["by_method"]},
        "emphasis_spearman": emphasis["spearman"],
        "emphasis": emphasis,
        "replacement_iou": replacement["iou"],
        "replacement": replacement,
        "shift_order_acc": shifting["accuracy"],
        "shift": shifting,
        "example_based": example,
        "grounding": grounding,
        "fid": {"emphasis": edit_fid(emph_out), "replacement": edit_fid(repl_out), "shift": edit_fid(shift_out),
                "example_based": example["fid"]},
        "settings": {**config.__dict__, "seconds_taken": round(time.perf_counter() - t0, 1)},
    }


def format_grounding(g: dict) -> str:
    """The grounding row: the share of the chosen spans where a jump lands, with and without grounding."""
    spans = ",".join(f"{a}:{b}" for a, b in g["spans"])
    detected = [d["grounded"]["jumps_detected"] for d in g["draws"]]
    outside = [d["grounded"]["jumps_outside"] for d in g["draws"]]
    attention = [d["grounded"]["attention_count"] for d in g["draws"]]
    plain = [d["without"]["jumps_detected"] for d in g["draws"]]
    placed = f"{g['placed']:.2f}" if "placed" in g else "-"  # a result saved before the share was kept has none
    placed_without = f" (without {g['placed_without']:.2f})" if "placed_without" in g else ""
    layers = g.get("layers", "all")
    layers = "every layer" if layers == "all" else "layers " + ", ".join(map(str, layers))
    return (f"grounding to {len(g['spans'])} spans ({g['prompt']!r}, {g['word']!r} -> {spans} of {g['frames']} "
            f"frames, weight {g['weight']:g}, {layers}): jumps land in {g['spans_hit']:.2f} of the spans (without "
            f"grounding {g['spans_hit_without']:.2f}; {len(g['draws'])} draws); {placed} of the jumps detected land "
            f"in a span{placed_without}; jumps detected per draw {detected} (without {plain}), outside the spans "
            f"{outside}, attention count {attention}")


def _layers_text(emphasis: dict) -> str:
    return "every layer" if emphasis.get("every_layer") else "layers " + ", ".join(map(str, emphasis["layers"]))


def format_table(result: dict) -> str:
    """The human-readable report of a :func:`bench_edits` result (also of a saved ``--json``)."""
    c, r, e = result["counting"], result["replacement"], result["example_based"]
    lines = [
        f"counting exact match: attention {c['attention']:.2f}  root-height baseline {c['baseline']:.2f}  "
        f"({c['samples']} motions)",
    ]
    if "by_method" in c:  # results saved before this figure existed lack it
        lines.append("  same maps, by counting method: " + ", ".join(f"{m} {v:.2f}" for m, v in c["by_method"].items()))
    lines += [
        f"emphasis Spearman (weight vs amplitude): {result['emphasis_spearman']:.2f} ("
        f"{result['emphasis'].get('mode', 'add')}, layers {', '.join(map(str, result['emphasis']['layers']))})" + (
            f"; amplitude change lowest to highest weight {result['emphasis']['change']:+.0%}, draws visibly bigger "
            f"(rho >= 0.8, >= {VISIBLE_CHANGE:.0%}) {result['emphasis']['visible']:.2f}" if "change" in result["emphasis"]
            else "") + (f"; lowest 'jumps' draw {result['emphasis']['jumps_min']:.2f}"
                        if result["emphasis"].get("jumps_min") is not None else ""),
        *[f"  in {m} mode ({_layers_text(o)}): Spearman {o['spearman']:.2f}, change "
          f"{o['change']:+.0%}, visibly bigger {o['visible']:.2f}"
          + (f", lowest 'jumps' draw {o['jumps_min']:.2f}" if o.get("jumps_min") is not None else "")
          for m, o in result["emphasis"].get("other_modes", {}).items()],
        f"replacement timing IoU: {r['iou']:.2f} (same noise, no replacement: {r['iou_without_replacement']:.2f}; "
        f"{r['pairs']} draws timed (prompt pairs x seeds), {r['pairs_without_walk']} whose reference does not walk)",
    ]
    if "edit_recognized" in r:  # results saved before this figure existed lack it
        lines.append(f"  edited motions nearer the edited prompt than the reference's (evaluator): "
                     f"{r['edit_recognized']:.2f} (without replacement {r['edit_recognized_without_replacement']:.2f})")
    lines += [f"  {pair}: IoU {', '.join(f'{v:.2f}' for v in ious)}" for pair, ious in r["per_pair"].items()]
    lines += [
        f"shift order accuracy: {result['shift_order_acc']:.2f}",
        f"example-based: FID {e['fid']:.3f} diversity {e['diversity']:.3f} | perturbed noise: FID "
        f"{e['perturbed_noise_fid']:.3f} diversity {e['perturbed_noise_diversity']:.3f}",
        "FID per edit: " + ", ".join(f"{k} {v:.3f}" for k, v in result["fid"].items() if v is not None),
    ]
    if "grounding" in result:
        lines.append(format_grounding(result["grounding"]))
    settings = result.get("settings", {})
    if "steps" in settings:
        eta = f", eta {settings['eta']:g}" if "eta" in settings else ""  # (results saved before eta was recorded)
        lines.append(f"{settings['steps']} sampling steps, guidance {settings['guidance']}{eta}, {settings['seconds']}-s "
                     f"motions, {settings['seconds_taken']:.0f} s")
    return "\n".join(lines)
