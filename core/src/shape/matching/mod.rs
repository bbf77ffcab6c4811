//! Cyclic order-preserving matching by dynamic programming (paper eqs. 4.4–4.9, 5.1).
//!
//! Part point `i` (of `n`) is matched to template point `j(i)` (of `m`, `n ≤ m < 2n`) with cost
//! `c_ij = |c_i − c'_j|` (eq. 4.4); every part point is matched once (4.8), no template point
//! twice (4.9), and the cyclic order is kept: for a start `s`,
//! `j(i) = (s + i + δ_i) mod m` with `0 = δ_0 ≤ δ_1 ≤ … ≤ δ_{n−1} ≤ m − n`. Contours have no
//! natural first point, so the optimum is taken over **every** start `s` (DESIGN.md).
//!
//! # One start
//!
//! For one start the recurrence is `D_i(δ) = c(i, s+i+δ) + min_{δ' ≤ δ} D_{i−1}(δ')`, one row of
//! `w = m − n + 1` cells updated in place with a running minimum: `O(n·w)` per start and
//! `O(m·n·w)` for all starts, the paper's cubic bound.
//!
//! # All starts: divide and conquer over the starts (Maes 1990)
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
//! # Across templates
//!
//! [`sorted_lower_bound`] bounds a template's optimum from the descriptor values alone (the
//! cheapest one-to-one map of sorted values, one `n·w` DP over no starts), so a library can be
//! searched best bound first and cut off exactly; [`match_at_start`] reads one start's
//! correspondence (e.g. the winner's from [`best_cost`]) in `n·w` cells instead of a second
//! search.
//!
//! # Memory
//!
//! Everything lives in the caller's `f32` buffer: [`search_cells`]`(n, m)` cells (the template
//! twice, `2m`, the part values and the column buffer, `n + 3` and `n + 4`, the band of a DP,
//! `2n`, `max(1, ⌈log2 m⌉)` paths of `n` cells — start 0's and one per depth that splits an
//! interval — and `(n + w − 1)·⌈w/16⌉ + 3` bit cells), which is at most
//! [`table_cells`]`(n, m) = n·w` once `m − n` exceeds about `⌈log2 m⌉ + 7` (every
//! `m ≥ n + 14` for `n = 64`). With fewer cells (at
//! least `w`) the plain per-start DP with row-minimum pruning runs instead, cheap for such
//! narrow rows, and [`match_with_assignment`] then refills the table for the winning start to
//! backtrack; the optimum is the same either way (up to the rounding above). The recursion is
//! `⌈log2 m⌉` calls deep (about 130 bytes of stack each on a Cortex-M4).

use crate::borders::resample::check_counts;
use crate::error::{Error, Result};

/// Cells of the backtracking table for `n` part and `m` template points: `n·(m − n + 1)`
/// (`usize::MAX` where that overflows: no buffer holds it).
pub const fn table_cells(n: usize, m: usize) -> usize {
    if m < n {
        0
    } else {
        n.saturating_mul((m - n).saturating_add(1))
    }
}

/// Bits of the backtracking record kept in one `f32` cell (stored as the cell's bit pattern).
const BITS_PER_CELL: usize = 16;

/// A small integer (a path's `δ` or a word of backtracking bits) kept in an `f32` cell of the
/// caller's buffer as the cell's bit pattern: no conversion on either side. Such a pattern is a
/// subnormal float, so these cells are only ever stored and copied, never computed with
/// (arithmetic under flush-to-zero would lose them).
#[inline(always)]
fn pack(v: usize) -> f32 {
    f32::from_bits(v as u32)
}

/// The integer [`pack`] stored.
#[inline(always)]
fn unpack(v: f32) -> usize {
    v.to_bits() as usize
}

/// `⌈log2 m⌉` (0 for `m ≤ 1`).
const fn ceil_log2(m: usize) -> usize {
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
/// [`best_cost`] and [`match_with_assignment`] use the search whenever their buffer holds this
/// many cells; it is at most [`table_cells`]`(n, m)` unless `m − n` is small (then the plain
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

/// The optimal cyclic match.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// `f_min`, the minimal total cost (eq. 4.6).
    pub cost: f32,
    /// `f' = f_min / n` (eq. 5.1).
    pub normalized: f32,
    /// The winning start offset `s`.
    pub start: usize,
}

/// The minimal cost over all starts, or `None` when no start beats `bound` (exclusive).
///
/// `row` needs `m − n + 1` cells; with [`search_cells`]`(n, m)` cells (at most
/// [`table_cells`]`(n, m)` for all but nearly equal `n` and `m`) the faster divide-and-conquer
/// search is used. Use [`match_with_assignment`] for the correspondence.
///
/// # Errors
/// [`Error::PointCounts`] when `n ≤ m < 2n` fails, [`Error::BufferTooSmall`] for `row`.
pub fn best_cost(part: &[f32], template: &[f32], bound: f32, row: &mut [f32]) -> Result<Option<Match>> {
    let (n, m) = (part.len(), template.len());
    check_counts(n, m)?;
    let width = m - n + 1;
    if row.len() < width {
        return Err(Error::BufferTooSmall {
            needed: width,
            got: row.len(),
        });
    }
    if let Some(found) = search(part, template, bound, row, &mut []) {
        return Ok(found);
    }
    Ok(plain_best_cost(part, template, bound, row))
}

