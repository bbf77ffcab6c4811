//! Rows of bits and the word operations on them: a box row as `N` machine words
//! ([`Bits`]), gathered from the low bits of the mask's bytes (8 with a multiplication), shifted,
//! eroded and dilated by segments, and scanned for runs and set bits.

use super::super::LOW;

/// The widest box (px) measured with bit rows.
pub(super) const MAX_WIDTH: usize = 256;

/// A word of a bit row: the machine's (64 columns on 64-bit targets, 32 on the Cortex-M4).
pub(super) type Word = usize;

/// Columns a word.
pub(super) const BITS: usize = Word::BITS as usize;

/// Bytes a word.
pub(super) const WORD_BYTES: usize = BITS / 8;

/// Words of the widest bit row.
pub(super) const WORDS: usize = MAX_WIDTH / BITS;

/// One row of the box as bits, `N` words: bit `j` of word `i` is the box's column `BITS·i + j`;
/// the bits past the box's width are 0.
pub(super) type Bits<const N: usize> = [Word; N];

/// Bit `i` of the result is the low bit of byte `i` of `v` (the other bits of `v` 0).
#[inline(always)]
pub(super) fn pack(v: u64) -> Word {
    (v.wrapping_mul(0x0102_0408_1020_4080) >> 56) as Word
}

/// Byte `i` of the result is bit `i` of `byte`, 0 or 1.
#[inline(always)]
pub(super) const fn spread(byte: u8) -> u64 {
    let bits = (byte as u64 * LOW) & 0x8040_2010_0804_0201;
    ((bits + 0x7F7F_7F7F_7F7F_7F7F) >> 7) & LOW
}

/// [`spread`] of every byte.
pub(super) static SPREAD: [u64; 256] = {
    let mut table = [0; 256];
    let mut i = 0;
    while i < 256 {
        table[i] = spread(i as u8);
        i += 1;
    }
    table
};

/// Bit `x` of the result is bit 0 of `row[x]`, `x < BITS·N`.
#[inline(always)]
pub(super) fn gather<const N: usize>(row: &[u8]) -> Bits<N> {
    let mut out = [0; N];
    for (o, chunk) in out.iter_mut().zip(row.chunks(BITS)) {
        *o = match <&[u8; BITS]>::try_from(chunk) {
            // A whole word's bytes: 8 at a time, unrolled.
            Ok(bytes) => {
                let mut word = 0;
                for j in 0..WORD_BYTES {
                    let eight = bytes.get(8 * j..8 * j + 8).and_then(|c| <[u8; 8]>::try_from(c).ok());
                    word |= pack(u64::from_le_bytes(eight.unwrap_or_default()) & LOW) << (8 * j);
                }
                word
            }
            Err(_) => gather_partial(row, row.len() - chunk.len()),
        };
    }
    out
}

/// [`gather`]'s last word, of fewer than `BITS` bytes from `start`: 8 at a time, and the last
/// few as the top of the row's last 8 (when it has 8).
#[inline(never)]
pub(super) fn gather_partial(row: &[u8], start: usize) -> Word {
    let mut word = 0;
    for j in 0..WORD_BYTES {
        let s = start + 8 * j;
        let v = match row.get(s..s + 8) {
            Some(c) => u64::from_le_bytes(c.try_into().unwrap_or_default()),
            None => {
                let rest = row.len().saturating_sub(s);
                let v = match row.len().checked_sub(8).and_then(|t| row.get(t..)) {
                    Some(last) if rest > 0 => {
                        u64::from_le_bytes(last.try_into().unwrap_or_default()) >> (8 * (8 - rest))
                    }
                    _ => {
                        let mut eight = [0u8; 8];
                        for (b, v) in eight.iter_mut().zip(row.get(s..).unwrap_or(&[])) {
                            *b = *v;
                        }
                        u64::from_le_bytes(eight)
                    }
                };
                word |= pack(v & LOW) << (8 * j);
                break;
            }
        };
        word |= pack(v & LOW) << (8 * j);
    }
    word
}

