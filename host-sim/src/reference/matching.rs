//! §7: the cyclic order-preserving assignment of eqs. 4.4–4.9 by dynamic programming, and a
//! brute-force enumeration to check it.

use super::RefError;

/// Result of [`cyclic_dp`].
#[derive(Debug, Clone, PartialEq)]
pub struct RefMatch {
    /// `f_min`, the minimal total cost `Σ_i c_{i, j(i)}` (eq. 4.6).
    pub cost: f64,
    /// `f' = f_min / n` (eq. 5.1).
    pub normalized: f64,
    /// `assignment[i] = j(i)`, the template point matched to part point `i`.
    pub assignment: Vec<usize>,
}

/// Common input checks: `1 ≤ n ≤ m`, every value finite.
fn check_inputs(part: &[f64], template: &[f64]) -> Result<(), RefError> {
    if part.is_empty() || template.is_empty() {
        return Err(RefError::Empty);
    }
    if part.len() > template.len() {
        return Err(RefError::InvalidParams(format!(
            "part has {} points, more than the template's {} (eq. 4.5 needs n <= m)",
            part.len(),
            template.len()
        )));
    }
    if part.iter().chain(template).any(|v| !v.is_finite()) {
        return Err(RefError::NonFinite);
    }
    Ok(())
}

/// The DP table for one start `s`: `table[i][δ]` is the least cost of matching part points
/// `0 … i` with `j(i) = (s + i + δ) mod m`, `0 = δ_0 ≤ … ≤ δ_i = δ`, for `δ ∈ [0, m − n]`:
///
/// `F[0][0] = c_{0,s}` (`F[0][δ>0] = ∞`, since `δ_0 = 0`),
/// `F[i][δ] = c_{i,(s+i+δ) mod m} + min_{δ' ≤ δ} F[i−1][δ']` (the running minimum).
fn table_for_start(part: &[f64], template: &[f64], s: usize) -> Vec<Vec<f64>> {
    let (n, m) = (part.len(), template.len());
    let width = m - n + 1;
    // eq. 4.4: c_ij = |c_i − c'_j|
    let cost = |i: usize, delta: usize| (part[i] - template[(s + i + delta) % m]).abs();
    let mut first = vec![f64::INFINITY; width];
    first[0] = cost(0, 0);
    let mut table = Vec::with_capacity(n);
    table.push(first);
    for i in 1..n {
        let mut running_min = f64::INFINITY;
        let row: Vec<f64> = table[i - 1]
            .iter()
            .enumerate()
            .map(|(delta, &previous)| {
                running_min = running_min.min(previous);
                running_min + cost(i, delta)
            })
            .collect();
        table.push(row);
    }
    table
}

/// Index of the first minimum of `values`.
fn first_argmin(values: &[f64]) -> usize {
    let mut best = 0;
    for (idx, &v) in values.iter().enumerate() {
        if v < values[best] {
            best = idx;
        }
    }
    best
}

/// Cyclic order-preserving DP of §7 (eqs. 4.6–4.9): the minimum over every start
/// `s ∈ [0, m)` and every `0 = δ_0 ≤ δ_1 ≤ … ≤ δ_{n−1} ≤ m − n` of
/// `Σ_i |part_i − template_{(s+i+δ_i) mod m}|`, in `O(n·m·(m − n + 1))`, with the assignment
/// recovered by backtracking through the best start's table.
///
/// Errors: an empty input ([`RefError::Empty`]), `n > m` ([`RefError::InvalidParams`]), a
/// non-finite value ([`RefError::NonFinite`]). The `m < 2n` rule of §5 is not required here.
pub fn cyclic_dp(part: &[f64], template: &[f64]) -> Result<RefMatch, RefError> {
    check_inputs(part, template)?;
    let (n, m) = (part.len(), template.len());

    // Every start s, keeping the first with the least final cost.
    let mut best_s = 0;
    let mut best_cost = f64::INFINITY;
    for s in 0..m {
        let table = table_for_start(part, template, s);
        let last = &table[n - 1];
        let cost = last[first_argmin(last)];
        if s == 0 || cost < best_cost {
            best_s = s;
            best_cost = cost;
        }
    }

    // Backtrack through the best start's table ("backward search", section 4.3).
    let table = table_for_start(part, template, best_s);
    let mut assignment = vec![0; n];
    let mut delta = first_argmin(&table[n - 1]);
    assignment[n - 1] = (best_s + n - 1 + delta) % m;
    for i in (1..n).rev() {
        // δ_{i−1} is the δ' ≤ δ_i that gave the running minimum.
        delta = first_argmin(&table[i - 1][..=delta]);
        assignment[i - 1] = (best_s + i - 1 + delta) % m;
    }

    Ok(RefMatch {
        cost: best_cost,
        normalized: best_cost / n as f64,
        assignment,
    })
}

/// Most assignments [`brute_force_cyclic`] will enumerate.
const BRUTE_FORCE_LIMIT: u128 = 20_000_000;

/// `f_min` by enumerating every cyclic order-preserving injective assignment (for tests;
/// intended for `n ≤ 7`, `m ≤ 10`).
///
/// Independent of the DP recurrence: every `n`-subset `j_0 < j_1 < … < j_{n−1}` of the
/// template's indices, read cyclically from each of its `n` elements (`i ↦ j_{(r+i) mod n}`),
/// is exactly one map that preserves the cyclic order and uses no template point twice
/// (eqs. 4.7–4.9); the least total cost over all of them is returned.
///
/// Errors as [`cyclic_dp`], plus [`RefError::TooLarge`] when there would be more than
/// 20 million assignments.
pub fn brute_force_cyclic(part: &[f64], template: &[f64]) -> Result<f64, RefError> {
    check_inputs(part, template)?;
    let (n, m) = (part.len(), template.len());
    if binomial(m, n).saturating_mul(n as u128) > BRUTE_FORCE_LIMIT {
        return Err(RefError::TooLarge);
    }

    let mut best = f64::INFINITY;
    // Lexicographic enumeration of n-subsets of 0..m.
    let mut subset: Vec<usize> = (0..n).collect();
    loop {
        for r in 0..n {
            let total: f64 = (0..n).map(|i| (part[i] - template[subset[(r + i) % n]]).abs()).sum();
            best = best.min(total);
        }
        // Next subset: bump the rightmost index that can still move, reset the ones after it.
        let Some(pos) = (0..n).rev().find(|&p| subset[p] < m - n + p) else {
            break;
        };
        subset[pos] += 1;
        for p in pos + 1..n {
            subset[p] = subset[p - 1] + 1;
        }
    }
    Ok(best)
}

/// `C(m, n)`, saturating.
fn binomial(m: usize, n: usize) -> u128 {
    let mut b: u128 = 1;
    for i in 0..n.min(m - n) {
        b = b.saturating_mul((m - i) as u128) / (i as u128 + 1);
    }
    b
}
