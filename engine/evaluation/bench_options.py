"""`moattn bench`'s settings, declared once: which benchmark, and the knobs each reads (the flags are generated
from these fields by engine/cli/options.py; each benchmark's own presets live in its config, e.g.
engine.evaluation.bench_adherence.AdherenceBenchConfig). Torch-free.

Each field's help says which benchmark reads it; the benchmarks themselves are exclusive ("benchmark"), except
``--control``, which also runs with ``--compose``.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from engine.methods.generate_options import SEQUENCE_MODES
from engine.options import option
from engine.paths import DUET_DIR, EVALUATOR_DIR, MODEL_DIR, shown_folder

EDITS = "--edits / --inversion / --transfer"  # the argument group of the model benchmarks' knobs


@dataclass(frozen=True, kw_only=True)
class BenchOptions:
    """Every `moattn bench` flag (the help of each is its flag's, verbatim)."""

    app: bool = option(False, exclusive="benchmark",
        help="click -> first frame, playback fps, layer switch in Chromium")
    soak: bool = option(False, exclusive="benchmark",
        help="--sessions browser sessions for --minutes against one server: server errors, memory, threads, worst time"
             " to result, cross-talk; the motion library after it and after a server restart")
    edits: bool = option(False, exclusive="benchmark", help="score the MotionCLR edits against corpus ground truth")
    inversion: bool = option(False, exclusive="benchmark",
        help="inversion round-trip error (m) and noise std: corpus, shared real files, given files")
    transfer: bool = option(False, exclusive="benchmark", help="MoMo transfer vs ground truth and baselines")
    compose: bool = option(False, exclusive="benchmark", help="DoubleTake vs first take vs naive concatenation")
    duet: bool = option(False, exclusive="benchmark", help="ComMDM vs the prior twice on held-out two-person duets")
    adherence: bool = option(False, exclusive="benchmark",
        help="prompt adherence (action, count, side, direction, order) of the model and the ground truth")
    sampling: bool = option(False, exclusive="benchmark",
        help="sampling speed per step count with adherence and FID, and attention-recording overhead")
    levers: bool = option(False, exclusive="benchmark",
        help="lever screen: one row per model folder given as FILES, scored on the dev prompt set")
    guidance: float | None = option(None, type=float,
        help="--adherence / --levers: classifier-free guidance scale (default: the sampling default)")
    guidance_from: int | None = option(None, type=int, bounds=(0, 999), whole=True,
        help="--adherence / --levers: the guidance applies at timesteps t >= this, of 1000 (0: every step; "
             "default: the sampling default)")
    eta: float | None = option(None, type=float, bounds=(0.0, 1.0),
        help="--adherence / --levers / --edits (--calibrate too): the fresh noise each sampling step adds (0: "
             "deterministic DDIM; default: the sampling default)")
    real: Path | None = option(None, type=Path,
        help="--levers: the real motion file whose inversion round trip each row reports")
    lengths: str | None = option(None, choices=("auto", "truth"),
        help="--adherence: the model's lengths, auto (predicted from the prompt, what a user gets; default) or truth "
             "(each seed's ground-truth length)")
    sequence: str | None = option(None, choices=SEQUENCE_MODES,
        help="--adherence: prompts of several actions in order generated clause by clause and joined with DoubleTake "
             "(clauses: what a user gets; default) or in one take of the whole prompt (whole: the model alone)")
    tries: int | None = option(None, type=int, bounds=(1, 8), whole=True,
        help="--adherence / --levers: tries per seed, each seed keeping the first that follows every checked "
             "attribute, else the one missing fewest (what `moattn generate --tries` and the studio keep; default 1: "
             "the model's single take)")
    tempo: bool = option(False, exclusive="benchmark",
        help="the model's count tempo: per counted action, the scale of its predicted length at which the model makes "
             "the asked-for count most often (calibration prompts); --write stores it in config.json, where every "
             "--seconds auto reads it")
    intensity: bool = option(False, exclusive="benchmark",
        help="does the model follow the words that scale an action (jumps high, waves gently)? each action plain and "
             "with the corpus's intensity words, from the same noise: the share of draws that grow and shrink as "
             "asked (engine/evaluation/bench_intensity.py)")
    exports: bool = option(False, exclusive="benchmark",
        help="seconds to export a 9.8-s motion as the studio's Export buttons do (GIF, MP4, GLB, BVH, npy)")
    train: bool = option(False, exclusive="benchmark",
        help="training step speed and GFLOP/s vs the matmul peak (two model shapes), and the corpus generator's "
             "samples/s with DataLoader workers")
    control: bool = option(False, help="control models and blending vs inpainting (PriorMDM)")
    model: Path = option(MODEL_DIR, help=f"model folder (default {shown_folder(MODEL_DIR)})")
    duet_model: Path = option(DUET_DIR, help=f"--duet: the ComMDM block (default {shown_folder(DUET_DIR)})")
    json: bool = option(False, help="print one JSON object")
    prompt: str = option("a person jumps twice", group="--app", help="the prompt whose generation is timed")
    seconds: float = option(3.0, group="--app", help="playback measuring window")
    log: Path | None = option(None, type=Path, group="--app", help="write the server's output here (also --soak)")
    compositing: str = option("both", choices=["swiftshader", "software", "both"], group="--app",
        help="Chromium compositing: SwiftShader GPU emulation, CPU (--disable-gpu), or both (default)")
    sessions: int | None = option(None, type=int, group="--soak", help="browser sessions at once (default 5)")
    minutes: float | None = option(None, type=float, group="--soak", help="how long the sessions go on (default 10)")
    library_mb: float | None = option(None, type=float, group="--soak",
        help="the scratch motion library's size bound in MB (default: the studio's); the soak checks it holds")
    quick: bool = option(False, group=EDITS, help="fewer samples and steps")
    evaluator: Path = option(EVALUATOR_DIR, group=EDITS, help="the evaluator folder (FID features)")
    calibrate: bool = option(False, group=EDITS,
        help="--edits: measure per layer whether emphasis grows the action (calibration prompts, not the benchmark's) "
             "instead of benchmarking")
    write: bool = option(False, group=EDITS,
        help="--calibrate: store the chosen layers in the model's config.json; --tempo: store the count tempo there; "
             "--control: record the drawn root + "
             "wrist figures beside the control models (bench.json: the studio's Control tab opens on blending only "
             "when they have it ahead of inpainting)")
    samples: int | None = option(None, type=int, group=EDITS,
        help="--inversion: corpus test motions (default 16, quick 6); --transfer: in-distribution pairs; --duet: held-"
             "out duets per interaction (default 3, quick 1)")
    ood_pairs: int | None = option(None, type=int, group=EDITS, help="--transfer: held-out pairs")
    seeds: int | None = option(None, type=int, group=EDITS,
        help="--duet: seeds per held-out duet (default 1); --adherence: seeds per prompt (default 4, quick 2); "
             "--intensity: seeds per action (default 12, quick 2); --tempo: seeds per count and scale (default 6, "
             "quick 4)")
    drawn: int | None = option(None, type=int, group=EDITS,
        help="--control: drawn paths per control (default 9, quick 3; 0: true paths only); the drawn root + left "
             "wrist task, which the studio's verdict reads, draws 3 times as many")
    prompts: Path | None = option(None, type=Path, group=EDITS,
        help="--adherence / --sampling: a file of prompts, one per line (default: the shipped set of prompts people "
             "type)")
    steps: int | None = option(None, type=int, group=EDITS,
        help="sampling steps for every benchmark but --app and --train (default: the benchmark's preset, 50; --quick: "
             "its own; --soak: 10); --train: timed training steps per row (default 5)")
    ddpm: bool = option(False, group=EDITS,
        help="--sampling: add the DDPM-1000 row, the slow baseline (12.5 x the steps of the DDIM rows together; left "
             "out by default)")
    full: bool = option(False, group=EDITS,
        help="--sampling: the thorough run: 16 prompts, FID on 64 motions, 3 repeats, 500 validation motions and the "
             "DDPM row (over half an hour on 2 cores; default: 8 prompts, FID on 32)")
    no_real_data: bool = option(False, group=EDITS,
        help="--inversion: skip the motion files of the shared real-data folder (../shared/data/real/)")
    files: tuple[Path, ...] | None = option(None, type=Path, nargs="*", positional=True, group=EDITS,
        help="--inversion: real motions (.bvh/.npy) to invert as well")