/// The bits of word `k` of a bit row within columns `lo..=hi`.
#[inline(always)]
pub(super) fn range_word(k: usize, lo: usize, hi: usize) -> Word {
    let (a, b) = (BITS * k, BITS * k + BITS - 1);
    if hi < a || lo > b {
        return 0;
    }
    let low = if lo > a { Word::MAX << (lo - a) } else { Word::MAX };
    let high = if hi < b { Word::MAX >> (b - hi) } else { Word::MAX };
    low & high
}

/// Whether column `x` of `bits` is set.
#[inline(always)]
pub(super) fn bit<const N: usize>(bits: &Bits<N>, x: usize) -> bool {
    bits.get(x / BITS).is_some_and(|&v| v >> (x % BITS) & 1 != 0)
}

/// The first column at or after `x` whose bit is `SET` (`BITS·N` when none is).
#[inline(always)]
pub(super) fn next_bit<const SET: bool, const N: usize>(bits: &Bits<N>, x: usize) -> usize {
    let flip = if SET { 0 } else { Word::MAX };
    let mut k = x / BITS;
    let mut word = match bits.get(k) {
        Some(&v) => (v ^ flip) & (Word::MAX << (x % BITS)),
        None => return BITS * N,
    };
    loop {
        if word != 0 {
            return BITS * k + word.trailing_zeros() as usize;
        }
        k += 1;
        match bits.get(k) {
            Some(&v) => word = v ^ flip,
            None => return BITS * N,
        }
    }
}

/// The run of set bits of `bits` around column `x` (which is set): its first and last column.
#[inline(always)]
pub(super) fn run_around<const N: usize>(bits: &Bits<N>, x: usize) -> (usize, usize) {
    (run_start(bits, x), next_bit::<false, N>(bits, x) - 1)
}

/// Sets columns `lo..=hi` of `bits`.
#[inline(always)]
pub(super) fn set_range<const N: usize>(bits: &mut Bits<N>, lo: usize, hi: usize) {
    for (k, v) in bits.iter_mut().enumerate() {
        *v |= range_word(k, lo, hi);
    }
}

/// The runs of set bits of `m` that hold a bit of `seeds` (which is within `m`): from each
/// run's lowest seed to its end by a carry through the run (`m + seeds` clears those bits), then
/// down to its start.
#[inline(always)]
pub(super) fn runs_of<const N: usize>(m: &Bits<N>, seeds: &Bits<N>) -> Bits<N> {
    let mut up = [0; N];
    let mut carry = false;
    for ((u, &m), &s) in up.iter_mut().zip(m).zip(seeds) {
        let (t, c1) = m.overflowing_add(s);
        let (t, c2) = t.overflowing_add(Word::from(carry));
        carry = c1 | c2;
        *u = (m & !t) | s;
    }
    // Every run touched (the common case: its last bit is in `up`): all of `m`.
    if none(&and_not(&and_not(m, &shift_down::<1, N>(m)), &up)) {
        return *m;
    }
    // The lowest bit of each run of `up`: where the run reaches below, the rest down to its start.
    let starts = and_not(&up, &shift_up::<1, N>(&up));
    for_each_bit(&starts, |p| {
        let a = run_start(m, p);
        if a < p {
            set_range(&mut up, a, p - 1);
        }
    });
    up
}

/// The first column of the run of set bits of `bits` that holds column `x`.
#[inline(always)]
pub(super) fn run_start<const N: usize>(bits: &Bits<N>, x: usize) -> usize {
    let (mut k, b) = (x / BITS, x % BITS);
    let word = |k: usize| bits.get(k).copied().unwrap_or(0);
    let mut z = !word(k) & ((1 << b) - 1);
    loop {
        if z != 0 {
            return BITS * k + BITS - z.leading_zeros() as usize;
        }
        if k == 0 {
            return 0;
        }
        k -= 1;
        z = !word(k);
    }
}

/// `a & b`, `a | b`, `a & !b` word by word.
#[inline(always)]
pub(super) fn and<const N: usize>(a: &Bits<N>, b: &Bits<N>) -> Bits<N> {
    core::array::from_fn(|k| a.get(k).copied().unwrap_or(0) & b.get(k).copied().unwrap_or(0))
}

