"""MoMo's transfer settings (the step and layer window, the root, the footwork, the direction trick), declared once:
fields, bounds, defaults, labels and help, read by the method, the CLI's flags (``moattn transfer``) and the studio's
Transfer tab. Torch-free, so a command line's parser can read its defaults.

Each user option is a dataclass field whose metadata holds its ``label``, ``help`` and, for numbers, ``bounds``
(inclusive); :func:`option_info` reads them back and :func:`check_option` is the one range check (a one-line
ValueError). The root modes carry their own label and help (:data:`ROOT_CHOICES`).
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, Literal

from engine.options import option

# mode -> (label in the studio, help). The default is chosen by ``moattn bench --transfer`` (see ROOT_DEFAULT).
ROOT_CHOICES: dict[str, tuple[str, str]] = {
    "trajectory": ("leader's path",
                   "the leader's root rotation and linear velocity are inpainted at every step: the output keeps the "
                   "leader's path and speed (a walk -> run runs at walking speed); its root height stays its own (but "
                   "see the flights option)"),
    "rotation": ("leader's heading (paper)",
                 "the paper's fix: the leader's root rotation (angular velocity about the vertical) is copied into the "
                 "finished output, which keeps its own speed and stride (a walk -> run runs at running speed) but "
                 "also travels as its follower does (a dance leader with a walking follower walks off)"),
    "none": ("its own", "the output's own root (direction and speed): nothing is taken from the leader's root"),
}
ROOT_MODES = tuple(ROOT_CHOICES)
# Chosen by `moattn bench --transfer` (its "the bench picks root=..." line: the lower root speed error over every
# pair). `bench --transfer --quick`, shipped model: trajectory 0.17 vs rotation 1.11 of the truth's speed over all
# 22 pairs. "rotation" wins the 6 walk <-> run pairs (output / truth speed 0.99 and 0.92 vs 0.68 and 1.47) but,
# travelling as its follower does, misses the path on the 16 others (gt_mpjpe 1.89 m vs 0.12 m, speed error 1.75
# vs 0.11); the pose error is the same (gt_mpjpe_local 0.096 vs 0.095 m).
ROOT_DEFAULT = "trajectory"
MAX_DIRECTIONS = 8


@dataclass(frozen=True)
class OptionInfo:
    name: str
    default: Any
    label: str
    help: str
    bounds: tuple[float, float] | None

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")


@dataclass(frozen=True)
class TransferConfig:
    """Where the output mixes, and how (each option's help is its declaration's; this adds how they interact).

    ``layers``: 0-based blocks that mix; None = every layer but the first (paper: 2-12 of 12).
    ``hard``: arg-max instead of softmax (the latent nearest-neighbour baseline; not a user option).
    ``directions`` > 1 applies to every follower: an imported follower is inverted once per turned copy, a
    generated one sampled once per seed, and the batch holds each copy (one stream each).
    """

    start: float = option(0.1, bounds=(0.0, 1.0), cli=False, label="First step that mixes (fraction of the run)",
                          help="fraction of the sampling run where mixing starts (paper: step 90 of 100 = 0.1)")
    end: float = option(0.9, bounds=(0.0, 1.0), cli=False, label="Last step that mixes (fraction of the run)",
                        help="fraction of the sampling run where mixing ends (paper: step 10 of 100 = 0.9)")
    layers: tuple[int, ...] | None = None
    root: Literal["trajectory", "rotation", "none"] = option(
        ROOT_DEFAULT, choices=ROOT_MODES, label="Root of the out", note="chosen by `moattn bench --transfer`",
        help="what the output takes from the leader's root: " + "; ".join(f"{m}: {h}" for m, (_, h) in
                                                                         ROOT_CHOICES.items()))
    hard: bool = False
    feet: bool = option(False, flag="--keep-feet", label="keep the leader's footwork (feet and contacts; not in the paper)",
                        help="also keep the leader's footwork (not in the paper): its foot-contact labels and the feet "
                             "and ankles' root-relative positions are inpainted at every step, so the output steps "
                             "exactly where and when the leader does and the follower shows in the rest of the body "
                             "(its own gait style and walk -> run changes are given up)")
    flights: bool = option(True, label="lift the out with the leader's flights (not in the paper)",
                           help="where the leader is off the floor (its lowest foot over 5 cm above its own floor: a "
                                "jump, a hop), the finished out is lifted so its lowest foot is as high above its "
                                "floor as the leader's: MoMo builds the out from its follower's values, and a walking "
                                "follower has no airborne frame, so without this a jumping leader's out stays on the "
                                "floor (session 38)")
    directions: int = option(
        1, bounds=(1, MAX_DIRECTIONS), whole=True, metavar="N", label="Follower directions (the paper's direction trick)",
        help="the paper's direction trick: each output attends over this many copies of its follower, concatenated "
             "in time, so each leader frame finds the copy heading its way: a generated follower is sampled once per "
             "seed, an imported one turned about the vertical axis (its heading turning by 360/N degree steps over "
             "the clip) and inverted once per copy. 1 = off; costs one stream per copy")

    def __post_init__(self) -> None:
        if self.root not in ROOT_MODES:
            raise ValueError(f"root must be one of {', '.join(repr(m) for m in ROOT_MODES)}, got {self.root!r}")
        for name in ("start", "end"):
            check_option(name, getattr(self, name), what=f"the step window's {name}")
        if isinstance(self.directions, bool) or not isinstance(self.directions, int):
            raise ValueError(f"directions must be a whole number, got {self.directions!r}")
        check_option("directions", self.directions)
        from engine.methods.windows import Window

        Window(self.start, self.end)  # validates the step window

    def window(self, n_layers: int):
        from engine.methods.windows import Window

        layers = tuple(range(1, n_layers)) if self.layers is None else tuple(self.layers)
        if not layers:
            raise ValueError("mixed attention needs at least one layer")
        return Window(self.start, self.end, layers=layers).check_layers(n_layers)


def option_info(name: str) -> OptionInfo:
    """The declared default, label, help and bounds of one option of :class:`TransferConfig`."""
    for f in fields(TransferConfig):
        if f.name == name and "help" in f.metadata:
            return OptionInfo(name, f.default, f.metadata["label"], f.metadata["help"], f.metadata["bounds"])
    raise KeyError(f"TransferConfig has no option {name!r}")


def check_option(name: str, value, *, what: str | None = None) -> None:
    """ValueError (one line) unless ``value`` is a finite number within the declared bounds of option ``name``."""
    info = option_info(name)
    label = what or name
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value:
        raise ValueError(f"{label} must be a number, got {value!r}")
    lo, hi = info.bounds
    if not lo <= value <= hi:
        raise ValueError(f"{label} must be between {lo:g} and {hi:g}, got {value:g}")


GENERATED_SECONDS = 5.0  # a prompt's leader/follower without --seconds


@dataclass(frozen=True, kw_only=True)
class TransferSources:
    """Where a transfer's leader and followers come from: prompts, or motion files (a window of them)."""

    leader: str = option(required=True, help="the leader: a prompt, or a .bvh/.npy motion to invert")
    leader_prompt: str | None = option(None, help="describes an imported leader (guides its inversion)")
    follower: tuple[str, ...] = option(required=True, action="append",
                                       help="a follower: a prompt or a .bvh/.npy motion (repeat for several followers)")
    follower_prompt: tuple[str, ...] | None = option(
        None, action="append", type=str, help="describes an imported follower (repeat in the order of --follower)")
    seconds: float | None = option(None, type=float, help=f"length of generated leaders/followers (default "
                                   f"{GENERATED_SECONDS:g}); with --start also the window cut from leader/follower "
                                   "files (default: to the end, at most the model's 9.8 s)")
    start: float | None = option(None, type=float, metavar="SECONDS",
                                 help="cut leader/follower files to a window starting this many seconds in (its "
                                      "length: --seconds); without it a file is taken whole")


@dataclass(frozen=True, kw_only=True)
class QKAnalysisOptions:
    """`moattn analyze-qk`'s own settings (MoMo's Q/K analysis figures)."""

    per_prompt: int = option(2, help="motions per built-in prompt to fit the clusters on")
    components: int = option(10, help="PCA dimensions (paper: 10)")
    clusters: int = option(10, help="K-Means clusters (paper: 10)")
    query_frames: tuple[int, ...] | None = option(None, nargs="+", type=int, help="leader frames for per-query maps")
