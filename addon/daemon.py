"""The `glint watch` daemon, seen from Blender: one per Blender session,
started on the first render and reused, watching one job folder.

The protocol (see src/watch.rs): the add-on renames `scene.glb` and
`request.json` into the folder; the daemon renders and rewrites `render.exr`
and `status.json` atomically; an empty file named `cancel` stops a render.
The daemon reads its standard input from a pipe that only this process holds,
so it quits when Blender does, however Blender ends.
"""

import atexit
import json
import os
import shutil
import subprocess
import tempfile

_daemon = None


class DaemonError(Exception):
    pass


class Daemon:
    def __init__(self, executable, threads):
        self.executable = executable
        self.threads = threads
        self.job_dir = tempfile.mkdtemp(prefix="glint-blender-")
        # Hidden (a leading dot): the daemon ignores it as a change.
        self.log_path = os.path.join(self.job_dir, ".daemon.log")
        self._log = open(self.log_path, "wb")
        args = [executable, "watch", self.job_dir, "--exit-with-stdin"]
        if threads > 0:
            args += ["--threads", str(threads)]
        try:
            self.process = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=self._log, stderr=subprocess.STDOUT)
        except OSError as e:
            self._log.close()
            shutil.rmtree(self.job_dir, ignore_errors=True)
            raise DaemonError(f"cannot start {executable}: {e}") from e

    def alive(self):
        return self.process.poll() is None

    def path(self, name):
        return os.path.join(self.job_dir, name)

    def put(self, name, data: bytes):
        """Write a file into the job folder under a temporary name, then rename."""
        tmp = self.path(f".{name}.tmp")
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, self.path(name))

    def status(self):
        """The daemon's last status, or None before its first."""
        try:
            with open(self.path("status.json"), "rb") as f:
                return json.loads(f.read())
        except (OSError, ValueError):
            return None

    def cancel(self):
        self.put("cancel", b"")

    def log_tail(self, lines=5):
        try:
            with open(self.log_path, "rb") as f:
                text = f.read().decode("utf-8", "replace")
        except OSError:
            return ""
        return "\n".join(text.strip().splitlines()[-lines:])

    def stop(self):
        if self.process.stdin:
            try:
                self.process.stdin.close()
            except OSError:
                pass
        try:
            self.process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self._log.close()
        shutil.rmtree(self.job_dir, ignore_errors=True)


def get(executable, threads):
    """The running daemon, started (again) when needed."""
    global _daemon
    if _daemon is not None and (not _daemon.alive() or _daemon.executable != executable or _daemon.threads != threads):
        _daemon.stop()
        _daemon = None
    if _daemon is None:
        _daemon = Daemon(executable, threads)
    return _daemon


def current():
    return _daemon


def stop():
    global _daemon
    if _daemon is not None:
        _daemon.stop()
        _daemon = None


atexit.register(stop)
