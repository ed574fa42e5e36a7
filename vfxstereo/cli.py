"""The ``vfxstereo`` command line: solve, zkey, render, split, info -- on single frames or frame sequences.

Every command accepts frame patterns (``plate_left.####.exr``, ``plate.%04d.exr``, ``plate.@@@@.exr``) for
its inputs and outputs; with patterns it runs once per frame of ``--frames`` (default: the frames found on
disk for the first input pattern). Frames whose outputs all exist are skipped unless ``--overwrite``, so a shot that was
interrupted resumes where it stopped; ``--jobs N`` runs frames in parallel processes.

Errors the user can cause end in one line on stderr and exit status 2; outputs are written atomically, so a
failure or Ctrl-C never leaves half a file and never clobbers an existing one.
"""

from __future__ import annotations

import argparse
import functools
import json
import logging
import multiprocessing
import os
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vfxstereo.errors import VfxStereoError

log = logging.getLogger("vfxstereo")

PICTURE_EXTENSIONS = {".png", ".jpg", ".jpeg", ".tif", ".tiff"}


# --------------------------------------------------------------------------------------------------------
# Progress and logging


class ProgressBars:
    """A progress callback (``stage, done, total``) shown as one tqdm bar per stage on stderr.

    On a terminal each stage gets a bar; when stderr is not a terminal (logs, CI) each finished stage is one
    log line with its time instead, so logs stay readable.
    """

    def __init__(self, *, enabled: bool = True, prefix: str = ""):
        self.enabled = enabled
        self.prefix = prefix
        self.tty = sys.stderr.isatty()
        self._bar = None
        self._stage = None
        self._t0 = time.perf_counter()

    def __call__(self, stage: str, done: int, total: int) -> None:
        """Show that ``done`` of ``total`` steps of ``stage`` are finished."""
        if not self.enabled or stage == "passes":
            return
        if stage != self._stage:
            self.close()
            self._stage = stage
            self._t0 = time.perf_counter()
            if self.tty:
                from tqdm import tqdm

                self._bar = tqdm(total=total, desc=f"{self.prefix}{stage}", file=sys.stderr, leave=False,
                                 dynamic_ncols=True, mininterval=0.2)
        if self._bar is not None:
            self._bar.n = done
            self._bar.refresh()
        if done >= total:
            log.debug("%s%s: %d steps in %.2f s", self.prefix, stage, total, time.perf_counter() - self._t0)
            self.close()

    def close(self) -> None:
        """Close the bar of the current stage."""
        if self._bar is not None:
            self._bar.close()
        self._bar = None
        self._stage = None


