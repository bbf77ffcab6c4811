//! Test only: the divide-and-conquer search of [`super`] restated cell by cell from its
//! definition, with `Vec`s and full band tables, so that the optimised search can be held to
//! the same bits: the same recursion (middle starts, the halves' relaxed bounds and their
//! order, the pruning), every band DP written as `D_i(k) = |p_i − t_k| + min D_{i−1}` over
//! the band of the previous row up to column `k − 1`, and every path read back as the first
//! minimum of the previous row (no records). Nothing here shares code with the search.

extern crate std;
use std::vec;
use std::vec::Vec;

/// `min(acc, v)` as the search takes it: the first of equal values, a NaN `v` ignored.
fn lesser(acc: f32, v: f32) -> f32 {
    if v < acc {
        v
    } else {
        acc
    }
}

/// The band of each row, columns `k` of the doubled template (inclusive).
type Band = Vec<(usize, usize)>;

/// A kept path: its start and `δ_i` per row.
type Path = (usize, Vec<usize>);

/// The search's result: the winner (cost and start) and its correspondence.
pub(super) type Found = Option<(f32, usize, Vec<u16>)>;

struct Spec<'a> {
    part: &'a [f32],
    t2: Vec<f32>,
    n: usize,
    m: usize,
    w: usize,
    best: f32,
    best_start: Option<usize>,
    want_out: bool,
    out: Vec<u16>,
    /// One slot per depth, as the search's.
    slots: Vec<Option<Path>>,
}

/// The search by definition: the optimum, its start and (with `want_out`) its correspondence.
pub(super) fn search(part: &[f32], template: &[f32], bound: f32, want_out: bool) -> Found {
    let (n, m) = (part.len(), template.len());
    let t2: Vec<f32> = template.iter().chain(template).copied().collect();
    let slots = 1 + super::search::ceil_log2(m);
    let mut st = Spec {
        part,
        t2,
        n,
        m,
        w: m - n + 1,
        best: bound,
        best_start: None,
        want_out,
        out: vec![0; n],
        slots: vec![None; slots],
    };
    st.run();
    st.best_start
        .map(|s| (st.best, s, if want_out { st.out } else { Vec::new() }))
}

/// An edge: a start and the slot of its path.
type Edge = Option<(usize, usize)>;

