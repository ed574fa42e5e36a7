import pytest

bpy = pytest.importorskip("bpy", reason="Blender tests run in .venv-blender (make test-blender)")
