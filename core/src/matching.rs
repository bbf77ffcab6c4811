//! Cyclic order-preserving matching by dynamic programming (paper eqs. 4.4–4.9, 5.1).
//!
//! Part point `i` (of `n`) is matched to template point `j(i)` (of `m`, `n ≤ m < 2n`) with cost
//! `c_ij = |c_i − c'_j|` (eq. 4.4); every part point is matched once (4.8), no template point
//! twice (4.9), and the cyclic order is kept: for a start `s`,
//! `j(i) = (s + i + δ_i) mod m` with `0 = δ_0 ≤ δ_1 ≤ … ≤ δ_{n−1} ≤ m − n`. Contours have no
//! natural first point, so the optimum is taken over **every** start `s` (DESIGN.md).
//!
//! For one start the recurrence is `D_i(δ) = c(i, s+i+δ) + min_{δ' ≤ δ} D_{i−1}(δ')`, one row of
//! `m − n + 1` cells updated in place with a running minimum: `O(n·(m−n+1))` per start and
//! `O(m·n·(m−n+1))` in all, the paper's cubic bound. Two exact savings:
//! - **pruning**: costs are non-negative, so a row's minimum never decreases with `i`; once it
//!   reaches the best total found so far (or a caller's bound, e.g. the best over other
//!   templates), the start cannot win and is abandoned. The optimum is unchanged.
//! - **backtracking on one table**: the search keeps one row; only the winning start is run again
//!   with the full `n × (m−n+1)` table, from which the correspondence is read backwards.
//!
//! Memory: the caller's table of `n·(m−n+1)` `f32` cells (the [`table_cells`] bound).

use crate::error::{Error, Result};
use crate::resample::check_counts;

/// Cells of the backtracking table for `n` part and `m` template points: `n·(m − n + 1)`.
pub const fn table_cells(n: usize, m: usize) -> usize {
    if m < n {
        0
    } else {
        n * (m - n + 1)
    }
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
/// `row` needs `m − n + 1` cells. Use [`match_with_assignment`] for the correspondence.
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
    let row = &mut row[..width];
    let mut best = bound;
    let mut best_start = None;
    for s in 0..m {
        if let Some(total) = run_start(part, template, s, best, row) {
            if total < best {
                best = total;
                best_start = Some(s);
            }
        }
    }
    Ok(best_start.map(|start| Match {
        cost: best,
        normalized: best / n as f32,
        start,
    }))
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
    let mut running = f32::INFINITY;
    let mut row_min = f32::INFINITY;
    for (cell, &t) in row.iter_mut().zip(head.iter().chain(tail)) {
        running = running.min(*cell);
        let v = (ci - t).abs() + running;
        *cell = v;
        row_min = row_min.min(v);
    }
    row_min
}

/// The optimal match and its correspondence: `assignment[i] = j(i)` for every part point.
///
/// `table` needs [`table_cells`]`(n, m)` cells and `assignment` `n` entries.
///
/// ```
/// use vorl_core::matching::{match_with_assignment, table_cells};
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
    if assignment.len() < n {
        return Err(Error::BufferTooSmall {
            needed: n,
            got: assignment.len(),
        });
    }
    let best = {
        let row = table.get_mut(..width).unwrap_or(&mut []);
        best_cost(part, template, f32::INFINITY, row)?
    };
    let Some(best) = best else {
        return Err(Error::DegenerateContour { points: n });
    };
    let s = best.start;
    fill_table(part, template, s, &mut table[..cells], width);
    backtrack(&table[..cells], width, n, m, s, assignment);
    Ok(best)
}

/// The full table of one start: row `i` holds `D_i(δ)`.
fn fill_table(part: &[f32], template: &[f32], s: usize, table: &mut [f32], width: usize) {
    let m = template.len();
    let mut rows = table.chunks_exact_mut(width);
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
