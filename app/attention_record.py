"""What the studio keeps of a generation's attention: every layer and head, both kinds, at chosen steps.

Recording plan (the memory budget): all layers, all heads, self- and cross-attention of the
conditional slot, fp16, at ``record_steps`` sampling steps spread evenly over the run (always the
first and the last). With the default of 10 steps a 6-layer, 4-head model at 196 frames keeps
10 x 6 x 4 x 196^2 x 2 B = 18 MB of self-attention (cross-attention is tiny); recording all 50 steps
would be 90 MB. Maps are copied out of the engine's ``AttentionStore`` into two stacked numpy
arrays, so switching layer, head or step is an index plus a mean (a few milliseconds).
"""
from __future__ import annotations

import io
import json
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

BYTES_PER_VALUE = 2  # fp16


def plan_steps(num_steps: int, record_steps: int) -> list[int]:
    """Sampling-step indices to record: ``record_steps`` of them, evenly spread, first and last included."""
    if num_steps < 1:
        raise ValueError("num_steps must be >= 1")
    n = int(np.clip(record_steps, 1, num_steps))
    if n == 1:
        return [num_steps - 1]
    return sorted({int(round(x)) for x in np.linspace(0, num_steps - 1, n)})


def estimate_bytes(*, num_steps: int, record_steps: int, layers: int, heads: int, frames: int, words: int) -> int:
    """Memory the recording of one motion takes."""
    steps = len(plan_steps(num_steps, record_steps))
    return steps * layers * heads * frames * (frames + words) * BYTES_PER_VALUE


def _check_recorded(store, steps, layers) -> None:
    """A one-line ValueError where the store holds nothing to keep, or ran out of its budget."""
    if not steps or not layers:
        raise ValueError("no attention was recorded")
    if store.skipped_sites:
        raise ValueError(f"the attention store ran out of budget ({len(store.skipped_sites)} maps skipped)")


