//! Glint: a physically based path tracer for glTF 2.0 scenes.

// `!(x > 0.0)` is how this code rejects NaN along with what is out of
// range, at the source of a division or a sample: `x <= 0.0` would let NaN
// through, and `partial_cmp` says the same at twice the length.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod accel;
pub mod adaptive;
pub mod affinity;
pub mod bsdf;
pub mod bvh_collapse;
pub mod camera;
pub mod camera_hits;
pub mod cpu;
pub mod caustic_guide;
pub mod console;
pub mod environment;
pub mod features;
pub mod integrator;
pub mod job;
pub mod lamps;
pub mod light_paths;
pub mod light_cache;
pub mod light_tree;
pub mod light_tracing;
pub mod lights;
pub mod loader;
pub mod memory;
pub mod material;
pub mod media;
pub mod output;
pub mod panorama;
pub mod pixel_filter;
pub mod parallelogram;
pub mod photons;
pub mod progressive;
pub mod portals;
pub mod punctual;
pub mod render;
pub mod request;
pub mod rng;
pub mod sampling;
pub mod scene;
pub mod shading;
pub mod softbox;
pub mod spherical_rectangle;
pub mod spherical_triangle;
pub mod strategies;
pub mod sun_cells;
pub mod texture;
pub mod traversal_bench;
pub mod triangle_pack;
pub mod watch;
pub mod wide_bvh;

/// Glint's 3-vector: glam's `Vec3A`, whose x, y and z sit in one 16-byte
/// SIMD register, so that a sum or a product of two vectors is one
/// instruction rather than three. Against glam's scalar `Vec3` (the same
/// formulas, images equal to 3·10⁻⁴; callgrind, 96², 4 spp, 1 thread): 9%
/// fewer instructions on the benchmark's Cornell box and 7% on its gold
/// sphere, 5% and 2% less time. The scene's triangles keep 12-byte vectors
/// (scene.rs), converted as they are read.
pub type Vec3 = glam::Vec3A;

/// The default scene, compiled into the binary so it renders from anywhere.
pub const DEFAULT_SCENE: &str = include_str!("../scenes/cornell-box.gltf");
pub const DEFAULT_SCENE_NAME: &str = "scenes/cornell-box.gltf (embedded)";
