"""What Glint is given for a render: the scene through Blender's own glTF
exporter, and a render request with what glTF cannot carry.

Through glTF (Principled BSDF → pbrMetallicRoughness, the exporter's job):
base colour, metallic, roughness, emission colour × strength
(KHR_materials_emissive_strength), Specular IOR Level 0 as
KHR_materials_specular 0, the image textures plugged into them and a Normal
Map node's image (with texture coordinates, Blender's own MikkTSpace
tangents where a normal map needs them, and the colour attributes materials
use), alpha, Transmission Weight and IOR (KHR_materials_transmission,
KHR_materials_ior: glass), Coat Weight and Roughness
(KHR_materials_clearcoat), Anisotropic and Anisotropic Rotation
(KHR_materials_anisotropy), cameras and mesh geometry with modifiers
applied.
Point, spot and sun lights go through glTF too (KHR_lights_punctual; COMPAT
units: W/(4π) per sr, sun W/m²); their radius and Soft Falloff, and a sun's
angle, go in the request. Not carried, or not yet rendered
by Glint: procedural textures, a Coat IOR other than 1.5, and the
Principled inputs Subsurface, Sheen and Thin Film, and a linked Diffuse
Roughness (the user is warned of each), and World node setups other than a plain Background colour or an
equirectangular Environment Texture (with at most a Mapping node's Z
rotation), or two of those mixed by Light Path › Is Camera Ray, which the
request carries (the camera's as `camera_world`, as is Ray Visibility ›
Camera off; the World's other Ray Visibility settings are warned of).

Through the request: resolution × percentage, the Tangent node that feeds
an anisotropic Principled BSDF's Tangent (Radial about X, Y or Z, or a UV
map; unlinked, Cycles' default, radial about Z; anything else is warned
of and rendered as the default), the objects hidden from the camera
and from shadow, diffuse, glossy or transmission rays (Object ›
Visibility › Ray Visibility; on an emitting object or a light, all but
Shadow and Camera are warned of and rendered as seen), the scene camera and what
glTF cannot say of it (Shift X and Y, Depth of Field, a panoramic camera's
type and settings), Film › Transparent (and
Cycles' Transparent Glass with its Roughness Threshold) and Pixel Filter,
a World image packed into the .blend (written into the job folder), Coat Tint, Diffuse
Roughness, samples, bounces,
time limit, Noise Threshold and Min Samples (adaptive sampling), a Volume
Absorption inside glass, a Diffuse, Glossy, Glass or Translucent BSDF node in place of
a Principled BSDF (the exporter writes glTF's default material), seed, the
World colour, every area light (glTF has none):
shape, size, world transform, colour and power, and the sizes of the
point, spot and sun lights. (The camera's Clip Start and End go through
glTF as znear and zfar.)
"""

import hashlib
import math
import os

import bpy
from mathutils import Matrix

# Blender's world is Z-up; glTF's is Y-up: (x, y, z) → (x, z, −y), as the
# exporter's export_yup does.
Z_UP_TO_Y_UP = Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))


def export_scene(path, frame, subframe):
    """Export the active scene at a frame as GLB to `path` (written whole,
    then renamed)."""
    # The exporter reads the view layer's depsgraph, which an animation
    # render does not move to the frame it renders: evaluate that frame.
    bpy.context.scene.frame_set(frame, subframe=subframe)
    # Blender 4.5's exporter fails on a panoramic camera with a KeyError
    # ('current_paths'): it goes out as a perspective one, which carries
    # its transform and clip distances, and the request carries its
    # panorama (`camera_lens`).
    instances = bpy.context.evaluated_depsgraph_get().object_instances
    panoramic = {i.object.original.data for i in instances if i.object.type == "CAMERA" and i.object.data.type == "PANO"}
    try:
        for camera in panoramic:
            camera.type = "PERSP"
        export_glb(path)
    finally:
        for camera in panoramic:
            camera.type = "PANO"


def export_glb(path):
    """The exporter's GLB of the active scene as it stands, written to a
    temporary file, then renamed to `path`."""
    normal_maps = any(uses_node(m, {"NORMAL_MAP"}) for m in used_materials(bpy.context.evaluated_depsgraph_get()))
    directory, name = os.path.split(path)
    tmp = os.path.join(directory, f".{name}.export.glb")
    result = bpy.ops.export_scene.gltf(
        filepath=tmp,
        export_format="GLB",
        use_active_scene=True,
        use_renderable=True,
        use_selection=False,
        export_apply=True,
        export_yup=True,
        export_cameras=True,
        export_lights=True,
        export_import_convert_lighting_mode="COMPAT",
        export_animations=False,
        # Without it, objects are exported as at frame 0, not the frame rendered.
        export_current_frame=True,
        export_skins=False,
        export_morph=False,
        export_extras=False,
        export_materials="EXPORT",
        # Only what Glint renders: images in their own format, texture
        # coordinates, the colour attributes materials use; tangents only
        # for normal maps (Blender's MikkTSpace, computed before the
        # exporter triangulates quads, so they match Cycles exactly).
        export_image_format="AUTO",
        export_texcoords=True,
        export_tangents=normal_maps,
        export_vertex_color="MATERIAL",
        export_all_vertex_colors=False,
        export_active_vertex_color_when_no_material=False,
        export_attributes=False,
    )
    if "FINISHED" not in result or not os.path.isfile(tmp):
        raise RuntimeError("Blender's glTF exporter did not finish")
    os.replace(tmp, path)


