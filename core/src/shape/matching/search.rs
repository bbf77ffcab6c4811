//! The fast path of the cyclic DP over every start ([`super::best_cost`], [`super::best_match`]):
//! divide and conquer over the starts, exact — the same optimum as the per-start definition in
//! [`super`] (the tests hold the two to each other, and `spec.rs` restates this search cell by
//! cell).
//!
//! # Divide and conquer over the starts (Maes 1990)
//!
//! Unroll the template (column `k` holds template point `k mod m`, `0 ≤ k < 2m`). A start's
//! assignment is then a *path* `k_0 < k_1 < … < k_{n−1}` with `k_i = s + i + δ_i`, `k_0 = s`
//! and `k_{n−1} ≤ s + m − 1`; its cost is `Σ_i c(i, k_i)`, and `c(i, k)` depends on the cell
//! only. Call `P ≤ Q` when `P_i ≤ Q_i` for every row.
//!
//! **Non-crossing lemma.** Let `P` be an optimal path of start `a` and `Q` one of start `b`,
//! `a < b`. Then `min(P, Q)` and `max(P, Q)` (row by row) are again paths: both are strictly
//! increasing (`min(P_i, Q_i) ≤ P_i < P_{i+1}` and `≤ Q_i < Q_{i+1}`, likewise for `max`);
//! `min` starts at `min(a, b) = a` and ends at `≤ P_{n−1} ≤ a + m − 1`; `max` starts at `b` and
//! ends at `≤ max(a + m − 1, b + m − 1) = b + m − 1`. Row by row they use the same two cells as
//! `P` and `Q`, so `cost(min) + cost(max) = cost(P) + cost(Q)`; as `P` is optimal for `a`,
//! `cost(min) ≥ cost(P)`, hence `cost(max) ≤ cost(Q)`: `max(P, Q)` is optimal for `b` and lies
//! on or above `P`. In the same way, if `U` is an optimal path of a start `c > b` with
//! `P ≤ U`, `min(max(P, Q), U)` is optimal for `b` and lies between `P` and `U`. So for every
//! start strictly between two starts with optimal paths `L ≤ U` there is an optimal path inside
//! the *band* `L ≤ · ≤ U`, and the DP restricted to the band finds the start's optimum.
//!
//! **The search.** Start 0 is solved on whole rows (path `P_0`); `P_0 + m` is an optimal path
//! of start `m`, the same contour point. The starts `(0, m)` are then split in halves: the middle
//! start of an interval `(lo, hi)` is solved inside the band between the paths of `lo` and `hi`,
//! and its path bounds the two halves `(lo, mid)` and `(mid, hi)`, down to single starts. At one
//! depth of the recursion the bands of the intervals tile the unrolled template between `P_0`
//! and `P_0 + m` (row by row, `Σ (U_i − L_i + 1) = m + intervals`), so depth `ℓ` visits at most
//! `n·(m + 2^ℓ)` cells for its middle starts and `n·(m + 2^(ℓ+1))` for the relaxed bounds of
//! their halves (below), each start at most `n·w`; with `⌈log2 m⌉` depths the search is
//! `O(n·m·log m)` instead of the plain `O(n·m·w)`. Measured on the benchmark's descriptors
//! (`core/benches/dp.rs`) it visits 1–10 % of the plain DP's `n·m·w` cells, on structureless
//! noise 6–36 % (the test `search_work_is_small`).
//!
//! **Exact pruning.** Costs are non-negative, so a row minimum never decreases with `i` and is a
//! lower bound on the total; a start or a whole interval of starts is dropped once a lower
//! bound on what it can reach is not below the best total so far (or the caller's `bound`, e.g.
//! the best over other templates). The optimum is unchanged:
//! - before an interval `(lo, hi)` of two or more starts is split, a *relaxed* DP runs over its
//!   band: a path may begin at any start in `(lo, hi)` and end anywhere up to
//!   `d = hi − 1 + w − 1` (`d = k − i`). Every start of the interval has an optimal path among
//!   these, so the relaxed optimum is a lower bound for all of them; when it (or its running
//!   row minimum) is not below the best, the interval is dropped. The two halves of an interval
//!   are visited lower bound first. Under a finite `bound` the same relaxed DP first runs over
//!   all starts, which usually rejects a template that cannot beat the bound at once.
//! - middle starts always run to the end, as their paths bound the halves; only a single start
//!   (an interval with nothing left to bound) is abandoned once its row minimum reaches the
//!   best. (Dropping a middle start early would also be exact — its halves would keep the
//!   interval's own bounding paths, valid by the lemma — but the wider bands cost more than the
//!   rows saved.)
//!
//! **The band DPs by columns.** Every band DP (a start's, a relaxed one) runs over the columns
//! `k` of the unrolled template instead of its rows. With `Q_i(k)` the least `D_i` of row `i`'s
//! band up to column `k`, a cell is `D_i(k) = |p_i − t_k| + Q_{i−1}(k − 1)` and
//! `Q_i(k) = min(Q_i(k − 1), D_i(k))`: every cell of a column depends only on the previous
//! column, so a column is one loop without a carried dependency — four rows to a vector
//! operation on the host, one at a time on a target without SIMD (the Cortex-M4) — where a
//! row's running minimum is a chain. The additions and comparisons are those of the row by row
//! recurrence, so are the results, bit for bit. The rows' bands move on strictly from row to
//! row, so a column meets a contiguous run of rows that only moves on; one buffer holds every
//! row's `Q`, updated in place. Rows one column wide, each alone in its column (the deep
//! levels' narrow bands), go as a plain chain `Q_i = |p_i − t_{k_i}| + Q_{i−1}`. A row's least
//! value is known once its band has ended, when the DP is dropped if it is not below the best
//! (later than row by row, by the rows the band spans: 3–15 % more cells on the bench set's
//! dropped DPs, each much cheaper).
//!
//! **Backtracking without a table.** While a column is updated, the rows whose running minimum
//! strictly decreases there are recorded as bits (16 per `f32` cell, kept as the cell's bit
//! pattern; bit `w − 1 − δ` of column `k` for row `i`, `δ = k − s − i`, `⌈w/16⌉` cells a
//! column). The first minimum of `D_{i−1}` up to column `k_i − 1` is the last column there (and
//! within row `i − 1`'s band) where row `i − 1`'s bit is set, or the band's first column: a
//! start's path is read back from its bits, one column step a row plus one per unit of `δ`, so
//! the winning start's correspondence needs no second DP; starts whose path is neither kept
//! (to bound halves) nor reported (a winner, when the correspondence is asked for) record no
//! bits.
//!
//! **Cost.** A search visits `O(n·m·log m)` cells (each bounded or relaxed DP a band of them);
//! what that comes to on the bench set and on the Cortex-M4 is in `docs/performance.md`.
//!
//! **Rounding.** The lemma holds in exact arithmetic. Each DP is exact in `f32` too — a rounded
//! sum is monotone in each term, so a DP returns the least rounded path total of its region —
//! but two paths whose exact totals tie may round differently, and in such a near tie a band
//! can miss a path whose total rounds a few units in the last place lower. The optimum is then
//! the plain DP's up to that rounding (in a stress run of 200 000 random inputs, `n ≤ 24`, 0.4 %
//! differed, by at most 2.3·10⁻⁷ relative); on costs whose sums are exact (e.g. multiples of a
//! power of two) it is identical. A bound never changes the result: the search returns the
//! same total with a bound as without whenever that total beats the bound.
//!

