//! The cyclic DP: the core (f32, in-place rows, exact pruning) against the std reference (f64,
//! the textbook O(n·m·(m−n+1)) loop), on the same descriptors, in one run.
//!
//! `cargo bench -p vorl-core --bench dp`

mod common;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use vorl_core::matching::{match_with_assignment, table_cells};

/// (n, m) pairs: m = 1.5·n as the core issue asks, plus the paper's 76 × 133.
const SIZES: [(usize, usize); 5] = [(32, 48), (64, 96), (76, 133), (128, 192), (256, 384)];

fn dp(c: &mut Criterion) {
    let mut g = c.benchmark_group("cyclic_dp");
    g.sample_size(20);
    for (n, m) in SIZES {
        let (part, tpl) = common::descriptors(n, m);
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

criterion_group!(benches, dp);
criterion_main!(benches);
