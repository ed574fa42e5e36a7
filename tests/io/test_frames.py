"""Frame patterns (#, @, %0Nd), frame ranges and finding sequences on disk."""

import os

import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.io import frames
from vfxstereo.io.frames import expand, find_frames, frame_path, is_pattern, parse_frames


@pytest.mark.parametrize(("pattern", "frame", "expected"), [
    ("plate.####.exr", 7, "plate.0007.exr"),
    ("plate.@@@@.exr", 7, "plate.0007.exr"),
    ("plate.%04d.exr", 7, "plate.0007.exr"),
    ("plate.#.exr", 7, "plate.7.exr"),
    ("plate.%d.exr", 1234, "plate.1234.exr"),
    ("plate.@@.exr", 7, "plate.07.exr"),
    ("plate.####.exr", 12345, "plate.12345.exr"),  # longer than the padding: written in full
    ("shot_v001/left_%06d.png", 1001, "shot_v001/left_001001.png"),
])
def test_frame_path(pattern, frame, expected):
    assert frame_path(pattern, frame) == expected


def test_is_pattern():
    assert is_pattern("a.####.exr") and is_pattern("a.%04d.exr") and is_pattern("a_@@@.png")
    assert is_pattern("a.%d.exr")
    assert not is_pattern("a.0001.exr")
    assert not is_pattern("shot#3/a.0001.exr")  # a # in a folder name is not a frame token
    assert not is_pattern("a.%s.exr")


def test_pattern_errors():
    with pytest.raises(VfxStereoError, match="not a frame pattern"):
        frame_path("a.0001.exr", 1)
    with pytest.raises(VfxStereoError, match="2 frame tokens"):
        frame_path("a.####.%04d.exr", 1)
    with pytest.raises(VfxStereoError, match="negative frame"):
        frame_path("a.####.exr", -1)


@pytest.mark.parametrize(("spec", "expected"), [
    ("1001-1005", [1001, 1002, 1003, 1004, 1005]),
    ("1001-1009x2", [1001, 1003, 1005, 1007, 1009]),
    ("1001-1010x3", [1001, 1004, 1007, 1010]),
    ("1001-1008x3", [1001, 1004, 1007]),
    ("1,5,10-12", [1, 5, 10, 11, 12]),
    (" 7 ", [7]),
    ("5,1,3-4,4", [1, 3, 4, 5]),  # sorted, no repeats
    ("0-2", [0, 1, 2]),
])
def test_parse_frames(spec, expected):
    assert parse_frames(spec) == expected


@pytest.mark.parametrize(("spec", "message"), [
    ("", "empty"),
    ("1,,3", "empty item"),
    ("10-5", "comes before"),
    ("1-10x0", "step must be at least 1"),
    ("5x2", "step needs a range"),
    ("a-b", "not a frame number"),
    ("-5", "negative"),
    ("-5-3", "negative"),
])
def test_parse_frames_errors(spec, message):
    with pytest.raises(VfxStereoError, match=message):
        parse_frames(spec)


def test_expand():
    assert expand("a.%03d.png", [1, 20]) == ["a.001.png", "a.020.png"]
    assert expand("a.@@@@.png", "1-5x2") == ["a.0001.png", "a.0003.png", "a.0005.png"]


@pytest.mark.parametrize("pattern", ["plate.####.exr", "plate.@@@@.exr", "plate.%04d.exr"])
def test_find_frames(tmp_path, pattern):
    for n in (1001, 1002, 1004, 12345):
        (tmp_path / f"plate.{n:04d}.exr").touch()
    # decoys: other padding, extension, prefix, not a number, a folder-looking name
    for name in ("plate.001.exr", "plate.01003.exr", "plate.1005.png", "plates.1006.exr", "plate.abcd.exr",
                 "plate.1007.exr.bak", "xplate.1008.exr"):
        (tmp_path / name).touch()
    full = os.path.join(str(tmp_path), pattern)
    found = find_frames(full)
    assert found == [1001, 1002, 1004, 12345]
    assert all(os.path.isfile(p) for p in expand(full, found))
    assert frames.existing(full, [1001, 1004]) == expand(full, [1001, 1004])
    with pytest.raises(VfxStereoError, match=r"frame file not found: .*plate.1003.exr"):
        frames.existing(full, "1001-1004")


def test_find_frames_unpadded(tmp_path):
    for n in (1, 2, 10):
        (tmp_path / f"f{n}.png").touch()
    (tmp_path / "f03.png").touch()  # padded: not written by a one-digit pattern
    assert find_frames(tmp_path / "f#.png") == [1, 2, 10]


def test_find_frames_nothing(tmp_path):
    (tmp_path / "plate.0001.exr").touch()
    with pytest.raises(VfxStereoError, match="no files match"):
        find_frames(tmp_path / "other.####.exr")
    with pytest.raises(VfxStereoError, match="no files match .*folder"):
        find_frames(tmp_path / "missing" / "plate.####.exr")
    with pytest.raises(VfxStereoError, match="not a frame pattern"):
        find_frames(tmp_path / "plate.0001.exr")


def test_hash_in_a_folder_name_is_not_a_token(tmp_path):
    folder = tmp_path / "shot#3"
    folder.mkdir()
    for n in (7, 8):
        (folder / f"a.{n:04d}.exr").touch()
    pattern = str(folder / "a.####.exr")
    assert is_pattern(pattern)
    assert frame_path(pattern, 7) == str(folder / "a.0007.exr")
    assert find_frames(pattern) == [7, 8]


def test_houdini_padding_reads_as_fileseq_does():
    assert frame_path("a.$F4.exr", 7) == "a.0007.exr"
    assert frame_path("a.$F.exr", 7) == "a.7.exr"


def test_a_range_inside_a_pattern_is_refused():
    assert is_pattern("a.1001-1010####.exr")
    with pytest.raises(VfxStereoError, match="--frames"):
        frame_path("a.1001-1010####.exr", 1001)


@pytest.mark.parametrize(("spec", "expected"), [
    ("1-10y3", [2, 3, 5, 6, 8, 9]),  # fileseq's "filled": the frames 1-10x3 leaves out
])
def test_parse_frames_takes_fileseq_forms(spec, expected):
    assert parse_frames(spec) == expected


@pytest.mark.parametrize(("spec", "message"), [
    ("1.5", "not a frame number"),
    ("1-10y0", "at least 1"),
    ("1-100000000", "MAX_FRAME_SIZE"),
    ("1-9:2", "write A-BxS"),  # fileseq: every frame, staggered; OpenJD: every second one
])
def test_parse_frames_refuses_what_we_do_not_support(spec, message):
    with pytest.raises(VfxStereoError, match=message):
        parse_frames(spec)


def test_frame_range_is_compact():
    assert frames.frame_range([1003, 1001, 1002, 1007]) == "1001-1003,1007"
    assert parse_frames(frames.frame_range([1, 3, 5, 6])) == [1, 3, 5, 6]