use super::Match;

/// Bits of the backtracking record kept in one `f32` cell (stored as the cell's bit pattern).
pub(super) const BITS_PER_CELL: usize = 16;

/// A small integer (a path's `δ` or a word of backtracking bits) kept in an `f32` cell of the
/// caller's buffer as the cell's bit pattern: no conversion on either side. Such a pattern is a
/// subnormal float, so these cells are only ever stored and copied, never computed with
/// (arithmetic under flush-to-zero would lose them).
#[inline(always)]
pub(super) fn pack(v: usize) -> f32 {
    f32::from_bits(v as u32)
}

/// The integer [`pack`] stored.
#[inline(always)]
fn unpack(v: f32) -> usize {
    v.to_bits() as usize
}

/// `⌈log2 m⌉` (0 for `m ≤ 1`).
pub(super) const fn ceil_log2(m: usize) -> usize {
    if m <= 1 {
        0
    } else {
        (usize::BITS - (m - 1).leading_zeros()) as usize
    }
}

/// Path slots the search keeps, `max(1, ⌈log2 m⌉)`: start 0's, and one per depth at which an
/// interval of three or more starts is split (an interval at depth `d` holds at most
/// `⌈m/2^d⌉` starts, so the deepest is `⌈log2 m⌉ − 2`).
const fn path_slots(m: usize) -> usize {
    let slots = ceil_log2(m);
    if slots == 0 {
        1
    } else {
        slots
    }
}

