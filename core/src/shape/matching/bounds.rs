//! Bounds across templates, from the descriptor values alone: cheap enough to order a library
//! before any search and to leave out, exactly, the templates that cannot win.
//!
//! [`sorted_lower_bound`] bounds a template's optimum from the descriptor values alone (the
//! cheapest one-to-one map of sorted values, one `n·w` DP over no starts), so a library can be
//! searched best bound first and cut off exactly; [`match_at_start`](super::match_at_start) reads one start's
//! correspondence (e.g. the winner's from [`best_cost`](super::best_cost)) in `n·w` cells instead of a second
//! search.
//!

use super::dp_row;
use crate::borders::resample::check_counts;
use crate::error::{Error, Result};

/// A lower bound on [`best_cost`](super::best_cost) from the descriptor values alone, or `None` when it is not
/// below `bound` (then no start can beat `bound`).
///
/// `part` and `template` hold the same values as for [`best_cost`](super::best_cost) but sorted ascending. Every
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
    // Column j writes `next` from `prev`; the two swap after each column (j even: odd → even).
    let (mut prev, mut next): (&mut [f32], &mut [f32]) = (odd, even);
    for (j, &b) in template.iter().enumerate() {
        // Rows lo ..= hi cover position j.
        let lo = (j + 1).saturating_sub(w);
        let hi = j.min(n - 1);
        let len = hi + 1 - lo;
        // The previous column's rows lo − 1 ..= hi (row −1 is cell 0), and this column's lo ..= hi.
        let (Some(src), Some(dst), Some(a)) = (
            prev.get(lo..lo + 1 + len),
            next.get_mut(lo + 1..lo + 1 + len),
            part.get(lo..lo + len),
        ) else {
            return None;
        };
        let (Some((_, same)), Some((_, below))) = (src.split_first(), src.split_last()) else {
            return None;
        };
        for (((d, &q), &p), &ai) in dst.iter_mut().zip(same).zip(below).zip(a) {
            let v = (ai - b).abs() + p;
            *d = if v < q { v } else { q };
        }
        // Row `lo` ends at position j; its least value is a lower bound on every later row's.
        if j + 1 >= w && dst.first().is_none_or(|&q| q >= bound) {
            return None;
        }
        core::mem::swap(&mut prev, &mut next);
    }
    // After the last column's swap its values are in `prev`.
    prev.get(n).copied().filter(|&total| total < bound)
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
