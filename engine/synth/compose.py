"""Time line: run the segments in order (each starts where the previous left the body),
layer "while" gestures, bridge the seams with C1 cubic blends, add the style, solve."""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from engine.synth.physics import bridge_all, clip01
from engine.synth.primitives import PRIMITIVES, Context, Event, State
from engine.synth.primitives.arms import apply_layer, gesture_layer
from engine.synth.program import Program
from engine.synth.rig import Channels, Solved, local_rotations, solve
from engine.synth.styles import StyleSpec, apply_style, style_spec

# channels that are blended across seams (feet are world targets and never blended)
_BRIDGED = ("root", "heading", "pelvis", "spine", "neck", "collar", "knee_out", "hand", "elbow_pole", "hand_frame")


@dataclass
class Synthesis:
    """Everything synthesis knows about a program's motion."""

    program: Program
    channels: Channels
    solved: Solved
    events: list[Event]
    segment_ranges: list[tuple[int, int]]
    blend_windows: list[tuple[int, int]]
    segment_params: list[dict]
    gait_phase: np.ndarray
    style: StyleSpec | None = field(default=None, repr=False)  # the program's resolved style
    _local: np.ndarray | None = field(default=None, repr=False)

    @property
    def joints(self) -> np.ndarray:
        return self.solved.joints

    @property
    def local_rotations(self) -> np.ndarray:
        if self._local is None:
            self._local = local_rotations(self.solved)
        return self._local


def synthesize(program: Program, *, fps: float = 20.0, start: State | None = None) -> Synthesis:
    spec = style_spec(program.style, program.style_strength)
    state = start if start is not None else State.initial(stance=program.person.stance)
    parts, events, busy, phases, posture, params = [], [], [], [], [], []
    offset = 0
    phase_offset = 0.0
    for i, seg in enumerate(program.segments):
        ctx = Context(segment=seg, state=state, style=spec, person=program.person, fps=fps,
                      seed=program.seed * 1000 + i)
        res = PRIMITIVES[seg.action](ctx)
        ch = res.channels
        arm_busy = res.arm_busy
        seg_events = list(res.events)
        if seg.overlay is not None:
            over = replace(seg.overlay, frames=seg.frames)
            layer = gesture_layer(over, seg.frames, fps)
            apply_layer(ch, layer)
            arm_busy = np.maximum(arm_busy, layer.busy)
            seg_events += layer.events
        parts.append(ch)
        busy.append(arm_busy)
        phases.append(res.gait_phase + phase_offset)
        phase_offset = phases[-1][-1] + (phases[-1][-1] - phases[-1][-2] if len(phases[-1]) > 1 else 0.0)
        posture.append(res.posture)
        events += [e.shifted(offset) for e in seg_events] if offset else seg_events  # (fresh events)
        params.append(dict(res.params))
        offset += seg.frames
        state = res.state
    ch = Channels.concat(parts)
    arm_busy = np.concatenate(busy, 0)
    gait_phase = np.concatenate(phases, 0)
    posture_w = np.concatenate(posture, 0)
    windows = []
    half = program.blend // 2
    for b in program.boundaries:
        lo, hi = max(b - half, 1), min(b + program.blend - half, ch.frames - 1)
        windows.append((lo, hi))
        bridge_all([getattr(ch, name) for name in _BRIDGED] + [arm_busy, posture_w, gait_phase], lo, hi)
    ch = apply_style(ch, spec, arm_free=clip01(1.0 - arm_busy), gait_phase=gait_phase,
                     posture_weight=clip01(posture_w), fps=fps, seed=program.seed, in_place=True)
    solved = solve(ch)
    events.sort(key=lambda e: (e.frame, e.kind))
    return Synthesis(program=program, channels=ch, solved=solved, events=events,
                     segment_ranges=program.segment_ranges(), blend_windows=windows,
                     segment_params=params, gait_phase=gait_phase, style=spec)
