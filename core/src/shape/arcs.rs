//! Partial, open order-preserving matching of a template against arcs of a blob's border.
//!
//! The paper's DP matches a whole border to a whole template, cyclically; a blob that holds
//! two touching parts, or a part cut by the frame's edge, shows each template only along an arc
//! of its border. Here the cyclic constraint is relaxed to a partial, open match (the local
//! alignment of Smith and Waterman, kept order-preserving): a run of consecutive border points
//! `i0 … i1` is matched to consecutive template points `j0 … j1` in the same order, each border
//! point to one template point, the template index advancing by 1 a step (or by 0 or 2, at a
//! penalty, where the part is a little larger or smaller than its template). A run scores
//! `Σ (r − min(|κ_i − κ'_j|, cap))` less the penalties, and the best runs end where the border
//! leaves the template (at the point where two parts meet, or the frame's edge).
//!
//! The paper's descriptor (`crate::shape::descriptor`) measures each point against the centroid of
//! the whole border, which a blob of several parts does not share with its template; a run
//! needs a local measure instead: the **turning angle** `κ_i`, the signed angle between
//! `q_i − q_{i−k}` and `q_{i+k} − q_i` (radians, positive for a left turn), at points spaced by
//! the same arc length on the border and on the template ([`turning`]). It does not change
//! with rotation or position, and little with a scale near 1.
//!
//! Both sequences are closed: the border is unrolled once (a run may pass its first point) and
//! the template twice, and a run covers at most the border once and the template once.
//! [`best_arcs`] keeps the best runs whose border stretches do not mostly overlap: the
//! candidates of one template for the parts of a blob.
//!
//! Time `O((n + m)·m)` cells for a border of `n` and a template of `m` points (three moves a
//! cell) and `O(K)` for each cell that may enter the list of `K` runs; memory: [`ARC_ROWS`]`·m`
//! `f32` of the caller's scratch.

use crate::error::{Error, Result};
use crate::math;

/// Scratch cells [`best_arcs`] needs per template point: eleven values per diagonal and the
/// template twice, and [`ARC_PAD`] more.
pub const ARC_ROWS: usize = 13;
/// Scratch cells [`best_arcs`] needs besides [`ARC_ROWS`] per template point.
pub const ARC_PAD: usize = 8;

/// Parameters of [`best_arcs`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcParams {
    /// Reward `r` of a matched point pair before its cost, radians of turning.
    pub reward: f32,
    /// Largest cost of one pair (a sharp turn on one side only costs no more than this).
    pub cap: f32,
    /// Penalty of a step that repeats or skips a template point.
    pub stretch: f32,
    /// Least template points a run must cover to be kept.
    pub min_template: usize,
}

impl ArcParams {
    /// The defaults the recognizer uses.
    pub const DEFAULT: ArcParams = ArcParams {
        reward: 0.25,
        cap: 1.0,
        stretch: 0.15,
        min_template: 8,
    };
}

/// One run: border points `part_start …` (`part_len` of them, indices modulo the border's
/// length) matched in order to template points `template_start …` (`template_len`, modulo the
/// template's length).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ArcMatch {
    /// First border point of the run.
    pub part_start: usize,
    /// Border points in the run.
    pub part_len: usize,
    /// First template point of the run.
    pub template_start: usize,
    /// Template points the run spans (first to last, inclusive).
    pub template_len: usize,
    /// The run's score (rewards less costs and penalties).
    pub score: f32,
}

/// Writes the signed turning angle at each point of the closed polyline `points` over `k`
/// neighbours each way into `out` (same length): the angle from `q_i − q_{i−k}` to
/// `q_{i+k} − q_i`, radians in `(−π, π]`, positive where the cross product of the two chords is (`atan2(cross, dot)`; the
/// outer borders of parts and templates run the same way round, so the signs agree).
///
/// ```
/// use vorl_core::shape::arcs::turning;
/// // A square traced with 4 points a side: the corners turn by a quarter turn, the sides not.
/// let mut pts = Vec::new();
/// for side in 0..4 {
///     for s in 0..4 {
///         let t = s as f32;
///         pts.push(match side { 0 => [t, 0.0], 1 => [4.0, t], 2 => [4.0 - t, 4.0], _ => [0.0, 4.0 - t] });
///     }
/// }
/// let mut k = vec![0.0f32; 16];
/// turning(&pts, 1, &mut k).unwrap();
/// assert!((k[4] - core::f32::consts::FRAC_PI_2).abs() < 1e-5);
/// assert!(k[2].abs() < 1e-6);
/// ```
///
/// # Errors
/// [`Error::DegenerateContour`] for fewer than 3 points, [`Error::BufferTooSmall`] when `out`
/// is shorter than `points`.
pub fn turning(points: &[[f32; 2]], k: usize, out: &mut [f32]) -> Result<()> {
    let n = points.len();
    if n < 3 {
        return Err(Error::DegenerateContour { points: n });
    }
    if out.len() < n {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: out.len(),
        });
    }
    let k = k.clamp(1, (n - 1) / 2).max(1);
    let at = |i: usize| points.get(i % n).copied().unwrap_or_default();
    for (i, o) in out.iter_mut().take(n).enumerate() {
        let (a, b, c) = (at(i + n - k), at(i), at(i + k));
        let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
        let cross = u[0] * v[1] - u[1] * v[0];
        let dot = u[0] * v[0] + u[1] * v[1];
        *o = if cross == 0.0 && dot == 0.0 {
            0.0
        } else {
            math::atan2(cross, dot)
        };
    }
    Ok(())
}

