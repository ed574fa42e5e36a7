"""benchmarks/cycles_scenes.py: the Cycles rig follows the house convention, and comp == plate off the element.

One tiny scene (96x54, 8 spp, a few seconds): an emission-textured fronto-parallel plane at known depth Z must
appear at column x - f*B/Z*(k - 2) of view k (to 0.1 px, measured by sub-pixel matching), and the ground-truth
comp must equal the plate bit for bit wherever the element's alpha is zero.
"""

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
ndimage = pytest.importorskip("scipy.ndimage")
oiio = pytest.importorskip("OpenImageIO")

pytestmark = pytest.mark.blender

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "cycles_scenes.py"
W, H = 96, 54
PLANE_Z = 3.0  # scene_plane_check's textured plane
PLANE_COLS = slice(6, 33)  # inside the plane in every view (it covers x < 40.8 of the reference, shifts <= 3.2 px)
PLANE_ROWS = slice(8, 46)


@pytest.fixture(scope="module")
def cycles_scenes():
    spec = importlib.util.spec_from_file_location("cycles_scenes", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)


@pytest.fixture(scope="module")
def rendered(cycles_scenes, tmp_path_factory):
    out = tmp_path_factory.mktemp("cycles")
    info = cycles_scenes.render_scene("plane_check", out, W, H, samples=8, log=lambda *a: None)
    yield out / "plane_check", info
    cycles_scenes.reset()


def read(path) -> tuple[np.ndarray, tuple]:
    buf = oiio.ImageBuf(str(path))
    pixels = buf.get_pixels(oiio.FLOAT)
    assert pixels is not None, buf.geterror()
    return pixels, tuple(buf.spec().channelnames)


def luminance(rgb):
    return rgb[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def best_shift(view, ref, axis, start, span, step):
    """The shift s (px) minimising the SSD of view(x) against ref(x + s) along ``axis`` over the plane window."""
    cand = np.arange(start - span, start + span + step / 2, step)
    costs = []
    for s in cand:
        shift = [0.0, 0.0]
        shift[axis] = -s  # ndimage.shift(a, -s)[x] = a[x + s]
        moved = ndimage.shift(ref, shift, order=3, mode="nearest")
        costs.append(float(np.sum((view - moved)[PLANE_ROWS, PLANE_COLS] ** 2)))
    i = int(np.argmin(costs))
    if 0 < i < len(cand) - 1:  # parabola through the three best
        c0, c1, c2 = costs[i - 1], costs[i], costs[i + 1]
        den = c0 - 2 * c1 + c2
        return float(cand[i] + (0.5 * (c0 - c2) / den * step if den > 0 else 0.0))
    return float(cand[i])


def test_scene_json_geometry(rendered, cycles_scenes):
    folder, info = rendered
    on_disk = json.loads((folder / "scene.json").read_text())
    assert on_disk["positions"] == [0, 1, 2, 3, 4] and on_disk["reference"] == 2
    f, B = on_disk["focal_px"], on_disk["baseline"]
    assert f == pytest.approx(W * 35.0 / 36.0)
    assert on_disk["element"]["disparity"] == pytest.approx(f * B / on_disk["element"]["depth"])
    assert len(on_disk["planes"]) >= 16
    lo, hi = on_disk["disparity_range"]
    assert on_disk["planes"][0] <= lo and on_disk["planes"][-1] >= hi
    for name in ["view0", "view1", "view2", "view3", "view4", "comp", "element", "disparity"]:
        assert (folder / f"{name}.exr").is_file()
    disparity, names = read(folder / "disparity.exr")
    assert names == ("Y", "Z")
    # the depth pass of a fronto-parallel plane is exact: d = f*B/Z on the plane
    assert np.allclose(disparity[PLANE_ROWS, PLANE_COLS, 0], f * B / PLANE_Z, atol=1e-4)


def test_views_shift_by_disparity_times_position(rendered):
    folder, info = rendered
    d = info["focal_px"] * info["baseline"] / PLANE_Z
    ref = luminance(read(folder / "view2.exr")[0])
    for k in [0, 1, 3, 4]:
        view = luminance(read(folder / f"view{k}.exr")[0])
        expected = d * (k - 2)  # view_k(x) = ref(x + d*(k - 2)): the point at x of the reference is at x - d*(k-2)
        coarse = best_shift(view, ref, axis=1, start=0.0, span=6.0, step=0.25)
        sx = best_shift(view, ref, axis=1, start=coarse, span=0.3, step=0.02)
        assert sx == pytest.approx(expected, abs=0.1), (k, sx, expected)
        # rectified: no vertical shift
        moved = ndimage.shift(ref, [0.0, -sx], order=3, mode="nearest")
        sy = best_shift(view, moved, axis=0, start=0.0, span=0.3, step=0.02)
        assert abs(sy) < 0.1, (k, sy)


def test_comp_equals_plate_outside_the_element(rendered):
    folder, info = rendered
    plate = read(folder / "view2.exr")[0]
    comp = read(folder / "comp.exr")[0]
    element, names = read(folder / "element.exr")
    assert names == ("R", "G", "B", "A", "Z")
    alpha = element[..., 3]
    outside = alpha == 0
    assert outside.sum() > 0.5 * alpha.size and (alpha == 1).sum() > 100
    assert np.array_equal(comp[outside], plate[outside])
    assert info["comp_vs_plate"]["max_abs_outside_element"] == 0.0
    # where the element covers the pixel fully (and nothing is in front), the comp is the element
    full = alpha == 1
    assert np.allclose(comp[full], element[full][:, :3], atol=2e-3)
    assert np.allclose(element[full][:, 4], 2.0, rtol=1e-5)  # scene_plane_check's card is at Z = 2
    assert np.all(element[..., :3] <= alpha[..., None] + 1e-3)  # premultiplied
