"""The command line on real files: outputs, bad input (one line, exit 2, nothing written), frame sequences."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from vfxstereo import cli, composite, samples
from vfxstereo.io import exr

SHAPE = (48, 48)


def run_cli(*args, cwd=None):
    """Run the real command in a new process; returns (status, stdout, stderr)."""
    proc = subprocess.run([sys.executable, "-m", "vfxstereo.cli", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, timeout=300)
    return proc.returncode, proc.stdout, proc.stderr


@pytest.fixture(scope="module")
def scene():
    return samples.random_dot_stereogram(shape=SHAPE, seed=3)


@pytest.fixture
def views(tmp_path, scene):
    paths = []
    for k, view in enumerate(scene.views):
        p = tmp_path / f"view{k}.exr"
        exr.write_image(p, view)
        paths.append(p)
    return paths


@pytest.fixture(scope="module")
def stack_file(tmp_path_factory, scene):
    path = tmp_path_factory.mktemp("stack") / "stack.exr"
    exr.write_stack(path, scene.stack, half=False)
    return path


def files_in(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


# ---------------------------------------------------------------------------------------------------------
# Working commands


def test_solve_writes_stack_disparity_and_deep(tmp_path, views, scene):
    out = tmp_path / "out"
    out.mkdir()
    status, _, err = run_cli("solve", *views, "-o", out / "s.exr", "--disparities", "0:7", "--preset", "wta",
                             "--disparity-out", out / "d.exr", "--deep-out", out / "deep.exr", "-q")
    assert status == 0, err
    stack = exr.read_stack(out / "s.exr")
    assert stack.depth == 8 and stack.shape[1:] == SHAPE
    np.testing.assert_array_equal(stack.disparities, np.arange(8.0))
    d, names, _ = exr.read_image(out / "d.exr")
    assert d.shape == SHAPE + (2,) and names == exr.DISPARITY_CHANNELS
    np.testing.assert_array_equal(d[..., 0], d[..., 1])
    gt = scene.gt_disparity()
    assert np.mean(np.abs(d[..., 0] - gt) < 0.5) > 0.8  # wta on the stereogram gets most pixels right
    assert exr.read_deep(out / "deep.exr") is not None
    assert files_in(out) == {"s.exr", "d.exr", "deep.exr"}


def test_solve_drops_the_empty_planes_when_asked(tmp_path, views, scene):
    status, _, err = run_cli("solve", *views, "-o", tmp_path / "s.exr", "--disparities", "0:12",
                             "--drop-empty-planes", "-q")
    assert status == 0, err
    stack = exr.read_stack(tmp_path / "s.exr")
    used = np.unique(scene.gt_disparity())  # the stereogram's planes (whole disparities)
    assert 2 <= stack.depth < 13 and set(used) <= set(stack.disparities)
    assert (stack.rgba[..., 3].max(axis=(1, 2)) > 0).all()  # every layer written holds something


def test_solve_takes_the_rounds_of_soft_edges_asked_for(tmp_path, views, scene):
    """--soft-rounds reaches the solver (the stack's settings record it); without it, the robust preset's 2."""
    rounds = {}
    for flag in ([], ["--soft-rounds", "1"]):
        out = tmp_path / f"s{len(flag)}.exr"
        status, _, err = run_cli("solve", *views, "-o", out, "--disparities", "0:7", *flag, "-q")
        assert status == 0, err
        rounds[tuple(flag)] = exr.read_stack(out).metadata["settings"]["soft_rounds"]
    assert len(scene.views) >= 3 and rounds == {(): 2, ("--soft-rounds", "1"): 1}


def test_solve_from_dataset_json(tmp_path, views, scene):
    import json

    (tmp_path / "dataset.json").write_text(json.dumps({
        "views": [p.name for p in views], "positions": list(map(float, scene.positions)),
        "reference": scene.reference}))
    status, _, err = run_cli("solve", "--dataset", tmp_path, "-o", tmp_path / "s.exr", "--disparities", "0:7",
                             "--preset", "wta", "-q")
    assert status == 0, err
    assert exr.read_stack(tmp_path / "s.exr").camera.reference_index == scene.reference


def test_zkey_split_render_info(tmp_path, stack_file, scene):
    element = np.zeros(SHAPE + (4,), np.float32)
    element[10:30, 10:30] = [0.2, 0.2, 0.2, 1.0]
    exr.write_image(tmp_path / "el.exr", element)
    status, _, err = run_cli("zkey", stack_file, tmp_path / "el.exr", "--disparity", "4.5", "-o",
                             tmp_path / "comp.exr", "--front-out", tmp_path / "f.exr", "--back-out",
                             tmp_path / "b.exr", "--holdout-out", tmp_path / "h.exr", "-q")
    assert status == 0, err
    comp, _, _ = exr.read_image(tmp_path / "comp.exr")
    np.testing.assert_allclose(comp, composite.insert(scene.stack, element, disparity=4.5), atol=1e-6)
    front, _, _ = exr.read_image(tmp_path / "f.exr")
    back, _, _ = exr.read_image(tmp_path / "b.exr")
    np.testing.assert_allclose(composite.over(front, composite.over(element, back)), comp, atol=1e-6)
    status, _, err = run_cli("render", stack_file, "--position", "0", "-o", tmp_path / "v0.exr", "-q")
    assert status == 0, err
    v0, _, _ = exr.read_image(tmp_path / "v0.exr")
    np.testing.assert_allclose(v0[..., :3], scene.views[0], atol=1e-6)
    status, out, _ = run_cli("info", stack_file, "--json")
    assert status == 0 and '"disparity": 7.0' in out
    status, out, _ = run_cli("info", stack_file)
    assert status == 0 and "8 layers" in out


def test_png_outputs_are_display_encoded(tmp_path, stack_file, scene):
    import OpenImageIO as oiio

    status, _, err = run_cli("render", stack_file, "--position", "2", "-o", tmp_path / "v.png", "-q")
    assert status == 0, err
    png = oiio.ImageBuf(str(tmp_path / "v.png")).get_pixels(oiio.UINT8).astype(np.float64) / 255.0
    linear = scene.views[2]
    srgb = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
    np.testing.assert_allclose(png[..., :3], srgb, atol=1.0 / 255 + 1e-6)


# ---------------------------------------------------------------------------------------------------------
# Multi-view EXR plates: one file per frame holds the views


VIEW_NAMES = ["c0", "c1", "c2", "c3", "c4"]


def assert_same_solve(a: Path, b: Path):
    sa, sb = exr.read_stack(a), exr.read_stack(b)
    np.testing.assert_array_equal(sa.rgba, sb.rgba)
    np.testing.assert_array_equal(sa.plate, sb.plate)
    assert sa.disparities.tolist() == sb.disparities.tolist()
    assert sa.camera == sb.camera


@pytest.mark.parametrize("layout", ["single", "multipart"])
def test_solve_a_multi_view_sequence_equals_the_solve_from_separate_files(tmp_path, views, scene, layout,
                                                                          multiview_exr):
    """plate.####.exr with five views inside, frames 1-2: the same stacks as from five files per frame."""
    from fractions import Fraction

    import OpenEXR

    tc = OpenEXR.TimeCode()
    tc.hours, tc.frame = 1, 2
    for f in (1, 2):
        frame_views = {n: v * (0.9 + 0.05 * f) for n, v in zip(VIEW_NAMES, scene.views, strict=True)}
        multiview_exr(tmp_path / f"plate.{f:04d}.exr", frame_views, layout,
                      header={"framesPerSecond": Fraction(25, 1), "timeCode": tc})
        for k, v in enumerate(frame_views.values()):
            exr.write_image(tmp_path / f"cam{k}.{f:04d}.exr", v)
    common = ["--disparities", "0:7", "--preset", "wta", "-q"]
    status, _, err = run_cli("solve", tmp_path / "plate.####.exr", "-o", tmp_path / "mv.####.exr",
                             "--deep-out", tmp_path / "mvdeep.####.exr", *common)
    assert status == 0, err
    status, _, err = run_cli("solve", *[tmp_path / f"cam{k}.####.exr" for k in range(5)], "-o",
                             tmp_path / "sep.####.exr", *common)
    assert status == 0, err
    for f in (1, 2):
        assert_same_solve(tmp_path / f"mv.{f:04d}.exr", tmp_path / f"sep.{f:04d}.exr")
    stack = exr.read_stack(tmp_path / "mv.0002.exr")
    assert stack.metadata["source_views"] == VIEW_NAMES
    assert stack.metadata["source_files"] == [str(tmp_path / "plate.0002.exr")] * 5
    status, out, err = run_cli("info", tmp_path / "mvdeep.0002.exr", "--json")
    assert status == 0, err
    info = json.loads(out)
    assert info["kind"] == "deep" and info["samples"] == "tidy"
    assert info["exr"]["framesPerSecond"] == [25, 1] and info["exr"]["timeCode"] == "01:00:00:02"
    assert info["exr"]["views"] == VIEW_NAMES and info["exr"]["sources"] == stack.metadata["source_files"]


def test_solve_picks_views_by_name_with_positions(tmp_path, views, scene, multiview_exr):
    """--views c3,c1 with --positions 3,1 is the solve of those two files at those positions."""
    multiview_exr(tmp_path / "plate.exr", dict(zip(VIEW_NAMES, scene.views, strict=True)), "multipart")
    common = ["--disparities", "0:7", "--preset", "wta", "--positions", "3,1", "--reference", "1", "-q"]
    status, _, err = run_cli("solve", tmp_path / "plate.exr", "--views", "c3,c1", "-o", tmp_path / "mv.exr",
                             *common)
    assert status == 0, err
    status, _, err = run_cli("solve", views[3], views[1], "-o", tmp_path / "sep.exr", *common)
    assert status == 0, err
    assert_same_solve(tmp_path / "mv.exr", tmp_path / "sep.exr")
    status, out, _ = run_cli("info", tmp_path / "mv.exr", "--json")
    assert status == 0 and json.loads(out)["exr"]["views"] == ["c3", "c1"]


def test_info_describes_a_multi_view_plate(tmp_path, scene, multiview_exr):
    path = multiview_exr(tmp_path / "plate.exr", dict(zip(VIEW_NAMES[:2], scene.views[:2], strict=True)),
                         "single")
    status, out, err = run_cli("info", path)
    assert status == 0, err
    assert "multi-view EXR, 1 part, 2 views: c0 (default), c1" in out
    assert "view c1: 48x48, colour from c1.R, c1.G, c1.B" in out
    status, out, _ = run_cli("info", path, "--json")
    info = json.loads(out)
    assert info["kind"] == "plate" and [v["name"] for v in info["views"]] == ["c0", "c1"]
    assert info["parts"][0]["channels"] == ["R", "G", "B", "Z", "c1.R", "c1.G", "c1.B", "c1.Z", "tmp.Z"]
    path = multiview_exr(tmp_path / "mp.exr", dict(zip(VIEW_NAMES[:2], scene.views[:2], strict=True)),
                         "multipart")
    status, out, _ = run_cli("info", path)
    assert "2 parts, 2 views" in out and "part 1 'rgba.c1': 48x48, view c1, channels R, G, B, A" in out


def test_info_of_a_deep_file_says_how_its_samples_are(tmp_path, stack_file):
    exr.write_deep(tmp_path / "deep.exr", exr.read_stack(stack_file))
    status, out, err = run_cli("info", tmp_path / "deep.exr")
    assert status == 0, err
    assert "deep scanline EXR, 48x48, 8 layers" in out
    assert cli.DEEP_STATE_NOTE in out


# ---------------------------------------------------------------------------------------------------------
# Bad input: one clear line on stderr, exit status 2, no output created or clobbered


def _bad_cases(tmp: Path, views: list[Path], stack_file: Path, write_multiview_exr):
    """(name, argv, expected words in the message); every case writes to tmp/'out.exr'."""
    out = tmp / "out.exr"
    small = tmp / "small.exr"
    exr.write_image(small, np.zeros((20, 30, 3), np.float32))
    nan_view = tmp / "nan.exr"
    img = np.full(SHAPE + (3,), 0.5, np.float32)
    img[3, 4, 1] = np.nan
    exr.write_image(nan_view, img)
    inf_view = tmp / "inf.exr"
    img[3, 4, 1] = np.inf
    exr.write_image(inf_view, img)
    truncated = tmp / "trunc.exr"
    truncated.write_bytes(views[0].read_bytes()[:300])
    plain = tmp / "plain.exr"
    exr.write_image(plain, np.zeros(SHAPE + (4,), np.float32))
    wrong_element = tmp / "el_small.exr"
    exr.write_image(wrong_element, np.zeros((10, 12, 4), np.float32))
    a_file = tmp / "not_a_folder"
    a_file.write_text("x")
    v = [str(p) for p in views]
    plain_views = {"left": np.zeros(SHAPE + (3,), np.float32), "right": np.ones(SHAPE + (3,), np.float32)}
    stereo = write_multiview_exr(tmp / "stereo.exr", plain_views, "multipart")
    odd = write_multiview_exr(tmp / "odd.exr", {**plain_views, "right": np.ones((40, 48, 3), np.float32)},
                              "multipart")
    return [
        ("missing view", ["solve", v[0], str(tmp / "nope.exr"), *v[2:], "-o", out], ["not found", "nope.exr"]),
        ("different sizes", ["solve", *v[:2], str(small), "-o", out], ["size"]),
        ("one view", ["solve", v[0], "-o", out], ["at least two"]),
        ("truncated view", ["solve", *v[:2], str(truncated), "-o", out], ["trunc.exr"]),
        ("nan in plate", ["solve", *v[:2], str(nan_view), "-o", out], ["nan.exr"]),
        ("inf in plate", ["solve", *v[:2], str(inf_view), "-o", out], ["inf.exr"]),
        ("not a stack", ["zkey", str(plain), str(plain), "--disparity", "1", "-o", out], ["plain.exr"]),
        ("truncated stack", ["info", str(truncated)], ["trunc.exr"]),
        ("min >= max", ["solve", *v, "-o", out, "--disparities", "5:5"], ["MIN", "MAX"]),
        # 99,901 planes of 48 x 48 with the paper's volumes: about 50 GiB (the robust preset's 19 GiB is too
        # close to what a 24 GiB machine has free to refuse every time; tests/test_solver.py checks its estimate)
        ("too many planes", ["solve", *v, "-o", out, "--disparities", "0:999:0.01", "--preset", "paper"],
         ["GiB"]),
        ("element size", ["zkey", str(stack_file), str(wrong_element), "--disparity", "1", "-o", out],
         ["12x10", "48x48"]),
        ("unwritable folder", ["solve", *v, "-o", str(a_file / "out.exr")], ["folder"]),
        ("pattern without files", ["solve", str(tmp / "cam0.####.exr"), str(tmp / "cam1.####.exr"),
                                   "-o", str(tmp / "s.####.exr")], ["no files", "cam0.####.exr"]),
        ("unknown view", ["solve", str(stereo), "--views", "left,centre", "-o", out],
         ["no view 'centre'", "left, right"]),
        ("views of different sizes", ["solve", str(odd), "-o", out], ["48x40", "48x48", "left, right"]),
        ("one view of a plate", ["solve", str(stereo), "--views", "right", "-o", out], ["at least 2", "left, right"]),
        ("views with several files", ["solve", *v[:2], "--views", "left,right", "-o", out], ["one multi-view"]),
        ("views of a plain file", ["solve", v[0], "--views", "left,right", "-o", out],
         ["not a multi-view", "none"]),
        ("positions for the views", ["solve", str(stereo), "--positions", "0,1,2", "-o", out],
         ["2 views need 2 positions"]),
        ("no soft rounds", ["solve", *v, "-o", out, "--soft-rounds", "0"], ["--soft-rounds", "1 or more"]),
    ]


CASE_NAMES = ["missing view", "different sizes", "one view", "truncated view", "nan in plate", "inf in plate",
              "not a stack", "truncated stack", "min >= max", "too many planes", "element size",
              "unwritable folder", "pattern without files", "unknown view", "views of different sizes",
              "one view of a plate", "views with several files", "views of a plain file",
              "positions for the views", "no soft rounds"]


@pytest.mark.parametrize("case", CASE_NAMES)
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, views, stack_file, case, multiview_exr):
    cases = {name: (argv, words) for name, argv, words in _bad_cases(tmp_path, views, stack_file, multiview_exr)}
    argv, words = cases[case]
    before = files_in(tmp_path)
    status, out, err = run_cli(*argv)
    assert status == 2, (case, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("vfxstereo: error: ")
    assert "Traceback" not in err
    for w in words:
        assert w.lower() in lines[0].lower(), (case, lines[0])
    assert files_in(tmp_path) == before  # nothing created, no temporary file left


def test_failed_command_does_not_clobber_an_existing_output(tmp_path, views):
    out = tmp_path / "keep.exr"
    out.write_bytes(b"precious")
    status, _, err = run_cli("solve", str(views[0]), str(tmp_path / "missing.exr"), "-o", out)
    assert status == 2
    assert out.read_bytes() == b"precious"


# ---------------------------------------------------------------------------------------------------------
# Frame sequences


def test_sequence_interrupted_then_resumed(tmp_path, scene, monkeypatch, plate_sequence):
    """Ctrl-C on frame 2 of 3: frame 1 stays intact, nothing partial is left; a rerun does frames 2-3 only."""
    from vfxstereo import solver

    patterns = plate_sequence(tmp_path, scene.views, [1, 2, 3])
    out = str(tmp_path / "out" / "stack.####.exr")
    (tmp_path / "out").mkdir()
    argv = ["solve", *patterns, "-o", out, "--frames", "1-3", "--disparities", "0:7", "--preset", "wta", "-q"]
    real_solve = solver.solve
    calls = []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real_solve(*args, **kwargs)

    monkeypatch.setattr(solver, "solve", interrupted)
    assert cli.main(argv) == 130
    assert files_in(tmp_path / "out") == {"stack.0001.exr"}
    first = tmp_path / "out" / "stack.0001.exr"
    mtime = first.stat().st_mtime_ns
    assert exr.read_stack(first).depth == 8

    monkeypatch.setattr(solver, "solve", real_solve)
    calls.clear()
    assert cli.main(argv) == 0
    assert files_in(tmp_path / "out") == {"stack.0001.exr", "stack.0002.exr", "stack.0003.exr"}
    assert first.stat().st_mtime_ns == mtime  # the finished frame was not redone
    s2 = exr.read_stack(tmp_path / "out" / "stack.0002.exr")
    assert s2.metadata["frame"] == 2
    # --overwrite redoes everything
    assert cli.main(argv + ["--overwrite"]) == 0
    assert first.stat().st_mtime_ns != mtime


def test_sequence_in_parallel_jobs_and_steps(tmp_path, scene, plate_sequence):
    patterns = plate_sequence(tmp_path, scene.views, [1001, 1002, 1003])
    out = tmp_path / "s.%04d.exr"
    status, _, err = run_cli("solve", *patterns, "-o", out, "--frames", "1001-1003x2", "--jobs", "2",
                             "--disparities", "0:7", "--preset", "wta", "-q")
    assert status == 0, err
    assert sorted(p.name for p in tmp_path.glob("s.*.exr")) == ["s.1001.exr", "s.1003.exr"]


def test_sigint_during_a_sequence_leaves_only_whole_files(tmp_path, scene, plate_sequence):
    patterns = plate_sequence(tmp_path, scene.views, list(range(1, 7)))
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "vfxstereo.cli", "solve", *patterns, "-o",
                             str(out_dir / "s.####.exr"), "--disparities", "0:7", "--preset", "paper", "-q"],
                            stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not list(out_dir.glob("s.*.exr")) and proc.poll() is None:
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode in (0, 130), err
    assert "Traceback" not in err
    finished = sorted(out_dir.iterdir())
    assert finished, "no frame finished before the interrupt"
    for p in finished:
        assert p.name.startswith("s.") and p.suffix == ".exr" and ".tmp" not in p.name
        assert exr.read_stack(p).depth == 8
    # one job solves the frames in order: what is there is the first n of them (listdir's order is the file
    # system's, so compare sorted; on a loaded machine all six may finish before the interrupt arrives)
    assert sorted(os.listdir(out_dir)) == [f"s.{n:04d}.exr" for n in range(1, len(finished) + 1)]


def test_interrupt_inside_a_numba_kernel_is_still_an_interrupt(tmp_path, views, monkeypatch):
    """numba turns Ctrl-C inside a kernel into a SystemError caused by the KeyboardInterrupt: still exit 130."""
    from vfxstereo import solver

    def interrupted_in_kernel(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("CPUDispatcher(...) returned a result with an exception set") from exc

    monkeypatch.setattr(solver, "solve", interrupted_in_kernel)
    out = tmp_path / "s.exr"
    assert cli.main(["solve", *map(str, views), "-o", str(out), "--disparities", "0:7", "-q"]) == 130
    assert not out.exists()
    monkeypatch.setattr(solver, "solve", lambda *a, **k: (_ for _ in ()).throw(SystemError("a real bug")))
    with pytest.raises(SystemError, match="a real bug"):
        cli.main(["solve", *map(str, views), "-o", str(out), "--disparities", "0:7", "-q"])
