"""`moattn bench --duet`: ComMDM against the prior run twice without the block, on held-out duets.

Held-out two-person interactions come from the corpus's test split (balanced over the
interactions). In one run:

- **prefix completion** (text masked, as in the paper): given 1 s of both people, complete 3 s;
  root and mean-joint L2 error (m) at 1, 2 and 3 s after the prefix, both people, in the shared
  frame of the ground truth.
- **text-to-duet** (the sample's caption, both people read it): relative-placement error (where b
  stands from a, metres, and the facing difference, degrees; the better of the two person
  orders), contact-timing error (s, onset and offset of the labelled contact, a missed contact
  counts the whole clip), contact rate, and the share of face-to-face interactions whose people
  face each other.
- **spacing** (issue #35): the torso distance between the two people (``duet_pose.torso_distance``), its
  smallest in the first second and anywhere in the clip, and how often the torsos interpenetrate
  (``duet_pose.interpenetrate``: they overlap seen from above), for the truth, each method as sampled
  (``raw``) and as shown once ``duet_spacing`` has moved person b apart (what ``text_to_duet`` returns);
  plus how often b was moved, and the start distance by interaction (truth / commdm raw / commdm).

Text-to-duet's other figures are measured on the duets as shown (spaced).

The baseline (``prior_twice``) is the same prior and word rows with no block; its placement is
the training set's mean. ``commdm`` samples text-to-duet with contact guidance (``duet_contact``,
beyond the paper); two more text-only rows separate its parts: ``block_only`` (the block, no
guidance) and ``prior_contact`` (no block, with guidance). Completion has no guidance, so it is
run for ``commdm`` and ``prior_twice`` only.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from engine.generate import FPS, SampleConfig
from engine.methods.commdm import Pose, placements
from engine.methods.duet import DuetModel, complete, space_apart, text_to_duet
from engine.methods.duet_contact import ContactConfig, plans_for
from engine.methods.duet_spacing import START_SECONDS
from engine.analysis.duet_pose import face_each_other, interpenetrate, torso_distance
from engine.methods.duet_data import few_shot
from engine.skeleton import JOINT_INDEX
from engine.units import DEFAULT_GUIDANCE
from engine.units import MAX_SECONDS

# method -> (the block communicates, contact guidance)
METHODS: dict[str, tuple[bool, ContactConfig | None]] = {
    "commdm": (True, ContactConfig()), "prior_twice": (False, None),
    "block_only": (True, None), "prior_contact": (False, ContactConfig()),
}
PREFIX_METHODS = ("commdm", "prior_twice")
FACE_TO_FACE = ("handshake", "high_five", "hug", "push", "sparring", "dance_together")
CHEST = JOINT_INDEX["spine3"]
WRISTS = (JOINT_INDEX["left_wrist"], JOINT_INDEX["right_wrist"])
# contact thresholds (m), checked on the corpus's own duets (tests/test_duet.py)
HANDS_TOUCH, HUG_REACH, PUSH_REACH = 0.1, 0.22, 0.25


@dataclass(frozen=True)
class DuetBenchConfig:
    per_interaction: int = 3
    steps: int = 50
    guidance: float = DEFAULT_GUIDANCE
    seeds: int = 1
    seed: int = 0

    @classmethod
    def quick(cls) -> "DuetBenchConfig":
        return cls(per_interaction=1, steps=20)


def contact_frames(kind: str, ja: np.ndarray, jb: np.ndarray) -> np.ndarray:
    """Per frame, whether the contact ``kind`` (a label of the corpus's duets) happens (either person acting)."""
    n = min(len(ja), len(jb))
    ja, jb = ja[:n], jb[:n]
    rw = JOINT_INDEX["right_wrist"]
    if kind == "right_hands":
        return np.linalg.norm(ja[:, rw] - jb[:, rw], axis=-1) < HANDS_TOUCH

    def reach(x, y):  # (T, 2): each wrist of x to y's chest
        return np.linalg.norm(x[:, list(WRISTS)] - y[:, None, CHEST], axis=-1)

    if kind == "bodies":  # both hands around the other's back
        return (reach(ja, jb).max(1) < HUG_REACH) | (reach(jb, ja).max(1) < HUG_REACH)
    if kind == "hands_on_chest":
        return (reach(ja, jb).max(1) < PUSH_REACH) | (reach(jb, ja).max(1) < PUSH_REACH)
    raise ValueError(f"unknown contact kind {kind!r}")


def contact_timing(kind: str, start: int, end: int, ja: np.ndarray, jb: np.ndarray) -> tuple[float, bool]:
    """(error in s: mean of |onset| and |offset| differences of the longest contact run; whether any contact)."""
    on = contact_frames(kind, ja, jb)
    if not on.any():
        return len(on) / FPS, False
    runs, k = [], 0
    while k < len(on):
        if on[k]:
            j = k
            while j < len(on) and on[j]:
                j += 1
            runs.append((k, j))
            k = j
        else:
            k += 1
    a, b = max(runs, key=lambda r: r[1] - r[0])
    return (abs(a - start) + abs(b - end)) / 2 / FPS, True


def placement_error(joints: np.ndarray, truth_a: np.ndarray, truth_b: np.ndarray) -> tuple[float, float]:
    """(metres, degrees) between where b stands from a in a duet and in the truth; the better person order."""
    gen, _ = placements(joints[0], joints[1])
    best = None
    for ta, tb in ((truth_a, truth_b), (truth_b, truth_a)):
        true, _ = placements(ta, tb)
        dist = float(np.hypot(gen.x - true.x, gen.z - true.z))
        ang = float(np.degrees(abs((gen.yaw - true.yaw + np.pi) % (2 * np.pi) - np.pi)))
        if best is None or dist < best[0]:
            best = (dist, ang)
    return best


def _prefix_errors(duet_joints: np.ndarray, ja: np.ndarray, jb: np.ndarray, given: int) -> dict:
    out = {}
    for sec in (1, 2, 3):
        f = given + sec * FPS - 1
        roots, joints = [], []
        for p, truth in enumerate((ja, jb)):
            roots.append(np.linalg.norm(duet_joints[p, f, 0] - truth[f, 0]))
            joints.append(np.linalg.norm(duet_joints[p, f] - truth[f], axis=-1).mean())
        out[f"root_{sec}s"] = float(np.mean(roots))
        out[f"joints_{sec}s"] = float(np.mean(joints))
    return out


def spacing_figures(joints: np.ndarray) -> dict:
    """Two people (2, T, 22, 3) -> their torso distance's minimum in the first second and over the clip (m), and
    whether their torsos interpenetrate in the first second, and the share of frames they do."""
    d, inside = torso_distance(joints), interpenetrate(joints)
    start = int(round(START_SECONDS * FPS))
    return {"start_min_m": float(d[:start].min()), "clip_min_m": float(d.min()),
            "inside_start": float(inside[:start].any()), "inside_frames": float(inside.mean())}


def _mean_figures(rows: list[dict]) -> dict:
    return {k: float(np.mean([r[k] for r in rows])) for k in rows[0]} | {"n": len(rows)}


def bench_duet(model: DuetModel, config: DuetBenchConfig = DuetBenchConfig(), *, log=print) -> dict:
    t0 = time.time()
    samples = few_shot("test", per_interaction=config.per_interaction, seed=config.seed)
    given, total = FPS, 4 * FPS
    result: dict = {"samples": len(samples), "interactions": sorted({s.interaction for s in samples}),
                    "steps": config.steps, "seeds": config.seeds, "prefix": {}, "text": {},
                    "block_after_layer": model.denoiser.after, "base_layers": model.denoiser.prior.num_layers,
                    "mirrored": bool(model.config.get("mirrored", False)), "spacing": {}}
    truth_spacing = [spacing_figures(np.stack([s.joints_a, s.joints_b])) for s in samples]
    result["spacing"]["truth"] = _mean_figures(truth_spacing) | {"moved": 0.0}
    start_by_kind: dict[str, dict[str, list[float]]] = {}
    for s, f in zip(samples, truth_spacing):
        start_by_kind.setdefault(s.interaction, {}).setdefault("truth", []).append(f["start_min_m"])
    for method, (communicate, contact) in METHODS.items():
        errs, place_m, place_deg, timing, touched, facing = [], [], [], [], [], []
        raw_spacing, spaced, moved = [], [], []
        per_kind: dict[str, list[float]] = {}
        for k, s in enumerate(samples):
            for seed in range(config.seeds):
                seed_value = config.seed + seed
                if method in PREFIX_METHODS and len(s.joints_a) >= total + 1:
                    d = complete(model, s.joints_a, s.joints_b, communicate=communicate,
                                 sample=SampleConfig(steps=config.steps, guidance=1.0, seed=seed_value))
                    errs.append(_prefix_errors(d.joints, s.joints_a, s.joints_b, given))
                seconds = min(MAX_SECONDS, (len(s.joints_a) - 1) / FPS)
                d = text_to_duet(model, s.captions[0], seconds=seconds, communicate=communicate, contact=contact,
                                 spacing=False,
                                 sample=SampleConfig(steps=config.steps, guidance=config.guidance, seed=seed_value))
                raw_spacing.append(spacing_figures(d.joints))
                d = space_apart(d, plans_for(model.contact_table, s.captions[0])[0])  # as text_to_duet does
                spaced.append(spacing_figures(d.joints))
                moved.append(float(d.spacing.moved))
                if method == "commdm":
                    kinds = start_by_kind[s.interaction]
                    kinds.setdefault("raw", []).append(raw_spacing[-1]["start_min_m"])
                    kinds.setdefault("spaced", []).append(spaced[-1]["start_min_m"])
                dist, ang = placement_error(d.joints, s.joints_a, s.joints_b)
                place_m.append(dist)
                place_deg.append(ang)
                per_kind.setdefault(s.interaction, []).append(dist)
                for c in s.labels["contacts"]:
                    err, hit = contact_timing(c["kind"], c["start"], c["end"], d.joints[0], d.joints[1])
                    timing.append(err)
                    touched.append(hit)
                if s.interaction in FACE_TO_FACE:
                    facing.append(face_each_other(d.joints))
            log(f"[{time.time() - t0:5.0f}s] {method}: {k + 1}/{len(samples)} duets")
        if errs:
            result["prefix"][method] = {key: float(np.mean([e[key] for e in errs])) for key in errs[0]} | {"n": len(errs)}
        result["text"][method] = {
            "placement_m": float(np.mean(place_m)), "facing_deg": float(np.mean(place_deg)),
            "contact_timing_s": float(np.mean(timing)), "contact_rate": float(np.mean(touched)),
            "face_each_other": float(np.mean(facing)), "n": len(place_m),
            "placement_m_by_interaction": {k: float(np.mean(v)) for k, v in sorted(per_kind.items())},
        }
        result["spacing"][f"{method} raw"] = _mean_figures(raw_spacing) | {"moved": 0.0}
        result["spacing"][method] = _mean_figures(spaced) | {"moved": float(np.mean(moved))}
    result["spacing_start_by_interaction"] = {k: {who: float(np.min(v)) for who, v in kinds.items()}
                                              for k, kinds in sorted(start_by_kind.items())}
    lower_is_better = [("prefix", k) for k in result["prefix"]["commdm"] if k != "n"] + \
        [("text", k) for k in ("placement_m", "facing_deg", "contact_timing_s")]
    higher_is_better = [("text", k) for k in ("contact_rate", "face_each_other")]
    wins = {f"{g}.{k}": result[g]["commdm"][k] < result[g]["prior_twice"][k] for g, k in lower_is_better}
    wins |= {f"{g}.{k}": result[g]["commdm"][k] > result[g]["prior_twice"][k] for g, k in higher_is_better}
    result["beats_baseline"] = wins
    result["beats_baseline_on_every_figure"] = all(wins.values())
    result["seconds"] = time.time() - t0
    return result


def format_table(result: dict) -> str:
    block = (f"; the block after base layer {result['block_after_layer']} of {result['base_layers']}, trained "
             f"{'with' if result['mirrored'] else 'without'} mirrored duets" if "block_after_layer" in result else "")
    lines = [f"ComMDM vs the prior twice (no block): {result['samples']} held-out duets "
             f"({', '.join(result['interactions'])}), {result['steps']} steps, {result['seeds']} seed(s) each, "
             f"{result['seconds']:.0f} s{block}",
             "", f"prefix completion (1 s given, text masked, no contact guidance; n = {result['prefix']['commdm']['n']}), "
             "L2 error in m",
             f"{'method':<13}" + "".join(f"{h:>10}" for h in ("root 1s", "root 2s", "root 3s", "joint 1s",
                                                              "joint 2s", "joint 3s"))]
    for m in PREFIX_METHODS:
        r = result["prefix"][m]
        lines.append(f"{m:<13}" + "".join(f"{r[k]:>10.3f}" for k in ("root_1s", "root_2s", "root_3s", "joints_1s",
                                                                      "joints_2s", "joints_3s")))
    lines += ["", f"text-to-duet (n = {result['text']['commdm']['n']}; commdm = block + contact guidance)",
              f"{'method':<14}{'place m':>10}{'facing°':>10}{'contact s':>11}{'touched':>9}{'face2face':>11}"]
    for m in METHODS:
        r = result["text"][m]
        lines.append(f"{m:<14}{r['placement_m']:>10.3f}{r['facing_deg']:>10.1f}{r['contact_timing_s']:>11.2f}"
                     f"{r['contact_rate']:>9.2f}{r['face_each_other']:>11.2f}")
    lines += ["", "placement error by interaction (m): " + ", ".join(
        f"{k} {result['text']['commdm']['placement_m_by_interaction'][k]:.2f}/"
        f"{result['text']['prior_twice']['placement_m_by_interaction'][k]:.2f}"
        for k in result["text"]["commdm"]["placement_m_by_interaction"]) + "  (commdm/prior_twice)"]
    if result.get("spacing"):
        lines += ["", "spacing: torso distance (m) between the people, the mean over duets of each one's smallest in "
                      "the first second and anywhere; inside: the share of duets whose torsos interpenetrate in the "
                      "first second, and of all frames; moved: the share spacing moved person b in",
                  f"{'method':<18}{'start min':>10}{'clip min':>10}{'inside 1s':>11}{'inside all':>12}{'moved':>8}"]
        for m, r in result["spacing"].items():
            lines.append(f"{m:<18}{r['start_min_m']:>10.3f}{r['clip_min_m']:>10.3f}{r['inside_start']:>11.2f}"
                         f"{r['inside_frames']:>12.2f}{r['moved']:>8.2f}")
        lines.append("smallest start distance by interaction (m): " + ", ".join(
            f"{k} " + "/".join(f"{v[w]:.2f}" for w in ("truth", "raw", "spaced") if w in v)
            for k, v in result["spacing_start_by_interaction"].items()) + "  (truth/commdm raw/commdm)")
    lost = [k for k, v in result["beats_baseline"].items() if not v]
    lines.append("beats the baseline on every figure" if not lost else f"does not beat the baseline on: {', '.join(lost)}")
    return "\n".join(lines)
