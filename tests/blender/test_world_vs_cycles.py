"""A World lit by an environment image (HDRI) in Glint against Cycles: a
diffuse floor and a glossy metal sphere under an equirectangular sky with a
small, very bright sun, turned by a Mapping node. The add-on passes the
image, strength and rotation in the request; Glint samples the map by
luminance. They must agree per 8 × 8 tile within 5 combined standard
errors (two seeds a side), where the sky seen directly checks the mapping
and the lit floor and sphere check the sampling."""

import math

import bpy
import numpy as np
from helpers import add_camera, give_principled
from test_textures_vs_cycles import compare


def sky(path, width=64, height=32):
    """A float equirectangular image, top row first: a blue-to-white
    gradient, an orange band near the horizon on one side, and a 2 × 2
    texel sun of radiance 400 at 40° elevation."""
    v, u = (np.mgrid[0:height, 0:width] + 0.5) / np.array([height, width])[:, None, None]
    elevation = (0.5 - v) * np.pi
    rgb = np.stack([0.3 + 0.5 * (1 - np.abs(np.sin(elevation))), 0.5 + 0.3 * (1 - np.abs(np.sin(elevation))), 0.9 * np.ones_like(u)], axis=-1)
    rgb[(np.abs(elevation) < 0.2) & (u < 0.3)] = (1.5, 0.6, 0.1)
    row = int(round((0.5 - 40 / 180) * height))
    rgb[row - 1 : row + 1, 40:42] = 400.0
    write_hdr(path, rgb)
    return bpy.data.images.load(str(path))


def write_hdr(path, rgb):
    """A Radiance .hdr file (flat RGBE scanlines, top row first). Blender's
    own HDR writer does not keep values as given (a sun of 400 came back
    as 12.75), and a user's HDRI is a file, so the test writes one."""
    height, width, _ = rgb.shape
    peak = rgb.max(axis=-1)
    mantissa, exponent = np.frexp(peak)
    scale = np.where(peak > 1e-32, mantissa * 256.0 / np.maximum(peak, 1e-32), 0.0)
    rgbe = np.zeros((height, width, 4), dtype=np.uint8)
    rgbe[..., :3] = np.clip(rgb * scale[..., None], 0, 255).astype(np.uint8)
    rgbe[..., 3] = np.where(peak > 1e-32, exponent + 128, 0).astype(np.uint8)
    with open(path, "wb") as f:
        f.write(f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode())
        f.write(rgbe.tobytes())


def test_environment_lit_scene_matches_cycles(empty_scene, tmp_path):
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    env = nodes.new("ShaderNodeTexEnvironment")
    env.image = sky(tmp_path / "sky.hdr")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value[2] = math.radians(35)
    coords = nodes.new("ShaderNodeTexCoord")
    links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    links.new(env.outputs["Color"], nodes["Background"].inputs["Color"])
    nodes["Background"].inputs["Strength"].default_value = 1.5
    empty_scene.world = world

    bpy.ops.mesh.primitive_plane_add(size=8.0)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.6, 0.6, 0.6, 1.0), Roughness=1.0)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.8, location=(0, 0, 0.8))
    bpy.ops.object.shade_smooth()
    give_principled(bpy.context.object, "Metal", Base_Color=(0.9, 0.7, 0.5, 1.0), Metallic=1.0, Roughness=0.3)
    add_camera(empty_scene, (0, -5.0, 2.2), (math.radians(75), 0, 0), lens=35)
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = 32
    empty_scene.view_settings.view_transform = "Standard"

    z, bias = compare(empty_scene, tmp_path, 128)
    import json

    from glint import daemon

    request = json.loads(open(daemon.current().path("request.json")).read())
    assert request["environment"]["strength"] == 1.5 and abs(request["environment"]["rotation"] - math.radians(35)) < 1e-6
    print(f"environment: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)


def test_a_packed_world_image_renders_as_its_file(empty_scene, tmp_path):
    """An HDRI packed into the .blend (as a .blend shared with others
    carries it) had rendered black, with a warning. The add-on now writes
    the packed file's bytes into the job folder, and Glint renders from
    them the image it renders from the file on disk, bit for bit."""
    import json
    import os

    from glint import daemon, export
    from helpers import render_rgb

    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    env = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = sky(tmp_path / "sky.hdr")
    world.node_tree.links.new(env.outputs["Color"], world.node_tree.nodes["Background"].inputs["Color"])
    empty_scene.world = world
    bpy.ops.mesh.primitive_plane_add(size=8.0)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.6, 0.6, 0.6, 1.0), Roughness=1.0)
    add_camera(empty_scene, (0, -5.0, 2.2), (math.radians(75), 0, 0), lens=35)
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = 16
    empty_scene.render.engine = "GLINT"
    empty_scene.glint.samples, empty_scene.glint.seed = 4, 1
    on_disk = render_rgb(tmp_path / "disk.exr")
    original = (tmp_path / "sky.hdr").read_bytes()

    env.image.pack()
    os.remove(tmp_path / "sky.hdr")
    _, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", 16, 16)
    assert any("not a file on disk" in w for w in warnings), warnings
    packed = render_rgb(tmp_path / "packed.exr")
    copy = json.loads(open(daemon.current().path("request.json")).read())["environment"]["image"]
    assert os.path.dirname(copy) == daemon.current().job_dir and open(copy, "rb").read() == original, copy
    assert on_disk.max() > 0.1 and np.array_equal(on_disk, packed), (on_disk.max(), np.abs(on_disk - packed).max())
