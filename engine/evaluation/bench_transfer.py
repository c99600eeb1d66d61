"""`moattn bench --transfer`: MoMo against corpus ground truth, baselines in the same run.

The synthetic transfer benchmark: leaders are locomotion outlines of the held-out test split
(walk, run, jog, jump, dance, side steps, ... with no style), followers are styled motions or
motions with a gesture, and the ground truth of a pair is the corpus program
``combine(outline_of=leader, motifs_of=follower)``. Pairs whose ground truth is a held-out
(action, style) combination form the ``ood`` subset. Leaders and followers are the corpus
motions themselves, DDIM-inverted (MoMo Inv.).

Figures per method (JSON keys, the paper's definitions):
- ``fid``: evaluator FID of the outputs vs the ground-truth motions of the pairs;
- ``r_precision_top3``: the follower's prompt ranks its output among it and 31 fixed corpus
  motions (the same distractors for every method);
- ``foot_contact``: agreement of binary foot contacts of the output and the leader;
- ``follower_rot`` / ``follower_loc``: share of output frames whose nearest frame among leader
  and follower (by joint rotations / root-relative joint positions) is the follower's;
- ``gt_mpjpe``: mean joint error (m) against the ground truth, both started at the origin
  facing +Z (heading aligned);
- ``gt_mpjpe_local``: the same on the pose alone: root-relative joints in each frame's heading
  frame (the representation's ric part), so a root path error does not count;
- ``motif_mpjpe_local``: ``gt_mpjpe_local`` on the joints where the follower's motif lives only (the rule
  below);
- ``ood``: the same figures on the held-out subset.

Restated figures (per row, ``ood`` rows against the ``ood`` rows of the references), the paper's figures put
beside what they mean on this corpus:
- ``gt_mpjpe_local_vs_leader_copy`` / ``gt_mpjpe_local_vs_nn_motion``: the row's ``gt_mpjpe_local`` divided by
  the ``leader_copy`` reference's and by the ``nn_motion`` method's (below 1: nearer the truth's poses than the
  trivial transfer / than copying follower frames);
- ``foot_contact_to_truth`` / ``follower_loc_to_truth``: |row − truth| on ``foot_contact`` and ``follower_loc``.
  The paper reads both as "higher is better", but the ground truth itself does not score 1 on them, so the
  distance to what the truth scores is the figure that a perfect transfer drives to 0. ``momo_gen``'s two
  figures are measured against its generated streams, the truth's against the pair's own: for it the
  distance compares like with like only loosely.

Motif-joint rule (``motif_region``), decided per pair from the corpus labels (``labels.motifs``): take the
motifs the ground truth carries (its style and gestures); when it carries neither (``combine`` dropped the
follower's because the leader's action cannot take them, e.g. a wave on a dance), take the follower's. A
posture style (any style not in ``splits.ARM_STYLES``: crouched, old, happy, sad, robot, drunk, proud) bends
the whole body: ``body``, all 21 root-relative joints (so ``motif_mpjpe_local`` equals ``gt_mpjpe_local`` on
that pair). Otherwise an arm style (``ARM_STYLES``: zombie, chicken, hands_up, gorilla) or a gesture (wave,
clap, raise_arms, punch, ... as an overlay or a segment) lives in the arms: ``arms``, the shoulders, elbows
and wrists of both sides (named in ``engine.skeleton.JOINT_NAMES``; both sides, as the other arm's swing is
changed by a one-sided gesture too). A pair with no motif at all (not drawn by :func:`build_pairs`) counts the
whole body. The JSON's ``motif_regions`` lists the region per pair.

Methods: ``momo`` (``TransferConfig()``, the default: its root mode is the one this bench chose),
``momo_rotation`` (the paper's root: the leader's root rotation copied, the output's own speed),
``momo_trajectory`` (the leader's whole root path and speed inpainted; one of these two equals ``momo``),
``momo_feet`` (the default plus the leader's footwork kept, an option that is not in the paper),
``momo_no_flights`` (the default without lifting the out with the leader's flights, ``TransferConfig.flights``:
the paper's output, which a walking follower keeps on the floor under a jumping leader),
``momo_directions`` (the default plus the paper's direction trick: the follower and 3 turned copies,
concatenated), ``nn_motion``, ``nn_latent``, ``inpaint_upper`` (see momo_baselines), and
``momo_gen`` (the paper's "MoMo Gen.": leader and follower generated from the pair's captions instead
of inverted, so its foot / rot / loc figures are measured against those generated streams; its
``gt_mpjpe`` compares it with a ground truth made from other leader and follower motions and only
tells how far the captions alone get).

Speed (JSON ``speed``; ``TransferBenchConfig.speed_pairs`` walk -> run and as many run -> walk pairs of plain
gaits, :func:`build_speed_pairs`): the root speed of each output against its ground truth, which takes the
follower gait's stride at the leader's step times (``combine(..., stride_of="follower")``: the paper counts "the
type of step (walk, run, hop)" among the motifs and the sequence and pace of steps as the outline), so a
walk -> run truth runs about 1.5x faster than its leader walked and a run -> walk one walks about 0.7x as fast.
Per method: the mean speed ratio (output / truth) per direction, the mean |speed error| / truth's speed, and
``gt_mpjpe_local`` on those pairs (with its ratio to the leader copy's). These pairs are not in the main table.
The main pairs' rows carry ``speed_error`` too (there the truth keeps the leader's speed: same gait kind, or the
corpus's default ``stride_of="leader"``), shown in the restated table. The error is taken relative to the truth's
speed but at least ``SPEED_FLOOR`` (0.5 m/s, a slow walk): a truth that stays in place (a jump, a dance) would
otherwise divide by almost nothing and one such pair outweigh all the others (session 36's "speed error 64.6").

References (JSON ``reference``), measured the same way: ``truth`` (the ground truth itself as the
output: what a perfect transfer scores on the similarity figures, which are not 1 for it: the
ground truth keeps the leader's outline, so it is often nearer the leader's poses than the
follower's) and ``leader_copy`` (the leader unchanged: the trivial transfer).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from engine.checkpoint import LoadedModel
from engine.evaluation.evaluator import LoadedEvaluator
from engine.evaluation.metrics import fid, root_speed
from engine.generate import SampleConfig
from engine.methods.momo import (
    Source, TransferConfig, canonical, direction_copies, prepare, transfer, transfer_streams,
)
from engine.methods.momo_baselines import inpaint_upper_body, latent_nn, motion_space_nn
from engine.representation import SLICES, foot_contacts, joints_to_features
from engine.skeleton import JOINT_NAMES, NUM_JOINTS
from engine.synth.splits import ARM_STYLES
from engine.units import DEFAULT_GUIDANCE

LEADER_ACTIONS = ("walk", "run", "jog", "jump", "jump_forward", "dance", "side_step", "walk_backward", "hop")
FOLLOWER_ACTIONS = ("walk", "run", "jog", "dance", "jump", "side_step")
METHODS = ("momo", "momo_rotation", "momo_trajectory", "momo_feet", "momo_no_flights", "momo_directions", "momo_gen",
           "nn_motion", "nn_latent", "inpaint_upper")
DIRECTIONS = 4  # momo_directions: the follower and 3 turned copies (the paper's direction trick)
REFERENCES = ("truth", "leader_copy")
KEYS = ("fid", "r_precision_top3", "foot_contact", "follower_rot", "follower_loc", "gt_mpjpe", "gt_mpjpe_local")
# the restated figures (second table): the motif-joint error per pair, the rest derived from the rows
RESTATED = ("gt_mpjpe_local_vs_leader_copy", "gt_mpjpe_local_vs_nn_motion", "foot_contact_to_truth",
            "follower_loc_to_truth", "motif_mpjpe_local", "speed_error")
# skeleton joint indices of each motif region (the ric part holds joints 1..21: joint j is its row j - 1)
MOTIF_JOINTS = {
    "arms": tuple(j for j, name in enumerate(JOINT_NAMES) if name.endswith(("shoulder", "elbow", "wrist"))),
    "body": tuple(range(1, NUM_JOINTS)),
}


def _carries_motif(motifs: dict) -> bool:
    return motifs.get("style", "none") != "none" or bool(motifs.get("gestures"))


def motif_region(truth_motifs: dict, follower_motifs: dict | None = None) -> str:
    """``"arms"`` or ``"body"``: where the follower's motif lives (the module docstring's rule).

    ``truth_motifs`` / ``follower_motifs``: ``labels.motifs`` of the ground truth and of the follower (only
    ``style`` and ``gestures`` are read).
    """
    motifs = truth_motifs
    if not _carries_motif(motifs) and follower_motifs is not None:
        motifs = follower_motifs
    style = motifs.get("style", "none")
    if style != "none" and style not in ARM_STYLES:
        return "body"
    if style in ARM_STYLES or motifs.get("gestures"):
        return "arms"
    return "body"


@dataclass(frozen=True)
class TransferBenchConfig:
    pairs: int = 32
    ood_pairs: int = 16
    steps: int = 50
    guidance: float = DEFAULT_GUIDANCE
    distractors: int = 31
    min_seconds: float = 2.5
    seed: int = 0
    speed_pairs: int = 4  # per direction: walk -> run and run -> walk

    @classmethod
    def quick(cls) -> "TransferBenchConfig":
        return cls(pairs=10, ood_pairs=6, steps=20, speed_pairs=3)


@dataclass
class Pair:
    leader: object  # engine.synth.Sample
    follower: object
    truth: object
    ood: bool

    @cached_property
    def reference(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """role -> (canonical joints, their features) of leader, follower and truth: computed once per pair."""
        out = {}
        for role in ("leader", "follower", "truth"):
            joints = canonical(getattr(self, role).joints)
            out[role] = (joints, joints_to_features(joints))
        return out

    @cached_property
    def motif_region(self) -> str:
        return motif_region(self.truth.labels.motifs, self.follower.labels.motifs)


def _single(program) -> bool:
    return len(program.segments) == 1


def build_pairs(config: TransferBenchConfig) -> list[Pair]:
    """Deterministic leader/follower pairs from the test split; held-out ground truths go to ``ood``."""
    from engine.synth import Corpus, make_sample
    from engine.synth.splits import is_held_out
    from engine.synth.transforms import combine

    corpus = Corpus(split="test", seed=config.seed)
    leaders, followers = [], []
    i = 0
    min_frames = config.min_seconds * 20
    while (len(leaders) < 4 * (config.pairs + config.ood_pairs) or len(followers) < 40) and i < 20000:
        program = corpus.program(i)[0]
        i += 1
        if not _single(program) or program.segments[0].frames < min_frames:
            continue
        seg = program.segments[0]
        if program.style == "none" and seg.overlay is None and seg.action in LEADER_ACTIONS:
            leaders.append(program)
        elif seg.action in FOLLOWER_ACTIONS and (program.style != "none" or seg.overlay is not None):
            followers.append(program)
    rng = np.random.default_rng(config.seed)
    pairs_in, pairs_ood = [], []
    for attempt in range(20000):
        if len(pairs_in) >= config.pairs and len(pairs_ood) >= config.ood_pairs:
            break
        lead = leaders[int(rng.integers(len(leaders)))]
        follow = followers[int(rng.integers(len(followers)))]
        truth = combine(outline_of=lead, motifs_of=follow)
        held = is_held_out(truth)
        bucket, quota = (pairs_ood, config.ood_pairs) if held else (pairs_in, config.pairs)
        if len(bucket) >= quota:
            continue
        try:
            made = [make_sample(p, split="test") for p in (lead, follow, truth)]
        except ValueError:  # a rare draw whose repetitions do not fit its duration (the corpus redraws these)
            continue
        bucket.append(Pair(leader=made[0], follower=made[1], truth=made[2], ood=held))
    return pairs_in + pairs_ood


SPEED_KINDS = (("walk", "run"), ("run", "walk"))  # (leader gait, follower gait) of the speed pairs


def build_speed_pairs(config: TransferBenchConfig) -> list[Pair]:
    """``config.speed_pairs`` walk -> run and as many run -> walk pairs (plain gaits, no style or gesture, test split,
    straight or turning), deterministic. Their ground truth takes the follower gait's stride at the leader's step
    times (``combine(..., stride_of="follower")``: the paper's "the type of step belongs to the motifs"), so a
    walk -> run truth runs faster than its leader walked; the leader's path shape and timing stay."""
    from engine.synth import Corpus, make_sample
    from engine.synth.transforms import combine

    if config.speed_pairs <= 0:
        return []
    corpus = Corpus(split="test", seed=config.seed + 7)
    plain: dict[str, list] = {"walk": [], "run": []}
    i = 0
    while min(len(v) for v in plain.values()) < 2 * config.speed_pairs and i < 20000:
        program = corpus.program(i)[0]
        i += 1
        if not _single(program) or program.segments[0].frames < config.min_seconds * 20:
            continue
        seg = program.segments[0]
        if program.style == "none" and seg.overlay is None and seg.action in plain:
            plain[seg.action].append(program)
    pairs = []
    for lead_kind, follow_kind in SPEED_KINDS:
        leaders, followers = plain[lead_kind], plain[follow_kind]
        made = 0
        for k in range(len(leaders)):
            if made >= config.speed_pairs:
                break
            lead, follow = leaders[k], followers[(k + 1) % len(followers)]
            truth = combine(outline_of=lead, motifs_of=follow, stride_of="follower")
            try:
                samples = [make_sample(p, split="test") for p in (lead, follow, truth)]
            except ValueError:  # a draw whose steps do not fit its duration
                continue
            pairs.append(Pair(leader=samples[0], follower=samples[1], truth=samples[2], ood=False))
            made += 1
    return pairs


def caption_for(loaded: LoadedModel, sample) -> str | None:
    """The first of a corpus motion's captions the model can read (the corpus grammar outgrew older models'
    vocabularies), else None: the motion is then inverted and read without text."""
    from engine.text import PromptError

    for caption in sample.captions:
        try:
            loaded.tokenizer.encode(caption)
        except PromptError:
            continue
        return caption
    return None


SPEED_FLOOR = 0.5  # m/s: the least speed a speed error is relative to (a slow walk; see the module docstring)


def measure_speed(out: np.ndarray, pair: Pair) -> dict:
    """Root speed of an output against its pair's ground truth (and the leader's and follower's, for reading)."""
    truth = root_speed(pair.reference["truth"][0])
    mine = root_speed(out)
    return {"speed": mine, "speed_truth": truth, "speed_ratio": mine / max(truth, 1e-9),
            "speed_error": abs(mine - truth) / max(truth, SPEED_FLOOR)}


# ----------------------------------------------------------------------------- per-output measurements
def _nearest_is_follower(out: np.ndarray, leader: np.ndarray, follower: np.ndarray) -> float:
    def d(a, b):
        return ((a**2).sum(1)[:, None] + (b**2).sum(1)[None] - 2 * a @ b.T).min(1)

    return float((d(out, follower) < d(out, leader)).mean())


def measure(out: np.ndarray, pair: Pair, *, streams: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """Ground-truth and similarity figures of one output (joints (T, 22, 3) of the leader's length).

    ``streams``: the (leader, follower) joints the output was made from when they are not the pair's own
    (generated from its captions); foot contact and follower similarity are measured against them.
    """
    truth, ft = pair.reference["truth"]
    if streams is None:
        (lead_j, fl), (_, ff) = pair.reference["leader"], pair.reference["follower"]
    else:
        lead_j, follow_j = (canonical(j) for j in streams)
        fl, ff = joints_to_features(lead_j), joints_to_features(follow_j)
    n = min(len(out), len(truth))
    mpjpe = float(np.linalg.norm(out[:n] - truth[:n], axis=-1).mean())
    m = min(len(out), len(lead_j))
    contact = float((foot_contacts(out[:m]) == foot_contacts(lead_j[:m])).mean())
    fo = joints_to_features(out)
    rot, ric = SLICES["rot6d"], SLICES["ric"]
    k = min(len(fo), len(ft))
    local = np.linalg.norm((fo[:k, ric] - ft[:k, ric]).reshape(k, -1, 3), axis=-1)  # (k, 21): joints 1..21
    motif = local[:, [j - 1 for j in MOTIF_JOINTS[pair.motif_region]]]
    return {"gt_mpjpe": mpjpe, "gt_mpjpe_local": float(local.mean()), "motif_mpjpe_local": float(motif.mean()),
            "foot_contact": contact,
            "follower_rot": _nearest_is_follower(fo[:, rot], fl[:, rot], ff[:, rot]),
            "follower_loc": _nearest_is_follower(fo[:, ric], fl[:, ric], ff[:, ric])}


def _r_precision_top3(text: np.ndarray, motion: np.ndarray, distractors: np.ndarray) -> float:
    """Each text ranks its motion among it and the fixed distractors: share ranked in the top 3."""
    own = np.linalg.norm(text - motion, axis=1)
    others = np.linalg.norm(text[:, None, :] - distractors[None], axis=-1)
    return float(((others < own[:, None]).sum(1) < 3).mean())


def _summary(rows: list[dict], outputs: list[np.ndarray], captions: list[str], evaluator: LoadedEvaluator,
             truth_emb: np.ndarray, distractors: np.ndarray) -> dict:
    feats = [joints_to_features(j) for j in outputs]
    emb = evaluator.motion_embeddings(feats)
    text = evaluator.text_embeddings(captions)
    out = {k: float(np.mean([r[k] for r in rows])) for k in (*KEYS, "motif_mpjpe_local", "speed_error")
           if k in rows[0]}
    out["fid"] = fid(emb, truth_emb) if len(emb) >= 2 else float("nan")  # a covariance needs two motions
    out["r_precision_top3"] = _r_precision_top3(text, emb, distractors)
    out["n"] = len(rows)
    return {k: out[k] for k in (*KEYS, "motif_mpjpe_local", "speed_error", "n") if k in out}


def restate(row: dict, *, leader_copy: dict, nn_motion: dict, truth: dict) -> None:
    """Add the restated figures to one summary row (in place), from the same subset's reference rows."""
    row["gt_mpjpe_local_vs_leader_copy"] = row["gt_mpjpe_local"] / max(leader_copy["gt_mpjpe_local"], 1e-9)
    row["gt_mpjpe_local_vs_nn_motion"] = row["gt_mpjpe_local"] / max(nn_motion["gt_mpjpe_local"], 1e-9)
    row["foot_contact_to_truth"] = abs(row["foot_contact"] - truth["foot_contact"])
    row["follower_loc_to_truth"] = abs(row["follower_loc"] - truth["follower_loc"])


def _variants() -> dict[str, TransferConfig]:
    """The MoMo rows: the default config, both root modes, the footwork option, the out without the leader's
    flights, the direction trick."""
    return {"momo": TransferConfig(), "momo_rotation": TransferConfig(root="rotation"),
            "momo_trajectory": TransferConfig(root="trajectory"), "momo_feet": TransferConfig(feet=True),
            "momo_no_flights": TransferConfig(flights=False), "momo_directions": TransferConfig(directions=DIRECTIONS)}


def _gen_prompt(loaded: LoadedModel, sample) -> str:
    """A prompt for MoMo Gen.: a readable caption, else the plain action ("a person runs")."""
    caption = caption_for(loaded, sample)
    if caption is not None:
        return caption
    action = sample.program.segments[0].action
    return {"walk": "a person walks", "run": "a person runs", "jog": "a person jogs"}.get(action, "a person moves")


def run_methods(loaded: LoadedModel, pair: Pair, config: TransferBenchConfig, sample: SampleConfig, *,
                pose_scale: np.ndarray) -> tuple[dict[str, np.ndarray], dict[str, tuple]]:
    """Every method's output on one pair (method -> joints) and the streams ``momo_gen`` was made from."""
    lead_prompt, follow_prompt = caption_for(loaded, pair.leader), caption_for(loaded, pair.follower)
    lead = prepare(loaded, Source(joints=pair.leader.joints, prompt=lead_prompt), seed=config.seed,
                   steps=config.steps, measure_inversion=False)
    follow_source = Source(joints=pair.follower.joints, prompt=follow_prompt)
    follow = prepare(loaded, follow_source, seed=config.seed + 1, steps=config.steps, measure_inversion=False)
    seconds = {r: len(pair.reference[r][1]) / 20 for r in ("leader", "follower")}  # feature frames at 20 fps
    default = TransferConfig()
    gen = transfer(loaded, Source(prompt=_gen_prompt(loaded, pair.leader), seconds=seconds["leader"]),
                   [Source(prompt=_gen_prompt(loaded, pair.follower), seconds=seconds["follower"])], default,
                   sample=sample)
    done: dict[TransferConfig, np.ndarray] = {}
    results = {}
    for name, variant in _variants().items():
        if variant not in done:  # the default is also one of the named variants: run once
            copies = None
            if variant.directions > 1:
                copies = [[prepare(loaded, c, seed=config.seed + 1, steps=config.steps, measure_inversion=False)
                           for c in direction_copies(follow_source, variant.directions)]]
            done[variant] = transfer_streams(loaded, lead, [follow], variant, sample=sample, copies=copies).out(0)
        results[name] = done[variant]
    results.update({
        "momo_gen": gen.out(0),
        "nn_motion": motion_space_nn(pair.leader.joints, pair.follower.joints, scale=pose_scale),
        "nn_latent": latent_nn(loaded, lead, follow, default, sample=sample),
        "inpaint_upper": inpaint_upper_body(loaded, lead, follow, sample=sample),
        "truth": pair.reference["truth"][0],
        "leader_copy": pair.reference["leader"][0],
    })
    return results, {"momo_gen": (gen.leader_joints(), gen.follower(0))}


def _speed_summary(rows: list[dict], pairs: list[Pair]) -> dict:
    """Speed figures of one method over the speed pairs: mean speed ratio (output / truth) per direction, mean
    |speed error| / truth's speed, and the pose error (gt_mpjpe_local)."""
    kinds = [(p.leader.program.segments[0].action, p.follower.program.segments[0].action) for p in pairs]
    out = {}
    for lead_kind, follow_kind in SPEED_KINDS:
        pick = [r for r, k in zip(rows, kinds) if k == (lead_kind, follow_kind)]
        out[f"{lead_kind}_{follow_kind}_ratio"] = float(np.mean([r["speed_ratio"] for r in pick])) if pick else None
    out["speed_error"] = float(np.mean([r["speed_error"] for r in rows]))
    out["gt_mpjpe_local"] = float(np.mean([r["gt_mpjpe_local"] for r in rows]))
    out["n"] = len(rows)
    return out


def bench_transfer(loaded: LoadedModel, evaluator: LoadedEvaluator, config: TransferBenchConfig = TransferBenchConfig(),
                   *, log=print) -> dict:
    from engine.synth import Corpus

    t0 = time.time()
    pairs = build_pairs(config)
    speed_pairs = build_speed_pairs(config)
    log(f"transfer benchmark: {sum(not p.ood for p in pairs)} in-distribution pairs, {sum(p.ood for p in pairs)} "
        f"held-out, {len(speed_pairs)} walk <-> run speed pairs; default root: {TransferConfig().root}")
    sample = SampleConfig(steps=config.steps, guidance=config.guidance, seed=config.seed)
    scale = (loaded.normalizer.std[SLICES["ric"]], loaded.normalizer.std[SLICES["rot6d"]])
    pose_scale = np.concatenate(scale)
    outputs = {m: [] for m in (*METHODS, *REFERENCES)}
    rows = {m: [] for m in (*METHODS, *REFERENCES)}
    speed_rows = {m: [] for m in (*METHODS, *REFERENCES)}
    for i, pair in enumerate(pairs + speed_pairs):
        results, streams = run_methods(loaded, pair, config, sample, pose_scale=pose_scale)
        speed_pair = i >= len(pairs)
        for m, joints in results.items():
            row = {**measure(joints, pair, streams=streams.get(m)), **measure_speed(joints, pair)}
            if speed_pair:
                speed_rows[m].append(row)
            else:
                outputs[m].append(joints)
                rows[m].append(row)
        what = "speed pair" if speed_pair else "pair"
        log(f"  {what} {i + 1}/{len(pairs) + len(speed_pairs)}{' (ood)' if pair.ood else ''}: "
            f"{pair.leader.captions[0]!r} <- {pair.follower.captions[0]!r}: momo {rows_of(speed_rows, rows, speed_pair)}"
            f" ({time.time() - t0:.0f} s)")
    truth_feats = [p.reference["truth"][1] for p in pairs]
    truth_emb = evaluator.motion_embeddings(truth_feats)
    corpus = Corpus(split="test", seed=config.seed + 1)
    distractors = evaluator.motion_embeddings([corpus.sample(10000 + j).features for j in range(config.distractors)])
    captions = [p.follower.captions[0] for p in pairs]
    ood = np.array([p.ood for p in pairs])
    result = {"pairs": len(pairs), "ood_pairs": int(ood.sum()), "steps": config.steps, "default_root": TransferConfig().root,
              "methods": {}, "reference": {}}
    for m in (*METHODS, *REFERENCES):
        pick = lambda mask: ([r for r, k in zip(rows[m], mask) if k], [o for o, k in zip(outputs[m], mask) if k],  # noqa: E731
                             [c for c, k in zip(captions, mask) if k])
        r_in, o_in, c_in = pick(~ood)
        r_ood, o_ood, c_ood = pick(ood)
        summary = _summary(r_in, o_in, c_in, evaluator, truth_emb[~ood], distractors)
        summary["ood"] = _summary(r_ood, o_ood, c_ood, evaluator, truth_emb[ood], distractors) if r_ood else None
        result["methods" if m in METHODS else "reference"][m] = summary
    copy, nn, truth = result["reference"]["leader_copy"], result["methods"]["nn_motion"], result["reference"]["truth"]
    for row in (*result["methods"].values(), *result["reference"].values()):
        restate(row, leader_copy=copy, nn_motion=nn, truth=truth)
        if row["ood"] is not None:
            restate(row["ood"], leader_copy=copy["ood"], nn_motion=nn["ood"], truth=truth["ood"])
    result["motif_regions"] = [p.motif_region for p in pairs]
    if speed_pairs:
        speed = {m: _speed_summary(speed_rows[m], speed_pairs) for m in (*METHODS, *REFERENCES)}
        for row in speed.values():
            row["gt_mpjpe_local_vs_leader_copy"] = row["gt_mpjpe_local"] / max(speed["leader_copy"]["gt_mpjpe_local"],
                                                                                 1e-9)
        result["speed"] = {"pairs": len(speed_pairs), "rows": speed,
                           "captions": [(p.leader.captions[0], p.follower.captions[0]) for p in speed_pairs]}
    result["root_choice"] = root_choice(rows, speed_rows)
    momo = result["methods"]["momo"]
    truth = result["reference"]["truth"]
    result["targets"] = {
        "gt_mpjpe_vs_nn_motion": momo["gt_mpjpe"] / max(nn["gt_mpjpe"], 1e-9),
        "gt_mpjpe_local_vs_leader_copy": momo["gt_mpjpe_local_vs_leader_copy"],
        "foot_contact": momo["foot_contact"],
        "follower_loc": momo["follower_loc"],
        "ood_vs_in_distribution": (momo["ood"]["gt_mpjpe"] / max(momo["gt_mpjpe"], 1e-9)) if momo["ood"] else None,
        "truth_foot_contact": truth["foot_contact"],  # what the ground truth itself scores on the two above
        "truth_follower_loc": truth["follower_loc"],
        "momo_gen_foot_contact": result["methods"]["momo_gen"]["foot_contact"],  # the paper's generated setting
        "momo_gen_follower_loc": result["methods"]["momo_gen"]["follower_loc"],
        "speed_error": result["speed"]["rows"]["momo"]["speed_error"] if speed_pairs else None,
    }
    result["seconds"] = time.time() - t0
    return result


def root_choice(rows: dict, speed_rows: dict) -> dict:
    """How the default root mode is chosen: per mode (its ``momo_<mode>`` row), the root speed error against the
    truth over every pair (main and speed pairs together, each pair once), the path error (``gt_mpjpe``, main
    pairs) and the pose error (``gt_mpjpe_local``, all pairs). The pick: the lowest speed error (what the root
    mode decides; the pose error barely moves with it), ties to the lower path error."""
    out = {}
    for mode in ("rotation", "trajectory"):
        every = rows[f"momo_{mode}"] + speed_rows[f"momo_{mode}"]
        out[mode] = {"speed_error": float(np.mean([r["speed_error"] for r in every])),
                     "gt_mpjpe": float(np.mean([r["gt_mpjpe"] for r in rows[f"momo_{mode}"]])),
                     "gt_mpjpe_local": float(np.mean([r["gt_mpjpe_local"] for r in every])), "n": len(every)}
    pick = min(out, key=lambda m: (round(out[m]["speed_error"], 3), out[m]["gt_mpjpe"]))
    return {"modes": out, "pick": pick, "default": TransferConfig().root}


def rows_of(speed_rows: dict, rows: dict, speed_pair: bool) -> str:
    """The log line's figures of the last pair: momo's pose error, or its speed against the truth's."""
    if speed_pair:
        r = speed_rows["momo"][-1]
        return f"{r['speed']:.2f} m/s (truth {r['speed_truth']:.2f}, leader copy {speed_rows['leader_copy'][-1]['speed']:.2f})"
    return f"{rows['momo'][-1]['gt_mpjpe_local']:.3f} m pose, leader copy {rows['leader_copy'][-1]['gt_mpjpe_local']:.3f} m"


def format_table(result: dict) -> str:
    head = f"{'method':<20}" + "".join(f"{k:>17}" for k in KEYS)
    lines = [head, "-" * len(head)]
    rows = list(result["methods"].items())
    rows += [(f"({m})", r) for m, r in result.get("reference", {}).items()]
    for m, row in rows:
        for name, r in ((m, row), (f"  {m} ood", row.get("ood"))):
            if r is None:
                continue
            lines.append(f"{name:<20}" + "".join(f"{r[k]:>17.3f}" for k in KEYS))
    if all(k in row for _, row in rows for k in RESTATED):  # results of older runs lack the restated figures
        lines.append("")
        lines.append("restated: gt_mpjpe_local as a ratio to leader_copy's / nn_motion's, |foot_contact - truth's|, "
                     "|follower_loc - truth's|, motif-joint error (m, pose only), |root speed - truth's| / truth's")
        names = ("mpjpe_loc/copy", "mpjpe_loc/nn", "|foot - truth|", "|loc - truth|", "motif_mpjpe_loc",
                 "|speed err|")
        head2 = f"{'method':<20}" + "".join(f"{k:>17}" for k in names)
        lines += [head2, "-" * len(head2)]
        for m, row in rows:
            for name, r in ((m, row), (f"  {m} ood", row.get("ood"))):
                if r is not None:
                    lines.append(f"{name:<20}" + "".join(f"{r[k]:>17.3f}" for k in RESTATED))
        regions = result.get("motif_regions", [])
        lines.append(f"motif joints per pair: {regions.count('arms')} arms (shoulders, elbows, wrists), "
                     f"{regions.count('body')} whole body (posture styles)")
    speed = result.get("speed")
    if speed:
        lines.append("")
        lines.append(f"speed: {speed['pairs']} walk <-> run pairs, root speed of the output / the truth's (the truth: "
                     "the follower gait's stride at the leader's step times), |error| / truth's, pose error")
        names = ("walk->run", "run->walk", "|speed err|", "gt_mpjpe_local", "mpjpe_loc/copy")
        head3 = f"{'method':<20}" + "".join(f"{k:>17}" for k in names)
        lines += [head3, "-" * len(head3)]
        for m, r in speed["rows"].items():
            name = m if m in result["methods"] else f"({m})"
            cells = [r["walk_run_ratio"], r["run_walk_ratio"], r["speed_error"], r["gt_mpjpe_local"],
                     r["gt_mpjpe_local_vs_leader_copy"]]
            lines.append(f"{name:<20}" + "".join(f"{'n/a':>17}" if c is None else f"{c:>17.3f}" for c in cells))
    choice = result.get("root_choice")
    if choice:
        lines.append("")
        modes = choice["modes"]
        lines.append("root modes over all pairs (main + speed): " + "; ".join(
            f"{m}: speed error {r['speed_error']:.2f}, gt_mpjpe {r['gt_mpjpe']:.3f} m, gt_mpjpe_local "
            f"{r['gt_mpjpe_local']:.3f} m" for m, r in modes.items()))
        verdict = "the default" if choice["pick"] == choice["default"] else f"NOT the default ({choice['default']})"
        lines.append(f"the bench picks root={choice['pick']} (lowest speed error): {verdict}")
    t = result["targets"]
    lines.append("")
    if "gt_mpjpe_local_vs_leader_copy" in t:
        lines.append(f"momo (default root: {result.get('default_root', '?')}) gt_mpjpe_local / leader_copy: "
                     f"{t['gt_mpjpe_local_vs_leader_copy']:.2f} (target <= 0.8)"
                     + ("" if t.get("speed_error") is None else
                        f"; walk <-> run speed error {t['speed_error']:.2f} of the truth's"))
    lines.append(f"momo gt_mpjpe / nn_motion: {t['gt_mpjpe_vs_nn_motion']:.2f} (target <= 0.5); foot_contact "
                 f"{t['foot_contact']:.3f} (>= 0.90); follower_loc {t['follower_loc']:.3f} (>= 0.97); ood / in "
                 + ("n/a" if t["ood_vs_in_distribution"] is None else f"{t['ood_vs_in_distribution']:.2f}") + " (<= 1.5)")
    if "truth_foot_contact" in t:
        lines.append(f"the ground truth itself scores foot_contact {t['truth_foot_contact']:.3f} and follower_loc "
                     f"{t['truth_follower_loc']:.3f}; momo_gen (generated streams, the paper's MoMo Gen.) "
                     f"{t['momo_gen_foot_contact']:.3f} and {t['momo_gen_follower_loc']:.3f}")
    lines.append(f"{result['pairs']} pairs ({result['ood_pairs']} held-out), {result['steps']} steps, "
                 f"{result['seconds']:.0f} s")
    return "\n".join(lines)
