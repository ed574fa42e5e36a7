"""Frame sequences: file-name patterns and frame ranges.

Pattern styles (one frame token per pattern, in the file name, not in the folder):

===================  ==================  =============================================================
pattern              frame 7             rule
===================  ==================  =============================================================
``plate.####.exr``   ``plate.0007.exr``  each ``#`` is one digit (Nuke, Blender)
``plate.@@@@.exr``   ``plate.0007.exr``  each ``@`` is one digit (Nuke, oiiotool)
``plate.%04d.exr``   ``plate.0007.exr``  printf: ``%0Nd`` pads to N digits, ``%d`` does not pad
``plate.#.exr``      ``plate.7.exr``     one ``#``: no padding
===================  ==================  =============================================================

Note that oiiotool reads a single ``#`` as *four* digits; vfxstereo follows Nuke and Blender, where
``####`` is four digits, so a pattern means the same in vfxstereo, Nuke and Blender. Frames with more
digits than the padding are written in full (``####`` with frame 12345 gives ``12345``). Negative frame
numbers are not supported.

Frame ranges (:func:`parse_frames`): ``"1001-1100"``, ``"1001-1100x2"`` (every second frame),
``"1,5,10-12"``, or a single ``"1001"``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from dataclasses import dataclass

from vfxstereo.errors import VfxStereoError

_TOKEN = re.compile(r"#+|@+|%(0\d+)?d")


@dataclass(frozen=True)
class FramePattern:
    """A parsed pattern: ``folder/head`` + frame number padded to ``padding`` digits + ``tail``."""

    head: str
    padding: int
    tail: str

    def path(self, frame: int) -> str:
        """The file name of ``frame``."""
        frame = int(frame)
        if frame < 0:
            raise VfxStereoError(f"negative frame numbers are not supported (frame {frame})")
        return f"{self.head}{frame:0{self.padding}d}{self.tail}"

    def match(self, name: str) -> int | None:
        """The frame number of file path ``name`` if it belongs to the sequence, else None."""
        if not (name.startswith(self.head) and name.endswith(self.tail)):
            return None
        digits = name[len(self.head):len(name) - len(self.tail)]
        if not digits.isascii() or not digits.isdigit():
            return None
        frame = int(digits)
        return frame if f"{frame:0{self.padding}d}" == digits else None


def _tokens(pattern: str) -> list[re.Match]:
    folder_len = len(os.path.dirname(pattern))
    return [m for m in _TOKEN.finditer(pattern) if m.start() >= folder_len]


def is_pattern(s) -> bool:
    """True if the file name in ``s`` holds a frame token (``#``, ``@`` or ``%0Nd``)."""
    return bool(_tokens(os.fspath(s)))


def parse_pattern(pattern) -> FramePattern:
    """Split a pattern at its frame token.

    Raises
    ------
    VfxStereoError
        If the file name holds no frame token, or more than one.
    """
    pattern = os.fspath(pattern)
    tokens = _tokens(pattern)
    if not tokens:
        raise VfxStereoError(f"{pattern!r} is not a frame pattern (use ####, @@@@ or %04d in the file name)")
    if len(tokens) > 1:
        raise VfxStereoError(f"{pattern!r} has {len(tokens)} frame tokens; use exactly one")
    m = tokens[0]
    text = m.group(0)
    if text.startswith("%"):
        padding = int(m.group(1)) if m.group(1) else 1  # %0Nd or %d
    else:
        padding = len(text)  # one digit per # or @
    return FramePattern(pattern[: m.start()], padding, pattern[m.end():])


def frame_path(pattern, frame: int) -> str:
    """The file of ``frame`` in ``pattern`` (``frame_path("a.####.exr", 7) == "a.0007.exr"``)."""
    return parse_pattern(pattern).path(frame)


def expand(pattern, frames) -> list[str]:
    """The files of ``frames`` in ``pattern``.

    Parameters
    ----------
    pattern : str or Path
        A frame pattern (see the module docstring).
    frames : iterable of int, or str
        Frame numbers, or a range such as ``"1001-1100x2"`` (:func:`parse_frames`).

    Returns
    -------
    list of str, in the order of ``frames``.
    """
    p = parse_pattern(pattern)
    if isinstance(frames, str):
        frames = parse_frames(frames)
    return [p.path(f) for f in frames]


def _int(text: str, spec: str) -> int:
    text = text.strip()
    if text.startswith("-"):
        raise VfxStereoError(f"negative frame numbers are not supported: {spec!r}")
    if not (text.isascii() and text.isdigit()):
        raise VfxStereoError(f"bad frame range {spec!r}: {text!r} is not a frame number "
                             "(use e.g. 1001-1100, 1001-1100x2 or 1,5,10-12)")
    return int(text)


def parse_frames(spec: str) -> list[int]:
    """Frame numbers of a range: ``"1001-1100"``, ``"1001-1100x2"``, ``"1,5,10-12"``, ``"1001"``.

    Returns
    -------
    list of int, sorted, without repeats. ``"A-BxS"`` runs from A to B (inclusive when it lands on B) in
    steps of S.

    Raises
    ------
    VfxStereoError
        Empty or malformed ranges, an end before its start, a step below 1, negative frames.
    """
    frames: set[int] = set()
    text = str(spec).strip()
    if not text:
        raise VfxStereoError("empty frame range")
    for part in text.split(","):
        part = part.strip()
        if not part:
            raise VfxStereoError(f"bad frame range {spec!r}: empty item")
        step = 1
        if "x" in part:
            part, step_text = part.split("x", 1)
            step = _int(step_text, spec)
            if step < 1:
                raise VfxStereoError(f"bad frame range {spec!r}: the step must be at least 1")
        if "-" in part.lstrip("-"):
            start_text, end_text = part.rsplit("-", 1) if not part.startswith("-") else ("-", "")
            start, end = _int(start_text, spec), _int(end_text, spec)
            if end < start:
                raise VfxStereoError(f"bad frame range {spec!r}: {end} comes before {start}")
            frames.update(range(start, end + 1, step))
        else:
            if step != 1:
                raise VfxStereoError(f"bad frame range {spec!r}: a step needs a range (A-BxS)")
            frames.add(_int(part, spec))
    return sorted(frames)


def find_frames(pattern) -> list[int]:
    """Frame numbers of the files of ``pattern`` that exist on disk, sorted.

    A file belongs to the sequence when its number is written with exactly the pattern's padding
    (``####`` matches ``0007`` and ``12345``, not ``007`` or ``00007``).

    Raises
    ------
    VfxStereoError
        If ``pattern`` is not a pattern, or no file matches it.
    """
    p = parse_pattern(pattern)
    folder = os.path.dirname(p.head) or "."
    prefix = os.path.basename(p.head)
    try:
        names = os.listdir(folder)
    except OSError:
        raise VfxStereoError(f"no files match {os.fspath(pattern)!r}: folder {folder!r} not found") from None
    local = FramePattern(prefix, p.padding, p.tail)
    frames = sorted(f for f in (local.match(n) for n in names) if f is not None)
    if not frames:
        raise VfxStereoError(f"no files match {os.fspath(pattern)!r}")
    return frames


def existing(pattern, frames: Iterable[int] | str) -> list[str]:
    """The files of ``frames`` (numbers or a range string) in ``pattern``, checking every one exists.

    Raises
    ------
    VfxStereoError
        Naming the first missing file.
    """
    paths = expand(pattern, frames)
    for path in paths:
        if not os.path.isfile(path):
            raise VfxStereoError(f"frame file not found: {path}")
    return paths
