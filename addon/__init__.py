"""Glint: a render engine for Blender that path traces with the Glint renderer.

F12 exports the scene with Blender's own glTF exporter into a job folder,
hands it to a `glint watch` daemon (one per Blender session), shows the image
as samples accumulate, and loads the final EXR into the render result.
Works as a Blender 4.2+ extension and as a legacy add-on.
"""

bl_info = {
    "name": "Glint",
    "author": "Glint developers",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "Render Properties > Render Engine > Glint",
    "description": "Physically based path tracing with the Glint renderer",
    "category": "Render",
}

from . import daemon, engine, preferences, properties  # noqa: E402

_modules = (preferences, properties, engine)


def register():
    for m in _modules:
        m.register()


def unregister():
    for m in reversed(_modules):
        m.unregister()
    daemon.stop()
