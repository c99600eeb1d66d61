"""A prompt's turn held by a root path: which prompts, the corpus's path, the plan that walks it, and the later tries
of `moattn generate` and the studio that take it."""
from __future__ import annotations

import json

import numpy as np
import pytest

from engine.intent import parse_intent
from engine.methods.held_direction import corpus_path, held_plan, held_segment


@pytest.fixture(scope="module")
def root_controls(tiny_model_dir, tmp_path_factory):
    """A controls folder whose root 'control model' is the tiny model's copy (the same base: it blends)."""
    from tests.test_priormdm import controls_with_prior

    return controls_with_prior(tiny_model_dir, tmp_path_factory.mktemp("held") / "control", ("root",), prior=False)


def test_only_one_gait_is_held():
    assert held_segment("a person walks to the left").direction == "left"
    assert held_segment("someone runs in a circle").direction == "circle"
    assert held_segment("a woman walks quickly to the right").action == "walk"
    assert held_segment("a kid runs in circles").direction == "circle"
    assert held_segment("a man jogs in a circle to the left").direction == "circle_left"
    assert held_segment("a person walks forward").direction == "forward"  # straight ahead too
    assert held_segment("an old man walks slowly").action == "walk"
    assert held_segment("someone walks while waving the right hand").action == "walk"
    for prompt in ("a person jumps twice", "someone steps sideways to the left", "a person walks backwards",
                   "a person walks to the left then jumps", "a person turns left", "a person waves"):
        assert held_segment(prompt) is None, prompt


def test_the_later_tries_of_one_take_are_held():
    from engine.methods.held_direction import held_take

    prompt = "a person walks to the left"
    assert [held_take(prompt, try_index=k) for k in range(3)] == [False, True, True]  # the first is the model's own
    assert not held_take(prompt, try_index=1, one_take=False)  # clause by clause: never
    assert not held_take("a person jumps twice", try_index=2)


def test_the_corpus_path_turns_the_way_the_prompt_says():
    left = corpus_path(parse_intent("a person walks to the left"), frames=80, seed=0)
    right = corpus_path(parse_intent("a person walks to the right"), frames=80, seed=0)
    circle = corpus_path(parse_intent("someone walks in a circle"), frames=120, seed=0)
    assert left.shape == right.shape == (81, 2) and circle.shape == (121, 2)
    heading = left[10] - left[0]  # starting straight ahead: the end lies to the walker's left (+x) or right
    assert heading[1] > 0 and abs(heading[0]) < 0.3 * heading[1]
    assert left[-1, 0] > 0.5 and right[-1, 0] < -0.5
    travelled = np.linalg.norm(np.diff(circle, axis=0), axis=1).sum()
    assert travelled > 3.0 and np.linalg.norm(circle[-1] - circle[0]) < 0.3 * travelled  # round, back near the start
    slow = corpus_path(parse_intent("an old man walks slowly"), frames=80, seed=0)
    quick = corpus_path(parse_intent("a person walks quickly"), frames=80, seed=0)
    assert slow[-1, 1] < 0.7 * quick[-1, 1]  # the corpus's slow walk is slow
    for seed in range(12):  # no direction said: straight ahead (+z) in every draw, never a drawn turn or circle
        for prompt in ("an old man walks slowly", "someone walks", "a man runs"):
            straight = corpus_path(parse_intent(prompt), frames=80, seed=seed)
            assert straight[-1, 1] > 0.5 and abs(straight[-1, 0]) < 0.2 * straight[-1, 1], (prompt, seed)


def test_a_held_plan_walks_the_corpus_path(tiny_model_dir, root_controls):
    from engine.checkpoint import load_model
    from engine.generate import Request, SampleConfig, generate

    loaded = load_model(tiny_model_dir)
    sample = SampleConfig(steps=3, seed=4)
    assert held_plan(loaded, "a person jumps twice", frames=60, sample=sample, controls=root_controls) is None
    straight = held_plan(loaded, "an old man walks slowly", frames=60, sample=sample, controls=root_controls)
    assert straight.note.startswith("walk forward held by a root path")
    assert held_plan(loaded, "a person walks to the left", frames=60, sample=sample,
                     controls=root_controls.parent / "none") is None  # no root control model: the model's own
    held = held_plan(loaded, "a person walks to the left", frames=60, sample=sample, controls=root_controls)
    assert held is not None and held.note.startswith("walk to the left held by a root path")
    circle = held_plan(loaded, "a man jogs in a circle to the left", frames=60, sample=sample, controls=root_controls)
    assert circle.note.startswith("jog in a circle to the left held by a root path")
    out = generate(loaded, Request(prompts=["a person walks to the left"], frames=[60], noise=held.plan.noise), sample,
                   hooks=held.plan.hooks, denoiser=held.plan.denoiser).joints[0]
    path = corpus_path(parse_intent("a person walks to the left"), frames=60, seed=4)
    pelvis = out[:, 0, [0, 2]]
    assert np.linalg.norm(pelvis - path[: len(pelvis)], axis=1).mean() < 0.05  # the root follows the path
    plain = generate(loaded, Request(prompts=["a person walks to the left"], frames=[60]), sample).joints[0]
    assert np.linalg.norm(plain[:, 0, [0, 2]] - path[: len(plain)], axis=1).mean() > 0.2  # the tiny model's own


