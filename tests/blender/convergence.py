"""Error against run time, Glint and Cycles (and Mitsuba 3) side by side,
on one machine.

    GLINT_EXECUTABLE=target/release/glint  VENV/bin/python tests/blender/convergence.py [--out convergence] [--size 64] [--mitsuba]

For each comparison scene (the Cornell box, imported from scenes/ with
Blender's glTF importer, a rough gold sphere under an area light, a hall
of 32 area lights, a room lit by the World through a window with a
portal in it, the gold sphere again under a bulb: a point light of
radius 0.1 m, whose light the gold focuses onto the floor, and a sphere
of smooth glass in its place, lit from behind, which focuses the area
light onto the floor before it; and, named with --scenes, the glass
sphere with a sun as well, the gold sphere under a sun alone and the
window room with a sun shining in on a gold ball, for Glint and Cycles
only: mitsuba_scene.py has no sun), it:

1. renders a converged reference with each renderer (--reference-spp
   samples): each renderer's noise is measured against its own converged
   image, and its bias against Cycles' is printed beside;
2. renders with Cycles at 1, 2, 4, … samples (fair settings: CPU, no
   denoising, adaptive sampling or clamping, box filter, equal bounces),
   with Glint at 1, 2, 4, … samples of the same exported scene (`glint
   render`, its own rendering time, without load, BVH build and the lights'
   set-up, which its --stats report apart), and with
   --mitsuba, with Mitsuba 3 (`pip install mitsuba`; its LLVM variant needs
   Debian's libllvm19, found through DRJIT_LIBLLVM_PATH) on the scene
   converted by mitsuba_scene.py (its docstring lists what differs), timed
   after a first render at the same sample count has compiled its kernels;
3. measures the error of each image against the reference: relative MSE
   (mean of (x − ref)² / (ref² + 0.01), ε = 0.01) and RMSE; with --seeds N,
   N images per renderer and sample count (seeds 0 … N−1, the renderers
   taking turns seed by seed), their mean error and time, and the error's
   standard error in the CSV; a point of
   few samples takes more images, until they hold --min-samples samples
   per pixel (32: 32 images at 1 spp, 16 at 2, …): a single image's
   error there is a few fireflies' and scatters by tens of percent;
4. writes OUT/SCENE.csv and OUT/SCENE.png (log–log error against seconds,
   one curve per renderer) and prints the equal-error speed-ups: the time
   Cycles (or Mitsuba) needs for N samples divided by the time Glint needs
   to reach the same error (interpolated on its curve), with Glint's
   million rays per second and peak memory; and the time to a clean
   image: the seconds each renderer needs for relMSE 0.1, 0.03, 0.01 and
   0.003, past the end of a curve extrapolated by the 1/time law.

This is a benchmark that prints figures, not a test: the README holds the
latest table and plot.
"""

import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from helpers import add_camera, fair_cycles, give_principled, plain_world, read_exr  # noqa: E402

BOUNCES = int(os.environ.get("GLINT_BENCH_BOUNCES", 8))
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def cornell(scene):
    bpy.ops.import_scene.gltf(filepath=str(REPO / "scenes" / "cornell-box.gltf"))
    cameras = [o for o in scene.objects if o.type == "CAMERA"]
    scene.camera = cameras[0]
    scene.world = None


def gold_sphere(scene):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0)
    bpy.ops.object.shade_smooth()
    give_principled(bpy.context.object, "Gold", Base_Color=(1.0, 0.71, 0.29, 1), Metallic=1.0, Roughness=0.3)
    bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, -1))
    give_principled(bpy.context.object, "Floor", Base_Color=(0.5, 0.5, 0.5, 1), Roughness=0.8)
    light = bpy.data.lights.new("Key", "AREA")
    light.size, light.energy = 1.0, 300.0
    lamp = bpy.data.objects.new("Key", light)
    lamp.location = (2.0, -2.0, 3.0)
    lamp.rotation_euler = (math.radians(40), 0, math.radians(45))
    scene.collection.objects.link(lamp)
    plain_world(scene, (0.2, 0.2, 0.2))
    add_camera(scene, (0, -5, 1.0), (math.radians(85), 0, 0))