class _OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line on stderr and exit status 2."""

    def error(self, message: str):  # noqa: D102
        self.exit(2, f"{self.prog}: error: {message}\n")


# --------------------------------------------------------------------------------------------------------
# Checks shared by the commands


def check_input(path: str, what: str = "input") -> Path:
    """An existing, readable file, or VfxStereoError."""
    p = Path(path)
    if not p.is_file():
        raise VfxStereoError(f"{what} not found: {path}")
    if not os.access(p, os.R_OK):
        raise VfxStereoError(f"{what} is not readable: {path}")
    return p


def check_output(path: str | None) -> None:
    """The folder of ``path`` must exist and be writable (checked before any work is done)."""
    if not path:
        return
    folder = Path(path).resolve().parent
    if not folder.is_dir():
        raise VfxStereoError(f"output folder does not exist: {folder}")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise VfxStereoError(f"output folder is not writable: {folder}")
    if Path(path).is_dir():
        raise VfxStereoError(f"output is a folder, not a file: {path}")


def parse_disparities(text: str) -> np.ndarray:
    """``MIN:MAX[:STEP]`` (inclusive) to an increasing array of disparities."""
    parts = text.split(":")
    try:
        values = [float(x) for x in parts]
    except ValueError:
        raise VfxStereoError(f"--disparities must be MIN:MAX[:STEP] numbers, got {text!r}") from None
    if len(values) not in (2, 3):
        raise VfxStereoError(f"--disparities must be MIN:MAX[:STEP], got {text!r}")
    lo, hi = values[:2]
    step = values[2] if len(values) == 3 else 1.0
    if not all(np.isfinite(values)):
        raise VfxStereoError(f"--disparities must be finite numbers, got {text!r}")
    if lo >= hi:
        raise VfxStereoError(f"--disparities MIN must be below MAX, got {lo:g}:{hi:g}")
    if step <= 0:
        raise VfxStereoError(f"--disparities STEP must be positive, got {step:g}")
    n = int(np.floor((hi - lo) / step + 1e-9)) + 1
    if n < 2:
        raise VfxStereoError(f"--disparities {text} gives fewer than two planes")
    if n > 100_000:
        raise VfxStereoError(f"--disparities {text} gives {n} planes; that cannot be right")
    return lo + step * np.arange(n)


def default_disparities(width: int) -> np.ndarray:
    """The default range: 0 to 5 % of the image width per view step, in whole pixels."""
    return np.arange(0, max(2, int(np.ceil(width * 0.05))) + 1, dtype=np.float64)


def parse_float_list(text: str, what: str) -> list[float]:
    """``"0,1.5,3"`` to numbers; ``what`` names the option in the error."""
    try:
        return [float(x) for x in text.split(",") if x.strip() != ""]
    except ValueError:
        raise VfxStereoError(f"{what} must be comma-separated numbers, got {text!r}") from None


# --------------------------------------------------------------------------------------------------------
# Frame sequences


@dataclass
class Job:
    """One command on one frame: concrete input and output paths."""

    frame: int | None
    inputs: dict[str, str | list[str] | None]
    outputs: dict[str, str | None]


def _substitute(value, frame):
    from vfxstereo.io import frames

    if value is None:
        return None
    if isinstance(value, list):
        return [_substitute(v, frame) for v in value]
    return frames.frame_path(value, frame) if frames.is_pattern(value) else value


def plan_jobs(args, inputs: dict, outputs: dict) -> list[Job]:
    """Expand patterns into per-frame jobs; skip frames whose outputs all exist unless ``--overwrite``."""
    from vfxstereo.io import frames

    flat_inputs = [v for val in inputs.values() if val is not None
                   for v in (val if isinstance(val, list) else [val])]
    patterns = [v for v in flat_inputs if frames.is_pattern(v)]
    for out in outputs.values():
        check_output(out if out is None or not frames.is_pattern(out) else frames.frame_path(out, 0))
    if not patterns:
        if any(o and frames.is_pattern(o) for o in outputs.values()):
            raise VfxStereoError("an output is a frame pattern but no input is")
        for val in flat_inputs:
            check_input(val)
        return [Job(None, inputs, outputs)]
    for name, out in outputs.items():
        if out is not None and not frames.is_pattern(out):
            raise VfxStereoError(f"inputs are frame patterns, so the output {name} must be one too: {out}")
    if getattr(args, "frames", None):
        frame_list = frames.parse_frames(args.frames)
    else:
        frame_list = frames.find_frames(patterns[0])
        if not frame_list:
            raise VfxStereoError(f"frame pattern matches no files: {patterns[0]}")
    for pattern in patterns:
        missing = [f for f in frame_list if not Path(frames.frame_path(pattern, f)).is_file()]
        if len(missing) == len(frame_list):
            raise VfxStereoError(f"frame pattern matches no files in the frame range: {pattern}")
        if missing:
            raise VfxStereoError(f"frame {missing[0]} of {pattern} is missing ({len(missing)} missing in all)")
    jobs = []
    for f in frame_list:
        outs = {k: _substitute(v, f) for k, v in outputs.items()}
        done = all(Path(o).exists() for o in outs.values() if o)
        if done and not args.overwrite:
            log.info("frame %d: outputs exist, skipped (use --overwrite to redo)", f)
            continue
        jobs.append(Job(f, {k: _substitute(v, f) for k, v in inputs.items()}, outs))
    return jobs


def run_jobs(args, jobs: list[Job], work: Callable[[Job, object], None]) -> int:
    """Run ``work(job, progress)`` for every job, in parallel processes with ``--jobs N``."""
    if not jobs:
        log.info("nothing to do: every frame is finished")
        return 0
    quiet = getattr(args, "quiet", False)
    sequence = jobs[0].frame is not None
    n_jobs = max(1, int(getattr(args, "jobs", 1) or 1))
    if n_jobs > 1 and len(jobs) > 1:
        from tqdm import tqdm

        bar = tqdm(total=len(jobs), desc="frames", file=sys.stderr, disable=quiet, dynamic_ncols=True)
        # spawn, not fork: forking a process whose OpenImageIO/OpenMP threads hold locks can deadlock the child
        with ProcessPoolExecutor(max_workers=n_jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = {pool.submit(_work_in_child, work, job): job for job in jobs}
            try:
                for fut in as_completed(futures):
                    job = futures[fut]
                    seconds = fut.result()
                    log.info("frame %s done in %.1f s", job.frame, seconds)
                    bar.update(1)
            except BaseException:
                for fut in futures:
                    fut.cancel()
                raise
            finally:
                bar.close()
        return 0
    for i, job in enumerate(jobs):
        prefix = f"frame {job.frame} ({i + 1}/{len(jobs)}) " if sequence else ""
        bars = ProgressBars(enabled=not quiet, prefix=prefix)
        t0 = time.perf_counter()
        try:
            work(job, bars)
        finally:
            bars.close()
        if sequence:
            log.info("frame %d done in %.1f s", job.frame, time.perf_counter() - t0)
    return 0


def _work_in_child(work, job) -> float:
    t0 = time.perf_counter()
    work(job, None)
    return time.perf_counter() - t0


# --------------------------------------------------------------------------------------------------------
# Output helpers


def write_picture(path: str, pixels: np.ndarray, *, metadata: dict | None = None) -> None:
    """EXR stays scene-linear; PNG/JPEG/TIFF are written display-encoded (sRGB, unpremultiplied over nothing)."""
    ext = Path(path).suffix.lower()
    if ext in PICTURE_EXTENSIONS:
        from vfxstereo.io import preview

        preview.write_png(path, pixels)
    else:
        from vfxstereo.io import exr

        exr.write_image(path, pixels, metadata=metadata)


# --------------------------------------------------------------------------------------------------------
# Commands


def _solve_frame(args, job: Job, progress) -> None:
    """``solve`` on one frame (module level, so that --jobs can send it to other processes)."""
    from vfxstereo import solver
    from vfxstereo.config import SolveConfig
    from vfxstereo.io import exr, plates, preview

    config = SolveConfig.preset(args.preset)
    view_set = plates.read_view_set(job.inputs["views"], views=args._view_names, colorspace=args.input_colorspace)
    views = view_set.pixels
    k, h, w = views.shape[:3]
    positions = args._positions if args._positions is not None else list(range(k))
    if len(positions) != k:
        raise VfxStereoError(f"{k} views need {k} positions, --positions gave {len(positions)}")
    disparities = args._disparities if args._disparities is not None else default_disparities(w)
    camera = args._camera
    result = solver.solve(views, positions=positions, reference=args._reference, disparities=disparities,
                          config=config, progress=progress, camera=camera, return_details=True)
    stack = result.stack
    stack.metadata.update(view_set.metadata(reference=stack.camera.reference_index))
    stack.metadata.update({"colorspace_in": args.input_colorspace or "default", "frame": job.frame})
    exr.write_stack(job.outputs["stack"], stack)
    if job.outputs.get("disparity"):
        exr.write_disparity(job.outputs["disparity"], result.disparity,
                            metadata={"vfxstereo/what": "sub-pixel disparity of the reference camera"})
    if job.outputs.get("deep"):
        exr.write_deep(job.outputs["deep"], stack)
    if args.previews:
        folder = Path(args.previews)
        stem = Path(job.outputs["stack"]).stem
        preview.write_png(str(folder / f"{stem}_layers.png"), preview.contact_sheet(stack))
        preview.write_png(str(folder / f"{stem}_disparity.png"), preview.disparity_preview(result.disparity))
        preview.write_png(str(folder / f"{stem}_flat.png"), stack.flatten())


def cmd_solve(args) -> int:
    """``vfxstereo solve``: views to a layer stack (and disparity, deep, previews)."""
    from vfxstereo.geometry import Camera
    from vfxstereo.io import plates

    views = list(args.views)
    args._view_names = _parse_view_names(args.view_names)
    args._positions = parse_float_list(args.positions, "--positions") if args.positions else None
    args._reference = args.reference
    args._disparities = parse_disparities(args.disparities) if args.disparities else None
    args._camera = None
    if args.dataset:
        ds = plates.load_dataset(args.dataset)
        if views:
            raise VfxStereoError("give either VIEW files or --dataset, not both")
        views = [str(v) for v in ds.views]
        if args._positions is None:
            args._positions = list(ds.positions)
        if args._reference is None:
            args._reference = int(ds.reference)
    if args.cameras:
        args._camera = _load_cameras(args.cameras)
    if not views:
        raise VfxStereoError("solve needs at least two views (files), or one multi-view EXR")
    if args._view_names is not None and len(views) != 1:
        raise VfxStereoError(f"--views picks views inside one multi-view EXR (or one frame pattern of them), "
                             f"but {len(views)} inputs were given")
    if args.previews:
        Path(args.previews).mkdir(parents=True, exist_ok=True)
        check_output(str(Path(args.previews) / "x.png"))
    _ = Camera  # camera model import kept local to the command
    jobs = plan_jobs(args, {"views": views},
                     {"stack": args.output, "disparity": args.disparity_out, "deep": args.deep_out})
    _check_solve_inputs(jobs, args)
    return run_jobs(args, jobs, functools.partial(_solve_frame, args))


def _parse_view_names(text: str | None) -> list[str] | None:
    """``--views left,right`` to names (None when not given)."""
    if text is None:
        return None
    names = [v.strip() for v in text.split(",")]
    if not all(names):
        raise VfxStereoError(f"--views must be comma-separated view names, got {text!r}")
    return names


def _check_solve_inputs(jobs: list[Job], args) -> None:
    """Before any work: the first frame's views, from their headers, against positions, cameras, memory."""
    if not jobs:
        return
    from vfxstereo import solver
    from vfxstereo.io import plates

    first = jobs[0].inputs["views"]
    if len(first) == 1:  # one multi-view EXR per frame
        layout = plates.describe_plate(first[0])
        if not layout.views and args._view_names is None:
            raise VfxStereoError(f"solve needs at least two views: {first[0]} is one image, not a multi-view "
                                 "EXR (no multiView header and no part with a view attribute)")
        names = layout.select(args._view_names)
        k, (h, w) = len(names), layout.view_size(names[0])
    else:
        k, (h, w) = len(first), plates.image_size(first[0])
    if args._positions is not None and len(args._positions) != k:
        raise VfxStereoError(f"{k} views need {k} positions, --positions gave {len(args._positions)}")
    if args._camera is not None and args._camera.K != k:
        raise VfxStereoError(f"--cameras describes {args._camera.K} cameras for {k} views")
    d = len(args._disparities) if args._disparities is not None else len(default_disparities(w))
    solver.check_memory((h, w), d, k)


