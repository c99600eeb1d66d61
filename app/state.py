"""One browser session's state: inputs, the running generation, the motions, the attention selection.

Every session gets its own ``StudioState``; only the loaded model (read-only) is shared between
sessions. Work that takes time (sampling) runs on a worker thread and *posts* its results back
with :meth:`StudioState.post`, which runs them on the session's document thread when served (or
directly in tests), so parameters are only ever changed from one thread at a time.
"""
from __future__ import annotations

import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import param

from app.attention_record import AttentionRecord
from app.generation import Cancelled, GenerationResult, GenerationSettings, check, run_generation
from engine.text import split_words

MAX_ITEMS = 8
MAX_ITEMS_WITH_ATTENTION = 3


@dataclass
class MotionItem:
    """A motion the session can show: generated (with attention) or imported."""

    name: str
    joints: np.ndarray  # (T, 22, 3) float32
    source: str  # "generated" | "imported"
    prompt: str = ""
    words: tuple[str, ...] = ()
    attention: AttentionRecord | None = None
    features: np.ndarray | None = None
    settings: GenerationSettings | None = None
    info: dict = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return len(self.joints)


class StudioState(param.Parameterized):
    """Everything a session's views read; each browser session gets its own instance."""

    # ---- generation inputs
    prompt = param.String(default="a person jumps twice", doc="what to generate")
    seconds = param.Number(default=4.0, doc="duration in seconds (1 to 9.8)")
    seed = param.Integer(default=0, doc="noise seed (same seed, same motion)")
    steps = param.Integer(default=50, bounds=(1, 1000), doc="sampling steps (DDIM)")
    guidance = param.Number(default=2.5, bounds=(0.0, 20.0), doc="classifier-free guidance scale")
    record_steps = param.Integer(default=10, bounds=(0, 1000),
                                 doc="sampling steps whose attention is recorded (0 = none)")

    # ---- derived from the prompt
    prompt_words = param.List(default=[], doc="words of the prompt")
    unknown_words = param.List(default=[], doc="words of the prompt the model does not know")
    suggestions = param.Dict(default={}, doc="unknown word -> close vocabulary words")

    # ---- generation progress
    running = param.Boolean(default=False)
    progress = param.Integer(default=0, doc="sampling steps done")
    progress_total = param.Integer(default=1)
    status = param.String(default="", doc="one line on what is happening")
    notice = param.Tuple(default=(0, "", ""), length=3, doc="(serial, level, text) of the last notification")

    # ---- motions
    items = param.Dict(default={}, doc="name -> MotionItem, in creation order")
    current = param.String(default="", doc="name of the motion shown (and whose attention is explored)")
    compare = param.String(default="", doc="name of a second motion shown side by side ('' = none)")
    frame = param.Integer(default=0, bounds=(0, None), doc="the playhead")
    playing = param.Boolean(default=False, doc="the browser is playing the motion")

    # ---- viewer settings
    follow = param.Boolean(default=True, doc="camera follows the pelvis")
    show_path = param.Boolean(default=True, doc="draw the root path on the floor")

    # ---- attention selection (None = mean)
    layer = param.Integer(default=None, allow_None=True, doc="layer of the self-attention map (None = mean)")
    head = param.Integer(default=None, allow_None=True, doc="head (None = mean of heads)")
    att_step = param.Integer(default=None, allow_None=True, doc="recorded sampling step (None = mean)")
    word = param.Integer(default=None, allow_None=True, doc="highlighted word (token index)")
    color_by_word = param.Boolean(default=False, doc="colour the skeleton by the highlighted word's attention")

    def __init__(self, *, model_dir: str | Path | None = None, **params):
        super().__init__(**params)
        self.model_dir = Path(model_dir) if model_dir is not None else None
        self._doc = None
        self._worker: threading.Thread | None = None
        self._cancel = threading.Event()
        self._counter = 0
        self.notices: list[tuple[str, str]] = []  # history (level, text), newest last
        self._closed = False
        self.param.watch(self._analyse_prompt, "prompt")
        self._analyse_prompt()

    # ------------------------------------------------------------------ threading
    def attach_document(self, doc) -> None:
        """Bind the session's Bokeh document: posted callbacks then run on its event loop."""
        self._doc = doc

    def post(self, fn: Callable[[], None]) -> None:
        """Run ``fn`` on the session's document thread (served) or right away (no server)."""
        doc = self._doc
        if doc is None or doc.session_context is None:
            fn()
            return
        from panel.io.state import set_curdoc

        def run():
            with set_curdoc(doc):
                try:
                    fn()
                except Exception as exc:  # never let a UI update kill the loop
                    traceback.print_exc()
                    self._notify("error", f"internal error: {exc}")

        try:
            doc.add_next_tick_callback(run)
        except Exception:  # the session is gone
            pass

    # ------------------------------------------------------------------ model
    @property
    def model(self):
        """The shared, read-only loaded model (raises if there is none)."""
        from app.model_cache import get_model

        if self.model_dir is None:
            raise FileNotFoundError("no model folder was given")
        return get_model(self.model_dir)

    @property
    def has_model(self) -> bool:
        try:
            self.model
            return True
        except Exception:
            return False

    @property
    def vocabulary(self) -> tuple[str, ...]:
        try:
            return self.model.tokenizer.words[1:]
        except Exception:
            return ()

    def _analyse_prompt(self, *_):
        words = split_words(self.prompt)
        try:
            tokenizer = self.model.tokenizer
        except Exception:
            tokenizer = None
        unknown = [] if tokenizer is None else list(dict.fromkeys(w for w in words if w not in tokenizer))
        suggestions = {} if tokenizer is None else {w: tokenizer.suggest(w) for w in unknown}
        with param.parameterized.batch_call_watchers(self):
            self.prompt_words = words
            self.unknown_words = unknown
            self.suggestions = suggestions

    def replace_word(self, old: str, new: str) -> None:
        """Swap an unknown word for a suggestion (whole words, case-insensitive)."""
        import re

        self.prompt = re.sub(rf"(?i)\b{re.escape(old)}\b", new, self.prompt)

    # ------------------------------------------------------------------ notifications
    def _notify(self, level: str, text: str) -> None:
        self._counter += 1
        self.notices.append((level, text))
        del self.notices[:-50]
        self.notice = (self._counter, level, text)

    def error(self, text: str) -> None:
        self._notify("error", text)

    def info(self, text: str) -> None:
        self._notify("info", text)

    # ------------------------------------------------------------------ generation
    def settings(self) -> GenerationSettings:
        return GenerationSettings(prompt=self.prompt, seconds=self.seconds, seed=self.seed, steps=self.steps,
                                  guidance=self.guidance, record_steps=self.record_steps)

    def generate(self) -> bool:
        """Check the inputs and start sampling on a worker thread; False (and a notification) if refused."""
        if self.running:
            self.error("a generation is already running: wait for it or press Cancel")
            return False
        try:
            loaded = self.model
        except Exception as exc:
            self.error(f"no model loaded: {exc}")
            return False
        try:
            checked = check(loaded, self.settings())
        except ValueError as exc:
            self.error(f"cannot generate: {exc}")
            return False
        self._cancel = threading.Event()
        cancel = self._cancel
        with param.parameterized.batch_call_watchers(self):
            self.running = True
            self.progress = 0
            self.progress_total = checked.config.steps
            self.status = f"generating {checked.frames / 20:.1f} s: step 0 / {checked.config.steps}"

        def on_step(done: int, total: int) -> None:
            def show():
                if cancel is self._cancel and self.running:
                    self.progress = done
                    self.status = f"generating: step {done} / {total}"
            self.post(show)

        def on_wait() -> None:
            self.post(lambda: setattr(self, "status", "waiting for another session's generation to finish"))

        def work() -> None:
            try:
                result = run_generation(loaded, checked, on_step=on_step, cancel=cancel, on_wait=on_wait)
            except Cancelled:
                self.post(lambda: self._finish(None, "generation cancelled", "info"))
                return
            except Exception as exc:  # shown to the user, the server keeps running
                traceback.print_exc()
                message = f"generation failed: {exc}"
                self.post(lambda: self._finish(None, message, "error"))
                return
            self.post(lambda: self._finish(result, "", ""))

        self._worker = threading.Thread(target=work, name="moattn-generate", daemon=True)
        self._worker.start()
        return True

    def cancel(self) -> None:
        if self.running:
            self._cancel.set()
            self.status = "cancelling..."

    def wait(self, timeout: float = 120.0) -> bool:
        """Block until the worker has finished (tests); True if it did."""
        worker = self._worker
        if worker is not None:
            worker.join(timeout)
            return not worker.is_alive()
        return True

    def _finish(self, result: GenerationResult | None, message: str, level: str) -> None:
        with param.parameterized.batch_call_watchers(self):
            self.running = False
            if result is None:
                self.progress = 0
                self.status = message
            else:
                self.progress = self.progress_total
                s = result.settings
                self.status = (f"{s.prompt!r}: {len(result.joints)} frames in {result.seconds_taken:.1f} s "
                               f"({s.steps} steps)")
        if result is None:
            if level:
                self._notify(level, message)
            return
        s = result.settings
        item = MotionItem(name=self._unique_name(f"{s.prompt} · seed {s.seed}"), joints=result.joints,
                          source="generated", prompt=s.prompt, words=result.words, attention=result.attention,
                          features=result.features, settings=s,
                          info={"seconds_taken": result.seconds_taken})
        self.add_item(item)

    # ------------------------------------------------------------------ motions
    def _unique_name(self, base: str) -> str:
        name, k = base, 2
        while name in self.items:
            name, k = f"{base} ({k})", k + 1
        return name

    def add_item(self, item: MotionItem, *, show: bool = True) -> None:
        """Add a motion to the session's list (oldest dropped past MAX_ITEMS) and show it."""
        items = dict(self.items)
        items[item.name] = item
        while len(items) > MAX_ITEMS:
            oldest = next(n for n in items if n not in (item.name, self.compare))
            del items[oldest]
        with_attention = [n for n, it in items.items() if it.attention is not None]
        for name in with_attention[:-MAX_ITEMS_WITH_ATTENTION]:
            items[name].attention = None  # keep memory bounded: old motions lose their maps
        with param.parameterized.batch_call_watchers(self):
            self.items = items
            if self.compare and self.compare not in items:
                self.compare = ""
            if show:
                self.show(item.name)

    def show(self, name: str) -> None:
        if name not in self.items:
            raise KeyError(f"no motion named {name!r}")
        item = self.items[name]
        with param.parameterized.batch_call_watchers(self):
            if self.compare == name:
                self.compare = ""
            self.frame = 0
            self.word = None
            if item.attention is not None:
                self.att_step = item.attention.steps[-1]
                if self.layer is not None and self.layer >= item.attention.n_layers:
                    self.layer = None
                if self.head is not None and self.head >= item.attention.n_heads:
                    self.head = None
                self.word = _content_word(item.words)
            self.current = name

    def show_motion(self, joints: np.ndarray, *, title: str, source: str = "imported") -> MotionItem:
        """Add a plain motion (file import, example) and show it."""
        joints = np.asarray(joints, dtype=np.float32)
        if joints.ndim != 3 or joints.shape[1:] != (22, 3) or len(joints) < 1:
            raise ValueError(f"a motion must have shape (T, 22, 3), got {joints.shape}")
        if not np.isfinite(joints).all():
            raise ValueError("the motion contains NaN or infinite values")
        item = MotionItem(name=self._unique_name(title), joints=joints, source=source)
        self.add_item(item)
        return item

    @property
    def item(self) -> MotionItem | None:
        return self.items.get(self.current)

    @property
    def compare_item(self) -> MotionItem | None:
        return self.items.get(self.compare) if self.compare else None

    @property
    def joints(self) -> np.ndarray | None:
        item = self.item
        return None if item is None else item.joints

    @property
    def n_frames(self) -> int:
        item = self.item
        n = 0 if item is None else item.n_frames
        other = self.compare_item
        return max(n, other.n_frames if other is not None else 0)

    @property
    def attention(self) -> AttentionRecord | None:
        item = self.item
        return None if item is None else item.attention

    def selection(self) -> dict:
        return {"step": self.att_step, "layer": self.layer, "head": self.head}

    def pick_frame(self, frame: int) -> None:
        """Move the playhead (from a click in an attention view)."""
        n = self.n_frames
        if n:
            self.frame = int(np.clip(frame, 0, n - 1))

    def word_values(self) -> np.ndarray | None:
        """Per-frame attention of the highlighted word for the current motion, or None."""
        record = self.attention
        if record is None or self.word is None or self.word >= len(record.words):
            return None
        sel = self.selection()
        sel["layer"] = None  # colouring uses the mean over layers (and the chosen step/head)
        return record.word_curve(self.word, **sel)

    def close(self) -> None:
        """The session ended: stop the worker."""
        self._closed = True
        self._cancel.set()


_FUNCTION_WORDS = {"a", "an", "the", "person", "man", "woman", "someone", "is", "and", "then", "while", "his",
                   "her", "their", "with", "in", "on", "of", "to", "at", "by", "like"}


def _content_word(words: tuple[str, ...]) -> int | None:
    """The first word that carries meaning (a verb, usually): the default highlighted word."""
    for i, w in enumerate(words):
        if w not in _FUNCTION_WORDS:
            return i
    return 0 if words else None
