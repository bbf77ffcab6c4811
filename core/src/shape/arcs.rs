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
//! `f32` of the caller's scratch. Where the target has 128-bit SIMD the cells go without a
//! branch, a row's diagonals four at once, after a bound on the runs' advance (a fraction of a
//! cell's cost) that spares the DP where no run could cover `min_template` template points (the
//! border of an unknown part, against most templates); elsewhere one cell at a time. Both give
//! the same runs: a unit test holds the rows against the DP one cell at a time.

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
/// With SIMD, first a relaxed pass over the same grid bounds each run's advance (`may_reach`);
/// where no run could cover [`ArcParams::min_template`] template points, none is kept and the
/// DP is not run. The rows then go four diagonals at once, a run named by one `f32`,
/// `begin·m + first template index`. Without SIMD, and for a border so long that the names pass
/// 2²⁴ (hundreds of thousands of points), each cell is worked out on its own, with the same
/// result.
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
    let too_small = Error::BufferTooSmall {
        needed: need,
        got: rows.len(),
    };
    let Some(rows) = rows.get_mut(..need) else {
        return Err(too_small);
    };
    // Without SIMD (the Cortex-M4) one cell at a time: its branches skip most of a cell's work
    // there, which the branch-free rows do in every lane, and the bound does not pay for itself
    // (the firmware's frame of touching parts: 31.7 M instructions so, 34.0 M with both). A run
    // is named by `begin·m + first template index`, exact in `f32` below 2²⁴; beyond (borders
    // of hundreds of thousands of points) each cell is worked out on its own too.
    let unrolled = n + m.min(n) - 1;
    if LANES == 1 || unrolled.saturating_add(2).saturating_mul(m) >= 1 << 24 {
        return best_arcs_by_cell(part, template, params, rows, out);
    }
    // No run can cover `min_template` template points: none is kept (a bound first, at a
    // fraction of the DP's cost).
    if !may_reach(part, template, params, rows) {
        return Ok(());
    }
    // Per diagonal o (template index j = (i + o) mod m at border point i), padded by one
    // diagonal each side (index o + 1; the pads repeat the other end, as the diagonals wrap):
    // the running score, its run's name and the template points it has advanced by. Then the
    // next row's three values; the best score each diagonal's run has reached, where (border
    // index) and at what advance; and the template twice over.
    let w = m + 2;
    let mut rest = rows;
    let (
        Some(score),
        Some(run),
        Some(advance),
        Some(next),
        Some(next_run),
        Some(next_adv),
        Some(peak),
        Some(peak_i),
        Some(peak_adv),
        Some(twice),
    ) = (
        take(w, &mut rest),
        take(w, &mut rest),
        take(w, &mut rest),
        take(m, &mut rest),
        take(m, &mut rest),
        take(m, &mut rest),
        take(m, &mut rest),
        take(m, &mut rest),
        take(m, &mut rest),
        take(2 * m, &mut rest),
    )
    else {
        return Err(too_small);
    };
    for (k, v) in twice.iter_mut().enumerate() {
        *v = template.get(k % m).copied().unwrap_or(0.0);
    }
    for v in [
        &mut *score,
        &mut *run,
        &mut *advance,
        &mut *peak,
        &mut *peak_i,
        &mut *peak_adv,
    ] {
        v.fill(0.0);
    }
    let min_len = params.min_template as f32;
    let (nf, mf) = (n as f32, m as f32);
    for i in 0..unrolled {
        // The pads: diagonal −1 is m − 1, diagonal m is 0.
        for v in [&mut *score, &mut *run, &mut *advance] {
            let (first, last) = (v.get(1).copied().unwrap_or(0.0), v.get(m).copied().unwrap_or(0.0));
            if let Some(x) = v.first_mut() {
                *x = last;
            }
            if let Some(x) = v.get_mut(m + 1) {
                *x = first;
            }
        }
        let r = i % m;
        let fi = i as f32;
        let row = Row {
            p: part.get(i % n).copied().unwrap_or(0.0),
            fi,
            oldest: (fi - nf + 1.0) * mf,
            here: fi * mf + r as f32,
            dead: (fi + 1.0) * mf,
            mf,
            min_len,
            params: *params,
        };
        let Some(trow) = twice.get(r..r + m) else {
            break;
        };
        let cur = [&*score, &*run, &*advance];
        let mut next = [&mut *next, &mut *next_run, &mut *next_adv];
        let mut peaks = [&mut *peak, &mut *peak_i, &mut *peak_adv];
        // The diagonals in groups of LANES (one vector operation each where the target has
        // them), then one by one.
        let groups = m / LANES;
        for g in 0..groups {
            row.group::<LANES, K>(g * LANES, n, m, cur, trow, &mut next, &mut peaks, out);
            if LANES > 1 {
                // An empty barrier: the loop vectoriser leaves the loop alone, so each group
                // stays one operation (as in `shape::matching`).
                core::hint::black_box(());
            }
        }
        for o in groups * LANES..m {
            row.group::<1, K>(o, n, m, cur, trow, &mut next, &mut peaks, out);
        }
        for (dst, src) in [
            (&mut *score, &*next[0]),
            (&mut *run, &*next[1]),
            (&mut *advance, &*next[2]),
        ] {
            if let Some(d) = dst.get_mut(1..m + 1) {
                d.copy_from_slice(src);
            }
        }
    }
    for o in 0..m {
        if let (Some(&pk), Some(&id), Some(&at), Some(&adv)) =
            (peak.get(o), run.get(o + 1), peak_i.get(o), peak_adv.get(o))
        {
            if pk > 0.0 && adv + 1.0 >= min_len {
                report_run(n, m, pk, id, at, adv, out);
            }
        }
    }
    best_first(out);
    Ok(())
}