/// Cells the divide-and-conquer search over all starts needs (see the module docs):
/// `2m + 4n + 7 + max(1, ⌈log2 m⌉)·n + (n + w − 1)·⌈w/16⌉ + 3` with `w = m − n + 1`, or 0 when
/// `m < n`.
///
/// [`best_cost`](super::best_cost) and [`match_with_assignment`](super::match_with_assignment) use the search whenever their buffer holds this
/// many cells; it is at most [`table_cells`](super::table_cells)`(n, m)` unless `m − n` is small (then the plain
/// per-start DP, cheap for a narrow row, is used).
pub const fn search_cells(n: usize, m: usize) -> usize {
    if m < n {
        return 0;
    }
    let w = (m - n).saturating_add(1);
    let paths = path_slots(m).saturating_mul(n);
    let bits = n
        .saturating_add(w - 1)
        .saturating_mul(w.div_ceil(BITS_PER_CELL))
        .saturating_add(3);
    // The template twice, the part values and the column buffer (`PAD` cells more each), the
    // band of a DP.
    let columns = n.saturating_mul(4).saturating_add(2 * PAD + 1);
    m.saturating_mul(2)
        .saturating_add(columns)
        .saturating_add(paths)
        .saturating_add(bits)
}

/// A known optimal path bounding a band: row `i` lies at `d_i = start + δ_i` (`d = k − i`, the
/// unrolled column minus the row), `δ_i` stored in path slot `slot`.
#[derive(Debug, Clone, Copy)]
struct Edge {
    start: usize,
    slot: usize,
}

/// The path of edge `e` among `paths` (its `n` values of `δ`) and its start; a missing edge is
/// an empty path (every `δ` read as 0) at `missing`.
#[inline]
fn edge_path(paths: &[f32], n: usize, e: Option<Edge>, missing: usize) -> (&[f32], usize) {
    e.and_then(|e| paths.get(e.slot * n..(e.slot + 1) * n).map(|p| (p, e.start)))
        .unwrap_or((&[], missing))
}

/// Rows computed past a column's run by the last group of [`column_cells`] (at most
/// `LANES − 1`): the part values and the column buffer have this many cells more.
pub(super) const PAD: usize = 3;

/// Cells [`column_cells`] computes at once: four where the target has 128-bit float SIMD (the
/// group becomes one vector operation each), one otherwise (the Cortex-M4: no cell is computed
/// in vain).
pub(super) const LANES: usize = if cfg!(any(
    target_feature = "sse2",
    target_feature = "neon",
    target_feature = "simd128"
)) {
    4
} else {
    1
};

const _: () = assert!(LANES >= 1 && LANES - 1 <= PAD);

/// The state of one divide-and-conquer search.
struct Search<'a, const L: usize> {
    /// The part values and `PAD` cells more (0).
    pc: &'a [f32],
    /// The template twice over: `t2[k] = template[k mod m]` for `k < 2m`.
    t2: &'a [f32],
    /// The column buffer of [`sweep`], `n + 1 + PAD` cells.
    cols: &'a mut [f32],
    /// The band of the current DP: the first column of row `i` in cell `i`, the last in cell
    /// `n + i` (as the cells' bit patterns).
    band: &'a mut [f32],
    /// [`path_slots`]`(m)` path slots of `n` cells (`δ_i` as the cells' bit patterns): slot 0 for
    /// start 0, slot `1 + depth` for the middle start of the interval being split at that depth.
    paths: &'a mut [f32],
    /// Backtracking bits of the current start: `chunks` cells per column.
    bits: &'a mut [f32],
    /// The caller's correspondence (empty when not wanted).
    out: &'a mut [u16],
    n: usize,
    m: usize,
    w: usize,
    chunks: usize,
    /// The best total so far (initially the caller's bound).
    best: f32,
    best_start: Option<usize>,
    /// Cells visited (for the tests' work bounds).
    cells: usize,
}

/// Runs the divide-and-conquer search in `scratch`; `None` when `scratch` is too small (the
/// caller then runs the plain DP). `Some(None)`: nothing beats `bound`. When `out` has `n`
/// entries it receives the winning correspondence.
pub(super) fn search(
    part: &[f32],
    template: &[f32],
    bound: f32,
    scratch: &mut [f32],
    out: &mut [u16],
) -> Option<Option<Match>> {
    search_counted::<LANES>(part, template, bound, scratch, out).map(|(found, _)| found)
}