def gold_sphere_bulb(scene):
    """The gold sphere lit by a bulb instead: Blender's default point light
    (radius 0.1 m, soft falloff) of 1,000 W where the area light was. The
    light the gold focuses onto the floor reaches a camera path only
    where a floor point's BSDF sample meets the spot of the sphere that
    mirrors the bulb toward it: a caustic of a small light."""
    gold_sphere(scene)
    key = scene.objects["Key"]
    light = bpy.data.lights.new("Bulb", "POINT")
    light.energy, light.shadow_soft_size = 1000.0, 0.1
    bulb = bpy.data.objects.new("Bulb", light)
    bulb.location = key.location
    scene.collection.objects.link(bulb)
    bpy.data.objects.remove(key)


def glass_sphere(scene):
    """The gold sphere's scene with a sphere of smooth clear glass (IOR
    1.5) in its place and the area light moved behind it: the sphere
    focuses the light into a bright caustic on the floor in front of it,
    which a camera path finds only where a floor point's BSDF sample
    passes through the sphere onto the light."""
    gold_sphere(scene)
    sphere = next(o for o in scene.objects if o.type == "MESH" and o.active_material and o.active_material.name.startswith("Gold"))
    sphere.data.materials.clear()
    give_principled(sphere, "Glass", Base_Color=(1.0, 1.0, 1.0, 1), Roughness=0.0, Transmission_Weight=1.0, IOR=1.5)
    key = scene.objects["Key"]
    # Behind and above it, facing it, out of the camera's view (Mitsuba
    # would show it: Cycles hides lights from the camera, and Mitsuba's
    # only way to is to hide the World too).
    key.location = (-2.0, 2.0, 5.0)
    key.rotation_euler = (math.radians(29.4), 0, math.radians(225))
    # The Mitsuba conversion reads matrix_world, which moves with them only
    # once the view layer is updated.
    bpy.context.view_layer.update()


def lamp_hall(scene):
    """Many lights, few of which matter to a point: a hall 8 m wide, 42 m
    long and 3 m high (one Lambertian grey inside a box), lit by 32 square
    area lights of 0.4 m under its ceiling, two rows 2.5 m apart, of 10, 20
    and 30 W in turn; the camera at one end looks down it."""
    import bmesh

    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 19, 1.5), scale=(8, 42, 3))
    hall = bpy.context.object
    mesh = bmesh.new()
    mesh.from_mesh(hall.data)
    bmesh.ops.reverse_faces(mesh, faces=mesh.faces)  # facing in
    mesh.to_mesh(hall.data)
    mesh.free()
    # Lambertian (Specular IOR Level 0): Mitsuba's `diffuse`, as Cycles and
    # Glint shade it. Inside a closed box of albedo ρ the light is 1/(1 − ρ)
    # times the direct light, so any difference in ρ is tripled; Mitsuba's
    # Disney `principled` came out 70% brighter than Cycles here.
    give_principled(hall, "Hall", Base_Color=(0.7, 0.7, 0.7, 1), Roughness=0.8, Specular_IOR_Level=0.0)
    for i in range(16):
        for j, x in enumerate((-2.0, 2.0)):
            light = bpy.data.lights.new(f"Lamp {i} {j}", "AREA")
            light.size, light.energy = 0.4, 10.0 * (1 + (i + j) % 3)
            light.color = (1.0, 0.9, 0.8)
            lamp = bpy.data.objects.new(light.name, light)
            lamp.location = (x, 1.0 + 2.5 * i, 2.95)  # facing down, as area lights do
            scene.collection.objects.link(lamp)
    scene.world = None
    add_camera(scene, (0, -1.5, 1.6), (math.radians(89.5), 0, 0), lens=31.2)  # 60° field of view


