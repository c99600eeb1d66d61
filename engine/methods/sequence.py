"""A prompt of several actions in order ("a man waves, then kicks"), generated clause by clause and joined with
DoubleTake (PriorMDM): each clause is one interval of its own prompt, consecutive intervals share a handshake.

Why: the base model, asked the whole sequence at once, often makes only one of its actions. The same model asked
each action alone does it, and DoubleTake is the paper's way to join short motions into one (``moattn bench
--adherence --sequence whole`` against the default reads the difference on the bench's sequence prompts).

The clauses come from :func:`engine.clauses.clause_prompts`; each clause gets the length predicted for it alone
(:func:`engine.duration.auto_seconds`; a turn on the spot a little more, :func:`settle_seconds`), or its share of a
length the user gave. What the generate command and the studio's Generate box do with a prompt is :func:`plan`
(None: one take of the whole prompt).
"""
from __future__ import annotations

from collections.abc import Callable

from engine.checkpoint import LoadedModel
from engine.clauses import clause_prompts
from engine.diffusion import StepState
from engine.duration import Tempo, auto_seconds
from engine.generate import FPS, SampleConfig
from engine.intent import parse_intent
from engine.methods.doubletake import (MIN_OWN_FRAMES, Composed, DoubleTakeConfig, Interval, compose,
                                       second_take_timesteps)
from engine.methods.generate_options import DEFAULT_SEQUENCE, check_sequence
from engine.units import MAX_FRAMES

#: frames two consecutive clauses share: half of DoubleTake's default (``option_info(DoubleTakeConfig, "handshake")``,
#: 20, chosen for long motions by ``moattn bench --compose``). A clause said with a count is short ("jumps twice",
#: 2.3 s), and a 20-frame handshake (averaged in the first take, redrawn with its ramps in the second) took one of its
#: repetitions away: on 10 sequence prompts with a counted clause (not a bench set's; v9, 6 seeds; assets/model/
#: TRAINING.md, session 35) the count was exact in 0.38 of the draws with 20 frames, 0.82 with 10 (the clauses
#: generated alone: 0.80), their actions 0.92 -> 0.98, the whole motion's jerk +4 %, foot skate the same.
HANDSHAKE = 10
JOIN = DoubleTakeConfig(handshake=HANDSHAKE)  # how the clauses are joined: DoubleTake's second take, these handshakes
SHORT_CLAUSE_FRAMES = 30  # a clause predicted shorter than this (1.5 s) keeps all of it outside its handshakes
#: frames a turn clause ("turns around") gets beyond its predicted time, per neighbour it shares a handshake with.
#: A turn generated alone turns through its whole predicted length; joined, each handshake averages its first or last
#: frames with the neighbour's gait, so it turned a third less and partly while walking, and the detectors read no
#: turn on the spot (direction 0.00 on 4 sequence prompts with a turn, 8 seeds, session 43, assets/model/TRAINING.md).
#: 5 and 10 frames read 0.31, 20 frames 0.62, 30 and 40 frames 0.53 and 0.59: 20, the shortest of the plateau.
TURN_SETTLE = 20


def sequence_clauses(prompt: str, sequence: str = DEFAULT_SEQUENCE) -> tuple[str, ...]:
    """The clauses ``prompt`` is generated as, one prompt each; () where it is one take (one action, ``sequence``
    "whole", or an order its words do not let cut)."""
    check_sequence(sequence)
    clauses = clause_prompts(prompt)
    return clauses if sequence == "clauses" and len(clauses) > 1 else ()


def settle_seconds(clause: str, *, neighbours: int) -> float:
    """The time a clause gets beyond its predicted length to settle its turn: :data:`TURN_SETTLE` frames per
    neighbour for a turn on the spot, else 0."""
    turns = any(seg.action == "turn" for seg in parse_intent(clause).segments)
    return TURN_SETTLE * neighbours / FPS if turns else 0.0


def plan(prompt: str, *, seconds: float | None = None, sequence: str = DEFAULT_SEQUENCE,
         tempo: Tempo = ()) -> list[Interval] | None:
    """The intervals ``prompt`` is generated as, or None where it is one take (one action, ``sequence`` "whole", or
    an order its words do not let cut). ``seconds`` None: each clause's predicted length; else the motion's total
    length, shared between the clauses as their predicted lengths are. A ValueError (one line) where ``seconds`` is
    too short for the clauses."""
    clauses = sequence_clauses(prompt, sequence)
    if not clauses:
        return None
    own = [auto_seconds(c, tempo) + settle_seconds(c, neighbours=(i > 0) + (i < len(clauses) - 1))
           for i, c in enumerate(clauses)]
    if seconds is not None:
        own = [float(seconds) * s / sum(own) for s in own]
    intervals = []
    for i, (clause, secs) in enumerate(zip(clauses, own)):
        shared = HANDSHAKE * ((i > 0) + (i < len(clauses) - 1))  # frames this interval shares with its neighbours
        own_frames = int(round(secs * FPS))
        frames = own_frames + shared // 2  # half of each handshake is this clause's own time
        # a short clause ("jumps once", 1.3 s) keeps all of its time outside the handshakes, where nothing blends
        frames = max(frames, shared + min(own_frames, SHORT_CLAUSE_FRAMES), shared + MIN_OWN_FRAMES)
        if frames > MAX_FRAMES:
            if seconds is not None:
                raise ValueError(f"{prompt!r} in {float(seconds):g} s gives its clause {clause!r} {frames / FPS:.1f} s, "
                                 f"longer than the model's {MAX_FRAMES / FPS:.1f} s: give a shorter duration")
            frames = MAX_FRAMES  # a clause predicted near the longest: its handshakes come out of its own time
        intervals.append(Interval(prompt=clause, seconds=frames / FPS))
    total = timeline_frames(intervals)
    if seconds is not None and total > int(round(float(seconds) * FPS)) + len(clauses):
        raise ValueError(f"{prompt!r} asks for {len(clauses)} actions in order: generated clause by clause it needs "
                         f"at least {total / FPS:.1f} s; give a longer duration, or sequence 'whole' (the whole prompt in one take)")
    return intervals


def timeline_frames(intervals: list[Interval]) -> int:
    """Frames of the joined motion: every interval's, less one handshake per transition."""
    return sum(int(round(iv.seconds * FPS)) for iv in intervals) - HANDSHAKE * (len(intervals) - 1)


def sampling_steps(steps: int) -> int:
    """Sampling steps a clause-by-clause run of ``steps`` steps makes: the first take's, then the second take's."""
    return steps + (len(second_take_timesteps(JOIN.second_take, steps)) if JOIN.second_take is not None else 0)


def generate_sequence(loaded: LoadedModel, intervals: list[Interval], sample: SampleConfig = SampleConfig(), *,
                      on_step: Callable[[StepState], None] | None = None, controller=None) -> Composed:
    """The clauses sampled together (one batch slot each, DoubleTake's first and second takes), joined;
    ``controller`` acts in the first take (where each clause is its own prompt)."""
    return compose(loaded, intervals, JOIN, sample=sample, on_step=on_step, controller=controller)
