"""`moattn train`: flags map one-to-one onto TrainConfig / ModelConfig fields."""
from __future__ import annotations

import argparse
import json
from dataclasses import fields
from pathlib import Path

from engine.model.denoiser import ModelConfig


def add_parser(sub: argparse._SubParsersAction) -> None:
    from engine.train import TrainConfig

    p = sub.add_parser(
        "train",
        help="train the denoiser on the procedural corpus (or a HumanML3D folder)",
        description="Train the motion denoiser. Checkpoints, log.jsonl and snapshots go to --out; "
        "--resume continues from the last checkpoint there. Run under torchrun for data parallel (gloo).",
    )
    defaults = TrainConfig()
    for f in fields(TrainConfig):
        if f.name == "model":
            continue
        value = getattr(defaults, f.name)
        if isinstance(value, bool):
            p.add_argument(f"--{f.name.replace('_', '-')}", action=argparse.BooleanOptionalAction, default=value,
                           help=f"(default: {value})")
        else:
            p.add_argument(f"--{f.name.replace('_', '-')}", type=type(value), default=value, help=f"(default: {value})")
    model_defaults = ModelConfig()
    for f in fields(ModelConfig):
        if f.name in ("feature_dim", "vocab_size", "max_frames"):
            continue
        value = getattr(model_defaults, f.name)
        p.add_argument(f"--{f.name.replace('_', '-')}", dest=f"model_{f.name}", type=type(value), default=value,
                       help=f"model {f.name} (default: {value})")
    p.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    p.add_argument("--init-from", type=Path, default=None,
                   help="start from a shipped model folder (e.g. assets/model): its weights, vocabulary, stats "
                        "and step; a fresh optimizer (used when no checkpoint in --out exists)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (logs still written)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from engine.train import TrainConfig, train

    model = ModelConfig(**{f.name: getattr(args, f"model_{f.name}") for f in fields(ModelConfig)
                           if hasattr(args, f"model_{f.name}")})
    config = TrainConfig(model=model, **{f.name: getattr(args, f.name) for f in fields(TrainConfig) if f.name != "model"})
    result = train(config, resume=args.resume, progress=not args.no_progress, init_from=args.init_from)
    print(json.dumps(result))
    return 0
