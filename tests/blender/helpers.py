"""Scene building and image reading shared by the Blender tests."""

import bpy
import numpy as np


def new_empty_scene():
    """Blender's factory settings with nothing in the scene, rendered by
    Glint, results saved as float EXR (linear, as rendered)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "GLINT"
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.exr_codec = "ZIP"
    return scene


def give_principled(obj, name, **inputs):
    """A new Principled BSDF material on `obj`, with inputs by their UI names
    (spaces as underscores: Base_Color=(r, g, b, a), Roughness=0.4)."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    for key, value in inputs.items():
        bsdf.inputs[key.replace("_", " ")].default_value = value
    obj.data.materials.append(material)
    return material


def read_exr(path):
    """An image file through Blender's reader, as a (height, width, 4) float
    array, bottom row first as Blender stores images."""
    image = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = image.size
        px = np.empty(w * h * 4, dtype=np.float32)
        image.pixels.foreach_get(px)
        return px.reshape(h, w, 4)
    finally:
        bpy.data.images.remove(image)


def fair_cycles(scene, samples, bounces, seed=0):
    """Cycles set for a fair comparison with Glint: CPU; no denoising,
    adaptive sampling, glossy blur, clamping or light threshold; the same
    bounce limit for every ray type; a one-pixel box filter, as Glint's."""
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device, c.samples, c.seed = "CPU", samples, seed
    c.use_denoising = c.use_adaptive_sampling = False
    c.blur_glossy = 0.0
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = 0.0
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = bounces
    # Cycles' Film settings are Glint's too (the add-on reads them).
    c.pixel_filter_type, c.filter_width = "BOX", 1.0


def add_camera(scene, location, rotation=(0.0, 0.0, 0.0), lens=50.0):
    """A camera named "Camera" (rotation in radians), made the scene's."""
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location, camera.rotation_euler = location, rotation
    camera.data.lens = lens
    scene.collection.objects.link(camera)
    scene.camera = camera
    return camera


def plain_world(scene, colour, strength=1.0):
    """A World of one Background colour × strength."""
    world = bpy.data.worlds.new("World")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*colour, 1.0)
    background.inputs["Strength"].default_value = strength
    scene.world = world
    return world


def render_rgb(path):
    """Render the active scene (F12), save the result to `path` and read it
    back as a (height, width, 3) float64 array."""
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(str(path))
    return read_exr(path)[..., :3].astype(np.float64)


def render_seeds(scene, tmp_path, samples, bounces, seeds):
    """The scene rendered with seeds 1…`seeds` by Cycles (set fair) and then
    by Glint (through the add-on): two lists of RGB arrays."""
    fair_cycles(scene, samples, bounces)
    cycles = []
    for seed in range(1, seeds + 1):
        scene.cycles.seed = seed
        cycles.append(render_rgb(tmp_path / f"c{seed}.exr"))
    scene.render.engine = "GLINT"
    scene.glint.samples, scene.glint.max_bounces = samples, bounces
    glint = []
    for seed in range(1, seeds + 1):
        scene.glint.seed = seed
        glint.append(render_rgb(tmp_path / f"g{seed}.exr"))
    return cycles, glint


def tile_means(img, tile):
    """The mean of each `tile` × `tile` tile of a (height, width, 3) image."""
    h, w, _ = img.shape
    return img.reshape(h // tile, tile, w // tile, tile, 3).mean(axis=(1, 3))


def two_seeds_by_tile(scene, tmp_path, samples, bounces, tile):
    """The scene rendered with seeds 1 and 2 by Cycles (set fair) and by
    Glint (through the add-on): both renderers' images ((c1, c2), (g1,
    g2)), the tile means of each one's mean image (c, g), and the standard
    error of their difference per tile, from the spread of the two seeds
    each side."""
    def image(engine, seed):
        if engine == "CYCLES":
            fair_cycles(scene, samples, bounces, seed)
        else:
            scene.render.engine = "GLINT"
            scene.glint.samples, scene.glint.max_bounces, scene.glint.seed = samples, bounces, seed
        return render_rgb(tmp_path / f"{engine[0].lower()}{seed}.exr")

    c1, c2 = image("CYCLES", 1), image("CYCLES", 2)
    g1, g2 = image("GLINT", 1), image("GLINT", 2)
    c, g = tile_means((c1 + c2) / 2, tile), tile_means((g1 + g2) / 2, tile)
    n = tile * tile
    se = np.sqrt((tile_means((c1 - c2) ** 2, tile) + tile_means((g1 - g2) ** 2, tile)) / 2 / (2 * n))
    return (c1, c2), (g1, g2), c, g, se


def tile_agreement(cycles, glint, tile):
    """How far apart two renderers' images are, per `tile` × `tile` tile:
    the difference of their tile means over its combined standard error
    (the noise estimated from the spread of the images each side, at least
    two), and Glint's relative bias over the whole image per channel."""
    def tiles(img):
        return tile_means(img, tile)

    def var(images):
        return tiles(np.var(np.stack(images), axis=0, ddof=1)) / (len(images) * tile * tile)

    c, g = tiles(np.mean(cycles, axis=0)), tiles(np.mean(glint, axis=0))
    # Tiles without noise (the World seen directly) still differ by float
    # rounding: 0.8 came back as 0.80000079 from Cycles, 0.79999971 from
    # Glint. A floor of 1e-5 relative keeps that from reading as 1000 σ.
    z = np.abs(c - g) / np.maximum(np.sqrt(var(cycles) + var(glint)), 1e-5 * np.abs(c) + 1e-9)
    bias = g.sum(axis=(0, 1)) / c.sum(axis=(0, 1)) - 1
    return z, bias
