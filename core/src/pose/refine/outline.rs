//! Distances from points to a closed polyline: the part → template half of the verification
//! score, each point of the part's edge against the aligned template outline ([`Outline`]).
//! Scanning every segment for every point costs `n·m` segment tests a candidate; grouped into
//! runs of consecutive segments, each with a bounding circle, a query scans the nearest run
//! first and then only the runs whose circle comes nearer than the best distance so far,
//! which gives the same minimum.
//!
//! Cost: `O(runs)` to order the runs, plus the segments of the runs scanned (a segment whose
//! start lies farther than the best distance plus the longest segment costs one comparison).
//! Memory: an [`Outline`] holds a borrowed slice and three arrays of [`OUTLINE_CHUNKS`] floats.
//! Guards: a polyline of fewer than 2 points gives the cap; the runs are scanned with a margin
//! of 10⁻³ px, so rounding cannot skip a nearer segment.

use crate::math;

/// Distances from points to a closed polyline (the template outline in verification).
///
/// The segments are grouped into at most [`OUTLINE_CHUNKS`] runs of consecutive segments, each
/// with a circle that holds its points (the centre of their bounding box, the farthest point's
/// distance). A query scans the run whose centre lies nearest first, then only the runs whose
/// circle comes nearer than the best distance so far (with a margin of 10⁻³ px, so rounding
/// cannot skip a nearer segment): the minimum over every segment, in about a quarter of the
/// segment tests for a 96-point outline and a query near it.
///
/// ```
/// use vorl_core::pose::refine::Outline;
/// let square = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
/// let outline = Outline::new(&square);
/// assert!((outline.capped_distance([5.0, 1.0], 5.0) - 1.0).abs() < 1e-6);
/// assert_eq!(outline.capped_distance([5.0, 5.0], 2.0), 2.0); // capped
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Outline<'a> {
    points: &'a [[f32; 2]],
    /// The longest segment, px.
    longest: f32,
    /// Segments per run (the last run may hold fewer).
    run: usize,
    /// How many runs.
    runs: usize,
    /// Each run's circle: centre x, centre y (apart, so that the distances to all of them
    /// vectorise), radius.
    centre_x: [f32; OUTLINE_CHUNKS],
    centre_y: [f32; OUTLINE_CHUNKS],
    radius: [f32; OUTLINE_CHUNKS],
}

/// Most runs of segments an [`Outline`] keeps a bounding circle for (longer outlines get longer
/// runs).
pub const OUTLINE_CHUNKS: usize = 32;

/// Segments per run of an [`Outline`] when the outline is short enough.
const OUTLINE_RUN: usize = 8;

/// How much nearer than the best distance so far a run's circle must come to be scanned, px.
const OUTLINE_MARGIN: f32 = 1e-3;

impl<'a> Outline<'a> {
    /// The closed polyline through `points` (the last joins the first). Segment `i` joins point
    /// `i − 1` (the last one for `i = 0`) to point `i`.
    pub fn new(points: &'a [[f32; 2]]) -> Self {
        let len = points.len();
        let mut longest2 = 0.0f32;
        let mut prev = points.last().copied().unwrap_or([0.0; 2]);
        for &p in points {
            longest2 = longest2.max((p[0] - prev[0]) * (p[0] - prev[0]) + (p[1] - prev[1]) * (p[1] - prev[1]));
            prev = p;
        }
        let run = OUTLINE_RUN.max(len.div_ceil(OUTLINE_CHUNKS));
        let runs = len.div_ceil(run).min(OUTLINE_CHUNKS);
        let (mut centre_x, mut centre_y, mut radius) =
            ([0.0f32; OUTLINE_CHUNKS], [0.0; OUTLINE_CHUNKS], [0.0; OUTLINE_CHUNKS]);
        let circles = centre_x.iter_mut().zip(centre_y.iter_mut()).zip(radius.iter_mut());
        for (r, ((cx, cy), radius)) in circles.enumerate().take(runs) {
            // The run's segments and the point before its first one.
            let first = r * run;
            let before = points.get((first + len - 1) % len.max(1)).copied().unwrap_or([0.0; 2]);
            let segments = points.get(first..(first + run).min(len)).unwrap_or(&[]);
            let (mut lo, mut hi) = (before, before);
            for p in segments {
                lo = [lo[0].min(p[0]), lo[1].min(p[1])];
                hi = [hi[0].max(p[0]), hi[1].max(p[1])];
            }
            let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
            let dist2 = |p: &[f32; 2]| (p[0] - c[0]) * (p[0] - c[0]) + (p[1] - c[1]) * (p[1] - c[1]);
            let r2 = segments.iter().fold(dist2(&before), |m, p| m.max(dist2(p)));
            (*cx, *cy, *radius) = (c[0], c[1], math::sqrt(r2));
        }
        Outline {
            points,
            longest: math::sqrt(longest2),
            run,
            runs,
            centre_x,
            centre_y,
            radius,
        }
    }

