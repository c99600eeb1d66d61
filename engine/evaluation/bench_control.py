"""`moattn bench --control`: control models and DiffusionBlending vs plain inpainting, on true and drawn paths.

Held-out test-split motions give the prompts (their captions) and the true control signals:
the root trajectory (feature dims 0-2) and each wrist's root-relative position. For each task
(root, left wrist, right wrist, and root + left wrist blended) the fine-tuned model(s) and the
base model with plain inpainting generate from the same noise. Figures (JSON
``control.<task>.<method>``): ``error_m`` (mean distance of the controlled joint from its true
position: the root on the floor, the wrist relative to the root), ``off_0_5m`` (share of frames
more than 0.5 m off), ``fid`` (evaluator, vs the held-out motions) and ``skate`` (foot skating;
``control.truth_skate``: the held-out motions' own).
``control.truth_redraw_fid`` is the floor of that FID: as many other held-out motions scored against the same
ones (with a few dozen motions it is far from 0; a ratio of two FIDs near it is mostly noise).

Beside the true paths, **paths a person would draw** (``engine.methods.drawn_paths``): root S-curves,
circles and zig-zags at walking speed from the origin heading +Z, and letters written in the air
with a wrist (the root + left wrist task pairs root path k with left-wrist letter k), each with a
prompt a person would type for it (in the model's vocabulary). The same methods generate them;
figures (JSON ``control.drawn.tasks.<task>.<method>``): ``error_m``, ``off_0_5m`` and ``skate`` as
above (no FID: drawn paths have no reference motions), per path under ``per_path``. The drawn root + left wrist
task, whose figures the studio's verdict reads (``control_options.bench_verdict``), draws
``ControlBenchConfig.verdict_factor`` times as many paths in the main rows (27 by default).

Adherence of the prompted action, on true and drawn paths alike: ``engine.evaluation.adherence.check_motion``
reads each generated motion against ``engine.intent.parse_intent`` of its prompt (all checks, no reliability
filter); ``action_match`` is the share of the motions whose intended actions are all detected
(``adherence``: every attribute's share and count, ``adherence.score``). The detectors' yardsticks beside them:
``control.truth_adherence`` (the held-out corpus motions with their own captions) and
``control.drawn.prompt_truth_adherence.<task>`` (a corpus motion realising each drawn path's prompt).

The table puts each method's drawn-path row right under its true-path row, so the premise of
DiffusionBlending (the fine-tuned models hold up on such paths where inpainting breaks down) shows, or its
opposite does, in the skate and action columns and in ``control.drawn_vs_true_error.<task>.<method>``
(drawn-path error over true-path error; None where the true-path error is under 5 mm: the root dims are
inpainted on every frame and decode onto the path, so both root errors are round-off).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from engine.checkpoint import LoadedModel
from engine.evaluation.adherence import check_motion, ground_truth_motion, score
from engine.evaluation.evaluator import LoadedEvaluator
from engine.evaluation.metrics import fid, foot_skate
from engine.generate import FPS, SampleConfig
from engine.intent import parse_intent
from engine.methods.control import Control, control_base, control_dims, controlled, load_controls
from engine.methods.control_options import BENCH_TASK, ControlOptions, option_info
from engine.methods.drawn_paths import DrawnPath, drawn_letters, drawn_root_paths
from engine.methods.paths import to_world
from engine.paths import shown_folder
from engine.representation import features_to_joints, joints_to_features
from engine.units import DEFAULT_GUIDANCE

TASKS = {"root": ("root",), "left_wrist": ("left_wrist",), "right_wrist": ("right_wrist",),
         "root+left_wrist": ("root", "left_wrist")}


@dataclass(frozen=True)
class ControlBenchConfig:
    motions: int = 64  # the FID floor (truth_redraw_fid) is 0.18 here, 0.43-0.45 with 24
    steps: int = 50
    guidance: float = DEFAULT_GUIDANCE
    seed: int = 0
    min_seconds: float = 3.0
    drawn_paths: int = 9  # drawn root paths, and letters per wrist (0: true paths only)
    # the task the studio's verdict reads (drawn root + left wrist, control_options.BENCH_TASK) draws this many times
    # as many paths in the main rows: with 9, one path was 11 % of the action figure, and blending and inpainting
    # were one or two paths apart (session 38: 27 paths put a path at 4 %)
    verdict_factor: int = 3
    # every row samples with the planted-feet correction as the CLI and the studio do by default; the drawn paths are
    # also sampled the other way (``drawn_other_feet``), so the paper's sampling stays on the record
    planted_feet: bool = option_info(ControlOptions, "planted_feet").default

    @classmethod
    def quick(cls) -> "ControlBenchConfig":
        return cls(motions=8, steps=20, drawn_paths=3)


# prompts a person would type for the drawn paths (every word in the model's vocabulary)
ROOT_PROMPTS = {"s_curve": "a person walks", "circle": "a person walks in a circle", "zigzag": "a person walks"}
WRIST_PROMPTS = ("a person waves the {side} hand", "a person stands still")  # letters take them in turn
BLEND_PROMPT = "{walk} while waving the left hand"


@dataclass(frozen=True)
class DrawnCase:
    """One drawn-path generation: the prompt, the controls, and the targets the errors are measured against."""

    name: str
    prompt: str
    seconds: float
    controls: list[Control]
    root_target: np.ndarray | None  # (T + 1, 2) root xz per pose (the path starts at the origin heading +Z)
    root_frame: dict | None
    wrist_targets: dict[str, np.ndarray]  # name -> (T, 3) ric values


def drawn_cases(task: str, n: int, *, min_seconds: float = 3.0) -> list[DrawnCase]:
    """The drawn paths of a task, ``n`` of them (``root+left_wrist``: root path k with left-wrist letter k)."""
    names = TASKS[task]
    roots = drawn_root_paths(n) if "root" in names else [None] * n
    letters = {w: drawn_letters(n, w.split("_")[0]) for w in names if w != "root"}
    out = []
    for k in range(n):
        parts: list[DrawnPath] = [p for p in [roots[k], *(letters[w][k] for w in letters)] if p is not None]
        seconds = max(min_seconds, *(p.seconds for p in parts))
        controls, root_target, frame, wrists = [], None, None, {}
        for p in parts:
            values, f = p.controls(seconds)
            controls.append(Control(p.control, values))
            if p.control == "root":
                root_target, frame = np.asarray(f["target"]), f
            else:
                wrists[p.control] = values
        if task == "root":
            prompt = ROOT_PROMPTS[roots[k].shape]
        elif task == "root+left_wrist":
            prompt = BLEND_PROMPT.format(walk=ROOT_PROMPTS[roots[k].shape])
        else:
            prompt = WRIST_PROMPTS[k % len(WRIST_PROMPTS)].format(side=names[0].split("_")[0])
        out.append(DrawnCase(name=" + ".join(p.name for p in parts), prompt=prompt, seconds=seconds,
                             controls=controls, root_target=root_target, root_frame=frame, wrist_targets=wrists))
    return out


def drawn_errors(joints: np.ndarray, case: DrawnCase) -> np.ndarray:
    """Per-frame distances (m) from the drawn targets: the root on the floor, each wrist in the body frame
    (as :func:`control_error` measures them on true paths), concatenated."""
    errors = []
    if case.root_target is not None:
        world = to_world(joints, case.root_frame)
        n = min(len(world), len(case.root_target))
        errors.append(np.linalg.norm(world[:n, 0, [0, 2]] - case.root_target[:n], axis=1))
    if case.wrist_targets:
        feats = joints_to_features(joints)
        for name, target in case.wrist_targets.items():
            n = min(len(feats), len(target))
            errors.append(np.linalg.norm(feats[:n, control_dims(name)] - target[:n], axis=1))
    return np.concatenate(errors)


def control_error(joints: np.ndarray, truth: np.ndarray, name: str) -> np.ndarray:
    """Per-frame distance (m) of the controlled joint: root on the floor, a wrist in the body frame."""
    n = min(len(joints), len(truth))
    if name == "root":
        return np.linalg.norm(joints[:n, 0, [0, 2]] - truth[:n, 0, [0, 2]], axis=1)
    # a wrist: its position in the body's own frame (root-relative, heading aligned), from each motion's joints
    dims = control_dims(name)
    a, b = joints_to_features(joints[: n + 1])[:, dims], joints_to_features(truth[: n + 1])[:, dims]
    return np.linalg.norm(a - b, axis=1)


def bench_control(loaded: LoadedModel, evaluator: LoadedEvaluator, config: ControlBenchConfig = ControlBenchConfig(),
                  *, models: dict[str, LoadedModel] | None = None, folder=None, log=print) -> dict:
    """The benchmark on the base the control models belong to (as ``moattn control`` and the studio run them):
    ``loaded`` when they blend with it, else the prior shipped beside them (``folder/prior``, default
    assets/control/prior); both methods run on that base. ``models``: the control models (default: those in
    ``folder``, default assets/control)."""
    from engine.paths import CONTROL_DIR
    from engine.synth import Corpus

    if config.motions < 2:
        raise ValueError(f"the control benchmark needs at least 2 held-out motions (an FID of one motion is undefined), "
                         f"got {config.motions}")
    t0 = time.time()
    folder = CONTROL_DIR if folder is None else folder
    models = load_controls(folder, runtime=loaded.runtime) if models is None else models
    run = control_base(loaded, models, folder=folder)
    loaded, models = run.loaded, run.models
    base = {"folder": shown_folder(loaded.folder), "step": loaded.config.get("step"), "control_prior": run.on_prior,
            "note": run.note, "unblendable": list(run.odd)}
    log(f"  base: {base['folder']} (step {base['step']})" + (f"; {run.note}" if run.note else ""))
    corpus = Corpus(split="test", seed=config.seed)

    def held_out(start: int) -> list:
        out, i = [], start
        while len(out) < config.motions:
            s = corpus.sample(i)
            i += 1
            if len(s.joints) - 1 >= config.min_seconds * FPS:
                out.append(s)
        return out

    items = held_out(20000)
    truth_emb = evaluator.motion_embeddings([s.features for s in items])
    floor = fid(evaluator.motion_embeddings([s.features for s in held_out(40000)]), truth_emb)
    log(f"  truth (other motions): FID {floor:.3f} (the floor)")
    sample = SampleConfig(steps=config.steps, guidance=config.guidance, seed=config.seed)
    intents = [parse_intent(s.captions[0]) for s in items]
    result = {"motions": len(items), "steps": config.steps, "models": sorted(models), "base": base, "tasks": {},
              "planted_feet": config.planted_feet,
              "truth_redraw_fid": floor,
              "truth_adherence": score(check_motion(s.joints, i) for s, i in zip(items, intents)),
              "truth_skate": float(np.mean([foot_skate(s.joints) for s in items]))}
    for task, names in TASKS.items():
        methods = task_methods(names, models)
        rows = {}
        for method, use in methods.items():
            errors, feats, skates, verdicts = {n: [] for n in names}, [], [], []
            for k, s in enumerate(items):
                seconds = (len(s.joints) - 1) / FPS
                truth = features_to_joints(s.features)
                controls = [Control(n, s.features[:, control_dims(n)]) for n in names]
                gen = controlled(loaded, s.captions[0], controls, seconds=seconds, models=use,
                                 sample=SampleConfig(steps=sample.steps, guidance=sample.guidance, seed=config.seed + k),
                                 planted_feet=config.planted_feet)
                joints = gen.joints[0]
                for n in names:
                    errors[n].append(control_error(joints, truth, n))
                feats.append(joints_to_features(joints))
                skates.append(foot_skate(joints))
                verdicts.append(check_motion(joints, intents[k]))
            err = np.concatenate([e for n in names for e in errors[n]])
            adherence = score(verdicts)
            rows[method] = {"error_m": float(err.mean()), "off_0_5m": float((err > 0.5).mean()),
                            "fid": fid(evaluator.motion_embeddings(feats), truth_emb), "skate": float(np.mean(skates)),
                            "action_match": adherence["action"], "adherence": adherence}
            log(f"  {task} / {method}: error {rows[method]['error_m']:.3f} m, FID {rows[method]['fid']:.3f} "
                f"({time.time() - t0:.0f} s)")
        result["tasks"][task] = rows
    if config.drawn_paths > 0:
        result["drawn"] = bench_drawn(loaded, models, config, log=lambda line: log(f"{line} ({time.time() - t0:.0f} s)"))
        other = replace(config, planted_feet=not config.planted_feet, verdict_factor=1)
        feet = "on" if other.planted_feet else "off"
        result["drawn_other_feet"] = bench_drawn(
            loaded, models, other, log=lambda line: log(f"{line}, planted feet {feet} ({time.time() - t0:.0f} s)"))
        result["drawn_vs_true_error"] = {task: {m: error_ratio(r["error_m"], result["tasks"][task][m]["error_m"])
                                                for m, r in rows.items()}
                                         for task, rows in result["drawn"]["tasks"].items()}
    blend = result["tasks"]["root+left_wrist"]
    result["blending_fid_vs_inpainting"] = (blend["blending"]["fid"] / max(blend["inpainting"]["fid"], 1e-9)
                                            if "blending" in blend else None)
    result["seconds"] = time.time() - t0
    return result


MIN_RATIO_ERROR = 0.005  # m: below this on the true paths the error is the decoding's round-off, not a yardstick


def error_ratio(drawn: float, true: float) -> float | None:
    """Drawn-path error over true-path error; None where the true-path error is ~0 (a root path is inpainted on
    every frame, so it decodes onto the path exactly: both errors are round-off)."""
    return drawn / true if true >= MIN_RATIO_ERROR else None


def task_methods(names: tuple[str, ...], models: dict) -> dict:
    """method -> control models (None: plain inpainting with the base model)."""
    methods = {"inpainting": None}
    if all(n in models for n in names):
        methods["blending" if len(names) > 1 else "fine_tuned"] = models
    return methods


def bench_drawn(loaded: LoadedModel, models: dict[str, LoadedModel], config: ControlBenchConfig, *, log=print) -> dict:
    """Every task's methods on the drawn paths: error, share > 0.5 m off, foot skate; per path as well."""
    out = {"paths": {}, "tasks": {}, "prompt_truth_adherence": {}}
    for task, names in TASKS.items():
        n = config.drawn_paths * (config.verdict_factor if task == BENCH_TASK else 1)
        cases = drawn_cases(task, n, min_seconds=config.min_seconds)
        out["paths"][task] = [{"name": c.name, "prompt": c.prompt, "seconds": c.seconds} for c in cases]
        intents = [parse_intent(c.prompt) for c in cases]
        out["prompt_truth_adherence"][task] = score(check_motion(ground_truth_motion(i, config.seed + k), i)
                                                    for k, i in enumerate(intents))
        rows = {}
        for method, use in task_methods(names, models).items():
            per_path = []
            for k, case in enumerate(cases):
                gen = controlled(loaded, case.prompt, case.controls, seconds=case.seconds, models=use,
                                 sample=SampleConfig(steps=config.steps, guidance=config.guidance, seed=config.seed + k),
                                 planted_feet=config.planted_feet)
                joints = gen.joints[0]
                err = drawn_errors(joints, case)
                per_path.append({"path": case.name, "error_m": float(err.mean()), "off_0_5m": float((err > 0.5).mean()),
                                 "skate": foot_skate(joints), "adherence": check_motion(joints, intents[k]), "_err": err})
            err = np.concatenate([p.pop("_err") for p in per_path])
            adherence = score(p["adherence"] for p in per_path)
            rows[method] = {"paths": len(per_path), "error_m": float(err.mean()), "off_0_5m": float((err > 0.5).mean()),
                            "skate": float(np.mean([p["skate"] for p in per_path])),
                            "action_match": adherence["action"], "adherence": adherence, "per_path": per_path}
            log(f"  drawn {task} / {method}: error {rows[method]['error_m']:.3f} m, skate {rows[method]['skate']:.3f}, "
                f"action {_share(rows[method]['action_match'])}")
        out["tasks"][task] = rows
    return out