/// A lower bound on [`best_cost`] from the descriptor values alone, or `None` when it is not
/// below `bound` (then no start can beat `bound`).
///
/// `part` and `template` hold the same values as for [`best_cost`] but sorted ascending. Every
/// cyclic order-preserving match is a one-to-one map of the part's values into the template's;
/// the cheapest one-to-one map under `|c − c'|` pairs the sorted values in order (an exchange of
/// two crossing pairs never costs more), so one DP over the sorted values, with the same band
/// of `m − n + 1` cells and no start to try, gives a total no match can undercut: `O(n·(m−n+1))`
/// instead of a search over all starts. Used to order a library and to skip templates that
/// cannot enter the best few.
///
/// `row` needs `m − n + 1` cells; with at least `2·(n + 1)` the DP runs column by column
/// (`sorted_columns`, which the compiler vectorises), else row by row. Both perform the
/// same additions on the same values and give the same bits.
///
/// ```
/// use vorl_core::shape::matching::{best_cost, sorted_lower_bound};
/// let template = [0.0f32, 3.0, 1.0, 4.0, 2.0, 5.0];
/// let part = [5.0f32, 0.5, 3.0, 1.0];
/// let (mut ts, mut ps) = (template, part);
/// ts.sort_by(f32::total_cmp);
/// ps.sort_by(f32::total_cmp);
/// let mut row = [0.0f32; 3];
/// let bound = sorted_lower_bound(&ps, &ts, f32::INFINITY, &mut row).unwrap().unwrap();
/// let exact = best_cost(&part, &template, f32::INFINITY, &mut row).unwrap().unwrap();
/// assert!(bound <= exact.cost);
/// ```
///
/// # Errors
/// [`Error::PointCounts`] when `n ≤ m < 2n` fails, [`Error::BufferTooSmall`] for `row`.
pub fn sorted_lower_bound(part: &[f32], template: &[f32], bound: f32, row: &mut [f32]) -> Result<Option<f32>> {
    let (n, m) = (part.len(), template.len());
    check_counts(n, m)?;
    let width = m - n + 1;
    if let Some(columns) = row.get_mut(..2 * (n + 1)) {
        return Ok(sorted_columns(part, template, bound, columns));
    }
    let Some(row) = row.get_mut(..width) else {
        return Err(Error::BufferTooSmall {
            needed: width,
            got: row.len(),
        });
    };
    // Row i holds part value i matched to template value i + δ, δ < width (never past m − 1);
    // unlike a start's DP, the first row is free too.
    let Some((&first, rest)) = part.split_first() else {
        return Ok(None);
    };
    for (cell, &t) in row.iter_mut().zip(template) {
        *cell = (first - t).abs();
    }
    for (i, &ci) in rest.iter().enumerate() {
        if dp_row(row, template, i + 1, ci) >= bound {
            return Ok(None);
        }
    }
    Ok(row.iter().copied().reduce(f32::min).filter(|&total| total < bound))
}

/// [`sorted_lower_bound`]'s DP column by column, in `buf` of `2·(n + 1)` cells (`n ≤ m`
/// checked by the caller).
///
/// With `Q_i(j)` the least `D_i` over template positions up to `j` (row `i` covers positions
/// `i ..= i + w − 1`), the row recurrence `D_i(j) = |a_i − b_j| + Q_{i−1}(j − 1)` becomes, per
/// template position `j`, `Q_i(j) = min(Q_i(j − 1), |a_i − b_j| + Q_{i−1}(j − 1))` for the at
/// most `w` rows that cover `j`: every cell of a column depends only on the previous column, so
/// a column is one loop without a carried dependency (four or eight cells per instruction on
/// the host), where a row's running minimum is a chain. The values and the additions are the
/// row version's, so are the results. Two buffers of `n + 1` cells take turns as the previous
/// and the new column; cell 0 is row −1 (0: the first row is free), cell `i + 1` row `i`.
fn sorted_columns(part: &[f32], template: &[f32], bound: f32, buf: &mut [f32]) -> Option<f32> {
    let n = part.len();
    let w = (template.len() + 1).checked_sub(n)?;
    buf.fill(f32::INFINITY);
    let (even, odd) = buf.split_at_mut(n + 1);
    for half in [&mut *even, &mut *odd] {
        if let Some(c) = half.first_mut() {
            *c = 0.0;
        }
    }
    for (j, &b) in template.iter().enumerate() {
        let (prev, next) = if j % 2 == 0 {
            (&*odd, &mut *even)
        } else {
            (&*even, &mut *odd)
        };
        // Rows lo ..= hi cover position j.
        let lo = (j + 1).saturating_sub(w);
        let hi = j.min(n - 1);
        let len = hi + 1 - lo;
        let (Some(dst), Some(same), Some(below), Some(a)) = (
            next.get_mut(lo + 1..).and_then(|r| r.get_mut(..len)),
            prev.get(lo + 1..).and_then(|r| r.get(..len)),
            prev.get(lo..).and_then(|r| r.get(..len)),
            part.get(lo..).and_then(|r| r.get(..len)),
        ) else {
            return None;
        };
        for k in 0..len {
            if let (Some(d), Some(&q), Some(&p), Some(&ai)) = (dst.get_mut(k), same.get(k), below.get(k), a.get(k)) {
                let v = (ai - b).abs() + p;
                *d = if v < q { v } else { q };
            }
        }
        // Row `lo` ends at position j; its least value is a lower bound on every later row's.
        if j + 1 >= w && next.get(lo + 1).is_none_or(|&q| q >= bound) {
            return None;
        }
    }
    let (even, odd) = buf.split_at(n + 1);
    let last = if template.len() % 2 == 1 { even } else { odd };
    last.get(n).copied().filter(|&total| total < bound)
}

/// A cheaper, looser lower bound than [`sorted_lower_bound`], on the same sorted values, in
/// `O(n)`: in the sorted DP, part value `i` is matched to a template value of rank `i ..= i +
/// m − n`, which lies between the sorted template's values `b_i` and `b_{i+m−n}`, so it costs
/// at least the distance from `a_i` to that interval. The sum of these distances never
/// exceeds [`sorted_lower_bound`], in `f32` too (each term is at most the DP's term of its
/// row, rounding is monotone, and both add the rows in order). Zero when each part value lies
/// within its interval; it rules out the templates whose value distribution is far from the
/// part's without their `n·(m − n + 1)` DP. `None` when `n ≤ m < 2n` fails.
///
/// ```
/// use vorl_core::shape::matching::{sorted_lower_bound, sorted_window_bound};
/// let part = [0.5f32, 1.0, 3.0, 5.0];
/// let template = [0.0f32, 1.0, 2.0, 3.0, 4.0, 4.0];
/// let window = sorted_window_bound(&part, &template).unwrap();
/// let dp = sorted_lower_bound(&part, &template, f32::INFINITY, &mut [0.0; 10]).unwrap().unwrap();
/// assert!(window <= dp);
/// assert_eq!(window, 1.0); // 5 lies 1 above its interval [3, 4]
/// ```
pub fn sorted_window_bound(part: &[f32], template: &[f32]) -> Option<f32> {
    let (n, m) = (part.len(), template.len());
    check_counts(n, m).ok()?;
    let w = m + 1 - n;
    let (Some(low), Some(high)) = (template.get(..n), template.get(w - 1..w - 1 + n)) else {
        return None;
    };
    let mut total = 0.0f32;
    for ((&a, &lo), &hi) in part.iter().zip(low).zip(high) {
        let below = if lo > a { lo - a } else { 0.0 };
        let above = if a > hi { a - hi } else { 0.0 };
        total += below + above;
    }
    Some(total)
}