/// [`search`] with `L` lanes in [`column_cells`] ([`LANES`] outside the tests), also returning
/// the number of cells visited.
pub(super) fn search_counted<const L: usize>(
    part: &[f32],
    template: &[f32],
    bound: f32,
    scratch: &mut [f32],
    out: &mut [u16],
) -> Option<(Option<Match>, usize)> {
    let (n, m) = (part.len(), template.len());
    // Columns, paths and bands are kept in 32 bits (`pack`, `fill_band`): far beyond any
    // buffer a caller could hold, and the plain DP runs there.
    if n == 0 || m < n || m > 1 << 28 || L == 0 || L - 1 > PAD || scratch.len() < search_cells(n, m) {
        return None;
    }
    let w = m - n + 1;
    let chunks = w.div_ceil(BITS_PER_CELL);
    let slots = path_slots(m);
    let (t2, rest) = scratch.split_at_mut_checked(2 * m)?;
    let (pc, rest) = rest.split_at_mut_checked(n + PAD)?;
    let (cols, rest) = rest.split_at_mut_checked(n + 1 + PAD)?;
    let (band, rest) = rest.split_at_mut_checked(2 * n)?;
    let (paths, rest) = rest.split_at_mut_checked(slots * n)?;
    let bits = rest.get_mut(..(n + w - 1) * chunks + 3)?;
    let (values, pad) = pc.split_at_mut(n);
    values.copy_from_slice(part);
    pad.fill(0.0);
    let (first, second) = t2.split_at_mut(m);
    first.copy_from_slice(template);
    second.copy_from_slice(template);
    let mut st = Search::<L> {
        pc,
        t2,
        cols,
        band,
        paths,
        bits,
        out,
        n,
        m,
        w,
        chunks,
        best: bound,
        best_start: None,
        cells: 0,
    };
    st.run();
    let found = st.best_start.map(|start| Match {
        cost: st.best,
        normalized: st.best / n as f32,
        start,
    });
    Some((found, st.cells))
}

