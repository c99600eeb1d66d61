"""The Duet tab's settings (ComMDM): from a prompt or completing a prefix, the lengths, the block and contact
guidance; the prefix choices (examples, uploads, the session's duets)."""
from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

import param

from app.components.option_params import param_for
from app.generation import PromptReading, prompt_analysis
from app.session.duets import DuetPair
from app.session.items import MAX_UPLOAD_BYTES, upload_limit_text
from app.tabs.duet.models import EXAMPLE, duet_vocabulary, example_names
from engine.methods.duet import COMPLETE_SECONDS, PREFIX_SECONDS, TEXT_SECONDS
from engine.methods.duet_options import DuetOptions
from engine.paths import DUET_DIR

MODES = {"text": "from a prompt", "prefix": "complete a prefix"}


class DuetSettings(param.Parameterized):
    """The Duet tab's settings (one per session, in ``StudioState.tab_settings["duet"]``) and its last duet.

    Lengths default to the engine's (``engine.methods.duet``: what ``moattn duet`` runs)."""

    mode = param.Selector(default="text", objects={label: key for key, label in MODES.items()}, label="Mode")
    # the tab opens on an example prompt (the command line has none unless given)
    prompt = param_for(DuetOptions, "prompt", default="two people shake hands")
    # a length, not None: the tab shows the mode's default length (None is "the mode's default" on the command line)
    seconds = param_for(DuetOptions, "seconds", default=TEXT_SECONDS)
    prefix = param.Selector(default=EXAMPLE + "handshake", objects=[EXAMPLE + "handshake"], label="Prefix (both people)",
                            doc="where the prefix comes from: an example, an upload or a duet of the session")
    prefix_seconds = param_for(DuetOptions, "prefix_seconds", default=PREFIX_SECONDS)  # the length None stands for
    # the switches' help is the --no-... flag's (what turning them off does): the checkboxes say what "on" does
    communicate = param_for(DuetOptions, "communication",
                            doc="ComMDM (the block); off: the prior twice, fixed placement")
    contact = param_for(DuetOptions, "contact",
                        doc="guide the hands to touch when the training examples do (text only)")
    duet_dir = param.Parameter(default=DUET_DIR, doc="folder of the trained ComMDM block")
    uploads = param.Dict(default={}, doc="name -> (2, T, 22, 3) duets uploaded in this session")
    reading = param.ClassSelector(class_=PromptReading, default=PromptReading(),
                                  doc="the prompt as the engine will read it (its notes, or why it refuses it)")
    result = param.Parameter(default=None, doc="DuetSummary of the last duet")

    @classmethod
    def for_session(cls, session, *, duet_dir=None) -> "DuetSettings":
        """The session's duet settings; the prefix list follows the session's duets."""
        extra = {} if duet_dir is None else {"duet_dir": duet_dir}
        settings = cls(tokenizer=session.tokenizer, items=lambda: session.items, **extra)
        session.param.watch(settings.refresh_prefixes, "items")
        return settings

    def __init__(self, *, tokenizer: Callable[[], object] | None = None, items: Callable[[], dict] | None = None,
                 **params):
        super().__init__(**params)
        self._prior_tokenizer = tokenizer or (lambda: None)
        self._items = items or dict
        self.param.watch(self._analyse, ["prompt", "mode"])
        self.param.watch(self._mode_length, "mode")
        self.param.watch(self.refresh_prefixes, "uploads")
        self._analyse()
        self.refresh_prefixes()

    def _mode_length(self, event) -> None:
        """Each mode's default length (the paper completes 3 s); a length the user typed is kept."""
        defaults = {"text": TEXT_SECONDS, "prefix": COMPLETE_SECONDS}
        if self.seconds == defaults[event.old]:
            self.seconds = defaults[event.new]

    def refresh_prefixes(self, *_) -> None:
        """The prefix choices: examples, uploads, the session's duets; the pick stays when it still exists."""
        options = self.prefix_options(self._items())
        self.param.prefix.objects = options
        if self.prefix not in options:
            self.prefix = options[0]

    def tokenizer(self):
        """The duet's vocabulary (read from its config once per duet folder and prior, not per keystroke)."""
        prior = self._prior_tokenizer()
        key = (str(self.duet_dir), id(prior))
        if getattr(self, "_vocab_key", None) != key:
            self._vocab, self._vocab_key = duet_vocabulary(self.duet_dir, prior), key
        return self._vocab

    def _analyse(self, *_) -> None:
        self.reading = prompt_analysis(self.tokenizer(), self.prompt)

    @property
    def blocked(self) -> bool:
        """From a prompt, the engine refuses it (completing a prefix, the prompt is optional)."""
        return self.mode == "text" and self.reading.blocked

    def prefix_options(self, items: dict) -> list[str]:
        """Examples, then uploaded duets, then duets of the session (their person-a motions)."""
        made = [n for n, it in items.items() if isinstance(it.info.get("duet"), DuetPair) and it.info["duet"].first == n]
        return [*example_names(), *self.uploads, *made]

    def add_upload(self, data: bytes, filename: str) -> str:
        """An uploaded duet .npy (2, T, 22, 3), parsed as data; its name in the prefix list."""
        from engine.io.npy import load_duet_npy

        if not data:
            raise ValueError(f"{filename} is empty")
        if len(data) > MAX_UPLOAD_BYTES:
            raise ValueError(f"{filename} is {len(data) / 2**20:.1f} MiB; uploads are limited to {upload_limit_text()}")
        if Path(filename).suffix.lower() != ".npy":
            raise ValueError(f"{filename}: a duet is a .npy of joints (2, T, 22, 3), as `moattn duet` writes")
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "duet.npy"
            path.write_bytes(data)
            joints = load_duet_npy(path)
        name = f"upload: {filename}"
        self.uploads = {**self.uploads, name: joints}  # the prefix choices follow
        self.prefix = name
        return name
