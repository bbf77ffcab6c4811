//! Cyclic order-preserving matching by dynamic programming (paper eqs. 4.4–4.9, 5.1).
//!
//! Part point `i` (of `n`) is matched to template point `j(i)` (of `m`, `n ≤ m < 2n`) with cost
//! `c_ij = |c_i − c'_j|` (eq. 4.4); every part point is matched once (4.8), no template point
//! twice (4.9), and the cyclic order is kept: for a start `s`,
//! `j(i) = (s + i + δ_i) mod m` with `0 = δ_0 ≤ δ_1 ≤ … ≤ δ_{n−1} ≤ m − n`. Contours have no
//! natural first point, so the optimum is taken over **every** start `s` (DESIGN.md).
//!
//! This file is the definition: for one start the recurrence is
//! `D_i(δ) = c(i, s+i+δ) + min_{δ' ≤ δ} D_{i−1}(δ')`, one row of `w = m − n + 1` cells updated in
//! place with a running minimum: `O(n·w)` per start and `O(m·n·w)` for all starts, the paper's
//! cubic bound (`plain_best_cost`, and [`match_at_start`] with its full table and backtracking).
//! The fast path beside it, `search.rs`, finds the same optimum over every start by divide and
//! conquer in `O(n·m·log m)` (its proof, pruning and rounding are in that file's docs; the
//! tests hold it to this definition and to a cell-by-cell restatement, `spec.rs`), and
//! `bounds.rs` bounds a template's optimum from sorted values so that a library is searched
//! best bound first ([`sorted_lower_bound`], [`sorted_window_bound`]).
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
//! backtrack; the optimum is the same either way (up to the search's rounding in near ties). The recursion is
//! `⌈log2 m⌉` calls deep (about 130 bytes of stack each on a Cortex-M4).

pub mod bounds;
pub mod search;

pub(crate) use bounds::sort_total;
pub use bounds::{sorted_lower_bound, sorted_window_bound};
use search::search;
pub use search::search_cells;

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

/// Whether every start within `reach` of `centre` (modulo `m`: `centre`, `centre ± 1`, …,
/// `centre ± reach`, at most `m` starts) costs at least `bound` (eq. 5.1, not normalised).
/// Each start's own DP on `row` (`m − n + 1` cells), abandoned once its row minimum reaches
/// `bound`; the test ends at the first start that comes in below it, the nearest starts first.
/// The recognizer asks it whether the correspondences half a turn on from the one the DP found
/// are all far worse (a part that the DP tells from its half-turned self).
///
/// ```
/// use vorl_core::shape::matching::starts_reach;
/// let template = [0.0f32, 1.0, 4.0, 2.0, 3.0, 5.0, 0.5, 2.5];
/// let part = [4.0f32, 2.0, 3.0, 5.0, 0.5, 2.5];
/// let mut row = [0.0f32; 3];
/// // Start 2 matches exactly (cost 0): not every start around 3 reaches 0.5.
/// assert!(!starts_reach(&part, &template, 3, 1, 0.5, &mut row).unwrap());
/// // Starts 5, 6 and 7 all cost at least 0.5.
/// assert!(starts_reach(&part, &template, 6, 1, 0.5, &mut row).unwrap());
/// ```
///
/// # Errors
/// [`Error::PointCounts`] when `n ≤ m < 2n` fails, [`Error::BufferTooSmall`] for `row`.
pub fn starts_reach(
    part: &[f32],
    template: &[f32],
    centre: usize,
    reach: usize,
    bound: f32,
    row: &mut [f32],
) -> Result<bool> {
    let (n, m) = (part.len(), template.len());
    check_counts(n, m)?;
    let width = m - n + 1;
    let Some(row) = row.get_mut(..width) else {
        return Err(Error::BufferTooSmall {
            needed: width,
            got: row.len(),
        });
    };
    let centre = centre.checked_rem(m).unwrap_or(0);
    let starts = reach.saturating_mul(2).saturating_add(1).min(m);
    for k in 0..starts {
        // 0, +1, −1, +2, −2, …
        let step = k.div_ceil(2);
        let s = if k % 2 == 1 { centre + step } else { centre + m - step };
        if run_start(part, template, s.checked_rem(m).unwrap_or(0), bound, row).is_some() {
            return Ok(false);
        }
    }
    Ok(true)
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
    use super::search::{column_cells, pack, read_path, search_counted, sweep, BITS_PER_CELL, LANES, PAD};
    use super::*;
    use crate::shape::descriptor::{describe, scaled_k, DescriptorParams};
    use crate::test_support::{descriptors, outline, sample};
    extern crate std;
    use std::vec;
    use std::vec::Vec;

    /// `starts_reach` says whether each start of its window, every start's own optimum (the
    /// unpruned per-start DP), reaches the bound; windows that run past `m` and wider than `m`.
    #[test]
    fn starts_reach_is_every_start_of_its_window_reaching_the_bound() {
        let mut rng = crate::test_rng::XorShift(0x0b0d_5eed_4a1f);
        let (mut reached, mut not) = (0, 0);
        for _ in 0..400 {
            let n = 1 + rng.below(40);
            let m = n + rng.below(n);
            let part: Vec<f32> = (0..n).map(|_| rng.below(1000) as f32 / 250.0).collect();
            let template: Vec<f32> = (0..m).map(|_| rng.below(1000) as f32 / 250.0).collect();
            let mut row = vec![0.0f32; m - n + 1];
            let own: Vec<f32> = (0..m)
                .map(|s| run_start(&part, &template, s, f32::INFINITY, &mut row).unwrap())
                .collect();
            let centre = rng.below(3 * m);
            let reach = rng.below(m / 2 + 2);
            let window: Vec<usize> = (0..(2 * reach + 1).min(m))
                .map(|k| (centre + m * 2 + if k % 2 == 1 { k.div_ceil(2) } else { m - k / 2 }) % m)
                .collect();
            let least = window.iter().map(|&s| own[s]).fold(f32::INFINITY, f32::min);
            // A bound at the window's least cost, just below it or just above it.
            let bound = [least, least * 1.01 + 1e-3, least * 0.99][rng.below(3)];
            let expected = window.iter().all(|&s| own[s] >= bound);
            assert_eq!(
                starts_reach(&part, &template, centre, reach, bound, &mut row).unwrap(),
                expected,
                "n {n} m {m} centre {centre} reach {reach} bound {bound}"
            );
            if expected {
                reached += 1;
            } else {
                not += 1;
            }
        }
        assert!(reached > 50 && not > 50, "{reached} {not}");
        assert!(starts_reach(&[1.0, 2.0], &[1.0, 2.0, 3.0], 0, 1, 1.0, &mut [0.0; 1]).is_err());
        assert!(starts_reach(&[1.0, 2.0, 3.0], &[1.0, 2.0], 0, 1, 1.0, &mut [0.0; 4]).is_err());
    }

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