    /// The distance from `q` to the polyline, or `cap` when that is less (also for a polyline
    /// of fewer than 2 points).
    pub fn capped_distance(&self, q: [f32; 2], cap: f32) -> f32 {
        if self.points.len() < 2 {
            return cap;
        }
        let runs = self.runs.min(OUTLINE_CHUNKS);
        // Squared distances from `q` to every run's centre (one loop the compiler vectorises),
        // then the nearest run first: its segments usually hold the answer.
        let mut far = [f32::INFINITY; OUTLINE_CHUNKS];
        for ((d2, &cx), &cy) in far.iter_mut().zip(&self.centre_x).zip(&self.centre_y) {
            *d2 = (q[0] - cx) * (q[0] - cx) + (q[1] - cy) * (q[1] - cy);
        }
        let far = far.get(..runs).unwrap_or(&[]);
        let mut first = 0usize;
        let mut nearest = f32::INFINITY;
        for (r, &d2) in far.iter().enumerate() {
            if d2 < nearest {
                (first, nearest) = (r, d2);
            }
        }
        // The best squared distance and its square root, taken only when it falls (a square
        // root is a library call on the Cortex-M4).
        let mut best = (cap * cap, cap);
        self.scan_run(first, q, &mut best);
        for ((r, &d2), &radius) in far.iter().enumerate().zip(&self.radius) {
            let reach = best.1 + radius + OUTLINE_MARGIN;
            if d2 < reach * reach && r != first {
                self.scan_run(r, q, &mut best);
            }
        }
        best.1
    }

    /// Lowers `best` (a squared distance and its square root) to that of the nearest segment
    /// of run `r` to `q`. A segment whose start lies farther than `√best + longest` from `q`
    /// costs one comparison.
    #[inline]
    fn scan_run(&self, r: usize, q: [f32; 2], best: &mut (f32, f32)) {
        let len = self.points.len();
        let first = r * self.run;
        let mut prev = self
            .points
            .get((first + len - 1) % len.max(1))
            .copied()
            .unwrap_or([0.0; 2]);
        let reach = best.1 + self.longest;
        let mut reject = reach * reach;
        for &cur in self.points.iter().skip(first).take(self.run) {
            let (dx, dy) = (prev[0] - q[0], prev[1] - q[1]);
            if dx * dx + dy * dy < reject {
                let c = crate::pose::closest_on_segment(q, prev, cur);
                let d = (c[0] - q[0]) * (c[0] - q[0]) + (c[1] - q[1]) * (c[1] - q[1]);
                if d < best.0 {
                    *best = (d, math::sqrt(d));
                    let r = best.1 + self.longest;
                    reject = r * r;
                }
            }
            prev = cur;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_rng::XorShift as Rng;

    #[test]
    fn outline_distance_matches_every_segment() {
        let mut rng = Rng(0x1234_5678_9abc_def1);
        for _ in 0..200 {
            let len = 2 + (rng.next() % 40) as usize;
            let mut pts = [[0.0f32; 2]; 41];
            for p in pts.iter_mut().take(len) {
                *p = [rng.unit() * 20.0, rng.unit() * 20.0];
            }
            let outline = Outline::new(&pts[..len]);
            for _ in 0..20 {
                let q = [rng.unit() * 30.0 - 5.0, rng.unit() * 30.0 - 5.0];
                let cap = rng.unit() * 6.0;
                let mut best = cap;
                for i in 0..len {
                    let (a, b) = (pts[(i + len - 1) % len], pts[i]);
                    let c = crate::pose::closest_on_segment(q, a, b);
                    best = best.min(math::hypot(c[0] - q[0], c[1] - q[1]));
                }
                let got = outline.capped_distance(q, cap);
                assert!((got - best).abs() <= 1e-5 * (1.0 + best), "{got} vs {best}");
            }
        }
        assert_eq!(Outline::new(&[[1.0, 1.0]]).capped_distance([0.0, 0.0], 3.0), 3.0);
        assert_eq!(Outline::new(&[]).capped_distance([0.0, 0.0], 3.0), 3.0);
    }

    #[test]
    fn outline_runs_give_the_distance_to_every_segment() {
        // Outlines of 2–400 points (runs of 8 up to 256 points, longer runs beyond), both
        // scattered and wavy closed curves, queried near the curve (where the runs' circles
        // overlap most) and anywhere, against every segment's distance.
        let mut rng = Rng(0x0ddb_a11c_a5ca_de42);
        let mut pts = [[0.0f32; 2]; 400];
        let mut scanned_all = 0usize;
        for round in 0..300 {
            let len = 2 + (rng.next() % 399) as usize;
            let wavy = round % 3 != 0;
            let (phase, wobble) = (rng.unit() * 6.0, 1.0 + rng.unit() * 8.0);
            for (i, p) in pts.iter_mut().take(len).enumerate() {
                *p = if wavy {
                    let a = i as f32 * core::f32::consts::TAU / len as f32;
                    let r = 30.0 + wobble * (3.0 * a + phase).sin() + (rng.unit() - 0.5) * 0.5;
                    [50.0 + r * a.cos(), 50.0 + r * a.sin()]
                } else {
                    [rng.unit() * 100.0, rng.unit() * 100.0]
                };
            }
            let outline = Outline::new(&pts[..len]);
            for _ in 0..40 {
                let q = if rng.next() % 2 == 0 {
                    let p = pts[(rng.next() % len as u64) as usize];
                    [p[0] + (rng.unit() - 0.5) * 3.0, p[1] + (rng.unit() - 0.5) * 3.0]
                } else {
                    [rng.unit() * 140.0 - 20.0, rng.unit() * 140.0 - 20.0]
                };
                let cap = [0.5f32, 2.0, 6.0, f32::INFINITY][(rng.next() % 4) as usize];
                let mut best = cap;
                for i in 0..len {
                    let (a, b) = (pts[(i + len - 1) % len], pts[i]);
                    let c = crate::pose::closest_on_segment(q, a, b);
                    best = best.min(math::hypot(c[0] - q[0], c[1] - q[1]));
                }
                let got = outline.capped_distance(q, cap);
                assert!((got - best).abs() <= 1e-5 * (1.0 + best), "len {len}: {got} vs {best}");
                scanned_all += (cap.is_infinite()) as usize;
            }
        }
        assert!(scanned_all > 1000);
    }
}
