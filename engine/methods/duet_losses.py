"""What ComMDM's training optimises, and the prefix a completion is trained with.

- ``duet_losses``: L_simple on both persons' motion, its frame-to-frame velocity, and the placement.
- ``contact_loss``: the distances that make a contact (right hand to right hand, each wrist to the
  other's chest, left hand to left hand: a set that maps onto itself when the scene is mirrored, so a
  mirrored training duet's contact counts as the original's), measured on the predicted people put
  together by the predicted placement,
  against the same distances in the truth. Plain feature MSE places people well but leaves their
  hands 20–30 cm apart; this term is what makes them touch.
- ``prefix_cells``: the cells a completion knows (the first frames of both people and the
  placement). Training gives them noise-free (sqrt(alpha_bar)·x0, PriorMDM Algorithm 1) and
  ``duet.complete`` samples them the same way (Algorithm 2).
"""
from __future__ import annotations

import torch

from engine.methods.commdm import PLACE_DIMS
from engine.representation import Normalizer, features_to_joints
from engine.skeleton import JOINT_INDEX
from engine.diffusion.losses import masked_losses

RW, LW, CHEST = JOINT_INDEX["right_wrist"], JOINT_INDEX["left_wrist"], JOINT_INDEX["spine3"]


def duet_losses(x0_hat: torch.Tensor, x0: torch.Tensor, frame_mask: torch.Tensor) -> tuple[torch.Tensor, ...]:
    """(motion mse, motion velocity mse, placement mse) on packed duet states (B, T + 1, D)."""
    mse, vel = masked_losses(x0_hat[:, :-1], x0[:, :-1], frame_mask[:, :-1])
    place = ((x0_hat[:, -1, :PLACE_DIMS] - x0[:, -1, :PLACE_DIMS]) ** 2).mean()
    return mse, vel, place


def place_seen_from_a(joints_b: torch.Tensor, place: torch.Tensor) -> torch.Tensor:
    """Person b's canonical joints (P, T, J, 3) put where ``place`` (P, 4: x, z, cos, sin — b seen from a)
    says, in person a's canonical frame (the same rotation as ``commdm.Pose.place``)."""
    yaw = torch.atan2(place[:, 3], place[:, 2])[:, None, None]  # (P, 1, 1)
    c, s = torch.cos(yaw), torch.sin(yaw)
    x, y, z = joints_b.unbind(-1)
    return torch.stack([c * x + s * z + place[:, 0, None, None], y, -s * x + c * z + place[:, 1, None, None]], -1)


# the columns of contact_distances, and the column each becomes when the scene is mirrored (left <-> right)
CONTACT_PAIRS = ("right hands", "a's left wrist to b's chest", "a's right wrist to b's chest",
                 "b's left wrist to a's chest", "b's right wrist to a's chest", "left hands")
MIRRORED_COLUMNS = (5, 2, 1, 4, 3, 0)


def contact_distances(ja: torch.Tensor, jb: torch.Tensor) -> torch.Tensor:
    """(P, T, 22, 3) twice, one frame -> (P, T, 6): right hand to right hand, each wrist of each
    person to the other's chest, left hand to left hand (``CONTACT_PAIRS``)."""
    pairs = ((ja[..., RW, :], jb[..., RW, :]), (ja[..., LW, :], jb[..., CHEST, :]), (ja[..., RW, :], jb[..., CHEST, :]),
             (jb[..., LW, :], ja[..., CHEST, :]), (jb[..., RW, :], ja[..., CHEST, :]), (ja[..., LW, :], jb[..., LW, :]))
    return torch.stack([torch.linalg.vector_norm(p - q, dim=-1) for p, q in pairs], dim=-1)


def _together(x: torch.Tensor, normalizer: Normalizer) -> torch.Tensor:
    """Duet states (2P, T + 1, D) (a slots, then b slots) -> contact distances (P, T, 6)."""
    p = x.shape[0] // 2
    joints = features_to_joints(normalizer.denormalize(x[:, :-1]))  # (2P, T, 22, 3)
    return contact_distances(joints[:p], place_seen_from_a(joints[p:], x[:p, -1, :PLACE_DIMS]))


def contact_loss(x0_hat: torch.Tensor, x0: torch.Tensor, frame_mask: torch.Tensor, *, normalizer: Normalizer,
                 near: float = 0.5, far_weight: float = 0.1) -> torch.Tensor:
    """Mean |d̂ − d| (m) over the contact distances; distances the truth has under ``near`` count
    fully, the rest ``far_weight`` (only how close people come matters, not how far apart they walk)."""
    p = x0.shape[0] // 2
    d_hat = _together(x0_hat, normalizer)
    with torch.no_grad():
        d = _together(x0, normalizer)
        real = (frame_mask[:p, :-1] & frame_mask[p:, :-1])[..., None].float()  # (P, T, 1)
        w = real * torch.where(d < near, 1.0, far_weight)
    return ((d_hat - d).abs() * w).sum() / w.sum().clamp_min(1e-6)


def prefix_cells(x0: torch.Tensor, pairs: torch.Tensor, given: int) -> torch.Tensor:
    """The known cells (2P, T + 1, D) bool of the pairs chosen by ``pairs`` (P,) bool: the first
    ``given`` frames of both people and the placement row."""
    both = pairs.repeat(2)
    mask = torch.zeros_like(x0, dtype=torch.bool)
    mask[both, :given] = True
    mask[both, -1, :PLACE_DIMS] = True
    return mask
