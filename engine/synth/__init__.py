"""Procedural, labelled human-motion corpus (DESIGN §5).

>>> from engine.synth import Corpus, vocabulary
>>> s = Corpus(split="train").sample(0)
>>> s.joints.shape[1:], s.features.shape[1], len(s.captions) >= 3
((22, 3), 263, True)
"""
from __future__ import annotations

from engine.synth.compose import Synthesis, synthesize
from engine.synth.corpus import Corpus, Sample, make_sample
from engine.synth.grammar import vocabulary
from engine.synth.labels import Labels
from engine.synth.program import ACTIONS, Person, Program, Segment
from engine.synth.styles import STYLES

__all__ = ["ACTIONS", "Corpus", "Labels", "Person", "Program", "STYLES", "Sample", "Segment", "Synthesis",
           "make_sample", "synthesize", "vocabulary"]
