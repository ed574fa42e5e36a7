"""Progress reporting: one callback signature shared by the solver, the CLI and the Blender add-on.

A progress callback is ``progress(stage, done, total)``: ``stage`` names what runs (``"sweep"``,
``"refine"``, ...), ``done`` of ``total`` steps of it are finished. The CLI turns it into a tqdm bar on
stderr, the Blender add-on into its status bar. ``None`` means no reporting.
"""

from __future__ import annotations

from collections.abc import Callable

Progress = Callable[[str, int, int], None]


def report(progress: Progress | None, stage: str, done: int, total: int) -> None:
    """Call ``progress`` if there is one."""
    if progress is not None:
        progress(stage, done, total)
