"""One home for units and defaults: frames per second, the longest motion, the default sampling settings.

The CLI, the studio, the corpus and the benches all read these; nothing else states them.
"""
from __future__ import annotations

FPS = 20  # frames per second of every motion (HumanML3D's rate)
MAX_FRAMES = 196  # the longest motion a model sees (HumanML3D's crop)
MAX_SECONDS = MAX_FRAMES / FPS  # 9.8 s
MIN_SECONDS = 1.0  # the shortest motion the studio and the CLI generate

# the default sampling config (engine.generate.SampleConfig and every bench and tab read these)
DEFAULT_STEPS = 50
DEFAULT_GUIDANCE = 2.5  # classifier-free guidance scale (MotionCLR's)
# guidance applies at the noisier timesteps t >= this (of 1000), where the action is decided; below it the
# conditional prediction alone: guidance in a limited interval (Kynkaanniemi et al. 2024). 0 = every step. On this
# project's models, guidance at the quieter steps lowers adherence (assets/model/TRAINING.md, session 25)
DEFAULT_GUIDANCE_FROM = 700
# the fresh noise each sampling step adds: 0 = deterministic DDIM, 1 = the DDPM posterior's (DDIM's eta). Stochastic
# steps keep the motion's amplitude: on this project's models feet slide less (2.6x the truth's skate, not 3.3x) and
# counts are kept more often, action adherence within the noise (assets/model/TRAINING.md, session 26). Inversion
# is always deterministic.
DEFAULT_ETA = 1.0
EDIT_SECONDS = 4.0  # the length of a motion `moattn edit` generates to edit

# a duet (ComMDM): from a prompt; a completion: the prefix given, the seconds completed
DUET_SECONDS = 5.0
DUET_PREFIX_SECONDS, DUET_COMPLETE_SECONDS = 1.0, 3.0
