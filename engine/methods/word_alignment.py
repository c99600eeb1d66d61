"""Which word of the edited prompt takes which word's cross-attention in in-place replacement, as prompt-to-prompt
(Hertz et al. 2023) aligns prompts. Torch-free: the CLI and the Edit tab show the alignment before anything runs.

- Prompts with the same number of words: word by word (prompt-to-prompt's *replace*); every word of the edited
  prompt takes the attention of the reference's word at the same place.
- Otherwise prompt-to-prompt's *refine* alignment: a global alignment of the two word sequences (its
  ``seq_aligner``: gap 0, match +1, mismatch -1, ties resolved as it resolves them), so the words both prompts share
  are matched in order. Between two matched words, the reference's unmatched words were *swapped* for the edited
  prompt's: one for one when there are as many on both sides, otherwise each new word takes the reference words'
  summed attention divided by the number of new words (how prompt-to-prompt maps a word onto a different number of
  tokens). New words with nothing swapped out (*inserted*) keep their own attention, from the edited prompt's own
  maps; reference words with nothing in their place are *dropped*.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

WORD_BY_WORD, ALIGNED = "word by word", "aligned"
#: what a swapped word attends with in the replacement (``ReplaceConfig.swapped``): its own cross-attention column,
#: or the reference's word's (the paper: the edited prompt takes the reference's whole map)
SWAPPED = ("own", "reference")
SWAPPED_DEFAULT = "own"  # the one home of the default (ReplaceConfig, EditOptions); measured in ReplaceConfig's doc

# prompt-to-prompt's seq_aligner.ScoreParams(gap=0, match=1, mismatch=-1)
GAP, MATCH, MISMATCH = 0, 1, -1


def global_align(source: Sequence[str], target: Sequence[str]) -> list[tuple[int | None, int | None]]:
    """prompt-to-prompt's global alignment of two sequences: a list of (i, j) in order; (i, j) with
    ``source[i] == target[j]`` or a mismatch, (i, None) a source word left out, (None, j) a target word put in."""
    n, m = len(source), len(target)
    score = [[GAP * (i + j) if i == 0 or j == 0 else 0 for j in range(m + 1)] for i in range(n + 1)]
    trace = [[1 if i == 0 else 2 for _ in range(m + 1)] for i in range(n + 1)]  # 1 left, 2 up, 3 diagonal
    trace[0][0] = 0
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            left, up = score[i][j - 1] + GAP, score[i - 1][j] + GAP
            diag = score[i - 1][j - 1] + (MATCH if source[i - 1] == target[j - 1] else MISMATCH)
            score[i][j] = best = max(left, up, diag)
            trace[i][j] = 1 if best == left else 2 if best == up else 3
    out: list[tuple[int | None, int | None]] = []
    i, j = n, m
    while i > 0 or j > 0:
        move = trace[i][j]
        if move == 3:
            i, j = i - 1, j - 1
            out.append((i, j))
        elif move == 1:
            j -= 1
            out.append((None, j))
        else:
            i -= 1
            out.append((i, None))
    return out[::-1]


@dataclass(frozen=True)
class WordAlignment:
    """``links[j]``: the reference words (index, weight) whose cross-attention the edited prompt's word j takes;
    () = its own attention (an inserted word). ``dropped``: reference words nothing takes."""

    source: tuple[str, ...]
    target: tuple[str, ...]
    links: tuple[tuple[tuple[int, float], ...], ...]
    mode: str
    groups: tuple[tuple[tuple[int, ...], tuple[int, ...]], ...]  # (reference words, edited words) in prompt order

    @property
    def dropped(self) -> tuple[int, ...]:
        return tuple(i for src, dst in self.groups if not dst for i in src)

    @property
    def inserted(self) -> tuple[int, ...]:
        return tuple(j for src, dst in self.groups if not src for j in dst)

    @property
    def changed(self) -> bool:
        return self.source != self.target

    @property
    def swaps(self) -> frozenset[int]:
        """Edited words put in other words' place ('jumps' → 'kicks'): their indices in ``target``."""
        return frozenset(j for src, dst in self.groups if src and dst and
                         [self.source[i] for i in src] != [self.target[k] for k in dst] for j in dst)

    def rows(self, *, swapped: str = SWAPPED_DEFAULT) -> list[str]:
        """One line per aligned group: kept ('a' = 'a'), swapped ('jumps' → 'kicks'), inserted, dropped.
        ``swapped``: as ``ReplaceConfig.swapped`` ("own": a swapped word keeps its own attention)."""
        out = []
        for src, dst in self.groups:
            a = " ".join(self.source[i] for i in src)
            b = " ".join(self.target[j] for j in dst)
            if src and dst and a == b:
                out.append(f"'{a}' = '{b}'")
            elif src and dst:
                note = ""
                if swapped == "own":
                    note = " (its own attention)" if len(dst) == 1 else " (their own attention)"
                elif len(src) != len(dst):
                    note = (f" (its attention shared by the {len(dst)} words)" if len(src) == 1 else
                            " (their attention summed)" if len(dst) == 1 else
                            f" (their attention summed, shared by the {len(dst)} words)")
                out.append(f"'{a}' → '{b}'{note}")
            elif dst:
                out.append(f"+ '{b}' (new: its own attention)")
            else:
                out.append(f"− '{a}' (dropped)")
        return out

    def changes(self) -> list[str]:
        """What changes, briefly: "'jumps' → 'kicks'", "+'high'" (inserted), "−'twice'" (dropped)."""
        out = []
        for src, dst in self.groups:
            a = " ".join(self.source[i] for i in src)
            b = " ".join(self.target[j] for j in dst)
            if src and dst and a != b:
                out.append(f"'{a}' → '{b}'")
            elif dst and not src:
                out.append(f"+'{b}'")
            elif src and not dst:
                out.append(f"−'{a}'")
        return out

    def describe(self, *, swapped: str = SWAPPED_DEFAULT) -> str:
        how = ("word by word (prompt-to-prompt's replace)" if self.mode == WORD_BY_WORD else
               f"as prompt-to-prompt refines ({len(self.source)} → {len(self.target)} words)")
        return f"aligned {how}: " + ", ".join(self.rows(swapped=swapped))


