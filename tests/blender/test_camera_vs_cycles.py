"""Where a pixel looks, in Glint and in Cycles: a sub-pixel offset of the
camera would shift every edge and highlight, and at 64 spp it hides in the
noise of the image comparisons. Here the corner of an emissive plane sits
at a known fraction of a pixel, so each edge pixel's value is the share of
the pixel the plane covers; for a perspective camera, and for an
orthographic one through Blender's glTF export of it (Orthographic Scale
across the image's larger side, Clip Start)."""

import bpy
import numpy as np
import pytest
from helpers import add_camera, fair_cycles, give_principled, plain_world, read_exr, render_seeds

SIZE, DISTANCE, LENS = 32, 10.0, 50.0
PIXEL = 2 * DISTANCE * 18 / LENS / SIZE  # metres per pixel on the plane (36 mm sensor)


def test_edge_pixels_cover_what_the_plane_covers(empty_scene, tmp_path):
    """The plane starts 0.3 pixel right of the image centre and 0.7 pixel
    above it (`assert_corner_coverage`)."""
    x0, y0 = 0.3 * PIXEL, 0.7 * PIXEL
    emitter = plane(empty_scene, "Plane", [(x0, y0, 0), (50, y0, 0), (50, 50, 0), (x0, 50, 0)])
    give_principled(emitter, "Emitter", Base_Color=(0, 0, 0, 1), Emission_Color=(1, 1, 1, 1),
                    Emission_Strength=1.0, Specular_IOR_Level=0.0)
    add_camera(empty_scene, (0, 0, DISTANCE), lens=LENS)  # looking down −Z
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = SIZE
    assert_corner_coverage(empty_scene, tmp_path, SIZE // 2, SIZE // 2)


def test_orthographic_edge_pixels_cover_what_the_plane_covers(empty_scene, tmp_path):
    """The same corner under an orthographic camera on a 48 × 32 image:
    Orthographic Scale 4.8 m spans the larger side, so a pixel is 0.1 m
    on the plane at any distance. A black card 1 m in front of the camera,
    nearer than its Clip Start (2 m), covers the whole view: Cycles starts
    orthographic rays at Clip Start and so does Glint (glTF's znear), or
    the image would be black."""
    width, height, pixel = 48, 32, 0.1
    x0, y0 = 0.3 * pixel, 0.7 * pixel
    emitter = plane(empty_scene, "Plane", [(x0, y0, 0), (50, y0, 0), (50, 50, 0), (x0, 50, 0)])
    give_principled(emitter, "Emitter", Base_Color=(0, 0, 0, 1), Emission_Color=(1, 1, 1, 1),
                    Emission_Strength=1.0, Specular_IOR_Level=0.0)
    card = plane(empty_scene, "Card", [(-50, -50, DISTANCE - 1), (50, -50, DISTANCE - 1), (50, 50, DISTANCE - 1), (-50, 50, DISTANCE - 1)])
    give_principled(card, "Card", Base_Color=(0, 0, 0, 1), Specular_IOR_Level=0.0)
    camera = add_camera(empty_scene, (0, 0, DISTANCE)).data
    camera.type, camera.ortho_scale, camera.clip_start = "ORTHO", width * pixel, 2.0
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = width, height
    assert_corner_coverage(empty_scene, tmp_path, height // 2, width // 2)


@pytest.mark.parametrize("width, height", [(48, 32), (32, 48)])
def test_shifted_view_covers_what_the_plane_covers(empty_scene, tmp_path, width, height):
    """A perspective camera with Shift X 0.1 and Y −0.05 on a 48 × 32 and
    a 32 × 48 image: Blender's shift is in units of the view's larger side
    (the one its sensor fits), so either way the view moves 4.8 pixels
    right and 2.4 down, and the plane's corner, placed 5.1 pixels right of
    and 1.7 below the axis, lands 0.3 right of and 0.7 above the image
    centre (`assert_corner_coverage`)."""
    pixel = 2 * DISTANCE * 18 / LENS / max(width, height)  # the 36 mm sensor spans the larger side
    x0, y0 = 5.1 * pixel, -1.7 * pixel
    emitter = plane(empty_scene, "Plane", [(x0, y0, 0), (50, y0, 0), (50, 50, 0), (x0, 50, 0)])
    give_principled(emitter, "Emitter", Base_Color=(0, 0, 0, 1), Emission_Color=(1, 1, 1, 1),
                    Emission_Strength=1.0, Specular_IOR_Level=0.0)
    camera = add_camera(empty_scene, (0, 0, DISTANCE), lens=LENS).data
    camera.shift_x, camera.shift_y = 0.1, -0.05
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = width, height
    assert_corner_coverage(empty_scene, tmp_path, height // 2, width // 2)


def test_depth_of_field_blurs_the_corner_as_in_cycles(empty_scene, tmp_path):
    """Depth of Field focused by an Empty 4 m in front of the camera, the
    plane 10 m away: F-Stop 0.1 on a 50 mm lens is a 0.25 m aperture, so
    the corner blurs over about 2.5 pixels vertically, half that across
    (Ratio 2), through a seven-bladed aperture turned by 0.4 rad. Every
    pixel within 6 of the corner, Cycles' against Glint's: each is a
    fraction of the samples that see the plane, binomial noise at most
    √(p(1−p)/N) a renderer; the tolerance is 5 σ of their difference.
    An aperture 10% too large fails it (2.2 × the tolerance), and a Ratio
    applied the wrong way round (14 ×)."""
    width, height = 48, 32
    pixel = 2 * DISTANCE * 18 / LENS / width
    x0, y0 = 0.3 * pixel, 0.7 * pixel
    emitter = plane(empty_scene, "Plane", [(x0, y0, 0), (50, y0, 0), (50, 50, 0), (x0, 50, 0)])
    give_principled(emitter, "Emitter", Base_Color=(0, 0, 0, 1), Emission_Color=(1, 1, 1, 1),
                    Emission_Strength=1.0, Specular_IOR_Level=0.0)
    camera_object = add_camera(empty_scene, (0, 0, DISTANCE), lens=LENS)
    focus = bpy.data.objects.new("Focus", None)
    focus.location = (1.0, -0.5, DISTANCE - 4.0)  # 4 m along the view axis, off it
    empty_scene.collection.objects.link(focus)
    dof = camera_object.data.dof
    dof.use_dof, dof.focus_object, dof.aperture_fstop = True, focus, 0.1
    dof.aperture_blades, dof.aperture_rotation, dof.aperture_ratio = 7, 0.4, 2.0
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = width, height
    empty_scene.view_settings.view_transform = "Standard"
    samples, seeds = 8192, 2
    cycles, glint = render_seeds(empty_scene, tmp_path, samples, 1, seeds)
    c, g = np.mean(cycles, 0)[..., 0], np.mean(glint, 0)[..., 0]
    r, k = height // 2, width // 2
    patch = (slice(r - 6, r + 7), slice(k - 6, k + 7))
    c, g = c[patch], g[patch]
    # The blur is there: a sharp corner has 0 or 1 everywhere but a cross.
    assert ((c > 0.05) & (c < 0.95)).sum() > 30, c
    p = (c + g) / 2
    tolerance = 5 * np.sqrt(2 * p * (1 - p) / (samples * seeds)) + 1e-3
    worst = np.max(np.abs(c - g) / tolerance)
    assert worst < 1, (worst, np.round(c, 3), np.round(g, 3))


def test_transparent_film_gives_coverage_as_alpha_as_in_cycles(empty_scene, tmp_path):
    """Film › Transparent: a grey Lambertian plane (albedo 0.5) whose
    corner is a fraction of a pixel off the image centre, under a white
    World that lights it but that the camera does not see. Alpha is each
    pixel's coverage, as in `assert_corner_coverage` (Cycles within 1e-3,
    Glint within 5 binomial σ), the colour 0.5 × alpha (premultiplied) in
    both, within 2% where alpha is above 0.05, and 0 where it is 0."""
    x0, y0 = 0.3 * PIXEL, 0.7 * PIXEL
    floor = plane(empty_scene, "Plane", [(x0, y0, 0), (50, y0, 0), (50, 50, 0), (x0, 50, 0)])
    give_principled(floor, "Grey", Base_Color=(0.5, 0.5, 0.5, 1), Specular_IOR_Level=0.0)
    plain_world(empty_scene, (1.0, 1.0, 1.0))
    add_camera(empty_scene, (0, 0, DISTANCE), lens=LENS)
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = SIZE
    empty_scene.render.film_transparent = True
    empty_scene.view_settings.view_transform = "Standard"
    samples = 4096
    images = {}
    for engine in ("CYCLES", "GLINT"):
        if engine == "CYCLES":
            fair_cycles(empty_scene, samples, 1, 1)
        else:
            empty_scene.render.engine = "GLINT"
            empty_scene.glint.samples, empty_scene.glint.max_bounces, empty_scene.glint.seed = samples, 1, 1
        bpy.ops.render.render()
        path = tmp_path / f"{engine}.exr"
        bpy.data.images["Render Result"].save_render(str(path))
        images[engine] = read_exr(path).astype(np.float64)
    h = SIZE // 2
    expected = {(h + 1, h): 0.7, (h, h + 1): 0.3, (h, h): 0.21, (h - 1, h): 0.0, (h + 1, h - 1): 0.0, (h + 1, h + 1): 1.0, (0, 0): 0.0}
    for engine, img in images.items():
        alpha, colour = img[..., 3], img[..., 0]
        for (row, col), p in expected.items():
            tolerance = 1e-3 if engine == "CYCLES" else 5 * np.sqrt(p * (1 - p) / samples) + 1e-4
            assert abs(alpha[row, col] - p) < tolerance, (engine, row, col, alpha[row, col], p)
        seen = alpha > 0.05
        assert np.all(np.abs(colour[seen] / alpha[seen] - 0.5) < 0.01), (engine, colour[seen] / alpha[seen])
        assert np.all(img[alpha == 0][..., :3] == 0), engine


# Six faces of a 4 m cube around the camera, each emitting its own colour,
# every channel a yes or no: +X red, −X cyan, +Y green, −Y magenta, +Z blue,
# −Z yellow. A pixel's channel is then the share of it that sees faces
# with that channel on.
CUBE_FACES = {
    "PosX": ([(2, -2, -2), (2, 2, -2), (2, 2, 2), (2, -2, 2)], (1, 0, 0)),
    "NegX": ([(-2, -2, -2), (-2, -2, 2), (-2, 2, 2), (-2, 2, -2)], (0, 1, 1)),
    "PosY": ([(-2, 2, -2), (-2, 2, 2), (2, 2, 2), (2, 2, -2)], (0, 1, 0)),
    "NegY": ([(-2, -2, -2), (2, -2, -2), (2, -2, 2), (-2, -2, 2)], (1, 0, 1)),
    "PosZ": ([(-2, -2, 2), (2, -2, 2), (2, 2, 2), (-2, 2, 2)], (0, 0, 1)),
    "NegZ": ([(-2, -2, -2), (-2, 2, -2), (2, 2, -2), (2, -2, -2)], (1, 1, 0)),
}


@pytest.mark.parametrize("kind, settings, shift, dof", [
    ("EQUIRECTANGULAR", {"latitude_min": -1.2, "latitude_max": 1.4, "longitude_min": -2.5, "longitude_max": 2.9}, (0.0, 0.0), None),
    ("EQUIRECTANGULAR", {}, (0.1, -0.05), None),
    ("EQUIRECTANGULAR", {}, (0.0, 0.0), (0.1, 1.5, 6)),
    ("EQUIANGULAR_CUBEMAP_FACE", {}, (0.0, 0.0), None),
    ("MIRRORBALL", {}, (0.0, 0.0), None),
    ("FISHEYE_EQUIDISTANT", {"fisheye_fov": 2.8}, (0.0, 0.0), None),
    ("FISHEYE_EQUIDISTANT", {"fisheye_fov": 2.8}, (0.0, 0.0), (0.2, 4.0, 0)),
    ("FISHEYE_EQUISOLID", {"fisheye_fov": 3.0, "fisheye_lens": 8.0}, (0.0, 0.0), None),
    ("FISHEYE_EQUISOLID", {"fisheye_fov": 2.5, "fisheye_lens": 10.0, "sensor_fit": "VERTICAL"}, (0.0, 0.0), None),
    ("FISHEYE_LENS_POLYNOMIAL", {}, (0.0, 0.0), None),
    ("CENTRAL_CYLINDRICAL", {"central_cylindrical_range_u_min": -2.0, "central_cylindrical_range_u_max": 2.5,
                             "central_cylindrical_range_v_min": -1.0, "central_cylindrical_range_v_max": 1.5,
                             "central_cylindrical_radius": 1.3}, (0.0, 0.0), None),
])
def test_panoramic_cameras_see_what_cycles_sees(empty_scene, tmp_path, kind, settings, shift, dof):
    """A panoramic camera, turned every way and off the centre of a cube
    whose six faces emit six colours (`CUBE_FACES`), on a 40 × 24 image:
    every pixel's channels are the shares of it that see each colour, in
    Cycles and in Glint. Glint's independent samples are binomial noise,
    √(p(1−p)/N) at most, Cycles' stratified ones less: the tolerance is
    5 σ of the difference, so that the face's edges, which cross the view
    along curves each mapping draws its own way, must fall within a few
    hundredths of a pixel of Cycles'. Outside a fisheye's circle or the
    mirror ball both are black (within 2e-3). With Depth of Field (an
    aperture of 25 cm and 6 cm, six blades and a disk, focused nearer and
    farther than the faces) the edges blur, and must blur as in Cycles,
    whose aperture sits across each ray, focused along it. A mapping flipped left for right, or an
    equisolid lens taken for an equidistant one, fails it by far."""
    for name, (corners, colour) in CUBE_FACES.items():
        give_principled(plane(empty_scene, name, corners), name, Base_Color=(0, 0, 0, 1), Emission_Color=(*colour, 1),
                        Emission_Strength=1.0, Specular_IOR_Level=0.0)
    camera = add_camera(empty_scene, (0.3, -0.2, 0.1), rotation=(1.2, 0.1, 0.5)).data
    camera.type, camera.panorama_type = "PANO", kind
    camera.shift_x, camera.shift_y = shift
    for key, value in settings.items():
        setattr(camera, key, value)
    if dof:
        # F-Stop on the 50 mm lens Cycles takes for it, the focus distance
        # along each ray, the blades.
        camera.dof.use_dof = True
        camera.dof.aperture_fstop, camera.dof.focus_distance, camera.dof.aperture_blades = dof
    width, height = 40, 24
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = width, height
    empty_scene.view_settings.view_transform = "Standard"
    samples = 2048
    (c,), (g,) = render_seeds(empty_scene, tmp_path, samples, 0, 1)
    assert camera.type == "PANO", "the add-on left the camera perspective"
    # Both see the faces over much of the view.
    assert (c.sum(axis=2) > 0).mean() > 0.3 and (g.sum(axis=2) > 0).mean() > 0.3
    p = np.clip((c + g) / 2, 0, 1)
    tolerance = 5 * np.sqrt(2 * p * (1 - p) / samples) + 2e-3
    excess = np.abs(c - g) / tolerance
    worst = np.unravel_index(np.argmax(excess), excess.shape)
    assert excess.max() < 1, (kind, worst, c[worst[:2]], g[worst[:2]])


def plane(scene, name, corners):
    """A one-quad mesh object."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(corners, [], [(0, 1, 2, 3)])
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def assert_corner_coverage(scene, tmp_path, row0, col0):
    """Renders the plane whose corner is 0.3 pixel right of and 0.7 pixel
    above the corner of pixel (`row0`, `col0`) (rows bottom first, as
    Blender stores images: the row spans [0, 1] pixel above that corner),
    so that pixel's right neighbour is 70% covered, the one above it 30%,
    itself 21%. Cycles' stratified samples give these within 1e-3; Glint's
    independent samples are binomial noise, √(p(1−p)/N) ≤ 0.004 at
    2 × 8,192 spp: a 5 σ tolerance catches an offset of 0.03 pixel."""
    scene.view_settings.view_transform = "Standard"
    samples, seeds = 8192, 2
    cycles, glint = render_seeds(scene, tmp_path, samples, 1, seeds)
    c, g = np.mean(cycles, 0)[..., 0], np.mean(glint, 0)[..., 0]
    r, k = row0, col0
    expected = {(r + 1, k): 0.7, (r + 2, k): 0.7, (r, k + 1): 0.3, (r, k + 2): 0.3, (r, k): 0.21,
                (r - 1, k): 0.0, (r + 1, k - 1): 0.0, (r + 1, k + 1): 1.0}
    for (row, col), p in expected.items():
        tolerance = 5 * np.sqrt(p * (1 - p) / (samples * seeds)) + 1e-4
        assert abs(c[row, col] - p) < 1e-3, ("Cycles", row, col, c[row, col], p)
        assert abs(g[row, col] - p) < tolerance, ("Glint", row, col, g[row, col], p, tolerance)


@pytest.mark.parametrize("kind, width", [("BLACKMAN_HARRIS", 1.5), ("GAUSSIAN", 2.5), ("BLACKMAN_HARRIS", 0.7)])
def test_pixel_filter_spreads_the_corner_as_in_cycles(empty_scene, tmp_path, kind, width):
    """Film › Pixel Filter, Cycles' setting, which the add-on sends Glint:
    the plane's corner of `test_edge_pixels_cover_what_the_plane_covers`
    under a Blackman-Harris filter of Cycles' default Width 1.5 (and two
    others), every pixel of the 8 × 8 around the corner against Cycles
    within 5 σ of Glint's binomial noise (√(p(1−p)/N), Cycles' stratified
    samples far less noisy) plus 2e-3 for the two renderers' filter tables.
    In the run that added it: 0.0006, 0.0009 and 0.0002 at worst. Rendered
    with the one-pixel box, as before, 0.038, 0.137 and 0.144 (the noise
    is 0.0055 at most)."""
    import json

    from glint import daemon
    from helpers import render_rgb

    x0, y0 = 0.3 * PIXEL, 0.7 * PIXEL
    emitter = plane(empty_scene, "Plane", [(x0, y0, 0), (50, y0, 0), (50, 50, 0), (x0, 50, 0)])
    give_principled(emitter, "Emitter", Base_Color=(0, 0, 0, 1), Emission_Color=(1, 1, 1, 1),
                    Emission_Strength=1.0, Specular_IOR_Level=0.0)
    add_camera(empty_scene, (0, 0, DISTANCE), lens=LENS)
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = SIZE
    empty_scene.view_settings.view_transform = "Standard"
    samples, seeds = 4096, 2
    cycles, glint = [], []
    for seed in range(1, seeds + 1):
        fair_cycles(empty_scene, samples, 1, seed)
        empty_scene.cycles.pixel_filter_type, empty_scene.cycles.filter_width = kind, width
        cycles.append(render_rgb(tmp_path / f"c{seed}.exr"))
    empty_scene.render.engine = "GLINT"
    empty_scene.glint.samples, empty_scene.glint.max_bounces = samples, 1
    for seed in range(1, seeds + 1):
        empty_scene.glint.seed = seed
        glint.append(render_rgb(tmp_path / f"g{seed}.exr"))
    sent = json.loads(open(daemon.current().path("request.json")).read())["pixel_filter"]
    assert sent == {"type": kind.lower(), "width": pytest.approx(width)}, sent
    c, g = np.mean(cycles, 0)[..., 0], np.mean(glint, 0)[..., 0]
    r, k = SIZE // 2, SIZE // 2
    window = (slice(r - 4, r + 4), slice(k - 4, k + 4))
    tolerance = 5 * np.sqrt(np.clip(g[window] * (1 - g[window]), 0, None) / (samples * seeds)) + 2e-3
    worst = np.max(np.abs(c[window] - g[window]) - tolerance)
    print(f"{kind} {width}: worst |Cycles − Glint| {np.abs(c[window] - g[window]).max():.4f}, spread over {np.count_nonzero((c[window] > 1e-3) & (c[window] < 1 - 1e-3))} pixels")
    assert worst < 0, (np.round(c[window], 3), np.round(g[window], 3))
