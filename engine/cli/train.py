"""`moattn train base|control|duet`: one subcommand per trainer, each with only its own flags.

Flags map one-to-one onto the trainer's config fields (TrainConfig and ModelConfig for base and control,
ComTrainConfig for duet); a flag left out takes that trainer's default. ``moattn train --...`` without a
subcommand still works as before: it is read as ``base``, ``control`` (with ``--control``) or ``duet`` (with
``--commdm``), so the commands in every TRAINING.md keep running.
"""
from __future__ import annotations

import argparse
import json
from dataclasses import fields
from pathlib import Path

from engine.methods.commdm import ComConfig
from engine.model.denoiser import ModelConfig
from engine.paths import shown_default
from engine.runtime import DEVICE_HELP, PRECISION_HELP, autocast_dtype, resolve_device

TRAINERS = ("base", "control", "duet")
_RUNTIME_HELP = {
    "device": DEVICE_HELP.replace("(default: auto)", "(default: auto; under torchrun on CUDA, rank r uses cuda:LOCAL_RANK)"),
    "precision": PRECISION_HELP,
}
# base-trainer fields a control fine-tune does not take (it keeps its base's architecture and data)
_NOT_FOR_CONTROL = ("data", "underspecified", "plain_verbs", "styled_captions", "focus_actions", "focus_share",
                    "focus_counted", "focus_intense", "keep_intensity")


def _configs():
    from engine.train import TrainConfig
    from engine.train_commdm import ComTrainConfig

    return TrainConfig, ComTrainConfig


def _add_config_flags(p: argparse.ArgumentParser, config_type, *, skip: tuple[str, ...] = ()) -> None:
    default = config_type()
    for f in fields(config_type):
        if f.name in ("model", "com", *skip):
            continue
        value = getattr(default, f.name)
        flag = f"--{f.name.replace('_', '-')}"
        said = f"{f.metadata['help']} " if "help" in f.metadata else ""  # the field's own help, where it has one
        if f.name in _RUNTIME_HELP:
            p.add_argument(flag, default=None, help=_RUNTIME_HELP[f.name])
        elif isinstance(value, bool):
            p.add_argument(flag, action=argparse.BooleanOptionalAction, default=None, help=f"{said}(default: {value})")
        else:
            p.add_argument(flag, type=type(value), default=None, help=f"{said}(default: {shown_default(value)})")


def _add_model_flags(p: argparse.ArgumentParser) -> None:
    model_defaults = ModelConfig()
    for f in fields(ModelConfig):
        if f.name in ("feature_dim", "vocab_size", "max_frames"):
            continue
        value = getattr(model_defaults, f.name)
        p.add_argument(f"--{f.name.replace('_', '-')}", dest=f"model_{f.name}", type=type(value), default=value,
                       help=f"model {f.name} (default: {value})")


def add_parser(sub: argparse._SubParsersAction) -> None:
    base_type, com_type = _configs()
    p = sub.add_parser("train", help="train the base denoiser, a control model, or the ComMDM duet block",
                       description="moattn train base|control|duet [flags]. Checkpoints, log.jsonl and snapshots go to "
                       "--out; --resume continues from the last checkpoint there (under any number of processes). "
                       "Run base under torchrun for data parallel: NCCL on CUDA, gloo on the CPU.")
    trainers = p.add_subparsers(dest="trainer", metavar="TRAINER")
    trainers.required = True

    b = trainers.add_parser("base", help="the denoiser on the procedural corpus (or a HumanML3D folder, --data)")
    _add_config_flags(b, base_type, skip=("control",))
    _add_model_flags(b)
    b.add_argument("--init-from", type=Path, default=None,
                   help="start from a shipped model folder (e.g. assets/model): its weights, vocabulary, stats and "
                        "step; a fresh optimizer (used when no checkpoint in --out exists)")
    b.add_argument("--fresh-schedule", action="store_true",
                   help="with --init-from: fine-tune with this call's hyper-parameters (--lr, --warmup, levers), "
                        "steps counted from 0, the model folder's architecture")

    c = trainers.add_parser("control", help="fine-tune a control model from a base (PriorMDM Algorithm 1)")
    c.add_argument("--control", required=True, choices=("root", "left_wrist", "right_wrist"),
                   help="the features the model receives noise-free")
    c.add_argument("--init-from", type=Path, required=True, help="the base model folder it is fine-tuned from")
    _add_config_flags(c, base_type, skip=("control", *_NOT_FOR_CONTROL))

    d = trainers.add_parser("duet", help="the ComMDM two-person block on a few corpus duets, the base (--prior) frozen")
    _add_config_flags(d, com_type)
    after = next(f for f in fields(ComConfig) if f.name == "after")  # declared once, on the block's config
    d.add_argument("--commdm-after", type=int, default=after.default, help=f"{after.metadata['help']} (default: "
                   f"{after.default})")

    for t in (b, c, d):
        t.add_argument("--resume", action="store_true", help="continue from the checkpoint in --out")
        t.add_argument("--no-progress", action="store_true", help="no progress bar (logs still written)")
        t.set_defaults(run=run)


def legacy_argv(argv: list[str]) -> list[str]:
    """``train --...`` as before the subcommands: ``train base|control|duet --...`` (``--commdm`` -> duet,
    ``--control X`` -> control)."""
    if not argv or argv[0] != "train" or len(argv) > 1 and argv[1] in (*TRAINERS, "-h", "--help"):
        return argv
    rest = argv[1:]
    if "--commdm" in rest:
        return ["train", "duet", *[a for a in rest if a != "--commdm"]]
    if any(a == "--control" or a.startswith("--control=") for a in rest):
        return ["train", "control", *rest]
    return ["train", "base", *rest]


def _given(args: argparse.Namespace, config_type) -> dict:
    return {f.name: getattr(args, f.name) for f in fields(config_type)
            if f.name not in ("model", "com") and getattr(args, f.name, None) is not None}


def run(args: argparse.Namespace) -> int:
    if args.trainer == "duet":
        return _run_duet(args)
    from engine.train import train

    base_type, _ = _configs()
    given = _given(args, base_type)
    # refuse an unusable device or precision before any data is built
    autocast_dtype(resolve_device(given.get("device", "auto")), given.get("precision", "auto"), training=True)
    model = ModelConfig(**{f.name: getattr(args, f"model_{f.name}") for f in fields(ModelConfig)
                           if hasattr(args, f"model_{f.name}")})
    config = base_type(model=model, **given)
    fresh = getattr(args, "fresh_schedule", False)
    if fresh and args.init_from is None:
        raise SystemExit("moattn train: --fresh-schedule needs --init-from (the model it fine-tunes)")
    result = train(config, resume=args.resume, progress=not args.no_progress, init_from=args.init_from,
                   given=tuple(given), fresh_schedule=fresh)
    print(json.dumps(result))
    return 0


def _run_duet(args: argparse.Namespace) -> int:
    from engine.train_commdm import ComTrainConfig, train_commdm

    config = ComTrainConfig(com=ComConfig(after=args.commdm_after), **_given(args, ComTrainConfig))
    result = train_commdm(config, resume=args.resume, progress=not args.no_progress)
    print(json.dumps(result))
    return 0
