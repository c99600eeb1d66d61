"""Checkpoints: a folder with weights, a JSON config (model, training, vocabulary) and Mean/Std.

Training checkpoints (`train_state.pt`) keep fp32 weights, EMA and optimizer state for --resume.
Shipped models (`weights.pt`) keep only fp16 EMA weights. Everything loads with weights_only=True.

A folder that cannot be loaded raises :class:`ModelFolderError` (a ``ValueError``) with one line naming the
file and what is wrong: a missing, unreadable or malformed config.json, a weights file that is not plain
tensors (a pickle of other objects is never loaded) or is corrupt/truncated, weights that do not fit the
config (names, shapes, NaN), a bad Mean.npy/Std.npy. The model's size is checked on the config before
anything is allocated (at most MAX_MODEL_ELEMENTS parameters and buffers).
"""
from __future__ import annotations

import json
import math
import os
import pickle
import zipfile
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import torch

from engine.duration import Tempo, model_tempo
from engine.model.denoiser import Denoiser, ModelConfig
from engine.representation import FEATURE_DIM, Normalizer
from engine.runtime import CPU, Runtime
from engine.text import Tokenizer

CONFIG_NAME = "config.json"
TRAIN_STATE = "train_state.pt"
WEIGHTS = "weights.pt"

MAX_CONFIG_BYTES = 16 * 2**20  # a config.json larger than this (16 MiB) is refused
MAX_WEIGHTS_BYTES = 2 * 2**30  # a weights.pt / train_state.pt larger than this (2 GiB) is refused
MAX_MODEL_ELEMENTS = 200_000_000  # parameters + buffers a config may ask for (0.8 GB in fp32)
MAX_LAYERS = 64  # layers / text_layers / heads a config may ask for


class ModelFolderError(ValueError):
    """A model folder that cannot be loaded; the message (one line) names the file and the problem."""


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

    @property
    def tempo(self) -> Tempo:
        """Its count tempo: how much longer than the corpus's length a counted action's segment must be for this
        model to make the count (config.json "durations"; () = none measured)."""
        return model_tempo(self.config)


def write_config(folder: Path, *, model_config: ModelConfig, vocabulary: tuple[str, ...], extra: dict) -> None:
    write_config_json(folder, {"model": model_config.to_json(), "vocabulary": list(vocabulary), **extra})


def write_config_json(folder: Path, data: dict) -> None:
    """A folder's config.json, written atomically."""
    _atomic_write_text(Path(folder) / CONFIG_NAME, json.dumps(data, indent=2))


