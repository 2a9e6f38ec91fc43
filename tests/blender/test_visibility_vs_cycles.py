"""Objects hidden from the camera (Object › Visibility › Ray Visibility ›
Camera off), in Glint against Cycles: camera rays pass them, and every
other ray sees them — their light, their shadow, their reflection."""

import json
import math

import bpy
import numpy as np
import pytest
from helpers import add_camera, give_principled, plain_world, render_rgb, render_seeds, tile_agreement

from glint import daemon


def lit_and_framed(scene, key, camera, resolution):
    """A square area light `key` = (size, watts, location, (x, y) turn in
    degrees), a camera = (location, tilt from straight down in degrees,
    lens in mm), a dim grey World, and a square image of `resolution`
    pixels in Standard colour."""
    size, energy, location, (turn_x, turn_y) = key
    light = bpy.data.lights.new("Key", "AREA")
    light.size, light.energy = size, energy
    lamp = bpy.data.objects.new("Key", light)
    lamp.location, lamp.rotation_euler = location, (math.radians(turn_x), math.radians(turn_y), 0)
    scene.collection.objects.link(lamp)
    (eye, tilt, lens) = camera
    add_camera(scene, eye, (math.radians(tilt), 0, 0), lens=lens)
    plain_world(scene, (0.1, 0.1, 0.1))
    scene.render.resolution_x = scene.render.resolution_y = resolution
    scene.view_settings.view_transform = "Standard"


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
    lit_and_framed(scene, (1.0, 300.0, (-1.5, -0.5, 3.5), (-10, -25)), ((0, -4.0, 1.6), 75, 35), 32)


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


def scene_with_rays_hidden(scene):
    """A matte floor, a rough gold ball and a slab of rough glass under an
    area light, with an object hidden from each other kind of ray: a board
    over the floor hidden from shadow rays (light samples pass it, the
    floor's diffuse bounces meet it), a red card by the ball hidden from
    glossy rays (the ball does not mirror it, the floor takes its red
    light), a blue card hidden from diffuse rays (the ball mirrors it, the
    floor takes none of its light), and a green block behind the glass
    hidden from transmission rays (seen beside the glass, not through it).
    Returns the four, by the kind they are hidden from."""
    bpy.ops.mesh.primitive_plane_add(size=8)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.6, 0.6, 0.6, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(0.7, 0.6, 0.6), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    give_principled(bpy.context.object, "Gold", Base_Color=(0.9, 0.6, 0.2, 1), Metallic=1.0, Roughness=0.2)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-1.0, -1.4, 0.5), scale=(0.5, 0.04, 0.5))
    give_principled(bpy.context.object, "Glass", Base_Color=(1, 1, 1, 1), Transmission_Weight=1.0, Roughness=0.05, IOR=1.45)
    hidden = {}
    for kind, name, colour, location, rotation, size in (
        ("shadow", "Board", (0.2, 0.2, 0.2, 1), (-0.6, 0.2, 2.0), (0, 0, 0), 1.4),
        ("glossy", "Red card", (0.8, 0.1, 0.1, 1), (1.8, 0.2, 0.7), (0, math.radians(90), 0), 1.2),
        ("diffuse", "Blue card", (0.1, 0.2, 0.8, 1), (-0.3, 1.6, 0.7), (math.radians(90), 0, math.radians(20)), 1.2),
    ):
        bpy.ops.mesh.primitive_plane_add(size=size, location=location, rotation=rotation)
        obj = bpy.context.object
        obj.name = name
        give_principled(obj, name, Base_Color=colour, Roughness=1.0, Specular_IOR_Level=0.0)
        hidden[kind] = obj
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(-1.1, -0.9, 0.25))
    block = bpy.context.object
    block.name = "Block"
    give_principled(block, "Green", Base_Color=(0.1, 0.7, 0.2, 1), Roughness=0.6)
    hidden["transmission"] = block
    for kind, obj in hidden.items():
        setattr(obj, f"visible_{kind}", False)
    lit_and_framed(scene, (1.5, 500.0, (-0.4, -0.6, 3.6), (-10, -10)), ((0, -4.6, 1.5), 78, 32), 48)
    return hidden


