"""A user option declared once: a dataclass field whose metadata holds its help, label, bounds, choices, unit and
how a command line spells it. Torch-free and argparse-free: the method reads the field, :func:`validate` checks it,
``engine.cli.options`` turns the fields into flags (and flags back into the dataclass), the studio's tabs read
labels, bounds and help from :func:`spec`.

Declare with :func:`option`::

    @dataclass(frozen=True, kw_only=True)
    class MyOptions:
        strength: float = option(0.5, bounds=(0.0, 1.0), label="Strength", help="how strongly ...")

        def __post_init__(self):
            validate(self)

Older declarations (``engine.methods.edit_options._option``, ``control_options.option``, ``transfer_config.option``,
``doubletake_config.option``) put the same keys in a field's metadata; :func:`specs` reads them all.
"""
from __future__ import annotations

import math
import numbers
import re
from collections.abc import Callable, Sequence
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any

# metadata keys an option may carry (beyond help); their meaning, see `option`
_KEYS = ("label", "bounds", "soft", "step", "choices", "unit", "flag", "metavar", "nargs", "parse", "cli", "none",
         "note", "positional", "action", "required", "type", "whole")


def option(default: Any = MISSING, *, help: str, label: str | None = None,  # noqa: A002 (argparse's word)
           bounds: tuple[float, float] | None = None, soft: tuple[float, float] | None = None,
           step: float | None = None, choices: Sequence[str] | Callable[[], Sequence[str]] | None = None, unit: str = "", flag: str | None = None,
           metavar: str | tuple[str, ...] | None = None, nargs: int | str | None = None,
           parse: Callable[[str], Any] | None = None, cli: bool = True, none: str = "", note: str = "",
           positional: bool = False, action: str | None = None, required: bool = False, type: type | None = None,  # noqa: A002
           whole: bool = False, group: str | None = None, exclusive: str | None = None,
           default_factory: Any = MISSING):
    """A field declared as a user option.

    ``bounds`` (inclusive) are checked by :func:`validate`; ``soft`` is the range a widget offers (default the
    bounds) with ``step``; ``choices`` for a word (or a function returning them, read when asked); ``unit`` is said after numbers; ``whole``: an integer.
    Command line: ``flag`` (default ``--name-with-dashes``; ``--no-x`` for a True default turns it off),
    ``metavar``, ``nargs``, ``parse`` (the text -> value function; default the default's type, or ``type``),
    ``action`` ("append"), ``positional``, ``required``, ``group`` (an argument group's title), ``exclusive`` (a
    mutually exclusive group's name); ``cli=False`` keeps it off the command line. ``none`` says
    what a None default means; ``note`` is appended to the flag's help.
    """
    metadata = {"option": True, "help": help, "label": label, "bounds": bounds, "soft": soft or bounds, "step": step,
                "choices": choices if choices is None or callable(choices) else tuple(choices), "unit": unit, "flag": flag,
                "metavar": metavar, "nargs": nargs, "parse": parse, "cli": cli, "none": none, "note": note,
                "positional": positional, "action": action, "required": required, "type": type, "whole": whole,
                "group": group, "exclusive": exclusive}
    if default_factory is not MISSING:
        return field(default_factory=default_factory, metadata=metadata)
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class Spec:
    """One declared option, read back from its field."""

    name: str
    default: Any  # dataclasses.MISSING when the field has none
    help: str
    label: str | None = None
    bounds: tuple[float, float] | None = None
    soft: tuple[float, float] | None = None
    step: float | None = None
    choices: tuple[str, ...] | None = None
    unit: str = ""
    flag_name: str | None = None
    metavar: Any = None
    nargs: Any = None
    parse: Callable[[str], Any] | None = None
    cli: bool = True
    none: str = ""
    note: str = ""
    positional: bool = False
    action: str | None = None
    required: bool = False
    type: type | None = None
    whole: bool = False

    @property
    def flag(self) -> str:
        """``--the-flag`` (a declared flag may be written with or without the dashes)."""
        if self.positional:
            return self.name
        name = self.flag_name or self.name.replace("_", "-")
        return name if name.startswith("--") else "--" + name

    @property
    def dest(self) -> str:
        """Where argparse keeps the value: the flag's name (``--count-method`` -> ``count_method``), except a
        ``--no-x`` switch, kept under the field's own name (its value is the field's)."""
        if self.positional or self.flag.startswith("--no-") and self.default is True:
            return self.name
        return self.flag[2:].replace("-", "_")

    @property
    def has_default(self) -> bool:
        return self.default is not MISSING

    def default_text(self) -> str:
        """The default as help says it (``none`` for a None default)."""
        if self.default is None or self.default is MISSING:
            return self.none
        if isinstance(self.default, float):
            return f"{self.default:g}"
        if isinstance(self.default, tuple):
            return " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in self.default)
        from engine.paths import shown_default  # a shipped folder as the project names it, not this machine's path

        return str(shown_default(self.default))

    def range_text(self) -> str:
        """The bounds as help says them ("0 to 20", "1 or more s"); '' without bounds."""
        if self.bounds is None:
            return ""
        lo, hi = self.bounds
        said = f"{lo:g} or more" if math.isinf(hi) else f"{lo:g} to {hi:g}"
        return f"{said} {self.unit}" if self.unit else said

    def check(self, value: Any, *, what: str | None = None) -> None:
        """One line (ValueError) unless ``value`` is within the declared bounds / choices (None passes when the
        default is None; a tuple is checked item by item)."""
        if value is None and (self.default is None or not self.has_default):
            return
        label = what or self.name
        if self.choices is not None and value not in self.choices:
            raise ValueError(f"{label} must be one of {', '.join(map(str, self.choices))}, got {value!r}")
        if self.bounds is None:
            return
        for item in value if isinstance(value, (tuple, list)) else (value,):
            _check_number(item, self.bounds, label=label, unit=self.unit, whole=self.whole)


