"""Whole shots: planning per-frame jobs, farm chunks, retries, and the same frames on a Dask cluster."""

import faulthandler
import logging
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from vfxstereo import cli, samples, shot, tasks
from vfxstereo.errors import VfxStereoError
from vfxstereo.io import exr

FRAMES = [1001, 1002, 1003, 1004]
COMMON = ["--disparities", "0:7", "--preset", "wta", "-q"]
DEADLINE = 300
"""Seconds this module may take in all; past it the process dumps its threads and exits, so CI cannot hang."""


@pytest.fixture(scope="module", autouse=True)
def watchdog():
    faulthandler.dump_traceback_later(DEADLINE, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


@pytest.fixture(scope="module")
def scene():
    return samples.random_dot_stereogram(shape=(48, 48), seed=5)


@pytest.fixture(scope="module")
def cluster():
    """A Dask LocalCluster of 2 single-threaded worker processes, shared by the tests of this module."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.CRITICAL) as c:
        yield c


def run_cli(*args, env=None):
    proc = subprocess.run([sys.executable, "-m", "vfxstereo", *map(str, args)], capture_output=True, text=True,
                          timeout=120, env=None if env is None else {**os.environ, **env})
    return proc.returncode, proc.stdout, proc.stderr


def files_in(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


def without_capture_date(data: bytes) -> bytes:
    """An EXR file's bytes with the value of the ``capDate`` attribute (OpenImageIO's write time) zeroed."""
    key = b"capDate\0string\0"
    at = data.find(key)
    if at < 0:
        return data
    start = at + len(key) + 4
    size = int.from_bytes(data[at + len(key):start], "little")
    return data[:start] + bytes(size) + data[start + size:]


# ---------------------------------------------------------------------------------------------------------
# The same shot, serially and on a cluster


def test_a_shot_on_a_dask_cluster_equals_the_serial_run(tmp_path, scene, plate_sequence, cluster):
    """Four frames through a LocalCluster of two workers: every output file is the serial run's, byte for byte
    (but for the write time OpenImageIO stamps in capDate)."""
    patterns = plate_sequence(tmp_path, scene.views, FRAMES)
    for name, how in [("serial", []), ("dask", ["--scheduler", cluster.scheduler_address])]:
        out = tmp_path / name
        out.mkdir()
        assert cli.main(["solve", *patterns, "-o", str(out / "s.####.exr"), "--disparity-out",
                         str(out / "d.####.exr"), "--deep-out", str(out / "deep.####.exr"), *COMMON, *how]) == 0
    names = {f"{kind}.{f}.exr" for kind in ("s", "d", "deep") for f in FRAMES}
    assert files_in(tmp_path / "serial") == names == files_in(tmp_path / "dask")
    for name in sorted(names):
        serial, dask = ((tmp_path / run / name).read_bytes() for run in ("serial", "dask"))
        assert without_capture_date(serial) == without_capture_date(dask), name
    # and the frames are different pictures, each solved from its own plates
    stacks = [exr.read_stack(tmp_path / "dask" / f"s.{f}.exr") for f in FRAMES]
    assert [s.metadata["frame"] for s in stacks] == FRAMES
    assert [s.metadata["source_files"][2] for s in stacks] == [str(tmp_path / f"cam2.{f}.exr") for f in FRAMES]
    assert not np.array_equal(stacks[0].plate, stacks[1].plate)


@dataclass(frozen=True)
class FlakyOnce:
    """The solve task, but the first attempt at frame 1003 fails (a file server hiccup); notes every attempt."""

    solve: tasks.SolveTask
    notes: str

    def __call__(self, job, progress=None):
        attempt = len(list(Path(self.notes).glob(f"{job.frame}.*")))
        (Path(self.notes) / f"{job.frame}.{attempt}").touch()
        if job.frame == 1003 and attempt == 0:
            raise OSError("the file server went away")
        self.solve(job, progress)


@pytest.mark.parametrize("where", ["here", "dask"])
def test_a_failed_frame_is_tried_again_after_the_others(tmp_path, scene, plate_sequence, cluster, where):
    import cloudpickle

    patterns = plate_sequence(tmp_path, scene.views, FRAMES)
    notes = tmp_path / "notes"
    notes.mkdir()
    task = FlakyOnce(tasks.SolveTask(preset="wta", disparities=np.arange(8.0)), str(notes))
    jobs = shot.plan_jobs({"views": patterns}, {"stack": str(tmp_path / "s.####.exr")})
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the workers cannot import this test module
    try:
        report = shot.run_jobs(jobs, task, scheduler=cluster.scheduler_address if where == "dask" else None,
                               retries=1, quiet=True)
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    assert report.failed == []
    assert sorted(report.done) == FRAMES
    if where == "here":
        assert report.done == [1001, 1002, 1004, 1003]  # the retry waits behind the frames queued before it
    assert sorted(p.name for p in notes.iterdir()) == ["1001.0", "1002.0", "1003.0", "1003.1", "1004.0"]
    assert [exr.read_stack(tmp_path / f"s.{f}.exr").metadata["frame"] for f in FRAMES] == FRAMES


def test_without_retries_a_failure_is_reported_with_its_traceback(tmp_path, scene, plate_sequence):
    patterns = plate_sequence(tmp_path, scene.views, FRAMES)
    (tmp_path / "notes").mkdir()
    task = FlakyOnce(tasks.SolveTask(preset="wta", disparities=np.arange(8.0)), str(tmp_path / "notes"))
    jobs = shot.plan_jobs({"views": patterns}, {"stack": str(tmp_path / "s.####.exr")})
    report = shot.run_jobs(jobs, task, retries=0, quiet=True)
    assert report.done == [1001, 1002, 1004]
    [failure] = report.failed
    assert (failure.frame, failure.error, failure.attempts) == (1003, "OSError: the file server went away", 1)
    assert "Traceback" in failure.details and "test_shot.py" in failure.details
    assert not (tmp_path / "s.1003.exr").exists()


@pytest.mark.parametrize("how", [[], ["--jobs", "2"], ["--scheduler", "local", "--jobs", "2"]],
                         ids=["serial", "processes", "dask-local"])
def test_a_corrupt_plate_fails_its_frame_only_and_a_rerun_finishes_the_shot(tmp_path, scene, plate_sequence, how):
    patterns = plate_sequence(tmp_path, scene.views, FRAMES)
    bad = tmp_path / "cam2.1003.exr"
    good = bad.read_bytes()
    bad.write_bytes(good[:300])
    out = tmp_path / "out"
    out.mkdir()
    argv = ["solve", *patterns, "-o", out / "s.####.exr", *COMMON, "--retries", "2"]
    status, _, err = run_cli(*argv, *how)
    assert status == 1, err
    assert files_in(out) == {"s.1001.exr", "s.1002.exr", "s.1004.exr"}  # no frame 1003, no temporary file
    assert re.findall(r"frame 1003 failed \(attempt (\d) of 3\)", err) == ["1", "2", "3"]
    assert "giving up" in err and "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("vfxstereo: error: 1 of 4 frames failed (1003; tried 3 times each), the others are "
                           "written. Frame 1003: cannot read ")
    assert "cam2.1003.exr" in last
    mtimes = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}

    bad.write_bytes(good)  # repaired: the same command does frame 1003 and nothing else
    status, _, err = run_cli(*argv)
    assert status == 0, err
    assert files_in(out) == {f"s.{f}.exr" for f in FRAMES}
    assert {name: (out / name).stat().st_mtime_ns for name in mtimes} == mtimes
    assert exr.read_stack(out / "s.1003.exr").metadata["frame"] == 1003


def test_bad_input_stops_before_a_cluster_starts(tmp_path, scene, plate_sequence):
    patterns = plate_sequence(tmp_path, scene.views, FRAMES)
    status, _, err = run_cli("solve", *patterns, "-o", tmp_path / "s.####.exr", *COMMON, "--positions", "0,1",
                             "--scheduler", "local")
    assert status == 2
    assert err.strip().splitlines() == ["vfxstereo: error: 5 views need 5 positions, --positions gave 2"]
    assert not list(tmp_path.glob("s.*"))


def test_an_unreachable_scheduler_is_one_line_and_exit_2(tmp_path, scene, plate_sequence):
    patterns = plate_sequence(tmp_path, scene.views, FRAMES[:1])
    status, _, err = run_cli("solve", *patterns, "-o", tmp_path / "s.####.exr", *COMMON, "--scheduler",
                             "tcp://127.0.0.1:9", env={"DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "1s"})
    assert status == 2
    [line] = err.strip().splitlines()
    assert line.startswith("vfxstereo: error: cannot reach the Dask scheduler at tcp://127.0.0.1:9")
    assert not list(tmp_path.glob("s.*"))


# ---------------------------------------------------------------------------------------------------------
# Farm chunks


@pytest.mark.parametrize(("frames", "size", "index", "expected"), [
    ("1001-1010", 3, 0, [1001, 1002, 1003]),
    ("1001-1010", 3, 2, [1007, 1008, 1009]),
    ("1001-1010", 3, 3, [1010]),  # the last chunk is short
    ("1001-1010x2", 2, 1, [1005, 1007]),  # chunks count frames of the list, not frame numbers
    ("1,5,10-12", 2, 2, [12]),
])
def test_a_chunk_is_its_run_of_the_frame_list(tmp_path, frames, size, index, expected):
    for f in range(1, 13):
        (tmp_path / f"p.{f:04d}.exr").touch()
    for f in range(1001, 1011):
        (tmp_path / f"p.{f:04d}.exr").touch()
    jobs = shot.plan_jobs({"views": [str(tmp_path / "p.####.exr")]}, {"stack": str(tmp_path / "s.####.exr")},
                          frames=frames, chunk=(size, index))
    assert [j.frame for j in jobs] == expected
    assert [j.inputs["views"] for j in jobs] == [[str(tmp_path / f"p.{f:04d}.exr")] for f in expected]


@pytest.mark.parametrize("size", [1, 3, 4, 7, 11])
def test_the_chunks_of_a_shot_cover_every_frame_once(size):
    frames = list(range(1001, 1011))
    n = -(-len(frames) // size)
    chunks = [shot.chunk_frames(frames, size, i) for i in range(n)]
    assert [f for chunk in chunks for f in chunk] == frames
    assert all(len(c) == size for c in chunks[:-1]) and 1 <= len(chunks[-1]) <= size


def test_chunk_errors():
    with pytest.raises(VfxStereoError, match="at least 1"):
        shot.chunk_frames([1, 2, 3], 0, 0)
    with pytest.raises(VfxStereoError, match=r"--chunk-index 2 is outside the 2 chunks \(0..1\) of 3 frames"):
        shot.chunk_frames([1, 2, 3], 2, 2)


def test_a_farm_task_runs_its_chunk_only(tmp_path, scene, plate_sequence):
    """A farm task with chunk 1 of size 3 writes frame 1004, and does not need the plates of other chunks."""
    patterns = plate_sequence(tmp_path, scene.views, FRAMES)
    for k in range(5):
        (tmp_path / f"cam{k}.1001.exr").unlink()
    out = tmp_path / "out"
    out.mkdir()
    argv = ["solve", *patterns, "-o", str(out / "s.####.exr"), *COMMON, "--frames", "1001-1004"]
    assert cli.main(argv + ["--chunk-size", "3", "--chunk-index", "1"]) == 0
    assert files_in(out) == {"s.1004.exr"}
    assert cli.main(argv + ["--chunk-size", "3", "--chunk-index", "0"]) == 2  # its frame 1001 is missing
    assert cli.main(argv + ["--chunk-size", "3"]) == 2
    assert cli.main(argv + ["--chunk-size", "3", "--chunk-index", "2"]) == 2
    assert files_in(out) == {"s.1004.exr"}
