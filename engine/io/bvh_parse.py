"""A strict BVH reader and vectorised forward kinematics.

The grammar read here::

    HIERARCHY
    ROOT <name> {                 (the brace may also stand on the next line)
        OFFSET x y z
        CHANNELS n <channel>...   (any order, any subset of X/Y/Z position/rotation)
        JOINT <name> { ... }      (nested, any depth)
        End Site { OFFSET x y z }
    }
    MOTION
    Frames: N
    Frame Time: seconds
    N lines of sum(n) numbers

Joint names may contain spaces ("Bip01 L Thigh"). Keywords are matched case-insensitively,
everything else strictly: every problem raises :class:`BVHError` naming the problem and the
line. What a file may declare is limited (:mod:`engine.io.errors`: at most MAX_JOINTS joints
nested at most MAX_DEPTH deep, a Frame Time from MIN_FRAME_TIME to MAX_FRAME_TIME, at most
MAX_DECLARED_FRAMES frames lasting at most MAX_IMPORT_SECONDS, at most MAX_JOINT_FRAMES
frames x joints); the limits are checked as the hierarchy and the ``Frames:`` / ``Frame Time:``
lines are read, before the motion is allocated. End Sites become joints of their own (no channels,
``end_site`` True) so forward kinematics returns their positions too.

Conventions (those of BVH and of :mod:`engine.skeleton`): a joint's world rotation is
``G[j] = G[parent] @ R[j]`` with ``R[j]`` the product of its rotation channels in file order
(the first channel outermost, e.g. "Zrotation Yrotation Xrotation" -> Rz @ Ry @ Rx); its world
position is ``P[parent] + G[parent] @ t[j]`` where ``t[j]`` is its OFFSET with every component
that has a position channel replaced by that channel's value (for the root this makes the
position channels absolute, as Blender reads them).
"""
from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from engine.io.errors import (
    DEFAULT_MAX_BYTES,
    MAX_DECLARED_FRAMES,
    MAX_DEPTH,
    MAX_FRAME_TIME,
    MAX_IMPORT_SECONDS,
    MAX_JOINT_FRAMES,
    MAX_JOINTS,
    MIN_FRAME_TIME,
    BVHError,
    check_file_size,
)
from engine.rotations import axis_rotation

