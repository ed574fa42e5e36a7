"""Shared fixtures. bpy must never write to the user's config or cache: point both at a temp folder first."""

import os
import tempfile
from pathlib import Path

_BL_TMP = tempfile.mkdtemp(prefix="vfxstereo-bl-")
os.environ.setdefault("BLENDER_USER_RESOURCES", os.path.join(_BL_TMP, "user"))
os.environ.setdefault("XDG_CACHE_HOME", os.path.join(_BL_TMP, "cache"))

import numpy as np  # noqa: E402
import pytest  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = (REPO / ".." / "shared" / "data").resolve()


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` beside the repository (CI has it there too)."""
    if not (SHARED_DATA / "README.md").exists():
        pytest.fail(f"shared data not found at {SHARED_DATA}")
    return SHARED_DATA


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1999)