/// Whether a run of [`best_arcs`] could cover `params.min_template` template points: the DP
/// relaxed to the scores alone (a run continues from any neighbour whose score is positive,
/// whatever its age), each cell bounding its run's advance by the largest among those
/// neighbours. Its scores are never below the DP's (the same sums, with fewer restarts), so
/// neither are its advances: when none reaches `min_template − 1`, the DP keeps no run.
/// `rows` is [`best_arcs`]'s scratch (`6·m + 4` cells of it).
fn may_reach(part: &[f32], template: &[f32], params: &ArcParams, rows: &mut [f32]) -> bool {
    let (n, m) = (part.len(), template.len());
    let goal = params.min_template as f32 - 1.0;
    if n == 0 || m == 0 || !(goal > 0.0) {
        return true;
    }
    let w = m + 2;
    let mut rest = rows;
    let (Some(score), Some(advance), Some(next), Some(next_adv), Some(twice)) = (
        take(w, &mut rest),
        take(w, &mut rest),
        take(m, &mut rest),
        take(m, &mut rest),
        take(2 * m, &mut rest),
    ) else {
        return true;
    };
    for (k, v) in twice.iter_mut().enumerate() {
        *v = template.get(k % m).copied().unwrap_or(0.0);
    }
    score.fill(0.0);
    advance.fill(0.0);
    let unrolled = n + m.min(n) - 1;
    for i in 0..unrolled {
        for v in [&mut *score, &mut *advance] {
            let (first, last) = (v.get(1).copied().unwrap_or(0.0), v.get(m).copied().unwrap_or(0.0));
            if let Some(x) = v.first_mut() {
                *x = last;
            }
            if let Some(x) = v.get_mut(m + 1) {
                *x = first;
            }
        }
        let p = part.get(i % n).copied().unwrap_or(0.0);
        let r = i % m;
        let Some(trow) = twice.get(r..r + m) else {
            return true;
        };
        let mut reach = [0.0f32; LANES];
        // (Comparisons, not `f32::max`: the DP's own choices, and one vector operation each;
        // each step over the lanes at once.)
        let larger = |a: f32, b: f32| if b > a { b } else { a };
        let groups = m / LANES;
        // The groups from slices of the exact lengths (each neighbour a slice one cell on), so
        // that the compiler sees every lane in bounds and keeps a group in registers.
        let span = groups * LANES;
        let (Some(s_l), Some(s_o), Some(s_r), Some(a_l), Some(a_o), Some(a_r), Some(tr), Some(ns), Some(na)) = (
            score.get(..span),
            score.get(1..span + 1),
            score.get(2..span + 2),
            advance.get(..span),
            advance.get(1..span + 1),
            advance.get(2..span + 2),
            trow.get(..span),
            next.get_mut(..span),
            next_adv.get_mut(..span),
        ) else {
            return true;
        };
        let sources = s_l
            .chunks_exact(LANES)
            .zip(s_o.chunks_exact(LANES))
            .zip(s_r.chunks_exact(LANES))
            .zip(
                a_l.chunks_exact(LANES)
                    .zip(a_o.chunks_exact(LANES))
                    .zip(a_r.chunks_exact(LANES)),
            )
            .zip(tr.chunks_exact(LANES));
        let targets = ns.chunks_exact_mut(LANES).zip(na.chunks_exact_mut(LANES));
        for (((((s_l, s_o), s_r), ((a_l, a_o), a_r)), tr), (ns, na)) in sources.zip(targets) {
            let (Some(s_l), Some(s_o), Some(s_r), Some(a_l), Some(a_o), Some(a_r), Some(tr)) = (
                arr::<LANES>(s_l),
                arr::<LANES>(s_o),
                arr::<LANES>(s_r),
                arr::<LANES>(a_l),
                arr::<LANES>(a_o),
                arr::<LANES>(a_r),
                arr::<LANES>(tr),
            ) else {
                return true;
            };
            let (vs, va) = relaxed_cells([s_l, s_o, s_r], [a_l, a_o, a_r], tr, p, params);
            for (re, a) in reach.iter_mut().zip(va) {
                *re = larger(*re, a);
            }
            ns.copy_from_slice(&vs);
            na.copy_from_slice(&va);
            if LANES > 1 {
                core::hint::black_box(());
            }
        }
        for o in groups * LANES..m {
            let g = |v: &[f32], i: usize| [v.get(i).copied().unwrap_or(0.0)];
            let ([v], [a]) = relaxed_cells(
                [g(score, o), g(score, o + 1), g(score, o + 2)],
                [g(advance, o), g(advance, o + 1), g(advance, o + 2)],
                g(trow, o),
                p,
                params,
            );
            if let (Some(ns), Some(na), Some(re)) = (next.get_mut(o), next_adv.get_mut(o), reach.first_mut()) {
                (*ns, *na) = (v, a);
                *re = larger(*re, a);
            }
        }
        if reach.iter().any(|a| *a >= goal) {
            return true;
        }
        for (dst, src) in [(&mut *score, &*next), (&mut *advance, &*next_adv)] {
            if let Some(d) = dst.get_mut(1..m + 1) {
                d.copy_from_slice(src);
            }
        }
    }
    false
}

