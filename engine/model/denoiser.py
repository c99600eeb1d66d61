"""The MotionCLR-style denoiser: normalised 263-dim frames + timestep + words -> predicted x0."""
from __future__ import annotations

import contextlib
import json
from dataclasses import asdict, dataclass, field, replace

import torch
from torch import nn

from engine.attention.attach import attached_controller
from engine.attention.context import BatchRoles, StepInfo, WordIndex
from engine.attention.controller import AttentionController
from engine.model.blocks import Block
from engine.representation import FEATURE_DIM
from engine.text import TextEncoder, sinusoidal
from engine.units import MAX_FRAMES



@dataclass(frozen=True)
class ModelConfig:
    width: int = 128
    layers: int = 6
    heads: int = 4
    text_layers: int = 2
    dropout: float = 0.0  # the corpus is unlimited; dropout costs ~15 % of a CPU step
    vocab_size: int = 512
    feature_dim: int = FEATURE_DIM
    max_frames: int = MAX_FRAMES
    #: the prediction's skip (EDM's c_skip, as a convex blend): x0_hat = c x_t / sqrt(alpha_bar) + (1 - c) network,
    #: c = s^2 / (sigma_t^2 + s^2), sigma_t^2 = (1 - alpha_bar) / alpha_bar. At the last sampling steps c is near 1, so
    #: the network removes the noise there instead of drawing the whole motion again (which a motion unlike the corpus
    #: never survives: the DDIM inversion round trip); at the noisy steps c is near 0 (an x0 prediction). 0: the
    #: network's output is x0_hat (every model before session 35). No weights: a fine-tune may switch it on.
    #: It acts only on the slots whose condition keeps its input (:data:`KEEP_INPUT`: training the skip path, DDIM
    #: inversion and the rebuild from inverted noise), never in generation. Screened in session 35 on every slot and
    #: in training the whole network (``--skip-sigma 0.1``, 3,000 steps from v9, assets/model/TRAINING.md): the real
    #: files' round trip fell from 61-98 cm to 9-11 cm, but generated motions kept noise the 128-wide network cannot
    #: remove (jerk 431 m/s^3 against 116). Base model v10 (session 36) keeps it to inversion.
    skip_sigma: float = 0.0
    #: hidden channels of a full-width path that denoises the skip's input (0: none; needs ``skip_sigma`` > 0).
    #: x0_hat = c (y + path(y, t)) + (1 - c) network, y = x_t / sqrt(alpha_bar): a 263 -> hidden -> 263 convolution
    #: over 3 frames, modulated by t, its last layer starting at zero (so a fine-tune that switches it on starts from
    #: the plain skip). It sees every feature dimension, which the 128-wide network cannot cancel noise in. Trained
    #: alone, the network frozen (``--skip-path-only``): base model v10.
    skip_path: int = 0

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict) -> "ModelConfig":
        known = {f for f in cls.__dataclass_fields__}
        unknown = set(data) - known
        if unknown:
            raise ValueError(f"unknown model config fields: {sorted(unknown)}")
        return cls(**data)


#: Condition.extras key: (B,) bool, the slots whose prediction keeps its input through the skip
#: (``ModelConfig.skip_sigma``): training the skip path (``--skip-path-only``, the network frozen) sets it on every
#: item, DDIM inversion and the rebuild from inverted noise on theirs. Generation leaves it out, and so does training
#: the network: the network stays the x0 prediction that generation uses, and a model whose skip path trained on it
#: generates exactly as its network did.
KEEP_INPUT = "keep_input"


