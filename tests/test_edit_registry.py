"""One registry of MotionCLR edit kinds: the CLI's choices, the Edit tab's buttons and fields, and the dispatch
all read it, so a kind is added by one entry."""
from __future__ import annotations

import pytest

from engine.cli import build_parser
from engine.methods import edit_kinds
from engine.methods.edit_kinds import INPUTS, KINDS, REGISTRY, EditKind
from engine.methods.edit_options import EditOptions, build_config, run_edit


def test_the_cli_and_the_tab_offer_the_registry():
    from app.tabs.edit.settings import KIND_HELP, KIND_LABELS

    parser = build_parser()
    for kind in KINDS:
        assert parser.parse_args(["edit", kind, "a person jumps"]).kind == kind
    with pytest.raises(SystemExit):
        parser.parse_args(["edit", "mirror", "a person jumps"])
    assert set(KIND_LABELS.values()) == set(KINDS) and set(KIND_HELP) == set(KINDS)


def test_the_tab_shows_exactly_the_fields_a_kind_reads(tiny_model_dir):
    from app.main import Studio

    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        tab = st.edit
        widgets = {"word": tab.words, "weight": tab.weight, "mode": tab.mode, "frames": tab.frames,
                   "edited": tab.edited, "style": tab.style_source, **tab.plain}
        for name, entry in REGISTRY.items():
            tab.kind.value = entry.label
            shown = {field for field, w in widgets.items() if w.visible}
            if tab.spans_box.visible:  # grounding's frames: several spans dragged on the word's curve
                assert not tab.frames.visible and name == "ground"
                shown.add("frames")
            assert shown == set(entry.inputs) & set(widgets), name
    finally:
        st.close()


def test_a_new_kind_is_one_entry(monkeypatch):
    """A throwaway kind registered at run time is built and run through the same two functions."""
    calls = []

    def build(options, *, frames, steps):
        return ("config", options.word, frames, steps)

    class Config(tuple):
        window = type("W", (), {"check_layers": staticmethod(lambda n: None)})()

    entry = EditKind("probe", "probe", "a test kind", inputs=frozenset({"word"}),
                     build=lambda o, *, frames, steps: Config(build(o, frames=frames, steps=steps)),
                     run=lambda loaded, o, cfg, **common: calls.append((o.kind, cfg, common["frames"])) or "out")
    monkeypatch.setitem(REGISTRY, "probe", entry)
    monkeypatch.setattr(edit_kinds, "KINDS", (*KINDS, "probe"))
    monkeypatch.setattr("engine.methods.edit_options.KINDS", (*KINDS, "probe"))
    options = EditOptions(kind="probe", prompt="a person jumps", word="jumps")
    assert build_config(options, frames=40)[:3] == ("config", "jumps", 40)
    loaded = type("Loaded", (), {"config": {}, "model": type("M", (), {"num_layers": 2})()})()
    assert run_edit(loaded, options, frames=40, sample=None) == "out" and calls[0][0] == "probe"


def test_an_entry_names_only_known_inputs():
    with pytest.raises(ValueError, match="unknown inputs"):
        EditKind("bad", "bad", "", inputs=frozenset({"colour"}))
    assert {f for k in REGISTRY.values() for f in k.inputs} <= INPUTS


def test_every_input_without_a_widget_of_its_own_gets_one_from_its_declaration(tiny_model_dir):
    """A new kind's new plain option (a number, a choice) reaches the Edit tab with nothing written in the app: its
    parameter, widget and help come from ``EditOptions``; only the inputs with widgets of their own are named."""
    from app.main import Studio
    from app.tabs.edit.settings import OWN_WIDGETS, PLAIN_INPUTS, EditSettings
    from engine.methods.edit_options import option_spec

    assert set(PLAIN_INPUTS) == INPUTS - OWN_WIDGETS and {"fraction", "count", "chunk_frames"} <= set(PLAIN_INPUTS)
    settings = EditSettings()
    for name in PLAIN_INPUTS:
        spec = option_spec(name)
        assert settings.param[name].default == spec.default and settings.param[name].label == spec.label, name
    st = Studio(model_dir=tiny_model_dir, initial=None)
    try:
        tab = st.edit
        assert set(tab.plain) == set(PLAIN_INPUTS)
        for name in PLAIN_INPUTS:
            assert tab.plain[name].value == option_spec(name).default
            assert tab.plain_help[name].object == option_spec(name).help
    finally:
        st.close()