def world_shaders(scene, folder=None):
    """(lighting, camera, problems) of the World, each World a (radiance
    RGB, environment or None) pair: a plain Background node's colour ×
    strength, or an Environment Texture (through an optional Mapping node)
    × strength, or the World colour without nodes. `camera` is what camera
    rays see where it is not `lighting`, else None: the second shader or
    colour of a Mix whose Fac is Light Path › Is Camera Ray (as Cycles
    keeps a ray the camera's through transparency, so does Glint), or
    black with Ray Visibility › Camera off. `problems`: warnings, one a
    setting. An image packed in the .blend is written into `folder` (the
    job's), as the file that was packed (`packed_copy`)."""
    world = scene.world
    if world is None:
        return BLACK, None, []
    visibility = getattr(world, "cycles_visibility", None)
    problems = []
    hidden = [name for name in ("diffuse", "glossy", "transmission") if visibility is not None and not getattr(visibility, name, True)]
    if hidden:
        problems.append(f"the World hidden from {', '.join(hidden)} rays is not rendered by Glint (it lights them as with Blender's defaults)")
    if not world.use_nodes or world.node_tree is None:
        lighting, camera = (list(world.color[:3]), None), None
    else:
        output = world_output(world)
        links = output.inputs["Surface"].links if output is not None else []
        lighting, camera, problem = world_shader(links[0].from_node if links else None, folder)
        if problem:
            problems.append(problem)
    if visibility is not None and not visibility.camera:
        camera = BLACK
    return lighting, camera, problems


BLACK = ([0.0, 0.0, 0.0], None)


def world_shader(node, folder):
    """(lighting, camera or None, problem or None) of the World shader
    `node` (None: unlinked, black): a Background node, or a Mix Shader of
    two whose Fac is Is Camera Ray."""
    if node is None:
        return BLACK, None, None
    if node.type == "MIX_SHADER" and is_camera_ray(node.inputs[0]):
        halves = [world_shader(s.links[0].from_node if s.is_linked else None, folder) for s in (node.inputs[1], node.inputs[2])]
        (lighting, _, problem), (seen, camera, other) = halves
        return lighting, camera or seen, problem or other
    if node.type != "BACKGROUND" or node.inputs["Strength"].is_linked:
        return BLACK, None, f"the World's node setup ({node.name}) is not a Background colour or environment image, or a Mix Shader of two by Light Path › Is Camera Ray; Glint renders it black"
    strength = node.inputs["Strength"].default_value
    colour = node.inputs["Color"]
    mix = colour.links[0].from_node if colour.is_linked else None
    if mix is not None and colour_mix_by_camera_ray(mix):
        a, b = ((mix.inputs["Color1"], mix.inputs["Color2"]) if mix.type == "MIX_RGB" else (by_identifier(mix.inputs, "A_Color"), by_identifier(mix.inputs, "B_Color")))
        (lighting, problem), (camera, other) = colour_source(a, strength, folder), colour_source(b, strength, folder)
        return lighting, camera, problem or other
    lighting, problem = colour_source(colour, strength, folder)
    return lighting, None, problem


def is_camera_ray(socket):
    """Whether `socket` is linked from a Light Path node's Is Camera Ray."""
    return socket.is_linked and socket.links[0].from_node.type == "LIGHT_PATH" and socket.links[0].from_socket.identifier == "Is Camera Ray"


def colour_mix_by_camera_ray(node):
    """Whether `node` is a Mix (Color, Mix blending, or the older MixRGB)
    whose factor is Is Camera Ray."""
    if node.type == "MIX_RGB":
        return node.blend_type == "MIX" and is_camera_ray(node.inputs["Fac"])
    return node.type == "MIX" and node.data_type == "RGBA" and node.blend_type == "MIX" and node.factor_mode == "UNIFORM" and is_camera_ray(by_identifier(node.inputs, "Factor_Float"))


def by_identifier(sockets, identifier):
    """The socket of `sockets` with `identifier`: a Mix node's inputs of
    each data type share their names."""
    return next(s for s in sockets if s.identifier == identifier)


def colour_source(socket, strength, folder):
    """((radiance RGB, environment or None), problem or None) of a World
    colour × `strength`: the socket's own colour, or an equirectangular
    Environment Texture (through an optional Mapping node's Z rotation)."""
    if not socket.is_linked:
        return ([c * strength for c in socket.default_value[:3]], None), None
    env = socket.links[0].from_node
    if env.type != "TEX_ENVIRONMENT" or env.image is None or env.projection != "EQUIRECTANGULAR":
        return BLACK, f"the World's colour comes from {env.name}, not an equirectangular Environment Texture; Glint renders it black"
    path = bpy.path.abspath(env.image.filepath, library=env.image.library)
    if env.image.packed_file is not None and folder is not None:
        path = packed_copy(env.image, folder)
    elif env.image.packed_file is not None or not os.path.isfile(path):
        return BLACK, f"the World's image {env.image.name} is not a file on disk (generated, or missing); save it to render it with Glint"
    rotation = 0.0
    vector = env.inputs["Vector"]
    if vector.is_linked:
        mapping = vector.links[0].from_node
        if mapping.type != "MAPPING" or any(mapping.inputs[k].is_linked for k in ("Rotation", "Location", "Scale")):
            return BLACK, f"the World's texture coordinates come from {mapping.name}; Glint takes an Environment Texture with at most a Mapping node's Z rotation"
        rotation = mapping.inputs["Rotation"].default_value[2]
    return ([0.0, 0.0, 0.0], {"image": os.path.abspath(path), "strength": strength, "rotation": rotation}), None