impl<const L: usize> Search<'_, L> {
    /// The whole search.
    fn run(&mut self) {
        let m = self.m;
        // Under a finite bound, first the relaxed DP of all starts: often none can beat it.
        if self.best < f32::INFINITY && self.relaxed(0, m - 1, None, None) >= self.best {
            return;
        }
        // Start 0 on whole rows: its path bounds every band, from below and (shifted by `m`, the
        // same start) from above.
        self.solve_start(0, None, None, Some(0), false);
        if m >= 2 {
            let lower = Edge { start: 0, slot: 0 };
            let upper = Edge { start: m, slot: 0 };
            self.solve(0, m, Some(lower), Some(upper), 0);
        }
    }

    /// Solves the starts strictly between `lo` and `hi` (`hi − lo ≥ 2`) inside the band of
    /// `lower` and `upper`.
    fn solve(&mut self, lo: usize, hi: usize, lower: Option<Edge>, upper: Option<Edge>, depth: usize) {
        let mid = lo + (hi - lo) / 2;
        let slot = depth + 1;
        // The middle start runs to the end (its path bounds the halves) unless it is alone.
        let alone = hi - lo <= 2;
        let keep = (!alone && slot * self.n < self.paths.len()).then_some(slot);
        let done = self.solve_start(mid, lower, upper, keep, alone);
        if alone {
            return;
        }
        // Without the path (no slot left: not reached for `m` of the sizes the docs give) the
        // halves keep the interval's own edges.
        let me = if done {
            keep.map(|slot| Edge { start: mid, slot })
        } else {
            None
        };
        // The halves `(lo, mid)` and `(mid, hi)`, the one with the lower bound first.
        let lb_left = self.interval_bound(lo, mid, lower, me.or(upper));
        let lb_right = self.interval_bound(mid, hi, me.or(lower), upper);
        let right_first = lb_right < lb_left;
        for right in [right_first, !right_first] {
            let (l, h, lb) = if right { (mid, hi, lb_right) } else { (lo, mid, lb_left) };
            if h - l >= 2 && lb < self.best {
                let (a, b) = if right {
                    (me.or(lower), upper)
                } else {
                    (lower, me.or(upper))
                };
                self.solve(l, h, a, b, depth + 1);
            }
        }
    }

    /// A lower bound on the optimum of every start in `(lo, hi)` ([`Self::relaxed`]); `+∞`
    /// without a start, `−∞` for a single start (solved directly) and for an interval of `w`
    /// or more starts: the relaxation lets a path reach that much further than any of its
    /// starts may, and as skipping template points is free, such a bound is far below every
    /// start's optimum (on the bench set's real descriptors it pruned under 1 % of the halves
    /// at the first depth, `n = 64`, `m = 96`) and costs more than it saves (6 % of a search's
    /// instructions).
    fn interval_bound(&mut self, lo: usize, hi: usize, lower: Option<Edge>, upper: Option<Edge>) -> f32 {
        match hi - lo {
            0 | 1 => f32::INFINITY,
            2 => f32::NEG_INFINITY,
            d if d > self.w => f32::NEG_INFINITY,
            _ => self.relaxed(lo + 1, hi - 1, lower, upper),
        }
    }

    /// The relaxed band DP of the starts `first ..= last`: a path may begin at any of them and
    /// end anywhere up to `d = last + w − 1`. Every start's optimal path in the band is one of
    /// these, so the result is a lower bound on their optima; `+∞` once its row minimum reaches
    /// the best so far (none of them can win).
    fn relaxed(&mut self, first: usize, last: usize, lower: Option<Edge>, upper: Option<Edge>) -> f32 {
        let (n, m, end) = (self.n, self.m, last + self.w - 1);
        // Row 0 holds every start; row `i ≥ 1` the band in `d` between the paths, clipped to
        // `[first, end]`.
        let (lower, upper) = (
            edge_path(self.paths, n, lower, 0),
            edge_path(self.paths, n, upper, 2 * m),
        );
        let (lo, hi) = (first as i32, end as i32);
        fill_band(self.band, lower, upper, (first, last), |i, dl, du| {
            let a = dl.max(lo);
            (i + a, i + du.min(hi).max(a))
        });
        let (pc, t2, best, cells) = (self.pc, self.t2, self.best, &mut self.cells);
        let (cols, band) = (&mut *self.cols, &*self.band);
        sweep::<false, false, L>(band, n, pc, t2, cols, &mut [], 0, 0, 0, best, cells).unwrap_or(f32::INFINITY)
    }

    /// Start `s`'s DP inside the band: records the path in slot `keep`, and the winner when it
    /// beats the best so far. Returns whether the path is in `keep`. With `abandon` the DP stops
    /// once its row minimum reaches the best so far.
    fn solve_start(
        &mut self,
        s: usize,
        lower: Option<Edge>,
        upper: Option<Edge>,
        keep: Option<usize>,
        abandon: bool,
    ) -> bool {
        let (n, m, chunks, top) = (self.n, self.m, self.chunks, self.w - 1);
        // Row 0 is the start's one cell; row `i ≥ 1` lies between the edges' rows, shifted to `s`
        // and clipped to `δ ∈ [0, top]`.
        let (lower, upper) = (
            edge_path(self.paths, n, lower, 0),
            edge_path(self.paths, n, upper, 2 * m),
        );
        let (si, ti) = (s as i32, top as i32);
        fill_band(self.band, lower, upper, (s, s), |i, dl, du| {
            // `max(0).min(ti)`, not `clamp`: clamp panics on crossed bounds.
            let low = (dl - si).max(0).min(ti);
            (si + i + low, si + i + (du - si).max(0).min(ti).max(low))
        });
        // The path is read back only to keep it or to report a winner: without either, no bits.
        let record = keep.is_some() || !self.out.is_empty();
        // A middle start runs to the end: no least value reaches NaN.
        let drop_at = if abandon { self.best } else { f32::NAN };
        let (pc, t2, cells) = (self.pc, self.t2, &mut self.cells);
        let (cols, band, bits) = (&mut *self.cols, &*self.band, &mut *self.bits);
        let total = if !record {
            sweep::<false, false, L>(band, n, pc, t2, cols, &mut [], 0, 0, 0, drop_at, cells)
        } else if chunks <= 64 / BITS_PER_CELL {
            sweep::<true, false, L>(band, n, pc, t2, cols, bits, chunks, s + top, s, drop_at, cells)
        } else {
            sweep::<true, true, L>(band, n, pc, t2, cols, bits, chunks, s + top, s, drop_at, cells)
        };
        let Some(total) = total else {
            return false;
        };
        let wins = total < self.best;
        if wins {
            self.best = total;
            self.best_start = Some(s);
        }
        let report = wins && !self.out.is_empty();
        if keep.is_none() && !report {
            return false;
        }
        let kept = match keep {
            Some(slot) => self.paths.get_mut(slot * n..(slot + 1) * n).unwrap_or_default(),
            None => &mut [],
        };
        let out: &mut [u16] = if report { &mut *self.out } else { &mut [] };
        read_path(self.band, n, self.bits, chunks, s + top, s, |i, k| {
            if let Some(c) = kept.get_mut(i) {
                *c = pack(k.wrapping_sub(s).wrapping_sub(i));
            }
            if let Some(o) = out.get_mut(i) {
                *o = k.checked_rem(m).unwrap_or(0) as u16;
            }
        });
        keep.is_some()
    }
}

