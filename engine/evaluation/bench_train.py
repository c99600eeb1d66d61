"""`moattn bench --train`: how fast a training step runs, how close it gets to the device's matmul peak, and
whether the corpus generator keeps up.

- **Training step** of the shipped model's shape (assets/model/config.json) and of one twice as wide, at the
  trainer's batch (32) and frame count (196) on a synthetic batch (random tensors of the right shapes, a fixed
  prompt of ``prompt_words`` tokens): noise and q_sample on the CPU as the trainer draws them, the batch's copy to
  the device, forward (the model's autocast), the trainer's masked loss, backward (loss-scaled for fp16), gradient
  clipping, AdamW and the EMA update — steps/s and samples/s, the median of ``steps`` timed steps after ``warmup``.
- **FLOPs per step**: every matmul of one forward + backward (linear layers, attention's bmm / SDPA) counted by
  ``torch.utils.flop_counter.FlopCounterMode``; GFLOP/s = FLOPs per step x steps/s; the **share of peak** divides it
  by the measured peak of a large square matmul in the same precision (best of a few; fp32 on CUDA means TF32).
- **Trainer's stream**: the trainer's own loop on real corpus batches (built in-process, as ``moattn train``
  builds them by default) for the shipped shape and the machine's default precision, with random batches
  (``length_groups`` 1), with batches of similar length (TrainConfig's default), and with each item in two
  batches (``moattn train --reuse 2``): samples/s and real (unpadded)
  frames per batch — what a training hour buys.
- **Corpus generator**: samples/s of :func:`engine.data.batch_loader` on the training corpus with 0, 1, 2 and
  "several" (min(4, CPUs)) worker processes, compared with the trainer's samples/s.
"""
from __future__ import annotations

import copy
import json
import os
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch

from engine.runtime import Runtime, cpu_native_bf16

_DTYPES = {"fp32": torch.float32, "bf16": torch.bfloat16, "fp16": torch.float16}


@dataclass(frozen=True)
class Shape:
    width: int
    layers: int
    heads: int = 4
    text_layers: int = 2

    @property
    def name(self) -> str:
        return f"{self.width}x{self.layers}"


@dataclass(frozen=True)
class TrainBenchConfig:
    shapes: tuple[Shape, ...] = ()  # empty: the shipped model's shape and one twice as wide
    batch_size: int = 32
    frames: int = 196  # the trainer's max_frames default
    prompt_words: int = 12
    vocab_size: int = 512
    warmup: int = 3
    steps: int = 12  # 5 read ±15 % between runs of the same code (session 40)
    peak_size: int | None = None  # square matmul side for the peak; None: 2048 on the CPU, 8192 on CUDA
    peak_repeats: int = 5
    generator_workers: tuple[int, ...] | None = None  # None: 0, 1, 2 and min(4, CPUs)
    generator_batches: int = 30  # timed batches per worker count (after the first)
    generator_batch_size: int = 32
    velocity_weight: float = 0.5  # TrainConfig's
    grad_clip: float = 1.0
    stream_steps: int = 80  # timed steps of the trainer's stream rows (after a few warm-up steps); 0 = no rows
    stream_rows: tuple[tuple[int, int], ...] = ((1, 1), (8, 1), (8, 2))  # (length_groups, reuse) of the stream rows

    def __post_init__(self) -> None:
        if min(self.batch_size, self.frames, self.prompt_words, self.steps, self.peak_repeats,
               self.generator_batches, self.generator_batch_size) < 1 or self.warmup < 0:
            raise ValueError("batch, frames, prompt words, steps, repeats and generator batches must be >= 1")

    @classmethod
    def quick(cls) -> "TrainBenchConfig":
        return cls(warmup=1, steps=3, peak_repeats=3, generator_batches=12, stream_steps=12)


def shipped_shapes(model_dir: str | Path) -> tuple[Shape, ...]:
    """The shape in ``model_dir``/config.json and one twice as wide (same depth and heads)."""
    model = json.loads((Path(model_dir) / "config.json").read_text())["model"]
    base = Shape(width=int(model["width"]), layers=int(model["layers"]), heads=int(model["heads"]),
                 text_layers=int(model["text_layers"]))
    return base, Shape(width=2 * base.width, layers=base.layers, heads=base.heads, text_layers=base.text_layers)