# Extensions of the image files Glint reads, by Blender's file format.
IMAGE_EXTENSIONS = {"HDR": ".hdr", "OPEN_EXR": ".exr", "OPEN_EXR_MULTILAYER": ".exr", "PNG": ".png", "JPEG": ".jpg"}


def packed_copy(image, folder):
    """The path of a copy, in `folder`, of the file packed in `image`: its
    bytes as they were packed, so Glint reads what Cycles reads, named by
    their hash (written once, whole, then renamed; a leading dot keeps the
    daemon from taking it for a change to render)."""
    data = image.packed_file.data
    extension = os.path.splitext(image.filepath)[1].lower() or IMAGE_EXTENSIONS.get(image.file_format, "")
    path = os.path.join(folder, f".world-{hashlib.sha1(data).hexdigest()[:16]}{extension}")
    if not os.path.isfile(path):
        temporary = f"{path}.{os.getpid()}.tmp"
        with open(temporary, "wb") as f:
            f.write(data)
        os.replace(temporary, path)
    return path


# Film › Pixel Filter's types, by the request's names.
PIXEL_FILTERS = {"BOX": "box", "GAUSSIAN": "gaussian", "BLACKMAN_HARRIS": "blackman_harris"}


def pixel_filter(cycles):
    """Film › Pixel Filter and its Width as the request carries them:
    Cycles' own settings, which the .blend keeps for both renderers (a box
    of one pixel, as Cycles renders it), or Cycles' defaults
    (Blackman-Harris, 1.5 px) without Cycles."""
    if cycles is None:
        return {"type": "blackman_harris", "width": 1.5}
    kind = PIXEL_FILTERS.get(cycles.pixel_filter_type, "blackman_harris")
    # Cycles' box is one pixel whatever the Width says (its panel greys it).
    return {"type": kind, "width": 1.0 if kind == "box" else max(float(cycles.filter_width), 0.01)}


