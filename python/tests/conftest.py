"""Shared fixtures of the Python module's tests: the command line, and small fast scenes."""
import copy
import os
import pathlib

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("RAYCLOTH_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
CLI = os.environ.get("RAYCLOTH_CLI", str(SOURCE_DIR / "build" / "raycloth"))

# A 15 x 15 cloth (3 cm apart) dropped on a sphere that slides sideways from t = 0.1 s: 0.2 s at
# 30 frames per second, 500 steps; a moving obstacle, so that obstacle frames are written too.
SMALL = {
    "name": "small_moving_sphere",
    "time": {"dt": 0.0004, "duration": 0.2, "fps": 30},
    "gravity": [0, -9.81, 0],
    "collision": {"tolerance": 0.005, "thickness": 0.002, "friction": 0.6, "cloth_cloth": True},
    "materials": [{"name": "cotton", "density": 0.2, "stretch": 200, "shear": 40, "bend": 4, "damping": 1.0}],
    "panels": [{"name": "cloth", "material": "cotton", "size": [0.42, 0.42], "resolution": [15, 15],
                "position": [0, 0.43, 0]}],
    "obstacles": [{"name": "sphere", "type": "uv_sphere", "radius": 0.4, "slices": 24, "stacks": 25,
                   "position": [0, 0, 0],
                   "motion": {"velocity": [0.5, 0, 0], "angular_velocity": [0, 0, 0], "start": 0.1}}],
}


@pytest.fixture
def small_scene():
    """The small scene as a dict (a fresh copy per test)."""
    return copy.deepcopy(SMALL)


@pytest.fixture
def cli():
    if not os.path.exists(CLI):
        pytest.skip(f"the command line is not built ({CLI})")
    return CLI