def _load_cameras(path: str):
    from vfxstereo.geometry import Camera

    check_input(path, "camera file")
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError) as exc:
        raise VfxStereoError(f"camera file is not valid JSON: {path}: {exc}") from None
    if "matrices" in data and "positions" not in data:
        data = dict(data, positions=[[float(i), 0.0] for i in range(len(data["matrices"]))],
                    reference=data.get("reference", [0.0, 0.0]))
    return Camera.from_dict(data)


def _read_stack(path: str):
    from vfxstereo.io import exr

    check_input(path, "stack")
    return exr.read_stack(path)


def _zkey_frame(args, job: Job, progress) -> None:
    """``zkey`` on one frame."""
    from vfxstereo import composite
    from vfxstereo.io import plates

    stack = _read_stack(job.inputs["stack"])
    element, z = plates.read_element(job.inputs["element"], colorspace=args.input_colorspace)
    if element.shape[:2] != stack.shape[1:]:
        raise VfxStereoError(f"element is {element.shape[1]}x{element.shape[0]} but the stack is "
                             f"{stack.shape[2]}x{stack.shape[1]}: {job.inputs['element']}")
    if job.inputs.get("depth"):
        depth_pixels, _, _ = _read_image(job.inputs["depth"])
        z = depth_pixels[..., 0]
    if args.disparity is not None:
        d_split = args.disparity
        comp = composite.insert(stack, element, disparity=d_split, into=args.into)
    else:
        if z is None:
            raise VfxStereoError("the element has no Z channel: give --disparity D or --element-depth FILE")
        if z.shape != stack.shape[1:]:
            raise VfxStereoError(f"the element depth is {z.shape[1]}x{z.shape[0]} but the stack is "
                                 f"{stack.shape[2]}x{stack.shape[1]}")
        d_split = None
        comp = composite.insert(stack, element, depth=z, into=args.into)
    write_picture(job.outputs["comp"], comp)
    if d_split is None:
        return
    if job.outputs.get("holdout"):
        write_picture(job.outputs["holdout"], composite.holdout(stack, d_split)[..., None])
    if job.outputs.get("front") or job.outputs.get("back"):
        front, back = composite.split(stack, d_split)
        if job.outputs.get("front"):
            write_picture(job.outputs["front"], front)
        if job.outputs.get("back"):
            write_picture(job.outputs["back"], back)


