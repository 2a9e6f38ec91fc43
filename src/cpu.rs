//! The x86-64 instruction sets this build was compiled to use (its
//! `target-cpu`: x86-64-v2 by `.cargo/config.toml`) against those of the
//! CPU it runs on. Without them it would stop on an illegal instruction
//! somewhere in a render; a one-line error says why at start instead.

/// The features the build uses that this CPU lacks: empty where it has
/// them all, and on other architectures.
pub fn missing_features() -> Vec<&'static str> {
    #[allow(unused_mut)]
    let mut missing = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        macro_rules! check {
            ($($feature:tt),*) => {
                $(if cfg!(target_feature = $feature) && !std::arch::is_x86_feature_detected!($feature) {
                    missing.push($feature);
                })*
            };
        }
        // x86-64-v2, then what v3 adds, for a build told to target it.
        check!("sse3", "ssse3", "sse4.1", "sse4.2", "popcnt", "cmpxchg16b", "avx", "avx2", "bmi1", "bmi2", "fma", "f16c", "lzcnt", "movbe");
    }
    missing
}

#[cfg(test)]
mod tests {
    /// The project's own target level is in effect (.cargo/config.toml
    /// read, not replaced), and the machine running the tests has it.
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_build_targets_x86_64_v2_and_this_cpu_has_it() {
        let built_for_v2 = cfg!(target_feature = "sse4.2") && cfg!(target_feature = "popcnt");
        assert!(built_for_v2, "built without x86-64-v2: .cargo/config.toml not in effect");
        assert_eq!(super::missing_features(), Vec::<&str>::new());
    }
}
