"""The studio benchmark (``moattn bench --app``): the studio in Chromium against a real server.

``moattn bench --app [--model DIR] [--prompt TEXT] [--json]`` starts ``moattn serve`` on a free
port, drives Debian's Chromium with Playwright and measures

- click -> first frame: from the Generate click until the new motion's first frame is drawn
  (sampling with the session's default settings, recording, scene build, first JPEG, transfer);
- playback fps: distinct frames drawn per second while playing (all frames loaded; target 20, the motions'
  own rate, which the player keeps: it never shows a frame early), and the frames it had to skip;
- layer switch: from choosing another layer / head / step until the heatmap canvas is redrawn
  (median and max over several switches; target <= 200 ms).

The command line lives in ``engine/cli/bench.py``; this module measures and prints.
"""
from __future__ import annotations

import json
import statistics
import time
from pathlib import Path


def _ms(x: float | None) -> float | None:
    return None if x is None else round(x, 1)


def _s(x: float | None) -> float | None:
    return None if x is None else round(x, 3)


def _one_run(pw, url: str, mode: str, *, prompt: str, play_seconds: float, layers: int,
             transfer: tuple[str, str]) -> dict:
    from app.bench import browser as br

    browser = br.launch(pw, mode)
    try:
        page = br.open_studio(browser, url)
        steps = int(page.locator(".steps-input input").input_value())
        gen = br.generate(page, prompt)
        key = gen["stats"]["motion_key"]
        stats = br.player_stats(page)
        click_wall = page.evaluate("window.moattnLastClickWall")
        first_preview = stats["preview_first"].get(str(key))
        job = stats["job"].get(str(key)) or {}
        first_frame_s = None if first_preview is None else (first_preview - page.evaluate("window.moattnLastClick")) / 1e3
        playable_s = stats["first_draw_wall"][str(key)] - click_wall
        sampling_s = job["ended"] - job["started"] if job else None
        sent, received = stats["scene_sent"].get(str(key)), stats["scene_received_wall"].get(str(key))
        # where the time after sampling goes: the server (job end -> scene built), the wire and the page's other
        # updates (-> scene received), the drawing (-> first picture)
        split = {"server_s": _s(sent - job["ended"]) if job and sent else None,
                 "to_page_s": _s(received - sent) if sent and received else None,
                 "draw_s": _s(stats["first_draw_wall"][str(key)] - received) if received else None}
        fps_1 = br.measure_draw_rate(page, play_seconds)
        orbit = br.measure_orbit(page)
        names = [f"layer {i}" for i in range(layers)]
        changes = [(".layer-select", lab) for lab in names] + [(".layer-select", "mean of layers")]
        changes += [(".head-select", "head 0"), (".head-select", "mean of heads")]
        changes += [(".layer-select", names[-1]), (".layer-select", "mean of layers")]
        switches = br.switch_timings(page, changes)
        transferred = br.run_transfer(page, leader=transfer[0], follower=transfer[1])
        fps_3 = br.measure_draw_rate(page, play_seconds)
    finally:
        browser.close()
    ok = [x for x in switches if x >= 0]
    return {
        "frames": stats["n_frames"], "steps": steps,
        "first_frame_s": _s(first_frame_s),
        "playable_s": _s(playable_s),
        "sampling_s": _s(sampling_s),
        "after_sampling": split,
        "transfer_playable_s": _s(transferred["playable_s"]),
        "transfer_roles": transferred["roles"],
        "fps_1": round(fps_1["fps"], 1),
        "fps_3": round(fps_3["fps"], 1),
        "draw_ms_1": _ms(fps_1["draw_ms"]),
        "draw_ms_3": _ms(fps_3["draw_ms"]),
        "orbit_ms": _ms(orbit["frame_ms"]),
        "orbit_changed_view": orbit["changed"],
        "layer_switch_ms": _ms(statistics.median(ok)) if ok else None,
        "layer_switch_ms_all": [round(x, 1) for x in switches],
        "layer_switch_failed": len(switches) - len(ok),
    }


TARGETS = {"first_frame_s": 1.0, "transfer_playable_s": 1.0, "fps_1": 30.0, "fps_3": 30.0, "orbit_ms": 50.0,
           "layer_switch_ms": 100.0, "gif_s": 5.0, "mp4_s": 10.0}
HIGHER_IS_BETTER = {"fps_1", "fps_3"}