/// Fills `band` (first columns in its first half, last columns in its second, as the cells'
/// bit patterns) for rows `1..n` from `rows(i, d_lower, d_upper)` with the edges' `d` of row
/// `i` (`δ = 0` for a missing edge's empty path), and row 0 with `row0`. In 32-bit integers
/// (every column is below `2^30`, see [`search_counted`]), so that the rows of two edges
/// become one loop of vector operations.
#[inline(always)]
fn fill_band(
    band: &mut [f32],
    lower: (&[f32], usize),
    upper: (&[f32], usize),
    row0: (usize, usize),
    rows: impl Fn(i32, i32, i32) -> (i32, i32),
) {
    let n = band.len() / 2;
    let (firsts, lasts) = band.split_at_mut(n);
    let ((lp, le), (up, ue)) = (lower, upper);
    let (le, ue) = (le as i32, ue as i32);
    let d = |e: i32, v: f32| e.wrapping_add(v.to_bits() as i32);
    let put = |c: &mut f32, v: i32| *c = f32::from_bits(v as u32);
    if lp.len() == n && up.len() == n {
        let cells = firsts.iter_mut().zip(lasts.iter_mut());
        for (i, ((f, l), (&dl, &du))) in cells.zip(lp.iter().zip(up)).enumerate() {
            let (a, b) = rows(i as i32, d(le, dl), d(ue, du));
            put(f, a);
            put(l, b);
        }
    } else {
        for (i, (f, l)) in firsts.iter_mut().zip(lasts.iter_mut()).enumerate() {
            let dl = lp.get(i).map_or(le, |&v| d(le, v));
            let du = up.get(i).map_or(ue, |&v| d(ue, v));
            let (a, b) = rows(i as i32, dl, du);
            put(f, a);
            put(l, b);
        }
    }
    if let (Some(f), Some(l)) = (firsts.first_mut(), lasts.first_mut()) {
        (*f, *l) = (pack(row0.0), pack(row0.1));
    }
}

