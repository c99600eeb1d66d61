"""`moattn bench --sampling`: the core's speed, and what fewer steps cost in quality.

- **Seconds** for one 6-s motion (batch 1, classifier-free guidance) at 10, 20 and 50 DDIM steps:
  the median of ``repeats`` runs after a warm-up. DDPM with 1000 steps, the baseline, is opt-in
  (``ddpm=True``, ``moattn bench --sampling --ddpm``): it is 12.5 times the sampling steps of the three
  DDIM rows together, and its adherence and FID made the bench run for more than half an hour.
- **Adherence** per setting (``engine.evaluation.adherence``, reliable checks only) on a spread
  subset of the adherence prompts, and **FID** per setting against corpus test motions (the
  shipped evaluator), so steps can be traded against quality.
- **Recording overhead**: 50 steps while recording self- and cross-attention maps the way the
  studio does (10 steps, evenly spread, conditional half), as a ratio to plain sampling.

Cost (:func:`sampling_steps` counts it): the default run samples about 1,200 steps of one motion and 80 steps
of a batch of 32 (FID), a few minutes on 2 CPU cores; ``--quick`` about half of that. ``full()``
(``--full``) is the old thoroughness: 16 prompts, FID on 64 motions, 3 repeats, 500 validation motions and
the DDPM row, some 20,000 single-motion steps and 2,160 batched ones (over half an hour on 2 cores).
"""
from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from engine.generate import FPS, Request, SampleConfig, generate

SETTINGS = {"10": ("ddim", 10), "20": ("ddim", 20), "50": ("ddim", 50), "ddpm1000": ("ddpm", 1000)}
DEFAULT_SETTINGS = ("10", "20", "50")  # "ddpm1000" only when asked for (SamplingBenchConfig.ddpm, --ddpm)
STUDIO_RECORD_STEPS = 10  # the studio's default (app.session.state.StudioState.record_steps)


@dataclass(frozen=True)
class SamplingBenchConfig:
    seconds: float = 6.0
    repeats: int = 2
    guidance: float = SampleConfig().guidance
    prompts: int = 8  # adherence prompts per setting (spread over the set)
    seeds: int = 1
    fid_samples: int = 32  # one batch per setting
    validation_motions: int = 200
    ddpm: bool = False  # add the DDPM-1000 row (slow: see the module's docstring)

    def __post_init__(self) -> None:
        if self.repeats < 1 or self.prompts < 1 or self.seeds < 1 or self.fid_samples < 2:
            raise ValueError("repeats, prompts and seeds must be >= 1 and fid_samples >= 2")

    @property
    def settings(self) -> dict[str, tuple[str, int]]:
        """The rows this run measures: name -> (sampler, steps)."""
        names = DEFAULT_SETTINGS + (("ddpm1000",) if self.ddpm else ())
        return {name: SETTINGS[name] for name in names}

    @classmethod
    def quick(cls) -> "SamplingBenchConfig":
        return cls(repeats=1, prompts=4, fid_samples=16, validation_motions=100)

    @classmethod
    def full(cls) -> "SamplingBenchConfig":
        """The thorough run (the default before the bench had to be quick): more prompts, FID samples and
        repeats, and the DDPM-1000 row."""
        return cls(repeats=3, prompts=16, fid_samples=64, validation_motions=500, ddpm=True)


FID_BATCH = 32


