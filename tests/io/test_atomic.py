"""atomic_output: temp file beside the target, rename on success, clean up on any failure."""

import os
import stat

import pytest

from vfxstereo.errors import VfxStereoError
from vfxstereo.io import atomic
from vfxstereo.io.atomic import atomic_output


def _listing(folder):
    return sorted(p.name for p in folder.iterdir())


def test_success_renames_temp_into_place(tmp_path):
    target = tmp_path / "stack.0001.exr"
    with atomic_output(target) as tmp:
        assert tmp.parent == tmp_path
        assert tmp.name.startswith(".stack.0001.tmp-") and tmp.name.endswith(".exr")
        assert tmp.exists() and not target.exists()
        tmp.write_bytes(b"complete")
    assert target.read_bytes() == b"complete"
    assert _listing(tmp_path) == ["stack.0001.exr"]


def test_success_replaces_existing_file_and_uses_umask_permissions(tmp_path):
    target = tmp_path / "out.png"
    target.write_bytes(b"old")
    with atomic_output(str(target)) as tmp:
        tmp.write_bytes(b"new")
    assert target.read_bytes() == b"new"
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~mask


@pytest.mark.parametrize("exc_type", [RuntimeError, KeyboardInterrupt, VfxStereoError])
def test_failure_keeps_target_and_removes_temp(tmp_path, exc_type):
    target = tmp_path / "comp.exr"
    target.write_bytes(b"good old file")
    with pytest.raises(exc_type), atomic_output(target) as tmp:
        tmp.write_bytes(b"half a fi")
        raise exc_type("writer died")
    assert target.read_bytes() == b"good old file"
    assert _listing(tmp_path) == ["comp.exr"]


def test_failure_without_existing_target_leaves_nothing(tmp_path):
    with pytest.raises(ValueError), atomic_output(tmp_path / "new.exr") as tmp:
        tmp.write_bytes(b"x")
        raise ValueError("boom")
    assert _listing(tmp_path) == []


def test_missing_folder_is_a_one_line_error_naming_it(tmp_path):
    folder = tmp_path / "no" / "such"
    with pytest.raises(VfxStereoError, match="does not exist") as info, atomic_output(folder / "a.exr"):
        pass
    assert str(folder) in str(info.value) and "\n" not in str(info.value)


def test_parent_that_is_a_file_is_an_error(tmp_path):
    (tmp_path / "file").write_bytes(b"")
    with pytest.raises(VfxStereoError, match="is not a folder"), atomic_output(tmp_path / "file" / "a.exr"):
        pass


def test_unwritable_folder_is_a_one_line_error(tmp_path, monkeypatch):
    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(atomic.tempfile, "mkstemp", refuse)
    with pytest.raises(VfxStereoError, match="not writable") as info, atomic_output(tmp_path / "a.exr"):
        pass
    assert str(tmp_path) in str(info.value)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes anywhere")
def test_read_only_folder_for_real(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        with pytest.raises(VfxStereoError, match="not writable"), atomic_output(folder / "a.exr"):
            pass
    finally:
        folder.chmod(0o755)


def test_rename_failure_is_reported_and_cleaned_up(tmp_path):
    target = tmp_path / "taken"
    target.mkdir()
    (target / "inside").write_bytes(b"")  # a non-empty folder cannot be replaced by a file
    with pytest.raises(VfxStereoError, match="cannot write"), atomic_output(target) as tmp:
        tmp.write_bytes(b"data")
    assert _listing(tmp_path) == ["taken"]
