//! No allocation per pixel sample: the render loop allocates per pass and
//! per group of sample indices (tiles' sums, light subpaths' vertices and
//! splats), never per path. Counted by a global allocator of this test
//! binary's own.

mod common;

use glint::integrator::Context;
use glint::loader::{load_bytes, LoadOptions};
use glint::render::{render_pass, Film, RenderSettings};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The embedded Cornell box (its gold sphere makes camera paths whose z is
/// not x1, so every strategy runs: light sampling, BSDF sampling, two and
/// sixteen connections, light tracing) at 32², rendered at 4 and at 36
/// samples per pixel on one worker: the 32 samples more (32,768 pixel
/// samples) may add allocations per group of four sample indices (measured:
/// 94 at 4 spp, 753 at 36, so 82 a group) but not one a path: the bound is
/// one per 16 pixel samples, 2,048. One `Vec` made in `radiance` gave
/// 33,427 more and fails it.
#[test]
fn the_render_loop_allocates_per_pass_not_per_pixel_sample() {
    let scene = load_bytes(glint::DEFAULT_SCENE.as_bytes(), None, "cornell", &LoadOptions::default()).unwrap();
    let ctx = Context::new(&scene).0;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let allocations = |spp: u32| {
        let settings = RenderSettings { mis: true, ..common::settings(32, 32, spp, 16, 5) };
        assert!(ctx.traces_light_paths(&settings), "the test must run every strategy");
        let mut film = Film::new(32, 32);
        pool.install(|| {
            let before = ALLOCATIONS.load(Ordering::Relaxed);
            let stats = render_pass(&ctx, &settings, &mut film, 0..spp, &AtomicBool::new(false), &|_| {}).unwrap();
            let count = ALLOCATIONS.load(Ordering::Relaxed) - before;
            assert!(stats.rays.shadow > 0 && stats.discarded == 0);
            count
        })
    };
    let (few, many) = (allocations(4), allocations(36));
    let extra_samples = 32 * 32 * 32;
    let extra = many.saturating_sub(few);
    assert!(extra < extra_samples / 16, "{extra} allocations for {extra_samples} more pixel samples ({few} at 4 spp, {many} at 36)");
}
