from engine.model.denoiser import MAX_FRAMES, Condition, Denoiser, ModelConfig

__all__ = ["MAX_FRAMES", "Condition", "Denoiser", "ModelConfig"]