/// See [`and`].
#[inline(always)]
pub(super) fn or<const N: usize>(a: &Bits<N>, b: &Bits<N>) -> Bits<N> {
    core::array::from_fn(|k| a.get(k).copied().unwrap_or(0) | b.get(k).copied().unwrap_or(0))
}

/// See [`and`].
#[inline(always)]
pub(super) fn and_not<const N: usize>(a: &Bits<N>, b: &Bits<N>) -> Bits<N> {
    core::array::from_fn(|k| a.get(k).copied().unwrap_or(0) & !b.get(k).copied().unwrap_or(0))
}

/// Whether `bits` has no bit set.
#[inline(always)]
pub(super) fn none<const N: usize>(bits: &Bits<N>) -> bool {
    bits.iter().all(|&v| v == 0)
}

/// Bit `c` of the result is bit `c + S` of `x` (0 past the row's end); `0 < S < BITS`.
#[inline(always)]
pub(super) fn shift_down<const S: usize, const N: usize>(x: &Bits<N>) -> Bits<N> {
    core::array::from_fn(|k| {
        let cur = x.get(k).copied().unwrap_or(0);
        let next = x.get(k + 1).copied().unwrap_or(0);
        (cur >> S) | (next << (BITS - S))
    })
}

/// Bit `c` of the result is bit `c − S` of `x` (0 before the row's start); `0 < S < BITS`.
#[inline(always)]
pub(super) fn shift_up<const S: usize, const N: usize>(x: &Bits<N>) -> Bits<N> {
    core::array::from_fn(|k| {
        let cur = x.get(k).copied().unwrap_or(0);
        let prev = k.checked_sub(1).and_then(|p| x.get(p)).copied().unwrap_or(0);
        (cur << S) | (prev >> (BITS - S))
    })
}

/// Horizontal erosion by the `(2K+1)`-segment (columns outside the row count as 0), `K` 2, 3 or
/// 5.
#[inline(always)]
pub(super) fn erode<const K: usize, const N: usize>(x: &Bits<N>) -> Bits<N> {
    // AND over windows from the column on: 2 columns, 4, then 5 (K = 2), 7 (K = 3) or 8 and 11
    // (K = 5); then centred.
    let a2 = and(x, &shift_down::<1, N>(x));
    let a4 = and(&a2, &shift_down::<2, N>(&a2));
    match K {
        2 => shift_up::<2, N>(&and(&a4, &shift_down::<4, N>(x))),
        3 => shift_up::<3, N>(&and(&a4, &shift_down::<3, N>(&a4))),
        _ => {
            let a8 = and(&a4, &shift_down::<4, N>(&a4));
            shift_up::<5, N>(&and(&a8, &shift_down::<7, N>(&a4)))
        }
    }
}

/// Horizontal dilation by the `(2K+1)`-segment, `K` 1 or 2 (not clipped to the box: the bits
/// past its width may be set).
#[inline(always)]
pub(super) fn dilate<const K: usize, const N: usize>(x: &Bits<N>) -> Bits<N> {
    let one = or(&or(x, &shift_down::<1, N>(x)), &shift_up::<1, N>(x));
    if K == 1 {
        one
    } else {
        or(&or(&one, &shift_down::<2, N>(x)), &shift_up::<2, N>(x))
    }
}

/// Calls `f` with the first and end column of every run of set bits of `bits`, in increasing
/// order.
#[inline(always)]
pub(super) fn for_each_run<const N: usize>(bits: &Bits<N>, mut f: impl FnMut(usize, usize)) {
    let mut x = next_bit::<true, N>(bits, 0);
    while x < BITS * N {
        let end = next_bit::<false, N>(bits, x);
        f(x, end);
        x = next_bit::<true, N>(bits, end);
    }
}

