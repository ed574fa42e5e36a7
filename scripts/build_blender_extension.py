"""Build the installable Blender extension zip (``make blender-extension``).

Stages ``blender_addon/`` with ``nodes/`` inside it and the wheels its manifest lists, then runs Blender's
own extension builder (``blender_ext.py build``, shipped inside bpy), which checks the manifest and writes
the zip. The manifest's ``wheels = [...]`` is the one list of what is bundled: each third-party wheel is
downloaded by exactly the name and version in its file name for CPython 3.11 on manylinux x86-64 (kept in a
cache folder, so later builds need no network), and the vfxstereo wheel is built from this checkout.

Run it with the Blender environment's Python (it needs pip and bpy's blender_ext.py)::

    .venv-blender/bin/python scripts/build_blender_extension.py [--output dist/vfxstereo-0.1.0-linux_x64.zip]
"""

from __future__ import annotations

import argparse
import importlib.util
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MANIFEST = REPO / "blender_addon" / "blender_manifest.toml"
PLATFORM_ARGS = ["--platform", "manylinux_2_28_x86_64", "--python-version", "3.11", "--implementation", "cp",
                 "--abi", "cp311", "--only-binary=:all:"]


def fail(message: str) -> None:
    """One line on stderr, exit status 2."""
    print(f"build_blender_extension: error: {message}", file=sys.stderr)
    sys.exit(2)


def default_output(manifest: dict) -> Path:
    """``dist/<id>-<version>-<platform>.zip``, Blender's name for a single-platform package."""
    platform = "-".join(p.replace("-", "_") for p in manifest.get("platforms", []))
    return REPO / "dist" / f"{manifest['id']}-{manifest['version']}{'-' + platform if platform else ''}.zip"


def blender_ext_script() -> Path:
    """Blender's extension command-line tool inside the bpy package."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        fail("bpy is not installed in this Python: run with .venv-blender/bin/python")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        fail(f"blender_ext.py not found inside bpy at {Path(spec.origin).parent}")
    return found[-1]


def wheel_requirement(filename: str) -> str:
    """``name==version`` from a wheel file name (PEP 427: ``{name}-{version}-...whl``)."""
    name, version = filename.split("-")[:2]
    return f"{name}=={version}"


def fetch_wheel(filename: str, cache: Path) -> Path:
    """The wheel ``filename`` from the cache, downloading it with pip if it is not there yet."""
    path = cache / filename
    if not path.exists():
        cache.mkdir(parents=True, exist_ok=True)
        subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps", *PLATFORM_ARGS, "-d",
                        str(cache), wheel_requirement(filename)], check=True)
    if not path.exists():
        got = sorted(p.name for p in cache.glob(filename.split("-")[0] + "-*.whl"))
        fail(f"pip did not fetch {filename} (the manifest's name); found {got}")
    return path


def build_vfxstereo_wheel(filename: str, into: Path) -> None:
    """Build vfxstereo's wheel from this checkout; its name must be the manifest's."""
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(into), str(REPO)],
                   check=True)
    if not (into / filename).exists():
        fail(f"the vfxstereo wheel is not {filename}: the manifest's version and pyproject.toml's differ")


def main(argv: list[str] | None = None) -> int:
    """Stage and build; print the zip's path and size."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=Path, help="the zip to write (default: dist/<id>-<version>-<platform>.zip)")
    parser.add_argument("--wheel-cache", type=Path, default=REPO / "dist" / "wheel-cache",
                        help="folder of downloaded wheels, reused between builds")
    args = parser.parse_args(argv)
    manifest = tomllib.loads(MANIFEST.read_text())
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    if manifest["version"] != project["version"]:
        fail(f"the manifest's version {manifest['version']} is not pyproject.toml's {project['version']}")
    output = (args.output or default_output(manifest)).resolve()
    stage = output.parent / f"{output.stem}-staging"
    shutil.rmtree(stage, ignore_errors=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(REPO / "blender_addon", stage, ignore=ignore)
    shutil.copytree(REPO / "nodes", stage / "nodes", ignore=ignore)
    wheels = stage / "wheels"
    wheels.mkdir()
    for entry in manifest.get("wheels", []):
        filename = Path(entry).name
        if filename.startswith("vfxstereo-"):
            build_vfxstereo_wheel(filename, wheels)
        else:
            shutil.copy2(fetch_wheel(filename, args.wheel_cache), wheels / filename)
    output.unlink(missing_ok=True)
    built = subprocess.run([sys.executable, str(blender_ext_script()), "build", "--source-dir", str(stage),
                            "--output-filepath", str(output)], capture_output=True, text=True)
    if built.returncode != 0:
        fail(f"Blender's extension builder refused the package: {' '.join(built.stdout.split())}")
    shutil.rmtree(stage)
    print(f"{output} ({output.stat().st_size / 1e6:.1f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
