"""Solve Plates: ``vfxstereo solve`` in a child process, without freezing Blender; Esc cancels.

Progress shows in the status bar (from a timer polling the child); a cancelled or failed solve leaves the
output folder as it was (:class:`vfxstereo.runner.SolveRun`). From a script (or in background mode) the
operator runs to the end before it returns, reporting each stage, and Ctrl-C cancels it the same way.
"""

import os

import bpy

from vfxstereo import cli
from vfxstereo.errors import VfxStereoError
from vfxstereo.io import frames
from vfxstereo.runner import SolveRequest, SolveRun

from .. import preferences

POLL_SECONDS = 0.25
"""How often the UI timer reads the child's progress."""


class VFXSTEREO_OT_solve_plates(bpy.types.Operator):
    """Solve a stack of premultiplied RGBA layers from K views (vfxstereo solve), in the background."""

    bl_idname = "vfxstereo.solve_plates"
    bl_label = "Solve Plates"
    bl_options = {"REGISTER"}

    directory: bpy.props.StringProperty(subtype="DIR_PATH", options={"SKIP_SAVE"})
    files: bpy.props.CollectionProperty(type=bpy.types.OperatorFileListElement, options={"SKIP_SAVE"})
    filter_image: bpy.props.BoolProperty(default=True, options={"HIDDEN", "SKIP_SAVE"})
    filter_folder: bpy.props.BoolProperty(default=True, options={"HIDDEN", "SKIP_SAVE"})
    dataset: bpy.props.StringProperty(
        name="Dataset", subtype="DIR_PATH",
        description="A folder with a dataset.json (views, positions, reference), instead of view files")
    output: bpy.props.StringProperty(
        name="Output", subtype="FILE_PATH",
        description="The stack EXR (stack.####.exr for frame sequences); empty: stack.exr beside the views")
    positions: bpy.props.StringProperty(
        name="Positions", description="Camera positions P0,P1,... in view steps; empty: 0..K-1")
    reference: bpy.props.IntProperty(
        name="Reference", default=-1, min=-1, description="Index of the reference view; -1: the middle one")
    disparities: bpy.props.StringProperty(
        name="Disparities",
        description="MIN:MAX[:STEP] in pixels per view step; empty: the add-on preferences' default, else "
                    "the command's")
    preset: bpy.props.StringProperty(
        name="Preset",
        description="Solver preset (paper, zkey, literal, wta, ...); empty: the add-on preferences' "
                    "default, else the command's own default")
    frames: bpy.props.StringProperty(
        name="Frames", description="Frame range for frame patterns (1001-1100); empty: the frames on disk")
    view_names: bpy.props.StringProperty(
        name="View Names",
        description="For one multi-view EXR (a stereo plate): the views to read, e.g. left,right; empty: all "
                    "of them, in the file's order")
    wait: bpy.props.BoolProperty(
        name="Wait", default=False, options={"SKIP_SAVE"},
        description="Return only when the solve has finished (for scripts); from the UI the solve runs in "
                    "the background")

    def invoke(self, context, event):
        """Pick the views in the file browser unless they were given."""
        if not self.files and not self.dataset:
            context.window_manager.fileselect_add(self)
            return {"RUNNING_MODAL"}
        return self.execute(context)

    def execute(self, context):
        """Start the child; in the UI hand over to the timer, else run it to the end."""
        prefs = preferences.get(context)
        try:
            command = preferences.solver(prefs)
            self._run = SolveRun(command, self.request(prefs))
            self._run.start()
        except VfxStereoError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Solving with {command.label} into {self._run.request.output}")
        wm = context.window_manager
        if bpy.app.background or self.wait or context.window is None:
            return self._run_to_end(context)
        self._timer = wm.event_timer_add(POLL_SECONDS, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 100)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        """Timer: show progress, finish when the child ends. Esc: cancel."""
        if event.type == "ESC":
            self.cancel(context)
            self.report({"WARNING"}, "Solve cancelled; no files were left behind")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if self._run.poll() is None:
            progress = self._run.progress
            context.workspace.status_text_set(f"vfxstereo: {progress.text()}  (Esc to cancel)")
            context.window_manager.progress_update(int(100 * progress.fraction))
            return {"RUNNING_MODAL"}
        self._end_ui(context)
        return self._finish(context)

    def cancel(self, context):
        """Stop the child and remove what it wrote (Esc, or Blender ending the operator)."""
        self._run.cancel()
        self._end_ui(context)

    def draw(self, context):
        """Options beside the file browser."""
        layout = self.layout
        for name in ("dataset", "output", "positions", "reference", "disparities", "preset", "frames",
                     "view_names"):
            layout.prop(self, name)
        layout.label(text=f"Solver: {preferences.describe_solver(preferences.get(context))}")

    # ---------------------------------------------------------------------------------------------------
    def request(self, prefs) -> SolveRequest:
        """The solve to run, from the operator's properties and the preferences' defaults.

        Raises
        ------
        VfxStereoError
            For no views (or both views and a dataset), or malformed positions or disparities; the command
            itself judges the files (one multi-view EXR is enough).
        """
        views = tuple(os.path.join(bpy.path.abspath(self.directory), f.name) for f in self.files if f.name)
        dataset = bpy.path.abspath(self.dataset) if self.dataset else None
        if bool(views) == bool(dataset):
            raise VfxStereoError("choose either view files or a dataset folder")
        positions = cli.parse_float_list(self.positions, "Positions") if self.positions.strip() else None
        if positions is not None and views and len(positions) != len(views):
            raise VfxStereoError(f"{len(views)} views need {len(views)} positions, got {len(positions)}")
        disparities = self.disparities.strip() or prefs.default_disparities.strip() or None
        if disparities:
            cli.parse_disparities(disparities)  # a malformed range is reported now, not by the child
        if self.output:
            output = bpy.path.abspath(self.output)
        else:
            folder = dataset or os.path.dirname(views[0])
            output = os.path.join(folder, "stack.####.exr" if frames.is_pattern(views[0] if views else "")
                                  else "stack.exr")
        return SolveRequest(output, views, dataset, tuple(positions) if positions else None,
                            self.reference if self.reference >= 0 else None, disparities,
                            self.preset.strip() or prefs.default_preset.strip() or None,
                            self.frames.strip() or None, self.view_names.strip() or None)

    def _run_to_end(self, context):
        wm = context.window_manager
        wm.progress_begin(0, 100)
        shown = []

        def show(progress):
            wm.progress_update(int(100 * progress.fraction))
            if progress.stage and progress.stage not in shown[-1:]:
                shown.append(progress.stage)
                self.report({"INFO"}, f"vfxstereo: {progress.text()}")

        try:
            self._run.wait(show)
        except KeyboardInterrupt:
            self.report({"WARNING"}, "Solve cancelled; no files were left behind")
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        return self._finish(context)

    def _finish(self, context):
        try:
            outputs = self._run.finish()
        except VfxStereoError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        image = bpy.data.images.load(str(outputs[0]), check_existing=True)
        image.reload()
        if len(outputs) > 1:
            image.source = "SEQUENCE"
        context.scene.vfxstereo.stack_path = str(outputs[0])
        self.report({"INFO"}, f"Solved with {self._run.command.label}: wrote {len(outputs)} file(s), "
                              f"loaded {outputs[0].name}")
        return {"FINISHED"}

    def _end_ui(self, context):
        wm = context.window_manager
        if getattr(self, "_timer", None) is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
            wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