def _read_image(path: str):
    from vfxstereo.io import exr

    check_input(path, "image")
    return exr.read_image(path)


def cmd_zkey(args) -> int:
    """``vfxstereo zkey``: a CG element between the layers of a stack."""
    if args.disparity is not None and args.element_depth is not None:
        raise VfxStereoError("give --disparity or --element-depth, not both")
    if args.disparity is None and any((args.holdout_out, args.front_out, args.back_out)):
        raise VfxStereoError("--holdout-out, --front-out and --back-out need --disparity")
    jobs = plan_jobs(args, {"stack": args.stack, "element": args.element, "depth": args.element_depth},
                     {"comp": args.output, "holdout": args.holdout_out, "front": args.front_out,
                      "back": args.back_out})
    return run_jobs(args, jobs, functools.partial(_zkey_frame, args))


def _render_frame(args, job: Job, progress) -> None:
    """``render`` on one frame."""
    from vfxstereo import composite

    stack = _read_stack(job.inputs["stack"])
    position = args._position if len(args._position) == 2 else args._position[0]
    write_picture(job.outputs["view"], composite.render_view(stack, position))


def cmd_render(args) -> int:
    """``vfxstereo render``: a novel view of a stack."""
    args._position = parse_float_list(args.position, "--position")
    if len(args._position) not in (1, 2):
        raise VfxStereoError("--position takes one number or X,Y")
    jobs = plan_jobs(args, {"stack": args.stack}, {"view": args.output})
    return run_jobs(args, jobs, functools.partial(_render_frame, args))


