"""The extension's manifest bundles the versions the Blender environment is tested with (no bpy needed)."""

import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _pins(path):
    pins = {}
    for line in (REPO / path).read_text().splitlines():
        line = line.split("#")[0].strip()
        if "==" in line:
            name, version = line.split("==")
            pins[name.strip().lower().replace("_", "-")] = version.strip()
    return pins


def test_bundled_wheels_are_the_versions_the_blender_environment_pins():
    manifest = tomllib.loads((REPO / "blender_addon" / "blender_manifest.toml").read_text())
    bundled = {Path(w).name.split("-")[0].lower().replace("_", "-"): Path(w).name.split("-")[1]
               for w in manifest["wheels"]}
    pins = _pins("requirements/blender.txt")
    assert "numpy" not in bundled  # Blender's own numpy is used, never replaced
    for name in ("scipy", "numba", "openimageio"):
        assert bundled[name] == pins[name], name
    assert bundled["vfxstereo"] == tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    assert manifest["version"] == bundled["vfxstereo"]
    for wheel in manifest["wheels"]:
        name = Path(wheel).name
        assert name.endswith("-py3-none-any.whl") or "-cp311-cp311-manylinux" in name, name
    assert manifest["platforms"] == ["linux-x64"]


def test_manifest_fields_blender_requires():
    manifest = tomllib.loads((REPO / "blender_addon" / "blender_manifest.toml").read_text())
    assert manifest["schema_version"] == "1.0.0" and manifest["type"] == "add-on"
    assert manifest["license"] == ["SPDX:GPL-3.0-or-later"]
    assert tuple(int(x) for x in manifest["blender_version_min"].split(".")) >= (5, 0, 0)
    assert all(len(reason) <= 64 and not reason.endswith(".") for reason in manifest["permissions"].values())
