"""Blender tests need bpy: they run in .venv-blender (make test-blender) and are left out elsewhere."""

import importlib.util

if importlib.util.find_spec("bpy") is None:
    collect_ignore_glob = ["test_*.py"]
