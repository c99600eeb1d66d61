"""The on-the-fly corpus: ``Corpus(split).sample(i)`` is deterministic for (seed, split, i)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from engine.representation import Normalizer, facing_direction, joints_to_features
from engine.synth.compose import Synthesis, synthesize
from engine.synth.grammar import captions as make_captions
from engine.synth.labels import Labels, build_labels
from engine.synth.program import MAX_FRAMES, Program
from engine.synth.splits import SPLIT_IDS, is_held_out, sample_program

def canonical_transform(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rotation (3, 3), shift (3,)) with canonical = rotation @ (p + shift), matching
    ``engine.representation.canonicalize`` (floor y = 0, root at the XZ origin, facing +Z)."""
    shift = np.array([-joints[0, 0, 0], -joints[..., 1].min(), -joints[0, 0, 2]])
    fx, _, fz = facing_direction(joints[0]).tolist()  # horizontal
    # the yaw taking the facing onto +Z, written out on scalars (a facing of exactly -Z is a half turn)
    norm = max(math.hypot(fx, fz), 1e-9)
    c, s = fz / norm, -fx / norm
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return rot, shift


def to_canonical(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rot, shift = canonical_transform(joints)
    return (joints + shift) @ rot.T, rot, shift


@dataclass
class Sample:
    """One corpus item: canonical joints (T, 22, 3), features (T-1, 263), captions, labels."""

    split: str
    index: int
    program: Program
    joints: np.ndarray
    features: np.ndarray
    captions: list[str]
    synthesis: Synthesis = field(repr=False)
    #: (rotation (3, 3), shift (3,)) taking the synthesis's world frame to the canonical one
    placement: tuple[np.ndarray, np.ndarray] = field(repr=False, compare=False, kw_only=True)
    held_out_template: bool = field(default=False, kw_only=True)

    @cached_property
    def labels(self) -> Labels:
        """The ground truth in the canonical frame, built on first use (training reads only features and captions:
        3 % of building a training batch saved)."""
        rotation, shift = self.placement
        return build_labels(self.synthesis, split=self.split, index=self.index, rotation=rotation, shift=shift,
                            held_out_pair=is_held_out(self.program), held_out_template=self.held_out_template)

    @property
    def local_rotations(self) -> np.ndarray:
        """Local joint rotations (T, 22, 3, 3) of the synthesis (world frame before canonicalisation)."""
        return self.synthesis.local_rotations


def make_sample(program: Program, *, split: str = "custom", index: int = 0, captions: list[str] | None = None,
                rng: np.random.Generator | None = None, held_out_template: bool = False,
                with_features: bool = True) -> Sample:
    """Synthesise a program into a :class:`Sample` (used by the corpus, transforms and tests)."""
    syn = synthesize(program)
    joints, rot, shift = to_canonical(syn.joints)
    if captions is None:
        captions = make_captions(program, rng if rng is not None else np.random.default_rng(program.seed),
                                 n=4, held_out=held_out_template)
    joints = joints.astype(np.float32)
    feats = joints_to_features(joints) if with_features else np.zeros((0, 263), np.float32)
    return Sample(split=split, index=index, program=program, joints=joints, features=feats, captions=captions,
                  synthesis=syn, placement=(rot, shift), held_out_template=held_out_template)


class Corpus:
    """Unlimited procedural corpus of one split ("train" | "test" | "ood")."""

    def __init__(self, split: str = "train", *, seed: int = 0, max_frames: int = MAX_FRAMES) -> None:
        if split not in SPLIT_IDS:
            raise ValueError(f"split must be one of {tuple(SPLIT_IDS)}, got {split!r}")
        if not 40 <= max_frames <= MAX_FRAMES:
            raise ValueError(f"max_frames must be within 40..{MAX_FRAMES}")
        self.split = split
        self.seed = int(seed)
        self.max_frames = int(max_frames)

    def rng(self, index: int) -> np.random.Generator:
        if index < 0:
            raise IndexError("corpus indices are >= 0")
        return np.random.default_rng([self.seed, SPLIT_IDS[self.split], int(index)])

    def program(self, index: int) -> tuple[Program, bool, np.random.Generator]:
        rng = self.rng(index)
        program, held_templates = sample_program(rng, self.split, max_frames=self.max_frames)
        return program, held_templates, rng

    def sample(self, index: int, *, with_features: bool = True) -> Sample:
        program, held_templates, rng = self.program(index)
        for _ in range(8):
            try:
                return make_sample(program, split=self.split, index=index, rng=rng,
                                   held_out_template=held_templates, with_features=with_features)
            except ValueError:
                # a rare draw whose repetitions do not fit its duration: draw again (deterministic)
                program, held_templates = sample_program(rng, self.split, max_frames=self.max_frames)
        raise RuntimeError(f"could not synthesise sample {index} of {self.split!r}")

    __getitem__ = sample

    def iterate(self, n: int, start: int = 0):
        for i in range(start, start + n):
            yield self.sample(i)

    def stats(self, n: int = 512, *, start: int = 0) -> Normalizer:
        """Mean/Std of the features over ``n`` samples (HumanML3D-style pooled std)."""
        feats = [self.sample(i).features for i in range(start, start + n)]
        return Normalizer.fit(np.concatenate(feats, 0))
