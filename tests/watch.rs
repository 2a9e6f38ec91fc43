//! `glint watch`, driven as the Blender addon drives it: files written under
//! a temporary name and renamed into a job folder, the daemon's status read
//! from its stdout lines and status.json.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

/// Generous: only a hung or broken daemon takes this long.
const TIMEOUT: Duration = Duration::from_secs(60);

struct Daemon {
    child: Child,
    lines: Receiver<String>,
    seen: Vec<String>,
    stdin: Option<ChildStdin>,
}

impl Daemon {
    fn spawn(target: &Path, extra: &[&str]) -> Child {
        Command::new(env!("CARGO_BIN_EXE_glint"))
            .arg("watch")
            .arg(target)
            .args(["--width", "32", "--height", "32", "--threads", "2"])
            .args(extra)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start glint watch")
    }

    fn start(target: &Path, extra: &[&str]) -> Daemon {
        let mut child = Self::spawn(target, extra);
        let (tx, lines) = channel();
        let out = BufReader::new(child.stdout.take().unwrap());
        std::thread::spawn(move || {
            for line in out.lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        let stdin = child.stdin.take();
        Daemon { child, lines, seen: Vec::new(), stdin }
    }

    /// A daemon whose client has stopped reading: its stdout and stderr
    /// closed at once, so it has no status lines to wait for.
    fn start_unread(target: &Path, extra: &[&str]) -> Daemon {
        let mut child = Self::spawn(target, extra);
        drop(child.stdout.take());
        drop(child.stderr.take());
        let stdin = child.stdin.take();
        Daemon { child, lines: channel().1, seen: Vec::new(), stdin }
    }

    /// Read status lines until one satisfies `want`; returns it.
    fn wait_for(&mut self, what: &str, want: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        while start.elapsed() < TIMEOUT {
            if let Ok(line) = self.lines.recv_timeout(Duration::from_millis(100)) {
                self.seen.push(line.clone());
                if want(&line) {
                    return line;
                }
            }
        }
        panic!("no status line {what} within {TIMEOUT:?}; saw {:#?}", self.seen);
    }

    /// Status lines that arrive within `quiet`.
    fn drain(&mut self, quiet: Duration) {
        while let Ok(line) = self.lines.recv_timeout(quiet) {
            self.seen.push(line);
        }
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn job_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("glint-watch-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// As a client must: a temporary name, then a rename.
fn put(dir: &Path, name: &str, bytes: &[u8]) {
    let tmp = dir.join(format!(".{name}.tmp"));
    std::fs::write(&tmp, bytes).unwrap();
    std::fs::rename(&tmp, dir.join(name)).unwrap();
}

fn request(job: &str, extra: &str) -> Vec<u8> {
    format!(r#"{{"job": "{job}", "width": 32, "height": 32 {extra}}}"#).into_bytes()
}

fn done(job: &str) -> impl Fn(&str) -> bool + '_ {
    move |l: &str| l.starts_with("done ") && l.ends_with(&format!("job={job}"))
}

const SCENE: &str = glint::DEFAULT_SCENE;

#[test]
fn a_changed_scene_renders_again_and_the_image_follows_it() {
    let dir = job_dir("change");
    put(&dir, "scene.gltf", SCENE.as_bytes());
    put(&dir, "request.json", &request("first", r#", "samples": 4"#));
    let mut d = Daemon::start(&dir, &[]);
    d.wait_for("done first", done("first"));
    let (w, h, first) = glint::output::read_exr(&dir.join("render.exr")).unwrap();
    assert_eq!((w, h), (32, 32));
    // Twice the light, twice the image (same seed, same paths).
    let brighter = SCENE.replace("\"emissiveStrength\": 17.0", "\"emissiveStrength\": 34.0");
    assert_ne!(brighter, SCENE, "the test must find the light's strength in the scene");
    put(&dir, "scene.gltf", brighter.as_bytes());
    put(&dir, "request.json", &request("second", r#", "samples": 4"#));
    d.wait_for("done second", done("second"));
    let (_, _, second) = glint::output::read_exr(&dir.join("render.exr")).unwrap();
    let mean = |img: &[glint::Vec3]| img.iter().map(|p| p.element_sum() as f64).sum::<f64>();
    let ratio = mean(&second) / mean(&first);
    assert!((ratio - 2.0).abs() < 1e-3, "ratio {ratio}");
    let status: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("status.json")).unwrap()).unwrap();
    assert_eq!(status["state"], "done");
    assert_eq!(status["job"], "second");
    assert_eq!(status["samples"], 4);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_change_mid_render_stops_it_and_the_new_one_finishes() {
    let dir = job_dir("restart");
    put(&dir, "scene.gltf", SCENE.as_bytes());
    // Unlimited samples for a minute: only a restart ends it in time.
    put(&dir, "request.json", &request("long", r#", "samples": 0, "time_limit": 600"#));
    let mut d = Daemon::start(&dir, &[]);
    d.wait_for("long rendering a few samples", |l| l.starts_with("rendering samples=4/") && l.ends_with("job=long"));
    let changed = Instant::now();
    put(&dir, "request.json", &request("short", r#", "samples": 8"#));
    d.wait_for("done short", done("short"));
    eprintln!("restart to a finished 8-sample render: {:.2} s", changed.elapsed().as_secs_f64());
    assert!(!d.seen.iter().any(|l| l.starts_with("done") && l.ends_with("job=long")), "{:#?}", d.seen);
    assert!(d.seen.iter().any(|l| l.starts_with("cancelled") && l.ends_with("job=long")), "{:#?}", d.seen);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_corrupt_scene_is_reported_and_the_last_good_image_kept() {
    let dir = job_dir("corrupt");
    put(&dir, "scene.gltf", SCENE.as_bytes());
    put(&dir, "request.json", &request("good", r#", "samples": 2"#));
    let mut d = Daemon::start(&dir, &[]);
    d.wait_for("done good", done("good"));
    let good = std::fs::read(dir.join("render.exr")).unwrap();
    // Half a file, as a producer that writes in place would leave it.
    put(&dir, "scene.gltf", &SCENE.as_bytes()[..SCENE.len() / 2]);
    put(&dir, "request.json", &request("broken", r#", "samples": 2"#));
    let line = d.wait_for("error", |l| l.starts_with("error: ") && l.ends_with("job=broken"));
    assert!(line.contains("scene.gltf") && line.contains("not valid glTF JSON"), "{line}");
    let status: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("status.json")).unwrap()).unwrap();
    assert_eq!(status["state"], "error");
    assert_eq!(std::fs::read(dir.join("render.exr")).unwrap(), good, "a broken scene must not touch the image");
    // A broken request likewise; then a good scene renders again.
    put(&dir, "request.json", br#"{"job": "typo", "widht": 3"#);
    d.wait_for("request error", |l| l.starts_with("error: ") && l.contains("request.json"));
    put(&dir, "scene.gltf", SCENE.as_bytes());
    put(&dir, "request.json", &request("fixed", r#", "samples": 2"#));
    d.wait_for("done fixed", done("fixed"));
    assert!(d.child.try_wait().unwrap().is_none(), "the daemon must keep running");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_burst_of_writes_renders_once_or_twice() {
    let dir = job_dir("burst");
    put(&dir, "scene.gltf", SCENE.as_bytes());
    put(&dir, "request.json", &request("start", r#", "samples": 1"#));
    let mut d = Daemon::start(&dir, &[]);
    d.wait_for("done start", done("start"));
    for i in 0..20 {
        put(&dir, "request.json", &request(&format!("burst{i}"), r#", "samples": 2"#));
        std::thread::sleep(Duration::from_millis(5));
    }
    d.wait_for("done burst19", done("burst19"));
    d.drain(Duration::from_millis(800));
    let renders = d.seen.iter().filter(|l| l.starts_with("rendering samples=0/") && l.contains("job=burst")).count();
    eprintln!("20 writes in ~0.1 s started {renders} render(s)");
    assert!((1..=2).contains(&renders), "{renders} renders: {:#?}", d.seen);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn cancel_stops_a_render_promptly_and_closing_stdin_ends_the_daemon() {
    let dir = job_dir("cancel");
    put(&dir, "scene.gltf", SCENE.as_bytes());
    put(&dir, "request.json", &request("long", r#", "samples": 0, "time_limit": 600"#));
    let mut d = Daemon::start(&dir, &["--exit-with-stdin"]);
    d.wait_for("rendering", |l| l.starts_with("rendering samples=2/"));
    let asked = Instant::now();
    std::fs::write(dir.join("cancel"), b"").unwrap();
    d.wait_for("cancelled", |l| l.starts_with("cancelled") && l.ends_with("job=long"));
    let latency = asked.elapsed();
    eprintln!("cancel to status 'cancelled': {:.3} s", latency.as_secs_f64());
    d.drain(Duration::from_millis(300));
    assert!(!dir.join("cancel").exists(), "the daemon removes the cancel file");
    let leftovers: Vec<_> = std::fs::read_dir(&dir).unwrap().filter_map(|e| e.ok()).map(|e| e.file_name()).filter(|n| n.to_string_lossy().starts_with('.')).collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
    drop(d.stdin.take());
    let start = Instant::now();
    while d.child.try_wait().unwrap().is_none() {
        assert!(start.elapsed() < TIMEOUT, "the daemon outlived its stdin");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_single_scene_file_is_watched_with_its_request_beside_it() {
    let dir = job_dir("file");
    put(&dir, "shot.gltf", SCENE.as_bytes());
    put(&dir, "shot.request.json", &request("shot", r#", "samples": 2, "background": [1, 1, 1]"#));
    let mut d = Daemon::start(&dir.join("shot.gltf"), &[]);
    d.wait_for("done shot", done("shot"));
    assert!(dir.join("shot.exr").exists() && dir.join("shot.status.json").exists());
    // Another scene in the same folder is not this job.
    put(&dir, "other.gltf", SCENE.as_bytes());
    d.drain(Duration::from_millis(600));
    let renders = d.seen.iter().filter(|l| l.starts_with("rendering samples=0/")).count();
    assert_eq!(renders, 1, "{:#?}", d.seen);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A client that stops reading the status lines (its pipes closed) leaves
/// the daemon rendering: status.json and the image still follow the job.
#[test]
fn a_daemon_whose_reader_is_gone_still_renders() {
    let dir = job_dir("deaf");
    put(&dir, "scene.gltf", SCENE.as_bytes());
    put(&dir, "request.json", &request("deaf", r#", "samples": 2"#));
    let mut d = Daemon::start_unread(&dir, &[]);
    let start = Instant::now();
    let state = || -> Option<serde_json::Value> { serde_json::from_slice(&std::fs::read(dir.join("status.json")).ok()?).ok() };
    while !state().is_some_and(|s| s["state"] == "done" && s["job"] == "deaf") {
        assert!(d.child.try_wait().unwrap().is_none(), "the daemon exited: {:?}", d.child.try_wait());
        assert!(start.elapsed() < TIMEOUT, "no finished job in status.json within {TIMEOUT:?}: {:?}", state());
        std::thread::sleep(Duration::from_millis(50));
    }
    let (w, h, _) = glint::output::read_exr(&dir.join("render.exr")).unwrap();
    assert_eq!((w, h), (32, 32));
    drop(d);
    std::fs::remove_dir_all(&dir).unwrap();
}
