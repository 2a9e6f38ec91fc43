//! The energy tables (energy.rs, dielectric.rs) as the binary carries them:
//! built once by Glint's own lobe code (`cargo run --release --example
//! bake_tables` writes `energy.bin` and `glass.bin` here) instead of at the
//! start of every process, where they took 0.1 s of a Principled render's
//! set-up (0.19 s of CPU) and 0.3 s of the first render with glass. The
//! test below builds them afresh and compares.
//!
//! Format: the tables' f32 values, little-endian, one after the other.

use std::path::Path;

/// The floats of a baked file; None where its length is not `count` floats.
pub(super) fn floats(bytes: &[u8], count: usize) -> Option<Vec<f32>> {
    (bytes.len() == count * 4).then(|| bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
}

/// Writes `values` to `path` as a baked file, under a temporary name first.
pub fn write(path: &Path, values: &[f32]) -> anyhow::Result<()> {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    crate::output::write_bytes_atomically(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{dielectric, energy};

    /// The baked files are the tables' size, so the binary uses them, and
    /// they are what the lobe code builds now: a lobe changed without
    /// baking again fails here. Tolerance 1e-5 (the values are albedos in
    /// [0, 1]): another CPU's libm may round a sine differently in the
    /// last bit; a changed lobe moves them by far more.
    #[test]
    fn baked_tables_are_what_the_lobe_code_builds() {
        let baked_energy = floats(include_bytes!("energy.bin"), energy::BAKED_FLOATS).expect("energy.bin is the tables' size");
        let baked_glass = floats(include_bytes!("glass.bin"), dielectric::BAKED_FLOATS).expect("glass.bin is the tables' size");
        assert_eq!(energy::tables().to_floats(), baked_energy);
        assert_eq!(dielectric::glass_tables().to_floats(), baked_glass);
        for (name, baked, built) in [
            ("energy", baked_energy, energy::EnergyTables::build().to_floats()),
            ("glass", baked_glass, dielectric::GlassTables::build().to_floats()),
        ] {
            assert_eq!(baked.len(), built.len());
            let worst = baked.iter().zip(&built).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(worst <= 1e-5, "{name} tables differ from a fresh build by {worst}: run `cargo run --release --example bake_tables`");
        }
    }
}
