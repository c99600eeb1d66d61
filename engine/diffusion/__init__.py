from engine.diffusion.guidance import ClassifierFreeGuidance
from engine.diffusion.sampler import CLEAN, Cancelled, StepState, ddim, ddim_invert, ddpm, final, run_loop
from engine.diffusion.schedule import CosineSchedule

__all__ = ["ClassifierFreeGuidance", "CLEAN", "Cancelled", "StepState", "ddim", "ddim_invert", "ddpm",
           "final", "run_loop", "CosineSchedule"]
