"""The ``vfxstereo`` command line: solve, zkey, render, split, info -- on single frames or frame sequences.

Every command accepts frame patterns (``plate_left.####.exr``, ``plate.%04d.exr``, ``plate.@@@@.exr``) for
its inputs and outputs; with patterns it runs once per frame of ``--frames`` (default: the frames found on
disk for the first input pattern), or of one farm chunk of them (``--chunk-size N --chunk-index I``). Frames
whose outputs all exist are skipped unless ``--overwrite``, so a shot that was interrupted resumes where it
stopped; ``--jobs N`` runs frames in parallel processes, ``--scheduler`` on a Dask cluster.

This module only parses arguments: :mod:`vfxstereo.tasks` does each frame's work, :mod:`vfxstereo.shot`
plans and runs the frames. Errors the user can cause end in one line on stderr and exit status 2; outputs
are written atomically, so a failure or Ctrl-C never leaves half a file and never clobbers an existing one.

Exit status: 0 done, 1 some frames of a sequence failed (each is reported; the others are written), 2 bad
input (nothing was run), 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from pathlib import Path

import numpy as np

from vfxstereo import shot, tasks
from vfxstereo.config import DEFAULT_PRESET
from vfxstereo.errors import VfxStereoError
from vfxstereo.tasks import check_input, check_output

log = logging.getLogger("vfxstereo")


class _OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line on stderr and exit status 2."""

    def error(self, message: str):  # noqa: D102
        self.exit(2, f"{self.prog}: error: {message}\n")


# --------------------------------------------------------------------------------------------------------
# Arguments


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


def parse_float_list(text: str, what: str) -> list[float]:
    """``"0,1.5,3"`` to numbers; ``what`` names the option in the error."""
    try:
        return [float(x) for x in text.split(",") if x.strip() != ""]
    except ValueError:
        raise VfxStereoError(f"{what} must be comma-separated numbers, got {text!r}") from None


# --------------------------------------------------------------------------------------------------------
# Commands: arguments to a task and its jobs (vfxstereo.tasks, vfxstereo.shot)


def _run(args, task, inputs: dict, outputs: dict) -> int:
    """Plan the jobs of the command's files, run ``task`` on them, and turn the report into the exit status."""
    chunk = None
    if (args.chunk_size is None) != (args.chunk_index is None):
        raise VfxStereoError("--chunk-size and --chunk-index go together")
    if args.chunk_size is not None:
        chunk = (args.chunk_size, args.chunk_index)
    jobs = shot.plan_jobs(inputs, outputs, frames=args.frames, overwrite=args.overwrite, chunk=chunk)
    report = shot.run_jobs(jobs, task, workers=args.jobs, scheduler=args.scheduler, retries=args.retries,
                           quiet=args.quiet)
    if not report.failed:
        return 0
    from vfxstereo.io import frames

    failed = report.failed
    first = failed[0]
    print(f"vfxstereo: error: {len(failed)} of {len(failed) + len(report.done)} frames failed "
          f"({frames.frame_range(f.frame for f in failed)}; tried {first.attempts} "
          f"time{'s' * (first.attempts > 1)} each), the others are written. Frame {first.frame}: {first.error}",
          file=sys.stderr)
    return 1


def cmd_solve(args) -> int:
    """``vfxstereo solve``: views to a layer stack (and disparity, deep, previews)."""
    from vfxstereo.io import plates

    views = list(args.views)
    view_names = _parse_view_names(args.view_names)
    positions = parse_float_list(args.positions, "--positions") if args.positions else None
    reference = args.reference
    camera = None
    if args.dataset:
        ds = plates.load_dataset(args.dataset)
        if views:
            raise VfxStereoError("give either VIEW files or --dataset, not both")
        views = [str(v) for v in ds.views]
        if positions is None:
            positions = list(ds.positions)
        if reference is None:
            reference = int(ds.reference)
    if args.cameras:
        camera = _load_cameras(args.cameras)
    if not views:
        raise VfxStereoError("solve needs at least two views (files), or one multi-view EXR")
    if view_names is not None and len(views) != 1:
        raise VfxStereoError(f"--views picks views inside one multi-view EXR (or one frame pattern of them), "
                             f"but {len(views)} inputs were given")
    if args.previews:
        Path(args.previews).mkdir(parents=True, exist_ok=True)
        check_output(str(Path(args.previews) / "x.png"))
    task = tasks.SolveTask(
        preset=args.preset, view_names=None if view_names is None else tuple(view_names),
        positions=None if positions is None else tuple(float(p) for p in positions), reference=reference,
        disparities=parse_disparities(args.disparities) if args.disparities else None, camera=camera,
        input_colorspace=args.input_colorspace, previews=os.path.abspath(args.previews) if args.previews else None,
        drop_empty_planes=args.drop_empty_planes, soft_rounds=args.soft_rounds)
    return _run(args, task, {"views": views},
                {"stack": args.output, "disparity": args.disparity_out, "deep": args.deep_out})


def _parse_view_names(text: str | None) -> list[str] | None:
    """``--views left,right`` to names (None when not given)."""
    if text is None:
        return None
    names = [v.strip() for v in text.split(",")]
    if not all(names):
        raise VfxStereoError(f"--views must be comma-separated view names, got {text!r}")
    return names


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