def bench_app(model_dir: Path, *, prompt: str = "a person jumps twice", play_seconds: float = 3.0,
              log_path: Path | None = None, modes=("swiftshader", "software"),
              transfer: tuple[str, str] = ("a person walks forward", "a person jumps twice"),
              exports: bool = True) -> dict:
    import os

    from playwright.sync_api import sync_playwright

    from app.bench import browser as br
    from engine.checkpoint import read_config

    if not Path(model_dir).exists():
        raise FileNotFoundError(f"no model at {model_dir}")
    if not br.chromium_available():
        raise FileNotFoundError(f"{br.CHROMIUM} not found: apt-get install chromium")
    config = read_config(Path(model_dir))["model"]
    runs = {}
    with br.studio_server(model_dir, log_path=log_path) as url, sync_playwright() as pw:
        for mode in modes:
            runs[mode] = _one_run(pw, url, mode, prompt=prompt, play_seconds=play_seconds, layers=config["layers"],
                                  transfer=transfer)
    first = next(iter(runs.values()))
    export_times = {}
    if exports:  # the studio's own Export path (server-side viz.export), once: it does not depend on the browser
        from app.bench.exports import bench_exports
        from engine.checkpoint import load_model

        rows = bench_exports(load_model(Path(model_dir)), formats=("gif", "mp4"))["rows"]
        export_times = {f"{r['format']}_s": round(r["seconds"], 2) for r in rows}
    return {
        "model": str(model_dir),
        "model_config": {k: config[k] for k in ("width", "layers", "heads")},
        "prompt": prompt,
        "frames": first["frames"],
        "steps": first["steps"],
        "cpus": os.cpu_count(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "runs": runs,
        **export_times,
        "when": time.strftime("%Y-%m-%d %H:%M:%S"),
    }


def _verdict(key: str, value) -> str:
    target = TARGETS.get(key)
    if target is None or value is None:
        return ""
    met = value >= target if key in HIGHER_IS_BETTER else value <= target
    return f"(target {'>=' if key in HIGHER_IS_BETTER else '<='} {target:g}: {'met' if met else 'MISSED'})"


def run_app_bench(args) -> int:
    modes = ["swiftshader", "software"] if args.compositing == "both" else [args.compositing]
    result = bench_app(args.model, prompt=args.prompt, play_seconds=args.seconds, log_path=args.log,
                       modes=modes)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    print(f"model {result['model']} {result['model_config']}; prompt {result['prompt']!r}, "
          f"{result['frames']} frames, {result['steps']} steps; {result['cpus']} cpus, "
          f"load average {result['load_average']}")
    for mode, r in result["runs"].items():
        playable_target = None if r["sampling_s"] is None else r["sampling_s"] + 0.5
        met = "" if playable_target is None else \
            f"(target <= sampling {r['sampling_s']:.2f} s + 0.5: {'met' if r['playable_s'] <= playable_target else 'MISSED'})"
        print(f"[{mode}]")
        print(f"  click -> first frame (live x\u03020)   {r['first_frame_s']} s {_verdict('first_frame_s', r['first_frame_s'])}")
        print(f"  click -> final motion playable      {r['playable_s']} s {met}")
        a = r["after_sampling"]
        print(f"    after sampling: server {a['server_s']} s, to the page {a['to_page_s']} s, drawn {a['draw_s']} s")
        print(f"  transfer end -> {r['transfer_roles']} skeletons playable "
              f"{r['transfer_playable_s']} s {_verdict('transfer_playable_s', r['transfer_playable_s'])}")
        print(f"  playback, 1 skeleton                {r['fps_1']} fps, {r['draw_ms_1']} ms a draw {_verdict('fps_1', r['fps_1'])}")
        print(f"  playback, 3 skeletons               {r['fps_3']} fps, {r['draw_ms_3']} ms a draw {_verdict('fps_3', r['fps_3'])}")
        print(f"  orbit-drag frame time               {r['orbit_ms']} ms {_verdict('orbit_ms', r['orbit_ms'])}"
              f"{'' if r['orbit_changed_view'] else '  (the view did NOT change)'}")
        print(f"  layer switch                        median {r['layer_switch_ms']} ms {_verdict('layer_switch_ms', r['layer_switch_ms'])}"
              f", all {r['layer_switch_ms_all']}")
    for key in ("gif_s", "mp4_s"):
        if key in result:
            print(f"export {key[:-2].upper()} of a 9.8-s motion   {result[key]} s {_verdict(key, result[key])}")
    return 0
