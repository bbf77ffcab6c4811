//! Deterministic random streams: one PCG generator per (seed, purpose, index).
//!
//! Every frame, background capture and noise field has its own stream, so frames can be made in
//! any order (or in parallel) and still come out byte-identical. Only `next_u64` of the generator
//! is used; uniform and Gaussian variates are derived here, so the output does not depend on how
//! a `rand` version maps bits to floats.

use rand::RngCore;
use rand_pcg::Pcg64Mcg;

/// Purposes of streams (the second key of [`Rng::stream`]).
pub(crate) mod purpose {
    /// Set-wide choices: lighting, base level.
    pub(crate) const SET: u64 = 1;
    /// Sensor noise of background captures (index = capture; right camera offset by 1000).
    pub(crate) const BACKGROUND: u64 = 2;
    /// Layout of a frame: parts, poses, looks, lighting drift.
    pub(crate) const LAYOUT: u64 = 3;
    /// Sensor noise of a frame (left or only camera).
    pub(crate) const NOISE_LEFT: u64 = 4;
    /// Sensor noise of a frame (right camera).
    pub(crate) const NOISE_RIGHT: u64 = 5;
    /// Set-wide choices of the real-camera variants: lens, camera height, platform texture,
    /// vignette (streams of their own, so the older variants draw exactly what they drew).
    pub(crate) const EFFECT_SET: u64 = 6;
    /// Per-scene choices of the real-camera variants: thickness, print, levels (index = scene).
    pub(crate) const EFFECT_SCENE: u64 = 7;
    /// Exposure (gain, offset) of a frame (index = frame).
    pub(crate) const EXPOSURE: u64 = 8;
    /// Which chiral parts of a `touching` scene lie upside down (index = scene; drawn before
    /// the parts are moved together, so `bring_together` draws what it drew).
    pub(crate) const TOUCHING_FLIP: u64 = 9;
}

/// SplitMix64 finaliser: a bijective mix of 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A random stream with uniform, range, choice and Gaussian draws.
pub(crate) struct Rng {
    inner: Pcg64Mcg,
    spare: Option<f64>,
}

impl Rng {
    /// The stream for `(seed, purpose, index)`.
    pub(crate) fn stream(seed: u64, purpose: u64, index: u64) -> Self {
        let a = mix(seed ^ mix(purpose.wrapping_mul(0x0000_0100_0000_01B3) ^ mix(index)));
        let b = mix(a ^ 0x5851_F42D_4C95_7F2D);
        Rng {
            inner: Pcg64Mcg::new((u128::from(a) << 64) | u128::from(b)),
            spare: None,
        }
    }

    /// Uniform in [0, 1), 53 random bits.
    pub(crate) fn uniform(&mut self) -> f64 {
        (self.inner.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Uniform integer in 0..n (n > 0).
    pub(crate) fn below(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// True with probability p.
    pub(crate) fn chance(&mut self, p: f64) -> bool {
        self.uniform() < p
    }

    /// +1 or −1 with equal probability.
    pub(crate) fn sign(&mut self) -> f64 {
        if self.chance(0.5) {
            1.0
        } else {
            -1.0
        }
    }

    /// Standard normal (Box–Muller, both values used).
    pub(crate) fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let u1 = 1.0 - self.uniform(); // (0, 1]
        let u2 = self.uniform();
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
        self.spare = Some(r * s);
        r * c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gen_streams_are_reproducible_and_distinct() {
        let mut a = Rng::stream(7, purpose::LAYOUT, 3);
        let mut b = Rng::stream(7, purpose::LAYOUT, 3);
        let mut c = Rng::stream(7, purpose::LAYOUT, 4);
        let xa: Vec<f64> = (0..8).map(|_| a.uniform()).collect();
        let xb: Vec<f64> = (0..8).map(|_| b.uniform()).collect();
        let xc: Vec<f64> = (0..8).map(|_| c.uniform()).collect();
        assert_eq!(xa, xb);
        assert_ne!(xa, xc);
    }

    #[test]
    fn gen_normal_has_unit_variance() {
        let mut r = Rng::stream(1, 99, 0);
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let z = r.normal();
            s += z;
            s2 += z * z;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "var {var}");
    }
}
