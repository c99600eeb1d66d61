"""`moattn bench --compose`: DoubleTake against corpus sequences with true transitions.

Held-out sequences: 3-4 single-action test-split programs (no style) chained by the corpus
(``interval_sequence``) with exact, physically blended transitions, kept only where the model reads every
caption (the corpus grammar can outgrow a shipped model's vocabulary). Each method generates the
same intervals (prompts = each part's caption, the same lengths):
- ``doubletake``: the engine's defaults (handshake 1 s, first and second take: the sandwich of the
  neighbouring intervals, see ``engine.methods.doubletake``);
- ``dt_paper``: the same with the paper's second take (``SecondTake.planted_feet`` off: no foot correction);
- ``first_take``: the handshake blending only;
- ``naive``: each interval sampled alone, concatenated.
Figures (JSON ``compose.<method>``): ``transition_fid`` (evaluator FID of 2-s windows centred on
each transition vs the true sequences' transition windows), ``jerk`` (mean |d³p/dt³| of the
joints in those windows, m/s³; ``compose.ground_truth_jerk`` beside it) and ``seconds_60s``:
the wall time of one 60-s DoubleTake motion on this machine.
``compose.truth_redraw.transition_fid`` is the floor of the FID: true transitions of as many other held-out
sequences (another corpus seed), scored against the same true windows. A method cannot be told from real
data below it, so the ratio to the first take is only meaningful while the first take is above it.
``interior_fid`` (per method, and ``truth_redraw.interior_fid``) is the same FID on 2-s windows centred
inside the intervals, away from any transition, against the true sequences' interior windows: how far the
model's own motion is from real at this window size, which a transition cannot be expected to beat.

Restated physical figures of the transition windows, against the truth's same windows (the true long motions'
windows centred on their true transitions, where each method's transitions are placed): ``foot_skate``
(``metrics.foot_skate``: share of grounded foot frame pairs that slide; ``compose.ground_truth_foot_skate``
beside it), ``jerk_vs_truth`` = ``jerk`` / ``ground_truth_jerk`` and ``foot_skate_vs_truth`` = ``foot_skate`` /
``ground_truth_foot_skate`` (None when the truth's windows do not skate at all). 1 is the truth's own
smoothness / footing; a seam shows as a jerk or skate ratio above it. ``interior_jerk`` / ``interior_foot_skate``
(and their ``_vs_truth`` ratios to the truth's interior windows) are the same figures inside the intervals: the
model's own smoothness and footing away from any transition. ``vs_first_take``: DoubleTake's transition jerk and
foot skate over the first take's (target <= 0.8 on both, with adherence no worse).

Adherence per interval (``compose.<method>.adherence``, ``compose.ground_truth_adherence`` beside it): the
2-s evaluator FID does not see whether a seam ate the actions on either side of it, so each interval of a
composed motion is cut out at the transition centres (all its own frames, half of each adjacent transition
included; the naive concatenation's intervals are its samples) and ``engine.evaluation.adherence.check_motion``
reads it against ``engine.intent.parse_intent`` of the interval's prompt (all checks, no reliability filter: the
truth's shares, read by the same detectors, are the yardstick). Figures: ``action`` (share of the intervals whose
action detector answers that match), ``count`` (the same for the count, where the prompt states one and the
detector is trusted), ``action_and_count`` (share of the checked intervals whose action matches and whose count
does not fail), with the numbers of intervals each share is over. The truth is cut at its true boundaries.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from engine.checkpoint import LoadedModel
from engine.evaluation.evaluator import LoadedEvaluator
from engine.evaluation.metrics import fid, foot_skate, jerk
from engine.generate import FPS, SampleConfig
from engine.methods.doubletake import DoubleTakeConfig, Interval, SecondTake, compose
from engine.representation import joints_to_features
from engine.units import DEFAULT_GUIDANCE

METHODS = ("doubletake", "dt_paper", "first_take", "naive")


@dataclass(frozen=True)
class ComposeBenchConfig:
    sequences: int = 64  # ~160 transitions: the FID floor (truth_redraw) is 0.03 here, 0.11-0.20 with 16
    window: int = 40  # frames around each transition
    steps: int = 50
    guidance: float = DEFAULT_GUIDANCE
    seed: int = 0
    long_intervals: int = 15  # 15 × 5 s with 1-s handshakes = 61 s

    @classmethod
    def quick(cls) -> "ComposeBenchConfig":
        return cls(sequences=6, steps=20)


@dataclass
class ComposeCase:
    intervals: list[Interval]
    truth: np.ndarray  # joints of the true long motion
    boundaries: list[int]  # true transition centres


def build_sequences(config: ComposeBenchConfig, *, seed: int | None = None,
                    readable: Callable[[str], bool] | None = None) -> list[ComposeCase]:
    """``config.sequences`` held-out sequences drawn with ``seed`` (default ``config.seed``).

    ``readable(caption)``: only sequences whose every caption the model reads are kept (the corpus's grammar can
    outgrow a shipped model's vocabulary; a prompt it refuses cannot be composed)."""
    from engine.synth import Corpus, make_sample
    from engine.synth.transforms import interval_sequence

    seed = config.seed if seed is None else seed
    corpus = Corpus(split="test", seed=seed)
    rng = np.random.default_rng(seed)
    pool = []
    i = 0
    while len(pool) < 6 * config.sequences and i < 20000:
        p = corpus.program(i)[0]
        i += 1
        if len(p.segments) == 1 and p.style == "none" and p.segments[0].overlay is None:
            pool.append(p)
    out = []
    for _ in range(50 * config.sequences):
        if len(out) >= config.sequences:
            break
        k = int(rng.integers(3, 5))
        parts = [pool[int(j)] for j in rng.choice(len(pool), size=k, replace=False)]
        frames = [int(rng.integers(70, 121)) for _ in parts]
        try:
            program, trans = interval_sequence(list(zip(parts, frames)), blend=10)
            truth = make_sample(program, split="test").joints
            captions = [make_sample(p, split="test").captions[0] for p in parts]
        except ValueError:  # repetitions that do not fit the new length
            continue
        if readable is not None and not all(readable(c) for c in captions):
            continue
        out.append(ComposeCase(intervals=[Interval(c, n / FPS) for c, n in zip(captions, frames)], truth=truth,
                             boundaries=[t["boundary"] for t in trans]))
    return out


def windows(joints: np.ndarray, centres: list[int], size: int) -> list[np.ndarray]:
    out = []
    for c in centres:
        a = int(np.clip(c - size // 2, 0, max(len(joints) - size - 1, 0)))
        out.append(joints[a : a + size + 1])
    return out


def interiors(centres: list[int], frames: int) -> list[int]:
    """Midpoints of the intervals that the transition frames ``centres`` cut a motion of ``frames`` into."""
    edges = [0, *centres, frames]
    return [(a + b) // 2 for a, b in zip(edges[:-1], edges[1:])]


def interval_crops(joints: np.ndarray, centres: list[int]) -> list[np.ndarray]:
    """Each interval's frames of a composed motion: cut at the transition centres (so with half of each transition)."""
    edges = [0, *centres, len(joints)]
    return [joints[a:b] for a, b in zip(edges[:-1], edges[1:])]


def adherence_shares(verdicts: list[dict]) -> dict:
    """Shares of ``check_motion`` verdicts (one per interval) that match; None where no interval was checked."""
    out: dict = {"intervals": len(verdicts)}
    for key in ("action", "count"):
        checked = [bool(v[key]) for v in verdicts if v.get(key) is not None]
        out[key] = float(np.mean(checked)) if checked else None
        out[f"{key}_checked"] = len(checked)
    both = [bool(v["action"]) and v.get("count") is not False for v in verdicts if v.get("action") is not None]
    out["action_and_count"] = float(np.mean(both)) if both else None
    return out


def interval_adherence(crops: list[np.ndarray], prompts: list[str]) -> dict:
    """:func:`adherence_shares` of the adherence detectors run on each interval's crop with its own prompt."""
    from engine.evaluation.adherence import check_motion
    from engine.intent import parse_intent

    intents = {p: parse_intent(p) for p in set(prompts)}
    return adherence_shares([check_motion(c, intents[p]) for c, p in zip(crops, prompts)])


def model_reads(loaded: LoadedModel) -> Callable[[str], bool]:
    """Whether ``loaded`` reads a caption as a prompt (unknown words by meaning or left out; refused: False)."""
    from engine.text import PromptError

    def reads(caption: str) -> bool:
        try:
            loaded.tokenizer.encode(caption)
        except PromptError:
            return False
        return True

    return reads


def _ratio(value: float, truth: float) -> float | None:
    """``value / truth``; None where the truth's figure is 0 (no scale to compare with)."""
    return value / truth if truth > 0 else None


def _run(loaded, seq: ComposeCase, method: str, sample: SampleConfig) -> tuple[np.ndarray, list[int]]:
    if method == "naive":
        result = compose(loaded, seq.intervals, DoubleTakeConfig(handshake=0, second_take=None), sample=sample)
        return result.joints, result.starts[1:]
    config = {"doubletake": DoubleTakeConfig(),
              "dt_paper": DoubleTakeConfig(second_take=SecondTake(planted_feet=False))}.get(
        method, DoubleTakeConfig(second_take=None))
    # the true parts last n_i frames; with handshakes the intervals are lengthened so that each
    # transition sits where the true one does: interval i spans its part plus half a handshake each side
    hs = (0, *config.handshakes(len(seq.intervals)), 0)
    ivs = [Interval(iv.prompt, iv.seconds + (hs[i] + hs[i + 1]) / 2 / FPS) for i, iv in enumerate(seq.intervals)]
    result = compose(loaded, ivs, config, sample=sample)
    return result.joints, [a + (b - a) // 2 for a, b in result.transitions]


def bench_compose(loaded: LoadedModel, evaluator: LoadedEvaluator, config: ComposeBenchConfig = ComposeBenchConfig(),
                  *, log=print) -> dict:
    t0 = time.time()
    reads = model_reads(loaded)
    seqs = build_sequences(config, readable=reads)
    log(f"compose benchmark: {len(seqs)} sequences, {sum(len(s.boundaries) for s in seqs)} transitions")
    sample = SampleConfig(steps=config.steps, guidance=config.guidance, seed=config.seed)

    def embed(wins: list[np.ndarray]) -> np.ndarray:
        return evaluator.motion_embeddings([joints_to_features(w) for w in wins])

    def cut(joints: np.ndarray, centres: list[int]) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """(transition windows, interior windows) of one motion."""
        return (windows(joints, centres, config.window),
                windows(joints, interiors(centres, len(joints)), config.window))

    true_windows, true_inside = (sum(part, []) for part in zip(*(cut(s.truth, s.boundaries) for s in seqs)))
    true_emb, true_inside_emb = embed(true_windows), embed(true_inside)
    result = {"sequences": len(seqs), "transitions": len(true_windows), "steps": config.steps,
              "ground_truth_jerk": float(np.mean([jerk(w) for w in true_windows])),
              "ground_truth_foot_skate": float(np.mean([foot_skate(w) for w in true_windows])),
              "ground_truth_interior_jerk": float(np.mean([jerk(w) for w in true_inside])),
              "ground_truth_interior_foot_skate": float(np.mean([foot_skate(w) for w in true_inside]))}
    prompts = [iv.prompt for s in seqs for iv in s.intervals]
    result["ground_truth_adherence"] = interval_adherence(
        [c for s in seqs for c in interval_crops(s.truth, s.boundaries)], prompts)
    redraw, redraw_inside = (sum(part, []) for part in zip(*(cut(s.truth, s.boundaries)
                                                            for s in build_sequences(config, seed=config.seed + 1,
                                                                                     readable=reads))))
    result["truth_redraw"] = {"transition_fid": fid(embed(redraw), true_emb), "transitions": len(redraw),
                              "interior_fid": fid(embed(redraw_inside), true_inside_emb)}
    log(f"  truth (other sequences): transition FID {result['truth_redraw']['transition_fid']:.3f}, interior FID "
        f"{result['truth_redraw']['interior_fid']:.3f} (the floors)")
    for method in METHODS:
        wins, inside, crops = [], [], []
        for s in seqs:
            joints, centres = _run(loaded, s, method, sample)
            a, b = cut(joints, centres)
            wins += a
            inside += b
            crops += interval_crops(joints, centres)
        result[method] = {"transition_fid": fid(embed(wins), true_emb),
                          "jerk": float(np.mean([jerk(w) for w in wins])),
                          "interior_fid": fid(embed(inside), true_inside_emb),
                          "foot_skate": float(np.mean([foot_skate(w) for w in wins])),
                          "interior_jerk": float(np.mean([jerk(w) for w in inside])),
                          "interior_foot_skate": float(np.mean([foot_skate(w) for w in inside]))}
        result[method]["jerk_vs_truth"] = _ratio(result[method]["jerk"], result["ground_truth_jerk"])
        result[method]["foot_skate_vs_truth"] = _ratio(result[method]["foot_skate"], result["ground_truth_foot_skate"])
        result[method]["interior_jerk_vs_truth"] = _ratio(result[method]["interior_jerk"],
                                                          result["ground_truth_interior_jerk"])
        result[method]["interior_foot_skate_vs_truth"] = _ratio(result[method]["interior_foot_skate"],
                                                                result["ground_truth_interior_foot_skate"])
        result[method]["adherence"] = interval_adherence(crops, prompts)
        log(f"  {method}: transition FID {result[method]['transition_fid']:.3f}, jerk {result[method]['jerk']:.1f}, "
            f"interior FID {result[method]['interior_fid']:.3f} ({time.time() - t0:.0f} s)")
    long = [Interval("a person walks forward", 5.0), Interval("a person jumps", 5.0),
            Interval("a person runs forward", 5.0), Interval("a person dances", 5.0)]
    long = (long * 4)[: config.long_intervals]
    timed = compose(loaded, long, DoubleTakeConfig(), sample=SampleConfig(steps=50, guidance=config.guidance))
    result["seconds_60s"] = timed.seconds
    result["long_motion_seconds"] = len(timed.joints) / FPS
    result["ratio_vs_first_take"] = result["doubletake"]["transition_fid"] / max(result["first_take"]["transition_fid"], 1e-9)
    result["vs_first_take"] = {key: _ratio(result["doubletake"][key], result["first_take"][key])
                               for key in ("jerk", "foot_skate")}
    result["paper_vs_first_take"] = {key: _ratio(result["dt_paper"][key], result["first_take"][key])
                                      for key in ("jerk", "foot_skate")}
    result["seconds"] = time.time() - t0
    return result


def format_table(result: dict) -> str:
    lines = [f"{'method':<12}{'transition FID':>16}{'jerk m/s³':>12}{'interior FID':>14}"]
    for m in METHODS:
        lines.append(f"{m:<12}{result[m]['transition_fid']:>16.3f}{result[m]['jerk']:>12.1f}"
                     f"{result[m]['interior_fid']:>14.3f}")
    truth = result["truth_redraw"]
    lines.append(f"{'truth':<12}{truth['transition_fid']:>16.3f}{result['ground_truth_jerk']:>12.1f}"
                 f"{truth['interior_fid']:>14.3f}   (FIDs: other true sequences, the floors)")
    lines.append("")
    lines.append("transition windows against the truth's same windows (ratio 1 = the truth's own):")
    lines.append(f"{'method':<12}{'jerk / truth':>14}{'foot skate':>12}{'skate / truth':>15}"
                 f"{'interior jerk':>15}{'interior skate':>16}   (interior: ratios to the truth's interior windows)")
    ratio = lambda v, width: f"{'n/a':>{width}}" if v is None else f"{v:>{width}.2f}"  # noqa: E731
    for m in METHODS:
        r = result[m]
        lines.append(f"{m:<12}{ratio(r['jerk_vs_truth'], 14)}{r['foot_skate']:>12.3f}"
                     f"{ratio(r['foot_skate_vs_truth'], 15)}{ratio(r.get('interior_jerk_vs_truth'), 15)}"
                     f"{ratio(r.get('interior_foot_skate_vs_truth'), 16)}")
    skate = result["ground_truth_foot_skate"]
    inner = result.get("ground_truth_interior_foot_skate", 0.0)
    lines.append(f"{'truth':<12}{ratio(1.0, 14)}{skate:>12.3f}{ratio(1.0 if skate > 0 else None, 15)}"
                 f"{ratio(1.0, 15)}{ratio(1.0 if inner > 0 else None, 16)}   (the true sequences' own windows)")
    if result.get("vs_first_take"):
        v = result["vs_first_take"]
        lines.append(f"DoubleTake / first take in the transition windows: jerk {ratio(v['jerk'], 0).strip()}, "
                     f"foot skate {ratio(v['foot_skate'], 0).strip()} (target <= 0.8 on both); interior: the same "
                     "figures on the 2-s windows inside the intervals (the model's own, which a transition cannot "
                     "be expected to beat)")
    if result.get("paper_vs_first_take"):
        v = result["paper_vs_first_take"]
        lines.append(f"the paper's second take (dt_paper: planted feet off) / first take: jerk "
                     f"{ratio(v['jerk'], 0).strip()}, foot skate {ratio(v['foot_skate'], 0).strip()}")
    lines.append("")
    lines.append("adherence per interval (cut at the transition centres; detectors on the interval's own prompt):")
    lines.append(f"{'method':<12}{'action':>8}{'count':>8}{'action+count':>14}   intervals checked (action / count)")
    share = lambda v, width: f"{'n/a':>{width}}" if v is None else f"{v:>{width}.2f}"  # noqa: E731
    for name, a in [*((m, result[m]["adherence"]) for m in METHODS), ("truth", result["ground_truth_adherence"])]:
        lines.append(f"{name:<12}{share(a['action'], 8)}{share(a['count'], 8)}{share(a['action_and_count'], 14)}"
                     f"   {a['action_checked']} / {a['count_checked']} of {a['intervals']}")
    lines.append("")
    lines.append("interior FID: 2-s windows inside the intervals, away from transitions (the model's own distance from "
                 "real motion at this window size)")
    lines.append(f"DoubleTake / first take transition FID: {result['ratio_vs_first_take']:.2f} (target <= 0.7); "
                 f"{result['long_motion_seconds']:.0f}-s motion in {result['seconds_60s']:.1f} s (target <= 15 s)")
    lines.append(f"{result['sequences']} sequences, {result['transitions']} transitions, {result['steps']} steps, "
                 f"{result['seconds']:.0f} s")
    return "\n".join(lines)
