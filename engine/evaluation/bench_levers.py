"""`moattn bench --levers RUN...`: one row per trained model folder, for a lever screen (#32).

Each row: dev-set adherence (action, count, side; ``data/dev_prompts.txt``, never the default set, which is for
reporting), foot skate of those motions against the ground truth's, their root speed against the truth's where every
action travels ("speed": a walk in place slides no foot), the inversion round trip of one real motion
file (mean error and the inverted noise's std), and the training samples/s the run logged. Rows are meant to be
runs of equal CPU (or GPU) time from the same start, beside a control row; the noise of a figure is stated by
the spread between seeds, which the table gives for action adherence (a lever inside it is not a lever).
"""
from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engine.evaluation.bench_adherence import AdherenceBenchConfig, bench_adherence, guidance_text, read_prompts

DEV_PROMPTS = Path(__file__).with_name("data") / "dev_prompts.txt"


@dataclass(frozen=True)
class LeverBenchConfig:
    seeds: int = 4
    validation_motions: int = 500
    inversion_steps: int = 50
    guidance: float | None = None  # None: the sampling default
    guidance_from: int | None = None  # None: the sampling default
    eta: float | None = None  # None: the sampling default
    steps: int | None = None  # sampling steps; None: the sampling default
    tries: int = 1  # tries per seed, each keeping its best (engine.analysis.followed.best_try); 1: the single take

    @classmethod
    def quick(cls) -> "LeverBenchConfig":
        return cls(seeds=2, validation_motions=200, inversion_steps=20)


def logged_rate(folder: Path) -> dict:
    """Steps, samples/s and the last logged loss of the run in ``folder`` (from its log.jsonl and config.json);
    empty figures for a model folder without a log."""
    out = {"step": None, "samples_per_s": None, "mse": None}
    try:
        config = json.loads((folder / "config.json").read_text())
        out["step"] = config.get("step")
        batch = int(config["train"]["batch_size"])
        log = [json.loads(line) for line in (folder / "log.jsonl").read_text().splitlines() if line.strip()]
    except (OSError, KeyError, ValueError):
        return out
    if log:
        tail = log[-5:]
        out["samples_per_s"] = batch / float(np.mean([r["s_per_step"] for r in tail]))
        out["mse"] = float(np.mean([r["mse"] for r in tail]))
    return out


def seed_spread(result: dict, attribute: str = "action") -> float | None:
    """Standard deviation, over seeds, of the model's mean adherence for ``attribute``: the screen's noise."""
    per_seed: dict[int, list[float]] = {}
    for row in result["per_prompt"]:
        for k, v in enumerate(row.get("model_seeds", {}).get(attribute, [])):
            if v is not None:
                per_seed.setdefault(k, []).append(float(v))
    means = [np.mean(v) for v in per_seed.values() if v]
    return float(np.std(means)) if len(means) > 1 else None


def score_row(folder: Path, config: LeverBenchConfig, *, prompts: Sequence[str], real_file: Path | None,
              log: Callable[[str], None] = lambda s: None) -> dict:
    from engine.checkpoint import load_model

    t0 = time.perf_counter()
    loaded = load_model(folder)
    settings = {k: v for k, v in {"guidance": config.guidance, "guidance_from": config.guidance_from,
                                  "eta": config.eta, "steps": config.steps}.items() if v is not None}
    # the model alone: actions in order in one take of the whole prompt (a user gets them clause by clause, which
    # would score the clauses' single actions twice and hide what a lever does to sequences), and every try its own
    # (a gait held by the shipped root control model would hide what a lever does to gaits)
    adherence = bench_adherence(loaded, AdherenceBenchConfig(seeds=config.seeds, sequence="whole", tries=config.tries,
                                                             held_paths=False,
                                                             validation_motions=config.validation_motions, **settings),
                                prompts=prompts, log=log)
    row = {"model": str(folder), **logged_rate(folder), "guidance": adherence["settings"]["guidance"],
           "guidance_from": adherence["settings"]["guidance_from"], "eta": adherence["settings"]["eta"]}
    model = adherence["model"]
    for attr in ("action", "count", "side"):
        row[attr] = model[attr]
    row["action_seed_std"] = seed_spread(adherence)
    # which prompts a lever moves: each prompt's action share (None where the prompt checks no action)
    row["per_prompt_action"] = {r["prompt"]: r.get("model", {}).get("action") for r in adherence["per_prompt"]}
    row["refused"] = len(adherence["refused"])
    skate = adherence["foot_skate"]
    row["foot_skate"], row["foot_skate_vs_truth"] = skate["model"], skate["ratio"]
    row["speed_vs_truth"] = adherence["root_speed"]["ratio"]  # a walk in place slides no foot: this shows it
    row["inversion_cm"] = row["inversion_noise_std"] = None
    if real_file is not None:
        from engine.evaluation.bench_inversion import given_motions, measure

        motion = given_motions([real_file], loaded.model.config.max_frames)[0]
        r = measure(loaded, motion, config.inversion_steps, log=log)
        row["inversion_cm"], row["inversion_noise_std"] = 100 * r["mean_m"], r["noise_std"]
    row["seconds"] = time.perf_counter() - t0
    return row


