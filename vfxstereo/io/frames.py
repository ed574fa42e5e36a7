"""Frame sequences: file-name patterns and frame ranges, through ``fileseq`` (the library VFX pipelines use).

Pattern styles (one frame token per pattern, in the file name, not in the folder):

===================  ==================  =============================================================
pattern              frame 7             rule
===================  ==================  =============================================================
``plate.####.exr``   ``plate.0007.exr``  each ``#`` is one digit (Nuke, Blender)
``plate.@@@@.exr``   ``plate.0007.exr``  each ``@`` is one digit (Nuke, oiiotool)
``plate.%04d.exr``   ``plate.0007.exr``  printf: ``%0Nd`` pads to N digits, ``%d`` does not pad
``plate.#.exr``      ``plate.7.exr``     one ``#``: no padding
``plate.$F4.exr``    ``plate.0007.exr``  Houdini: ``$FN`` pads to N digits (fileseq reads it too)
===================  ==================  =============================================================

fileseq's own default reads ``#`` as *four* digits (as oiiotool does); vfxstereo parses with
``fileseq.PAD_STYLE_HASH1``, where ``####`` is four digits, so a pattern means the same in vfxstereo, Nuke
and Blender. Frames with more digits than the padding are written in full (``####`` with frame 12345 gives
``12345``). Negative frame numbers are not supported.

Frame ranges (:func:`parse_frames`): ``"1001-1100"``, ``"1001-1100x2"`` (every second frame),
``"1,5,10-12"``, or a single ``"1001"``; and fileseq's ``"1-10y3"`` (the frames ``1-10x3`` leaves out).
``"A-B:S"`` is refused: fileseq reads it as every frame of A-B in a staggered order, OpenJD (Deadline Cloud)
as every S-th frame, and a farm chunk read the wrong way would redo other chunks' frames.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from dataclasses import dataclass

import fileseq

from vfxstereo.errors import VfxStereoError

PAD_STYLE = fileseq.PAD_STYLE_HASH1
"""fileseq's padding style for our patterns: each ``#`` and each ``@`` is one digit."""

_TOKEN = re.compile(r"#+|@+|%0?\d*d|\$F\d*")
"""One frame token, as fileseq reads it (hash, at, printf and Houdini styles)."""

_RANGE_ITEM = re.compile(r"(?P<start>\d+)(?:-(?P<end>\d+)(?:(?P<mode>[xy])(?P<step>\d+))?)?")
"""One comma-separated item of a frame range, as we accept it: whole, non-negative frame numbers."""


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


def _sequence(pattern: str) -> fileseq.FileSequence | None:
    """The file name of ``pattern`` as fileseq reads it (not the folder: a ``#`` there is no token)."""
    try:
        return fileseq.FileSequence(os.path.basename(pattern), pad_style=PAD_STYLE)
    except fileseq.ParseException:
        return None


def is_pattern(s) -> bool:
    """True if the file name in ``s`` holds a frame token (``#``, ``@``, ``%0Nd`` or ``$FN``)."""
    s = os.fspath(s)
    seq = _sequence(s)
    # fileseq also reads a plain frame file ("a.0001.exr") as a sequence: a token must be written in the name
    return bool(seq is not None and _TOKEN.search(seq.padding()) and _TOKEN.search(os.path.basename(s)))


def parse_pattern(pattern) -> FramePattern:
    """Split a pattern at its frame token.

    Raises
    ------
    VfxStereoError
        If the file name holds no frame token, more than one, or a frame range (give that as ``--frames``).
    """
    pattern = os.fspath(pattern)
    folder, name = os.path.split(pattern)
    tokens = _TOKEN.findall(name)
    if len(tokens) > 1:
        raise VfxStereoError(f"{pattern!r} has {len(tokens)} frame tokens; use exactly one")
    seq = _sequence(pattern)
    if seq is None or not tokens or _TOKEN.fullmatch(seq.padding()) is None:
        raise VfxStereoError(f"{pattern!r} is not a frame pattern (use ####, @@@@ or %04d in the file name)")
    if seq.frameSet() is not None:
        raise VfxStereoError(f"{pattern!r} holds a frame range; give the range as --frames and the pattern "
                             f"without it")
    head = os.path.join(folder, seq.basename()) if folder else seq.basename()
    return FramePattern(head, fileseq.getPaddingNum(seq.padding(), pad_style=PAD_STYLE), seq.extension())


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