/// One band DP over the columns `k` of the unrolled template `t2` (module docs): row `i` covers
/// the columns `first(i) ..= last(i)` of `band` (cells `i` and `n + i`, strictly increasing in
/// `i` as the bounding paths are), and its cell in column `k` is
/// `D_i(k) = |p_i − t2[k]| + Q_{i−1}(k − 1)`, with `Q_i(k)` the least `D_i` of its band up
/// to column `k` (`Q_{−1} = 0`: row 0 is free). Per column, `Q_i(k) = min(Q_i(k − 1), D_i(k))`
/// for the run of rows whose band holds `k` ([`column_cells`], `L` rows at a time). `p` is `pc`
/// (the part values, `PAD` cells more), `q` the column buffer (`n + 1 + PAD` cells).
///
/// Cell `i + 1` of `q` holds `Q_i`, cell 0 `Q_{−1}`. A row that has not begun holds `−∞`,
/// which no value undercuts, so the rows [`column_cells`] computes past a column's run (to fill
/// its last group) stay as they are and set no bits; a row is set to `+∞` as it begins, and
/// keeps its value once it has ended. Columns that meet no row are skipped; rows one column wide,
/// each alone in its column, go as a chain (module docs), their columns without records.
///
/// With `BITS`, column `k`'s record (`chunks` cells of `bits` from `(k − col0)·chunks`) holds
/// bit `i + base − k` for each row `i` whose `Q_i` strictly decreases at `k` (`WIDE`: records
/// of more than 64 bits); [`read_path`] backtracks through them. Returns the last row's least
/// value, or `None` once a row's least value reaches `best` (the row by row DP's test after
/// every row; row minima never decrease, so the same DPs are abandoned; `best = NaN`: never).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(super) fn sweep<const BITS: bool, const WIDE: bool, const L: usize>(
    band: &[f32],
    n: usize,
    pc: &[f32],
    t2: &[f32],
    q: &mut [f32],
    bits: &mut [f32],
    chunks: usize,
    base: usize,
    col0: usize,
    best: f32,
    cells: &mut usize,
) -> Option<f32> {
    let q = q.get_mut(..n + 1 + PAD)?;
    q.fill(f32::NEG_INFINITY);
    if let Some(c) = q.first_mut() {
        *c = 0.0;
    }
    let (firsts, lasts) = band.split_at(n.min(band.len()));
    let first = |i: usize| firsts.get(i).map_or(usize::MAX, |&v| unpack(v));
    let last = |i: usize| lasts.get(i).map_or(usize::MAX, |&v| unpack(v));
    let end = last(n - 1);
    // The template up to the last column (so that the loop's `k ≤ end` bounds every read).
    let t2 = t2.get(..=end)?;
    let mut k = first(0);
    // Rows `lo .. hi` are in the band of column `k`; row `hi` begins at column `enter`, row
    // `lo` ends at column `leave`. Column `k`'s record is at `bits[at..]`.
    let (mut lo, mut hi) = (0usize, 0usize);
    let mut enter = k;
    let mut leave = last(0);
    let mut at = k.wrapping_sub(col0).wrapping_mul(chunks);
    while k <= end {
        while enter <= k {
            if let Some(c) = q.get_mut(hi + 1) {
                *c = f32::INFINITY;
            }
            hi += 1;
            enter = first(hi);
        }
        while leave < k {
            if q.get(lo + 1).is_some_and(|&v| v >= best) {
                return None;
            }
            lo += 1;
            leave = last(lo);
        }
        // `lo ≤ hi`: a row that has ended has begun (its first column is not past its last).
        let active = hi.wrapping_sub(lo);
        if active == 1 && first(lo) == leave {
            // Rows one column wide, each alone in its column (the deep levels' narrow bands):
            // a chain, `Q_i = D_i = |p_i − t2[k_i]| + Q_{i−1}` (the cell against `+∞`, as in
            // `column_cells`) with the row below ended. Their columns need no record: a path's
            // row there can only lie in its band's one column, and no other row reads them.
            // Rows `lo ..` side by side (their first and last columns, part values and `Q`
            // cells), so that no row needs a bounds check of its own.
            let (Some((below, chain)), Some(fs), Some(ls), Some(ps)) = (
                q.get_mut(lo..).and_then(|c| c.split_first_mut()),
                firsts.get(lo..),
                lasts.get(lo..),
                pc.get(lo..),
            ) else {
                return None;
            };
            let mut below = *below;
            let mut r = lo;
            for (((&f, &l), &p), c) in fs.iter().zip(ls).zip(ps).zip(chain) {
                // Row `lo` is one column wide (tested above), a later row must be too.
                if r > lo && f.to_bits() != l.to_bits() {
                    break;
                }
                let d = match t2.get(unpack(f)) {
                    Some(&t) => (p - t).abs() + below,
                    None => f32::NAN,
                };
                let v = if d < f32::INFINITY { d } else { f32::INFINITY };
                *c = v;
                if cfg!(test) {
                    *cells += 1;
                }
                // Row `r` has ended.
                if v >= best {
                    return None;
                }
                below = v;
                r += 1;
            }
            (lo, hi) = (r, r);
            (enter, leave) = (first(r), last(r));
            k = enter;
            at = k.wrapping_sub(col0).wrapping_mul(chunks);
            continue;
        }
        if active == 0 {
            // No row meets this column: on to the next row's first.
            k = enter;
            at = k.wrapping_sub(col0).wrapping_mul(chunks);
            continue;
        }
        if cfg!(test) {
            *cells += active;
        }
        let t = t2.get(k).copied().unwrap_or(f32::NAN);
        // `div_ceil` tests the remainder apart, one more branch a column.
        #[allow(clippy::manual_div_ceil)]
        let groups = (active + L - 1) / L;
        if WIDE {
            // Runs of 64 rows, the top one first (a run reads the old value of the row below
            // it), each run's bits put in place in a cleared record.
            let col = bits.get_mut(at..at + chunks).unwrap_or_default();
            col.fill(pack(0));
            let per_run = 64 / L;
            let mut to = groups;
            while to > 0 {
                let from = (to - 1) / per_run * per_run;
                let mask = column_cells::<L>(q, pc, lo + from * L, to - from, t);
                or_bits(col, (lo + from * L + base).wrapping_sub(k), mask);
                to = from;
            }
        } else {
            // A column of one row (a third of them on the bench set) without the group's lanes.
            let mask = if L > 1 && active == 1 {
                column_cells::<1>(q, pc, lo, 1, t)
            } else {
                column_cells::<L>(q, pc, lo, groups, t)
            };
            if BITS {
                // Four cells whatever `chunks` is (at most 4 here): the cells past this
                // column's record are the next column's, written after it (or never read).
                let word = mask.wrapping_shl((lo + base).wrapping_sub(k) as u32);
                if let Some(dst) = bits.get_mut(at..at + 4).and_then(|c| <&mut [f32; 4]>::try_from(c).ok()) {
                    *dst = [0u32, 16, 32, 48].map(|s| pack(((word >> s) & 0xffff) as usize));
                }
            }
        }
        k += 1;
        at = at.wrapping_add(chunks);
    }
    let total = q.get(n).copied().unwrap_or(f32::INFINITY);
    if total >= best {
        return None;
    }
    Some(total)
}