def world_output(world):
    """The World's active World Output node, or None."""
    return next((n for n in world.node_tree.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)


def world_volume(scene):
    """Whether the World's active output has a Volume linked."""
    world = scene.world
    if world is None or not world.use_nodes or world.node_tree is None:
        return False
    output = world_output(world)
    return output is not None and output.inputs["Volume"].is_linked


def area_lights(depsgraph):
    """Every visible area light (instances included) as request records,
    portals among them."""
    records = []
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type != "LIGHT" or obj.data.type != "AREA":
            continue
        light = obj.data
        shape = light.shape
        size_y = light.size_y if shape in {"RECTANGLE", "ELLIPSE"} else light.size
        m = Z_UP_TO_Y_UP @ instance.matrix_world
        records.append(
            {
                "name": obj.name,
                "shape": shape,
                "size": [light.size, size_y],
                "matrix": [m[r][c] for c in range(4) for r in range(4)],  # column-major
                "color": list(light.color[:3]),
                # Unnormalised lights give power per unit area, as the exporter reads them.
                "power": light.energy if getattr(light, "normalize", True) else light.energy * light.area(matrix_world=instance.matrix_world),
                "visible_camera": bool(obj.visible_camera),
                # Cycles' Light › Portal: no light of its own; Glint samples
                # the World through it.
                "portal": bool(getattr(getattr(light, "cycles", None), "is_portal", False)),
                # Radians, the opening of the cone the light leaves in.
                "spread": float(getattr(light, "spread", math.pi)),
                # Light › Cast Shadow: off, its light samples trace no shadow ray.
                "cast_shadow": bool(getattr(light, "use_shadow", True)),
            }
        )
    return records


def surface_objects(depsgraph):
    """The evaluated objects other than lights, cameras and empties, once
    each (instances share their object), sorted by name: the exporter's
    node names."""
    objects = {i.object.name: i.object for i in depsgraph.object_instances if i.object.type not in {"LIGHT", "CAMERA", "EMPTY"}}
    return [objects[name] for name in sorted(objects)]


def hidden_from_camera(depsgraph):
    """Names of the objects with Object › Visibility › Ray Visibility ›
    Camera off: camera rays pass them, every other ray sees them."""
    return [obj.name for obj in surface_objects(depsgraph) if not obj.visible_camera]


# Object › Visibility › Ray Visibility, but the camera's: each kind of ray
# Glint renders, by the render request's name, and the object's property
# for it. Volume Scatter is not among them: Glint has no scattering
# volumes (they have their own warning), so no ray of that kind is traced.
RAYS = (("shadow", "visible_shadow"), ("diffuse", "visible_diffuse"), ("glossy", "visible_glossy"),
        ("transmission", "visible_transmission"))


def rays_hidden_from(obj, kinds=None):
    """The kinds of rays `obj` is hidden from, among `kinds` (every kind
    of RAYS without)."""
    return [name for name, key in RAYS if (kinds is None or name in kinds) and not getattr(obj, key, True)]


def hidden_from_rays(depsgraph):
    """The objects other than lights hidden from shadow, diffuse, glossy
    or transmission rays, for the request: by name (the exporter's node
    names) with the kinds, sorted by name. Glint's rays of those kinds
    pass them, as Cycles'; on an emitting object it renders the Shadow
    setting alone, and says so."""
    return [{"object": obj.name, "rays": hidden} for obj in surface_objects(depsgraph) if (hidden := rays_hidden_from(obj))]


def light_settings_left_out(depsgraph):
    """One warning per light with settings Glint does not render, naming
    them: the rays it is hidden from (Object › Visibility › Ray
    Visibility). Glint renders such a light as if they were left at
    Blender's defaults."""
    warnings = {}
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type != "LIGHT":
            continue
        light = obj.data
        left_out = []
        hidden = rays_hidden_from(obj, ("diffuse", "glossy", "transmission"))
        if hidden:
            left_out.append(f"hidden from {', '.join(hidden)} rays")
        if left_out:
            warnings[obj.name] = f"{obj.name}: {'; '.join(left_out)} not rendered by Glint (it lights as with Blender's defaults)"
    return [warnings[name] for name in sorted(warnings)]


def light_sizes(depsgraph):
    """The size of every point, spot and sun light, which KHR_lights_punctual
    cannot carry: radius and Soft Falloff, or a sun's angle. Keyed by the
    light data's name, the name the exporter gives the glTF light; with
    whether the camera sees it (Object › Visibility › Camera, off for
    lights by default) and whether it casts shadows (Light › Cast Shadow)."""
    sizes = {}
    for instance in depsgraph.object_instances:
        light = instance.object.data if instance.object.type == "LIGHT" else None
        if light is None or light.type not in {"POINT", "SPOT", "SUN"}:
            continue
        common = {"name": light.name, "visible_camera": bool(instance.object.visible_camera), "cast_shadow": bool(getattr(light, "use_shadow", True))}
        if light.type == "SUN":
            sizes[light.name] = {**common, "angle": float(light.angle)}
        else:
            soft = bool(getattr(light, "use_soft_falloff", True))
            sizes[light.name] = {**common, "radius": float(light.shadow_soft_size), "soft_falloff": soft}
    return list(sizes.values())


def render_request(depsgraph, job, width, height, folder=None):
    """The request for this render, and warnings for the user; files it
    needs beside the scene (a packed World image) go in `folder`."""
    scene = depsgraph.scene
    settings = scene.glint
    warnings = []
    (background, environment), camera_world, problems = world_shaders(scene, folder)
    warnings.extend(problems)
    if world_volume(scene):
        warnings.append("the World's Volume (fog, haze) is not rendered by Glint: its rays cross empty space")
    procedural = [m.name for m in used_materials(depsgraph) if uses_node(m, PROCEDURAL_TEXTURES)]
    if procedural:
        warnings.append(f"{', '.join(procedural)}: procedural textures cannot go through glTF; Glint renders the node's own values (bake them to an image)")
    warnings.extend(principled_inputs_left_out(depsgraph))
    warnings.extend(light_settings_left_out(depsgraph))
    tints, coat_iors = coat_settings(depsgraph)
    rough_diffuse, linked_roughness = diffuse_roughness(depsgraph)
    if linked_roughness:
        warnings.append(f"{', '.join(linked_roughness)}: a linked Diffuse Roughness of the Principled BSDF is not rendered by Glint (rendered as 0)")
    if coat_iors:
        warnings.append(f"{', '.join(coat_iors)}: Coat IOR other than 1.5 is not rendered by Glint (glTF's coat has IOR 1.5)")
    bsdf_nodes, shader_mixes, other_surfaces, mixed_otherwise, approximate, node_single_scatter = surface_shaders(depsgraph)
    if mixed_otherwise:
        warnings.append(f"{', '.join(mixed_otherwise)}: a Principled BSDF mixed or added with other shaders otherwise than in one Mix Shader with a constant Fac and a Diffuse, Glossy, Glass, Transparent or Translucent BSDF or an Emission shader, or an Add Shader with an Emission shader, is not rendered by Glint, which renders the Principled BSDF alone (what the exporter writes)")
    if other_surfaces:
        warnings.append(f"{', '.join(other_surfaces)}: a surface without a Principled BSDF, or a Diffuse, Glossy, Glass, Transparent or Translucent BSDF or an Emission shader alone, or two of those BSDFs in a Mix Shader with a constant Fac, cannot go through glTF; Glint renders what the exporter writes (glTF's default, a white rough metal)")
    if approximate:
        warnings.append(f"{', '.join(approximate)}: Glint renders this BSDF node as the nearest Principled BSDF (a Diffuse BSDF, a Glossy BSDF white and isotropic, a Glass BSDF clear, GGX or Multiscatter GGX — in a Mix Shader, as the Principled BSDF's —, a Transparent BSDF white, a Translucent BSDF, no Normal: exact; otherwise not)")
    absorption, other_volumes = volume_absorption(depsgraph)
    if other_volumes:
        warnings.append(f"{', '.join(other_volumes)}: a volume other than a Volume Absorption node with unlinked Color and Density is not rendered by Glint")
    tangents, other_tangents = anisotropy_tangents(depsgraph)
    if other_tangents:
        warnings.append(f"{', '.join(other_tangents)}: a Tangent other than a Tangent node's (Radial, or one of the first two UV maps) is not rendered by Glint, which stretches Anisotropic along the default tangent (circles about the object's Z axis)")
    request = {
        "job": job,
        "scene": "scene.glb",
        "width": width,
        "height": height,
        "samples": settings.samples,
        "max_depth": settings.max_bounces + 1,
        "seed": settings.seed,
        "bsdf": settings.bsdf.lower(),
        "background": background,
        # Cycles' Emission emits from both faces; the exporter's doubleSided
        # is Blender's backface culling, which Cycles ignores. (A Cornell box
        # whose light faced down came out 9% dark without this.)
        "two_sided_emission": True,
        # An object without a material renders with Cycles' default surface
        # (diffuse 0.8 grey), not glTF's default (white metal).
        "default_surface": [0.8, 0.8, 0.8],
        "area_lights": area_lights(depsgraph),
        "light_sizes": light_sizes(depsgraph),
        "hidden_from_camera": hidden_from_camera(depsgraph),
        "hidden_from_rays": hidden_from_rays(depsgraph),
        "anisotropy_tangents": tangents,
    }
    if environment:
        request["environment"] = environment
    if camera_world is not None:
        seen_colour, seen_image = camera_world
        request["camera_world"] = {"environment": seen_image} if seen_image else {"background": seen_colour}
    single_scatter = sorted(
        {m.name for m in used_materials(depsgraph) if any(n.type == "BSDF_PRINCIPLED" and n.distribution == "GGX" for n in m.node_tree.nodes)} | set(node_single_scatter)
    )
    if single_scatter:
        request["single_scatter_materials"] = single_scatter
    if tints:
        request["coat_tints"] = tints
    if rough_diffuse:
        request["diffuse_roughness"] = rough_diffuse
    if absorption:
        request["volume_absorption"] = absorption
    if bsdf_nodes:
        request["bsdf_nodes"] = bsdf_nodes
    if shader_mixes:
        request["shader_mixes"] = shader_mixes
    if settings.time_limit > 0:
        request["time_limit"] = settings.time_limit
    if settings.use_adaptive_sampling:
        request["noise_threshold"] = settings.adaptive_threshold
        request["adaptive_min_samples"] = settings.adaptive_min_samples
    if settings.light_paths != "AUTO":
        request["light_paths"] = settings.light_paths == "ON"
    cycles = getattr(scene, "cycles", None)
    if scene.render.film_transparent:
        request["transparent_film"] = True
        if cycles is not None and cycles.film_transparent_glass:
            request["transparent_glass"] = cycles.film_transparent_roughness
    request["pixel_filter"] = pixel_filter(cycles)
    if scene.camera is not None:
        request["camera"] = scene.camera.name
        lens = camera_lens(scene, scene.camera)
        if lens:
            request["lens"] = lens
    return request, warnings


def camera_lens(scene, camera):
    """A camera's Shift X and Y, its Depth of Field and a panoramic one's
    projection, as Cycles renders them (its blender/camera.cpp), or None
    where it has none of them."""
    if camera.type != "CAMERA":
        return None
    data = camera.data
    lens = {}
    if data.type == "PANO":
        # Cycles moves a panorama's view, the unit square, by the shift
        # itself.
        if data.shift_x or data.shift_y:
            lens["shift"] = [data.shift_x, data.shift_y]
        lens["panorama"] = panorama(scene, data)
    elif data.shift_x or data.shift_y:
        # Blender's shift is in units of the view's fitted side (the larger
        # one under Auto); the request's, in fractions of each side.
        render = scene.render
        x = render.resolution_x * render.pixel_aspect_x
        y = render.resolution_y * render.pixel_aspect_y
        horizontal = x > y if data.sensor_fit == "AUTO" else data.sensor_fit == "HORIZONTAL"
        fitted = x if horizontal else y
        lens["shift"] = [data.shift_x * fitted / x, data.shift_y * fitted / y]
    dof = data.dof
    if dof.use_dof:
        fstop = max(dof.aperture_fstop, 1e-5)
        radius = 1.0 / (2.0 * fstop) if data.type == "ORTHO" else data.lens * 1e-3 / (2.0 * fstop)
        lens["aperture"] = {
            "radius": radius,
            # Glint needs a plane of focus in front of the lens.
            "focus_distance": max(focus_distance(camera), 1e-4),
            "blades": dof.aperture_blades,
            "rotation": dof.aperture_rotation,
            "ratio": dof.aperture_ratio,
        }
    return lens or None


def panorama(scene, data):
    """A panoramic camera's Panorama Type and the settings Cycles reads for
    it (angles in radians, lens and sensor in mm)."""
    kind = data.panorama_type
    record = {"type": kind}
    if kind == "EQUIRECTANGULAR":
        record["latitude"] = [data.latitude_min, data.latitude_max]
        record["longitude"] = [data.longitude_min, data.longitude_max]
    elif kind == "FISHEYE_EQUIDISTANT":
        record["fov"] = data.fisheye_fov
    elif kind == "FISHEYE_EQUISOLID":
        record.update(fov=data.fisheye_fov, lens=data.fisheye_lens, sensor=fitted_sensor(scene, data))
    elif kind == "FISHEYE_LENS_POLYNOMIAL":
        k = [getattr(data, f"fisheye_polynomial_k{i}") for i in range(5)]
        record.update(fov=data.fisheye_fov, k=k, sensor=fitted_sensor(scene, data))
    elif kind == "CENTRAL_CYLINDRICAL":
        record["u_range"] = [data.central_cylindrical_range_u_min, data.central_cylindrical_range_u_max]
        record["v_range"] = [data.central_cylindrical_range_v_min, data.central_cylindrical_range_v_max]
        record["radius"] = data.central_cylindrical_radius
    return record


def fitted_sensor(scene, data):
    """The sensor's width and height in mm as Cycles fits it to the image
    for a fisheye: the side Sensor Fit picks is the sensor's size, the
    other follows the image's aspect."""
    render = scene.render
    scale = render.resolution_percentage / 100
    x = int(render.resolution_x * scale) * render.pixel_aspect_x
    y = int(render.resolution_y * scale) * render.pixel_aspect_y
    if data.sensor_fit == "VERTICAL":
        return [data.sensor_height * x / y, data.sensor_height]
    if data.sensor_fit == "HORIZONTAL" or x > y:
        return [data.sensor_width, data.sensor_width * y / x]
    return [data.sensor_width * x / y, data.sensor_width]


def focus_distance(camera):
    """Depth of Field's Focus Distance, or the distance along the camera's
    view axis to its Focus Object (or that armature's bone)."""
    dof = camera.data.dof
    target = dof.focus_object
    if target is None:
        return dof.focus_distance
    where = target.matrix_world
    if target.pose is not None and dof.focus_subtarget:
        bone = target.pose.bones.get(dof.focus_subtarget)
        if bone is not None:
            where = where @ bone.matrix
    view = camera.matrix_world.to_3x3().normalized().col[2]
    return abs(view.dot(camera.matrix_world.translation - where.translation))


def used_materials(depsgraph):
    """The node materials of every rendered object, once each, by name."""
    found = {}
    for i in depsgraph.object_instances:
        for slot in getattr(i.object, "material_slots", []):
            m = slot.material
            if m is not None and m.use_nodes and m.node_tree is not None:
                found[m.name] = m
    return [found[name] for name in sorted(found)]


# Principled BSDF inputs Glint does not render, and what a warning calls them.
PRINCIPLED_LEFT_OUT = (("Subsurface Weight", "Subsurface"), ("Sheen Weight", "Sheen"), ("Thin Film Thickness", "Thin Film"))


def principled_inputs_left_out(depsgraph):
    """One warning per material whose Principled BSDF uses an input Glint
    does not render (linked, or above 0), naming them; Glint renders it as
    if they were 0."""
    warnings = []
    for m in used_materials(depsgraph):
        principled = [n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED"]
        labels = [label for name, label in PRINCIPLED_LEFT_OUT if any(n.inputs[name].is_linked or n.inputs[name].default_value > 0.0 for n in principled)]
        if labels:
            warnings.append(f"{m.name}: {', '.join(labels)} of the Principled BSDF not rendered by Glint (rendered as 0)")
    return warnings


def diffuse_roughness(depsgraph):
    """What glTF leaves out of Principled BSDFs with a rough diffuse base:
    their Diffuse Roughness where it is above 0 (for the request, clamped
    to [0, 1]; Glint renders Cycles' Oren–Nayar lobe), and the names of
    materials where it is linked (rendered as 0)."""
    records, linked = [], []
    for m in used_materials(depsgraph):
        for node in (n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED"):
            roughness = node.inputs["Diffuse Roughness"]
            if roughness.is_linked:
                linked.append(m.name)
            elif roughness.default_value > 0.0:
                records.append({"material": m.name, "roughness": min(float(roughness.default_value), 1.0)})
            break
    return records, linked


def coat_settings(depsgraph):
    """What glTF's coat leaves out of coated Principled BSDFs: their Coat
    Tint where it is not white (for the request; a linked one is left
    white), and the names of materials whose Coat IOR is not 1.5."""
    tints, iors = [], []
    for m in used_materials(depsgraph):
        for node in (n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED"):
            weight = node.inputs["Coat Weight"]
            if not weight.is_linked and weight.default_value <= 0.0:
                continue
            tint = node.inputs["Coat Tint"]
            rgb = unit_rgb(tint)
            if not tint.is_linked and rgb != [1.0, 1.0, 1.0]:
                tints.append({"material": m.name, "tint": rgb})
            ior = node.inputs["Coat IOR"]
            if ior.is_linked or abs(ior.default_value - 1.5) > 1e-4:
                iors.append(m.name)
            break
    return tints, iors


def fed_outputs(depsgraph, name):
    """(material, input, node feeding it) for each rendered material, by
    name, whose Material Output that Cycles renders with has its input
    `name` (Surface, Volume) linked."""
    for m in used_materials(depsgraph):
        outputs = [n for n in m.node_tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output and n.target in {"ALL", "CYCLES"}]
        socket = outputs[0].inputs[name] if outputs else None
        if socket is not None and socket.is_linked:
            yield m, socket, socket.links[0].from_node


def unit_rgb(socket):
    """A colour input's value, each channel clamped to [0, 1]."""
    return [min(max(c, 0.0), 1.0) for c in socket.default_value[:3]]


def upstream(socket):
    """Every node that feeds this input, directly or through others."""
    found, stack = [], [socket]
    while stack:
        for link in stack.pop().links:
            node = link.from_node
            if node not in found:
                found.append(node)
                stack.extend(i for i in node.inputs if i.is_linked)
    return found


# Blender's plain BSDF nodes Glint renders, by the request's names.
PLAIN_NODES = {"BSDF_DIFFUSE": "diffuse", "BSDF_GLOSSY": "glossy", "BSDF_GLASS": "glass", "BSDF_TRANSPARENT": "transparent", "BSDF_TRANSLUCENT": "translucent", "EMISSION": "emission"}


def plain_node(material, node):
    """A plain BSDF node or an Emission shader with unlinked Color,
    Roughness, IOR and Strength as a request record of `material`
    (colours clamped to [0, 1], an IOR to ≥ 1, a Strength to ≥ 0),
    whether Glint renders it exactly (not: a coloured or anisotropic Glossy, a coloured Glass or Transparent, a
    Beckmann or Ashikhmin-Shirley distribution, an IOR below 1, a linked
    Normal, a colour clamped) and whether it asks for GGX without
    multiple scattering; None for any other node."""
    inputs = [node.inputs[name] for name in ("Color", "Roughness", "IOR", "Strength") if name in node.inputs]
    if node.type not in PLAIN_NODES or any(i.is_linked for i in inputs):
        return None
    record = {"material": material.name, "node": PLAIN_NODES[node.type], "color": unit_rgb(node.inputs["Color"])}
    if node.type == "BSDF_TRANSPARENT":
        return record, record["color"] == [1.0, 1.0, 1.0], False
    if node.type == "BSDF_TRANSLUCENT":
        return record, not node.inputs["Normal"].is_linked and list(node.inputs["Color"].default_value[:3]) == record["color"], False
    if node.type == "EMISSION":
        record["strength"] = max(float(node.inputs["Strength"].default_value), 0.0)
        return record, list(node.inputs["Color"].default_value[:3]) == record["color"], False
    roughness = node.inputs["Roughness"].default_value
    exact = not node.inputs["Normal"].is_linked
    single_scatter = False
    record["roughness"] = min(max(float(roughness), 0.0), 1.0)
    if node.type != "BSDF_DIFFUSE":
        exact = exact and record["color"] == [1.0, 1.0, 1.0] and node.distribution in {"GGX", "MULTI_GGX"}
        single_scatter = node.distribution == "GGX"
    if node.type == "BSDF_GLOSSY":
        exact = exact and node.inputs["Anisotropy"].default_value == 0.0 and not node.inputs["Anisotropy"].is_linked
    if node.type == "BSDF_GLASS":
        ior = float(node.inputs["IOR"].default_value)
        record["ior"] = max(ior, 1.0)
        exact = exact and ior >= 1.0
    return record, exact, single_scatter


def shader_mix(material, node):
    """A Mix Shader with a constant Fac of a Principled BSDF (the one the
    exporter writes, the surface's only one) and a plain node
    (`plain_node`), or an Add Shader of a Principled BSDF and an Emission
    shader, as a request record: the node's share (`weight`: Fac where
    the node is the lower input, 1 − Fac where it is the upper; 0 for an
    added Emission, which takes none of the BSDF), its record (`mixed`)
    and, for an Emission shader, the whole emission; with `plain_node`'s
    exactness (and an unlinked Principled Emission where it counts) and
    GGX; None for any other node, mix or sum."""
    if node.type == "MIX_SHADER":
        fac, shaders = node.inputs[0], (node.inputs[1], node.inputs[2])
        if fac.is_linked:
            return None
    elif node.type == "ADD_SHADER":
        fac, shaders = None, (node.inputs[0], node.inputs[1])
    else:
        return None
    if not all(s.is_linked for s in shaders):
        return None
    nodes = [s.links[0].from_node for s in shaders]
    principled = [n.type == "BSDF_PRINCIPLED" for n in nodes]
    if principled.count(True) != 1:
        return None
    side = principled.index(False)
    found = plain_node(material, nodes[side])
    if found is None or any(n.type == "BSDF_PRINCIPLED" for n in upstream(shaders[side])):
        return None
    record, exact, single_scatter = found
    if fac is None and record["node"] != "emission":
        return None
    if fac is None:
        # A sum keeps each whole: the Principled BSDF's share is 1, and
        # the Emission shader, black, takes none of the BSDF.
        weight, kept, added = 0.0, 1.0, 1.0
    else:
        share = float(min(max(fac.default_value, 0.0), 1.0))
        weight = share if side == 1 else 1.0 - share
        kept, added = 1.0 - weight, weight
    mix = {"weight": weight, "mixed": record}
    if record["node"] == "emission":
        # The exporter writes the Emission shader's emission as the
        # material's, and drops the Principled BSDF's: the whole goes in.
        principled = nodes[1 - side]
        colour, strength = principled.inputs["Emission Color"], principled.inputs["Emission Strength"]
        exact = exact and not colour.is_linked and not strength.is_linked
        own = [c * max(float(strength.default_value), 0.0) for c in unit_rgb(colour)]
        mix["emission"] = [kept * p + added * c * record["strength"] for p, c in zip(own, record["color"])]
    return mix, exact, single_scatter


# Plain nodes that can be the first half of a Mix Shader of two: the
# record Glint makes the material from before it mixes in the second.
MIX_BASES = {"diffuse", "glossy", "glass", "translucent"}


def plain_mix(material, node):
    """A Mix Shader with a constant Fac of two plain nodes and no Principled
    BSDF (a Diffuse and a Glossy, the way materials were made before the
    Principled BSDF; a Diffuse and a Translucent, a leaf), as two request
    records: the upper node as the material (`bsdf_nodes`) and the lower
    mixed into it by Fac (`shader_mixes`); with both nodes' exactness and
    whether they ask for plain GGX; None for any other node. The upper one
    must be a Diffuse, Glossy, Glass or Translucent BSDF, the lower any of
    those or a Transparent BSDF (Emission shaders: the exporter writes
    theirs as it likes)."""
    if node.type != "MIX_SHADER" or node.inputs[0].is_linked or not all(s.is_linked for s in node.inputs[1:3]):
        return None
    halves = [plain_node(material, s.links[0].from_node) for s in node.inputs[1:3]]
    if None in halves or halves[0][0]["node"] not in MIX_BASES or halves[1][0]["node"] not in MIX_BASES | {"transparent"}:
        return None
    (base, base_exact, base_ggx), (mixed, mixed_exact, mixed_ggx) = halves
    weight = float(min(max(node.inputs[0].default_value, 0.0), 1.0))
    # Plain GGX is the material's, both halves': exact unless two glossy
    # halves ask for different ones.
    glossy = {"glossy", "glass"}
    agree = not (base["node"] in glossy and mixed["node"] in glossy and base_ggx != mixed_ggx)
    return base, {"weight": weight, "mixed": mixed}, base_exact and mixed_exact and agree, base_ggx or mixed_ggx


def surface_shaders(depsgraph):
    """What the exporter cannot write of surfaces: for those without a
    Principled BSDF (it writes glTF's default material, a white rough
    metal), a plain node straight into the Material Output (`plain_node`),
    for the request's `bsdf_nodes`; a Mix Shader of the Principled BSDF
    and a plain node (`shader_mix`; the exporter writes the Principled
    BSDF alone), for its `shader_mixes`; the names of materials with other
    surfaces (a Mix Shader of other shaders, a Subsurface Scattering node, …) and of
    those whose Principled BSDF is mixed or added in other ways; those of
    nodes Glint renders only approximately; and those whose node asks for
    GGX without multiple scattering (a plain node's own)."""
    records, mixes, others, mixed_otherwise, approximate, single_scatter = [], [], [], [], [], []
    for m, surface, node in fed_outputs(depsgraph, "Surface"):
        if node.type in {"BSDF_PRINCIPLED", "EMISSION"}:
            continue
        found = shader_mix(m, node)
        if found is not None:
            mixes.append(found[0])
            # The node's half takes the Principled BSDF's multiple
            # scattering setting: a single-scattering GGX node is inexact.
            _, exact, ggx = found
            if ggx or not exact:
                approximate.append(m.name)
            continue
        if any(n.type == "BSDF_PRINCIPLED" for n in upstream(surface)):
            mixed_otherwise.append(m.name)
            continue
        pair = plain_mix(m, node)
        if pair is not None:
            base, mix, exact, ggx = pair
            records.append(base)
            mixes.append(mix)
            if ggx:
                single_scatter.append(m.name)
            if not exact:
                approximate.append(m.name)
            continue
        found = plain_node(m, node)
        if found is None:
            others.append(m.name)
            continue
        records.append(found[0])
        _, exact, ggx = found
        if ggx:
            single_scatter.append(m.name)
        if not exact:
            approximate.append(m.name)
    return records, mixes, others, mixed_otherwise, approximate, single_scatter


def volume_absorption(depsgraph):
    """What glTF leaves out of materials with a volume: a Volume Absorption
    node on the Material Output's Volume, for the request (its Color clamped
    to [0, 1] and Density to ≥ 0; Glint absorbs (1 − Color) × Density per
    metre inside the material's glass, as Cycles does); and the names of
    materials whose volume is something else (scattering, emission, linked
    inputs), which Glint does not render. The exporter writes
    KHR_materials_volume only from a glTF Material Output node."""
    records, others = [], []
    for m, _, node in fed_outputs(depsgraph, "Volume"):
        color, density = (node.inputs.get("Color"), node.inputs.get("Density")) if node.type == "VOLUME_ABSORPTION" else (None, None)
        if color is None or density is None or color.is_linked or density.is_linked:
            others.append(m.name)
            continue
        records.append({"material": m.name, "color": unit_rgb(color), "density": max(float(density.default_value), 0.0)})
    return records, others


def anisotropy_tangents(depsgraph):
    """The Tangent input of anisotropic Principled BSDFs: where a Tangent
    node feeds it, a request record (Radial about the object's X, Y or Z,
    or a UV map by its index among the mesh's UV maps: the exporter's
    TEXCOORD_n); and the names of materials whose Tangent something else
    feeds, which Glint renders along the default tangent (radial about Z,
    what an unlinked input gets)."""
    meshes = {}
    for i in depsgraph.object_instances:
        if i.object.type == "MESH":
            for slot in i.object.material_slots:
                if slot.material is not None:
                    meshes.setdefault(slot.material.name, i.object.data)
    records, others = [], []
    for m in used_materials(depsgraph):
        for node in (n for n in m.node_tree.nodes if n.type == "BSDF_PRINCIPLED"):
            anisotropic, tangent = node.inputs["Anisotropic"], node.inputs["Tangent"]
            if not (anisotropic.is_linked or anisotropic.default_value > 0.0) or not tangent.is_linked:
                continue
            source = tangent.links[0].from_node
            if source.type != "TANGENT":
                others.append(m.name)
            elif source.direction_type == "RADIAL":
                records.append({"material": m.name, "radial_axis": source.axis})
            else:
                uv_layers = getattr(meshes.get(m.name), "uv_layers", None)
                names = [layer.name for layer in uv_layers] if uv_layers is not None else []
                index = names.index(source.uv_map) if source.uv_map in names else 0
                if index > 1:
                    others.append(m.name)
                else:
                    records.append({"material": m.name, "uv_map": index})
            break
    return records, others


# Texture nodes that compute their values: glTF carries images only.
PROCEDURAL_TEXTURES = {
    "TEX_NOISE", "TEX_VORONOI", "TEX_WAVE", "TEX_MAGIC", "TEX_GRADIENT", "TEX_CHECKER",
    "TEX_BRICK", "TEX_GABOR", "TEX_WHITE_NOISE", "TEX_MUSGRAVE", "TEX_SKY",
}


def uses_node(material, types):
    """Whether a node of one of these types feeds something in the material."""
    return any(n.type in types and any(o.is_linked for o in n.outputs) for n in material.node_tree.nodes)


def json_bytes(obj):
    import json

    return json.dumps(obj, indent=1).encode()