/// The correspondence of one start (e.g. [`Match::start`] from [`best_cost`]): fills
/// `assignment` and returns that start's cost, in `O(n·(m−n+1))` with the full table of
/// [`table_cells`]`(n, m)` cells.
///
/// ```
/// use vorl_core::shape::matching::{best_cost, match_at_start};
/// let template = [0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0];
/// let part = [2.0f32, 3.0, 5.0, 0.0];
/// let mut table = [0.0f32; 12];
/// let best = best_cost(&part, &template, f32::INFINITY, &mut table).unwrap().unwrap();
/// let mut assignment = [0u16; 4];
/// let m = match_at_start(&part, &template, best.start, &mut table, &mut assignment).unwrap();
/// assert_eq!((m.cost, assignment), (0.0, [2, 3, 5, 0]));
/// ```
///
/// # Errors
/// [`Error::PointCounts`], [`Error::BufferTooSmall`] for `table` or `assignment`,
/// [`Error::Parameter`] for a start not below `m`, and [`Error::DegenerateContour`] when the
/// cost is not finite.
pub fn match_at_start(
    part: &[f32],
    template: &[f32],
    start: usize,
    table: &mut [f32],
    assignment: &mut [u16],
) -> Result<Match> {
    let (n, m) = (part.len(), template.len());
    check_counts(n, m)?;
    if start >= m {
        return Err(Error::Parameter {
            name: "start",
            value: start as f32,
        });
    }
    let width = m - n + 1;
    let cells = table_cells(n, m);
    let Some(table) = table.get_mut(..cells) else {
        return Err(Error::BufferTooSmall {
            needed: cells,
            got: table.len(),
        });
    };
    let Some(assignment) = assignment.get_mut(..n) else {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: assignment.len(),
        });
    };
    fill_table(part, template, start, table, width);
    let cost = table
        .get((n - 1) * width..)
        .and_then(|r| r.iter().copied().reduce(f32::min))
        .filter(|c| c.is_finite())
        .ok_or(Error::DegenerateContour { points: n })?;
    backtrack(table, width, n, m, start, assignment);
    Ok(Match {
        cost,
        normalized: cost / n as f32,
        start,
    })
}

/// The plain search: every start in turn on one row of `m − n + 1` cells, with row-minimum
/// pruning.
fn plain_best_cost(part: &[f32], template: &[f32], bound: f32, row: &mut [f32]) -> Option<Match> {
    let n = part.len();
    let width = (template.len() + 1).saturating_sub(n);
    let row = row.get_mut(..width)?;
    let mut best = bound;
    let mut best_start = None;
    for s in 0..template.len() {
        if let Some(total) = run_start(part, template, s, best, row) {
            if total < best {
                best = total;
                best_start = Some(s);
            }
        }
    }
    best_start.map(|start| Match {
        cost: best,
        normalized: best / n as f32,
        start,
    })
}

/// One start's DP with a single row; `None` when pruned by `bound`.
#[inline]
fn run_start(part: &[f32], template: &[f32], s: usize, bound: f32, row: &mut [f32]) -> Option<f32> {
    let m = template.len();
    let mut first = true;
    for (i, &ci) in part.iter().enumerate() {
        let j0 = (s + i) % m;
        if first {
            let c0 = template.get(j0).map_or(f32::INFINITY, |&t| (ci - t).abs());
            for (d, cell) in row.iter_mut().enumerate() {
                *cell = if d == 0 { c0 } else { f32::INFINITY };
            }
            first = false;
            if c0 >= bound {
                return None;
            }
            continue;
        }
        let row_min = dp_row(row, template, j0, ci);
        if row_min >= bound {
            return None;
        }
    }
    row.iter().copied().reduce(f32::min)
}

/// In-place row update `D(δ) = |ci − t[j0+δ]| + min_{δ'≤δ} D_prev(δ')`; returns the new row's
/// minimum. The template index wraps at most once.
#[inline]
fn dp_row(row: &mut [f32], template: &[f32], j0: usize, ci: f32) -> f32 {
    let (tail, head) = template.split_at(j0.min(template.len()));
    if head.len() >= row.len() {
        // No wrap: one slice, a tighter loop.
        return dp_cells(row, head, f32::INFINITY, ci).1;
    }
    let (first, second) = row.split_at_mut(head.len());
    let (running, min_first) = dp_cells(first, head, f32::INFINITY, ci);
    let (_, min_second) = dp_cells(second, tail, running, ci);
    lesser(min_first, min_second)
}

/// [`dp_row`] over cells whose template values are one slice, the running minimum of the
/// previous row starting at `running`; returns the running minimum and the new cells' minimum.
#[inline(always)]
fn dp_cells(row: &mut [f32], template: &[f32], running: f32, ci: f32) -> (f32, f32) {
    let len = row.len().min(template.len());
    let (Some(row), Some(template)) = (row.get_mut(..len), template.get(..len)) else {
        return (running, f32::INFINITY);
    };
    let mut cell = Cell {
        running,
        row_min: f32::INFINITY,
        ci,
    };
    cell.update_run(row, template);
    (cell.running, cell.row_min)
}

/// `min(acc, v)` for an accumulator that is never NaN, in one comparison (a NaN `v` is ignored,
/// as by `f32::min`, which costs a NaN test in the loop-carried chain).
#[inline(always)]
fn lesser(acc: f32, v: f32) -> f32 {
    if v < acc {
        v
    } else {
        acc
    }
}

/// The optimal match and its correspondence: `assignment[i] = j(i)` for every part point.
///
/// `table` needs [`table_cells`]`(n, m)` cells and `assignment` `n` entries. With at least
/// [`search_cells`]`(n, m)` cells (fewer than `table_cells` for all but nearly equal `n` and
/// `m`) the divide-and-conquer search runs and reads the correspondence from its own record;
/// otherwise the plain DP runs and the table is refilled for the winning start.
///
/// ```
/// use vorl_core::shape::matching::{match_with_assignment, table_cells};
/// let template = [0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0];
/// let part = [2.0f32, 3.0, 5.0, 0.0]; // starts at template point 2, skips point 4 and 1
/// let mut table = [0.0f32; 12];
/// assert_eq!(table_cells(4, 6), 12);
/// let mut assignment = [0u16; 4];
/// let m = match_with_assignment(&part, &template, &mut table, &mut assignment).unwrap();
/// assert_eq!(m.cost, 0.0);
/// assert_eq!(assignment, [2, 3, 5, 0]);
/// ```
///
/// # Errors
/// [`Error::PointCounts`], [`Error::BufferTooSmall`] for `table` or `assignment`, and
/// [`Error::DegenerateContour`] when the costs are not finite (NaN descriptors).
pub fn match_with_assignment(
    part: &[f32],
    template: &[f32],
    table: &mut [f32],
    assignment: &mut [u16],
) -> Result<Match> {
    best_match(part, template, f32::INFINITY, table, assignment)?.ok_or(Error::DegenerateContour { points: part.len() })
}

