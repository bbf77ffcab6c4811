//! The cyclic DP and its bounds on any descriptor arrays (NaN, ∞, equal values, any lengths):
//! `matching::best_cost` (the search and the plain per-start DP), `best_match`,
//! `match_with_assignment`, `match_at_start`, `sorted_lower_bound`, `sorted_window_bound`,
//! `table_cells` and `search_cells`, with buffers of every size.
//!
//! Input: `n`, `m` (mostly `n ≤ m < 2n`, sometimes anything), a bound, buffer choices, the `n`
//! part and `m` template values.
//!
//! Checked, where every value is finite and moderate (|v| ≤ 1000, so that rounding stays far
//! below the tolerances): the search and the plain DP find the same optimum; `best_match` and
//! `match_at_start` at the winning start agree with it; every assignment is a template index;
//! `sorted_window_bound ≤ sorted_lower_bound` exactly (as documented, in `f32` too) and the
//! sorted bound is at most the optimum.

#![no_main]

use libfuzzer_sys::fuzz_target;
use vorl_core::shape::matching::{
    best_cost, best_match, match_at_start, match_with_assignment, search_cells, sorted_lower_bound,
    sorted_window_bound, table_cells,
};
use vorl_fuzz::Input;

fuzz_target!(|data: &[u8]| {
    let mut input = Input::new(data);
    let (n, m) = match input.u8() {
        0..=199 => {
            let n = 1 + input.below(96);
            (n, n + input.below(n))
        }
        _ => (input.below(200), input.below(200)),
    };
    let bound = if input.flag() { f32::INFINITY } else { input.num() };
    let buffers = input.u8();
    let part = input.nums(n);
    let template = input.nums(m);
    let _ = search_cells(input.count(), input.count());
    let _ = table_cells(input.count(), input.count());
    let cells = table_cells(n, m);
    // Buffers: exact, the search's size, one short, empty.
    let size = |choice: u8, exact: usize| match choice % 4 {
        0 => exact,
        1 => exact.max(search_cells(n, m)),
        2 => exact.saturating_sub(1),
        _ => 0,
    };
    let mut row = vec![0.0f32; size(buffers, (m + 1).saturating_sub(n))];
    let mut table = vec![0.0f32; size(buffers >> 2, cells)];
    let mut assignment = vec![0u16; size(buffers >> 4, n)];

    let cost = best_cost(&part, &template, bound, &mut row);
    let matched = best_match(&part, &template, bound, &mut table, &mut assignment);
    let _ = match_with_assignment(&part, &template, &mut table, &mut assignment);
    let start = input.count();
    let _ = match_at_start(&part, &template, start, &mut table, &mut assignment);

    let (mut ps, mut ts) = (part.clone(), template.clone());
    ps.sort_by(f32::total_cmp);
    ts.sort_by(f32::total_cmp);
    let bounded = sorted_lower_bound(&ps, &ts, bound, &mut row);
    let windowed = sorted_window_bound(&ps, &ts);
    // The bounds on unsorted values too: any order is input.
    let _ = sorted_lower_bound(&part, &template, bound, &mut row);
    let _ = sorted_window_bound(&part, &template);

    let moderate = |v: &[f32]| v.iter().all(|x| x.is_finite() && x.abs() <= 1000.0);
    if !(moderate(&part) && moderate(&template) && n >= 1 && n <= m && m < 2 * n) {
        return;
    }
    // Exact buffers everywhere, unbounded: every path must find the optimum.
    let mut big = vec![0.0f32; cells.max(search_cells(n, m))];
    let mut narrow = vec![0.0f32; m - n + 1];
    let mut a = vec![0u16; n];
    let search = best_cost(&part, &template, f32::INFINITY, &mut big)
        .unwrap()
        .expect("finite costs");
    let plain = best_cost(&part, &template, f32::INFINITY, &mut narrow)
        .unwrap()
        .expect("finite costs");
    let tol = |v: f32| 1e-3 + 1e-4 * v.abs();
    assert!(
        (search.cost - plain.cost).abs() <= tol(plain.cost),
        "search {search:?} vs plain {plain:?}"
    );
    let mut full = vec![0.0f32; cells];
    let with = best_match(&part, &template, f32::INFINITY, &mut full, &mut a)
        .unwrap()
        .expect("finite costs");
    assert!(
        (with.cost - plain.cost).abs() <= tol(plain.cost),
        "best_match {with:?} vs {plain:?}"
    );
    assert!(
        a.iter().all(|&j| usize::from(j) < m),
        "assignment {a:?} into {m} points"
    );
    let at = match_at_start(&part, &template, with.start, &mut full, &mut a).unwrap();
    assert!(
        (at.cost - with.cost).abs() <= tol(with.cost),
        "match_at_start {at:?} vs {with:?}"
    );
    assert!(
        a.iter().all(|&j| usize::from(j) < m),
        "assignment {a:?} into {m} points"
    );
    let mut cols = vec![0.0f32; 2 * (n + 1)];
    let lower = sorted_lower_bound(&ps, &ts, f32::INFINITY, &mut cols)
        .unwrap()
        .expect("finite");
    let window = sorted_window_bound(&ps, &ts).expect("valid counts");
    assert!(window <= lower, "window bound {window} above the sorted bound {lower}");
    assert!(
        lower <= plain.cost + tol(plain.cost),
        "sorted bound {lower} above the optimum {plain:?}"
    );
    // Bounded: nothing at or above the bound, the optimum below it.
    let b = plain.cost;
    if let Ok(Some(found)) = best_cost(&part, &template, b, &mut big) {
        assert!(found.cost < b, "{found:?} not below the bound {b}");
    }
    let _ = (cost, matched, bounded, windowed);
});