def cmd_zkey(args) -> int:
    """``vfxstereo zkey``: a CG element between the layers of a stack."""
    if args.disparity is not None and args.element_depth is not None:
        raise VfxStereoError("give --disparity or --element-depth, not both")
    if args.disparity is None and any((args.holdout_out, args.front_out, args.back_out)):
        raise VfxStereoError("--holdout-out, --front-out and --back-out need --disparity")
    task = tasks.ZkeyTask(disparity=args.disparity, into=args.into, input_colorspace=args.input_colorspace)
    return _run(args, task, {"stack": args.stack, "element": args.element, "depth": args.element_depth},
                {"comp": args.output, "holdout": args.holdout_out, "front": args.front_out, "back": args.back_out})


def cmd_render(args) -> int:
    """``vfxstereo render``: a novel view of a stack."""
    position = parse_float_list(args.position, "--position")
    if len(position) not in (1, 2):
        raise VfxStereoError("--position takes one number or X,Y")
    task = tasks.RenderTask(position=tuple(position) if len(position) == 2 else position[0])
    return _run(args, task, {"stack": args.stack}, {"view": args.output})


def cmd_split(args) -> int:
    """``vfxstereo split``: the flattened layers in front of and behind a disparity."""
    if not (args.front_out or args.back_out or args.holdout_out):
        raise VfxStereoError("split needs --front-out, --back-out or --holdout-out")
    return _run(args, tasks.SplitTask(disparity=args.disparity), {"stack": args.stack},
                {"front": args.front_out, "back": args.back_out, "holdout": args.holdout_out})


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
        stack = tasks.read_stack(path)
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
    common.add_argument("--jobs", type=_count(1), default=1, metavar="N",
                        help="frames processed in parallel: local processes, or the workers of --scheduler local")
    common.add_argument("--scheduler", metavar="ADDRESS",
                        help="run the frames on a Dask cluster: 'local' starts one here with --jobs workers, "
                             "or a scheduler address such as tcp://10.0.0.5:8786 (workers must see the same "
                             "paths)")
    common.add_argument("--retries", type=_count(0), default=1, metavar="N",
                        help="try a failed frame of a sequence up to N more times (default 1); the other "
                             "frames go on, and the exit status is 1 if any frame failed")
    common.add_argument("--chunk-size", type=_count(1), metavar="N",
                        help="render-farm chunks: N frames per task (the farm's chunk size); with --chunk-index")
    common.add_argument("--chunk-index", type=_count(0), metavar="I",
                        help="which chunk of --frames this task runs, counting from 0: frames I*N .. I*N+N-1 "
                             "of the frame list")
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
    s.add_argument("--preset", default=DEFAULT_PRESET,
                   help="robust (default: robust multi-view depth, hidden layers, soft edges that follow the "
                        "matte where the views agree; the best measured for z-keying real plates; zkey is the "
                        "same), soft (robust with the matte followed everywhere: hair, fur, foliage over plain "
                        "backgrounds), grille (robust with plain surfaces sent back where two far-apart depths "
                        "match alike: a plain wall through a grille, fence, wicker or foliage; costly on plain "
                        "foreground objects), paper (Szeliski & Golland's stages with "
                        "our additions), literal (the paper as written), wta, fig6a..fig6e (the paper's "
                        "configurations)")
    s.add_argument("--dataset", help="folder with a dataset.json (views, positions, reference)")
    s.add_argument("--disparity-out", help="EXR with the sub-pixel disparity of the reference camera (channels "
                                           "Y and Z, the same values)")
    s.add_argument("--deep-out", help="deep EXR of the stack (R,G,B,A,Z,ZBack)")
    s.add_argument("--cameras", help="JSON with general cameras: matrices (K 3x4) and M0 (4x4)")
    s.add_argument("--previews", help="folder for PNG previews (contact sheet of layers, disparity, flat)")
    s.add_argument("--drop-empty-planes", action="store_true",
                   help="write only the planes that hold something (robust preset): a 4K plate over 128 planes "
                        "then needs memory for its occupied layers only")
    s.add_argument("--soft-rounds", type=int, default=None, metavar="N",
                   help="rounds of layers and soft edges with three views or more (robust presets; default 2: "
                        "the second builds the layers again from the edges the first moved; 1 takes half the "
                        "soft edges' time for slightly worse z-keys)")
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


def _count(minimum: int):
    """An argparse type: a whole number of at least ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {value}")
        return value

    return parse


def _version() -> str:
    from vfxstereo import __version__

    return __version__


class _StderrHandler(logging.StreamHandler):
    """Our log lines on stderr (``vfxstereo: ...``); a class of its own so that main() adds it once."""

    def __init__(self):
        super().__init__(sys.stderr)
        self.setFormatter(logging.Formatter("vfxstereo: %(message)s"))

    @property
    def stream(self):  # always the current sys.stderr (tests replace it)
        return sys.stderr

    @stream.setter
    def stream(self, value):
        pass


def _log_to_stderr(level: int) -> None:
    """Show the ``vfxstereo`` logger's lines on stderr at ``level``; other libraries' loggers (Dask's) stay quiet."""
    log.setLevel(level)
    if not any(isinstance(h, _StderrHandler) for h in log.handlers):
        log.addHandler(_StderrHandler())


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``vfxstereo`` console script."""
    parser = build_parser()
    args = parser.parse_args(argv)
    _log_to_stderr(logging.WARNING if args.quiet else logging.DEBUG if args.verbose else logging.INFO)
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
        if shot.caused_by_interrupt(exc):
            return _interrupted()
        raise


def _interrupted() -> int:
    print("vfxstereo: interrupted; finished frames are intact, no partial files were left", file=sys.stderr)
    return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