/// [`may_reach`]'s cells of `L` diagonals: from the scores and advances of their left
/// neighbours, themselves and their right neighbours, and the template values `t` against
/// border turning `p`, the next scores and the bounds on their runs' advances.
#[inline(always)]
fn relaxed_cells<const L: usize>(
    [s_l, s_o, s_r]: [[f32; L]; 3],
    [a_l, a_o, a_r]: [[f32; L]; 3],
    t: [f32; L],
    p: f32,
    params: &ArcParams,
) -> ([f32; L], [f32; L]) {
    let larger = |a: f32, b: f32| if b > a { b } else { a };
    let lane = |v: &[f32; L], k: usize| v.get(k).copied().unwrap_or(0.0);
    let ls: [f32; L] = core::array::from_fn(|k| lane(&s_l, k) - params.stretch);
    let rs: [f32; L] = core::array::from_fn(|k| lane(&s_r, k) - params.stretch);
    let best: [f32; L] = core::array::from_fn(|k| larger(larger(lane(&s_o, k), lane(&ls, k)), lane(&rs, k)));
    let d: [f32; L] = core::array::from_fn(|k| (p - lane(&t, k)).abs());
    let gain: [f32; L] = core::array::from_fn(|k| {
        let d = lane(&d, k);
        params.reward - if d < params.cap { d } else { params.cap }
    });
    let v: [f32; L] = core::array::from_fn(|k| lane(&gain, k) + larger(0.0, lane(&best, k)));
    let a: [f32; L] = core::array::from_fn(|k| {
        let own = if lane(&s_o, k) > 0.0 { lane(&a_o, k) + 1.0 } else { 0.0 };
        let left = if lane(&ls, k) > 0.0 { lane(&a_l, k) + 2.0 } else { 0.0 };
        let right = if lane(&rs, k) > 0.0 { lane(&a_r, k) } else { 0.0 };
        larger(larger(own, left), right)
    });
    let live: [bool; L] = core::array::from_fn(|k| lane(&v, k) > 0.0);
    let alive = |x: &[f32; L], k: usize| {
        if live.get(k).copied().unwrap_or(false) {
            lane(x, k)
        } else {
            0.0
        }
    };
    (
        core::array::from_fn(|k| alive(&v, k)),
        core::array::from_fn(|k| alive(&a, k)),
    )
}

