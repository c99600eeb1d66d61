"""Ground-truth labels of a sample (dataclasses -> JSON), in the sample's canonical frame."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from engine.synth.compose import Synthesis
from engine.synth.program import family
from engine.synth.styles import style_spec

JUMP_KINDS = ("jump", "hop", "jack", "jack_in")
COUNT_KIND = {"jump": "jump", "jump_forward": "jump", "hop": "hop", "jumping_jacks": "jack", "squat": "squat",
              "kick": "kick", "punch": "punch", "wave": "wave", "clap": "clap", "raise_arms": "raise", "bow": "bow",
              "dance": "beat", "walk": "step", "run": "step", "jog": "step", "walk_backward": "step",
              "side_step": "step", "turn": "step"}
FOOT_NAMES = ("left_ankle", "left_toe", "right_ankle", "right_toe")


def intervals(mask: np.ndarray) -> list[list[int]]:
    """Runs of True as [start, end) frame pairs."""
    return column_intervals(np.asarray(mask, dtype=bool)[:, None])[0]


def column_intervals(mask: np.ndarray) -> list[list[list[int]]]:
    """:func:`intervals` of every column of a (T, K) bool mask, in one pass."""
    padded = np.zeros((mask.shape[1], mask.shape[0] + 2), dtype=np.int8)
    padded[:, 1:-1] = mask.T
    column, frame = np.nonzero(np.diff(padded, axis=1))  # run edges, by column then frame
    column, frame = column.tolist(), frame.tolist()
    out: list[list[list[int]]] = [[] for _ in range(mask.shape[1])]
    for k, a, b in zip(column[::2], frame[::2], frame[1::2]):  # edges pair up within a column
        out[k].append([a, b])
    return out


@dataclass
class SegmentLabel:
    index: int
    action: str
    family: str
    start: int
    end: int  # exclusive
    count: int  # the program's count (gaits: steps taken)
    counted: int  # events of the counted kind inside the segment
    params: dict
    overlay: dict | None = None


@dataclass
class Labels:
    split: str
    index: int
    frames: int
    fps: float
    style: str
    style_strength: float
    segments: list[SegmentLabel]
    transitions: list[dict]  # {"boundary", "start", "end"} blend windows
    counts: dict[str, int]
    events: list[dict]
    jumps: list[dict]  # airborne phases: apex frame, height (m), takeoff/landing frames
    contacts: dict[str, list[list[int]]]  # per foot joint: [start, end) intervals
    contact_frames: np.ndarray = field(repr=False)  # (T, 4) bool
    root_path: np.ndarray = field(repr=False)  # (T, 2) x, z
    heading: np.ndarray = field(repr=False)  # (T,) rad
    outline: dict = field(default_factory=dict)
    motifs: dict = field(default_factory=dict)
    held_out_pair: bool = False
    held_out_template: bool = False
    floor_shift: float = 0.0

    def to_json(self) -> dict:
        out = {k: v for k, v in asdict(self).items() if k not in ("contact_frames", "root_path", "heading", "segments")}
        out["segments"] = [asdict(s) for s in self.segments]
        out["root_path"] = np.round(self.root_path, 4).tolist()
        out["heading"] = np.round(self.heading, 4).tolist()
        return out


def build_labels(syn: Synthesis, *, split: str, index: int, rotation: np.ndarray, shift: np.ndarray,
                 held_out_pair: bool, held_out_template: bool, fps: float = 20.0) -> Labels:
    """Labels in the canonical frame: p_canonical = rotation @ (p + shift)."""
    prog = syn.program
    T = syn.joints.shape[0]
    root = syn.joints[:, 0] + shift
    root = root @ rotation.T
    yaw_fix = float(np.arctan2(rotation[0, 2], rotation[0, 0]))
    heading = syn.channels.heading + yaw_fix
    contact = syn.channels.contact.reshape(T, 4)
    events = [e.to_json() for e in syn.events]
    jumps = [
        {"apex": e.frame, "height": round(e.height, 5), "takeoff": e.extra.get("takeoff"),
         "landing": e.extra.get("landing"), "kind": e.kind}
        for e in syn.events if e.kind in JUMP_KINDS
    ]
    segs = []
    counts: dict[str, int] = {}
    for i, (seg, (a, b), params) in enumerate(zip(prog.segments, syn.segment_ranges, syn.segment_params)):
        kind = COUNT_KIND.get(seg.action)
        n_ev = sum(1 for e in syn.events if e.kind == kind and a <= e.frame < b)
        overlay = None
        if seg.overlay is not None:
            ok = COUNT_KIND.get(seg.overlay.action)
            overlay = {"action": seg.overlay.action, "side": seg.overlay.side, "count": seg.overlay.count,
                       "counted": sum(1 for e in syn.events if e.kind == ok and a <= e.frame < b)}
            counts[seg.overlay.action] = counts.get(seg.overlay.action, 0) + overlay["counted"]
        count = n_ev if family(seg.action) == "locomotion" or seg.action in ("dance", "stand") else seg.count
        segs.append(SegmentLabel(index=i, action=seg.action, family=family(seg.action), start=a, end=b,
                                 count=count, counted=n_ev,
                                 params={**{k: v for k, v in seg.to_json().items() if k not in ("overlay", "frames")},
                                         **{k: (round(v, 5) if isinstance(v, float) else v) for k, v in params.items()}},
                                 overlay=overlay))
        if kind is not None and seg.action != "stand":
            counts[seg.action] = counts.get(seg.action, 0) + count
    transitions = [{"boundary": b, "start": lo, "end": hi} for b, (lo, hi) in zip(prog.boundaries, syn.blend_windows)]
    spec = syn.style if syn.style is not None else style_spec(prog.style, prog.style_strength)
    steps = [e for e in syn.events if e.kind == "step"]
    outline = {
        "frames": T,
        "segments": [{"start": s.start, "end": s.end, "family": s.family, "action": s.action, "count": s.count,
                      "direction": prog.segments[s.index].direction, "turn": prog.segments[s.index].turn,
                      "speed": prog.segments[s.index].speed,
                      "cadence": syn.segment_params[s.index].get("cadence"),
                      "lead": prog.segments[s.index].lead} for s in segs],
        "step_frames": {"left": [e.frame for e in steps if e.side == "left"],
                        "right": [e.frame for e in steps if e.side == "right"]},
        "jump_apexes": [j["apex"] for j in jumps],
        "counts": counts,
    }
    motifs = {
        "style": prog.style,
        "style_strength": prog.style_strength,
        "gestures": [{"segment": s.index, "action": s.action if s.family == "gesture" else s.overlay["action"],
                      "side": prog.segments[s.index].side if s.family == "gesture" else s.overlay["side"]}
                     for s in segs if s.family == "gesture" or s.overlay is not None],
        "posture": {"trunk_pitch": spec.trunk_pitch, "neck_pitch": spec.neck_pitch, "crouch": spec.crouch,
                    "arms": spec.arms, "stance": spec.stance, "lift": spec.lift, "swing": spec.swing},
        "person": prog.person.to_json(),
    }
    return Labels(
        split=split, index=index, frames=T, fps=fps, style=prog.style, style_strength=prog.style_strength,
        segments=segs, transitions=transitions, counts=counts, events=events, jumps=jumps,
        contacts=dict(zip(FOOT_NAMES, column_intervals(contact))),
        contact_frames=contact, root_path=root[:, [0, 2]], heading=heading, outline=outline, motifs=motifs,
        held_out_pair=held_out_pair, held_out_template=held_out_template, floor_shift=float(-shift[1]),
    )
