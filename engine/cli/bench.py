"""`moattn bench`: benchmark commands (tables or --json), never timed tests.

--app        the studio in Chromium against a real server (app/bench/studio.py)
--soak       several browser sessions against one real server for minutes: generate, edit, play, reload, close;
             server-log errors, memory and threads, worst time to result, cross-talk (app/bench/soak.py)
--edits      MotionCLR edits against corpus ground truth (engine/evaluation/bench_edits.py)
--inversion  DDIM inversion round trip (m) and the inverted noise's std on corpus motions, the shared real
             motions (../shared/data/real/) and given files (engine/evaluation/bench_inversion.py)
--transfer   MoMo leader -> follower transfer against corpus ground truth, with baselines
--compose    DoubleTake transitions vs first take only vs naive concatenation, and a 60-s motion's time
--control    control models and DiffusionBlending vs inpainting on true and drawn paths (with --compose: one run)
--duet       ComMDM vs the prior run twice on held-out duets: prefix completion and text-to-duet
--adherence  does a generated motion do what its prompt says? detectors validated on corpus labels first,
             then the model and the ground truth on prompts people type (engine/evaluation/bench_adherence.py)
--sampling   seconds for a 6-s motion at 10/20/50 DDIM steps (and DDPM 1000 with --ddpm or --full: slow), with
             adherence and FID per setting, and the attention-recording overhead (engine/evaluation/bench_sampling.py)
--levers     a lever screen: one row per model folder (given as FILES) on the dev prompt set: dev action,
             count and side adherence with the seeds' spread, foot skate vs the truth, one real file's inversion
             round trip, the run's logged samples/s (engine/evaluation/bench_levers.py)
--train      training steps/s, samples/s, GFLOP/s and share of the matmul peak for the shipped model's shape
             and one twice as wide (fp32 and bf16 on the CPU; --device / --precision), and whether the corpus
             generator keeps up with 0/1/2/several DataLoader workers (engine/evaluation/bench_train.py)
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

from engine.paths import DUET_DIR, EVALUATOR_DIR, MODEL_DIR
from engine.runtime import add_runtime_arguments, runtime_from_args


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="benchmarks: --app (studio in Chromium), --soak (browser sessions for minutes), "
                       "--edits (MotionCLR), --inversion, --transfer (MoMo), --compose / --control (PriorMDM), --duet (ComMDM)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--app", action="store_true", help="click -> first frame, playback fps, layer switch in Chromium")
    mode.add_argument("--soak", action="store_true",
                      help="--sessions browser sessions for --minutes against one server: server errors, memory, "
                           "threads, worst time to result, cross-talk")
    mode.add_argument("--edits", action="store_true", help="score the MotionCLR edits against corpus ground truth")
    mode.add_argument("--inversion", action="store_true",
                      help="inversion round-trip error (m) and noise std: corpus, shared real files, given files")
    mode.add_argument("--transfer", action="store_true", help="MoMo transfer vs ground truth and baselines")
    mode.add_argument("--compose", action="store_true", help="DoubleTake vs first take vs naive concatenation")
    mode.add_argument("--duet", action="store_true", help="ComMDM vs the prior twice on held-out two-person duets")
    mode.add_argument("--adherence", action="store_true",
                      help="prompt adherence (action, count, side, direction, order) of the model and the ground truth")
    mode.add_argument("--sampling", action="store_true",
                      help="sampling speed per step count with adherence and FID, and attention-recording overhead")
    mode.add_argument("--levers", action="store_true",
                      help="lever screen: one row per model folder given as FILES, scored on the dev prompt set")
    p.add_argument("--guidance", type=float, default=None,
                   help="--adherence / --levers: classifier-free guidance scale (default: the sampling default)")
    p.add_argument("--real", type=Path, default=None,
                   help="--levers: the real motion file whose inversion round trip each row reports")
    p.add_argument("--lengths", choices=("auto", "truth"), default=None,
                   help="--adherence: the model's lengths, auto (predicted from the prompt, what a user gets; default) "
                        "or truth (each seed's ground-truth length)")
    mode.add_argument("--exports", action="store_true",
                      help="seconds to export a 9.8-s motion as the studio's Export buttons do (GIF, MP4, GLB, BVH, npy)")
    mode.add_argument("--train", action="store_true",
                      help="training step speed and GFLOP/s vs the matmul peak (two model shapes), and the corpus "
                           "generator's samples/s with DataLoader workers")
    p.add_argument("--control", action="store_true", help="control models and blending vs inpainting (PriorMDM)")
    p.add_argument("--model", type=Path, default=MODEL_DIR, help=f"model folder (default {MODEL_DIR})")
    p.add_argument("--duet-model", type=Path, default=DUET_DIR, help=f"--duet: the ComMDM block (default {DUET_DIR})")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    add_runtime_arguments(p)  # --device, --precision: used by --train (the other benchmarks run on the CPU for now)
    app = p.add_argument_group("--app")
    app.add_argument("--prompt", default="a person jumps twice")
    app.add_argument("--seconds", type=float, default=3.0, help="playback measuring window")
    app.add_argument("--log", type=Path, default=None, help="write the server's output here (also --soak)")
    app.add_argument("--compositing", choices=["swiftshader", "software", "both"], default="both",
                     help="Chromium compositing: SwiftShader GPU emulation, CPU (--disable-gpu), or both (default)")
    soak = p.add_argument_group("--soak")
    soak.add_argument("--sessions", type=int, default=None, help="browser sessions at once (default 5)")
    soak.add_argument("--minutes", type=float, default=None, help="how long the sessions go on (default 10)")
    edits = p.add_argument_group("--edits / --inversion / --transfer")
    edits.add_argument("--quick", action="store_true", help="fewer samples and steps")
    edits.add_argument("--evaluator", type=Path, default=EVALUATOR_DIR)
    edits.add_argument("--calibrate", action="store_true",
                       help="--edits: measure per layer whether emphasis grows the action (calibration prompts, not "
                            "the benchmark's) instead of benchmarking")
    edits.add_argument("--write", action="store_true", help="--calibrate: store the chosen layers in the model's config.json; "
                       "--control: record the drawn root + wrist figures beside the control models (bench.json: the "
                       "studio's Control tab opens on blending only when they have it ahead of inpainting)")
    edits.add_argument("--samples", type=int, default=None,
                       help="--inversion: corpus test motions (default 16, quick 6); --transfer: in-distribution pairs; "
                            "--duet: held-out duets per interaction (default 3, quick 1)")
    edits.add_argument("--ood-pairs", type=int, default=None, help="--transfer: held-out pairs")
    edits.add_argument("--seeds", type=int, default=None,
                       help="--duet: seeds per held-out duet (default 1); --adherence: seeds per prompt (default 4, "
                            "quick 2)")
    edits.add_argument("--drawn", type=int, default=None,
                       help="--control: drawn paths per control (default 9, quick 3; 0: true paths only)")
    edits.add_argument("--prompts", type=Path, default=None,
                       help="--adherence / --sampling: a file of prompts, one per line (default: the shipped set of "
                            "prompts people type)")
    edits.add_argument("--steps", type=int, default=None,
                       help="sampling steps for every benchmark but --app and --train (default: the benchmark's "
                            "preset, 50; --quick: its own; --soak: 10); --train: timed training steps per row (default 5)")
    edits.add_argument("--ddpm", action="store_true",
                       help="--sampling: add the DDPM-1000 row, the slow baseline (12.5 x the steps of the DDIM rows "
                            "together; left out by default)")
    edits.add_argument("--full", action="store_true",
                       help="--sampling: the thorough run: 16 prompts, FID on 64 motions, 3 repeats, 500 validation "
                            "motions and the DDPM row (over half an hour on 2 cores; default: 8 prompts, FID on 32)")
    edits.add_argument("--no-real-data", action="store_true",
                       help="--inversion: skip the motion files of the shared real-data folder (../shared/data/real/)")
    edits.add_argument("files", nargs="*", type=Path, help="--inversion: real motions (.bvh/.npy) to invert as well")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    given_steps(args)  # a bad --steps fails before any model loads
    if args.guidance is not None and not (args.adherence or args.levers):
        raise ValueError("--guidance goes with --adherence or --levers")
    if args.real is not None and not args.levers:
        raise ValueError("--real goes with --levers")
    if args.seeds is not None and not (args.duet or args.adherence or args.sampling or args.levers):
        raise ValueError("--seeds goes with --duet, --adherence, --sampling or --levers")
    if args.sampling and args.steps is not None:
        raise ValueError("--sampling measures its own step counts (10, 20, 50; DDPM 1000 with --ddpm): drop --steps")
    if (args.ddpm or args.full) and not args.sampling:
        raise ValueError("--ddpm and --full go with --sampling")
    if args.full and args.quick:
        raise ValueError("--full and --quick are opposites: choose one")
    if args.drawn is not None and not args.control:
        raise ValueError("--drawn goes with --control")
    if args.drawn is not None and args.drawn < 0:
        raise ValueError("--drawn must be 0 or more")
    if args.lengths is not None and not args.adherence:
        raise ValueError("--lengths goes with --adherence")
    if args.prompts is not None and not (args.adherence or args.sampling or args.levers):
        raise ValueError("--prompts goes with --adherence, --sampling or --levers")
    if args.calibrate and not args.edits:
        raise ValueError("--calibrate and --write go with --edits (--write also with --control)")
    if args.write and not (args.edits or args.control):
        raise ValueError("--write goes with --edits --calibrate or with --control")
    if args.write and args.control and args.drawn == 0:
        raise ValueError("--write records the drawn-path figures: --drawn must be above 0")
    if args.no_real_data and not args.inversion:
        raise ValueError("--no-real-data goes with --inversion")
    if args.write and args.edits and not args.calibrate:
        raise ValueError("--write stores a calibration: add --calibrate")
    if (args.sessions is not None or args.minutes is not None) and not args.soak:
        raise ValueError("--sessions and --minutes go with --soak")
    if args.train:
        if args.control:
            raise ValueError("--train goes alone")
        return run_train(args)
    if args.exports:
        if args.control:
            raise ValueError("--exports goes alone")
        return run_exports(args)
    if args.soak:
        if args.control:
            raise ValueError("--soak goes alone")
        from app.bench.soak import run_soak_bench

        return run_soak_bench(args)
    if args.compose or args.control:
        if args.app or args.edits or args.inversion or args.transfer or args.duet:
            raise ValueError("--control goes alone or with --compose")
        return run_priormdm(args)
    if args.duet:
        return run_duet(args)
    if args.adherence:
        return run_adherence(args)
    if args.levers:
        return run_levers(args)
    if args.sampling:
        return run_sampling(args)
    if not (args.app or args.edits or args.inversion or args.transfer):
        raise ValueError("choose a benchmark: --app, --soak, --edits, --inversion, --transfer, --compose and/or --control, "
                         "--duet, --adherence, --sampling, --train, --exports")
    if args.app:
        from app.bench.studio import run_app_bench

        return run_app_bench(args)
    if args.edits:
        return run_edits(args)
    if args.transfer:
        return run_transfer(args)
    return run_inversion(args)


def given_steps(args: argparse.Namespace) -> int | None:
    """``--steps`` when given, else None; out of range: a ValueError."""
    if args.steps is not None and not 1 <= args.steps <= 1000:
        raise ValueError(f"--steps must be between 1 and 1000, got {args.steps}")
    return args.steps


def preset(cls, args: argparse.Namespace, **overrides):
    """The benchmark config ``cls`` (``cls.quick()`` under --quick) with the given fields replaced where they are
    not None, and ``--steps`` where given."""
    config = cls.quick() if args.quick else cls()
    fields = {k: v for k, v in {**overrides, "steps": given_steps(args)}.items() if v is not None}
    return replace(config, **fields)


def _model(args: argparse.Namespace):
    """``--model`` on ``--device``."""
    from engine.checkpoint import load_model

    return load_model(args.model, runtime=runtime_from_args(args))


def _log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def run_calibration(args: argparse.Namespace) -> int:
    from engine.evaluation.calibrate_edits import calibrate_emphasis, write_calibration

    result = calibrate_emphasis(_model(args), log=_log)
    if args.write:
        write_calibration(args.model, result)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    print("emphasis response (mean Spearman of weight vs amplitude on calibration prompts):")
    for layer, rho in result["per_layer"].items():
        print(f"  layer {layer} alone: {rho:+.2f}")
    for row in result["history"]:
        print(f"  layers {', '.join(map(str, row['layers']))}: {row['spearman']:+.2f}")
    chosen = ", ".join(map(str, result["layers"])) or "none (all layers stay the default)"
    print(f"emphasis layers: {chosen}" + (f"  (written to {args.model}/config.json)" if args.write else
                                          "  (not written: add --write)"))
    return 0


def run_edits(args: argparse.Namespace) -> int:
    if args.calibrate:
        return run_calibration(args)
    from engine.evaluation.bench_edits import EditBenchConfig, bench_edits, format_table
    from engine.evaluation.evaluator import load_evaluator

    config = preset(EditBenchConfig, args)
    result = bench_edits(_model(args), load_evaluator(args.evaluator), config, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_transfer(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_transfer import TransferBenchConfig, bench_transfer, format_table
    from engine.evaluation.evaluator import load_evaluator

    config = preset(TransferBenchConfig, args, pairs=args.samples, ood_pairs=args.ood_pairs)
    result = bench_transfer(_model(args), load_evaluator(args.evaluator), config, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_priormdm(args: argparse.Namespace) -> int:
    from engine.evaluation.evaluator import load_evaluator

    loaded, evaluator = _model(args), load_evaluator(args.evaluator)
    result, tables = {}, []
    if args.compose:
        from engine.evaluation.bench_compose import ComposeBenchConfig, bench_compose, format_table

        config = preset(ComposeBenchConfig, args, sequences=args.samples)
        result["compose"] = bench_compose(loaded, evaluator, config, log=_log)
        tables.append(format_table(result["compose"]))
    if args.control:
        from engine.evaluation.bench_control import ControlBenchConfig, bench_control, format_table

        config = preset(ControlBenchConfig, args, motions=args.samples, drawn_paths=args.drawn)
        result["control"] = bench_control(loaded, evaluator, config, log=_log)
        tables.append(format_table(result["control"]))
        if args.write:
            from engine.methods.control_options import bench_verdict, write_bench_record
            from engine.paths import CONTROL_DIR

            written = write_bench_record(result["control"], folder=CONTROL_DIR)
            result["control_record"] = str(written)
            tables.append(f"recorded in {written}: {bench_verdict(CONTROL_DIR).message}")
    print(json.dumps(result, indent=2, default=float) if args.json else "\n\n".join(tables))
    return 0


def run_adherence(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_adherence import AdherenceBenchConfig, bench_adherence, format_table, read_prompts

    config = preset(AdherenceBenchConfig, args, seeds=args.seeds, lengths=args.lengths,
                    guidance=args.guidance)  # fails before the model loads
    prompts = read_prompts(args.prompts) if args.prompts is not None else None
    result = bench_adherence(_model(args), config, prompts=prompts, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_levers(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_levers import DEV_PROMPTS, LeverBenchConfig, bench_levers, format_table

    if not args.files:
        raise ValueError("--levers needs the model folders to score, e.g. moattn bench --levers runs/a runs/b")
    config = preset(LeverBenchConfig, args, seeds=args.seeds, guidance=args.guidance)
    result = bench_levers(args.files, config, prompts_file=args.prompts or DEV_PROMPTS, real_file=args.real, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_sampling(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_adherence import read_prompts
    from engine.evaluation.bench_sampling import SamplingBenchConfig, bench_sampling, format_table
    from engine.evaluation.evaluator import load_evaluator

    config = preset(SamplingBenchConfig, args, seeds=args.seeds, ddpm=args.ddpm or None)
    if args.full:
        config = replace(SamplingBenchConfig.full(), **({"seeds": args.seeds} if args.seeds is not None else {}))
    prompts = read_prompts(args.prompts) if args.prompts is not None else None
    result = bench_sampling(_model(args), load_evaluator(args.evaluator), config, prompts=prompts, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_duet(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_duet import DuetBenchConfig, bench_duet, format_table
    from engine.train_commdm import load_trained

    if args.seeds is not None and args.seeds < 1:
        raise ValueError("--seeds must be at least 1")
    config = preset(DuetBenchConfig, args, per_interaction=args.samples, seeds=args.seeds)
    result = bench_duet(load_trained(args.duet_model, args.model, runtime=runtime_from_args(args)), config, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_inversion(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_inversion import InversionBenchConfig, bench_inversion, format_table

    config = preset(InversionBenchConfig, args, motions=args.samples)
    if args.no_real_data:
        config = replace(config, real_data=None)
    result = bench_inversion(_model(args), config, args.files, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_exports(args: argparse.Namespace) -> int:
    from app.bench.exports import bench_exports, format_table

    result = bench_exports(_model(args), log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_train(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_train import TrainBenchConfig, bench_train, format_table, runtimes

    runtimes(args.device, args.precision)  # a device that cannot be used fails in one line before any work
    config = preset(TrainBenchConfig, args)
    result = bench_train(config, device=args.device, precision=args.precision, model_dir=args.model, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0