@dataclass
class Condition:
    """Everything a denoiser call is conditioned on, besides x_t and t.

    text_ids/text_mask (B, L); frame_mask (B, T) True on real frames; use_text (B,) False for the
    unconditional pass; roles and words name the batch slots for attention controllers.
    """

    text_ids: torch.Tensor
    text_mask: torch.Tensor
    frame_mask: torch.Tensor
    use_text: torch.Tensor
    roles: BatchRoles
    words: WordIndex | None = None
    extras: dict = field(default_factory=dict)  # method-specific tensors (e.g. control targets)

    def __len__(self) -> int:
        return self.text_ids.shape[0]

    def keeping_input(self) -> "Condition":
        """The same condition with every slot asking the prediction's skip to act (:data:`KEEP_INPUT`)."""
        return replace(self, extras={**self.extras, KEEP_INPUT: torch.ones(len(self), dtype=torch.bool,
                                                                      device=self.text_ids.device)})

    def map_tensors(self, fn) -> "Condition":
        """The same condition with ``fn`` applied to each of its tensors (tensor extras included)."""
        return replace(self, text_ids=fn(self.text_ids), text_mask=fn(self.text_mask), frame_mask=fn(self.frame_mask),
                       use_text=fn(self.use_text),
                       extras={k: fn(v) if isinstance(v, torch.Tensor) else v for k, v in self.extras.items()})

    def to_device(self, device: torch.device) -> "Condition":
        """The same condition with its tensors on ``device``."""
        if self.text_ids.device == device:
            return self
        return self.map_tensors(lambda t: t.to(device))

    def take(self, slots: list[int]) -> "Condition":
        """The condition of these batch slots only, in this order: tensors (tensor extras too), roles and words."""
        index = torch.tensor(slots, dtype=torch.long)
        taken = self.map_tensors(lambda t: t[index.to(t.device)])
        roles = BatchRoles(names=tuple(self.roles.names[i] for i in slots),
                           uncond=tuple(self.roles.uncond[i] for i in slots))
        words = None if self.words is None else WordIndex(words=tuple(self.words.words[i] for i in slots))
        return replace(taken, roles=roles, words=words)

    def with_uncond(self) -> "Condition":
        """The CFG batch: these slots, then the same slots without text."""
        return Condition(
            text_ids=torch.cat([self.text_ids, self.text_ids]),
            text_mask=torch.cat([self.text_mask, self.text_mask]),
            frame_mask=torch.cat([self.frame_mask, self.frame_mask]),
            use_text=torch.cat([self.use_text, torch.zeros_like(self.use_text)]),
            roles=self.roles.with_uncond(),
            words=None if self.words is None else self.words.with_uncond(),
            extras={k: torch.cat([v, v]) if isinstance(v, torch.Tensor) else v for k, v in self.extras.items()},
        )


@dataclass
class LayerPass:
    """One denoiser call's shared inputs to its layers."""

    cond: Condition
    temb: torch.Tensor  # (B, width)
    text: torch.Tensor  # (B, L, width)
    info: StepInfo | None
    controller: AttentionController | None


