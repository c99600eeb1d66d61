"""Captions, vocabulary and the held-out split."""
from __future__ import annotations

import re

from engine.synth import Corpus, vocabulary
from engine.synth.grammar import HELD_OUT_TEMPLATES, VOCABULARY_FILE, tokens, words
from engine.synth.splits import HELD_OUT_COMBOS, program_pairs

N = 150


def test_vocabulary_file_is_current():
    assert VOCABULARY_FILE.read_text().split() == list(vocabulary())
    assert list(vocabulary()) == sorted(set(vocabulary()))


def test_vocabulary_covers_all_captions_of_all_splits():
    vocab = set(vocabulary())
    for split in ("train", "test", "ood"):
        c = Corpus(split)
        for i in range(N):
            for cap in c.sample(i, with_features=False).captions:
                unknown = set(words(cap)) - vocab
                assert not unknown, (split, i, cap, unknown)


def test_captions_are_paraphrases():
    c = Corpus("train")
    for i in range(30):
        caps = c.sample(i, with_features=False).captions
        assert len(caps) >= 3 and len(set(caps)) == len(caps)
        assert all(cap == cap.strip() and "  " not in cap for cap in caps)


def _held_out_template(cap: str) -> bool:
    pats = [re.escape(t).replace(r"\{s\}", ".+").replace(r"\{ing\}", ".+").replace(r"\{vp\}", ".+")
            for t in HELD_OUT_TEMPLATES.values()]
    return any(re.fullmatch(p, cap) for p in pats)


def test_ood_pairs_and_templates_never_in_train_or_test():
    seen_actions, seen_styles = set(), set()
    for split in ("train", "test"):
        c = Corpus(split)
        for i in range(N * 2):
            s = c.sample(i, with_features=False)
            pairs = program_pairs(s.program)
            assert not pairs & HELD_OUT_COMBOS
            assert not any(_held_out_template(cap) for cap in s.captions)
            for a, st in pairs:
                seen_actions.add(a)
                seen_styles.add(st)
    # each held-out pair's action and style are seen separately (MoMo's OOD case)
    for a, st in HELD_OUT_COMBOS:
        assert a in seen_actions and st in seen_styles


def test_ood_split_is_all_held_out():
    c = Corpus("ood")
    for i in range(N):
        s = c.sample(i, with_features=False)
        assert s.labels.held_out_pair or s.labels.held_out_template
        if s.labels.held_out_template:
            assert all(_held_out_template(cap) for cap in s.captions)


def test_tokens_are_word_pos_pairs():
    tok = tokens("a person walks forward while waving the left hand twice")
    parts = tok.split()
    assert all(re.fullmatch(r"[a-z]+/[A-Z]+", p) for p in parts)
    assert "walk/VERB" in parts and "hand/NOUN" in parts


def test_underspecified_captions_leave_attributes_out_with_corpus_words_only():
    """Captions the way people type them: no side, no count, no style; some bare subject-and-verb ones."""
    import re

    import numpy as np

    from engine.data import CorpusSource
    from engine.synth import Corpus
    from engine.synth.grammar import underspecified_captions, vocabulary

    known = set(vocabulary())
    corpus = Corpus("train")
    texts, bare, sided = [], 0, 0
    for i in range(120):
        program = corpus.program(i)[0]
        for text in underspecified_captions(program, np.random.default_rng([i, 1]), n=2):
            words = re.findall(r"[a-z']+", text)
            assert set(words) <= known, text
            texts.append(text)
            bare += len(words) <= 4
            sided += bool(re.search(r"\b(left|right)\b", text)) and all(
                s.action not in ("walk", "run", "jog", "turn", "side_step") for s in program.segments)
    assert len(texts) >= 200 and bare >= 40  # short captions are common
    assert sided < 0.3 * len(texts)  # the side mostly left out
    # the corpus's own captions are untouched; the training source adds the extra ones after them
    plain, extra = CorpusSource(split="train").get(3), CorpusSource(split="train", underspecified=2).get(3)
    assert extra.captions[: len(plain.captions)] == plain.captions and len(extra.captions) == len(plain.captions) + 2
    assert CorpusSource(split="train", underspecified=2).get(3).captions == extra.captions  # deterministic