def align_words(source: Sequence[str], target: Sequence[str]) -> WordAlignment:
    """The alignment of the reference's words ``source`` and the edited prompt's ``target`` (see the module)."""
    source, target = tuple(source), tuple(target)
    if not source or not target:
        raise ValueError("both prompts need at least one word to align")
    if len(source) == len(target):
        groups = tuple(((i,), (i,)) for i in range(len(source)))
        links = tuple(((j, 1.0),) for j in range(len(target)))
        return WordAlignment(source, target, links, WORD_BY_WORD, groups)
    groups: list[tuple[tuple[int, ...], tuple[int, ...]]] = []
    src_run: list[int] = []
    dst_run: list[int] = []

    def close_run() -> None:
        if src_run or dst_run:
            groups.append((tuple(src_run), tuple(dst_run)))
            src_run.clear()
            dst_run.clear()

    for i, j in global_align(source, target):
        if i is not None and j is not None and source[i] == target[j]:
            close_run()
            groups.append(((i,), (j,)))
        else:
            if i is not None:
                src_run.append(i)
            if j is not None:
                dst_run.append(j)
    close_run()
    # a run with words on both sides is a swap; split it one for one where the sides are equally long
    final: list[tuple[tuple[int, ...], tuple[int, ...]]] = []
    for src, dst in groups:
        if src and dst and len(src) == len(dst) and len(src) > 1:
            final.extend(((a,), (b,)) for a, b in zip(src, dst))
        else:
            final.append((src, dst))
    links: list[tuple[tuple[int, float], ...]] = [()] * len(target)
    for src, dst in final:
        if src and dst:
            share = 1.0 / len(dst) if len(dst) != len(src) else 1.0
            for k, j in enumerate(dst):
                links[j] = ((src[k], 1.0),) if len(dst) == len(src) else tuple((i, share) for i in src)
    return WordAlignment(source, target, tuple(links), ALIGNED, tuple(final))
