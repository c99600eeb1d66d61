"""`moattn bench --compose`: DoubleTake against corpus sequences with true transitions.

Held-out sequences: 3-4 single-action test-split programs (no style) chained by the corpus
(``interval_sequence``) with exact, physically blended transitions. Each method generates the
same intervals (prompts = each part's caption, the same lengths):
- ``doubletake``: handshake 1 s, first and second take;
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
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from engine.checkpoint import LoadedModel
from engine.evaluation.evaluator import LoadedEvaluator
from engine.evaluation.metrics import fid
from engine.generate import FPS, SampleConfig
from engine.methods.doubletake import DoubleTakeConfig, Interval, compose
from engine.representation import joints_to_features

METHODS = ("doubletake", "first_take", "naive")


@dataclass(frozen=True)
class ComposeBenchConfig:
    sequences: int = 64  # ~160 transitions: the FID floor (truth_redraw) is 0.03 here, 0.11-0.20 with 16
    window: int = 40  # frames around each transition
    steps: int = 50
    guidance: float = 2.5
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


def build_sequences(config: ComposeBenchConfig, *, seed: int | None = None) -> list[ComposeCase]:
    """``config.sequences`` held-out sequences drawn with ``seed`` (default ``config.seed``)."""
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


def jerk(window: np.ndarray) -> float:
    """Mean magnitude of the third time derivative of joint positions (m/s³)."""
    d3 = np.diff(window, n=3, axis=0) * FPS**3
    return float(np.linalg.norm(d3, axis=-1).mean())


def _run(loaded, seq: ComposeCase, method: str, sample: SampleConfig) -> tuple[np.ndarray, list[int]]:
    if method == "naive":
        result = compose(loaded, seq.intervals, DoubleTakeConfig(handshake=0, second_take=None), sample=sample)
        return result.joints, result.starts[1:]
    config = DoubleTakeConfig() if method == "doubletake" else DoubleTakeConfig(second_take=None)
    # the true parts last n_i frames; with handshakes the intervals are lengthened so that each
    # transition sits where the true one does: interval i spans its part plus half a handshake each side
    h = config.handshake
    ivs = [Interval(iv.prompt, iv.seconds + (h / FPS) * ((i > 0) + (i < len(seq.intervals) - 1)) / 2)
           for i, iv in enumerate(seq.intervals)]
    result = compose(loaded, ivs, config, sample=sample)
    return result.joints, [a + h // 2 for a, _ in result.transitions]


def bench_compose(loaded: LoadedModel, evaluator: LoadedEvaluator, config: ComposeBenchConfig = ComposeBenchConfig(),
                  *, log=print) -> dict:
    t0 = time.time()
    seqs = build_sequences(config)
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
              "ground_truth_jerk": float(np.mean([jerk(w) for w in true_windows]))}
    redraw, redraw_inside = (sum(part, []) for part in zip(*(cut(s.truth, s.boundaries)
                                                            for s in build_sequences(config, seed=config.seed + 1))))
    result["truth_redraw"] = {"transition_fid": fid(embed(redraw), true_emb), "transitions": len(redraw),
                              "interior_fid": fid(embed(redraw_inside), true_inside_emb)}
    log(f"  truth (other sequences): transition FID {result['truth_redraw']['transition_fid']:.3f}, interior FID "
        f"{result['truth_redraw']['interior_fid']:.3f} (the floors)")
    for method in METHODS:
        wins, inside = [], []
        for s in seqs:
            a, b = cut(*_run(loaded, s, method, sample))
            wins += a
            inside += b
        result[method] = {"transition_fid": fid(embed(wins), true_emb),
                          "jerk": float(np.mean([jerk(w) for w in wins])),
                          "interior_fid": fid(embed(inside), true_inside_emb)}
        log(f"  {method}: transition FID {result[method]['transition_fid']:.3f}, jerk {result[method]['jerk']:.1f}, "
            f"interior FID {result[method]['interior_fid']:.3f} ({time.time() - t0:.0f} s)")
    long = [Interval("a person walks forward", 5.0), Interval("a person jumps", 5.0),
            Interval("a person runs forward", 5.0), Interval("a person dances", 5.0)]
    long = (long * 4)[: config.long_intervals]
    timed = compose(loaded, long, DoubleTakeConfig(), sample=SampleConfig(steps=50, guidance=config.guidance))
    result["seconds_60s"] = timed.seconds
    result["long_motion_seconds"] = len(timed.joints) / FPS
    result["ratio_vs_first_take"] = result["doubletake"]["transition_fid"] / max(result["first_take"]["transition_fid"], 1e-9)
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
    lines.append("interior FID: 2-s windows inside the intervals, away from transitions (the model's own distance from "
                 "real motion at this window size)")
    lines.append(f"DoubleTake / first take transition FID: {result['ratio_vs_first_take']:.2f} (target <= 0.7); "
                 f"{result['long_motion_seconds']:.0f}-s motion in {result['seconds_60s']:.1f} s (target <= 15 s)")
    lines.append(f"{result['sequences']} sequences, {result['transitions']} transitions, {result['steps']} steps, "
                 f"{result['seconds']:.0f} s")
    return "\n".join(lines)
