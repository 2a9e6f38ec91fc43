//! Builds the BSDF energy tables with the lobe code and writes them where
//! the binary bakes them in (src/bsdf/baked.rs):
//! `cargo run --release --example bake_tables`, after a change to a lobe.
use glint::bsdf::{baked, dielectric::GlassTables, energy::EnergyTables};
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/bsdf");
    baked::write(&dir.join("energy.bin"), &EnergyTables::build().to_floats())?;
    baked::write(&dir.join("glass.bin"), &GlassTables::build().to_floats())?;
    println!("wrote {} and {}", dir.join("energy.bin").display(), dir.join("glass.bin").display());
    Ok(())
}
