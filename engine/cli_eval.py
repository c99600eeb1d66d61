"""`moattn eval` and `moattn evaluator` (train the text-motion evaluator)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from engine.paths import EVALUATOR_DIR, MODEL_DIR


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="score a model against the corpus ground truth (FID, R-precision, ...)",
                       description="Prints the model's row, the ground-truth row and a ground-truth noise-floor FID "
                       "on the test and ood splits.")
    p.add_argument("--model", type=Path, default=MODEL_DIR, help=f"model folder (default: {MODEL_DIR})")
    p.add_argument("--evaluator", type=Path, default=EVALUATOR_DIR, help=f"evaluator folder (default: {EVALUATOR_DIR})")
    p.add_argument("--quick", action="store_true", help="128 samples per split, 20 steps (under 5 minutes on 2 cores)")
    p.add_argument("--samples", type=int, default=None, help="samples per split (overrides the preset)")
    p.add_argument("--steps", type=int, default=None, help="sampling steps (overrides the preset)")
    p.add_argument("--splits", default="test,ood", help="comma-separated splits (default: test,ood)")
    p.add_argument("--gt-only", action="store_true", help="only the ground-truth rows (no model needed)")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(run=run_eval)

    e = sub.add_parser("evaluator", help="train the contrastive text-motion evaluator on the corpus train split")
    e.add_argument("--out", type=Path, default=EVALUATOR_DIR, help=f"output folder (default: {EVALUATOR_DIR})")
    e.add_argument("--steps", type=int, default=1500)
    e.add_argument("--batch-size", type=int, default=48)
    e.add_argument("--pool-size", type=int, default=3000, help="corpus motions generated once and trained on")
    e.add_argument("--seed", type=int, default=0)
    e.set_defaults(run=run_train_evaluator)


def run_eval(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from engine.checkpoint import load_model
    from engine.evaluation.evaluator import load_evaluator
    from engine.evaluation.run import EvalConfig, evaluate_split, format_table

    config = EvalConfig.quick() if args.quick else EvalConfig()
    if args.samples:
        config = replace(config, samples=args.samples)
    if args.steps:
        config = replace(config, steps=args.steps)
    evaluator = load_evaluator(args.evaluator)
    loaded = None if args.gt_only else load_model(args.model)
    splits = [s.strip() for s in args.splits.split(",") if s.strip()]
    results = {}
    for split in splits:
        def progress(done, total, split=split):
            print(f"\r[{split}] sampling {done}/{total}", end="", file=sys.stderr, flush=True)

        results[split] = evaluate_split(loaded, evaluator, split, config, progress=progress)
        print(file=sys.stderr)
    if args.json:
        first = results[splits[0]]
        payload = {**{k: first[k] for k in ("model", "ground_truth", "gt_noise_floor_fid") if k in first},
                   "split": splits[0], "splits": results,
                   "settings": {"samples": config.samples, "steps": config.steps, "guidance": config.guidance,
                                "model": str(args.model)}}
        print(json.dumps(payload, indent=2))
    else:
        print(format_table(results))
    return 0


def run_train_evaluator(args: argparse.Namespace) -> int:
    from engine.data import CorpusSource
    from engine.evaluation.evaluator import train_evaluator

    summary = train_evaluator(CorpusSource(split="train", seed=args.seed), out=args.out, steps=args.steps,
                              batch_size=args.batch_size, pool_size=args.pool_size, seed=args.seed)
    print(json.dumps(summary))
    return 0
