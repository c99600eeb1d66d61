"""`moattn eval` and `moattn evaluator` (train the text-motion evaluator).

Both read the procedural corpus by default, or a HumanML3D-layout folder with ``--data DIR``
(``evaluator``: its train split and its own vocabulary; ``eval``: its test split as ground truth).
"""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
import warnings
from pathlib import Path

from engine.cli.common import check_output_folder, seed_argument
from engine.cli.options import add_sample_options, check_args
from engine.options import specs
from engine.sampling_options import SampleOptions
from engine.paths import EVALUATOR_DIR, MODEL_DIR, shown_folder
from engine.runtime import add_runtime_arguments, runtime_from_args

_GUIDANCE = ("guidance", "guidance_from", "eta")  # the sampling options eval takes as they are declared
DATA_HELP = ("a HumanML3D-layout folder (new_joint_vecs/, texts/, train.txt/val.txt/test.txt) to use instead of the "
             "procedural corpus (default: corpus)")


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="score a model against ground truth (FID, R-precision, ...): the corpus or --data DIR",
                       description="Prints the model's row, the ground-truth row and a ground-truth noise-floor FID "
                       "on the corpus's test and ood splits, or on a HumanML3D folder's test split (--data DIR).")
    p.add_argument("--model", type=Path, default=MODEL_DIR,
                   help=f"model folder (default: {shown_folder(MODEL_DIR)})")
    p.add_argument("--evaluator", type=Path, default=EVALUATOR_DIR,
                   help=f"evaluator folder (default: {shown_folder(EVALUATOR_DIR)})")
    p.add_argument("--data", default=None, metavar="DIR", help=DATA_HELP)
    p.add_argument("--quick", action="store_true", help="128 samples per split, 20 steps (under 5 minutes on 2 cores)")
    p.add_argument("--samples", type=int, default=None, help="samples per split (overrides the preset)")
    p.add_argument("--steps", type=int, default=None, help="sampling steps (overrides the preset)")
    add_sample_options(p, only=_GUIDANCE)
    p.add_argument("--splits", default=None,
                   help="comma-separated splits (default: test,ood for the corpus, test for --data)")
    p.add_argument("--gt-only", action="store_true", help="only the ground-truth rows (no model needed)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    add_runtime_arguments(p)
    p.set_defaults(run=run_eval)

    e = sub.add_parser("evaluator", help="train the contrastive text-motion evaluator on the corpus or --data DIR",
                       description="Trains the evaluator on the corpus train split, or on a HumanML3D folder's train "
                       "split with that folder's own vocabulary (--data DIR).")
    e.add_argument("--out", type=Path, default=EVALUATOR_DIR,
                   help=f"output folder (default: {shown_folder(EVALUATOR_DIR)})")
    e.add_argument("--data", default=None, metavar="DIR", help=DATA_HELP)
    e.add_argument("--steps", type=int, default=1500)
    e.add_argument("--batch-size", type=int, default=48)
    e.add_argument("--pool-size", type=int, default=None,
                   help="motions drawn once and trained on (default: 3000 corpus motions, or every item of --data's "
                        "train split)")
    e.add_argument("--seed", type=seed_argument, default=0)
    add_runtime_arguments(e)
    e.set_defaults(run=run_train_evaluator)


@contextlib.contextmanager
def _warnings_as_lines(command: str):
    """Warnings raised inside (skipped samples, unknown words) printed as one stderr line each; when the
    block fails, only its error is shown (the CLI's one line)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    for w in caught:
        print(f"moattn {command}: warning: {w.message}", file=sys.stderr)


def _data(args: argparse.Namespace) -> str | None:
    data = getattr(args, "data", None)
    return None if data is None or data == "corpus" else data


def run_eval(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from engine.checkpoint import load_model
    from engine.evaluation.evaluator import load_evaluator
    from engine.evaluation.run import EvalConfig, evaluate_split, format_table

    runtime = runtime_from_args(args)
    data = _data(args)
    config = EvalConfig.quick() if args.quick else EvalConfig()
    if args.samples:
        config = replace(config, samples=args.samples)
    if args.steps:
        config = replace(config, steps=args.steps)
    # --guidance / --guidance-from / --eta within their declared bounds (eval's --steps and --model are its own)
    check_args(args, SampleOptions, skip=[s.name for s in specs(SampleOptions) if s.name not in _GUIDANCE])
    config = replace(config, guidance=args.guidance, guidance_from=args.guidance_from, eta=args.eta)
    evaluator = load_evaluator(args.evaluator, runtime=runtime)
    loaded = None if args.gt_only else load_model(args.model, runtime=runtime)
    splits = [s.strip() for s in (args.splits or ("test,ood" if data is None else "test")).split(",") if s.strip()]
    results = {}
    for split in splits:
        def progress(done, total, split=split):
            print(f"\r[{split}] sampling {done}/{total}", end="", file=sys.stderr, flush=True)

        with _warnings_as_lines("eval"):
            results[split] = evaluate_split(loaded, evaluator, split, config, progress=progress, data=data)
            print(file=sys.stderr)
    if args.json:
        first = results[splits[0]]
        payload = {**{k: first[k] for k in ("model", "ground_truth", "gt_noise_floor_fid") if k in first},
                   "split": splits[0], "splits": results,
                   "settings": {"samples": config.samples, "steps": config.steps, "guidance": config.guidance,
                                "guidance_from": config.guidance_from, "eta": config.eta, "model": str(args.model),
                                "data": data or "corpus", "device": str(runtime.device)}}
        print(json.dumps(payload, indent=2))
    else:
        print(format_table(results))
    return 0


def run_train_evaluator(args: argparse.Namespace) -> int:
    from engine.data import CorpusSource, FolderSource
    from engine.evaluation.evaluator import train_evaluator

    check_output_folder(args.out)
    runtime = runtime_from_args(args, training=True)
    data = _data(args)
    with _warnings_as_lines("evaluator"):
        source = CorpusSource(split="train", seed=args.seed) if data is None else FolderSource(data, split="train")
    pool_size = args.pool_size if args.pool_size is not None else (3000 if data is None else None)
    summary = train_evaluator(source, out=args.out, steps=args.steps, batch_size=args.batch_size,
                              pool_size=pool_size, seed=args.seed, runtime=runtime)
    print(json.dumps({**summary, "data": data or "corpus"}))
    return 0