def test_plain_verbs_make_the_plain_verb_common_in_underspecified_captions():
    """--plain-verbs: the action's plain verb ("walks") in most short captions; 0 leaves the captions as they were."""
    import numpy as np

    from engine.synth import Corpus
    from engine.synth.grammar import VERBS, underspecified_captions

    corpus = Corpus("train")
    walks = {0.0: 0, 0.8: 0}
    total = 0
    for i in range(300):
        program = corpus.program(i)[0]
        if program.segments[0].action != "walk":
            continue
        total += 1
        for plain in walks:
            text = underspecified_captions(program, np.random.default_rng([i, 1]), n=1, plain=plain)[0]
            walks[plain] += " walks" in text.split(",")[0].split(" then ")[0]
        assert underspecified_captions(program, np.random.default_rng([i, 1]), n=2) == underspecified_captions(
            program, np.random.default_rng([i, 1]), n=2, plain=0.0)
    assert total >= 10
    assert walks[0.8] >= 0.7 * total > walks[0.0] * 2, (walks, total)
    assert VERBS["walk"][0][0] == "walks" and VERBS["punch"][0][0] == "punches"


def test_styled_captions_keep_a_styled_motions_style_even_when_bare():
    """--styled-captions: "a person walks like a robot" / "a zombie walks" (the style as a phrase or the subject),
    bare ones included, with corpus words only; 0 draws exactly the captions it drew before the option existed."""
    import re

    import numpy as np

    from engine.synth import Corpus
    from engine.synth.grammar import STYLE_PHRASES, STYLE_SUBJECTS, underspecified_captions, vocabulary

    known = set(vocabulary())
    corpus = Corpus("train")
    styled_programs = kept = bare_kept = 0
    for i in range(300):
        program = corpus.program(i)[0]
        off = underspecified_captions(program, np.random.default_rng([i, 1]), n=2, plain=0.6)
        assert off == underspecified_captions(program, np.random.default_rng([i, 1]), n=2, plain=0.6, styled=0.0)
        if program.style == "none":
            assert off == underspecified_captions(program, np.random.default_rng([i, 1]), n=2, plain=0.6, styled=1.0)
            continue
        styled_programs += 1
        marks = STYLE_PHRASES[program.style] + STYLE_SUBJECTS.get(program.style, ())
        for text in underspecified_captions(program, np.random.default_rng([i, 1]), n=2, plain=0.6, styled=1.0):
            words = re.findall(r"[a-z']+", text)
            assert set(words) <= known, text
            has = any(m in text for m in marks)
            kept += has
            bare_kept += has and len(words) <= 7
    assert styled_programs >= 100 and kept >= 1.6 * styled_programs and bare_kept >= 30, (styled_programs, kept,
                                                                                           bare_kept)


def test_keep_intensity_keeps_the_intensity_word_in_captions_that_are_not_bare():
    """A big wave captioned "waves" most of the time teaches that waves are big; keep_intensity keeps the word."""
    import numpy as np

    from engine.synth import Corpus
    from engine.synth.grammar import INTENSITY_WORDS, underspecified_captions

    corpus = Corpus("train")
    said = {False: 0, True: 0}
    captions = 0
    for i in range(600):
        program = corpus.program(i)[0]
        intense = [s for s in program.segments if s.action == "wave" and s.intensity_word != "normal"]
        if not intense:
            continue
        words = INTENSITY_WORDS["wave"][intense[0].intensity_word]
        for keep in (False, True):
            texts = underspecified_captions(program, np.random.default_rng([i, 1]), n=2, keep_intensity=keep)
            long = [t for t in texts if len(t.split()) > 4]
            said[keep] += sum(any(w in t for w in words) for t in long)
            captions += len(long) if keep else 0
    # a caption that is not bare says it (a bare one, "the guy greets someone with a wave", may run past 4 words)
    assert captions >= 10 and said[True] >= 0.8 * captions
    assert said[False] < 0.6 * captions and said[True] > said[False] + 3  # without the option, most drop it
    # the option off draws exactly what the captions drew before it existed
    program = corpus.program(5)[0]
    assert underspecified_captions(program, np.random.default_rng([5, 1]), n=2) == \
        underspecified_captions(program, np.random.default_rng([5, 1]), n=2, keep_intensity=False)
