"""Atomic file output: write to a temporary name in the target's folder, rename into place on success.

Every writer of the project goes through :func:`atomic_output`, so an interrupted or failed write never
leaves half a file under the real name and never clobbers a good file that was already there::

    with atomic_output("out/stack.0001.exr") as tmp:   # tmp: out/.stack.0001.tmp-k3j9x2.exr
        write_something(tmp)                          # any exception: tmp is removed, target untouched
    # here out/stack.0001.exr is complete (os.replace is atomic within one file system)

The temporary name keeps the real extension at its end, because OpenImageIO chooses the file format from
the extension; it starts with a dot so file browsers and frame-sequence scanners hide it.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from vfxstereo.errors import VfxStereoError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_output(path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; move it onto ``path`` when the block succeeds.

    Parameters
    ----------
    path : str or Path
        The file to create or replace.

    Yields
    ------
    Path
        ``<folder>/.<stem>.tmp-XXXXXXXX<suffix>``, already created (empty) so the name is reserved; write
        the output there (OpenImageIO overwrites it).

    Raises
    ------
    VfxStereoError
        If the folder does not exist or cannot be written, or the result cannot be renamed into place.
        Any exception raised inside the block (KeyboardInterrupt included) removes the temporary file,
        leaves an existing ``path`` untouched and propagates unchanged.

    Notes
    -----
    The final file gets the usual permissions (``0o666`` less the umask), not the private ``0o600`` of
    :func:`tempfile.mkstemp`.
    """
    path = Path(path)
    folder = path.parent
    if path.name in ("", ".", ".."):
        raise VfxStereoError(f"cannot write {path}: not a file name")
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise VfxStereoError(f"cannot write {path}: the folder {folder} {what}")
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{path.stem}.tmp-", suffix=path.suffix, dir=folder)
    except OSError as exc:
        raise VfxStereoError(
            f"cannot write {path}: the folder {folder} is not writable ({exc.strerror})") from None
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except OSError as exc:
        _remove(tmp)
        raise VfxStereoError(f"cannot write {path}: {exc.strerror or exc}") from None
    except BaseException:
        _remove(tmp)
        raise


def _remove(tmp: Path) -> None:
    with contextlib.suppress(OSError):
        tmp.unlink()
