"""A method's options are declared once (issue #34, item 1), the tabs' side: each tab's settings parameter that is an
engine option is made from the option's declaration (``app.components.option_params.param_for``), so its default,
bounds, widget range, step, choices, label and help are the engine's; the widgets made from it (``from_param``,
``pn.Param``) show them, and a changed declaration changes them."""
from __future__ import annotations

import math
import subprocess
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import panel as pn
import param
import pytest

from app.components.option_params import param_for, widget_doc
from app.session.generation import GenerateBox
from app.tabs.compose.settings import ComposeSettings
from app.tabs.control.settings import METHOD_LABELS, ControlSettings
from app.tabs.duet.settings import DuetSettings
from app.tabs.edit.settings import EditSettings
from app.tabs.transfer.settings import ROOT_LABELS, TransferSettings
from engine.methods.control_options import ControlOptions
from engine.methods.doubletake_config import SecondTake
from engine.methods.duet_options import DuetOptions
from engine.methods.edit_options import EditOptions
from engine.methods.transfer_config import TransferConfig
from engine.options import option, spec
from engine.sampling_options import SampleOptions

ROOT = Path(__file__).resolve().parents[1]

# (tab settings, parameter) -> (options class, option, what the tab overrides on purpose)
FROM_OPTIONS = {
    (EditSettings, "word"): (EditOptions, "word", {"default"}),
    (EditSettings, "occurrence"): (EditOptions, "occurrence", set()),
    (EditSettings, "mode"): (EditOptions, "mode", {"objects", "default"}),  # the session opens on its model's mode
    (EditSettings, "weight"): (EditOptions, "weight", {"default"}),  # the mode's default weight
    (EditSettings, "step_window"): (EditOptions, "step_window", set()),
    (EditSettings, "layers"): (EditOptions, "layers", {"default"}),
    (EditSettings, "fraction"): (EditOptions, "fraction", set()),
    (EditSettings, "count"): (EditOptions, "count", set()),
    (EditSettings, "chunk_frames"): (EditOptions, "chunk_frames", set()),
    (EditSettings, "edited"): (EditOptions, "edited", {"default"}),
    (ControlSettings, "seconds"): (ControlOptions, "seconds", {"bounds"}),
    (ControlSettings, "method"): (ControlOptions, "method", {"default", "objects"}),
    (TransferSettings, "root"): (TransferConfig, "root", {"objects"}),
    (TransferSettings, "directions"): (TransferConfig, "directions", set()),
    (TransferSettings, "feet"): (TransferConfig, "feet", set()),
    (ComposeSettings, "second_take_text"): (SecondTake, "text", set()),
    (DuetSettings, "prompt"): (DuetOptions, "prompt", {"default"}),
    (DuetSettings, "seconds"): (DuetOptions, "seconds", {"default"}),
    (DuetSettings, "prefix_seconds"): (DuetOptions, "prefix_seconds", {"default"}),
    (DuetSettings, "communicate"): (DuetOptions, "communication", {"doc"}),
    (DuetSettings, "contact"): (DuetOptions, "contact", {"doc"}),
    (GenerateBox, "seed"): (SampleOptions, "seed", set()),
    (GenerateBox, "steps"): (SampleOptions, "steps", set()),
    (GenerateBox, "guidance"): (SampleOptions, "guidance", set()),
}


def _open(bounds):
    return None if bounds is None else tuple(None if math.isinf(v) else v for v in bounds)


@pytest.mark.parametrize("settings, name", list(FROM_OPTIONS), ids=[f"{c.__name__}.{n}" for c, n in FROM_OPTIONS])
def test_a_tab_parameter_is_its_engine_option(settings, name):
    cls, option_name, overridden = FROM_OPTIONS[settings, name]
    p, s = settings.param[name], spec(cls, option_name)
    if "default" not in overridden:
        assert p.default == s.default, (p.default, s.default)
    if isinstance(p, (param.Number, param.Range)):
        if "bounds" not in overridden:
            assert p.bounds == _open(s.bounds)
        assert p.softbounds == _open(s.soft)
        if s.step is not None:
            assert p.step == s.step
    if s.label is not None:
        assert p.label == s.label
    if "doc" not in overridden:
        assert p.doc == widget_doc(s) and p.doc.startswith(s.help)
    if s.choices is not None:
        objects = p.objects.values() if isinstance(p.objects, dict) else p.objects
        assert sorted(objects) == sorted(s.choices)


def test_what_a_tab_overrides_is_what_it_says():
    assert EditSettings().word == "" and EditSettings().layers == [] and EditSettings().edited == ""
    assert ControlSettings.param.seconds.bounds is None  # the engine's frames_for names a length out of range
    assert ControlSettings.param.seconds.softbounds == spec(ControlOptions, "seconds").bounds
    assert ControlSettings.param.method.objects == METHOD_LABELS and ControlSettings.param.method.default == "inpainting"
    assert TransferSettings.param.root.objects == ROOT_LABELS
    assert DuetSettings.param.seconds.default == 5.0 and DuetSettings.param.prefix_seconds.default == 1.0
    assert not DuetSettings.param.seconds.allow_None  # a length: emptying the box shows the default again


def test_the_edit_tabs_sliders_have_the_engines_bounds():
    e = EditSettings()
    for name, widget in (("count", pn.widgets.IntSlider), ("chunk_frames", pn.widgets.IntSlider)):
        s = spec(EditOptions, name)
        slider = widget.from_param(e.param[name])
        assert (slider.start, slider.end, slider.value, slider.name) == (*s.bounds, s.default, s.label)
        with pytest.raises(ValueError):
            setattr(e, name, s.bounds[1] + 1)
    s = spec(EditOptions, "fraction")
    slider = pn.widgets.FloatSlider.from_param(e.param.fraction)
    assert (slider.start, slider.end, slider.step, slider.value, slider.name) == (*s.soft, s.step, s.default, s.label)
    mode = pn.widgets.RadioButtonGroup.from_param(e.param.mode)  # its help is its tooltip (the view's Tooltip)
    assert mode.description == widget_doc(spec(EditOptions, "mode")) and mode.options == e.param.mode.objects


