"""`moattn export-model`: copy a training run's model into a shipped folder (fp16 EMA weights,
config, vocabulary, Mean/Std) with a TRAINING.md recording the exact command and its metrics."""
from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

from engine.paths import MODEL_DIR, PROJECT_ROOT

PATH_FIELDS = ("out", "data")  # training-config fields that hold folders


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("export-model", help="ship a trained run (or snapshot) as an fp16 model folder")
    p.add_argument("source", type=Path, metavar="RUN", help="training run folder (or one of its snapshots/step_*)")
    p.add_argument("--out", type=Path, default=MODEL_DIR)
    p.add_argument("--command", default="", help="the exact training command, recorded in TRAINING.md")
    p.add_argument("--eval-json", type=Path, action="append", default=[],
                   help="output of `moattn eval --json` (or other JSON reports) to record")
    p.add_argument("--note", default="", help="free text appended to TRAINING.md")
    p.set_defaults(run=run)


def portable(path: str | Path) -> str:
    """A folder as shipped files record it: relative to the project when inside it, else its name alone
    (a shipped file never carries one machine's absolute path)."""
    path = Path(path)
    if not path.is_absolute():
        return path.as_posix()
    try:
        return path.resolve().relative_to(PROJECT_ROOT).as_posix()
    except ValueError:
        return path.name


def export_model(run_dir: Path, out: Path, *, command: str, reports: list[Path], note: str = "") -> Path:
    import torch

    from engine.checkpoint import CONFIG_NAME, WEIGHTS, export_weights, read_config

    run_dir, out = Path(run_dir), Path(out)
    config = read_config(run_dir)
    train_config = config.get("train", {})
    for key in PATH_FIELDS:
        if isinstance(train_config.get(key), str) and train_config[key] != "corpus":
            train_config[key] = portable(train_config[key])
    out.mkdir(parents=True, exist_ok=True)
    if (run_dir / WEIGHTS).exists():
        state = torch.load(run_dir / WEIGHTS, map_location="cpu", weights_only=True)
    else:
        state = torch.load(run_dir / "train_state.pt", map_location="cpu", weights_only=True)["ema"]
    export_weights(out, state)
    for name in ("Mean.npy", "Std.npy"):
        shutil.copyfile(run_dir / name, out / name)
    (out / CONFIG_NAME).write_text(json.dumps(config, indent=2))
    (out / "vocabulary.txt").write_text("\n".join(config["vocabulary"]) + "\n")
    log = run_dir / "log.jsonl"
    if not log.exists() and (run_dir.parent.parent / "log.jsonl").exists():
        log = run_dir.parent.parent / "log.jsonl"  # a snapshot: the run's log
    rows = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    lines = ["# Shipped model", "", f"Exported from `{portable(run_dir)}` at training step {config.get('step')}.", ""]
    lines += ["## Command", "", "```bash", command or "(not recorded)", "```", ""]
    lines += ["## Model and training configuration", "", "```json", json.dumps(config.get("train", {}), indent=2), "```", ""]
    if rows:
        last = rows[-1]
        lines += ["## Training log (last entries)", "", "| step | mse | vel | lr | s/step |", "|---|---|---|---|---|"]
        stride = max(1, len(rows) // 12)
        for r in rows[::stride] + ([last] if rows[::stride][-1] is not last else []):
            lines.append(f"| {r['step']} | {r['mse']:.4f} | {r['vel']:.4f} | {r['lr']:.2e} | {r['s_per_step']:.2f} |")
        lines.append("")
    for report in reports:
        lines += [f"## {report.name}", "", "```json", Path(report).read_text().strip(), "```", ""]
    if note:
        lines += ["## Notes", "", note, ""]
    (out / "TRAINING.md").write_text("\n".join(lines))
    return out


def run(args: argparse.Namespace) -> int:
    out = export_model(args.source, args.out, command=args.command, reports=args.eval_json, note=args.note)
    size = sum(p.stat().st_size for p in out.iterdir()) / 1e6
    print(f"exported {args.source} -> {out} ({size:.1f} MB)")
    print(f"emphasis layers are not calibrated for this model yet: moattn bench --edits --calibrate --write --model {out}")
    return 0
