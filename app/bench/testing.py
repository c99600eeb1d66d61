"""Helpers for the app's tests: a tiny model trained on the procedural corpus in about a minute."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]  # the project: where `python -m engine.cli` runs

TINY_TRAIN_ARGS = ["--steps", "40", "--width", "64", "--layers", "2", "--heads", "2", "--text-layers", "1",
                   "--batch-size", "8", "--stats-samples", "50", "--snapshot-every", "0", "--threads", "1",
                   "--no-progress"]


def tiny_model(folder: Path) -> Path:
    """Train (once) a 2-layer, 2-head model into ``folder``; reuse it if it is already there."""
    folder = Path(folder)
    if (folder / "weights.pt").exists() and (folder / "config.json").exists():
        return folder
    folder.parent.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "engine.cli", "train", "--out", str(folder), *TINY_TRAIN_ARGS]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=900)
    if done.returncode != 0 or not (folder / "weights.pt").exists():
        raise RuntimeError(f"training the tiny test model failed ({done.returncode}):\n{done.stdout[-2000:]}\n"
                           f"{done.stderr[-4000:]}")
    return folder


def tiny_duet(folder: Path, prior: Path) -> Path:
    """Train (once) a few steps of the ComMDM block on the tiny ``prior`` into ``folder``."""
    folder = Path(folder)
    if (folder / "weights.pt").exists() and (folder / "config.json").exists():
        return folder
    cmd = [sys.executable, "-m", "engine.cli", "train", "--commdm", "--prior", str(prior), "--out", str(folder),
           "--steps", "6", "--shots", "1", "--batch-size", "4", "--crop-every", "40", "--threads", "1",
           "--no-progress"]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=600)
    if done.returncode != 0 or not (folder / "weights.pt").exists():
        raise RuntimeError(f"training the tiny duet model failed ({done.returncode}):\n{done.stdout[-2000:]}\n"
                           f"{done.stderr[-4000:]}")
    return folder