_RANGE_HELP = "use e.g. 1001-1100, 1001-1100x2 or 1,5,10-12"


def _check_item(item: str, spec: str) -> None:
    """Our rules on one item of a range, before fileseq expands it: the errors a user can act on."""
    m = _RANGE_ITEM.fullmatch(item)
    if m is not None:
        if m["end"] is not None and int(m["end"]) < int(m["start"]):
            raise VfxStereoError(f"bad frame range {spec!r}: {m['end']} comes before {m['start']}")
        if m["step"] is not None and int(m["step"]) < 1:
            raise VfxStereoError(f"bad frame range {spec!r}: the step must be at least 1")
        return
    if ":" in item:  # fileseq: staggered order (as a set, the whole range); OpenJD (Deadline Cloud): a step
        raise VfxStereoError(f"bad frame range {spec!r}: A-B:S means a step to some tools and every frame to "
                             f"others; write A-BxS for every S-th frame")
    if item.startswith("-") or "--" in item:
        raise VfxStereoError(f"negative frame numbers are not supported: {spec!r}")
    if re.fullmatch(r"\d+[xy]\d+", item):
        raise VfxStereoError(f"bad frame range {spec!r}: a step needs a range (A-BxS)")
    raise VfxStereoError(f"bad frame range {spec!r}: {item!r} is not a frame number or range ({_RANGE_HELP})")


def parse_frames(spec: str) -> list[int]:
    """Frame numbers of a range: ``"1001-1100"``, ``"1001-1100x2"``, ``"1,5,10-12"``, ``"1001"``.

    Returns
    -------
    list of int, sorted, without repeats. ``"A-BxS"`` runs from A to B (inclusive when it lands on B) in
    steps of S. fileseq expands the range; we only refuse what vfxstereo does not support.

    Raises
    ------
    VfxStereoError
        Empty or malformed ranges, an end before its start, a step below 1, negative or fractional frames.
    """
    text = str(spec).strip()
    if not text:
        raise VfxStereoError("empty frame range")
    for item in text.split(","):
        if not item.strip():
            raise VfxStereoError(f"bad frame range {spec!r}: empty item")
        _check_item(item.strip(), spec)
    try:
        frame_set = fileseq.FrameSet(",".join(item.strip() for item in text.split(",")))
    except (fileseq.ParseException, fileseq.MaxSizeException) as exc:
        raise VfxStereoError(f"bad frame range {spec!r}: {str(exc).splitlines()[0]}") from None
    return sorted({int(f) for f in frame_set})


def find_frames(pattern) -> list[int]:
    """Frame numbers of the files of ``pattern`` that exist on disk, sorted.

    A file belongs to the sequence when its number is written with exactly the pattern's padding
    (``####`` matches ``0007`` and ``12345``, not ``007`` or ``00007``).

    Raises
    ------
    VfxStereoError
        If ``pattern`` is not a pattern, or no file matches it.
    """
    pattern = os.fspath(pattern)
    p = parse_pattern(pattern)
    folder, prefix = os.path.split(p.head)
    folder = folder or "."
    try:
        names = set(os.listdir(folder))
    except OSError:
        raise VfxStereoError(f"no files match {pattern!r}: folder {folder!r} not found") from None
    # fileseq groups the folder's names into sequences (its findSequenceOnDisk would also read a # or @ in
    # the folder's name as padding); a frame is ours when the pattern writes exactly that name back
    local = FramePattern(prefix, p.padding, p.tail)
    found = {int(f) for seq in fileseq.findSequencesInList(sorted(names), pad_style=PAD_STYLE)
             if seq.basename() == prefix and seq.extension() == p.tail
             for f in (seq.frameSet() or ()) if int(f) >= 0 and local.path(int(f)) in names}
    if not found:
        raise VfxStereoError(f"no files match {pattern!r}")
    return sorted(found)


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


def frame_range(frames: Iterable[int]) -> str:
    """Frame numbers as a compact fileseq range (``[1001, 1002, 1003, 1007]`` -> ``"1001-1003,1007"``)."""
    return fileseq.framesToFrameRange(sorted(frames), sort=False)