def _split_frame(args, job: Job, progress) -> None:
    """``split`` on one frame."""
    from vfxstereo import composite

    stack = _read_stack(job.inputs["stack"])
    front, back = composite.split(stack, args.disparity)
    if job.outputs.get("front"):
        write_picture(job.outputs["front"], front)
    if job.outputs.get("back"):
        write_picture(job.outputs["back"], back)
    if job.outputs.get("holdout"):
        write_picture(job.outputs["holdout"], composite.holdout(stack, args.disparity)[..., None])


def cmd_split(args) -> int:
    """``vfxstereo split``: the flattened layers in front of and behind a disparity."""
    if not (args.front_out or args.back_out or args.holdout_out):
        raise VfxStereoError("split needs --front-out, --back-out or --holdout-out")
    jobs = plan_jobs(args, {"stack": args.stack},
                     {"front": args.front_out, "back": args.back_out, "holdout": args.holdout_out})
    return run_jobs(args, jobs, functools.partial(_split_frame, args))


def stack_info(stack, path: str | None = None, attributes: dict | None = None) -> dict:
    """What ``vfxstereo info`` prints for a stack file, as a plain dict (``attributes``: its header's)."""
    from vfxstereo.io import exr

    cov = stack.alpha_coverage()
    d, h, w = stack.shape
    return {
        "kind": "layerstack",
        "file": path,
        "width": w,
        "height": h,
        "layers": [{"index": i, "disparity": float(stack.disparities[i]), "coverage": float(cov[i])}
                   for i in range(d)],
        "camera": stack.camera.to_dict() if stack.camera is not None else None,
        "white": stack.white,
        "plate": stack.plate is not None,
        "metadata": stack.metadata,
        "exr": exr.pipeline_attributes(attributes or {}),
    }


