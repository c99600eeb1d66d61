"""`moattn bench --exports`: seconds to export a generated motion as the studio's Export buttons do.

A motion of the model's longest length (9.8 s) is generated once from a fixed prompt; each format is then
exported through ``app.tabs.files.exports.export_bytes`` (the function behind the buttons), best of ``repeats``.
The issue's targets hold for a 10-s motion on a loaded 2-core machine: GIF <= 5 s, MP4 <= 10 s. So by default the
exports run beside ``busy`` busy processes (each a Python loop spinning on one core, started after the motion is
generated and stopped after the last export); ``busy=0`` measures a quiet machine. Besides wall seconds each row
has ``cpu_s``: the CPU seconds the export used (this process and the encoder it starts), which do not depend on
how loaded the machine is. Videos are opened again to report what a user gets: width x height, frames and seconds
of play.
"""
from __future__ import annotations

import io
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

TARGETS = {"gif": 5.0, "mp4": 10.0}
PROMPT = "a person walks forward, then jumps twice"
SPIN = "while True:\n    pass\n"


@contextmanager
def busy_processes(count: int) -> Iterator[list[subprocess.Popen]]:
    """``count`` processes spinning on one core each while the block runs (stopped, by their ids, after it)."""
    procs = [subprocess.Popen([sys.executable, "-c", SPIN], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) for _ in range(max(0, int(count)))]
    try:
        time.sleep(0.2 if procs else 0.0)  # let them start spinning before the clock starts
        yield procs
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


def cpu_seconds() -> float:
    """CPU seconds used so far by this process and its finished children (ffmpeg, once its writer is closed)."""
    import resource

    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def video_info(data: bytes, fmt: str) -> dict:
    """Width, height, frames and seconds of play of a GIF or MP4 export (its bytes)."""
    if fmt == "gif":
        from PIL import Image

        with Image.open(io.BytesIO(data)) as im:
            width, height = im.size
            frames, ms = 0, 0.0
            for k in range(im.n_frames):
                im.seek(k)
                frames += 1
                ms += im.info.get("duration", 0)
        return {"width": width, "height": height, "frames": frames, "play_s": ms / 1000.0}
    if fmt == "mp4":
        import tempfile
        from pathlib import Path

        import imageio_ffmpeg

        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "video.mp4"
            path.write_bytes(data)
            reader = imageio_ffmpeg.read_frames(str(path))
            meta = next(reader)
            reader.close()
            frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(path))
        width, height = meta["size"]
        return {"width": int(width), "height": int(height), "frames": int(frames), "play_s": float(seconds)}
    raise ValueError(f"{fmt!r} is not a video export")


def bench_exports(loaded, *, formats=("bvh", "joints.npy", "glb", "gif", "mp4"), repeats: int = 1, steps: int = 20,
                  busy: int = 1, log: Callable[[str], None] = lambda s: None) -> dict:
    from app.session.items import MotionItem
    from app.tabs.files.exports import EXPORTS, export_bytes
    from engine.generate import Request, SampleConfig, generate
    from engine.units import FPS

    for fmt in formats:
        if fmt not in EXPORTS:
            raise ValueError(f"no export {fmt!r}; the studio offers {', '.join(EXPORTS)}")
    frames = loaded.model.config.max_frames
    gen = generate(loaded, Request(prompts=[PROMPT], frames=[frames]), SampleConfig(steps=steps))
    item = MotionItem(name=f"{PROMPT} · seed 0", joints=gen.joints[0], source="generated", prompt=PROMPT)
    rows = []
    with busy_processes(busy):
        for fmt in formats:
            times, cpu, data = [], [], b""
            for _ in range(max(1, repeats)):
                t0, c0 = time.perf_counter(), cpu_seconds()
                data = export_bytes(item, fmt)
                times.append(time.perf_counter() - t0)
                cpu.append(cpu_seconds() - c0)
            seconds = min(times)
            target = TARGETS.get(fmt)
            row = {"format": fmt, "seconds": seconds, "cpu_s": min(cpu), "kb": len(data) / 1024, "target_s": target,
                   "meets_target": None if target is None else seconds <= target}
            if fmt in ("gif", "mp4"):
                row.update(video_info(data, fmt))
            rows.append(row)
            log(f"{fmt}: {seconds:.2f} s ({min(cpu):.2f} CPU s), {len(data) / 1024:.0f} KB")
    return {"motion_seconds": len(item.joints) / FPS, "frames": len(item.joints), "prompt": PROMPT, "busy": busy,
            "title": item.name, "rows": rows}


def format_table(result: dict) -> str:
    busy = result.get("busy", 0)
    beside = (f"beside {busy} busy process{'es' if busy != 1 else ''} (a loop spinning on one core each)" if busy
              else "on a quiet machine")
    lines = [f"exports of a {result['motion_seconds']:.1f}-s motion ({result['frames']} frames), as the studio's "
             f"Export buttons make them, {beside}",
             "format     seconds  CPU s      KB  picture   frames  plays  target"]
    for r in result["rows"]:
        target = "" if r["target_s"] is None else f"<= {r['target_s']:g} s: {'met' if r['meets_target'] else 'MISSED'}"
        picture = f"{r['width']}x{r['height']}" if "width" in r else ""
        frames = str(r["frames"]) if "frames" in r else ""
        plays = f"{r['play_s']:.1f} s" if "play_s" in r else ""
        cpu = f"{r['cpu_s']:6.2f}" if "cpu_s" in r else " " * 6
        lines.append(f"{r['format']:<10} {r['seconds']:7.2f} {cpu} {r['kb']:7.0f}  {picture:<9} {frames:>6}  "
                     f"{plays:>6}  {target}")
    return "\n".join(lines)
