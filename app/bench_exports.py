"""`moattn bench --exports`: seconds to export a generated motion as the studio's Export buttons do.

A motion of the model's longest length (9.8 s) is generated once from a fixed prompt; each format is then
exported through ``app.tabs.files.view.export_bytes`` (the function behind the buttons), best of ``repeats``.
The issue's targets for a 10-s motion on 2 cores: GIF <= 5 s, MP4 <= 10 s.
"""
from __future__ import annotations

import time
from collections.abc import Callable

TARGETS = {"gif": 5.0, "mp4": 10.0}
PROMPT = "a person walks forward, then jumps twice"


def bench_exports(loaded, *, formats=("bvh", "joints.npy", "glb", "gif", "mp4"), repeats: int = 1, steps: int = 20,
                  log: Callable[[str], None] = lambda s: None) -> dict:
    from app.session.items import MotionItem
    from app.tabs.files.exports import EXPORTS, export_bytes
    from engine.generate import Request, SampleConfig, generate
    from engine.units import FPS

    frames = loaded.model.config.max_frames
    gen = generate(loaded, Request(prompts=[PROMPT], frames=[frames]), SampleConfig(steps=steps))
    item = MotionItem(name=f"{PROMPT} · seed 0", joints=gen.joints[0], source="generated", prompt=PROMPT)
    rows = []
    for fmt in formats:
        if fmt not in EXPORTS:
            raise ValueError(f"no export {fmt!r}; the studio offers {', '.join(EXPORTS)}")
        key = fmt
        times, size = [], 0
        for _ in range(max(1, repeats)):
            t0 = time.perf_counter()
            size = len(export_bytes(item, key))
            times.append(time.perf_counter() - t0)
        seconds = min(times)
        target = TARGETS.get(fmt)
        rows.append({"format": fmt, "seconds": seconds, "kb": size / 1024, "target_s": target,
                     "meets_target": None if target is None else seconds <= target})
        log(f"{fmt}: {seconds:.2f} s, {size / 1024:.0f} KB")
    return {"motion_seconds": len(item.joints) / FPS, "frames": len(item.joints), "prompt": PROMPT, "rows": rows}


def format_table(result: dict) -> str:
    lines = [f"exports of a {result['motion_seconds']:.1f}-s motion ({result['frames']} frames), as the studio's "
             f"Export buttons make them", "format     seconds      KB  target"]
    for r in result["rows"]:
        target = "" if r["target_s"] is None else f"<= {r['target_s']:g} s: {'met' if r['meets_target'] else 'MISSED'}"
        lines.append(f"{r['format']:<10} {r['seconds']:5.2f} {r['kb']:7.0f}  {target}")
    return "\n".join(lines)
