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


def floor_and_sphere(scene, eye, tilt, lens):
    """A grey diffuse floor and a glossy metal sphere on it, seen from `eye`
    tilted `tilt` degrees up from straight down, 32 × 32 pixels."""
    bpy.ops.mesh.primitive_plane_add(size=8.0)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.6, 0.6, 0.6, 1.0), Roughness=1.0)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.8, location=(0, 0, 0.8))
    bpy.ops.object.shade_smooth()
    give_principled(bpy.context.object, "Metal", Base_Color=(0.9, 0.7, 0.5, 1.0), Metallic=1.0, Roughness=0.3)
    add_camera(scene, eye, (math.radians(tilt), 0, 0), lens=lens)
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.view_settings.view_transform = "Standard"


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
    floor_and_sphere(empty_scene, (0, -5.0, 2.2), 75, 35)

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


def camera_world_scene(scene, tmp_path):
    """The environment test's floor and metal sphere, with the camera
    seeing the sky above them, under a World whose Mix Shader gives the
    camera rays a plain red-orange (Fac: Light Path › Is Camera Ray) and
    every other ray the environment image. Returns the node tree."""
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    env = nodes.new("ShaderNodeTexEnvironment")
    env.image = sky(tmp_path / "sky.hdr")
    links.new(env.outputs["Color"], nodes["Background"].inputs["Color"])
    nodes["Background"].inputs["Strength"].default_value = 1.5
    seen = nodes.new("ShaderNodeBackground")
    seen.inputs["Color"].default_value = (0.8, 0.15, 0.05, 1.0)
    seen.inputs["Strength"].default_value = 2.0
    mix = nodes.new("ShaderNodeMixShader")
    links.new(nodes.new("ShaderNodeLightPath").outputs["Is Camera Ray"], mix.inputs["Fac"])
    links.new(nodes["Background"].outputs["Background"], mix.inputs[1])
    links.new(seen.outputs["Background"], mix.inputs[2])
    links.new(mix.outputs["Shader"], nodes["World Output"].inputs["Surface"])
    scene.world = world
    floor_and_sphere(scene, (0, -5.0, 1.6), 82, 30)
    return world.node_tree


def test_a_world_the_camera_alone_sees_matches_cycles(empty_scene, tmp_path):
    """Light Path › Is Camera Ray mixing two World shaders (the usual way
    to light a scene by an HDRI and show a plain colour behind it) had
    rendered black, with a warning. The camera's sky is the plain colour;
    the floor, lit, and the sphere, reflecting, show the image's light.
    Per 8 × 8 tile within 5 combined standard errors (two seeds a side);
    the same World as a Mix of colours into one Background makes the same
    request, and World › Ray Visibility › Camera off shows black."""
    import json

    from glint import daemon, export

    from helpers import render_seeds, tile_agreement
    from test_textures_vs_cycles import BOUNCES, TILE

    tree = camera_world_scene(empty_scene, tmp_path)
    cycles, glint = render_seeds(empty_scene, tmp_path, 128, BOUNCES, 2)
    z, bias = tile_agreement(cycles, glint, TILE)
    # The top rows (Blender's last) see the sky: the camera's colour alone.
    for image in (cycles[0], glint[0]):
        assert np.allclose(image[-2:], [1.6, 0.3, 0.1], atol=1e-3), image[-1, :4]
    request = json.loads(open(daemon.current().path("request.json")).read())
    assert np.allclose(request["camera_world"]["background"], [1.6, 0.3, 0.1]), request["camera_world"]
    assert request["environment"]["strength"] == 1.5
    print(f"camera's own World: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)

    depsgraph = bpy.context.evaluated_depsgraph_get()
    by_shader, _ = export.render_request(depsgraph, "j", 32, 32)
    # The same as one Background whose Color mixes the image and the colour.
    nodes, links = tree.nodes, tree.links
    colour = nodes.new("ShaderNodeMix")
    colour.data_type = "RGBA"
    socket = {s.identifier: s for s in colour.inputs}
    links.new(nodes["Light Path"].outputs["Is Camera Ray"], socket["Factor_Float"])
    links.new(nodes["Environment Texture"].outputs["Color"], socket["A_Color"])
    socket["B_Color"].default_value = (0.8 * 2 / 1.5, 0.15 * 2 / 1.5, 0.05 * 2 / 1.5, 1.0)
    links.new(next(s for s in colour.outputs if s.identifier == "Result_Color"), nodes["Background"].inputs["Color"])
    links.new(nodes["Background"].outputs["Background"], nodes["World Output"].inputs["Surface"])
    by_colour, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", 32, 32)
    assert not [w for w in warnings if "World" in w], warnings
    assert by_colour["environment"] == by_shader["environment"] and np.allclose(by_colour["camera_world"]["background"], by_shader["camera_world"]["background"]), (by_colour, by_shader)

    # Hidden from the camera, the World is black where the camera sees it.
    links.new(nodes["Environment Texture"].outputs["Color"], nodes["Background"].inputs["Color"])
    empty_scene.world.cycles_visibility.camera = False
    z, bias = compare(empty_scene, tmp_path, 64)
    assert json.loads(open(daemon.current().path("request.json")).read())["camera_world"] == {"background": [0.0, 0.0, 0.0]}
    print(f"World hidden from the camera: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)
