"""Blender area lights through the add-on against Cycles itself: a floor lit
only directly (no bounces) by each light shape, seen through a narrow camera
so every pixel estimates the same irradiance. Cycles' convention is radiance
P/(π·A) from the front face; Glint's lamps must give the same floor."""

import math

import bpy
import numpy as np
import pytest
from helpers import add_camera, fair_cycles, give_principled, read_exr


def scene_with_light(scene, shape, rotation):
    bpy.ops.mesh.primitive_plane_add(size=200)
    # Specular IOR Level 0: pure Lambert in both renderers.
    give_principled(bpy.context.object, "Floor", Base_Color=(0.5, 0.5, 0.5, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    light = bpy.data.lights.new("Lamp", "AREA")
    light.shape, light.size, light.size_y, light.energy = shape, 1.0, 0.5, 50.0
    light.color = (1.0, 0.6, 0.3)
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location, lamp.rotation_euler = (0.2, -0.1, 1.0), rotation
    scene.collection.objects.link(lamp)
    add_camera(scene, (0, 0, 3), lens=2000)  # a 2 cm spot on the floor
    scene.world = None
    scene.render.resolution_x = scene.render.resolution_y = 16


def mean_and_error(path):
    rgb = read_exr(path)[..., :3].reshape(-1, 3).astype(np.float64)
    return rgb.mean(axis=0), rgb.std(axis=0) / math.sqrt(len(rgb))


@pytest.mark.parametrize(
    "shape, rotation",
    [("SQUARE", (0, 0, 0)), ("RECTANGLE", (0.3, 0.2, 0.5)), ("DISK", (0, 0, 0)), ("ELLIPSE", (-0.4, 0, 1.0))],
)
def test_area_light_lights_the_floor_as_in_cycles(empty_scene, tmp_path, shape, rotation):
    scene = empty_scene
    scene_with_light(scene, shape, rotation)
    scene.view_settings.view_transform = "Standard"
    fair_cycles(scene, 256, 0)
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(str(tmp_path / "cycles.exr"))
    scene.render.engine = "GLINT"
    scene.glint.samples, scene.glint.max_bounces = 256, 0
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(str(tmp_path / "glint.exr"))
    (cm, ce), (gm, ge) = mean_and_error(tmp_path / "cycles.exr"), mean_and_error(tmp_path / "glint.exr")
    print(f"{shape}: Cycles {cm} ± {ce}, Glint {gm} ± {ge}")
    # Both are unbiased estimates of one irradiance: they must agree within
    # 5 combined standard errors (each about 0.1–0.3% here).
    assert np.all(np.abs(cm - gm) < 5 * np.sqrt(ce**2 + ge**2)), (cm, gm, ce, ge)
    assert cm[0] > 0.1