/// Calls `f` with the column of every set bit of `bits`, in increasing order.
#[inline(always)]
pub(super) fn for_each_bit<const N: usize>(bits: &Bits<N>, mut f: impl FnMut(usize)) {
    for (k, &word) in bits.iter().enumerate() {
        let mut word = word;
        while word != 0 {
            f(BITS * k + word.trailing_zeros() as usize);
            word &= word - 1;
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    extern crate std;

    use super::*;
    use std::vec::Vec;

    use crate::test_rng::XorShift as Rng;

    /// A random bit row of `width` columns (the bits past it 0).
    pub(in super::super) fn random_bits(rng: &mut Rng, width: usize) -> Bits<WORDS> {
        let mut bits = [0; WORDS];
        let density = rng.unit();
        for x in 0..width {
            if rng.chance(density) {
                bits[x / BITS] |= 1 << (x % BITS);
            }
        }
        bits
    }

    #[test]
    fn bit_row_morphology_is_the_per_bit_definition() {
        // Erosion and dilation by segments over a row's words, and the shifts they are made of,
        // against the definition column by column (outside the row is 0).
        let mut rng = Rng(2024);
        for case in 0..3000 {
            let width = 1 + rng.below(MAX_WIDTH);
            let x = random_bits(&mut rng, width);
            let at = |c: isize| c >= 0 && bit(&x, c as usize);
            for c in 0..MAX_WIDTH {
                let ci = c as isize;
                let window = |k: isize, all: bool| {
                    let mut v = (-k..=k).map(|d| at(ci + d));
                    if all {
                        v.all(|b| b)
                    } else {
                        v.any(|b| b)
                    }
                };
                assert_eq!(
                    bit(&erode::<2, WORDS>(&x), c),
                    window(2, true),
                    "case {case} erode 2 at {c}"
                );
                assert_eq!(
                    bit(&erode::<3, WORDS>(&x), c),
                    window(3, true),
                    "case {case} erode 3 at {c}"
                );
                assert_eq!(
                    bit(&erode::<5, WORDS>(&x), c),
                    window(5, true),
                    "case {case} erode 5 at {c}"
                );
                assert_eq!(
                    bit(&dilate::<1, WORDS>(&x), c),
                    window(1, false),
                    "case {case} dilate 1 at {c}"
                );
                assert_eq!(
                    bit(&dilate::<2, WORDS>(&x), c),
                    window(2, false),
                    "case {case} dilate 2 at {c}"
                );
                assert_eq!(bit(&shift_down::<7, WORDS>(&x), c), at(ci + 7));
                assert_eq!(bit(&shift_up::<5, WORDS>(&x), c), at(ci - 5));
            }
            // Runs around a set bit, runs of seeds, the next set or clear bit, column ranges.
            let set: Vec<usize> = (0..width).filter(|&c| bit(&x, c)).collect();
            if let Some(&c) = set.get(rng.below(set.len().max(1))) {
                let (l, r) = run_around(&x, c);
                assert!((l..=r).all(|k| bit(&x, k)), "case {case}");
                assert!(l == 0 || !bit(&x, l - 1));
                assert!(!bit(&x, r + 1));
            }
            let seeds = and(&random_bits(&mut rng, width), &x);
            let runs = runs_of(&x, &seeds);
            for c in 0..MAX_WIDTH {
                let (mut l, mut r) = (c, c);
                while l > 0 && bit(&x, l - 1) {
                    l -= 1;
                }
                while bit(&x, r + 1) {
                    r += 1;
                }
                let want = bit(&x, c) && (l..=r).any(|k| bit(&seeds, k));
                assert_eq!(bit(&runs, c), want, "case {case} runs at {c}");
            }
            let from = rng.below(MAX_WIDTH + 1);
            for set in [true, false] {
                let want = (from..MAX_WIDTH).find(|&c| bit(&x, c) == set).unwrap_or(MAX_WIDTH);
                let got = if set {
                    next_bit::<true, WORDS>(&x, from)
                } else {
                    next_bit::<false, WORDS>(&x, from)
                };
                assert_eq!(got, want, "case {case} next {set} from {from}");
            }
            let lo = rng.below(MAX_WIDTH);
            let hi = lo + rng.below(MAX_WIDTH - lo);
            for c in 0..MAX_WIDTH {
                assert_eq!(
                    range_word(c / BITS, lo, hi) >> (c % BITS) & 1 != 0,
                    (lo..=hi).contains(&c)
                );
            }
        }
    }
}
