"""Counting the shown motion's repetitions (the session's ``count_result``: the Edit tab's readout, the Attention
tab's peaks): from its recorded self-attention (at once, as it is shown) or by DDIM inversion (the Edit tab's job),
with the session's counting method (``count_method``: the project's lag profile, MotionCLR's recipe as published, or
the per-row variant; see ``engine.analysis.counting.COUNTING_METHODS``). A readout keeps its self-attention map, so
another method recounts it at once (an imported motion is not inverted again)."""
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
    method: str = "lag"  # the counting method (engine.analysis.counting.COUNTING_METHODS)
    self_map: np.ndarray | None = None  # (T, T) the self-attention map counted on


def _run(method: str | None):
    from engine.analysis.counting import CountingConfig
    from engine.methods.edits import CountingRun

    return CountingRun(counting=CountingConfig(method=method or CountingConfig.method))


def _readout(result, *, item: str, baseline: int, source: str, run, attn: np.ndarray) -> CountReadout:
    return CountReadout(item=item, count=result.count, rounded=result.rounded, baseline=baseline,
                        peaks=list(result.peaks), processed=result.processed, downsample=run.counting.downsample,
                        source=source, period=result.period, span=result.span, method=run.counting.method,
                        self_map=np.asarray(attn, dtype=np.float32))


def count_record(record: AttentionRecord, joints: np.ndarray, *, item: str, run=None,
                 method: str | None = None) -> CountReadout:
    """Count on a generated motion's recorded self-attention (the recipe of ``edits.count_actions``: mean over
    heads and layers of the recorded steps in the run's step window)."""
    from engine.analysis.counting import count_from_attention, count_from_root_height

    run = run or _run(method)
    steps = run.chosen_steps(list(record.steps), record.num_steps)
    layers = run.chosen_layers(list(range(record.n_layers)))
    maps = record.self_maps[[record.step_position(s) for s in steps]][:, layers]
    attn = maps.astype(np.float32).mean(axis=(0, 1, 2))
    result = count_from_attention(attn, run.counting)
    source = (f"recorded self-attention: mean of heads, layers {', '.join(str(l + 1) for l in layers)} of "
              f"{record.n_layers} over {len(steps)} recorded step(s) {steps[0] + 1}–{steps[-1] + 1} "
              f"of {record.num_steps}")
    return _readout(result, item=item, baseline=count_from_root_height(np.asarray(joints)[:, 0, 1]), source=source,
                    run=run, attn=attn)


def count_imported(loaded, joints: np.ndarray, *, item: str, prompt: str = "", steps: int = 20,
                   method: str | None = None) -> CountReadout:
    """Count on a motion without recorded attention: DDIM-invert it, record self-attention while it is rebuilt."""
    from engine.methods.edits import count_motion

    run = _run(method)
    count = count_motion(loaded, np.asarray(joints), prompt=prompt, steps=steps, run=run)
    return _readout(count.attention, item=item, baseline=count.baseline, run=run, attn=count.self_map,
                    source=f"inverted ({steps} DDIM steps), self-attention recorded while it was rebuilt")


def recount(readout: CountReadout, method: str) -> CountReadout:
    """The same self-attention map counted with another method (nothing is recorded or inverted again)."""
    from engine.analysis.counting import count_from_attention

    if readout.self_map is None:
        raise ValueError(f"the count of {readout.item!r} kept no map to recount")
    run = _run(method)
    result = count_from_attention(readout.self_map, run.counting)
    return _readout(result, item=readout.item, baseline=readout.baseline, source=readout.source, run=run,
                    attn=readout.self_map)


def auto_count(session) -> None:
    """Generated motions are counted from their recorded maps as soon as they are shown (milliseconds), with the
    session's counting method; a motion counted by inversion is recounted from its kept map when the method
    changes."""
    item = session.item
    method = getattr(session, "count_method", None)
    if item is None:
        session.count_result = None
        return
    if item.attention is None:
        previous = session.count_result
        if previous is None or previous.item != item.name:
            session.count_result = None
        elif previous.method != method and previous.self_map is not None:
            session.count_result = recount(previous, method)
        return
    try:
        session.count_result = count_record(item.attention, item.joints, item=item.name, method=method)
    except ValueError as exc:  # e.g. too short
        session.count_result = None
        session.warning(f"cannot count on {item.name!r}: {exc}")
