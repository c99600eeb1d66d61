"""An uploaded motion file parsed as data (never unpickled): the Files tab's import and the Transfer tab's source
upload share this."""
from __future__ import annotations

import re
import tempfile
from pathlib import Path

from app.session.items import MAX_UPLOAD_BYTES, upload_limit_text

_QUOTED = r"""(?:'(?:[^'\\\n]|\\.)*'|"(?:[^"\\\n]|\\.)*")"""
#: a quoted piece of the file after "found" or at the end of a message: a line of the file, never shown back
_ECHO = re.compile(rf"(?:,\s*found\s+{_QUOTED}|\s*\(?found\s+{_QUOTED}\)?|:\s*{_QUOTED}\s*$)")
#: what may stay quoted in a message: a name (a joint, a keyword) or a brace, not a piece of text
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.:\-]{0,31}|[{}]")


def display_name(filename: str | None) -> str:
    """The user's file name as messages show it: its last part, no control characters, at most 60 characters."""
    name = Path(str(filename or "")).name if filename else ""
    name = "".join(ch for ch in name if ch.isprintable()).strip() or "the file"
    return name if len(name) <= 60 else name[:40] + "…" + name[-19:]


def upload_reason(exc: Exception, filename: str, stand_in: Path) -> str:
    """Why an upload could not be read, said about the user's file: the parser saw it as ``stand_in`` (a temporary
    copy), so that path or name becomes ``filename``; the file's own text (a line it quoted) is left out."""
    text = str(exc)
    text = text.replace(str(stand_in), filename).replace(stand_in.name, filename)
    if text.startswith(f"{filename}: "):  # the message that carries this reason names the file already
        text = text[len(filename) + 2:]
    text = _ECHO.sub("", text)
    text = re.sub(_QUOTED, lambda m: m.group(0) if _NAME.fullmatch(m.group(0)[1:-1]) else "…", text)
    return text.strip() or "it is not a motion file this studio can read"


def import_bytes(data: bytes, filename: str):
    """Parse an uploaded file as data (never unpickled) -> joints (T, 22, 3).

    Every refusal is a ``ValueError`` whose message names the user's file (``filename``) and never quotes the
    file's content."""
    from engine.io import load_motion

    filename = display_name(filename)
    if not data:
        raise ValueError(f"{filename} is empty (0 bytes)")
    if len(data) > MAX_UPLOAD_BYTES:
        raise ValueError(f"{filename} is {len(data) / 2**20:.1f} MiB; uploads are limited to {upload_limit_text()}")
    suffix = Path(filename).suffix.lower()
    if suffix not in (".bvh", ".npy"):
        raise ValueError(f"{filename}: only .bvh and .npy files can be imported")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"upload{suffix}"
        path.write_bytes(data)
        try:
            joints = load_motion(path)
        except Exception as exc:  # the user's file, told by its name and without its text
            raise ValueError(upload_reason(exc, filename, stand_in=path)) from None
    if len(joints) < 2:
        raise ValueError(f"{filename} has {len(joints)} frame(s); at least 2 are needed")
    return joints


WINDOW_FIELDS = ("Start", "Seconds")  # the import's window fields, as the window's messages name them


def import_window(data: bytes, filename: str, *, start: float | None = None, seconds: float | None = None,
                  max_frames: int | None = None):
    """An upload's joints in the window ``start`` / ``seconds`` (seconds; None: from the beginning / to the end)
    and the whole file's length in frames. With ``max_frames`` (the model's limit) a longer window, or a longer
    file with no window, is refused with a one-line hint naming the Start/Seconds fields (engine.io.window)."""
    from engine.io import pick_window

    joints = import_bytes(data, filename)
    if seconds is None and start is not None and float(start) == 0.0:
        start = None  # no window asked for: a file over the limit gets the "pick a window" hint
    return pick_window(joints, start=start, seconds=seconds, max_frames=max_frames, name=filename,
                       flags=WINDOW_FIELDS), len(joints)
