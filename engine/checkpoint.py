"""Checkpoints: a folder with weights, a JSON config (model, training, vocabulary) and Mean/Std.

Training checkpoints (`train_state.pt`) keep fp32 weights, EMA and optimizer state for --resume.
Shipped models (`weights.pt`) keep only fp16 EMA weights. Everything loads with weights_only=True.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import torch

from engine.model.denoiser import Denoiser, ModelConfig
from engine.representation import Normalizer
from engine.runtime import CPU, Runtime
from engine.text import Tokenizer

CONFIG_NAME = "config.json"
TRAIN_STATE = "train_state.pt"
WEIGHTS = "weights.pt"


@dataclass
class LoadedModel:
    model: Denoiser
    tokenizer: Tokenizer
    normalizer: Normalizer
    config: dict
    folder: Path

    @property
    def runtime(self) -> Runtime:
        """Where the model runs (its device and autocast)."""
        return Runtime(device=self.model.device, dtype=self.model.autocast_dtype)


def write_config(folder: Path, *, model_config: ModelConfig, vocabulary: tuple[str, ...], extra: dict) -> None:
    write_config_json(folder, {"model": model_config.to_json(), "vocabulary": list(vocabulary), **extra})


def write_config_json(folder: Path, data: dict) -> None:
    """A folder's config.json, written atomically."""
    _atomic_write_text(Path(folder) / CONFIG_NAME, json.dumps(data, indent=2))


def read_config(folder: Path) -> dict:
    path = Path(folder) / CONFIG_NAME
    if not path.exists():
        raise FileNotFoundError(f"no {CONFIG_NAME} in {folder}: not a model folder")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path} is not valid JSON: {exc}") from None


def save_train_state(folder: Path, state: dict) -> None:
    tmp = folder / (TRAIN_STATE + ".tmp")
    torch.save(state, tmp)
    os.replace(tmp, folder / TRAIN_STATE)


def load_train_state(folder: Path) -> dict:
    return torch.load(Path(folder) / TRAIN_STATE, map_location="cpu", weights_only=True)


def export_weights(folder: Path, ema_state: dict, *, dtype: torch.dtype = torch.float16) -> Path:
    """Write the shipped fp16 weights (floating tensors cast, others kept)."""
    out = {k: (v.to(dtype) if v.is_floating_point() else v) for k, v in ema_state.items()}
    path = folder / WEIGHTS
    tmp = folder / (WEIGHTS + ".tmp")
    torch.save(out, tmp)
    os.replace(tmp, path)
    return path


def load_model(folder: str | Path, *, prefer: str = "weights", runtime: Runtime = CPU) -> LoadedModel:
    """Load a model folder for inference (fp32 weights on ``runtime.device``, its autocast on the model);
    ``prefer`` "weights" or "ema" (train state). The files themselves are device-free."""
    folder = Path(folder)
    config = read_config(folder)
    model_config = ModelConfig.from_json(config["model"])
    model = Denoiser(model_config)
    weights_path = folder / WEIGHTS
    if prefer == "weights" and weights_path.exists():
        state = torch.load(weights_path, map_location="cpu", weights_only=True)
    elif (folder / TRAIN_STATE).exists():
        state = load_train_state(folder)["ema"]
    elif weights_path.exists():
        state = torch.load(weights_path, map_location="cpu", weights_only=True)
    else:
        raise FileNotFoundError(f"no {WEIGHTS} or {TRAIN_STATE} in {folder}")
    model.load_state_dict({k: v.float() if v.is_floating_point() else v for k, v in state.items()})
    model.eval()
    for p in model.parameters():
        p.requires_grad_(False)
    model.to(runtime.device)
    model.autocast_dtype = runtime.dtype
    tokenizer = Tokenizer(config["vocabulary"])
    normalizer = Normalizer.load(folder)
    return LoadedModel(model=model, tokenizer=tokenizer, normalizer=normalizer, config=config, folder=folder)


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
