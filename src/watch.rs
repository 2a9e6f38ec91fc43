//! `glint watch`: the render daemon. It follows a job folder (or one scene
//! file) with `notify` and renders whenever the scene or its render request
//! changes.
//!
//! A job folder holds:
//!
//! | file | written by | what |
//! |---|---|---|
//! | `scene.glb` or `scene.gltf` (+ `.bin`) | client | the scene (the request's `scene` may name another) |
//! | `request.json` | client | a render request (`request.rs`); optional |
//! | `cancel` | client | stops the render in progress; the daemon removes it |
//! | `render.exr` | daemon | the image (the request's `output` may name another), rewritten as samples accumulate |
//! | `status.json` | daemon | `{job, state, samples, total_samples, elapsed, width, height, output, message, warnings, sequence}` |
//!
//! Watching a scene file `NAME.glb` instead, the others are `NAME.request.json`,
//! `NAME.cancel`, `NAME.exr` and `NAME.status.json` beside it.
//!
//! Clients write files under a temporary name starting with `.` and rename
//! them; such names are ignored. A burst of changes renders once, after
//! `DEBOUNCE` of quiet; a change during a render cancels it and starts over.
//! `state` is `waiting`, `rendering`, `done`, `cancelled` or `error` (then
//! `message` says why in one line). Every status is also printed on stdout
//! as one line: `STATE samples=N/TOTAL elapsed=S job=ID`, or
//! `error: MESSAGE job=ID`. A broken scene or request never replaces the
//! last good image; the daemon reports it and waits for the next change.

use crate::integrator::Context;
use crate::job::{self, JobOptions};
use crate::output;
use crate::progressive::render_progressive;
use crate::render::Film;
use crate::request::RenderRequest;
use anyhow::{bail, Context as _, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{channel, RecvTimeoutError};
use std::time::{Duration, Instant};

/// Quiet time after the last change before a render starts.
pub const DEBOUNCE: Duration = Duration::from_millis(150);
/// The image is rewritten at most this often while samples accumulate.
pub const IMAGE_CADENCE: Duration = Duration::from_secs(1);

pub struct WatchOptions {
    pub target: PathBuf,
    /// What a render request leaves out.
    pub defaults: JobOptions,
    pub exit_with_stdin: bool,
}

/// The files of one job.
#[derive(Clone, Debug)]
pub struct JobPaths {
    pub dir: PathBuf,
    /// A watched scene file; None: a job folder.
    pub scene_file: Option<PathBuf>,
    pub request: PathBuf,
    pub cancel: PathBuf,
    pub status: PathBuf,
    pub default_output: PathBuf,
}

impl JobPaths {
    pub fn new(target: &Path) -> Result<Self> {
        if target.is_dir() {
            let dir = target.to_path_buf();
            return Ok(JobPaths {
                scene_file: None,
                request: dir.join("request.json"),
                cancel: dir.join("cancel"),
                status: dir.join("status.json"),
                default_output: dir.join("render.exr"),
                dir,
            });
        }
        let name = target.file_name().and_then(|n| n.to_str()).context("the target has no file name")?;
        let stem = name.strip_suffix(".glb").or_else(|| name.strip_suffix(".gltf"));
        let Some(stem) = stem else { bail!("{}: not a folder, a .glb or a .gltf file", target.display()) };
        let dir = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        if !dir.is_dir() {
            bail!("{}: folder does not exist", dir.display());
        }
        Ok(JobPaths {
            scene_file: Some(target.to_path_buf()),
            request: dir.join(format!("{stem}.request.json")),
            cancel: dir.join(format!("{stem}.cancel")),
            status: dir.join(format!("{stem}.status.json")),
            default_output: dir.join(format!("{stem}.exr")),
            dir,
        })
    }

    /// The scene to render for a request.
    fn scene(&self, request: &RenderRequest) -> PathBuf {
        if let Some(f) = &self.scene_file {
            return f.clone();
        }
        if let Some(name) = &request.scene {
            return self.dir.join(name);
        }
        let glb = self.dir.join("scene.glb");
        if glb.exists() { glb } else { self.dir.join("scene.gltf") }
    }

    /// What a change to `path` means.
    fn classify(&self, path: &Path) -> Option<Signal> {
        let name = path.file_name()?.to_str()?;
        if path == self.cancel {
            return Some(Signal::Cancel);
        }
        if name.starts_with('.') || path == self.status || name.ends_with(".exr") {
            return None;
        }
        match &self.scene_file {
            Some(scene) => (path == scene || path == self.request).then_some(Signal::Changed),
            None => Some(Signal::Changed),
        }
    }
}

enum Signal {
    Changed,
    Cancel,
    Quit,
    Finished(Outcome),
}

enum Outcome {
    Done,
    Cancelled,
    Failed(String),
}

/// Writes `status.json` and the matching stdout line.
struct Status<'a> {
    paths: &'a JobPaths,
    sequence: AtomicU64,
}