/// One column in place: rows `from .. from + groups·L` of `q` (row `i` in cell `i + 1`), at
/// template value `t`, `L` rows at a time: `q[i + 1] = min(q[i + 1], |p_i − t| + q[i])`
/// with the comparison of the row by row DP (`q[i + 1]` kept unless the new value is strictly
/// below it, so a NaN value is ignored), `q[i]` the previous column's value (the row below's
/// old value is carried from one group to the next); bit `x` of the result is set where row
/// `from + x` took the new value (up to 64 rows).
#[inline(always)]
pub(super) fn column_cells<const L: usize>(q: &mut [f32], pc: &[f32], from: usize, groups: usize, t: f32) -> u64 {
    let span = groups * L;
    let (Some((first, cells)), Some(part)) = (
        q.get_mut(from..from + 1 + span).and_then(|s| s.split_first_mut()),
        pc.get(from..from + span),
    ) else {
        return 0;
    };
    let mut carry = *first;
    let mut mask = 0u64;
    let (mut shift, mut bit) = (0u32, 1u64);
    for (c, a) in cells.chunks_exact_mut(L).zip(part.chunks_exact(L)) {
        let (Ok(c), Ok(a)) = (<&mut [f32; L]>::try_from(c), <&[f32; L]>::try_from(a)) else {
            break;
        };
        let same = *c;
        let mut below = [carry; L];
        for (b, &v) in below.iter_mut().skip(1).zip(&same) {
            *b = v;
        }
        carry = same.last().copied().unwrap_or(carry);
        let mut out = [0.0f32; L];
        let mut lanes = 0u32;
        for (bit, (((o, &q), &p), &a)) in out.iter_mut().zip(&same).zip(&below).zip(a).enumerate() {
            let v = (a - t).abs() + p;
            let lower = v < q;
            *o = if lower { v } else { q };
            lanes |= (lower as u32) << bit;
        }
        *c = out;
        if L == 1 {
            // One lane: the bit moves on by a constant shift (a variable 64-bit shift is a
            // handful of instructions on a 32-bit core).
            mask |= bit & 0u64.wrapping_sub(u64::from(lanes));
            bit <<= 1;
        } else {
            mask |= u64::from(lanes).wrapping_shl(shift);
            shift = shift.wrapping_add(L as u32);
        }
        if L > 1 {
            // An empty barrier: the loop vectoriser leaves the loop alone (it would spread a
            // group over iterations, with strided loads), so each group stays one operation.
            core::hint::black_box(());
        }
    }
    mask
}

/// ORs `word` into the record `cells` (16 bits per cell) from bit `at` on.
#[inline]
fn or_bits(cells: &mut [f32], at: usize, word: u64) {
    let wide = u128::from(word) << (at % BITS_PER_CELL);
    for (t, c) in cells.iter_mut().skip(at / BITS_PER_CELL).take(5).enumerate() {
        let part = ((wide >> (BITS_PER_CELL * t)) & 0xffff) as usize;
        *c = pack(unpack(*c) | part);
    }
}

/// Backtracks the path of the last [`sweep`] with `BITS` over `band`: row `n − 1` ends at the
/// last column of its band where its least value strictly decreased (its first minimum), and
/// row `i − 1` at the last such column before row `i`'s and within its band (the first minimum
/// of `D_{i−1}` up to there), or at its band's first column when there is none. `emit(i, k)`
/// receives each row's column, last row first.
pub(super) fn read_path(
    band: &[f32],
    n: usize,
    bits: &[f32],
    chunks: usize,
    base: usize,
    col0: usize,
    mut emit: impl FnMut(usize, usize),
) {
    let (firsts, lasts) = band.split_at(n.min(band.len()));
    let mut k = usize::MAX;
    for (i, (&first, &last)) in firsts.iter().zip(lasts).enumerate().rev() {
        let (first, last) = (unpack(first), unpack(last));
        let mut x = k.wrapping_sub(1).min(last).max(first);
        // Bit `j = i + base − x` of column `x`'s record; one column back is one bit up.
        let mut j = (i + base).wrapping_sub(x);
        let mut at = x.wrapping_sub(col0).wrapping_mul(chunks);
        while x > first {
            let set = bits
                .get(at.wrapping_add(j / BITS_PER_CELL))
                .is_some_and(|&c| (unpack(c) >> (j % BITS_PER_CELL)) & 1 != 0);
            if set {
                break;
            }
            x -= 1;
            j = j.wrapping_add(1);
            at = at.wrapping_sub(chunks);
        }
        k = x;
        emit(i, k);
    }
}
