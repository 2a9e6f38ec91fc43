//! Glint: a physically based path tracer for glTF 2.0 scenes.
pub mod bsdf;
pub mod material;
pub mod rng;
pub mod sampling;
