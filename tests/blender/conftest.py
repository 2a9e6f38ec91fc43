"""Blender (the bpy module) with the Glint add-on registered, for tests.

The add-on is imported as the package `glint` from a temporary folder that
links to the repository's addon/. The glint executable is the one Cargo
built (GLINT_EXECUTABLE, set by tests/run-all; target/debug/glint if unset).

A bpy process that has rendered through a Python RenderEngine deadlocks in
bpy's exit handlers, so the session leaves through os._exit with pytest's
status once pytest has reported.
"""

import os
import sys
import tempfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
ADDON = REPO / "addon"

os.environ.setdefault("GLINT_EXECUTABLE", str(REPO / "target" / "debug" / "glint"))
_addons = tempfile.mkdtemp(prefix="glint-addon-path-")
os.symlink(ADDON, os.path.join(_addons, "glint"))
sys.path.insert(0, _addons)

import bpy  # noqa: E402

import glint  # noqa: E402
from helpers import new_empty_scene  # noqa: E402

glint.register()

_exit_status = 0


def pytest_sessionfinish(session, exitstatus):
    global _exit_status
    _exit_status = int(exitstatus)


def pytest_unconfigure(config):
    glint.unregister()  # stops the daemon and removes its job folder
    os.unlink(os.path.join(_addons, "glint"))
    os.rmdir(_addons)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(_exit_status)


@pytest.fixture
def executable():
    path = os.environ["GLINT_EXECUTABLE"]
    assert os.path.isfile(path), f"build glint first: {path} is missing"
    return path


@pytest.fixture
def empty_scene():
    return new_empty_scene()