def bench_levers(folders: Sequence[Path], config: LeverBenchConfig = LeverBenchConfig(), *,
                 prompts_file: Path = DEV_PROMPTS, real_file: Path | None = None,
                 log: Callable[[str], None] = lambda s: None) -> dict:
    if not folders:
        raise ValueError("--levers needs one or more model folders (a run's --out, or assets/model)")
    prompts = read_prompts(prompts_file)
    if real_file is not None:  # a file that cannot be read fails now, not after the first row's minutes
        from engine.io import load_motion

        load_motion(real_file)
    rows = [score_row(Path(f), config, prompts=prompts, real_file=real_file, log=log) for f in folders]
    return {"rows": rows, "prompts_file": str(prompts_file), "prompts": len(prompts), "seeds": config.seeds,
            "tries": config.tries,
            "real_file": None if real_file is None else Path(real_file).name}


def _f(v, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def format_table(result: dict) -> str:
    guidance = sorted({(r["guidance"], r.get("guidance_from", 0), r.get("eta", 0.0)) for r in result["rows"]})
    lines = [f"lever screen: {result['prompts']} dev prompts x {result['seeds']} seeds, guidance "
             f"{', '.join(guidance_text(g, t, e) for g, t, e in guidance)}"
             + (f" (each the best of {result['tries']} tries)" if result.get("tries", 1) > 1 else "")
             + "; actions in order in one take (the model alone)"
             + (f"; inversion of {result['real_file']}" if result["real_file"] else ""),
             f"{'model':<28}{'step':>7}{'action':>8}{'±seed':>7}{'count':>7}{'side':>6}{'skate':>7}{'vs GT':>7}"
             f"{'speed':>7}{'inv cm':>8}{'noise':>7}{'smp/s':>8}{'refused':>8}"]
    for r in result["rows"]:
        name = r["model"] if len(r["model"]) <= 27 else "…" + r["model"][-26:]
        lines.append(f"{name:<28}{_f(r['step'], 'd'):>7}{_f(r['action'], '.3f'):>8}{_f(r['action_seed_std'], '.3f'):>7}"
                     f"{_f(r['count'], '.3f'):>7}{_f(r['side'], '.2f'):>6}{_f(r['foot_skate'], '.2f'):>7}"
                     f"{_f(r['foot_skate_vs_truth'], '.1f'):>7}{_f(r.get('speed_vs_truth'), '.2f'):>7}"
                     f"{_f(r['inversion_cm'], '.1f'):>8}"
                     f"{_f(r['inversion_noise_std'], '.2f'):>7}{_f(r['samples_per_s'], '.0f'):>8}{r['refused']:>8}")
    if len(result["rows"]) > 1 and all("per_prompt_action" in r for r in result["rows"]):
        lines.append(prompt_changes(result))
    return "\n".join(lines)


def prompt_changes(result: dict, *, control: int = 0, least: float = 0.5) -> str:
    """Per row against the control row (``rows[control]``): the dev prompts whose action share moved by at least
    ``least`` (with 4 seeds, two seeds of one prompt), e.g. ``+ someone walks 0.00 -> 0.75``."""
    rows = result["rows"]
    base = rows[control].get("per_prompt_action") or {}
    lines = []
    for k, r in enumerate(rows):
        if k == control:
            continue
        moved = [(p, base[p], v) for p, v in (r.get("per_prompt_action") or {}).items()
                 if v is not None and base.get(p) is not None and abs(v - base[p]) >= least]
        lines.append(f"{r['model']} against {rows[control]['model']}: {len(moved)} prompts moved by >= {least:g}")
        lines += [f"  {'+' if v > b else '-'} {p} {b:.2f} -> {v:.2f}" for p, b, v in sorted(moved, key=lambda m: m[1] - m[2])]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m engine.evaluation.bench_levers FOLDER... [--real FILE] [--quick] [--json OUT]``: the same rows as
    ``moattn bench --levers``, for machines where only the engine is installed."""
    import argparse
    import sys

    p = argparse.ArgumentParser(prog="bench_levers", allow_abbrev=False)
    p.add_argument("folders", nargs="+", type=Path)
    p.add_argument("--real", type=Path, default=None)
    p.add_argument("--prompts", type=Path, default=DEV_PROMPTS)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--json", type=Path, default=None)
    args = p.parse_args(argv)
    config = LeverBenchConfig.quick() if args.quick else LeverBenchConfig()
    result = bench_levers(args.folders, config, prompts_file=args.prompts, real_file=args.real,
                          log=lambda s: print(s, file=sys.stderr, flush=True))
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    print(format_table(result))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
