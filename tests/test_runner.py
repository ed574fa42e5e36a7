"""The child-process solve the Blender add-on uses: progress read from the real command's output, outputs
moved into place only on success, and a cancel that leaves the output folder as it was."""

import io
import os
import sys
import time
from pathlib import Path

import pytest
from tqdm import tqdm

from vfxstereo import VfxStereoError, cli, samples
from vfxstereo.io import exr
from vfxstereo.runner import STAGE_SHARES, ProgressParser, SolverCommand, SolveRequest, SolveRun

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "samples" / "demo"


def _bars(*stages, prefix=""):
    """What the CLI writes on a terminal: one real tqdm bar per stage, plus the -v line when it ends."""
    buf = io.StringIO()
    for stage, total in stages:
        bar = tqdm(total=total, desc=f"{prefix}{stage}", file=buf, leave=False, ncols=100, mininterval=0)
        for _ in range(total):
            bar.update(1)
        bar.close()
        buf.write(f"vfxstereo: {prefix}{stage}: {total} steps in 0.10 s\n")
    return buf.getvalue()


def _fed_in_pieces(text, size=7):
    parser, seen = ProgressParser(), []
    for i in range(0, len(text), size):  # bytes arrive in arbitrary pieces
        if parser.feed(text[i:i + size]):
            p = parser.progress
            seen.append((p.stage, p.done, p.total, p.fraction))
    return parser, seen


def test_progress_follows_real_tqdm_bars_through_the_stages():
    parser, seen = _fed_in_pieces(_bars(("sweep", 5), ("aggregate", 10), ("refine", 40), ("subpixel", 1)))
    stages = [s for s, *_ in seen]
    assert stages.index("sweep") < stages.index("refine") < stages.index("subpixel")
    assert ("refine", 20, 40) in [s[:3] for s in seen]  # mid-stage steps come through, not just stage ends
    fractions = [f for *_, f in seen]
    assert fractions == sorted(fractions)  # never backwards, although sweep restarts at 0 of a new stage
    refine_half = [f for s, d, t, f in seen if s == "refine" and d == 20][0]
    start, end = STAGE_SHARES["refine"]
    assert refine_half == pytest.approx(start + (end - start) / 2)
    assert parser.progress.fraction == pytest.approx(1.0)


def test_progress_of_a_sequence_counts_frames():
    text = _bars(("refine", 4), prefix="frame 1001 (1/2) ") + _bars(("refine", 4), prefix="frame 1002 (2/2) ")
    parser, seen = _fed_in_pieces(text)
    first_of_second = [f for s, d, t, f in seen if d == 1 and f > 0.5]
    assert first_of_second and parser.progress.frame_index == 2 and parser.progress.frame_count == 2
    assert "frame 2/2" in parser.progress.text()


def test_the_commands_error_line_is_kept_and_other_lines_change_nothing():
    parser = ProgressParser()
    assert not parser.feed("vfxstereo: some log line\nvfxstereo: error: input not found: a.png\n")
    assert parser.error == "input not found: a.png"
    assert parser.progress.stage == "" and parser.progress.fraction == 0.0


def test_request_arguments_are_what_the_real_command_line_parses():
    req = SolveRequest("out.exr", views=("a.png", "b.png", "c.png"), positions=(0, 1.5, 3), reference=1,
                       disparities="0:8:0.5", preset="zkey", frames="1-3")
    args = cli.build_parser().parse_args(req.arguments("work/out.exr"))
    assert args.views == ["a.png", "b.png", "c.png"] and args.output == "work/out.exr"
    assert (args.positions, args.reference, args.disparities, args.preset, args.frames) == (
        "0,1.5,3", 1, "0:8:0.5", "zkey", "1-3")
    stereo = cli.build_parser().parse_args(SolveRequest("o.exr", views=("plate.exr",),
                                                        view_names="left,right").arguments("o.exr"))
    assert stereo.views == ["plate.exr"] and "left,right" in vars(stereo).values()
    default = cli.build_parser().parse_args(SolveRequest("o.exr", dataset="ds").arguments("o.exr"))
    assert default.preset == cli.build_parser().parse_args(["solve", "x", "-o", "y"]).preset  # no preset given
    with pytest.raises(VfxStereoError, match="either"):
        SolveRequest("o.exr").arguments("o.exr")


def test_an_external_command_that_does_not_exist_is_one_clear_error(tmp_path):
    with pytest.raises(VfxStereoError, match="not found"):
        SolverCommand.external(str(tmp_path / "vfxstereo"))


def _bundled():
    return SolverCommand.bundled(sys.executable, str(REPO), version="test")


