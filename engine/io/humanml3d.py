"""Read and write folders in the HumanML3D layout.

    <folder>/new_joint_vecs/<name>.npy   (T-1, 263) float32 features
    <folder>/new_joints/<name>.npy       (T, 22, 3) float32 joints (optional)
    <folder>/texts/<name>.txt            one caption per line: caption#tokens#start#end
    <folder>/Mean.npy, Std.npy           (263,) normalisation statistics
    <folder>/train.txt, val.txt, test.txt  one sample name per line

In a caption line, ``tokens`` are space-separated ``word/POS`` pairs and ``start``/``end`` are
seconds into the clip; ``0#0`` (or NaN, as some HumanML3D lines have) means the whole clip.
The reader is what training iterates over; the writer is what the corpus exporter uses, so the
two agree by construction.
"""
from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np

from engine.io.errors import DEFAULT_MAX_BYTES, MotionIOError
from engine.io.npy import classify_motion_array, load_npy, read_array
from engine.representation import FEATURE_DIM, Normalizer

FEATURES_DIR = "new_joint_vecs"
JOINTS_DIR = "new_joints"
TEXTS_DIR = "texts"
SPLITS: tuple[str, ...] = ("train", "val", "test")
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$")
_WORD_RE = re.compile(r"[a-z0-9']+")


@dataclass(frozen=True)
class Caption:
    """One caption of a clip: text, ``word/POS`` tokens, and the seconds it covers (0, 0 = whole clip)."""

    text: str
    tokens: tuple[str, ...] = ()
    start: float = 0.0
    end: float = 0.0

    @property
    def whole_clip(self) -> bool:
        return self.start == 0.0 and self.end == 0.0

    def frames(self, *, fps: float = 20.0) -> tuple[int, int] | None:
        """(first, last + 1) frame of the covered interval at ``fps``, or None for the whole clip."""
        if self.whole_clip:
            return None
        return int(math.floor(self.start * fps)), int(math.floor(self.end * fps))

    def to_line(self) -> str:
        if "#" in self.text or "\n" in self.text or "\r" in self.text:
            raise MotionIOError(f"caption text must not contain '#' or line breaks: {self.text!r}")
        for token in self.tokens:
            if not token or "#" in token or any(c.isspace() for c in token):
                raise MotionIOError(f"caption token {token!r} must be non-empty, without '#' or spaces")
        tokens = self.tokens or default_tokens(self.text)
        return f"{self.text.strip()}#{' '.join(tokens)}#{float(self.start)!r}#{float(self.end)!r}"


def default_tokens(text: str) -> tuple[str, ...]:
    """``word/OTHER`` tokens for a caption without part-of-speech tags (HumanML3D's OTHER category)."""
    return tuple(f"{w}/OTHER" for w in _WORD_RE.findall(text.lower()))


def parse_caption_line(line: str, *, source: str = "captions", line_no: int | None = None) -> Caption:
    """Parse ``caption#tokens#start#end``; raises :class:`MotionIOError` naming the line."""
    where = f"{source}" + (f" line {line_no}" if line_no is not None else "")
    parts = line.rstrip("\r\n").split("#")
    if len(parts) != 4:
        raise MotionIOError(f"{where}: expected 'caption#tokens#start#end' (4 fields), found {len(parts)} fields")
    text, tokens, start_text, end_text = parts
    if not text.strip():
        raise MotionIOError(f"{where}: empty caption")
    times = []
    for label, value in (("start", start_text), ("end", end_text)):
        try:
            number = float(value)
        except ValueError:
            raise MotionIOError(f"{where}: {label} time {value!r} is not a number") from None
        if math.isnan(number):
            number = 0.0  # HumanML3D writes NaN for "whole clip" on some lines
        if not math.isfinite(number) or number < 0:
            raise MotionIOError(f"{where}: {label} time must be a non-negative number, got {value!r}")
        times.append(number)
    start, end = times
    if not (start == 0.0 and end == 0.0) and end <= start:
        raise MotionIOError(f"{where}: end time {end} is not after start time {start}")
    return Caption(text=text.strip(), tokens=tuple(tokens.split()), start=start, end=end)