/// Diagonals [`best_arcs`] computes at once: four where the target has 128-bit float SIMD,
/// one otherwise (the Cortex-M4).
const LANES: usize = if cfg!(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
)) {
    4
} else {
    1
};

/// The first `len` cells of `rest`, which keeps the others.
fn take<'a>(len: usize, rest: &mut &'a mut [f32]) -> Option<&'a mut [f32]> {
    let (head, tail) = core::mem::take(rest).split_at_mut_checked(len)?;
    *rest = tail;
    Some(head)
}

/// `L` values of `v` from `at`.
#[inline(always)]
fn lanes<const L: usize>(v: &[f32], at: usize) -> Option<[f32; L]> {
    v.get(at..at.checked_add(L)?)?.try_into().ok()
}

/// The `L` values of a chunk of exactly `L` (`None` for another length).
#[inline(always)]
fn arr<const L: usize>(v: &[f32]) -> Option<[f32; L]> {
    v.try_into().ok()
}

/// Writes `L` values into `v` from `at`.
#[inline(always)]
fn put<const L: usize>(v: &mut [f32], at: usize, x: [f32; L]) {
    if let Some(d) = at.checked_add(L).and_then(|end| v.get_mut(at..end)) {
        d.copy_from_slice(&x);
    }
}

/// One row of [`best_arcs`]: border point `fi` (its index as `f32`) with turning `p`. A run is
/// named `begin·m + j` (begun at border index `begin`, template index `j`), exact in `f32`.
#[derive(Clone, Copy)]
struct Row {
    p: f32,
    fi: f32,
    /// The least name of a run that has not yet covered the border once
    /// (`(fi − n + 1)·m`: begun after border index `fi − n`).
    oldest: f32,
    /// The name of a run begun here on diagonal 0 (on diagonal o: `+ o`, less `m` from `dead`).
    here: f32,
    /// A dead cell's name (a run begun at the next border index, template index 0).
    dead: f32,
    mf: f32,
    min_len: f32,
    params: ArcParams,
}

