//! Shared input decoding of vorl's fuzz targets.
//!
//! Every target reads its input through [`Input`], a thin layer over
//! [`arbitrary::Unstructured`]: integers and floats are `arbitrary`'s little-endian reads from
//! the front of the data (zero once it runs out), so a seed file is easy to write by hand
//! (`scripts/fuzz-seeds.py` writes the committed ones). Numbers lean towards the values that
//! break arithmetic: [`Input::num`] gives NaN, ±∞, ±0, subnormals, huge values and exact
//! duplicates about half of the time, and [`Input::count`] gives 0, 1, `usize::MAX` and values
//! past every capacity.

use arbitrary::Unstructured;
use vorl_core::pixels::mask::{Cleanup, Threshold};
use vorl_core::params::{AngleEstimator, Params, Position, Refine};

/// Floats that break arithmetic.
pub const SPECIAL: [f32; 16] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    0.0,
    -0.0,
    1.0,
    -1.0,
    f32::MIN_POSITIVE,
    1e-45,
    f32::MAX,
    f32::MIN,
    f32::EPSILON,
    0.5,
    1e20,
    -1e20,
    1e-20,
];

/// The decoder.
pub struct Input<'a> {
    u: Unstructured<'a>,
}

impl<'a> Input<'a> {
    /// Over the fuzzer's bytes.
    pub fn new(data: &'a [u8]) -> Self {
        Input {
            u: Unstructured::new(data),
        }
    }

    /// The next byte (0 at the end).
    pub fn u8(&mut self) -> u8 {
        self.u.arbitrary().unwrap_or(0)
    }

    /// The next two bytes, little-endian (0 at the end).
    pub fn u16(&mut self) -> u16 {
        self.u.arbitrary().unwrap_or(0)
    }

    /// The next four bytes, little-endian (0 at the end).
    pub fn u32(&mut self) -> u32 {
        self.u.arbitrary().unwrap_or(0)
    }

    /// A flag from one byte.
    pub fn flag(&mut self) -> bool {
        self.u8() & 1 == 1
    }

    /// In `0..n` from two bytes (0 for `n = 0`).
    pub fn below(&mut self, n: usize) -> usize {
        usize::from(self.u16()) % n.max(1)
    }

    /// Any float, from one selector byte: a [`SPECIAL`] value, a small integer (exact
    /// duplicates), a value in `[-256, 256)`, or any 32 bits.
    pub fn num(&mut self) -> f32 {
        match self.u8() {
            0..=63 => SPECIAL[usize::from(self.u8()) % SPECIAL.len()],
            64..=127 => f32::from(self.u8() as i8),
            128..=191 => (f32::from(self.u16()) - 32768.0) / 128.0,
            _ => f32::from_bits(self.u32()),
        }
    }

    /// A float that is usually ordinary: `usual` for selector bytes below 160, else
    /// [`Self::num`].
    pub fn num_or(&mut self, usual: f32) -> f32 {
        if self.u8() < 160 {
            usual
        } else {
            self.num()
        }
    }

    /// Any count, from one selector byte: 0, 1, `usize::MAX`, `2³¹` (overflows `2n` on 32-bit
    /// targets), `u16::MAX + 1`, or a small value.
    pub fn count(&mut self) -> usize {
        match self.u8() % 16 {
            0 => 0,
            1 => 1,
            2 => usize::MAX,
            3 => 1 << 31,
            4 => usize::from(u16::MAX) + 1,
            5 => usize::from(self.u16()),
            _ => usize::from(self.u8()),
        }
    }

    /// A count that is usually `usual` (selector byte below 160), else [`Self::count`].
    pub fn count_or(&mut self, usual: usize) -> usize {
        if self.u8() < 160 {
            usual
        } else {
            self.count()
        }
    }

    /// Up to `n` bytes (fewer when the data runs out).
    pub fn bytes(&mut self, n: usize) -> &'a [u8] {
        let n = n.min(self.u.len());
        self.u.bytes(n).unwrap_or(&[])
    }

    /// Exactly `n` bytes: the data's next bytes, then zeros.
    pub fn plane(&mut self, n: usize) -> Vec<u8> {
        let mut v = self.bytes(n).to_vec();
        v.resize(n, 0);
        v
    }

    /// `n` floats from [`Self::num`].
    pub fn nums(&mut self, n: usize) -> Vec<f32> {
        (0..n).map(|_| self.num()).collect()
    }

    /// Bytes left.
    pub fn left(&self) -> usize {
        self.u.len()
    }
}

/// Any threshold.
pub fn threshold(input: &mut Input<'_>) -> Threshold {
    if input.u8() < 64 {
        Threshold::Otsu
    } else {
        Threshold::Fixed(input.u8())
    }
}

/// Any clean-up.
pub fn cleanup(input: &mut Input<'_>) -> Cleanup {
    match input.u8() % 3 {
        0 => Cleanup::Off,
        1 => Cleanup::Open,
        _ => Cleanup::OpenClose,
    }
}

/// Parameters: each field is the default's or, for a selector byte of 160 and more, any value
/// (NaN, ∞, 0 and huge numbers; 0, 1, `usize::MAX` and huge counts). `set_params` refuses most
/// of the wild ones, and the recognizer keeps running on its previous parameters.
pub fn params(input: &mut Input<'_>) -> Params {
    let d = Params::DEFAULT;
    let mut p = d;
    p.alpha = input.num_or(d.alpha);
    p.threshold = if input.u8() < 160 {
        d.threshold
    } else {
        threshold(input)
    };
    p.cleanup = if input.u8() < 160 { d.cleanup } else { cleanup(input) };
    p.min_points = input.count_or(d.min_points);
    p.min_area = input.num_or(d.min_area);
    // n and m from a few valid pairs (n ≤ m < 2n) or anything.
    match input.u8() {
        0..=159 => {}
        160..=223 => {
            let n = 8 + input.below(57);
            p.n = n;
            p.m = n + input.below(n);
        }
        _ => {
            p.n = input.count();
            p.m = input.count();
        }
    }
    p.k = input.count_or(d.k);
    p.omega = input.num_or(d.omega);
    p.epsilon = input.num_or(d.epsilon);
    p.angle = if input.flag() {
        AngleEstimator::Paper
    } else {
        AngleEstimator::Signed
    };
    p.refine = match input.u8() {
        0..=159 => d.refine,
        160..=207 => Refine::Off,
        _ => Refine::Pose,
    };
    p.candidates = input.count_or(d.candidates);
    p.candidate_ratio = input.num_or(d.candidate_ratio);
    p.verify_threshold = input.num_or(d.verify_threshold);
    p.verify_relative = input.num_or(d.verify_relative);
    p.offset_relative = input.num_or(d.offset_relative);
    p.scale_min = input.num_or(d.scale_min);
    p.scale_max = input.num_or(d.scale_max);
    p.position = if input.u8() < 200 {
        d.position
    } else {
        Position::Polygon
    };
    p
}