class SkipPath(nn.Module):
    """The skip's own denoiser (``ModelConfig.skip_path``): y (B, T, D), t (B,) -> a correction (B, T, D), zero at
    start."""

    def __init__(self, *, features: int, hidden: int):
        super().__init__()
        self.conv_in = nn.Conv1d(features, hidden, kernel_size=3, padding=1)
        self.time = nn.Linear(64, 2 * hidden)
        self.conv_out = nn.Conv1d(hidden, features, kernel_size=3, padding=1)
        for p in (self.time.weight, self.time.bias, self.conv_out.weight, self.conv_out.bias):
            nn.init.zeros_(p)

    def forward(self, y: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        scale, shift = self.time(sinusoidal(t, 64).to(y.dtype))[:, :, None].chunk(2, dim=1)  # (B, hidden, 1) each
        h = self.conv_in(y.transpose(1, 2))  # (B, hidden, T)
        h = nn.functional.silu(h * (1 + scale) + shift)
        return self.conv_out(h).transpose(1, 2)  # (B, T, D)


class Denoiser(nn.Module):
    """x_t (B, T, 263), t (B,), Condition -> x0_hat (B, T, 263)."""

    def __init__(self, config: ModelConfig):
        super().__init__()
        self.config = config
        w = config.width
        self.text_encoder = TextEncoder(vocab_size=config.vocab_size, width=w, layers=config.text_layers,
                                        heads=config.heads, dropout=config.dropout)
        self.in_proj = nn.Linear(config.feature_dim, w)
        self.time_mlp = nn.Sequential(nn.Linear(w, w), nn.SiLU(), nn.Linear(w, w))
        self.blocks = nn.ModuleList(
            Block(layer=i, width=w, heads=config.heads, text_width=w, dropout=config.dropout) for i in range(config.layers)
        )
        self.out_norm = nn.LayerNorm(w)
        self.out_proj = nn.Linear(w, config.feature_dim)
        self.register_buffer("frame_pos", sinusoidal(torch.arange(config.max_frames), w), persistent=False)
        # autocast dtype of a call (None = fp32); set by the runtime that loads the model (engine.runtime)
        self.autocast_dtype: torch.dtype | None = None
        if config.skip_sigma < 0:
            raise ValueError(f"skip_sigma must be >= 0, got {config.skip_sigma:g}")
        if config.skip_sigma > 0:
            # the training schedule's alpha_bar, indexed t + 1 (t = -1: clean), for the prediction's skip; imported
            # here, not at the top: engine.diffusion's package imports this module
            from engine.diffusion.schedule import CosineSchedule

            table = torch.cat([torch.ones(1, dtype=torch.float64), CosineSchedule().alphas_cumprod]).float()
            self.register_buffer("skip_alpha_bar", table, persistent=False)
        if config.skip_path < 0 or config.skip_path > 0 and config.skip_sigma <= 0:
            raise ValueError(f"skip_path must be 0, or > 0 with skip_sigma > 0; got {config.skip_path}")
        self.skip_path = SkipPath(features=config.feature_dim, hidden=config.skip_path) if config.skip_path else None

    @property
    def device(self) -> torch.device:
        return self.frame_pos.device

    def enter(self, x: torch.Tensor, t: torch.Tensor, cond: Condition):
        """The call's inputs on the model's device (the one place tensors cross to it), and its autocast."""
        device = self.device
        if x.device != device:
            x, t, cond = x.to(device), t.to(device), cond.to_device(device)
        if self.autocast_dtype is None:  # leave any caller's autocast as it is
            return x, t, cond, contextlib.nullcontext()
        return x, t, cond, torch.autocast(device.type, dtype=self.autocast_dtype)

    @property
    def num_layers(self) -> int:
        return self.config.layers

    def encode_text(self, cond: Condition) -> torch.Tensor:
        return self.text_encoder(cond.text_ids, cond.text_mask)

    def forward(
        self,
        x: torch.Tensor,
        t: torch.Tensor,
        cond: Condition,
        *,
        step: int = 0,
        controller: AttentionController | None = None,
    ) -> torch.Tensor:
        home = x
        x, t, cond, cast = self.enter(x, t, cond)
        with cast:
            run = self.begin(t, cond, step=step, controller=controller)
            h = self.layers(self.embed_frames(x), run, range(self.num_layers))
            out = self.prediction(x, t, self.head(h), keep=cond.extras.get(KEEP_INPUT))
        return out.to(home.device, home.dtype)

    # The forward pass in three parts, for methods that act between layers (ComMDM).
    def begin(self, t: torch.Tensor, cond: Condition, *, step: int = 0, controller: AttentionController | None = None,
              text: torch.Tensor | None = None) -> "LayerPass":
        """What every layer of one call shares; ``text`` (B, L, width) replaces the model's own word encoding."""
        controller = controller if controller is not None else attached_controller(self)
        info = StepInfo(step=step, t=int(t.reshape(-1)[0]), roles=cond.roles, words=cond.words) if controller is not None else None
        temb = self.time_mlp(sinusoidal(t, self.config.width))
        return LayerPass(cond=cond, temb=temb, text=self.encode_text(cond) if text is None else text, info=info,
                         controller=controller)

    def embed_frames(self, x: torch.Tensor) -> torch.Tensor:
        """(B, T, 263) -> (B, T, width)."""
        frames = x.shape[1]
        if frames > self.config.max_frames:
            raise ValueError(f"{frames} frames exceed the model's maximum of {self.config.max_frames}")
        return self.in_proj(x) + self.frame_pos[:frames][None]

    def layers(self, h: torch.Tensor, run: "LayerPass", which: range) -> torch.Tensor:
        for i in which:
            h = self.blocks[i](h, run.temb, run.cond.frame_mask, run.text, run.cond.text_mask, run.cond.use_text,
                               info=run.info, controller=run.controller)
        return h

    def head(self, h: torch.Tensor) -> torch.Tensor:
        """(B, T, width) -> the network's output (B, T, 263): x0_hat itself, or its part beside the skip
        (:meth:`prediction`)."""
        return self.out_proj(self.out_norm(h))

    def prediction(self, x: torch.Tensor, t: torch.Tensor, out: torch.Tensor, *,
                   keep: torch.Tensor | None = None) -> torch.Tensor:
        """x0_hat (B, T, 263) from x_t (B, T, 263), t (B,) and the network's output: ``out`` itself, or on the slots
        that ``keep`` (B,) bool names (:data:`KEEP_INPUT`; None: none) blended with the skip
        (``ModelConfig.skip_sigma``)."""
        if self.config.skip_sigma <= 0 or keep is None or not bool(keep.any()):
            return out
        ab = self.skip_alpha_bar[t.long() + 1].reshape(-1, *([1] * (x.dim() - 1)))  # (B, 1, 1)
        c = self.skip_weight(t).reshape(ab.shape) * keep.to(ab.dtype).reshape(ab.shape)
        y = x / ab.sqrt()
        if self.skip_path is not None:
            y = y + self.skip_path(y, t)
        return (c * y + (1 - c) * out).to(out.dtype)

    def skip_weight(self, t: torch.Tensor) -> torch.Tensor:
        """The skip's share c = s^2 / (sigma_t^2 + s^2) at timesteps ``t`` (any shape; needs ``skip_sigma`` > 0)."""
        s = self.config.skip_sigma
        ab = self.skip_alpha_bar[t.long() + 1]
        return s * s / ((1 - ab) / ab + s * s)

    # -- persistence -------------------------------------------------------------
    def config_json(self) -> str:
        return json.dumps(self.config.to_json(), indent=2)