impl Row {
    /// Diagonals `at … at + L` of the next row from the current one (`cur`: score, run name,
    /// advance, each padded), written into `next`; each diagonal's best in `peaks` (score,
    /// where, advance) after the runs that end here were offered, in diagonal order. Without a
    /// branch but for the offers (rare).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn group<const L: usize, const K: usize>(
        &self,
        at: usize,
        n: usize,
        m: usize,
        cur: [&[f32]; 3],
        trow: &[f32],
        next: &mut [&mut [f32]; 3],
        peaks: &mut [&mut [f32]; 3],
        out: &mut heapless::Vec<ArcMatch, K>,
    ) {
        let [score, run, advance] = cur;
        let three = |v: &[f32]| Some((lanes::<L>(v, at)?, lanes::<L>(v, at + 1)?, lanes::<L>(v, at + 2)?));
        let (Some((s_l, s_o, s_r)), Some((id_l, id_o, id_r)), Some((a_l, a_o, a_r))) =
            (three(score), three(run), three(advance))
        else {
            return;
        };
        let (Some(tr), Some(pk), Some(pi), Some(pa)) = (
            lanes::<L>(trow, at),
            lanes::<L>(peaks[0], at),
            lanes::<L>(peaks[1], at),
            lanes::<L>(peaks[2], at),
        ) else {
            return;
        };
        let ArcParams {
            reward, cap, stretch, ..
        } = self.params;
        let (fi, mf) = (self.fi, self.mf);
        let here = self.here + at as f32;
        let (mut ns, mut nid, mut na) = ([0.0f32; L], [0.0f32; L], [0.0f32; L]);
        let (mut npk, mut npi, mut npa) = ([0.0f32; L], [0.0f32; L], [0.0f32; L]);
        let mut offers = 0u32;
        for k in 0..L {
            let g = |v: &[f32; L]| v.get(k).copied().unwrap_or(0.0);
            let own = g(&s_o);
            // Along the diagonal, or from a neighbour: o − 1 skips a template point, o + 1
            // repeats one.
            let (ls, rs) = (g(&s_l) - stretch, g(&s_r) - stretch);
            let take_l = ls > own;
            let best_l = if take_l { ls } else { own };
            let take_r = rs > best_l;
            let best = if take_r { rs } else { best_l };
            let run_id = if take_r {
                g(&id_r)
            } else if take_l {
                g(&id_l)
            } else {
                g(&id_o)
            };
            let run_a = if take_r {
                g(&a_r)
            } else if take_l {
                g(&a_l) + 2.0
            } else {
                g(&a_o) + 1.0
            };
            let gain = reward - (self.p - g(&tr)).abs().min(cap);
            // Within one turn of the border and of the template, else a new run (at template
            // point (r + o) mod m).
            let cont = (best > 0.0) & (run_id >= self.oldest) & (run_a < mf);
            let j = here + k as f32;
            let j = if j >= self.dead { j - mf } else { j };
            let v = if cont { best + gain } else { gain };
            let vid = if cont { run_id } else { j };
            let va = if cont { run_a } else { 0.0 };
            let dead = v <= 0.0;
            // The run that held this diagonal ends: its best is a candidate.
            let ended = dead | ((own > 0.0) & (vid != g(&id_o)));
            let (pkk, pak) = (g(&pk), g(&pa));
            offers |= u32::from(ended & (pkk > 0.0) & (pak + 1.0 >= self.min_len)) << k;
            let base = if ended { 0.0 } else { pkk };
            let raise = !dead & (v > base);
            if let (Some(ns), Some(nid), Some(na), Some(npk), Some(npi), Some(npa)) = (
                ns.get_mut(k),
                nid.get_mut(k),
                na.get_mut(k),
                npk.get_mut(k),
                npi.get_mut(k),
                npa.get_mut(k),
            ) {
                *ns = if dead { 0.0 } else { v };
                *nid = if dead { self.dead } else { vid };
                *na = if dead { 0.0 } else { va };
                *npk = if raise { v } else { base };
                *npi = if raise { fi } else { g(&pi) };
                *npa = if raise { va } else { pak };
            }
        }
        if offers != 0 {
            for k in 0..L {
                if offers & (1 << k) != 0 {
                    let g = |v: &[f32; L]| v.get(k).copied().unwrap_or(0.0);
                    report_run(n, m, g(&pk), g(&id_o), g(&pi), g(&pa), out);
                }
            }
        }
        let [next_s, next_id, next_a] = next;
        put(next_s, at, ns);
        put(next_id, at, nid);
        put(next_a, at, na);
        let [peak, peak_i, peak_adv] = peaks;
        put(peak, at, npk);
        put(peak_i, at, npi);
        put(peak_adv, at, npa);
    }
}

/// Offers the run named `id` (`begin·m + first template index`) that held a diagonal
/// ([`offer`]): its best `peak`, reached at border index `end` after advancing `adv`
/// template points.
#[cold]
fn report_run<const K: usize>(
    n: usize,
    m: usize,
    peak: f32,
    id: f32,
    end: f32,
    adv: f32,
    out: &mut heapless::Vec<ArcMatch, K>,
) {
    let (id, m) = (id as usize, m.max(1));
    let first = id / m;
    offer(
        n,
        ArcMatch {
            part_start: first % n,
            part_len: (end as usize + 1).saturating_sub(first),
            template_start: id % m,
            template_len: adv as usize + 1,
            score: peak,
        },
        out,
    );
}

/// [`best_arcs`] one cell at a time, its run's begin and first template index kept apart (the
/// DP as first written; for borders too long to name a run in `f32`).
fn best_arcs_by_cell<const K: usize>(
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
    best_first(out);
    Ok(())
}