DEEP_STATE_NOTE = ("samples tidy (sorted nearest first, non-overlapping), stated in vfxstereo/deepImageState; "
                   "OpenEXR's typed deepImageState is left out because OpenEXR's Python module refuses files "
                   "that carry it")
"""How ``vfxstereo info`` states the deep files' guarantee."""


def cmd_info(args) -> int:
    """``vfxstereo info``: what a stack, deep or plate file holds, as text or JSON."""
    from vfxstereo.io import exr

    path = args.file
    check_input(path, "file")
    kind = exr.file_kind(path)
    if kind == "layerstack":
        stack = _read_stack(path)
        info = stack_info(stack, path, exr.read_attributes(path))
        lines = _stack_lines(stack, info)
    elif kind == "deep":
        info = {"kind": "deep", "file": path, **exr.read_deep_header(path)}
        if info["samples"] == "tidy":
            info["samples_note"] = DEEP_STATE_NOTE
        lines = _deep_lines(info)
    else:
        from vfxstereo.io import plates

        layout = plates.describe_plate(path)
        info = {"kind": "plate", **layout.to_dict(), "exr": exr.pipeline_attributes(layout.attributes)}
        lines = _plate_lines(info)
    if args.json:
        print(json.dumps(info, indent=2, default=str))
    else:
        print("\n".join(lines + _exr_lines(info["exr"])))
    return 0


def _stack_lines(stack, info: dict) -> list[str]:
    path = info["file"]
    lines = [f"{path}: {info['width']}x{info['height']}, {len(info['layers'])} layers, "
             f"disparities {stack.disparities[0]:g}..{stack.disparities[-1]:g}, "
             + ("with the plate (zkey composes into it)" if info["plate"]
                else "no plate (zkey composes into the layers)"),
             "  layer  disparity  coverage"]
    for layer in info["layers"]:
        bar = "#" * int(round(layer["coverage"] * 40))
        lines.append(f"  {layer['index']:5d}  {layer['disparity']:9.3f}  {layer['coverage']:8.4f}  {bar}")
    cam = stack.camera
    if cam is not None:
        pos = ", ".join(f"{p[0]:g}" if p[1] == 0 else f"({p[0]:g},{p[1]:g})" for p in cam.positions)
        lines.append(f"  camera: views at [{pos}], reference {cam.reference_index} at {cam.reference[0]:g}"
                     + (f", focal {cam.focal:g} px, baseline {cam.baseline:g}" if cam.focal and cam.baseline
                        else "")
                     + (" (general matrices)" if cam.is_general else ""))
    return lines + _metadata_lines(stack.metadata)


_SHOWN_AS_EXR = ("source_files", "source_views", "frames_per_second", "time_code")  # by _exr_lines


def _metadata_lines(metadata: dict) -> list[str]:
    lines = []
    for key, value in sorted(metadata.items()):
        if key in _SHOWN_AS_EXR:
            continue
        text = json.dumps(value, default=str)
        lines.append(f"  {key}: {text if len(text) < 100 else text[:97] + '...'}")
    return lines