struct StatusLine<'a> {
    job: Option<&'a str>,
    state: &'a str,
    samples: u32,
    total_samples: u32,
    elapsed: f64,
    size: (u32, u32),
    output: Option<&'a Path>,
    message: &'a str,
    /// The scene's load warnings, for the client to show.
    warnings: &'a [String],
}

impl Status<'_> {
    fn write(&self, s: StatusLine) {
        let sequence = self.sequence.fetch_add(1, Ordering::Relaxed) + 1;
        let json = serde_json::json!({
            "job": s.job, "state": s.state, "samples": s.samples, "total_samples": s.total_samples,
            "elapsed": s.elapsed, "width": s.size.0, "height": s.size.1,
            "output": s.output.map(|p| p.display().to_string()), "message": s.message, "warnings": s.warnings, "sequence": sequence,
        });
        if let Err(e) = output::write_bytes_atomically(&self.paths.status, json.to_string().as_bytes()) {
            crate::stderr_line!("glint watch: {e:#}");
        }
        let job = s.job.unwrap_or("-");
        if s.state == "error" {
            crate::stdout_line!("error: {} job={job}", s.message);
        } else {
            crate::stdout_line!("{} samples={}/{} elapsed={:.2} job={job}", s.state, s.samples, s.total_samples, s.elapsed);
        }
    }

    fn simple(&self, job: Option<&str>, state: &str, message: &str) {
        self.write(StatusLine { job, state, samples: 0, total_samples: 0, elapsed: 0.0, size: (0, 0), output: None, message, warnings: &[] });
    }
}

/// Watch until standard input closes (with `exit_with_stdin`) or forever.
pub fn run(options: &WatchOptions, pool: &rayon::ThreadPool) -> Result<()> {
    let paths = JobPaths::new(&options.target)?;
    let (tx, rx) = channel::<Signal>();
    let watch_tx = tx.clone();
    let classifier = paths.clone();
    let mut watcher = notify::recommended_watcher(move |event: notify::Result<notify::Event>| match event {
        Ok(event) => {
            // Reading the scene makes access events: only real changes count.
            use notify::event::{EventKind, MetadataKind, ModifyKind};
            let changes = match event.kind {
                EventKind::Modify(ModifyKind::Metadata(MetadataKind::AccessTime)) => false,
                EventKind::Create(_) | EventKind::Modify(_) | EventKind::Remove(_) => true,
                _ => false,
            };
            if !changes {
                return;
            }
            for signal in event.paths.iter().filter_map(|p| classifier.classify(p)) {
                let _ = watch_tx.send(signal);
            }
        }
        Err(e) => crate::stderr_line!("glint watch: {e}"),
    })
    .context("cannot start watching files")?;
    notify::Watcher::watch(&mut watcher, &paths.dir, notify::RecursiveMode::NonRecursive)
        .with_context(|| format!("{}: cannot watch", paths.dir.display()))?;
    if options.exit_with_stdin {
        let stdin_tx = tx.clone();
        std::thread::spawn(move || {
            let _ = std::io::copy(&mut std::io::stdin().lock(), &mut std::io::sink());
            let _ = stdin_tx.send(Signal::Quit);
        });
    }
    let status = Status { paths: &paths, sequence: AtomicU64::new(0) };
    crate::stderr_line!("glint watch: following {}", options.target.display());
    let _ = std::fs::remove_file(&paths.cancel);
    let mut dirty = paths.request.exists() || paths.scene(&RenderRequest::default()).exists();
    if !dirty {
        status.simple(None, "waiting", "");
    }
    loop {
        // Wait for a change, then for quiet.
        let mut quiet_since_change = false;
        while !(dirty && quiet_since_change) {
            let next = if dirty { rx.recv_timeout(DEBOUNCE) } else { rx.recv().map_err(|_| RecvTimeoutError::Disconnected) };
            match next {
                Ok(Signal::Changed) => {
                    dirty = true;
                    quiet_since_change = false;
                }
                Ok(Signal::Cancel) => {
                    let _ = std::fs::remove_file(&paths.cancel);
                    if dirty {
                        dirty = false;
                        status.simple(None, "cancelled", "");
                    }
                }
                Ok(Signal::Quit) | Err(RecvTimeoutError::Disconnected) => return Ok(()),
                Ok(Signal::Finished(_)) => {}
                Err(RecvTimeoutError::Timeout) => quiet_since_change = true,
            }
        }
        dirty = false;
        let cancel = AtomicBool::new(false);
        let mut quit = false;
        std::thread::scope(|scope| {
            let done_tx = tx.clone();
            let (paths, cancel, status) = (&paths, &cancel, &status);
            scope.spawn(move || {
                let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| pool.install(|| render_job(paths, &options.defaults, cancel, status))))
                    .unwrap_or_else(|_| Outcome::Failed("internal error: the renderer panicked (please report this scene)".into()));
                let _ = done_tx.send(Signal::Finished(outcome));
            });
            loop {
                match rx.recv() {
                    Ok(Signal::Changed) => {
                        // Start over on the new content once this render stops.
                        dirty = true;
                        cancel.store(true, Ordering::Relaxed);
                    }
                    Ok(Signal::Cancel) => {
                        let _ = std::fs::remove_file(&paths.cancel);
                        dirty = false;
                        cancel.store(true, Ordering::Relaxed);
                    }
                    Ok(Signal::Quit) | Err(_) => {
                        quit = true;
                        cancel.store(true, Ordering::Relaxed);
                    }
                    Ok(Signal::Finished(outcome)) => {
                        if let Outcome::Failed(message) = outcome {
                            crate::stderr_line!("glint watch: {message}");
                        }
                        break;
                    }
                }
            }
        });
        if quit {
            return Ok(());
        }
    }
}

