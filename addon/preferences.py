"""Where the glint executable is."""

import os
import shutil
from pathlib import Path

import bpy

ENV_VAR = "GLINT_EXECUTABLE"


class GlintPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    executable: bpy.props.StringProperty(
        name="Glint executable",
        description=f"Path to the glint program. Empty: ${ENV_VAR}, else glint on PATH, "
        "else target/release/glint beside this add-on's folder",
        subtype="FILE_PATH",
        default="",
    )

    def draw(self, context):
        self.layout.prop(self, "executable")
        try:
            self.layout.label(text=f"Using: {find_executable(self.executable)}")
        except ExecutableNotFound as e:
            self.layout.label(text=str(e), icon="ERROR")


def preferences():
    addon = bpy.context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


class ExecutableNotFound(Exception):
    pass


def _usable(path):
    return path.is_file() and os.access(path, os.X_OK)


def find_executable(configured=""):
    """The glint program to run. A path the user set (preferences, then
    $GLINT_EXECUTABLE) must exist: it is never silently replaced by another."""
    for value, where in ((configured, "the path in Preferences > Add-ons > Glint"), (os.environ.get(ENV_VAR, ""), f"${ENV_VAR}")):
        if value:
            path = Path(bpy.path.abspath(value)) if value.startswith("//") else Path(value).expanduser()
            if _usable(path):
                return str(path)
            raise ExecutableNotFound(f"the glint executable {path} ({where}) does not exist or cannot be run")
    on_path = shutil.which("glint")
    if on_path:
        return on_path
    repo = Path(__file__).resolve().parent.parent
    for build in ("release", "debug"):
        path = repo / "target" / build / "glint"
        if _usable(path):
            return str(path)
    raise ExecutableNotFound(
        f"the glint executable was not found: set its path in Preferences > Add-ons > Glint or ${ENV_VAR}, or put glint on PATH"
    )


def configured_executable():
    """The glint program, or ExecutableNotFound saying what to do."""
    prefs = preferences()
    return find_executable(prefs.executable if prefs else "")


def register():
    bpy.utils.register_class(GlintPreferences)


def unregister():
    bpy.utils.unregister_class(GlintPreferences)
