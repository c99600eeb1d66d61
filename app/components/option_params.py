"""A tab's settings parameter made from an engine option's declaration (:mod:`engine.options`): issue #34's "declared
once", the tab's side. The option's default, bounds, widget range and step, choices, label and help become the
``param`` parameter a widget is made from (``from_param`` / ``pn.Param``), so a tab never restates them::

    class EditSettings(param.Parameterized):
        count = param_for(EditOptions, "count")

Overrides are for what the tab shows differently on purpose (labelled choices, an example prompt as the default)
and should be rare; say why beside each. Torch-free: it reads dataclass fields only.
"""
from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import MISSING
from typing import Any

import param

from engine.options import Spec, spec as declared_spec

_LISTS = ("+", "*")  # nargs that make a list of values


def param_for(spec_or_cls: Spec | type, name: str | None = None, **overrides: Any) -> param.Parameter:
    """The parameter for one declared option: ``param_for(Options, "name")`` or ``param_for(a_spec)``.

    Its kind follows the declaration: choices -> Selector, two numbers (``nargs=2``) -> Range, several values ->
    List, a bool -> Boolean, a whole number (``whole`` or an int default) -> Integer, a number -> Number, else
    String. ``bounds`` are the declared bounds, ``softbounds`` the declared widget range (``soft``), an infinite
    end open (None); ``label`` the declared label (none: param's, from the attribute's name); ``doc`` the declared
    help with its bounds, unit and note. None is allowed when the default is None. ``overrides`` replace any of
    these (``objects=`` must offer exactly the declared choices, e.g. labelled ones)."""
    s = _spec(spec_or_cls, name)
    default = overrides.pop("default", None if s.default is MISSING else s.default)
    kind, kwargs = _kind(s, default)
    kwargs.update(default=default, label=s.label, doc=widget_doc(s))
    if default is None:
        kwargs["allow_None"] = True
    if "objects" in overrides:
        _check_objects(s, overrides["objects"])
    kwargs.update(overrides)
    return kind(**kwargs)


def widget_doc(spec: Spec) -> str:
    """A widget's help (its tooltip): the declared help, then its bounds with their unit, and its note."""
    parts = [spec.range_text()] if spec.bounds is not None else []
    parts += [spec.note] if spec.note else []
    return f"{spec.help} ({'; '.join(parts)})" if parts else spec.help


def _spec(spec_or_cls: Spec | type, name: str | None) -> Spec:
    if isinstance(spec_or_cls, Spec):
        if name is not None and name != spec_or_cls.name:
            raise ValueError(f"the spec given is {spec_or_cls.name!r}, not {name!r}")
        return spec_or_cls
    if name is None:
        raise TypeError(f"param_for({spec_or_cls.__name__}) needs the option's name")
    return declared_spec(spec_or_cls, name)


def _kind(s: Spec, default: Any) -> tuple[type[param.Parameter], dict]:
    """The parameter class for ``s`` and its keyword arguments besides default, label, doc and allow_None."""
    value = default if default is not None else s.default if s.default not in (None, MISSING) else None
    if s.choices is not None:
        return param.Selector, {"objects": list(s.choices)}
    if s.nargs == 2 or _is_pair(value):
        return param.Range, _numbers(s)
    if s.nargs in _LISTS or s.action == "append":
        return param.List, {"item_type": s.type} if s.type is not None else {}
    if isinstance(value, bool):
        return param.Boolean, {}
    if s.whole or _is_int(value) or value is None and s.type is int:
        return param.Integer, _numbers(s)
    if isinstance(value, numbers.Real) or value is None and s.type is float:
        return param.Number, _numbers(s)
    if isinstance(value, str) or value is None and s.type is str:
        return param.String, {}
    raise TypeError(f"option {s.name!r} (default {value!r}) has no widget parameter kind: give it a type")


def _numbers(s: Spec) -> dict:
    out = {"bounds": _open(s.bounds), "softbounds": _open(s.soft)}
    if s.step is not None:
        out["step"] = s.step
    return out


def _open(bounds: tuple[float, float] | None) -> tuple | None:
    """Declared bounds as param's: an infinite end is open (None)."""
    if bounds is None:
        return None
    return tuple(None if math.isinf(v) else v for v in bounds)


def _is_int(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _is_pair(value: Any) -> bool:
    return isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, numbers.Real) for v in value)


def _check_objects(s: Spec, objects: Any) -> None:
    """Labelled choices offer exactly the declared ones: a choice the engine lacks (or one left out) is a mistake."""
    if s.choices is None:
        raise ValueError(f"option {s.name!r} declares no choices to label")
    values = list(objects.values()) if isinstance(objects, Mapping) else list(objects)
    if sorted(values) != sorted(s.choices):
        raise ValueError(f"option {s.name!r}: the objects offer {values}, the declaration {list(s.choices)}")