/// Read the request and the scene, render progressively, and report.
fn render_job(paths: &JobPaths, defaults: &JobOptions, cancel: &AtomicBool, status: &Status) -> Outcome {
    let request = if paths.request.exists() {
        match RenderRequest::read(&paths.request) {
            Ok(r) => r,
            Err(e) => return failed(status, None, format!("{}: {e}", paths.request.display())),
        }
    } else {
        RenderRequest::default()
    };
    let job_id = request.job.as_deref();
    let mut options = JobOptions::from(&request).or(defaults);
    let camera_environment = options.camera_world.as_mut().and_then(|w| w.environment.as_mut());
    for env in options.environment.iter_mut().chain(camera_environment) {
        env.image = paths.dir.join(&env.image);
    }
    let scene_path = paths.scene(&request);
    let output_path = request.output.as_ref().map_or(paths.default_output.clone(), |o| paths.dir.join(o));
    let job = match job::prepare(Some(&scene_path), &options, (&request).into()) {
        Ok(job) => job,
        Err(e) => return failed(status, job_id, e),
    };
    for w in &job.scene.warnings {
        crate::stderr_line!("glint watch: warning: {}: {w}", scene_path.display());
    }
    let (settings, budget) = (&job.settings, &job.budget);
    let (ctx, _) = Context::new(&job.scene);
    let features = ctx.features_line(settings);
    crate::stderr_line!("glint watch: {}: {features}", scene_path.display());
    let mut film = Film::new(settings.width, settings.height);
    let line = |state, samples, elapsed, message| StatusLine {
        job: job_id,
        state,
        samples,
        total_samples: budget.samples,
        elapsed,
        size: (settings.width, settings.height),
        output: Some(&output_path),
        message,
        warnings: &job.scene.warnings,
    };
    status.write(line("rendering", 0, 0.0, &features));
    let mut last_image: Option<Instant> = None;
    let mut write_error: Option<String> = None;
    let result = render_progressive(&ctx, settings, budget, &mut film, cancel, &|_| {}, &mut |p| {
        if p.finished || last_image.is_none_or(|t| t.elapsed() >= IMAGE_CADENCE) {
            if let Err(e) = output::write_exr(&output_path, settings.width, settings.height, &p.film.mean(), p.film.alpha().as_deref()) {
                write_error = Some(format!("{e:#}"));
                cancel.store(true, Ordering::Relaxed);
                return;
            }
            last_image = Some(Instant::now());
        }
        if !p.finished {
            status.write(line("rendering", p.film.samples, p.elapsed.as_secs_f64(), ""));
        } else {
            status.write(line("done", p.film.samples, p.elapsed.as_secs_f64(), ""));
        }
    });
    if let Some(e) = write_error {
        return failed(status, job_id, e);
    }
    match result {
        Ok(_) => Outcome::Done,
        Err(_) => {
            status.write(line("cancelled", film.samples, 0.0, ""));
            Outcome::Cancelled
        }
    }
}

fn failed(status: &Status, job: Option<&str>, message: String) -> Outcome {
    let message = message.replace('\n', " ");
    status.simple(job, "error", &message);
    Outcome::Failed(message)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn own_writes_and_temp_files_are_not_changes() {
        let dir = std::env::temp_dir();
        let p = JobPaths::new(&dir).unwrap();
        assert!(matches!(p.classify(&dir.join("scene.glb")), Some(Signal::Changed)));
        assert!(matches!(p.classify(&dir.join("request.json")), Some(Signal::Changed)));
        assert!(matches!(p.classify(&dir.join("cancel")), Some(Signal::Cancel)));
        for ignored in ["status.json", "render.exr", ".scene.glb.tmp", ".status.json.12.tmp"] {
            assert!(p.classify(&dir.join(ignored)).is_none(), "{ignored}");
        }
        let f = JobPaths::new(&dir.join("shot.glb")).unwrap();
        assert_eq!(f.request, dir.join("shot.request.json"));
        assert!(matches!(f.classify(&dir.join("shot.glb")), Some(Signal::Changed)));
        assert!(f.classify(&dir.join("other.glb")).is_none());
        assert!(JobPaths::new(&dir.join("shot.obj")).is_err());
    }
}