@dataclass
class AttentionRecord:
    """Recorded maps of one motion.

    ``self_maps`` (S, L, H, N, N) and ``cross_maps`` (S, L, H, N, W) in fp16, S recorded steps
    (``steps`` gives their indices in the sampling loop of ``num_steps``), L layers, H heads,
    N frames, W words. Rows are query frames; self-attention columns are key frames and
    cross-attention columns are words. ``layer``/``head``/``step`` ``None`` means the mean.
    """

    words: tuple[str, ...]
    steps: tuple[int, ...]
    num_steps: int
    timesteps: tuple[int, ...]
    self_maps: np.ndarray
    cross_maps: np.ndarray
    _cache: OrderedDict = field(default_factory=OrderedDict, repr=False, compare=False)

    @property
    def n_layers(self) -> int:
        return self.self_maps.shape[1]

    @property
    def n_heads(self) -> int:
        return self.self_maps.shape[2]

    @property
    def n_frames(self) -> int:
        return self.self_maps.shape[3]

    @property
    def nbytes(self) -> int:
        return int(self.self_maps.nbytes + self.cross_maps.nbytes)

    @classmethod
    def from_store(cls, store, *, words, num_steps: int, timesteps: dict[int, int] | None = None,
                   slot: int = 0, steps=None) -> "AttentionRecord":
        """Copy the maps of one conditional slot out of an ``engine.attention.AttentionStore``.

        ``slot`` is the position among the recorded (conditional) slots; ``steps`` keeps only those
        recorded steps (None = all of them).
        """
        steps = store.steps if steps is None else [s for s in store.steps if s in set(steps)]
        layers = store.layers
        _check_recorded(store, steps, layers)

        def stack(kind: str) -> np.ndarray:
            per_step = []
            for s in steps:
                per_layer = [store.get(step=s, layer=l, kind=kind).probs[slot].numpy() for l in layers]
                per_step.append(np.stack(per_layer))
            return np.ascontiguousarray(np.stack(per_step), dtype=np.float16)

        times = timesteps or {}
        return cls(words=tuple(words), steps=tuple(steps), num_steps=int(num_steps),
                   timesteps=tuple(int(times.get(s, -1)) for s in steps),
                   self_maps=stack("self"), cross_maps=stack("cross"))

    @classmethod
    def from_timeline(cls, store, *, words, lengths, starts, num_steps: int,
                      timesteps: dict[int, int] | None = None) -> "AttentionRecord":
        """One record of a motion joined from several slots (DoubleTake's first take: slot i is interval i, its
        ``words[i]`` and ``lengths[i]`` frames, starting at frame ``starts[i]`` of the timeline).

        The words are every slot's in turn. Slot i's self-attention fills its block of the timeline (rows and keys
        of its own frames) and its cross-attention its own words' columns; a frame two slots share (a handshake)
        takes the mean of both rows, so every row still sums to 1 and a word's curve is zero outside its slot."""
        steps, layers = store.steps, store.layers
        _check_recorded(store, steps, layers)
        if not len(words) == len(lengths) == len(starts):
            raise ValueError("give one word list, length and start per slot")
        total = max(s + n for s, n in zip(starts, lengths))
        cols = np.concatenate([[0], np.cumsum([len(w) for w in words])]).astype(int)
        cover = np.zeros(total, np.float32)
        for s, n in zip(starts, lengths):
            cover[s:s + n] += 1
        if (cover == 0).any():
            raise ValueError("the slots leave frames of the timeline uncovered")
        shape = (len(steps), len(layers), store.get(step=steps[0], layer=layers[0], kind="self").probs.shape[1])
        self_maps = np.zeros(shape + (total, total), np.float16)
        cross_maps = np.zeros(shape + (total, int(cols[-1])), np.float16)
        for si, step in enumerate(steps):  # one step at a time in float32: the sums stay small
            acc_self = np.zeros(shape[1:] + (total, total), np.float32)
            acc_cross = np.zeros(shape[1:] + (total, int(cols[-1])), np.float32)
            for li, layer in enumerate(layers):
                sp = store.get(step=step, layer=layer, kind="self").probs.float().numpy()  # (B, H, N, N)
                cp = store.get(step=step, layer=layer, kind="cross").probs.float().numpy()  # (B, H, N, W)
                for slot, (s, n) in enumerate(zip(starts, lengths)):
                    acc_self[li, :, s:s + n, s:s + n] += sp[slot, :, :n, :n]
                    acc_cross[li, :, s:s + n, cols[slot]:cols[slot + 1]] += cp[slot, :, :n, :len(words[slot])]
            self_maps[si] = acc_self / cover[:, None]
            cross_maps[si] = acc_cross / cover[:, None]
        times = timesteps or {}
        return cls(words=tuple(w for ws in words for w in ws), steps=tuple(steps), num_steps=int(num_steps),
                   timesteps=tuple(int(times.get(s, -1)) for s in steps), self_maps=self_maps, cross_maps=cross_maps)

    # ------------------------------------------------------------------ reading
    def step_position(self, step: int) -> int:
        try:
            return self.steps.index(int(step))
        except ValueError:
            raise KeyError(f"step {step} was not recorded; recorded steps: {list(self.steps)}") from None

    def _select(self, maps: np.ndarray, kind: str, step, layer, head) -> np.ndarray:
        key = (kind, step, layer, head)
        hit = self._cache.get(key)
        if hit is not None:
            self._cache.move_to_end(key)
            return hit
        sel = maps
        sel = sel[[self.step_position(step)]] if step is not None else sel
        if layer is not None:
            if not 0 <= layer < self.n_layers:
                raise KeyError(f"layer {layer} out of range 0..{self.n_layers - 1}")
            sel = sel[:, [layer]]
        if head is not None:
            if not 0 <= head < self.n_heads:
                raise KeyError(f"head {head} out of range 0..{self.n_heads - 1}")
            sel = sel[:, :, [head]]
        out = sel.astype(np.float32).mean(axis=(0, 1, 2))
        self._cache[key] = out
        while len(self._cache) > 24:
            self._cache.popitem(last=False)
        return out

    def self_map(self, *, step: int | None = None, layer: int | None = None, head: int | None = None) -> np.ndarray:
        """(N, N) float32: frame-to-frame attention (rows: query frames)."""
        return self._select(self.self_maps, "self", step, layer, head)

    def cross_map(self, *, step: int | None = None, layer: int | None = None, head: int | None = None) -> np.ndarray:
        """(N, W) float32: frame-to-word attention."""
        return self._select(self.cross_maps, "cross", step, layer, head)

    def word_curve(self, word: int, **selection) -> np.ndarray:
        """(N,) attention of every frame on word ``word`` (a token index)."""
        if not 0 <= word < len(self.words):
            raise KeyError(f"word index {word} out of range for {self.words}")
        return self.cross_map(**selection)[:, word]

    # ------------------------------------------------------------------ export
    def to_json_dict(self, *, step: int | None, layer: int | None, head: int | None) -> dict:
        return {
            "words": list(self.words),
            "frames": self.n_frames,
            "fps": 20,
            "num_steps": self.num_steps,
            "recorded_steps": list(self.steps),
            "selection": {"step": step, "layer": layer, "head": head,
                          "meaning": "null = mean over that axis; rows are query frames"},
            "self_attention": np.round(self.self_map(step=step, layer=layer, head=head), 6).tolist(),
            "cross_attention": np.round(self.cross_map(step=step, layer=layer, head=head), 6).tolist(),
        }

    def to_json_bytes(self, **selection) -> bytes:
        return json.dumps(self.to_json_dict(**selection)).encode()

    def to_png_bytes(self, *, step: int | None, layer: int | None, head: int | None, title: str = "") -> bytes:
        """A figure with the self-attention heatmap and the word curves (matplotlib, Agg)."""
        from matplotlib.figure import Figure

        sm = self.self_map(step=step, layer=layer, head=head)
        cm = self.cross_map(step=step, layer=layer, head=head)
        fig = Figure(figsize=(11, 5), dpi=100, layout="constrained")  # no label over a neighbour's ticks
        ax1, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1, 1.3]})
        im = ax1.imshow(sm, cmap="viridis", origin="upper", vmin=0, vmax=float(np.quantile(sm, 0.995)) or None)
        ax1.set_xlabel("key frame")
        ax1.set_ylabel("query frame")
        ax1.set_title("self-attention")
        fig.colorbar(im, ax=ax1, fraction=0.046, pad=0.03, label="attention (clipped at the 99.5th pct)")
        for i, w in enumerate(self.words):
            ax2.plot(cm[:, i], label=w)
        ax2.set_xlabel("frame")
        ax2.set_ylabel("attention")
        ax2.set_title("cross-attention per word")
        ax2.legend(fontsize=8, ncol=2)
        sel = describe_selection(step=step, layer=layer, head=head, num_steps=self.num_steps)
        fig.suptitle(f"{title}  ({sel})" if title else sel)
        buf = io.BytesIO()
        fig.savefig(buf, format="png")
        return buf.getvalue()


def describe_selection(*, step, layer, head, num_steps: int | None = None) -> str:
    """The selection as the studio states it: steps counted from 1 ("step 50/50"), as in its Step menu."""
    return ", ".join([
        "all recorded steps" if step is None else (f"step {step + 1}/{num_steps}" if num_steps else f"step {step + 1}"),
        "mean of layers" if layer is None else f"layer {layer}",
        "mean of heads" if head is None else f"head {head}",
    ])
