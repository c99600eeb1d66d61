"""`moattn bench`: benchmark commands (tables or --json), never timed tests.

--app        the studio in Chromium against a real server (app/bench/studio.py)
--soak       several browser sessions against one real server for minutes: generate, edit, play, reload, close;
             server-log errors, memory and threads, worst time to result, cross-talk, the motion library after it
             and after a server restart (app/bench/soak.py)
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
--tempo      the model's count tempo: per counted action, the scale of its predicted length at which it makes the
             count asked for most often; --write stores it where --seconds auto reads it
             (engine/evaluation/calibrate_tempo.py)
--intensity  does the model follow the words that scale an action ("jumps high", "waves gently")? each action plain
             and with the corpus's intensity words from the same noise (engine/evaluation/bench_intensity.py)
--train      training steps/s, samples/s, GFLOP/s and share of the matmul peak for the shipped model's shape
             and one twice as wide (fp32 and bf16 on the CPU; --device / --precision), and whether the corpus
             generator keeps up with 0/1/2/several DataLoader workers (engine/evaluation/bench_train.py)
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace

from engine.cli.options import add_options
from engine.evaluation.bench_options import BenchOptions
from engine.paths import CONTROL_DIR, shown_folder
from engine.runtime import add_runtime_arguments, runtime_from_args


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="benchmarks: --app (studio in Chromium), --soak (browser sessions for minutes), "
                       "--edits (MotionCLR), --inversion, --transfer (MoMo), --compose / --control (PriorMDM), --duet (ComMDM)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(p, BenchOptions, describe_with=lambda spec: spec.help)  # declared once: engine/evaluation/bench_options.py
    add_runtime_arguments(p)  # --device, --precision: used by --train (the other benchmarks run on the CPU for now)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    given_steps(args)  # a bad --steps fails before any model loads
    if (args.guidance is not None or args.guidance_from is not None) and not (args.adherence or args.levers):
        raise ValueError("--guidance and --guidance-from go with --adherence or --levers")
    if args.eta is not None and not (args.adherence or args.levers or args.edits):
        raise ValueError("--eta goes with --adherence, --levers or --edits")
    if args.real is not None and not args.levers:
        raise ValueError("--real goes with --levers")
    if args.seeds is not None and not (args.duet or args.adherence or args.sampling or args.levers or args.intensity
                                       or args.tempo):
        raise ValueError("--seeds goes with --duet, --adherence, --sampling, --levers, --intensity or --tempo")
    if args.seeds is not None and args.seeds < 1:
        raise ValueError(f"--seeds must be at least 1, got {args.seeds}")
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
    if args.tries is not None and not (args.adherence or args.levers):
        raise ValueError("--tries goes with --adherence or --levers")
    if args.sequence is not None and not args.adherence:
        raise ValueError("--sequence goes with --adherence")
    if args.prompts is not None and not (args.adherence or args.sampling or args.levers):
        raise ValueError("--prompts goes with --adherence, --sampling or --levers")
    if args.calibrate and not args.edits:
        raise ValueError("--calibrate and --write go with --edits (--write also with --control)")
    if args.write and not (args.edits or args.control or args.tempo):
        raise ValueError("--write goes with --edits --calibrate, --tempo or --control")
    if args.write and args.control and args.drawn == 0:
        raise ValueError("--write records the drawn-path figures: --drawn must be above 0")
    if args.no_real_data and not args.inversion:
        raise ValueError("--no-real-data goes with --inversion")
    if args.write and args.edits and not args.calibrate:
        raise ValueError("--write stores a calibration: add --calibrate")
    if (args.sessions is not None or args.minutes is not None or args.library_mb is not None) and not args.soak:
        raise ValueError("--sessions, --minutes and --library-mb go with --soak")
    if args.library_mb is not None and not args.library_mb > 0:
        raise ValueError(f"--library-mb must be above 0, got {args.library_mb:g}")
    for name, runner in _ALONE.items():  # the benchmarks that run alone (the argparse group refuses two of them;
        if getattr(args, name):          # --control is not in it, for --compose --control)
            if args.control:
                raise ValueError(f"--{name} goes alone")
            return runner(args)
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
                         "--duet, --adherence, --sampling, --train, --exports, --tempo, --intensity")
    if args.app:
        from app.bench.studio import run_app_bench

        return run_app_bench(args)
    if args.edits:
        return run_edits(args)
    if args.transfer:
        return run_transfer(args)
    return run_inversion(args)


def run_soak(args: argparse.Namespace) -> int:
    from app.bench.soak import run_soak_bench

    return run_soak_bench(args)


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


def run_tempo(args: argparse.Namespace) -> int:
    from engine.evaluation.calibrate_tempo import TempoConfig, calibrate_tempo, format_table, write_tempo

    config = preset(TempoConfig, args, seeds=args.seeds)
    result = calibrate_tempo(_model(args), config, log=_log)
    if args.write:
        write_tempo(args.model, result)
    print(json.dumps(result, indent=2) if args.json else format_table(result) + (
        f"\ncount tempo written to {shown_folder(args.model)}/config.json" if args.write else
        "\n(not written: add --write)"))
    return 0


def run_intensity(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_intensity import IntensityBenchConfig, bench_intensity, format_table

    result = bench_intensity(_model(args), preset(IntensityBenchConfig, args, seeds=args.seeds), log=_log)
    print(json.dumps(result, indent=2) if args.json else format_table(result))
    return 0


def run_calibration(args: argparse.Namespace) -> int:
    from engine.evaluation.calibrate_edits import CalibrationConfig, calibrate_emphasis, write_calibration

    config = CalibrationConfig.quick() if args.quick else CalibrationConfig()
    config = config if args.eta is None else replace(config, eta=args.eta)
    result = calibrate_emphasis(_model(args), config, log=_log)
    if args.write:
        write_calibration(args.model, result)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    print("emphasis response (mean rank correlation of weight vs amplitude, scaled down where the change is under "
          "10 %, on the calibration prompts), per mode:")
    for mode, row in result["modes"].items():
        weights = ", ".join(f"{w:g}" for w in result["weights"][mode])
        if row["per_layer"]:  # a mode searched layer by layer (guide and intensity are measured once)
            singles = "  ".join(f"{layer}: {rho:+.2f}" for layer, rho in row["per_layer"].items())
            print(f"  {mode} ({weights}), layer alone: {singles}")
            where = "layers " + ", ".join(map(str, row["layers"]))
        else:
            where = f"({weights}) every layer"
        print(f"  {mode}, {where}: {row['response']:+.2f} (change {row['change']:+.0%})")
    for row in result["history"]:
        print(f"  {result['mode']}: layers {', '.join(map(str, row['layers']))}: {row['response']:+.2f} "
              f"(change {row['change']:+.0%})")
    chosen = ", ".join(map(str, result["layers"])) or "none (all layers stay the default)"
    if result.get("fallback"):  # intensity chosen: what a word without intensity words ("punches") gets
        fb = result["fallback"]
        print(f"for a word the corpus does not scale (punches): {fb['mode']}, layers "
              f"{', '.join(map(str, fb['layers'])) or 'all'}")
    print(f"emphasis mode: {result['mode']}, layers: {chosen}" + (
        f"  (written to {shown_folder(args.model)}/config.json)" if args.write else "  (not written: add --write)"))
    return 0


def run_edits(args: argparse.Namespace) -> int:
    if args.calibrate:
        return run_calibration(args)
    from engine.evaluation.bench_edits import EditBenchConfig, bench_edits, format_table
    from engine.evaluation.evaluator import load_evaluator

    config = preset(EditBenchConfig, args, eta=args.eta)
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

            written = write_bench_record(result["control"], folder=CONTROL_DIR)
            result["control_record"] = shown_folder(written)
            tables.append(f"recorded in {shown_folder(written)}: {bench_verdict(CONTROL_DIR).message}")
    print(json.dumps(result, indent=2, default=float) if args.json else "\n\n".join(tables))
    return 0


def run_adherence(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_adherence import AdherenceBenchConfig, bench_adherence, format_table, read_prompts

    config = preset(AdherenceBenchConfig, args, seeds=args.seeds, lengths=args.lengths, sequence=args.sequence,
                    tries=args.tries, guidance=args.guidance, guidance_from=args.guidance_from, eta=args.eta)  # fails before the model loads
    prompts = read_prompts(args.prompts) if args.prompts is not None else None
    result = bench_adherence(_model(args), config, prompts=prompts, log=_log)
    print(json.dumps(result, indent=2, default=float) if args.json else format_table(result))
    return 0


def run_levers(args: argparse.Namespace) -> int:
    from engine.evaluation.bench_levers import DEV_PROMPTS, LeverBenchConfig, bench_levers, format_table

    if not args.files:
        raise ValueError("--levers needs the model folders to score, e.g. moattn bench --levers runs/a runs/b")
    config = preset(LeverBenchConfig, args, seeds=args.seeds, tries=args.tries, guidance=args.guidance,
                    guidance_from=args.guidance_from, eta=args.eta)
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


#: benchmarks that run alone, in the order they are looked for
_ALONE = {"train": run_train, "exports": run_exports, "tempo": run_tempo, "soak": run_soak, "intensity": run_intensity}
