"""The ways emphasis can act, declared once: each mode's weight range, label, default weight, benchmark sweep, and
whether it edits the attention maps or guides the prediction through a denoiser wrapper.

``engine.methods.edit_options`` (the CLI flags, the Edit tab, the checks), ``engine.methods.motionclr`` (the
config and its controller), ``engine.methods.edit_kinds`` (the one-line description) and
``engine.evaluation.calibrate_edits`` (which modes are searched layer by layer) all read this table.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EmphasisMode:
    name: str
    label: str  # how it reads in a front end (the Edit tab's mode buttons)
    range: tuple[float, float]  # the weights it accepts
    why: str  # what lies past the range (the message of a weight outside it)
    default: float  # the weight it starts from when none is given
    sweep: tuple[float, ...]  # what a benchmark or a calibration sweeps, lowest to highest, unedited in the middle
    guided: bool = False  # edits no attention map: a denoiser wrapper guides the prediction; measured once, not per layer
    suffix: str = ""  # after the weight in a one-line description
    in_layers: bool = True  # acts in the chosen layers (intensity guides through another prompt: no layers)

    def check(self, weight: float) -> None:
        lo, hi = self.range
        if not lo <= weight <= hi:
            raise ValueError(f"the {self.name} weight must be between {lo:g} and {hi:g} ({self.why}), got {weight:g}")


# Measured on the shipped model ("a person jumps twice", emphasis on "jumps", 3 seeds): the trunk's largest
# pitch is 36 deg unedited, 55 deg at add +0.5 or mul x3, and 68 deg ("bent double") at add +1.0.
_BENT = "past that the body bends out of shape"
MODES: dict[str, EmphasisMode] = {m.name: m for m in (
    EmphasisMode("add", "add +w", (-0.5, 0.5), _BENT, 0.3, (-0.4, -0.2, 0.0, 0.2, 0.4)),
    # multiplying from x0.5 to x2 around the unedited x1, as adding goes from -0.4 to +0.4 around 0
    EmphasisMode("mul", "multiply ×w", (0.0, 3.0), _BENT, 2.0, (0.5, 0.75, 1.0, 1.5, 2.0)),
    # session 39: the attention left as it is, the prediction moved away from the one whose word column is erased:
    # x0 + w (x0 - x0 without the word)
    EmphasisMode("guide", "guide +w", (-1.0, 1.0), "-1 is the word erased; past +1 the motion leaves the corpus", 0.5,
                 (-0.5, -0.25, 0.0, 0.5, 1.0), guided=True, suffix=" guided"),
    # session 41: the prediction moved towards the prompt said with the corpus's intensity word for the word's action
    # ("a person jumps high" for w > 0, "a person jumps a little" for w < 0, by |w|): +-1 is that prompt
    EmphasisMode("intensity", "intensity ±w", (-1.0, 1.0),
                 "+1 is the prompt said with the action's high word, -1 with its little word", 0.5,
                 (-1.0, -0.5, 0.0, 0.5, 1.0), guided=True, suffix=" by intensity", in_layers=False),
)}
GUIDED_MODES: tuple[str, ...] = tuple(name for name, m in MODES.items() if m.guided)