CHANNEL_NAMES: tuple[str, ...] = (
    "Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation",
)
_CHANNEL_LOOKUP = {name.lower(): name for name in CHANNEL_NAMES}
_AXIS = {"X": 0, "Y": 1, "Z": 2}
_FRAMES_RE = re.compile(r"^frames\s*:\s*(\S+)\s*$", re.IGNORECASE)
_FRAME_TIME_RE = re.compile(r"^frame\s+time\s*:\s*(\S+)\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class BVHData:
    """A parsed BVH file.

    names:      joint names, parents before children (End Sites are named "<parent>/End Site")
    parents:    parent index per joint, -1 for the root
    offsets:    (J, 3) rest offsets from the parent, in the file's units
    channels:   per joint, its channel names in file order (() for End Sites)
    end_site:   per joint, whether it is an End Site
    frame_time: seconds per frame
    motion:     (F, C) channel values per frame, C = total number of channels, float64
    source:     file name, for messages
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    channels: tuple[tuple[str, ...], ...]
    end_site: tuple[bool, ...]
    frame_time: float
    motion: np.ndarray
    source: str | None = None

    # ------------------------------------------------------------------ basic facts
    @property
    def num_joints(self) -> int:
        return len(self.names)

    @property
    def num_frames(self) -> int:
        return int(self.motion.shape[0])

    @property
    def num_channels(self) -> int:
        return int(self.motion.shape[1])

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Seconds from the first to the last frame."""
        return (self.num_frames - 1) * self.frame_time

    @property
    def channel_starts(self) -> tuple[int, ...]:
        """Column of each joint's first channel in :attr:`motion`."""
        starts, column = [], 0
        for chans in self.channels:
            starts.append(column)
            column += len(chans)
        return tuple(starts)

    def index(self, name: str) -> int:
        """Index of the joint called ``name`` (exact match)."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no joint named {name!r} in the BVH hierarchy") from None

    def children(self, joint: int) -> tuple[int, ...]:
        return tuple(c for c, p in enumerate(self.parents) if p == joint)

    # ------------------------------------------------------------------ kinematics
    def local_transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-frame local rotations (F, J, 3, 3) and translations (F, J, 3)."""
        return _local(self, self.motion)

    def world_transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """World rotations (F, J, 3, 3) and positions (F, J, 3) of every joint, End Sites included."""
        return self._world(self.motion)

    def _world(self, motion: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        rot, trans = _local(self, motion)
        glob = np.empty_like(rot)
        pos = np.empty_like(trans)
        for j, parent in enumerate(self.parents):
            if parent < 0:
                glob[:, j] = rot[:, j]
                pos[:, j] = trans[:, j]
            else:
                glob[:, j] = glob[:, parent] @ rot[:, j]
                pos[:, j] = pos[:, parent] + np.einsum("fab,fb->fa", glob[:, parent], trans[:, j])
        return glob, pos

    def world_positions(self) -> np.ndarray:
        """World positions (F, J, 3) of every joint, End Sites included, in the file's units.

        Computed a block of frames at a time, so only the positions are held for the whole motion."""
        step = max(1, _FK_BLOCK // max(1, self.num_joints))
        out = np.empty((self.num_frames, self.num_joints, 3))
        for first in range(0, self.num_frames, step):
            out[first:first + step] = self._world(self.motion[first:first + step])[1]
        return out

    def rest_positions(self) -> np.ndarray:
        """Positions (J, 3) of the rest pose (all rotations identity, offsets only)."""
        pos = np.zeros((self.num_joints, 3))
        for j, parent in enumerate(self.parents):
            pos[j] = self.offsets[j] if parent < 0 else pos[parent] + self.offsets[j]
        return pos


_FK_BLOCK = 200_000  # joint-frames of forward kinematics computed at once by world_positions


def _local(data: BVHData, motion: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations (F, J, 3, 3) and translations (F, J, 3) of the frames ``motion`` (F, C)."""
    frames = len(motion)
    rot = np.broadcast_to(np.eye(3), (frames, data.num_joints, 3, 3)).copy()
    trans = np.broadcast_to(data.offsets, (frames, data.num_joints, 3)).copy()
    for j, (chans, start) in enumerate(zip(data.channels, data.channel_starts)):
        for k, chan in enumerate(chans):
            values = motion[:, start + k]
            axis = chan[0]
            if chan.endswith("position"):
                trans[:, j, _AXIS[axis]] = values
            else:
                rot[:, j] = rot[:, j] @ axis_rotation(axis.lower(), np.deg2rad(values))
    return rot, trans


# ---------------------------------------------------------------------- reading
def read_bvh(path: str | os.PathLike[str], *, max_bytes: int = DEFAULT_MAX_BYTES) -> BVHData:
    """Parse the BVH file at ``path``; files larger than ``max_bytes`` are refused."""
    path = Path(path)
    check_file_size(path, max_bytes=max_bytes, kind="BVH", error=BVHError)
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return parse_bvh(text, source=path.name, max_bytes=max_bytes)


def parse_bvh(text: str, *, source: str | None = None, max_bytes: int = DEFAULT_MAX_BYTES) -> BVHData:
    """Parse BVH text (see the module docstring for the grammar); raises :class:`BVHError`."""
    if len(text) > max_bytes:
        raise BVHError(
            f"BVH text is {len(text) / 2**20:.1f} MiB, larger than the limit of {max_bytes / 2**20:.1f} MiB",
            source=source,
        )
    return _Parser(text.splitlines(), source).parse()


class _Parser:
    """Line-based recursive-descent parser; one instance per text."""

    def __init__(self, lines: list[str], source: str | None) -> None:
        self.lines = lines
        self.source = source
        self.pos = 0  # index of the next line to read
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[tuple[float, float, float] | None] = []
        self.channels: list[tuple[str, ...]] = []
        self.end_site: list[bool] = []
        self.defined_on: dict[str, int] = {}

    # -------------------------------------------------------------- helpers
    def error(self, message: str, line: int | None = None) -> BVHError:
        return BVHError(message, line=line, source=self.source)

    def next_line(self, what: str) -> tuple[int, str]:
        """The next non-blank line (1-based number, stripped text); EOF is an error naming ``what``."""
        while self.pos < len(self.lines):
            text = self.lines[self.pos].strip()
            self.pos += 1
            if text:
                return self.pos, text
        raise self.error(f"unexpected end of file: expected {what}", len(self.lines) or None)

    def number(self, token: str, what: str, line: int) -> float:
        try:
            value = float(token)
        except ValueError:
            raise self.error(f"non-numeric value {token!r} in {what}", line) from None
        if not math.isfinite(value):
            raise self.error(f"{what} contains a NaN or infinite value ({token!r})", line)
        return value

    # -------------------------------------------------------------- grammar
    def parse(self) -> BVHData:
        line, text = self.next_line("HIERARCHY")
        if text.upper() != "HIERARCHY":
            raise self.error(f"expected HIERARCHY at the start of the file, found {text[:40]!r}", line)
        line, text = self.next_line("ROOT")
        keyword, rest = _split_keyword(text)
        if keyword.upper() != "ROOT":
            raise self.error(f"expected ROOT after HIERARCHY, found {text[:40]!r}", line)
        self.joint(rest, parent=-1, line=line, end_site=False, depth=1)
        try:
            line, text = self.next_line("MOTION")
        except BVHError:
            raise self.error("missing MOTION section after the hierarchy", len(self.lines)) from None
        keyword = text.split()[0].upper()
        if keyword == "ROOT":
            raise self.error("a second ROOT was found; only one skeleton per file is supported", line)
        if text == "}":
            raise self.error("unbalanced braces: '}' without a matching '{'", line)
        if text.upper() != "MOTION":
            raise self.error(f"expected MOTION after the hierarchy, found {text[:40]!r}", line)
        num_channels = sum(len(c) for c in self.channels)
        if num_channels == 0:
            raise self.error("the hierarchy declares no channels, so there is no motion to read", line)
        frames, frame_time, motion = self.motion(num_channels)
        return BVHData(
            names=tuple(self.names),
            parents=tuple(self.parents),
            offsets=np.array(self.offsets, dtype=np.float64),
            channels=tuple(self.channels),
            end_site=tuple(self.end_site),
            frame_time=frame_time,
            motion=motion,
            source=self.source,
        )

    def open_brace(self, header_rest: str, header_line: int, what: str) -> str:
        """Consume the '{' of a block (trailing on the header or on the next line); returns the header name."""
        name = header_rest.strip()
        if name.endswith("{"):
            return name[:-1].strip()
        line, text = self.next_line(f"'{{' opening {what}")
        if text != "{":
            raise self.error(f"expected '{{' to open {what}, found {text[:40]!r}", line)
        return name

    def joint(self, header_rest: str, *, parent: int, line: int, end_site: bool, depth: int) -> None:
        what = "End Site" if end_site else "joint"
        if depth > MAX_DEPTH:
            raise self.error(f"the hierarchy is nested more than {MAX_DEPTH} joints deep, deeper than the limit "
                             f"of {MAX_DEPTH}", line)
        if len(self.names) >= MAX_JOINTS:
            raise self.error(f"the hierarchy has more than {MAX_JOINTS} joints (End Sites included), more than the "
                             f"limit of {MAX_JOINTS}", line)
        name = self.open_brace(header_rest, line, what)
        if end_site:
            parent_name = self.names[parent]
            name = f"{parent_name}/End Site"
        else:
            if not name:
                raise self.error("joint without a name", line)
            if "{" in name or "}" in name:
                raise self.error(f"unbalanced braces in the joint header {name!r}", line)
            if name in self.defined_on:
                raise self.error(
                    f"duplicate joint name {name!r} (first defined on line {self.defined_on[name]})", line
                )
            self.defined_on[name] = line
        index = len(self.names)
        self.names.append(name)
        self.parents.append(parent)
        self.offsets.append(None)
        self.channels.append(())
        self.end_site.append(end_site)
        label = f"End Site of {self.names[parent]!r}" if end_site else f"joint {name!r}"

        while True:
            try:
                line_no, text = self.next_line(f"'}}' closing {label}")
            except BVHError:
                raise self.error(
                    f"unbalanced braces: the file ends inside {label} (opened on line {line}), "
                    "a '}' is missing",
                    len(self.lines),
                ) from None
            keyword, rest = _split_keyword(text)
            upper = keyword.upper()
            if text == "}":
                break
            if upper == "OFFSET":
                if self.offsets[index] is not None:
                    raise self.error(f"second OFFSET in {label}", line_no)
                values = rest.split()
                if len(values) != 3:
                    raise self.error(f"OFFSET of {label} has {len(values)} values, expected 3", line_no)
                self.offsets[index] = tuple(self.number(v, f"OFFSET of {label}", line_no) for v in values)
            elif upper == "CHANNELS":
                if end_site:
                    raise self.error("an End Site cannot have CHANNELS", line_no)
                if self.channels[index]:
                    raise self.error(f"second CHANNELS line in {label}", line_no)
                self.channels[index] = self.channel_list(rest, label, line_no)
            elif upper in ("JOINT", "END"):
                if end_site:
                    raise self.error(f"an End Site cannot contain {keyword}", line_no)
                if self.offsets[index] is None:
                    raise self.error(f"{label} has no OFFSET before its children", line_no)
                if upper == "END":
                    site, rest = _split_keyword(rest)
                    if site.lower().rstrip("{") != "site":
                        raise self.error(f"expected 'End Site', found {text[:40]!r}", line_no)
                    if site.endswith("{"):
                        rest = "{"
                    self.joint(rest, parent=index, line=line_no, end_site=True, depth=depth + 1)
                else:
                    self.joint(rest, parent=index, line=line_no, end_site=False, depth=depth + 1)
            elif upper == "ROOT":
                raise self.error(f"ROOT inside {label}: unbalanced braces or a second skeleton", line_no)
            elif upper == "MOTION":
                raise self.error(
                    f"unbalanced braces: MOTION found while {label} (opened on line {line}) is still open",
                    line_no,
                )
            elif text == "{":
                raise self.error(f"unexpected '{{' inside {label}", line_no)
            else:
                raise self.error(f"unexpected line in {label}: {text[:40]!r}", line_no)
        if self.offsets[index] is None:
            raise self.error(f"{label} has no OFFSET", line_no)

    def channel_list(self, rest: str, label: str, line: int) -> tuple[str, ...]:
        tokens = rest.split()
        if not tokens:
            raise self.error(f"CHANNELS of {label} gives no count", line)
        try:
            count = int(tokens[0])
        except ValueError:
            raise self.error(f"CHANNELS count of {label} is not an integer: {tokens[0]!r}", line) from None
        names = tokens[1:]
        if count < 0 or count != len(names):
            raise self.error(
                f"CHANNELS of {label} declares {count} channels but lists {len(names)}", line
            )
        out = []
        for token in names:
            canonical = _CHANNEL_LOOKUP.get(token.lower())
            if canonical is None:
                raise self.error(
                    f"unknown channel name {token!r} in {label} (expected one of {', '.join(CHANNEL_NAMES)})",
                    line,
                )
            if canonical in out:
                raise self.error(f"channel {canonical} appears twice in {label}", line)
            out.append(canonical)
        return tuple(out)

    def motion(self, num_channels: int) -> tuple[int, float, np.ndarray]:
        line, text = self.next_line("'Frames:'")
        match = _FRAMES_RE.match(text)
        if not match:
            raise self.error(f"expected 'Frames: <count>' after MOTION, found {text[:40]!r}", line)
        try:
            frames = int(match.group(1))
        except ValueError:
            raise self.error(f"frame count is not an integer: {match.group(1)!r}", line) from None
        if frames <= 0:
            raise self.error(f"the file declares {frames} frames; at least one frame is needed (zero frames)", line)
        if frames > MAX_DECLARED_FRAMES:
            raise self.error(f"the file declares {frames} frames, more than the limit of {MAX_DECLARED_FRAMES:,}", line)
        line, text = self.next_line("'Frame Time:'")
        match = _FRAME_TIME_RE.match(text)
        if not match:
            raise self.error(f"expected 'Frame Time: <seconds>' after Frames, found {text[:40]!r}", line)
        frame_time = self.number(match.group(1), "Frame Time", line)
        if frame_time <= 0:
            raise self.error(f"Frame Time must be positive, got {frame_time}", line)
        if not MIN_FRAME_TIME <= frame_time <= MAX_FRAME_TIME:
            raise self.error(
                f"Frame Time {frame_time:g} s is outside the limits of {MIN_FRAME_TIME:g} s to {MAX_FRAME_TIME:g} s "
                f"({1 / MAX_FRAME_TIME:g} to {1 / MIN_FRAME_TIME:g} fps)", line)
        duration = (frames - 1) * frame_time
        if duration > MAX_IMPORT_SECONDS:
            raise self.error(
                f"{frames} frames of {frame_time:g} s make {duration:.1f} s of motion, longer than the limit of "
                f"{MAX_IMPORT_SECONDS:g} s ({MAX_IMPORT_SECONDS / 60:g} min); cut the file", line)
        joints = len(self.names)
        if frames * joints > MAX_JOINT_FRAMES:
            raise self.error(
                f"{frames} frames of {joints} joints (End Sites included) make {frames * joints:,} joint-frames, "
                f"more than the limit of {MAX_JOINT_FRAMES:,}; cut the file or lower its frame rate", line)
        # a file too short for its declared frames is refused here, before the motion array is allocated: it
        # needs a line per frame, and every value takes at least 2 characters ("0 ")
        rest = self.lines[self.pos:]
        lines_left = sum(1 for text in rest if not text.isspace() and text)
        if lines_left < frames:
            raise self.error(
                f"the file ends after {lines_left} of the {frames} frames declared by 'Frames:' (missing frame lines)",
                len(self.lines),
            )
        if frames * num_channels * 2 - 1 > sum(len(text) + 1 for text in rest):
            raise self.error(
                f"the file is too short for the {frames} frames of {num_channels} values declared by 'Frames:' "
                "(missing frame lines)", len(self.lines))

        motion = np.empty((frames, num_channels), dtype=np.float64)
        row_lines: list[int] = []
        count = 0
        while self.pos < len(self.lines):
            raw = self.lines[self.pos]
            self.pos += 1
            tokens = raw.split()
            if not tokens:
                continue
            if count == frames:
                raise self.error(
                    f"more frame lines than the {frames} declared by 'Frames:' (extra data)", self.pos
                )
            if len(tokens) != num_channels:
                raise self.error(
                    f"wrong number of values on frame {count + 1}: {len(tokens)} values, "
                    f"expected {num_channels} (one per channel)",
                    self.pos,
                )
            motion[count] = self.row(tokens, count + 1)
            row_lines.append(self.pos)
            count += 1
        if count < frames:
            raise self.error(
                f"the file ends after {count} of the {frames} frames declared by 'Frames:' (missing frame lines)",
                len(self.lines),
            )
        finite = np.isfinite(motion).all(axis=1)
        if not finite.all():
            k = int(np.argmin(finite))
            raise self.error(f"NaN or infinite value on frame {k + 1}", row_lines[k])
        return frames, frame_time, motion

    def row(self, tokens: list[str], frame: int) -> np.ndarray:
        """One frame's values (tokens already counted); a non-number is an error naming it."""
        try:
            return np.array(tokens, dtype=np.float64)
        except (ValueError, OverflowError):
            pass
        values = []
        for token in tokens:  # numpy refused one: Python's float names it (or reads what numpy would not)
            try:
                values.append(float(token))
            except ValueError:
                raise self.error(f"non-numeric value {token[:40]!r} on frame {frame}", self.pos) from None
        return np.array(values, dtype=np.float64)


def _split_keyword(text: str) -> tuple[str, str]:
    """'JOINT Bip01 L Thigh' -> ('JOINT', 'Bip01 L Thigh'); any whitespace separates the keyword."""
    parts = text.split(None, 1)
    return (parts[0], parts[1] if len(parts) > 1 else "")
