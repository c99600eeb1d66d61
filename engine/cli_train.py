"""`moattn train`: flags map one-to-one onto TrainConfig / ModelConfig fields (and, with --commdm,
onto ComTrainConfig's). A flag left out takes the default of the run's kind."""
from __future__ import annotations

import argparse
import json
from dataclasses import fields

from engine.model.denoiser import ModelConfig
from engine.runtime import DEVICE_HELP, PRECISION_HELP, autocast_dtype, resolve_device


_RUNTIME_HELP = {
    "device": DEVICE_HELP.replace("(default: auto)", "(default: auto; under torchrun on CUDA, rank r uses cuda:LOCAL_RANK)"),
    "precision": PRECISION_HELP,
}


def _configs():
    from engine.train import TrainConfig
    from engine.train_commdm import ComTrainConfig

    return TrainConfig, ComTrainConfig


def add_parser(sub: argparse._SubParsersAction) -> None:
    from pathlib import Path

    base_type, com_type = _configs()
    p = sub.add_parser(
        "train",
        help="train the denoiser on the procedural corpus (or a HumanML3D folder), or the ComMDM block",
        description="Train the motion denoiser. Checkpoints, log.jsonl and snapshots go to --out; "
        "--resume continues from the last checkpoint there (under any number of processes). Run under torchrun for "
        "data parallel: NCCL on CUDA, gloo on the CPU. "
        "With --commdm: train the two-person ComMDM block on a few corpus duets, the base model (--prior) frozen.",
    )
    base, com = base_type(), com_type()
    base_names = {f.name for f in fields(base_type)}
    for f in [*fields(base_type), *[g for g in fields(com_type) if g.name not in base_names]]:
        if f.name in ("model", "com"):
            continue
        value = getattr(base, f.name) if f.name in base_names else getattr(com, f.name)
        if f.name not in base_names:
            shown = f"--commdm only; default: {value}"
        elif hasattr(com, f.name) and getattr(com, f.name) != value:
            shown = f"default: {value}; with --commdm: {getattr(com, f.name)}"
        else:
            shown = f"default: {value}"
        flag = f"--{f.name.replace('_', '-')}"
        if f.name in _RUNTIME_HELP:
            p.add_argument(flag, default=None, help=_RUNTIME_HELP[f.name])
        elif isinstance(value, bool):
            p.add_argument(flag, action=argparse.BooleanOptionalAction, default=None, help=f"({shown})")
        else:
            p.add_argument(flag, type=type(value), default=None, help=f"({shown})")
    model_defaults = ModelConfig()
    for f in fields(ModelConfig):
        if f.name in ("feature_dim", "vocab_size", "max_frames"):
            continue
        value = getattr(model_defaults, f.name)
        p.add_argument(f"--{f.name.replace('_', '-')}", dest=f"model_{f.name}", type=type(value), default=value,
                       help=f"model {f.name} (default: {value})")
    p.add_argument("--commdm", action="store_true",
                   help="train the ComMDM two-person block (few-shot, the base model frozen)")
    p.add_argument("--commdm-after", type=int, default=0,
                   help="--commdm: the base layer the block follows (0 = the last, as in the paper)")
    p.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
    p.add_argument("--init-from", type=Path, default=None,
                   help="start from a shipped model folder (e.g. assets/model): its weights, vocabulary, stats "
                        "and step; a fresh optimizer (used when no checkpoint in --out exists)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (logs still written)")
    p.set_defaults(run=run)


def _given(args: argparse.Namespace, config_type) -> dict:
    return {f.name: getattr(args, f.name) for f in fields(config_type)
            if f.name not in ("model", "com") and getattr(args, f.name, None) is not None}


def run(args: argparse.Namespace) -> int:
    base_type, com_type = _configs()
    base_given, com_given = _given(args, base_type), _given(args, com_type)
    if args.commdm:
        return _run_commdm(args, com_given, sorted(set(base_given) - set(com_given)))
    foreign = sorted(set(com_given) - set(base_given))
    if foreign:
        raise SystemExit(f"--{foreign[0].replace('_', '-')} applies to --commdm only")
    from engine.train import train

    # refuse an unusable device or precision before any data is built
    autocast_dtype(resolve_device(base_given.get("device", "auto")), base_given.get("precision", "auto"), training=True)
    model = ModelConfig(**{f.name: getattr(args, f"model_{f.name}") for f in fields(ModelConfig)
                           if hasattr(args, f"model_{f.name}")})
    config = base_type(model=model, **base_given)
    result = train(config, resume=args.resume, progress=not args.no_progress, init_from=args.init_from,
                   given=tuple(base_given))
    print(json.dumps(result))
    return 0


def _run_commdm(args: argparse.Namespace, given: dict, unused: list[str]) -> int:
    from engine.methods.commdm import ComConfig
    from engine.train_commdm import ComTrainConfig, train_commdm

    if unused or args.init_from is not None:
        flag = unused[0].replace("_", "-") if unused else "init-from"
        raise SystemExit(f"--{flag} does not apply to --commdm (the frozen base model is --prior)")
    config = ComTrainConfig(com=ComConfig(after=args.commdm_after), **given)
    result = train_commdm(config, resume=args.resume, progress=not args.no_progress)
    print(json.dumps(result))
    return 0
