"""`moattn transfer` and `moattn analyze-qk`: MoMo from the command line (same functions as the Transfer tab)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from engine.cli.common import MOTION_SUFFIXES, RENDER_SUFFIXES, check_output_folder, check_outputs
from engine.cli.options import add_options, add_sample_options, from_args, sample_config
from engine.library.cli_support import add_library_arguments, cli_recipe, keep
from engine.runtime import add_runtime_arguments, runtime_from_args
from engine.methods.transfer_config import GENERATED_SECONDS, QKAnalysisOptions, TransferConfig, TransferSources
from engine.options import spec


def _common(p: argparse.ArgumentParser) -> None:
    add_options(p, TransferSources)
    p.add_argument("--layers", type=int, nargs=2, default=None, metavar=("FIRST", "LAST"),
                   help="mixed layers, inclusive 0-based range (default: every layer but the first)")
    start, end = spec(TransferConfig, "start"), spec(TransferConfig, "end")
    p.add_argument("--step-window", type=float, nargs=2, default=(start.default, end.default),
                   metavar=("START", "END"),
                   help=f"fractions of the sampling steps that mix, each in [{start.bounds[0]:g}, {start.bounds[1]:g}] "
                        f"(default {start.default} {end.default}; paper: steps 90 -> 10 of 100)")
    add_options(p, TransferConfig)  # --root, --keep-feet, --directions: declared on the method's config
    add_sample_options(p)
    add_runtime_arguments(p)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("transfer", help="MoMo: the leader's outline with the follower's motifs",
                       description="Leader -> follower motion transfer by mixed self-attention (MoMo). Writes the "
                       "output motion(s) and optionally a leader | follower | out render.")
    _common(p)
    p.add_argument("--out", type=Path, required=True,
                   help="output motion (.npy or .bvh); several followers write NAME_1.npy, NAME_2.npy, ...")
    p.add_argument("--render", type=Path, default=None,
                   help="leader | follower | out picture side by side (.gif, .mp4 or .png) by the studio's exporter, "
                        "titled 'LEADER ← FOLLOWER'")
    add_library_arguments(p)
    p.set_defaults(run=run_transfer)
    a = sub.add_parser("analyze-qk", help="MoMo's analysis: Q/K clusters, correspondences, attention maps",
                       description="Run a transfer with Q and K recorded and write the figures: clusters.png (PCA + "
                       "K-Means of Q and of K), correspondence.png (nearest follower frame per leader frame), "
                       "maps.png (leader, follower and mixed maps, per-query rows) and analysis.json.")
    _common(a)
    a.add_argument("--out", type=Path, required=True, help="folder for the figures")
    add_options(a, QKAnalysisOptions)
    a.set_defaults(run=run_analyze)


def sources(args: argparse.Namespace, *, max_frames: int | None = None):
    """The leader and followers as ``Source``s: prompts stay prompts, .bvh/.npy files are loaded (in the window
    --start/--seconds when --start is given; checked against the model's ``max_frames``)."""
    from engine.methods.momo import Source

    def one(text: str, prompt: str | None) -> Source:
        path = Path(text)
        if path.suffix.lower() in (".bvh", ".npy"):
            from engine.io import load_motion, pick_window

            windowed = args.start is not None
            joints = pick_window(load_motion(path), start=args.start, seconds=args.seconds if windowed else None,
                                 max_frames=max_frames, name=path.name,
                                 hint="pick a window with --start and --seconds (without --start a file is taken whole)")
            return Source(joints=joints, prompt=prompt, name=path.name)
        return Source(prompt=text, seconds=GENERATED_SECONDS if args.seconds is None else args.seconds)

    if args.start is not None and not any(Path(t).suffix.lower() in (".bvh", ".npy")
                                          for t in (args.leader, *args.follower)):
        raise ValueError("--start cuts a window of a leader/follower file: give one (.bvh/.npy)")
    prompts = list(args.follower_prompt or [])
    if len(prompts) > len(args.follower):
        raise ValueError("more --follower-prompt than --follower")
    prompts += [None] * (len(args.follower) - len(prompts))
    return one(args.leader, args.leader_prompt), [one(f, p) for f, p in zip(args.follower, prompts)]


def config_from_args(args: argparse.Namespace):
    layers = None
    if args.layers is not None:
        first, last = args.layers
        if last < first:
            raise ValueError(f"--layers {first} {last}: the last layer comes before the first")
        layers = tuple(range(first, last + 1))
    return from_args(TransferConfig, args, start=args.step_window[0], end=args.step_window[1], layers=layers)


def _run(args: argparse.Namespace, *, record: bool):
    from engine.checkpoint import load_model
    from engine.analysis.qk import qk_record
    from engine.methods.momo import transfer

    config = config_from_args(args)  # a flag out of bounds fails before the model loads
    loaded = load_model(args.model, runtime=runtime_from_args(args))
    leader, followers = sources(args, max_frames=loaded.model.config.max_frames)
    sample = sample_config(args)
    result = transfer(loaded, leader, followers, config, sample=sample, record=qk_record() if record else None)
    report = {"leader": leader.label, "followers": [f.label for f in followers], "root": config.root,
              "directions": config.directions,
              "leader_inversion_m": result.leader.inversion,
              "follower_inversion_m": [f.inversion for f in result.followers]}
    if config.directions > 1:
        report["direction_copies"] = [[c.source.label for c in group] for group in result.copies]
    return loaded, sample, result, report


def out_paths(out: Path, followers: int) -> list[Path]:
    """Where the outputs go: ``out`` for one follower, NAME_1.npy, NAME_2.npy, ... for several."""
    return [out] if followers == 1 else [out.with_name(f"{out.stem}_{i + 1}{out.suffix}") for i in range(followers)]


def run_transfer(args: argparse.Namespace) -> int:
    from engine.io import save_motion

    check_outputs(out_paths(args.out, len(args.follower)), MOTION_SUFFIXES)
    check_outputs([args.render], RENDER_SUFFIXES, flag="--render")
    _, _, result, report = _run(args, record=False)
    outs = []
    for i, path in enumerate(out_paths(args.out, len(result.followers))):
        save_motion(result.out(i), path)
        outs.append(str(path))
        pair = {"leader": report["leader"], "follower": report["followers"][i]}
        keep(args, result.out(i), kind="transfer", stream=sys.stderr, title=f"{pair['leader']} ← {pair['follower']}"[:200],
             recipe=cli_recipe(args, made_by="moattn transfer", frames=len(result.out(i)),
                               transfer={**pair, "root": report["root"], "directions": report["directions"]}))
    report["out"] = outs
    if args.render is not None:  # the studio's exporter, side by side, titled as kept (every follower named)
        from viz.export import write_picture

        motions = {"leader": result.leader_joints()}
        for i in range(len(result.followers)):
            motions[f"follower {i + 1}"] = result.follower(i)
            motions[f"out {i + 1}"] = result.out(i)
        write_picture(motions, args.render, title=f"{report['leader']} ← {', '.join(report['followers'])}"[:200])
        report["render"] = str(args.render)
    print(json.dumps(report, indent=2))
    return 0


def run_analyze(args: argparse.Namespace) -> int:
    from engine.analysis.qk import FIT_PROMPTS, ClusterConfig, cluster_site, fit_clusters
    from engine.methods.momo import analyze
    from viz.qk_figures import cluster_figure, correspondence_figure, maps_figure

    check_output_folder(args.out)
    loaded, sample, result, report = _run(args, record=True)
    site = cluster_site(loaded.model.config.layers, sample.steps)
    clusters = fit_clusters(loaded, FIT_PROMPTS, site=site, sample=sample, per_prompt=args.per_prompt,
                            config=ClusterConfig(components=args.components, clusters=args.clusters))
    analysis = analyze(loaded, result, clusters=clusters, sample=sample)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    motions = {"leader": result.leader_joints(), "follower": result.follower(0), "out": result.out(0)}
    n = len(analysis.maps["leader"])
    frames = args.query_frames or [n // 4, n // 2]
    bad = [f for f in frames if not 0 <= f < n]
    if bad:
        raise ValueError(f"--query-frames {bad} are outside the leader's frames 0..{n - 1}")
    cluster_figure(motions, analysis.q_labels, analysis.k_labels, out / "clusters.png")
    correspondence_figure(motions["leader"], motions["follower"], analysis.nearest, out / "correspondence.png")
    maps_figure(analysis.maps, out / "maps.png", per_query={f: analysis.per_query(f) for f in frames})
    report.update(figures=[str(out / n) for n in ("clusters.png", "correspondence.png", "maps.png")],
                  fitted_frames=clusters.fitted_frames, **analysis.to_json())
    (out / "analysis.json").write_text(json.dumps(report, indent=1))
    print(json.dumps({k: report[k] for k in ("leader", "followers", "figures", "cluster_site", "correspondence_site",
                                             "maps_site", "fitted_frames")}, indent=2))
    return 0
