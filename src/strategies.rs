//! Which estimators add their light to the image, to take a render apart
//! by sampling strategy and path depth and see where its noise comes from
//! (`glint render --strategies … --depths …`). Every estimator still runs,
//! draws its numbers and casts its rays; one left out only keeps its
//! MIS-weighted contribution out of the pixels. So the images of a
//! partition (each strategy on its own; depths 1, 2 and 3–) add up to the
//! whole render, sample for sample, and each one's error against a
//! reference is its share of the noise.
//!
//! A path's depth is its scattering events, as `--max-depth` counts them:
//! 0 for an emitter the camera sees, 1 for direct light.

use std::fmt;

/// One way a path's light reaches a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Emitters, lamps and the World seen by the camera ray itself.
    Camera,
    /// Light that a BSDF-sampled ray reaches after a bounce (s = 0).
    Bsdf,
    /// Light sampling at a vertex, with its shadow ray (s = 1).
    Light,
    /// A camera vertex joined to a light subpath's vertex (light_paths.rs).
    Connection,
    /// A light subpath's vertex joined to the camera (light_tracing.rs).
    Tracing,
    /// A camera vertex merged with the photons around it (photons.rs).
    Merge,
}

impl Strategy {
    pub const ALL: [Strategy; 6] = [Strategy::Camera, Strategy::Bsdf, Strategy::Light, Strategy::Connection, Strategy::Tracing, Strategy::Merge];

    pub fn name(self) -> &'static str {
        match self {
            Strategy::Camera => "camera",
            Strategy::Bsdf => "bsdf",
            Strategy::Light => "light",
            Strategy::Connection => "connection",
            Strategy::Tracing => "tracing",
            Strategy::Merge => "merge",
        }
    }

    fn bit(self) -> u8 {
        1 << self as u8
    }
}

/// The strategies and path depths whose light is kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strategies {
    kinds: u8,
    min_depth: u32,
    max_depth: u32,
}

impl Default for Strategies {
    fn default() -> Self {
        Strategies::ALL
    }
}

impl Strategies {
    /// Everything: a normal render.
    pub const ALL: Strategies = Strategies { kinds: (1 << Strategy::ALL.len()) - 1, min_depth: 0, max_depth: u32::MAX };

    /// Only these strategies, at every depth.
    pub fn only(kinds: &[Strategy]) -> Self {
        Strategies { kinds: kinds.iter().fold(0, |k, s| k | s.bit()), ..Strategies::ALL }
    }

    /// These, for paths of `min..=max` scattering events only.
    pub fn with_depths(self, min: u32, max: u32) -> Self {
        Strategies { min_depth: min, max_depth: max, ..self }
    }

    #[inline]
    pub fn keeps(&self, strategy: Strategy, depth: u32) -> bool {
        self.kinds & strategy.bit() != 0 && depth >= self.min_depth && depth <= self.max_depth
    }

    pub fn is_all(&self) -> bool {
        *self == Strategies::ALL
    }

    /// A comma-separated list of strategy names: those only.
    pub fn parse_list(text: &str) -> Result<Strategies, String> {
        let kinds: Vec<Strategy> = text
            .split(',')
            .map(|name| {
                let name = name.trim();
                Strategy::ALL.into_iter().find(|s| s.name() == name).ok_or_else(|| {
                    let names: Vec<_> = Strategy::ALL.iter().map(|s| s.name()).collect();
                    format!("unknown strategy `{name}` (one of {})", names.join(", "))
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Strategies::only(&kinds))
    }

    /// `N`, `N-M` or `N-` (N and deeper), in scattering events.
    pub fn parse_depths(text: &str) -> Result<(u32, u32), String> {
        let number = |s: &str| s.trim().parse::<u32>().map_err(|_| format!("`{text}` is not a depth range (N, N-M or N-)"));
        let (min, max) = match text.split_once('-') {
            None => {
                let n = number(text)?;
                (n, n)
            }
            Some((a, "")) => (number(a)?, u32::MAX),
            Some((a, b)) => (number(a)?, number(b)?),
        };
        if min > max {
            return Err(format!("depth range `{text}` is empty"));
        }
        Ok((min, max))
    }
}

impl fmt::Display for Strategies {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let names: Vec<_> = Strategy::ALL.iter().filter(|s| self.kinds & s.bit() != 0).map(|s| s.name()).collect();
        write!(f, "{}", if names.is_empty() { "none".to_string() } else { names.join(", ") })?;
        match (self.min_depth, self.max_depth) {
            (0, u32::MAX) => Ok(()),
            (a, u32::MAX) => write!(f, "; depths {a}-"),
            (a, b) if a == b => write!(f, "; depth {a}"),
            (a, b) => write!(f, "; depths {a}-{b}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_and_depth_ranges_parse_and_bad_ones_are_named() {
        assert_eq!(Strategies::parse_list("bsdf, light").unwrap(), Strategies::only(&[Strategy::Bsdf, Strategy::Light]));
        assert!(Strategies::parse_list("bsdf,photon").unwrap_err().contains("`photon`"));
        assert_eq!(Strategies::parse_depths("2").unwrap(), (2, 2));
        assert_eq!(Strategies::parse_depths("2-4").unwrap(), (2, 4));
        assert_eq!(Strategies::parse_depths("3-").unwrap(), (3, u32::MAX));
        assert!(Strategies::parse_depths("4-2").is_err() && Strategies::parse_depths("x").is_err() && Strategies::parse_depths("-2").is_err());
        let s = Strategies::only(&[Strategy::Light]).with_depths(2, u32::MAX);
        assert!(s.keeps(Strategy::Light, 2) && s.keeps(Strategy::Light, 9));
        assert!(!s.keeps(Strategy::Light, 1) && !s.keeps(Strategy::Bsdf, 2));
        assert_eq!(s.to_string(), "light; depths 2-");
        assert!(Strategies::only(&Strategy::ALL).is_all() && Strategies::default().is_all());
    }
}
