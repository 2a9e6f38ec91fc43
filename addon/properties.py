"""Glint's render settings and their panel in the Render properties."""

import bpy


class GlintRenderSettings(bpy.types.PropertyGroup):
    samples: bpy.props.IntProperty(name="Samples", description="Samples per pixel", default=64, min=1, max=1_000_000)
    max_bounces: bpy.props.IntProperty(
        name="Max Bounces", description="Most bounces of a path (as Cycles' Max Bounces: 0 is direct light only)", default=12, min=0, max=1023
    )
    time_limit: bpy.props.FloatProperty(
        name="Time Limit", description="Stop adding samples after this long (0: no limit)", default=0.0, min=0.0, subtype="TIME_ABSOLUTE", unit="TIME_ABSOLUTE"
    )
    use_adaptive_sampling: bpy.props.BoolProperty(
        name="Noise Threshold",
        description="Adaptive sampling, as Cycles': a pixel stops taking samples once its noise is below the threshold, "
        "and Samples becomes the most a pixel takes",
        default=False,
    )
    adaptive_threshold: bpy.props.FloatProperty(
        name="Noise Threshold",
        description="Noise level at which a pixel stops taking samples (as Cycles': typical values 0.1 to 0.001; lower is cleaner and slower)",
        default=0.01,
        min=0.0001,
        max=1.0,
        precision=4,
    )
    adaptive_min_samples: bpy.props.IntProperty(
        name="Min Samples",
        description="Samples every pixel takes before adaptive sampling stops any (0: from the threshold, as Cycles)",
        default=0,
        min=0,
        max=1_000_000,
    )
    seed: bpy.props.IntProperty(name="Seed", description="Random seed: the same seed gives the same image", default=0, min=0)
    bsdf: bpy.props.EnumProperty(
        name="BSDF",
        description="How materials reflect light",
        items=[
            ("PRINCIPLED", "Principled", "What Cycles' Principled BSDF does (multiscatter GGX, energy-conserving layering)"),
            ("SEED", "Seed", "Glint's first model (Schlick-GGX, kd = (1 − F)(1 − metallic)), for comparison"),
        ],
        default="PRINCIPLED",
    )
    light_paths: bpy.props.EnumProperty(
        name="Light Paths",
        description="Paths traced from the lights and joined to the camera's: they find light that camera paths reach only by chance "
        "(caustics, the patch a lamp lights beside it, the indirect light of a scene open to the World on some sides)",
        items=[
            ("AUTO", "Auto", "Where they pay for their time: Glint decides from the scene (its first line says which)"),
            ("ON", "On", "Always, where there are emitting surfaces or area lights to start them"),
            ("OFF", "Off", "Never: camera paths alone"),
        ],
        default="AUTO",
    )
    threads: bpy.props.IntProperty(
        name="Threads", description="Render threads (0: all cores but one, so Blender stays responsive)", default=0, min=0, max=1024
    )


class RENDER_PT_glint_sampling(bpy.types.Panel):
    bl_label = "Glint"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {"GLINT"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.glint
        col = layout.column()
        # Cycles' layout: the threshold's checkbox in its row's heading.
        row = col.row(heading="Noise Threshold")
        row.prop(settings, "use_adaptive_sampling", text="")
        sub = row.row()
        sub.active = settings.use_adaptive_sampling
        sub.prop(settings, "adaptive_threshold", text="")
        col.prop(settings, "samples", text="Max Samples" if settings.use_adaptive_sampling else "Samples")
        sub = col.column()
        sub.active = settings.use_adaptive_sampling
        sub.prop(settings, "adaptive_min_samples")
        col.prop(settings, "time_limit")
        col.prop(settings, "max_bounces")
        col.prop(settings, "seed")
        col.prop(settings, "bsdf")
        col.prop(settings, "light_paths")
        col.prop(settings, "threads")
        # Film › Transparent, and Cycles' own Pixel Filter and Transparent
        # Glass settings (kept in the .blend by Cycles; Glint renders them
        # the same way).
        render, cycles = context.scene.render, getattr(context.scene, "cycles", None)
        if cycles is not None:
            col.prop(cycles, "pixel_filter_type", text="Pixel Filter")
            sub = col.column()
            sub.active = cycles.pixel_filter_type != "BOX"
            sub.prop(cycles, "filter_width", text="Width")
        col.prop(render, "film_transparent")
        if cycles is not None:
            sub = col.column()
            sub.active = render.film_transparent
            sub.prop(cycles, "film_transparent_glass", text="Transparent Glass")
            sub = sub.column()
            sub.active = render.film_transparent and cycles.film_transparent_glass
            sub.prop(cycles, "film_transparent_roughness", text="Roughness Threshold")


# Blender's own panels (output format, dimensions, lights, materials...)
# list the engines they draw for; the ones Blender's renderer uses apply to
# Glint as well. These two are about Blender's own render passes.
_EXCLUDED_PANELS = {"VIEWLAYER_PT_filter", "VIEWLAYER_PT_layer_passes"}


def _shared_panels():
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if engines is not None and "BLENDER_RENDER" in engines and panel.__name__ not in _EXCLUDED_PANELS:
            yield panel


def register():
    bpy.utils.register_class(GlintRenderSettings)
    bpy.types.Scene.glint = bpy.props.PointerProperty(type=GlintRenderSettings)
    bpy.utils.register_class(RENDER_PT_glint_sampling)
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.add("GLINT")


def unregister():
    for panel in _shared_panels():
        panel.COMPAT_ENGINES.discard("GLINT")
    bpy.utils.unregister_class(RENDER_PT_glint_sampling)
    del bpy.types.Scene.glint
    bpy.utils.unregister_class(GlintRenderSettings)
