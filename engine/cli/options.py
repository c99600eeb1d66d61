"""Flags generated from declared options (:mod:`engine.options`): the one place a `moattn` command's flags are
made from a dataclass, and read back into it.

- :func:`add_options` adds one argparse argument per declared field of an options class: its flag, default, type
  (the ``parse`` function, else the default's type), choices, nargs, metavar and help (the declared help, then
  bounds, default and notes in parentheses). A bool with a False default is a switch (``store_true``); one with a
  True default and a ``--no-...`` flag turns it off. Metadata ``group`` puts a flag in an argument group,
  ``exclusive`` in a mutually exclusive one.
- :func:`from_args` builds the options class from the parsed flags (plus values the command computed), each
  flag's value checked against its declared bounds first, named by its flag: ``--directions must be between 1 and 8,
  got 0`` (``check=False``: the class's own validate names it).
- :class:`SampleOptions` (declared in :mod:`engine.sampling_options`, which the studio's Generate box reads too):
  the flags every sampling command shares (seed, steps, guidance, model); the defaults are engine.units's and
  engine.paths's.
"""
from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable, Mapping
from dataclasses import fields
from pathlib import Path
from typing import Any

from engine.options import Spec, specs
from engine.sampling_options import SampleOptions  # noqa: F401 (re-exported: declared there, the studio reads it too)


def describe(spec: Spec, note: str = "") -> str:
    """A flag's help: the declared help, then (bounds; default; notes)."""
    parts = [spec.range_text()] if spec.bounds is not None else []
    if spec.has_default and spec.default not in (None, "") and not isinstance(spec.default, bool) or spec.none:
        parts.append(f"default {spec.default_text()}")
    parts += [n for n in (spec.note, note) if n]
    return f"{spec.help} ({'; '.join(parts)})" if parts else spec.help


def _parser(parse: Callable[[str], Any], name: str) -> Callable[[str], Any]:
    """``parse`` as an argparse type: its ValueError becomes argparse's one-line error, said as it is."""
    if parse in (int, float, str, Path):
        return parse

    def read(text: str):
        try:
            return parse(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    read.__name__ = name
    return read


def argument(spec: Spec, *, help: str, given_only: bool = False) -> tuple[tuple[str, ...], dict]:  # noqa: A002
    """(names, keyword arguments) of ``spec``'s argparse argument. ``given_only``: default None (a flag left out
    reads None, so the command can tell it from one given with the default's value)."""
    kw: dict[str, Any] = {"help": help}
    if not spec.positional:
        kw["dest"] = spec.dest
    default = spec.default if spec.has_default else None
    if isinstance(default, bool) and spec.action is None:
        turn_off = default and spec.flag.startswith("--no-")
        kw["action"] = "store_false" if turn_off else "store_true" if not default else argparse.BooleanOptionalAction
        kw["default"] = None if given_only and kw["action"] is argparse.BooleanOptionalAction else default
        return (spec.flag,), kw
    element = default[0] if isinstance(default, tuple) and default else default
    parse = spec.parse or spec.type or (Path if isinstance(element, Path) else
                                        type(element) if element is not None else None)
    if parse is not None and parse is not str:
        kw["type"] = _parser(parse, spec.name)
    for key in ("choices", "nargs", "metavar", "action"):
        if getattr(spec, key) is not None:
            kw[key] = getattr(spec, key)
    if spec.required:
        kw["required"] = True
    elif spec.has_default or spec.positional:
        kw["default"] = None if given_only else default
    return (spec.flag,), kw


def add_options(parser: argparse.ArgumentParser, cls, *, skip: Iterable[str] = (), only: Iterable[str] | None = None,
                notes: Mapping[str, str] | None = None, helps: Mapping[str, str] | None = None,
                describe_with: Callable[[Spec], str] | None = None, given_only: bool = False) -> list[Spec]:
    """One argument per declared, command-line option of ``cls`` (those in ``only``, none in ``skip``): returns
    their specs. ``notes``: name -> text appended to the help; ``helps``: name -> the whole help instead;
    ``describe_with``: spec -> help for every option. Metadata ``group`` (a title) and ``exclusive`` (a name) place
    the argument in an argument group / a mutually exclusive group of ``parser``."""
    chosen = [s for s in specs(cls) if s.cli and s.name not in set(skip) and (only is None or s.name in set(only))]
    groups: dict[str, Any] = {}
    meta = {f.name: f.metadata for f in fields(cls)}
    for s in chosen:
        text = (helps or {}).get(s.name) or (describe_with(s) if describe_with
                                             else describe(s, (notes or {}).get(s.name, "")))
        names, kw = argument(s, help=text, given_only=given_only)
        exclusive, title = meta[s.name].get("exclusive"), meta[s.name].get("group")
        if exclusive and exclusive not in groups:
            groups[exclusive] = parser.add_mutually_exclusive_group()
        elif title and title not in groups:
            groups[title] = parser.add_argument_group(title)
        (groups[exclusive] if exclusive else groups[title] if title else parser).add_argument(*names, **kw)
    return chosen


def values(args: argparse.Namespace, cls, *, skip: Iterable[str] = ()) -> dict[str, Any]:
    """The parsed values of ``cls``'s command-line options (lists from nargs as tuples)."""
    out = {}
    for s in specs(cls):
        if s.cli and s.name not in set(skip) and hasattr(args, s.dest):
            value = getattr(args, s.dest)
            out[s.name] = tuple(value) if isinstance(value, list) and s.action != "append" else value
    return out


def check_args(args: argparse.Namespace, cls, *, skip: Iterable[str] = ()) -> None:
    """Every parsed option of ``cls`` within its declared bounds and choices: one line naming its flag."""
    by_name = {s.name: s for s in specs(cls)}
    for name, value in values(args, cls, skip=skip).items():
        by_name[name].check(value, what=by_name[name].flag)


def from_args(cls, args: argparse.Namespace, *, skip: Iterable[str] = (), check: bool = True, **given):
    """``cls`` from the parsed flags: each flag's value checked (named by its flag; ``check=False``: left to the
    class's own validate), then ``given`` (values the command computed, e.g. a source file loaded) in place of the
    flags of those names."""
    skip = (*skip, *given)
    if check:
        check_args(args, cls, skip=skip)
    return cls(**values(args, cls, skip=skip), **given)


def add_sample_options(parser: argparse.ArgumentParser, **kw) -> list[Spec]:
    """``--seed``, ``--steps``, ``--guidance``, ``--guidance-from``, ``--eta``, ``--model`` (``kw``: see
    :func:`add_options`)."""
    return add_options(parser, SampleOptions, **kw)


SAMPLING_FIELDS = ("seed", "steps", "guidance", "guidance_from", "eta")  # SampleOptions' fields SampleConfig takes


def sample_config(args: argparse.Namespace, **overrides):
    """The ``engine.generate.SampleConfig`` of a command's sampling flags (those it has; ``overrides`` win)."""
    from engine.generate import SampleConfig

    given = {name: getattr(args, name) for name in SAMPLING_FIELDS if getattr(args, name, None) is not None}
    return SampleConfig(**{**given, **overrides})