def window_room(scene):
    """An interior lit only by the World through a window: the 4 × 4 × 3 m
    white room of test_portal_vs_cycles.py, its 1.2 × 1 m window holding a
    Cycles portal (Glint honours it; Mitsuba 3 has none and samples the
    World its own way)."""
    from test_portal_vs_cycles import room_with_a_window

    room_with_a_window(scene)


SCENES = {"cornell-box": cornell, "gold-sphere": gold_sphere, "lamp-hall": lamp_hall, "window-room": window_room, "gold-sphere-bulb": gold_sphere_bulb, "glass-sphere": glass_sphere}


def add_sun(scene):
    """A sun of 3 W·m⁻², 5° across (Blender's default is 0.5°), 50° above
    the horizon, from the camera's right."""
    light = bpy.data.lights.new("Sun", "SUN")
    light.energy, light.angle = 3.0, math.radians(5.0)
    sun = bpy.data.objects.new("Sun", light)
    sun.rotation_euler = (math.radians(40), 0, math.radians(30))
    scene.collection.objects.link(sun)


def glass_sphere_sun(scene):
    """The glass sphere with a sun as well (`add_sun`), whose light the
    sphere also focuses onto the floor: a camera path finds that caustic
    only where a BSDF sample goes through the sphere into the sun's
    5°."""
    glass_sphere(scene)
    add_sun(scene)


def gold_sphere_sun(scene):
    """The gold sphere lit by a sun (`add_sun`) instead of its area light,
    under the same World: the rough gold throws the sun onto the floor."""
    gold_sphere(scene)
    bpy.data.objects.remove(scene.objects["Key"])
    add_sun(scene)


def window_room_sun(scene):
    """The window room with a sun of 3 W·m⁻², 5° across, 35° above the
    horizon, shining in at its window onto a rough gold ball (0.4 m) on
    the floor, and no lamp: most of the sun's light lands on the room's
    outside, where no camera ray goes."""
    window_room(scene)
    light = bpy.data.lights.new("Sun", "SUN")
    light.energy, light.angle = 3.0, math.radians(5.0)
    sun = bpy.data.objects.new("Sun", light)
    sun.rotation_euler = (0.0, math.radians(55), 0.0)  # its light along −X, down 35°
    scene.collection.objects.link(sun)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=0.4, location=(0.0, 0.0, 0.4))
    bpy.ops.object.shade_smooth()
    give_principled(bpy.context.object, "Gold", Base_Color=(1.0, 0.71, 0.29, 1), Metallic=1.0, Roughness=0.3)
    bpy.context.view_layer.update()


def gold_sphere_sun_1km(scene):
    """The gold sphere under the sun (`gold_sphere_sun`) on a ground 1 km
    wide instead of its 20 m floor, as outdoor scenes have: the scene's
    bounding sphere is 50 times as wide, and the sphere 2 m across."""
    gold_sphere_sun(scene)
    floor = next(o for o in scene.objects if o.type == "MESH" and o.active_material and o.active_material.name.startswith("Floor"))
    floor.scale = (50.0, 50.0, 1.0)
    bpy.context.view_layer.update()


# Scenes that only `--scenes` runs: Mitsuba's conversion has no sun.
MORE_SCENES = {"glass-sphere-sun": glass_sphere_sun, "gold-sphere-sun": gold_sphere_sun, "gold-sphere-sun-1km": gold_sphere_sun_1km, "window-room-sun": window_room_sun}


def setup(build, size):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    build(scene)
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    fair_cycles(scene, 1, BOUNCES)
    scene.render.threads_mode = "AUTO"
    scene.glint.max_bounces = BOUNCES
    return scene


def cycles(scene, spp, path, seed=0):
    fair_cycles(scene, spp, BOUNCES, seed)
    start = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - start
    bpy.data.images["Render Result"].save_render(str(path))
    return read_exr(path)[..., :3].astype(np.float64), seconds


def export_for_glint(scene, folder):
    """The scene and request exactly as the add-on hands them to Glint."""
    import glint.export as export

    scene.render.engine = "GLINT"
    depsgraph = bpy.context.evaluated_depsgraph_get()
    export.export_scene(str(folder / "scene.glb"), scene.frame_current, scene.frame_subframe)
    size = scene.render.resolution_x
    request, _ = export.render_request(depsgraph, "convergence", size, size, str(folder))
    (folder / "request.json").write_bytes(export.json_bytes(request))


