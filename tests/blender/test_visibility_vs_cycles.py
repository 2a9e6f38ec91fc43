"""Objects hidden from the camera (Object › Visibility › Ray Visibility ›
Camera off), in Glint against Cycles: camera rays pass them, and every
other ray sees them — their light, their shadow, their reflection."""

import json
import math

import bpy
import numpy as np
import pytest
from helpers import add_camera, give_principled, plain_world, render_seeds, tile_agreement

from glint import daemon


def scene_with_hidden_objects(scene):
    """A matte floor and a rough gold ball under an area light; between the
    camera and the ball an emitting panel and, above, a dark board that
    shades part of the floor from the lamp, both hidden from the camera:
    the camera sees through them, the ball reflects the panel, the floor
    is lit by it and shaded by the board."""
    bpy.ops.mesh.primitive_plane_add(size=8)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.6, 0.6, 0.6, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.7, location=(0, 0.5, 0.7), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    give_principled(bpy.context.object, "Gold", Base_Color=(0.9, 0.6, 0.2, 1), Metallic=1.0, Roughness=0.25)
    bpy.ops.mesh.primitive_plane_add(size=1.2, location=(0.3, -1.2, 0.8), rotation=(math.radians(90), 0, 0))
    panel = bpy.context.object
    panel.name = "Panel"
    give_principled(panel, "Glow", Base_Color=(0, 0, 0, 1), Emission_Color=(1.0, 0.7, 0.4, 1), Emission_Strength=4.0)
    bpy.ops.mesh.primitive_plane_add(size=1.5, location=(-1.0, -0.3, 2.0))
    board = bpy.context.object
    board.name = "Board"
    give_principled(board, "Board", Base_Color=(0.1, 0.1, 0.1, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    for obj in (panel, board):
        obj.visible_camera = False
    light = bpy.data.lights.new("Key", "AREA")
    light.size, light.energy = 1.0, 300.0
    lamp = bpy.data.objects.new("Key", light)
    lamp.location, lamp.rotation_euler = (-1.5, -0.5, 3.5), (math.radians(-10), math.radians(-25), 0)
    scene.collection.objects.link(lamp)
    add_camera(scene, (0, -4.0, 1.6), (math.radians(75), 0, 0), lens=35)
    plain_world(scene, (0.1, 0.1, 0.1))
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.view_settings.view_transform = "Standard"


@pytest.mark.parametrize("light_paths", ["ON", "OFF"])
def test_objects_hidden_from_the_camera_match_cycles(empty_scene, tmp_path, light_paths):
    """With light paths on, light tracing must neither splat the hidden
    panel nor let it block its way to the camera."""
    scene_with_hidden_objects(empty_scene)
    empty_scene.glint.light_paths = light_paths
    cycles, glint = render_seeds(empty_scene, tmp_path, 256, 8, 3)
    request = json.loads(open(daemon.current().path("request.json")).read())
    assert request["hidden_from_camera"] == ["Board", "Panel"], request["hidden_from_camera"]
    z, bias = tile_agreement(cycles, glint, 8)
    print(f"hidden from the camera, light paths {light_paths}: bias against Cycles {np.round(bias * 100, 2)} % (R, G, B), worst tile {z.max():.1f} σ")
    # 16 tiles × 3 channels at 5 σ: a false alarm 1 time in 30,000.
    assert z.max() < 5.0, (z.max(), bias)
    assert np.all(np.abs(bias) < 0.02), bias
