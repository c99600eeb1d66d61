"""How big an action is, measured the way the corpus's ``intensity`` scales it (the emphasis benchmark's amplitude).

``moattn bench --edits`` and the emphasis calibration rank it against the emphasis weight; ``moattn edit`` and the
Edit tab report it before and after an emphasis or an erasure, so a user sees whether the action grew.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from engine.representation import SLICES, joints_to_features
from engine.skeleton import JOINT_INDEX

_WRISTS = ("right_wrist", "left_wrist")
_FEET = ("left_ankle", "right_ankle", "left_foot", "right_foot")
#: what is measured, per action family (a word's stem)
MEASURES: dict[str, str] = {
    "jump": "feet's peak above the floor", "hop": "feet's peak above the floor",
    "wave": "wrist's side-to-side swing", "punch": "wrist's forward reach", "kick": "foot's height range",
    "clap": "wrist's height range",
}


def body_frame(joints: np.ndarray) -> np.ndarray:
    """Joints in the body frame, (T-1, 22, 3): x lateral and z forward relative to the root with the heading
    removed, y the height above the floor (HumanML3D's "ric"; the root's own row is zero)."""
    ric = joints_to_features(joints)[:, SLICES["ric"]].reshape(-1, 21, 3)
    return np.concatenate([np.zeros((len(ric), 1, 3)), ric], axis=1)


def _family(verb: str) -> str | None:
    return next((k for k in MEASURES if verb.startswith(k)), None)


def amplitude(joints: np.ndarray, verb: str) -> float:
    """How big the action is (m), measured as the corpus's ``intensity`` scales it.

    jumps / hops: the feet's peak above the floor (the lowest of the ankles and toes at its highest, above that
    height's 5th percentile; in the corpus it grows as the intensity does, 0.14 / 0.25 / 0.40 m for a little / normal
    / high jumps; the pelvis's peak above its median height, used until session 41, read a high jump as lower, its
    median lifted by the time spent in the air); waves: the wrist's side-to-side swing
    (peak to peak of a sine with the high-passed lateral position's std, in the body frame); punches: the wrist's forward
    reach; kicks and anything else: the moving limb's height range.
    """
    family = _family(verb)
    if family in ("jump", "hop"):
        lowest = joints[:, [JOINT_INDEX[n] for n in _FEET], 1].min(axis=1)  # (T,)
        return float(lowest.max() - np.percentile(lowest, 5))
    wrists = [JOINT_INDEX[w] for w in _WRISTS]
    if family == "wave":
        lateral = body_frame(joints)[:, wrists, 0]
        swing = lateral - gaussian_filter1d(lateral, 6.0, axis=0, mode="nearest")
        return float(2.0 * np.sqrt(2.0) * swing.std(axis=0).max())
    if family == "punch":
        forward = body_frame(joints)[:, wrists, 2]
        return float((forward.max(0) - forward.min(0)).max())
    names = ("right_foot", "left_foot") if family == "kick" else _WRISTS
    heights = joints[:, [JOINT_INDEX[n] for n in names], 1]
    return float((heights.max(0) - heights.min(0)).max())


#: action -> (under this size it reads "a little", over this one "high"), metres of the action's measure: the midpoints
#: between the corpus's a little / normal / high means of unstyled single actions (runs/s41/measure.py: jumps 0.14 /
#: 0.25 / 0.40, hops 0.07 / 0.12 / 0.19, kicks 0.44 / 0.59 / 0.80, waves 0.12 / 0.18 / 0.23). Whether a reading
#: is trusted is the adherence validation's call, per action (engine.evaluation.adherence.validate)
INTENSITY_BOUNDS: dict[str, tuple[float, float]] = {"jump": (0.19, 0.32), "hop": (0.093, 0.155), "kick": (0.51, 0.70),
                                                    "wave": (0.148, 0.202)}
_VERB = {"jump": "jumps", "hop": "hops", "kick": "kicks", "wave": "waves"}


def intensity_seen(joints: np.ndarray, action: str, *, style: str | None = None,
                   events: Sequence[int] | None = None) -> tuple[str, float] | None:
    """The intensity level ("a little" | "normal" | "high") the motion's ``action`` reads at, and its size as measured
    (m, before any style is taken out); None for an action without bounds (:data:`INTENSITY_BOUNDS`).

    Jumps and hops: ``events`` (the detected apexes' frames) keep the reading to the action's own frames, each apex's
    feet above the floor (another action of the motion, e.g. jumping jacks, is not read); ``style`` takes out the
    style's own jump height (a zombie jumps at 0.6x: its high jump is a normal one's height)."""
    if action not in INTENSITY_BOUNDS:
        return None
    if action in ("jump", "hop") and events:
        lowest = joints[:, [JOINT_INDEX[n] for n in _FEET], 1].min(axis=1)  # (T,)
        floor = np.percentile(lowest, 5)
        size = float(np.median([lowest[max(0, f - 4):f + 5].max() - floor for f in events]))
    else:
        size = amplitude(joints, _VERB[action])
    read = size
    if action in ("jump", "hop") and style is not None:
        from engine.synth.styles import SPECS

        if style in SPECS:
            read = size / SPECS[style].jump
    little, high = INTENSITY_BOUNDS[action]
    return ("a little" if read < little else "high" if read > high else "normal"), size


@dataclass(frozen=True)
class SizeChange:
    """An action's size before and after an edit of its word."""

    word: str
    measure: str
    before: float  # m
    after: float  # m

    @property
    def relative(self) -> float:
        return (self.after - self.before) / max(abs(self.before), 1e-6)

    def describe(self) -> str:
        return (f"'{self.word}' ({self.measure}): {self.before:.2f} → {self.after:.2f} m ({self.relative:+.0%})")

    def to_json(self) -> dict:
        return {"word": self.word, "measure": self.measure, "before_m": round(self.before, 4),
                "after_m": round(self.after, 4), "change": round(self.relative, 4)}


def size_change(word: str, *, before: np.ndarray, after: np.ndarray) -> SizeChange | None:
    """The size of ``word``'s action in ``before`` and ``after`` (joints (T, 22, 3)); None for a word that names no
    action this measures (e.g. "person")."""
    family = _family(word)
    if family is None:
        return None
    return SizeChange(word=word, measure=MEASURES[family], before=amplitude(before, word),
                      after=amplitude(after, word))