def glint_render(executable, folder, spp, path, stats=None, seed=0):
    out = subprocess.run(
        [executable, "render", str(folder / "scene.glb"), "--request", str(folder / "request.json"), "--spp", str(spp), "-o", str(path),
         "--max-depth", str(BOUNCES + 1), "--seed", str(seed), "--stats"],
        check=True,
        capture_output=True,
        text=True,
    )
    lines = out.stderr.strip().splitlines()
    # The summary line: "WxH, N spp, S s, M Mrays/s -> out.exr": rendering
    # only; its seconds are rounded to milliseconds, a few percent of a
    # 1-spp image, so they come from the stats line's time per sample
    # ("time: T s per sample …", five decimals) times the samples.
    summary = next(line for line in lines if " spp, " in line and "->" in line)
    per_sample = next(line for line in lines if line.startswith("time: "))
    seconds = max(float(per_sample.split()[1]) * spp, 1e-4)
    if stats is not None:
        stats["mrays"] = float(summary.split(",")[3].split()[0])
        stats["memory"] = next((line.split("peak RSS")[1].strip() for line in lines if "peak RSS" in line), "?")
        stats["setup"] = glint_setup_seconds(lines)
    return read_exr(path)[..., :3].astype(np.float64), seconds


def glint_setup_seconds(lines):
    """The set-up Glint's times leave out, from its --stats line "scene:
    …; load L s, BVH build B s, lights and the rest of the set-up R s":
    B + R (Cycles' times hold theirs, in its sync); None without it."""
    scene_line = next((line for line in lines if line.startswith("scene: ")), "")
    try:
        return sum(float(scene_line.split(key)[1].split()[0]) for key in ("BVH build ", "the rest of the set-up "))
    except (IndexError, ValueError):
        return None


def mitsuba_setup(scene):
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    import mitsuba as mi

    variant = os.environ.get("GLINT_BENCH_MITSUBA_VARIANT", "llvm_ad_rgb")
    mi.set_variant(variant)
    from mitsuba_scene import scene_dict

    return mi.load_dict(scene_dict(scene, BOUNCES)), variant