def _share(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def format_table(result: dict) -> str:
    drawn = result.get("drawn", {}).get("tasks", {})
    lines = [f"{'task':<18}{'method':<12}{'paths':<7}{'error m':>9}{'>0.5 m':>8}{'FID':>8}{'skate':>8}{'action':>8}"]
    for task, rows in result["tasks"].items():
        for method, r in rows.items():
            lines.append(f"{task:<18}{method:<12}{'true':<7}{r['error_m']:>9.3f}{r['off_0_5m']:>8.3f}{r['fid']:>8.3f}"
                         f"{r['skate']:>8.3f}{_share(r['action_match']):>8}")
            d = drawn.get(task, {}).get(method)
            if d is not None:
                lines.append(f"{'':<18}{'':<12}{'drawn':<7}{d['error_m']:>9.3f}{d['off_0_5m']:>8.3f}{'-':>8}"
                             f"{d['skate']:>8.3f}{_share(d['action_match']):>8}")
    other = result.get("drawn_other_feet", {}).get("tasks", {})
    if other:
        how = "off (the paper's sampling)" if result.get("planted_feet", True) else "on"
        lines.append(f"drawn paths with planted feet {how}:")
        for task, rows in other.items():
            for method, d in rows.items():
                lines.append(f"{task:<18}{method:<12}{'drawn':<7}{d['error_m']:>9.3f}{d['off_0_5m']:>8.3f}{'-':>8}"
                             f"{d['skate']:>8.3f}{_share(d['action_match']):>8}")
    lines.append(f"planted feet (engine.diffusion.feet): {'on' if result.get('planted_feet', True) else 'off'} in the "
                 "main rows")
    lines.append(f"skate: share of grounded foot frame pairs that slide; the held-out motions' own: "
                 f"{result['truth_skate']:.3f}")
    lines.append("action: share of the motions whose prompted action is detected (engine.evaluation.adherence); "
                 f"the truth's own: {_share(result['truth_adherence']['action'])} (held-out motions, their captions)"
                 + ("" if not drawn else "; corpus motions of the drawn prompts: " + ", ".join(
                     f"{task} {_share(a['action'])}" for task, a in result["drawn"]["prompt_truth_adherence"].items())))
    if drawn:
        ratios = result["drawn_vs_true_error"]
        lines.append("drawn / true path error: " + "; ".join(
            f"{task} " + ", ".join(f"{m} " + ("n/a (both ~0)" if v is None else f"x{v:.2f}") for m, v in rows.items())
            for task, rows in ratios.items()))
        paths = result["drawn"]["paths"]
        lines.append(f"drawn paths: root {', '.join(p['name'] for p in paths['root'])}; letters (left, right wrist) "
                     f"{', '.join(p['name'].split('_')[1] for p in paths['left_wrist'])}" + "".join(
                         f"; {task}: {len(cases)} paths (root path k with letter k)"
                         for task, cases in paths.items() if "+" in task))
    ratio = result["blending_fid_vs_inpainting"]
    lines.append("blending / inpainting FID (root + left wrist): " + ("n/a (no control models)" if ratio is None
                                                                       else f"{ratio:.2f} (target <= 0.5)"))
    lines.append(f"FID floor (other held-out motions vs the same ones): {result['truth_redraw_fid']:.3f}")
    lines.append(f"{result['motions']} held-out motions, {result['steps']} steps, control models: "
                 f"{', '.join(result['models']) or 'none'}, {result['seconds']:.0f} s")
    base = result.get("base")
    if base is not None:
        lines.append(f"base (inpainting and blending): {base['folder']}, step {base['step']}"
                     + (" — the control models' own base, not the loaded one" if base["control_prior"] else "")
                     + (f"; not blendable with it: {', '.join(base['unblendable'])}" if base["unblendable"] else ""))
        if base["note"]:
            lines.append(f"note: {base['note']}")
    return "\n".join(lines)