def _check_number(value, bounds, *, label: str, unit: str, whole: bool) -> None:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ValueError(f"{label} must be a {'whole ' if whole else ''}number, got {value!r}")
    if whole and value != int(value):
        raise ValueError(f"{label} must be a whole number, got {value!r}")
    lo, hi = bounds
    if not lo <= value <= hi:
        upper = "" if hi == math.inf else f" and {hi:g}"
        said = f"between {lo:g}{upper}" if upper else f"at least {lo:g}"
        raise ValueError(f"{label} must be {said}{' ' + unit if unit else ''}, got {value:g}")


_TYPES = {"int": int, "float": float, "str": str, "Path": Path}


def _annotated(annotation) -> type | None:
    """The value type an annotation names first (``int | None`` -> int, ``tuple[float, float]`` -> float)."""
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
    words = [w for w in re.split(r"[^\w]+", text) if w and w not in ("tuple", "Optional", "None", "list")]
    return _TYPES.get(words[0]) if words else None


def specs(cls) -> list[Spec]:
    """Every declared option of the dataclass ``cls`` (fields whose metadata has a help), in declaration order."""
    out = []
    for f in fields(cls):
        m = f.metadata
        if "help" not in m:
            continue
        default = f.default if f.default is not MISSING else (
            f.default_factory() if f.default_factory is not MISSING else MISSING)
        given = {k: m[k] for k in _KEYS if m.get(k) is not None}
        if "flag" in given:
            given["flag_name"] = given.pop("flag")
        if "type" not in given and "parse" not in given and (default is None or default is MISSING):
            given["type"] = _annotated(f.type)  # a None default: the value's type from the annotation
        if "choices" in given:  # a callable: read when asked (a registry that may grow)
            given["choices"] = tuple(given["choices"]() if callable(given["choices"]) else given["choices"])
        out.append(Spec(name=f.name, default=default, help=m["help"], **given))
    return out


def spec(cls, name: str) -> Spec:
    """The declaration of option ``name`` of ``cls``."""
    for s in specs(cls):
        if s.name == name:
            return s
    raise KeyError(f"{cls.__name__} has no declared option {name!r}")


def validate(obj, *, names: Callable[[Spec], str] | None = None):
    """Check every declared option of the dataclass instance ``obj`` against its bounds and choices; the first
    value out of them is one ValueError line naming it (``names(spec)``, default the field's name). Returns ``obj``."""
    for s in specs(type(obj)):
        s.check(getattr(obj, s.name), what=names(s) if names else None)
    return obj