def _deep_lines(info: dict) -> list[str]:
    layers = info["layers"]
    lines = [f"{info['file']}: deep scanline EXR, {info['width']}x{info['height']}, {len(layers)} layers, "
             f"channels {', '.join(info['channels'])}",
             f"  {info.get('samples_note') or 'samples: ' + str(info['samples'])}",
             "  layer  disparity  depth (Z = ZBack)"]
    lines += [f"  {la['index']:5d}  {la['disparity']:9.3f}  {la['depth']:.6g}" for la in layers]
    return lines + _metadata_lines(info["metadata"])


def _plate_lines(info: dict) -> list[str]:
    parts = info["parts"]
    if info["multi_view"]:
        views = ", ".join(v["name"] + (" (default)" if v["default"] else "") for v in info["views"])
        head = (f"{info['file']}: multi-view EXR, {len(parts)} part{'s' * (len(parts) > 1)}, "
                f"{len(info['views'])} views: {views}")
    else:
        head = f"{info['file']}: an image, {len(parts)} part{'s' * (len(parts) > 1)}, not multi-view"
    lines = [head]
    for part in parts:
        name = f" {part['name']!r}" if part["name"] else ""
        view = f", view {part['view']}" if part["view"] else ""
        deep = ", deep" if part["deep"] else ""
        lines.append(f"  part {part['index']}{name}: {part['width']}x{part['height']}{view}{deep}, channels "
                     f"{', '.join(part['channels'])}")
    for v in info["views"]:
        if "width" not in v:
            lines.append(f"  view {v['name']}: no channels")
            continue
        colour = ", ".join(v["colour"]) if v["colour"] else "none found"
        lines.append(f"  view {v['name']}: {v['width']}x{v['height']}, colour from {colour} "
                     f"(channels {', '.join(v['channels'])})")
    return lines


def _exr_lines(attributes: dict) -> list[str]:
    lines = []
    for key in ("framesPerSecond", "timeCode", "sources", "views"):
        if key in attributes:
            value = attributes[key]
            if key == "framesPerSecond":
                value = f"{value[0]}/{value[1]} ({value[0] / value[1]:.6g} fps)"
            elif isinstance(value, list):
                value = ", ".join(value)
            lines.append(f"  {key}: {value}")
    lines += [f"  {key}: present (general cameras)" for key in ("worldToCamera", "worldToNDC") if key in attributes]
    return lines


