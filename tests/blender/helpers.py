"""Scene building and image reading shared by the Blender tests."""

import bpy
import numpy as np


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