/// How many points two runs on a closed border of `n` points share.
fn shared(n: usize, a: &ArcMatch, b: &ArcMatch) -> usize {
    if n == 0 {
        return 0;
    }
    let d = (b.part_start + n - a.part_start % n) % n;
    let first = a.part_len.min(d + b.part_len).saturating_sub(d);
    let wrapped = a.part_len.min((d + b.part_len).saturating_sub(n));
    first + wrapped
}

/// Offers a run to the list: a run sharing more than half of the shorter one's border points
/// with a kept run replaces it when it scores more, and is dropped otherwise; a run apart from
/// all enters when there is room, or replaces the lowest-scoring one.
fn offer<const K: usize>(n: usize, run: ArcMatch, out: &mut heapless::Vec<ArcMatch, K>) {
    for kept in out.iter_mut() {
        let s = shared(n, kept, &run);
        if 2 * s > kept.part_len.min(run.part_len) {
            if run.score > kept.score {
                *kept = run;
            }
            return;
        }
    }
    if out.push(run).is_err() {
        let mut low: Option<&mut ArcMatch> = None;
        for kept in out.iter_mut() {
            if low.as_ref().is_none_or(|l| kept.score < l.score) {
                low = Some(kept);
            }
        }
        if let Some(l) = low.filter(|l| l.score < run.score) {
            *l = run;
        }
    }
}