# --------------------------------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every command."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--frames", help="frame range for patterns: 1001-1100, 1001-1100x2, 1,5,10-12")
    common.add_argument("--overwrite", action="store_true", help="redo frames whose outputs exist")
    common.add_argument("--jobs", type=int, default=1, help="frames processed in parallel (local cores)")
    common.add_argument("-q", "--quiet", action="store_true", help="no progress bars or log lines")
    common.add_argument("-v", "--verbose", action="store_true", help="more log lines")
    common.add_argument("--input-colorspace", default=None,
                        help="colour space of the inputs (OCIO name from $OCIO or the built-in config); default: "
                             "8/16-bit files are sRGB, float files scene-linear")

    p = _OneLineParser(prog="vfxstereo", description=__doc__.split("\n\n")[0])
    p.add_argument("--version", action="version", version=f"vfxstereo {_version()}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_OneLineParser)

    s = sub.add_parser("solve", parents=[common], help="solve a layer stack from K views",
                       description="Solve a stack of premultiplied RGBA layers (one per disparity plane) from "
                                   "K views (Szeliski & Golland 1999).")
    s.add_argument("views", nargs="*", help="view files (or frame patterns), ordered along the baseline; or one "
                                            "multi-view EXR (or a frame pattern of them)")
    s.add_argument("--views", dest="view_names", metavar="NAMES",
                   help="views of a multi-view EXR to solve, in baseline order: left,right (default: all, in the "
                        "file's order)")
    s.add_argument("-o", "--output", required=True, help="stack EXR (multilayer)")
    s.add_argument("--positions", help="camera positions P0,P1,... in view steps (default 0..K-1)")
    s.add_argument("--reference", type=int, default=None, help="index of the reference view (default middle)")
    s.add_argument("--disparities", help="MIN:MAX[:STEP] in pixels per unit of position, inclusive (default "
                                         "0 to 5%% of the image width, step 1)")
    s.add_argument("--preset", default="paper",
                   help="paper (default), zkey (paper + edge matting: best soft edges), literal (the paper "
                        "as written), wta, fig6a..fig6e (the paper's configurations)")
    s.add_argument("--dataset", help="folder with a dataset.json (views, positions, reference)")
    s.add_argument("--disparity-out", help="EXR with the sub-pixel disparity of the reference camera (channels "
                                           "Y and Z, the same values)")
    s.add_argument("--deep-out", help="deep EXR of the stack (R,G,B,A,Z,ZBack)")
    s.add_argument("--cameras", help="JSON with general cameras: matrices (K 3x4) and M0 (4x4)")
    s.add_argument("--previews", help="folder for PNG previews (contact sheet of layers, disparity, flat)")
    s.set_defaults(func=cmd_solve)

    z = sub.add_parser("zkey", parents=[common], help="insert a CG element between the layers",
                       description="Composite a premultiplied RGBA element between the layers of a stack.")
    z.add_argument("stack")
    z.add_argument("element", help="RGBA element (EXR premultiplied; PNG straight alpha, premultiplied on read)")
    z.add_argument("--disparity", type=float, help="insert at this disparity (layers with larger d in front)")
    z.add_argument("--element-depth", help="file with the element's per-pixel depth (first channel)")
    z.add_argument("--into", choices=("plate", "stack"), default="plate",
                   help="plate (default): compose into the plate stored in the stack, which stays untouched "
                        "wherever the element adds nothing; stack: into the stack's own re-synthesis")
    z.add_argument("-o", "--output", required=True, help="comp (EXR linear; PNG/JPEG display-encoded sRGB)")
    z.add_argument("--holdout-out", help="matte of everything in front of the disparity")
    z.add_argument("--front-out", help="flattened layers in front of the disparity")
    z.add_argument("--back-out", help="flattened layers behind the disparity")
    z.set_defaults(func=cmd_zkey)

    r = sub.add_parser("render", parents=[common], help="render a novel view of a stack")
    r.add_argument("stack")
    r.add_argument("--position", required=True, help="camera position P (or X,Y) in view steps")
    r.add_argument("-o", "--output", required=True)
    r.set_defaults(func=cmd_render)

    sp = sub.add_parser("split", parents=[common], help="flatten the layers in front of / behind a disparity")
    sp.add_argument("stack")
    sp.add_argument("--disparity", type=float, required=True)
    sp.add_argument("--front-out")
    sp.add_argument("--back-out")
    sp.add_argument("--holdout-out")
    sp.set_defaults(func=cmd_split)

    i = sub.add_parser("info", help="describe a stack, deep or plate file (views, parts, channels)")
    i.add_argument("file", help="a stack EXR, a deep EXR, or a plate (multi-view EXR or any image)")
    i.add_argument("--json", action="store_true", help="machine-readable output")
    i.set_defaults(func=cmd_info, quiet=True, verbose=False)
    return p


def _version() -> str:
    from vfxstereo import __version__

    return __version__


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``vfxstereo`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING if args.quiet else logging.DEBUG if args.verbose else logging.INFO
    logging.basicConfig(level=level, format="vfxstereo: %(message)s", stream=sys.stderr)
    try:
        return int(args.func(args) or 0)
    except VfxStereoError as exc:
        print(f"vfxstereo: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return _interrupted()
    except BrokenPipeError:  # output piped into head & co.
        sys.stderr.close()
        return 0
    except MemoryError:
        print("vfxstereo: error: out of memory; use fewer disparity planes or smaller plates", file=sys.stderr)
        return 2
    except Exception as exc:
        # Ctrl-C inside a numba kernel surfaces as a SystemError caused by the KeyboardInterrupt.
        if _caused_by_interrupt(exc):
            return _interrupted()
        raise


def _caused_by_interrupt(exc: BaseException) -> bool:
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _interrupted() -> int:
    print("vfxstereo: interrupted; finished frames are intact, no partial files were left", file=sys.stderr)
    return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
