"""The render engine: F12 → export → daemon → progress → result."""

import itertools
import os
import time

import bpy
import numpy as np

from . import daemon, export, preferences

POLL_SECONDS = 0.05
PREVIEW_SECONDS = 1.0
# After a cancel, how long to wait for the daemon to confirm.
CANCEL_WAIT_SECONDS = 5.0
# A daemon that has not started a job this long after it was handed over is
# stuck (it starts within its debounce time, 0.15 s, plus the scene load).
PICKUP_SECONDS = 120.0

_jobs = itertools.count(1)


class GlintRenderEngine(bpy.types.RenderEngine):
    bl_idname = "GLINT"
    bl_label = "Glint"
    bl_use_preview = False
    bl_use_postprocess = True
    # The viewport shows EEVEE's material preview; Glint renders finals.
    bl_use_eevee_viewport = True

    def __init__(self, *args, **kwargs):
        # Required from Blender 4.4 on.
        super().__init__(*args, **kwargs)

    def render(self, depsgraph):
        scene = depsgraph.scene
        scale = scene.render.resolution_percentage / 100.0
        width = max(1, int(scene.render.resolution_x * scale))
        height = max(1, int(scene.render.resolution_y * scale))
        try:
            ok = self._render(depsgraph, width, height)
        except Exception as e:  # noqa: BLE001 — the user sees one line, never a traceback
            self.report({"ERROR"}, f"Glint: {e}")
            ok = False
        if not ok and bpy.app.background and bpy.app.binary_path:
            # A farm runs `blender -b file.blend -E GLINT -f N`: a failed
            # frame must fail the command. (Not when Blender is a Python module.)
            import sys

            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(1)

    def _render(self, depsgraph, width, height):
        scene = depsgraph.scene
        try:
            executable = preferences.configured_executable()
        except preferences.ExecutableNotFound as e:
            self.report({"ERROR"}, f"Glint: {e}")
            return False
        threads = scene.glint.threads or max(1, (os.cpu_count() or 2) - 1)
        d = daemon.get(executable, threads)
        job = f"{os.getpid()}-{next(_jobs)}-frame{scene.frame_current}"
        self.update_stats("", "Glint: exporting")
        export.export_scene(d.path("scene.glb"), scene.frame_current, scene.frame_subframe)
        request, warnings = export.render_request(depsgraph, job, width, height, d.job_dir)
        for w in warnings:
            self.report({"WARNING"}, f"Glint: {w}")
        d.put("request.json", export.json_bytes(request))
        return self._follow(d, job, width, height)

    def _follow(self, d, job, width, height):
        """Poll the daemon's status until our job ends; show images as they come."""
        result = self.begin_result(0, 0, width, height)
        shown_sequence = None
        last_preview = 0.0
        cancelled_at = None
        handed_over = time.monotonic()
        shown_stats = None
        warned = False
        while True:
            if cancelled_at is None and self._cancel_requested():
                d.cancel()
                cancelled_at = time.monotonic()
            if not d.alive():
                self.end_result(result, cancel=True)
                self.report({"ERROR"}, f"Glint: the renderer stopped unexpectedly: {d.log_tail(1)}")
                return False
            status = d.status()
            mine = status is not None and status.get("job") == job
            state = status.get("state") if mine else None
            if not mine and cancelled_at is None and time.monotonic() - handed_over > PICKUP_SECONDS:
                self.end_result(result, cancel=True)
                self.report({"ERROR"}, f"Glint: the renderer did not start the job: {d.log_tail(1)}")
                return False
            if cancelled_at is not None and (state in {"cancelled", "done", "error"} or time.monotonic() - cancelled_at > CANCEL_WAIT_SECONDS):
                self.end_result(result, cancel=True)
                return True
            if state == "error":
                self.end_result(result, cancel=True)
                self.report({"ERROR"}, f"Glint: {status.get('message', 'render failed')}")
                return False
            if mine and state in {"rendering", "done"}:
                if not warned:
                    for w in status.get("warnings", []):
                        self.report({"WARNING"}, f"Glint: {w}")
                    warned = True
                samples, total = status.get("samples", 0), status.get("total_samples", 0)
                elapsed = status.get("elapsed", 0.0)
                # Adaptive sampling and a time limit end with fewer
                # samples than the budget: done is the whole bar.
                if state == "done":
                    self._show_progress(1.0)
                elif total:
                    self._show_progress(min(1.0, samples / total))
                stats = f"Glint | {samples}{'/' + str(total) if total else ''} samples | {elapsed:.1f} s"
                if stats != shown_stats:
                    # Blender prints every update in background mode.
                    self.update_stats("", stats)
                    shown_stats = stats
                final = state == "done"
                fresh = status.get("sequence") != shown_sequence and samples > 0
                if fresh and (final or time.monotonic() - last_preview >= PREVIEW_SECONDS):
                    if self._load_image(result, status.get("output") or d.path("render.exr"), width, height):
                        shown_sequence = status.get("sequence")
                        last_preview = time.monotonic()
                        if not final:
                            self.update_result(result)
                if final:
                    self.end_result(result)
                    return True
            time.sleep(POLL_SECONDS)

    def _show_progress(self, fraction):
        """Blender's progress bar (a seam for tests, which cannot read it)."""
        self.update_progress(fraction)

    def _cancel_requested(self):
        """Esc in the render window, or a farm's abort (a seam for tests,
        which cannot press Esc)."""
        return self.test_break()

    def _load_image(self, result, path, width, height):
        """Copy an EXR into the result. RenderLayer.load_from_file wants a
        multilayer EXR with Blender's pass names, so the image is read through
        bpy.data.images instead."""
        if not os.path.isfile(path):
            return False
        image = bpy.data.images.load(path, check_existing=False)
        try:
            if tuple(image.size) != (width, height):
                return False
            pixels = np.empty(width * height * 4, dtype=np.float32)
            image.pixels.foreach_get(pixels)
            result.layers[0].passes["Combined"].rect.foreach_set(pixels)
            return True
        finally:
            bpy.data.images.remove(image)


def register():
    bpy.utils.register_class(GlintRenderEngine)


def unregister():
    bpy.utils.unregister_class(GlintRenderEngine)
