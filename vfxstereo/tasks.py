"""What each command does to one frame: read its inputs, compute, write its outputs (atomically).

A task is a small frozen dataclass holding a command's settings; calling it on a :class:`vfxstereo.shot.Job`
(one frame's concrete input and output paths) does the work of that frame::

    task = SolveTask(preset="wta", disparities=(0.0, 1.0, 2.0, 3.0))
    task(Job(1001, {"views": ["cam0.1001.exr", "cam1.1001.exr"]}, {"stack": "stack.1001.exr"}))

Tasks are top-level, picklable callables, so the same object runs in this process, in the ``--jobs``
process pool, on a Dask worker and in the Blender add-on; :mod:`vfxstereo.shot` plans the jobs and runs
them. ``check(job)``, where a task has it, validates one frame from file headers only, before any work is
sent anywhere. Each task reads its own inputs and writes its own outputs through :mod:`vfxstereo.io`, whose
writers are atomic: a failed or interrupted frame leaves no partial file and clobbers nothing.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vfxstereo.config import DEFAULT_PRESET
from vfxstereo.errors import VfxStereoError
from vfxstereo.progress import Progress

if TYPE_CHECKING:
    from vfxstereo.shot import Job

PICTURE_EXTENSIONS = {".png", ".jpg", ".jpeg", ".tif", ".tiff"}
"""Outputs with these extensions are written display-encoded (sRGB); everything else as scene-linear EXR."""


# --------------------------------------------------------------------------------------------------------
# Files


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


def write_picture(path: str, pixels: np.ndarray, *, metadata: dict | None = None) -> None:
    """EXR stays scene-linear; PNG/JPEG/TIFF are written display-encoded (sRGB, unpremultiplied over nothing)."""
    ext = Path(path).suffix.lower()
    if ext in PICTURE_EXTENSIONS:
        from vfxstereo.io import preview

        preview.write_png(path, pixels)
    else:
        from vfxstereo.io import exr

        exr.write_image(path, pixels, metadata=metadata)


def read_stack(path: str):
    """The LayerStack in ``path`` (VfxStereoError if it is missing or not a stack)."""
    from vfxstereo.io import exr

    check_input(path, "stack")
    return exr.read_stack(path)


def read_image(path: str):
    """``(pixels, channel names, metadata)`` of an image file (VfxStereoError if it is missing or unreadable)."""
    from vfxstereo.io import exr

    check_input(path, "image")
    return exr.read_image(path)


def default_disparities(width: int) -> np.ndarray:
    """The default range: 0 to 5 % of the image width per view step, in whole pixels."""
    return np.arange(0, max(2, int(np.ceil(width * 0.05))) + 1, dtype=np.float64)


# --------------------------------------------------------------------------------------------------------
# solve


@dataclass(frozen=True)
class SolveTask:
    """``solve`` on one frame: views to a layer stack, and the disparity map, deep file and previews asked for.

    Inputs of a job: ``views`` (list of files, or one multi-view EXR). Outputs: ``stack`` (required),
    ``disparity``, ``deep`` (optional).

    Parameters
    ----------
    preset : str
        :meth:`vfxstereo.SolveConfig.preset` name.
    view_names : tuple of str or None
        Views to read from a multi-view EXR, in baseline order (None: all, in the file's order).
    positions : tuple of float or None
        Camera positions in view steps (None: ``0..K-1``).
    reference : int or None
        Index of the reference view (None: the middle one).
    disparities : ndarray of shape (D,) or None
        The planes (None: :func:`default_disparities` of the plate width).
    camera : vfxstereo.geometry.Camera or None
        General cameras; overrides ``positions``.
    input_colorspace : str or None
        OCIO colour space of the plates (None: by file type).
    previews : str or None
        Folder for PNG previews (contact sheet, disparity, flattened stack).
    drop_empty_planes : bool
        Keep only the planes that hold something (``SolveConfig.keep_empty_planes = False``).
    soft_rounds : int or None
        Rounds of the layers and soft edges with three views or more (``SolveConfig.soft_rounds``; None: the
        preset's, 2 for the robust presets; 1 takes half the soft edges' time).
    """

    preset: str = DEFAULT_PRESET
    view_names: tuple[str, ...] | None = None
    positions: tuple[float, ...] | None = None
    reference: int | None = None
    disparities: Any = None
    camera: Any = None
    input_colorspace: str | None = None
    previews: str | None = None
    drop_empty_planes: bool = False
    soft_rounds: int | None = None

    def config(self):
        """The solver's settings: the preset, with ``drop_empty_planes`` and ``soft_rounds``."""
        from vfxstereo.config import SolveConfig
        from vfxstereo.solver import check_soft_rounds

        config = SolveConfig.preset(self.preset)
        if self.soft_rounds is not None:
            check_soft_rounds(self.soft_rounds, "--soft-rounds")  # before any frame is read, in the flag's name
            config = config.replace(soft_rounds=self.soft_rounds)
        return config.replace(keep_empty_planes=False) if self.drop_empty_planes else config

    def check(self, job: Job) -> None:
        """Before any work: the frame's views, from their headers, against positions, cameras and memory."""
        from vfxstereo import solver
        from vfxstereo.io import plates

        config = self.config()
        first = job.inputs["views"]
        if len(first) == 1:  # one multi-view EXR per frame
            layout = plates.describe_plate(first[0])
            if not layout.views and self.view_names is None:
                raise VfxStereoError(f"solve needs at least two views: {first[0]} is one image, not a multi-view "
                                     "EXR (no multiView header and no part with a view attribute)")
            names = layout.select(None if self.view_names is None else list(self.view_names))
            k, (h, w) = len(names), layout.view_size(names[0])
        else:
            k, (h, w) = len(first), plates.image_size(first[0])
        if self.positions is not None and len(self.positions) != k:
            raise VfxStereoError(f"{k} views need {k} positions, --positions gave {len(self.positions)}")
        if self.camera is not None and self.camera.K != k:
            raise VfxStereoError(f"--cameras describes {self.camera.K} cameras for {k} views")
        d = len(self.disparities) if self.disparities is not None else len(default_disparities(w))
        solver.check_memory((h, w), d, k, **solver.memory_settings(config))

    def __call__(self, job: Job, progress: Progress | None = None) -> None:
        """Solve the frame of ``job`` and write its outputs."""
        from vfxstereo import solver
        from vfxstereo.io import exr, plates, preview

        config = self.config()
        view_set = plates.read_view_set(job.inputs["views"],
                                        views=None if self.view_names is None else list(self.view_names),
                                        colorspace=self.input_colorspace)
        views = view_set.pixels
        k, h, w = views.shape[:3]
        positions = list(self.positions) if self.positions is not None else list(range(k))
        if len(positions) != k:
            raise VfxStereoError(f"{k} views need {k} positions, --positions gave {len(positions)}")
        disparities = np.asarray(self.disparities) if self.disparities is not None else default_disparities(w)
        result = solver.solve(views, positions=positions, reference=self.reference, disparities=disparities,
                              config=config, progress=progress, camera=self.camera, return_details=True)
        stack = result.stack
        stack.metadata.update(view_set.metadata(reference=stack.camera.reference_index))
        stack.metadata.update({"colorspace_in": self.input_colorspace or "default", "frame": job.frame})
        exr.write_stack(job.outputs["stack"], stack)
        if job.outputs.get("disparity"):
            exr.write_disparity(job.outputs["disparity"], result.disparity,
                                metadata={"vfxstereo/what": "sub-pixel disparity of the reference camera"})
        if job.outputs.get("deep"):
            exr.write_deep(job.outputs["deep"], stack)
        if self.previews:
            folder = Path(self.previews)
            stem = Path(job.outputs["stack"]).stem
            preview.write_png(str(folder / f"{stem}_layers.png"), preview.contact_sheet(stack))
            preview.write_png(str(folder / f"{stem}_disparity.png"), preview.disparity_preview(result.disparity))
            preview.write_png(str(folder / f"{stem}_flat.png"), stack.flatten())


# --------------------------------------------------------------------------------------------------------
# zkey, render, split


@dataclass(frozen=True)
class ZkeyTask:
    """``zkey`` on one frame: a CG element between the layers of a stack.

    Inputs of a job: ``stack``, ``element``, ``depth`` (optional per-pixel depth of the element). Outputs:
    ``comp`` (required); ``holdout``, ``front``, ``back`` (with ``disparity`` only).

    Parameters
    ----------
    disparity : float or None
        Insert at this disparity; None: by the element's own depth (its Z channel or the ``depth`` file).
    into : {"plate", "stack"}
        Compose into the plate stored in the stack, or into the stack's own re-synthesis.
    input_colorspace : str or None
        OCIO colour space of the element.
    """

    disparity: float | None = None
    into: str = "plate"
    input_colorspace: str | None = None

    def __call__(self, job: Job, progress: Progress | None = None) -> None:
        """Composite the frame of ``job`` and write its outputs."""
        from vfxstereo import composite
        from vfxstereo.io import plates

        stack = read_stack(job.inputs["stack"])
        element, z = plates.read_element(job.inputs["element"], colorspace=self.input_colorspace)
        if element.shape[:2] != stack.shape[1:]:
            raise VfxStereoError(f"element is {element.shape[1]}x{element.shape[0]} but the stack is "
                                 f"{stack.shape[2]}x{stack.shape[1]}: {job.inputs['element']}")
        if job.inputs.get("depth"):
            depth_pixels, _, _ = read_image(job.inputs["depth"])
            z = depth_pixels[..., 0]
        if self.disparity is not None:
            comp = composite.insert(stack, element, disparity=self.disparity, into=self.into)
        else:
            if z is None:
                raise VfxStereoError("the element has no Z channel: give --disparity D or --element-depth FILE")
            if z.shape != stack.shape[1:]:
                raise VfxStereoError(f"the element depth is {z.shape[1]}x{z.shape[0]} but the stack is "
                                     f"{stack.shape[2]}x{stack.shape[1]}")
            comp = composite.insert(stack, element, depth=z, into=self.into)
        write_picture(job.outputs["comp"], comp)
        if self.disparity is not None:
            _write_split(stack, self.disparity, job.outputs)


def _write_split(stack, disparity: float, outputs: dict) -> None:
    """The ``holdout``, ``front`` and ``back`` outputs asked for, at ``disparity``."""
    from vfxstereo import composite

    if outputs.get("holdout"):
        write_picture(outputs["holdout"], composite.holdout(stack, disparity)[..., None])
    if outputs.get("front") or outputs.get("back"):
        front, back = composite.split(stack, disparity)
        if outputs.get("front"):
            write_picture(outputs["front"], front)
        if outputs.get("back"):
            write_picture(outputs["back"], back)


@dataclass(frozen=True)
class RenderTask:
    """``render`` on one frame: a novel view of the job's ``stack``, written to its ``view`` output.

    Parameters
    ----------
    position : float or tuple of float
        Camera position P, or (X, Y), in view steps.
    """

    position: Any = 0.0

    def __call__(self, job: Job, progress: Progress | None = None) -> None:
        """Render the frame of ``job``."""
        from vfxstereo import composite

        write_picture(job.outputs["view"], composite.render_view(read_stack(job.inputs["stack"]), self.position))


@dataclass(frozen=True)
class SplitTask:
    """``split`` on one frame: the job's ``stack`` flattened in front of / behind ``disparity``.

    Outputs of a job: any of ``front``, ``back``, ``holdout``.
    """

    disparity: float = 0.0

    def __call__(self, job: Job, progress: Progress | None = None) -> None:
        """Split the frame of ``job``."""
        _write_split(read_stack(job.inputs["stack"]), self.disparity, job.outputs)
