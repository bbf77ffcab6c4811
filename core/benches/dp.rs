//! The cyclic DP: the core (f32, divide and conquer over the starts, exact pruning) against the
//! std reference (f64, the textbook O(n·m·(m−n+1)) loop), on the same descriptors, in one run.
//! A second group compares the core's search (a buffer of `table_cells`) with its plain per-start
//! DP (a buffer of one row), on the descriptors and on structureless noise, where pruning helps
//! least.
//!
//! `cargo bench -p vorl-core --bench dp`

#[path = "../src/test_support.rs"]
mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use vorl_core::shape::matching::{best_cost, match_with_assignment, table_cells};

/// (n, m) pairs: m = 1.5·n as the core issue asks, plus the paper's 76 × 133.
const SIZES: [(usize, usize); 5] = [(32, 48), (64, 96), (76, 133), (128, 192), (256, 384)];

fn dp(c: &mut Criterion) {
    let mut g = c.benchmark_group("cyclic_dp");
    g.sample_size(20);
    for (n, m) in SIZES {
        let (part, tpl) = common::descriptors(n, m, 37.0, 0);
        let mut table = vec![0.0f32; table_cells(n, m)];
        let mut assignment = vec![0u16; n];
        g.bench_with_input(BenchmarkId::new("core", format!("{n}x{m}")), &(n, m), |b, _| {
            b.iter(|| {
                match_with_assignment(black_box(&part), black_box(&tpl), &mut table, &mut assignment).expect("core DP")
            })
        });
        let part64: Vec<f64> = part.iter().map(|&v| v as f64).collect();
        let tpl64: Vec<f64> = tpl.iter().map(|&v| v as f64).collect();
        g.bench_with_input(BenchmarkId::new("reference", format!("{n}x{m}")), &(n, m), |b, _| {
            b.iter(|| vorl_host_sim::reference::cyclic_dp(black_box(&part64), black_box(&tpl64)).expect("reference DP"))
        });
    }
    g.finish();
}

/// Uniform noise in [0, 2) (xorshift), the same on every run.
fn noise(count: usize, seed: u64) -> Vec<f32> {
    let mut x = seed | 1;
    (0..count)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % 1_000_000) as f32 / 500_000.0
        })
        .collect()
}

fn search_vs_plain(c: &mut Criterion) {
    let mut g = c.benchmark_group("best_cost");
    g.sample_size(20);
    for (n, m) in SIZES {
        let inputs = [
            ("descriptors", common::descriptors(n, m, 37.0, 0)),
            ("noise", (noise(n, 1), noise(m, 2))),
        ];
        for (kind, (part, tpl)) in inputs {
            let mut table = vec![0.0f32; table_cells(n, m)];
            let mut row = vec![0.0f32; m - n + 1];
            for (name, buffer) in [("search", &mut table), ("plain", &mut row)] {
                let id = BenchmarkId::new(format!("{name}/{kind}"), format!("{n}x{m}"));
                g.bench_with_input(id, &(n, m), |b, _| {
                    b.iter(|| best_cost(black_box(&part), black_box(&tpl), f32::INFINITY, buffer).expect("best cost"))
                });
            }
        }
    }
    g.finish();
}

criterion_group!(benches, dp, search_vs_plain);
criterion_main!(benches);