/// Sorts the runs best first (insertion sort: `K` is small).
fn best_first<const K: usize>(out: &mut heapless::Vec<ArcMatch, K>) {
    for a in 1..out.len() {
        let mut b = a;
        while b > 0 && out.get(b - 1).map(|x| x.score) < out.get(b).map(|x| x.score) {
            out.swap(b - 1, b);
            b -= 1;
        }
    }
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

    /// The DP gives exactly the runs of the reference (the same scores bit for bit, the same
    /// order): random turning angles, borders shorter and longer than the template, templates of
    /// 1 to 60 points, stretches of the template copied in, every list length.
    #[test]
    fn best_arcs_gives_the_reference_runs() {
        let mut rng = crate::test_rng::XorShiftStar(0xa4c5_0001);
        let mut rows = std::vec![0.0f32; ARC_ROWS * 64 + ARC_PAD];
        let mut rows_ref = rows.clone();
        for case in 0..600 {
            let m = 1 + rng.below(60) as usize;
            let n = 1 + rng.below(150) as usize;
            let template: std::vec::Vec<f32> = (0..m).map(|_| rng.below(4000) as f32 * 0.001 - 2.0).collect();
            let mut part: std::vec::Vec<f32> = (0..n).map(|_| rng.below(4000) as f32 * 0.001 - 2.0).collect();
            if rng.below(2) == 0 {
                let len = 1 + rng.below(m.min(n) as u64) as usize;
                let (ps, ts) = (rng.below(n as u64) as usize, rng.below(m as u64) as usize);
                for k in 0..len {
                    part[(ps + k) % n] = template[(ts + k) % m] + rng.below(100) as f32 * 0.001;
                }
            }
            let params = ArcParams {
                min_template: rng.below(m as u64 + 2) as usize,
                ..ArcParams::DEFAULT
            };
            let mut out = heapless::Vec::<ArcMatch, 4>::new();
            let mut out_ref = heapless::Vec::<ArcMatch, 4>::new();
            best_arcs(&part, &template, &params, &mut rows, &mut out).unwrap();
            best_arcs_by_cell(&part, &template, &params, &mut rows_ref, &mut out_ref).unwrap();
            assert_eq!(out.len(), out_ref.len(), "case {case}: n {n} m {m}");
            for (a, b) in out.iter().zip(&out_ref) {
                assert_eq!(
                    (
                        a.part_start,
                        a.part_len,
                        a.template_start,
                        a.template_len,
                        a.score.to_bits()
                    ),
                    (
                        b.part_start,
                        b.part_len,
                        b.template_start,
                        b.template_len,
                        b.score.to_bits()
                    ),
                    "case {case}: n {n} m {m}"
                );
            }
            let mut one = heapless::Vec::<ArcMatch, 1>::new();
            let mut one_ref = heapless::Vec::<ArcMatch, 1>::new();
            best_arcs(&part, &template, &params, &mut rows, &mut one).unwrap();
            best_arcs_by_cell(&part, &template, &params, &mut rows_ref, &mut one_ref).unwrap();
            assert_eq!(one, one_ref, "case {case}");
        }
    }

    /// A border so long that its runs' names pass 2²⁴ (each cell worked out on its own): the
    /// best run is still the copied stretch.
    #[test]
    fn a_border_too_long_for_run_names_still_gives_the_copied_stretch() {
        let m = 4096;
        let n = 2100;
        let mut rng = crate::test_rng::XorShiftStar(0x10_0000);
        let template: std::vec::Vec<f32> = (0..m).map(|_| rng.below(2000) as f32 * 0.001 - 1.0).collect();
        let mut part = std::vec![3.0f32; n];
        for k in 0..600 {
            part[(2000 + k) % n] = template[(100 + k) % m];
        }
        assert!((n + m.min(n) + 1) * m >= 1 << 24);
        let mut rows = std::vec![0.0f32; ARC_ROWS * m + ARC_PAD];
        let mut out = heapless::Vec::<ArcMatch, 2>::new();
        let params = ArcParams {
            min_template: 16,
            ..ArcParams::DEFAULT
        };
        best_arcs(&part, &template, &params, &mut rows, &mut out).unwrap();
        let best = out[0];
        assert_eq!(
            (best.part_start, best.part_len, best.template_start, best.template_len),
            (2000, 600, 100, 600),
            "{out:?}"
        );
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