def read_config(folder: Path) -> dict:
    """The folder's config.json as a dict; :class:`ModelFolderError` when it is missing, too large, not UTF-8
    JSON or not a JSON object."""
    path = Path(folder) / CONFIG_NAME
    if not path.is_file():
        if not Path(folder).is_dir():
            raise ModelFolderError(f"model folder {folder} does not exist (or is not a folder)")
        raise ModelFolderError(f"no {CONFIG_NAME} in {folder}: not a model folder")
    try:
        size = path.stat().st_size
        if size > MAX_CONFIG_BYTES:
            raise ModelFolderError(f"{path} is {size / 2**20:.1f} MiB, larger than the limit of "
                                   f"{MAX_CONFIG_BYTES / 2**20:.0f} MiB for a config")
        data = json.loads(path.read_bytes().decode("utf-8"))
    except ModelFolderError:
        raise
    except OSError as exc:
        raise ModelFolderError(f"cannot read {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise ModelFolderError(f"{path} is not valid JSON: it is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise ModelFolderError(f"{path} is not valid JSON: {exc}") from None
    except RecursionError:
        raise ModelFolderError(f"{path} is not valid JSON: nested too deeply") from None
    except ValueError as exc:  # e.g. an integer with too many digits
        raise ModelFolderError(f"{path} is not valid JSON: {_one_line(exc)}") from None
    if not isinstance(data, dict):
        raise ModelFolderError(f"{path} holds a JSON {type(data).__name__}, not an object with the model's settings")
    return data


def model_config_of(config: dict, path: Path | str = CONFIG_NAME) -> ModelConfig:
    """The checked :class:`ModelConfig` of a config.json's "model" section (``path`` names the file in messages):
    known fields of the right types and sizes, a model of at most MAX_MODEL_ELEMENTS parameters and buffers."""
    section = config.get("model")
    if not isinstance(section, dict):
        raise ModelFolderError(f"{path} has no \"model\" section (an object with the network's sizes)")
    kinds = {f.name: f.type for f in fields(ModelConfig)}
    unknown = sorted(set(section) - set(kinds))
    if unknown:
        raise ModelFolderError(f"{path}: unknown model settings {unknown[:5]}")
    for name, value in section.items():
        default = getattr(ModelConfig(), name)
        if isinstance(default, bool) or not isinstance(default, (int, float)):
            continue
        if isinstance(default, int):
            least = 0 if default == 0 else 1  # a setting that is off by default (skip_path) may be 0
            if not isinstance(value, int) or isinstance(value, bool) or not least <= value <= 10**7:
                raise ModelFolderError(f"{path}: model setting {name!r} must be a whole number from {least} to "
                                       f"10,000,000, got {_short(value)}")
        elif not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
            raise ModelFolderError(f"{path}: model setting {name!r} must be a number, got {_short(value)}")
    try:
        model_config = ModelConfig.from_json(section)
    except (TypeError, ValueError) as exc:
        raise ModelFolderError(f"{path}: bad model settings: {_one_line(exc)}") from None
    for name in ("layers", "text_layers", "heads"):
        value = getattr(model_config, name, None)
        if isinstance(value, int) and value > MAX_LAYERS:
            raise ModelFolderError(f"{path}: model setting {name!r} is {value}, more than the limit of {MAX_LAYERS}")
    if model_config.feature_dim != FEATURE_DIM:
        raise ModelFolderError(f"{path}: feature_dim is {model_config.feature_dim}; motions have {FEATURE_DIM}")
    if model_config.width % model_config.heads:
        raise ModelFolderError(f"{path}: width {model_config.width} is not a multiple of heads {model_config.heads}")
    if not 0.0 <= model_config.dropout < 1.0:
        raise ModelFolderError(f"{path}: dropout must be from 0 to below 1, got {model_config.dropout}")
    elements = _elements(model_config, path)
    if elements > MAX_MODEL_ELEMENTS:
        raise ModelFolderError(f"{path}: the model would have {elements:,} parameters and buffers, more than the limit "
                               f"of {MAX_MODEL_ELEMENTS:,}")
    return model_config


def _elements(model_config: ModelConfig, path) -> int:
    """Parameters + buffers of the model a config describes, counted without allocating them."""
    w, layers, vocab, frames = model_config.width, model_config.layers, model_config.vocab_size, model_config.max_frames
    rough = (layers + model_config.text_layers + 2) * 16 * w * w + (vocab + frames + 2 * FEATURE_DIM) * w
    if rough > 4 * MAX_MODEL_ELEMENTS:  # far too large: refused before building even the meta model
        return rough
    try:
        with torch.device("meta"):
            meta = Denoiser(model_config)
    except Exception as exc:  # noqa: BLE001 - any failure to build is the config's
        raise ModelFolderError(f"{path}: these model settings do not build a network: {_one_line(exc)}") from None
    return sum(t.numel() for t in meta.parameters()) + sum(t.numel() for t in meta.buffers())


def read_tensors(path: Path, *, what: str = "weights") -> dict:
    """``torch.load(path, weights_only=True)`` of a weights/train-state file, with every failure one
    :class:`ModelFolderError` naming the file (a pickle of anything but tensors is refused, never loaded)."""
    path = Path(path)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise ModelFolderError(f"no {path.name} in {path.parent}") from None
    except OSError as exc:
        raise ModelFolderError(f"cannot read {path}: {exc.strerror or exc}") from None
    if not path.is_file():
        raise ModelFolderError(f"{path} is not a file")
    if size > MAX_WEIGHTS_BYTES:
        raise ModelFolderError(f"{path} is {size / 2**30:.1f} GiB, larger than the limit of "
                               f"{MAX_WEIGHTS_BYTES / 2**30:.0f} GiB for {what}")
    if not zipfile.is_zipfile(path):
        raise ModelFolderError(f"{path} is not a PyTorch {what} file (not the zip format torch.save writes; "
                               "truncated or corrupt?)")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError:
        # torch's own message suggests weights_only=False, i.e. running the file's code: never do that
        raise ModelFolderError(f"{path} holds Python objects other than tensors, which are never loaded "
                               f"(only plain {what} are); it is not a file this program wrote") from None
    except MemoryError:
        raise ModelFolderError(f"{path} is corrupt: it asks for more memory than is available") from None
    except Exception:  # noqa: BLE001 - a corrupt zip/record/storage surfaces as many types; none may escape
        raise ModelFolderError(f"{path} is not a readable PyTorch {what} file (truncated or corrupt)") from None
    if not isinstance(state, dict):
        raise ModelFolderError(f"{path} holds a {type(state).__name__}, not a dictionary of {what}")
    return state


def check_state(model: torch.nn.Module, state, path: Path, *, strict: bool = True) -> dict:
    """``state`` as float32 tensors that fit ``model`` (names, shapes, finite values); raises one
    :class:`ModelFolderError` naming ``path`` and the first mismatches. ``strict`` False allows missing names."""
    if not isinstance(state, dict):
        raise ModelFolderError(f"{path} holds a {type(state).__name__}, not a dictionary of weights")
    expected = model.state_dict()
    bad_values = [k for k, v in state.items() if not isinstance(k, str) or not isinstance(v, torch.Tensor)]
    if bad_values:
        raise ModelFolderError(f"{path}: entries that are not named tensors: {_names(bad_values)}")
    unexpected = sorted(set(state) - set(expected))
    missing = sorted(set(expected) - set(state)) if strict else []
    if unexpected or missing:
        parts = ([f"missing {len(missing)} ({_names(missing)})"] if missing else []) + \
                ([f"{len(unexpected)} unknown ({_names(unexpected)})"] if unexpected else [])
        raise ModelFolderError(f"{path} does not fit its {CONFIG_NAME}: weights {'; '.join(parts)}")
    shapes = [k for k, v in state.items() if tuple(v.shape) != tuple(expected[k].shape)]
    if shapes:
        k = shapes[0]
        raise ModelFolderError(f"{path} does not fit its {CONFIG_NAME}: {len(shapes)} weight(s) of the wrong shape "
                               f"(first: {k!r} is {tuple(state[k].shape)} in the file, {tuple(expected[k].shape)} "
                               "for the config)")
    out = {}
    for k, v in state.items():
        if expected[k].is_floating_point():
            if not (v.is_floating_point() or v.dtype in (torch.int8, torch.int16, torch.int32, torch.int64,
                                                         torch.uint8, torch.bool)):
                raise ModelFolderError(f"{path}: weight {k!r} holds {v.dtype} values; expected floats")
            v = v.float()
            if not torch.isfinite(v).all():
                raise ModelFolderError(f"{path}: weight {k!r} contains NaN or infinite values")
        out[k] = v
    return out


def load_normalizer(folder: str | Path) -> Normalizer:
    """Mean.npy and Std.npy of a model folder, read as data (never unpickled, header checked before reading):
    (263,) finite floats each, Std positive; :class:`ModelFolderError` naming the file otherwise."""
    from engine.io.errors import MotionIOError
    from engine.io.npy import read_array

    folder = Path(folder)
    arrays = {}
    for name in ("Mean.npy", "Std.npy"):
        path = folder / name

        def check(shape, dtype, path=path):
            if tuple(shape) != (FEATURE_DIM,) or not np.issubdtype(dtype, np.floating):
                raise ModelFolderError(
                    f"{path} holds {dtype} of shape {tuple(shape)}; expected ({FEATURE_DIM},) floats")

        try:
            arrays[name] = read_array(path, max_bytes=2**20, check=check)
        except MotionIOError as exc:
            raise ModelFolderError(f"{path}: {exc}" if str(path) not in str(exc) else str(exc)) from None
        check(arrays[name].shape, arrays[name].dtype)
    try:
        return Normalizer(mean=arrays["Mean.npy"], std=arrays["Std.npy"])
    except ValueError as exc:
        raise ModelFolderError(f"{folder}: bad Mean.npy/Std.npy: {_one_line(exc)}") from None


def _names(keys, n: int = 3) -> str:
    keys = [repr(k)[:60] for k in keys]
    return ", ".join(keys[:n]) + (", ..." if len(keys) > n else "")


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 200 else text[:197] + "..."


def save_train_state(folder: Path, state: dict) -> None:
    tmp = folder / (TRAIN_STATE + ".tmp")
    torch.save(state, tmp)
    os.replace(tmp, folder / TRAIN_STATE)


def load_train_state(folder: Path) -> dict:
    """A training checkpoint (weights_only); :class:`ModelFolderError` when it is not a readable one."""
    return read_tensors(Path(folder) / TRAIN_STATE, what="training state")


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
    config_path = folder / CONFIG_NAME
    model_config = model_config_of(config, config_path)  # checked, and its size, before anything is allocated
    vocabulary = config.get("vocabulary")
    if not isinstance(vocabulary, list) or not all(isinstance(w, str) for w in vocabulary):
        raise ModelFolderError(f"{config_path} has no \"vocabulary\" list of words")
    try:
        tokenizer = Tokenizer(vocabulary)
    except ValueError as exc:
        raise ModelFolderError(f"{config_path}: {_one_line(exc)}") from None
    if len(tokenizer) > model_config.vocab_size:
        raise ModelFolderError(f"{config_path}: {len(tokenizer) - 1} words do not fit the model's vocab_size "
                               f"{model_config.vocab_size}")
    weights_path = folder / WEIGHTS
    if prefer == "weights" and weights_path.exists():
        state, source = read_tensors(weights_path), weights_path
    elif (folder / TRAIN_STATE).exists():
        source = folder / TRAIN_STATE
        state = load_train_state(folder)
        state = state.get("ema") if isinstance(state, dict) else None
        if not isinstance(state, dict):
            raise ModelFolderError(f"{source} has no \"ema\" weights")
    elif weights_path.exists():
        state, source = read_tensors(weights_path), weights_path
    else:
        raise ModelFolderError(f"no {WEIGHTS} or {TRAIN_STATE} in {folder}")
    normalizer = load_normalizer(folder)
    model = Denoiser(model_config)
    state = check_state(model, state, source)
    try:
        model.load_state_dict(state)
    except RuntimeError as exc:
        raise ModelFolderError(f"{source} does not fit its {CONFIG_NAME}: {_one_line(exc)}") from None
    model.eval()
    for p in model.parameters():
        p.requires_grad_(False)
    model.to(runtime.device)
    model.autocast_dtype = runtime.dtype
    return LoadedModel(model=model, tokenizer=tokenizer, normalizer=normalizer, config=config, folder=folder)


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
