"""The window of a motion: which poses of a longer file to keep, given in seconds at the project's fps.

One home for the rule every entry point shares (``moattn convert / invert / transfer --start --seconds``,
the studio's import, the inversion benchmark, :func:`engine.methods.inversion.invert`):

- a motion is ``len(joints)`` poses long, ``len(joints) / FPS`` seconds;
- a window starts at pose ``round(start * FPS)`` and holds ``round(seconds * FPS)`` poses (``seconds`` left
  out: to the end of the motion); it must hold at least 2 poses and end within the motion;
- with a model's ``max_frames`` (its config's longest sequence), a window or a whole motion may hold at most
  ``max_frames`` poses, i.e. ``max_frames / FPS`` seconds (9.8 s for the shipped model), the same limit as
  a generated motion's;
- the file itself is imported whole only up to ``MAX_IMPORT_SECONDS`` (:mod:`engine.io.errors`, 10 minutes):
  the readers refuse a longer file from its header, naming that limit, before reading its motion.

Every problem is a one-line ``ValueError`` that names the option to change (``--start`` / ``--seconds`` on the
command line; the app passes its own field names).
"""
from __future__ import annotations

import math

import numpy as np

from engine.units import FPS
from engine.io.errors import MAX_IMPORT_SECONDS  # noqa: F401 - the import cap, stated once (see the docstring)

FLAGS = ("--start", "--seconds")


def seconds_of(frames: int) -> float:
    """The duration of ``frames`` poses in seconds (of a model's ``max_frames``: the longest motion it takes)."""
    return frames / FPS


def window_slice(total: int, *, start: float | None = None, seconds: float | None = None,
                 max_frames: int | None = None, name: str = "the motion",
                 flags: tuple[str, str] = FLAGS, hint: str | None = None) -> slice:
    """The poses ``[first, first + count)`` of a ``total``-pose motion to keep (see the module's rule).

    ``start`` and ``seconds`` both None keeps the whole motion (refused when it is longer than ``max_frames``
    poses, with ``hint``, by default "pick a window with START/SECONDS" naming ``flags``). Raises ``ValueError``
    with one line saying what to change.
    """
    start_flag, seconds_flag = flags
    length = f"{name} ({seconds_of(total):.1f} s, {total} frames)"
    limit = None if max_frames is None else seconds_of(max_frames)
    if start is None and seconds is None:
        if max_frames is not None and total > max_frames:
            raise ValueError(f"{name} is {seconds_of(total):.1f} s, longer than the model's {limit:.1f} s: "
                             + (hint or f"pick a window with {start_flag}/{seconds_flag}"))
        return slice(0, total)
    start = 0.0 if start is None else seconds_number(start, start_flag)
    if start < 0:
        raise ValueError(f"{start_flag} must be 0 s or more, got {start:g} s")
    first = int(round(start * FPS))
    if first >= total:
        raise ValueError(f"{start_flag} {start:g} s is beyond the end of {length}")
    if seconds is None:
        count = total - first
        if max_frames is not None and count > max_frames:
            raise ValueError(f"{name} from {start:g} s to its end is {seconds_of(count):.1f} s, longer than the "
                             f"model's {limit:.1f} s: add {seconds_flag} (at most {limit:g})")
    else:
        seconds = seconds_number(seconds, seconds_flag)
        if seconds <= 0:
            raise ValueError(f"{seconds_flag} must be more than 0 s, got {seconds:g} s")
        count = int(round(seconds * FPS))
        if max_frames is not None and count > max_frames:
            raise ValueError(f"{seconds_flag} {seconds:g} s is longer than the model's {limit:.1f} s")
        if first + count > total:
            raise ValueError(f"the window {start:g} s + {seconds:g} s runs past the end of {length}: "
                             f"at most {seconds_of(total - first):g} s from {start:g} s")
    if count < 2:
        raise ValueError(f"the window holds {count} frame(s) of {name}; at least 2 are needed "
                         f"({2 / FPS:g} s at {FPS} fps)")
    return slice(first, first + count)


def pick_window(joints: np.ndarray, *, start: float | None = None, seconds: float | None = None,
                max_frames: int | None = None, name: str = "the motion",
                flags: tuple[str, str] = FLAGS, hint: str | None = None) -> np.ndarray:
    """The poses of ``joints`` (T, 22, 3) in the window (see :func:`window_slice`); the whole motion when neither
    ``start`` nor ``seconds`` is given and it fits ``max_frames``."""
    return joints[window_slice(len(joints), start=start, seconds=seconds, max_frames=max_frames, name=name,
                               flags=flags, hint=hint)]


def seconds_number(value, what: str) -> float:
    """``value`` as a finite number of seconds; else a one-line ValueError naming ``what`` (a flag or a field)."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be a number of seconds, got {value!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{what} must be a number of seconds, got {value}")
    return value
