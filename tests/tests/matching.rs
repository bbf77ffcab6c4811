//! DP optimality: for every n ≤ 7 and n ≤ m ≤ min(10, 2n − 1), the core's cyclic DP (both the
//! divide-and-conquer search and the per-start DP) finds the same optimum as a brute force over every cyclic order-preserving injective assignment (the
//! reference's `brute_force_cyclic`, which shares no code with either DP), and its own
//! assignment is valid and has that cost. The winning start's correspondence read back alone
//! (`match_at_start`) has the same cost, and the sorted-values lower bound that lets the
//! recognizer skip templates (`sorted_lower_bound`) never exceeds the optimum, also at the
//! recognizer's sizes.

use proptest::prelude::*;
use vorl_core::shape::matching::{
    best_cost, match_at_start, match_with_assignment, search_cells, sorted_lower_bound, table_cells,
};
use vorl_host_sim::reference::brute_force_cyclic;

fn check(part: &[f32], tpl: &[f32]) -> Result<(), TestCaseError> {
    let (n, m) = (part.len(), tpl.len());
    // Both code paths: the divide-and-conquer search (a buffer of `search_cells`) and the
    // per-start DP (a buffer of only `table_cells`, used when the search does not fit).
    let mut big = vec![0.0f32; search_cells(n, m).max(table_cells(n, m))];
    let mut asg_big = vec![0u16; n];
    let fast = match_with_assignment(part, tpl, &mut big, &mut asg_big).unwrap();
    let mut table = vec![0.0f32; table_cells(n, m)];
    let mut asg = vec![0u16; n];
    let got = match_with_assignment(part, tpl, &mut table, &mut asg).unwrap();
    prop_assert!(
        (fast.cost - got.cost).abs() <= 1e-5 * got.cost.max(1.0),
        "search {} per-start {}",
        fast.cost,
        got.cost
    );
    let cost_fast: f32 = part
        .iter()
        .zip(&asg_big)
        .map(|(a, &j)| (a - tpl[j as usize]).abs())
        .sum();
    prop_assert!((cost_fast - fast.cost).abs() <= 1e-4 * cost_fast.max(1.0));
    let p64: Vec<f64> = part.iter().map(|&v| v as f64).collect();
    let t64: Vec<f64> = tpl.iter().map(|&v| v as f64).collect();
    let want = brute_force_cyclic(&p64, &t64).unwrap();
    prop_assert!(
        (got.cost as f64 - want).abs() <= 1e-4 * want.max(1.0),
        "n {n} m {m}: DP {} brute force {want}",
        got.cost
    );
    // The assignment: injective, cyclic order kept (offsets from j(0) strictly increasing), cost.
    let offs: Vec<usize> = asg.iter().map(|&j| (j as usize + m - asg[0] as usize) % m).collect();
    prop_assert!(
        offs.windows(2).all(|w| w[0] < w[1]),
        "not cyclic order-preserving: {asg:?}"
    );
    let cost: f32 = part.iter().zip(&asg).map(|(a, &j)| (a - tpl[j as usize]).abs()).sum();
    prop_assert!((cost - got.cost).abs() <= 1e-4 * cost.max(1.0));
    check_start_and_bound(part, tpl)
}