def test_pn_param_makes_the_same_kinds_of_widgets():
    """What ``pn.Param`` makes of the converted parameters: the kinds the tabs had before (sliders for bounded
    numbers, a select for choices, a checkbox for a switch, a box for a number with no range)."""
    kinds = {(EditSettings, "count"): pn.widgets.IntSlider, (EditSettings, "fraction"): pn.widgets.FloatSlider,
             (EditSettings, "weight"): pn.widgets.FloatSlider, (EditSettings, "mode"): pn.widgets.Select,
             (EditSettings, "edited"): pn.widgets.TextInput, (TransferSettings, "directions"): pn.widgets.IntSlider,
             (TransferSettings, "feet"): pn.widgets.Checkbox, (TransferSettings, "root"): pn.widgets.Select,
             (ControlSettings, "seconds"): pn.widgets.FloatSlider, (GenerateBox, "seed"): pn.widgets.IntInput,
             (GenerateBox, "steps"): pn.widgets.IntSlider, (ComposeSettings, "second_take_text"): pn.widgets.Checkbox}
    for (settings, name), kind in kinds.items():
        widgets = pn.Param(settings.param, parameters=[name], show_name=False)
        assert type(widgets._widgets[name]) is kind, (settings.__name__, name)  # noqa: SLF001 (panel keeps them there)


@dataclass(frozen=True, kw_only=True)
class Tiny:
    level: int = option(3, bounds=(1, 5), whole=True, label="Level", help="a level")
    ratio: float = option(0.5, bounds=(0.0, 1.0), soft=(0.2, 0.8), step=0.1, unit="m", note="a note", help="a ratio")
    kind: str = option("a", choices=("a", "b"), help="a kind")
    flag: bool = option(False, help="a switch")
    word: str | None = option(None, help="a word")
    count: int = option(0, bounds=(0, math.inf), whole=True, help="how many")
    window: tuple[float, float] | None = option(None, nargs=2, type=float, help="a window")
    items: tuple[int, ...] | None = option(None, nargs="+", type=int, help="some items")
    length: float | None = option(None, help="a length")


def test_param_for_makes_each_kind_from_the_declaration():
    made = {name: param_for(Tiny, name) for name in ("level", "ratio", "kind", "flag", "word", "count", "window",
                                                     "items", "length")}
    level, ratio = made["level"], made["ratio"]
    assert type(level) is param.Integer and (level.default, level.bounds, level.label, level.doc) == (
        3, (1, 5), "Level", "a level (1 to 5)")
    assert type(ratio) is param.Number and (ratio.bounds, ratio.softbounds, ratio.step) == ((0.0, 1.0), (0.2, 0.8), 0.1)
    assert ratio.doc == "a ratio (0 to 1 m; a note)"
    assert type(made["kind"]) is param.Selector and made["kind"].objects == ["a", "b"]
    assert type(made["flag"]) is param.Boolean and made["flag"].default is False
    assert type(made["word"]) is param.String and made["word"].default is None and made["word"].allow_None
    assert type(made["count"]) is param.Integer and made["count"].bounds == (0, None)  # an infinite end is open
    assert type(made["window"]) is param.Range and made["window"].allow_None
    assert type(made["items"]) is param.List and made["items"].item_type is int
    assert type(made["length"]) is param.Number and made["length"].allow_None
    assert param_for(spec(Tiny, "level")).bounds == (1, 5)  # a Spec works as well as (class, name)


def test_labelled_choices_must_be_the_declared_ones():
    assert param_for(Tiny, "kind", objects={"first": "a", "second": "b"}).objects == {"first": "a", "second": "b"}
    with pytest.raises(ValueError, match="the objects offer"):
        param_for(Tiny, "kind", objects={"first": "a", "third": "c"})
    with pytest.raises(ValueError, match="declares no choices"):
        param_for(Tiny, "level", objects=[1, 2])


@dataclass(frozen=True, kw_only=True)
class Changed:
    level: int = option(4, bounds=(2, 9), whole=True, label="Another level", help="another level")


def test_a_changed_declaration_reaches_the_widget(monkeypatch):
    """param_for reads the declaration when the settings class is made: another declaration, another widget."""
    def settings():
        class Settings(param.Parameterized):
            level = param_for(Tiny, "level")

        return Settings

    before = pn.widgets.IntSlider.from_param(settings().param.level)
    assert (before.start, before.end, before.value, before.name) == (1, 5, 3, "Level")
    monkeypatch.setitem(Tiny.__dataclass_fields__, "level", Changed.__dataclass_fields__["level"])
    changed = settings()
    after = pn.widgets.IntSlider.from_param(changed.param.level)
    assert (after.start, after.end, after.value, after.name) == (2, 9, 4, "Another level")
    assert pn.widgets.IntInput.from_param(changed.param.level).description == "another level (2 to 9)"
    with pytest.raises(ValueError):
        changed(level=1)  # the new bounds hold for the settings too
    count = replace(spec(EditOptions, "count"), default=2, bounds=(2, 4), soft=(2, 4), label="Outputs")
    assert (param_for(count).default, param_for(count).bounds, param_for(count).label) == (2, (2, 4), "Outputs")


def test_the_helper_and_the_edit_settings_load_without_torch():
    code = ("import sys; import app.components.option_params, engine.sampling_options, app.tabs.edit.settings; "
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "False", out.stderr
