"""The studio benchmark (``moattn bench --app``): the studio in Chromium against a real server.

``moattn bench --app [--model DIR] [--prompt TEXT] [--json]`` starts ``moattn serve`` on a free
port, drives Debian's Chromium with Playwright and measures

- click -> first frame: from the Generate click until the new motion's first frame is drawn
  (sampling with the session's default settings, recording, scene build, first JPEG, transfer);
- playback fps: distinct frames drawn per second while playing (all frames loaded; target 20, the motions'
  own rate, which the player keeps: it never shows a frame early), and the frames it had to skip;
- layer switch: from choosing another layer / head / step until the heatmap canvas is redrawn
  (median and max over several switches; target <= 200 ms).

The command line lives in ``engine/cli_bench.py``; this module measures and prints.
"""
from __future__ import annotations

import json
import statistics
import time
from pathlib import Path


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
        "playback_frames_skipped": play["skipped"],
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


def run_app_bench(args) -> int:
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
        print(f"  playback              {r['playback_fps']:.1f} fps (target >= 20), "
              f"{r['playback_frames_skipped']} frames skipped")
        print(f"  layer switch          median {r['layer_switch_ms_median']} ms, max {r['layer_switch_ms_max']} ms "
              f"(target <= 200)")
    return 0