def read_captions(path: str | os.PathLike[str], *, source: str | None = None) -> tuple[Caption, ...]:
    """All captions of a ``texts/<name>.txt`` file (blank lines skipped); errors name ``source`` (the path)."""
    path = Path(path)
    source = source or str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MotionIOError(f"caption file not found: {source}") from None
    except UnicodeDecodeError as exc:
        raise MotionIOError(f"{source} is not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise MotionIOError(f"cannot read caption file {source}: {exc.strerror or exc}") from None
    return tuple(
        parse_caption_line(line, source=source, line_no=i)
        for i, line in enumerate(text.splitlines(), start=1)
        if line.strip()
    )


def check_name(name: str) -> str:
    """A sample or split name safe to use as a file name (letters, digits, '_', '-', '.')."""
    if not isinstance(name, str) or not _NAME_RE.match(name) or ".." in name:
        raise MotionIOError(
            f"invalid sample name {name!r}: use letters, digits, '_', '-' and '.', starting with a letter or digit"
        )
    return name


class HumanML3DSample(NamedTuple):
    """One clip: its name, features (T-1, 263) float32 and captions (unpacks as a 3-tuple)."""

    name: str
    features: np.ndarray
    captions: tuple[Caption, ...]


class HumanML3DFolder:
    """A HumanML3D-layout folder (see the module docstring); nothing is read until asked for."""

    def __init__(self, root: str | os.PathLike[str], *, max_bytes: int = DEFAULT_MAX_BYTES,
                 require_texts: bool = True) -> None:
        self.root = Path(root)
        self.max_bytes = max_bytes
        if not self.root.is_dir():
            what = "is a file" if self.root.exists() else "does not exist"
            raise MotionIOError(f"{self.root} is not a HumanML3D folder: it {what}")
        if not (self.root / FEATURES_DIR).is_dir():
            raise MotionIOError(f"{self.root} is not a HumanML3D folder: it has no {FEATURES_DIR}/ directory")
        if require_texts and not (self.root / TEXTS_DIR).is_dir():
            raise MotionIOError(f"{self.root} is not a HumanML3D folder: it has no {TEXTS_DIR}/ directory")

    def __repr__(self) -> str:
        return f"HumanML3DFolder({str(self.root)!r})"

    def split_names(self, split: str) -> list[str]:
        """Sample names listed in ``<split>.txt`` (order kept, blank lines skipped)."""
        path = self.root / f"{check_name(split)}.txt"
        if not path.is_file():
            raise MotionIOError(f"split list {path} does not exist")
        names = [line.strip() for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]
        for i, name in enumerate(names, start=1):
            try:
                check_name(name)
            except MotionIOError as exc:
                raise MotionIOError(f"{path} line {i}: {exc}") from None
        return names

    def names(self) -> list[str]:
        """Every sample that has a feature file, sorted."""
        return sorted(p.stem for p in (self.root / FEATURES_DIR).glob("*.npy"))

    def features_path(self, name: str) -> Path:
        return self.root / FEATURES_DIR / f"{check_name(name)}.npy"

    def captions_path(self, name: str) -> Path:
        return self.root / TEXTS_DIR / f"{check_name(name)}.txt"

    def read_features(self, name: str) -> np.ndarray:
        """Features (T, 263) float32 of a sample; any problem is one :class:`MotionIOError` naming the file."""
        path = self.features_path(name)
        try:
            kind, array = load_npy(path, max_bytes=self.max_bytes)
        except MotionIOError as exc:
            message = str(exc)
            if str(path) not in message:  # the npy reader names the file only; give the whole path
                message = message.replace(path.name, str(path), 1) if path.name in message else f"{path}: {message}"
            raise MotionIOError(message) from None
        if kind != "vecs":
            raise MotionIOError(f"{path} holds joints {array.shape}, expected features (T, 263)")
        return array

    def read_joints(self, name: str) -> np.ndarray | None:
        """Joints (T, 22, 3) of a sample, or None when the folder has none for it."""
        path = self.root / JOINTS_DIR / f"{check_name(name)}.npy"
        if not path.is_file():
            return None
        kind, array = load_npy(path, max_bytes=self.max_bytes)
        if kind != "joints":
            raise MotionIOError(f"{path} holds features {array.shape}, expected joints (T, 22, 3)")
        return array

    def read_captions(self, name: str) -> tuple[Caption, ...]:
        """Captions of a sample; () when it has no text file."""
        path = self.captions_path(name)
        return read_captions(path) if path.is_file() else ()

    def read_sample(self, name: str) -> HumanML3DSample:
        return HumanML3DSample(name, self.read_features(name), self.read_captions(name))

    def missing_files(self, names: Iterable[str]) -> dict[str, Path]:
        """name -> the first of its files (features, then captions) that does not exist, for each incomplete name."""
        missing = {}
        for name in names:
            for path in (self.features_path(name), self.captions_path(name)):
                if not path.is_file():
                    missing[name] = path
                    break
        return missing

    def iter_samples(self, split: str | None = None, *, skip_missing: bool = False) -> Iterator[HumanML3DSample]:
        """Samples of a split (or all samples), as (name, features, captions).

        A listed name without its feature or caption file raises :class:`MotionIOError` naming the file;
        with ``skip_missing`` such names are skipped with one warning that counts them and names the
        first, and a split none of whose names is complete raises.
        """
        names = self.names() if split is None else self.split_names(split)
        missing = self.missing_files(names)
        if missing:
            where = self.root / f"{split}.txt" if split is not None else self.root
            first_name, first_path = next(iter(missing.items()))
            if not skip_missing:
                kind = "feature" if first_path.suffix == ".npy" else "caption"
                raise MotionIOError(f"sample {first_name!r} listed in {where} has no {kind} file: {first_path} not found")
            if len(missing) == len(names):
                raise MotionIOError(f"none of the {len(names)} samples listed in {where} has both its feature and "
                                    f"caption file (first missing: {first_path})")
            warnings.warn(f"{where}: skipped {len(missing)} of {len(names)} listed samples whose feature or caption "
                          f"file is missing (first: {first_path})", UserWarning, stacklevel=2)
        for name in names:
            if name not in missing:
                yield self.read_sample(name)

    def has_normalizer(self) -> bool:
        """Whether the folder has Mean.npy or Std.npy (then :meth:`normalizer` checks both)."""
        return any((self.root / n).exists() for n in ("Mean.npy", "Std.npy"))

    def normalizer(self) -> Normalizer:
        """Mean/Std of the folder: (263,) finite floats each, Std positive; errors name the file."""
        arrays = {}
        for file_name in ("Mean.npy", "Std.npy"):
            path = self.root / file_name
            if not path.is_file():
                raise MotionIOError(f"{self.root} has no {file_name}")
            array = read_array(path, max_bytes=self.max_bytes)
            if array.shape != (FEATURE_DIM,) or not np.issubdtype(array.dtype, np.floating):
                raise MotionIOError(f"{path} holds {array.dtype} of shape {array.shape}; expected ({FEATURE_DIM},) floats")
            bad = ~np.isfinite(array)
            if file_name == "Std.npy":
                bad |= ~(array > 0)
            if bad.any():
                what = "NaN/inf" if file_name == "Mean.npy" else "zero, negative or non-finite"
                raise MotionIOError(f"{path} has {int(bad.sum())} {what} entries (first at index "
                                    f"{int(np.argmax(bad))}); every entry must be a finite"
                                    f"{' positive' if file_name == 'Std.npy' else ''} number")
            arrays[file_name] = array
        return Normalizer(mean=arrays["Mean.npy"], std=arrays["Std.npy"])


def write_sample(
    folder: str | os.PathLike[str],
    name: str,
    features: np.ndarray,
    joints: np.ndarray | None,
    captions: Sequence[Caption | str],
) -> None:
    """Write one sample: features (T-1, 263), joints (T, 22, 3) or None, and its captions.

    Plain strings become whole-clip captions with ``word/OTHER`` tokens.
    """
    root = Path(folder)
    check_name(name)
    kind, features = classify_motion_array(features, name=f"features of {name!r}")
    if kind != "vecs":
        raise MotionIOError(f"features of {name!r} must have shape (T, 263), got {np.shape(features)}")
    lines = [(c if isinstance(c, Caption) else Caption(text=str(c))).to_line() for c in captions]
    if joints is not None:
        kind, joints = classify_motion_array(joints, name=f"joints of {name!r}")
        if kind != "joints":
            raise MotionIOError(f"joints of {name!r} must have shape (T, 22, 3), got {np.shape(joints)}")
        if len(joints) != len(features) + 1:
            raise MotionIOError(
                f"{name!r}: {len(joints)} joint frames for {len(features)} feature frames; "
                "HumanML3D keeps T poses and T-1 feature frames"
            )
    for sub in (FEATURES_DIR, TEXTS_DIR) + ((JOINTS_DIR,) if joints is not None else ()):
        (root / sub).mkdir(parents=True, exist_ok=True)
    np.save(root / FEATURES_DIR / f"{name}.npy", features, allow_pickle=False)
    if joints is not None:
        np.save(root / JOINTS_DIR / f"{name}.npy", joints, allow_pickle=False)
    (root / TEXTS_DIR / f"{name}.txt").write_text("".join(line + "\n" for line in lines), encoding="utf-8")


def write_split(folder: str | os.PathLike[str], split: str, names: Iterable[str]) -> Path:
    """Write ``<folder>/<split>.txt`` with one sample name per line; returns its path."""
    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    path = root / f"{check_name(split)}.txt"
    path.write_text("".join(check_name(n) + "\n" for n in names), encoding="utf-8")
    return path


def write_normalizer(folder: str | os.PathLike[str], normalizer: Normalizer) -> None:
    """Write ``Mean.npy`` and ``Std.npy``."""
    normalizer.save(folder)
