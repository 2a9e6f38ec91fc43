"""Textured materials in Glint against Cycles: a plane filling the view
with an image texture on its base colour (and alpha), or a normal map on a
glossy metal, lit by an area light and a grey World. Rendered by both
through the path a user takes (Cycles set fair; Glint through the add-on,
which exports the images, UVs and Blender's MikkTSpace tangents). They must
agree per 8 × 8 tile within 5 combined standard errors (noise from two
seeds a side)."""

import math

import bpy
import numpy as np
import pytest
from helpers import add_camera, plain_world, render_seeds, tile_agreement

SIZE, TILE, BOUNCES = 32, 8, 4


def image(name, pixels, path, non_color=False):
    """An 8-bit image from an (h, w, 4) array in [0, 1] (top row first),
    saved as PNG where the exporter and Cycles both read it."""
    h, w, _ = pixels.shape
    img = bpy.data.images.new(name, w, h, alpha=True)
    img.pixels.foreach_set(np.ascontiguousarray(pixels[::-1], dtype=np.float32).ravel())
    img.filepath_raw, img.file_format = str(path), "PNG"
    img.save()
    if non_color:
        img.colorspace_settings.name = "Non-Color"
    return img


def plane_scene(scene, tmp_path):
    """The plane z = 0, 2 × 2 m, seen from 2.2 m above (50 mm: it fills the
    view), with its Principled BSDF; an area light and a grey World."""
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.object
    material = bpy.data.materials.new("Textured")
    material.use_nodes = True
    plane.data.materials.append(material)
    light = bpy.data.lights.new("Key", "AREA")
    light.shape, light.size, light.energy = "SQUARE", 1.0, 300.0
    lamp = bpy.data.objects.new("Key", light)
    lamp.location = (1.2, -0.8, 2.0)
    lamp.rotation_euler = (math.radians(25), math.radians(20), 0)
    scene.collection.objects.link(lamp)
    plain_world(scene, (0.3, 0.3, 0.3))
    add_camera(scene, (0, 0, 2.2))
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.view_settings.view_transform = "Standard"
    return material, material.node_tree.nodes["Principled BSDF"]


def compare(scene, tmp_path, samples, bounces=BOUNCES):
    cycles, glint = render_seeds(scene, tmp_path, samples, bounces, 2)
    return tile_agreement(cycles, glint, TILE)


def checker(n, a, b):
    """An n × n checker of 4 × 4-texel squares of colours a and b (RGBA)."""
    y, x = np.mgrid[0:n, 0:n] // 4
    return np.where(((x + y) % 2 == 0)[..., None], np.array(a), np.array(b))