def test_objects_hidden_from_other_rays_match_cycles(empty_scene, tmp_path):
    """Shadow, Diffuse, Glossy and Transmission off on four objects: each
    kind of ray passes its object, as in Cycles. With any one of the four
    settings left out (its object seen by that kind, as Glint rendered it
    before it read these settings), Glint's image must be far from Cycles'
    (over 8 σ in some tile), so the scene shows each setting."""
    hidden = scene_with_rays_hidden(empty_scene)
    cycles, glint = render_seeds(empty_scene, tmp_path, 256, 8, 3)
    request = json.loads(open(daemon.current().path("request.json")).read())
    kinds = {r["object"]: r["rays"] for r in request["hidden_from_rays"]}
    assert kinds == {obj.name: [kind] for kind, obj in hidden.items()}, kinds
    z, bias = tile_agreement(cycles, glint, 8)
    print(f"hidden from other rays: bias against Cycles {np.round(bias * 100, 2)} % (R, G, B), worst tile {z.max():.1f} σ")
    left_out = {}
    for kind, obj in hidden.items():
        setattr(obj, f"visible_{kind}", True)
        seen = []
        for seed in range(1, 4):
            empty_scene.glint.seed = seed
            seen.append(render_rgb(tmp_path / f"{kind}{seed}.exr"))
        setattr(obj, f"visible_{kind}", False)
        z_seen, bias_seen = tile_agreement(cycles, seen, 8)
        left_out[kind] = z_seen.max()
        print(f"  {obj.name} seen by {kind} rays: bias {np.round(bias_seen * 100, 2)} %, worst tile {z_seen.max():.1f} σ")
    # 36 tiles × 3 channels at 5 σ: a false alarm about 1 time in 16,000.
    assert z.max() < 5.0, (z.max(), bias)
    assert np.all(np.abs(bias) < 0.02), bias
    assert all(z_seen > 8.0 for z_seen in left_out.values()), left_out


def test_lights_casting_no_shadow_match_cycles(empty_scene, tmp_path):
    """Light › Cast Shadow off on an area light and a point light over a
    floor, a gold ball and a board: their light samples pass everything,
    while BSDF rays that reach them meet what is in the way, as in Cycles.
    With Cast Shadow left on in Glint alone (what it rendered before it
    read the setting) the image must be far from Cycles' (over 8 σ in
    some tile), so the scene shows it."""
    bpy.ops.mesh.primitive_plane_add(size=8)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.6, 0.6, 0.6, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(0.7, 0.6, 0.6), segments=48, ring_count=24)
    bpy.ops.object.shade_smooth()
    give_principled(bpy.context.object, "Gold", Base_Color=(0.9, 0.6, 0.2, 1), Metallic=1.0, Roughness=0.3)
    bpy.ops.mesh.primitive_plane_add(size=1.4, location=(-0.6, 0.2, 1.8))
    give_principled(bpy.context.object, "Board", Base_Color=(0.3, 0.3, 0.3, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    lit_and_framed(empty_scene, (1.0, 300.0, (-0.6, 0.0, 3.4), (0, 0)), ((0, -4.6, 1.5), 78, 32), 48)
    bulb = bpy.data.lights.new("Bulb", "POINT")
    bulb.energy, bulb.shadow_soft_size = 150.0, 0.2
    point = bpy.data.objects.new("Bulb", bulb)
    point.location = (1.2, -0.6, 2.6)
    empty_scene.collection.objects.link(point)
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(1.0, -0.3, 2.0))
    give_principled(bpy.context.object, "Shade", Base_Color=(0.3, 0.3, 0.3, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    lights = [bpy.data.lights["Key"], bulb]
    for light in lights:
        light.use_shadow = False
    cycles, glint = render_seeds(empty_scene, tmp_path, 256, 8, 3)
    request = json.loads(open(daemon.current().path("request.json")).read())
    assert request["area_lights"][0]["cast_shadow"] is False and request["light_sizes"][0]["cast_shadow"] is False, request
    z, bias = tile_agreement(cycles, glint, 8)
    print(f"lights casting no shadow: bias against Cycles {np.round(bias * 100, 2)} % (R, G, B), worst tile {z.max():.1f} σ")
    for light in lights:
        light.use_shadow = True
    cast = []
    for seed in range(1, 4):
        empty_scene.glint.seed = seed
        cast.append(render_rgb(tmp_path / f"cast{seed}.exr"))
    z_cast, bias_cast = tile_agreement(cycles, cast, 8)
    print(f"  the same with their shadows cast: bias {np.round(bias_cast * 100, 2)} %, worst tile {z_cast.max():.1f} σ")
    # 36 tiles × 3 channels at 5 σ: a false alarm about 1 time in 16,000.
    assert z.max() < 5.0, (z.max(), bias)
    assert np.all(np.abs(bias) < 0.02), bias
    assert z_cast.max() > 8.0, z_cast.max()