def runtimes(device: str = "auto", precision: str = "auto") -> list[Runtime]:
    """The rows' runtimes: fp32 and the device's low precision where it runs natively (CPU: bf16 with
    AVX512-BF16/AMX; CUDA: bf16, or fp16 where bf16 is unsupported), or only ``precision`` when one is named
    (``--precision bf16`` times emulated bf16 on purpose). Bad devices fail here (one line)."""
    if precision != "auto":
        return [Runtime.create(device, precision, training=True)]
    auto = Runtime.create(device, "auto", training=True)
    if auto.device.type == "cpu" and not cpu_native_bf16():
        return [Runtime.create(auto.device, "fp32", training=True)]  # emulated bf16 is opt-in: slow to time
    low = "bf16" if auto.device.type == "cpu" else auto.precision
    return [Runtime.create(auto.device, "fp32", training=True), Runtime.create(auto.device, low, training=True)]


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def matmul_peak(device: torch.device, dtype: torch.dtype, *, size: int, repeats: int) -> float:
    """GFLOP/s of the best of ``repeats`` (size x size) @ (size x size) matmuls in ``dtype``."""
    gen = torch.Generator(device=device).manual_seed(0)
    a = torch.randn(size, size, device=device, dtype=dtype, generator=gen)
    b = torch.randn(size, size, device=device, dtype=dtype, generator=gen)
    torch.mm(a, b)  # warm-up
    _sync(device)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        torch.mm(a, b)
        _sync(device)
        best = min(best, time.perf_counter() - t0)
    return 2.0 * size**3 / best / 1e9


def _sdpa_cpu_flop(query_shape, key_shape, value_shape, *args, **kwargs) -> int:
    from torch.utils.flop_counter import sdpa_flop_count

    return sdpa_flop_count(query_shape, key_shape, value_shape)


def _sdpa_cpu_backward_flop(grad_out_shape, query_shape, key_shape, value_shape, *args, **kwargs) -> int:
    from torch.utils.flop_counter import sdpa_backward_flop_count

    return sdpa_backward_flop_count(grad_out_shape, query_shape, key_shape, value_shape)


def flop_counter():
    """FlopCounterMode that also counts the CPU's fused attention (the text encoder's SDPA on the CPU)."""
    from torch.utils.flop_counter import FlopCounterMode

    aten = torch.ops.aten
    mapping = {}
    if hasattr(aten, "_scaled_dot_product_flash_attention_for_cpu"):
        mapping[aten._scaled_dot_product_flash_attention_for_cpu] = _sdpa_cpu_flop
    if hasattr(aten, "_scaled_dot_product_flash_attention_for_cpu_backward"):
        mapping[aten._scaled_dot_product_flash_attention_for_cpu_backward] = _sdpa_cpu_backward_flop
    return FlopCounterMode(display=False, custom_mapping=mapping)


