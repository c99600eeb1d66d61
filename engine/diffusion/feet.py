"""Denoiser wrapper: planted feet. Where the prediction's feet are on the floor, they stop sliding.

At the low-noise steps (t < ``below``) the wrapper takes the inner denoiser's clean prediction x̂0, and moves the
legs' joint positions in it (knees, ankles, toes: their "ric" features; the root and everything else stay) so that
each foot joint on the floor (lower than :data:`engine.evaluation.metrics.foot_skate`'s 5 cm in two neighbouring
frames) moves as little as it can across the floor, while each leg bone keeps its length and the change stays small.
It is a few steps of gradient descent on the joint positions, a small inverse kinematics, with the root fixed: the
root is what a control path imposes. The next denoising step sees the corrected prediction, so the model carries the
change into the rest of the body; at the last step it is what the user gets.

The term is MDM's foot contact loss (:func:`engine.diffusion.losses.foot_contact_loss`) applied at sampling time to
the model's own prediction, where the training loss applied it against the target. ``strength`` 0 is the inner
denoiser unchanged, bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from engine.representation import NUM_JOINTS, SLICES, Normalizer, features_to_joints
from engine.skeleton import FOOT_JOINTS

#: the floor height below which a foot joint counts as on the floor (the skate figure's, metres)
ON_FLOOR = 0.05
#: the joints the correction moves (knees, ankles, toes) and the leg bones whose lengths it keeps
MOVED = (4, 5, 7, 8, 10, 11)
BONES = ((1, 4), (4, 7), (7, 10), (2, 5), (5, 8), (8, 11))
FEET = (*FOOT_JOINTS["left"], *FOOT_JOINTS["right"])
#: Adam's eps for the descent. Adam steps about ``lr`` whatever a gradient's size; with its default eps (1e-8) the tiny
#: gradients of joints that need no change (a foot in the air, a bone already at length) moved them by that much a
#: step, a different way each frame: jitter that added 20 % to a walk's jerk (and 7 % to a jump with no foot to fix).
#: At 1e-4 such gradients take small steps, the feet on the floor still stop sliding, and the jerk rises 2-4 %
#: (the shipped model's walks and jumps, corrected at t = 0). Small gradients also converge slower, so the bone term
#: weighs 10: the leg bones then stay within 0.3 cm on those walks and jumps (2.2 cm at weight 1). Measurements:
#: assets/control/root/TRAINING.md, session 34.
ADAM_EPS = 1e-4
BONE_WEIGHT = 10.0
#: the moved joints' cells among the ric features (NUM_JOINTS - 1 joints x 3), and their feature dims
_MOVED_RIC = torch.zeros(NUM_JOINTS - 1, 3, dtype=torch.bool)
_MOVED_RIC[[j - 1 for j in MOVED]] = True
_MOVED_RIC = _MOVED_RIC.reshape(-1)
_MOVED_DIMS = torch.arange(SLICES["ric"].start, SLICES["ric"].stop)[_MOVED_RIC]


@dataclass
class PlantedFeet:
    """x̂0 with the legs moved so the feet on the floor stay put (see the module). ``strength``: the weight of the
    sliding term against keeping the pose (0: off); ``below``: the timesteps it acts at (t < below); ``iterations``
    and ``lr`` (metres per step) of the descent."""

    denoiser: object
    normalizer: Normalizer
    strength: float = 1.0
    below: int = 400
    iterations: int = 60  # 30 left drawn root paths sliding (skate 0.09 against 0.03) once small steps were small (ADAM_EPS)
    lr: float = 0.004
    # a frame whose lowest foot joint hovers under ON_FLOOR (or sinks under the floor) is brought onto the floor: its
    # feet on the floor aim at their heights less that gap (the legs reach down; the pelvis stays)
    ground: bool = True

    def __call__(self, x: torch.Tensor, t: torch.Tensor, cond, *, step: int = 0, controller=None) -> torch.Tensor:
        x0 = self.denoiser(x, t, cond, step=step, controller=controller)
        if self.strength <= 0 or not bool((t < self.below).any()):
            return x0
        fixed = x0.detach().float()  # (B, T, D) normalised
        mean = torch.as_tensor(np.asarray(self.normalizer.mean), dtype=torch.float32)
        std = torch.as_tensor(np.asarray(self.normalizer.std), dtype=torch.float32)
        feats = fixed * std + mean
        ric = SLICES["ric"]
        moved = _MOVED_RIC
        with torch.enable_grad():
            start = features_to_joints(feats)  # (B, T, 22, 3)
            low = (start[:, 1:, FEET, 1] < ON_FLOOR) & (start[:, :-1, FEET, 1] < ON_FLOOR)  # (B, T-1, 4)
            if not bool(low.any()):
                return x0
            low = low.float()
            feet_y = start[..., FEET, 1]  # (B, T, 4)
            gap = feet_y.min(-1).values  # the lowest foot joint's height per frame (B, T)
            gap = torch.where(gap < ON_FLOOR, gap, torch.zeros_like(gap)) if self.ground else torch.zeros_like(gap)
            aim = feet_y - gap[..., None]
            a, b = zip(*BONES)
            length = (start[:, :, list(b)] - start[:, :, list(a)]).norm(dim=-1)  # (B, T, bones)
            delta = torch.zeros(feats.shape[:-1] + (int(moved.sum()),), requires_grad=True)
            opt = torch.optim.Adam([delta], lr=self.lr, eps=ADAM_EPS)
            for _ in range(self.iterations):
                opt.zero_grad()
                values = feats[..., ric].clone()
                values[..., moved] = values[..., moved] + delta
                f = torch.cat([feats[..., :ric.start], values, feats[..., ric.stop:]], dim=-1)
                j = features_to_joints(f)
                slide = (j[:, 1:, FEET][..., [0, 2]] - j[:, :-1, FEET][..., [0, 2]]).pow(2).sum(-1)  # m^2 per frame
                # on the floor the foot keeps its height (a leg stretched to reach back would lift it), less the gap
                # that keeps the frame's lowest foot joint off the floor
                lift = (j[:, 1:, FEET, 1] - aim[:, 1:]).pow(2)
                loss_feet = ((slide + lift) * low).sum() / low.sum()
                bones = (j[:, :, list(b)] - j[:, :, list(a)]).norm(dim=-1)
                loss_bones = (bones - length).pow(2).mean()
                loss = self.strength * loss_feet + BONE_WEIGHT * loss_bones + 1e-3 * delta.pow(2).mean()
                loss.backward()
                opt.step()
        dims = _MOVED_DIMS
        result = fixed.clone()
        result[..., dims] = (feats[..., dims] + delta.detach() - mean[dims]) / std[dims]
        return result.to(x0.dtype)
