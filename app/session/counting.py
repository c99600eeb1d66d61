"""Counting the shown motion's repetitions (the session's ``count_result``: the Edit tab's readout, the Attention
tab's peaks): from its recorded self-attention (at once, as it is shown) or by DDIM inversion (the Edit tab's job)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.attention_record import AttentionRecord


@dataclass
class CountReadout:
    item: str  # the motion counted
    count: float
    rounded: int
    baseline: int
    peaks: list[tuple[int, int]]  # (row, col) in frames
    processed: np.ndarray  # the filtered, downsampled, normalised map
    downsample: int
    source: str  # how the self-attention map was obtained
    period: int | None = None  # frames between repetitions (None: no repetition found)
    span: tuple[int, int] | None = None  # first and last frame of the repetitions


def count_record(record: AttentionRecord, joints: np.ndarray, *, item: str, run=None) -> CountReadout:
    """Count on a generated motion's recorded self-attention (the recipe of ``edits.count_actions``: mean over
    heads and layers of the recorded steps in the run's step window)."""
    from engine.analysis.counting import count_from_attention, count_from_root_height
    from engine.methods.edits import CountingRun

    run = run or CountingRun()
    steps = run.chosen_steps(list(record.steps), record.num_steps)
    layers = run.chosen_layers(list(range(record.n_layers)))
    maps = record.self_maps[[record.step_position(s) for s in steps]][:, layers]
    attn = maps.astype(np.float32).mean(axis=(0, 1, 2))
    result = count_from_attention(attn, run.counting)
    source = (f"recorded self-attention: mean of heads, layers {', '.join(str(l + 1) for l in layers)} of "
              f"{record.n_layers} over {len(steps)} recorded step(s) {steps[0] + 1}–{steps[-1] + 1} "
              f"of {record.num_steps}")
    return CountReadout(item=item, count=result.count, rounded=result.rounded,
                        baseline=count_from_root_height(np.asarray(joints)[:, 0, 1]), peaks=list(result.peaks),
                        processed=result.processed, downsample=run.counting.downsample, source=source,
                        period=result.period, span=result.span)


def count_imported(loaded, joints: np.ndarray, *, item: str, prompt: str = "", steps: int = 20) -> CountReadout:
    """Count on a motion without recorded attention: DDIM-invert it, record self-attention while it is rebuilt."""
    from engine.methods.edits import CountingRun, count_motion

    run = CountingRun()
    count = count_motion(loaded, np.asarray(joints), prompt=prompt, steps=steps, run=run)
    r = count.attention
    return CountReadout(item=item, count=r.count, rounded=r.rounded, baseline=count.baseline, peaks=list(r.peaks),
                        processed=r.processed, downsample=run.counting.downsample, period=r.period,
                        span=r.span, source=f"inverted ({steps} DDIM steps), self-attention recorded while it was rebuilt")


def auto_count(session) -> None:
    """Generated motions are counted from their recorded maps as soon as they are shown (milliseconds)."""
    item = session.item
    if item is None or item.attention is None:
        session.count_result = None
        return
    try:
        session.count_result = count_record(item.attention, item.joints, item=item.name)
    except ValueError as exc:  # e.g. too short
        session.count_result = None
        session.warning(f"cannot count on {item.name!r}: {exc}")