def test_generate_holds_the_turn_from_the_second_try(tiny_model_dir, root_controls, tmp_path, capsys, monkeypatch):
    import engine.paths
    from engine.cli import main

    monkeypatch.setattr(engine.paths, "CONTROL_DIR", root_controls)
    out = tmp_path / "w.npy"
    args = ["generate", "a person walks to the left", "--steps", "2", "--seconds", "3", "--model",
            str(tiny_model_dir), "--out", str(out), "--no-library"]
    assert main([*args, "--tries", "1"]) == 0
    one = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert one["held_path"] is False  # one take: the model's own
    assert main([*args, "--tries", "3"]) == 0
    captured = capsys.readouterr()
    printed = captured.out
    report = json.loads(printed.splitlines()[-1])
    assert report["tries"] == 3  # the tiny model turns left in none of them
    assert "tried seeds 0, 1, 2 (1, 2 along the corpus's path): kept seed" in captured.err
    assert report["held_path"] == (report["seed"] >= 1)
    assert ("held by a root path" in printed) == report["held_path"]


def test_a_held_take_keeps_it_in_its_recipe():
    from app.generation import GenerationSettings
    from app.session.library import settings_from_recipe

    recipe = {"prompt": "a person walks to the left", "seed": 1, "steps": 50, "guidance": 2.5,
              "operation": {"held_path": True, "sequence": "clauses"}}
    assert settings_from_recipe(recipe) == GenerationSettings(prompt="a person walks to the left", seed=1, steps=50,
                                                              guidance=2.5, guidance_from=0, eta=0.0, held_path=True)
    assert settings_from_recipe({**recipe, "operation": {}}).held_path is False


def test_the_studio_holds_the_turn_from_the_second_try(tiny_model_dir, root_controls, monkeypatch):
    import engine.paths
    from app import generation as gen
    from engine.checkpoint import load_model

    monkeypatch.setattr(engine.paths, "CONTROL_DIR", root_controls)
    loaded = load_model(tiny_model_dir)
    settings = gen.GenerationSettings(prompt="a person walks to the left", seconds=3.0, steps=2, record_steps=1,
                                      seed=3, tries=2)
    takes = []
    real = gen.run_generation
    monkeypatch.setattr(gen, "run_generation", lambda loaded, checked, **kw: takes.append(checked.settings) or
                        real(loaded, checked, **kw))
    result = gen.run_tries(loaded, gen.check(loaded, settings))
    assert [(t.seed, t.held_path) for t in takes] == [(3, False), (4, True)]  # the first try is the model's own
    assert result.settings.held_path == (result.settings.seed == 4)
    assert any("held by a root path" in n for n in result.notes) == result.settings.held_path
    # the held take walks the corpus's path, and recording its attention still works
    held = real(loaded, gen.check(loaded, gen.GenerationSettings(**{**settings.__dict__, "seed": 4, "tries": 1,
                                                                    "held_path": True})))
    path = corpus_path(parse_intent("a person walks to the left"), frames=60, seed=4)
    assert np.linalg.norm(held.joints[:, 0, [0, 2]] - path[:60], axis=1).mean() < 0.05
    assert held.attention is not None and held.settings.held_path
    # a prompt with no turn is never held, nor is a take without a root control model
    takes.clear()
    gen.run_tries(loaded, gen.check(loaded, gen.GenerationSettings(**{**settings.__dict__,
                                                                      "prompt": "a person walks forward"})))
    assert [t.held_path for t in takes] == [False] * len(takes)
    monkeypatch.setattr(engine.paths, "CONTROL_DIR", root_controls.parent / "none")
    plain = real(loaded, gen.check(loaded, gen.GenerationSettings(**{**settings.__dict__, "seed": 4, "tries": 1,
                                                                     "held_path": True})))
    assert plain.settings.held_path is False and not any("held" in n for n in plain.notes)


def test_the_adherence_bench_holds_the_later_tries_as_the_studio_does(tiny_model_dir, root_controls, monkeypatch):
    import engine.evaluation.bench_adherence as ba
    import engine.paths
    from engine.checkpoint import load_model

    monkeypatch.setattr(engine.paths, "CONTROL_DIR", root_controls)
    loaded = load_model(tiny_model_dir)
    config = ba.AdherenceBenchConfig(seeds=2, steps=2, tries=2, validation_motions=10)
    prompt = "a person walks to the left"
    motions = ba._model_motions(loaded, prompt, [61] * 4, config, held_from=2)
    assert len(motions) == 4
    for k, joints in enumerate(motions):
        path = corpus_path(parse_intent(prompt), frames=60, seed=config.seed + k)
        error = np.linalg.norm(joints[:60, 0, [0, 2]] - path[:60], axis=1).mean()
        assert (error < 0.1) == (k >= 2), (k, error)  # the first tries are the model's own, the later ones held
    seen = []
    real = ba._model_motions
    monkeypatch.setattr(ba, "_model_motions", lambda *a, **kw: seen.append(kw["held_from"]) or real(*a, **kw))
    ba.bench_adherence(loaded, config, prompts=[prompt, "a person jumps twice"])
    assert seen == [2, None]  # the turning prompt's second tries are held; a jump's never
    ba.bench_adherence(loaded, ba.AdherenceBenchConfig(seeds=2, steps=2, tries=2, validation_motions=10,
                                                       held_paths=False), prompts=[prompt])
    assert seen[-1] is None  # the lever screen's setting: every try the model's own
