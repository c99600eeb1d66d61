"""`moattn bench --control`: control models and DiffusionBlending vs plain inpainting on true paths.

Held-out test-split motions give the prompts (their captions) and the true control signals:
the root trajectory (feature dims 0-2) and each wrist's root-relative position. For each task
(root, left wrist, right wrist, and root + left wrist blended) the fine-tuned model(s) and the
base model with plain inpainting generate from the same noise. Figures (JSON
``control.<task>.<method>``): ``error_m`` (mean distance of the controlled joint from its true
position: the root on the floor, the wrist relative to the root), ``off_0_5m`` (share of frames
more than 0.5 m off), ``fid`` (evaluator, vs the held-out motions) and ``skate`` (foot skating).
``control.truth_redraw_fid`` is the floor of that FID: as many other held-out motions scored against the same
ones (with a few dozen motions it is far from 0; a ratio of two FIDs near it is mostly noise).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from engine.checkpoint import LoadedModel
from engine.evaluation.evaluator import LoadedEvaluator
from engine.evaluation.metrics import fid, foot_skate
from engine.generate import FPS, SampleConfig
from engine.methods.control import Control, control_dims, controlled, load_controls
from engine.representation import features_to_joints, joints_to_features

TASKS = {"root": ("root",), "left_wrist": ("left_wrist",), "right_wrist": ("right_wrist",),
         "root+left_wrist": ("root", "left_wrist")}


@dataclass(frozen=True)
class ControlBenchConfig:
    motions: int = 64  # the FID floor (truth_redraw_fid) is 0.18 here, 0.43-0.45 with 24
    steps: int = 50
    guidance: float = 2.5
    seed: int = 0
    min_seconds: float = 3.0

    @classmethod
    def quick(cls) -> "ControlBenchConfig":
        return cls(motions=8, steps=20)


def control_error(joints: np.ndarray, truth: np.ndarray, name: str) -> np.ndarray:
    """Per-frame distance (m) of the controlled joint: root on the floor, a wrist in the body frame."""
    n = min(len(joints), len(truth))
    if name == "root":
        return np.linalg.norm(joints[:n, 0, [0, 2]] - truth[:n, 0, [0, 2]], axis=1)
    # a wrist: its position in the body's own frame (root-relative, heading aligned), from each motion's joints
    dims = control_dims(name)
    a, b = joints_to_features(joints[: n + 1])[:, dims], joints_to_features(truth[: n + 1])[:, dims]
    return np.linalg.norm(a - b, axis=1)


def bench_control(loaded: LoadedModel, evaluator: LoadedEvaluator, config: ControlBenchConfig = ControlBenchConfig(),
                  *, models: dict[str, LoadedModel] | None = None, log=print) -> dict:
    from engine.paths import CONTROL_DIR
    from engine.synth import Corpus

    t0 = time.time()
    models = load_controls(CONTROL_DIR) if models is None else models
    corpus = Corpus(split="test", seed=config.seed)

    def held_out(start: int) -> list:
        out, i = [], start
        while len(out) < config.motions:
            s = corpus.sample(i)
            i += 1
            if len(s.joints) - 1 >= config.min_seconds * FPS:
                out.append(s)
        return out

    items = held_out(20000)
    truth_emb = evaluator.motion_embeddings([s.features for s in items])
    floor = fid(evaluator.motion_embeddings([s.features for s in held_out(40000)]), truth_emb)
    log(f"  truth (other motions): FID {floor:.3f} (the floor)")
    sample = SampleConfig(steps=config.steps, guidance=config.guidance, seed=config.seed)
    result = {"motions": len(items), "steps": config.steps, "models": sorted(models), "tasks": {},
              "truth_redraw_fid": floor}
    for task, names in TASKS.items():
        methods = {"inpainting": None}
        if all(n in models for n in names):
            methods["blending" if len(names) > 1 else "fine_tuned"] = models
        rows = {}
        for method, use in methods.items():
            errors, feats, skates = {n: [] for n in names}, [], []
            for k, s in enumerate(items):
                seconds = (len(s.joints) - 1) / FPS
                truth = features_to_joints(s.features)
                controls = [Control(n, s.features[:, control_dims(n)]) for n in names]
                gen = controlled(loaded, s.captions[0], controls, seconds=seconds, models=use,
                                 sample=SampleConfig(steps=sample.steps, guidance=sample.guidance, seed=config.seed + k))
                joints = gen.joints[0]
                for n in names:
                    errors[n].append(control_error(joints, truth, n))
                feats.append(joints_to_features(joints))
                skates.append(foot_skate(joints))
            err = np.concatenate([e for n in names for e in errors[n]])
            rows[method] = {"error_m": float(err.mean()), "off_0_5m": float((err > 0.5).mean()),
                            "fid": fid(evaluator.motion_embeddings(feats), truth_emb), "skate": float(np.mean(skates))}
            log(f"  {task} / {method}: error {rows[method]['error_m']:.3f} m, FID {rows[method]['fid']:.3f} "
                f"({time.time() - t0:.0f} s)")
        result["tasks"][task] = rows
    blend = result["tasks"]["root+left_wrist"]
    result["blending_fid_vs_inpainting"] = (blend["blending"]["fid"] / max(blend["inpainting"]["fid"], 1e-9)
                                            if "blending" in blend else None)
    result["seconds"] = time.time() - t0
    return result


def format_table(result: dict) -> str:
    lines = [f"{'task':<18}{'method':<12}{'error m':>9}{'>0.5 m':>8}{'FID':>8}{'skate':>8}"]
    for task, rows in result["tasks"].items():
        for method, r in rows.items():
            lines.append(f"{task:<18}{method:<12}{r['error_m']:>9.3f}{r['off_0_5m']:>8.3f}{r['fid']:>8.3f}{r['skate']:>8.3f}")
    ratio = result["blending_fid_vs_inpainting"]
    lines.append("blending / inpainting FID (root + left wrist): " + ("n/a (no control models)" if ratio is None
                                                                       else f"{ratio:.2f} (target <= 0.5)"))
    lines.append(f"FID floor (other held-out motions vs the same ones): {result['truth_redraw_fid']:.3f}")
    lines.append(f"{result['motions']} held-out motions, {result['steps']} steps, control models: "
                 f"{', '.join(result['models']) or 'none'}, {result['seconds']:.0f} s")
    return "\n".join(lines)
