"""Action primitives: one module per action family. ``PRIMITIVES[action](ctx) -> Result``."""
from __future__ import annotations

from engine.synth.primitives.base import Context, Event, Result, State
from engine.synth.primitives import arms, body, dance, jumps, legs, locomotion

PRIMITIVES = {
    "stand": body.stand,
    "bow": body.bow,
    "walk": locomotion.gait,
    "run": locomotion.gait,
    "jog": locomotion.gait,
    "walk_backward": locomotion.gait,
    "side_step": locomotion.gait,
    "turn": locomotion.gait,
    "jump": jumps.jump,
    "jump_forward": jumps.jump,
    "hop": jumps.hop,
    "jumping_jacks": jumps.jumping_jacks,
    "squat": legs.squat,
    "kick": legs.kick,
    "punch": arms.gesture,
    "wave": arms.gesture,
    "clap": arms.gesture,
    "raise_arms": arms.gesture,
    "dance": dance.dance,
}

__all__ = ["PRIMITIVES", "Context", "Event", "Result", "State"]