/// `best_cost`'s start read back by `match_at_start` gives the same cost with a valid
/// assignment; the sorted lower bound is at most that cost and honours its own `bound`.
fn check_start_and_bound(part: &[f32], tpl: &[f32]) -> Result<(), TestCaseError> {
    let (n, m) = (part.len(), tpl.len());
    let mut buf = vec![0.0f32; search_cells(n, m).max(table_cells(n, m))];
    let best = best_cost(part, tpl, f32::INFINITY, &mut buf).unwrap().unwrap();
    let mut asg = vec![0u16; n];
    let at = match_at_start(part, tpl, best.start, &mut buf, &mut asg).unwrap();
    prop_assert!(
        (at.cost - best.cost).abs() <= 1e-5 * best.cost.max(1.0),
        "start {}: {} vs {}",
        best.start,
        at.cost,
        best.cost
    );
    prop_assert_eq!(asg[0] as usize, best.start);
    let offs: Vec<usize> = asg.iter().map(|&j| (j as usize + m - asg[0] as usize) % m).collect();
    prop_assert!(
        offs.windows(2).all(|w| w[0] < w[1]),
        "not cyclic order-preserving: {asg:?}"
    );
    let cost: f32 = part.iter().zip(&asg).map(|(a, &j)| (a - tpl[j as usize]).abs()).sum();
    prop_assert!((cost - at.cost).abs() <= 1e-4 * cost.max(1.0));
    let (mut ps, mut ts) = (part.to_vec(), tpl.to_vec());
    ps.sort_by(f32::total_cmp);
    ts.sort_by(f32::total_cmp);
    let lb = sorted_lower_bound(&ps, &ts, f32::INFINITY, &mut buf).unwrap().unwrap();
    prop_assert!(
        lb <= best.cost * (1.0 + 1e-5) + 1e-6,
        "bound {lb} above the optimum {}",
        best.cost
    );
    prop_assert_eq!(sorted_lower_bound(&ps, &ts, lb, &mut buf).unwrap(), None);
    prop_assert_eq!(sorted_lower_bound(&ps, &ts, lb + 1.0, &mut buf).unwrap(), Some(lb));
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, .. ProptestConfig::default() })]

    #[test]
    fn dp_equals_brute_force(n in 1usize..=7, extra in 0usize..=3, seed in any::<u64>(), ties in any::<bool>()) {
        let m = (n + extra).min(10).min(2 * n - 1).max(n);
        let mut x = seed | 1;
        let mut next = || { x ^= x << 13; x ^= x >> 7; x ^= x << 17; x };
        // With `ties`, values on a coarse grid so that many assignments cost the same.
        let val = |r: u64| if ties { (r % 4) as f32 * 0.5 } else { (r % 10_000) as f32 / 5_000.0 };
        let part: Vec<f32> = (0..n).map(|_| val(next())).collect();
        let tpl: Vec<f32> = (0..m).map(|_| val(next())).collect();
        check(&part, &tpl)?;
    }
}

#[test]
fn every_size_pair_once() {
    for n in 1..=7usize {
        for m in n..=10usize.min(2 * n - 1) {
            let part: Vec<f32> = (0..n).map(|i| ((i * 7 + 3) % 5) as f32 * 0.3).collect();
            let tpl: Vec<f32> = (0..m).map(|j| ((j * 3 + 1) % 7) as f32 * 0.2).collect();
            check(&part, &tpl).unwrap();
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, .. ProptestConfig::default() })]

    /// The recognizer's sizes (n up to 64, m up to 2n − 1), smooth descriptor-like values.
    #[test]
    fn start_and_sorted_bound_at_recognizer_sizes(n in 8usize..=64, extra in 0usize..=63, seed in any::<u64>()) {
        let m = (n + extra).min(2 * n - 1);
        let mut x = seed | 1;
        let mut next = || { x ^= x << 13; x ^= x >> 7; x ^= x << 17; (x % 10_000) as f32 / 10_000.0 };
        let (a, b) = (next() * 6.0, next() * 6.0);
        let part: Vec<f32> = (0..n).map(|i| 1.0 + 0.3 * (a + i as f32 * 0.4).sin() + 0.05 * next()).collect();
        let tpl: Vec<f32> = (0..m).map(|j| 1.0 + 0.3 * (b + j as f32 * 0.3).sin() + 0.05 * next()).collect();
        check_start_and_bound(&part, &tpl)?;
    }
}

#[test]
fn start_out_of_range_and_short_buffers_are_errors() {
    let (part, tpl) = ([1.0f32, 2.0, 3.0], [1.0f32, 2.0, 3.0, 4.0]);
    let mut table = [0.0f32; 6];
    let mut asg = [0u16; 3];
    assert!(match_at_start(&part, &tpl, 4, &mut table, &mut asg).is_err());
    assert!(match_at_start(&part, &tpl, 0, &mut table[..5], &mut asg).is_err());
    assert!(match_at_start(&part, &tpl, 0, &mut table, &mut asg[..2]).is_err());
    assert!(sorted_lower_bound(&part, &tpl, f32::INFINITY, &mut table[..1]).is_err());
    assert!(sorted_lower_bound(&tpl, &part, f32::INFINITY, &mut table).is_err());
}
