"""Run ``vfxstereo solve`` in a child process: live progress from its output, and a cancel that leaves nothing.

The Blender add-on solves plates without freezing Blender: it starts the ``vfxstereo`` command as a child
process and polls it from a timer. Nothing here imports bpy; :class:`SolveRun` is the whole mechanism and
the add-on only shows its :class:`Progress` and calls :meth:`SolveRun.cancel` on Esc.

Which command
    :meth:`SolverCommand.bundled` runs ``python -m vfxstereo.cli`` with the interpreter and package given
    (inside Blender: Blender's own Python and the vfxstereo the extension bundles);
    :meth:`SolverCommand.external` runs a ``vfxstereo`` executable installed elsewhere (a pipeline's
    environment), for dependencies an extension cannot bundle. Both take the same arguments.

Progress
    The command draws one tqdm bar per solver stage (``refine:  40%|####  | 40/100 [...]``) when its
    output is a terminal, so the child runs on a pseudo-terminal (POSIX: Linux and macOS); ``-v`` adds a
    line when each stage ends (``vfxstereo: refine: 100 steps in 9.1 s``).
    :class:`ProgressParser` reads both. The fraction it reports is an estimate: the solver's stages repeat
    and their number depends on the preset, so each stage's share (:data:`STAGE_SHARES`) was measured on the
    demo sample, and the fraction never goes backwards.

No partial files
    The child writes into a hidden folder beside the output (``.vfxstereo-solve-XXXX``); its files are moved
    into place (``os.replace``, atomic on one file system) only when the whole command has succeeded.
    Cancelling interrupts the child (SIGINT, then SIGKILL after a grace period) and removes that folder, so
    the output folder is left exactly as it was, however the child ended.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import os
import pty
import re
import shutil
import signal
import struct
import subprocess
import tempfile
import termios
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from vfxstereo.errors import VfxStereoError

STAGE_SHARES = {
    # the robust preset (the default)
    "match": (0.0, 0.55),
    "sgm": (0.55, 0.65),
    "layers": (0.65, 0.75),
    "soft-edges": (0.75, 1.0),
    # the paper's stages
    "sweep": (0.0, 0.10),
    "aggregate": (0.0, 0.10),
    "select": (0.0, 0.10),
    "visibility": (0.0, 0.10),
    "complete": (0.10, 0.12),
    "refine": (0.12, 0.92),
    "matting": (0.92, 0.98),
    "subpixel": (0.98, 1.0),
}
"""Share of a frame's time each solver stage spans, ``(start, end)`` in [0, 1] (the demo sample; with the paper
preset refinement is 80-95 % of a solve). Stages that repeat once per pass share one span. A stage not listed
keeps the fraction where it was."""

WORK_PREFIX = ".vfxstereo-solve-"
"""Name prefix of the hidden folder a run writes into before its outputs are moved into place."""

_ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
_FRAME = r"(?:frame (?P<frame>-?\d+) \((?P<index>\d+)/(?P<count>\d+)\) )?"
_BAR = re.compile(_FRAME + r"(?P<stage>[A-Za-z_][\w-]*): +\d+%\|.*?\| *(?P<done>\d+)/(?P<total>\d+)")
_STAGE_END = re.compile(r"vfxstereo: " + _FRAME + r"(?P<stage>[A-Za-z_][\w-]*): (?P<total>\d+) steps in ")
_FRAME_DONE = re.compile(r"vfxstereo: frame (?P<frame>-?\d+) done in ")
_ERROR = re.compile(r"vfxstereo: error: (?P<message>.*)")


# --------------------------------------------------------------------------------------------------------
# What to run


@dataclass(frozen=True)
class SolverCommand:
    """The program that solves: its argv before ``solve``, extra environment, and a label for reports.

    Attributes
    ----------
    argv : tuple of str
        ``(python, "-m", "vfxstereo.cli")`` or ``(path_to_vfxstereo,)``.
    env : dict
        Variables added to the child's environment.
    label : str
        Says which vfxstereo runs, for the user (``"the bundled vfxstereo 0.1.0 (python3.11)"``).
    """

    argv: tuple[str, ...]
    env: dict = field(default_factory=dict)
    label: str = ""

    @classmethod
    def bundled(cls, python: str, package_root: str, *, version: str = "", env: dict | None = None):
        """``python -m vfxstereo.cli`` with ``package_root`` (the folder holding ``vfxstereo/``) first on its path.

        Parameters
        ----------
        python : str
            The interpreter (inside Blender, ``sys.executable`` is Blender's own Python).
        package_root : str
            Folder that holds the ``vfxstereo`` package and the wheels it needs.
        version : str
            vfxstereo's version, for the label.
        env : dict, optional
            More variables for the child (e.g. ``NUMBA_CACHE_DIR``).
        """
        path = os.pathsep.join([str(package_root), *filter(None, [os.environ.get("PYTHONPATH")])])
        label = f"the bundled vfxstereo{' ' + version if version else ''} ({Path(python).name})"
        return cls((str(python), "-m", "vfxstereo.cli"), {"PYTHONPATH": path, **(env or {})}, label)

    @classmethod
    def external(cls, command: str, *, env: dict | None = None):
        """A ``vfxstereo`` executable: a path, or a name found on ``PATH``.

        Raises
        ------
        VfxStereoError
            If the command cannot be found or is not executable.
        """
        found = shutil.which(os.path.expanduser(str(command)))
        if not found:
            raise VfxStereoError(f"the vfxstereo command {command!r} was not found or is not executable")
        return cls((found,), dict(env or {}), f"the external command {found}")


@dataclass(frozen=True)
class SolveRequest:
    """The ``vfxstereo solve`` options the add-on offers (see ``vfxstereo solve --help``).

    Attributes
    ----------
    output : str
        The stack EXR, or a frame pattern (``stack.####.exr``) when the views are patterns.
    views : tuple of str
        View files or frame patterns, in baseline order; empty with ``dataset``.
    dataset : str or None
        A folder with a ``dataset.json`` (views, positions, reference).
    positions : tuple of float or None
        Camera positions in view steps; None: the command's default (0..K-1, or the dataset's).
    reference : int or None
        Index of the reference view; None: the command's default (the middle one).
    disparities : str or None
        ``MIN:MAX[:STEP]``; None: the command's default.
    preset : str or None
        A SolveConfig preset name; None: the command's own default.
    frames : str or None
        Frame range for patterns (``1001-1100``); None: the frames on disk.
    view_names : str or None
        ``left,right``: the views to read from one multi-view EXR (``--views``); None: all, in file order.
    """

    output: str
    views: tuple[str, ...] = ()
    dataset: str | None = None
    positions: tuple[float, ...] | None = None
    reference: int | None = None
    disparities: str | None = None
    preset: str | None = None
    frames: str | None = None
    view_names: str | None = None

    def arguments(self, output: str) -> list[str]:
        """The command-line arguments, writing to ``output`` instead of :attr:`output`."""
        if bool(self.views) == bool(self.dataset):
            raise VfxStereoError("give either view files or a dataset folder")
        args = ["solve", *self.views, "-o", str(output), "-v"]
        if self.dataset:
            args += ["--dataset", str(self.dataset)]
        if self.positions is not None:
            args += ["--positions", ",".join(f"{p:g}" for p in self.positions)]
        if self.reference is not None:
            args += ["--reference", str(int(self.reference))]
        for flag, value in (("--disparities", self.disparities), ("--preset", self.preset),
                            ("--frames", self.frames), ("--views", self.view_names)):
            if value:
                args += [flag, str(value)]
        return args


# --------------------------------------------------------------------------------------------------------
# Progress


@dataclass
class Progress:
    """Where a run is.

    Attributes
    ----------
    stage : str
        The solver stage running (``"refine"``), or ``""`` before the first.
    done, total : int
        Steps of that stage.
    frame_index, frame_count : int
        Which frame of how many (1-based; 1 of 1 for a single frame).
    fraction : float
        Estimated fraction of the whole run, in [0, 1], never decreasing.
    """

    stage: str = ""
    done: int = 0
    total: int = 0
    frame_index: int = 1
    frame_count: int = 1
    fraction: float = 0.0

    def text(self) -> str:
        """One line for a status bar: ``"refine 40/100, frame 2/10, 23%"``."""
        parts = [f"{self.stage} {self.done}/{self.total}" if self.stage else "starting"]
        if self.frame_count > 1:
            parts.append(f"frame {self.frame_index}/{self.frame_count}")
        parts.append(f"{self.fraction:.0%}")
        return ", ".join(parts)


class ProgressParser:
    """Reads the command's output as it arrives; keeps the :class:`Progress` and the last error line."""

    def __init__(self):
        self.progress = Progress()
        self.error: str | None = None
        self.last_line = ""
        self._pending = ""

    def feed(self, text: str) -> bool:
        """Take more output; True when the progress changed."""
        segments = re.split(r"[\r\n]", self._pending + _ANSI.sub("", text))
        self._pending = segments.pop()  # an unfinished segment waits for the rest
        changed = False
        for segment in segments:
            changed |= self._segment(segment.strip())
        return changed

    def _segment(self, s: str) -> bool:
        if not s:
            return False
        self.last_line = s
        if m := _ERROR.search(s):
            self.error = m.group("message").strip()
            return False
        m = _STAGE_END.search(s)  # "vfxstereo: refine: 100 steps in 9.1 s" may end a bar's line
        if m is None:
            m = _BAR.search(s)
        if m is None:
            if _FRAME_DONE.search(s):
                return self._update(self.progress.stage, 1, 1, None, None, frame_done=True)
            return False
        total = int(m.group("total"))
        done = int(m.groupdict().get("done") or total)
        index = int(m.group("index")) if m.group("index") else None
        count = int(m.group("count")) if m.group("count") else None
        return self._update(m.group("stage"), done, total, index, count)

    def _update(self, stage, done, total, index, count, *, frame_done=False) -> bool:
        p = self.progress
        if count:
            p.frame_index, p.frame_count = index, count
        if stage == "frames":  # the --jobs bar counts frames
            p.frame_count = max(total, 1)
            fraction = done / p.frame_count
        elif frame_done or stage in STAGE_SHARES:
            start, end = STAGE_SHARES.get(stage, (1.0, 1.0))
            within = 1.0 if frame_done else start + (end - start) * (done / total if total else 1.0)
            fraction = (p.frame_index - 1 + within) / p.frame_count
        else:
            fraction = p.fraction
        new = (stage, done, total, max(p.fraction, min(fraction, 1.0)))
        old = (p.stage, p.done, p.total, p.fraction)
        p.stage, p.done, p.total, p.fraction = new
        return new != old


# --------------------------------------------------------------------------------------------------------
# The run


class SolveRun:
    """One ``vfxstereo solve`` in a child process, writing into a hidden folder until it has succeeded.

    Parameters
    ----------
    command : SolverCommand
    request : SolveRequest

    Examples
    --------
    >>> command = SolverCommand.external("vfxstereo")  # doctest: +SKIP
    >>> run = SolveRun(command, SolveRequest("out/stack.exr", dataset="demo"))  # doctest: +SKIP
    >>> run.start()                          # doctest: +SKIP
    >>> while run.poll() is None: ...        # doctest: +SKIP  (a UI timer; run.progress.text())
    >>> outputs = run.finish()               # doctest: +SKIP  (or run.cancel() on Esc)
    """

    def __init__(self, command: SolverCommand, request: SolveRequest):
        self.command = command
        self.request = request
        self.parser = ProgressParser()
        self.returncode: int | None = None
        self._proc: subprocess.Popen | None = None
        self._fd: int | None = None
        self._work: Path | None = None

    @property
    def progress(self) -> Progress:
        """The latest :class:`Progress`."""
        return self.parser.progress

    @property
    def work_dir(self) -> Path | None:
        """The hidden folder the child writes into (None before :meth:`start` and after clean-up)."""
        return self._work

    def start(self) -> None:
        """Check the output folder, make the hidden work folder, and start the child.

        Raises
        ------
        VfxStereoError
            If the output folder does not exist or is not writable, or the command cannot be started.
        """
        out = Path(self.request.output)
        folder = out.resolve().parent
        if not folder.is_dir():
            raise VfxStereoError(f"the output folder does not exist: {folder}")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise VfxStereoError(f"the output folder is not writable: {folder}")
        self._work = Path(tempfile.mkdtemp(prefix=WORK_PREFIX, dir=folder))
        argv = [*self.command.argv, *self.request.arguments(str(self._work / out.name))]
        env = {**os.environ, **self.command.env, "PYTHONUNBUFFERED": "1"}
        try:
            self._proc, self._fd = _spawn(argv, env)
        except OSError as exc:
            self._remove_work()
            raise VfxStereoError(f"cannot start {self.command.label or argv[0]}: {exc.strerror or exc}") from None

    def poll(self) -> int | None:
        """Read the output that has arrived; the exit status once the child has ended and said all, else None."""
        if self._proc is None:
            return self.returncode
        eof = self._read()
        status = self._proc.poll()
        if status is not None and eof:
            self.returncode = status
            self._close()
        return self.returncode

    def wait(self, on_progress: Callable[[Progress], None] | None = None, *, interval: float = 0.1) -> int:
        """Poll until the child ends; ``on_progress(progress)`` on every change. Ctrl-C cancels the run."""
        seen = None
        try:
            while self.poll() is None:
                now = dataclasses.astuple(self.progress)
                if on_progress is not None and now != seen:
                    on_progress(self.progress)
                    seen = now
                time.sleep(interval)
        except KeyboardInterrupt:
            self.cancel()
            raise
        return self.returncode

    def finish(self) -> list[Path]:
        """After a successful exit, move the outputs into place and return their paths.

        Raises
        ------
        VfxStereoError
            With the command's own one-line message when it failed (the work folder is removed either way).
        """
        if self.returncode is None:
            raise VfxStereoError("the solve has not finished yet")
        try:
            if self.returncode != 0:
                why = self.parser.error or (
                    "interrupted" if self.returncode in (130, -signal.SIGINT) else
                    f"exit status {self.returncode}: {self.parser.last_line or 'no output'}")
                raise VfxStereoError(f"{self.command.label or 'vfxstereo'} failed: {why}")
            folder = Path(self.request.output).resolve().parent
            moved = []
            for f in sorted(self._work.iterdir()):
                if f.is_file() and not f.name.startswith("."):
                    os.replace(f, folder / f.name)
                    moved.append(folder / f.name)
            if not moved:
                raise VfxStereoError(f"{self.command.label or 'vfxstereo'} wrote nothing: "
                                     f"{self.parser.last_line or 'no output'}")
            return moved
        finally:
            self._remove_work()

    def cancel(self, *, grace: float = 10.0) -> None:
        """Stop the child (SIGINT, then SIGKILL after ``grace`` seconds) and remove everything it wrote."""
        if self._proc is not None and self._proc.poll() is None:
            _signal(self._proc, signal.SIGINT)
            deadline = time.monotonic() + grace
            while self._proc.poll() is None and time.monotonic() < deadline:
                self._read()
                time.sleep(0.05)
            if self._proc.poll() is None:
                _signal(self._proc, signal.SIGKILL)
                self._proc.wait()
        if self._proc is not None:
            self.returncode = self._proc.returncode
            self._close()
        self._remove_work()

    # ---------------------------------------------------------------------------------------------------
    def _read(self) -> bool:
        """Feed what the child has written; True at end of output."""
        while True:
            try:
                data = os.read(self._fd, 65536)
            except BlockingIOError:
                return False
            except OSError:  # EIO: a pseudo-terminal whose child side is closed
                return True
            if not data:
                return True
            self.parser.feed(data.decode("utf-8", errors="replace"))

    def _close(self) -> None:
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
        self._fd = None
        self._proc = None

    def _remove_work(self) -> None:
        if self._work is not None:
            shutil.rmtree(self._work, ignore_errors=True)
        self._work = None


def _spawn(argv: list[str], env: dict) -> tuple[subprocess.Popen, int]:
    """Start ``argv`` in a session of its own (so a signal reaches its workers too), output on a pseudo-terminal.

    POSIX only (Linux, macOS): the extension ships Linux wheels, and an external command runs the same way.
    """
    parent, child = pty.openpty()
    fcntl.ioctl(child, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 160, 0, 0))  # tqdm sizes its bar by it
    try:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=child, stderr=child, env=env,
                                start_new_session=True)
    except OSError:
        os.close(parent)
        raise
    finally:
        os.close(child)
    os.set_blocking(parent, False)
    return proc, parent


def _signal(proc: subprocess.Popen, sig: int) -> None:
    """Send ``sig`` to the child's process group, which holds its worker processes too."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, sig)