impl Spec<'_> {
    fn run(&mut self) {
        let m = self.m;
        if self.best < f32::INFINITY && self.relaxed(0, m - 1, None, None) >= self.best {
            return;
        }
        self.solve_start(0, None, None, Some(0), false);
        if m >= 2 {
            self.solve(0, m, Some((0, 0)), Some((m, 0)), 0);
        }
    }

    fn solve(&mut self, lo: usize, hi: usize, lower: Edge, upper: Edge, depth: usize) {
        let mid = lo + (hi - lo) / 2;
        let slot = depth + 1;
        let alone = hi - lo <= 2;
        let keep = (!alone && slot < self.slots.len()).then_some(slot);
        let done = self.solve_start(mid, lower, upper, keep, alone);
        if alone {
            return;
        }
        let me = if done { keep.map(|slot| (mid, slot)) } else { None };
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

    fn interval_bound(&mut self, lo: usize, hi: usize, lower: Edge, upper: Edge) -> f32 {
        match hi - lo {
            0 | 1 => f32::INFINITY,
            2 => f32::NEG_INFINITY,
            d if d > self.w => f32::NEG_INFINITY,
            _ => self.relaxed(lo + 1, hi - 1, lower, upper),
        }
    }

    /// The column of row `i` on the path of edge `e` (`d = start + δ_i`, before adding `i`).
    fn edge_d(&self, e: Edge, i: usize) -> Option<usize> {
        let (start, slot) = e?;
        let (_, path) = self.slots.get(slot)?.as_ref()?;
        Some(start + path[i])
    }

    fn band_dp(&self, band: &Band, abandon: bool) -> Option<Vec<Vec<f32>>> {
        band_table(self.part, &self.t2, band, abandon, self.best)
    }

    fn relaxed(&mut self, first: usize, last: usize, lower: Edge, upper: Edge) -> f32 {
        let end = last + self.w - 1;
        let mut band = vec![(first, last)];
        for i in 1..self.n {
            let a = self.edge_d(lower, i).map_or(first, |d| d.max(first));
            let b = self.edge_d(upper, i).map_or(end, |d| d.min(end)).max(a);
            band.push((i + a, i + b));
        }
        match self.band_dp(&band, true) {
            Some(table) => table[self.n - 1].iter().copied().fold(f32::INFINITY, lesser),
            None => f32::INFINITY,
        }
    }

    fn solve_start(&mut self, s: usize, lower: Edge, upper: Edge, keep: Option<usize>, abandon: bool) -> bool {
        let (n, top) = (self.n, self.w - 1);
        let mut band = vec![(s, s)];
        for i in 1..n {
            let a = self.edge_d(lower, i).map_or(0, |d| d.saturating_sub(s).min(top));
            let b = self
                .edge_d(upper, i)
                .map_or(top, |d| d.saturating_sub(s).min(top))
                .max(a);
            band.push((s + i + a, s + i + b));
        }
        let Some(table) = self.band_dp(&band, abandon) else {
            return false;
        };
        let (mut k, total) = first_min(&table, &band, n - 1, band[n - 1].1);
        let wins = total < self.best;
        if wins {
            self.best = total;
            self.best_start = Some(s);
        }
        let report = wins && self.want_out;
        if keep.is_none() && !report {
            return false;
        }
        let mut path = vec![0usize; n];
        path[n - 1] = k - s - (n - 1);
        for i in (1..n).rev() {
            k = first_min(&table, &band, i - 1, (k - 1).min(band[i - 1].1)).0;
            path[i - 1] = k - s - (i - 1);
        }
        if report {
            for (i, o) in self.out.iter_mut().enumerate() {
                *o = ((s + i + path[i]) % self.m) as u16;
            }
        }
        if let Some(slot) = keep {
            self.slots[slot] = Some((s, path));
        }
        keep.is_some()
    }
}

/// The band DP by definition: row `i` covers columns `band[i].0 ..= band[i].1` of `t` (indices
/// taken mod its length), `D_i(k) = |p_i − t_k| + min D_{i−1}` over the previous row's band up
/// to column `k − 1` (0 for row 0). Every row's values, or `None` once a row minimum reaches
/// `best` (with `abandon`).
pub(super) fn band_table(
    part: &[f32],
    t: &[f32],
    band: &[(usize, usize)],
    abandon: bool,
    best: f32,
) -> Option<Vec<Vec<f32>>> {
    let mut table: Vec<Vec<f32>> = Vec::new();
    for (i, &(a, b)) in band.iter().enumerate() {
        let p = part[i];
        let mut row = Vec::new();
        for k in a..=b {
            let before = if i == 0 {
                0.0
            } else {
                let (pa, pb) = band[i - 1];
                let mut q = f32::INFINITY;
                for x in pa..=pb.min(k - 1) {
                    q = lesser(q, table[i - 1][x - pa]);
                }
                q
            };
            row.push((p - t[k % t.len()]).abs() + before);
        }
        let row_min = row.iter().copied().fold(f32::INFINITY, lesser);
        table.push(row);
        if abandon && row_min >= best {
            return None;
        }
    }
    Some(table)
}

/// The first minimum of row `i`'s values over the columns from its band's first up to `to`
/// (the band's first column when none is below `+∞`), and that minimum.
pub(super) fn first_min(table: &[Vec<f32>], band: &[(usize, usize)], i: usize, to: usize) -> (usize, f32) {
    let (a, _) = band[i];
    let (mut at, mut least) = (a, f32::INFINITY);
    for (x, &v) in table[i].iter().enumerate().take(to + 1 - a) {
        if v < least {
            (at, least) = (a + x, v);
        }
    }
    (at, least)
}
