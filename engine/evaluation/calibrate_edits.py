"""How and in which layers emphasis should act, measured per model (``moattn bench --edits --calibrate [--write]``).

MotionCLR adds the weight to a word's cross-attention column in every layer. In a small denoiser the
layers do not all agree: in some, more attention to the verb makes the action bigger; in others it
makes it smaller (the model's own division of labour between layers). This measures, one layer at a
time, how the action's amplitude answers the emphasis weight (the same measure as ``moattn bench --edits``: the rank
correlation, scaled down where the change is too small to see, :func:`engine.evaluation.bench_edits.emphasis_response`;
on base v5 the rank correlation alone chose a layer whose emphasis moved the amplitude by 0.6 %) on calibration
prompts that the benchmark does not use, and builds the
layer set by forward selection (layers interact, so a set is measured as a whole). It does so for each way of
weighting the column, added (the paper's) or multiplied (which scales the word's pull where it already acts, not at
every frame alike); guide mode (the prediction moved away from the one with the word erased,
:mod:`engine.methods.word_guidance`) and intensity mode (moved towards the prompt said with the action's intensity
word, :mod:`engine.methods.intensity`) are measured once, over every layer. It keeps the mode that responds best.
The result goes into the model's ``config.json`` ("edits": {"emphasize_mode": "add"|"mul"|"guide"|"intensity",
"emphasize_layers": [...], "calibration": {...}}), where
the CLI, the app and the benchmark read it as the emphasis default (grounding acts in every layer: on the shipped model the
calibrated layers put fewer jumps in the chosen spans than no grounding at all, see the edits bench's grounding row).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from engine.checkpoint import LoadedModel, read_config, write_config_json
from engine.generate import SampleConfig
from engine.methods import edits
from engine.methods.edit_options import SWEEP_WEIGHTS, sweep_weights
from engine.methods.emphasis_modes import GUIDED_MODES
from engine.methods.intensity import scales
from engine.methods.motionclr import ReweightConfig
from engine.methods.windows import Window
from engine.units import DEFAULT_ETA, DEFAULT_GUIDANCE


@dataclass(frozen=True)
class CalibrationConfig:
    #: (prompt, verb) pairs; none of them is an emphasis prompt of ``moattn bench --edits``
    prompts: tuple[tuple[str, str], ...] = (
        ("a person jumps forward", "jumps"), ("a person kicks with the left leg", "kicks"),
        ("a person waves the left hand", "waves"), ("a person hops on the left leg", "hops"),
        ("a person punches with the left hand", "punches"))
    #: the modes measured (each gets its own layer set; the better one is kept): adding to the word's attention
    #: column as the paper does, or multiplying it (on base v9 adding in the chosen layers shrank the bench's actions,
    #: Spearman -0.35, while multiplying in layer 0 grew jumps and kicks, +0.33)
    modes: tuple[str, ...] = tuple(SWEEP_WEIGHTS)
    #: how many of the mode's sweep weights (engine.methods.edit_options.SWEEP_WEIGHTS) are sampled: 5, or 3 (the
    #: lowest, the unedited and the highest)
    points: int = 5
    seeds: int = 2
    #: sample as the studio, ``moattn edit`` and ``moattn bench --edits`` do (50): a 10-step calibration measures another
    #: regime (on the step-16000 model the bench's emphasis figure is 0.28 at 10 steps, 0.75 at 50)
    steps: int = SampleConfig().steps
    guidance: float = DEFAULT_GUIDANCE
    eta: float = DEFAULT_ETA
    seconds: float = 5.0
    threshold: float = 0.3
    min_gain: float = 0.02
    #: a set that ties on score (within min_gain) still wins when its amplitude change is this share bigger
    min_change_gain: float = 0.2
    #: forward selection adds only layers among the best ``candidates`` single layers (None: any layer)
    candidates: int | None = None

    def __post_init__(self) -> None:
        unknown = [m for m in self.modes if m not in SWEEP_WEIGHTS]
        if unknown or not self.modes:
            raise ValueError(f"calibration modes must be among {', '.join(SWEEP_WEIGHTS)}, got {self.modes}")
        sweep_weights(self.modes[0], self.points)  # a clear error for a sweep of another length

    def weights(self, mode: str) -> tuple[float, ...]:
        """The weights sampled for ``mode``, lowest to highest."""
        return sweep_weights(mode, self.points)

    @classmethod
    def quick(cls) -> "CalibrationConfig":
        """About a third of the work (``moattn bench --edits --calibrate --quick``): three weights per mode, and sets
        built from the three best single layers."""
        return cls(points=3, candidates=3)


class Response(NamedTuple):
    """A layer set's emphasis response over the calibration draws: ``score`` (rank correlation x visible size,
    ``emphasis_response``'s score) and ``change`` (the amplitude's relative change from the lowest to the highest
    weight), both means."""

    score: float
    change: float


def response(loaded: LoadedModel, layers: tuple[int, ...], config: CalibrationConfig, *, mode: str = "add") -> Response:
    """The mean emphasis response over the calibration prompts and seeds, emphasis in ``layers`` only, in ``mode``."""
    from engine.analysis.action_size import amplitude
    from engine.evaluation.bench_edits import emphasis_response

    frames = int(config.seconds * 20)
    weights = config.weights(mode)
    draws = []
    for prompt, verb in config.prompts:
        loaded.tokenizer.encode(prompt).word_index(verb)  # a clear error if the model lacks a word
        if mode == "intensity" and not scales(verb):  # no intensity word ("punches"): the mode cannot emphasise it
            draws += [{"score": 0.0, "change": 0.0}] * config.seeds
            continue
        for seed in range(config.seeds):
            sample = SampleConfig(steps=config.steps, guidance=config.guidance, eta=config.eta, seed=seed)
            configs = [ReweightConfig(word=verb, weight=w, mode=mode, window=Window(layers=layers)) for w in weights]
            amps = [amplitude(edits.reweight(loaded, prompt, cfg, frames=frames, sample=sample).after, verb)
                    for cfg in configs]
            draws.append(emphasis_response(weights, amps))
    return Response(score=float(np.mean([d["score"] for d in draws])),
                    change=float(np.mean([d["change"] for d in draws])))


def _better(trial: Response, current: Response, config: CalibrationConfig) -> bool:
    """Does ``trial`` beat ``current``: a higher score by more than ``min_gain``, or a tie in score (within
    ``min_gain``: with three weights and the visible-size cap, many sets score alike) and a change bigger by more
    than ``min_change_gain`` of it (the bigger effect a user sees)?"""
    if trial.score > current.score + config.min_gain:
        return True
    bigger = trial.change > current.change + abs(current.change) * config.min_change_gain
    return trial.score >= current.score - config.min_gain and bigger


#: modes measured once with every layer, not layer by layer: guide's other pass is the prediction without the word,
#: which erasing the word's column in every layer gives (a per-layer search would cost twice a plain mode's);
#: intensity's is the prediction for another prompt, which has no layers
WHOLE_MODEL_MODES = GUIDED_MODES


def _select_layers(loaded: LoadedModel, config: CalibrationConfig, mode: str, log) -> dict:
    """Forward selection of the layers for one mode -> {"layers", "best" (their Response), "per_layer", "history"}."""
    if mode in WHOLE_MODEL_MODES:
        every = list(range(loaded.model.num_layers))
        best = response(loaded, tuple(every), config, mode=mode)
        log(f"{mode}: every layer: response {best.score:+.2f} (change {best.change:+.0%})")
        return {"layers": every, "best": best, "per_layer": {},
                "history": [{"layers": every, "response": round(best.score, 3), "change": round(best.change, 3)}]}
    per_layer: dict[int, Response] = {}
    for layer in range(loaded.model.num_layers):
        per_layer[layer] = response(loaded, (layer,), config, mode=mode)
        log(f"{mode}: layer {layer} alone: response {per_layer[layer].score:+.2f} "
            f"(change {per_layer[layer].change:+.0%})")
    ranked = sorted(per_layer, key=lambda k: per_layer[k], reverse=True)  # the best single layer first
    pool = ranked[: config.candidates] if config.candidates else ranked
    chosen, best = ranked[:1], per_layer[ranked[0]]
    history = [{"layers": list(chosen), "response": round(best.score, 3), "change": round(best.change, 3)}]
    while len(chosen) < len(pool):
        trials = {layer: response(loaded, tuple(sorted(chosen + [layer])), config, mode=mode)
                  for layer in pool if layer not in chosen}
        for layer, r in trials.items():
            log(f"{mode}: layers {sorted(chosen + [layer])}: response {r.score:+.2f} (change {r.change:+.0%})")
        layer = max(trials, key=lambda k: trials[k])
        if not _better(trials[layer], best, config):
            break
        chosen, best = sorted(chosen + [layer]), trials[layer]
        history.append({"layers": list(chosen), "response": round(best.score, 3), "change": round(best.change, 3)})
    return {"layers": chosen, "best": best, "per_layer": {str(k): round(v.score, 3) for k, v in per_layer.items()},
            "history": history}


def calibrate_emphasis(loaded: LoadedModel, config: CalibrationConfig = CalibrationConfig(), *, log=print) -> dict:
    """The emphasis mode and layers -> {"mode", "layers": [...], "per_layer": {layer: score}, "history": [...],
    "modes": {mode: its own figures}, ...}.

    For each mode, every layer is measured alone; the best one starts the set, and the layer whose addition raises
    the set's response most is added while it beats the set (:func:`_better`: a higher score, or as high a score and
    a bigger change). The mode whose set responds best is kept (the first listed on a tie). No layer is kept when the
    final set responds below ``threshold`` (emphasis then acts in all layers): layers too weak alone may still
    qualify together.
    """
    t0 = time.perf_counter()
    found = {mode: _select_layers(loaded, config, mode, log) for mode in config.modes}
    mode = config.modes[0]
    for other in config.modes[1:]:
        if _better(found[other]["best"], found[mode]["best"], config):
            mode = other
    chosen = found[mode]
    best = chosen["best"]
    kept = chosen["layers"] if best.score >= config.threshold else []
    fallback = {}
    if mode == "intensity":  # for a word without intensity words ("punches"): the best of the other modes
        others = [m for m in config.modes if m != "intensity"]
        if others:
            runner = others[0]
            for other in others[1:]:
                if _better(found[other]["best"], found[runner]["best"], config):
                    runner = other
            good = found[runner]["best"].score >= config.threshold
            fallback = {"fallback": {"mode": runner, "layers": found[runner]["layers"] if good else []}}
    return {"mode": mode, "layers": kept, **fallback, "response": round(best.score, 3), "change": round(best.change, 3),
            "per_layer": chosen["per_layer"], "history": chosen["history"],
            "modes": {m: {"layers": f["layers"], "response": round(f["best"].score, 3),
                          "change": round(f["best"].change, 3), "per_layer": f["per_layer"]} for m, f in found.items()},
            "threshold": config.threshold, "prompts": [p for p, _ in config.prompts], "seeds": config.seeds,
            "steps": config.steps, "weights": {m: list(config.weights(m)) for m in config.modes}, "eta": config.eta,
            "candidates": config.candidates, "seconds_taken": round(time.perf_counter() - t0, 1)}


def write_calibration(folder: Path, result: dict) -> None:
    """Store the chosen mode and layers in the model folder's config.json (all layers when none qualified)."""
    data = read_config(folder)
    edits = {k: v for k, v in data.get("edits", {}).items() if k != "emphasize_fallback"}
    fallback = result.get("fallback")
    data["edits"] = {**edits, "emphasize_mode": result.get("mode", "add"),
                     "emphasize_layers": result["layers"] or None,
                     **({"emphasize_fallback": {"mode": fallback["mode"], "layers": fallback["layers"] or None}}
                        if fallback else {}),
                     "calibration": {k: v for k, v in result.items() if k not in ("layers", "mode", "fallback")}}
    write_config_json(folder, data)
