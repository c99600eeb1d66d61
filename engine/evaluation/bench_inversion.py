"""`moattn bench --inversion`: the DDIM inversion round trip, motion -> noise -> motion, as a yardstick.

Measured on three sets of motions, each under two settings (plain DDIM inversion, ``refine`` and ``landing`` 0,
and the fixed-point refinement of every step and of the first one, clean -> the cleanest timestep, that
``moattn invert`` uses by default, ``InversionConfig().refine`` and ``.landing``):

- ``corpus``: test-split corpus motions, inverted with their caption;
- the real reference motions: every motion file in the shared real-data folder (``engine.paths.REAL_DATA_DIR``:
  BVH files and HumanML3D joints / vectors ``.npy``; files that are not motions, such as the HumanML3D
  Mean/Std, are listed as skipped), inverted without text; an absent folder is said in one line;
- files given on the command line, inverted without text.

Real and given motions are cut to the model's longest duration (its config's ``max_frames``, 9.8 s for the
shipped model; ``engine.io.window``). Figures per motion and setting (``roundtrip_error``): ``mean_m`` / ``max_m``,
the joint position error in metres of the motion sampled back from the inverted noise against the input's own
feature decoding, ``pose_mean_m``, the same for the joints relative to the root (the pose without the root's path,
which integrates the root's velocities and drifts), and ``noise_std``, the standard deviation of the inverted noise
(the Gaussian noise the model samples from has 1). JSON: ``corpus`` holds the default setting's figures (the mean of
``mean_m``, ``pose_mean_m`` and ``noise_std`` over the motions, the max of ``max_m``), ``corpus_by_setting`` both
settings; each entry of ``files`` holds the default setting's figures and ``by_setting`` both.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engine.checkpoint import LoadedModel
from engine.io import SUPPORTED_SUFFIXES, load_motion
from engine.io.window import seconds_of
from engine.methods.inversion import InversionConfig, roundtrip_error
from engine.paths import REAL_DATA_DIR

_DEFAULT = InversionConfig()  # what `moattn invert` uses unless told otherwise
# name -> fixed-point iterations per step (refine) and of the first step (landing)
SETTINGS = {"plain_ddim": {"refine": 0, "landing": 0},
            "fixed_point": {"refine": _DEFAULT.refine, "landing": _DEFAULT.landing}}
DEFAULT_SETTING = "fixed_point"
FIGURES = ("mean_m", "max_m", "pose_mean_m", "noise_std")


@dataclass(frozen=True)
class InversionBenchConfig:
    motions: int = 16  # corpus test motions
    steps: int = 50
    real_data: Path | None = REAL_DATA_DIR  # folder of real motions to invert as well (None: none)
    first_seed: int = 20_000  # corpus test motions first_seed, first_seed + 1, ...

    def __post_init__(self) -> None:
        if self.motions < 0:
            raise ValueError(f"the number of corpus motions must be 0 or more, got {self.motions}")
        if not 1 <= self.steps <= 1000:
            raise ValueError(f"steps must be between 1 and 1000, got {self.steps}")

    @classmethod
    def quick(cls) -> "InversionBenchConfig":
        return cls(motions=6)


@dataclass
class Motion:
    source: str
    joints: np.ndarray
    prompt: str = ""
    real: bool = False
    trimmed_from_s: float | None = None


def real_motions(folder: Path | None, max_frames: int, *, log=print) -> tuple[list[Motion], dict]:
    """Every motion file in ``folder`` (sorted by name) cut to ``max_frames`` poses, and what was found there."""
    info = {"folder": None if folder is None else str(folder), "present": False, "skipped": []}
    if folder is None:
        return [], info
    folder = Path(folder)
    if not folder.is_dir():
        log(f"real-data folder {folder} is absent: inverting the corpus and given files only")
        return [], info
    info["present"] = True
    out = []
    for path in sorted(folder.iterdir()):
        if not path.is_file() or path.suffix.lower() not in SUPPORTED_SUFFIXES:
            continue
        try:
            joints = load_motion(path)
        except ValueError as exc:  # the HumanML3D Mean/Std and other arrays that are not motions
            info["skipped"].append({"source": path.name, "reason": str(exc)})
            log(f"skipped {path.name}: {exc}")
            continue
        out.append(_cut(path.name, joints, max_frames, real=True))
    return out, info


def given_motions(files, max_frames: int) -> list[Motion]:
    """The files given on the command line (a file that cannot be read is an error), cut to ``max_frames``."""
    return [_cut(str(path), load_motion(path), max_frames) for path in files]


def _describe(setting: dict) -> str:
    return ", ".join(f"{k} {v}" for k, v in setting.items())


def _cut(source: str, joints: np.ndarray, max_frames: int, *, real: bool = False) -> Motion:
    cut = joints[:max_frames]  # the model's longest duration
    return Motion(source=source, joints=cut, real=real,
                  trimmed_from_s=seconds_of(len(joints)) if len(cut) < len(joints) else None)


def measure(loaded: LoadedModel, motion: Motion, steps: int, *, log=print) -> dict:
    """One motion's figures under every setting: {source, seconds, ..., the default's figures, by_setting}."""
    by_setting = {}
    for name, setting in SETTINGS.items():
        r = roundtrip_error(loaded, motion.joints, InversionConfig(prompt=motion.prompt, steps=steps, **setting))
        by_setting[name] = {**setting, **r}
        log(f"{motion.source} {name}: mean {r['mean_m'] * 100:.2f} cm, max {r['max_m'] * 100:.2f} cm, "
            f"pose {r['pose_mean_m'] * 100:.2f} cm, noise std {r['noise_std']:.3f}")
    default = by_setting[DEFAULT_SETTING]
    return {"source": motion.source, "real": motion.real, "seconds": seconds_of(len(motion.joints)),
            "trimmed_from_s": motion.trimmed_from_s, **default, "by_setting": by_setting}


def summary(rows: list[dict]) -> dict:
    """Mean error, max error and mean noise std over ``rows`` (one setting's figures per motion)."""
    if not rows:
        return {"mean_m": None, "max_m": None, "pose_mean_m": None, "noise_std": None, "motions": 0}
    return {"mean_m": float(np.mean([r["mean_m"] for r in rows])), "max_m": float(np.max([r["max_m"] for r in rows])),
            "pose_mean_m": float(np.mean([r["pose_mean_m"] for r in rows])),
            "noise_std": float(np.mean([r["noise_std"] for r in rows])), "motions": len(rows)}


def bench_inversion(loaded: LoadedModel, config: InversionBenchConfig = InversionBenchConfig(), files=(), *,
                    log=print) -> dict:
    from engine.synth import Corpus

    t0 = time.time()
    max_frames = loaded.model.config.max_frames
    given = given_motions(files, max_frames)  # a bad path fails before the long part
    real, real_info = real_motions(config.real_data, max_frames, log=log)
    corpus = Corpus(split="test")
    corpus_motions = []
    for i in range(config.motions):
        s = corpus.sample(config.first_seed + i, with_features=False)
        corpus_motions.append(Motion(source=f"corpus test {config.first_seed + i}",
                                     joints=s.joints[:max_frames], prompt=s.captions[0]))
    log(f"inversion benchmark: {len(corpus_motions)} corpus motions, {len(real)} real, {len(given)} given; "
        f"{config.steps} steps, settings {', '.join(f'{n} ({_describe(s)})' for n, s in SETTINGS.items())}")
    corpus_rows = [measure(loaded, m, config.steps, log=log) for m in corpus_motions]
    file_rows = [measure(loaded, m, config.steps, log=log) for m in real + given]
    by_setting = {name: {**setting, **summary([r["by_setting"][name] for r in corpus_rows])}
                  for name, setting in SETTINGS.items()}
    return {
        "corpus": by_setting[DEFAULT_SETTING],
        "corpus_by_setting": by_setting,
        "corpus_motions": [{k: r[k] for k in ("source", "seconds", "by_setting")} for r in corpus_rows],
        "files": file_rows,
        "real_data": real_info,
        "default_setting": DEFAULT_SETTING,
        "settings": dict(SETTINGS),
        "max_seconds": seconds_of(max_frames),
        "steps": config.steps,
        "elapsed_s": time.time() - t0,
    }


def format_table(result: dict) -> str:
    label = {"plain_ddim": "plain DDIM", "fixed_point": "fixed point"}
    head = f"{'motion':<34}{'s':>6}  {'setting':<20}{'mean cm':>9}{'max cm':>9}{'pose cm':>9}{'noise std':>11}"
    lines = [head, "-" * len(head)]

    def row(name: str, seconds: str, setting: str, r: dict) -> str:
        if r["mean_m"] is None:
            return f"{name:<34}{seconds:>6}  {setting:<20}{'n/a':>9}{'n/a':>9}{'n/a':>9}{'n/a':>11}"
        return (f"{name:<34}{seconds:>6}  {setting:<20}{r['mean_m'] * 100:>9.2f}{r['max_m'] * 100:>9.2f}"
                f"{r['pose_mean_m'] * 100:>9.2f}{r['noise_std']:>11.3f}")

    def setting_name(name: str) -> str:
        setting = result["settings"][name]
        return f"{label.get(name, name)} (r{setting['refine']} l{setting['landing']})" + (
            " *" if name == result["default_setting"] else "")

    corpus = result["corpus_by_setting"]
    motions = next(iter(corpus.values()))["motions"]
    for i, (name, r) in enumerate(corpus.items()):
        lines.append(row(f"corpus ({motions} test motions)" if i == 0 else "", "", setting_name(name), r))
    for f in result["files"]:
        source = Path(f["source"]).name if f["real"] else f["source"]
        if len(source) > 33:
            source = "…" + source[-32:]
        seconds = f"{f['seconds']:.1f}" + ("✂" if f["trimmed_from_s"] is not None else "")
        for i, (name, r) in enumerate(f["by_setting"].items()):
            lines.append(row(source if i == 0 else "", seconds if i == 0 else "", setting_name(name), r))
    lines.append("")
    lines.append("pose cm: the joints relative to the root (the root's path, integrated from its velocities, taken out)")
    lines.append(f"* the default (moattn invert); r = fixed-point iterations per step, l = of the first step (clean -> the cleanest timestep); corpus: mean of the means, max of "
                 f"the maxima, mean noise std (pure noise: 1); {result['steps']} steps, {result['elapsed_s']:.0f} s")
    real = result["real_data"]
    if real["folder"] is None:
        lines.append("real data: not asked for")
    elif not real["present"]:
        lines.append(f"real data: the folder {real['folder']} is absent")
    else:
        count = sum(f["real"] for f in result["files"])
        skipped = ", ".join(s["source"] for s in real["skipped"])
        lines.append(f"real data: {count} motion files in {real['folder']}"
                     + (f" (not motions, skipped: {skipped})" if skipped else ""))
    trimmed = [f for f in result["files"] if f["trimmed_from_s"] is not None]
    if trimmed:
        lines.append(f"✂ cut to the model's first {result['max_seconds']:.1f} s: "
                     + ", ".join(f"{Path(f['source']).name} ({f['trimmed_from_s']:.1f} s)" for f in trimmed))
    return "\n".join(lines)