def sampling_steps(config: SamplingBenchConfig, prompts: int | None = None) -> dict[str, int]:
    """What a run costs, counted in sampling steps: ``single`` steps of one motion (speed rows with their warm-up,
    recording overhead, adherence) and ``batched`` steps of up to FID_BATCH motions (FID). ``prompts``: the
    adherence prompts actually used (default ``config.prompts``)."""
    prompts = config.prompts if prompts is None else prompts
    rows = config.settings.values()
    speed = sum(steps * (2 if steps > 100 else config.repeats + 1) for _, steps in rows)
    recording = 2 * (config.repeats + 1) * 50
    adherence = prompts * config.seeds * sum(steps for _, steps in rows)
    batches = -(-config.fid_samples // FID_BATCH)
    return {"single": speed + recording + adherence, "batched": batches * sum(steps for _, steps in rows)}


def _time(fn: Callable[[], object], repeats: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def _record_steps(num_steps: int, n: int) -> frozenset[int]:
    return frozenset(int(round(x)) for x in np.linspace(0, num_steps - 1, min(n, num_steps)))


def bench_sampling(loaded, evaluator, config: SamplingBenchConfig = SamplingBenchConfig(), *,
                   prompts: Sequence[str] | None = None, log: Callable[[str], None] = lambda s: None) -> dict:
    from engine.attention.store import AttentionStore, StoreConfig
    from engine.evaluation.adherence import check_motion, ground_truth_motion, reliability, score, validate
    from engine.evaluation.bench_adherence import read_prompts
    from engine.evaluation.metrics import fid
    from engine.evaluation.run import load_split
    from engine.intent import parse_intent

    t_start = time.perf_counter()
    frames = int(round(config.seconds * FPS))
    request = Request(prompts=["a person walks forward then jumps twice"], frames=[frames])
    seconds = {}
    rows_measured = config.settings
    for name, (sampler, steps) in rows_measured.items():
        sc = SampleConfig(steps=steps, guidance=config.guidance, sampler=sampler)
        seconds[name] = _time(lambda: generate(loaded, request, sc), 1 if steps > 100 else config.repeats)
        log(f"{name}: {seconds[name]:.3f} s")
    plain = SampleConfig(steps=50, guidance=config.guidance)

    def recorded():
        store = AttentionStore(StoreConfig(kinds=("self", "cross"), steps=_record_steps(50, STUDIO_RECORD_STEPS),
                                           conditional_only=True))
        return generate(loaded, request, plain, controller=store)

    t_rec = _time(recorded, config.repeats)
    t_plain = _time(lambda: generate(loaded, request, plain), config.repeats)
    log(f"recording: {t_rec:.3f} s vs {t_plain:.3f} s")

    # quality per setting
    every = read_prompts() if prompts is None else list(prompts)
    pick = [every[int(i)] for i in np.linspace(0, len(every) - 1, min(config.prompts, len(every)))]
    intents = [parse_intent(p) for p in pick]
    intents = [(p, it) for p, it in zip(pick, intents) if it.segments and not loaded.tokenizer.unknown_words(p)]
    reliable = reliability(validate(motions=config.validation_motions))
    lengths = {(p, k): len(ground_truth_motion(it, 1000 * i + k)) - 1
               for i, (p, it) in enumerate(intents) for k in range(config.seeds)}
    gt = load_split("test", count=config.fid_samples)
    reference = evaluator.motion_embeddings(gt.features)
    adherence, fids = {}, {}
    for name, (sampler, steps) in rows_measured.items():
        sc = dict(steps=steps, guidance=config.guidance, sampler=sampler)
        rows = []
        for p, it in intents:
            for k in range(config.seeds):
                n = min(lengths[(p, k)], loaded.model.config.max_frames)
                gen = generate(loaded, Request(prompts=[p], frames=[n]), SampleConfig(seed=k, **sc))
                rows.append(check_motion(gen.joints[0], it, reliable=reliable))
        adherence[name] = score(rows)
        feats = []
        for start in range(0, config.fid_samples, FID_BATCH):
            caps = gt.captions[start:start + FID_BATCH]
            lens = [len(f) for f in gt.features[start:start + FID_BATCH]]
            gen = generate(loaded, Request(prompts=caps, frames=lens), SampleConfig(seed=start, **sc))
            feats += [gen.features[i, :n] for i, n in enumerate(lens)]
        fids[name] = fid(evaluator.motion_embeddings(feats), reference)
        log(f"{name}: adherence {adherence[name]['action']}, FID {fids[name]:.3f}")
    return {"seconds": seconds, "record_overhead": t_rec / t_plain,
            "record_seconds": {"recording": t_rec, "plain": t_plain}, "adherence": adherence, "fid": fids,
            "settings": {"motion_seconds": config.seconds, "guidance": config.guidance, "repeats": config.repeats,
                         "prompts": len(intents), "seeds": config.seeds, "fid_samples": config.fid_samples,
                         "rows": list(rows_measured), "sampling_steps": sampling_steps(config, len(intents)),
                         "threads": torch.get_num_threads()},
            "bench_seconds": time.perf_counter() - t_start}


def format_table(result: dict) -> str:
    s = result["settings"]
    head = f"{'setting':<10}{'seconds':>9}{'action':>8}{'count':>7}{'side':>7}{'order':>7}{'FID':>8}"
    rows = s.get("rows", list(result["seconds"]))
    once = "; ddpm1000 once" if "ddpm1000" in rows else ""
    lines = [f"one {s['motion_seconds']:g}-s motion, guidance {s['guidance']}, {s['threads']} threads "
             f"(median of {s['repeats']}{once}):", head]

    def f(v):
        return "     -" if v is None else f"{v:6.2f}"

    for name in rows:
        a = result["adherence"][name]
        label = f"ddim {name}" if name != "ddpm1000" else "ddpm 1000"
        lines.append(f"{label:<10}{result['seconds'][name]:>9.3f} {f(a['action'])} {f(a['count'])} {f(a['side'])} "
                     f"{f(a['order'])}{result['fid'][name]:>8.3f}")
    r = result["record_seconds"]
    lines.append(f"attention recording (studio: {STUDIO_RECORD_STEPS} of 50 steps, self + cross): "
                 f"{result['record_overhead']:.2f} x plain ({r['recording']:.3f} s vs {r['plain']:.3f} s; goal <= 1.3)")
    lines.append(f"adherence on {s['prompts']} prompts x {s['seeds']} seeds, FID on {s['fid_samples']} corpus test "
                 f"motions; {result['bench_seconds']:.0f} s")
    if "ddpm1000" not in rows:
        lines.append("the DDPM-1000 baseline row is left out (slow): add --ddpm")
    return "\n".join(lines)
