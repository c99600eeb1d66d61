"""The few-shot two-person data ComMDM trains and is scored on (the corpus's interactions).

A pair item holds both persons' normalised features, each in the person's own canonical frame,
and each person's placement of the other. Cropping (later start frames, re-canonicalised) and
mirroring multiply the few samples, as in the paper ("we augment the data by randomly mirroring
and cropping each sequence"): a mirrored pair is the scene reflected left <-> right, both people
together (x -> -x in their shared frame, each left joint swapped with its right partner, "left"
and "right" swapped in the captions), so person a stays person a, a right-hand handshake becomes
a left-hand one and b stands on a's other side.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import torch

from engine.methods.commdm import PLACE_DIMS, Pose, mean_pose, pack, placements
from engine.representation import Normalizer, joints_to_features
from engine.skeleton import mirror_joints
from engine.synth.duet import DUET_CAPTIONS, INTERACTIONS, DuetCorpus, DuetSample

MIN_FRAMES = 60  # the shortest crop used for training


def few_shot(split: str, *, per_interaction: int, seed: int = 0) -> list[DuetSample]:
    """The first ``per_interaction`` samples of every interaction in ``split`` (a balanced few-shot set)."""
    if per_interaction < 1:
        raise ValueError("per_interaction must be at least 1")
    corpus = DuetCorpus(split, seed=seed)
    found: dict[str, list[DuetSample]] = {k: [] for k in INTERACTIONS}
    index = 0
    while any(len(v) < per_interaction for v in found.values()):
        s = corpus.sample(index)
        if len(found[s.interaction]) < per_interaction:
            found[s.interaction].append(s)
        index += 1
        if index > 1000 * per_interaction:
            raise RuntimeError("the duet corpus does not cover every interaction")
    return [s for k in INTERACTIONS for s in found[k]]


def duet_words() -> list[str]:
    """Every word of the duet captions (sorted)."""
    return sorted({w for caps in DUET_CAPTIONS.values() for c in caps for w in re.findall(r"[a-z]+", c.lower())})


@dataclass
class PairItem:
    motion: torch.Tensor  # (2, T, D) normalised, persons a then b, each in its own canonical frame
    place: torch.Tensor  # (2, 4): b seen from a, a seen from b
    captions: list[str]
    interaction: str


_SIDES = {"left": "right", "right": "left"}


def mirror_caption(text: str) -> str:
    """A caption of the mirrored scene: "left" and "right" swapped (other words kept)."""
    return re.sub(r"\b(left|right)\b", lambda m: _SIDES[m.group(1)], text)


def pair_item(sample: DuetSample, normalizer: Normalizer, *, start: int = 0, mirror: bool = False) -> PairItem:
    """Both people from frame ``start``; ``mirror``: the scene reflected left <-> right (both people together)."""
    ja, jb = sample.joints_a[start:], sample.joints_b[start:]
    captions = list(sample.captions)
    if mirror:
        ja, jb = mirror_joints(ja), mirror_joints(jb)
        captions = [mirror_caption(c) for c in captions]
    feats = np.stack([joints_to_features(ja), joints_to_features(jb)])
    b_from_a, a_from_b = placements(ja, jb)
    return PairItem(motion=torch.from_numpy(normalizer.normalize(feats)).float(),
                    place=torch.from_numpy(np.stack([b_from_a.vector(), a_from_b.vector()])),
                    captions=captions, interaction=sample.interaction)


def training_items(samples: list[DuetSample], normalizer: Normalizer, *, crop_every: int = 10,
                   mirror: bool = True) -> list[PairItem]:
    """Every sample from its first frame and from later starts (every ``crop_every`` frames) while
    at least MIN_FRAMES remain; with ``mirror`` (the default, as the paper) each of those crops mirrored too."""
    items = []
    for s in samples:
        last = len(s.joints_a) - 1 - MIN_FRAMES
        for start in range(0, max(0, last) + 1, crop_every):
            items.append(pair_item(s, normalizer, start=start))
            if mirror:
                items.append(pair_item(s, normalizer, start=start, mirror=True))
    return items


def mean_placement(items: list[PairItem]) -> Pose:
    """The mean of where b stands seen from a (the no-communication baseline's fixed guess)."""
    return mean_pose([Pose.of_vector(it.place[0].numpy()) for it in items])


def stack_pairs(items: list[PairItem]) -> tuple[torch.Tensor, torch.Tensor]:
    """Pairs -> duet states (2P, T + 1, D) (all a slots, then all b slots) and frame masks (2P, T + 1)."""
    frames = max(it.motion.shape[1] for it in items)
    dim = items[0].motion.shape[2]
    p = len(items)
    motion = torch.zeros(2 * p, frames, dim)
    place = torch.zeros(2 * p, PLACE_DIMS)
    mask = torch.zeros(2 * p, frames + 1, dtype=torch.bool)
    for k, it in enumerate(items):
        n = it.motion.shape[1]
        for person in (0, 1):
            row = k + person * p
            motion[row, :n] = it.motion[person]
            place[row] = it.place[person]
            mask[row, :n] = True
    return pack(motion, place), mask