/// [`best_cost`] with the winner's correspondence: `assignment[i] = j(i)` for every part point
/// when some start beats `bound` (exclusive); `Ok(None)` otherwise (then `assignment` is
/// unspecified). The search reads the correspondence back from its own record, so this costs
/// little more than [`best_cost`] and saves the [`match_at_start`] a caller would run after
/// it. `table` needs [`table_cells`]`(n, m)` cells (as [`match_with_assignment`]).
///
/// ```
/// use vorl_core::shape::matching::{best_cost, best_match, table_cells};
/// let template = [0.0f32, 1.0, 2.0, 3.0, 4.0, 5.0];
/// let part = [2.0f32, 3.0, 5.0, 0.0];
/// let mut table = [0.0f32; 12];
/// let mut assignment = [0u16; 4];
/// let m = best_match(&part, &template, f32::INFINITY, &mut table, &mut assignment).unwrap().unwrap();
/// assert_eq!((m.cost, m.start, assignment), (0.0, 2, [2, 3, 5, 0]));
/// // Nothing beats a bound of 0.
/// assert!(best_match(&part, &template, 0.0, &mut table, &mut assignment).unwrap().is_none());
/// ```
///
/// # Errors
/// [`Error::PointCounts`] and [`Error::BufferTooSmall`] for `table` or `assignment`.
pub fn best_match(
    part: &[f32],
    template: &[f32],
    bound: f32,
    table: &mut [f32],
    assignment: &mut [u16],
) -> Result<Option<Match>> {
    let (n, m) = (part.len(), template.len());
    check_counts(n, m)?;
    let width = m - n + 1;
    let cells = table_cells(n, m);
    if table.len() < cells {
        return Err(Error::BufferTooSmall {
            needed: cells,
            got: table.len(),
        });
    }
    let Some(assignment) = assignment.get_mut(..n) else {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: assignment.len(),
        });
    };
    let best = match search(part, template, bound, table, assignment) {
        Some(found) => found,
        None => {
            let best = plain_best_cost(part, template, bound, table);
            if let (Some(b), Some(table)) = (best, table.get_mut(..cells)) {
                fill_table(part, template, b.start, table, width);
                backtrack(table, width, n, m, b.start, assignment);
            }
            best
        }
    };
    Ok(best)
}

/// Sorts `values` ascending in [`f32::total_cmp`]'s order: the same result as
/// `values.sort_unstable_by(f32::total_cmp)` (values equal in that order are the same bits, so
/// any correct sort gives the same slice), by insertion, which cannot panic. The standard sort
/// keeps a panic for comparators that are not a total order (`panic_on_ord_violation`), which
/// the optimiser cannot remove even for `total_cmp`; descriptors are sorted once per part or
/// template (n, m ≤ a few hundred values), where insertion costs about what it does.
pub(crate) fn sort_total(values: &mut [f32]) {
    // `total_cmp`'s key: the bits as `i32`, the magnitude bits flipped for negative values.
    let key = |v: f32| {
        let b = v.to_bits() as i32;
        b ^ (((b >> 31) as u32) >> 1) as i32
    };
    for i in 1..values.len() {
        let Some(&x) = values.get(i) else { break };
        let kx = key(x);
        let mut j = i;
        while let Some(&p) = j.checked_sub(1).and_then(|k| values.get(k)) {
            if key(p) <= kx {
                break;
            }
            if let Some(c) = values.get_mut(j) {
                *c = p;
            }
            j -= 1;
        }
        if let Some(c) = values.get_mut(j) {
            *c = x;
        }
    }
}

/// The full table of one start: row `i` holds `D_i(δ)`.
fn fill_table(part: &[f32], template: &[f32], s: usize, table: &mut [f32], width: usize) {
    let m = template.len();
    let mut rows = table.chunks_exact_mut(width.max(1));
    let Some(first) = rows.next() else { return };
    let c0 = part
        .first()
        .zip(template.get(s % m))
        .map_or(f32::INFINITY, |(&a, &b)| (a - b).abs());
    for (d, cell) in first.iter_mut().enumerate() {
        *cell = if d == 0 { c0 } else { f32::INFINITY };
    }
    let mut prev: &[f32] = first;
    for (i, row) in rows.enumerate() {
        let i = i + 1;
        let ci = part.get(i).copied().unwrap_or(0.0);
        row.copy_from_slice(prev);
        dp_row(row, template, (s + i) % m, ci);
        prev = row;
    }
}