def test_base_colour_texture_matches_cycles(empty_scene, tmp_path):
    material, bsdf = plane_scene(empty_scene, tmp_path)
    tex = material.node_tree.nodes.new("ShaderNodeTexImage")
    # A 16 × 16 checker over 32 pixels: bilinear filtering between texels
    # must agree too (Linear interpolation in both).
    tex.image = image("Checker", checker(16, (0.9, 0.3, 0.1, 1.0), (0.1, 0.5, 0.8, 1.0)), tmp_path / "checker.png")
    material.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = 0.6
    z, bias = compare(empty_scene, tmp_path, 64)
    print(f"base colour texture: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)


def test_alpha_texture_matches_cycles(empty_scene, tmp_path):
    """Texture alpha into the Principled Alpha: the exporter writes BLEND,
    Cycles and Glint both let the World and the light through the holes."""
    material, bsdf = plane_scene(empty_scene, tmp_path)
    tex = material.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = image("Holes", checker(16, (0.8, 0.8, 0.8, 1.0), (0.8, 0.2, 0.2, 0.25)), tmp_path / "holes.png")
    material.node_tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    material.node_tree.links.new(tex.outputs["Alpha"], bsdf.inputs["Alpha"])
    # A floor under the plane, seen through its holes.
    bpy.ops.mesh.primitive_plane_add(size=4.0, location=(0, 0, -0.5))
    z, bias = compare(empty_scene, tmp_path, 64)
    print(f"alpha texture: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)


def bumps(material, bsdf, tmp_path, socket="Normal"):
    """A normal map into the Principled BSDF's Normal (or another normal
    socket) that tilts the normal by up to ~25°."""
    n = 64
    v, u = (np.mgrid[0:n, 0:n] + 0.5) / n
    slope_x, slope_y = 0.45 * np.sin(2 * np.pi * 3 * u), 0.45 * np.cos(2 * np.pi * 2 * v)
    normal = np.stack([slope_x, slope_y, np.ones_like(u)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    pixels = np.concatenate([normal * 0.5 + 0.5, np.ones((n, n, 1))], axis=-1)
    tex = material.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = image("Bumps", pixels, tmp_path / "bumps.png", non_color=True)
    normal_map = material.node_tree.nodes.new("ShaderNodeNormalMap")
    material.node_tree.links.new(tex.outputs["Color"], normal_map.inputs["Color"])
    material.node_tree.links.new(normal_map.outputs["Normal"], bsdf.inputs[socket])


def test_normal_map_matches_cycles(empty_scene, tmp_path):
    """A glossy metal whose normal map tilts the normal by up to ~25°: the
    key light's highlight moves across it, so tangents (Blender's exported
    MikkTSpace) and the tangent-space convention must both be right."""
    material, bsdf = plane_scene(empty_scene, tmp_path)
    bumps(material, bsdf, tmp_path)
    bsdf.inputs["Base Color"].default_value = (0.9, 0.7, 0.4, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = 0.35
    z, bias = compare(empty_scene, tmp_path, 64)
    print(f"normal map: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)


@pytest.mark.parametrize("socket, roughness, coat_roughness", [("Normal", 0.35, 0.1), ("Coat Normal", 0.5, 0.15)], ids=["base", "coat"])
def test_bumps_under_or_on_a_coat_match_cycles(empty_scene, tmp_path, socket, roughness, coat_roughness):
    """The same bumps with a smooth coat over a metal. On Normal they bend
    the metal below and not the coat, whose normal stays the plane's
    (Cycles' Coat Normal, unlinked): Glint's coat bent by the map as well
    put the key light's reflection in the wrong places. On Coat Normal
    (the exporter's clearcoatNormalTexture) they bend the coat alone, its
    lobe weighed by the cosine about its own normal as Cycles weighs it
    (17 σ off about the shading normal; 84 σ with the map unread)."""
    material, bsdf = plane_scene(empty_scene, tmp_path)
    bumps(material, bsdf, tmp_path, socket=socket)
    bsdf.inputs["Base Color"].default_value = (0.9, 0.7, 0.4, 1.0)
    bsdf.inputs["Metallic"].default_value = 1.0
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Coat Weight"].default_value = 1.0
    bsdf.inputs["Coat Roughness"].default_value = coat_roughness
    z, bias = compare(empty_scene, tmp_path, 64)
    print(f"bumps on {socket} with a coat: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)


def test_coat_textures_match_cycles(empty_scene, tmp_path):
    """Coat Weight and Coat Roughness from one image's red and green
    channels (through Separate Color), which Blender's exporter writes as
    KHR_materials_clearcoat's two textures: a checker of a smooth full
    coat and a rough half coat over a red dielectric. With the textures
    left unread (the factors, 1, everywhere), Glint's plane came out 4–24%
    dark (330 σ)."""
    material, bsdf = plane_scene(empty_scene, tmp_path)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = image("Coat", checker(16, (1.0, 0.05, 0.0, 1.0), (0.5, 0.6, 0.0, 1.0)), tmp_path / "coat.png", non_color=True)
    separate = nodes.new("ShaderNodeSeparateColor")
    links.new(tex.outputs["Color"], separate.inputs["Color"])
    links.new(separate.outputs["Red"], bsdf.inputs["Coat Weight"])
    links.new(separate.outputs["Green"], bsdf.inputs["Coat Roughness"])
    bsdf.inputs["Base Color"].default_value = (0.6, 0.1, 0.05, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.5
    z, bias = compare(empty_scene, tmp_path, 64)
    print(f"coat textures: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)
