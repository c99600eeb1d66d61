"""Physical-plausibility report of the corpus (``moattn corpus --check``)."""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from engine.skeleton import PARENTS
from engine.synth.corpus import Corpus, Sample

FOOT_JOINTS = (7, 10, 8, 11)  # left ankle, left toe, right ankle, right toe (label order)
LIMITS = {
    "foot_slide_cm": ("<", 1.0),
    "penetration_cm": ("<=", 1.0),
    "bone_length_std_cm": ("<", 0.01),
    "max_joint_speed_ms": ("<", 12.0),
    "transition_accel_ratio": ("<", 1.25),
    "nan_count": ("==", 0),
    "knee_hyperextension_count": ("==", 0),
}
SPEED_TARGET = 200.0


@dataclass
class SampleMetrics:
    slide_sum_cm: float
    slide_pairs: int
    slide_max_cm: float
    penetration_cm: float
    bone_std_cm: float
    max_speed: float
    blend_accel: float | None
    segment_accel: float | None
    nans: int
    knee_hyper: int
    knee_max_deg: float


def measure(sample: Sample, fps: float = 20.0) -> SampleMetrics:
    j = sample.joints.astype(np.float64)
    nans = int((~np.isfinite(j)).sum() + (~np.isfinite(sample.features)).sum())
    contact = sample.labels.contact_frames
    feet = j[:, FOOT_JOINTS]
    both = contact[1:] & contact[:-1]
    step = np.linalg.norm(feet[1:] - feet[:-1], axis=-1) * 100.0
    slide = step[both]
    toe_c = contact[:, [1, 3]]
    toe_h = j[:, [10, 11], 1][toe_c]
    floor = float(np.median(toe_h)) if toe_h.size else 0.0
    pen = max(0.0, (floor - j[..., 1].min()) * 100.0)
    parents = np.array(PARENTS[1:])
    bones = np.linalg.norm(j[:, 1:] - j[:, parents], axis=-1)
    bone_std = float(bones.std(0).max() * 100.0)
    vel = np.diff(j, axis=0) * fps
    speed = float(np.linalg.norm(vel, axis=-1).max()) if len(vel) else 0.0
    acc = np.linalg.norm(np.diff(j, 2, axis=0), axis=-1).max(1) * fps * fps  # (T-2,) max over joints
    windows = sample.labels.transitions
    blend_acc = seg_acc = None
    if windows and len(acc):
        in_win = np.zeros(len(acc), dtype=bool)
        for w in windows:
            in_win[max(w["start"] - 2, 0):max(w["end"] - 1, 0)] = True
        # airborne frames are excluded (gravity switches on at take-off by design)
        air = np.zeros(len(acc), dtype=bool)
        for jp in sample.labels.jumps:
            a, b = int(np.floor(jp["takeoff"])) - 2, int(np.ceil(jp["landing"])) + 1
            air[max(a, 0):max(b, 0)] = True
        if (in_win & ~air).any() and (~in_win & ~air).any():
            blend_acc = float(acc[in_win & ~air].max())
            seg_acc = float(acc[~in_win & ~air].max())
    # knee angle between thigh and shin, and hyperextension (knee bending backwards)
    knee_max, hyper = 0.0, 0
    for hip, knee, ankle in ((1, 4, 7), (2, 5, 8)):
        a = j[:, hip] - j[:, knee]
        b = j[:, ankle] - j[:, knee]
        cosang = (a * b).sum(-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
        flex = 180.0 - np.degrees(np.arccos(np.clip(cosang, -1, 1)))
        knee_max = max(knee_max, float(flex.max()))
        # hyperextension: the shin must rotate backward relative to the thigh about the hips' axis
        left = j[:, 1] - j[:, 2]
        sign = (np.cross(-a, b) * left).sum(-1)
        hyper += int(((sign < -1e-4) & (flex > 5)).sum())
    return SampleMetrics(slide_sum_cm=float(slide.sum()), slide_pairs=int(slide.size),
                         slide_max_cm=float(slide.max()) if slide.size else 0.0, penetration_cm=pen,
                         bone_std_cm=bone_std, max_speed=speed, blend_accel=blend_acc, segment_accel=seg_acc,
                         nans=nans, knee_hyper=hyper, knee_max_deg=knee_max)


def check_corpus(n: int = 1000, *, split: str = "train", seed: int = 0, progress=None) -> dict:
    """Generate ``n`` samples, time them, and report the plausibility metrics and limits."""
    corpus = Corpus(split, seed=seed)
    metrics = []
    frames = 0
    t0 = time.perf_counter()
    samples = []
    for i in range(n):
        s = corpus.sample(i)
        frames += s.joints.shape[0]
        samples.append(s)
        if progress is not None:
            progress(1)
    elapsed = time.perf_counter() - t0
    for s in samples:
        metrics.append(measure(s))
    pairs = sum(m.slide_pairs for m in metrics)
    blend = [m.blend_accel for m in metrics if m.blend_accel is not None]
    seg = [m.segment_accel for m in metrics if m.segment_accel is not None]
    report = {
        "n": n,
        "split": split,
        "frames": frames,
        "foot_slide_cm": round(sum(m.slide_sum_cm for m in metrics) / max(pairs, 1), 4),
        "foot_slide_max_cm": round(max(m.slide_max_cm for m in metrics), 4),
        "penetration_cm": round(max(m.penetration_cm for m in metrics), 4),
        "bone_length_std_cm": round(max(m.bone_std_cm for m in metrics), 6),
        "max_joint_speed_ms": round(max(m.max_speed for m in metrics), 3),
        "transition_accel_ms2": round(float(np.mean(blend)), 3) if blend else None,
        "segment_accel_ms2": round(float(np.mean(seg)), 3) if seg else None,
        "transition_accel_ratio": round(float(np.mean(blend) / np.mean(seg)), 4) if blend else 0.0,
        "transitions_checked": len(blend),
        "nan_count": int(sum(m.nans for m in metrics)),
        "knee_max_flexion_deg": round(max(m.knee_max_deg for m in metrics), 2),
        "knee_hyperextension_count": int(sum(m.knee_hyper for m in metrics)),
        "samples_per_s": round(n / elapsed, 2),
        "six_second_samples_per_s": round(n / elapsed * (frames / n) / 120.0, 2),
        "samples_per_s_target": SPEED_TARGET,
    }
    failures = []
    for key, (op, limit) in LIMITS.items():
        value = report[key]
        ok = {"<": value < limit, "<=": value <= limit, "==": value == limit}[op]
        if not ok:
            failures.append(f"{key} {value} (limit {op} {limit})")
    report["limits"] = {k: f"{op} {v}" for k, (op, v) in LIMITS.items()}
    report["failures"] = failures
    report["ok"] = not failures
    return report


__all__ = ["LIMITS", "SampleMetrics", "asdict", "check_corpus", "measure"]