def mitsuba_render(mscene, spp, seed=0):
    import drjit as dr
    import mitsuba as mi

    # The first render at a sample count compiles its kernels: not timed.
    dr.eval(mi.render(mscene, spp=spp, seed=seed + 7919))
    dr.sync_thread()
    start = time.perf_counter()
    img = mi.render(mscene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    seconds = time.perf_counter() - start
    # Mitsuba's rows run top first, Blender's bottom first.
    return np.array(img, dtype=np.float64)[::-1, :, :3], seconds


def errors(img, ref):
    relmse = float(np.mean((img - ref) ** 2 / (ref**2 + 0.01)))
    rmse = float(np.sqrt(np.mean((img - ref) ** 2)))
    return relmse, rmse


def black_relmse(ref):
    """The relMSE of an all-black image against `ref`: mean(ref²/(ref² +
    ε)). An image with more error than this shows less of the scene than
    none at all, so the error levels above it say little of what a user
    sees: on a dim scene (a Cornell box, much of it in shade) it is well
    below 1."""
    return errors(np.zeros_like(ref), ref)[0]


def relative_seconds_se(row):
    """A point's time's standard error over its time; None where the row
    has no finite `seconds_se` or no time."""
    se = row.get("seconds_se", math.nan)
    return se / row["seconds"] if math.isfinite(se) and row["seconds"] > 0 else None


def relative_time_scatter(glint_rows, target):
    """The standard error, relative, of the time Glint's curve takes to
    `target` (`time_to_reach`): the larger of those of the points the
    time comes from, the first point's alone where it is that point's;
    None without `seconds_se`."""
    rse = [relative_seconds_se(r) for r in glint_rows]
    span = reached_between(curve_of(glint_rows, "glint"), target)
    if span is None or None in rse:
        return None
    return max(rse[k] for k in span)


def peer_rows(name, peer, rows, glint_curve, black):
    """One line a peer's point: its seconds and error, the seconds
    Glint's curve takes to that error and the speed-up, marked where the
    point's error is above a black image's (`black`, against the peer's
    own reference). Where the rows carry `seconds_se` (the standard error
    of a point's mean time over its images), the speed-up's standard
    error follows it (± s): the scatter of the timings within the run,
    which does not hold a slow spell of the machine that lasts longer
    than a point's images."""
    lines = [f"{name}: spp | {peer} s | {peer} relMSE | Glint s to that error | speed-up"]
    glint_rows = [r for r in rows if r["renderer"] == "glint"]
    for r in (r for r in rows if r["renderer"] == peer):
        t = time_to_reach(glint_curve, r["relmse"])
        speedup = f"{r['seconds'] / t:.1f}×" if t else "n/a"
        rse_glint = relative_time_scatter(glint_rows, r["relmse"]) if t else None
        rse_peer = relative_seconds_se(r)
        if rse_glint is not None and rse_peer is not None:
            speedup += f" ± {r['seconds'] / t * math.hypot(rse_peer, rse_glint):.2f}"
        mark = " (above a black image's error)" if r["relmse"] > black else ""
        lines.append(f"{name}: {r['spp']:5d} | {r['seconds']:8.3f} | {r['relmse']:.3e} | {t if t else float('nan'):8.3f} | {speedup}{mark}")
    return "\n".join(lines)


def curve_of(rows, renderer):
    """A renderer's (seconds, relMSE) points from the benchmark's rows."""
    return [(row["seconds"], row["relmse"]) for row in rows if row["renderer"] == renderer]


def clamped(curve):
    """A (seconds, error) curve with no time or error at zero, for logs."""
    return [(max(t, 1e-4), max(e, 1e-30)) for t, e in curve]


def reached_between(curve, target):
    """The indices (k, k + 1) of the two points of a (seconds, error)
    curve whose errors `target` lies between, the first such pair; (0,)
    where it lies at or above the first point's error alone; None when
    the curve never reaches it."""
    curve = clamped(curve)
    for k, ((_, e0), (_, e1)) in enumerate(zip(curve, curve[1:])):
        if e1 <= target <= e0 and e0 > e1:
            return (k, k + 1)
    if curve and curve[0][1] <= target:
        return (0,)
    return None


def time_to_reach(curve, target):
    """Seconds at which a (seconds, error) curve reaches `target`, by
    log–log interpolation; None when it never does within the curve."""
    span = reached_between(curve, target)
    if span is None:
        return None
    curve = clamped(curve)
    if len(span) == 1:
        return curve[0][0]
    (t0, e0), (t1, e1) = curve[span[0]], curve[span[1]]
    a = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
    return math.exp(math.log(t0) + a * (math.log(t1) - math.log(t0)))


# Errors at which an image counts as clean, for the time-to-clean table:
# relMSE 0.01 is about 10% noise in a mid-grey pixel.
CLEAN_LEVELS = (0.1, 0.03, 0.01, 0.003)


def time_to_level(curve, target):
    """(seconds, extrapolated): when a (seconds, error) curve reaches
    `target` — on the curve by log–log interpolation, or past its last
    point by the 1/time law of an unbiased estimator (error × time stays
    constant), then flagged; (None, False) for an empty curve."""
    t = time_to_reach(curve, target)
    if t is not None or not curve:
        return t, False
    t_last, e_last = curve[-1]
    return t_last * e_last / target, True


def clean_image_table(name, rows, renderers):
    """Seconds each renderer needs for an image of each `CLEAN_LEVELS`
    error, and Glint's lead over each peer there: the time a user waits
    for a clean image. A time past a curve's last point is extrapolated
    (marked ~)."""
    curves = {r: curve_of(rows, r) for r in renderers}
    lines = [f"{name}: time to relMSE | " + " | ".join(f"{r} s" for r in renderers) + " | " + " | ".join(f"over {r}" for r in renderers if r != "glint")]
    for level in CLEAN_LEVELS:
        times = {r: time_to_level(curves[r], level) for r in renderers}
        cells = [f"{'~' if x else ''}{t:.3f}" if t else "n/a" for t, x in times.values()]
        glint = times["glint"][0]
        leads = [f"{'~' if times[r][1] or times['glint'][1] else ''}{times[r][0] / glint:.1f}×" if glint and times[r][0] else "n/a" for r in renderers if r != "glint"]
        lines.append(f"{name}: {level:g} | " + " | ".join(cells) + " | " + " | ".join(leads))
    return "\n".join(lines)


def plot(name, rows, path, black=None):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    for renderer, style in (("glint", "o-"), ("cycles", "s--"), ("mitsuba", "^:")):
        pts = curve_of(rows, renderer)
        if not pts:
            continue
        ax.loglog([p[0] for p in pts], [p[1] for p in pts], style, label=renderer.capitalize())
    if black is not None:
        ax.axhline(black, color="grey", linewidth=0.8, linestyle="-.", label="an all-black image")
    ax.set_xlabel("rendering time (s)")
    ax.set_ylabel("relative MSE (ε = 0.01)")
    ax.set_title(f"{name}: error against time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def machine():
    """The processor, its cores and vector extensions: renderers' ratios
    depend on them (Mitsuba's LLVM kernels take the host's widest vectors,
    Glint's node test AVX where it is found)."""
    model, flags = "unknown processor", set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and model == "unknown processor":
                    model = value.strip()
                elif key.strip() == "flags" and not flags:
                    flags = set(value.split())
    except OSError:
        pass
    vectors = ", ".join(v for v in ("avx2", "fma", "avx512f") if v in flags) or "no AVX2"
    return f"{model}, {os.cpu_count()} cores, {vectors}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="convergence")
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--max-spp", type=int, default=256)
    parser.add_argument("--reference-spp", type=int, default=4096)
    parser.add_argument("--scenes", default=",".join(SCENES), help=f"of {', '.join(SCENES)} (the default) and {', '.join(MORE_SCENES)}")
    parser.add_argument("--mitsuba", action="store_true", help="also Mitsuba 3 (GLINT_BENCH_MITSUBA_VARIANT, default llvm_ad_rgb)")
    parser.add_argument("--seeds", type=int, default=1, help="images per renderer and sample count; the curves are their means")
    parser.add_argument("--min-samples", type=int, default=32, help="more images at low sample counts, until a point's images hold this many samples per pixel")
    parser.add_argument("--export", metavar="DIR", help="only write each scene as the add-on hands it to Glint, DIR/NAME/scene.glb and request.json, and stop")
    args = parser.parse_args()
    executable = os.environ.get("GLINT_EXECUTABLE", str(REPO / "target" / "release" / "glint"))
    out = Path(args.out)
    if not args.export:
        out.mkdir(parents=True, exist_ok=True)
        print(f"machine: {machine()}", flush=True)

    addons = tempfile.mkdtemp(prefix="glint-addon-path-")
    os.symlink(REPO / "addon", os.path.join(addons, "glint"))
    sys.path.insert(0, addons)
    import glint

    glint.register()
    os.environ["GLINT_EXECUTABLE"] = executable
    status = 0
    try:
        for name in args.scenes.split(","):
            scene = setup({**SCENES, **MORE_SCENES}[name], args.size)
            if args.export:
                folder = Path(args.export) / name
                folder.mkdir(parents=True, exist_ok=True)
                export_for_glint(scene, folder)
                print(f"{name}: wrote {folder / 'scene.glb'} and {folder / 'request.json'}", flush=True)
                continue
            work = Path(tempfile.mkdtemp(prefix=f"glint-conv-{name}-"))
            refs = {}
            refs["cycles"], ref_seconds = cycles(scene, args.reference_spp, work / "ref.exr", seed=12345)
            print(f"{name}: Cycles reference {args.reference_spp} spp in {ref_seconds:.1f} s", flush=True)
            export_for_glint(scene, work)
            # Its own seed, as the peers' references: the images at seed 0 would
            # otherwise be the first samples of the reference itself.
            refs["glint"], _ = glint_render(executable, work, args.reference_spp, work / "g-ref.exr", seed=12345)
            renderers = {
                "cycles": lambda spp, seed: cycles(scene, spp, work / f"c{spp}.exr", seed=seed),
                "glint": lambda spp, seed: glint_render(executable, work, spp, work / f"g{spp}.exr", stats, seed=seed),
            }
            stats = {}
            if args.mitsuba:
                mscene, variant = mitsuba_setup(scene)
                refs["mitsuba"], _ = mitsuba_render(mscene, args.reference_spp, seed=12345)
                renderers["mitsuba"] = lambda spp, seed: mitsuba_render(mscene, spp, seed=seed)
            rows = []
            spp = 1
            while spp <= args.max_spp:
                # Seeds 0, 1, …: one image each, the means reported (a
                # single image's error scatters by tens of percent). The
                # renderers take turns seed by seed, so that a slow spell
                # of a shared machine falls on all three alike.
                runs = {renderer: [] for renderer in renderers}
                for seed in range(max(args.seeds, -(-args.min_samples // spp))):
                    for renderer, render in renderers.items():
                        img, t = render(spp, seed)
                        runs[renderer].append((t, *errors(img, refs[renderer]), errors(img, refs["cycles"])[0]))
                for renderer, images in runs.items():
                    t, relmse, rmse, vs_cycles = (float(np.mean(column)) for column in zip(*images))
                    se, t_se = (float(np.std([r[k] for r in images], ddof=1) / math.sqrt(len(images))) if len(images) > 1 else float("nan") for k in (1, 0))
                    rows.append({"renderer": renderer, "spp": spp, "seconds": t, "seconds_se": t_se, "relmse": relmse, "relmse_se": se, "rmse": rmse,
                                 "relmse_vs_cycles": vs_cycles})
                spp *= 2
            with open(out / f"{name}.csv", "w", newline="") as f:
                w = csv.DictWriter(f, fieldnames=["renderer", "spp", "seconds", "seconds_se", "relmse", "relmse_se", "rmse", "relmse_vs_cycles"])
                w.writeheader()
                w.writerows(rows)
            blacks = {renderer: black_relmse(ref) for renderer, ref in refs.items()}
            plot(name, rows, out / f"{name}.png", blacks["cycles"])
            print(f"{name}: an all-black image's relMSE: " + ", ".join(f"{blacks[r]:.3f} against {r}'s reference" for r in renderers))
            for renderer, ref in refs.items():
                if renderer != "cycles":
                    bias = ref.reshape(-1, 3).mean(axis=0) / refs["cycles"].reshape(-1, 3).mean(axis=0) - 1
                    print(f"{name}: {renderer} bias against Cycles' reference (R, G, B): {np.round(bias * 100, 2)} %")
            outside = "" if stats.get("setup") is None else f", set-up outside its times (BVH build, lights) {stats['setup'] * 1000:.0f} ms"
            print(f"{name}: Glint {stats['mrays']:.1f} Mrays/s at {args.max_spp} spp, peak RSS {stats['memory']}{outside}")
            glint_curve = curve_of(rows, "glint")
            for peer in [p for p in renderers if p != "glint"]:
                print(peer_rows(name, peer, rows, glint_curve, blacks[peer]))
            print(clean_image_table(name, rows, list(renderers)), flush=True)
            print(f"{name}: wrote {out / (name + '.csv')} and {out / (name + '.png')}", flush=True)
    except Exception as e:  # noqa: BLE001
        print(f"error: {e}", file=sys.stderr)
        status = 1
    finally:
        glint.unregister()
        sys.stdout.flush()
        sys.stderr.flush()
        # bpy deadlocks at exit after a Python render engine has run.
        os._exit(status)


if __name__ == "__main__":
    main()