/// Reads the correspondence back from the table of the winning start.
fn backtrack(table: &[f32], width: usize, n: usize, m: usize, s: usize, assignment: &mut [u16]) {
    let row = |i: usize| table.get(i * width..(i + 1) * width).unwrap_or(&[]);
    let argmin_upto = |r: &[f32], limit: usize| -> usize {
        let mut best = 0;
        let mut best_v = f32::INFINITY;
        for (d, &v) in r.iter().enumerate().take(limit + 1) {
            if v < best_v {
                best_v = v;
                best = d;
            }
        }
        best
    };
    let mut delta = argmin_upto(row(n - 1), width - 1);
    for i in (0..n).rev() {
        if i < n - 1 {
            delta = argmin_upto(row(i), delta);
        }
        if let Some(a) = assignment.get_mut(i) {
            *a = ((s + i + delta) % m) as u16;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Divide and conquer over the starts.
// ---------------------------------------------------------------------------------------------

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
const PAD: usize = 3;

/// Cells [`column_cells`] computes at once: four where the target has 128-bit float SIMD (the
/// group becomes one vector operation each), one otherwise (the Cortex-M4: no cell is computed
/// in vain).
const LANES: usize = if cfg!(any(
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
fn search(part: &[f32], template: &[f32], bound: f32, scratch: &mut [f32], out: &mut [u16]) -> Option<Option<Match>> {
    search_counted::<LANES>(part, template, bound, scratch, out).map(|(found, _)| found)
}

/// [`search`] with `L` lanes in [`column_cells`] ([`LANES`] outside the tests), also returning
/// the number of cells visited.
fn search_counted<const L: usize>(
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
fn sweep<const BITS: bool, const WIDE: bool, const L: usize>(
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
        let active = hi.saturating_sub(lo);
        if active == 1 && first(lo) == leave {
            // Rows one column wide, each alone in its column (the deep levels' narrow bands):
            // a chain, `Q_i = D_i = |p_i − t2[k_i]| + Q_{i−1}` (the cell against `+∞`, as in
            // `column_cells`) with the row below ended. Their columns need no record: a path's
            // row there can only lie in its band's one column, and no other row reads them.
            let mut below = q.get(lo).copied().unwrap_or(f32::NAN);
            let mut r = lo;
            loop {
                let kr = first(r);
                let d = match (pc.get(r), t2.get(kr)) {
                    (Some(&p), Some(&t)) => (p - t).abs() + below,
                    _ => f32::NAN,
                };
                let v = if d < f32::INFINITY { d } else { f32::INFINITY };
                if let Some(c) = q.get_mut(r + 1) {
                    *c = v;
                }
                if cfg!(test) {
                    *cells += 1;
                }
                // Row `r` has ended.
                if v >= best {
                    return None;
                }
                below = v;
                r += 1;
                if r >= n || first(r) != last(r) {
                    break;
                }
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
fn column_cells<const L: usize>(q: &mut [f32], pc: &[f32], from: usize, groups: usize, t: f32) -> u64 {
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
fn read_path(
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

/// The state of [`dp_cells`] along a row.
struct Cell {
    /// The running minimum of the previous row.
    running: f32,
    /// The minimum of the new cells.
    row_min: f32,
    /// The part value of the row.
    ci: f32,
}

impl Cell {
    /// `c` holds the previous row's value and receives the new one.
    #[inline(always)]
    fn update(&mut self, c: &mut f32, t: f32) {
        let p = *c;
        self.running = if p < self.running { p } else { self.running };
        let v = (self.ci - t).abs() + self.running;
        *c = v;
        self.row_min = lesser(self.row_min, v);
    }

    /// [`Self::update`] over cells and their template values (slices of one length), two a loop
    /// turn: fewer register moves and loop tests than one at a time, the same operations in the
    /// same order.
    #[inline(always)]
    fn update_run(&mut self, cells: &mut [f32], ts: &[f32]) {
        let mut pairs = cells.chunks_exact_mut(2);
        let mut t_pairs = ts.chunks_exact(2);
        for (c, tv) in (&mut pairs).zip(&mut t_pairs) {
            if let ([c0, c1], [t0, t1]) = (c, tv) {
                self.update(c0, *t0);
                self.update(c1, *t1);
            }
        }
        for (c, &tv) in pairs.into_remainder().iter_mut().zip(t_pairs.remainder()) {
            self.update(c, tv);
        }
    }
}

#[cfg(test)]
mod spec;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::descriptor::{describe, scaled_k, DescriptorParams};
    use crate::test_support::{descriptors, outline, sample};
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn sort_total_is_the_standard_sort_by_total_cmp() {
        let mut rng = crate::test_rng::XorShift(0x5eed_f0f5_5027);
        let special = [
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            1e-45,
            f32::MAX,
            1.5,
        ];
        for len in 0..80 {
            for _ in 0..20 {
                let v: Vec<f32> = (0..len)
                    .map(|_| match rng.below(4) {
                        0 => special[rng.below(special.len())],
                        1 => (rng.below(5) as f32) - 2.0,
                        _ => f32::from_bits(rng.next() as u32),
                    })
                    .collect();
                let (mut ours, mut std_sorted) = (v.clone(), v);
                sort_total(&mut ours);
                std_sorted.sort_unstable_by(f32::total_cmp);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&ours), bits(&std_sorted));
            }
        }
    }

    /// The straightforward DP: every start on its whole row, no pruning.
    fn reference(part: &[f32], template: &[f32]) -> f32 {
        let (n, m) = (part.len(), template.len());
        let w = m - n + 1;
        let mut best = f32::INFINITY;
        for s in 0..m {
            let mut row = vec![f32::INFINITY; w];
            row[0] = (part[0] - template[s]).abs();
            for i in 1..n {
                let mut running = f32::INFINITY;
                for d in 0..w {
                    running = running.min(row[d]);
                    row[d] = (part[i] - template[(s + i + d) % m]).abs() + running;
                }
            }
            best = best.min(row.iter().copied().fold(f32::INFINITY, f32::min));
        }
        best
    }

    use crate::test_rng::XorShift as Rng;

    /// Kinds of input: continuous values, a coarse grid (many ties, exact sums), constants.
    fn values(rng: &mut Rng, count: usize, kind: u64) -> Vec<f32> {
        (0..count)
            .map(|_| match kind {
                0 => (rng.next() % 1_000_000) as f32 / 250_000.0,
                1 => (rng.next() % 4) as f32 * 0.5,
                _ => 1.25,
            })
            .collect()
    }

    /// The assignment is cyclic order-preserving, injective, and costs `cost` exactly.
    fn check_assignment(part: &[f32], template: &[f32], asg: &[u16], cost: f32) {
        let m = template.len();
        let j0 = asg[0] as usize;
        let offs: Vec<usize> = asg.iter().map(|&j| (j as usize + m - j0) % m).collect();
        assert!(offs.windows(2).all(|w| w[0] < w[1]), "order: {asg:?}");
        let total = part
            .iter()
            .zip(asg)
            .fold(0.0f32, |acc, (p, &j)| acc + (p - template[j as usize]).abs());
        assert_eq!(total, cost, "assignment cost");
    }

    fn compare(part: &[f32], template: &[f32], exact: bool) {
        let (n, m) = (part.len(), template.len());
        let want = reference(part, template);
        let close = |got: f32| {
            if exact {
                got == want
            } else {
                (got - want).abs() <= 1e-5 * want.max(1.0)
            }
        };
        // The search on a large buffer, the plain DP on a row, and the table of the callers.
        let mut big = vec![0.0f32; search_cells(n, m).max(table_cells(n, m))];
        let fast = search(part, template, f32::INFINITY, &mut big, &mut [])
            .unwrap()
            .unwrap();
        assert_eq!(best_cost(part, template, f32::INFINITY, &mut big).unwrap(), Some(fast));
        assert!(close(fast.cost), "n {n} m {m}: search {} reference {want}", fast.cost);
        let mut row = vec![0.0f32; m - n + 1];
        let plain = best_cost(part, template, f32::INFINITY, &mut row).unwrap().unwrap();
        assert!(close(plain.cost), "n {n} m {m}: plain {} reference {want}", plain.cost);
        for buffer in [table_cells(n, m), big.len()] {
            let mut table = vec![0.0f32; buffer];
            let mut asg = vec![0u16; n];
            let got = match_with_assignment(part, template, &mut table, &mut asg).unwrap();
            assert!(close(got.cost), "n {n} m {m}: match {} reference {want}", got.cost);
            assert_eq!(got.normalized, got.cost / n as f32);
            check_assignment(part, template, &asg, got.cost);
            assert_eq!(asg[0] as usize, got.start);
        }
        // Bounds: exact pruning of the search.
        for bound in [want * 0.5, want, want * 1.5 + 0.1] {
            let bounded = best_cost(part, template, bound, &mut big).unwrap();
            if fast.cost < bound {
                assert_eq!(bounded.map(|b| b.cost), Some(fast.cost));
            } else {
                assert!(bounded.is_none(), "n {n} m {m} bound {bound}: {bounded:?}");
            }
        }
    }

    #[test]
    fn search_fits_the_table_for_usual_sizes() {
        for (n, m) in [(32, 48), (64, 96), (76, 133), (128, 192), (256, 384), (64, 127)] {
            assert!(search_cells(n, m) <= table_cells(n, m), "{n} × {m}");
        }
    }

    #[test]
    fn window_bound_never_exceeds_the_sorted_bound() {
        let mut rng = Rng(0x77AA_1234_DEAD_0042);
        let (mut positive, mut equal) = (0, 0);
        for n in 1..=70usize {
            for _ in 0..6 {
                let m = n + rng.next() as usize % n;
                let (ka, kb) = (rng.next() % 3, rng.next() % 3);
                let mut part = values(&mut rng, n, ka);
                let mut template = values(&mut rng, m, kb);
                // Shift some templates so that whole ranges of values miss.
                if rng.next() % 2 == 0 {
                    let d = rng.unit() * 2.0;
                    template.iter_mut().for_each(|v| *v += d);
                }
                part.sort_by(f32::total_cmp);
                template.sort_by(f32::total_cmp);
                let window = sorted_window_bound(&part, &template).unwrap();
                let mut buf = vec![0.0f32; 2 * (n + 1)];
                let dp = sorted_lower_bound(&part, &template, f32::INFINITY, &mut buf)
                    .unwrap()
                    .unwrap();
                assert!(window <= dp, "n {n} m {m}: window {window} > dp {dp}");
                positive += (window > 0.0) as usize;
                equal += (window == dp) as usize;
            }
        }
        // The bound must be informative for the test to mean anything, and not trivially equal.
        assert!(positive > 100 && equal < 400, "{positive} {equal}");
        assert_eq!(sorted_window_bound(&[1.0, 2.0, 3.0], &[1.0; 7]), None);
    }

    #[test]
    fn sorted_bound_by_columns_equals_by_rows() {
        // The same bits from both orders of the DP, with and without a bound that prunes, on
        // continuous values, a coarse grid (ties) and constants; and the rows' DP written out.
        let mut rng = Rng(0x51ED_2701_9A3C_44F1);
        for n in 1..=70usize {
            for _ in 0..4 {
                let m = n + rng.next() as usize % n;
                for kind in 0..3 {
                    let mut part = values(&mut rng, n, kind);
                    let mut template = values(&mut rng, m, kind);
                    part.sort_by(f32::total_cmp);
                    template.sort_by(f32::total_cmp);
                    let w = m - n + 1;
                    let mut buf = vec![0.0f32; 2 * (n + 1)];
                    // Row i, cell δ: part i against template i + δ; the first row free.
                    let mut row: Vec<f32> = (0..w).map(|d| (part[0] - template[d]).abs()).collect();
                    for i in 1..n {
                        let mut running = f32::INFINITY;
                        for d in 0..w {
                            running = running.min(row[d]);
                            row[d] = (part[i] - template[i + d]).abs() + running;
                        }
                    }
                    let want = row.iter().copied().fold(f32::INFINITY, f32::min);
                    let half = want * rng.unit();
                    for bound in [f32::INFINITY, want, half, want * 1.5 + 1.0] {
                        let by_rows = sorted_lower_bound(&part, &template, bound, &mut buf[..w]).unwrap();
                        let by_columns = sorted_lower_bound(&part, &template, bound, &mut buf).unwrap();
                        let expected = Some(want).filter(|&v| v < bound);
                        assert_eq!(
                            by_rows.map(f32::to_bits),
                            expected.map(f32::to_bits),
                            "rows, n {n} m {m}"
                        );
                        assert_eq!(
                            by_columns.map(f32::to_bits),
                            expected.map(f32::to_bits),
                            "columns, n {n} m {m}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn search_equals_reference_on_random_inputs() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        for n in 1..=40usize {
            let mut ms = vec![n, 2 * n - 1, (3 * n) / 2];
            for _ in 0..3 {
                ms.push(n + (rng.next() as usize % n));
            }
            for m in ms {
                let m = m.clamp(n, 2 * n - 1);
                for kind in 0..3 {
                    let part = values(&mut rng, n, kind);
                    let template = values(&mut rng, m, kind);
                    compare(&part, &template, kind != 0);
                }
            }
        }
    }

    #[test]
    fn search_equals_reference_on_shifted_copies() {
        // A template and a part cut from it: a clear optimum, everything else pruned.
        let mut rng = Rng(12345);
        for (n, m) in [(20, 30), (33, 50), (48, 72), (64, 96), (64, 127)] {
            let template = values(&mut rng, m, 0);
            let shift = rng.next() as usize % m;
            let part: Vec<f32> = (0..n).map(|i| template[(shift + i * m / n) % m] + 0.001).collect();
            compare(&part, &template, false);
        }
    }

    #[test]
    fn search_equals_reference_large() {
        let mut rng = Rng(777);
        for kind in 0..2 {
            let part = values(&mut rng, 256, kind);
            let template = values(&mut rng, 384, kind);
            compare(&part, &template, kind != 0);
        }
    }

    /// The least left-to-right `f32` total over every start and every `δ` sequence.
    fn brute_force(part: &[f32], template: &[f32]) -> f32 {
        fn extend(part: &[f32], template: &[f32], s: usize, i: usize, delta: usize, acc: f32, best: &mut f32) {
            let (n, m) = (part.len(), template.len());
            if i == n {
                *best = best.min(acc);
                return;
            }
            for d in delta..=m - n {
                let c = (part[i] - template[(s + i + d) % m]).abs();
                extend(part, template, s, i + 1, d, acc + c, best);
            }
        }
        let mut best = f32::INFINITY;
        for s in 0..template.len() {
            let c0 = (part[0] - template[s]).abs();
            extend(part, template, s, 1, 0, c0, &mut best);
        }
        best
    }

    #[test]
    fn search_equals_brute_force_on_small_inputs() {
        let mut rng = Rng(0xD1B5_4A32_D192_ED03);
        for _ in 0..3000 {
            let n = 1 + (rng.next() % 7) as usize;
            let m = (n + (rng.next() % 4) as usize).min(10).min(2 * n - 1);
            let kind = rng.next() % 3;
            let part = values(&mut rng, n, kind);
            let template = values(&mut rng, m, kind);
            let want = brute_force(&part, &template);
            let mut big = vec![0.0f32; search_cells(n, m)];
            let mut asg = vec![0u16; n];
            let got = match_with_assignment(&part, &template, &mut big, &mut asg).unwrap();
            if kind == 0 {
                assert!((got.cost - want).abs() <= 1e-5 * want.max(1.0), "{got:?} {want}");
            } else {
                assert_eq!(got.cost, want, "n {n} m {m}");
            }
            check_assignment(&part, &template, &asg, got.cost);
        }
    }

    /// The search's work on the benchmark's kind of input (a part and its template, a shifted
    /// part, a different template with and without a bound) and on noise, against the plain
    /// DP's `n·m·(m − n + 1)` cells (the cells of the bands the sweeps visit).
    #[test]
    fn search_work_is_small() {
        let run = |label: &str, part: &[f32], tpl: &[f32], bound: f32, most: f64| {
            let (n, m) = (part.len(), tpl.len());
            let mut table = vec![0.0f32; table_cells(n, m)];
            let (found, cells) = search_counted::<LANES>(part, tpl, bound, &mut table, &mut []).unwrap();
            let share = cells as f64 / (n * m * (m - n + 1)) as f64;
            std::println!("{n}×{m} {label}: {cells} cells, {share:.3} of the plain DP");
            assert!(share <= most, "{n}×{m} {label}: {share}");
            found
        };
        for (n, m) in [(32, 48), (64, 96), (76, 133), (128, 192), (256, 384)] {
            let (part, tpl) = descriptors(n, m, 37.0, 0);
            let right = run("descriptors", &part, &tpl, f32::INFINITY, 0.15).unwrap();
            let (shifted, _) = descriptors(n, m, 37.0, n / 3);
            run("shifted part", &shifted, &tpl, f32::INFINITY, 0.2);
            let mut rng = Rng(5);
            let pn = values(&mut rng, n, 0);
            let tn = values(&mut rng, m, 0);
            run("noise", &pn, &tn, f32::INFINITY, 0.4);
            // Another template (the outline squeezed), free and under the right one's cost.
            let other: Vec<[f32; 2]> = outline(0.0).iter().map(|p| [p[0] * 0.5, p[1] * 2.0]).collect();
            let mut wrong = vec![0.0; m];
            let params = DescriptorParams {
                k: scaled_k((n / 16).max(1), n, m),
                omega: 0.5,
            };
            describe(&sample(&other, m, 0.0), params, &mut wrong).unwrap();
            run("other template", &part, &wrong, f32::INFINITY, 0.35);
            // A DP is dropped once one of its rows has ended, which in the column sweep comes a
            // little later than row by row (up to 0.077 here, 32×48).
            assert!(run("other template, bound", &part, &wrong, right.cost * 3.0, 0.08).is_none());
        }
    }

    #[test]
    fn non_finite_costs_are_degenerate() {
        let part = [0.0f32, f32::NAN, 1.0, 2.0];
        let template = [0.0f32, 1.0, 2.0, 3.0, 4.0];
        let mut table = vec![0.0f32; 200];
        let mut asg = [0u16; 4];
        assert_eq!(
            match_with_assignment(&part, &template, &mut table, &mut asg),
            Err(Error::DegenerateContour { points: 4 })
        );
        assert_eq!(best_cost(&part, &template, f32::INFINITY, &mut table), Ok(None));
    }

    /// Inputs for the bit-for-bit checks: continuous values, a coarse grid (ties), constants,
    /// and values with some infinite or NaN points.
    fn awkward(rng: &mut Rng, count: usize, kind: u64) -> Vec<f32> {
        let mut v = values(rng, count, kind % 3);
        if kind >= 3 {
            for x in v.iter_mut() {
                match rng.next() % 16 {
                    0 => *x = f32::INFINITY,
                    1 if kind == 4 => *x = f32::NAN,
                    _ => {}
                }
            }
        }
        v
    }

    /// The search against its definition ([`spec`]): the same cost bits, start and
    /// correspondence, with and without a bound and a correspondence, on every kind of input.
    #[test]
    fn search_equals_its_definition_bit_for_bit() {
        let mut rng = Rng(0x5EED_D1CE_0BAD_F00D);
        let mut sizes: Vec<(usize, usize)> = vec![(64, 96), (32, 48), (64, 127), (20, 39), (70, 140 - 1)];
        for _ in 0..400 {
            let n = 1 + rng.next() as usize % 40;
            let m = n + rng.next() as usize % n;
            sizes.push((n, m));
        }
        for (round, &(n, m)) in sizes.iter().enumerate() {
            let kind = round as u64 % 5;
            let part = awkward(&mut rng, n, kind);
            let template = awkward(&mut rng, m, kind);
            let want = spec::search(&part, &template, f32::INFINITY, false);
            let cost = want.as_ref().map_or(1.0, |w| w.0);
            for bound in [f32::INFINITY, cost, cost * 1.01 + 0.01, cost * rng.unit() * 2.0] {
                for with_out in [false, true] {
                    let want = spec::search(&part, &template, bound, with_out);
                    let mut big = vec![0.0f32; search_cells(n, m)];
                    let mut out = vec![0u16; if with_out { n } else { 0 }];
                    let key = |f: &(f32, usize, Vec<u16>)| (f.0.to_bits(), f.1, f.2.clone());
                    // The target's lanes, and one lane (the Cortex-M4's) and four either way.
                    for lanes in [LANES, 1, 4] {
                        let got = match lanes {
                            1 => search_counted::<1>(&part, &template, bound, &mut big, &mut out),
                            4 => search_counted::<4>(&part, &template, bound, &mut big, &mut out),
                            _ => search_counted::<LANES>(&part, &template, bound, &mut big, &mut out),
                        };
                        let got = got.unwrap().0.map(|g| (g.cost, g.start, out.clone()));
                        assert_eq!(
                            got.as_ref().map(key),
                            want.as_ref().map(key),
                            "n {n} m {m} kind {kind} bound {bound} out {with_out} lanes {lanes}"
                        );
                    }
                }
            }
        }
    }

    /// [`column_cells`] against the per-cell update, with one lane and with four: each row of
    /// the groups takes `min(old, |p − t| + old value of the row below)` (the old value kept
    /// unless the new one is strictly below it), the mask marks exactly the rows that took the
    /// new value, and no other cell moves; on continuous values, ties, infinities and NaNs.
    #[test]
    fn column_cells_equal_per_cell_update() {
        fn check<const L: usize>(rng: &mut Rng) {
            for round in 0..20_000u64 {
                let len = 2 + rng.below(90);
                let kind = round % 5;
                let old = awkward(rng, len, kind);
                let pc = awkward(rng, len, kind);
                let t = awkward(rng, 1, kind)[0];
                let from = rng.below(len - 1);
                let groups = rng.below((len - 1 - from) / L + 1);
                let mut q = old.clone();
                let mask = column_cells::<L>(&mut q, &pc, from, groups, t);
                let rows = from..from + groups * L;
                for (c, (&was, &now)) in old.iter().zip(&q).enumerate() {
                    if c == 0 || !rows.contains(&(c - 1)) {
                        assert_eq!(now.to_bits(), was.to_bits(), "cell {c} outside {rows:?}");
                        continue;
                    }
                    let v = (pc[c - 1] - t).abs() + old[c - 1];
                    let want = if v < was { v } else { was };
                    assert_eq!(now.to_bits(), want.to_bits(), "L {L} cell {c}");
                    if rows.len() <= 64 {
                        assert_eq!((mask >> (c - 1 - from)) & 1 == 1, v < was, "L {L} bit of cell {c}");
                    }
                }
            }
        }
        let mut rng = Rng(0xC011_CE11_5EED_0001);
        check::<1>(&mut rng);
        check::<4>(&mut rng);
    }

    /// [`sweep`] and [`read_path`] against the band DP by definition ([`spec::band_table`]) on
    /// random bands of a start (strictly increasing, some with columns that no row meets, some
    /// with stretches of rows one column wide), with
    /// one lane and four, without records and with them (records of more than 64 bits too),
    /// abandoned or not: the same bits of the last row's minimum, the same abandonment, and each
    /// row's column on the path of first minima. Records start out as garbage.
    #[test]
    fn sweep_equals_band_dp_by_definition() {
        fn check<const L: usize>(rng: &mut Rng) {
            for round in 0..4000u64 {
                let n = 1 + rng.below(if round % 8 == 0 { 90 } else { 40 });
                let m = n + rng.below(n);
                let (w, kind) = (m - n + 1, round % 5);
                let top = w - 1;
                let part = awkward(rng, n, kind);
                let template = awkward(rng, m, kind);
                let s = rng.below(m);
                // δ bounds per row, non-decreasing within [0, top]; jumps leave gaps.
                let (mut a, mut b) = (rng.below(w), 0);
                b = b.max(a + rng.below(w - a));
                let mut band = vec![(s + a, s + b)];
                // Some rounds pull every band to one column in stretches (the chains of rows
                // alone in their columns).
                let narrow = round % 3 == 0;
                for i in 1..n {
                    let step = |rng: &mut Rng| if rng.next() % 3 == 0 { rng.below(w) } else { 0 };
                    a = (a + step(rng)).min(top);
                    b = (b + step(rng)).min(top).max(a);
                    if narrow && (i / 8) % 2 == 0 {
                        a = b;
                    }
                    band.push((s + i + a, s + i + b));
                }
                let mut cells = vec![0.0f32; 2 * n];
                for (i, &(f, l)) in band.iter().enumerate() {
                    (cells[i], cells[n + i]) = (pack(f), pack(l));
                }
                let full = spec::band_table(&part, &template, &band, false, f32::INFINITY).unwrap();
                let total = full[n - 1].iter().copied().fold(f32::INFINITY, lesser);
                let best = match rng.next() % 3 {
                    0 => f32::INFINITY,
                    1 => total,
                    _ => total * rng.unit(),
                };
                let abandon = rng.next() % 2 == 0;
                let drop_at = if abandon { best } else { f32::NAN };
                let want = spec::band_table(&part, &template, &band, abandon, best)
                    .map(|t| t[n - 1].iter().copied().fold(f32::INFINITY, lesser));
                let chunks = w.div_ceil(BITS_PER_CELL);
                let t2: Vec<f32> = template.iter().chain(&template).copied().collect();
                let mut pc = part.clone();
                pc.extend([0.0; PAD]);
                let mut q = vec![0.0f32; n + 1 + PAD];
                let mut bits = vec![pack(0xA5A5); (n + w - 1) * chunks + 3];
                let mut count = 0;
                let plain =
                    sweep::<false, false, L>(&cells, n, &pc, &t2, &mut q, &mut [], 0, 0, 0, drop_at, &mut count);
                let (base, col0) = (s + top, s);
                let recorded = if chunks <= 64 / BITS_PER_CELL {
                    sweep::<true, false, L>(
                        &cells, n, &pc, &t2, &mut q, &mut bits, chunks, base, col0, drop_at, &mut count,
                    )
                } else {
                    sweep::<true, true, L>(
                        &cells, n, &pc, &t2, &mut q, &mut bits, chunks, base, col0, drop_at, &mut count,
                    )
                };
                let label = std::format!("L {L} n {n} m {m} kind {kind} abandon {abandon} best {best}");
                assert_eq!(plain.map(f32::to_bits), want.map(f32::to_bits), "{label}");
                assert_eq!(recorded.map(f32::to_bits), want.map(f32::to_bits), "{label}");
                if recorded.is_none() {
                    continue;
                }
                let mut path = vec![usize::MAX; n];
                read_path(&cells, n, &bits, chunks, base, col0, |i, k| path[i] = k);
                let mut k = spec::first_min(&full, &band, n - 1, band[n - 1].1).0;
                assert_eq!(path[n - 1], k, "{label} row {}", n - 1);
                for i in (1..n).rev() {
                    k = spec::first_min(&full, &band, i - 1, (k - 1).min(band[i - 1].1)).0;
                    assert_eq!(path[i - 1], k, "{label} row {}", i - 1);
                }
            }
        }
        let mut rng = Rng(0x5EE9_BA4D_0000_0002);
        check::<1>(&mut rng);
        check::<4>(&mut rng);
    }
}