/// The best open runs of `template` (turning angles, `m` points) along `part` (turning angles
/// of a closed border, `n` points), at most `K`, whose border stretches overlap by no more than
/// half; best first. `rows` is scratch of at least [`ARC_ROWS`]`·m + `[`ARC_PAD`] cells.
///
/// The DP runs along the diagonals of the unrolled grid: on diagonal `o` border point `i` meets
/// template point `(i + o) mod m`, and a run's score is the best sum of consecutive gains
/// ending at each cell (restarting where the sum falls to zero, Kadane's rule). Between two
/// cells of neighbouring diagonals the template index repeats or skips one point at the
/// [`ArcParams::stretch`] penalty, which lets a run follow a part a few per cent larger or
/// smaller than its template: each row keeps, for every diagonal, the running score and where
/// its run began, and a cell takes the best of its own diagonal and its two neighbours'.
///
/// ```
/// use vorl_core::shape::arcs::{best_arcs, ArcMatch, ArcParams};
/// // The template's turning angles appear on the border from point 5 on, 12 of its 16 points.
/// let template: Vec<f32> = (0..16).map(|j| ((j * 7) % 5) as f32 * 0.3).collect();
/// let mut part = vec![2.5f32; 40];
/// for s in 0..12 {
///     part[5 + s] = template[(3 + s) % 16];
/// }
/// let mut rows = vec![0.0f32; 13 * 16 + 8];
/// let mut out = heapless::Vec::<ArcMatch, 4>::new();
/// best_arcs(&part, &template, &ArcParams::DEFAULT, &mut rows, &mut out).unwrap();
/// assert_eq!((out[0].part_start, out[0].part_len), (5, 12));
/// assert_eq!((out[0].template_start, out[0].template_len), (3, 12));
/// ```
///
/// # Errors
/// [`Error::DegenerateContour`] for an empty sequence, [`Error::BufferTooSmall`] for `rows`.
pub fn best_arcs<const K: usize>(
    part: &[f32],
    template: &[f32],
    params: &ArcParams,
    rows: &mut [f32],
    out: &mut heapless::Vec<ArcMatch, K>,
) -> Result<()> {
    let (n, m) = (part.len(), template.len());
    out.clear();
    if n == 0 || m == 0 {
        return Err(Error::DegenerateContour { points: n.min(m) });
    }
    let need = ARC_ROWS.saturating_mul(m).saturating_add(ARC_PAD);
    let Some(rows) = rows.get_mut(..need) else {
        return Err(Error::BufferTooSmall {
            needed: need,
            got: rows.len(),
        });
    };
    // Per diagonal o (template index j = (i + o) mod m at border point i), padded by one
    // diagonal each side (index o + 1; the pads repeat the other end, as the diagonals wrap):
    // the running score, the border index where its run began, its first template index and
    // the template points it has advanced by. Then the best score each diagonal's run has
    // reached, where (border index) and at what advance; the next row's four values; and the
    // template twice over.
    let w = m + 2;
    let (score, rest) = rows.split_at_mut(w);
    let (begin, rest) = rest.split_at_mut(w);
    let (tstart, rest) = rest.split_at_mut(w);
    let (advance, rest) = rest.split_at_mut(w);
    let (peak, rest) = rest.split_at_mut(m);
    let (peak_i, rest) = rest.split_at_mut(m);
    let (peak_adv, rest) = rest.split_at_mut(m);
    let (next, rest) = rest.split_at_mut(m);
    let (next_begin, rest) = rest.split_at_mut(m);
    let (next_tstart, rest) = rest.split_at_mut(m);
    let (next_adv, rest) = rest.split_at_mut(m);
    let (twice, _) = rest.split_at_mut(2 * m);
    for (k, v) in twice.iter_mut().enumerate() {
        *v = template.get(k % m).copied().unwrap_or(0.0);
    }
    score.fill(0.0);
    begin.fill(0.0);
    tstart.fill(0.0);
    advance.fill(0.0);
    peak.fill(0.0);
    peak_i.fill(0.0);
    peak_adv.fill(0.0);
    // A run covers the border once at most: the border is unrolled by the template's length.
    let unrolled = n + m.min(n) - 1;
    let min_len = params.min_template as f32;
    let report = |peak: f32, begin: f32, first_t: f32, end: f32, adv: f32, out: &mut heapless::Vec<ArcMatch, K>| {
        if peak > 0.0 && adv + 1.0 >= min_len {
            let first = begin as usize;
            offer(
                n,
                ArcMatch {
                    part_start: first % n,
                    part_len: (end as usize + 1).saturating_sub(first),
                    template_start: first_t as usize % m,
                    template_len: adv as usize + 1,
                    score: peak,
                },
                out,
            );
        }
    };
    let (nf, mf) = (n as f32, m as f32);
    let (reward, cap, stretch) = (params.reward, params.cap, params.stretch);
    for i in 0..unrolled {
        let p = part.get(i % n).copied().unwrap_or(0.0);
        let fi = i as f32;
        let r = i % m;
        let Some(trow) = twice.get(r..r + m) else {
            break;
        };
        // The pads: diagonal −1 is m − 1, diagonal m is 0.
        for v in [&mut *score, &mut *begin, &mut *tstart, &mut *advance] {
            let (first, last) = (v.get(1).copied().unwrap_or(0.0), v.get(m).copied().unwrap_or(0.0));
            if let Some(x) = v.first_mut() {
                *x = last;
            }
            if let Some(x) = v.get_mut(m + 1) {
                *x = first;
            }
        }
        for o in 0..m {
            let (own, left, right) = (score[o + 1], score[o], score[o + 2]);
            let gain = reward - (p - trow[o]).abs().min(cap);
            // Along the diagonal, or from a neighbour: o − 1 skips a template point, o + 1
            // repeats one.
            let (mut best, mut k, mut step) = (own, o + 1, 1.0f32);
            if left - stretch > best {
                (best, k, step) = (left - stretch, o, 2.0);
            }
            if right - stretch > best {
                (best, k, step) = (right - stretch, o + 2, 0.0);
            }
            let pick = |v: &[f32]| v.get(k).copied().unwrap_or(0.0);
            let (b, bt, a) = (pick(begin), pick(tstart), pick(advance) + step);
            // Within one turn of the border and of the template, else a new run.
            let (mut v, mut vb, mut vt, mut va) = if best > 0.0 && fi - b < nf && a < mf {
                (best + gain, b, bt, a)
            } else {
                (gain, fi, ((i + o) % m) as f32, 0.0)
            };
            let (old_b, old_t) = (begin[o + 1], tstart[o + 1]);
            if v <= 0.0 || (own > 0.0 && (vb != old_b || vt != old_t)) {
                // The run that held this diagonal ends: its best is a candidate.
                report(peak[o], old_b, old_t, peak_i[o], peak_adv[o], out);
                peak[o] = 0.0;
            }
            if v <= 0.0 {
                (v, vb, vt, va) = (0.0, fi + 1.0, 0.0, 0.0);
            } else if v > peak[o] {
                (peak[o], peak_i[o], peak_adv[o]) = (v, fi, va);
            }
            (next[o], next_begin[o], next_tstart[o], next_adv[o]) = (v, vb, vt, va);
        }
        for (dst, src) in [
            (&mut *score, &*next),
            (&mut *begin, &*next_begin),
            (&mut *tstart, &*next_tstart),
            (&mut *advance, &*next_adv),
        ] {
            for (d, v) in dst.iter_mut().skip(1).zip(src.iter()) {
                *d = *v;
            }
        }
    }
    for o in 0..m {
        report(peak[o], begin[o + 1], tstart[o + 1], peak_i[o], peak_adv[o], out);
    }
    // Best first (insertion sort: K is small).
    for a in 1..out.len() {
        let mut b = a;
        while b > 0 && out.get(b - 1).map(|x| x.score) < out.get(b).map(|x| x.score) {
            out.swap(b - 1, b);
            b -= 1;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    /// Turning angles do not change when the outline is turned and moved.
    #[test]
    fn turning_is_invariant_to_rotation_and_translation() {
        let mut rng = crate::test_rng::XorShiftStar(0x7a11);
        for _ in 0..50 {
            let n = 12 + rng.below(60) as usize;
            let pts: std::vec::Vec<[f32; 2]> = (0..n)
                .map(|i| {
                    let t = i as f32 * core::f32::consts::TAU / n as f32;
                    let r = 20.0 + rng.below(100) as f32 * 0.05;
                    [r * libm::cosf(t), r * libm::sinf(t)]
                })
                .collect();
            let (s, c) = libm::sincosf(rng.below(628) as f32 * 0.01);
            let moved: std::vec::Vec<[f32; 2]> = pts
                .iter()
                .map(|p| [c * p[0] - s * p[1] + 31.0, s * p[0] + c * p[1] - 7.5])
                .collect();
            let (mut a, mut b) = (std::vec![0.0f32; n], std::vec![0.0f32; n]);
            let k = 1 + rng.below(3) as usize;
            turning(&pts, k, &mut a).unwrap();
            turning(&moved, k, &mut b).unwrap();
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 2e-3, "{x} {y}");
            }
        }
    }

    /// A stretch of a template's turning angles (with a little noise) copied into a border of
    /// unrelated values, anywhere — across the border's first point too — and from any
    /// template point: the best run is that stretch, matched to those template points.
    #[test]
    fn the_best_run_is_the_copied_stretch() {
        let mut rng = crate::test_rng::XorShiftStar(0xa5c5);
        let mut rows = std::vec![0.0f32; ARC_ROWS * 64 + ARC_PAD];
        for case in 0..200 {
            let m = 16 + rng.below(48) as usize;
            let n = m + rng.below(120) as usize;
            let template: std::vec::Vec<f32> = (0..m).map(|_| rng.below(2000) as f32 * 0.001 - 1.0).collect();
            // Unrelated values: far from every template value (a gain of 0 at best).
            let mut part: std::vec::Vec<f32> = (0..n).map(|_| 3.0 + rng.below(100) as f32 * 0.01).collect();
            let len = m / 2 + rng.below((m / 2) as u64) as usize;
            let (ps, ts) = (rng.below(n as u64) as usize, rng.below(m as u64) as usize);
            for k in 0..len {
                let noise = rng.below(200) as f32 * 0.0001 - 0.01;
                part[(ps + k) % n] = template[(ts + k) % m] + noise;
            }
            let mut out = heapless::Vec::<ArcMatch, 3>::new();
            best_arcs(
                &part,
                &template,
                &ArcParams {
                    min_template: 4,
                    ..ArcParams::DEFAULT
                },
                &mut rows,
                &mut out,
            )
            .unwrap();
            let best = out[0];
            assert_eq!(
                (best.part_start, best.part_len, best.template_start, best.template_len),
                (ps, len, ts, len),
                "case {case}: n {n} m {m}: {out:?}"
            );
        }
    }

    /// Bad input: empty sequences and short scratch are errors, not panics.
    #[test]
    fn bad_input_is_an_error() {
        let mut out = heapless::Vec::<ArcMatch, 2>::new();
        let mut rows = [0.0f32; 8];
        assert!(best_arcs(&[], &[1.0], &ArcParams::DEFAULT, &mut rows, &mut out).is_err());
        assert!(best_arcs(&[1.0; 4], &[1.0; 4], &ArcParams::DEFAULT, &mut rows, &mut out).is_err());
        assert!(turning(&[[0.0, 0.0]; 2], 1, &mut [0.0; 2]).is_err());
    }
}