def synthetic_batch(config: TrainBenchConfig, vocab_size: int, *, seed: int = 0):
    """A Batch of the trainer's shape: random normalised frames with varied lengths (one full-length), a fixed
    prompt length, 10 % text dropout."""
    from engine.attention.context import BatchRoles
    from engine.data import Batch
    from engine.model.denoiser import Condition

    gen = torch.Generator().manual_seed(seed)
    b, frames, words = config.batch_size, config.frames, config.prompt_words
    lengths = torch.randint(max(1, frames // 4), frames + 1, (b,), generator=gen)
    lengths[0] = frames
    frame_mask = torch.arange(frames)[None] < lengths[:, None]
    x0 = torch.randn(b, frames, 263, generator=gen) * frame_mask[..., None]
    use_text = torch.rand(b, generator=gen) >= 0.1
    use_text[0] = True
    cond = Condition(text_ids=torch.randint(1, vocab_size, (b, words), generator=gen),
                     text_mask=torch.ones(b, words, dtype=torch.bool), frame_mask=frame_mask, use_text=use_text,
                     roles=BatchRoles.single("out", size=b))
    return Batch(x0=x0, cond=cond, captions=[""] * b)


class _Trainer:
    """One shape on one runtime: the trainer's step (engine/train.py) on a fixed synthetic batch."""

    def __init__(self, shape: Shape, runtime: Runtime, config: TrainBenchConfig):
        from engine.model.denoiser import Denoiser, ModelConfig
        from engine.train import TrainStep, adamw

        torch.manual_seed(0)
        self.config, self.runtime = config, runtime
        model_config = ModelConfig(width=shape.width, layers=shape.layers, heads=shape.heads,
                                   text_layers=shape.text_layers, dropout=0.0, vocab_size=config.vocab_size,
                                   max_frames=max(config.frames, 1))
        device = runtime.device
        model = Denoiser(model_config).to(device).train()
        model.autocast_dtype = runtime.dtype
        ema = copy.deepcopy(model).eval()
        for p in ema.parameters():
            p.requires_grad_(False)
        optimizer = adamw(model.parameters(), lr=2e-4, weight_decay=1e-2)
        self.step_of = TrainStep(model=model, net=model, ema=ema, optimizer=optimizer, runtime=runtime,
                                 generator=torch.Generator().manual_seed(1), velocity_weight=config.velocity_weight,
                                 grad_clip=config.grad_clip)
        self.model, self.optimizer = model, optimizer
        self.batch = synthetic_batch(config, config.vocab_size)
        if device.type == "cuda":
            self.batch.x0 = self.batch.x0.pin_memory()

    def loss(self) -> torch.Tensor:
        return self.step_of.loss(self.batch)[0]

    def step(self) -> None:
        self.step_of(self.batch, step=1000, lr=2e-4)

    def flops(self) -> tuple[int, int]:
        """(forward, forward + backward) matmul FLOPs of one step."""
        self.optimizer.zero_grad(set_to_none=True)
        with flop_counter() as counter:  # one block: entering the mode again would reset its counts
            loss = self.loss()
            forward = counter.get_total_flops()
            loss.backward()
        self.optimizer.zero_grad(set_to_none=True)
        return forward, counter.get_total_flops()

    def timed(self) -> float:
        """Median seconds of a step."""
        device = self.runtime.device
        for _ in range(self.config.warmup):
            self.step()
        _sync(device)
        times = []
        for _ in range(self.config.steps):
            t0 = time.perf_counter()
            self.step()
            _sync(device)
            times.append(time.perf_counter() - t0)
        return statistics.median(times)


def stream_rate(config: TrainBenchConfig, shape: Shape, runtime: Runtime, *, length_groups: int, reuse: int = 1,
                source, tokenizer, normalize, vocab_size: int) -> dict:
    """The trainer's loop on the corpus stream: batch building in-process, then the step; samples/s over
    ``config.stream_steps`` steps after 3 warm-up steps, and the real frames per padded frame."""
    from engine.data import batch_loader

    trainer = _Trainer(shape, runtime, replace(config, vocab_size=vocab_size))
    stream = batch_loader(source, tokenizer=tokenizer, normalize=normalize, batch_size=config.batch_size, seed=0,
                          max_frames=config.frames, length_groups=length_groups, reuse=reuse)
    try:
        for _ in range(3):
            trainer.step_of(next(stream), step=1000, lr=2e-4)
        _sync(runtime.device)
        samples, real, padded = 0, 0, 0
        t0 = time.perf_counter()
        for _ in range(config.stream_steps):
            batch = next(stream)
            trainer.step_of(batch, step=1000, lr=2e-4)
            samples += batch.x0.shape[0]
            real += int(batch.cond.frame_mask.sum())
            padded += batch.cond.frame_mask.numel()
        _sync(runtime.device)
        seconds = time.perf_counter() - t0
    finally:
        stream.close()
    return {"shape": shape.name, "precision": runtime.precision, "length_groups": length_groups, "reuse": reuse,
            "samples_per_s": samples / seconds, "steps_per_s": config.stream_steps / seconds,
            "real_frame_share": real / max(1, padded)}


def _generator(config: TrainBenchConfig, workers: int, *, source, tokenizer, normalize, pin: bool = False) -> float:
    from engine.data import batch_loader

    stream = batch_loader(source, tokenizer=tokenizer, normalize=normalize, batch_size=config.generator_batch_size,
                          seed=0, workers=workers, pin_memory=pin, max_frames=config.frames)
    try:
        next(stream)  # worker start-up is not part of the rate
        samples = 0
        t0 = time.perf_counter()
        for _ in range(config.generator_batches):
            samples += next(stream).x0.shape[0]
        return samples / (time.perf_counter() - t0)
    finally:
        stream.close()


def _generator_setup(model_dir: Path):
    from engine.data import CorpusSource
    from engine.representation import FEATURE_DIM, Normalizer
    from engine.text import Tokenizer

    source = CorpusSource(split="train")
    try:
        normalizer = Normalizer.load(model_dir)  # the cost is the same with any statistics
    except (OSError, ValueError):
        normalizer = Normalizer(mean=np.zeros(FEATURE_DIM), std=np.ones(FEATURE_DIM))
    return source, Tokenizer(sorted(source.words())), normalizer.normalize


def bench_train(config: TrainBenchConfig = TrainBenchConfig(), *, device: str = "auto", precision: str = "auto",
                model_dir: str | Path | None = None, log: Callable[[str], None] = lambda s: None) -> dict:
    """The training-speed benchmark as a JSON-ready dict (see the module's docstring)."""
    from engine.paths import MODEL_DIR

    started = time.perf_counter()
    rts = runtimes(device, precision)  # a device that cannot be used fails before any work
    dev = rts[0].device
    model_dir = Path(model_dir) if model_dir is not None else MODEL_DIR
    shapes = config.shapes or shipped_shapes(model_dir)
    on_cpu = dev.type == "cpu"
    result: dict = {
        "device": str(dev) if on_cpu else f"{dev} ({torch.cuda.get_device_name(dev)})",
        "cpu_capability": torch.backends.cpu.get_cpu_capability(),
        "native_bf16": cpu_native_bf16() if on_cpu else bool(torch.cuda.is_bf16_supported()),
        "threads": torch.get_num_threads(),
        "torch": torch.__version__,
        "settings": {**{k: v for k, v in asdict(config).items() if k != "shapes"},
                     "shapes": [s.name for s in shapes]},
    }
    size = config.peak_size or (2048 if on_cpu else 8192)
    result["settings"]["peak_size"] = size
    peaks = {}
    for rt in rts:
        name = rt.precision
        log(f"matmul peak {name} ({size}x{size}) on {dev}")
        peaks[name] = matmul_peak(dev, _DTYPES[name], size=size, repeats=config.peak_repeats)
    result["peak_gflops"] = peaks

    rows = []
    for shape in shapes:
        for rt in rts:
            log(f"training step {shape.name} {rt.precision} on {dev}")
            trainer = _Trainer(shape, rt, config)
            forward, total = trainer.flops()
            seconds = trainer.timed()
            gflops = total / seconds / 1e9
            rows.append({
                "shape": shape.name, "width": shape.width, "layers": shape.layers, "heads": shape.heads,
                "precision": rt.precision, "device": str(dev),
                "cpu_capability": result["cpu_capability"] if on_cpu else None,
                "native_bf16": result["native_bf16"],
                "parameters": sum(p.numel() for p in trainer.model.parameters()),
                "seconds_per_step": seconds, "steps_per_s": 1.0 / seconds,
                "samples_per_s": config.batch_size / seconds,
                "gflop_forward": forward / 1e9, "gflop_per_step": total / 1e9, "gflops": gflops,
                "share_of_peak": gflops / peaks[rt.precision],
            })
            del trainer
    result["rows"] = rows

    workers = config.generator_workers
    if workers is None:
        workers = (0, 1, 2, min(4, os.cpu_count() or 1))
    workers = tuple(dict.fromkeys(workers))
    source, tokenizer, normalize = _generator_setup(model_dir)
    fastest = max(r["samples_per_s"] for r in rows)
    generator = []
    for w in workers:
        log(f"corpus generator, {w} worker(s)")
        rate = _generator(config, w, source=source, tokenizer=tokenizer, normalize=normalize,
                          pin=dev.type == "cuda")  # as the trainer loads for a GPU
        generator.append({"workers": w, "samples_per_s": rate, "keeps_up": rate >= fastest})
    result["generator"] = generator
    result["trainer_samples_per_s"] = fastest
    result["generator_keeps_up"] = max(g["samples_per_s"] for g in generator) >= fastest
    in_process = next((g["samples_per_s"] for g in generator if g["workers"] == 0), None)
    # with workers=0 the trainer builds each batch itself: that share of a step goes to the generator
    result["in_process_generator_share"] = (None if in_process is None
                                            else (1 / in_process) / (1 / in_process + 1 / fastest))
    stream_rows = []
    if config.stream_steps:
        default = Runtime.create(dev, precision, training=True)  # what `moattn train` uses here
        for groups, reuse in config.stream_rows:
            log(f"trainer's stream {shapes[0].name} {default.precision}, length groups {groups}, reuse {reuse}")
            stream_rows.append(stream_rate(config, shapes[0], default, length_groups=groups, reuse=reuse,
                                           source=source, tokenizer=tokenizer, normalize=normalize,
                                           vocab_size=max(config.vocab_size, len(tokenizer) + 1)))
    result["stream"] = stream_rows
    result["bench_seconds"] = time.perf_counter() - started
    return result


def format_table(result: dict) -> str:
    s = result["settings"]
    dev = result["device"]
    if dev.startswith("cpu"):
        where = (f"{dev} ({result['cpu_capability']}, bf16 {'native' if result['native_bf16'] else 'emulated'}), "
                 f"{result['threads']} threads")
    else:
        where = f"{dev}, bf16 {'supported' if result['native_bf16'] else 'unsupported (fp16)'}, fp32 = TF32"
    peaks = ", ".join(f"{k} {v:,.1f}" for k, v in result["peak_gflops"].items())
    lines = [f"training step on {where}: batch {s['batch_size']} x {s['frames']} frames, prompt {s['prompt_words']} "
             f"words, median of {s['steps']} steps after {s['warmup']} warm-up",
             f"matmul peak ({s['peak_size']}x{s['peak_size']}, GFLOP/s): {peaks}",
             f"{'shape':<8}{'precision':<11}{'steps/s':>8}{'samples/s':>11}{'GFLOP/step':>12}{'GFLOP/s':>10}"
             f"{'of peak':>9}  device"]
    for r in result["rows"]:
        if r["cpu_capability"] is not None:
            note = f"cpu {r['cpu_capability']}, bf16 {'native' if r['native_bf16'] else 'emulated'}"
        else:
            note = r["device"]
        lines.append(f"{r['shape']:<8}{r['precision']:<11}{r['steps_per_s']:>8.2f}{r['samples_per_s']:>11.1f}"
                     f"{r['gflop_per_step']:>12.2f}{r['gflops']:>10.1f}{r['share_of_peak']:>8.0%}  {note}")
    lines.append(f"corpus generator (batch_loader on the train corpus, batch {s['generator_batch_size']}, "
                 f"{s['generator_batches']} batches):")
    lines.append(f"{'workers':<8}{'samples/s':>10}  vs the fastest trainer row ({result['trainer_samples_per_s']:.1f} "
                 "samples/s)")
    for g in result["generator"]:
        lines.append(f"{g['workers']:<8}{g['samples_per_s']:>10.1f}  {'keeps up' if g['keeps_up'] else 'too slow'}")
    share = result["in_process_generator_share"]
    lines.append(f"generator keeps up: {'yes' if result['generator_keeps_up'] else 'no'}"
                 + ("" if share is None else f"; with workers=0 building batches takes {share:.0%} of a step's time"))
    if result.get("stream"):
        lines.append("trainer's stream (corpus batches built in-process, the trainer's step; samples/s):")
        lines.append(f"{'shape':<8}{'precision':<11}{'length groups':>14}{'reuse':>7}{'steps/s':>9}{'samples/s':>11}"
                     f"{'real frames':>13}")
        for r in result["stream"]:
            lines.append(f"{r['shape']:<8}{r['precision']:<11}{r['length_groups']:>14}{r.get('reuse', 1):>7}"
                         f"{r['steps_per_s']:>9.2f}{r['samples_per_s']:>11.1f}{r['real_frame_share']:>12.0%}")
    lines.append(f"FLOPs: matmuls of forward + backward (FlopCounterMode); {result['bench_seconds']:.0f} s")
    return "\n".join(lines)
