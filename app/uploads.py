"""An uploaded motion file parsed as data (never unpickled): the Files tab's import and the Transfer tab's source
upload share this."""
from __future__ import annotations

import tempfile
from pathlib import Path

from app.session.items import MAX_UPLOAD_BYTES, upload_limit_text


def import_bytes(data: bytes, filename: str):
    """Parse an uploaded file as data (never unpickled) -> joints (T, 22, 3)."""
    from engine.io import load_motion

    if not data:
        raise ValueError(f"{filename} is empty")
    if len(data) > MAX_UPLOAD_BYTES:
        raise ValueError(f"{filename} is {len(data) / 2**20:.1f} MiB; uploads are limited to {upload_limit_text()}")
    suffix = Path(filename).suffix.lower()
    if suffix not in (".bvh", ".npy"):
        raise ValueError(f"{filename}: only .bvh and .npy files can be imported")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"upload{suffix}"
        path.write_bytes(data)
        joints = load_motion(path)
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
