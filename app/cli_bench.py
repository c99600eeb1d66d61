"""`moattn bench`: benchmarks. ``--app``: the studio in Chromium against a real server.

``moattn bench --app [--model DIR] [--prompt TEXT] [--json]`` starts ``moattn serve`` on a free
port, drives Debian's Chromium with Playwright and measures

- click -> first frame: from the Generate click until the new motion's first frame is drawn
  (sampling with the session's default settings, recording, scene build, first JPEG, transfer);
- playback fps: distinct frames drawn per second while playing (all frames loaded; target 20);
- layer switch: from choosing another layer / head / step until the heatmap canvas is redrawn
  (median and max over several switches; target <= 200 ms).

Other benchmark modes can join this subcommand as further flags.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    from engine.paths import MODEL_DIR

    p = sub.add_parser("bench", help="benchmarks (--app: the studio in Chromium)",
                       description="Benchmarks. --app measures the studio in Debian's Chromium against a real "
                                   "`moattn serve`: click -> first frame, playback fps, layer-switch time.")
    p.add_argument("--app", action="store_true", help="benchmark the studio in the browser")
    p.add_argument("--edits", action="store_true",
                   help="score the MotionCLR edits against corpus ground truth (engine.evaluation.bench_edits)")
    p.add_argument("--quick", action="store_true", help="with --edits: fewer samples and 20 steps")
    p.add_argument("--evaluator", type=Path, default=None, help="with --edits: evaluator folder (default assets/evaluator)")
    p.add_argument("--model", type=Path, default=MODEL_DIR, help=f"model folder (default {MODEL_DIR})")
    p.add_argument("--prompt", default="a person jumps twice")
    p.add_argument("--seconds", type=float, default=3.0, help="playback measuring window")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--log", type=Path, default=None, help="write the server's output here")
    p.add_argument("--compositing", choices=["swiftshader", "software", "both"], default="both",
                   help="Chromium compositing: SwiftShader GPU emulation, CPU (--disable-gpu), or both (default)")
    p.set_defaults(run=run)


def run_edits(args: argparse.Namespace) -> int:
    import sys

    from engine.checkpoint import load_model
    from engine.evaluation.bench_edits import EditBenchConfig, bench_edits
    from engine.evaluation.evaluator import load_evaluator
    from engine.paths import EVALUATOR_DIR

    config = EditBenchConfig.quick() if args.quick else EditBenchConfig()
    result = bench_edits(load_model(args.model), load_evaluator(args.evaluator or EVALUATOR_DIR), config,
                         log=lambda line: print(line, file=sys.stderr, flush=True))
    if args.json:
        print(json.dumps(result, indent=2, default=float))
    else:
        c = result["counting"]
        print(f"counting exact match: attention {c['attention']:.2f}  root-height baseline {c['baseline']:.2f}  "
              f"({c['samples']} motions)")
        print(f"emphasis Spearman (weight vs amplitude): {result['emphasis_spearman']:.2f}")
        r = result["replacement"]
        print(f"replacement timing IoU: {r['iou']:.2f} (same noise, no replacement: {r['iou_without_replacement']:.2f})")
        print(f"shift order accuracy: {result['shift_order_acc']:.2f}")
        e = result["example_based"]
        print(f"example-based: FID {e['fid']:.3f} diversity {e['diversity']:.3f} | perturbed noise: FID "
              f"{e['perturbed_noise_fid']:.3f} diversity {e['perturbed_noise_diversity']:.3f}")
        print("FID per edit: " + ", ".join(f"{k} {v:.3f}" for k, v in result["fid"].items() if v is not None))
    return 0


def run(args: argparse.Namespace) -> int:
    if args.edits:
        return run_edits(args)
    if not args.app:
        raise ValueError("choose a benchmark: --app (the studio in Chromium) or --edits (MotionCLR edits)")
    modes = ["swiftshader", "software"] if args.compositing == "both" else [args.compositing]
    result = bench_app(args.model, prompt=args.prompt, play_seconds=args.seconds, log_path=args.log,
                       modes=modes)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    print(f"model {result['model']} {result['model_config']}; prompt {result['prompt']!r}, "
          f"{result['frames']} frames, {result['steps']} steps; load average {result['load_average']}")
    for mode, r in result["runs"].items():
        print(f"[{mode}]")
        print(f"  click -> first frame  {r['click_to_first_frame_ms']:.0f} ms")
        print(f"  all frames ready      {r['all_frames_ready_ms']:.0f} ms after the click")
        print(f"  playback              {r['playback_fps']:.1f} fps (target >= 20)")
        print(f"  layer switch          median {r['layer_switch_ms_median']} ms, max {r['layer_switch_ms_max']} ms "
              f"(target <= 200)")
    return 0


def _one_run(pw, url: str, mode: str, *, prompt: str, play_seconds: float, layers: int) -> dict:
    from app import browser as br

    browser = br.launch(pw, mode)
    try:
        page = br.open_studio(browser, url)
        steps = int(page.locator(".steps-input input").input_value())
        gen = br.generate(page, prompt)
        t_click = page.evaluate("window.moattnLastClick")
        br.wait_all_frames(page)
        all_ready = page.evaluate("performance.now()") - t_click
        frames = br.player_stats(page)["n_frames"]
        play = br.measure_playback(page, play_seconds)
        names = [f"layer {i}" for i in range(layers)]
        changes = [(".layer-select", lab) for lab in names] + [(".layer-select", "mean of layers")]
        changes += [(".head-select", "head 0"), (".head-select", "mean of heads")]
        changes += [(".layer-select", names[-1]), (".layer-select", "mean of layers")]
        switches = br.switch_timings(page, changes)
    finally:
        browser.close()
    ok = [x for x in switches if x >= 0]
    return {
        "frames": frames, "steps": steps,
        "click_to_first_frame_ms": round(gen["click_to_first_frame_ms"], 1),
        "all_frames_ready_ms": round(all_ready, 1),
        "playback_fps": round(play["playback_fps"], 2),
        "playback_frames_counted": play["frames_drawn"],
        "layer_switch_ms": [round(x, 1) for x in switches],
        "layer_switch_ms_median": round(statistics.median(ok), 1) if ok else None,
        "layer_switch_ms_max": round(max(ok), 1) if ok else None,
        "layer_switch_failed": len(switches) - len(ok),
    }


def bench_app(model_dir: Path, *, prompt: str = "a person jumps twice", play_seconds: float = 3.0,
              log_path: Path | None = None, modes=("swiftshader", "software")) -> dict:
    import os

    from playwright.sync_api import sync_playwright

    from app import browser as br
    from engine.checkpoint import read_config

    if not Path(model_dir).exists():
        raise FileNotFoundError(f"no model at {model_dir}")
    if not br.chromium_available():
        raise FileNotFoundError(f"{br.CHROMIUM} not found: apt-get install chromium")
    config = read_config(Path(model_dir))["model"]
    runs = {}
    with br.studio_server(model_dir, log_path=log_path) as url, sync_playwright() as pw:
        for mode in modes:
            runs[mode] = _one_run(pw, url, mode, prompt=prompt, play_seconds=play_seconds, layers=config["layers"])
    first = next(iter(runs.values()))
    return {
        "model": str(model_dir),
        "model_config": {k: config[k] for k in ("width", "layers", "heads")},
        "prompt": prompt,
        "frames": first["frames"],
        "steps": first["steps"],
        "cpus": os.cpu_count(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "runs": runs,
        "when": time.strftime("%Y-%m-%d %H:%M:%S"),
    }
