"""Shared helpers of the benchmarks: Markdown tables, timing, image metrics, the output folder.

Benchmarks print tables and write figures; they do not gate CI. Everything they write goes to
``benchmarks/out/`` (git-ignored).
"""

from __future__ import annotations

import os
import platform
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
OUT = HERE / "out"
"""Where benchmarks write their figures (created on demand; git-ignored)."""

DATA = Path(os.environ.get("VFXSTEREO_DATA", HERE.parent.parent / "shared" / "data"))
"""The shared evaluation data (``$VFXSTEREO_DATA`` or ``../shared/data`` beside the repository)."""


def out_dir(sub: str | None = None) -> Path:
    """``benchmarks/out`` (or a sub-folder of it), created if missing."""
    path = OUT / sub if sub else OUT
    path.mkdir(parents=True, exist_ok=True)
    return path


# --------------------------------------------------------------------------------------------------------
# Tables


def _cell(v, digits: int) -> str:
    if v is None:
        return "--"
    if isinstance(v, bool | np.bool_):
        return "yes" if v else "no"
    if isinstance(v, int | np.integer):
        return str(int(v))
    if isinstance(v, float | np.floating):
        if not np.isfinite(v):
            return "--" if np.isnan(v) else ("inf" if v > 0 else "-inf")
        return f"{float(v):.{digits}f}"
    return str(v)


def markdown_table(headers: Sequence[str], rows: Sequence[Sequence], *, digits: int = 2,
                   align: str | None = None) -> str:
    """A GitHub-flavoured Markdown table.

    Parameters
    ----------
    headers : sequence of str
    rows : sequence of sequences
        Cells: str as is, int as is, float with ``digits`` decimals, None/NaN as ``--``.
    digits : int
        Decimals of float cells.
    align : str, optional
        One of ``l``, ``r``, ``c`` per column; default: text columns left, number columns right.
    """
    if align is None:
        align = "".join("l" if all(isinstance(r[i], str) or r[i] is None for r in rows) else "r"
                        for i in range(len(headers)))
    text = [[_cell(v, digits) for v in row] for row in rows]
    widths = [max([3, len(h)] + [len(r[i]) for r in text]) for i, h in enumerate(headers)]
    rule = {"l": lambda w: ":" + "-" * (w - 1), "r": lambda w: "-" * (w - 1) + ":",
            "c": lambda w: ":" + "-" * (w - 2) + ":"}

    def line(cells):
        out = []
        for c, w, a in zip(cells, widths, align, strict=True):
            out.append(c.ljust(w) if a == "l" else c.rjust(w) if a == "r" else c.center(w))
        return "| " + " | ".join(out) + " |"

    lines = [line(headers), "| " + " | ".join(rule[a](w) for w, a in zip(widths, align, strict=True)) + " |"]
    lines += [line(r) for r in text]
    return "\n".join(lines)


def section(title: str, body: str = "") -> str:
    """A Markdown heading followed by ``body``."""
    return f"\n## {title}\n\n{body}".rstrip() + "\n"


# --------------------------------------------------------------------------------------------------------
# Timing


def best_time(fn: Callable[[], object], *, repeat: int = 5, number: int = 1, min_time: float = 0.0) -> float:
    """Seconds per call of ``fn``: the best of ``repeat`` runs of ``number`` calls (after one warm-up).

    The minimum is the least disturbed by the other processes of a shared machine. With ``min_time`` the
    number of calls per run grows until a run lasts at least that long.
    """
    fn()  # warm-up: caches, numba compilation, page faults of first-touch allocations
    while True:
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        t = time.perf_counter() - t0
        if t >= min_time or number >= 1 << 20:
            break
        number *= 2
    best = t / number
    for _ in range(repeat - 1):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best


class Stopwatch:
    """``with Stopwatch() as sw: ...``; then ``sw.seconds``."""

    def __enter__(self) -> Stopwatch:
        self._t0 = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        self.seconds = time.perf_counter() - self._t0


def machine_line() -> str:
    """One line describing the machine and the numpy the numbers were measured with."""
    return (f"{platform.machine()} / {os.cpu_count()} cores / Python {sys.version.split()[0]} / "
            f"numpy {np.__version__}")


# --------------------------------------------------------------------------------------------------------
# Image metrics


def psnr(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None = None, *, peak: float = 1.0) -> float:
    """Peak signal-to-noise ratio in dB of ``a`` against ``b`` (all channels), over ``mask`` if given.

    ``10 log10(peak^2 / MSE)``; ``inf`` when the images agree exactly; NaN for an empty mask.
    """
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    err = (a - b) ** 2
    if err.ndim == 3:
        err = err.mean(axis=-1)
    if mask is not None:
        if not mask.any():
            return float("nan")
        err = err[mask]
    mse = float(err.mean())
    return float("inf") if mse == 0.0 else 10.0 * np.log10(peak * peak / mse)


def configured(preset: str, overrides: dict | None = None):
    """The preset with ``overrides`` applied: ``{"soft_edge": {"laplacian": 0.3}, "depth_config": {...}}``
    (a dict for a group of settings changes only the names it gives) or top-level settings."""
    import dataclasses

    from vfxstereo import SolveConfig

    def merged(current, value):
        if dataclasses.is_dataclass(current) and isinstance(value, dict):  # nested groups too (depth matching)
            return dataclasses.replace(current, **{k: merged(getattr(current, k, None), v) for k, v in value.items()})
        return value

    config = SolveConfig.preset(preset)
    for key, value in (overrides or {}).items():
        config = config.replace(**{key: merged(getattr(config, key, None), value)})
    return config