def write_small_views(folder):
    """Five 48x40 views of a random-dot stereogram as EXR files (a solve of a second or two); their paths."""
    sample = samples.random_dot_stereogram(shape=(40, 48), num_planes=4, squares=[(2, 8, 10, 20, 24)])
    return [str(exr.write_image(folder / f"v{k}.exr", v)) for k, v in enumerate(sample.views)]


@pytest.fixture(scope="module")
def small_views(tmp_path_factory):
    return write_small_views(tmp_path_factory.mktemp("views"))


def test_a_run_moves_its_stack_into_place_only_at_the_end(tmp_path, small_views):
    out = tmp_path / "stack.exr"
    run = SolveRun(_bundled(), SolveRequest(str(out), views=tuple(small_views), disparities="0:3"))
    run.start()
    assert run.work_dir.parent == tmp_path and run.work_dir.name.startswith(".vfxstereo-solve-")
    seen = []
    assert run.wait(lambda p: seen.append((p.stage, p.fraction))) == 0
    assert not out.exists()  # still in the work folder until finish()
    assert run.finish() == [out]
    assert os.listdir(tmp_path) == ["stack.exr"]
    assert exr.read_stack(out).depth == 4
    stages = {s for s, _ in seen}
    # the default preset's last stage; on this tiny plate the earlier ones can finish between two reads of the
    # terminal (the solve of the demo in tests/blender shows them all)
    assert "soft-edges" in stages and seen[-1][1] == pytest.approx(1.0)


def test_a_frame_sequence_run_moves_every_frame_and_counts_frames(tmp_path, small_views):
    for frame in (1001, 1002):  # two frames of the same five views, as frame patterns v<k>.####.exr
        for k, view in enumerate(small_views):
            os.link(view, tmp_path / f"v{k}.{frame}.exr")
    out = tmp_path / "out"
    out.mkdir()
    patterns = tuple(str(tmp_path / f"v{k}.####.exr") for k in range(len(small_views)))
    run = SolveRun(_bundled(), SolveRequest(str(out / "stack.####.exr"), views=patterns, disparities="0:3"))
    run.start()
    counts = set()
    assert run.wait(lambda p: counts.add((p.frame_index, p.frame_count))) == 0
    assert run.finish() == [out / "stack.1001.exr", out / "stack.1002.exr"]
    assert sorted(os.listdir(out)) == ["stack.1001.exr", "stack.1002.exr"]
    assert (2, 2) in counts and run.progress.fraction == pytest.approx(1.0)


def test_a_failing_run_reports_the_commands_one_line_error_and_leaves_nothing(tmp_path):
    run = SolveRun(_bundled(), SolveRequest(str(tmp_path / "s.exr"), views=("nope0.png", "nope1.png")))
    run.start()
    assert run.wait() == 2
    with pytest.raises(VfxStereoError, match="failed: input not found: nope0.png"):
        run.finish()
    assert os.listdir(tmp_path) == []


def test_cancel_stops_the_child_and_leaves_the_folder_as_it_was(tmp_path, small_views):
    # A shot of 200 frames (hard links to the same views): minutes of work, so the child cannot end on its own
    # between the test seeing it start and cancelling it. The demo's one-frame solve (~2.5 s) sometimes did, on a
    # loaded 2-core CI machine, and then exited 0 before the SIGINT.
    shot = tmp_path / "plates"
    shot.mkdir()
    for frame in range(1001, 1201):
        for k, view in enumerate(small_views):
            os.link(view, shot / f"v{k}.{frame}.exr")
    patterns = tuple(str(shot / f"v{k}.####.exr") for k in range(len(small_views)))
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    run = SolveRun(_bundled(), SolveRequest(str(out / "stack.####.exr"), views=patterns, disparities="0:3"))
    run.start()
    deadline = time.monotonic() + 60
    while run.poll() is None and run.progress.frame_index < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert run.returncode is None, "the solve ended before it could be cancelled"
    pid = run._proc.pid
    run.cancel()
    assert os.listdir(out) == ["keep.txt"]  # not even the frames finished before the cancel
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # the child is gone (and reaped)
    # (it failed once in a full local suite with exit 0 and has not since, alone or under load: say what the
    # child printed last, so that the next failure tells why)
    assert run.returncode != 0, (run.returncode, run.parser.last_line, run.parser.error, run.progress)


def test_start_refuses_a_missing_output_folder(tmp_path):
    run = SolveRun(_bundled(), SolveRequest(str(tmp_path / "no" / "s.exr"), dataset=str(DEMO)))
    with pytest.raises(VfxStereoError, match="does not exist"):
        run.start()
